"""Stage 6 — residuals: thresholds, decision rules and their evaluation.
"""
from ._decision import (DecisionRule, Decisions, decision_rule, decide, NO_FAULT, UNKNOWN_PATTERN, MAX_RESIDUALS)
from ._evaluation import (RunOutcome, Metrics, FaultCase, evaluate_result, fault_onsets, true_labels)
from ._sampled import (sampled_threshold, SAMPLED_DISCRETISATIONS, ROUNDOFF_FACTOR)
from ._l1 import (WorstCase, worst_case_sums, transient_envelope)
from ._threshold import (ErrorSystem, Threshold, ThresholdSpec, guaranteed_threshold, constant_threshold, residual_outputs, min_detectable_fault, DEFAULT_MARGIN, RELATIVE_ROUNDOFF)

__all__ = ["DecisionRule", "Decisions", "decision_rule", "decide", "NO_FAULT", "UNKNOWN_PATTERN", "MAX_RESIDUALS", "ErrorSystem", "Threshold", "ThresholdSpec", "guaranteed_threshold", "constant_threshold", "residual_outputs", "min_detectable_fault", "DEFAULT_MARGIN", "RELATIVE_ROUNDOFF", "sampled_threshold", "SAMPLED_DISCRETISATIONS", "ROUNDOFF_FACTOR", "WorstCase", "worst_case_sums", "transient_envelope", "RunOutcome", "Metrics", "FaultCase", "evaluate_result", "fault_onsets", "true_labels"]
