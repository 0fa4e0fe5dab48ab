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
from typing import Any, Mapping

import sympy as sp

from ..synthesis import Design, output_symbols
from ..errors import UsageError
from ..model import PlantModel, parse_expression

__all__ = ["Observer", "estimate_name", "output_symbols"]


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
    threshold: Any = None  # a Threshold when r_lower/r_upper bands were added (_threshold.py)

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
    def own_conditions(self) -> tuple:
        """The conditions the observer adds to its design's (stability of the gains,
        inclusion, monotonicity, bounds): what building it checked."""
        base = set(self.design.conditions) if self.design is not None else set()
        return tuple(c for c in self.conditions if c not in base)

    @property
    def failed_conditions(self) -> tuple:
        """Required conditions that do not hold: such an observer must not be used."""
        return tuple(c for c in self.conditions if c.required and not c.holds)

    def __repr__(self) -> str:
        return (f"<Observer {self.kind} {self.name} ({self.time} time): {len(self.states)} states,"
                f" outputs {', '.join(self.output_names)}>")

    def _repr_markdown_(self) -> str:
        dot = r"(t+1)" if self.time == "discrete" else r"'"
        lines = [f"**Observer** `{self.kind}` `{self.name}` ({self.time} time): {self.description}",
                 ""]
        for x, e in zip(self.states, self.update):
            lines.append(f"$${sp.latex(x)}{dot} = {sp.latex(e)}$$")
        for name, e in self.outputs:
            label = name.replace("_", r"\_")
            lines.append(f"$$\\mathrm{{{label}}} = {sp.latex(e)}$$")
        if self.parameters:
            lines.append("parameters: " + ", ".join(f"`{p} = {v}`" for p, v in self.parameters.items()))
        return "\n".join(lines)

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


def estimate_name(model: PlantModel, design: Design) -> str:
    """``x1`` when z = M x is a single state, else ``z``."""
    est = design.estimate
    if est is not None:
        if not isinstance(est, (str, sp.Basic)):
            return "z"
        try:  # text is read by the safe reader, never evaluated
            e = parse_expression(est, model.states, where="--estimate")
        except UsageError:
            return "z"
        if e in model.states:
            return str(e)
    return "z"


