"""The plant model: what a control engineer writes once, symbolically.

A model file is a plain Python module that defines ``model = PlantModel(...)``;
:func:`load_model` imports one by path. The model is immutable and validated on
construction: every symbol is declared in exactly one role, lengths agree, outputs
are linear in the states, noise enters linearly (outputs, and optionally the dynamics).

Plant (METHOD §1), continuous ``dx/dt`` or discrete ``x(t+1)``::

    x' = F x + G u + C Ψ(x, u) + D d + L ρ + Bw w,     y = H x + Gy u + Dy d + Ly ρ + W w
"""
from __future__ import annotations

import dataclasses
import importlib.util
import math
import re
import sys
from fractions import Fraction
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import sympy as sp

from ..errors import DimensionError, ExpressionError, ModelError
from ._expressions import parse_number
from ._statespace import statespace_model_arguments

__all__ = ["PlantModel", "load_model", "load_model_module", "model_from_module", "to_rational",
           "MAX_BOUND", "bound_problem"]

TIME_DOMAINS = ("continuous", "discrete")


def to_rational(value: Any, what: str) -> sp.Expr:
    """Convert a number to an exact sympy Rational (floats via their decimal string).

    ``0.02`` becomes ``1/50``, not the binary expansion of the double. Values must be
    finite and real: NaN, ±oo, zoo and complex numbers are refused (ModelError naming
    ``what``). Text is read by :func:`~observer_cad.model.parse_number` (never evaluated).
    """
    if isinstance(value, sp.Basic):
        if value.has(sp.nan, sp.oo, -sp.oo, sp.zoo) or value.is_finite is False:
            raise ModelError(f"{what}: value {value} is not a finite number")
        if value.is_Rational:
            return value
        if value.is_Float:
            if not value.is_finite:
                raise ModelError(f"{what}: value {value} is not a finite number")
            return sp.Rational(str(value))
        if value.is_number:
            try:
                v = complex(sp.N(value, 30))
            except (TypeError, ValueError, OverflowError):
                raise ModelError(f"{what}: value {value} is not a finite number") from None
            if not (math.isfinite(v.real) and math.isfinite(v.imag)):
                raise ModelError(f"{what}: value {value} is not a finite number")
            if v.imag != 0 or value.is_real is False:
                raise ModelError(f"{what}: value {value} is not real")
            return value
        raise ModelError(f"{what}: value {value} is not a number")
    if isinstance(value, complex):
        raise ModelError(f"{what}: value {value!r} is not real")
    if isinstance(value, bool):
        raise ModelError(f"{what}: value {value!r} is not a number")
    if isinstance(value, int):
        return sp.Integer(value)
    if isinstance(value, Fraction):
        return sp.Rational(value.numerator, value.denominator)
    if isinstance(value, float):
        if value != value or value in (float("inf"), float("-inf")):
            raise ModelError(f"{what}: value {value!r} is not a finite number")
        return sp.Rational(repr(value))
    if isinstance(value, str):
        try:
            return to_rational(parse_number(value, where=what), what)
        except ExpressionError as exc:
            raise ModelError(f"{what}: value {value!r} is not a finite real number"
                             f" ({exc.reason})") from None
    raise ModelError(f"{what}: value {value!r} is not a number")


def free_symbols(e: sp.Basic) -> set:
    """``e.free_symbols``, with a sum's terms ``number·symbol`` and ``symbol`` read off
    directly: one pass over the terms of a long linear equation instead of sympy's
    recursion through every number and product (5× faster on a 300-term sum)."""
    if not e.is_Add:
        return set(e.free_symbols)
    out = set()
    for t in e.args:
        if t.is_Symbol:
            out.add(t)
        elif t.is_Mul and len(t.args) == 2 and t.args[0].is_Number and t.args[1].is_Symbol:
            out.add(t.args[1])
        else:
            out |= t.free_symbols
    return out


