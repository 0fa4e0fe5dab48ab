"""Stage 7 — simulation: JSON scenarios, the reference numpy simulator of plant and
observer together, and the Monte-Carlo evaluation of a decision rule over fault cases.
"""
from ._evaluation import (evaluate_ensemble)
from ._simulate import (align_delay, Scenario, load_scenario, scenario_from_dict, simulate, SimulationResult, column_units, T, memory_limit, check_memory, find_nonfinite, finish_result, MEMORY_LIMIT_ENV, DEFAULT_MEMORY_LIMIT)
from ._random import (RANDOM_C, PARAMETER_STREAMS, mix64, stream_keys, uniform_samples, normal_samples)
from ._sampling import (Distribution, SignalProgram, signal_program, RunDraws, draw_runs, DrawPlan, draw_plan, ParameterLayout, parameter_layout, SAMPLING_METHODS, NOMINAL_CASE, DECLARED)
from ._quantile import (quantile_threshold, fault_free, apply_threshold)
from ._summaries import (SummaryField, Monitors, monitors, RunSummaries, summarise, SUMMARY_KINDS)

__all__ = ["evaluate_ensemble", "align_delay", "Scenario", "load_scenario", "scenario_from_dict", "simulate", "SimulationResult", "column_units", "T", "memory_limit", "check_memory", "find_nonfinite", "finish_result", "MEMORY_LIMIT_ENV", "DEFAULT_MEMORY_LIMIT", "quantile_threshold", "fault_free", "apply_threshold", "RANDOM_C", "PARAMETER_STREAMS", "mix64", "stream_keys", "uniform_samples", "normal_samples", "Distribution", "SignalProgram", "signal_program", "RunDraws", "draw_runs", "DrawPlan", "draw_plan", "ParameterLayout", "parameter_layout", "SAMPLING_METHODS", "NOMINAL_CASE", "DECLARED", "SummaryField", "Monitors", "monitors", "RunSummaries", "summarise", "SUMMARY_KINDS"]
