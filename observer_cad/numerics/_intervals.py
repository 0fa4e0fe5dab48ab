"""Interval arithmetic on matrices: the positive and negative parts of a matrix and the
extremes of A v over a box (METHOD §3)."""
from __future__ import annotations

import sympy as sp

__all__ = ["pos", "neg", "box_min", "box_max", "comparison_stability"]


def pos(A):
    """A⁺ = max(0, A) elementwise (numeric matrices)."""
    return sp.Matrix(A).applyfunc(lambda e: sp.Max(e, 0) if e.free_symbols else (e if e > 0 else 0))


def neg(A):
    """A⁻ = A⁺ − A ≥ 0."""
    return (pos(A) - sp.Matrix(A)).applyfunc(sp.cancel)


def box_min(A, lo, hi):
    """min of A v over the box lo ≤ v ≤ hi: A⁺ lo − A⁻ hi.

    Examples
    --------
    >>> import sympy as sp
    >>> from observer_cad.numerics import box_min, box_max
    >>> A = sp.Matrix([[1, -2]])
    >>> box_min(A, [0, 0], [1, 1]), box_max(A, [0, 0], [1, 1])
    (Matrix([[-2]]), Matrix([[1]]))
    """
    return pos(A) * sp.Matrix(lo) - neg(A) * sp.Matrix(hi)


def box_max(A, lo, hi):
    """max of A v over the box lo ≤ v ≤ hi: A⁺ hi − A⁻ lo."""
    return pos(A) * sp.Matrix(hi) - neg(A) * sp.Matrix(lo)


def comparison_stability(M, time: str):
    """(stable, figure, minors): the exact test that −M (continuous time, M Metzler) or I − M
    (discrete time, M ≥ 0) is a nonsingular M-matrix — every leading principal minor > 0 —
    which is equivalent to spectral abscissa α(M) < 0 (resp. spectral radius ρ(M) < 1).
    A minor whose sign sympy cannot decide counts as not proven. ``figure`` is α(M) or
    ρ(M) in floating point (inf when M has unbounded entries, with no minors).

    Examples
    --------
    The comparison system of the interval width of ``models/nonmonotone_chain.py``:

    >>> import sympy as sp
    >>> from observer_cad.numerics import comparison_stability
    >>> M = sp.Matrix([[-7, 9], [3, -21]]) / 8
    >>> stable, alpha, minors = comparison_stability(M, "continuous")
    >>> stable, round(alpha, 6), minors
    (True, -0.660275, [7/8, 15/8])
    """
    import numpy as np
    M = sp.Matrix(M)
    k = M.rows
    if any(e.has(sp.oo, -sp.oo, sp.zoo) for e in M):
        return False, float("inf"), []
    Z = -M if time == "continuous" else sp.eye(k) - M
    minors = [sp.simplify(Z[:r, :r].det()) for r in range(1, k + 1)]
    try:
        stable = all(bool(m > 0) for m in minors)
    except TypeError:
        stable = False
    if not k:
        return stable, float("-inf") if time == "continuous" else 0.0, minors
    ev = np.linalg.eigvals(np.array(M.evalf(), dtype=float))
    fig = float(np.max(ev.real)) if time == "continuous" else float(np.max(np.abs(ev)))
    return stable, fig, minors
