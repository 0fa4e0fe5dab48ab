"""Special eigenvalues for the Jordan form when every λ is admissible (METHOD §2b).

When [L0(F − λI); H] loses row rank for every λ, the default lists (−1, −2, … or
1/2, 1/4, …) give generic rows. A design of fewer rows may need a *particular* λ; every
such λ is a root of an exact polynomial, computed here:

* **one row (k = 1)**, virtual sensor / interval observer for z = M x (M one row, not
  in rowspace H): Φ = M − Q H (up to a nonzero factor) must satisfy Φ L = 0 and
  Φ (F − λI) = J* H, i.e. (Q, J*) E(λ) = m(λ) with

      E(λ) = [H L, H(F − λI); 0, H],     m(λ) = (M L, M(F − λI)).

  Solvable at λ iff rank [E(λ); m(λ)] = rank E(λ). When that fails for λ a free symbol
  (rank r + 1 against r), it can hold only where [E; m] drops below r + 1, so only at
  the roots of the pivots of an exact elimination of [E; m] over QQ(λ): if no pivot
  vanishes at λ0, the same elimination is valid at λ0 and gives the same rank.
  The roots of those factors are the candidates p(λ) = 0; each is then checked exactly
  by the design itself.
* **one row, diagnostic**: Φ = R* H (Φ ∈ rowspace H), and Φ(F − λI) ∈ rowspace H does
  not depend on λ: no λ is special.
* **family jumps**: where P(λ) drops below its rank for λ a free symbol (the pivots
  of its exact elimination: unobservable or decoupled eigenvalues of F, transmission
  zeros), the family of rows Φ_λ is larger; a design of several rows may need those λ
  (a row coinciding with a left eigenvector direction, a fixed mode of the reduced
  model). They are candidates for k ≥ 2.

Roots are exact: rationals, quadratic surds, and real roots of irreducible factors of
degree ≥ 3 as ``sympy.CRootOf`` (arithmetic in the algebraic number field, exact).

References: seed 002 §2 eqs. (2.4)-(2.5); METHOD §2b.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..numerics import exact_rank
from ._reduced import is_stable

__all__ = ["SpecialLambdas", "one_row_lambdas", "family_jump_lambdas", "exact_real_roots"]


@dataclasses.dataclass(frozen=True)
class SpecialLambdas:
    """The real λ at which a condition polynomial in λ vanishes, found exactly.

    ``generic``: the condition holds for λ a free symbol (no λ is special);
    ``analysed``: False when the question was not decided (then ``evidence`` says why);
    ``polynomial``: p(λ), the product of the candidate factors (1 when none);
    ``roots``: its real roots, exact, ascending; ``stable``: the stable ones.
    """

    generic: bool
    analysed: bool
    polynomial: sp.Expr
    roots: tuple
    stable: tuple
    evidence: str


def exact_real_roots(factors, lam) -> list:
    """Real roots of irreducible polynomials in ``lam`` (numeric coefficients), exactly:
    rationals, square roots, ``CRootOf`` for degree ≥ 3; ascending, without repeats."""
    out = []
    for f in factors:
        poly = sp.Poly(f, lam)
        if poly.degree() <= 0:
            continue
        if poly.degree() <= 2:
            rts = [r for r in sp.roots(poly).keys() if r.is_real]
        else:
            rts = list(poly.real_roots())
        for r in rts:
            if not any(abs(float(r) - float(o)) <= 1e-9 * (1 + abs(float(o)))
                       and sp.simplify(r - o) == 0 for o in out):
                out.append(r)
    out.sort(key=lambda v: float(v.evalf(30)))
    return out


def _factors(conditions, lam) -> list:
    """The λ-polynomials of an ExactRank's pivot conditions ``Ne(f, 0)``."""
    fs = []
    for c in conditions:
        f = sp.expand(c.lhs)
        if f.free_symbols == {lam}:
            fs.append(f)
    fs.sort(key=str)
    return fs


def _product(factors):
    return sp.Mul(*factors) if factors else sp.Integer(1)


def _special(conditions, lam, time, generic: bool, what: str) -> SpecialLambdas:
    fs = _factors(conditions, lam)
    roots = exact_real_roots(fs, lam)
    stable = tuple(r for r in roots if is_stable(r, time))
    p = _product(fs)
    rt = ", ".join(map(str, roots)) or "none real"
    ev = f"{what}: p(λ) = {sp.factor(p)}" + (f", real roots {rt}" if fs else " (no factor)")
    return SpecialLambdas(generic, True, p, tuple(roots), stable, ev)


def one_row_lambdas(F, H, L, M, lam, time: str) -> SpecialLambdas:
    """The λ admitting a one-row virtual sensor / interval observer for z = M x.

    ``L``: the decoupled inputs (n × p, p may be 0); ``M``: one row, not in rowspace H.
    """
    F, H, L, M = (sp.Matrix(X) for X in (F, H, L, M))
    n, l = F.rows, H.rows  # noqa: E741
    free = set().union(*(X.free_symbols for X in (F, H, L, M)))
    if free:
        return SpecialLambdas(False, False, sp.Integer(1), (), (),
                              "not analysed: symbolic parameters (only the default λ are tried)")
    if M.rows != 1:
        return SpecialLambdas(False, False, sp.Integer(1), (), (),
                              f"not analysed: z has {M.rows} components")
    A = F - lam * sp.eye(n)
    E = sp.Matrix.vstack(sp.Matrix.hstack(H * L, H * A),
                         sp.Matrix.hstack(sp.zeros(l, L.cols), H))
    m = sp.Matrix.hstack(M * L, M * A)
    rE = exact_rank(E).rank
    rB = exact_rank(sp.Matrix.vstack(E, m))
    if rB.rank == rE:
        return SpecialLambdas(True, True, sp.Integer(1), (), (),
                              f"rank [E(λ); m(λ)] = rank E(λ) = {rE} for λ a free symbol:"
                              " a one-row design exists for all but finitely many λ")
    return _special(rB.conditions, lam, time, False,
                    f"k = 1 needs M − Q H with (M − Q H) L = 0 and (M − Q H)(F − λI) ∈"
                    f" rowspace H: rank [E(λ); m(λ)] = {rB.rank} > rank E(λ) = {rE} for λ a free"
                    " symbol, so it needs λ a root of the pivots of [E(λ); m(λ)]")


def family_jump_lambdas(F, H, L0, lam, time: str) -> SpecialLambdas:
    """The λ where P(λ) = [L0(F − λI); H] drops below its rank for λ a free symbol."""
    F, H, L0 = (sp.Matrix(X) for X in (F, H, L0))
    if set().union(*(X.free_symbols for X in (F, H, L0))):
        return SpecialLambdas(False, False, sp.Integer(1), (), (),
                              "not analysed: symbolic parameters")
    P = sp.Matrix.vstack(L0 * (F - lam * sp.eye(F.rows)), H)
    rk = exact_rank(P)
    return _special(rk.conditions, lam, time, not rk.conditions,
                    f"rank P(λ) = {rk.rank} for λ a free symbol; it drops (a larger family of"
                    " rows) only at roots of its pivots")