def _symbols(seq: Any, role: str, where: str) -> tuple[sp.Symbol, ...]:
    if seq is None:
        return ()
    if isinstance(seq, sp.Symbol):
        seq = (seq,)
    try:
        items = tuple(seq)
    except TypeError:
        raise ModelError(f"{where}: {role} must be a list of sympy Symbols, got {seq!r}") from None
    for s in items:
        if not isinstance(s, sp.Symbol):
            raise ModelError(f"{where}: {role} must be plain sympy Symbols; {s!r} is not")
    seen = set()
    for s in items:
        if s in seen:
            raise ModelError(f"{where}: symbol '{s}' is listed twice in {role}")
        seen.add(s)
    return items


#: names the tool gives its own symbols and columns: the time, the outputs, observer states
_RESERVED = re.compile(r"t|y[0-9]+|xs[0-9]+")


def _not_a_real_finite_expression(e) -> str:
    """Why a model expression cannot describe a real plant ("" if it can): NaN or an
    infinity in it (``sp.nan``, ``sp.zoo``, a division by zero), the imaginary unit or a
    non-real number (``sp.I``, ``sp.sqrt(-2)``, ``(-1)**(1/3)``), or a number beyond the
    floating-point range (no simulation can use it)."""
    if e.has(sp.nan, sp.zoo, sp.oo, -sp.oo):
        return "is not finite (NaN, an infinity or a division by zero)"
    if e.has(sp.I) or any(p.is_number and p.is_extended_real is False for p in e.atoms(sp.Pow)):
        return "is not real (the imaginary unit or a non-real power)"
    for a in e.atoms(sp.Number):
        try:
            if math.isfinite(float(a)):
                continue
        except OverflowError:
            pass
        return f"contains the number {sp.Float(a, 6) if a.is_Rational else a}, beyond the floating-point range"
    return ""


