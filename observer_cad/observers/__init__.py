"""Stage 5 — observers: the one :class:`Observer` value that simulation and code generation
consume, and the builders that turn certified designs into observers (virtual sensors,
residual generators, interval, unknown-input, sliding-mode, DREM).
"""
from ._builders import (build_observer, virtual_sensor_observer, interval_observer, bank_observer)
from ._drem_class import (DremSpec, DremTerm, DremClass, analyse, load_drem)
from ._drem import (DremDesign, gains_from_poles, parametrisation_residual, chain_error_residual, drem_design, drem_observer, determinants)
from ._drem_excitation import (ExcitationReport, ExcitationError, excitation_report, check_excitation, suggest_gamma, true_unknowns)
from ._interval import (interval_observer_nonlinear)
from ._full_state import (full_state_intervals)
from ._observer import (Observer, output_symbols)
from ._sliding import (sliding_observer)
from ._uio_derivation import (Derivation, derive_estimate, ALPHA, ALPHA_PREV)
from ._uio_continuous import (continuous_unknown_input_observer, DEFAULT_TAU)
from ._uio import (unknown_input_observer, vector_unknown_input_observer, combine_observers, default_gains)

__all__ = [
    "build_observer", "virtual_sensor_observer", "interval_observer", "bank_observer",
    "DremSpec", "DremTerm", "DremClass", "DremDesign", "ExcitationReport", "ExcitationError",
    "analyse", "load_drem", "gains_from_poles", "parametrisation_residual",
    "chain_error_residual", "drem_design", "drem_observer", "excitation_report",
    "check_excitation", "suggest_gamma", "true_unknowns", "determinants",
    "interval_observer_nonlinear", "full_state_intervals", "Observer", "output_symbols",
    "sliding_observer", "Derivation", "derive_estimate", "unknown_input_observer",
    "vector_unknown_input_observer", "combine_observers", "ALPHA", "ALPHA_PREV", "default_gains",
    "continuous_unknown_input_observer", "DEFAULT_TAU"
]
