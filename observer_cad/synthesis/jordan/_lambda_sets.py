"""Rows spanning z modulo the outputs, and q + e rows through sets of e + 1 λ (METHOD §2b,
"q + e rows through e + 1 λ").

When q = rank [M; H] − rank H rows are impossible, a model of q + e rows has its rows'
images modulo rowspace [M; H] in an e-dimensional U; e + 1 rational λ with Σ Φ_i Q = 0
fix U, and the further λ are the rank drops of E(λ) for T = [M; Φ_1 … Φ_e]. Which sets
are worth an exact solve is decided first in floating point.

References: METHOD §2b.
"""
from __future__ import annotations

import itertools

import numpy as np
import sympy as sp

from ...numerics import exact_product, float_left_null_space, float_rank, left_null_space
from ...progress import report
from ._admissible import LAMBDA, rank_of, rows_for_lambda, same_number
from ._lambda_search import q_rows_possible
from ._rows_check import rows_satisfy_task

__all__ = ["rows_spanning_z", "rows_through_lambda_sets", "float_rank_full", "real_roots", "PRECHECK_RTOL",
           "TUPLE_E_MAX", "TUPLE_E_CAP"]


def rows_spanning_z(fam, lam_list, H, M, observer, D, st, tried, names=(), extra=()):
    """Rows spanning T = [M; extra rows] modulo H with nothing to spare, rank [T; H] − rank H
    of them: with no extra rows the fewest any model of z = M x can have, when the rows
    inside rowspace [M; H] of the λ tried span z modulo H (:func:`q_rows_possible`). At each λ
    the rows c N_λ L0 ∈ rowspace [T; H] (left null space of [N_λ L0; T; H]), taken greedily
    while they add rank to [H; rows so far] (a basis of a sum of subspaces)."""
    T = sp.Matrix.vstack(M, *extra)
    rH = rank_of(H)
    rows, have, r_have = [], sp.Matrix(H), rH
    target = rank_of(sp.Matrix.vstack(H, T))
    for lam in lam_list:
        if lam not in fam:
            continue
        PhiB, JB = fam[lam]
        stacked = sp.Matrix.vstack(PhiB, T, H)
        if lam.has(sp.CRootOf) and float_rank_full(stacked):
            continue  # no row of this λ inside rowspace [T; H] (numerically clear)
        basis, _ = left_null_space(stacked)
        for v in basis:
            c = v[:, :PhiB.rows]
            row = exact_product(c, PhiB)
            if row == sp.zeros(1, row.cols):
                continue
            trial = sp.Matrix.vstack(have, row)
            r_trial = rank_of(trial)
            if r_trial > r_have:
                rows.append((lam, row, exact_product(c, JB)))
                have, r_have = trial, r_trial
        if r_have == target:
            break
    if r_have != target or len(rows) != target - rH:
        return None
    return rows if rows_satisfy_task(rows, len(rows), observer, H, D, M, st, tried, names) else None


