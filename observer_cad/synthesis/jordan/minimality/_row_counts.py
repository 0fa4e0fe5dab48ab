"""Can k rows give z = M x? Exact decisions for a few row counts above the least
(q = rank [M; H] − rank H) and one below a basis modulo the outputs (METHOD §2b): each
checks its preconditions, then hands the images of the rows modulo rowspace [M; H] to
the decision for their shape (a hyperplane family here; lines and planes of four, five
and six dimensions in their own modules).

References: METHOD §2b; seed 002 §2.
"""
from __future__ import annotations

import sympy as sp
from sympy.polys.matrices import DomainMatrix

from ....numerics import exact_rank, left_null_space
from .._lambda_search import (coefficient_rows, family_jump_lambdas, polynomial_row,
                               rank_drop_lambdas, span_pencil)
from ._clock import UNLIMITED
from ._families import family_order, monic_family
from ._q_plus_one_rows import q_plus_one_rows_in_four_dimensions
from ._q_plus_two_rows import (q_plus_two_rows_in_five_dimensions,
                               q_plus_two_rows_in_four_dimensions)
from ._rows_in_six_dimensions import rows_in_six_dimensions
from ._rows_verdict import RowsVerdict

__all__ = ["RowsVerdict", "q_plus_one_rows_possible", "basis_minus_one_rows_possible",
           "q_plus_two_rows_possible", "q_plus_three_rows_possible"]


def q_plus_one_rows_possible(F, H, L, M, lam, time: str, clock=UNLIMITED) -> RowsVerdict:
    """Decide exactly whether a Jordan model of z = M x with q + 1 rows can exist, in the
    case where the rows' images modulo rowspace [M; H] form a polynomial family of
    hyperplanes (METHOD §2b, "one more row").

    Let Q span the right null space of [M; H] (c columns) and V(λ) the rows Φ with
    Φ L = 0 and Φ (F − λI) ∈ rowspace H. Preconditions, each checked exactly (M is first
    reduced to q rows independent modulo H, which gives the same models): no row of any
    real stable λ lies in rowspace [M; H] outside rowspace H (E(λ) of :func:`q_rows_possible`
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
    line's partners (:func:`q_plus_one_rows_in_four_dimensions`). Otherwise not analysed."""
    return _rows_possible(F, H, L, M, lam, time, "more", clock)


def basis_minus_one_rows_possible(F, H, L, M, lam, time: str, clock=UNLIMITED) -> RowsVerdict:
    """Decide exactly whether a Jordan model of z = M x with n − rank H − 1 rows (one
    fewer than a basis modulo the outputs) can exist when each λ has one row (f = 1):
    the dual of :func:`q_plus_one_rows_possible` (METHOD §2b, "one row short").

    Same preconditions (no row inside rowspace [M; H] outside rowspace H, no family jump).
    k = n − rank H − 1 = q + c − 1 independent rows span z modulo H and c − 1 more
    directions, so their images Φ_i Q span a hyperplane w^⊥ of the c dimensions modulo
    rowspace [M; H]. With f = 1 each λ has one row, Φ = v(λ) up to scale, and its image
    γ(λ) = v(λ) Q is never 0 (precondition), so w·γ(λ_i) = 0 at k distinct real stable
    λ_i. With γ made primitive, p_w(λ) = γ(λ)·w is a linear family of polynomials of
    degree ≤ D = deg γ, decided as in :func:`q_plus_one_rows_possible`. Conversely k such roots give
    k rows with images in w^⊥; when they are independent modulo H they span z (the design
    checks and certifies that)."""
    return _rows_possible(F, H, L, M, lam, time, "short", clock)


