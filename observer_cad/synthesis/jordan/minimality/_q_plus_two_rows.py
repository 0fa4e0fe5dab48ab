"""q + 2 rows when the rows of each λ have planes W(λ) as images modulo rowspace
[M; H] in four or five dimensions (METHOD §2b, "Two more rows", "Two more rows in five
dimensions").

References: METHOD §2b.
"""
from __future__ import annotations

import itertools

import sympy as sp
from sympy.polys.matrices import DomainMatrix

from ....numerics import exact_rank
from .._lambda_search import coefficient_rows
from ._box_cover import quadric_cover
from ._clock import UNLIMITED
from ._rows_verdict import RowsVerdict
from ._exterior import pair_minors, perm_sign, plucker
from ._families import family_order, monic_family
from ._roots import stable_root_count

__all__ = ["q_plus_two_rows_in_four_dimensions", "q_plus_two_rows_in_five_dimensions",
           "rows_into"]


def q_plus_two_rows_in_four_dimensions(G, k, lam, time, no, clock=UNLIMITED) -> RowsVerdict:
    """:func:`q_plus_two_rows_possible` once its preconditions hold: ``G`` (2 × 4) the images of a
    polynomial basis of the rows of λ modulo rowspace [M; H]."""
    pi, Om = plucker(G, lam)
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
        return RowsVerdict(True, False, (), f"{fam}: p_U ∧ π(λ) has degree ≤ {D} < {k} and"
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
    cover = quadric_cover(k, form, time, equality=not kernel, clock=clock)
    if cover.proven:
        return RowsVerdict(True, False, (), f"{fam}; a plane exists iff {need}: {cover.evidence},"
                          f" so no choice of real stable λ gives {k} rows", k)
    if cover.found is not None:
        lams = [(x + 1) / (x - 1) if time == "continuous" else x for x in cover.found]
        return no(f"{fam}; a plane exists iff {need}, which holds at λ ≈"
                  f" ({', '.join(f'{v:.4g}' for v in lams)}): {k} rows are not ruled out", k)
    return no(f"{fam}; a plane exists iff {need}: {cover.evidence}", k)


def q_plus_two_rows_in_five_dimensions(G, k, lam, time, no, basis_rows,
                                       clock=UNLIMITED) -> RowsVerdict:
    """:func:`q_plus_two_rows_possible` for planes W(λ) of c = 5 dimensions (lines of P⁴) once its
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
    pi = pair_minors(G, lam)
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
                T[row * (D + 1) + e, i] += perm_sign(S + S2) * cf
    if exact_rank(T).rank < len(pairs):
        return no(f"{fam}, but some p ≠ 0 has p ∧ π(λ) ≡ 0 (a plane may meet every W(λ))", k)
    coef = sp.Matrix([list(cf) for r in range(G.rows) for cf in coefficient_rows(G[r, :], lam)])
    if exact_rank(coef).rank < c:
        return no(f"{fam}, but every W(λ) lies in one hyperplane", k)
    if D <= k:
        return RowsVerdict(True, False, (), f"{fam}: p_U ∧ π(λ) ≢ 0 has degree ≤ {D}, so {k}"
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
            A[e, trips.index(Sc)] += perm_sign(Sc + S) * cf
    basis = A.nullspace()
    head = (f"{fam}; p_U ∧ π(λ) = p(λ) ℓ(λ) with ℓ linear puts U in a 3-space X meeting"
            " every W(λ)")
    if not basis:
        return RowsVerdict(True, False, (), f"{head}, and no 3-space meets every W(λ): no"
                          f" choice of real stable λ gives {k} rows", k)
    points = _solid_points(basis, trips, pairs, quads, clock)
    if points is None:
        return no(f"{head}; the 3-spaces X (on G(3, 5)) are not found as finitely many points"
                  " in shape position (not decided)", k)
    parts, found = [], None
    for field, p_X in points:
        verdict = _solid_verdict(field, p_X, pi, pairs, trips, k, lam, time, clock)
        if verdict[0] == "open":
            return no(f"{head}; {verdict[1]} (not decided)", k)
        parts.append(verdict[1])
        if verdict[0] == "possible" and found is None:
            found = verdict[2:]
    text = f"{head}; {len(points)} such X (conjugate sets): " + "; ".join(parts)
    if found is not None:
        lams, y = found
        return RowsVerdict(True, True, tuple(lams), text, k,
                          rows_into(G, basis_rows, y, lams, lam))
    return RowsVerdict(True, False, (), f"{text}: no choice of real stable λ gives {k} rows", k)


def _solid_points(basis, trips, pairs, quads, clock=UNLIMITED):
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
        clock.check()
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


def _solid_verdict(field, p_X, pi, pairs, trips, k, lam, time, clock=UNLIMITED) -> tuple:
    """("none" | "possible" | "open", text[, λ]) for one (conjugate set of) 3-space X of
    :func:`q_plus_two_rows_in_five_dimensions`."""
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
        if stable_root_count(Zq, time) > 0:
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
    a0, dirs = monic_family([sp.Poly(v.as_expr(), lam) for v in gam if not v.is_zero], m, lam)
    order = family_order(m, a0, dirs, lam, time, clock=clock)
    text = f"X rational: X ∩ W(λ) traces a curve of degree {m}: {order.evidence}"
    if order.lambdas:
        return ("possible", text, order.lambdas, [K.to_sympy(e) for e in Yr[use]])
    return ("none", text) if order.impossible else ("open", text)


def _hodge_dual(pX, pairs, trips) -> dict:
    """The 2-vector ω of a 3-vector p_X of R⁵ (ω_S = ε(S^c S) p_X[S^c]): decomposable
    together, and ω = y_1 ∧ y_2 for X^⊥ = span(y_1, y_2)."""
    rest = {S: tuple(sorted(set(range(5)) - set(S))) for S in pairs}
    return {S: perm_sign(rest[S] + S) * pX[trips.index(rest[S])] for S in pairs}


def rows_into(G, basis_rows, y, lams, lam) -> tuple:
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
