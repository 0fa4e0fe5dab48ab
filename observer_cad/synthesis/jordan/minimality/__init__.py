"""Proofs that a Jordan design has the fewest rows (METHOD §2b), behind one entry:
:func:`prove_minimal` (with a time budget). The row search also asks two of its
questions itself — which λ a model of m rows can have (:func:`chain_order`) and whether
q + 1 rows are possible (:func:`q_plus_one_rows_possible`) — and hands the answers to
the proof in the :class:`MinimalityProblem`.

Modules, by the question each answers: ``_prove`` (the entry and its stages),
``_condition`` (the condition's text), ``_bounds`` (how many states every model needs),
``_chains`` (which λ an m-row model can have), ``_families`` (does a family of monic
polynomials have a member with real stable roots), ``_box_cover`` (exact exclusion over
the root box), ``_row_counts`` (can k rows give z), ``_q_plus_one_rows``,
``_q_plus_two_rows``, ``_rows_in_six_dimensions`` (the shapes of the rows' images),
``_exterior``, ``_roots`` (shared algebra), ``_clock`` (the time budget).
"""
from ._box_cover import (BoxCover, box_cover, quadric_cover, pencil_cover)
from ._bounds import OrderBound, estimation_order_bound, residual_order_bound, nonlinear_jordan_bound
from ._chains import chain_order, chain_system, spread_lambdas
from ._clock import ProofClock, ProofStopped, UNLIMITED, proof_seconds_value
from ._families import (ChainOrder, family_order, plane_order, hyperplane_corners, hyperplane_member, MAX_SUBSETS)
from ._prove import MinimalityProblem, ChosenRows, prove_minimal
from ._row_counts import (q_plus_one_rows_possible, basis_minus_one_rows_possible, q_plus_two_rows_possible,
                          q_plus_three_rows_possible)
from ._rows_verdict import RowsVerdict

__all__ = [
    "prove_minimal", "MinimalityProblem", "ChosenRows", "ProofClock", "ProofStopped",
    "UNLIMITED", "proof_seconds_value", "BoxCover", "box_cover", "quadric_cover",
    "pencil_cover", "OrderBound", "estimation_order_bound", "residual_order_bound",
    "nonlinear_jordan_bound", "chain_order", "chain_system", "spread_lambdas", "ChainOrder",
    "family_order", "plane_order", "hyperplane_corners", "hyperplane_member", "MAX_SUBSETS",
    "RowsVerdict", "q_plus_one_rows_possible", "basis_minus_one_rows_possible",
    "q_plus_two_rows_possible", "q_plus_three_rows_possible"
]
