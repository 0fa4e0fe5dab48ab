"""Unknown-input estimators on plants whose outputs carry the known inputs
(y = H x + Gy u + …): the estimator reads ŷ = y − Gy u (METHOD §2 with output feedthrough).

A design with feedthrough reads y with G* = Φ G − J* Gy; the estimators of seed 000 and
the continuous filtered one derive their formulas from the reduced model in the outputs
free of the known inputs, x*' = F* x* + J* ŷ + Φ G u + D* d with x*_1 = R* ŷ. So they
are built on the model whose outputs are h(x, 0, d, ρ, w) (u at zero) with Φ G = G* + J*
Gy (:func:`~._uio_derivation.reduced_model`), and every output symbol of the result is then
replaced by y − Gy u — the two copies, the memory states of y (which hold ŷ) and the
estimate alike. The unknown input itself in the outputs is refused at design time
(observer_cad.synthesis.design).
"""
from __future__ import annotations

import copy
import dataclasses

import sympy as sp

from ..model import PlantModel
from ._observer import Observer, output_symbols

__all__ = ["known_input_view", "reading_y_less_Gy_u"]


def known_input_view(model: PlantModel) -> tuple:
    """(the model with the known inputs zeroed in its outputs, {y_k: y_k − (Gy u)_k});
    ``(model, {})`` when no known input enters the outputs."""
    us = set(model.inputs)
    if not any(sp.sympify(h).free_symbols & us for h in model.outputs):
        return model, {}
    zero = {u: 0 for u in model.inputs}
    outs = tuple(sp.expand(sp.sympify(h).xreplace(zero)) for h in model.outputs)
    ys = output_symbols(len(outs))
    sub = {y: sp.expand(y - (sp.sympify(h) - o))
           for y, h, o in zip(ys, model.outputs, outs)}
    view = copy.copy(model)  # the same model, its outputs without Gy u (no re-check)
    object.__setattr__(view, "outputs", outs)
    return view, {y: e for y, e in sub.items() if e != y}


def reading_y_less_Gy_u(obs: Observer, sub: dict) -> Observer:
    """The observer built on :func:`known_input_view`'s model, reading y − Gy u."""
    def tr(e):
        return sp.expand(sp.sympify(e).xreplace(sub))
    return dataclasses.replace(
        obs, update=tuple(tr(e) for e in obs.update),
        outputs=tuple((n, tr(e)) for n, e in obs.outputs),
        description=obs.description + "; reads y − Gy u (the known inputs' feedthrough"
                    f" removed: {', '.join(f'{y} − ({y - e})' for y, e in sub.items())})")
