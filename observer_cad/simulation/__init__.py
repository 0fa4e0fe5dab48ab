"""Stage 7 — simulation: JSON scenarios, the reference numpy simulator of plant and
observer together, and the Monte-Carlo evaluation of a decision rule over fault cases.
"""
from ._evaluation import (evaluate_ensemble)
from ._simulate import (align_delay, Scenario, load_scenario, scenario_from_dict, simulate, SimulationResult, column_units, T, memory_limit, check_memory, finish_result, MEMORY_LIMIT_ENV)
from ._random import (RANDOM_C, mix64, stream_keys, uniform_samples, normal_samples)
from ._sampling import (Distribution, SignalProgram, signal_program, RunDraws, draw_runs, DrawPlan, draw_plan, parameter_layout)
from ._quantile import (quantile_threshold, fault_free, apply_threshold)
from ._summaries import (SummaryField, Monitors, monitors, RunSummaries, summarise)
from ._recording import (TIME_RTOL, declared_envelope, declared_signal_bounds, bounds_check, read_table, parse_row)
from ._engine import (sample_steps, check_band_step)
from ._monitor import (Monitor, MonitorStep, ReferenceMonitorEngine, monitor_signals, monitor_signal_columns,
                       CategoricalColumn)

__all__ = [
    "evaluate_ensemble", "align_delay", "Scenario", "load_scenario", "scenario_from_dict",
    "simulate", "SimulationResult", "column_units", "T", "memory_limit", "check_memory",
    "finish_result", "MEMORY_LIMIT_ENV", "quantile_threshold", "fault_free", "apply_threshold",
    "RANDOM_C", "mix64", "stream_keys", "uniform_samples", "normal_samples", "Distribution",
    "SignalProgram", "signal_program", "RunDraws", "draw_runs", "DrawPlan", "draw_plan",
    "parameter_layout", "SummaryField", "Monitors", "monitors", "RunSummaries", "summarise",
    "TIME_RTOL", "declared_envelope", "declared_signal_bounds", "bounds_check", "read_table",
    "parse_row", "Monitor", "MonitorStep", "ReferenceMonitorEngine", "monitor_signals",
    "CategoricalColumn", "monitor_signal_columns", "sample_steps", "check_band_step"
]
