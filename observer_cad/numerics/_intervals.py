"""Interval arithmetic on matrices: the positive and negative parts of a matrix and the
extremes of A v over a box (METHOD §3)."""
from __future__ import annotations

import sympy as sp

__all__ = ["pos", "neg", "box_min", "box_max"]


def pos(A):
    """A⁺ = max(0, A) elementwise (numeric matrices)."""
    return sp.Matrix(A).applyfunc(lambda e: sp.Max(e, 0) if e.free_symbols else (e if e > 0 else 0))


def neg(A):
    """A⁻ = A⁺ − A ≥ 0."""
    return (pos(A) - sp.Matrix(A)).applyfunc(sp.cancel)


def box_min(A, lo, hi):
    """min of A v over the box lo ≤ v ≤ hi: A⁺ lo − A⁻ hi."""
    return pos(A) * sp.Matrix(lo) - neg(A) * sp.Matrix(hi)


def box_max(A, lo, hi):
    """max of A v over the box lo ≤ v ≤ hi: A⁺ hi − A⁻ lo."""
    return pos(A) * sp.Matrix(hi) - neg(A) * sp.Matrix(lo)
