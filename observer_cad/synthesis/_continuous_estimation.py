"""The structural test of continuous-time unknown-input estimation, before any design work
(METHOD §3, "Unknown-input estimation in continuous time").

Continuous-time estimation of an unknown input d (the filtered estimator of
:mod:`observer_cad.observers`, or the sliding-mode observer of seed 002 §5) needs a
*measured* row that sees d: a combination R y of the outputs that the decoupled inputs do not
reach, whose derivative reads d directly and no unmeasured state. Two rank tests on the
extracted H, F, D, L decide it (the second for linear models, where it is exact):

    rank [H L, H D] > rank [H L]                 (d reaches a measured combination directly)
    rank [H L, H F N, H D] > rank [H L, H F N]   (N spanning the null space of H)

Failing either, neither estimator applies and the refusal names what to use instead.
"""
from __future__ import annotations

import sympy as sp

from ..errors import InfeasibleDesignError
from ..model import PlantModel, extract_structure

__all__ = ["continuous_estimation_check"]

_INSTEAD = ("detect it with a residual (--observer diagnostic), or estimate it on a"
            " discrete-time model (seed 000, with a delay)")


def _rank(M: sp.Matrix) -> int:
    return M.rank() if M.rows and M.cols else 0


def _hstack(*blocks) -> sp.Matrix:
    """The blocks side by side (the empty ones left out; no block: an empty matrix)."""
    blocks = [b for b in blocks if b.cols]
    return sp.Matrix.hstack(*blocks) if blocks else sp.zeros(0, 0)


def continuous_estimation_check(model: PlantModel, target: str, decouple=()) -> None:
    """Refuse (one line, :class:`~observer_cad.errors.InfeasibleDesignError`) a
    continuous-time unknown-input request that no measured row can serve (module docstring), before any design work: rank tests on
    the extracted H, F, D, L only. ``target``: the input to estimate; ``decouple``: further
    faults or disturbances to decouple (the model's disturbances other than the target
    always are). Does nothing for a discrete-time model."""
    if model.time != "continuous":
        return
    sym = model.symbol(str(target))
    if sym is None or sym not in tuple(model.faults) + tuple(model.disturbances):
        return  # the design names the unknown input itself
    work = model
    if model.parameters and all(v is not None for v in model.parameters.values()):
        work = model.substitute_parameters()
    st = extract_structure(work)
    H = sp.Matrix(st.H)
    names = [s.name for s in model.disturbances if s != sym] + [str(n) for n in decouple
                                                                   if str(n) != sym.name]
    L = sp.Matrix(st.unknown_input_columns(names)) if names else sp.zeros(st.n, 0)
    Dt = sp.Matrix(st.unknown_input_columns([sym.name]))
    HL, HD = H * L, H * Dt
    if _rank(_hstack(HL, HD)) == _rank(HL):
        raise InfeasibleDesignError(
            f"{model.where}: continuous-time estimation of '{sym}' needs it to reach a measured"
            f" combination of the outputs directly (relative degree one, H D ∉ span H L); it does"
            f" not, so neither the filtered estimator nor the sliding-mode observer applies:"
            f" {_INSTEAD}")
    if st.is_linear:
        null = H.nullspace()
        N = sp.Matrix.hstack(*null) if null else sp.zeros(st.n, 0)
        HFN = H * sp.Matrix(st.F) * N
        if _rank(_hstack(HL, HFN, HD)) == _rank(_hstack(HL, HFN)):
            raise InfeasibleDesignError(
                f"{model.where}: continuous-time estimation of '{sym}' needs a measured"
                f" combination of the outputs that sees it and whose derivative involves no"
                f" unmeasured state; none exists (rank [H L, H F N, H D] = rank [H L, H F N]),"
                f" so neither the filtered estimator nor the sliding-mode observer applies:"
                f" {_INSTEAD}")
