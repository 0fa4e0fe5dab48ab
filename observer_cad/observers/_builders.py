"""From a design to a runnable observer: the dispatch by observer kind.

:func:`build_observer` turns a certified :class:`~observer_cad.synthesis.Design` into the
single :class:`~observer_cad.observers.Observer` representation that simulation and code
generation consume.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..synthesis import Design, DesignMatrices
from ..analysis import ResidualBank
from ..errors import FailedConditionError, UsageError
from ..model import PlantModel
from ._drem import DremDesign
from ._interval import interval_observer_nonlinear
from ._observer import Observer, estimate_name, output_symbols
from ._sliding import sliding_observer
from ._uio import combine_observers, unknown_input_observer

__all__ = ["build_observer", "virtual_sensor_observer", "diagnostic_observer", "interval_observer",
           "bank_observer"]


def _signals(model: PlantModel, l: int):
    return tuple(output_symbols(l)) + tuple(model.inputs)


def _mapped_initial(model: PlantModel, design: Design) -> dict:
    """Default initial state x*(0) = Φ x(0), an expression in the plant's initial state
    (the simulator substitutes it; a scenario's ``observer_initial`` overrides it to
    study the transient from a wrong start)."""
    Phi = sp.Matrix(design.matrices.Phi)
    xs0 = Phi * sp.Matrix(model.states)
    return {x: xs0[i] for i, x in enumerate(design.observer_states)}


def virtual_sensor_observer(model: PlantModel, design: Design) -> Observer:
    """The virtual sensor's equations: the design's x*' and z = H_z x* + Q y."""
    if design.observer != "virtual-sensor" or not design.equations:
        raise UsageError("virtual_sensor_observer needs a virtual-sensor design")
    l = len(model.outputs)
    name = estimate_name(model, design)
    zexpr = dict(design.outputs)["z"]
    return Observer(
        name=f"{model.name}_virtual_sensor", kind="virtual-sensor", time=model.time,
        states=design.observer_states, signals=_signals(model, l), parameters={},
        update=design.equations, outputs=((f"{name}_hat", zexpr),),
        initial=_mapped_initial(model, design), conditions=design.conditions,
        assumptions=design.assumptions, design=design,
        description=f"virtual sensor for z = {design.estimate}")


def diagnostic_observer(model: PlantModel, design: Design) -> Observer:
    """Residual generator: the design's equations and r = R* y − H* x*."""
    if (not design.equations and design.k) or "r" not in dict(design.outputs):
        raise UsageError("diagnostic_observer needs a design with a residual")
    l = len(model.outputs)
    return Observer(
        name=f"{model.name}_diagnostic", kind="diagnostic", time=model.time,
        states=design.observer_states, signals=_signals(model, l), parameters={},
        update=design.equations, outputs=(("r", dict(design.outputs)["r"]),),
        initial=_mapped_initial(model, design), conditions=design.conditions,
        assumptions=design.assumptions, design=design,
        description="residual generator r = R* y − H* x*")


def bank_observer(model: PlantModel, bank: ResidualBank) -> Observer:
    """A residual bank as one observer: the residual generators side by side, their states
    prefixed (``r1_xs1``), their residuals named ``r1 … rm`` in the order of the bank's
    structure matrix, so that simulation writes one column per residual and code
    generation exports the whole bank as one step function."""
    if not isinstance(bank, ResidualBank) or not bank.designs:
        raise UsageError("bank_observer needs a ResidualBank with at least one residual")
    parts = {}
    for i, d in enumerate(bank.designs, 1):
        o = diagnostic_observer(model, d)
        (_, r), = o.outputs
        parts[f"r{i}"] = dataclasses.replace(o, outputs=((f"r{i}", r),))
    rows = ", ".join("".join(map(str, r)) for r in bank.structure_matrix)
    ob = combine_observers(parts, name=f"{model.name}_bank")
    return dataclasses.replace(
        ob, kind="diagnostic",
        description=(f"residual bank over ({', '.join(bank.faults)}), structure matrix"
                     f" {rows} ({bank.scheme}); r_i = R*_i y − H*_i x*_i"))


def interval_observer(model: PlantModel, design: Design, **options) -> Observer:
    """Interval observer for z = M x (METHOD §3): see
    :func:`observer_cad.observers.interval_observer_nonlinear`, which handles linear and
    nonlinear, continuous and discrete designs, the faults' and disturbances' bounds
    through Φ [L D], the H_z sign split and the noise through Q y.

    Canonical designs of seed 001 method 1 are used in their diagonal (Metzler) form.
    """
    if design.matrices.F_diag is not None:  # 001 method 1: the diagonalised, stabilised model
        if design.nonlinear:
            raise UsageError("the diagonal form of a canonical design is built for linear"
                             " models; use --form jordan for nonlinear interval observers")
        m = design.matrices
        diag = DesignMatrices(Phi=m.Phi_diag, F_star=m.F_diag, J_star=m.J_diag,
                              G_star=m.G_diag, Hz=m.Hz_diag, Q=m.Q)
        design = dataclasses.replace(design, matrices=diag, form="jordan",
                                     lambdas=tuple(sp.Matrix(m.F_diag).diagonal()))
    elif design.matrices.K is not None:
        raise UsageError("interval observers need a diagonal (Metzler) model: use a Jordan"
                         " design or real distinct --eigenvalues (seed 001 method 1)")
    return interval_observer_nonlinear(model, design, **options)


def build_observer(model: PlantModel, design: Design, *, allow_failed: bool = False,
                   **options) -> Observer:
    """The observer for a design (or a :class:`ResidualBank`: one observer with outputs
    r1 … rm); ``options`` go to the kind's builder (gains, bounds).

    An observer that fails a required condition (an unstable gain, a sliding gain below
    its bound) must not be used: :class:`~observer_cad.errors.FailedConditionError` (one
    line naming the condition; its ``observer`` is what was built), unless
    ``allow_failed`` (then check ``failed_conditions`` yourself)."""
    observer = _build(model, design, **options)
    failed = observer.failed_conditions
    if failed and not allow_failed:
        c = failed[0]
        more = f"; and {len(failed) - 1} more" if len(failed) > 1 else ""
        raise FailedConditionError(f"the observer fails a required condition: {c.name}"
                                   f" ({c.detail}){more}", observer=observer)
    return observer


def _build(model: PlantModel, design: Design, **options) -> Observer:
    if isinstance(design, DremDesign):  # DREM designs carry their observer
        return design.observer
    if isinstance(design, ResidualBank):  # r1 … rm side by side
        return bank_observer(model, design)
    if not isinstance(design, Design):
        raise UsageError(f"build_observer takes a Design, not a {type(design).__name__}"
                         " (a design's JSON comes back with Design.from_json(data, model)"
                         " or read_design_json(path, model))")
    kind = design.observer
    if kind == "virtual-sensor":
        return virtual_sensor_observer(model, design)
    if kind == "diagnostic":
        return diagnostic_observer(model, design)
    if kind == "interval":
        return interval_observer(model, design, **options)
    if kind == "unknown-input":
        return unknown_input_observer(model, design, **options)
    if kind == "sliding-mode":
        return sliding_observer(model, design)
    raise UsageError(f"no observer builder for kind {kind!r}")
