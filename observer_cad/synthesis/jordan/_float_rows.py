"""The rows of the float Jordan path (METHOD §2b): the λ lists, each λ's family of rows
from the numerical left null space of P(λ), and the row searches (least squares / SVD
with stated tolerances).
"""
from __future__ import annotations

import itertools

import numpy as np

from ...numerics import default_rtol, float_left_null_space, float_rank
from ...progress import report
from ._float_lambdas import float_pencil

__all__ = ["Families", "pools_by_size", "rows_solving_for_z", "residual_rows",
           "one_row_lambda", "SearchBudgetSpent", "default_lambdas", "stable_float",
           "lambda_set_text", "lstsq_relative", "phi_rank", "fmt", "PHI_RTOL"]


#: cap on the λ-sets of one size examined by the row searches (in lexicographic order)
_MAX_SETS = 300


#: cap on the λ-sets examined in all
_MAX_TOTAL = 3000


#: relative cut (rows of Φ normalised) for rank Φ = k
PHI_RTOL = 1e-10


#: length of the default λ list when every λ is admissible (see :func:`default_lambdas`)
_N_DEFAULTS = 16


#: continuous-time defaults (see :func:`default_lambdas`): log-spread over [−8, −1/8], coarsest first
_CONTINUOUS_DEFAULTS = (-1.0, -2.0, -0.5, -3.0, -1.5, -0.25, -4.0, -0.75, -6.0, -1.25, -0.125,
                        -8.0, -2.5, -0.375, -5.0, -1.75)


#: generic case: the sets of size k are drawn from the first max(k + _POOL_SLACK,
#: _POOL_MIN) default λ (see :func:`pools_by_size`)
_POOL_SLACK = 2


_POOL_MIN = 8


#: generic case: a size is left after this many λ-sets failed for the generic reason
_GENERIC_FAILS = 2


# ---------------------------------------------------------------- helpers
def stable_float(lam: float, time: str) -> bool:
    return lam < 0 if time == "continuous" else abs(lam) < 1


def default_lambdas(time: str, count: int):
    """The λ the float path tries when every λ is admissible: a fixed, well-separated set
    of stable values, at most :data:`_N_DEFAULTS` (and at most ``count``) of them.

    Discrete time: the dyadic points of (0, 1), coarsest first: 1/2, 1/4, 3/4, 1/8, 3/8,
    5/8, 7/8, 1/16, … (15 values, spacing ≥ 1/16, nonnegative so F* ≥ 0). Continuous
    time: :data:`_CONTINUOUS_DEFAULTS`, −1, −2, −1/2, −3, −3/2, −1/4, … spread on a log
    scale over [−8, −1/8] around the unit scale.

    Rows for nearby λ are nearly parallel (Φ_λ = J H (F − λI)⁻¹ moves with λ relative to
    the spectrum of F), so crowded λ waste SVDs and give ill-conditioned or spurious row
    combinations: the exact path's discrete list 1/2, 1/4, …, 1/2ⁿ crowds at 0 (1/2⁶⁰ and
    1/2³⁰⁰ give the same P(λ) in floating point), and −1, −2, …, −n crowds in direction
    for abs(λ) ≫ ‖F‖. Every λ is generically as good as any other here; the list only has to
    be long enough for the rows a design needs (one λ per row), and ``lambdas=`` widens it.
    """
    if time == "continuous":
        vals = list(_CONTINUOUS_DEFAULTS)
    else:
        vals = [j / 2.0 ** e for e in range(1, 5) for j in range(1, 2 ** e, 2)]
    return vals[:max(1, min(count, _N_DEFAULTS))]


