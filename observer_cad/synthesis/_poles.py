"""Closed-loop eigenvalues of canonical designs: defaults, parsing, stability, exact
pole placement of F* − K H*."""
from __future__ import annotations

import sympy as sp

from ..errors import InfeasibleDesignError, UsageError
from ..model import parse_number
from ..numerics import rationalize_floats

__all__ = ["default_eigenvalues", "parse_eigenvalues", "place_poles", "require_stable"]

S = sp.Dummy("s")  # never a model parameter named s


def default_eigenvalues(time: str, k: int):
    if time == "continuous":
        return [sp.Integer(-i) for i in range(1, k + 1)]
    return [sp.Rational(1, 2 ** i) for i in range(1, k + 1)]


def parse_eigenvalues(values):
    """Closed-loop eigenvalues from text (read by the safe reader, ``I`` allowed) or
    sympy numbers; each must be a finite number."""
    out = []
    for v in values:
        e = parse_number(v, where="--eigenvalues", allow_complex=True)
        e = sp.nsimplify(e, rational=True) if e.has(sp.Float) else e
        out.append(e)
    # complex values must come in conjugate pairs for a real gain
    for e in out:
        if sp.im(e) != 0 and not any(sp.simplify(f - sp.conjugate(e)) == 0 for f in out):
            raise UsageError(f"eigenvalue {e} needs its conjugate {sp.conjugate(e)} too (real gain)")
    return out


def place_poles(Fs, Hs, eigenvalues):
    """K with det(sI − F* + K H*) = Π(s − μ_i), exactly; raises if (F*, H*) is not
    observable enough to place them."""
    Fs, Hs = sp.Matrix(Fs), sp.Matrix(Hs)
    k = Fs.rows
    if len(eigenvalues) != k:
        raise UsageError(f"{k} eigenvalues needed (k = {k}), got {len(eigenvalues)}")
    Ks = tuple(sp.Dummy(f"K{i}") for i in range(1, k + 1))  # never a model parameter
    K = sp.Matrix(Ks)
    target = sp.Poly(sp.expand(sp.prod([S - mu for mu in eigenvalues])), S)
    cp = sp.Poly((S * sp.eye(k) - Fs + K * Hs).det(method="berkowitz"), S)
    eqs = [sp.expand(a - b) for a, b in zip(cp.all_coeffs(), target.all_coeffs())]
    sol = sp.solve(eqs, Ks, dict=True)
    if not sol:
        raise InfeasibleDesignError(
            "the requested eigenvalues cannot be placed: (F*, H*) is not observable")
    K = K.xreplace({s: rationalize_floats(sp.expand(sol[0].get(s, 0)).xreplace({t: 0 for t in Ks}))
                    for s in Ks})
    K = K.applyfunc(lambda e: sp.expand(e.xreplace({t: 0 for t in Ks})))
    # exact re-check of the closed-loop characteristic polynomial
    check = sp.Poly((S * sp.eye(k) - Fs + K * Hs).det(method="berkowitz"), S)
    if sp.expand(check.as_expr() - target.as_expr()) != 0:  # pragma: no cover
        raise InfeasibleDesignError("pole placement failed its exact check")
    return K


def require_stable(eigs, time, requested):
    """Requested closed-loop eigenvalues must be stable for the time domain."""
    bad = [e for e in eigs if not ((sp.re(e) < 0) if time == "continuous" else (sp.Abs(e) < 1))]
    if bad:
        need = "Re < 0" if time == "continuous" else "|·| < 1"
        raise InfeasibleDesignError(
            f"requested eigenvalues {[str(e) for e in requested]} are not stable in {time} time"
            f" (needs {need}): {', '.join(map(str, bad))}")
