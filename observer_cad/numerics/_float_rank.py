"""Floating-point linear algebra with rank evidence: SVD with a stated tolerance;
:class:`FloatRank` carries the singular values around the cut and the gap, the evidence
for the rank decision."""
from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["default_rtol", "rank_from_sv", "FloatRank", "float_rank", "float_left_null_space"]


@dataclasses.dataclass(frozen=True)
class FloatRank:
    """Numerical rank from an SVD, with the evidence.

    ``singular_values`` (all, descending), ``tol`` the cut, ``rank`` the number above
    it, ``gap`` the ratio σ_rank / σ_(rank+1) (inf when nothing is cut). ``shape`` is
    the matrix's shape and ``rtol`` the relative tolerance the cut was derived from
    (``tol = max(atol, rtol·σ_1)``).

    The decision is trustworthy when the singular values on both sides of the cut are
    far from it: :attr:`margin` is ``min(σ_rank / tol, tol / σ_(rank+1))`` over the
    sides that exist (inf for a zero matrix with nothing kept and nothing cut).
    """

    rank: int
    singular_values: tuple
    tol: float
    gap: float
    shape: tuple = ()
    rtol: float | None = None

    @property
    def margin(self) -> float:
        s, r, tol = self.singular_values, self.rank, self.tol
        out = []
        if r > 0:
            out.append(s[r - 1] / tol if tol > 0 else float("inf"))
        if r < len(s):
            out.append(tol / s[r] if s[r] > 0 else float("inf"))
        return float(min(out)) if out else float("inf")

    @property
    def full(self) -> bool:
        """Nothing was cut: the rank is min(shape), decided by σ_min alone."""
        return self.rank == len(self.singular_values)

    def evidence(self) -> str:
        s = self.singular_values
        r = self.rank
        shape = f" of {self.shape[0]}×{self.shape[1]}" if len(self.shape) == 2 else ""
        tol = f"tol {self.tol:.2e}" + (f" = {self.rtol:.1e}·σ_1" if self.rtol is not None
                                      and s and self.tol == self.rtol * s[0] else "")
        around = []
        if r > 0:
            kept = f"σ_{r} = {s[r - 1]:.3e}"
            if self.tol > 0:
                kept += f" = {s[r - 1] / self.tol:.1e}·tol"
            around.append(kept)
        if r < len(s):
            cut = f"σ_{r + 1} = {s[r]:.3e}"
            if self.tol > 0:
                cut += f" = {s[r] / self.tol:.1e}·tol"
            around.append(cut)
        if not s:
            tail = "empty matrix"
        elif s[0] == 0:
            tail = "zero matrix"
        elif self.full:
            rc = self.shape if len(self.shape) == 2 else (0, 0)
            kind = "column " if rc[1] < rc[0] else "row " if rc[0] < rc[1] else ""
            tail = f"nothing cut: full {kind}rank"
        else:
            tail = "gap " + ("inf" if self.gap == float("inf") else f"{self.gap:.2e}")
        return f"rank {r}{shape} ({tol}; {', '.join(around + [tail])})"


def default_rtol(shape) -> float:
    return max(shape) * np.finfo(float).eps * 1e3 if len(shape) else 0.0


def rank_from_sv(s, shape, atol, rtol) -> FloatRank:
    s = np.asarray(s, dtype=float)
    smax = s[0] if s.size else 0.0
    if rtol is None:
        rtol = default_rtol(shape)
    tol = max(atol or 0.0, rtol * smax)
    r = int(np.sum(s > tol))
    if r == 0 or r >= s.size:
        gap = float("inf") if r >= s.size else 0.0
    else:
        gap = float(s[r - 1] / s[r]) if s[r] > 0 else float("inf")
    return FloatRank(r, tuple(float(v) for v in s), float(tol), gap, tuple(int(d) for d in shape),
                     float(rtol))


def float_rank(M, *, atol: float | None = None, rtol: float | None = None) -> FloatRank:
    """Numerical rank by SVD; tolerance ``max(atol, rtol·σ_max)``.

    The default ``rtol`` is ``max(shape)·eps·1e3`` (about 2e-11 for an 80-row matrix).
    """
    M = np.asarray(M, dtype=float)
    if M.size == 0:
        return FloatRank(0, (), 0.0, float("inf"), tuple(M.shape), rtol)
    s = np.linalg.svd(M, compute_uv=False)
    return rank_from_sv(s, M.shape, atol, rtol)


def float_left_null_space(M, *, atol: float | None = None, rtol: float | None = None):
    """Orthonormal basis (rows) of the numerical left null space, and the FloatRank.

    ``N M ≈ 0`` with ``N Nᵀ = I``; the rows span the left singular vectors of the
    singular values at or below the cut (and the structural ones when M has more rows
    than columns).
    """
    M = np.asarray(M, dtype=float)
    m = M.shape[0]
    if M.shape[1] == 0 or m == 0:
        return np.eye(m), FloatRank(0, (), 0.0, float("inf"), tuple(M.shape), rtol)
    U, s, _ = np.linalg.svd(M, full_matrices=True)
    fr = rank_from_sv(s, M.shape, atol, rtol)
    return U[:, fr.rank:].T.copy(), fr
