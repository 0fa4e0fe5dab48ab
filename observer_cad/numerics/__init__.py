"""Stage 2 — numerics: exact linear algebra over QQ and QQ(parameters) with recorded pivot
conditions, float linear algebra with rank evidence, interval arithmetic on matrices.
"""
from ._floats import (np_exact, to_sympy_float, SingleThreadBLAS, rationalize_floats, rational_approximation, algebraic_to_float, ALGEBRAIC_DIGITS, readable, full_int_text, with_full_int_text)
from ._intervals import (pos, neg, box_min, box_max, comparison_stability)
from ._signs import SignAlternative, gordan_alternative, positive_combination
from ._float_rank import (default_rtol, rank_from_sv, FloatRank, float_rank, float_left_null_space)
from ._linalg import (ExactRank, exact_rank, left_null_space, echelon_rows, solve_left, nonzero_conditions, denominator_conditions, to_domain_matrix, rational_rref, rational_left_null, GrowingLeftNull, left_null_echelon, exact_rank_value, as_rational, from_rational, RATIONAL_BACKEND, exact_product, number_field)

__all__ = [
    "np_exact", "to_sympy_float", "SingleThreadBLAS", "rationalize_floats",
    "rational_approximation", "algebraic_to_float", "ALGEBRAIC_DIGITS", "readable",
    "full_int_text", "with_full_int_text", "pos", "neg", "box_min", "box_max",
    "comparison_stability", "default_rtol", "rank_from_sv", "ExactRank", "FloatRank",
    "exact_rank", "left_null_space", "echelon_rows", "solve_left", "float_rank",
    "float_left_null_space", "nonzero_conditions", "denominator_conditions", "to_domain_matrix",
    "rational_rref", "rational_left_null", "GrowingLeftNull", "left_null_echelon",
    "exact_rank_value", "as_rational", "from_rational", "RATIONAL_BACKEND", "exact_product",
    "number_field", "SignAlternative", "gordan_alternative", "positive_combination"
]
