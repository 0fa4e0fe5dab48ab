"""Stage 6 — residuals: thresholds, decision rules and their evaluation.
"""
from ._decision import (DecisionRule, Decisions, decision_rule, decide, NO_FAULT, UNKNOWN_PATTERN, MAX_RESIDUALS)
from ._evaluation import (RunOutcome, Metrics, FaultCase, evaluate_result, fault_onsets, true_labels)
from ._threshold import (ErrorSystem, Threshold, ThresholdSpec, guaranteed_threshold, constant_threshold, residual_outputs, min_detectable_fault, DEFAULT_MARGIN)

__all__ = ["DecisionRule", "Decisions", "decision_rule", "decide", "NO_FAULT", "UNKNOWN_PATTERN", "MAX_RESIDUALS", "ErrorSystem", "Threshold", "ThresholdSpec", "guaranteed_threshold", "constant_threshold", "residual_outputs", "min_detectable_fault", "DEFAULT_MARGIN", "RunOutcome", "Metrics", "FaultCase", "evaluate_result", "fault_onsets", "true_labels"]