class Families:
    """λ → (PhiB, JB), the rows of the left null space of P(λ) (see :func:`_family`),
    computed on first use: a search that stops at k rows pays the SVDs of the λ it
    looked at, not of the whole list."""

    def __init__(self, A, B, L0, m0, tol):
        self.A, self.B, self.L0, self.m0, self.tol = A, B, L0, m0, tol
        self._fam: dict = {}
        self.evidence: dict = {}

    def get(self, lam):
        """(PhiB on the states, JB), or None when P(λ) gives no nonzero row Φ."""
        if lam not in self._fam:
            report(f"designing (float, Jordan form): null space for λ = {fmt(lam)}"
                   f" ({len(self._fam) + 1} computed)")
            PhiB_S, JB, fr = _family(self.A, self.B, lam, self.m0, self.tol)
            self.evidence[lam] = fr.evidence()
            self._fam[lam] = None if PhiB_S is None else (PhiB_S @ self.L0, JB)
        return self._fam[lam]

    def __getitem__(self, lam):
        return self._fam[lam]

    def __contains__(self, lam) -> bool:
        return self._fam.get(lam) is not None

    def __iter__(self):
        return (lam for lam, f in self._fam.items() if f is not None)

    def __bool__(self) -> bool:
        return any(f is not None for f in self._fam.values())

    def reached(self, lam_list) -> list:
        """The λ of the list whose null space was computed (in list order)."""
        return [lam for lam in lam_list if lam in self._fam]

    def usable(self, lam_list, count=None) -> list:
        """The first ``count`` λ of the list (all when None) with a nonzero family."""
        out = []
        for lam in lam_list:
            if count is not None and len(out) >= count:
                break
            if self.get(lam) is not None:
                out.append(lam)
        return out


def pools_by_size(fam: Families, lam_list, narrow: bool):
    """size → the λ the sets of that size are drawn from.

    ``narrow`` (every λ admissible, the default list): the first max(size + 2, 8)
    usable λ. The early exit of the generic case: a λ-set's success depends on its
    values only on a lower-dimensional set, so when the first sets of a size fail, the
    rest of the list (equally generic) would fail the same way; the two spare λ guard
    against a default that happens to be special for this plant (an eigenvalue of F,
    say). Otherwise (admissible values computed, or λ given) every usable λ.

    With ``narrow``, the searches also leave a size after :data:`_GENERIC_FAILS` sets
    failed for the generic reason (no combination of their rows lies in rowspace(H); z
    not reachable): that is a rank condition on [Φ_λ1; …; Φ_λk; H], which holds at
    generic λ exactly when it holds at all but a lower-dimensional set of λ-tuples, so
    the other default sets of that size fail the same way (a design that needs a
    special λ is found by the admissible-λ computation or ``lambdas=``, not by luck)."""
    if not narrow:
        every = fam.usable(lam_list)
        pools = lambda size: every  # noqa: E731
    else:
        pools = lambda size: fam.usable(lam_list, max(size + _POOL_SLACK, _POOL_MIN))  # noqa: E731
    pools.narrow = narrow
    return pools


def _family(A, B, lam, m0, tol):
    """Rows Φ = c PhiB (PhiB orthonormal rows), J* = c JB, from the left null space of P(λ),
    and the FloatRank evidence. Members with Φ = 0 (S = 0) are dropped."""
    P = float_pencil(A, B, lam)
    N, fr = float_left_null_space(P, rtol=tol)
    if N.shape[0] == 0:
        return None, None, fr
    S, V = N[:, :m0], N[:, m0:]
    U, s, Wt = np.linalg.svd(S, full_matrices=False)
    keep = s > 1e-6 * s[0] if s.size else np.zeros(0, bool)
    if not np.any(keep):
        return None, None, fr
    U, s, Wt = U[:, keep], s[keep], Wt[keep]
    C = (U / s).T  # coefficient rows on N: C S = Wt (orthonormal)
    return Wt, -(C @ V), fr  # PhiB_S (on L0's rows), JB


def phi_rank(Phi, tol):
    nr = np.linalg.norm(Phi, axis=1)
    nr[nr == 0] = 1.0
    return float_rank(Phi / nr[:, None], rtol=tol)


def lstsq_relative(Bm, M):
    """X with X Bm ≈ M, and the relative residual ‖X Bm − M‖ / ‖M‖."""
    X, *_ = np.linalg.lstsq(Bm.T, M.T, rcond=None)
    X = X.T
    nm = np.linalg.norm(M)
    return X, float(np.linalg.norm(X @ Bm - M) / (nm if nm > 0 else 1.0))


def fmt(v: float) -> str:
    return f"{v:.12g}"


