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
import random

import numpy as np
import sympy as sp

from sympy.polys.matrices import DomainMatrix

from ...numerics import exact_rank_value, left_null_space, solve_left
from ..core import is_stable

__all__ = ["SpecialLambdas", "QRowsVerdict", "one_row_lambdas", "family_jump_lambdas",
           "rank_drop_lambdas", "q_rows_possible", "span_pencil", "exact_real_roots",
           "polynomial_row", "coefficient_rows"]


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
    Adding λ times the H block to E(λ) removes λ from it: (Q, J*) E(λ) = m(λ) becomes
    x E0 = m0 − λ m1 with E0 = [H L, H F; 0, H], m0 = (M L, M F), m1 = (0, M); so λ is
    the coefficient of m1 in the exact solution of (x, λ) [E0; m1] = m0 — one rational λ,
    every λ (m1, m0 ∈ rowspace E0), or none.
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
    E0 = sp.Matrix.vstack(sp.Matrix.hstack(H * L, H * F),
                          sp.Matrix.hstack(sp.zeros(l, L.cols), H))
    m0 = sp.Matrix.hstack(M * L, M * F)
    m1 = sp.Matrix.hstack(sp.zeros(1, L.cols), M)
    how = ("k = 1 needs Φ = M − Q H with Φ L = 0 and Φ (F − λI) ∈ rowspace H, i.e."
           " (x, λ) [E0; m1] = m0 with E0 = [H L, H F; 0, H], m0 = (M L, M F), m1 = (0, M)")
    if solve_left(E0, m1) is not None:  # λ drops out: every λ or none
        if solve_left(E0, m0) is not None:
            return SpecialLambdas(True, True, sp.Integer(1), (), (),
                                  f"{how}: m0 and m1 lie in rowspace E0, so every λ admits one row")
        return SpecialLambdas(False, True, sp.Integer(1), (), (),
                              f"{how}: m1 lies in rowspace E0 but m0 does not, so no λ admits one"
                              " row")
    X = solve_left(sp.Matrix.vstack(E0, m1), m0)
    if X is None:
        return SpecialLambdas(False, True, sp.Integer(1), (), (),
                              f"{how}: m0 is not in rowspace [E0; m1], so no λ admits one row")
    root = sp.sympify(X[0, X.cols - 1])  # exact (rational) already
    p = lam - root
    stable = (root,) if is_stable(root, time) else ()
    return SpecialLambdas(False, True, p, (root,), stable,
                          f"{how}: it needs λ = {root}, the root of p(λ) = {p}")


def family_jump_lambdas(F, H, L0, lam, time: str) -> SpecialLambdas:
    """The λ where P(λ) = [L0(F − λI); H] drops below its rank r for λ a free symbol
    (see :func:`rank_drop_lambdas`)."""
    F, H, L0 = (sp.Matrix(X) for X in (F, H, L0))
    if set().union(*(X.free_symbols for X in (F, H, L0))):
        return SpecialLambdas(False, False, sp.Integer(1), (), (),
                              "not analysed: symbolic parameters")
    P = sp.Matrix.vstack(L0 * (F - lam * sp.eye(F.rows)), H)
    return rank_drop_lambdas(P, lam, time, "P(λ)", "a larger family of rows")[1]


