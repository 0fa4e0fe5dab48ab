"""Stage 6 — residuals: thresholds, decision rules and their evaluation.
"""
from ._decision import (DecisionRule, Decisions, decision_rule, decide, NO_FAULT, UNKNOWN_PATTERN)
from ._evaluation import (RunOutcome, Metrics, FaultCase, evaluate_result, fault_onsets, true_labels)
from ._threshold import (ErrorSystem, Threshold, ThresholdSpec, guaranteed_threshold, constant_threshold, residual_names, min_detectable_fault)
from ._l1 import (WorstCase, worst_case_sums, transient_envelope)
from ._sampled import (sampled_threshold, sampled_band_refusal)
from ._intervals import interval_range

__all__ = [
    "DecisionRule", "Decisions", "decision_rule", "decide", "NO_FAULT", "UNKNOWN_PATTERN",
    "ErrorSystem", "Threshold", "ThresholdSpec", "guaranteed_threshold", "constant_threshold",
    "residual_names", "min_detectable_fault", "RunOutcome", "Metrics", "FaultCase",
    "evaluate_result", "fault_onsets", "true_labels", "sampled_threshold", "sampled_band_refusal", "interval_range", "WorstCase",
    "worst_case_sums", "transient_envelope"
]