def _exprs(seq: Any, role: str, where: str) -> tuple[sp.Expr, ...]:
    if seq is None:
        return ()
    if isinstance(seq, (sp.Expr, int, float)):
        seq = (seq,)
    if isinstance(seq, sp.MatrixBase):
        seq = list(seq)
    out = []
    for i, e in enumerate(seq):
        try:
            e = sp.sympify(e, strict=True) if not isinstance(e, sp.Basic) else e
        except sp.SympifyError:
            raise ModelError(f"{where}: {role}[{i + 1}] = {e!r} is not a sympy expression") from None
        if not isinstance(e, sp.Expr) or getattr(e, "is_Matrix", False):
            raise ModelError(f"{where}: {role}[{i + 1}] = {e} is not a scalar expression")
        bad = _not_a_real_finite_expression(e)
        if bad:
            raise ModelError(f"{where}: {role}[{i + 1}] = {e} {bad}")
        out.append(e)
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class PlantModel:
    """An immutable, validated plant model.

    Parameters
    ----------
    name : str
        Name of the model (used in reports and generated code).
    time : {"continuous", "discrete"}
        Time domain: right-hand sides are ``dx/dt`` or ``x(t+1)``.
    states : list of Symbol
        State variables x1 ... xn.
    outputs : list of Expr
        Measured outputs y1 ... yl, linear in the states, the noise and (feedthrough) the
        inputs, faults and disturbances: ``x1 + fs1`` is a bias fault on a sensor.
    dynamics : list of Expr
        Right-hand side, one expression per state.
    inputs, faults, disturbances, noise : list of Symbol, optional
        Known controls u, unknown inputs / faults d, disturbances ρ to decouple from,
        noise w: measurement noise in the outputs (W w) and/or process noise in the
        dynamics (Bw w, linear with constant coefficients); bounded, never decoupled.
    parameters : mapping Symbol -> number or None, optional
        Symbolic parameters and their default values (None: no default; numeric
        designs then fail with a clear error).
    bounds : mapping Symbol -> (low, high), optional
        Bounds on faults, disturbances and noise; bounds on states and inputs form the
        operating envelope (the range the plant stays in while it runs), which sampled-data
        guaranteed thresholds rest on (:func:`observer_cad.residuals.sampled_threshold`).
    initial : mapping Symbol -> (low, high), optional
        A box for the plant's unknown initial state x(0), e.g. ``{x1: (0, 1), x2: (-1, 1)}``
        (every state, once one is named; low = high for a known one). Sampled-data
        guaranteed bands (:func:`observer_cad.residuals.sampled_threshold`, which the
        monitor and codegen use for a continuous-time model with a complete operating
        envelope) include the transient of the initial observer error from this box; the
        continuous-time band does not read it (its initial error is ``--initial-error``,
        0 by default: x*(0) = Φ x(0), a listed condition).
    domain : list of sympy relations, optional
        The state domain that nonlinear checks may assume, e.g. ``x1 >= x2``.
    linear_part : matrix, optional
        The state matrix F of the linear/nonlinear split (METHOD §1). When given, the
        difference between the right-hand side's own linear part and F is absorbed
        into the nonlinear terms as formal terms ``β_j A_j x`` (seed 002 §8).
    units : mapping Symbol -> str, optional
        The unit of any declared symbol, e.g. ``{x1: "rad", u: "V"}`` (a symbol's name
        may stand for it). Used for axis labels, ``signals.units.json`` beside the CSV
        and the report; an output ``y_i`` has the unit its states share
        (:meth:`output_unit`). A symbol without an entry has no unit.
    uncertainty : mapping Symbol -> (low, high), optional
        Parameter uncertainty: the true value of a parameter lies in [low, high] (which
        contains its default, the nominal value every design uses). Guaranteed
        thresholds (:func:`observer_cad.observers.guaranteed_threshold`) absorb it;
        scenarios may set the true plant parameters within it (``"parameters"``).
    source : str, optional
        The model file it came from (set by :func:`load_model`; used in messages).
    """

    name: str
    time: str
    states: tuple
    outputs: tuple
    dynamics: tuple
    inputs: tuple = ()
    faults: tuple = ()
    disturbances: tuple = ()
    noise: tuple = ()
    parameters: Mapping = dataclasses.field(default_factory=dict)
    bounds: Mapping = dataclasses.field(default_factory=dict)
    domain: tuple = ()
    linear_part: Any = None
    units: Mapping = dataclasses.field(default_factory=dict)
    uncertainty: Mapping = dataclasses.field(default_factory=dict)
    initial: Mapping = dataclasses.field(default_factory=dict)
    source: str | None = None

    def __post_init__(self) -> None:
        where = self.where
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        if not isinstance(self.name, str) or not self.name.strip():
            raise ModelError(f"{where}: name must be a non-empty string")
        if _has_control_character(self.name):
            raise ModelError(f"{where}: name {self.name!r} has a control character (a newline,"
                             " a tab, …)")
        if self.time not in TIME_DOMAINS:
            raise ModelError(f"{where}: time must be 'continuous' or 'discrete', got {self.time!r}")
        set_("states", _symbols(self.states, "states", where))
        set_("inputs", _symbols(self.inputs, "inputs", where))
        set_("faults", _symbols(self.faults, "faults", where))
        set_("disturbances", _symbols(self.disturbances, "disturbances", where))
        set_("noise", _symbols(self.noise, "noise", where))
        set_("dynamics", _exprs(self.dynamics, "dynamics", where))
        set_("outputs", _exprs(self.outputs, "outputs", where))
        if not self.states:
            raise DimensionError(f"{where}: the model has no states")
        if not self.outputs:
            raise DimensionError(f"{where}: the model has no outputs")
        if len(self.dynamics) != len(self.states):
            raise DimensionError(
                f"{where}: {len(self.states)} states but {len(self.dynamics)} dynamics equations")
        params = _parameter_defaults(self.parameters, where)
        set_("parameters", MappingProxyType(params))
        roles = _symbol_roles(self, params, where)
        _check_expression_symbols(self, roles, where)
        set_("bounds", MappingProxyType(_declared_bounds(self.bounds, roles, where)))
        set_("domain", _state_domain(self.domain, self.states, params, where))
        if self.linear_part is not None:
            set_("linear_part", _checked_linear_part(self.linear_part, len(self.states), params,
                                                     where))
        set_("units", MappingProxyType(_units(self.units, roles, where)))
        set_("uncertainty", MappingProxyType(_uncertainty(self.uncertainty, params, where)))
        set_("initial", MappingProxyType(_initial_box(self.initial, self.states, self.bounds,
                                                      where)))

    @classmethod
    def from_statespace(cls, sys, **options) -> "PlantModel":
        """A model from a python-control ``StateSpace``, a scipy ``lti``/``dlti`` or a
        tuple ``(A, B, C, D)``, its input columns grouped by role
        (the options: :func:`observer_cad.model.statespace_model_arguments`)."""
        return cls(**statespace_model_arguments(sys, **options))

    # ------------------------------------------------------------------ helpers
    @property
    def where(self) -> str:
        """Prefix for messages: the model file if known, else the model name."""
        src = self.__dict__.get("source")
        if src:
            return str(src)
        return f"model '{self.__dict__.get('name', '?')}'"

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(f"y{i + 1}" for i in range(len(self.outputs)))

    def role_of(self, sym: sp.Symbol) -> str | None:
        for role in ("states", "inputs", "faults", "disturbances", "noise"):
            if sym in getattr(self, role):
                return role
        if sym in self.parameters:
            return "parameters"
        return None

    def symbol(self, name: str) -> sp.Symbol | None:
        """The declared symbol called ``name`` (any role), or None."""
        for role in ("states", "inputs", "faults", "disturbances", "noise"):
            for s in getattr(self, role):
                if s.name == name:
                    return s
        for s in self.parameters:
            if s.name == name:
                return s
        return None

    def unit_of(self, name: str) -> str | None:
        """The unit of a declared symbol or an output ``y_i`` (by name), or None."""
        sym = self.symbol(name)
        if sym is not None:
            return self.units.get(sym)
        if name in self.output_names:
            return self.output_unit(self.output_names.index(name))
        return None

    def output_unit(self, i: int) -> str | None:
        """Unit of output ``y_{i+1}``: the unit every state in it has (noise and parameters
        do not count), or None when a state in it has no unit or two units differ."""
        states = [s for s in self.states if s in self.outputs[i].free_symbols]
        found = {self.units.get(s) for s in states}
        if len(found) != 1 or None in found:
            return None
        return found.pop()

    def parameter_values(self) -> dict:
        """Defaults of all parameters; raises ModelError naming one without a value."""
        for p, v in self.parameters.items():
            if v is None:
                raise ModelError(
                    f"{self.where}: parameter '{p}' has no value; give one in the model"
                    " or design with --symbolic")
        return dict(self.parameters)

    def substitute_parameters(self) -> "PlantModel":
        """The same model with every parameter replaced by its exact default."""
        vals = self.parameter_values()
        if not vals:
            return self
        sub = lambda e: sp.sympify(e).xreplace(vals)  # noqa: E731
        for i, f in enumerate(self.dynamics):
            g = sub(f)
            if g.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
                raise ModelError(f"{self.where}: the parameter values make dynamics equation"
                                 f" {i + 1} undefined (division by zero): {f}")
        return dataclasses.replace(
            self,
            dynamics=tuple(sub(f) for f in self.dynamics),
            outputs=tuple(sub(h) for h in self.outputs),
            parameters={},
            domain=tuple(sub(r) for r in self.domain),
            linear_part=None if self.linear_part is None else self.linear_part.xreplace(vals),
            units={s: u for s, u in self.units.items() if s not in vals},
            uncertainty={},
        )

    def _sizes(self) -> str:
        n, l = len(self.states), len(self.outputs)
        parts = [f"{n} state{'s' * (n != 1)}", f"{l} output{'s' * (l != 1)}"]
        for role in ("inputs", "faults", "disturbances", "noise", "parameters"):
            k = len(getattr(self, role))
            if k:
                parts.append(f"{k} {role if k > 1 or role == 'noise' else role[:-1]}")
        return ", ".join(parts)

    def __str__(self) -> str:
        return f"PlantModel({self.name!r}, {self.time}, n={len(self.states)}, l={len(self.outputs)})"

    def __repr__(self) -> str:
        return f"<PlantModel {self.name!r}: {self.time} time, {self._sizes()}>"

    def _equations_latex(self) -> str:
        """The model's equations, one per line (``aligned``)."""
        lhs = (lambda x: rf"{sp.latex(x)}(t+1)") if self.time == "discrete" else \
            (lambda x: rf"\dot{{{sp.latex(x)}}}")
        rows = [rf"{lhs(x)} &= {sp.latex(f)}" for x, f in zip(self.states, self.dynamics)]
        rows += [rf"y_{{{i + 1}}} &= {sp.latex(h)}" for i, h in enumerate(self.outputs)]
        return r"\begin{aligned}" + r" \\ ".join(rows) + r"\end{aligned}"

    def _repr_latex_(self) -> str:
        return "$$" + self._equations_latex() + "$$"

    def _repr_markdown_(self) -> str:
        def names(syms):
            return ", ".join(f"{s}" + (f" [{self.units[s]}]" if s in self.units else "")
                             for s in syms) or "—"
        lines = [f"**PlantModel `{self.name}`** — {self.time} time, {self._sizes()}", "",
                 "| role | symbols |", "|---|---|"]
        for role in ("states", "inputs", "faults", "disturbances", "noise"):
            syms = getattr(self, role)
            if syms:
                lines.append(f"| {role} | {names(syms)} |")
        if self.parameters:
            lines.append(f"| parameters | {', '.join(str(p) for p in self.parameters)} |")
        lines += ["", "$$" + self._equations_latex() + "$$"]
        return "\n".join(lines)


