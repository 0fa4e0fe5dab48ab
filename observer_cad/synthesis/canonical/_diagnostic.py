"""Diagnostic observer (residual generator) in the identification canonical form
(METHOD §3; seed 002 §2): the reduced model plus feedback on the residual,

    x*' = F* x* + J* y + G* u + K r,     r = R* y − H* x*,

with K placing the eigenvalues of F* − K H* exactly where requested. Without faults
and disturbances r → 0; a fault with Φ D ≠ 0 makes r ≠ 0.
"""
from __future__ import annotations

import dataclasses
from typing import Sequence

import sympy as sp

from ._canonical import design_canonical
from ...errors import UsageError
from ..core import Condition, Design
from ..core import task_for
from ..core import observer_symbols, output_symbols, reduced_equations, residual_outputs
from ...model import PlantModel, Task
from ..core import (closed_loop_eigenvalues, default_eigenvalues, parse_eigenvalues,
                    pole_placement, require_stable)

__all__ = ["design_diagnostic_canonical", "observer_equations"]

def observer_equations(mats, inputs, k: int, l: int, with_feedback: bool = True,
                       nonlinear=()):
    """Right-hand sides F* x* + J* y + G* u + C* Ψ*(x*, y, u) (+ K r) and the residual r."""
    xs, ys = observer_symbols(k), output_symbols(l)
    rhs = reduced_equations(mats, inputs, xs, ys, nonlinear=nonlinear, feedback=with_feedback,
                            deep=True)
    return rhs, sp.expand(residual_outputs(mats, xs, ys)[0, 0]), xs


def design_diagnostic_canonical(model: PlantModel, *, fault: str, decouple: Sequence[str] = (),
                                eigenvalues: Sequence | None = None,
                                symbolic: bool = False, task: Task | None = None) -> Design:
    """Canonical-form residual generator for one fault, with exact pole placement."""
    task = task_for(model, task, observer="diagnostic", faults=[fault], disturbances=decouple)
    if len(task.targets) != 1:
        raise UsageError("canonical-form diagnostic observers take one --fault; use --form"
                         " jordan for several (seed 002 Remark 1)")
    base = design_canonical(model, unknown_input=task.targets[0], symbolic=symbolic,
                            single_row=False, task=task)
    k = base.k
    mats = base.matrices.as_dict()
    eigs = parse_eigenvalues(eigenvalues) if eigenvalues else default_eigenvalues(model.time, k)
    placed = pole_placement(mats["F_star"], mats["H_star"], eigs)
    K = sp.Matrix(placed.K)
    mats["K"] = K
    # certified: det(sI − F* + K H*) = Π(s − μ_i) exactly, so the μ_i are the eigenvalues
    cl = closed_loop_eigenvalues(placed)
    l = sp.Matrix(mats["R_star"]).cols
    eqs, r, xs = observer_equations(mats, list(model.inputs), k, l, nonlinear=base.nonlinear)
    require_stable(cl, model.time, eigs)
    conds = list(base.conditions)
    conds.insert(-1, Condition("closed-loop eigenvalues of F* − K H*", True,
                               f"requested {[str(e) for e in eigs]}, obtained exactly"
                               f" {[str(e) for e in cl]} ({placed.method}; det(sI − F* + K H*)"
                               " recomputed and equal to Π(s − μ_i))", "METHOD §3"))
    return dataclasses.replace(
        base, matrices=mats, conditions=tuple(conds),
        closed_loop_eigenvalues=cl, equations=eqs, observer_states=tuple(xs),
        outputs=(("r", r),))
