"""Sliding-mode observers (seed 002 §5).
"""
from ._sliding import (K1, EPS, TAU, design_sliding, sliding_pencil, admissible_sliding_lambdas, GainBound, GainTerm, gain_bound, reaching_time)

__all__ = [
    "K1", "EPS", "TAU", "design_sliding", "sliding_pencil", "admissible_sliding_lambdas",
    "GainBound", "GainTerm", "gain_bound", "reaching_time"
]