def one_row_lambda(F, H, L, M, tol):
    """The one λ (or None) at which a one-row virtual sensor / interval observer exists when
    it does not for generic λ (METHOD §2b). Φ ∝ M − Q H needs (Q, J*) E0 = m0 − λ m1 with
    E0 = [H L, H F; 0, H], m0 = (M L, M F), m1 = (0, M) (λ H absorbed into J*): λ enters
    linearly, so it is the coefficient of m1 in the least-squares solution of
    (x, λ) [E0; m1] = m0, kept when the relative residual is below ``tol``-scaled 1e-7 and
    m1 is not in rowspace E0 (then every λ or none works: the defaults decide)."""
    if M.shape[0] != 1:
        return None
    n, l, p = F.shape[0], H.shape[0], L.shape[1]  # noqa: E741
    E0 = np.block([[H @ L, H @ F], [np.zeros((l, p)), H]])
    m0 = np.hstack([M @ L, M @ F])
    m1 = np.hstack([np.zeros((1, p)), M])
    _, r1 = lstsq_relative(E0, m1)
    if r1 <= max(1e-7, 100.0 * tol):
        return None
    X, res = lstsq_relative(np.vstack([E0, m1]), m0)
    if res > max(1e-7, 100.0 * tol):
        return None
    return float(X[0, -1])


def lambda_set_text(lams) -> str:
    """{λ1, λ2, …} for messages; long lists (the n default λ of a large model) abridged."""
    shown = [fmt(v) for v in lams[:6]]
    more = f", … ({len(lams)} values)" if len(lams) > 8 else ""
    if not more:
        shown = [fmt(v) for v in lams]
    return "{" + ", ".join(shown) + more + "}"


class SearchBudgetSpent(Exception):
    pass


def _combos(lams, size, tried, budget):
    """The λ-sets of one size in order, at most :data:`_MAX_SETS` of them (noted in tried);
    raises SearchBudgetSpent once :data:`_MAX_TOTAL` sets were examined in all."""
    for i, combo in enumerate(itertools.combinations(lams, size)):
        if i == _MAX_SETS:
            tried.append(f"k={size}: only the first {_MAX_SETS} λ-sets (lexicographic) examined")
            return
        budget[0] += 1
        if budget[0] > _MAX_TOTAL:
            tried.append(f"search stopped after {_MAX_TOTAL} λ-sets in all (at k={size})")
            raise SearchBudgetSpent
        yield combo


def rows_solving_for_z(fam, pools, H, M, n, tol, res_tol, tried, budget):
    """Sets of distinct λ, smallest first: M ≈ Σ c_λ PhiB_λ + Q H by least squares."""
    checked, reachable = None, True  # the pool whose reachability was decided last
    for size in range(1, n):
        lams = pools(size)
        if len(lams) < size:
            break
        if lams != checked:
            # shortcut: not reachable with every family of the pool at once -> not
            # reachable by any subset of it
            checked = lams
            allB = np.vstack([fam[lam][0] for lam in lams] + [H])
            _, res_all = lstsq_relative(allB, M)
            reachable = res_all <= res_tol
            if not reachable:
                msg = (f"M is not in rowspace(H) + Σ_λ rowspace(N_λ L0) over {len(lams)} λ"
                       f" (relative least-squares residual {res_all:.2e} > {res_tol:.0e})")
                if tried and tried[-1].startswith("M is not in rowspace(H)"):
                    tried[-1] = msg  # the latest (widest) pool says it all
                else:
                    tried.append(msg)
        if not reachable:
            continue
        report(f"designing (float, Jordan form): k = {size}, λ-sets from {len(lams)} values")
        fails = 0
        for combo in _combos(lams, size, tried, budget):
            if pools.narrow and fails >= _GENERIC_FAILS:
                break  # generic λ: the other sets of this size fail the same way
            Bm = np.vstack([fam[lam][0] for lam in combo] + [H])
            X, res = lstsq_relative(Bm, M)
            if res > res_tol:
                fails += 1
                if len(tried) < 12:
                    tried.append(f"k={size}, λ = ({', '.join(map(fmt, combo))}): z not reachable"
                                 f" (relative residual {res:.2e})")
                continue
            rows, off = [], 0
            for lam in combo:
                PhiB, JB = fam[lam]
                c = X[:, off:off + PhiB.shape[0]]
                off += PhiB.shape[0]
                if M.shape[0] > 1:  # several estimates: a basis of the rows they need
                    _, s, Vt = np.linalg.svd(c, full_matrices=False)
                    c = Vt[s > res_tol * (s[0] if s.size else 0.0)] if s.size and s[0] > 0 else c[:0]
                for ci in c:
                    if np.linalg.norm(ci) > res_tol * np.linalg.norm(M):
                        rows.append((lam, ci @ PhiB, ci @ JB))
            if len({r[0] for r in rows}) != size:
                continue  # a smaller set does it
            Phi = np.vstack([r[1] for r in rows])
            if phi_rank(Phi, PHI_RTOL).rank < len(rows):
                continue
            return rows, {}
    return None