def rows_through_lambda_sets(F, H, L, L0, fam, lam_list, M, observer, D, st, tried, names, time,
                       e=1, hint=()):
    """q + e rows for z with several components when q rows are impossible. Modulo
    rowspace [M; H] (the columns of Q span its right null space) q + e rows spanning z
    modulo H have their images in an e-dimensional subspace U. e + 1 λ with rows
    Σ Φ_i Q = 0 (a linear solve for rational λ_i) give U = span of e of the images; the
    further λ whose rows meet rowspace [M; Φ_1 … Φ_e; H] are the rank drops of E(λ) for
    T = [M; Φ_1; …; Φ_e] (:func:`q_rows_possible`, exact roots: often rational, not in any
    list), and the rows spanning T modulo H are taken as in :func:`rows_spanning_z`
    (METHOD §2b). e = 1: pairs of λ and one line w (q + 1 rows, the least when q rows are
    impossible).

    The further λ depend on the chosen λ: a floating-point scan over a grid of rational
    λ (generalised eigenvalues of E(λ)) picks the sets whose further λ look real and
    stable; only those are solved exactly (the solution of the float scan carried over
    by a rationalised least-squares fit when the solutions form more than a line), and
    the exact solve decides. ``hint``: λ known to allow q + 1 rows (:func:`q_plus_one_rows_possible`);
    pairs of its rational ones are tried after the scan's (whose λ are less stiff)."""
    Q = sp.Matrix.hstack(*sp.Matrix.vstack(M, H).nullspace())
    if Q.cols == 0:
        return None
    q = rank_of(sp.Matrix.vstack(M, H)) - rank_of(H)
    grid = [lam for lam in lam_list if lam.is_rational] + [
        v for v in _PAIR_GRID[time] if not any(v == w for w in lam_list)]
    if e > 1:  # the list's first λ, then the grid spread over its range
        head = [lam for lam in lam_list if lam.is_rational][:_TUPLE_GRID // 3]
        top = _TUPLE_STIFF * (abs(head[0]) if head else 1)
        rest = sorted(v for v in grid if not any(v == w for w in head)
                      and (time != "continuous" or abs(v) <= top))
        slots = min(len(rest), _TUPLE_GRID - len(head))
        grid = head + [rest[int(round(i))] for i in np.linspace(0, len(rest) - 1, slots)]
    sets = _promising_sets(F, H, L, L0, M, Q, grid, q, time, e)[:_PAIR_EXACT]
    seen = [lams for lams, _ in sets]
    if e == 1:
        sets += [(pr, None) for pr in itertools.combinations([v for v in hint if v.is_rational], 2)
                 if pr not in seen]
    for i, (lams, phis) in enumerate(sets):
        report(f"designing (Jordan form): q + {e} rows through λ = {', '.join(map(str, lams))}"
               f" (set {i + 1})")
        more = dict(fam)
        for lam in lams:
            if lam not in more:
                rows_phi, js, _ = rows_for_lambda(F, H, L0, lam)
                if not rows_phi:
                    break
                more[lam] = (sp.Matrix.vstack(*rows_phi), sp.Matrix.vstack(*js))
        else:
            Ns = [more[lam][0] for lam in lams]
            basis, _ = left_null_space(sp.Matrix.vstack(*[N * Q for N in Ns]))
            if not basis:
                continue
            y = _fitted_solution(basis, Ns, phis)
            rows, off = [], 0
            for N in Ns:
                rows.append(exact_product(y[:, off:off + N.rows], N))
                off += N.rows
            if any((r * Q).is_zero_matrix for r in rows):
                continue  # a row inside rowspace [M; H]: the q-row case, already decided
            extra, images = [], sp.zeros(0, Q.cols)
            for r in rows:
                if rank_of(sp.Matrix.vstack(images, r * Q)) > images.rows:
                    extra.append(r)
                    images = sp.Matrix.vstack(images, r * Q)
            if len(extra) != e:
                continue
            sr = q_rows_possible(F, H, L, sp.Matrix.vstack(M, *extra), LAMBDA, time)
            if not sr.possible:
                continue
            further = []
            # rows inside rowspace [T; H] at every λ but finitely many (e + f > c): the
            # list's λ serve as well as any
            generic = [] if sr.stable else [v for v in lam_list if v not in lams]
            for lam in list(sr.stable) + generic:
                same = next((w for w in more if same_number(lam, w)), None)
                if same is None:
                    rows_phi, js, _ = rows_for_lambda(F, H, L0, lam)
                    if rows_phi:
                        more[lam] = (sp.Matrix.vstack(*rows_phi), sp.Matrix.vstack(*js))
                        same = lam
                if same is not None and same not in lams and same not in further:
                    further.append(same)
            order = list(lams) + further
            found = rows_spanning_z(more, order, H, M, observer, D, st, tried, names, tuple(extra))
            if found is not None:
                return found
    return None


def _fitted_solution(basis, Ns, phis):
    """An exact solution y (Σ y_i N_i Q = 0) close to the float rows ``phis`` of the scan:
    the first basis vector when the solutions form a line (or no float rows are given),
    else the least-squares combination of the basis rows, its weights rationalised."""
    if len(basis) == 1 or phis is None:
        return basis[0]
    def rows_of(v):
        out, off = [], 0
        for N in Ns:
            out.append(np.array((v[:, off:off + N.rows] * N).evalf().tolist(), dtype=float).ravel())
            off += N.rows
        return np.concatenate(out)
    R = np.array([rows_of(b) for b in basis]).T
    target = np.concatenate([np.asarray(p, dtype=float).ravel() for p in phis])
    alpha, *_ = np.linalg.lstsq(R, target, rcond=None)
    if not np.all(np.isfinite(alpha)) or not np.any(alpha):
        return basis[0]
    scale = np.max(np.abs(alpha))
    w = [sp.Rational(float(a / scale)).limit_denominator(10 ** 6) for a in alpha]
    y = sum((wk * b for wk, b in zip(w, basis)), sp.zeros(*basis[0].shape))
    return y if not y.is_zero_matrix else basis[0]


def _promising_sets(F, H, L, L0, M, Q, grid, q, time, e=1) -> list:
    """Sets of e + 1 rational λ of the grid for which, in floating point, rows Φ_i of the
    λ_i with Σ Φ_i Q = 0, all images nonzero and spanning e dimensions, exist, and E(λ) of
    T = [M; e of the rows] drops rank at q − 1 further real stable λ (distinct, not among
    the set); the least stiff first (continuous: the ratio of the largest to the smallest
    abs(λ); discrete: the largest abs(λ)). Items: (the λ, the float rows)."""
    try:
        Fn, Hn, L0n, Mn, Qn = (np.array(X.evalf().tolist(), dtype=float).reshape(X.shape)
                               for X in (F, H, L0, M, Q))
        Ln = np.array(L.evalf().tolist(), dtype=float).reshape(L.shape)
    except (TypeError, ValueError):
        return []
    n = Fn.shape[0]
    fams = {}
    for lam in grid:
        x = float(lam)
        S = float_left_null_space(np.vstack([L0n @ (Fn - x * np.eye(n)), Hn]), rtol=1e-9)[0]
        fams[lam] = S[:, :L0n.shape[0]] @ L0n
    sizes = sorted(len(N) for N in fams.values())
    if not sizes or (e + 1) * sizes[len(sizes) // 2] <= Qn.shape[1]:
        return []  # e + 1 generic families: fewer unknowns than conditions Σ Φ_i Q = 0
    zl = np.zeros((Hn.shape[0], Ln.shape[1]))
    probe = []  # (λ', basis of the rows' images modulo [M; H]) with e + f' = c
    for x in _PROBE_LAMBDAS[time]:
        S = float_left_null_space(np.vstack([L0n @ (Fn - x * np.eye(n)), Hn]), rtol=1e-9)[0]
        W = S[:, :L0n.shape[0]] @ L0n @ Qn
        if len(W) + e == Qn.shape[1] and float_rank(W, rtol=1e-9).rank == len(W):
            probe.append((x, W))

    def score(lams, Ns, y):
        """(stiffness, rows) when the rows of the solution y qualify, else None."""
        rows, off = [], 0
        for N in Ns:
            rows.append(y[off:off + N.shape[0]] @ N)
            off += N.shape[0]
        images = np.array([r @ Qn for r in rows])
        if any(np.linalg.norm(im) < 1e-8 * max(1.0, np.linalg.norm(r))
               for im, r in zip(images, rows)):
            return None
        if np.linalg.matrix_rank(images, tol=1e-8 * np.abs(images).max()) != e:
            return None
        extra, got = [], np.zeros((0, Qn.shape[1]))
        for r, im in zip(rows, images):
            trial = np.vstack([got, im])
            if np.linalg.matrix_rank(trial, tol=1e-8 * np.abs(trial).max()) > got.shape[0]:
                extra.append(r)
                got = trial
        T = np.vstack([Mn] + extra)
        A = np.block([[T @ Fn, T @ Ln], [Hn @ Fn, Hn @ Ln], [-Hn, zl]])
        B = np.vstack([np.hstack([T, np.zeros((T.shape[0], Ln.shape[1]))]),
                       np.zeros((2 * Hn.shape[0], n + Ln.shape[1]))])
        r, ev = _pencil_drops(A, B)
        if ev is None:
            return None
        xs = [float(v) for v in lams]
        real = sorted({round(float(z.real), 9) for z in ev
                       if np.isfinite(z) and abs(z.imag) <= 1e-7 * (1 + abs(z))})
        new = [z for z in real if min(abs(z - x) for x in xs) > 1e-4 * (1 + abs(z))
               and (z < 0 if time == "continuous" else abs(z) < 1)
               and float_rank(A - z * B, rtol=1e-8).rank < r]
        if len(new) < q - 1:
            return None
        mags = [abs(v) for v in xs + new[:q - 1]]
        # continuous: the least stiff (fastest / slowest |λ|); discrete: the fastest
        return ((max(mags) / min(mags)) if time == "continuous" else max(mags)), rows

    scored = []
    for lams in itertools.combinations(grid, e + 1):
        Ns = [fams[v] for v in lams]
        if any(not len(N) for N in Ns):
            continue
        Y = float_left_null_space(np.vstack([N @ Qn for N in Ns]), rtol=1e-9)[0]
        if Y.shape[0] == 0:
            continue
        # the solutions form a space: its first vector, then (when it is more than a
        # line) points of the pencil Y₀ + t Y₁ where U(t) meets the rows' image of a
        # further λ' (:func:`_pencil_points`)
        ys = [Y[0]] + (_pencil_points(Y, Ns, Qn, e, probe) if Y.shape[0] > 1 else [])
        best = None
        for y in ys:
            got = score(lams, Ns, y)
            if got is not None and (best is None or got[0] < best[0]):
                best = got
        if best is not None:
            scored.append((best[0], lams, best[1]))
    scored.sort(key=lambda t: t[0])
    return [(lams, rows) for _, lams, rows in scored]


def _pencil_drops(A, B) -> tuple:
    """``(r, candidates)``: the rank r of A − λB at a shift σ (its generic rank unless σ
    is a drop) and candidates for the λ where it drops below r: the finite eigenvalues of
    a random r × r compression U (A − λB) V (a superset of the drops), by shift and invert
    (μ = 1 / (λ − σ) of (U (A − σB) V)⁻¹ U B V; μ = 0 is λ = ∞). Candidates None when the
    compression is singular at the shift."""
    rng = np.random.default_rng(20261123)
    r = np.linalg.matrix_rank(A - _SHIFT * B)
    if r == 0:
        return r, None
    U, V = rng.standard_normal((r, A.shape[0])), rng.standard_normal((A.shape[1], r))
    try:
        mu = np.linalg.eigvals(np.linalg.solve(U @ (A - _SHIFT * B) @ V, U @ B @ V))
    except np.linalg.LinAlgError:
        return r, None
    big = np.abs(mu) > 1 / _PAIR_MAX  # |λ − σ| < _PAIR_MAX; smaller μ: λ taken as infinite
    return r, _SHIFT + 1 / mu[big]


#: the further λ' at which :func:`_pencil_points` looks for points of the pencil
_PROBE_LAMBDAS = {"continuous": tuple(-np.logspace(-1.5, 3, 91)),
                  "discrete": tuple(np.linspace(-0.975, 0.975, 79))}


#: the most pencil points of one set scored by :func:`_promising_sets`
_PENCIL_POINTS = 3


def real_roots(coeffs):
    """The real roots of the polynomials whose coefficients (highest first) are the
    columns of ``coeffs``: in closed form for degree ≤ 2 (vectorised), else the
    eigenvalues of batched companion matrices. Leading coefficients below 1e-12 of a
    column's largest are taken as zero (the degree drops; np.roots would instead return a
    root near infinity)."""
    deg = coeffs.shape[0] - 1
    if deg == 1:
        a, b = coeffs
        ok = np.abs(a) > 1e-12 * np.abs(b)
        return -b[ok] / a[ok]
    if deg == 2:
        a, b, c = coeffs
        lin = np.abs(a) <= 1e-12 * (np.abs(b) + np.abs(c))
        disc = b * b - 4 * a * c
        ok = ~lin & (disc >= 0)
        sq = np.sqrt(disc[ok])
        q = -0.5 * (b[ok] + np.copysign(sq, b[ok]))  # no cancellation
        out = [q / a[ok], np.divide(c[ok], q, out=np.full(q.shape, np.nan), where=q != 0)]
        keep = lin & (np.abs(b) > 0)
        out.append(-c[keep] / b[keep])
        r = np.concatenate(out)
        return r[np.isfinite(r)]
    # degree ≥ 3: the eigenvalues of the companion matrices, one batched call per degree
    # (each polynomial trimmed to its degree first)
    out = []
    scale = np.abs(coeffs).max(axis=0)
    lead = np.argmax(np.abs(coeffs) > 1e-12 * scale, axis=0)
    for d in range(1, deg + 1):  # the columns whose leading nonzero coefficient is at deg − d
        cols = coeffs[:, (deg - lead == d) & (scale > 0)]
        if not cols.shape[1]:
            continue
        top = cols[deg - d:]  # (d + 1, P): leading coefficient first
        comp = np.zeros((top.shape[1], d, d))
        comp[:, 0, :] = -(top[1:] / top[0]).T
        comp[:, np.arange(1, d), np.arange(d - 1)] = 1.0
        r = np.linalg.eigvals(comp).ravel()
        out.append(r.real[np.abs(r.imag) <= 1e-9 * (1 + np.abs(r))])
    return np.concatenate(out) if out else np.zeros(0)


def _pencil_points(Y, Ns, Qn, e, probe) -> list:
    """Solutions y = Y₀ + t Y₁ (normalised) of a set whose solutions Σ y_i N_i Q = 0 form
    more than a line, chosen where the images U(t) of its first e rows meet the image
    W(λ') of the rows of a further λ' (e + dim W = c: det [U(t); W(λ')] = 0, a
    polynomial of degree ≤ e in t, interpolated at e + 1 points, its real roots): along
    the pencil U and the further λ move, and a sweep at fixed t would step over the
    narrow stretches where they are stable. At most :data:`_PENCIL_POINTS`, spread over
    the λ' (floats; the caller scores each and the exact solve decides)."""
    if not probe or len(Ns) < e:
        return []
    ts = np.arange(e + 1, dtype=float) - e / 2
    Ws = np.array([W for _, W in probe])  # (P, f', c)
    dets = []
    for t in ts:
        y, off, U = Y[0] + t * Y[1], 0, []
        for N in Ns[:e]:
            U.append(y[off:off + N.shape[0]] @ N @ Qn)
            off += N.shape[0]
        U = np.array(U)
        dets.append(np.linalg.det(np.concatenate(
            [np.broadcast_to(U, (len(probe),) + U.shape), Ws], axis=1)))
    coeffs = np.linalg.solve(np.vander(ts, e + 1), np.array(dets))  # (e + 1, P)
    coeffs = coeffs[:, np.any(np.abs(coeffs) > 1e-12 * np.abs(coeffs).max(initial=0.0),
                              axis=0)]
    roots = np.sort(real_roots(coeffs))
    if not len(roots):
        return []
    picks = [roots[int(i)] for i in np.linspace(0, len(roots) - 1, min(_PENCIL_POINTS,
                                                                        len(roots)))]
    return [(Y[0] + t * Y[1]) / np.linalg.norm(Y[0] + t * Y[1]) for t in picks]


#: the shift of :func:`_pencil_drops` (a number no λ of interest sits on)
_SHIFT = 0.3717


#: the rational λ the pair search scans besides the list's (continuous / discrete)
_PAIR_GRID = {
    "continuous": [sp.Rational(v) for v in (
        "-1/10", "-1/5", "-1/4", "-1/3", "-1/2", "-2/3", "-3/4", "-1", "-3/2", "-2", "-3", "-4",
        "-5", "-6", "-8", "-10", "-15", "-20", "-30", "-50", "-100", "-200", "-500", "-1000")],
    "discrete": [s_ * sp.Rational(v) for v in (
        "1/16", "1/8", "1/4", "3/8", "1/2", "5/8", "3/4", "7/8", "15/16") for s_ in (1, -1)],
}


#: |λ − shift| at least this large is taken as infinite (B is singular)
_PAIR_MAX = 1e5


#: sets solved exactly after the scan
_PAIR_EXACT = 6


#: every e (q + e rows) up to this is searched through sets of e + 1 λ; beyond it only
#: e = c − f (the rows of a further λ generically meet U at finitely many λ) ...
TUPLE_E_MAX = 2


#: ... up to this (C(_TUPLE_GRID, e + 1) sets are scanned: 2002 for e = 4)
TUPLE_E_CAP = 4


#: grid values scanned for sets of three or more λ (the first of the list and the grid)
_TUPLE_GRID = 14


#: continuous time: the grid for sets of three or more λ stops at this many times the
#: list's first |λ| (stiffer sets are rarely needed and make stiff observers)
_TUPLE_STIFF = 100


#: float pre-check for sets with irrational λ: relative least-squares residual above which
#: X B = M is certainly not solvable (an exact solution leaves ~1e-15; the exact solve decides)
PRECHECK_RTOL = 1e-6


def float_rank_full(A) -> bool:
    """True when A has full row rank with a clear margin in floating point."""
    try:
        An = np.array(A.evalf(30).tolist(), dtype=float)
    except (TypeError, ValueError):
        return False
    if An.shape[0] > An.shape[1]:
        return False
    s = np.linalg.svd(An, compute_uv=False)
    return bool(s.size and s[-1] > PRECHECK_RTOL * s[0])
