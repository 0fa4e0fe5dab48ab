"""Exact exclusion for an affine family of monic polynomials: no member has m distinct real
stable roots, proven by covering the root box with cells (METHOD §2b, "box cover").

The family is {monic p : ℓ_k(p) = 0, k = 1 … r}, ℓ_k linear functionals on the
coefficients. Map the stable roots to μ ∈ (−1, 1): λ = (μ + 1)/(μ − 1) (continuous;
μ → 1 is λ → −∞, μ → −1 is λ → 0) or λ = μ (discrete). Then

    g_k(μ) = ℓ_k(Π_i ((μ_i − 1) λ − (μ_i + 1)))     (continuous; Π_i (λ − μ_i) discrete)

is ℓ_k(p) times a factor of constant sign, and it is *multi-affine* in μ: affine in each
μ_i. On a closed cell (a product of intervals) a multi-affine map is a convex combination
of its values at the cell's vertices (the weights Π t_i or (1 − t_i) are ≥ 0 and sum to
1), so if some c has c·g(v) > 0 at every vertex v, g ≠ 0 on the whole cell. g is
symmetric, so cells covering the ordered chamber −1 ≤ μ_1 ≤ … ≤ μ_m ≤ 1 cover every
root set; when each of them has such a c, no member has its m roots real and stable
(distinct or not). Cells are split in halves until every one is excluded or the budget
is spent (then: undecided).

Exactness: the cells' corners are dyadic, μ = 2u/2ᴶ − 1, and g is evaluated in integers
(each factor scaled by the positive 2ᴶ); c is found by a float linear programme for each
cell and c·g(v) > 0 checked in integers at every vertex (:func:`positive_combination`)."""
from __future__ import annotations

import dataclasses
import itertools
import math

import sympy as sp

from ..numerics import positive_combination

__all__ = ["BoxCover", "box_cover", "BOX_CELLS", "BOX_DEPTH", "PROBES"]

#: cells examined at most before giving up (undecided)
BOX_CELLS = 6000

#: halvings of the initial cells at most
BOX_DEPTH = 7

#: initial cells per axis (2: the halves of (−1, 1))
_START = 2

#: cells not excluded that are probed after each halving, at most (spread over the list)
PROBES = 400


@dataclasses.dataclass(frozen=True)
class BoxCover:
    """``proven``: every cell of the ordered chamber was excluded (no member has all m
    roots real and stable); ``cells``: cells examined; ``depth``: halvings used;
    ``evidence``: one line; ``found``: what ``probe`` returned for a cell that could not
    be excluded (a member, so the family is possible), else None."""

    proven: bool
    cells: int
    depth: int
    evidence: str
    found: object = None


def _integer_rows(functionals) -> list:
    rows = []
    for f in functionals:
        vals = [sp.Rational(v) for v in f]
        den = math.lcm(*[int(v.q) for v in vals]) if vals else 1
        rows.append([int(v * den) for v in vals])
    return rows


