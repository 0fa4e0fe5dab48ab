"""What a design is for: the observer kind, the inputs it estimates or detects, those it
is decoupled from, those it bounds, those it takes as zero, and the estimate z = M x.

:func:`resolve_task` is the one place where the names a user gives (``--fault``,
``--disturbance``, ``--estimate``) are checked against the model; every designer works
from the resulting :class:`Task`.

=================  =====================  ==========================================
observer           targets                decoupled (others are assumed zero)
=================  =====================  ==========================================
unknown-input      the one input to       every declared disturbance but the target,
                   estimate               plus ``disturbances``; other faults zero
sliding-mode       the one fault to       every other fault and every disturbance,
                   estimate               plus ``disturbances``
diagnostic         the faults to detect   every disturbance not detected, plus
                   (default: all faults)  ``disturbances``; other faults zero
virtual-sensor     — (z = M x)            every disturbance, plus ``disturbances``
interval           — (z = M x)            nothing: every disturbance is bounded
=================  =====================  ==========================================
"""
from __future__ import annotations

import dataclasses
import enum
from typing import Sequence

import sympy as sp

from ..errors import ExpressionError, ModelError, UsageError
from ._expressions import parse_expression
from ._plant import PlantModel
from ._structure import Structure

__all__ = ["ObserverKind", "Task", "resolve_task", "parse_estimate"]


class ObserverKind(str, enum.Enum):
    """The observers the tool designs (the values are the CLI's ``--observer`` names)."""

    UNKNOWN_INPUT = "unknown-input"
    DIAGNOSTIC = "diagnostic"
    VIRTUAL_SENSOR = "virtual-sensor"
    INTERVAL = "interval"
    SLIDING_MODE = "sliding-mode"
    DREM = "drem"

    def __str__(self) -> str:
        return self.value

    @classmethod
    def parse(cls, value) -> "ObserverKind":
        try:
            return cls(str(value))
        except ValueError:
            raise UsageError(f"unknown observer kind {str(value)!r}; choose from "
                             + ", ".join(k.value for k in cls)) from None


@dataclasses.dataclass(frozen=True)
class Task:
    """A resolved design task (see the module table). Names are the model's symbol names."""

    observer: ObserverKind
    targets: tuple = ()  # estimated (unknown-input, sliding-mode) or detected (diagnostic)
    decoupled: tuple = ()  # Φ L = 0 for these
    bounded: tuple = ()  # interval observers: disturbances enter through their bounds
    assumed_zero: tuple = ()  # declared faults the design takes as zero
    estimate: str | None = None  # z = M x as the user wrote it
    M: sp.ImmutableMatrix | None = None

    @property
    def unknown_input(self) -> str | None:
        """The estimated input of unknown-input and sliding-mode designs."""
        if self.observer in (ObserverKind.UNKNOWN_INPUT, ObserverKind.SLIDING_MODE):
            return self.targets[0] if self.targets else None
        return None

    def D(self, st: Structure) -> sp.Matrix:
        """Columns of the estimated or detected inputs (n × 0 when there are none)."""
        return sp.Matrix(st.unknown_input_columns(self.targets)) if self.targets \
            else sp.zeros(st.n, 0)

    def L(self, st: Structure) -> sp.Matrix:
        """Columns the design is decoupled from (interval: every disturbance, bounded)."""
        names = self.bounded if self.observer == ObserverKind.INTERVAL else self.decoupled
        return sp.Matrix(st.unknown_input_columns(names)) if names else sp.zeros(st.n, 0)

    def __repr__(self) -> str:
        return f"Task({self.observer.value}: {self.describe()})"

    def describe(self) -> str:
        what = {ObserverKind.UNKNOWN_INPUT: f"estimate {', '.join(self.targets)}",
                ObserverKind.SLIDING_MODE: f"estimate {', '.join(self.targets)}",
                ObserverKind.DIAGNOSTIC: f"detect {', '.join(self.targets)}",
                ObserverKind.VIRTUAL_SENSOR: f"virtual sensor for z = {self.estimate}",
                ObserverKind.INTERVAL: f"bounds on z = {self.estimate}",
                ObserverKind.DREM: "DREM adaptive observer"}[self.observer]
        if self.decoupled:
            what += f", decoupled from {', '.join(self.decoupled)}"
        return what

    def to_json(self) -> dict:
        return {"observer": self.observer.value, "targets": list(self.targets),
                "decoupled": list(self.decoupled), "bounded": list(self.bounded),
                "assumed_zero": list(self.assumed_zero), "estimate": self.estimate}

    @classmethod
    def from_json(cls, data, model: PlantModel) -> "Task":
        """The task recorded by :meth:`to_json`, re-resolved against ``model`` (so the
        names are checked again and M is rebuilt from the estimate)."""
        if not isinstance(data, dict):
            raise UsageError("a design's 'task' must be a JSON object")
        observer = ObserverKind.parse(data.get("observer"))
        names = {}
        for key in ("targets", "decoupled", "bounded", "assumed_zero"):
            v = data.get(key, [])
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise UsageError(f"a design's task.{key} must be a list of names")
            names[key] = tuple(v)
        estimate = data.get("estimate")
        if estimate is not None and not isinstance(estimate, str):
            raise UsageError("a design's task.estimate must be a string")
        declared = {s.name for s in model.faults + model.disturbances}
        for key, vals in names.items():
            for nm in vals:
                if nm not in declared:
                    raise ModelError(f"{model.where}: the recorded task's {key} names '{nm}',"
                                     " which the model does not declare as a fault or"
                                     " disturbance")
        M = est_text = None
        if estimate is not None:
            M = sp.ImmutableMatrix(parse_estimate(model, estimate))
            zx = M * sp.Matrix(model.states)
            est_text = str(zx[0, 0]) if M.rows == 1 else str(list(zx))
        elif observer in (ObserverKind.VIRTUAL_SENSOR, ObserverKind.INTERVAL):
            raise UsageError(f"a recorded {observer} task needs its estimate")
        return cls(observer=observer, targets=names["targets"], decoupled=names["decoupled"],
                   bounded=names["bounded"], assumed_zero=names["assumed_zero"],
                   estimate=est_text, M=M)


