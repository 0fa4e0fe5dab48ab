"""The algebra the sampled-data bands share: affine splits of the model's and the
observer's expressions, exact ranges of monomials over boxes, the observer's discrete
step in 40 digits (METHOD §3, residual evaluation)."""
from __future__ import annotations

import dataclasses

import mpmath
import numpy as np
import sympy as sp

from ..errors import UsageError
from ..synthesis import Condition

__all__ = ["Affine", "split_affine", "box_of", "to_mp", "hold_step", "to_np", "affine_and_rest",
           "exp_tail", "DPS", "identity_condition"]

#: working precision (decimal digits) of the step matrices
DPS = 40


@dataclasses.dataclass(frozen=True)
class Affine:
    """An expression vector split as M_x x + M_u u + m0 + Σ_t (coefficients) φ_t."""

    Mx: sp.Matrix
    Mu: sp.Matrix
    m0: sp.Matrix
    rest: list  # of (monomial φ, column vector of coefficients)



def split_affine(exprs, xs, us, uncertain, what: str, where: str) -> Affine:
    """Split into the nominal affine part in (x, u) and the monomials carrying an uncertain
    symbol; refuse a nominal part that is not affine with constant coefficients."""
    gens = list(xs) + list(us) + list(uncertain)
    n = len(exprs)
    Mx, Mu, m0 = sp.zeros(n, len(xs)), sp.zeros(n, len(us)), sp.zeros(n, 1)
    rest: dict = {}
    unc = set(uncertain)
    for i, e in enumerate(exprs):
        try:
            poly = sp.Poly(e, *gens) if gens else None
        except sp.PolynomialError:
            poly = None
        if poly is None or any(c.free_symbols for c in poly.coeffs()):
            raise UsageError(f"{where}: {what} {i + 1} is not polynomial with constant"
                             f" coefficients ({e}); sampled guaranteed thresholds need a plant"
                             " linear in its states and inputs")
        for monom, c in poly.terms():
            syms = {g for g, a in zip(gens, monom) if a}
            phi = sp.Mul(*[g ** a for g, a in zip(gens, monom) if a])
            if syms & unc:
                rest.setdefault(phi, sp.zeros(n, 1))[i] += c
            elif not syms:
                m0[i] += c
            elif len(syms) == 1 and sum(monom) == 1:
                g = syms.pop()
                if g in xs:
                    Mx[i, list(xs).index(g)] += c
                else:
                    Mu[i, list(us).index(g)] += c
            else:
                raise UsageError(f"{where}: {what} {i + 1} has the nonlinear nominal term {phi}"
                                 "; sampled guaranteed thresholds need a plant linear in its"
                                 " states and inputs (use the continuous-time guaranteed band)")
    return Affine(Mx, Mu, m0, list(rest.items()))



def box_of(phi, box, where: str) -> tuple:
    """Exact range [lo, hi] of a monomial over the boxes."""
    lo = hi = sp.Integer(1)
    for s, a in phi.as_powers_dict().items():
        if s.is_number:
            lo, hi = lo * s ** a, hi * s ** a
            continue
        if s not in box:
            raise UsageError(f"{where}: '{s}' has no declared bounds; the sampled guaranteed"
                             f" threshold needs them (declare bounds={{{s}: (low, high)}})")
        l, u = box[s]
        a = int(a)
        if a % 2 == 0 and l < 0 < u:
            pl, ph = sp.Integer(0), max(l ** a, u ** a)
        else:
            pl, ph = sorted((l ** a, u ** a))
        ps = [lo * pl, lo * ph, hi * pl, hi * ph]
        lo, hi = min(ps), max(ps)
    return lo, hi



def to_mp(M) -> mpmath.matrix:
    M = sp.Matrix(M)
    out = mpmath.matrix(M.rows, M.cols)
    for i in range(M.rows):
        for j in range(M.cols):
            out[i, j] = mpmath.mpf(sp.Rational(M[i, j]).p) / sp.Rational(M[i, j]).q
    return out



def hold_step(A, h, how: str) -> tuple:
    """(e^{A h}, ∫₀ʰ e^{A τ} dτ) for how = "exact", or RK4's (F, Q) for how = "rk4",
    in 40-digit arithmetic (RK4: exact rationals)."""
    k = A.rows
    if how == "rk4":
        hA = sp.Matrix(A) * h
        I = sp.eye(k)
        F = I + hA + hA ** 2 / 2 + hA ** 3 / 6 + hA ** 4 / 24
        Q = h * (I + hA / 2 + hA ** 2 / 6 + hA ** 3 / 24)
        return to_mp(F), to_mp(Q)
    with mpmath.workdps(DPS):
        M = mpmath.zeros(2 * k, 2 * k)
        Am = to_mp(A)
        hm = mpmath.mpf(sp.Rational(h).p) / sp.Rational(h).q
        for i in range(k):
            M[i, k + i] = hm
            for j in range(k):
                M[i, j] = Am[i, j] * hm
        E = mpmath.expm(M) if k else M
        return E[:k, :k] if k else mpmath.zeros(0, 0), E[:k, k:] if k else mpmath.zeros(0, 0)



def to_np(M) -> np.ndarray:
    return np.array([[float(M[i, j]) for j in range(M.cols)] for i in range(M.rows)],
                    dtype=float).reshape(M.rows, M.cols)



def affine_and_rest(e, gens) -> tuple:
    """e = (terms of degree ≤ 1 in ``gens`` with constant coefficients) + the rest."""
    aff, rest = sp.Integer(0), sp.Integer(0)
    for term in sp.Add.make_args(sp.expand(e)):
        try:
            poly = sp.Poly(term, *gens) if gens else None
            ok = poly is None or (poly.total_degree() <= 1
                                  and not any(c.free_symbols for c in poly.coeffs()))
        except sp.PolynomialError:
            ok = False
        if ok:
            aff += term
        else:
            rest += term
    return aff, rest



def exp_tail(M: np.ndarray) -> np.ndarray:
    """Σ_{m ≥ 2} M^m/m! of a nonnegative matrix (positive terms: no cancellation)."""
    term, total = M.copy(), np.zeros_like(M)
    for j in range(2, 200):
        term = term @ M / j
        total += term
        if not np.any(term > 1e-18 * (total + 1e-300)):
            break
    return total


def identity_condition(g: dict, out: Affine, plant: dict, where: str, what: str) -> Condition:
    """The exact identities the band rests on: the plant's (``plant``: name → matrix that
    must vanish) and the residual's (C_r Φ + G_r H = 0, G_r D_y + G_ru = 0, G_r h0 + c_r = 0);
    a one-line refusal naming the first that fails."""
    checks = dict(plant)
    checks.update({"C_r Φ + G_r H = 0": g["Cr"] * g["Phi"] + g["Gr"] * out.Mx,
                   "G_r D_y + G_ru = 0": g["Gr"] * out.Mu + g["Gru"],
                   "G_r h0 + c_r = 0": g["Gr"] * out.m0 + g["cr"]})
    for name, M in checks.items():
        if any(sp.simplify(e) != 0 for e in M):
            raise UsageError(f"{where}: the observer does not reproduce the nominal plant"
                             f" ({name} fails); the residual is not zero without faults,"
                             " noise, disturbances and uncertainty")
    return Condition("fault-free residual identity", True,
                     "exact: " + ", ".join(checks) + f" ({what}, observer's own equations)",
                     "METHOD §3 (residual evaluation)")