def _parameter_defaults(raw: Any, where: str) -> dict:
    """Parameters: symbol → exact default (or None); a list of symbols has no defaults."""
    params = {}
    raw = raw or {}
    if not isinstance(raw, Mapping):
        raw = {p: None for p in _symbols(raw, "parameters", where)}
    for p, v in raw.items():
        if not isinstance(p, sp.Symbol):
            raise ModelError(f"{where}: parameter {p!r} is not a sympy Symbol")
        params[p] = None if v is None else to_rational(v, f"{where}: parameter '{p}'")
    return params


def _has_control_character(text: str) -> bool:
    """Whether ``text`` has a character of Unicode category C* other than a plain space's
    kin (newlines, tabs, escapes, format and private-use characters)."""
    import unicodedata
    return any(unicodedata.category(c).startswith("C") for c in text)


def _symbol_roles(model: "PlantModel", params: dict, where: str) -> dict:
    """Every symbol in exactly one role, none with a reserved name: symbol → role."""
    roles: dict[sp.Symbol, str] = {}
    for role, syms in (("states", model.states), ("inputs", model.inputs),
                       ("faults", model.faults), ("disturbances", model.disturbances),
                       ("noise", model.noise), ("parameters", tuple(params))):
        for s in syms:
            if s in roles:
                raise ModelError(
                    f"{where}: symbol '{s}' is declared in two roles: {roles[s]} and {role}")
            roles[s] = role
    for s, role in roles.items():
        if _has_control_character(s.name) or not s.name.strip():
            raise ModelError(f"{where}: the {role[:-1] if role != 'noise' else role} name"
                             f" {s.name!r} is empty or has a control character (a newline, a"
                             " tab, …): such a name cannot head a CSV column or a line")
        if _RESERVED.fullmatch(s.name):
            raise ModelError(
                f"{where}: the {role[:-1] if role != 'noise' else role} name '{s}' is reserved"
                " (t is the time, y1, y2, … the outputs and xs1, xs2, … an observer's"
                " states in every equation and output file): rename it")
    return roles


