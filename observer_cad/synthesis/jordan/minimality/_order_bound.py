"""Lower bounds on the order of *any* reduced model, proven exactly (METHOD §2b).

The Jordan form searches rows Φ_i with Φ_i (F − λ_i I) = J*_i H over real λ_i; when every
λ is admissible the λ can only be searched over finite lists. A lower bound on the
order of every reduced model — whatever its F*: complex, repeated, unstable eigenvalues
included — proves a Jordan design minimal when it reaches the bound.

**Estimation** (virtual sensors, interval observers; z = M x). A model of order k is a
row space V (dim V = k) with V F ⊆ V + rowspace H (the rows of Φ F = F* Φ + J* H) and
M ∈ V + rowspace H (M = H_z Φ + Q H). Write W_j = rowspace [H; H F; …; H Fʲ]. Then

* **subspace bound**: M Fʲ ∈ V + W_j for every j (induction: M Fʲ⁺¹ ∈ V F + W_j F ⊆
  V + W_{j+1}), so k ≥ rank [M; M F; …; M Fʲ; H; …; H Fʲ] − rank [H; …; H Fʲ] for every j;
* **chain bound** (one row M): the chain Φ_1 = M − Q_0 H, Φ_{i+1} = Φ_i F − J_i H stays in
  V, so Φ_1, …, Φ_{k+1} are dependent; at the first dependence Φ_{m+1} = Σ a_i Φ_i with
  m ≤ k, which reads M p(F) ∈ W_m for a monic p of degree m, i.e.
  M Fᵐ ∈ rowspace [M; …; M Fᵐ⁻¹; H; …; H Fᵐ]. So k ≥ the least such m. Conversely that
  chain *is* a model of order m (F* the companion matrix of p), so for a linear model
  without decoupled inputs this bound is the exact least order over all F*.

Decoupling (Φ L = 0), the nonlinear argument substitution and "λ real and stable" only
remove models, so both bounds stay valid lower bounds for them.

**Residual generators** (diagnostic observers). A model of order k with Φ L = 0 whose
residual r = R* y − H* x* responds to every fault (H*(sI − F*)⁻¹ Φ D has no zero column)
has an observable part for (F*, H*) of order k' ≤ k with the same transfer; an observable
single-output pair is similar to the observer canonical form, whose first row x*_1 = R* y
is measured, so its feedback term moves into J* and the model is the identification
canonical form (F* the shift matrix) of :mod:`._canonical` at order k', with Φ D ≠ 0
column by column. Canonical members nest (a member at k' extends to k' + 1 by a zero row),
so the least k' whose null space of (W⁽ᵏ'⁾ L⁽ᵏ'⁾) holds a member seeing every fault bounds
the order of every residual generator that responds to every fault.

With symbolic parameters the ranks are generic: the bound holds where the pivots listed
in ``conditions`` are nonzero.

References: seed 000 §2-3 (the canonical form); seed 002 §2 (the Jordan form); METHOD §2a-b.
"""
from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import sympy as sp

from ....numerics import (exact_rank, gordan_alternative, left_null_echelon, left_null_space,
                          solve_left)
from ._box_cover import box_cover, pencil_cover, quadric_cover
from ...canonical import krylov_blocks, member_to_phi
from sympy.polys.matrices import DomainMatrix
from sympy.polys.polyfuncs import symmetrize

from .._lambda_search import (coefficient_rows, exact_real_roots, family_jump_lambdas,
                              polynomial_row, rank_drop_lambdas, span_pencil, span_rows)
from ...core import is_stable

__all__ = ["OrderBound", "ChainOrder", "estimation_order_bound", "residual_order_bound",
           "nonlinear_jordan_bound", "OneMoreRow", "one_more_row", "one_row_short", "two_more_rows",
           "three_more_rows",
           "family_order",
           "chain_order", "chain_system", "hyperplane_functional", "hyperplane_corners",
           "hyperplane_member", "plane_order", "spread_lambdas", "MAX_SUBSETS"]

#: at most this many subsets of the tried λ are used to pin a member of a family of p
MAX_SUBSETS = 60
#: angles θ of the pencil parameter t = tan θ searched for a member (:func:`three_more_rows`)
_PENCIL_ANGLES = 96
#: float members rebuilt exactly at most, the least stiff first (:func:`three_more_rows`)
_PENCIL_EXACT = 20
#: seeded random λ sets tried (in floating point first) after those subsets
SAMPLES = 3000


@dataclasses.dataclass(frozen=True)
class OrderBound:
    """Every reduced model of the kind has at least ``k`` states (any F*).

    ``evidence``: the ranks it rests on; ``conditions``: the parameter pivots (``Ne(f, 0)``)
    the generic ranks need (empty for numeric models); ``exact``: the bound is the least
    order over all F* itself (not only a bound)."""

    k: int
    evidence: str
    conditions: frozenset = frozenset()
    exact: bool = False


def _rank(blocks) -> tuple:
    rows = [B for B in blocks if B.rows]
    if not rows:
        return 0, frozenset()
    r = exact_rank(sp.Matrix.vstack(*rows))
    return r.rank, r.conditions


def estimation_order_bound(F, H, M, *, decoupled: bool = False, linear: bool = True) -> OrderBound:
    """The lower bound for a model of z = M x (M not in rowspace H): the larger of the
    subspace bound (any number of rows of M) and the chain bound (one row; never below the
    subspace one). ``exact`` when M is one row of a linear model without decoupled inputs."""
    F, H, M = (sp.Matrix(X) for X in (F, H, M))
    n = F.rows
    conds: set = set()
    HF, MF = [H], [M]
    best, best_j, prev = 0, 0, None
    for j in range(n + 1):  # W_j grows at most n times
        if j:
            HF.append(HF[-1] * F)
            MF.append(MF[-1] * F)
        rw, cw = _rank(HF)
        rmw, cmw = _rank(MF + HF)
        conds |= cw | cmw
        if rmw - rw > best:
            best, best_j = rmw - rw, j
        if (rw, rmw) == prev:  # both spaces stopped growing: so do all later ones
            break
        prev = (rw, rmw)
    ev = (f"subspace bound: rank [M, …, M F^{best_j}; H, …, H F^{best_j}] − rank [H, …,"
          f" H F^{best_j}] = {best}")
    exact = False
    if M.rows == 1:
        m = _chain_order(F, H, M, conds)
        ev += (f"; chain bound: M F^{m} ∈ rowspace [M, …, M F^{m - 1}; H, …, H F^{m}] first"
               f" at m = {m} (M p(F) ∈ W_m for a monic p of degree {m})")
        best, exact = max(best, m), not decoupled and linear
    return OrderBound(best, ev, frozenset(conds), exact)


#: nonlinear terms beyond which :func:`nonlinear_jordan_bound` is not tried (2^t subsets)
NONLINEAR_SUBSETS_MAX_TERMS = 4


def nonlinear_jordan_bound(F, H, L, M, C, A_rows, k: int, lam, time: str, tries,
                           defaults=None) -> OrderBound | None:
    """A lower bound on the rows of a Jordan model of z = M x in a model with nonlinear
    terms φ_j(A_j x) entering through the columns C_j (numeric F, H, L, M, C, A).

    Argument substitution: a term the rows see (Φ C_j ≠ 0) needs A_j ∈ rowspace [Φ; H].
    So a model whose rows see the terms S and no other is a linear Jordan model of
    z_S = [M; A_j (j ∈ S)] decoupled from L_S = [L, C_j (j ∉ S)] (seeing the terms of S is
    relaxed away, which only adds models). For each S the bound is the larger of
    rank [M_S; H] − rank H (+ 1 when that many rows are impossible for every real stable λ,
    :func:`span_rows`) and 1 + the largest order m < k whose joint chain polynomials with
    r(s) L_S = 0 have no member with m distinct real stable roots (members nest, so the
    orders ruled out are 1 … m). The bound is the least over all S; None when some S
    gives less than k (nothing proven), when there are more than
    :data:`NONLINEAR_SUBSETS_MAX_TERMS` terms, or when parameters are symbolic.
    """
    t = len(A_rows)
    if not t or t > NONLINEAR_SUBSETS_MAX_TERMS:
        return None
    if set().union(*(X.free_symbols for X in (F, H, L, M, C) + tuple(A_rows))):
        return None
    rH = exact_rank(H).rank if H.rows else 0
    least, parts = None, []
    for size in range(t + 1):
        for S in itertools.combinations(range(t), size):
            MS = sp.Matrix.vstack(M, *[A_rows[j] for j in S])
            LS = sp.Matrix.hstack(L, *[C[:, j] for j in range(t) if j not in S])
            q = exact_rank(sp.Matrix.vstack(MS, H)).rank - rH
            bound, why = q, f"q = {q}"
            if q < k:
                sr = span_rows(F, H, LS, MS, lam, time)
                if sr.analysed and not sr.possible:
                    bound, why = q + 1, f"{q} rows impossible for every λ"
            if bound < k:
                for m in range(1, k):
                    c = chain_order(F, H, MS, m, lam, time, tries, LS if LS.cols else None,
                                    defaults)
                    if not c.impossible:
                        break
                    if m + 1 > bound:
                        bound, why = m + 1, f"chain orders ≤ {m} ruled out"
            name = "{" + ", ".join(str(j + 1) for j in S) + "}"
            parts.append(f"S = {name}: ≥ {bound} ({why})")
            if bound < k:  # no proof at k (the least over every S is below k)
                return None
            least = bound if least is None else min(least, bound)
    return OrderBound(least, _nonlinear_evidence(parts))


@dataclasses.dataclass(frozen=True)
class OneMoreRow:
    """Can k rows give z = M x — k = q + 1 (:func:`one_more_row`), k = q + 2
    (:func:`two_more_rows`) or k = n − rank H − 1 (:func:`one_row_short`),
    q = rank [M; H] − rank H?

    ``analysed``: False when the case is outside what is decided (``evidence`` says why);
    ``possible``: some w gives k distinct real stable λ (a necessary condition; a design
    still has to be built and certified); ``lambdas``: such λ when found (exact);
    ``evidence``: one line; ``k``: the number of rows asked about (0 when not analysed
    before it was known); ``rows``: when known, one row Φ_i (1 × n, exact) of each λ of
    ``lambdas`` whose images fit together (the design still checks and certifies them)."""

    analysed: bool
    possible: bool
    lambdas: tuple
    evidence: str
    k: int = 0
    rows: tuple = ()


def one_more_row(F, H, L, M, lam, time: str) -> OneMoreRow:
    """Decide exactly whether a Jordan model of z = M x with q + 1 rows can exist, in the
    case where the rows' images modulo rowspace [M; H] form a polynomial family of
    hyperplanes (METHOD §2b, "one more row").

    Let Q span the right null space of [M; H] (c columns) and V(λ) the rows Φ with
    Φ L = 0 and Φ (F − λI) ∈ rowspace H. Preconditions, each checked exactly (M is first
    reduced to q rows independent modulo H, which gives the same models): no row of any
    real stable λ lies in rowspace [M; H] outside rowspace H (E(λ) of :func:`span_rows`
    has no a-part, generically nor at its drops); V(λ) has the same dimension f at every
    real stable λ (no family jump); f = c − 1.
    Then q + 1 rows span z and one more direction modulo H, so their images Φ_i Q all lie
    on one line w ≠ 0; none is 0 and no two share a λ (either would put a row of V(λ)
    inside rowspace [M; H]). So w ∈ W(λ_i) = V(λ_i) Q at q + 1 distinct real stable λ_i,
    and W(λ) ⊆ ν(λ)^⊥ with ν(λ) the primitive vector of signed maximal minors of a
    polynomial basis of W(λ): p_w(λ) = ν(λ)·w has q + 1 distinct real stable roots. The
    p_w form a linear family of polynomials of degree ≤ D = deg ν (of dimension c when
    no w has p_w ≡ 0). D < q + 1: impossible. D = q + 1: every root must be real,
    distinct and stable, and the monic members are an affine family of dimension c − 1,
    decided as the chain polynomials are (:func:`family_order`). For q = 2, f = 2, c = 4
    (the images are lines of P³) the three lines must meet pairwise, decided through each
    line's partners (:func:`_line_rows`). Otherwise not analysed."""
    return _hyperplane_rows(F, H, L, M, lam, time, "more")


def one_row_short(F, H, L, M, lam, time: str) -> OneMoreRow:
    """Decide exactly whether a Jordan model of z = M x with n − rank H − 1 rows (one
    fewer than a basis modulo the outputs) can exist when each λ has one row (f = 1):
    the dual of :func:`one_more_row` (METHOD §2b, "one row short").

    Same preconditions (no row inside rowspace [M; H] outside rowspace H, no family jump).
    k = n − rank H − 1 = q + c − 1 independent rows span z modulo H and c − 1 more
    directions, so their images Φ_i Q span a hyperplane w^⊥ of the c dimensions modulo
    rowspace [M; H]. With f = 1 each λ has one row, Φ = v(λ) up to scale, and its image
    γ(λ) = v(λ) Q is never 0 (precondition), so w·γ(λ_i) = 0 at k distinct real stable
    λ_i. With γ made primitive, p_w(λ) = γ(λ)·w is a linear family of polynomials of
    degree ≤ D = deg γ, decided as in :func:`one_more_row`. Conversely k such roots give
    k rows with images in w^⊥; when they are independent modulo H they span z (the design
    checks and certifies that)."""
    return _hyperplane_rows(F, H, L, M, lam, time, "short")


def two_more_rows(F, H, L, M, lam, time: str) -> OneMoreRow:
    """Decide exactly whether a Jordan model of z = M x with q + 2 rows can exist when the
    rows of each λ have a 2-dimensional image W(λ) modulo rowspace [M; H] in c = 4
    dimensions — 2-planes of R⁴, lines of P³ (METHOD §2b, "two more rows") — or in c = 5
    dimensions (:func:`_space_rows`: the plane U then lies in one of finitely many
    3-spaces meeting every W(λ)), or in c = 6 (:func:`_six_rows`: U is the one plane that
    a curve of 4-vectors containing every W(λ) fixes, when that curve is unique).

    Same preconditions as :func:`one_more_row` (M reduced to q rows; no row of a real
    stable λ inside rowspace [M; H] outside rowspace H; no family jump), and fewer rows
    ruled out by the caller. Then the q + 2 rows of a model are independent modulo H and
    their images span a plane U; r rows at one λ_i put an r-dimensional U ∩ W(λ_i) there.
    With π(λ) the primitive vector of 2 × 2 minors of a polynomial basis of W(λ) (the
    Plücker vector of W(λ) at every λ), U meets W(λ) iff P_U(λ) = p_U ∧ π(λ) = 0, linear in
    U's Plücker vector p_U, and r rows at λ_i make λ_i a root of order ≥ r (r rows of a
    basis at λ_i lie in U). So P_U, of degree ≤ D = deg π, has q + 2 real stable roots
    counted with multiplicity, unless P_U ≡ 0. With the linear map T: p ↦ p ∧ π(λ):

    * D < q + 2: impossible when no plane has P_U ≡ 0 (ker T = 0, or one-dimensional and
      spanned by a κ with κ ∧ κ ≠ 0: not a plane);
    * D = q + 2 and T onto the polynomials of degree ≤ D: P_U = s · Π (λ − λ_i) with a
      its coefficient vector, and p_U = s R a + t κ (R a right inverse of T) must be
      decomposable, (s R a + t κ) ∧ (s R a + t κ) = 0 with s ≠ 0: for ker T = span κ
      (κ ∧ κ ≠ 0) a real (s, t) exists iff Δ(a) = (R a ∧ κ)² − (R a ∧ R a)(κ ∧ κ) ≥ 0; for
      ker T = 0, iff R a ∧ R a = 0. Both are quadratic forms in a; the roots' box is
      covered by cells on which the form's Bernstein coefficients exclude it
      (:func:`quadric_cover`, exact).

    Anything else is not analysed; a root set where the condition holds is reported (the
    design search then has to find the rows; for c = 5 the rows are returned too)."""
    return _hyperplane_rows(F, H, L, M, lam, time, "plane")


