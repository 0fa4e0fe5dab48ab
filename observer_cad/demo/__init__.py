"""Stage 11 — the demo: the seed papers' examples, their figures and the report.
"""
from ._demo import (CASES, EXAMPLES_DIR, FIGURES, Case, Run, run_demo, DIAGNOSABILITY, BANK_FIGURE, DiagnosabilityExample)
from ._evaluation import (EvaluationOutcome, run_evaluation, evaluation_section, evaluation_summary, DRIVE_MODEL, BANK_MODEL, ENSEMBLE_MODEL)

__all__ = ["CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo", "DIAGNOSABILITY", "BANK_FIGURE", "DiagnosabilityExample", "EvaluationOutcome", "run_evaluation", "evaluation_section", "evaluation_summary", "DRIVE_MODEL", "BANK_MODEL", "ENSEMBLE_MODEL"]
