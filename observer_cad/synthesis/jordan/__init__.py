"""The Jordan canonical form (METHOD §2b), exact and float, with the proofs that a
design has the fewest rows (:mod:`.minimality`).

Modules, by step: ``_jordan`` (the design: the steps in order), ``_problem`` (1. the
task), ``_admissible`` and ``_lambdas`` (2. the admissible λ and the λ strategies),
``_lambda_search`` (the special λ), ``_row_search``, ``_lambda_sets`` and ``_rows_check``
(3. the rows), :mod:`.minimality` (4. the proof), and the float path (``_float``,
``_float_lambdas``, ``_float_rows``).
"""
from ._admissible import Admissible, admissible_lambdas
from ._float import design_jordan_float
from ._float_lambdas import (admissible_lambdas_float)
from ._jordan import design_jordan, design_jordan_unknown_input
from ._lambda_search import (SpecialLambdas, QRowsVerdict, one_row_lambdas, q_rows_possible, exact_real_roots)
from .minimality import proof_seconds_value

__all__ = [
    "admissible_lambdas_float", "design_jordan_float", "Admissible", "admissible_lambdas",
    "design_jordan", "design_jordan_unknown_input", "SpecialLambdas", "QRowsVerdict",
    "one_row_lambdas", "q_rows_possible", "exact_real_roots", "proof_seconds_value"
]