def three_more_rows(F, H, L, M, lam, time: str) -> OneMoreRow:
    """Decide exactly whether a Jordan model of z = M x with q + 3 rows can exist when the
    rows of each λ have a 2-dimensional image W(λ) modulo rowspace [M; H] in c = 6
    dimensions (METHOD §2b, "Planes of six dimensions"): U, the 3-space of the rows'
    images, lies in a 4-space X(t) = ker ℓ0(t) ∩ ker ℓ1(t) for a pencil ℓ0 + λ ℓ1 of forms
    annihilating every W(λ) (a linear space of pencils, computed exactly), and the λ are the
    roots of u·γ(λ, t), γ spanning X(t) ∩ W(λ). A member with q + 3 real stable roots is
    searched (and rebuilt exactly, with the row of each λ); otherwise the family, which
    moves with t, is excluded by :func:`pencil_cover`. Same preconditions as
    :func:`two_more_rows`; a model of fewer rows extends to q + 3 by rows of further λ, so
    "impossible" rules out every order up to q + 3."""
    return _hyperplane_rows(F, H, L, M, lam, time, "solid")


def _hyperplane_rows(F, H, L, M, lam, time: str, kind: str) -> OneMoreRow:
    F, H, L, M = (sp.Matrix(X) for X in (F, H, L, M))
    if set().union(*(X.free_symbols for X in (F, H, L, M))):
        return OneMoreRow(False, False, (), "not analysed: symbolic parameters")
    n = F.rows
    short = kind == "short"
    what = {"short": "one row short", "more": "one more row", "plane": "two more rows",
            "solid": "three more rows"}[kind]

    def no(why, k=0):
        return OneMoreRow(False, False, (), f"{what} not analysed: {why}", k)

    rH = exact_rank(H).rank if H.rows else 0
    rMH = exact_rank(sp.Matrix.vstack(M, H)).rank
    q, c = rMH - rH, n - rMH
    k = q + c - 1 if short else {"more": q + 1, "plane": q + 2, "solid": q + 3}[kind]
    if q != M.rows:  # the same models: z's rows independent modulo H
        keep, r_have = [], rH
        for i in range(M.rows):
            r_trial = exact_rank(sp.Matrix.vstack(H, *keep, M[i, :])).rank
            if r_trial > r_have:
                keep.append(M[i, :])
                r_have = r_trial
        M = sp.Matrix.vstack(*keep)
    if c < 2:
        return no(f"rowspace [M; H] has codimension {c}", k)
    L0 = (sp.Matrix.vstack(*left_null_space(L)[0]) if L.cols else sp.eye(n))
    if L0.rows == 0:
        return no("no row has Φ L = 0", k)
    rows = []
    for v in left_null_space(sp.Matrix.vstack(L0 * (F - lam * sp.eye(n)), H))[0]:
        phi = sp.Matrix([polynomial_row(v[:, :L0.rows] * L0)])
        if not phi.is_zero_matrix:
            rows.append(phi)
    f = len(rows)
    if short and f != 1:
        return no(f"each λ has {f} rows, not one", k)
    E = span_pencil(F, H, L, M, lam)
    if any(not v[:, :M.rows].is_zero_matrix for v in left_null_space(E)[0]):
        return no("rows inside rowspace [M; H] exist for λ generic", k)
    lines = kind == "more" and (f, c, q) == (2, 4, 2)  # three rows through lines of P³
    if kind == "more" and f != c - 1 and not lines:  # (before the exact drops and jumps)
        return no(f"the images of the rows modulo rowspace [M; H] have dimension {f}, not"
                  f" {c - 1} (a hyperplane of the {c} dimensions)", k)
    if kind == "plane" and (f, c) not in ((2, 4), (2, 5), (2, 6)):
        return no(f"the images of the rows modulo rowspace [M; H] have dimension {f} of {c},"
                  " not planes of 4, 5 or 6 dimensions", k)
    if kind == "solid" and (f, c) != (2, 6):
        return no(f"the images of the rows modulo rowspace [M; H] have dimension {f} of {c},"
                  " not planes of 6 dimensions", k)
    _, drop = rank_drop_lambdas(E, lam, time, "E(λ)", "rows inside rowspace [M; H]")
    if not drop.analysed:  # pragma: no cover - singular compressions (probability 0)
        return no(drop.evidence, k)
    for v in drop.stable:
        if any(not b[:, :M.rows].is_zero_matrix for b in left_null_space(E.subs(lam, v))[0]):
            return no(f"at λ = {v} a row lies inside rowspace [M; H]", k)
    jumps = family_jump_lambdas(F, H, L0, lam, time)
    if not jumps.analysed or jumps.stable:
        return no("the family of rows grows at λ = " + ", ".join(map(str, jumps.stable))
                  if jumps.stable else jumps.evidence, k)
    Q = sp.Matrix.hstack(*sp.Matrix.vstack(M, H).nullspace())
    G = (sp.Matrix.vstack(*rows) * Q).applyfunc(sp.expand) if rows else sp.zeros(0, c)
    if kind == "solid" or (kind == "plane" and c == 6):
        return _six_rows(G, k, lam, time, no, rows, kind)
    if kind == "plane":
        if c == 4:
            return _plane_rows(G, k, lam, time, no)
        return _space_rows(G, k, lam, time, no, rows)
    if lines:
        return _line_rows(G, k, lam, time, no)
    if short:
        # fewer rows nest: a model of k' < k rows takes a row of a further λ while the rows
        # of all λ (the coefficient rows of v(λ)) and H span more than n − 2 dimensions
        coeffs = sp.Matrix(coefficient_rows(rows[0], lam))
        if exact_rank(sp.Matrix.vstack(coeffs, H)).rank < n - 1:
            return no("the rows of all λ and H span fewer than n − 1 dimensions (models of"
                      " fewer rows need not extend to k)", k)
        nu = list(G)
        space = "modulo rowspace [M; H] the row of λ has the image γ(λ)"
        need = f"{k} rows need a hyperplane w^⊥ with γ(λ)·w = 0 at {k} distinct real stable λ"
    else:
        nu = []
        for j in range(c):
            minor = G[:, [i for i in range(c) if i != j]]
            dm = DomainMatrix.from_Matrix(minor).convert_to(sp.QQ[lam])
            nu.append((-1) ** j * sp.QQ[lam].to_sympy(dm.det()))
        space = "modulo rowspace [M; H] the rows of λ span the hyperplane ν(λ)^⊥, ν(λ)"
        need = f"q + 1 = {k} rows need a w with ν(λ)·w = 0 at {k} distinct real stable λ"
    g = sp.gcd_list(nu)
    if g == 0:
        return no("the images of the rows are dependent for λ generic", k)
    nu = [sp.cancel(e / g) for e in nu]
    polys = [sp.Poly(e, lam) for e in nu]
    D = max(p.degree() for p in polys)
    coef = sp.Matrix([[p.coeff_monomial(lam ** i) for i in range(D + 1)] for p in polys])
    name = "γ" if short else "ν"
    fam = f"{space} = ({', '.join(str(sp.factor(e)) for e in nu)}); {need}"
    if exact_rank(coef).rank < c:
        return no(f"{fam}, but some w ≠ 0 has {name}(λ)·w ≡ 0", k)
    if D < k:
        return OneMoreRow(True, False, (), f"{fam}: {name}(λ)·w has degree ≤ {D} < {k},"
                          f" so no choice of real stable λ gives {k} rows", k)
    if D > k:
        return no(f"{fam}: {name}(λ)·w has degree {D} > {k} (at least {k} of its roots"
                  " stable: not decided)", k)
    m = D
    a0, dirs = _monic_family(polys, m, lam)
    order = family_order(m, a0, dirs, lam, time)
    if order.lambdas:
        return OneMoreRow(True, True, tuple(order.lambdas), f"{fam}: {order.evidence}", k)
    if order.verdict == "free" and order.dim >= m:  # every monic p of degree m
        return OneMoreRow(True, True, (), f"{fam}: {order.evidence}", k)
    if not order.decided:
        return no(f"{fam}: {order.evidence}", k)
    return OneMoreRow(True, False, (), f"{fam}: {order.evidence}, so no choice of real"
                      f" stable λ gives {k} rows", k)


def _plucker(G, lam):
    """(π, Ω): the primitive Plücker vector π(λ) (2 × 2 minors, over the pairs of
    {0, 1, 2, 3}) of the plane spanned by the two rows of ``G`` (polynomials in λ), or None
    when they are dependent for λ generic; and Ω with p ∧ p' = pᵀ Ω p'
    (Σ_S ε_S p_{S^c} p'_S, ε_S the sign of the permutation S S^c)."""
    pairs = list(itertools.combinations(range(4), 2))
    comp = {S: tuple(sorted(set(range(4)) - set(S))) for S in pairs}
    Om = sp.zeros(6, 6)
    for i, S in enumerate(pairs):
        Om[pairs.index(comp[S]), i] = _perm_sign(S + comp[S])
    return _pair_minors(G, lam), Om


def _pair_minors(G, lam):
    """The primitive vector of the 2 × 2 minors of the two rows of ``G`` (polynomials in
    λ), over the pairs of columns in lexicographic order, or None when the rows are
    dependent for λ generic."""
    minors = []
    for S in itertools.combinations(range(G.cols), 2):
        dm = DomainMatrix.from_Matrix(G[:, list(S)]).convert_to(sp.QQ[lam])
        minors.append(sp.QQ[lam].to_sympy(dm.det()))
    g = sp.gcd_list(minors)
    return None if g == 0 else [sp.cancel(e / g) for e in minors]


def _perm_sign(seq) -> int:
    """The sign of the permutation ``seq`` of distinct integers."""
    return (-1) ** sum(1 for i in range(len(seq)) for j in range(i + 1, len(seq))
                       if seq[i] > seq[j])


def _line_rows(G, k, lam, time, no) -> OneMoreRow:
    """:func:`one_more_row` for q = 2 when the rows of each λ have a 2-dimensional image
    W(λ) modulo rowspace [M; H] in c = 4 dimensions (lines ℓ(λ) of P³), its preconditions
    holding: three rows need one w ≠ 0 in W(λ_1), W(λ_2), W(λ_3) at distinct real stable
    λ_i, so the three lines meet pairwise. Two lines meet iff π(λ_i) ∧ π(λ_j) = 0, and
    that polynomial is divisible by (λ_i − λ_j)² (π ∧ π = 0 and π ∧ π' = ½ (π ∧ π)' = 0):
    g(λ_i, λ_j) = π(λ_i) ∧ π(λ_j) / (λ_i − λ_j)², symmetric. g of degree 2 in each
    variable: decided through the partners (:func:`_partner_triples`). Otherwise a triple
    needs g(λ_1, λ_3) = g(λ_2, λ_3) = 0, so s(λ_1, λ_2) = Res_x(g(λ_1, x), g(λ_2, x)) = 0
    (which vanishes on λ_1 = λ_2: divided out), and g(λ_1, λ_2) = 0, so R(λ_1) =
    Res_y(g(λ_1, y), s(λ_1, y)) = 0: a necessary condition on each λ of the triple. R with
    no real stable root (an exact Sturm count) proves three rows impossible; otherwise
    not decided (R vanishes at torsal λ too, where g(λ, λ) = 0)."""
    pi, Om = _plucker(G, lam)
    if pi is None:
        return no("the images of the rows are dependent for λ generic", k)
    x, y = sp.symbols("x y")
    fam = ("modulo rowspace [M; H] the rows of λ span planes W(λ) of 4 dimensions (lines of"
           f" P³), Plücker vector π(λ) = ({', '.join(str(sp.factor(e)) for e in pi)}); {k} rows"
           f" need one w in W(λ_i) at {k} distinct real stable λ_i, so the lines meet pairwise")
    P1 = sp.Matrix(pi)
    P2 = sp.Matrix([e.subs(lam, x) for e in pi])
    meet = sp.Poly(sp.expand((P1.T * Om * P2)[0]), lam, x)
    g, r = sp.div(meet, sp.Poly((lam - x) ** 2, lam, x))
    if not r.is_zero:  # pragma: no cover - excluded by the identity above
        return no(f"{fam}, but π(λ) ∧ π(x) is not divisible by (λ − x)²", k)
    if g.is_zero:
        return no(f"{fam}, and every two of the lines meet", k)
    if g.total_degree() == 0:
        return OneMoreRow(True, False, (), f"{fam}: π(λ) ∧ π(x) = {g.as_expr()} · (λ − x)²,"
                          " so no two lines meet and no choice of real stable λ gives"
                          f" {k} rows", k)
    if g.degree(x) == 2:  # each line meets at most two others: the partners, exactly
        verdict, text, lams = _partner_triples(g, lam, x, time)
        if verdict == "impossible":
            return OneMoreRow(True, False, (), f"{fam}: {text}, so no choice of real stable"
                              f" λ gives {k} rows", k)
        if verdict == "possible":
            return OneMoreRow(True, True, lams, f"{fam}: {text}", k)
        return no(f"{fam}: {text}", k)
    g_ly = g.as_expr().subs(x, y)
    g_lx, g_yx = g.as_expr(), g.as_expr().subs(lam, y)
    s_ly = sp.Poly(sp.resultant(g_lx, g_yx, x), lam, y)
    while not s_ly.is_zero:  # divide out λ = y (where the two polynomials in x coincide)
        qt, rm = sp.div(s_ly, sp.Poly(lam - y, lam, y))
        if not rm.is_zero:
            break
        s_ly = qt
    if s_ly.is_zero:
        return no(f"{fam}; the lines meeting two of them are never finitely many", k)
    R = sp.Poly(sp.resultant(g_ly, s_ly.as_expr(), y), lam)
    if R.is_zero:
        return no(f"{fam}; the elimination of the other two λ leaves 0", k)
    stable = _stable_root_count(R, time)
    elim = (f"g(λ, x) = π(λ) ∧ π(x) / (λ − x)² = {sp.factor(g.as_expr())}; eliminating the"
            f" other two λ of a triple (resultants) leaves R(λ) of degree {R.degree()}")
    if stable == 0:
        return OneMoreRow(True, False, (), f"{fam}: {elim} with no real stable root (Sturm),"
                          f" so no choice of real stable λ gives {k} rows", k)
    return no(f"{fam}: {elim}, with {stable} real stable root(s): not decided", k)


