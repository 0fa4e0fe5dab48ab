"""Closed-loop eigenvalues of canonical designs: defaults, parsing, stability, exact
pole placement of F* − K H*.

Pole placement (METHOD §3) finds K with det(sI − F* + K H*) = p(s) = Π(s − μ_i) over the
exact field of the entries of F*, H* (QQ, QQ(parameters), an algebraic field, else sympy's
EX), by the observer form of Ackermann's formula:

* one output row h:   K = p(F*) O⁻¹ e_k,  O = [h; h F*; …; h F*^{k−1}]  (the
  observability matrix; e_k the last unit vector);
* several rows H*:    a seeded rational combination c (unit vectors first, then all
  ones, then small random integers) with (F*, c H*) observable, K = K₁ c with K₁ from
  the one-row formula; when F* is not cyclic no c exists and a seeded random K₀ first
  makes F* − K₀ H* cyclic (Heymann's lemma: for observable (F*, H*) almost every K₀
  and c work), K = K₀ + K₁ c.

K₁ = Σ a_i F*^{k−i} x (x = O⁻¹ e_k) is linear in the coefficients a_i of p, so irrational
or complex μ_i (whose p has algebraic coefficients) never enlarge the field the
elimination runs in: the a_i are combined with the Krylov vectors F*^j x at the end.
No polynomial system is solved: the cost is k matrix products and one k×k solve, so
k = 8 takes milliseconds (the previous ``solve`` of the coefficient equations took
15 s at k = 6). Every gain is certified: the characteristic polynomial of F* − K H* is
recomputed from the returned sympy matrices (a fresh domain, Berkowitz's algorithm)
and must equal Π(s − μ_i) coefficient by coefficient, exactly.

References: J. Ackermann, "Der Entwurf linearer Regelungssysteme im Zustandsraum",
Regelungstechnik 20 (1972); M. Heymann, "Comments on pole assignment in multi-input
controllable linear systems", IEEE TAC 13 (1968); T. Kailath, *Linear Systems* (1980),
§3.2 and §7.2.
"""
from __future__ import annotations

import dataclasses
import random

import sympy as sp
from sympy.polys.matrices import DomainMatrix

from ...errors import CertificateError, DimensionError, InfeasibleDesignError, UsageError
from ...model import parse_number
from ...numerics import nonzero_conditions, rationalize_floats, to_domain_matrix

__all__ = ["default_eigenvalues", "parse_eigenvalues", "place_poles", "pole_placement",
           "PolePlacement", "certify_poles", "closed_loop_eigenvalues", "target_polynomial",
           "PLACEMENT_SEED", "require_stable"]

S = sp.Dummy("s")  # never a model parameter named s

#: seed of the rational combinations tried for several output rows (reproducible gains)
PLACEMENT_SEED = 0
_TRIES = 40  # random combinations c / preliminary gains K₀ tried before giving up


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


@dataclasses.dataclass(frozen=True)
class PolePlacement:
    """A certified gain K (k × p) with det(sI − F* + K H*) = Π(s − μ_i).

    ``characteristic_polynomial``: the coefficients of det(sI − F* + K H*), leading 1,
    recomputed independently from ``K`` (they equal those of Π(s − μ_i)).
    ``combination``: the row c (1 × p) with K = K₀ + K₁ c for several output rows
    (``None`` for one row); ``preliminary``: K₀ when F* had to be made cyclic first.
    ``assumptions``: ``Ne(f, 0)`` for the factors of det O when F*, H* have
    parameters (the gain holds where the observability matrix used is invertible).
    """
    K: sp.ImmutableMatrix
    eigenvalues: tuple
    characteristic_polynomial: tuple
    combination: sp.ImmutableMatrix | None = None
    preliminary: sp.ImmutableMatrix | None = None
    assumptions: frozenset = frozenset()

    @property
    def method(self) -> str:
        if self.combination is None:
            return "Ackermann (one output row)"
        c = list(self.combination)
        txt = f"Ackermann on c H* with c = {c}"
        return txt + (", after K0 making F* − K0 H* cyclic" if self.preliminary is not None else "")


def target_polynomial(eigenvalues) -> tuple:
    """Coefficients of Π(s − μ_i), leading 1, exact (real for conjugate pairs)."""
    p = sp.expand(sp.prod([S - mu for mu in eigenvalues]))
    return tuple(sp.expand(p.coeff(S, i)) for i in range(len(eigenvalues), -1, -1))


def _same(a, b) -> bool:
    d = sp.expand(a - b)
    return d == 0 or sp.simplify(d) == 0  # nested radicals, rational functions: canonicalise


