"""Stage 3 — synthesis: the design value and every designer, in rooms that follow the
method:

* :mod:`.certificates` — certificates, assumptions, conditioning, fault signatures;
* :mod:`.core` — the design value, the reduced model's equations, the task, pole placement;
* :mod:`.canonical` — the identification canonical form (METHOD §2a);
* :mod:`.jordan` — the Jordan canonical form (METHOD §2b), with :mod:`.jordan.minimality`;
* :mod:`.robust` — robust (approximate) decoupling (METHOD §2d);
* :mod:`.sliding` — sliding-mode observers (seed 002 §5);

and :func:`design`, the one entry that dispatches to them.
"""
from .certificates import (Identity, Certificate, certify_reduced_model, certify_design, certify_against_model, MODEL_PREFIX, denominator_assumptions, complete_assumptions, CONDITIONING_LEVEL, CONDITIONING_NAME, conditioning_numbers, FaultSensitivity, fault_sensitivity)
from .core import (Condition, Design, DesignMatrices, DesignRequest, Form, Method, NonlinearSubstitution, SlidingGainInputs, parse_json_expression, check_model_hash, substitute_arguments, default_eigenvalues, place_poles, pole_placement, PolePlacement, certify_poles, closed_loop_eigenvalues, target_polynomial, PLACEMENT_SEED, observer_symbols, output_symbols, is_stable)
from .canonical import (design_canonical, krylov_blocks, krylov_null_spaces, member_to_phi,
                        FLOAT_AUTO_N, design_diagnostic_canonical, observer_equations,
                        design_virtual_sensor_canonical, shift_matrix)
from .jordan import (Admissible, admissible_lambdas, design_jordan, design_jordan_unknown_input, admissible_lambdas_float, design_jordan_float)
from .robust import (design_robust_canonical, design_robust_jordan, robust_basis, jordan_candidates)
from .sliding import (K1, EPS, TAU, design_sliding, sliding_pencil, admissible_sliding_lambdas, GainBound, GainTerm, gain_bound, reaching_time)
from ._continuous_estimation import (continuous_estimation_check)
from ._dispatch import (design)
from ._frozen import (load_design_data, recomputed_design)

__all__ = [
    "Identity", "Certificate", "certify_reduced_model", "certify_design",
    "certify_against_model", "MODEL_PREFIX", "denominator_assumptions", "complete_assumptions",
    "CONDITIONING_LEVEL", "CONDITIONING_NAME", "conditioning_numbers", "FaultSensitivity",
    "fault_sensitivity", "Condition", "Design", "DesignMatrices", "DesignRequest", "Form",
    "Method", "NonlinearSubstitution", "SlidingGainInputs", "parse_json_expression",
    "substitute_arguments", "default_eigenvalues", "place_poles", "pole_placement",
    "PolePlacement", "certify_poles", "closed_loop_eigenvalues", "target_polynomial",
    "PLACEMENT_SEED", "observer_symbols", "output_symbols", "is_stable", "design_canonical",
    "krylov_blocks", "krylov_null_spaces", "member_to_phi", "FLOAT_AUTO_N",
    "design_diagnostic_canonical", "observer_equations", "design_virtual_sensor_canonical",
    "shift_matrix", "Admissible", "admissible_lambdas", "design_jordan",
    "design_jordan_unknown_input", "admissible_lambdas_float", "design_jordan_float",
    "design_robust_canonical", "design_robust_jordan", "robust_basis", "jordan_candidates",
    "K1", "EPS", "TAU", "design_sliding", "sliding_pencil", "admissible_sliding_lambdas",
    "GainBound", "GainTerm", "gain_bound", "reaching_time", "continuous_estimation_check",
    "design", "check_model_hash", "load_design_data", "recomputed_design"
]