def _partner_triples(g, lam, x, time):
    """Three distinct real stable λ whose lines meet pairwise, for g(λ, x) of degree 2 in
    each variable (π of degree 4): the partners of λ_1 — the λ whose lines meet ℓ(λ_1) —
    are the roots of g(λ_1, x) = a x² + b x + c, so a triple is λ_1 with two distinct real
    stable partners, neither λ_1, that meet each other: h(λ_1) = a² g(λ_2, λ_3) = 0, with
    g(λ_2, λ_3) written in λ_2 + λ_3 = −b/a and λ_2 λ_3 = c/a (h is a quadratic form in
    (a, b, c), so it vanishes also where g(λ_1, ·) ≡ 0). The conditions on λ_1: a ≠ 0,
    b² − 4ac > 0, g(λ_1, λ_1) ≠ 0, both partners stable (signs of polynomials in λ_1).

    h ≢ 0: every real stable root α of h is checked exactly (signs at α by interval
    arithmetic on its isolating interval, refined until certain). h ≡ 0 (a Poncelet
    porism: the symmetric (2, 2) correspondence closes a triangle from every point): a
    triple exists iff the conditions hold at some real stable λ_1, decided by testing one
    rational point between each two consecutive real roots of the condition polynomials.

    Returns (verdict, evidence, λ): verdict "impossible", "possible" (λ: a triple, exact)
    or "undecided"."""
    coeffs = sp.Poly(g.as_expr(), x).all_coeffs()
    a, b, c = (sp.expand(e) for e in coeffs)
    diag = sp.expand(g.as_expr().subs(x, lam))
    # (what fails, a polynomial that must be > 0 at λ_1)
    if time == "continuous":  # both partners < 0: a b > 0 and a c > 0
        stab = [("a b ≤ 0", a * b), ("a c ≤ 0", a * c)]
    else:  # both in (−1, 1): a (a + b + c) > 0, a (a − b + c) > 0, 4a² − b² > 0
        stab = [("a (a + b + c) ≤ 0", a * (a + b + c)), ("a (a − b + c) ≤ 0", a * (a - b + c)),
                ("4a² − b² ≤ 0", 4 * a ** 2 - b ** 2)]
    checks = [("a = 0", a ** 2), ("b² − 4ac ≤ 0", b ** 2 - 4 * a * c),
              ("g(λ, λ) = 0", diag ** 2)] + stab
    h = _triangle_polynomial(g, lam, x, a, b, c)
    where = f"g(λ, x) = {sp.factor(g.as_expr())}; the partners of λ_1 are the roots of g(λ_1, x)"
    if h is None:
        return "undecided", f"{where}: not analysed (not symmetric)", ()
    if h.is_zero:
        return _porism_triple(g, lam, x, checks, time, where)
    roots, fails = 0, []
    abc = [sp.Poly(e, lam) for e in (a, b, c)]
    conds = [(name, sp.Poly(e, lam)) for name, e in checks]
    for f, _m in h.factor_list()[1]:
        if f.degree() < 1:
            continue
        for (lo, hi), _ in f.intervals():
            lo, hi = _stable_interval(f, sp.Rational(lo), sp.Rational(hi), time)
            if lo is None:
                continue
            roots += 1
            if all(_sign_at(q, f, lo, hi) == 0 for q in abc):
                return "undecided", (f"{where}; at a root λ ≈ {float((lo + hi) / 2):.4g} of h"
                                     " every line meets ℓ(λ): not decided"), ()
            bad = next((name for name, q in conds if _sign_at(q, f, lo, hi) <= 0), None)
            if bad is None:  # pragma: no cover - h ≢ 0 leaves only degenerate roots
                return "undecided", (f"{where}; at λ ≈ {float((lo + hi) / 2):.4g} (a root of"
                                     " h) three lines of real stable λ meet pairwise: not"
                                     " ruled out"), ()
            fails.append(bad)
    return "impossible", (f"{where}, and they meet iff h(λ_1) = a² g(λ_2, λ_3) = 0, h of"
                          f" degree {h.degree()} with {roots} real stable root(s)"
                          + (f", each failing a condition exactly ({', '.join(fails)})"
                             if fails else "")), ()


def _triangle_polynomial(g, lam, x, a, b, c):
    """h(λ) = a² g(λ_2, λ_3) for λ_2, λ_3 the roots of g(λ, x) = a x² + b x + c (through
    λ_2 + λ_3 = −b/a, λ_2 λ_3 = c/a), a polynomial; None when g is not symmetric."""
    u, v, s1, s2 = sp.symbols("u v s1 s2")
    sym, rest, defs = symmetrize(sp.expand(g.as_expr().subs({lam: u, x: v}, simultaneous=True)),
                                 [u, v], formal=True)
    if rest != 0:  # pragma: no cover - π(λ) ∧ π(x) is symmetric
        return None
    sym = sym.subs({d[0]: {u + v: s1, u * v: s2}[d[1]] for d in defs})
    h = sp.cancel(sp.expand(a ** 2 * sym.subs({s1: -b / a, s2: c / a}, simultaneous=True)))
    if sp.fraction(h)[1].has(lam):  # pragma: no cover - a quadratic form in (a, b, c)
        return None
    return sp.Poly(h, lam)


def _porism_triple(g, lam, x, checks, time, where):
    """h ≡ 0: a real stable λ_1 meeting every condition, or none (one rational point in
    each open interval between consecutive real roots of the conditions' polynomials and
    the stability boundary: their signs are constant there, and the set is open)."""
    polys = [sp.Poly(e, lam) for _, e in checks]
    boundary = sp.Poly(sp.Mul(*(lam - e for e in _stability_edges(time))), lam)
    points = _cell_points([boundary] + [q for q in polys if not q.is_zero])
    for t in points:
        if not is_stable(t, time):
            continue
        if all(q(t) > 0 for q in polys):
            partners = sp.Poly(g.as_expr().subs(lam, t), x).all_roots()
            lams = (t, *partners)
            return "possible", (f"{where}; h(λ_1) = a² g(λ_2, λ_3) vanishes identically (every"
                                " λ_1 starts a triangle of meeting lines), and at λ_1 = "
                                f"{t} both partners are real, distinct and stable: λ ="
                                f" ({', '.join(map(str, lams))}) (three lines meeting pairwise:"
                                " concurrent or coplanar)"), lams
    return "impossible", (f"{where}; h(λ_1) = a² g(λ_2, λ_3) vanishes identically, but no real"
                          " stable λ_1 has two distinct real stable partners (one point"
                          f" tested in each of the {len(points)} intervals cut by the real"
                          " roots of the conditions)"), ()


def _stability_edges(time: str) -> tuple:
    """The boundary of the stability region on the real line: 0 (continuous), ±1 (discrete)."""
    return (0,) if time == "continuous" else (1, -1)


def _stable_interval(f, lo, hi, time):
    """The isolating interval [lo, hi] of a real root of f refined until it lies inside
    the open stability region or outside it: (lo, hi), or (None, None) when the root is
    not stable (the boundary 0 or ±1 itself is not)."""
    bounds = _stability_edges(time)
    for _ in range(200):
        if lo == hi:
            break
        if not any(lo <= t <= hi for t in bounds):
            break
        lo, hi = (sp.Rational(z) for z in f.refine_root(lo, hi, eps=(hi - lo) / 4))
    mid = (lo + hi) / 2
    if any(lo <= t <= hi for t in bounds) and lo != hi:  # pragma: no cover - refined away
        return None, None
    return (lo, hi) if is_stable(mid, time) else (None, None)


def _sign_at(q, f, lo, hi) -> int:
    """The sign of q(α), α the root of the irreducible f isolated in [lo, hi]: 0 when f
    divides q, else by interval evaluation of q over the interval, refined until the sign
    is certain."""
    if q.is_zero:
        return 0
    if sp.rem(q, f).is_zero:
        return 0
    for _ in range(400):
        qlo, qhi = _interval_value(q, lo, hi)
        if qlo > 0:
            return 1
        if qhi < 0:
            return -1
        lo, hi = (sp.Rational(z) for z in f.refine_root(lo, hi, eps=(hi - lo) / 4))
    raise ArithmeticError("the sign of a polynomial at an algebraic number was not"
                          " settled")  # pragma: no cover - q(α) ≠ 0 settles it


def _interval_value(q, lo, hi) -> tuple:
    """[min, max] enclosure of q over [lo, hi] by interval Horner (rationals)."""
    rlo = rhi = sp.Integer(0)
    for co in q.all_coeffs():
        prods = (rlo * lo, rlo * hi, rhi * lo, rhi * hi)
        rlo, rhi = min(prods) + co, max(prods) + co
    return rlo, rhi


def _stable_root_count(R, time) -> int:
    """The number of distinct real roots of R in the open stability region (λ < 0, or
    −1 < λ < 1), exactly (Sturm sequences)."""
    R = R.sqf_part()
    if R.degree() <= 0:
        return 0
    if time == "continuous":
        return R.count_roots(-sp.oo, 0) - (R(0) == 0)
    return R.count_roots(-1, 1) - (R(-1) == 0) - (R(1) == 0)


def _plane_rows(G, k, lam, time, no) -> OneMoreRow:
    """:func:`two_more_rows` once its preconditions hold: ``G`` (2 × 4) the images of a
    polynomial basis of the rows of λ modulo rowspace [M; H]."""
    pi, Om = _plucker(G, lam)
    if pi is None:
        return no("the images of the rows are dependent for λ generic", k)
    D = max(sp.degree(e, lam) for e in pi)
    C = sp.Matrix([[sp.Poly(e, lam).coeff_monomial(lam ** j) for j in range(D + 1)] for e in pi])
    T = (Om * C).T  # coefficients of p ∧ π(λ), λ⁰ … λᴰ, as a map of p
    kernel = T.nullspace()
    fam = ("modulo rowspace [M; H] the rows of λ span planes W(λ) of 4 dimensions, Plücker"
           f" vector π(λ) = ({', '.join(str(sp.factor(e)) for e in pi)}); {k} rows need a plane"
           f" U with p_U ∧ π(λ) = 0 at {k} real stable λ (counted with multiplicity)")

    def plane(v):  # a decomposable vector (the Plücker vector of a plane)
        return (v.T * Om * v)[0] == 0

    if len(kernel) > 1 or (kernel and plane(kernel[0])):
        return no(f"{fam}, but a plane U may have p_U ∧ π(λ) ≡ 0", k)
    if D < k:
        return OneMoreRow(True, False, (), f"{fam}: p_U ∧ π(λ) has degree ≤ {D} < {k} and"
                          f" vanishes identically for no plane, so no choice of real stable λ"
                          f" gives {k} rows", k)
    if D > k:
        return no(f"{fam}: p_U ∧ π(λ) has degree {D} > {k} (at least {k} of its roots stable:"
                  " not decided)", k)
    if T.rank() != D + 1:
        return no(f"{fam}: the p ∧ π(λ) are not every polynomial of degree ≤ {D}", k)
    R = T.T * (T * T.T).inv()  # T R = I
    if kernel:
        kap = kernel[0]
        K = (kap.T * Om * kap)[0]
        w = R.T * Om * kap
        form = w * w.T - K * R.T * Om * R  # Δ(a) = (R a ∧ κ)² − (R a ∧ R a)(κ ∧ κ)
        need = "Δ(a) = (R a ∧ κ)² − (R a ∧ R a)(κ ∧ κ) ≥ 0 for its coefficients a"
    else:
        form = R.T * Om * R
        need = "R a ∧ R a = 0 for its coefficients a"
    cover = quadric_cover(k, form, time, equality=not kernel)
    if cover.proven:
        return OneMoreRow(True, False, (), f"{fam}; a plane exists iff {need}: {cover.evidence},"
                          f" so no choice of real stable λ gives {k} rows", k)
    if cover.found is not None:
        lams = [(x + 1) / (x - 1) if time == "continuous" else x for x in cover.found]
        return no(f"{fam}; a plane exists iff {need}, which holds at λ ≈"
                  f" ({', '.join(f'{v:.4g}' for v in lams)}): {k} rows are not ruled out", k)
    return no(f"{fam}; a plane exists iff {need}: {cover.evidence}", k)


