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

import numpy as np
import sympy as sp

from ..numerics import exact_rank, left_null_echelon, left_null_space, solve_left
from ._canonical import krylov_blocks, member_to_phi
from ._lambda_search import exact_real_roots
from ._reduced import is_stable

__all__ = ["OrderBound", "ChainOrder", "estimation_order_bound", "residual_order_bound",
           "chain_order", "spread_lambdas", "MAX_SUBSETS"]

#: at most this many subsets of the tried λ are used to pin a member of a family of p
MAX_SUBSETS = 60
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
    """What the monic polynomials p of degree m with M p(F) ∈ W_m say about order m.

    ``verdict``: "empty" (no such p: no model of order m), "unique" (one p; its roots are
    every model's eigenvalues), "line" (a one-parameter family, decided exactly), "signed"
    (a hyperplane of p none of which has only negative roots, continuous time), "free" (an
    affine family of dimension ``dim``, searched, undecided when nothing is found);
    ``polynomial``: the unique p, or the member found with ``lambdas`` as its roots;
    ``lambdas``: m distinct real stable roots of a member (exact), () when none was found;
    ``evidence``: one line."""

    m: int
    verdict: str
    dim: int
    polynomial: sp.Expr | None
    lambdas: tuple
    evidence: str

    @property
    def impossible(self) -> bool:
        """No member has m distinct real stable roots (decided exactly)."""
        return self.verdict in ("empty", "signed") or (self.verdict in ("unique", "line")
                                                         and not self.lambdas)


def chain_order(F, H, M, m: int, lam, time: str, tries) -> ChainOrder:
    """The affine family of monic p (degree m) with M p(F) ∈ W_m, for one row M and numeric
    F, H, and a member with m distinct real stable roots: the unique one's roots, or, for a
    family of dimension d, the member through d values of ``tries`` (each d-subset in turn)
    whose other roots are real, distinct and stable. By :func:`estimation_order_bound`'s
    chain argument each member is the characteristic polynomial of a model of order m (no
    decoupling), and a Jordan design of m rows with λ_1, …, λ_m has p = Π (s − λ_i) here."""
    F, H, M = (sp.Matrix(X) for X in (F, H, M))
    MF, HF = [M], [H]
    for _ in range(m):
        MF.append(MF[-1] * F)
        HF.append(HF[-1] * F)
    A = sp.Matrix.vstack(*MF[:m], *HF)
    X0 = solve_left(A, MF[m])
    if X0 is None:
        return ChainOrder(m, "empty", -1, None, (), f"m = {m}: M F^{m} ∉ rowspace [M, …,"
                          f" M F^{m - 1}; H, …, H F^{m}]: no model of order {m}")
    a0 = [X0[0, i] for i in range(m)]
    basis, _ = left_null_space(A)
    dirs = _independent([[v[0, i] for i in range(m)] for v in basis])
    d = len(dirs)

    def poly(a):
        return sp.expand(lam ** m - sum(a[i] * lam ** i for i in range(m)))

    def roots_ok(p):
        if sp.degree(sp.gcd(p, sp.diff(p, lam)), lam) > 0:
            return ()  # a repeated root
        _, facs = sp.factor_list(p, lam)
        rts = exact_real_roots([f for f, _ in facs], lam)
        if len(rts) == m and all(is_stable(r, time) for r in rts):
            return tuple(rts)
        return ()

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
    if d == m - 1 and time == "continuous":
        sign = _one_sign(m, a0, dirs)
        if sign:
            return ChainOrder(m, "signed", d, None, (),
                              f"m = {m}: the p form a hyperplane Σ c_i e_i(−λ) = 0 with every c_i"
                              f" {sign} and e_i(−λ) > 0 for λ < 0: no p has only negative roots")

    if d == 1:
        return _pencil_order(m, poly(a0), sp.expand(-sum(dirs[0][i] * lam ** i
                                                          for i in range(m))), lam, time,
                             roots_ok)

    def pinned(subset):
        """The member with p(v) = 0 for each v of the subset (d linear equations in the d
        directions' weights), exactly; None when they do not determine it."""
        B = sp.Matrix([[sum(dirs[r][i] * v ** i for i in range(m)) for r in range(d)]
                       for v in subset])
        if exact_rank(B).rank < d:
            return None
        w = B.LUsolve(sp.Matrix([poly(a0).subs(lam, v) for v in subset]))
        return poly([a0[i] + sum(w[r] * dirs[r][i] for r in range(d)) for i in range(m)])

    subsets = itertools.chain(itertools.islice(itertools.combinations(tries, d), MAX_SUBSETS),
                              _sampled_subsets(m, d, a0, dirs, time))
    for subset in subsets:
        p = pinned(subset)
        rts = roots_ok(p) if p is not None else ()
        if rts:
            return ChainOrder(m, "free", d, p, rts,
                              f"m = {m}: a {d}-parameter family of p; through λ ="
                              f" {', '.join(map(str, subset))}: p(λ) = {sp.factor(p)}")
    return ChainOrder(m, "free", d, None, (),
                      f"m = {m}: a {d}-parameter family of p; none through {d} of the tried λ"
                      f" nor of {SAMPLES} sampled sets has only real, distinct, stable roots"
                      " (undecided)")


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
    edges = [0] if time == "continuous" else [1, -1]
    crit = sp.Mul(disc, *[pt.subs(lam, e) for e in edges])
    crit = sp.Poly(sp.expand(crit), t)
    pts = []
    ends = _separated_roots(crit.sqf_part()) if crit.degree() > 0 else []
    if ends:
        pts.append(ends[0][0] - 1)
        pts += [(ends[i][1] + ends[i + 1][0]) / 2 for i in range(len(ends) - 1)]
        pts.append(ends[-1][1] + 1)
    else:  # no real root in t (or none at all): one interval, the whole line
        pts.append(sp.Integer(0))
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


def _one_sign(m, a0, dirs) -> str:
    """For a hyperplane of monic p (one linear condition on its coefficients): "≥ 0" or
    "≤ 0" when, written as Σ_j c_j e_j(μ) = 0 in μ = −λ (e_j the elementary symmetric
    polynomials, e_0 = 1), every c_j has that sign (not all 0); "" otherwise.

    p = Σ_i q_i λ^i with q_m = 1, q_i = −a_i; the members are a = a0 + span(dirs), so the
    condition is n·(a − a0) = 0 for the normal n of span(dirs). With λ_i = −μ_i,
    q_i = e_{m−i}(μ): the condition reads Σ_i n_i (−e_{m−i}(μ)) − n·a0 = 0."""
    N = sp.Matrix(dirs)
    normal = N.nullspace()
    if len(normal) != 1:
        return ""
    nv = list(normal[0])
    c = [-nv[i] for i in range(m)] + [0]  # coefficient of e_{m−i}(μ) for i = 0..m−1
    c[m] = -sum(nv[i] * a0[i] for i in range(m))  # the constant: coefficient of e_0
    if all(v >= 0 for v in c) and any(v != 0 for v in c):
        return "≥ 0"
    if all(v <= 0 for v in c) and any(v != 0 for v in c):
        return "≤ 0"
    return ""


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
