"""Stage 8 — the command line (``observer-cad``) and the seed-paper demo.

The demo's names (:mod:`._demo`: numpy, the whole pipeline, plots) are imported on first
use (PEP 562), so that ``observer-cad design`` does not pay for them (issue 14 item 5).
"""
from ._main import (main, build_parser)

_DEMO = ("CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo", "DIAGNOSABILITY",
         "BANK_FIGURE", "DiagnosabilityExample")

__all__ = ["CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo", "DIAGNOSABILITY", "BANK_FIGURE",
           "DiagnosabilityExample", "main", "build_parser"]


def __getattr__(name):
    if name in _DEMO:
        import importlib
        value = getattr(importlib.import_module(f"{__name__}._demo"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'observer_cad.cli' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