def _space_rows(G, k, lam, time, no, basis_rows) -> OneMoreRow:
    """:func:`two_more_rows` for planes W(λ) of c = 5 dimensions (lines of P⁴) once its
    preconditions hold: ``G`` (2 × 5) the images of a polynomial basis of the rows of λ
    modulo rowspace [M; H] (METHOD §2b, "two more rows in five dimensions").

    With π(λ) the primitive Plücker vector of W(λ) (degree D), P_U(λ) = p_U ∧ π(λ), a
    vector of Λ⁴R⁵ ≅ (R⁵)*, is the linear form vanishing on U + W(λ); it vanishes at the k
    real stable λ_i of a model (with multiplicity), so P_U = p(λ) ℓ(λ) with deg ℓ ≤ D − k,
    and ℓ(λ) annihilates U and W(λ) for every λ. Requirements (else not analysed): no
    plane has P_U ≡ 0 (T: p ↦ p ∧ π(λ) injective) and the W(λ) span R⁵ (so ℓ is not a
    fixed form up to scale). Then D < k or D = k: impossible; D = k + 1: ℓ = ℓ0 + λ ℓ1
    with ℓ0, ℓ1 independent, and X = {ℓ0, ℓ1}^⊥ is a 3-space containing U that meets
    every W(λ) (ℓ1 cuts W(λ) in a line, which ℓ(λ) − λ ℓ1 also annihilates). Such X
    satisfy ⟨p_X, π(λ)⟩ ≡ 0, linear in p_X ∈ Λ³R⁵, and lie on G(3, 5): finitely many,
    found exactly (a lex Gröbner basis in shape position per chart; each irreducible
    factor of its last polynomial a conjugate set of X, over Q or its number field).
    For a real X: W(λ) ⊂ X only at the common roots Z of ι_y π(λ), y ∈ X^⊥ (required to
    have no real stable one), so elsewhere X ∩ W(λ) is the line of γ(λ) = ι_{y_1} π(λ)
    made primitive, and U = X ∩ ker u meets W(λ) iff u·γ(λ) = 0 — two rows at one λ would
    put W(λ) in U ⊂ X. So the λ_i are k distinct real stable roots of u·γ, a polynomial
    of degree ≤ g = deg γ: g < k rules X out; g = k (X rational) is the affine family of
    monic members, decided by :func:`family_order`. Degrees are the same for conjugate X,
    so an irrational X is decided only when g < k. ``basis_rows``: the rows of λ whose
    images are the rows of ``G``; a member found gives the row of each of its λ."""
    c = 5
    pairs = list(itertools.combinations(range(c), 2))
    trips = list(itertools.combinations(range(c), 3))
    quads = list(itertools.combinations(range(c), 4))
    pi = _pair_minors(G, lam)
    if pi is None:
        return no("the images of the rows are dependent for λ generic", k)
    D = max(sp.degree(e, lam) for e in pi)
    fam = ("modulo rowspace [M; H] the rows of λ span planes W(λ) of 5 dimensions (lines of"
           f" P⁴), Plücker vector π(λ) of degree {D}; {k} rows need a plane U with"
           f" p_U ∧ π(λ) = 0 at {k} real stable λ (counted with multiplicity)")
    coeffs = [list(reversed(sp.Poly(e, lam).all_coeffs())) for e in pi]  # λ⁰, λ¹, …
    # T: p ↦ p ∧ π(λ), coefficient by coefficient (Λ⁴ components × powers of λ)
    T = sp.zeros(len(quads) * (D + 1), len(pairs))
    for i, S in enumerate(pairs):
        for j, S2 in enumerate(pairs):
            if set(S) & set(S2):
                continue
            row = quads.index(tuple(sorted(S + S2)))
            for e, cf in enumerate(coeffs[j]):
                T[row * (D + 1) + e, i] += _perm_sign(S + S2) * cf
    if exact_rank(T).rank < len(pairs):
        return no(f"{fam}, but some p ≠ 0 has p ∧ π(λ) ≡ 0 (a plane may meet every W(λ))", k)
    coef = sp.Matrix([list(cf) for r in range(G.rows) for cf in coefficient_rows(G[r, :], lam)])
    if exact_rank(coef).rank < c:
        return no(f"{fam}, but every W(λ) lies in one hyperplane", k)
    if D <= k:
        return OneMoreRow(True, False, (), f"{fam}: p_U ∧ π(λ) ≢ 0 has degree ≤ {D}, so {k}"
                          " roots leave a constant factor ℓ and every W(λ) would lie in the"
                          f" hyperplane ℓ^⊥ (they span R⁵): no choice of real stable λ gives"
                          f" {k} rows", k)
    if D > k + 1:
        return no(f"{fam}: p_U ∧ π(λ) has degree {D} > {k + 1} (not decided)", k)
    # 3-spaces X meeting every W(λ): ⟨p_X, π(λ)⟩ = p_X ∧ π(λ) ≡ 0, p_X decomposable
    A = sp.zeros(D + 1, len(trips))
    for j, S in enumerate(pairs):
        Sc = tuple(sorted(set(range(c)) - set(S)))
        for e, cf in enumerate(coeffs[j]):
            A[e, trips.index(Sc)] += _perm_sign(Sc + S) * cf
    basis = A.nullspace()
    head = (f"{fam}; p_U ∧ π(λ) = p(λ) ℓ(λ) with ℓ linear puts U in a 3-space X meeting"
            " every W(λ)")
    if not basis:
        return OneMoreRow(True, False, (), f"{head}, and no 3-space meets every W(λ): no"
                          f" choice of real stable λ gives {k} rows", k)
    points = _solid_points(basis, trips, pairs, quads)
    if points is None:
        return no(f"{head}; the 3-spaces X (on G(3, 5)) are not found as finitely many points"
                  " in shape position (not decided)", k)
    parts, found = [], None
    for field, p_X in points:
        verdict = _solid_verdict(field, p_X, pi, pairs, trips, k, lam, time)
        if verdict[0] == "open":
            return no(f"{head}; {verdict[1]} (not decided)", k)
        parts.append(verdict[1])
        if verdict[0] == "possible" and found is None:
            found = verdict[2:]
    text = f"{head}; {len(points)} such X (conjugate sets): " + "; ".join(parts)
    if found is not None:
        lams, y = found
        return OneMoreRow(True, True, tuple(lams), text, k,
                          _rows_into(G, basis_rows, y, lams, lam))
    return OneMoreRow(True, False, (), f"{text}: no choice of real stable λ gives {k} rows", k)


def _six_rows(G, k, lam, time, no, basis_rows, what) -> OneMoreRow:
    """:func:`two_more_rows` (k = q + 2, ``what`` "plane") and :func:`three_more_rows`
    (k = q + 3, "solid") for planes W(λ) of c = 6 dimensions once their preconditions hold
    (METHOD §2b, "Planes of six dimensions"). The images of a model's k rows span a space
    U of dimension e = k − q (2 or 3) meeting W(λ_i) at k real stable λ_i (at most one row
    at each when no W(λ) lies in the spaces below); P_U(λ) = p_U ∧ π(λ) ∈ Λ^(e+2)R⁶ is the
    (e + 2)-vector of U + W(λ), so P_U = p(λ) ℓ(λ) with deg ℓ ≤ d = D − k and
    ℓ(λ) ∧ w = 0 for w ∈ W(λ): ℓ lies in the linear space L_d of such curves, and U in the
    space they all contain. Requirements (else not analysed): no p ≠ 0 has p ∧ π ≡ 0 and
    the W(λ) span R⁶."""
    c = 6
    pi = _pair_minors(G, lam)
    if pi is None:
        return no("the images of the rows are dependent for λ generic", k)
    e = 2 if what == "plane" else 3
    D = max(sp.degree(x, lam) for x in pi)
    pairs = list(itertools.combinations(range(c), 2))
    pim = {S: sp.Poly(x, lam) for S, x in zip(pairs, pi)}
    fam = (f"modulo rowspace [M; H] the rows of λ span planes W(λ) of 6 dimensions, Plücker"
           f" vector π(λ) of degree {D}; {k} rows need a {e}-space U meeting W(λ) at {k} real"
           " stable λ")
    # T: p ↦ p ∧ π(λ) on Λᵉ R⁶, coefficient by coefficient
    cols = list(itertools.combinations(range(c), e))
    T = {}
    for i, S in enumerate(cols):
        for S2, P in pim.items():
            if set(S) & set(S2):
                continue
            key = tuple(sorted(S + S2))
            sign = _perm_sign(S + S2)
            for (deg,), cf in P.terms():
                T[(key, deg, i)] = T.get((key, deg, i), 0) + sign * cf
    keys = sorted({(key, deg) for key, deg, _ in T})
    Tm = sp.Matrix(len(keys), len(cols), lambda r, i: T.get(keys[r] + (i,), 0))
    if exact_rank(Tm).rank < len(cols):
        return no(f"{fam}, but some p ≠ 0 has p ∧ π(λ) ≡ 0 (a space may meet every W(λ))", k)
    coef = sp.Matrix([list(cf) for r in range(G.rows) for cf in coefficient_rows(G[r, :], lam)])
    if exact_rank(coef).rank < c:
        return no(f"{fam}, but every W(λ) lies in one hyperplane", k)
    d = D - k
    if d < 0 or (d == 0 and e == 3):
        return OneMoreRow(True, False, (), f"{fam}: P_U = p_U ∧ π(λ) ≢ 0 has degree ≤ {D}, so"
                          f" {k} roots leave a factor ℓ of degree {max(d, 0)}"
                          + (" (none)" if d < 0 else ", a fixed form annihilating every W(λ),"
                             " which span R⁶") + f": no choice of real stable λ gives {k} rows",
                          k)
    if what == "plane":
        return _fixed_plane_verdict(G, pim, pairs, k, d, lam, time, no, fam)
    if d > 1:
        return no(f"{fam}: P_U = p_U ∧ π(λ) has degree {D} > {k + 1} (not decided)", k)
    return _pencil_verdict(G, pim, k, lam, time, no, fam, basis_rows)


def _wedge_rows(G, grade, d, lam) -> tuple:
    """(index sets of Λ^grade R⁶, basis of L_d): the curves ℓ(λ) = Σ_j ℓ_j λʲ (j ≤ d) of
    ``grade``-vectors with ℓ(λ) ∧ G_r(λ) ≡ 0 for both rows of G, exactly; each basis
    element a list of d + 1 dicts (index set → coefficient)."""
    c = G.cols
    sets = list(itertools.combinations(range(c), grade))
    nvar = len(sets) * (d + 1)
    eqs: dict = {}
    for r in range(G.rows):
        polys = [sp.Poly(G[r, a], lam) for a in range(c)]
        for i, S in enumerate(sets):
            for a in range(c):
                if a in S or polys[a].is_zero:
                    continue
                key = tuple(sorted(S + (a,)))
                sign = _perm_sign(S + (a,))
                for (deg,), cf in polys[a].terms():
                    for j in range(d + 1):
                        row = (r, key, deg + j)
                        eqs.setdefault(row, {})
                        col = j * len(sets) + i
                        eqs[row][col] = eqs[row].get(col, 0) + sign * cf
    A = sp.Matrix(len(eqs), nvar, lambda r, col: 0)
    for r, row in enumerate(eqs.values()):
        for col, v in row.items():
            A[r, col] = v
    out = []
    for v in A.nullspace():
        part = [{S: v[j * len(sets) + i] for i, S in enumerate(sets)} for j in range(d + 1)]
        out.append([{S: x for S, x in p.items() if x != 0} for p in part])
    return sets, out


def _contained(ell, c=6) -> list:
    """A basis of {x ∈ Rᶜ : ℓ_j ∧ x = 0 for every coefficient ℓ_j of ``ell``}."""
    rows: dict = {}
    for j, part in enumerate(ell):
        for S, v in part.items():
            for a in range(c):
                if a in S:
                    continue
                key = (j, tuple(sorted(S + (a,))))
                rows.setdefault(key, [0] * c)
                rows[key][a] += _perm_sign(S + (a,)) * v
    if not rows:
        return [sp.Matrix(sp.eye(c)[i, :]) for i in range(c)]
    return [v.T for v in sp.Matrix(list(rows.values())).nullspace()]


def _fixed_plane_verdict(G, pim, pairs, k, d, lam, time, no, fam) -> OneMoreRow:
    """k = q + 2 rows in six dimensions: U is a plane, ℓ(λ) a curve of 4-vectors of
    degree ≤ d containing W(λ) and U."""
    _, L = _wedge_rows(G, 4, d, lam)
    head = f"{fam}; P_U = p(λ) ℓ(λ), ℓ of degree ≤ {d} with ℓ(λ) ⊇ W(λ) and U"
    if not L:
        return OneMoreRow(True, False, (), f"{head}, and no such ℓ ≠ 0 exists: no choice of"
                          f" real stable λ gives {k} rows", k)
    if len(L) > 1:
        return no(f"{head}: such ℓ form a {len(L)}-dimensional space (not decided)", k)
    Y = _contained(L[0])
    if len(Y) < 2:
        return OneMoreRow(True, False, (), f"{head}: ℓ is unique up to scale and the vectors"
                          f" every ℓ(λ) contains span {len(Y)} dimension(s), no plane: no"
                          f" choice of real stable λ gives {k} rows", k)
    if len(Y) > 2:
        return no(f"{head}: ℓ is unique up to scale, but the vectors every ℓ(λ) contains span"
                  f" {len(Y)} dimensions (not decided)", k)
    # U = Y: it meets W(λ) where p_Y ∧ π(λ) = 0
    pY = {S: Y[0][S[0]] * Y[1][S[1]] - Y[0][S[1]] * Y[1][S[0]] for S in pairs}
    comps: dict = {}
    for S, v in pY.items():
        if v == 0:
            continue
        for S2, P in pim.items():
            if set(S) & set(S2):
                continue
            key = tuple(sorted(S + S2))
            comps[key] = comps.get(key, sp.Poly(0, lam)) + P * (_perm_sign(S + S2) * v)
    g = sp.Poly(0, lam)
    for P in comps.values():
        g = g.gcd(P) if not P.is_zero else g
    if g.is_zero:  # pragma: no cover - excluded by T injective
        return no(f"{head}: the plane Y meets every W(λ)", k)
    count = sum(mult * _stable_root_count(f, time) for f, mult in g.sqf_list()[1])
    poly = sp.factor(g.as_expr())
    text = (f"{head}: ℓ is unique up to scale and fixes U = Y, the plane every ℓ(λ)"
            f" contains, which meets W(λ) at the roots of {poly}, {count} of them real and"
            " stable counted with multiplicity (a root of order r holds at most r rows)")
    if count < k:
        return OneMoreRow(True, False, (), f"{text}: no choice of real stable λ gives {k} rows",
                          k)
    return no(f"{text} (not decided: the rows there are not built)", k)


def _pencil_verdict(G, pim, k, lam, time, no, fam, basis_rows) -> OneMoreRow:
    """k = q + 3 rows in six dimensions: U is a 3-space and P_U = p(λ) ℓ(λ) with ℓ a
    pencil ℓ0 + λ ℓ1 of forms annihilating U and W(λ) (5-vectors of U + W(λ)); the
    pencils form the linear space L_1, and U lies in X = ker ℓ0 ∩ ker ℓ1."""
    c = 6
    _, L = _wedge_rows(G, 5, 1, lam)
    head = (f"{fam}; P_U = p(λ) ℓ(λ) with ℓ = ℓ0 + λ ℓ1 a pencil of forms annihilating U and"
            " every W(λ)")
    if not L:
        return OneMoreRow(True, False, (), f"{head}, and no such pencil exists: no choice of"
                          f" real stable λ gives {k} rows", k)
    if len(L) > 2:
        return no(f"{head}: the pencils form a {len(L)}-dimensional space (not decided)", k)

    def form(part):  # the 5-vector Σ ℓ_S e_S as the form x ↦ ℓ ∧ x
        full = tuple(range(c))
        return [_perm_sign(tuple(i for i in full if i != a) + (a,))
                * part.get(tuple(i for i in full if i != a), 0) for a in range(c)]

    t = sp.Dummy("t")
    b1 = [form(ell[1]) for ell in L]  # ℓ1 of each basis pencil
    charts = [("t", [x + t * y for x, y in zip(*b1)]), ("1/t", [t * x + y for x, y in zip(*b1)])
              ] if len(L) == 2 else [("the pencil", b1[0])]
    gammas = []
    for name, b in charts:
        gam = [sp.expand(sum(b[i] * (pim[(i, j)] if i < j else -pim[(j, i)]).as_expr()
                             for i in range(c) if i != j)) for j in range(c)]
        gammas.append((name, b, gam))
    g = max(sp.degree(x, lam) for _, _, gam in gammas for x in gam)
    X_txt = (f"{len(L)} independent pencil{'s' if len(L) > 1 else ''}: U lies in a 4-space"
             f" X(t) = ker ℓ0(t) ∩ ker ℓ1(t) of a {'line' if len(L) == 2 else 'point'} of"
             " pencils, X(t) ∩ W(λ) is the line of γ(λ, t) = ι_ℓ1(t) π(λ) (0 only where"
             " W(λ) ⊂ X(t)), and U = X ∩ ker u meets W(λ) iff u·γ(λ, t) = 0, a polynomial of"
             f" degree ≤ {g} in λ")
    if g < k:
        return OneMoreRow(True, False, (), f"{head}; {X_txt} < {k}: no choice of real stable"
                          f" λ gives {k} rows", k)
    if g > k:
        return no(f"{head}; {X_txt} > {k} (not decided)", k)
    mats = [sp.Matrix([[sp.Poly(x, lam).coeff_monomial(lam ** i) for i in range(k + 1)]
                       for x in gam]) for _, _, gam in gammas]
    bad = _pencil_signs(mats[0], t, k, time) if len(gammas) == 2 else None
    found = _pencil_member(gammas, k, lam, t, time, bad)
    if found is not None:
        lams, b, where = found
        rows = _rows_into(G, basis_rows, b, lams, lam)
        return OneMoreRow(True, True, tuple(lams), f"{head}; {X_txt}: at {where} a member has"
                          f" {k} real stable roots", k, rows)
    # W(λ) ⊂ X(t) only at the common zeros of γ(λ, t): none with λ real and stable allowed
    for name, b, gam in gammas:  # (a found member needs no such check: it is certified)
        gb = sp.groebner([x for x in gam if x != 0], t, lam, order="lex").exprs
        if gb == [1]:
            continue
        last = sp.Poly(gb[-1], t, lam)
        if last.degree(t) > 0 or last.degree(lam) <= 0:
            return no(f"{head}: X({name}) contains W(λ) along a curve (not decided)", k)
        if _stable_root_count(sp.Poly(gb[-1], lam), time) > 0:
            return no(f"{head}: some X({name}) contains W(λ) at a real stable root of"
                      f" {sp.factor(gb[-1])} (not decided)", k)
    if bad is None:  # every parameter value to the cover
        whole = [(-1, 1)]
        charts, signs = [(g[0], whole) for g in gammas], ""
    else:
        charts, signs = _chart_intervals(bad), (
            f"the signs (Gordan, exactly at one t between consecutive real roots of the"
            f" critical polynomials of the annulling functionals; closed under limits) rule out"
            f" every t but {_describe_intervals(bad)}")
        if not any(iv for _, iv in charts):
            return OneMoreRow(True, False, (), f"{head}; {X_txt}; {signs}: no choice of real"
                              f" stable λ gives {k} rows", k)
        signs += "; there "
    cover = pencil_cover(k, [(name, _kernel_functionals(Cm, t), iv) for (name, iv), Cm
                             in zip(charts, mats)], time)
    if not cover.proven:
        return no(f"{head}; {X_txt}: no member found, {signs}{cover.evidence} (not decided)", k)
    return OneMoreRow(True, False, (), f"{head}; {X_txt}; {signs}{cover.evidence}: no choice"
                      f" of real stable λ gives {k} rows", k)


