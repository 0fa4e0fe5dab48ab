"""Does an affine family of monic polynomials of degree m have a member with m distinct
real stable roots? (METHOD §2b, the chain polynomials and the row decisions.)

Decided by the family's dimension d: a point, a line (:func:`plane_order`'s line
decision), a hyperplane (:func:`hyperplane_corners`), a plane (:func:`plane_order`),
every monic p (d ≥ m), and for 3 ≤ d ≤ m − 2 the sign test, pinned members and the box
cover (:func:`family_order`).

References: METHOD §2b; seed 002 §2.
"""
from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import sympy as sp

from ....numerics import exact_rank, gordan_alternative
from .._lambda_search import exact_real_roots
from ...core import is_stable
from ._box_cover import box_cover
from ._clock import UNLIMITED
from ._roots import cell_points, stability_edges

__all__ = ["ChainOrder", "family_order", "plane_order", "hyperplane_functional",
           "hyperplane_corners", "hyperplane_member", "pinned_member", "monic_family",
           "independent_vectors", "MAX_SUBSETS", "SAMPLES"]


#: at most this many subsets of the tried λ are used to pin a member of a family of p
MAX_SUBSETS = 60


#: seeded random λ sets tried (in floating point first) after those subsets
SAMPLES = 3000


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


def family_order(m: int, a0, dirs, lam, time: str, tries=(), clock=UNLIMITED) -> ChainOrder:
    """Decide whether the affine family of monic p(λ) = λᵐ − Σ_i (a0_i + Σ_j t_j v_ji) λⁱ
    (``dirs`` = the v_j, independent) has a member with m distinct real stable roots.

    By the family's dimension d: a point, a line, a hyperplane (d = m − 1) and a plane are
    decided exactly; d ≥ m: every monic p; 3 ≤ d ≤ m − 2: first the sign test
    (:func:`_sign_order`: a member with every root real and stable has coefficients of one
    sign — after λ = (μ + 1)/(μ − 1) in discrete time — so a Gordan certificate that none
    has rules the order out exactly), then members through d pinned roots (``tries``, then
    seeded samples), then a cover of the root box by cells on which the family's
    conditions cannot all vanish (:func:`box_cover`, exact); undecided when none of them
    settles it. ``clock`` (:class:`ProofClock`) is checked between the steps: between
    pinned members, lines of a plane and cells of the cover."""
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
                             roots_ok, clock)
    if 3 <= d <= m - 2:
        clock.check()
        signs = _sign_order(m, a0, dirs, lam, time)
        if signs is not None:
            return signs

    def pinned(subset):
        a = pinned_member(a0, dirs, subset, poly(a0), lam)
        return poly(a) if a is not None else None

    subsets = itertools.chain(itertools.islice(itertools.combinations(tries, d), MAX_SUBSETS),
                              _sampled_subsets(m, d, a0, dirs, time))
    ell = hyperplane_functional(m, a0, dirs) if d == m - 1 else None
    hyper = hyperplane_corners(ell, time) if ell is not None else None
    if hyper is not None and not hyper[0]:
        return ChainOrder(m, "hyperplane", d, None, (), f"m = {m}: {hyper[1]}")
    for subset in subsets:
        clock.check()
        p = pinned(subset)
        rts = roots_ok(p) if p is not None else ()
        if rts:
            return ChainOrder(m, "hyperplane" if hyper else "free", d, p, rts,
                              f"m = {m}: " + (hyper[1] + "; " if hyper else
                                              f"a {d}-parameter family of p; ")
                              + f"through λ = {', '.join(map(str, subset))}: p(λ) ="
                              f" {sp.factor(p)}")
    if hyper is not None:  # a member exists: build it near the vertices of opposite sign
        p = hyperplane_member(ell, time, lam, roots_ok, clock)
        if p is not None:
            return ChainOrder(m, "hyperplane", d, p, roots_ok(p),
                              f"m = {m}: {hyper[1]}; p(λ) = {sp.factor(p)}")
    if d == 2:  # a plane: exact cell decomposition in (t1, t2)
        return plane_order(m, poly(a0), [sp.expand(-sum(v[i] * lam ** i for i in range(m)))
                                          for v in dirs], lam, time, roots_ok, clock)
    return _box_order(m, a0, dirs, lam, time, pinned, roots_ok, clock)


