"""One representation for every observer: what simulation and code generation consume.

An :class:`Observer` is a set of sympy equations

    continuous:  d/dt ξ = f(ξ, s, p)          discrete:  ξ(t+1) = f(ξ(t), s(t), p)
    outputs:     o = g(ξ, s, p)

in its own states ξ, the signals s it reads from the plant each step (the measured
outputs ``y1, y2, …`` and the known inputs ``u``), and named parameters p with values
(gains, bounds). Outputs are named as in the CSV the simulator writes: ``x1_hat`` /
``z_hat`` for estimates, ``x1_lower`` / ``x1_upper`` (``z_lower`` / ``z_upper``) for
interval bounds, ``r`` for residuals, ``d_hat`` for unknown-input estimates. An output
may refer to an earlier time (``delays``: the estimate of d(t − delay) is produced at
step t), which the simulator aligns.

Builders turn certified designs into observers: :func:`virtual_sensor_observer`,
:func:`diagnostic_observer`, :func:`interval_observer` (linear, continuous or
discrete). Further kinds (unknown-input estimators, sliding-mode, DREM) build the same
value.
"""
from __future__ import annotations

import dataclasses
from types import MappingProxyType
from typing import Mapping

import sympy as sp

from .design import Design
from .errors import UsageError
from .model import PlantModel

__all__ = ["Observer", "box_min", "box_max", "pos", "neg", "estimate_name",
           "virtual_sensor_observer", "diagnostic_observer", "interval_observer",
           "output_symbols"]


def output_symbols(l: int):
    return sp.symbols(f"y1:{l + 1}")


@dataclasses.dataclass(frozen=True)
class Observer:
    """An observer as equations; see the module docstring."""

    name: str
    kind: str
    time: str
    states: tuple
    signals: tuple
    parameters: Mapping
    update: tuple
    outputs: tuple  # of (name, expr)
    delays: Mapping = dataclasses.field(default_factory=dict)
    initial: Mapping = dataclasses.field(default_factory=dict)
    conditions: tuple = ()
    assumptions: tuple = ()
    design: Design | None = None
    description: str = ""

    def __post_init__(self):
        if self.time not in ("continuous", "discrete"):
            raise UsageError(f"observer time must be continuous or discrete, got {self.time!r}")
        if len(self.update) != len(self.states):
            raise UsageError(f"observer {self.name}: {len(self.states)} states but"
                             f" {len(self.update)} update equations")
        allowed = set(self.states) | set(self.signals) | set(self.parameters)
        for e in list(self.update) + [e for _, e in self.outputs]:
            extra = sp.sympify(e).free_symbols - allowed
            if extra:
                raise UsageError(f"observer {self.name}: equation uses undeclared"
                                 f" '{sorted(extra, key=str)[0]}'")
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))
        object.__setattr__(self, "delays", MappingProxyType(dict(self.delays)))
        object.__setattr__(self, "initial", MappingProxyType(dict(self.initial)))

    @property
    def output_names(self) -> tuple:
        return tuple(name for name, _ in self.outputs)

    def equations_text(self) -> list:
        dot = "(t+1)" if self.time == "discrete" else "'"
        out = [f"{x}{dot} = {e}" for x, e in zip(self.states, self.update)]
        out += [f"{name} = {e}" for name, e in self.outputs]
        return out

    def to_json(self) -> dict:
        return {
            "name": self.name, "kind": self.kind, "time": self.time,
            "states": [str(s) for s in self.states],
            "signals": [str(s) for s in self.signals],
            "parameters": {str(p): str(v) for p, v in self.parameters.items()},
            "equations": [str(e) for e in self.update],
            "outputs": {name: str(e) for name, e in self.outputs},
            "delays": {k: int(v) for k, v in self.delays.items()},
            "initial": {str(k): str(v) for k, v in self.initial.items()},
        }