def box_cover(m: int, functionals, time: str, *, max_cells: int = BOX_CELLS,
              max_depth: int = BOX_DEPTH, probe=None) -> BoxCover:
    """Try to prove that no monic p of degree m with ℓ_k(p) = 0 for every row ℓ_k of
    ``functionals`` (rational, m + 1 entries: the weights of the coefficients of λ⁰ … λᵐ)
    has m real stable roots (module docstring).

    ``probe(mu)``, optional: called with the centre (rationals μ_1 < … < μ_m) of up to
    :data:`PROBES` cells that are not excluded after each halving; a cell that cannot be
    excluded usually holds a member, so the probe (e.g. pinning roots there) may find it.
    Whatever truthy value it returns ends the cover (``found``)."""
    from scipy.optimize import linprog  # lazy: scipy costs ~0.3 s to import

    ell = _integer_rows(functionals)
    r = len(ell)
    if r == 0:
        return BoxCover(False, 0, 0, "no condition on p: every monic p is a member")
    levels = max_depth + int(math.log2(_START))
    top = 2 ** levels  # coordinates u ∈ [0, top], μ = 2u/top − 1
    cache: dict = {}

    def values(u):  # (ℓ_k(g(u)))_k in integers, g symmetric: cached on the sorted corner
        key = tuple(sorted(u))
        got = cache.get(key)
        if got is None:
            coef = [1] + [0] * m  # the coefficients of λ⁰ … λᵐ of the product
            for ui in key:
                if time == "continuous":  # (μ − 1) λ − (μ + 1), times top/2
                    a, b = ui - top, -ui
                else:  # λ − μ, times top/2
                    a, b = top // 2, top // 2 - ui
                new = [0] * (m + 1)
                for j, cj in enumerate(coef):
                    if cj:
                        new[j] += cj * b
                        if j + 1 <= m:
                            new[j + 1] += cj * a
                coef = new
            got = tuple(sum(w * cj for w, cj in zip(row, coef)) for row in ell)
            cache[key] = got
        return got

    last = [None]  # the combination that excluded the previous cell: often works again

    def excluded(lo, hi):
        V = [values(v) for v in set(itertools.product(*zip(lo, hi)))]
        hint = last[0]
        if hint is not None and all(sum(c * x for c, x in zip(hint, row)) > 0 for row in V):
            return hint
        c = positive_combination(V, linprog=linprog)
        if c is not None:
            last[0] = c
        return c

    def meets_chamber(lo, hi):  # some u_1 < … < u_m with lo_i ≤ u_i ≤ hi_i (cells are
        # closed and cover the box, so the cells meeting the open chamber cover it)
        x = lo[0]
        for a, b in zip(lo[1:], hi[1:]):
            if x >= b:
                return False
            x = max(x, a)
        return True

    step = top // _START
    cells = [(tuple(i * step for i in ix), tuple((i + 1) * step for i in ix))
             for ix in itertools.combinations_with_replacement(range(_START), m)]
    examined = 0
    for depth in range(max_depth + 1):
        left = []
        for lo, hi in cells:
            examined += 1
            if examined > max_cells:
                return BoxCover(False, examined - 1, depth,
                                f"not proven: {max_cells} cells examined, {len(left)} at depth"
                                f" {depth} not excluded yet")
            if excluded(lo, hi) is None:
                left.append((lo, hi))
        if not left:
            return BoxCover(True, examined, depth,
                            f"covered by {examined} cells of the ordered root box (μ ∈ [−1, 1]^{m},"
                            f" {depth} halvings): on each, a combination of the {r} conditions"
                            " is of one sign at every vertex, hence on the whole cell (multi-"
                            "affine), so no member has its roots real and stable")
        if probe is not None and depth >= 1:
            for lo, hi in left[::max(1, len(left) // PROBES)][:PROBES]:
                centre = tuple(sp.Rational(a + b, top) - 1 for a, b in zip(lo, hi))
                if len(set(centre)) < m:
                    continue
                got = probe(centre)
                if got:
                    return BoxCover(False, examined, depth, "a member found in a cell that"
                                    " could not be excluded", got)
        if depth == max_depth:
            break
        cells = []
        for lo, hi in left:
            if any(b - a < 2 for a, b in zip(lo, hi)):
                return BoxCover(False, examined, depth, "not proven: cells at the finest grid"
                                " are not excluded (a member may exist)")
            mid = tuple((a + b) // 2 for a, b in zip(lo, hi))
            for pick in itertools.product((0, 1), repeat=m):
                lo2 = tuple(md if p else a for p, a, md in zip(pick, lo, mid))
                hi2 = tuple(b if p else md for p, b, md in zip(pick, hi, mid))
                if meets_chamber(lo2, hi2):
                    cells.append((lo2, hi2))
    return BoxCover(False, examined, max_depth,
                    f"not proven: after {max_depth} halvings cells remain that are not excluded")