def _check_expression_symbols(model: "PlantModel", roles: dict, where: str) -> None:
    """Every symbol of the equations declared; noise in some output or dynamics equation
    (process noise enters the dynamics linearly, checked at extraction); every fault and
    disturbance in some dynamics equation or output (inputs, faults and disturbances may
    enter the outputs: y = H x + Gy u + Dy d + Ly ρ + W w). Each expression's symbols are
    collected once (one walk over its terms)."""
    declared = set(roles)
    dyn_syms = [free_symbols(f) for f in model.dynamics]
    out_syms = [free_symbols(h) for h in model.outputs]
    for i, (x, fs) in enumerate(zip(model.states, dyn_syms)):
        for s in sorted(fs - declared, key=str):
            raise ModelError(
                f"{where}: undeclared symbol '{s}' in dynamics equation {i + 1} (for {x})")
    for i, (h, hs) in enumerate(zip(model.outputs, out_syms)):
        name = f"y{i + 1}"
        for s in sorted(hs - declared, key=str):
            raise ModelError(f"{where}: undeclared symbol '{s}' in output {name} = {h}")
    in_outputs = set().union(*out_syms)
    in_dynamics = set().union(*dyn_syms)
    for w in model.noise:
        if w not in in_outputs and w not in in_dynamics:
            raise ModelError(f"{where}: noise '{w}' is declared but appears in no output"
                             " and no dynamics equation")
    for role, syms in (("fault", model.faults), ("disturbance", model.disturbances)):
        for s in syms:
            if s not in in_dynamics and s not in in_outputs:
                raise ModelError(f"{where}: {role} '{s}' is declared but appears in no"
                                 " dynamics equation or output")


