"""Stage 8 — the command line (``observer-cad``) and the seed-paper demo.
"""
from ._demo import (CASES, EXAMPLES_DIR, FIGURES, Case, Run, run_demo, DIAGNOSABILITY, BANK_FIGURE,
                    DiagnosabilityExample)
from ._main import (main, build_parser)

__all__ = ["CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo", "DIAGNOSABILITY", "BANK_FIGURE",
           "DiagnosabilityExample", "main", "build_parser"]