def _pencil_signs(Cm, t, k, time):
    """The open intervals of t (ends rational bounds, None for ±∞) where the sign test
    does not rule out every member of the family {u·γ(λ, t)} (coefficient rows ``Cm``),
    or None when its annulling functionals are not a plane for t generic.

    A member with k real stable roots has the coefficients of p (continuous) or of
    (μ − 1)ᵏ p((μ + 1)/(μ − 1)) (discrete) all of one sign, so a y ≥ 0, y ≠ 0 annulling
    the family in those coefficients rules t out. They are the plane of functionals
    w_1(t), w_2(t); such a y exists iff the vectors (w_1e, w_2e) lie in a closed
    half-plane, which depends only on the signs of the w_ke and of their 2 × 2
    determinants: constant between consecutive real roots of those polynomials, decided
    exactly at one rational t there. The set of t ruled out is closed (a limit of
    certificates annuls the limit family), so the roots themselves follow from their
    neighbours, and so does t = ∞."""
    if time != "continuous":
        mu = sp.Dummy("mu")
        Tm = sp.Matrix(k + 1, k + 1, lambda i, j: sp.Poly(
            (mu + 1) ** j * (mu - 1) ** (k - j), mu).coeff_monomial(mu ** i))
        Cm = Cm * Tm.T  # a row a of λ-coefficients becomes Tm a
    N = [sp.Matrix([sp.cancel(x) for x in v]) for v in Cm.nullspace()]
    if len(N) != 2:
        return None
    W = [[sp.Poly(x, t) for x in _cleared(v)] for v in N]
    crit = [P for P in W[0] + W[1] if P.degree() > 0]
    crit += [W[0][i] * W[1][j] - W[0][j] * W[1][i] for i, j in
             itertools.combinations(range(k + 1), 2)]
    crit = [P for P in crit if P.degree() > 0]
    ends = (sorted((sp.Rational(a), sp.Rational(b)) for (a, b), _ in sp.intervals(crit))
            if crit else [])
    if any(ends[i][1] >= ends[i + 1][0] for i in range(len(ends) - 1)):  # touching
        prod = crit[0]
        for P in crit[1:]:
            prod = prod * P
        ends = _separated_roots(prod.sqf_part())
    cuts = [None] + ends + [None]
    bad = []
    for left, right in zip(cuts, cuts[1:]):
        lo = left[1] if left else (right[0] - 1 if right else sp.Integer(-1))
        hi = right[0] if right else lo + 2
        point = (lo + hi) / 2
        vecs = [(W[0][e](point), W[1][e](point)) for e in range(k + 1)]
        if not _half_plane(vecs):
            bad.append((left[0] if left else None, right[1] if right else None))
    return bad


def _half_plane(vecs) -> bool:
    """Whether some x ≠ 0 has x·v ≥ 0 for every v of ``vecs`` (exact rationals in R²): if
    any, an extreme one is perpendicular to some v (or every v is 0)."""
    nonzero = [v for v in vecs if v != (0, 0)]
    if not nonzero:
        return True
    for a, b in nonzero:
        for x in ((-b, a), (b, -a)):
            if all(x[0] * c + x[1] * d >= 0 for c, d in nonzero):
                return True
    return False


def _chart_intervals(bad) -> list:
    """The closed intervals of the charts t ∈ [−1, 1] and s = 1/t ∈ [−1, 1] that cover the
    open t-intervals ``bad`` (None for ±∞)."""
    one, two = [], []
    for a, b in bad:
        a = -sp.oo if a is None else a
        b = sp.oo if b is None else b
        if a < 1 and b > -1:
            one.append((max(a, -1), min(b, 1)))
        if b > 1:  # t ∈ [max(a, 1), b] ↔ s ∈ [1/b, 1/max(a, 1)]
            two.append((0 if b == sp.oo else 1 / b, 1 / max(a, 1)))
        if a < -1:
            two.append((1 / min(b, -1), 0 if a == -sp.oo else 1 / a))
    return [("t", one), ("1/t", two)]


def _describe_intervals(bad) -> str:
    if not bad:
        return "none"
    return " ∪ ".join(f"({'−∞' if a is None else a}, {'∞' if b is None else b})"
                      for a, b in bad)


def _kernel_functionals(Cm, t) -> list:
    """Integer polynomial functionals y(t) (weights of λ⁰ … λᵐ, coefficient lists in t)
    with Cm(t) y(t) ≡ 0, spanning the kernel at every t where its dimension is generic: the
    kernel basis normalised on pairs of coordinates, added until their 2 × 2 minors have
    no common root (one basis can degenerate at some t)."""
    N = [sp.Matrix([sp.cancel(x) for x in v]) for v in Cm.nullspace()]
    out, minors = [], []
    for S in itertools.combinations(range(Cm.cols), len(N)):
        sub = sp.Matrix([[v[i] for v in N] for i in S])
        det = sp.cancel(sub.det())
        if det == 0:
            continue
        B = (sp.Matrix.hstack(*N) * sub.inv()).applyfunc(sp.cancel)
        out += [_cleared(B[:, j]) for j in range(B.cols)]
        minors += [sp.expand(a[i] * b[j] - a[j] * b[i]) for a, b in itertools.combinations(
            out, 2) for i, j in itertools.combinations(range(Cm.cols), 2)]
        if len(N) < 2 or sp.degree(sp.gcd_list([m for m in minors if m != 0] or [0]), t) == 0:
            break
    funcs = []
    for col in out:
        assert (Cm * col).applyfunc(sp.expand).is_zero_matrix
        polys = [sp.Poly(x, t) for x in col]
        den = math.lcm(*[int(sp.Rational(cf).q) for P in polys for cf in P.coeffs()] or [1])
        funcs.append([[int(cf * den) for cf in reversed(P.all_coeffs())] if not P.is_zero
                      else [0] for P in polys])
    return funcs


def _cleared(v):
    """A vector of rational functions times the lcm of its denominators: polynomials."""
    den = sp.lcm_list([sp.fraction(sp.together(x))[1] for x in v])
    return sp.Matrix([sp.expand(sp.cancel(x * den)) for x in v])


def _pencil_member(gammas, k, lam, t, time, bad):
    """A member u·γ(λ, t) with k distinct real stable roots, exactly: ((λ_i), ℓ1, where) or
    None. Parameters t: where the signs do not rule t out (``bad``, open intervals, None
    ends for ±∞; when None, t = tan θ on a grid of angles and t = ∞), a grid in each; at
    each, k − 2 roots pinned on a grid in floating point, the last two the roots of the
    quadratic left, rebuilt exactly (:func:`_exact_member`); then :func:`family_order`
    (exact) at the middle of each interval."""
    grid = ([-sp.Rational(x) for x in ("1/1000", "1/100", "1/10", "1/2", "1", "2", "4",
                                        "8", "16", "32", "64", "128", "512", "4096")]
            if time == "continuous" else
            [sp.Rational(x, 16) for x in range(-15, 16, 2)])
    name, b, gam = gammas[0]
    if bad is None:
        pars = [sp.Rational(math.tan(math.pi * (i / _PENCIL_ANGLES - 0.5))
                            ).limit_denominator(32) for i in range(1, _PENCIL_ANGLES)]
        middles = []
    else:
        pars, middles = [], []
        for lo, hi in bad:
            lo = hi - 64 if lo is None else lo
            hi = lo + 64 if hi is None else hi
            pars += [lo + (hi - lo) * sp.Rational(i, 12) for i in range(1, 12)]
            middles.append((lo + hi) / 2)
    tries = [(gammas[0], tv) for tv in (pars if len(gammas) == 2 else [sp.Integer(0)])]
    if len(gammas) == 2 and bad is None:
        tries.append((gammas[1], sp.Integer(0)))
    # γ's coefficients are affine in t: C(t) = C0 + t C1, in floats once per chart
    affine = {}
    for chart in {id(g): g for g, _ in tries}.values():
        C = [[sp.Poly(sp.Poly(x, lam).coeff_monomial(lam ** i), t) for i in range(k + 1)]
             for x in chart[2]]
        affine[id(chart)] = tuple(np.array([[float(P.coeff_monomial(t ** j)) for P in row]
                                            for row in C]) for j in (0, 1))
    V = np.vander(np.array([float(x) for x in grid]), k + 1, increasing=True)
    combos = np.array(list(itertools.combinations(range(len(grid)), k - 2)))
    hits = []  # (stiffness score, order, pins, chart, t): least stiff first
    for chart, tv in tries:
        C0, C1 = affine[id(chart)]
        _, sv, Vt = np.linalg.svd(C0 + float(tv) * C1)
        basis = Vt[: int((sv > 1e-9 * sv[0]).sum())]
        if basis.shape[0] != k - 1:
            continue
        # every pinned set at once: the member through k − 2 pinned roots (a null vector),
        # its roots as the eigenvalues of its companion matrix
        null = np.linalg.svd((V @ basis.T)[combos])[2][:, -1, :]
        P = null @ basis  # coefficients of λ⁰ … λᵏ, one row per pinned set
        lead = P[:, -1]
        ok = np.abs(lead) >= 1e-9 * np.abs(P).max(axis=1)
        comp = np.zeros((int(ok.sum()), k, k))
        comp[:, 1:, :-1] = np.eye(k - 1)
        comp[:, :, -1] = -P[ok, :-1] / lead[ok, None]
        roots = np.linalg.eigvals(comp)
        real = np.all(np.abs(roots.imag) <= 1e-9 * (1 + np.abs(roots)), axis=1)
        rr = np.sort(roots.real, axis=1)
        stable = np.all(rr < 0 if time == "continuous" else np.abs(rr) < 1, axis=1)
        apart = np.min(np.diff(rr, axis=1), axis=1) >= 1e-6 * (1 + np.abs(rr).max(axis=1))
        good = real & stable & apart
        score = (np.abs(rr).max(axis=1) / np.abs(rr).min(axis=1) if time == "continuous"
                 else np.abs(rr).max(axis=1))
        for j in np.flatnonzero(good):
            hits.append((float(score[j]), len(hits), tuple(combos[ok][j]), chart, tv))
    for _, _, pins, (cname, b, gam), tv in sorted(hits, key=lambda h: h[:2])[:_PENCIL_EXACT]:
        got = _exact_member([x.subs(t, tv) for x in gam], [grid[i] for i in pins], k, lam,
                            time)
        if got is not None:
            where = cname if len(gammas) == 1 else f"{cname} = {tv}"
            return got, [x.subs(t, tv) for x in b], where
    for tv in middles:
        polys = [sp.Poly(x.subs(t, tv), lam) for x in gam]
        a0, dirs = _monic_family(polys, k, lam)
        order = family_order(k, a0, dirs, lam, time)
        if order.lambdas:
            return list(order.lambdas), [x.subs(t, tv) for x in b], f"{name} = {tv}"
    return None


def _exact_member(gam, pins, k, lam, time):
    """The member u·γ(λ) (``gam`` at one parameter value) through the pinned rational
    roots, exactly: its roots (the pins first) when the other two are real, distinct,
    stable and not pinned, else None."""
    polys = [sp.Poly(x, lam) for x in gam]
    A = sp.Matrix([[P(v) for P in polys] for v in pins])
    for u in A.nullspace():
        p = sum((P * u[i] for i, P in enumerate(polys) if u[i] != 0), sp.Poly(0, lam))
        if p.is_zero or p.degree() != k:
            continue
        rest = p
        for v in pins:
            rest = rest.quo(sp.Poly(lam - v, lam))
        if rest.degree() != 2 or any(rest(v) == 0 for v in pins):
            return None
        if rest.discriminant() <= 0 or _stable_root_count(rest, time) != 2:
            return None
        return list(pins) + sorted(sp.roots(rest.as_expr(), lam), key=lambda z: float(z))
    return None


