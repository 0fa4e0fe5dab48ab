"""Which inputs a design estimates, detects and decouples (resolved from the model)."""
from __future__ import annotations

import sympy as sp

from ..errors import ModelError, UsageError
from ..model import PlantModel, Structure
from ._reduced import parse_estimate

__all__ = ["resolve_jordan_task"]


def resolve_jordan_task(work: PlantModel, st: Structure, observer: str, estimate, faults,
                        decouple):
    """M (or None), the faults to detect, the inputs to decouple, and the matching D, L.

    Interval observers are not decoupled: L holds every disturbance (bounded instead).
    """
    where = work.where
    n = st.n
    M = None
    if observer in ("virtual-sensor", "interval"):
        if estimate is None:
            raise UsageError(f"--observer {observer} needs --estimate EXPR (e.g. x1)")
        M = parse_estimate(work, estimate)
    fault_syms = []
    if observer == "diagnostic":
        names = list(faults) if faults else [f.name for f in work.faults]
        if not names:
            raise ModelError(f"{where}: the model declares no faults to detect")
        for nm in names:
            s = work.symbol(str(nm))
            if s is None or (s not in work.faults and s not in work.disturbances):
                raise ModelError(f"{where}: unknown fault '{nm}'; declared faults: "
                                 + (", ".join(f.name for f in work.faults) or "none"))
            fault_syms.append(s)
    dec = [] if observer == "interval" else [r for r in work.disturbances if r not in fault_syms]
    for nm in decouple or ():
        s = work.symbol(str(nm))
        if s is None or (s not in work.faults and s not in work.disturbances):
            raise ModelError(f"{where}: unknown disturbance '{nm}'")
        if s in fault_syms:
            raise UsageError(f"'{nm}' cannot be both detected (--fault) and decoupled (--disturbance)")
        if s not in dec:
            dec.append(s)
    D = sp.Matrix(st.unknown_input_columns(fault_syms)) if fault_syms else sp.zeros(n, 0)
    if observer == "interval":
        L = sp.Matrix(st.L)  # all disturbances bounded, not decoupled
    else:
        L = sp.Matrix(st.unknown_input_columns(dec)) if dec else sp.zeros(n, 0)
    return M, fault_syms, dec, D, L
