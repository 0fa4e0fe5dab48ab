"""Proofs that a Jordan design has the fewest rows (METHOD §2b).
"""
from ._box_cover import (BoxCover, box_cover, quadric_cover, BOX_CELLS, BOX_DEPTH, PROBES)
from ._order_bound import (OrderBound, ChainOrder, estimation_order_bound, residual_order_bound, nonlinear_jordan_bound, OneMoreRow, one_more_row, one_row_short, two_more_rows, three_more_rows, family_order, chain_order, chain_system, hyperplane_functional, hyperplane_corners, hyperplane_member, plane_order, spread_lambdas, MAX_SUBSETS)

__all__ = ["BoxCover", "box_cover", "quadric_cover", "BOX_CELLS", "BOX_DEPTH", "PROBES", "OrderBound", "ChainOrder", "estimation_order_bound", "residual_order_bound", "nonlinear_jordan_bound", "OneMoreRow", "one_more_row", "one_row_short", "two_more_rows", "three_more_rows", "family_order", "chain_order", "chain_system", "hyperplane_functional", "hyperplane_corners", "hyperplane_member", "plane_order", "spread_lambdas", "MAX_SUBSETS"]
