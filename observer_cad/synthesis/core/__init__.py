"""The design value, the reduced model's equations, the task and pole placement; the one
preparation step and the exact / float arithmetic strategies every designer uses.
"""
from ._values import (Condition, DesignMatrices, DesignRequest, Form, Method, NonlinearSubstitution, SlidingGainInputs, PROOF_SECONDS)
from ._design import (Design)
from ._expr import (parse_json_expression)
from ._design_file import (check_model_hash)
from ._nonlinear import (substitute_arguments)
from ._prepare import (Prepared, prepare, FLOAT_AUTO_N, METHODS)
from ._arithmetic import (Arithmetic, ExactArithmetic, RationalArithmetic, FloatArithmetic, arithmetic, arithmetic_for)
from ._poles import (default_eigenvalues, parse_eigenvalues, place_poles, pole_placement, PolePlacement, certify_poles, closed_loop_eigenvalues, target_polynomial, PLACEMENT_SEED, require_stable)
from ._reduced import (observer_symbols, output_symbols, is_stable, jordan_equations, reduced_equations, residual_outputs, estimate_outputs, named_outputs, sliding_equations, K1, EPS, TAU, INJECTIONS)
from ._task import (task_for, task_parts)
from ._feedthrough import (has_output_feedthrough, FeedthroughView, feedthrough_view, lift_design, zero_order_design, zero_order_first)
from ._feedthrough_kinds import (lift_kind_design, check_kind_feedthrough, check_robust_feedthrough, lift_robust_design)

__all__ = [
    "Prepared", "prepare", "FLOAT_AUTO_N", "METHODS", "Arithmetic", "ExactArithmetic",
    "RationalArithmetic", "FloatArithmetic", "arithmetic", "arithmetic_for", "Condition",
    "Design", "DesignMatrices", "DesignRequest", "Form", "Method", "NonlinearSubstitution",
    "SlidingGainInputs", "PROOF_SECONDS", "parse_json_expression", "check_model_hash",
    "substitute_arguments", "default_eigenvalues", "parse_eigenvalues", "place_poles",
    "pole_placement", "PolePlacement", "certify_poles", "closed_loop_eigenvalues",
    "target_polynomial", "PLACEMENT_SEED", "require_stable", "observer_symbols",
    "output_symbols", "is_stable", "jordan_equations", "reduced_equations", "residual_outputs",
    "estimate_outputs", "named_outputs", "sliding_equations", "K1", "EPS", "TAU", "INJECTIONS",
    "task_for", "task_parts", "has_output_feedthrough", "FeedthroughView", "feedthrough_view",
    "lift_design", "zero_order_design", "zero_order_first", "lift_kind_design", "check_kind_feedthrough",
    "check_robust_feedthrough", "lift_robust_design"
]
