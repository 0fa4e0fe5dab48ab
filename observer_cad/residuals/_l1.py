"""Worst-case sums of a stable discrete linear error system driven by bounded scalar inputs:
the L1 norm of each impulse response, truncated with a rigorous geometric tail bound, and the
geometric envelope of the initial-error transient (METHOD §3, residual evaluation).

The error system is ``e(k+1) = F e(k) + Σ_t b_t ψ_t(k)``, ``r(k) = N e(k) + Σ_t c_t ψ_t(k)``
with each scalar ψ_t(k) ∈ [lo_t, hi_t] at every k and chosen freely from step to step (bang-bang
is allowed). The response of residual i to input t is h_0 = c_t[i], h_j = (N F^{j−1} b_t)[i];
the largest value r_i(k) can take from e(0) = 0 is sup_k Σ_{j ≤ k} max(h_j lo_t, h_j hi_t),
attained by an input sequence, so the sum is the exact worst case (a symbol used by several
terms is one input: its uses with opposite signs cancel inside h_j).

Tail: with β = ‖abs(F^L)‖_∞ < 1 for some L, Σ_{j ≥ J} abs(N F^j b) ≤ (abs(N) 1)·Σ_{m < L}
‖F^{J+m} b‖_∞ / (1 − β) elementwise. Computed in double precision; the caller adds a relative allowance.
"""
from __future__ import annotations

import collections
import dataclasses

import numpy as np

from ..errors import UsageError

__all__ = ["WorstCase", "contraction", "worst_case_sums", "transient_envelope"]

#: the truncation stops once the tail bound is below this fraction of the sum (or at MAX_STEPS)
_REL_TAIL = 1e-12
_MAX_STEPS = 2_000_000


@dataclasses.dataclass(frozen=True)
class WorstCase:
    """Upper and lower worst-case sums per residual (``upper[i] ≥ r_i ≥ lower[i]``), the
    number of impulse-response terms summed and the tail bound added."""

    upper: np.ndarray
    lower: np.ndarray
    steps: int
    tail: float


def contraction(F: np.ndarray, max_power: int = 1 << 24) -> tuple:
    """The smallest power L (doubling) with β = ‖abs(F^L)‖_∞ < 1/2, and β: (L, β). Raises a
    UsageError when F is not a contraction in any power up to ``max_power``."""
    k = F.shape[0]
    if k == 0:
        return 1, 0.0
    P, L = F.copy(), 1
    while L <= max_power:
        beta = float(np.max(np.sum(np.abs(P), axis=1)))
        if beta < 0.5:
            return L, beta
        P, L = P @ P, 2 * L
    raise UsageError("the discrete error system is not stable (‖F^L‖ does not fall below 1/2"
                     f" for L ≤ {max_power}): no bounded band")


def worst_case_sums(F, N, B, Cd, lo, hi) -> WorstCase:
    """Worst-case sums of the inputs ψ_t ∈ [lo_t, hi_t] (columns of B into the error, of Cd
    directly into the residuals; see the module docstring)."""
    F, N, B, Cd = (np.asarray(a, dtype=float) for a in (F, N, B, Cd))
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    m = N.shape[0]
    T = B.shape[1]
    if T == 0:
        return WorstCase(np.zeros(m), np.zeros(m), 0, 0.0)
    L, beta = contraction(F)
    if L > _MAX_STEPS:
        raise UsageError(f"the error system contracts only after {L} steps (more than"
                         f" {_MAX_STEPS:,} summed): too slow for a worst-case band")
    rowN = np.sum(np.abs(N), axis=1)
    big = np.maximum(np.abs(lo), np.abs(hi))

    def terms(H):  # H: m × T responses at one lag
        a, b = H * lo, H * hi
        return np.maximum(a, b), np.minimum(a, b)

    up, dn = terms(Cd)
    S_up, S_dn = up.copy(), dn.copy()
    best_up, best_dn = S_up.copy(), S_dn.copy()
    V = B.copy()
    j = 0
    norms: collections.deque = collections.deque(maxlen=L)
    while True:
        H = N @ V
        up, dn = terms(H)
        S_up += up
        S_dn += dn
        best_up = np.maximum(best_up, S_up)
        best_dn = np.minimum(best_dn, S_dn)
        V = F @ V
        j += 1
        norms.append(np.max(np.abs(V), axis=0) if V.size else np.zeros(T))
        if len(norms) == L and (j % L == 0 or j >= _MAX_STEPS):
            tail_t = np.outer(rowN, np.sum(norms, axis=0) / (1.0 - beta)) * big  # m × T
            scale = np.maximum(np.abs(best_up), np.abs(best_dn)).sum(axis=1) + 1e-300
            if np.all(tail_t.sum(axis=1) <= _REL_TAIL * scale) or j >= _MAX_STEPS:
                break
    # sup over k of the partial sums: the best seen so far, or the last plus the tail
    upper = np.maximum(best_up, S_up + tail_t).sum(axis=1)
    lower = np.minimum(best_dn, S_dn - tail_t).sum(axis=1)
    return WorstCase(upper, lower, j, float(tail_t.sum()))


def transient_envelope(F, N, V0, q: float) -> np.ndarray:
    """K_i with Σ_c abs((N F^k V0)_{i,c}) ≤ K_i q^k for every k ≥ 0 (columns of V0: the initial
    error directions scaled by their radii); q must exceed the spectral radius of F."""
    F, N, V0 = (np.asarray(a, dtype=float) for a in (F, N, V0))
    m = N.shape[0]
    if V0.size == 0 or not np.any(V0):
        return np.zeros(m)
    L, beta = contraction(F)
    # a power L' (multiple of L) with ‖|F^L'|‖ ≤ q^L'
    Lp, Pw, ok = L, np.linalg.matrix_power(F, L), False
    for _ in range(40):
        if float(np.max(np.sum(np.abs(Pw), axis=1))) <= q ** Lp:
            ok = True
            break
        Pw, Lp = Pw @ Pw, 2 * Lp
    if not ok or 2 * Lp > _MAX_STEPS:
        raise UsageError(f"the transient decay rate {q:g} is not above the error system's"
                         f" (or it is reached only after more than {_MAX_STEPS:,} steps)")
    rowN = np.sum(np.abs(N), axis=1)
    K = np.zeros(m)
    V, scale = V0.copy(), 1.0
    j, window = 0, collections.deque(maxlen=Lp)
    while True:
        K = np.maximum(K, np.sum(np.abs(N @ V), axis=1) / scale)
        window.append(float(np.max(np.sum(np.abs(V), axis=1))) / scale)
        V, scale, j = F @ V, scale * q, j + 1
        if len(window) == Lp and j >= 2 * Lp and j % Lp == 0:
            tailK = rowN * max(window)
            if np.all(tailK <= K) or j >= _MAX_STEPS:
                return np.maximum(K, tailK)
