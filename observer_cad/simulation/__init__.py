"""Stage 5 — simulation: JSON scenarios and the reference numpy simulator of plant and
observer together.
"""
from ._simulate import (signal_arrays, align_delay, Scenario, load_scenario, scenario_from_dict, simulate, SimulationResult, column_units, T, memory_limit, check_memory, find_nonfinite, finish_result, parameter_arrays, MEMORY_LIMIT_ENV, DEFAULT_MEMORY_LIMIT)
from ._quantile import (quantile_threshold, fault_free, apply_threshold)

__all__ = ["signal_arrays", "align_delay", "Scenario", "load_scenario", "scenario_from_dict", "simulate", "SimulationResult", "column_units", "T", "memory_limit", "check_memory", "find_nonfinite", "finish_result", "parameter_arrays", "MEMORY_LIMIT_ENV", "DEFAULT_MEMORY_LIMIT", "quantile_threshold", "fault_free", "apply_threshold"]