def _solid_points(basis, trips, pairs, quads):
    """The decomposable p_X = Σ y_i basis_i (3-spaces of R⁵), projectively, as
    [(field, p_X)]: one entry per irreducible factor of each chart's last Gröbner polynomial
    (field QQ for a rational point, else the algebraic field of one root, the entries of
    p_X in it); only factors with a real root. None when a chart's lex Gröbner basis is not
    in shape position (y_i = f_i(y_last), g(y_last) = 0)."""
    s = len(basis)
    ys = sp.symbols(f"y0:{s}")
    pX = sum((ys[i] * basis[i] for i in range(s)), sp.zeros(len(trips), 1))
    om = _hodge_dual(pX, pairs, trips)
    plucker = [sp.expand(om[(a, b)] * om[(c, d)] - om[(a, c)] * om[(b, d)]
                         + om[(a, d)] * om[(b, c)]) for a, b, c, d in quads]
    out = []
    for j in range(s - 1, -1, -1):  # chart y_j = 1, y_i = 0 for i > j
        fix = {ys[j]: 1, **{ys[i]: 0 for i in range(j + 1, s)}}
        eqs = [e for e in (sp.expand(q.subs(fix)) for q in plucker) if e != 0]
        free = ys[:j]
        if not free:
            if not eqs:
                out.append((sp.QQ, pX.subs(fix)))
            continue
        if not eqs:
            return None  # a whole chart of solutions
        gb = sp.groebner(eqs, *free, order="lex")
        if list(gb.exprs) == [1]:
            continue
        last, t = gb.exprs[-1], free[-1]
        if len(gb.exprs) != len(free) or last.free_symbols != {t}:
            return None
        subs = {}
        for i, e in enumerate(gb.exprs[:-1]):
            P = sp.Poly(e, *free)
            if (P.degree(free[i]) != 1 or e.free_symbols - {free[i], t}
                    or not sp.diff(e, free[i]).is_Rational):
                return None
            subs[free[i]] = sp.expand(free[i] - e / sp.diff(e, free[i]))  # f_i(t)
        for h, _ in sp.factor_list(last, t)[1]:
            h = sp.Poly(h, t)
            if h.degree() == 1:
                root = -h.nth(0) / h.nth(1)
                vals = {**fix, t: root, **{v: f.subs(t, root) for v, f in subs.items()}}
                out.append((sp.QQ, [sp.expand(e.subs(vals)) for e in pX]))
                continue
            if h.count_roots() == 0:  # no real point: no real X
                continue
            field = sp.QQ.algebraic_field(sp.CRootOf(h.as_expr(), 0))

            def elem(expr, h=h, field=field):
                rem = sp.Poly(sp.expand(expr), t).rem(h)
                return field.new([sp.QQ.convert(cf) for cf in rem.all_coeffs()])

            vals = {**fix, **subs}
            out.append((field, [elem(sp.expand(e.subs(vals))) for e in pX]))
    return out


def _solid_verdict(field, p_X, pi, pairs, trips, k, lam, time) -> tuple:
    """("none" | "possible" | "open", text[, λ]) for one (conjugate set of) 3-space X of
    :func:`_space_rows`."""
    K = field
    pX = [K.convert(e) if K == sp.QQ else e for e in p_X]
    om = _hodge_dual(pX, pairs, trips)
    # X^⊥ = {y : ω ∧ y = 0} (ω the Hodge dual of p_X, the 2-vector y_1 ∧ y_2)
    rows = []
    for a, b, c in trips:
        r = [K.zero] * 5
        r[c] += om[(a, b)]
        r[b] -= om[(a, c)]
        r[a] += om[(b, c)]
        rows.append(r)
    Yr = DomainMatrix(rows, (len(trips), 5), K).nullspace().to_list()
    if len(Yr) != 2:  # pragma: no cover - a point of G(3, 5) has a 2-dimensional X^⊥
        return ("open", f"a point p_X with X^⊥ of dimension {len(Yr)}")
    pim = {}
    for j, (a, b) in enumerate(pairs):
        P = sp.Poly(pi[j], lam, domain=K)
        pim[(a, b)], pim[(b, a)] = P, -P
    zero = sp.Poly(0, lam, domain=K)
    contr = []
    for y in Yr:  # ι_y π(λ): (ι_y π)_b = Σ_a y_a π_ab
        contr.append([sum((pim[(a, b)].mul_ground(y[a]) for a in range(5)
                           if a != b and y[a] != K.zero), zero) for b in range(5)])
    where = ("rational" if K == sp.QQ else f"over a number field of degree"
             f" {K.ext.minpoly.degree()} (as many conjugate X)")
    Z = zero
    for v in contr[0] + contr[1]:
        Z = Z.gcd(v) if not v.is_zero else Z
    if Z.degree() > 0:
        if K != sp.QQ:
            return ("open", f"X {where} contains W(λ) at the roots of a polynomial of degree"
                    f" {Z.degree()}")
        Zq = sp.Poly(Z.as_expr(), lam)
        if _stable_root_count(Zq, time) > 0:
            return ("open", f"X ({where}) contains W(λ) at a real stable root of"
                    f" {sp.factor(Zq.as_expr())}")
    use = 0 if any(not v.is_zero for v in contr[0]) else 1
    gam = contr[use]
    cont = zero
    for v in gam:
        cont = cont.gcd(v) if not v.is_zero else cont
    gam = [v.quo(cont) for v in gam]
    g = max(v.degree() for v in gam)
    if g < k:
        return ("none", f"X {where}: X ∩ W(λ) traces a curve of degree {g} < {k} in X, met"
                f" by a plane U ⊂ X at ≤ {g} λ")
    if g > k or K != sp.QQ:
        return ("open", f"X {where}: X ∩ W(λ) traces a curve of degree {g}")
    m = k
    a0, dirs = _monic_family([sp.Poly(v.as_expr(), lam) for v in gam if not v.is_zero], m, lam)
    order = family_order(m, a0, dirs, lam, time)
    text = f"X rational: X ∩ W(λ) traces a curve of degree {m}: {order.evidence}"
    if order.lambdas:
        return ("possible", text, order.lambdas, [K.to_sympy(e) for e in Yr[use]])
    return ("none", text) if order.impossible else ("open", text)


def _monic_family(polys, m, lam) -> tuple:
    """(a0, dirs) of :func:`family_order` for the monic members of degree m of the span of
    ``polys`` (Poly in λ of degree ≤ m, one of degree m): p0 = that one made monic, the
    directions P − lc_m(P) p0 of the others, an independent subset."""
    j0 = next(j for j, P in enumerate(polys) if P.degree() == m)
    p0 = polys[j0].to_field().monic()
    a0 = [-p0.coeff_monomial(lam ** i) for i in range(m)]
    dirs = _independent([[-(P - p0 * P.coeff_monomial(lam ** m)).coeff_monomial(lam ** i)
                          for i in range(m)] for j, P in enumerate(polys) if j != j0])
    return a0, dirs


def _hodge_dual(pX, pairs, trips) -> dict:
    """The 2-vector ω of a 3-vector p_X of R⁵ (ω_S = ε(S^c S) p_X[S^c]): decomposable
    together, and ω = y_1 ∧ y_2 for X^⊥ = span(y_1, y_2)."""
    rest = {S: tuple(sorted(set(range(5)) - set(S))) for S in pairs}
    return {S: _perm_sign(rest[S] + S) * pX[trips.index(rest[S])] for S in pairs}


def _rows_into(G, basis_rows, y, lams, lam) -> tuple:
    """The row of each λ in ``lams`` whose image lies in X: (y·G_0) Φ_1 − (y·G_1) Φ_0 of the
    basis rows Φ_0, Φ_1 (image ι_y of their Plücker vector, on the line X ∩ W(λ)), its
    common polynomial factor removed; () when it vanishes at one of the λ."""
    g0, g1 = ((sp.Matrix([y]) * G[i, :].T)[0] for i in range(2))
    num = (sp.expand(g0) * basis_rows[1] - sp.expand(g1) * basis_rows[0]).applyfunc(sp.expand)
    content = sp.gcd_list([e for e in num if e != 0])
    num = num.applyfunc(lambda e: sp.cancel(e / content))
    out = []
    for v in lams:
        row = num.subs(lam, v).applyfunc(lambda e: sp.radsimp(sp.expand(e)))
        if row.is_zero_matrix:
            return ()
        out.append(row)
    return tuple(out)


def _nonlinear_evidence(parts) -> str:
    return ("nonlinear terms: rows seeing the terms S are a linear model of [M; A_j, j ∈ S]"
            " decoupled from C_j, j ∉ S; " + "; ".join(parts))


def _chain_order(F, H, M, conds: set) -> int:
    """The least m ≥ 1 with M Fᵐ ∈ rowspace [M, …, M Fᵐ⁻¹; H, …, H Fᵐ] (m ≤ n by
    Cayley–Hamilton)."""
    MF, HF = [M], [H]
    m = 0
    while True:
        m += 1
        MF.append(MF[-1] * F)
        HF.append(HF[-1] * F)
        r0, c0 = _rank(MF[:m] + HF)
        r1, c1 = _rank(MF + HF)
        conds |= c0 | c1
        if r1 == r0:
            return m


def residual_order_bound(F, H, L, D, k_max: int) -> OrderBound:
    """The least k' ≤ ``k_max`` at which a residual generator decoupled from L and
    responding to every column of D exists (canonical form, any F*); ``k_max + 1`` when
    none exists up to ``k_max`` (every such generator has more states)."""
    F, H, L, D = (sp.Matrix(X) for X in (F, H, L, D))
    conds: set = set()
    tried = []
    for k in range(1, k_max + 1):
        W, Lk = krylov_blocks(F, H, L, k)
        members, rk = left_null_echelon(sp.Matrix.hstack(W, Lk) if Lk.cols else W)
        conds |= rk.conditions
        blind = _blind_columns(members, F, H, D, k)
        if members and not blind:
            return OrderBound(k, f"canonical form: the null space of (W⁽{k}⁾ L⁽{k}⁾) has a member"
                              " seeing every fault" + _tried(tried), frozenset(conds))
        tried.append(f"k = {k}: " + (f"rank (W L) = {rk.rank} = l(k+1), no member" if not members
                                     else f"{len(members)} member(s), none sees fault column(s)"
                                     f" {', '.join(str(c + 1) for c in blind)}"))
    return OrderBound(k_max + 1, "canonical form: " + "; ".join(tried), frozenset(conds))


def _tried(tried) -> str:
    return f" (below it: {'; '.join(tried)})" if tried else ""


def _blind_columns(members, F, H, D, k) -> list:
    """The fault columns c with Φ(v) D_c = 0 for every member v (a generic combination of
    the members sees every other column: a finite union of proper subspaces is not the
    whole space)."""
    if not members:
        return list(range(D.cols))
    seen = set()
    for v in members:
        _, _, Phi = member_to_phi(v, F, H, k)
        PD = (Phi * D).applyfunc(sp.cancel)
        seen |= {c for c in range(D.cols) if any(e != 0 for e in PD[:, c])}
        if len(seen) == D.cols:
            break
    return [c for c in range(D.cols) if c not in seen]


@dataclasses.dataclass(frozen=True)
class ChainOrder:
    """What the monic polynomials p of degree m with M p(F) ∈ W_m (and, decoupled, the
    quotient condition r(s) L = 0) say about order m.

    ``verdict``: "empty" (no such p: no model of order m), "unique" (one p; its roots are
    every model's eigenvalues), "line" (a one-parameter family, decided exactly),
    "hyperplane" (one linear condition on p, decided exactly), "plane" (a two-parameter
    family, decided exactly), "signs" (a family of dimension 3 … m − 2 in which no
    member has coefficients of one sign: ruled out exactly), "box" (such a family ruled out
    exactly by :func:`box_cover`), "free" (an affine family of
    dimension 3 … m − 2, searched; undecided when nothing is found; or ``dim`` ≥ m: every
    monic p), "symbolic" (parameters: a member whose roots are rational functions of
    them was looked for; undecided when none is found); ``polynomial``: the unique p, or
    the member found with ``lambdas`` as its roots; ``lambdas``: m distinct real stable
    roots of a member (exact; with parameters, stable at their defaults), () when none was
    found; ``evidence``: one line; ``conditions``: with parameters, the pivots (``Ne(f, 0)``)
    the generic ranks rest on."""

    m: int
    verdict: str
    dim: int
    polynomial: sp.Expr | None
    lambdas: tuple
    evidence: str
    conditions: frozenset = frozenset()

    @property
    def impossible(self) -> bool:
        """No member has m distinct real stable roots (decided exactly)."""
        return self.verdict in ("empty", "signs", "box") or (
            self.verdict in ("unique", "line", "hyperplane", "plane") and not self.lambdas)

    @property
    def decided(self) -> bool:
        """Whether some member has m distinct real stable roots is known exactly."""
        return self.verdict not in ("free", "symbolic") or bool(self.lambdas)


def chain_system(F, H, M, m: int, L=None):
    """The linear system X A = B of the order-m chain polynomials: X = (a_0, …, a_{m−1},
    b_0, …, b_m), p(λ) = λᵐ − Σ a_i λⁱ, M p(F) = Σ b_i H Fⁱ (n columns) and, for
    decoupled inputs L, the quotient r(s) = Σ_j r_j sʲ of b(s) H − p(s) M = r(s)(sI − F)
    with r_j L = 0 (q columns for each j = 0, …, m − 1):
    Σ_{i>j} (a_i M + b_i H) F^{i−j−1} L = M F^{m−j−1} L (a_m = 0).

    Several rows of M share p (the polynomial whose roots are the model's distinct λ) and
    have their own b: X = (a, b⁽¹⁾, …, b⁽ʳ⁾), one column block per row."""
    parts = [_row_system(F, H, M[j, :], m, L) for j in range(M.rows)]
    if len(parts) == 1:
        Aa, Ab, B = parts[0]
        return sp.Matrix.vstack(Aa, Ab), B
    cols = [P[0].cols for P in parts]
    Aa = sp.Matrix.hstack(*[P[0] for P in parts])
    blocks = []
    for j, P in enumerate(parts):
        blocks.append(sp.Matrix.hstack(*[P[1] if i == j else sp.zeros(P[1].rows, c)
                                         for i, c in enumerate(cols)]))
    return sp.Matrix.vstack(Aa, *blocks), sp.Matrix.hstack(*[P[2] for P in parts])


def _row_system(F, H, M, m, L):
    """For one row M: the rows of X A = B for a (m rows) and for b ((m + 1) l rows), and B."""
    MF, HF = [M], [H]
    for _ in range(m):
        MF.append(MF[-1] * F)
        HF.append(HF[-1] * F)
    Aa, Ab = sp.Matrix.vstack(*MF[:m]), sp.Matrix.vstack(*HF)
    B = MF[m]
    if L is not None and L.cols:
        ML = [X * L for X in MF]
        HL = [X * L for X in HF]
        zero = sp.zeros(1, L.cols)
        ba, bb, rhs = [], [], []
        for j in range(m):
            ba.append(sp.Matrix.vstack(*[ML[i - j - 1] if i > j else zero for i in range(m)]))
            bb.append(sp.Matrix.vstack(*[HL[i - j - 1] if i > j else sp.zeros(H.rows, L.cols)
                                         for i in range(m + 1)]))
            rhs.append(ML[m - j - 1])
        Aa, Ab = sp.Matrix.hstack(Aa, *ba), sp.Matrix.hstack(Ab, *bb)
        B = sp.Matrix.hstack(B, *rhs)
    return Aa, Ab, B


