"""Robust (approximate) decoupling (METHOD §2d).
"""
from ._robust import (design_robust_canonical, design_robust_jordan, robust_basis, jordan_candidates, TASK_RTOL)

__all__ = ["design_robust_canonical", "design_robust_jordan", "robust_basis", "jordan_candidates", "TASK_RTOL"]
