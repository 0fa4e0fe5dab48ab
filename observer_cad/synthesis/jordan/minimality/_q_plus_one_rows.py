"""q + 1 rows when the rows of each λ have planes of R⁴ (lines of P³) as images modulo
rowspace [M; H] (METHOD §2b, "One more row through lines of P³"): three rows need three
lines of real stable λ meeting pairwise.

References: METHOD §2b.
"""
from __future__ import annotations

import sympy as sp
from sympy.polys.polyfuncs import symmetrize

from ...core import is_stable
from ._clock import UNLIMITED
from ._rows_verdict import RowsVerdict
from ._exterior import plucker
from ._roots import cell_points, stability_edges, stable_root_count

__all__ = ["q_plus_one_rows_in_four_dimensions"]


def q_plus_one_rows_in_four_dimensions(G, k, lam, time, no, clock=UNLIMITED) -> RowsVerdict:
    """:func:`q_plus_one_rows_possible` for q = 2 when the rows of each λ have a 2-dimensional image
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
    pi, Om = plucker(G, lam)
    if pi is None:
        return no("the images of the rows are dependent for λ generic", k)
    x, y = sp.symbols("x y")
    fam = ("modulo rowspace [M; H] the rows of λ span planes W(λ) of 4 dimensions (lines of"
           f" P³), Plücker vector π(λ) = ({', '.join(str(sp.factor(e)) for e in pi)}); {k} rows"
           f" need one w in W(λ_i) at {k} distinct real stable λ_i, so the lines meet pairwise")
    clock.check()
    P1 = sp.Matrix(pi)
    P2 = sp.Matrix([e.subs(lam, x) for e in pi])
    meet = sp.Poly(sp.expand((P1.T * Om * P2)[0]), lam, x)
    g, r = sp.div(meet, sp.Poly((lam - x) ** 2, lam, x))
    if not r.is_zero:  # pragma: no cover - excluded by the identity above
        return no(f"{fam}, but π(λ) ∧ π(x) is not divisible by (λ − x)²", k)
    if g.is_zero:
        return no(f"{fam}, and every two of the lines meet", k)
    if g.total_degree() == 0:
        return RowsVerdict(True, False, (), f"{fam}: π(λ) ∧ π(x) = {g.as_expr()} · (λ − x)²,"
                          " so no two lines meet and no choice of real stable λ gives"
                          f" {k} rows", k)
    if g.degree(x) == 2:  # each line meets at most two others: the partners, exactly
        verdict, text, lams = _partner_triples(g, lam, x, time, clock)
        if verdict == "impossible":
            return RowsVerdict(True, False, (), f"{fam}: {text}, so no choice of real stable"
                              f" λ gives {k} rows", k)
        if verdict == "possible":
            return RowsVerdict(True, True, lams, f"{fam}: {text}", k)
        return no(f"{fam}: {text}", k)
    clock.check()
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
    stable = stable_root_count(R, time)
    elim = (f"g(λ, x) = π(λ) ∧ π(x) / (λ − x)² = {sp.factor(g.as_expr())}; eliminating the"
            f" other two λ of a triple (resultants) leaves R(λ) of degree {R.degree()}")
    if stable == 0:
        return RowsVerdict(True, False, (), f"{fam}: {elim} with no real stable root (Sturm),"
                          f" so no choice of real stable λ gives {k} rows", k)
    return no(f"{fam}: {elim}, with {stable} real stable root(s): not decided", k)


def _partner_triples(g, lam, x, time, clock=UNLIMITED):
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
        return _porism_triple(g, lam, x, checks, time, where, clock)
    roots, fails = 0, []
    abc = [sp.Poly(e, lam) for e in (a, b, c)]
    conds = [(name, sp.Poly(e, lam)) for name, e in checks]
    for f, _m in h.factor_list()[1]:
        if f.degree() < 1:
            continue
        for (lo, hi), _ in f.intervals():
            clock.check()
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


def _porism_triple(g, lam, x, checks, time, where, clock=UNLIMITED):
    """h ≡ 0: a real stable λ_1 meeting every condition, or none (one rational point in
    each open interval between consecutive real roots of the conditions' polynomials and
    the stability boundary: their signs are constant there, and the set is open)."""
    polys = [sp.Poly(e, lam) for _, e in checks]
    boundary = sp.Poly(sp.Mul(*(lam - e for e in stability_edges(time))), lam)
    points = cell_points([boundary] + [q for q in polys if not q.is_zero])
    for t in points:
        clock.check()
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


def _stable_interval(f, lo, hi, time):
    """The isolating interval [lo, hi] of a real root of f refined until it lies inside
    the open stability region or outside it: (lo, hi), or (None, None) when the root is
    not stable (the boundary 0 or ±1 itself is not)."""
    bounds = stability_edges(time)
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
