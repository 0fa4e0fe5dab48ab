"""Stage 5 — simulation: JSON scenarios and the reference numpy simulator of plant and
observer together.
"""
from ._simulate import (signal_arrays, align_delay, Scenario, load_scenario, scenario_from_dict, simulate, SimulationResult, column_units, T)

__all__ = ["signal_arrays", "align_delay", "Scenario", "load_scenario", "scenario_from_dict", "simulate", "SimulationResult", "column_units", "T"]
