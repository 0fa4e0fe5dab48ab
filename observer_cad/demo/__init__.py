"""Stage 11 — the demo: the seed papers' examples, their figures and the report.

The rooms: the cases (``_cases``: what each paper's example runs), running them
(``_designs``), the diagnosability example (``_diagnosability``), the residual
evaluation (``_evaluation``), the figures (``_figures``: the table; ``_figures_000``,
``_figures_001``, ``_figures_002``: one module per seed paper; ``_plotting``: what they
share), the report (``_report``) and :func:`run_demo`, which runs them in order (``_run``).
"""
from ._cases import (CASES, EXAMPLES_DIR, Case, Run, DIAGNOSABILITY, BANK_FIGURE, DiagnosabilityExample)
from ._figures import FIGURES
from ._run import run_demo
from ._evaluation import (EvaluationOutcome)

__all__ = [
    "CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo", "DIAGNOSABILITY",
    "BANK_FIGURE", "DiagnosabilityExample", "EvaluationOutcome"
]
