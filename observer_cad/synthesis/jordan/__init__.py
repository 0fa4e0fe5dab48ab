"""The Jordan canonical form (METHOD §2b), exact and float, with the proofs that a
design has the fewest rows (:mod:`.minimality`).
"""
from ._float import (admissible_lambdas_float, design_jordan_float, DEFAULT_RTOL)
from ._jordan import (Admissible, admissible_lambdas, design_jordan, design_jordan_unknown_input)
from ._lambda_search import (SpecialLambdas, SpanRows, one_row_lambdas, family_jump_lambdas, rank_drop_lambdas, span_rows, span_pencil, exact_real_roots, polynomial_row, coefficient_rows)

__all__ = ["admissible_lambdas_float", "design_jordan_float", "DEFAULT_RTOL", "Admissible", "admissible_lambdas", "design_jordan", "design_jordan_unknown_input", "SpecialLambdas", "SpanRows", "one_row_lambdas", "family_jump_lambdas", "rank_drop_lambdas", "span_rows", "span_pencil", "exact_real_roots", "polynomial_row", "coefficient_rows"]