def q_plus_two_rows_possible(F, H, L, M, lam, time: str, clock=UNLIMITED) -> RowsVerdict:
    """Decide exactly whether a Jordan model of z = M x with q + 2 rows can exist when the
    rows of each λ have a 2-dimensional image W(λ) modulo rowspace [M; H] in c = 4
    dimensions — 2-planes of R⁴, lines of P³ (METHOD §2b, "two more rows") — or in c = 5
    dimensions (:func:`q_plus_two_rows_in_five_dimensions`: the plane U then lies in one of finitely many
    3-spaces meeting every W(λ)), or in c = 6 (:func:`rows_in_six_dimensions`: U is the one plane that
    a curve of 4-vectors containing every W(λ) fixes, when that curve is unique).

    Same preconditions as :func:`q_plus_one_rows_possible` (M reduced to q rows; no row of a real
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
    return _rows_possible(F, H, L, M, lam, time, "plane", clock)


def q_plus_three_rows_possible(F, H, L, M, lam, time: str, clock=UNLIMITED) -> RowsVerdict:
    """Decide exactly whether a Jordan model of z = M x with q + 3 rows can exist when the
    rows of each λ have a 2-dimensional image W(λ) modulo rowspace [M; H] in c = 6
    dimensions (METHOD §2b, "Planes of six dimensions"): U, the 3-space of the rows'
    images, lies in a 4-space X(t) = ker ℓ0(t) ∩ ker ℓ1(t) for a pencil ℓ0 + λ ℓ1 of forms
    annihilating every W(λ) (a linear space of pencils, computed exactly), and the λ are the
    roots of u·γ(λ, t), γ spanning X(t) ∩ W(λ). A member with q + 3 real stable roots is
    searched (and rebuilt exactly, with the row of each λ); otherwise the family, which
    moves with t, is excluded by :func:`pencil_cover`. Same preconditions as
    :func:`q_plus_two_rows_possible`; a model of fewer rows extends to q + 3 by rows of further λ, so
    "impossible" rules out every order up to q + 3."""
    return _rows_possible(F, H, L, M, lam, time, "solid", clock)


def _rows_possible(F, H, L, M, lam, time: str, kind: str, clock=UNLIMITED) -> RowsVerdict:
    """The preconditions shared by the decisions (``kind``: "more" q + 1, "short"
    n − rank H − 1, "plane" q + 2, "solid" q + 3), checked exactly with ``clock``
    (:class:`ProofClock`) checked between them, then the decision for the shape of the
    images (:func:`_images_verdict`)."""
    F, H, L, M = (sp.Matrix(X) for X in (F, H, L, M))
    if set().union(*(X.free_symbols for X in (F, H, L, M))):
        return RowsVerdict(False, False, (), "not analysed: symbolic parameters")
    n = F.rows
    short = kind == "short"
    what = {"short": "one row short", "more": "one more row", "plane": "two more rows",
            "solid": "three more rows"}[kind]

    def no(why, k=0):
        return RowsVerdict(False, False, (), f"{what} not analysed: {why}", k)

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
    clock.check()
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
    clock.check()
    _, drop = rank_drop_lambdas(E, lam, time, "E(λ)", "rows inside rowspace [M; H]")
    if not drop.analysed:  # pragma: no cover - singular compressions (probability 0)
        return no(drop.evidence, k)
    for v in drop.stable:
        if any(not b[:, :M.rows].is_zero_matrix for b in left_null_space(E.subs(lam, v))[0]):
            return no(f"at λ = {v} a row lies inside rowspace [M; H]", k)
    clock.check()
    jumps = family_jump_lambdas(F, H, L0, lam, time)
    if not jumps.analysed or jumps.stable:
        return no("the family of rows grows at λ = " + ", ".join(map(str, jumps.stable))
                  if jumps.stable else jumps.evidence, k)
    clock.check()
    Q = sp.Matrix.hstack(*sp.Matrix.vstack(M, H).nullspace())
    G = (sp.Matrix.vstack(*rows) * Q).applyfunc(sp.expand) if rows else sp.zeros(0, c)
    if kind == "solid" or (kind == "plane" and c == 6):
        return rows_in_six_dimensions(G, k, lam, time, no, rows, kind, clock)
    if kind == "plane":
        if c == 4:
            return q_plus_two_rows_in_four_dimensions(G, k, lam, time, no, clock)
        return q_plus_two_rows_in_five_dimensions(G, k, lam, time, no, rows, clock)
    if lines:
        return q_plus_one_rows_in_four_dimensions(G, k, lam, time, no, clock)
    return _hyperplane_verdict(G, H, rows, k, c, lam, time, no, short, clock)


def _hyperplane_verdict(G, H, rows, k, c, lam, time, no, short, clock) -> RowsVerdict:
    """q + 1 rows (images on one line w) or n − rank H − 1 rows (images in a hyperplane
    w^⊥) once the preconditions hold: the p_w(λ) = ν(λ)·w (resp. γ(λ)·w) form a linear
    family of polynomials, decided by :func:`family_order`."""
    n = H.cols
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
        return RowsVerdict(True, False, (), f"{fam}: {name}(λ)·w has degree ≤ {D} < {k},"
                          f" so no choice of real stable λ gives {k} rows", k)
    if D > k:
        return no(f"{fam}: {name}(λ)·w has degree {D} > {k} (at least {k} of its roots"
                  " stable: not decided)", k)
    m = D
    a0, dirs = monic_family(polys, m, lam)
    order = family_order(m, a0, dirs, lam, time, clock=clock)
    if order.lambdas:
        return RowsVerdict(True, True, tuple(order.lambdas), f"{fam}: {order.evidence}", k)
    if order.verdict == "free" and order.dim >= m:  # every monic p of degree m
        return RowsVerdict(True, True, (), f"{fam}: {order.evidence}", k)
    if not order.decided:
        return no(f"{fam}: {order.evidence}", k)
    return RowsVerdict(True, False, (), f"{fam}: {order.evidence}, so no choice of real"
                      f" stable λ gives {k} rows", k)
