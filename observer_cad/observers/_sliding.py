"""The sliding-mode fault estimator (seed 002 §5) built from its certified design."""
from __future__ import annotations

import dataclasses
import math

import sympy as sp

from ..errors import UsageError
from ..model import PlantModel
from ..synthesis import EPS, K1, TAU, Condition, Design, gain_bound
from ._observer import Observer

__all__ = ["sliding_observer", "MAX_SLIDING_PARAMETER"]


#: the largest k_sm (k1), eps_sm (ε) and tau_sm (τ) a sliding-mode observer is built with
#: (a design file can carry any number): k1·sign(e) of 1e6 moves the estimate by 1e4 in a
#: step of 0.01, and e/(|e| + ε) with ε above 1e6 is zero to double precision for any
#: error a plant of these examples has
MAX_SLIDING_PARAMETER = 1e6


def sliding_observer(model: PlantModel, design: Design) -> Observer:
    """The estimator x̂*' = λ x̂* + J* y + G* u + C* Ψ* − k1 v of a sliding-mode design
    (:func:`observer_cad.synthesis.design_sliding`), with its gains as parameters."""
    if design.observer != "sliding-mode":
        raise UsageError("sliding_observer needs a sliding-mode design")
    states = tuple(design.observer_states)
    l = len(model.outputs)
    ys = sp.symbols(f"y1:{l + 1}")
    params = dict(design.parameters)
    sign = len(states) == 2  # sign injection: x̂* and the filter state v_f
    # the gains are the design's data (its JSON, for one): present, finite and positive,
    # and k1 above d*|D*| — necessary for a sliding mode whatever δ — recomputed here
    for sym in (K1, TAU if sign else EPS):
        v = params.get(sym)
        try:
            ok = v is not None and math.isfinite(float(v)) and float(v) > 0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise UsageError(f"the sliding-mode design's parameter {sym} must be a finite"
                             f" positive number, got {v}")
        if float(v) > MAX_SLIDING_PARAMETER:
            raise UsageError(f"the sliding-mode design's parameter {sym} = {float(v):.6g} is"
                             f" above {MAX_SLIDING_PARAMETER:g}: a gain that large makes the"
                             " step function meaningless in double precision, and ε or τ"
                             " that large switches the injection off")
    k1v = float(params[K1])
    inputs = design.sliding_inputs
    if inputs is not None:
        # the whole bound, for these gains: the recorded gain conditions were computed
        # for the gains of the design run, which a design file may have changed
        gb = gain_bound(model, design, delta=inputs.delta, lipschitz=inputs.lipschitz)
        eps = None if sign else float(params[EPS])
        fresh = gb.conditions(k1v, eps)
        names = {c.name for c in fresh}
        conditions = tuple(c for c in design.conditions if c.name not in names) + tuple(
            dataclasses.replace(c, name=c.name + " (recomputed on building)")
            if c.name.startswith("sliding gain bound") else c for c in fresh)
    else:  # (a design file written before δ and N* were recorded)
        gb = gain_bound(model, design, lipschitz=0.0)  # (only d* and D* are used here)
        need = gb.d_star * abs(gb.D_star)
        conditions = tuple(design.conditions) + (Condition(
            "k1 > d*|D*| (recomputed from the model on building)", k1v > need,
            f"k1 = {k1v:.6g}, d*|D*| = {need:.6g}" + ("" if k1v > need else
                                                       " — no sliding mode: d̂ saturates"),
            "seed 002 eq. (5.5) corrected"),)
    vtext = "sign(e)" if sign else "e/(|e| + ε)"
    est = "v_f, v_f' = (sign(e) − v_f)/τ" if sign else "e/(|e| + ε)"
    fault = design.unknown_input
    ystar = (sp.Matrix(design.matrices.R_star) * sp.Matrix(ys))[0, 0]
    return Observer(
        name=f"{model.name}_sliding", kind="sliding-mode", time="continuous", states=states,
        signals=tuple(ys) + tuple(model.inputs), parameters=params, update=design.equations,
        outputs=design.outputs, initial={s_: 0 for s_ in states}, conditions=conditions,
        assumptions=(), design=design,
        description=(f"sliding-mode estimator of {fault} (k_sm = k1 = {k1v:.6g}):"
                     f" x̂*' = F* x̂* + J* y + G* u + C* Ψ* − k1 v, v = {vtext},"
                     f" e = x̂* − ({ystar}); {fault}_hat = −k1 D*⁻¹ {est}"))
