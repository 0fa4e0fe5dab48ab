"""Stage 4 — analysis: diagnosability (detectability, isolability, the achievable
structure matrix), the nonlinear checks, and residual banks that realise a structure.
"""
from ._bank import (ResidualBank, design_bank, parse_structure)
from ._frozen import (load_design, BANK_KIND)
from ._ranges import (interval_scale, range_sign, format_number, Domain, RangeAnalyzer, argument_range, derivative_range)
from ._checks import (LipschitzResult, MonotoneResult, StabilityResult, lipschitz, is_monotone, is_cooperative, stability_condition, model_nonlinearity, reduced_nonlinearity, nonlinear_conditions)
from ._diagnosability import (analyze, Analysis, FaultAnalysis, PairAnalysis, StructureRow, StrongFault, Suggestion, detecting_orders, feedthrough_orders, parse_frequencies)

__all__ = ["parse_frequencies", 
    "load_design", "BANK_KIND", "ResidualBank", "design_bank", "parse_structure",
    "interval_scale", "range_sign", "format_number", "Domain", "RangeAnalyzer",
    "LipschitzResult", "MonotoneResult", "StabilityResult", "lipschitz", "is_monotone",
    "is_cooperative", "stability_condition", "argument_range", "derivative_range",
    "model_nonlinearity", "reduced_nonlinearity", "nonlinear_conditions", "analyze", "Analysis",
    "FaultAnalysis", "PairAnalysis", "StructureRow", "StrongFault", "Suggestion",
    "detecting_orders", "feedthrough_orders"
]