def _declared_pair(s, b, what: str, where: str) -> tuple:
    """One exact (low, high) pair, with one-line errors."""
    if not isinstance(b, (tuple, list)) or len(b) != 2:
        raise ModelError(f"{where}: {what} of '{s}' must be a pair (low, high)")
    one = "bound" if what == "bounds" else what
    lo = to_rational(b[0], f"{where}: lower {one} of '{s}'")
    hi = to_rational(b[1], f"{where}: upper {one} of '{s}'")
    if bool(lo > hi):
        raise ModelError(f"{where}: {what} of '{s}' have low {lo} > high {hi}")
    problem = bound_problem(lo, hi)
    if problem:
        raise ModelError(f"{where}: {what} of '{s}' {problem}")
    return (lo, hi)


def _declared_bounds(raw: Any, roles: dict, where: str) -> dict:
    """Bounds of faults, disturbances, noise, inputs and states (the operating envelope):
    symbol → exact (low, high)."""
    bounds = {}
    if raw is not None and not isinstance(raw, Mapping):
        raise ModelError(f"{where}: bounds must be a mapping {{symbol: (low, high)}}")
    for s, b in (raw or {}).items():
        if not isinstance(s, sp.Symbol) or s not in roles:
            raise ModelError(f"{where}: bounds given for undeclared symbol '{s}'")
        if roles[s] not in ("faults", "disturbances", "noise", "inputs", "states"):
            raise ModelError(
                f"{where}: bounds may be given for states, inputs, faults, disturbances and"
                f" noise; '{s}' is in {roles[s]}")
        bounds[s] = _declared_pair(s, b, "bounds", where)
    return bounds