def chain_order(F, H, M, m: int, lam, time: str, tries, L=None, defaults=None) -> ChainOrder:
    """The affine family of monic p (degree m) with M p(F) ∈ W_m — and, when ``L`` has
    columns (decoupled inputs), with the quotient r(s) of b(s) H − p(s) M = r(s)(sI − F)
    satisfying r(s) L = 0 — and a member with m distinct real stable roots.

    Every Jordan design of m rows with λ_1, …, λ_m (Φ_i L = 0 when decoupled) gives
    p = Π (s − λ_i) here (r(s) = −Σ c_i Φ_i Π_{j≠i} (s − λ_j)); conversely a member with m
    distinct roots gives the rows Φ_i = r(λ_i) (Φ_i (F − λ_i I) = −b(λ_i) H, Φ_i L = 0) and
    M = b_m H − Σ Φ_i / p'(λ_i): a linear model of order m with those λ (METHOD §2b).

    Several rows of M: p has the *distinct* λ of the model as roots (each row of M is a
    combination of its rows, so each satisfies its own chain condition with that p). A
    model of k rows has at most k distinct λ, so "impossible" at order m still rules out
    every model of ≤ m rows; a member gives the λ, with up to one row per row of M each.

    With symbolic parameters in F, H, M, L the ranks are generic (``conditions``) and a
    member is accepted only when it splits into linear factors over QQ(parameters), with
    distinct roots that are stable at the ``defaults`` (symbol -> value): see
    :func:`_symbolic_chain`."""
    F, H, M = (sp.Matrix(X) for X in (F, H, M))
    L = sp.Matrix(L) if L is not None else None
    dec = L is not None and L.cols > 0
    A, B = chain_system(F, H, M, m, L)
    if A.free_symbols | B.free_symbols:
        # (a parameter without a default has no nominal value: it stays a symbol)
        known = {p: v for p, v in (defaults or {}).items() if v is not None}
        return _symbolic_chain(A, B, m, lam, tries, dec, known, time)
    X0 = solve_left(A, B)
    if X0 is None:
        return ChainOrder(m, "empty", -1, None, (), f"m = {m}: M F^{m} ∉ rowspace [M, …,"
                          f" M F^{m - 1}; H, …, H F^{m}]" + (" with r(s) L = 0" if dec else "")
                          + f": no model of order {m}")
    a0 = [X0[0, i] for i in range(m)]
    basis, _ = left_null_space(A)
    dirs = _independent([[v[0, i] for i in range(m)] for v in basis])
    return family_order(m, a0, dirs, lam, time, tries)


def family_order(m: int, a0, dirs, lam, time: str, tries=()) -> ChainOrder:
    """Decide whether the affine family of monic p(λ) = λᵐ − Σ_i (a0_i + Σ_j t_j v_ji) λⁱ
    (``dirs`` = the v_j, independent) has a member with m distinct real stable roots.

    By the family's dimension d: a point, a line, a hyperplane (d = m − 1) and a plane are
    decided exactly; d ≥ m: every monic p; 3 ≤ d ≤ m − 2: first the sign test
    (:func:`_sign_order`: a member with every root real and stable has coefficients of one
    sign — after λ = (μ + 1)/(μ − 1) in discrete time — so a Gordan certificate that none
    has rules the order out exactly), then members through d pinned roots (``tries``, then
    seeded samples), then a cover of the root box by cells on which the family's
    conditions cannot all vanish (:func:`box_cover`, exact); undecided when none of them
    settles it."""
    d = len(dirs)

    def poly(a):
        return sp.expand(lam ** m - sum(a[i] * lam ** i for i in range(m)))

    def roots_ok(p):
        return _stable_distinct_roots(p, lam, m, time)

    if d == 0:
        p = poly(a0)
        rts = roots_ok(p)
        return ChainOrder(m, "unique", 0, p, rts,
                          f"m = {m}: one p(λ) = {sp.factor(p)}, "
                          + (f"roots {', '.join(map(str, rts))}" if rts else
                             "whose roots are not real, distinct and stable: no Jordan model of"
                             f" order {m}"))
    if d >= m:  # every monic p: the default λ already give order m
        return ChainOrder(m, "free", d, None, (), f"m = {m}: every monic p of degree {m}")
    if d == 1:
        return _pencil_order(m, poly(a0), sp.expand(-sum(dirs[0][i] * lam ** i
                                                          for i in range(m))), lam, time,
                             roots_ok)
    if 3 <= d <= m - 2:
        signs = _sign_order(m, a0, dirs, lam, time)
        if signs is not None:
            return signs

    def pinned(subset):
        a = _pinned(a0, dirs, subset, poly(a0), lam)
        return poly(a) if a is not None else None

    subsets = itertools.chain(itertools.islice(itertools.combinations(tries, d), MAX_SUBSETS),
                              _sampled_subsets(m, d, a0, dirs, time))
    ell = hyperplane_functional(m, a0, dirs) if d == m - 1 else None
    hyper = hyperplane_corners(ell, time) if ell is not None else None
    if hyper is not None and not hyper[0]:
        return ChainOrder(m, "hyperplane", d, None, (), f"m = {m}: {hyper[1]}")
    for subset in subsets:
        p = pinned(subset)
        rts = roots_ok(p) if p is not None else ()
        if rts:
            return ChainOrder(m, "hyperplane" if hyper else "free", d, p, rts,
                              f"m = {m}: " + (hyper[1] + "; " if hyper else
                                              f"a {d}-parameter family of p; ")
                              + f"through λ = {', '.join(map(str, subset))}: p(λ) ="
                              f" {sp.factor(p)}")
    if hyper is not None:  # a member exists: build it near the vertices of opposite sign
        p = hyperplane_member(ell, time, lam, roots_ok)
        if p is not None:
            return ChainOrder(m, "hyperplane", d, p, roots_ok(p),
                              f"m = {m}: {hyper[1]}; p(λ) = {sp.factor(p)}")
    if d == 2:  # a plane: exact cell decomposition in (t1, t2)
        return plane_order(m, poly(a0), [sp.expand(-sum(v[i] * lam ** i for i in range(m)))
                                          for v in dirs], lam, time, roots_ok)
    A0f = np.array([float(v) for v in a0])
    Df = np.array([[float(v) for v in row] for row in dirs])

    def probe(mu):  # the cell's centre as roots: pin d of them (floats first, then exactly)
        lams = [(u + 1) / (u - 1) if time == "continuous" else u for u in mu]
        for subset in (lams[:d], lams[-d:], lams[::2][:d], lams[1::2][:d]):
            if len(subset) < d or len(set(subset)) < d:
                continue
            xs = np.array([float(v) for v in subset])
            V = np.vander(xs, m, increasing=True)  # p(x) = xᵐ − (a0 + Σ w_r dir_r)·(1, x, …)
            try:
                w = np.linalg.solve(V @ Df.T, xs ** m - V @ A0f)
            except np.linalg.LinAlgError:
                continue
            r = np.roots(np.r_[1.0, -(A0f + w @ Df)[::-1]])
            if (np.max(np.abs(r.imag)) > 1e-9 or len(np.unique(np.round(r.real, 9))) < m
                    or not all(is_stable(sp.Float(v), time) for v in r.real)):
                continue
            exact = [sp.Rational(v).limit_denominator(1000) for v in subset]
            p = pinned(exact) if len(set(exact)) == d else None
            rts = roots_ok(p) if p is not None else ()
            if rts:
                return p, rts, exact
        return None

    cover = box_cover(m, _annihilators(m, a0, dirs), time, probe=probe)
    if cover.found:
        p, rts, subset = cover.found
        return ChainOrder(m, "free", d, p, rts, f"m = {m}: a {d}-parameter family of p;"
                          f" through λ = {', '.join(map(str, subset))} (a cell the box cover"
                          f" could not exclude): p(λ) = {sp.factor(p)}")
    if cover.proven:
        return ChainOrder(m, "box", d, None, (), f"m = {m}: a {d}-parameter family of p;"
                          f" {cover.evidence}: no Jordan model of order {m}")
    return ChainOrder(m, "free", d, None, (),
                      f"m = {m}: a {d}-parameter family of p; none through {d} of the tried λ"
                      f" nor of {SAMPLES} sampled sets has only real, distinct, stable roots;"
                      f" the box cover is {cover.evidence} (undecided)")


def _annihilators(m, a0, dirs) -> list:
    """Rational functionals ℓ (weights of the coefficients of λ⁰ … λᵐ) whose common zeros
    among monic p of degree m are exactly the family p = λᵐ − Σ (a0_i + Σ_j t_j v_ji) λⁱ."""
    gens = sp.Matrix([[-a for a in a0] + [1]] + [[-v[i] for i in range(m)] + [0] for v in dirs])
    return [list(v) for v in gens.nullspace()]


def _sign_order(m, a0, dirs, lam, time) -> ChainOrder | None:
    """Order m ruled out exactly when no member of the family has coefficients of one
    sign (None when some member has, or the alternative is undecided).

    A monic p with every root real and < 0 is Π (λ + r_i), r_i > 0: every coefficient
    positive. In discrete time (roots in (−1, 1)) the same holds for
    p̃(μ) = (μ − 1)ᵐ p((μ + 1)/(μ − 1)) = Π ((1 − λ_i) μ + (1 + λ_i)). The coefficients are
    linear in (s, t) for s p0 + Σ t_j d_j, so "some member has them all positive" is
    A (s, t) > 0 for a rational A (s > 0 follows: s is the leading coefficient of p, and
    p̃(1) = 2ᵐ s), and Gordan's alternative gives a certificate y ≥ 0, y ≠ 0,
    yᵀ A = 0 when none has (:func:`gordan_alternative`, verified exactly)."""
    gens = [sp.expand(lam ** m - sum(a0[i] * lam ** i for i in range(m)))]
    gens += [sp.expand(-sum(v[i] * lam ** i for i in range(m))) for v in dirs]
    if time != "continuous":
        mu = sp.Dummy("mu")
        gens = [sp.expand(sp.cancel(g.subs(lam, (mu + 1) / (mu - 1)) * (mu - 1) ** m)
                          ).subs(mu, lam) for g in gens]
    A = sp.Matrix([[sp.Poly(g, lam).coeff_monomial(lam ** i) for g in gens]
                   for i in range(m + 1)])
    if not all(e.is_Rational for e in A):
        return None
    alt = gordan_alternative(A)
    if not alt.infeasible:
        return None
    what = ("p(λ)" if time == "continuous" else
            f"(μ − 1)^{m} p((μ + 1)/(μ − 1))")
    roots = "real and < 0" if time == "continuous" else "real in (−1, 1)"
    y = ", ".join(str(e) for e in alt.y)
    return ChainOrder(m, "signs", len(dirs), None, (),
                      f"m = {m}: a {len(dirs)}-parameter family of p; no member has the"
                      f" coefficients of {what} all of one sign (Gordan: y = ({y}) ≥ 0 annuls"
                      f" them on the whole family), but every root {roots} makes them all"
                      f" positive: no Jordan model of order {m}")


def _symbolic_chain(A, B, m, lam, tries, dec, defaults, time) -> ChainOrder:
    """:func:`chain_order` over QQ(parameters): "empty" (generically), or the unique member
    / a member through ``d`` of the ``tries`` whose numerator splits into distinct linear
    factors in λ, each root stable at the defaults; otherwise "symbolic" (undecided)."""
    X0 = solve_left(A, B)
    basis, rk = left_null_space(A)
    conds = frozenset(rk.conditions)
    where = (f" (for parameters with {', '.join(sorted(str(c.lhs) for c in conds))} nonzero)"
             if conds else "")
    if X0 is None:
        return ChainOrder(m, "empty", -1, None, (), f"m = {m}: M F^{m} ∉ rowspace [M, …,"
                          f" M F^{m - 1}; H, …, H F^{m}]" + (" with r(s) L = 0" if dec else "")
                          + f"{where}: no model of order {m}", conds)
    a0 = [sp.cancel(X0[0, i]) for i in range(m)]
    dirs = _independent([[sp.cancel(v[0, i]) for i in range(m)] for v in basis])
    d = len(dirs)

    def poly(a):
        return sp.expand(lam ** m - sum(a[i] * lam ** i for i in range(m)))

    def split(p):
        num, _ = sp.fraction(sp.cancel(sp.together(p)))
        _, facs = sp.factor_list(num, lam)
        rts = []
        for f, mult in facs:
            deg = sp.degree(f, lam)
            if deg == 0:
                continue
            if deg > 1 or mult > 1:
                return ()
            c1, c0 = sp.Poly(f, lam).all_coeffs()
            rts.append(sp.cancel(-c0 / c1))
        if len(rts) != m or any(sp.cancel(r - q) == 0 for r, q in itertools.combinations(rts, 2)):
            return ()
        nominal = [r.subs(defaults) for r in rts]
        if any(v.free_symbols or not v.is_real or not is_stable(v, time) for v in nominal):
            return ()  # no defaults, or not stable at them: not used
        return tuple(rts)

    if d >= m:
        return ChainOrder(m, "free", d, None, (), f"m = {m}: every monic p of degree {m}"
                          f"{where}", conds)
    cands = [poly(a0)] if d == 0 else []
    for subset in itertools.islice(itertools.combinations(tries, d), MAX_SUBSETS) if d else ():
        a = _pinned(a0, dirs, subset, poly(a0), lam)
        if a is not None:
            cands.append(poly([sp.cancel(v) for v in a]))
    for p in cands:
        rts = split(p)
        if rts:
            return ChainOrder(m, "symbolic", d, p, rts,
                              f"m = {m}: " + ("one p" if d == 0 else f"a {d}-parameter family"
                                              " of p; a member") + f"{where}: p(λ) ="
                              f" {sp.factor(p)}, roots {', '.join(map(str, rts))} (stable at the"
                              " parameter defaults)", conds)
    return ChainOrder(m, "symbolic", d, cands[0] if d == 0 else None, (),
                      f"m = {m}: " + (f"one p(λ) = {sp.factor(cands[0])}" if d == 0 else
                                      f"a {d}-parameter family of p") + f"{where}; no member"
                      " splits into distinct linear factors over the parameters with roots"
                      " stable at their defaults (undecided for symbolic parameters)", conds)


def _pinned(a0, dirs, subset, p0, lam):
    """The coefficients a (p = λᵐ − Σ a_i λⁱ) of the member of a0 + span(dirs) with
    p(v) = 0 for each v of the subset (d linear equations in the d directions' weights),
    exactly; None when they do not determine it. ``p0`` is the polynomial of a0."""
    m, d = len(a0), len(dirs)
    Bm = sp.Matrix([[sum(dirs[r][i] * v ** i for i in range(m)) for r in range(d)]
                    for v in subset])
    if exact_rank(Bm).rank < d:
        return None
    w = Bm.LUsolve(sp.Matrix([p0.subs(lam, v) for v in subset]))
    return [a0[i] + sum(w[r] * dirs[r][i] for r in range(d)) for i in range(m)]


def hyperplane_functional(m, a0, dirs) -> list:
    """The hyperplane of monic p as a linear form ℓ on polynomials of degree ≤ m with
    ℓ(p) = 0 exactly for its members: ``[ℓ(1), ℓ(λ), …, ℓ(λᵐ)]``.

    p = λᵐ − Σ a_i λⁱ with a ∈ a0 + span(dirs) (m − 1 directions): the one functional
    of :func:`_annihilators`."""
    return _annihilators(m, a0, dirs)[0]