def rank_drop_lambdas(P, lam, time: str, name: str, meaning: str) -> tuple:
    """``(r, SpecialLambdas)``: the rank r of the numeric matrix P(λ) for λ a free symbol
    and the real λ where P drops below r.

    Candidates: the roots of gcd(det(U₁ P V₁), det(U₂ P V₂)) for random integer U_i (r × rows),
    V_i (n × r) — by Cauchy–Binet each is a combination of the r × r minors, so divisible by
    their gcd: the drop points are among the roots (a superset, never fewer); the roots
    where P keeps rank r are then removed by a singular-value check.
    """
    dm = DomainMatrix.from_Matrix(P).convert_to(sp.QQ[lam])
    r = dm.convert_to(sp.QQ.frac_field(lam)).rank()
    if r == 0:
        return 0, SpecialLambdas(True, True, sp.Integer(1), (), (), f"{name} = 0")
    rng = random.Random(20261122)
    g, tries = None, 0
    while tries < 6 and (g is None or tries < 2):
        tries += 1
        U = DomainMatrix([[sp.QQ[lam](rng.randint(-9, 9)) for _ in range(P.rows)] for _ in range(r)],
                         (r, P.rows), sp.QQ[lam])
        V = DomainMatrix([[sp.QQ[lam](rng.randint(-9, 9)) for _ in range(r)] for _ in range(P.cols)],
                         (P.cols, r), sp.QQ[lam])
        d = sp.QQ[lam].to_sympy((U * dm * V).det())
        if d == 0:
            continue
        g = d if g is None else sp.gcd(g, d)
    if g is None:  # pragma: no cover - every compression singular (probability 0)
        return r, SpecialLambdas(False, False, sp.Integer(1), (), (),
                                 "not analysed: singular compressions")
    _, facs = sp.factor_list(g, lam)
    conds = [sp.Ne(f, 0) for f, _m in facs if f.has(lam)]
    sp_ = _special(conds, lam, time, not conds,
                   f"rank {name} = {r} for λ a free symbol; it drops ({meaning})"
                   " only at roots of gcd(det(U P V)) over two random compressions")
    # keep the roots where P really drops rank (an exact root of a true drop leaves σ_r at
    # rounding level; a spurious one a clear σ_r)
    keep = tuple(v for v in sp_.stable if _drops(P, lam, v, r))
    dropped = [v for v in sp_.stable if v not in keep]
    ev = sp_.evidence + (f"; {name} keeps rank {r} at {', '.join(map(str, dropped))}"
                         f" (σ_{r}/σ_1 > {_DROP_RTOL:.0e})" if dropped else "")
    return r, dataclasses.replace(sp_, stable=keep, evidence=ev)


@dataclasses.dataclass(frozen=True)
class QRowsVerdict:
    """Can q = rank [M; H] − rank H rows — the fewest any model of z = M x has — do it?

    Such rows span z modulo the outputs with nothing to spare, so each lies in
    rowspace [M; H]: Φ = a M + b H with Φ (F − λI) ∈ rowspace H (and Φ L = 0). ``A(λ)``
    is the space of those a at λ; q rows exist iff the A(λ) over the real stable λ sum to
    all of Rᵐ (m = rows of M; the a with a M ∈ rowspace H lie in every A(λ)).

    ``analysed``: False when not decided (``evidence`` says why); ``possible``: q rows
    exist for some real stable λ (the linear conditions; the task may add more);
    ``stable``: the stable λ where A(λ) is larger than for λ generic and adds a direction
    (they must be among the λ tried); ``q``: the number of rows.
    """

    analysed: bool
    possible: bool
    q: int
    stable: tuple
    evidence: str


def polynomial_row(entries) -> list:
    """Rational functions of λ times the lcm of their denominators: a row of polynomials,
    the same direction wherever no denominator vanishes."""
    a = [sp.together(e) for e in entries]
    den = sp.lcm_list([sp.fraction(e)[1] for e in a])
    return [sp.cancel(e * den) for e in a]


def coefficient_rows(row, lam) -> list:
    """The nonzero coefficient vectors (of λ⁰, λ¹, …) of a row of polynomials in λ: they
    span what the row's values span over any infinitely many λ (Vandermonde)."""
    polys = [sp.Poly(e, lam) for e in row]
    deg = max(p.degree() for p in polys)
    out = []
    for j in range(max(deg, 0) + 1):
        coefs = [p.coeff_monomial(lam ** j) for p in polys]
        if any(coefs):
            out.append(coefs)
    return out


