"""q + 2 and q + 3 rows when the rows of each λ have planes W(λ) of six dimensions as
images modulo rowspace [M; H] (METHOD §2b, "Planes of six dimensions"): a plane fixed by
the unique curve of 4-vectors, or a 3-space inside the kernel of a pencil of forms.

References: METHOD §2b.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import sympy as sp

from ....numerics import exact_rank
from .._lambda_search import coefficient_rows
from ._box_cover import pencil_cover
from ._clock import UNLIMITED
from ._rows_verdict import RowsVerdict
from ._exterior import pair_minors, perm_sign
from ._families import family_order, monic_family
from ._q_plus_two_rows import rows_into
from ._roots import separated_roots, stable_root_count

__all__ = ["rows_in_six_dimensions"]

#: angles θ of the pencil parameter t = tan θ searched for a member (q + 3 rows)
_PENCIL_ANGLES = 96
#: float members rebuilt exactly at most, the least stiff first (q + 3 rows)
_PENCIL_EXACT = 20


def rows_in_six_dimensions(G, k, lam, time, no, basis_rows, what,
                           clock=UNLIMITED) -> RowsVerdict:
    """:func:`q_plus_two_rows_possible` (k = q + 2, ``what`` "plane") and :func:`q_plus_three_rows_possible`
    (k = q + 3, "solid") for planes W(λ) of c = 6 dimensions once their preconditions hold
    (METHOD §2b, "Planes of six dimensions"). The images of a model's k rows span a space
    U of dimension e = k − q (2 or 3) meeting W(λ_i) at k real stable λ_i (at most one row
    at each when no W(λ) lies in the spaces below); P_U(λ) = p_U ∧ π(λ) ∈ Λ^(e+2)R⁶ is the
    (e + 2)-vector of U + W(λ), so P_U = p(λ) ℓ(λ) with deg ℓ ≤ d = D − k and
    ℓ(λ) ∧ w = 0 for w ∈ W(λ): ℓ lies in the linear space L_d of such curves, and U in the
    space they all contain. Requirements (else not analysed): no p ≠ 0 has p ∧ π ≡ 0 and
    the W(λ) span R⁶."""
    c = 6
    pi = pair_minors(G, lam)
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
            sign = perm_sign(S + S2)
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
        return RowsVerdict(True, False, (), f"{fam}: P_U = p_U ∧ π(λ) ≢ 0 has degree ≤ {D}, so"
                          f" {k} roots leave a factor ℓ of degree {max(d, 0)}"
                          + (" (none)" if d < 0 else ", a fixed form annihilating every W(λ),"
                             " which span R⁶") + f": no choice of real stable λ gives {k} rows",
                          k)
    if what == "plane":
        return _fixed_plane_verdict(G, pim, pairs, k, d, lam, time, no, fam, clock)
    if d > 1:
        return no(f"{fam}: P_U = p_U ∧ π(λ) has degree {D} > {k + 1} (not decided)", k)
    return _pencil_verdict(G, pim, k, lam, time, no, fam, basis_rows, clock)


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
                sign = perm_sign(S + (a,))
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
                rows[key][a] += perm_sign(S + (a,)) * v
    if not rows:
        return [sp.Matrix(sp.eye(c)[i, :]) for i in range(c)]
    return [v.T for v in sp.Matrix(list(rows.values())).nullspace()]


def _fixed_plane_verdict(G, pim, pairs, k, d, lam, time, no, fam, clock=UNLIMITED) -> RowsVerdict:
    """k = q + 2 rows in six dimensions: U is a plane, ℓ(λ) a curve of 4-vectors of
    degree ≤ d containing W(λ) and U."""
    clock.check()
    _, L = _wedge_rows(G, 4, d, lam)
    head = f"{fam}; P_U = p(λ) ℓ(λ), ℓ of degree ≤ {d} with ℓ(λ) ⊇ W(λ) and U"
    if not L:
        return RowsVerdict(True, False, (), f"{head}, and no such ℓ ≠ 0 exists: no choice of"
                          f" real stable λ gives {k} rows", k)
    if len(L) > 1:
        return no(f"{head}: such ℓ form a {len(L)}-dimensional space (not decided)", k)
    Y = _contained(L[0])
    if len(Y) < 2:
        return RowsVerdict(True, False, (), f"{head}: ℓ is unique up to scale and the vectors"
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
            comps[key] = comps.get(key, sp.Poly(0, lam)) + P * (perm_sign(S + S2) * v)
    g = sp.Poly(0, lam)
    for P in comps.values():
        g = g.gcd(P) if not P.is_zero else g
    if g.is_zero:  # pragma: no cover - excluded by T injective
        return no(f"{head}: the plane Y meets every W(λ)", k)
    count = sum(mult * stable_root_count(f, time) for f, mult in g.sqf_list()[1])
    poly = sp.factor(g.as_expr())
    text = (f"{head}: ℓ is unique up to scale and fixes U = Y, the plane every ℓ(λ)"
            f" contains, which meets W(λ) at the roots of {poly}, {count} of them real and"
            " stable counted with multiplicity (a root of order r holds at most r rows)")
    if count < k:
        return RowsVerdict(True, False, (), f"{text}: no choice of real stable λ gives {k} rows",
                          k)
    return no(f"{text} (not decided: the rows there are not built)", k)


def _pencil_verdict(G, pim, k, lam, time, no, fam, basis_rows, clock=UNLIMITED) -> RowsVerdict:
    """k = q + 3 rows in six dimensions: U is a 3-space and P_U = p(λ) ℓ(λ) with ℓ a
    pencil ℓ0 + λ ℓ1 of forms annihilating U and W(λ) (5-vectors of U + W(λ)); the
    pencils form the linear space L_1, and U lies in X = ker ℓ0 ∩ ker ℓ1."""
    c = 6
    clock.check()
    _, L = _wedge_rows(G, 5, 1, lam)
    head = (f"{fam}; P_U = p(λ) ℓ(λ) with ℓ = ℓ0 + λ ℓ1 a pencil of forms annihilating U and"
            " every W(λ)")
    if not L:
        return RowsVerdict(True, False, (), f"{head}, and no such pencil exists: no choice of"
                          f" real stable λ gives {k} rows", k)
    if len(L) > 2:
        return no(f"{head}: the pencils form a {len(L)}-dimensional space (not decided)", k)

    def form(part):  # the 5-vector Σ ℓ_S e_S as the form x ↦ ℓ ∧ x
        full = tuple(range(c))
        return [perm_sign(tuple(i for i in full if i != a) + (a,))
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
        return RowsVerdict(True, False, (), f"{head}; {X_txt} < {k}: no choice of real stable"
                          f" λ gives {k} rows", k)
    if g > k:
        return no(f"{head}; {X_txt} > {k} (not decided)", k)
    mats = [sp.Matrix([[sp.Poly(x, lam).coeff_monomial(lam ** i) for i in range(k + 1)]
                       for x in gam]) for _, _, gam in gammas]
    bad = _pencil_signs(mats[0], t, k, time) if len(gammas) == 2 else None
    clock.check()
    found = _pencil_member(gammas, k, lam, t, time, bad, clock)
    if found is not None:
        lams, b, where = found
        rows = rows_into(G, basis_rows, b, lams, lam)
        return RowsVerdict(True, True, tuple(lams), f"{head}; {X_txt}: at {where} a member has"
                          f" {k} real stable roots", k, rows)
    # W(λ) ⊂ X(t) only at the common zeros of γ(λ, t): none with λ real and stable allowed
    for name, b, gam in gammas:  # (a found member needs no such check: it is certified)
        clock.check()
        gb = sp.groebner([x for x in gam if x != 0], t, lam, order="lex").exprs
        if gb == [1]:
            continue
        last = sp.Poly(gb[-1], t, lam)
        if last.degree(t) > 0 or last.degree(lam) <= 0:
            return no(f"{head}: X({name}) contains W(λ) along a curve (not decided)", k)
        if stable_root_count(sp.Poly(gb[-1], lam), time) > 0:
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
            return RowsVerdict(True, False, (), f"{head}; {X_txt}; {signs}: no choice of real"
                              f" stable λ gives {k} rows", k)
        signs += "; there "
    clock.check()
    cover = pencil_cover(k, [(name, _kernel_functionals(Cm, t), iv) for (name, iv), Cm
                             in zip(charts, mats)], time, clock=clock)
    if not cover.proven:
        return no(f"{head}; {X_txt}: no member found, {signs}{cover.evidence} (not decided)", k)
    return RowsVerdict(True, False, (), f"{head}; {X_txt}; {signs}{cover.evidence}: no choice"
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
        ends = separated_roots(prod.sqf_part())
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


def _pencil_member(gammas, k, lam, t, time, bad, clock=UNLIMITED):
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
        clock.check()
        got = _exact_member([x.subs(t, tv) for x in gam], [grid[i] for i in pins], k, lam,
                            time)
        if got is not None:
            where = cname if len(gammas) == 1 else f"{cname} = {tv}"
            return got, [x.subs(t, tv) for x in b], where
    for tv in middles:
        polys = [sp.Poly(x.subs(t, tv), lam) for x in gam]
        a0, dirs = monic_family(polys, k, lam)
        order = family_order(k, a0, dirs, lam, time, clock=clock)
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
        if rest.discriminant() <= 0 or stable_root_count(rest, time) != 2:
            return None
        return list(pins) + sorted(sp.roots(rest.as_expr(), lam), key=lambda z: float(z))
    return None