def certify_poles(Fs, Hs, K, eigenvalues) -> tuple:
    """The coefficients of det(sI − F* + K H*), recomputed from the sympy matrices over a
    fresh exact domain; raises :class:`CertificateError` unless they equal those of
    Π(s − μ_i) exactly."""
    Fs, Hs, K = sp.Matrix(Fs), sp.Matrix(Hs), sp.Matrix(K)
    want = target_polynomial(eigenvalues)
    Fcl = Fs - K * Hs
    if Fcl.rows == 0:
        got = (sp.Integer(1),)
    else:
        dm = to_domain_matrix(Fcl)
        got = tuple(sp.expand(dm.domain.to_sympy(c)) for c in dm.charpoly())
    bad = [i for i, (a, b) in enumerate(zip(got, want)) if not _same(a, b)]
    if len(got) != len(want) or bad:
        raise CertificateError(
            "pole placement failed its exact check: det(sI − F* + K H*) has coefficients"
            f" {[str(c) for c in got]}, Π(s − μ_i) has {[str(c) for c in want]}")
    return got


# ---------------------------------------------------------------- exact construction
def _field(mats):
    """The matrices over one exact field (QQ, QQ(parameters), an algebraic field or EX)."""
    flat = [e for M in mats for e in M]
    dm = to_domain_matrix(sp.Matrix(len(flat), 1, flat) if flat else sp.zeros(1, 1))
    K = dm.domain
    elems = dm.to_list_flat()
    out, i = [], 0
    for M in mats:
        n = M.rows * M.cols
        out.append((DomainMatrix.from_list_flat(elems[i:i + n], M.shape, K) if n
                    else DomainMatrix.zeros(M.shape, K)).to_dense())
        i += n
    return K, out


def _observability(F: DomainMatrix, H: DomainMatrix) -> DomainMatrix:
    rows, r = [], H
    for _ in range(F.shape[0]):
        rows.append(r)
        r = r * F
    return DomainMatrix.vstack(*rows)


def _krylov(F: DomainMatrix, h: DomainMatrix):
    """x = O⁻¹ e_k and the vectors F^j x, j = 0 … k, for one output row h; ``None`` when
    (F, h) is not observable. Returns (vectors, det O)."""
    K, k = F.domain, F.shape[0]
    O = _observability(F, h)
    det = O.det()
    if det == K.zero:
        return None, det
    e = DomainMatrix([[K.zero]] * (k - 1) + [[K.one]], (k, 1), K).to_dense()
    vs = [O.to_dense().lu_solve(e)]
    for _ in range(k):
        vs.append(F * vs[-1])
    return vs, det


def _ackermann(vs, coeffs, dom):
    """K₁ = p(F) x = Σ_i a_i F^{k−i} x as a sympy column. The coefficients a_i enter
    linearly, so F and h stay over their own field; irrational a_i (algebraic μ_i) are
    combined as sympy numbers rather than by building an algebraic field."""
    k = len(vs) - 1
    try:
        a = [dom.from_sympy(c) for c in coeffs]
    except Exception:  # noqa: BLE001 - not in the field of F*, H* (CoercionFailed and kin)
        a = None
    if a is not None:
        acc = vs[k]
        for i in range(1, k + 1):
            acc = acc + vs[k - i] * a[i]
        return acc.to_Matrix()
    cols = [v.to_Matrix() for v in vs]
    acc = sum((coeffs[i] * cols[k - i] for i in range(1, k + 1)), cols[k])
    return acc.applyfunc(sp.expand if dom.is_QQ or dom.is_ZZ else sp.cancel)


def _combinations(p: int, rng: random.Random):
    """Unit vectors, all ones, then seeded small random integer rows."""
    for i in range(p):
        yield [1 if j == i else 0 for j in range(p)]
    yield [1] * p
    for _ in range(_TRIES):
        yield [rng.randint(-3, 3) for _ in range(p)]