def span_pencil(F, H, L, M, lam):
    """E(λ) with (a, b, g) E(λ) = 0 ⇔ Φ = a M + b H has Φ L = 0 and Φ (F − λI) = (g − λ b) H:
    E(λ) = [M (F − λI), M L; H F, H L; −H, 0]."""
    n = F.rows
    return sp.Matrix.vstack(sp.Matrix.hstack(M * (F - lam * sp.eye(n)), M * L),
                            sp.Matrix.hstack(H * F, H * L),
                            sp.Matrix.hstack(-H, sp.zeros(H.rows, L.cols)))


def q_rows_possible(F, H, L, M, lam, time: str) -> QRowsVerdict:
    """Decide exactly whether q = rank [M; H] − rank H rows give z = M x for some real stable λ.

    For λ a free symbol, A(λ) is the a-part of the left null space of E(λ)
    (:func:`span_pencil`), a basis of rational vectors v(λ); the span of v(λ) over
    infinitely many λ is the span of the coefficient vectors of its numerator (a Vandermonde
    argument). The space {(0, b, g)} of the null space does not depend on λ, so A(λ) is
    larger than generically exactly where E(λ) drops rank: those real roots are computed
    exactly (:func:`rank_drop_lambdas`) and A(λ) there is added.
    """
    F, H, L, M = (sp.Matrix(X) for X in (F, H, L, M))
    if set().union(*(X.free_symbols for X in (F, H, L, M))):
        return QRowsVerdict(False, False, 0, (), "not analysed: symbolic parameters")
    mrows = M.rows
    rH = exact_rank_value(H) if H.rows else 0
    q = exact_rank_value(sp.Matrix.vstack(M, H)) - rH
    E = span_pencil(F, H, L, M, lam)
    basis, _ = left_null_space(E)
    coef = []
    for v in basis:
        coef += coefficient_rows(polynomial_row(v[:, :mrows]), lam)
    gen = exact_rank_value(sp.Matrix(coef)) if coef else 0
    how = ("q rows span z modulo the outputs with nothing to spare, so each lies in rowspace"
           " [M; H]: Φ = a M + b H with Φ (F − λI) ∈ rowspace H" + (" and Φ L = 0" if L.cols else "")
           + f"; the a of such rows for λ generic span a space of dimension {gen} of {mrows}")
    if gen == mrows:
        return QRowsVerdict(True, True, q, (), f"{how}: {q} rows exist for all but finitely many"
                                           " choices of λ")
    _, drop = rank_drop_lambdas(E, lam, time, "E(λ) = [M (F − λI), M L; H F, H L; −H, 0]",
                                "more rows inside rowspace [M; H]")
    if not drop.analysed:  # pragma: no cover - singular compressions (probability 0)
        return QRowsVerdict(False, False, q, (), f"{how}; the special λ: {drop.evidence}")
    adds, total = [], list(coef)
    for v in drop.stable:
        Ev = E.subs(lam, v)
        extra = [list(b[:, :mrows]) for b in left_null_space(Ev)[0]]
        if extra and exact_rank_value(sp.Matrix(total + extra)) > (
                exact_rank_value(sp.Matrix(total)) if total else 0):
            adds.append(v)
            total += extra
    got = exact_rank_value(sp.Matrix(total)) if total else 0
    txt = (f"{how}; {drop.evidence}" + (f"; at λ = {', '.join(map(str, adds))} the space grows"
                                          if adds else "") + f"; with every real stable λ: {got}")
    if got == mrows:
        return QRowsVerdict(True, True, q, tuple(adds), f"{txt}, so {q} rows exist only with"
                        f" λ = {', '.join(map(str, adds))} among them")
    return QRowsVerdict(True, False, q, (), f"{txt} < {mrows}, so no choice of real stable λ gives"
                    f" {q} rows")


#: P(λ0) drops below its generic rank r when σ_r / σ_1 ≤ this (λ0 an exact root)
_DROP_RTOL = 1e-8


def _drops(P, lam, v, r) -> bool:
    Pn = np.array(P.subs(lam, sp.Float(v.evalf(30), 30)).evalf(30).tolist(), dtype=float)
    s = np.linalg.svd(Pn, compute_uv=False)
    return bool(s.size < r or s[0] == 0 or s[r - 1] <= _DROP_RTOL * s[0])
