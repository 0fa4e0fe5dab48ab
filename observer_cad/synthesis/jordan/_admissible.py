"""The admissible λ of the Jordan form (METHOD §2b, seed 002 eq. (2.5)) and the rows of
each λ.

F* = diag(λ_1, …, λ_k), real and stable, so the defining equation splits by rows::

    (S_i, −J*_i) [L0 (F − λ_i I); H] = 0,     Φ_i = S_i L0

A λ is *admissible* when that stacked matrix P(λ) loses row rank: for every λ (generic
solvability, e.g. when it has more rows than columns) or on the finite set of roots of
the greatest common divisor of its maximal minors, computed exactly here.

References: seed 002 §2, eq. (2.5); seed 000 eq. (8.2); METHOD §2b.
"""
from __future__ import annotations

import dataclasses
import itertools

import sympy as sp

from ...numerics import exact_rank, exact_rank_value, left_null_echelon

__all__ = ["LAMBDA", "Admissible", "admissible_lambdas", "pencil", "rows_for_lambda",
           "rank_of", "same_number"]


LAMBDA = sp.Symbol("lambda")


@dataclasses.dataclass(frozen=True)
class Admissible:
    """Which λ make [L0 (F − λI); H] lose row rank."""

    generic: bool
    values: tuple  # real roots (exact) when not generic
    other_roots: tuple  # complex roots, reported, not usable (F* must be real)
    evidence: str

    def contains(self, lam) -> bool:
        if self.generic:
            return True
        lam = sp.sympify(lam)
        return any(same_number(lam, v) for v in self.values)

    def describe(self) -> str:
        if self.generic:
            return "every λ (generic solvability)"
        vals = ", ".join(str(v) for v in self.values) or "none real"
        return f"λ ∈ {{{vals}}}"


def pencil(F, H, L0, lam):
    """P(λ) = [L0 (F − λI); H] (its left null space gives the rows of λ)."""
    n = F.rows
    return sp.Matrix.vstack(L0 * (F - lam * sp.eye(n)), H)


def rows_for_lambda(F, H, L0, lam) -> tuple:
    """The rows of λ: ``(Φ rows, J rows, pivot conditions)`` with Φ = S L0 and
    S L0 (F − λI) = J H, from the left null space of [L0 (F − λI); H] (nonzero Φ only)."""
    members, rkP = left_null_echelon(pencil(F, H, L0, lam))
    rows_phi, rows_j = [], []
    for v in members:
        S, J = v[:, :L0.rows], -v[:, L0.rows:]
        Phi_i = (S * L0).applyfunc(sp.cancel)
        if Phi_i != sp.zeros(1, F.rows):
            rows_phi.append(Phi_i)
            rows_j.append(J.applyfunc(sp.cancel))
    return rows_phi, rows_j, rkP.conditions


def _det(M):
    """Determinant over the polynomial ring (fast, exact), as an expression."""
    from sympy.polys.matrices import DomainMatrix
    dm = DomainMatrix.from_Matrix(sp.Matrix(M))
    return dm.domain.to_sympy(dm.det()) if hasattr(dm.domain, "to_sympy") else dm.to_Matrix().det()


def admissible_lambdas(F, H, L0) -> Admissible:
    """Exactly: generic solvability, or the real roots where P(λ) drops row rank."""
    F, H, L0 = sp.Matrix(F), sp.Matrix(H), sp.Matrix(L0)
    n = F.rows
    P = pencil(F, H, L0, LAMBDA)
    r = P.rows
    if r > n:
        return Admissible(True, (), (), f"[L0(F − λI); H] has {r} rows > {n} columns:"
                                        " a left null vector exists for every λ")
    gr = exact_rank(P)
    if gr.rank < r:
        return Admissible(True, (), (), f"rank [L0(F − λI); H] = {gr.rank} < {r} rows"
                                        " for λ as a free symbol")
    minors = []
    for cols in itertools.combinations(range(n), r):
        m = sp.expand(_det(P[:, list(cols)]))
        if m != 0:
            minors.append(m)
    g = minors[0]
    for m in minors[1:]:
        g = sp.gcd(g, m)
    g = sp.factor(g)
    if not g.has(LAMBDA):
        return Admissible(False, (), (), f"gcd of the maximal minors of [L0(F − λI); H] is"
                                         f" {g}, free of λ: no admissible λ")
    real, other = [], []
    _, factors = sp.factor_list(g, LAMBDA)
    for f, _mult in factors:
        deg = sp.degree(f, LAMBDA)
        if deg == 0:
            continue
        if deg <= 2:  # rational or quadratic roots: exact arithmetic stays cheap
            rts = list(sp.roots(sp.Poly(f, LAMBDA)).keys())
        elif not f.free_symbols - {LAMBDA}:
            rts = list(sp.Poly(f, LAMBDA).all_roots())  # CRootOf: reported, not used
        else:
            rts = []
        for rt in rts:
            real_ = rt.is_real
            if real_ or (real_ is None and rt.free_symbols):
                real.append(rt)
            else:
                other.append(rt)
    real.sort(key=lambda v: (bool(v.free_symbols), sp.re(v) if v.is_number else 0, str(v)))
    return Admissible(False, tuple(real), tuple(other),
                      f"gcd of the maximal minors of [L0(F − λI); H] = {g}")


def rank_of(M) -> int:
    """The exact rank of M (0 for an empty matrix)."""
    M = sp.Matrix(M)
    if M.rows == 0 or M.cols == 0:
        return 0
    return exact_rank_value(M)


def same_number(a, b) -> bool:
    """Exact equality of two real numbers (rationals, surds, CRootOf); a float comparison
    first, so that distinct values never reach ``simplify``."""
    if a == b:
        return True
    if a.free_symbols or b.free_symbols:
        return sp.simplify(a - b) == 0
    if abs(float(a) - float(b)) > 1e-9 * (1 + abs(float(a))):
        return False
    return sp.simplify(a - b) == 0