def parse_estimate(model: PlantModel, expr, *, what: str = "--estimate") -> sp.Matrix:
    """z = M x from an expression in the state names (``"x1"``, ``"x1 - x2"``)."""
    where = model.where
    if isinstance(expr, sp.MatrixBase):
        M = sp.Matrix(expr)
        if M.cols != len(model.states):
            raise ModelError(f"{where}: M must have {len(model.states)} columns")
        return M
    exprs = expr if isinstance(expr, (list, tuple)) else [expr]
    rows = []
    loc = {s.name: s for s in model.states}
    loc.update({p.name: p for p in model.parameters})
    for e in exprs:
        if isinstance(e, str):  # text: the safe reader (never evaluated)
            try:
                e = parse_expression(e, loc, where=f"{where}: {what}")
            except ExpressionError as exc:
                reason = exc.reason if exc.reason.startswith("not a valid expression") \
                    else f"not a valid expression: {exc.reason}"
                raise ModelError(f"{where}: cannot parse {what} {e!r}: {reason}") from None
        elif not isinstance(e, sp.Basic):
            raise ModelError(f"{where}: {what} {e!r} must be one expression in the"
                             " states, e.g. x1 or 'x1 - x2'")
        if not isinstance(e, sp.Expr):
            raise ModelError(f"{where}: {what} {expr!r} must be one expression in the"
                             " states, e.g. x1 or 'x1 - x2'")
        if e == 0:
            raise ModelError(f"{where}: {what} is identically zero")
        extra = e.free_symbols - set(model.states) - set(model.parameters)
        if extra:
            raise ModelError(f"{where}: {what} {e} uses '{sorted(extra, key=str)[0]}',"
                             " which is not a state of the model")
        row = [sp.diff(e, x) for x in model.states]
        if any(c.free_symbols & set(model.states) for c in row) or \
                sp.expand(e - sum(c * x for c, x in zip(row, model.states))) != 0:
            raise ModelError(f"{where}: {what} {e} is not linear in the states")
        rows.append(row)
    return sp.Matrix(rows)


def _names(values) -> list:
    if values is None:
        return []
    if isinstance(values, (str, sp.Symbol)):
        return [str(values)]
    return [str(v) for v in values]