def hyperplane_corners(ell, time: str) -> tuple:
    """Decide a hyperplane of monic p of degree m = len(ell) − 1 (ℓ(p) = 0, ``ell`` =
    [ℓ(1), ℓ(λ), …, ℓ(λᵐ)]) exactly: (a member has m distinct real stable roots, evidence).

    With p = Π (λ − λ_i), ℓ(p) is multi-affine and symmetric in the roots. Map the stable
    region onto (−1, 1) by λ_i = (μ_i + 1)/(μ_i − 1) (continuous) or λ_i = μ_i (discrete):
    N(μ) = ℓ(Π_i ((μ_i − 1) λ − (μ_i + 1))) = ℓ(p) Π (μ_i − 1) is multi-affine in μ and
    Π (μ_i − 1) keeps one sign on the box. A non-constant multi-affine function has no
    interior extremum (it is affine in each μ_i), so it maps the open box — and, by symmetry
    and density, the convex chamber μ_1 < … < μ_m — onto the open interval between its
    least and greatest corner value. Corner j (j roots at 0 and m − j at −∞) gives
    N = (−2)ᵐ ℓ(λʲ) (continuous); discrete, j roots at 1 and m − j at −1:
    ℓ((λ − 1)ʲ (λ + 1)^{m−j}). So a member exists iff the corner values take both strict
    signs."""
    vals = _corner_values(ell, time)
    corner = ("ℓ(λʲ), j = 0…m" if time == "continuous" else
              "ℓ((λ − 1)ʲ (λ + 1)^(m−j)), j = 0…m")
    text = (f"the p form a hyperplane ℓ(p) = 0 (one linear condition); at the corners of the"
            f" stable region {corner} = {', '.join(map(str, vals))}")
    if any(v > 0 for v in vals) and any(v < 0 for v in vals):
        return True, text + ": both signs, so ℓ(p) = 0 for some m distinct stable real roots"
    return False, (text + ": one sign, so ℓ(Π (λ − λ_i)) never vanishes for distinct stable"
                   " real λ_i (ℓ is multi-affine in the roots: no interior extremum)")


def _corner_values(ell, time) -> list:
    m = len(ell) - 1
    if time == "continuous":
        return list(ell)
    out = []
    for j in range(m + 1):
        q = sp.Poly((_LAM - 1) ** j * (_LAM + 1) ** (m - j), _LAM).all_coeffs()[::-1]
        out.append(sum(ell[i] * q[i] for i in range(m + 1)))
    return out


_LAM = sp.Symbol("lambda")


def hyperplane_member(ell, time: str, lam, accept=None):
    """A member of the hyperplane ℓ(p) = 0 with m distinct real stable roots, exactly, when
    :func:`hyperplane_corners` says one exists (else None): walk from a corner of one sign
    to one of the other, moving one root at a time from near one end of the stable region
    to near the other (ε = 10⁻¹, 10⁻², …); ℓ is affine in the moving root, so where the
    sign changes the root solving ℓ = 0 is rational and lies between its two ends.
    ``accept(p)`` (default: m distinct real stable roots) checks each candidate."""
    m = len(ell) - 1
    vals = _corner_values(ell, time)
    if not (any(v > 0 for v in vals) and any(v < 0 for v in vals)):
        return None
    if accept is None:
        def accept(p):
            return _stable_distinct_roots(p, lam, m, time)
    first = next(j for j, v in enumerate(vals) if v != 0)
    hi = next(j for j in range(m + 1) if vals[j] != 0 and (vals[j] > 0) != (vals[first] > 0))
    lo = max(j for j in range(hi) if vals[j] != 0)  # the last strict sign before hi

    def ellp(roots):
        q = sp.Poly(sp.Mul(*[(lam - r) for r in roots]), lam).all_coeffs()[::-1]
        return sum(ell[i] * q[i] for i in range(m + 1))

    for e in range(1, 13):
        eps = sp.Rational(1, 10 ** e)
        if time == "continuous":
            near0 = [-eps * (i + 1) for i in range(m)]  # the corner end "root at 0"
            far = [-(i + 1) / eps for i in range(m)]  # "root at −∞"
        else:
            near0 = [1 - eps * (i + 1) for i in range(m)]  # "root at 1"
            far = [-1 + eps * (i + 1) for i in range(m)]  # "root at −1"
        path = [near0[:j] + far[j:] for j in range(lo, hi + 1)]
        signs = [ellp(r) for r in path]
        if 0 in (signs[0], signs[-1]) or (signs[0] > 0) == (signs[-1] > 0):
            continue  # ε not yet small enough for the corners' signs
        for s in range(len(path) - 1):
            a, b = signs[s], signs[s + 1]
            if b == 0:
                cand = path[s + 1]
            elif (a > 0) != (b > 0):
                c = lo + s  # root c moves from far[c] to near0[c]
                rest = path[s][:c] + path[s][c + 1:]
                q = sp.Poly(sp.Mul(*[(lam - r) for r in rest]), lam).all_coeffs()[::-1]
                lq = sum(ell[i] * q[i] for i in range(m))  # ℓ(q)
                lqx = sum(ell[i + 1] * q[i] for i in range(m))  # ℓ(λ q)
                if lq == 0:
                    continue
                cand = rest + [lqx / lq]
            else:
                continue
            p = sp.expand(sp.Mul(*[(lam - r) for r in cand]))
            if accept(p):
                return p
    return None


def _stable_distinct_roots(p, lam, m, time) -> tuple:
    """The m distinct real stable roots of p (exact), or ()."""
    if sp.degree(sp.gcd(p, sp.diff(p, lam)), lam) > 0:
        return ()  # a repeated root
    _, facs = sp.factor_list(p, lam)
    rts = exact_real_roots([f for f, _ in facs], lam)
    if len(rts) == m and all(is_stable(r, time) for r in rts):
        return tuple(rts)
    return ()


def _pencil_order(m, p0, p1, lam, time, roots_ok) -> ChainOrder:
    """Decide the one-parameter family p0 + t p1 (p1 of degree < m, so every member has
    degree m) exactly: its roots collide only where the discriminant in λ vanishes and
    cross the stability boundary only where p(0) = 0 (continuous) or p(±1) = 0 (discrete);
    between consecutive such t (roots in t, isolated exactly) whether all m roots are
    real, distinct and stable does not change, so one rational t per interval decides."""
    t = sp.Symbol("t")
    pt = sp.expand(p0 + t * p1)
    disc = sp.discriminant(sp.Poly(pt, lam)).as_expr()
    fam = f"the p form the line p0 + t p1, p0 = {sp.factor(p0)}, p1 = {sp.factor(p1)}"
    if sp.expand(disc) == 0:
        return ChainOrder(m, "line", 1, None, (), f"m = {m}: {fam}; every member has a"
                          " repeated root")
    edges = _stability_edges(time)
    crit = sp.Mul(disc, *[pt.subs(lam, e) for e in edges])
    pts = _cell_points([sp.Poly(sp.expand(crit), t)])
    for v in pts:
        p = sp.expand(pt.subs(t, v))
        rts = roots_ok(p)
        if rts:
            return ChainOrder(m, "line", 1, p, rts, f"m = {m}: {fam}; at t = {v}: p(λ) ="
                              f" {sp.factor(p)}")
    return ChainOrder(m, "line", 1, None, (),
                      f"m = {m}: {fam}; no t gives only real, distinct, stable roots (checked"
                      f" at one t in each of the {len(pts)} intervals cut by the"
                      f" {len(pts) - 1} t where roots collide or cross the stability boundary)")


def plane_order(m, p0, dirs, lam, time: str, roots_ok=None) -> ChainOrder:
    """Decide the plane p0 + t1 p1 + t2 p2 (p1, p2 of degree < m) exactly by a cylindrical
    decomposition: whether p_t has m distinct real stable roots can change only on the
    curve crit(t1, t2) = 0 (discriminant in λ times p(0), or p(1) p(−1)). Over an interval
    of t1 free of the real roots of R(t1) — the leading coefficients and discriminants in
    t2 of crit's factors, their pairwise resultants, and its factors free of t2 — the real
    roots in t2 of crit(t1, ·) move continuously without meeting, so the sectors between
    them keep the property. The set of good t is open: if it is not empty it meets a
    sector over some such interval, and the line at one rational t1 per interval
    (:func:`_pencil_order`, exact) finds it."""
    if roots_ok is None:
        def roots_ok(p):
            return _stable_distinct_roots(p, lam, m, time)
    t1, t2 = sp.symbols("t1 t2")
    p1, p2 = dirs
    pt = sp.expand(p0 + t1 * p1 + t2 * p2)
    fam = (f"the p form the plane p0 + t1 p1 + t2 p2, p0 = {sp.factor(p0)}, p1 ="
           f" {sp.factor(p1)}, p2 = {sp.factor(p2)}")
    disc = sp.expand(sp.discriminant(sp.Poly(pt, lam)).as_expr())
    if disc == 0:
        return ChainOrder(m, "plane", 2, None, (), f"m = {m}: {fam}; every member has a"
                          " repeated root")
    edges = _stability_edges(time)
    crit = sp.expand(sp.Mul(disc, *[pt.subs(lam, e) for e in edges]))
    _, facs = sp.factor_list(crit, t1, t2)
    curves = [sp.Poly(f, t2) for f, _ in facs if sp.degree(f, t2) > 0]
    R = [sp.Poly(f, t1) for f, _ in facs if sp.degree(f, t2) == 0 and sp.degree(f, t1) > 0]
    for i, f in enumerate(curves):
        R.append(sp.Poly(f.LC(), t1))
        if f.degree() > 1:
            R.append(sp.Poly(sp.discriminant(f.as_expr(), t2), t1))
        for g in curves[i + 1:]:
            R.append(sp.Poly(sp.resultant(f.as_expr(), g.as_expr(), t2), t1))
    pts = _cell_points(R)
    for v in pts:
        line = _pencil_order(m, sp.expand(p0 + v * p1), p2, lam, time, roots_ok)
        if line.lambdas:
            return ChainOrder(m, "plane", 2, line.polynomial, line.lambdas,
                              f"m = {m}: {fam}; at t1 = {v}: p(λ) = {sp.factor(line.polynomial)}")
    return ChainOrder(m, "plane", 2, None, (),
                      f"m = {m}: {fam}; no t gives only real, distinct, stable roots (decided"
                      f" exactly on the line t1 = c for one rational c in each of the"
                      f" {len(pts)} intervals cut by the {len(pts) - 1} real roots of the"
                      " projection polynomial of the curve where roots collide or cross the"
                      " stability boundary)")


def _cell_points(polys) -> list:
    """One rational point in each open interval of the line cut by the real roots of the
    product of ``polys`` (univariate); [0] when there is no real root (one interval)."""
    polys = [q for q in polys if q.degree() > 0]
    if not polys:
        return [sp.Integer(0)]
    # disjoint isolating intervals of the roots of all of them (sympy isolates each and
    # separates the overlaps: far cheaper than isolating the product, whose roots crowd)
    ends = sorted((sp.Rational(a), sp.Rational(b)) for (a, b), _ in sp.intervals(polys))
    if not ends:
        return [sp.Integer(0)]
    points = [ends[0][0] - 1]
    for (_, hi), (lo, _) in zip(ends, ends[1:]):
        if hi < lo:
            points.append((hi + lo) / 2)
        elif hi == lo and all(q(hi) != 0 for q in polys):  # touching at a non-root
            points.append(hi)
        else:  # pragma: no cover - (not expected) the product's roots, isolated apart
            prod = polys[0]
            for q in polys[1:]:
                prod = prod * q
            ends = _separated_roots(prod.sqf_part())
            return ([ends[0][0] - 1] + [(ends[i][1] + ends[i + 1][0]) / 2
                                        for i in range(len(ends) - 1)] + [ends[-1][1] + 1])
    return points + [ends[-1][1] + 1]


def _separated_roots(poly) -> list:
    """Isolating intervals [a, b] of the real roots of a squarefree polynomial, ascending and
    strictly apart (b_i < a_{i+1}: an interval may end exactly on the next root, which is
    then refined away)."""
    eps = None
    while True:
        ivs = poly.intervals() if eps is None else poly.intervals(eps=eps)
        ends = sorted((sp.Rational(a), sp.Rational(b)) for (a, b), _ in ivs)
        if all(ends[i][1] < ends[i + 1][0] for i in range(len(ends) - 1)):
            return ends
        eps = sp.Rational(1, 10) if eps is None else eps / 1000


def _sampled_subsets(m, d, a0, dirs, time):
    """Seeded random sets of d rational stable λ whose pinned member has, in floating point,
    m − d further roots that are real, distinct and stable with a margin (the exact check
    follows): log-uniform over 10⁻² … 10^2.5 (continuous), uniform in (−0.95, 0.95)
    (discrete), two significant digits."""
    rng = np.random.default_rng(20261123)
    A0 = np.array([float(v) for v in a0])
    Dn = np.array([[float(v) for v in r] for r in dirs])
    for _ in range(SAMPLES):
        if time == "continuous":
            vals = -10.0 ** rng.uniform(-2, 2.5, d)
        else:
            vals = rng.uniform(-0.95, 0.95, d)
        vals = np.array([float(f"{v:.2g}") for v in vals])
        if len(set(vals)) < d:
            continue
        V = np.vander(vals, m, increasing=True)  # V[j, i] = v_j^i
        B = V @ Dn.T
        rhs = vals ** m - V @ A0
        try:
            w = np.linalg.solve(B, rhs)
        except np.linalg.LinAlgError:
            continue
        a = A0 + w @ Dn
        r = np.roots(np.concatenate([[1.0], -a[::-1]]))
        if np.max(np.abs(r.imag)) > 1e-9 * (1 + np.max(np.abs(r))):
            continue
        r = np.sort(r.real)
        if (np.min(np.diff(r)) <= 1e-6 * (1 + np.max(np.abs(r))) or
                (time == "continuous" and r.max() >= -1e-9) or
                (time != "continuous" and np.abs(r).max() >= 1 - 1e-9)):
            continue
        yield tuple(sp.Rational(f"{v:.2g}") for v in vals)


def spread_lambdas(time: str) -> list:
    """Stable λ over several orders of magnitude, tried (after the defaults) to pin a member
    of a family of chain polynomials whose other roots must come out stable."""
    if time == "continuous":
        return [sp.Rational(v) for v in ("-1/10", "-1/3", "-1/2", "-3/2", "-5/2", "-7", "-10",
                                         "-30", "-100")]
    return [sp.Rational(v) for v in ("0", "3/4", "9/10", "-1/2", "-1/4", "-3/4", "1/10",
                                     "-9/10", "99/100")]


def _independent(vectors) -> list:
    """A maximal independent subset (exact) of nonzero coefficient vectors."""
    out: list = []
    for v in vectors:
        if all(e == 0 for e in v):
            continue
        if exact_rank(sp.Matrix(out + [v])).rank == len(out) + 1:
            out.append(v)
    return out