def _initial_box(raw: Any, states: tuple, bounds: Mapping, where: str) -> dict:
    """The box of the initial state: state → exact (low, high), inside the state's operating
    envelope when it has one."""
    if raw is not None and not isinstance(raw, Mapping):
        raise ModelError(f"{where}: initial must be a mapping {{state: (low, high)}}")
    box = {}
    for s, b in (raw or {}).items():
        if not isinstance(s, sp.Symbol) or s not in states:
            raise ModelError(f"{where}: initial box given for '{s}', which is not a state")
        lo, hi = _declared_pair(s, b, "initial box", where)
        if s in bounds and (bool(lo < bounds[s][0]) or bool(hi > bounds[s][1])):
            raise ModelError(f"{where}: initial box of '{s}' [{lo}, {hi}] leaves its bounds"
                             f" [{bounds[s][0]}, {bounds[s][1]}]")
        box[s] = (lo, hi)
    missing = [s for s in states if s not in box]
    if box and missing:
        raise ModelError(f"{where}: the initial box names some states but not '{missing[0]}'"
                         " (give a (low, high) pair for every state)")
    return box


#: the largest |bound| of a signal: interval arithmetic in double precision with bounds of
#: 1e15 leaves no significant digit of values of order one (1e15 · 2⁻⁵² ≈ 0.2), so a
#: band, an interval or a threshold built on them would be noise presented as a result
MAX_BOUND = 1e12


def bound_problem(lo, hi) -> str | None:
    """What is wrong with bounds (low, high) beyond their order, or None: a magnitude above
    :data:`MAX_BOUND` is refused (leave the bounds out for a signal that has none)."""
    try:
        big = max(abs(float(lo)), abs(float(hi)))
    except (TypeError, ValueError, OverflowError):
        return "are not finite numbers"
    if not big <= MAX_BOUND:
        return (f"reach {big:.3g}, above {MAX_BOUND:g}: in double precision such an interval"
                " leaves no significant digit of the values it encloses (declare no bounds for"
                " a signal that has none)")
    return None


def _state_domain(relations: Any, states, params: dict, where: str) -> tuple:
    """The domain: sympy relations in the states (and parameters)."""
    dom = []
    for i, rel in enumerate(relations or ()):
        if not isinstance(rel, sp.core.relational.Relational):
            raise ModelError(f"{where}: domain[{i + 1}] = {rel!r} is not a sympy relation")
        extra = rel.free_symbols - set(states) - set(params)
        if extra:
            raise ModelError(
                f"{where}: domain[{i + 1}] = {rel} uses '{sorted(extra, key=str)[0]}',"
                " which is not a state or parameter")
        dom.append(rel)
    return tuple(dom)


def _checked_linear_part(linear_part: Any, n: int, params: dict, where: str) -> sp.ImmutableMatrix:
    """The declared F of the linear/nonlinear split: n×n, in the parameters only."""
    try:
        F = sp.ImmutableMatrix(linear_part)
    except Exception:
        raise ModelError(f"{where}: linear_part is not a matrix") from None
    if F.shape != (n, n):
        raise DimensionError(f"{where}: linear_part must be {n}x{n}, got {F.shape[0]}x{F.shape[1]}")
    extra = F.free_symbols - set(params)
    if extra:
        raise ModelError(
            f"{where}: linear_part uses '{sorted(extra, key=str)[0]}', which is not a parameter")
    return F


def _uncertainty(raw: Any, params: Mapping, where: str) -> dict:
    """Validate ``uncertainty``: parameter -> (low, high), finite, low <= default <= high."""
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise ModelError(f"{where}: uncertainty must be a mapping parameter -> (low, high),"
                         f" got {raw!r}")
    by_name = {s.name: s for s in params}
    out = {}
    for key, b in raw.items():
        p = by_name.get(key) if isinstance(key, str) else key
        if not isinstance(p, sp.Symbol) or p not in params:
            raise ModelError(f"{where}: uncertainty given for '{key}', which is not a parameter")
        if params[p] is None:
            raise ModelError(f"{where}: uncertainty of '{p}' needs a nominal value: give the"
                             " parameter a default")
        try:
            lo, hi = b
        except (TypeError, ValueError):
            raise ModelError(f"{where}: uncertainty of '{p}' must be a pair (low, high)") from None
        lo = to_rational(lo, f"{where}: lower uncertainty bound of '{p}'")
        hi = to_rational(hi, f"{where}: upper uncertainty bound of '{p}'")
        if not (lo.is_Rational and hi.is_Rational):
            raise ModelError(f"{where}: uncertainty bounds of '{p}' must be rational numbers")
        nominal = params[p]
        if bool(lo > hi):
            raise ModelError(f"{where}: uncertainty of '{p}' has low {lo} > high {hi}")
        if nominal.is_Rational and not (lo <= nominal <= hi):
            raise ModelError(f"{where}: uncertainty [{lo}, {hi}] of '{p}' does not contain its"
                             f" nominal value {nominal}")
        out[p] = (lo, hi)
    return out


