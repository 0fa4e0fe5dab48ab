"""Robust (approximate) decoupling (METHOD §2d).
"""
from ._canonical import (design_robust_canonical, robust_basis)
from ._jordan import (design_robust_jordan, jordan_candidates)

__all__ = [
    "design_robust_canonical", "design_robust_jordan", "robust_basis", "jordan_candidates"
]
