"""The sliding-mode fault estimator (seed 002 §5) built from its certified design."""
from __future__ import annotations

import sympy as sp

from ..errors import UsageError
from ..model import PlantModel
from ..synthesis import K1, Design
from ._observer import Observer

__all__ = ["sliding_observer"]


def sliding_observer(model: PlantModel, design: Design) -> Observer:
    """The estimator x̂*' = λ x̂* + J* y + G* u + C* Ψ* − k1 v of a sliding-mode design
    (:func:`observer_cad.synthesis.design_sliding`), with its gains as parameters."""
    if design.observer != "sliding-mode":
        raise UsageError("sliding_observer needs a sliding-mode design")
    states = tuple(design.observer_states)
    l = len(model.outputs)
    ys = sp.symbols(f"y1:{l + 1}")
    params = dict(design.parameters)
    k1v = float(params[K1])
    sign = len(states) == 2  # sign injection: x̂* and the filter state v_f
    vtext = "sign(e)" if sign else "e/(|e| + ε)"
    est = "v_f, v_f' = (sign(e) − v_f)/τ" if sign else "e/(|e| + ε)"
    fault = design.unknown_input
    ystar = (sp.Matrix(design.matrices.R_star) * sp.Matrix(ys))[0, 0]
    return Observer(
        name=f"{model.name}_sliding", kind="sliding-mode", time="continuous", states=states,
        signals=tuple(ys) + tuple(model.inputs), parameters=params, update=design.equations,
        outputs=design.outputs, initial={s_: 0 for s_ in states}, conditions=design.conditions,
        assumptions=(), design=design,
        description=(f"sliding-mode estimator of {fault} (k_sm = k1 = {k1v:.6g}):"
                     f" x̂*' = F* x̂* + J* y + G* u + C* Ψ* − k1 v, v = {vtext},"
                     f" e = x̂* − ({ystar}); {fault}_hat = −k1 D*⁻¹ {est}"))
