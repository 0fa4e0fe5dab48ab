"""Stage 12 — the command line (``observer-cad``).

The demo's names (:mod:`observer_cad.demo`: numpy, the whole pipeline, plots) are
imported on first use (PEP 562), so that ``observer-cad design`` does not pay for them.
"""
from ._main import main
from ._parser import build_parser

_DEMO = ("CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo", "DIAGNOSABILITY",
         "BANK_FIGURE", "DiagnosabilityExample")

__all__ = ["CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo", "DIAGNOSABILITY", "BANK_FIGURE",
           "DiagnosabilityExample", "main", "build_parser"]


def __getattr__(name):
    if name in _DEMO:
        from ..demo import (BANK_FIGURE, CASES, DIAGNOSABILITY, EXAMPLES_DIR, FIGURES, Case,
                            DiagnosabilityExample, Run, run_demo)
        found = {k: v for k, v in locals().items() if k in _DEMO}
        globals().update(found)
        return found[name]
    raise AttributeError(f"module 'observer_cad.cli' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
