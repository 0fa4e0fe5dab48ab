"""The observer kinds beyond residual generators and virtual sensors on plants whose
outputs carry inputs, faults and disturbances (y = H x + Gy u + Dy d + Ly ρ + W w; the
lift itself is :mod:`._feedthrough`'s).

- **Interval observers** decouple nothing: the design is the virtual sensor's on the
  measured part (N = I: no decoupled input), lifted with G* = Φ G − J* Gy, and certified
  with Φ L − L* for the bounded disturbances (not Φ L − J* Ly = 0). The observer reads
  y − Gy u; the faults and disturbances in the outputs it reads are bounded like the
  measurement noise (observers/_interval_feedthrough.py).
- **Unknown-input estimators** (seed 000, and the continuous filtered one) and
  **sliding-mode observers** (seed 002 §5) take the known inputs in the outputs: the
  lift is the residual generators' (y − Gy u in their equations; the estimators read it,
  observers/_uio_feedthrough.py); decoupled inputs in the outputs are removed by N.
  The estimated input itself in the outputs is refused in one line
  (:func:`check_kind_feedthrough`) naming what takes it: a diagnostic observer detects
  it (sensor faults included), an interval observer bounds it.
- **Robust (approximate) designs** (METHOD §2d) take the known inputs in the outputs: the
  same lift as the interval observer's, on the measured part, with L* = Φ L certified as
  the residual it is (Φ L − L*). An input they decouple or estimate that enters the
  outputs is refused in one line (:func:`check_robust_feedthrough`) naming the exact
  design, which decouples inputs of the outputs.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ...errors import UsageError
from ...model import ObserverKind, PlantModel, Task, extract_structure
from ..certificates import MODEL_PREFIX, Certificate, certify_design
from ._feedthrough import FeedthroughView, lift_design
from ._reduced import output_symbols

__all__ = ["lift_kind_design", "check_kind_feedthrough", "check_robust_feedthrough",
           "lift_robust_design"]


def _lift_known_inputs(d, view: FeedthroughView, task: Task, L: sp.Matrix):
    """``d`` (made on ``view.model``, N = I) lifted for the known inputs in the outputs:
    G* = Φ G − J* Gy (also of the diagonal form), y − Gy u in its equations, outputs and
    nonlinear substitutions, certified with Φ L − L* for the columns ``L`` (not
    decoupled: bounded, or approximately decoupled)."""
    st = view.structure
    m = d.matrices.as_dict()
    Gy = sp.Matrix(st.Gy)
    for g, j in (("G_star", "J_star"), ("G_diag", "J_diag")):
        if m.get(g) is not None and m.get(j) is not None and Gy.cols:
            m[g] = (sp.Matrix(m[g]) - sp.Matrix(m[j]) * Gy).applyfunc(sp.cancel)
    ys = sp.Matrix(output_symbols(st.l))
    u = sp.Matrix(st.model.inputs) if st.model.inputs else sp.zeros(0, 1)
    measured = ys - Gy * u if u.rows else ys
    sub = dict(zip(list(ys), list(measured)))

    def tr(e):
        return sp.expand(sp.sympify(e).xreplace(sub))
    plant = {"F": st.F, "G": st.G, "H": st.H, "C": st.C, "D": task.D(st), "L": L,
             "Gy": st.Gy, "Dy": sp.zeros(st.l, len(task.targets))}
    old = d.certificate
    cert = certify_design(plant, m, M=task.M, decoupled=False, exact=old.exact,
                          tolerance=old.tolerance if old.tolerance is not None else 1e-9)
    kept = tuple(i for i in old.identities
                 if not i.name.startswith(MODEL_PREFIX) and i.name.startswith("A_"))
    cert = Certificate(tuple(cert.identities) + kept, cert.exact, cert.tolerance)
    conds = tuple(dataclasses.replace(c, holds=cert.passed, detail=cert.summary())
                  if c.name == "certificate" else c for c in d.conditions)
    nonlinear = tuple(dataclasses.replace(ns, function=tr(ns.function), argument=tr(ns.argument))
                      for ns in d.nonlinear)
    return dataclasses.replace(
        d, structure=st, task=task, matrices=m, certificate=cert, conditions=conds,
        nonlinear=nonlinear, equations=tuple(tr(e) for e in d.equations),
        outputs=tuple((name, tr(e)) for name, e in d.outputs))


def check_robust_feedthrough(view: FeedthroughView, cause=None) -> None:
    """A robust (approximate) design takes the known inputs in the outputs (Gy u) only:
    one-line refusal, naming what is supported and what to use, when an input it would
    decouple or estimate enters the outputs (``cause``: the exact design's failure)."""
    st, task = view.structure, view.task
    direct = [n for n in tuple(task.targets) + tuple(task.decoupled)
              if not st.output_columns([n]).is_zero_matrix]
    if direct:
        name = direct[0]
        raise UsageError(
            f"{st.model.where}: no exact design, and {name} enters the outputs directly:"
            " robust (approximate) designs take only known inputs in the outputs (y − Gy u);"
            f" bound {name} with an interval observer (--observer interval) instead of"
            " decoupling it") from cause


def lift_robust_design(d, view: FeedthroughView):
    """An approximate design (METHOD §2d) made on ``view.model`` lifted for the known
    inputs in the outputs (:func:`check_robust_feedthrough` first): its L* = Φ L is its
    residual, certified as Φ L − L*, not as a decoupling."""
    st = view.structure
    names = d.task.bounded if d.task.observer == ObserverKind.INTERVAL else d.task.decoupled
    L = sp.Matrix(st.unknown_input_columns(names)) if names else sp.zeros(st.n, 0)
    return _lift_known_inputs(d, view, d.task, L)


def lift_kind_design(d, view: FeedthroughView):
    """The design ``d`` made on ``view.model`` as one for the plant with feedthrough,
    for every observer kind that takes it (see the module docstring)."""
    if view.task.observer == ObserverKind.INTERVAL:
        # nothing decoupled (N = I): the bounded disturbances' Φ L − L*, not Φ L − J* Ly
        return _lift_known_inputs(d, view, view.task, view.task.L(view.structure))
    return lift_design(d, view)


def check_kind_feedthrough(work: PlantModel, task: Task) -> None:
    """One-line refusal when an unknown-input or sliding-mode design is asked for an input
    that enters the outputs directly (its column of Dy or Ly is nonzero)."""
    if task.observer not in (ObserverKind.UNKNOWN_INPUT, ObserverKind.SLIDING_MODE):
        return
    st = extract_structure(work)
    direct = [n for n in task.targets if not st.output_columns([n]).is_zero_matrix]
    if not direct:
        return
    name = direct[0]
    kind = ("unknown-input estimators" if task.observer == ObserverKind.UNKNOWN_INPUT
            else "the sliding-mode observer")
    raise UsageError(
        f"{work.where}: {name} enters the outputs directly; {kind} take known inputs in the"
        f" outputs (y − Gy u) only: detect {name} with a diagnostic observer (--observer"
        f" diagnostic --fault {name}, which handles sensor faults) or bound it with an"
        " interval observer (--observer interval)")