def _units(raw: Any, roles: dict, where: str) -> dict:
    """Validate ``units``: keys declared symbols (or their names), values non-empty strings."""
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise ModelError(f"{where}: units must be a mapping symbol -> unit string, got {raw!r}")
    by_name = {s.name: s for s in roles}
    out = {}
    for key, unit in raw.items():
        sym = by_name.get(key) if isinstance(key, str) else key
        if not isinstance(sym, sp.Symbol) or sym not in roles:
            raise ModelError(f"{where}: units given for '{key}', which is not a declared symbol")
        if not isinstance(unit, str) or not unit.strip() or "\n" in unit:
            raise ModelError(f"{where}: the unit of '{sym}' must be a non-empty one-line string,"
                             f" got {unit!r}")
        if sym in out:
            raise ModelError(f"{where}: units of '{sym}' are given twice")
        out[sym] = unit.strip()
    return out


def load_model_module(path: str | Path):
    """Execute a model file (a plain Python module) and return its namespace.

    Errors (missing file, import failure, a ModelError raised while building) are
    :class:`ModelError` with a one-line message naming the file (and the line).
    """
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"{path}: no such model file")
    modname = f"_observer_cad_model_{abs(hash(str(p.resolve())))}"
    spec = importlib.util.spec_from_file_location(modname, p)
    if spec is None or spec.loader is None:
        raise ModelError(f"{path}: cannot be imported as a Python module")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except ModelError as exc:
        msg = str(exc)
        if not msg.startswith(str(path)):
            msg = f"{path}: {msg}"
        raise type(exc)(msg) from None  # keep the class (DimensionError)
    except BaseException as exc:  # noqa: BLE001 - any failure of user code
        if isinstance(exc, KeyboardInterrupt):
            raise
        detail = " / ".join(line.strip() for line in str(exc).strip().splitlines() if line.strip())
        lineno = ""
        tb = exc.__traceback__
        here = p.resolve()
        while tb is not None:
            if Path(tb.tb_frame.f_code.co_filename).resolve() == here:
                lineno = f", line {tb.tb_lineno}"
            tb = tb.tb_next
        if isinstance(exc, SyntaxError) and exc.lineno:
            lineno = f", line {exc.lineno}"
        raise ModelError(f"{path}: failed to import{lineno}: {type(exc).__name__}: {detail}") from None
    finally:
        sys.modules.pop(modname, None)
    return module


def load_model(path: str | Path) -> PlantModel:
    """Import a model file (a plain Python module defining ``model``) and return it.

    Errors (missing file, import failure, no ``model``, wrong type, invalid model)
    are :class:`ModelError` with a one-line message naming the file.
    """
    return model_from_module(load_model_module(path), path)


def model_from_module(module, path) -> PlantModel:
    """The ``model`` an executed model file defines (see :func:`load_model_module`)."""
    model = getattr(module, "model", None)
    if model is None:
        raise ModelError(f"{path}: the model file defines no 'model'")
    if not isinstance(model, PlantModel):
        raise ModelError(f"{path}: 'model' is a {type(model).__name__}, not a PlantModel")
    return dataclasses.replace(model, source=str(path))
