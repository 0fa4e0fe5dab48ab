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
from fractions import Fraction
import itertools
import math

import sympy as sp

from ....numerics import positive_combination
from ._clock import UNLIMITED

__all__ = ["BoxCover", "box_cover", "quadric_cover", "BOX_CELLS", "BOX_DEPTH", "PROBES"]

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


def _factor(ui: int, top: int, time: str) -> tuple:
    """(constant, λ coefficient) of the root factor at u, times top/2: (μ − 1) λ − (μ + 1)
    (continuous) or λ − μ (discrete), μ = 2u/top − 1."""
    return (-ui, ui - top) if time == "continuous" else (top // 2 - ui, top // 2)


def _product(key, top, time, m) -> list:
    """The coefficients of λ⁰ … λᵐ of the product of the root factors at the u of key."""
    coef = [1] + [0] * m
    for ui in key:
        b, a = _factor(ui, top, time)
        new = [0] * (m + 1)
        for j, cj in enumerate(coef):
            if cj:
                new[j] += cj * b
                if j + 1 <= m:
                    new[j + 1] += cj * a
        coef = new
    return coef


def _meets_chamber(lo, hi) -> bool:
    """Some u_1 < … < u_m with lo_i ≤ u_i ≤ hi_i (cells are closed and cover the box, so
    the cells meeting the open chamber cover it)."""
    x = lo[0]
    for a, b in zip(lo[1:], hi[1:]):
        if x >= b:
            return False
        x = max(x, a)
    return True


def _halves(lo, hi, m) -> list:
    mid = tuple((a + b) // 2 for a, b in zip(lo, hi))
    out = []
    for pick in itertools.product((0, 1), repeat=m):
        lo2 = tuple(md if p else a for p, a, md in zip(pick, lo, mid))
        hi2 = tuple(b if p else md for p, b, md in zip(pick, hi, mid))
        if _meets_chamber(lo2, hi2):
            out.append((lo2, hi2))
    return out


def _cover(m: int, top: int, excluded, proven: str, probe, probe_from: int, max_cells: int,
           max_depth: int, clock=UNLIMITED) -> BoxCover:
    """The cover loop shared by :func:`box_cover` and :func:`quadric_cover`: cells of the
    ordered chamber (integer corners u ∈ [0, top]) are examined with ``excluded(lo, hi)``,
    the ones left are halved, at most ``max_cells`` cells and ``max_depth`` halvings.
    From depth ``probe_from`` on, ``probe(lo, hi)`` is called on up to :data:`PROBES` cells
    left (spread over them); a (evidence, found) pair it returns ends the cover.
    ``proven``: the evidence after "covered by … cells" when every cell is excluded.
    ``clock`` (:class:`ProofClock`) is checked before each cell."""
    step = top // _START
    cells = [(tuple(i * step for i in ix), tuple((i + 1) * step for i in ix))
             for ix in itertools.combinations_with_replacement(range(_START), m)]
    examined = 0
    for depth in range(max_depth + 1):
        left = []
        for lo, hi in cells:
            clock.check()
            examined += 1
            if examined > max_cells:
                return BoxCover(False, examined - 1, depth,
                                f"not proven: {max_cells} cells examined, {len(left)} at depth"
                                f" {depth} not excluded yet")
            if not excluded(lo, hi):
                left.append((lo, hi))
        if not left:
            return BoxCover(True, examined, depth,
                            f"covered by {examined} cells of the ordered root box"
                            f" (μ ∈ [−1, 1]^{m}, {depth} halvings): {proven}")
        if probe is not None and depth >= probe_from:
            for lo, hi in left[::max(1, len(left) // PROBES)][:PROBES]:
                got = probe(lo, hi)
                if got is not None:
                    return BoxCover(False, examined, depth, got[0], got[1])
        if depth == max_depth:
            break
        if any(b - a < 2 for lo, hi in left for a, b in zip(lo, hi)):
            return BoxCover(False, examined, depth, "not proven: cells at the finest grid"
                            " are not excluded (a root set may satisfy the conditions)")
        cells = [c for lo, hi in left for c in _halves(lo, hi, m)]
    return BoxCover(False, examined, max_depth,
                    f"not proven: after {max_depth} halvings cells remain that are not excluded")


def quadric_cover(m: int, S, time: str, *, equality: bool, max_cells: int = BOX_CELLS,
                  max_depth: int = BOX_DEPTH, clock=UNLIMITED) -> BoxCover:
    """Try to prove that no p = Π (λ − λ_i) with m real stable roots (repeated or not)
    has q(p) ≥ 0 — or q(p) = 0 when ``equality`` — for the quadratic form
    q(p) = aᵀ S a of its coefficient vector a (λ⁰ … λᵐ; S rational symmetric).

    With the roots mapped to μ ∈ [−1, 1] as in :func:`box_cover`, a(μ) is a nonzero
    multiple of the coefficients (q is homogeneous of degree 2, so its sign is kept) and
    multi-affine, so q(a(μ)) is multi-quadratic. On a cell with vertex values a_v
    (v ∈ {0, 1}ᵐ), its Bernstein coefficients of degree (2, …, 2) are
    b_α = 2^(−#{α_i = 1}) Σ_{v + w = α} a_vᵀ S a_w (the product rule of Bernstein forms), and
    q lies between the least and the largest b_α on the cell (the Bernstein polynomials are
    ≥ 0 and sum to 1). A cell is excluded when every b_α < 0 (or, for the equality, every
    b_α is of one strict sign), checked in integers; cells are halved as in
    :func:`box_cover`. ``found``: a cell centre (μ) where q ≥ 0 in floating point (a root
    set where the condition holds, so the cover cannot close), when one is met."""
    S = sp.Matrix(S)
    den = math.lcm(*[int(sp.Rational(v).q) for v in S])
    Si = [[int(sp.Rational(S[i, j]) * den) for j in range(m + 1)] for i in range(m + 1)]
    levels = max_depth + int(math.log2(_START))
    top = 2 ** levels
    def at_corner(key):
        a = _product(key, top, time, m)
        return a, [sum(Si[i][j] * a[j] for j in range(m + 1)) for i in range(m + 1)]

    vertex = _symmetric_memo(at_corner)

    def bernstein_signs(lo, hi):
        verts = list(itertools.product((0, 1), repeat=m))
        vals = {v: vertex(tuple(h if b else l for b, l, h in zip(v, lo, hi))) for v in verts}
        gram = {}
        signs = set()
        for alpha in itertools.product((0, 1, 2), repeat=m):
            total = 0
            choices = [((0, 0),) if x == 0 else ((1, 1),) if x == 2 else ((0, 1), (1, 0))
                       for x in alpha]
            for pairs in itertools.product(*choices):
                v = tuple(p[0] for p in pairs)
                w = tuple(p[1] for p in pairs)
                k = (v, w) if v <= w else (w, v)
                g = gram.get(k)
                if g is None:
                    g = sum(x * y for x, y in zip(vals[k[0]][0], vals[k[1]][1]))
                    gram[k] = g
                total += g
            signs.add((total > 0) - (total < 0))
            if 0 in signs or (not equality and 1 in signs) or len(signs) > 1:
                return False
        return True

    def value(mu):  # q at the root set μ (rounded to the grid: exact there)
        a = _product(tuple(int(round((x + 1) * top / 2)) for x in mu), top, time, m)
        return sum(Si[i][j] * a[i] * a[j] for i in range(m + 1) for j in range(m + 1))

    what = "= 0" if equality else "≥ 0"

    def probe(lo, hi):
        centre = tuple((a + b) / top - 1 for a, b in zip(lo, hi))
        if equality or value(centre) < 0:
            return None
        mu = ", ".join(f"{x:.4g}" for x in centre)
        return f"the form is {what} at the root set μ = ({mu})", centre

    return _cover(m, top, bernstein_signs,
                  "on each, every Bernstein coefficient of the quadratic form is"
                  f" {'of one strict sign' if equality else '< 0'}, so no root set, real and"
                  f" stable, has it {what}", probe, 0, max_cells, max_depth, clock)


def box_cover(m: int, functionals, time: str, *, max_cells: int = BOX_CELLS,
              max_depth: int = BOX_DEPTH, probe=None, clock=UNLIMITED) -> BoxCover:
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
    def at_corner(key):  # (ℓ_k(g(u)))_k in integers, g symmetric: cached on the sorted corner
        coef = _product(key, top, time, m)
        return tuple(sum(w * cj for w, cj in zip(row, coef)) for row in ell)

    values = _symmetric_memo(at_corner)
    combination = _hinted_combination(linprog)

    def excluded(lo, hi):
        return combination([values(v) for v in set(itertools.product(*zip(lo, hi)))])

    def member(lo, hi):
        centre = tuple(sp.Rational(a + b, top) - 1 for a, b in zip(lo, hi))
        got = probe(centre) if len(set(centre)) == m else None
        return ("a member found in a cell that could not be excluded", got) if got else None

    return _cover(m, top, lambda lo, hi: excluded(lo, hi) is not None,
                  f"on each, a combination of the {r} conditions is of one sign at every vertex,"
                  " hence on the whole cell (multi-affine), so no member has its roots real and"
                  " stable", member if probe is not None else None, 1, max_cells, max_depth,
                  clock)


#: halvings of the parameter interval at most (:func:`pencil_cover`)
PENCIL_DEPTH = 14

#: halvings of the root box per parameter interval at most (:func:`pencil_cover`)
_PENCIL_MU_DEPTH = 3


def pencil_cover(m: int, charts, time: str, *, max_cells: int = 40 * BOX_CELLS,
                 t_depth: int = PENCIL_DEPTH, clock=UNLIMITED) -> BoxCover:
    """Try to prove that for no parameter value a monic p of degree m with ℓ_k(p) = 0 for
    every k has m real stable roots: :func:`box_cover` for a family that moves with a
    parameter. ``charts``: pairs (name, functionals), the parameter of each running over
    [−1, 1] (e.g. t and s = 1/t, which together cover R ∪ {∞}); ``functionals``: rows
    ℓ_k, each m + 1 entries (the weights of λ⁰ … λᵐ), each entry the integer coefficients
    of t⁰, t¹, … of a polynomial in the chart's parameter t. Every member at a parameter
    value must satisfy ℓ_k(p) = 0 for every k there (the caller's guarantee).

    With the roots mapped to μ as in :func:`box_cover`, h_k(μ, t) = ℓ_k(t)(g(μ)) is
    multi-affine in μ and a polynomial in t; on a cell × an interval T, c·h(v, t) at each
    vertex v has Bernstein coefficients on T, and if some c makes all of them > 0, then
    c·h > 0 on the whole cell × T (the vertex weights and the Bernstein polynomials are
    ≥ 0 and sum to 1), so no member there. Each interval T is tried with the root box
    cover at a fixed c per cell (up to a few halvings of the box); when that fails T is
    halved (up to ``t_depth`` times). Exact: dyadic interval ends, Bernstein coefficients
    in rationals, c found by a float linear programme and checked exactly
    (:func:`positive_combination`)."""
    from scipy.optimize import linprog  # lazy: scipy costs ~0.3 s to import

    levels = _PENCIL_MU_DEPTH + int(math.log2(_START))
    top = 2 ** levels  # μ = 2u/top − 1 on the root box
    examined = [0]
    deepest = [0]

    def bernstein(q, d, a, b):  # Bernstein coefficients of Σ q_i t^i on [a, b] (Fractions)
        s = [Fraction(0)] * (d + 1)
        for c in reversed(q):  # Horner in t = a + (b − a) x
            new = [Fraction(0)] * (d + 1)
            for i, x in enumerate(s):
                if x:
                    new[i] += x * a
                    if i < d:
                        new[i + 1] += x * (b - a)
            new[0] += c
            s = new
        return [sum(Fraction(math.comb(j, i), math.comb(d, i)) * s[i] for i in range(j + 1))
                for j in range(d + 1)]

    def interval_proven(rows, d, a, b) -> bool:
        def at_corner(key):  # the Bernstein coefficients on [a, b] of each h_k(v, ·)
            coef = _product(key, top, time, m)
            polys = [[sum(e[i] * cj for e, cj in zip(row, coef)) for i in range(d + 1)]
                     for row in rows]
            return list(zip(*(bernstein(q, d, a, b) for q in polys)))

        vertex_rows = _symmetric_memo(at_corner)
        combination = _hinted_combination(linprog)

        def excluded(lo, hi):
            clock.check()
            examined[0] += 1
            V = {x for v in set(itertools.product(*zip(lo, hi))) for x in vertex_rows(v)}
            return combination([_scaled(x) for x in V]) is not None

        got = _cover(m, top, excluded, "", None, 0, 200, _PENCIL_MU_DEPTH)
        return got.proven

    for name, functionals, intervals in charts:
        if not intervals:
            continue
        if not functionals:
            return BoxCover(False, examined[0], 0, f"no condition on p for {name}")
        d = max(len(e) for row in functionals for e in row) - 1
        rows = [[list(e) + [0] * (d + 1 - len(e)) for e in row] for row in functionals]
        todo = [(_fraction(a), _fraction(b), 0) for a, b in intervals]
        while todo:
            a, b, depth = todo.pop()
            if examined[0] > max_cells:
                return BoxCover(False, examined[0], depth, f"not proven: {max_cells} cells"
                                " examined")
            if interval_proven(rows, d, a, b):
                deepest[0] = max(deepest[0], depth)
                continue
            if depth == t_depth:
                where = f"{name} ∈ [{a}, {b}]"
                return BoxCover(False, examined[0], depth, f"not proven: {where} is not"
                                f" excluded after {t_depth} halvings of the parameter")
            mid = (a + b) / 2
            todo += [(a, mid, depth + 1), (mid, b, depth + 1)]
    return BoxCover(True, examined[0], deepest[0],
                    f"covered by {examined[0]} cells of the ordered root box times intervals of"
                    f" the parameter ({'; '.join(_where(n, iv) for n, _, iv in charts if iv)},"
                    f" {deepest[0]} halvings at most): on"
                    " each, a combination of the conditions has positive Bernstein"
                    " coefficients at every vertex, so no t and no member has its roots real"
                    " and stable")


def _symmetric_memo(compute):
    """u ↦ compute(sorted u), cached on the sorted corner (the root factors commute)."""
    cache: dict = {}

    def get(u):
        key = tuple(sorted(u))
        got = cache.get(key)
        if got is None:
            got = cache[key] = compute(key)
        return got

    return get


def _hinted_combination(linprog):
    """rows ↦ integer c with c·row > 0 for every row, or None (:func:`positive_combination`),
    trying first the c that worked last (neighbouring cells often share it)."""
    last = [None]

    def find(rows):
        hint = last[0]
        if hint is not None and all(sum(c * x for c, x in zip(hint, row)) > 0 for row in rows):
            return hint
        c = positive_combination(rows, linprog=linprog)
        if c is not None:
            last[0] = c
        return c

    return find


def _fraction(x) -> Fraction:
    x = sp.Rational(x)
    return Fraction(int(x.p), int(x.q))


def _where(name, intervals) -> str:
    return f"{name} in " + " ∪ ".join(f"[{a}, {b}]" for a, b in intervals)


def _scaled(row) -> tuple:
    """A row of Fractions times the positive lcm of its denominators: the same signs of
    every combination, in integers."""
    den = math.lcm(*[x.denominator for x in row])
    return tuple(int(x * den) for x in row)