def residual_rows(fam, pools, H, D, n, tol, res_tol, tried, budget):
    """Sets of distinct λ, smallest first: rows Φ_i = c_i PhiB_i with Σ Φ_i ∈ rowspace(H)
    (intersection by SVD of [B; H]) and every fault column seen by some row."""
    nD = np.linalg.norm(D, axis=0)
    nD[nD == 0] = 1.0
    rng = np.random.default_rng(7)

    def seen(Phi):
        rel = np.abs(Phi @ D) / (np.maximum(np.linalg.norm(Phi, axis=1), 1e-300)[:, None] * nD)
        return np.any(rel > res_tol, axis=0) if D.shape[1] else np.zeros(0, bool)

    for size in range(1, n):
        lams = pools(size)
        if len(lams) < size:
            break
        report(f"designing (float, Jordan form): k = {size}, λ-sets from {len(lams)} values")
        fails = 0
        for combo in _combos(lams, size, tried, budget):
            if pools.narrow and fails >= _GENERIC_FAILS:
                break  # generic λ: the other sets of this size fail the same way
            dims = [fam[lam][0].shape[0] for lam in combo]
            Bm = np.vstack([fam[lam][0] for lam in combo])
            BH = np.vstack([Bm, H])
            N, fr = float_left_null_space(BH, rtol=min(tol, default_rtol(BH.shape)))
            X = N[:, :Bm.shape[0]]
            if X.shape[0] == 0 or np.linalg.norm(X) <= res_tol:
                fails += 1
                if len(tried) < 12:
                    tried.append(f"k={size}, λ = ({', '.join(map(fmt, combo))}): no combination"
                                 f" of the rows lies in rowspace(H) ({fr.evidence()})")
                continue
            cands = list(N) + [g @ N for g in rng.standard_normal((6, N.shape[0]))]
            why = "no candidate sees every fault with rank Φ = k"
            for v in cands:
                x, h = v[:Bm.shape[0]], v[Bm.shape[0]:]
                rows, used, off = [], [], 0
                for lam, d in zip(combo, dims):
                    PhiB, JB = fam[lam]
                    c = x[off:off + d]
                    off += d
                    used.append(np.linalg.norm(c) > res_tol * np.linalg.norm(x))
                    rows.append([lam, c])
                if not any(used):
                    continue
                # a λ not used by the residual: give it the member most sensitive to the
                # faults the others miss (exact path: any row may see a fault)
                Phi = np.vstack([c @ fam[lam][0] if u else np.zeros(n)
                                 for (lam, c), u in zip(rows, used)])
                miss = ~seen(Phi[used]) if D.shape[1] else np.zeros(0, bool)
                if not all(used):
                    if not np.any(miss):
                        continue  # a smaller set does it
                    for i, u in enumerate(used):
                        if not u:
                            lam = rows[i][0]
                            T = fam[lam][0] @ D[:, miss]
                            uu, _, _ = np.linalg.svd(T, full_matrices=False)
                            rows[i][1] = uu[:, 0]
                    Phi = np.vstack([c @ fam[lam][0] for lam, c in rows])
                    miss = ~seen(Phi)
                if np.any(miss):
                    why = f"fault column(s) {[i + 1 for i in np.flatnonzero(miss)]} not seen (Φ D ≈ 0)"
                    continue
                if phi_rank(Phi, PHI_RTOL).rank < size:
                    why = "rank Φ < k"
                    continue
                out = [(lam, c @ fam[lam][0], c @ fam[lam][1]) for lam, c in rows]
                Hs = np.array([[1.0 if u else 0.0 for u in used]])
                # Σ_used Φ_i = x B = −h H
                return out, {"H_star": Hs, "R_star": -h[None, :]}
            if len(tried) < 12:
                tried.append(f"k={size}, λ = ({', '.join(map(fmt, combo))}): {why}")
    return None
