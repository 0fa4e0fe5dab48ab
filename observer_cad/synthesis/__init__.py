"""Stage 3 — synthesis: the design value, its certificate, and every designer (canonical,
Jordan exact and float, robust, pole placement, virtual sensors, residual generators,
sliding-mode design, nonlinear checks).
"""
from ._assumptions import (denominator_assumptions, complete_assumptions)
from ._bank import (ResidualBank, design_bank, parse_structure, realised_row, FULL_SEARCH_FAULTS)
from ._canonical import (design_canonical, krylov_blocks, krylov_null_spaces, member_to_phi, FLOAT_AUTO_N)
from ._certificate import (Identity, Certificate, certify_reduced_model, certify_design, certify_against_model, MODEL_PREFIX)
from ._checks import (interval_scale, range_sign, format_number, Domain, RangeAnalyzer, LipschitzResult, MonotoneResult, StabilityResult, lipschitz, is_monotone, is_cooperative, stability_condition, argument_range, derivative_range, model_nonlinearity, reduced_nonlinearity, nonlinear_conditions)
from ._conditioning import (CONDITIONING_LEVEL, CONDITIONING_NAME, CONDITIONING_REFERENCE, conditioning_numbers, conditioning_verdict)
from ._design import (Condition, Design, DesignMatrices, DesignRequest, Form, Method, NonlinearSubstitution, SlidingGainInputs, MATRIX_ORDER)
from ._diagnosability import (analyze, Analysis, FaultAnalysis, PairAnalysis, StructureRow, Suggestion, detecting_orders, MAX_ENUMERATED_FAULTS)
from ._diagnostic import (design_diagnostic_canonical, observer_equations)
from ._dispatch import (design, OBSERVERS)
from ._expr import (parse_json_expression)
from ._jordan import (Admissible, admissible_lambdas, design_jordan, design_jordan_unknown_input)
from ._jordan_float import (admissible_lambdas_float, design_jordan_float, DEFAULT_RTOL)
from ._nonlinear import (substitute_arguments)
from ._poles import (default_eigenvalues, parse_eigenvalues, place_poles, require_stable, pole_placement, PolePlacement, certify_poles, closed_loop_eigenvalues, target_polynomial, PLACEMENT_SEED)
from ._reduced import (observer_symbols, output_symbols, is_stable, jordan_equations, reduced_equations, residual_outputs, estimate_outputs, named_outputs)
from ._robust import (design_robust_canonical, design_robust_jordan, robust_basis, jordan_candidates, TASK_RTOL)
from ._signature import (FaultSensitivity, fault_signature, fault_sensitivity, residual_response, SIGNATURE_RTOL)
from ._sliding import (K1, EPS, TAU, design_sliding, sliding_pencil, admissible_sliding_lambdas, GainBound, GainTerm, gain_bound, reaching_time, RK4_STABILITY)
from ._task import (task_for, task_parts)
from ._virtual import (design_virtual_sensor_canonical)

__all__ = ["denominator_assumptions", "complete_assumptions", "ResidualBank", "design_bank", "parse_structure", "realised_row", "FULL_SEARCH_FAULTS", "design_canonical", "krylov_blocks", "krylov_null_spaces", "member_to_phi", "FLOAT_AUTO_N", "Identity", "Certificate", "certify_reduced_model", "certify_design", "certify_against_model", "MODEL_PREFIX", "interval_scale", "range_sign", "format_number", "Domain", "RangeAnalyzer", "LipschitzResult", "MonotoneResult", "StabilityResult", "lipschitz", "is_monotone", "is_cooperative", "stability_condition", "argument_range", "derivative_range", "model_nonlinearity", "reduced_nonlinearity", "nonlinear_conditions", "CONDITIONING_LEVEL", "CONDITIONING_NAME", "CONDITIONING_REFERENCE", "conditioning_numbers", "conditioning_verdict", "Condition", "Design", "DesignMatrices", "DesignRequest", "Form", "Method", "NonlinearSubstitution", "SlidingGainInputs", "MATRIX_ORDER", "analyze", "Analysis", "FaultAnalysis", "PairAnalysis", "StructureRow", "Suggestion", "detecting_orders", "MAX_ENUMERATED_FAULTS", "design_diagnostic_canonical", "observer_equations", "design", "OBSERVERS", "parse_json_expression", "Admissible", "admissible_lambdas", "design_jordan", "design_jordan_unknown_input", "admissible_lambdas_float", "design_jordan_float", "DEFAULT_RTOL", "substitute_arguments", "default_eigenvalues", "parse_eigenvalues", "place_poles", "require_stable", "pole_placement", "PolePlacement", "certify_poles", "closed_loop_eigenvalues", "target_polynomial", "PLACEMENT_SEED", "observer_symbols", "output_symbols", "is_stable", "jordan_equations", "reduced_equations", "residual_outputs", "estimate_outputs", "named_outputs", "design_robust_canonical", "design_robust_jordan", "robust_basis", "jordan_candidates", "TASK_RTOL", "FaultSensitivity", "fault_signature", "fault_sensitivity", "residual_response", "SIGNATURE_RTOL", "K1", "EPS", "TAU", "design_sliding", "sliding_pencil", "admissible_sliding_lambdas", "GainBound", "GainTerm", "gain_bound", "reaching_time", "RK4_STABILITY", "task_for", "task_parts", "design_virtual_sensor_canonical"]
