"""Where the real roots of a polynomial lie with respect to the stability region (METHOD
§2b): exact counts (Sturm), the stability boundary, and one rational point in each
interval cut by real roots.
"""
from __future__ import annotations

import sympy as sp

__all__ = ["stability_edges", "stable_root_count", "cell_points", "separated_roots"]


def stability_edges(time: str) -> tuple:
    """The boundary of the stability region on the real line: 0 (continuous), ±1 (discrete)."""
    return (0,) if time == "continuous" else (1, -1)


def stable_root_count(R, time) -> int:
    """The number of distinct real roots of R in the open stability region (λ < 0, or
    −1 < λ < 1), exactly (Sturm sequences)."""
    R = R.sqf_part()
    if R.degree() <= 0:
        return 0
    if time == "continuous":
        return R.count_roots(-sp.oo, 0) - (R(0) == 0)
    return R.count_roots(-1, 1) - (R(-1) == 0) - (R(1) == 0)


def cell_points(polys) -> list:
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
            ends = separated_roots(prod.sqf_part())
            return ([ends[0][0] - 1] + [(ends[i][1] + ends[i + 1][0]) / 2
                                        for i in range(len(ends) - 1)] + [ends[-1][1] + 1])
    return points + [ends[-1][1] + 1]


def separated_roots(poly) -> list:
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