def _box_order(m, a0, dirs, lam, time, pinned, roots_ok, clock) -> ChainOrder:
    """The last step of :func:`family_order` (3 ≤ d ≤ m − 2, no member pinned): the box
    cover of the root box, probing the cells it cannot exclude for a member (d roots pinned
    at the cell's centre, floats first, then exactly)."""
    d = len(dirs)
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

    cover = box_cover(m, _annihilators(m, a0, dirs), time, probe=probe, clock=clock)
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


def pinned_member(a0, dirs, subset, p0, lam):
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


def hyperplane_member(ell, time: str, lam, accept=None, clock=UNLIMITED):
    """A member of the hyperplane ℓ(p) = 0 with m distinct real stable roots, exactly, when
    :func:`hyperplane_corners` says one exists (else None): walk from a corner of one sign
    to one of the other, moving one root at a time from near one end of the stable region
    to near the other (ε = 10⁻¹, 10⁻², …); ℓ is affine in the moving root, so where the
    sign changes the root solving ℓ = 0 is rational and lies between its two ends.
    ``accept(p)`` (default: m distinct real stable roots) checks each candidate;
    ``clock`` is checked before each ε."""
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
        clock.check()
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


def _pencil_order(m, p0, p1, lam, time, roots_ok, clock=UNLIMITED) -> ChainOrder:
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
    edges = stability_edges(time)
    crit = sp.Mul(disc, *[pt.subs(lam, e) for e in edges])
    pts = cell_points([sp.Poly(sp.expand(crit), t)])
    for v in pts:
        clock.check()
        p = sp.expand(pt.subs(t, v))
        rts = roots_ok(p)
        if rts:
            return ChainOrder(m, "line", 1, p, rts, f"m = {m}: {fam}; at t = {v}: p(λ) ="
                              f" {sp.factor(p)}")
    return ChainOrder(m, "line", 1, None, (),
                      f"m = {m}: {fam}; no t gives only real, distinct, stable roots (checked"
                      f" at one t in each of the {len(pts)} intervals cut by the"
                      f" {len(pts) - 1} t where roots collide or cross the stability boundary)")


def plane_order(m, p0, dirs, lam, time: str, roots_ok=None, clock=UNLIMITED) -> ChainOrder:
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
    edges = stability_edges(time)
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
    pts = cell_points(R)
    for v in pts:
        line = _pencil_order(m, sp.expand(p0 + v * p1), p2, lam, time, roots_ok, clock)
        if line.lambdas:
            return ChainOrder(m, "plane", 2, line.polynomial, line.lambdas,
                              f"m = {m}: {fam}; at t1 = {v}: p(λ) = {sp.factor(line.polynomial)}")
    return ChainOrder(m, "plane", 2, None, (),
                      f"m = {m}: {fam}; no t gives only real, distinct, stable roots (decided"
                      f" exactly on the line t1 = c for one rational c in each of the"
                      f" {len(pts)} intervals cut by the {len(pts) - 1} real roots of the"
                      " projection polynomial of the curve where roots collide or cross the"
                      " stability boundary)")


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


def monic_family(polys, m, lam) -> tuple:
    """(a0, dirs) of :func:`family_order` for the monic members of degree m of the span of
    ``polys`` (Poly in λ of degree ≤ m, one of degree m): p0 = that one made monic, the
    directions P − lc_m(P) p0 of the others, an independent subset."""
    j0 = next(j for j, P in enumerate(polys) if P.degree() == m)
    p0 = polys[j0].to_field().monic()
    a0 = [-p0.coeff_monomial(lam ** i) for i in range(m)]
    dirs = independent_vectors([[-(P - p0 * P.coeff_monomial(lam ** m)).coeff_monomial(lam ** i)
                          for i in range(m)] for j, P in enumerate(polys) if j != j0])
    return a0, dirs


def independent_vectors(vectors) -> list:
    """A maximal independent subset (exact) of nonzero coefficient vectors."""
    out: list = []
    for v in vectors:
        if all(e == 0 for e in v):
            continue
        if exact_rank(sp.Matrix(out + [v])).rank == len(out) + 1:
            out.append(v)
    return out