def pole_placement(Fs, Hs, eigenvalues, *, seed: int = PLACEMENT_SEED) -> PolePlacement:
    """K with det(sI − F* + K H*) = Π(s − μ_i), exactly, certified.

    Parameters
    ----------
    Fs
        The k × k matrix F*.
    Hs
        The p × k matrix H* (any number of rows p ≥ 1).
    eigenvalues
        k exact numbers μ_i (complex ones in conjugate pairs).
    seed
        Seed of the random combinations tried for several rows (default 0).

    Notes
    -----
    Method: observer-form Ackermann formula over the exact field (module docstring);
    floats in F*, H* are read as the rationals their decimal strings denote.
    Raises :class:`InfeasibleDesignError` when (F*, H*) is not observable (with the rank
    of its observability matrix), :class:`DimensionError` for mismatched shapes.
    """
    Fs = sp.Matrix(Fs).applyfunc(rationalize_floats)
    Hs = sp.Matrix(Hs).applyfunc(rationalize_floats)
    k = Fs.rows
    if Fs.cols != k:
        raise DimensionError(f"pole placement: F* must be square, got {Fs.rows}×{Fs.cols}")
    if Hs.cols != k:
        raise DimensionError(f"pole placement: H* must have k = {k} columns like F*,"
                             f" got {Hs.rows}×{Hs.cols}")
    eigenvalues = tuple(rationalize_floats(sp.sympify(e)) for e in eigenvalues)
    if len(eigenvalues) != k:
        raise UsageError(f"{k} eigenvalues needed (k = {k}), got {len(eigenvalues)}")
    p = Hs.rows
    if k == 0:
        return PolePlacement(sp.ImmutableMatrix(sp.zeros(0, p)), (), (sp.Integer(1),))
    if p == 0:
        raise InfeasibleDesignError("the requested eigenvalues cannot be placed: (F*, H*) is"
                                    " not observable (H* has no rows)")
    coeffs = target_polynomial(eigenvalues)
    dom, (F, H) = _field([Fs, Hs])

    # Step 1) one row: Ackermann directly
    c = K0 = None
    if p == 1:
        vs, det = _krylov(F, H)
    else:
        # Step 1') several rows: (F*, H*) must be observable at all
        vs = None
        if _observability(F, H).rank() == k:
            rng = random.Random(seed)
            Fw = F
            for attempt in range(_TRIES + 1):
                if attempt:  # F* not cyclic: a preliminary gain K₀ (Heymann's lemma)
                    K0 = DomainMatrix([[dom.convert(rng.randint(-2, 2)) for _ in range(p)]
                                       for _ in range(k)], (k, p), dom).to_dense()
                    Fw = F - K0 * H
                for cand in _combinations(p, rng):
                    cd = DomainMatrix([[dom.convert(v) for v in cand]], (1, p), dom).to_dense()
                    vs, det = _krylov(Fw, cd * H)
                    if vs is not None:
                        c = cand
                        break
                if vs is not None:
                    break
    if vs is None:
        r = _observability(F, H).rank()
        raise InfeasibleDesignError(
            "the requested eigenvalues cannot be placed: (F*, H*) is not observable (rank of"
            f" the observability matrix {r} < k = {k})")
    # Step 2) K = K₀ + K₁ c with K₁ = p(F* − K₀ H*) O⁻¹ e_k
    K = _ackermann(vs, coeffs, dom)
    if c is not None:
        K = K * sp.Matrix([c])
        if K0 is not None:
            K = K + K0.to_Matrix()
    K = K.applyfunc(sp.cancel)
    # Step 3) certificate: det(sI − F* + K H*) recomputed independently
    cp = certify_poles(Fs, Hs, K, eigenvalues)
    return PolePlacement(
        sp.ImmutableMatrix(K), eigenvalues, cp,
        combination=None if c is None else sp.ImmutableMatrix([c]),
        preliminary=None if K0 is None else sp.ImmutableMatrix(K0.to_Matrix()),
        assumptions=nonzero_conditions(dom.to_sympy(det)))


def closed_loop_eigenvalues(placed: PolePlacement) -> tuple:
    """The eigenvalues of F* − K H*, sorted by real then imaginary part: the requested
    μ_i themselves, since the certificate proved det(sI − F* + K H*) = Π(s − μ_i)."""
    return tuple(sorted(placed.eigenvalues, key=lambda z: (float(sp.re(z)), float(sp.im(z)))))


def place_poles(Fs, Hs, eigenvalues):
    """K (k × p, a sympy Matrix) with det(sI − F* + K H*) = Π(s − μ_i), exactly and
    certified; see :func:`pole_placement` (which also returns the certificate)."""
    return sp.Matrix(pole_placement(Fs, Hs, eigenvalues).K)


def require_stable(eigs, time, requested):
    """Requested closed-loop eigenvalues must be stable for the time domain."""
    bad = [e for e in eigs if not ((sp.re(e) < 0) if time == "continuous" else (sp.Abs(e) < 1))]
    if bad:
        need = "Re < 0" if time == "continuous" else "|·| < 1"
        raise InfeasibleDesignError(
            f"requested eigenvalues {[str(e) for e in requested]} are not stable in {time} time"
            f" (needs {need}): {', '.join(map(str, bad))}")