# ---------------------------------------------------------------- interval arithmetic
def pos(A):
    """A⁺ = max(0, A) elementwise (numeric matrices)."""
    return sp.Matrix(A).applyfunc(lambda e: sp.Max(e, 0) if e.free_symbols else (e if e > 0 else 0))


def neg(A):
    """A⁻ = A⁺ − A ≥ 0."""
    return (pos(A) - sp.Matrix(A)).applyfunc(sp.cancel)


def box_min(A, lo, hi):
    """min of A v over the box lo ≤ v ≤ hi: A⁺ lo − A⁻ hi."""
    return pos(A) * sp.Matrix(lo) - neg(A) * sp.Matrix(hi)


def box_max(A, lo, hi):
    """max of A v over the box lo ≤ v ≤ hi: A⁺ hi − A⁻ lo."""
    return pos(A) * sp.Matrix(hi) - neg(A) * sp.Matrix(lo)


def estimate_name(model: PlantModel, design: Design) -> str:
    """``x1`` when z = M x is a single state, else ``z``."""
    est = design.estimate
    if est is not None:
        e = sp.sympify(est, locals={s.name: s for s in model.states})
        if e in model.states:
            return str(e)
    return "z"


def _signals(model: PlantModel, l: int):
    return tuple(output_symbols(l)) + tuple(model.inputs)


def _mapped_initial(model: PlantModel, design: Design) -> dict:
    """Default initial state x*(0) = Φ x(0), an expression in the plant's initial state
    (the simulator substitutes it; a scenario's ``observer_initial`` overrides it to
    study the transient from a wrong start)."""
    Phi = sp.Matrix(design.matrices["Phi"])
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
    if not design.equations or "r" not in dict(design.outputs):
        raise UsageError("diagnostic_observer needs a design with a residual")
    l = len(model.outputs)
    return Observer(
        name=f"{model.name}_diagnostic", kind="diagnostic", time=model.time,
        states=design.observer_states, signals=_signals(model, l), parameters={},
        update=design.equations, outputs=(("r", dict(design.outputs)["r"]),),
        initial=_mapped_initial(model, design), conditions=design.conditions,
        assumptions=design.assumptions, design=design,
        description="residual generator r = R* y − H* x*")


def interval_observer(model: PlantModel, design: Design, **options) -> Observer:
    """Interval observer for z = M x (METHOD §3): see
    :func:`observer_cad.interval.interval_observer_nonlinear`, which handles linear and
    nonlinear, continuous and discrete designs, the faults' and disturbances' bounds
    through Φ [L D], the H_z sign split and the noise through Q y.

    Canonical designs of seed 001 method 1 are used in their diagonal (Metzler) form.
    """
    from .interval import interval_observer_nonlinear
    if "F_diag" in design.matrices:  # 001 method 1: the diagonalised, stabilised model
        if design.nonlinear:
            raise UsageError("the diagonal form of a canonical design is built for linear"
                             " models; use --form jordan for nonlinear interval observers")
        m = design.matrices
        mats = {"Phi": m["Phi_diag"], "F_star": m["F_diag"], "J_star": m["J_diag"],
                "G_star": m["G_diag"], "Hz": m["Hz_diag"], "Q": m["Q"]}
        design = dataclasses.replace(design, matrices=mats, form="jordan",
                                     lambdas=tuple(sp.Matrix(m["F_diag"]).diagonal()))
    elif "K" in design.matrices:
        raise UsageError("interval observers need a diagonal (Metzler) model: use a Jordan"
                         " design or real distinct --eigenvalues (seed 001 method 1)")
    return interval_observer_nonlinear(model, design, **options)


def _interval_initial(model, d, xl, xu, margin=1):
    """Default initial bounds Φ x(0) ∓ margin (expressions in the plant's initial state;
    a scenario's ``observer_initial`` overrides them)."""
    Phi = sp.Matrix(d.matrices["Phi"])
    xs0 = Phi * sp.Matrix(model.states)
    init = {}
    for i in range(Phi.rows):
        init[xl[i]] = xs0[i] - margin
        init[xu[i]] = xs0[i] + margin
    return init