def resolve_task(model: PlantModel, *, observer, faults: Sequence[str] | str | None = (),
                 disturbances: Sequence[str] | None = (), estimate=None) -> Task:
    """Check the names a user gave against ``model`` and resolve the design task.

    Raises :class:`~observer_cad.errors.ModelError` for a name the model does not declare
    in that role and :class:`~observer_cad.errors.UsageError` for a request that does not
    fit the observer kind; each message is one line naming the model file and the name.

    Examples
    --------
    (from the repository's root)

    >>> from observer_cad import load_model, resolve_task
    >>> drive = load_model("models/electric_drive.py")
    >>> resolve_task(drive, observer="unknown-input", faults=["d"])
    Task(unknown-input: estimate d, decoupled from rho)
    >>> resolve_task(drive, observer="unknown-input", faults=["x"])
    Traceback (most recent call last):
    ...
    observer_cad.errors.ModelError: models/electric_drive.py: unknown fault or disturbance 'x'; declared: d, rho
    """
    kind = ObserverKind.parse(observer)
    where = model.where
    fault_names, extra = _names(faults), _names(disturbances)

    def lookup(name, role, allowed):
        sym = model.symbol(name)
        if sym is None or sym not in allowed:
            pool = ", ".join(s.name for s in allowed) or "none"
            shown = repr(name) if not str(name).isprintable() else f"'{name}'"
            raise ModelError(f"{where}: unknown {role} {shown}; declared: {pool}")
        return sym

    targets: list = []
    if kind in (ObserverKind.VIRTUAL_SENSOR, ObserverKind.INTERVAL):
        if estimate is None or (isinstance(estimate, str) and not estimate.strip()):
            raise UsageError(f"--observer {kind} needs --estimate EXPR (e.g. x1)")
        if fault_names:
            raise UsageError(f"--fault does not apply to --observer {kind}")
    elif estimate is not None:
        raise UsageError(f"--estimate does not apply to --observer {kind}")

    if kind == ObserverKind.UNKNOWN_INPUT:
        if len(fault_names) != 1:
            raise UsageError("--observer unknown-input needs exactly one --fault NAME"
                             " (the input to estimate)")
        targets = [lookup(fault_names[0], "fault or disturbance",
                          list(model.faults) + list(model.disturbances))]
    elif kind == ObserverKind.SLIDING_MODE:
        if not model.faults:
            raise ModelError(f"{where}: the model declares no faults to estimate")
        if len(fault_names) > 1:
            raise UsageError("the sliding-mode observer estimates one --fault")
        if not fault_names:
            if len(model.faults) > 1:
                raise UsageError(f"{where}: several faults ({', '.join(f.name for f in model.faults)});"
                                 " name the one to estimate (--fault NAME)")
            targets = [model.faults[0]]
        else:
            targets = [lookup(fault_names[0], "fault", list(model.faults))]
    elif kind == ObserverKind.DIAGNOSTIC:
        names = fault_names or [f.name for f in model.faults]
        if not names:
            raise ModelError(f"{where}: the model declares no faults to detect")
        for nm in names:
            s = lookup(nm, "fault", list(model.faults) + list(model.disturbances))
            if s not in targets:
                targets.append(s)

    if kind == ObserverKind.INTERVAL:
        dec = []
    elif kind == ObserverKind.SLIDING_MODE:
        dec = [f for f in model.faults if f not in targets] + list(model.disturbances)
    else:
        dec = [r for r in model.disturbances if r not in targets]
    for nm in extra:
        s = lookup(nm, "disturbance", list(model.faults) + list(model.disturbances))
        if s in targets:
            verb = "detected" if kind == ObserverKind.DIAGNOSTIC else "estimated"
            raise UsageError(f"'{nm}' cannot be both {verb} (--fault) and decoupled"
                             " (--disturbance)")
        if kind == ObserverKind.INTERVAL:
            raise UsageError("--disturbance does not apply to --observer interval: an interval"
                             " observer bounds every disturbance instead of decoupling it")
        if s not in dec:
            dec.append(s)
    bounded = tuple(s.name for s in model.disturbances) if kind == ObserverKind.INTERVAL else ()
    zero = tuple(f.name for f in model.faults if f not in targets and f not in dec)
    M = None
    est_text = None
    if estimate is not None:
        M = sp.ImmutableMatrix(parse_estimate(model, estimate))
        zx = M * sp.Matrix(model.states)
        est_text = str(zx[0, 0]) if M.rows == 1 else str(list(zx))
    return Task(observer=kind, targets=tuple(s.name for s in targets),
                decoupled=tuple(s.name for s in dec), bounded=bounded, assumed_zero=zero,
                estimate=est_text, M=M)
