"""Reference simulator: plant and observer together, in plain numpy (the oracle the
compiled path is checked against).

Scenarios are data (JSON)::

    {"steps": 200,                      # discrete time; or "t_end": 20, "dt": 0.01
     "seed": 1,
     "initial": {"x1": 0, "x2": 0},     # plant initial state (missing: 0)
     "observer_initial": {"xl1": -1},   # optional, overrides the observer's defaults
     "signals": {"u": "0.2*sin(t/10)",  # expression in t (the safe reader's grammar:
                                        # observer_cad.model.parse_expression; Piecewise allowed)
                 "rho": {"uniform": [-0.05, 0.05]},   # seeded random samples
                 "d": {"piecewise": [["0.3*sin(t/2)", "t <= 20"],
                                     [{"uniform": [-0.5, 0.5]}, true]]}}}

Every value is validated when the :class:`Scenario` is made (before anything is
allocated); :func:`check_memory` refuses arrays above ``$OBSERVER_CAD_MEMORY_LIMIT``
(default 2 GiB). A value that becomes NaN or infinite stops the simulation with
:class:`~observer_cad.errors.NonFiniteError` naming the first one (CLI exit status 4).
Every input, fault, disturbance and noise not given is zero. Signals are held constant
over a step. Continuous time: plant and observer are integrated as one system by
fixed-step RK4 (the outputs y = h(x, u, d, ρ, w) are evaluated inside the stages, so the
observer sees the plant exactly as the equations say); with ``"sample_time": h`` the observer
runs as deployed instead: stepped every h by the monitor's step on the plant's sampled
outputs, the inputs held over h (:func:`simulate`). Discrete time: both step at once.

:func:`simulate` runs one scenario; with ``runs=R`` it runs R seeded realisations of
the random signals at once (vectorised over runs) for Monte-Carlo checks.
"""
from __future__ import annotations

import dataclasses
import json
import math
import numbers
import os
from typing import Mapping, NamedTuple

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import PRECEDENCE

from ..errors import NonFiniteError, UsageError
from ..files import read_json_file
from ..model import PlantModel, parse_expression
from ..numerics import algebraic_to_float
from ..observers import Observer, output_symbols
from ._engine import (ReferenceMonitorEngine, hold_ranges, monitor_initial_state, sample_steps,
                      step_runs)
from ._sampling import (DECLARED, NOMINAL_CASE, SAMPLING_METHODS, check_distribution, draw_runs,
                        parameter_layout, signal_program)

__all__ = ["align_delay", "Scenario", "load_scenario", "scenario_from_dict",
           "simulate", "SimulationResult", "column_units", "T", "memory_limit", "check_memory",
           "find_nonfinite", "finish_result", "MEMORY_LIMIT_ENV", "DEFAULT_MEMORY_LIMIT"]

T = sp.Symbol("t")

#: environment variable that sets the memory limit of one simulation (bytes; a suffix
#: K, M, G or T multiplies by 1024, 1024², …)
MEMORY_LIMIT_ENV = "OBSERVER_CAD_MEMORY_LIMIT"
#: default limit of :func:`check_memory`: 2 GiB
DEFAULT_MEMORY_LIMIT = 2 * 1024 ** 3
_KNOWN_KEYS = ("steps", "t_end", "dt", "seed", "initial", "observer_initial", "signals",
               "description", "parameters", "observer_parameters", "sampling", "cases",
               "sample_time")


def _is_number(v) -> bool:
    """A real number (Python or numpy), not a bool."""
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def _finite(where, what, v):
    """A finite JSON number (bool and strings refused)."""
    if not _is_number(v):
        raise UsageError(f"{where}: {what} must be a number, got {json.dumps(v) if _jsonable(v) else repr(v)}")
    try:
        ok = math.isfinite(float(v))
    except OverflowError:  # a JSON integer beyond the double range
        ok = False
    if not ok:
        text = repr(v)
        raise UsageError(f"{where}: {what} must be finite (a double), got"
                         f" {text if len(text) <= 40 else text[:20] + '…'}")
    return v


def _jsonable(v) -> bool:
    try:
        json.dumps(v)
    except (TypeError, ValueError):
        return False
    return True


def _whole(where, what, v):
    """A whole number: an int, or a float without fraction (1e3); not a bool."""
    if isinstance(v, float) and math.isfinite(v) and v.is_integer():
        return int(v)
    if not isinstance(v, numbers.Integral) or isinstance(v, (bool, np.bool_)):
        shown = json.dumps(v) if _jsonable(v) else repr(v)
        raise UsageError(f"{where}: {what} must be a whole number, got {shown}")
    return int(v)


def _signal_spec(where, name, spec, depth=0):
    """Check one signal specification (and parse its expressions); nothing is evaluated."""
    what = f"signal '{name}'"
    if spec == DECLARED:  # uniform over the model's declared bounds (checked with the model)
        return
    if isinstance(spec, str):
        parse_expression(spec, {"t": T}, where=f"{where}: {what}")
        return
    if _is_number(spec):
        _finite(where, what, spec)
        return
    if isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("uniform", "normal"):
        check_distribution(where, what, spec)
        return
    if isinstance(spec, dict) and set(spec) == {"piecewise"} and depth == 0:
        segs = spec["piecewise"]
        if not isinstance(segs, (list, tuple)) or not segs:
            raise UsageError(f"{where}: {what}: piecewise needs a non-empty list of"
                             " [value, condition] pairs")
        for seg in segs:
            if not isinstance(seg, (list, tuple)) or len(seg) != 2:
                raise UsageError(f"{where}: {what}: piecewise segments are [value, condition] pairs")
            _signal_spec(where, name, seg[0], depth + 1)
            if not isinstance(seg[1], bool):
                if not isinstance(seg[1], str):
                    raise UsageError(f"{where}: {what}: a piecewise condition is text in t"
                                     " (e.g. \"t <= 20\") or true")
                parse_expression(seg[1], {"t": T}, where=f"{where}: {what} condition",
                                 condition=True)
        return
    if isinstance(spec, bool):
        raise UsageError(f"{where}: {what} must be a number or an expression in t, got {json.dumps(spec)}")
    raise UsageError(f"{where}: {what}: use an expression in t, a number,"
                     " {\"uniform\": [low, high]}, {\"normal\": [mean, std]} or"
                     " {\"piecewise\": [[value, condition], ...]}")


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A validated scenario: every value is checked on construction (types, finiteness,
    ranges, whole step counts, signal expressions parsed by the safe reader), before
    anything is allocated."""

    signals: Mapping
    initial: Mapping
    observer_initial: Mapping | None = None
    steps: int | None = None
    t_end: float | None = None
    dt: float | None = None
    seed: int = 0
    source: str | None = None
    parameters: Mapping | None = None
    observer_parameters: Mapping | None = None
    sampling: str = "random"
    cases: Mapping | None = None
    sample_time: float | None = None

    def __post_init__(self):
        where = self.source or "scenario"
        for key, val in (("signals", self.signals), ("initial", self.initial)):
            if not isinstance(val, Mapping):
                raise UsageError(f"{where}: '{key}' must be an object {{name: value}}, got"
                                 f" {type(val).__name__ if not isinstance(val, list) else 'a list'}")
        for key in ("observer_initial", "parameters", "observer_parameters"):
            val = getattr(self, key)
            if val is not None and not isinstance(val, Mapping):
                raise UsageError(f"{where}: '{key}' must be an object {{name: value}}")
        for key, val, what in (("initial", self.initial, "initial"),
                               ("observer_initial", self.observer_initial, "observer_initial"),
                               ("parameters", self.parameters, "parameter"),
                               ("observer_parameters", self.observer_parameters, "observer parameter")):
            for name, v in (val or {}).items():
                if not isinstance(name, str):
                    raise UsageError(f"{where}: {key}: names must be text, got {name!r}")
                check_distribution(where, f"{what} '{name}'", v, declared=key == "parameters")
        if self.sampling not in SAMPLING_METHODS:
            raise UsageError(f"{where}: 'sampling' must be one of {', '.join(SAMPLING_METHODS)},"
                             f" got {self.sampling!r}")
        if self.cases is not None:
            if not isinstance(self.cases, Mapping) or not self.cases:
                raise UsageError(f"{where}: 'cases' must be a non-empty object"
                                 " {case name: {signal: value}}")
            for cname, sigs in self.cases.items():
                if not isinstance(cname, str) or not cname.strip():
                    raise UsageError(f"{where}: cases: a case name must be non-empty text, got {cname!r}")
                if not isinstance(sigs, Mapping):
                    raise UsageError(f"{where}: case '{cname}' must be an object {{signal: value}}")
                for name, spec in sigs.items():
                    if not isinstance(name, str):
                        raise UsageError(f"{where}: case '{cname}': signal names must be text, got {name!r}")
                    _signal_spec(f"{where}: case '{cname}'", name, spec)
        for name, spec in self.signals.items():
            if not isinstance(name, str):
                raise UsageError(f"{where}: signal names must be text, got {name!r}")
            _signal_spec(where, name, spec)
        if self.steps is not None:
            st = _whole(where, "'steps'", self.steps)
            if st < 1:
                raise UsageError(f"{where}: 'steps' must be at least 1, got {st}")
            object.__setattr__(self, "steps", st)
        for key in ("t_end", "dt", "sample_time"):
            v = getattr(self, key)
            if v is not None:
                _finite(where, f"'{key}'", v)
                if not v > 0:
                    raise UsageError(f"{where}: '{key}' must be > 0, got {v}")
        if self.t_end is not None and self.dt is not None and self.dt > self.t_end:
            raise UsageError(f"{where}: 'dt' = {self.dt} is larger than 't_end' = {self.t_end}")
        seed = _whole(where, "'seed'", self.seed)
        if not 0 <= seed < 2**64:  # (the random streams take it modulo 2⁶⁴: refused, not wrapped)
            raise UsageError(f"{where}: 'seed' must be a whole number in [0, 2^64), got {seed}")
        object.__setattr__(self, "seed", seed)

    @property
    def case_names(self) -> tuple:
        """The fault cases' names: ``"cases"``'s keys, or ("nominal",) without cases."""
        return tuple(self.cases) if self.cases else (NOMINAL_CASE,)

    def size(self, time: str) -> int:
        """The number of time points, computed without allocating anything."""
        where = self.source or "scenario"
        if time == "discrete":
            if self.steps is None:
                raise UsageError(f"{where}: a discrete-time scenario needs 'steps'")
            if self.t_end is not None or self.dt is not None:
                raise UsageError(f"{where}: 't_end' and 'dt' do not apply to a discrete-time"
                                 " model (its time is the step count 'steps'); remove them")
            return int(self.steps)
        if self.steps is not None:
            raise UsageError(f"{where}: 'steps' does not apply to a continuous-time model"
                             " (give 't_end' and 'dt'); remove it")
        if self.t_end is None or self.dt is None:
            raise UsageError(f"{where}: a continuous-time scenario needs 't_end' and 'dt'")
        ratio = self.t_end / self.dt
        if not math.isfinite(ratio) or ratio > 2 ** 62:
            raise UsageError(f"{where}: t_end / dt = {self.t_end} / {self.dt} is too many steps")
        steps = int(round(ratio))
        if abs(ratio - steps) > 1e-9 * max(1.0, ratio):  # the grid would not end at t_end
            raise UsageError(f"{where}: 't_end' = {self.t_end} is not a whole number of steps"
                             f" 'dt' = {self.dt} (t_end / dt = {ratio:.6g}: the time grid would"
                             f" end at {steps * self.dt:.6g}); choose dt = t_end / N")
        return steps + 1

    def grid(self, time: str) -> np.ndarray:
        n = self.size(time)
        if time == "discrete":
            return np.arange(n, dtype=float)
        return np.arange(n) * float(self.dt)


def load_scenario(path) -> Scenario:
    """Read a scenario JSON file; errors name the file and the key."""
    data = read_json_file(path, "scenario")
    return scenario_from_dict(data, source=str(path))


def scenario_from_dict(data: dict, source: str | None = None) -> Scenario:
    where = source or "scenario"
    if not isinstance(data, dict):
        raise UsageError(f"{where}: a scenario is a JSON object")
    for key in data:
        if key not in _KNOWN_KEYS:
            raise UsageError(f"{where}: unknown key '{key}' (known: {', '.join(sorted(_KNOWN_KEYS))})")
    if "description" in data and not isinstance(data["description"], str):
        raise UsageError(f"{where}: 'description' must be text")
    return Scenario(signals=data.get("signals", {}), initial=data.get("initial", {}),
                    observer_initial=data.get("observer_initial"), steps=data.get("steps"),
                    t_end=data.get("t_end"), dt=data.get("dt"), seed=data.get("seed", 0),
                    source=source, parameters=data.get("parameters"),
                    observer_parameters=data.get("observer_parameters"),
                    sampling=data.get("sampling", "random"), cases=data.get("cases"),
                    sample_time=data.get("sample_time"))


def memory_limit() -> int:
    """Bytes one simulation may allocate: ``$OBSERVER_CAD_MEMORY_LIMIT`` (bytes, or with a
    suffix K, M, G, T) or :data:`DEFAULT_MEMORY_LIMIT` (2 GiB)."""
    raw = os.environ.get(MEMORY_LIMIT_ENV, "").strip()
    if not raw:
        return DEFAULT_MEMORY_LIMIT
    mult = 1
    if raw[-1].upper() in "KMGT":
        mult = 1024 ** ("KMGT".index(raw[-1].upper()) + 1)
        raw = raw[:-1]
    try:
        v = float(raw) * mult
    except ValueError:
        v = float("nan")
    if not (math.isfinite(v) and v > 0):
        raise UsageError(f"{MEMORY_LIMIT_ENV}={os.environ[MEMORY_LIMIT_ENV]!r}: use a number of"
                         " bytes, e.g. 4G")
    return int(v)


def check_memory(scenario: Scenario, time: str, *, runs: int, columns: int) -> int:
    """Refuse (UsageError) a simulation whose arrays would exceed :func:`memory_limit`:
    runs × time points × columns × 8 bytes. Returns the number of time points."""
    where = scenario.source or "scenario"
    n = scenario.size(time)
    need = int(runs) * n * max(int(columns), 1) * 8
    limit = memory_limit()
    if need > limit:
        raise UsageError(
            f"{where}: {runs} run(s) × {n} time points × {columns} columns would need about"
            f" {_human(need)}, above the limit of {_human(limit)}; use fewer steps or a larger"
            f" dt, or raise the limit with {MEMORY_LIMIT_ENV} (e.g. {MEMORY_LIMIT_ENV}=8G)")
    return n


def _human(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if n < 1024 or unit == "EiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} EiB"  # pragma: no cover


@dataclasses.dataclass(frozen=True)
class SimulationResult:
    """Columns by name: ``t``, the plant states, ``y1…``, every input, fault,
    disturbance and noise, and the observer's outputs. Arrays have shape (N,) for one
    run, (R, N) for ``runs=R``.

    ``order`` is the CSV's column order (noise is a column but not in the CSV);
    ``delays``: observer outputs produced late — their last ``delay`` rows are not
    available (NaN); ``nonfinite``: when non-finite values were kept
    (``keep_nonfinite=True``), the one-line description of the first; ``units`` maps a
    column to its unit (columns without one are absent, see :func:`column_units`);
    ``model`` and ``time`` name the simulated plant and its time domain; ``holds``: a
    sampled run's (min, max) per sample of each disturbance and noise over its hold.
    """

    columns: dict
    order: tuple
    delays: Mapping = dataclasses.field(default_factory=dict)
    nonfinite: str | None = None
    units: Mapping = dataclasses.field(default_factory=dict)
    model: str | None = None
    time: str | None = None
    parameters: Mapping = dataclasses.field(default_factory=dict)  # the true plant's, per run
    holds: Mapping = dataclasses.field(default_factory=dict)

    def __getitem__(self, name):
        return self.columns[name]

    @property
    def runs(self) -> int | None:
        """R for a Monte-Carlo result, None for a single run."""
        t = np.asarray(self.columns["t"])
        return None if t.ndim == 1 else t.shape[0]

    def to_pandas(self):
        """The columns in ``order`` as a ``pandas.DataFrame`` indexed by ``t`` (one run), or
        with a ``(run, t)`` MultiIndex (``runs=R``); ``df.attrs["units"]`` holds the units.

        pandas is optional: without it this raises :class:`ImportError` saying
        ``pip install pandas``.
        """
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("SimulationResult.to_pandas() needs pandas:"
                              " pip install pandas (or pip install 'observer_cad[export]')") from None
        names = [c for c in self.order if c != "t"]
        t = np.asarray(self.columns["t"], dtype=float)

        def col(c):  # numbers as float; text (the diagnosis) as it is
            v = np.asarray(self.columns[c])
            return v if v.dtype == object else v.astype(float)
        if t.ndim == 1:
            df = pd.DataFrame({c: col(c) for c in names}, index=pd.Index(t, name="t"))
        else:
            R, N = t.shape
            index = pd.MultiIndex.from_arrays([np.repeat(np.arange(R), N), t.reshape(-1)],
                                              names=["run", "t"])
            df = pd.DataFrame({c: col(c).reshape(-1) for c in names}, index=index)
        df.attrs["units"] = {c: u for c, u in self.units.items() if c in self.order}
        if self.model is not None:
            df.attrs["model"] = self.model
        return df

    def _summary(self) -> str:
        t = np.asarray(self.columns["t"], dtype=float)
        n = t.shape[-1]
        unit = "s" if self.time == "continuous" else ("steps" if self.time == "discrete" else "")
        span = f"t = {t.flat[0]:g} … {t.flat[-1]:g}{' ' + unit if unit else ''}" if n else "no samples"
        runs = "" if t.ndim == 1 else f", {t.shape[0]} runs"
        what = f"{self.model!r}, " if self.model else ""
        time = f"{self.time} time, " if self.time else ""
        return f"{what}{time}{n} samples{runs}, {span}, {len(self.order) - 1} signals"

    def __repr__(self) -> str:
        return f"<SimulationResult {self._summary()}>"

    def _label(self, c: str) -> str:
        return f"{c} [{self.units[c]}]" if c in self.units else c

    def _repr_markdown_(self) -> str:
        cols = ", ".join(f"`{self._label(c)}`" for c in self.order if c != "t")
        return f"**SimulationResult** — {self._summary()}\n\ncolumns: {cols}"

    def _repr_latex_(self) -> str:
        t = np.asarray(self.columns["t"], dtype=float)
        cols = ", ".join(r"\mathrm{" + self._label(c).replace("_", r"\_") + "}"
                         for c in self.order if c != "t")
        return (rf"$\text{{SimulationResult: {t.shape[-1]} samples, }}"
                rf"t \in [{t.flat[0]:g}, {t.flat[-1]:g}];\ {cols}$")


def column_units(model: PlantModel, observer: Observer | None, names) -> dict:
    """The unit of every column in ``names`` that has one.

    Plant columns take the model's units (``y_i`` the unit its states share,
    :meth:`PlantModel.output_unit`). Observer outputs inherit their signal's:
    ``x1_hat``, ``x1_lower``, ``x1_upper`` the unit of ``x1``; ``d_hat`` that of ``d``;
    a residual ``r`` (``r1``, …) the unit of the outputs it compares when they share
    one, else none; an estimate of an expression (``z_hat``) has none.
    """
    ys = list(output_symbols(len(model.outputs)))
    out_expr = dict(observer.outputs) if observer is not None else {}
    units = {}
    for name in names:
        u = model.unit_of(name)
        if u is None:
            for suffix in ("_hat", "_lower", "_upper"):
                if name.endswith(suffix) and model.symbol(name[:-len(suffix)]) is not None:
                    u = model.unit_of(name[:-len(suffix)])
                    break
            else:
                if name in out_expr and (name == "r" or (name[:1] == "r" and name[1:].isdigit())):
                    used = sp.sympify(out_expr[name]).free_symbols & set(ys)
                    found = {model.output_unit(ys.index(y)) for y in used}
                    if len(found) == 1:
                        u = found.pop()
        if u is not None:
            units[name] = u
    return units


def find_nonfinite(columns: Mapping, order, *, t: np.ndarray, delays: Mapping, signals=(),
                   states=(), outputs=(), observer=()) -> str | None:
    """The first non-finite value of a simulation, as one line naming the time, the
    column and a likely cause; None when every value is finite. Columns have shape
    (R, N); an observer output's last ``delays[name]`` rows (not available) are skipped.
    Ties at the same step are reported in the order signals, states, outputs, observer."""
    best = None
    N = t.shape[-1]
    groups = (("signal", signals), ("state", states), ("output", outputs), ("observer", observer))
    for rank, (kind, names) in enumerate(groups):
        for name in names:
            v = np.asarray(columns[name])
            v = v.reshape(-1, N)[:, :N - int(delays.get(name, 0))]
            bad = ~np.isfinite(v)
            if not bad.any():
                continue
            cols = np.flatnonzero(bad.any(axis=0))
            i = int(cols[0])
            run = int(np.flatnonzero(bad[:, i])[0])
            if best is None or (i, rank) < best[:2]:
                best = (i, rank, kind, name, run, float(v[run, i]))
    if best is None:
        return None
    i, _, kind, name, run, val = best
    val_s = "nan" if math.isnan(val) else ("inf" if val > 0 else "-inf")
    ti = float(np.asarray(t).reshape(-1)[i])
    at = f"at t = {ti:g}" + (f" (run {run})" if np.asarray(columns[name]).ndim > 1
                              and np.asarray(columns[name]).shape[0] > 1 else "")
    cause = {
        "signal": f"signal '{name}' is {val_s} {at}: its expression is not finite there"
                  " (a division by zero or an overflow)",
        "state": f"{name} became {val_s} {at}: the plant left its domain or the input overflowed",
        "output": f"output {name} became {val_s} {at}: a state or noise value overflowed",
        "observer": f"observer output {name} became {val_s} {at}: the observer left its domain"
                    " (e.g. sqrt or log of a negative argument) or diverged",
    }[kind]
    return cause


def align_delay(v: np.ndarray, delay: int) -> np.ndarray:
    """Shift an output produced ``delay`` steps late so that column t holds the estimate of
    time t (NaN where it is not available yet). ``v`` has shape (runs, N)."""
    if not delay:
        return v
    shifted = np.full_like(v, np.nan)
    shifted[:, :-delay] = v[:, delay:]
    return shifted


class _SameBitsPrinter(NumPyPrinter):
    """numpy code whose every operation rounds the same on float64 scalars as on arrays:
    the Python ``**`` operator does not (on arrays numpy takes exact fast paths for x**2,
    x**-1, x**0.5; on scalars it calls pow), so powers are printed as products and
    quotients (small integer exponents), numpy.sqrt, or the ufunc numpy.power."""

    def _print_Pow(self, expr, rational=False):
        b, e = expr.base, expr.exp
        base = self.parenthesize(b, PRECEDENCE["Atom"] + 1)
        if e.is_Integer and 1 <= abs(int(e)) <= 4:
            prod = "*".join([base] * abs(int(e)))
            return f"({prod})" if e > 0 else f"(1/({prod}))"
        if e == sp.S.Half:
            return f"{self._module_format('numpy.sqrt')}({self._print(b)})"
        if e == -sp.S.Half:
            return f"(1/{self._module_format('numpy.sqrt')}({self._print(b)}))"
        return f"{self._module_format('numpy.power')}({self._print(b)}, {self._print(e)})"


def _vector_fn(args, exprs):
    """Numpy function of arrays (one per arg) returning a list of arrays (broadcast); the
    same code on float64 scalars gives the same bits (:class:`_SameBitsPrinter`)."""
    # cse: long expressions (e.g. DREM's determinants) share their subexpressions
    printer = _SameBitsPrinter({"fully_qualified_modules": False, "inline": True,
                                "allow_unknown_functions": True, "user_functions": {}})
    f = sp.lambdify(args, list(exprs), "numpy", cse=True, printer=printer)

    def call(*vals):
        res = f(*vals)
        shape = None
        out = []
        for r in res:
            if np.ndim(r) == 0:  # a constant expression: broadcast to the runs
                if shape is None:
                    shape = np.broadcast_shapes(*(np.shape(v) for v in vals)) if vals else ()
                r = np.full(shape, float(r))
            out.append(r)
        return out
    call.raw = f  # the lambdified function itself (scalars in, scalars out)
    return call


def _integrate(f, X, U, pvals, t, *, discrete: bool) -> None:
    """Fill X from its first step: X is states × runs × steps (arrays over the runs) or,
    for a single run, states × steps (numpy float64 scalars: the same numpy arithmetic —
    powers printed by :class:`_SameBitsPrinter` — at a fraction of the per-operation
    overhead of one-element arrays, so run 0 of a batch bit for bit). U: inputs × (runs ×)
    steps; pvals: the parameters (arrays over the runs, or the run's values). The classic
    RK4 in continuous time."""
    for i in range(t.size - 1):
        u = list(U[..., i])
        cur = list(X[..., i])
        if discrete:
            nxt = f(*cur, *u, *pvals)
        else:
            h = t[i + 1] - t[i]
            k1 = f(*cur, *u, *pvals)
            k2 = f(*[c + h / 2 * k for c, k in zip(cur, k1)], *u, *pvals)
            k3 = f(*[c + h / 2 * k for c, k in zip(cur, k2)], *u, *pvals)
            k4 = f(*[c + h * k for c, k in zip(cur, k3)], *u, *pvals)
            nxt = [c + h / 6 * (a + 2 * b + 2 * cc + d)
                   for c, a, b, cc, d in zip(cur, k1, k2, k3, k4)]
        X[..., i + 1] = nxt


def simulate(model: PlantModel, observer: Observer | None, scenario: Scenario, *,
             runs: int | None = None, keep_nonfinite: bool = False, first_run: int = 0,
             case: str | None = None, samples: int | None = None,
             sample_time: float | None = None, engine=None) -> SimulationResult:
    """Simulate the plant with the observer attached.

    The plant's parameters are the scenario's ``"parameters"`` (sampled per run) or the
    model's values; the observer's are its own (or the scenario's
    ``"observer_parameters"``). ``runs=R`` simulates the samples ``first_run … first_run
    + R − 1`` at once (vectorised); what is random about sample k depends on (seed, k)
    only, so a run is the same in any batch (:mod:`observer_cad.simulation` sampling).
    ``case``: a name of the scenario's ``"cases"`` (its signal overrides; default the
    first case); ``samples``: the ensemble's number of samples per case (only
    ``"sampling": "lhs"`` needs it: without it, ``first_run + runs``).

    Refuses (UsageError) a scenario whose arrays would exceed :func:`memory_limit`
    before allocating them. A value that is not finite (NaN, ±inf) in a signal, a
    state, an output or an observer output raises :class:`NonFiniteError` naming the
    first one (time, column, likely cause) — or, with ``keep_nonfinite=True``, is kept
    and described in ``result.nonfinite``.

    ``sample_time=h`` (default the scenario's ``"sample_time"``; continuous time, a whole
    multiple of the scenario's ``dt``): the observer as deployed. The plant is integrated
    on the scenario's grid with its inputs held (ZOH) over each h, its outputs are sampled
    at t = 0, h, 2h, … and the observer is stepped once per sample by the monitor's step
    (``engine``: an object with ``run(x0, V, h)``, default :class:`ReferenceMonitorEngine`;
    ``observer_cad.codegen.CompiledMonitorEngine`` gives the same numbers to ~1e-15),
    from where the monitor starts. The rows are the samples; the observer columns are
    what :class:`~observer_cad.simulation.Monitor` (and the exported C) computes on the
    t, u and y columns.
    """
    m = model
    if sample_time is None:
        sample_time = scenario.sample_time
    steps = sample_steps(m, observer, scenario, sample_time, engine)
    if observer is not None and observer.time != m.time:
        raise UsageError(f"observer is {observer.time}-time but the model is {m.time}-time")
    R = 1 if runs is None else int(runs)
    if R < 1:
        raise UsageError(f"runs must be at least 1, got {runs}")
    first_run = int(first_run)
    if first_run < 0:
        raise UsageError(f"first_run must be ≥ 0, got {first_run}")
    nsig = len(m.inputs) + len(m.faults) + len(m.disturbances) + len(m.noise)
    ncols = 1 + 2 * len(m.states) + len(m.outputs) + 2 * nsig + (
        2 * len(observer.states) + len(observer.outputs) if observer is not None else 0)
    check_memory(scenario, m.time, runs=R, columns=ncols)
    t = scenario.grid(m.time)
    ks = np.arange(first_run, first_run + R)
    draws = draw_runs(m, observer, scenario, ks, total=samples or first_run + R)
    layout = parameter_layout(m, observer)
    pvals = [draws.P[:, j] for j in range(len(layout.plant) + len(layout.observer))]
    if case is None and scenario.cases:  # the first case, as the CLI and ensembles
        case = scenario.case_names[0]
    prog = signal_program(m, scenario, t, case=case)
    Vall = prog.values(scenario.seed, ks)
    fns = _numeric_functions(m, observer, layout)
    U = np.ascontiguousarray(np.moveaxis(Vall, 2, 0)) if fns.ins else np.zeros((0, R, t.size))
    if steps:
        cols, order, delays, ts = _sampled_columns(m, observer, fns, layout, draws, U, t, steps,
                                                   engine, float(sample_time),
                                                   set(scenario.observer_initial or {}))
        res = _finished(cols, order, delays, ts, m, observer, runs, keep_nonfinite, scenario, draws)
        return dataclasses.replace(res, holds=hold_ranges(m, fns.ins, U, steps, runs is None))
    X = np.zeros((len(fns.xs) + len(fns.obs_states), R, t.size))
    X[:len(fns.xs), :, 0] = draws.x0.T
    X[len(fns.xs):, :, 0] = draws.xi0.T
    with np.errstate(all="ignore"):  # non-finite values are reported below, not warned
        if R == 1:
            _integrate(fns.f_joint.raw, X[:, 0, :], U[:, 0, :], [v[0] for v in pvals], t,
                       discrete=m.time == "discrete")
        else:
            _integrate(fns.f_joint, X, U, pvals, t, discrete=m.time == "discrete")
    cols, order, delays = _result_columns(m, observer, fns, X, U, pvals, t)
    return _finished(cols, order, delays, t, m, observer, runs, keep_nonfinite, scenario, draws)


def _finished(cols, order, delays, t, m, observer, runs, keep_nonfinite, scenario, draws):
    """:func:`finish_result`, with the plant parameters the scenario drew."""
    res = finish_result(cols, order, delays, t, m, observer, runs, keep_nonfinite,
                        where=scenario.source)
    if draws.plant:
        par_cols = {name: (v if runs is not None else v[0]) for name, v in draws.plant.items()}
        res = dataclasses.replace(res, parameters=par_cols)
    return res


def _sampled_columns(m: PlantModel, observer, fns: _Functions, layout, draws, U, t, steps: int,
                     engine, h: float, given=()) -> tuple:
    """(columns (R, n), CSV order, delays, sample times) of the sampled-data runs
    (:func:`simulate` with ``sample_time``): the plant on the grid ``t`` with its inputs
    held over each sample, its outputs sampled, the observer stepped by ``engine`` (the
    states named in ``given`` start as the scenario says, the others as the monitor's)."""
    pars = list(layout.plant) + list(layout.observer)
    pvals = [draws.P[:, j] for j in range(len(pars))]
    R, N = U.shape[1], t.size
    ni = len(m.inputs)  # ZOH: the input of sample k over [k h, (k + 1) h)
    U[:ni] = U[:ni][:, :, (np.arange(N) // steps) * steps]
    X = np.zeros((len(fns.xs), R, N))
    X[:, :, 0] = draws.x0.T
    f_plant = _vector_fn(fns.xs + fns.ins + pars, list(m.dynamics))
    with np.errstate(all="ignore"):
        if R == 1:
            _integrate(f_plant.raw, X[:, 0, :], U[:, 0, :], [v[0] for v in pvals], t,
                       discrete=False)
        else:
            _integrate(f_plant, X, U, pvals, t, discrete=False)
    idx = np.arange(0, N, steps)
    ts, Xs, Us = t[idx], X[:, :, idx], np.ascontiguousarray(U[:, :, idx])
    n = ts.size
    cols = {"t": np.broadcast_to(ts, (R, n)).copy()}
    cols.update({s.name: Xs[j] for j, s in enumerate(fns.xs)})
    with np.errstate(all="ignore"):
        yv = fns.f_y(*Xs, *Us, *[v[:, None] for v in pvals])
    cols.update({str(y): np.asarray(v, dtype=float) for y, v in zip(fns.ys, yv)})
    cols.update({s.name: Us[j] for j, s in enumerate(fns.ins)})
    order = ["t"] + [s.name for s in fns.xs] + [str(y) for y in fns.ys] + \
        [s.name for s in fns.ins if s not in m.noise]
    delays = {}
    if observer is not None and observer.outputs:
        if engine is None:
            engine = ReferenceMonitorEngine(observer)
        mine = [str(s) in given for s in observer.states]  # else the monitor's start
        xi0 = np.where(mine, draws.xi0, monitor_initial_state(observer)).reshape(draws.xi0.shape)
        with np.errstate(all="ignore"):
            O = step_runs(engine, observer, cols, xi0, h, n)
        for j, (name, _) in enumerate(observer.outputs):
            delays[name] = int(observer.delays.get(name, 0))
            cols[name] = align_delay(np.ascontiguousarray(O[:, :, j]), delays[name])
            order.append(name)
    return cols, order, delays, ts


class _Functions(NamedTuple):
    """The numeric functions :func:`simulate` evaluates, with the symbols they order."""

    xs: list            # plant states
    obs_states: list    # observer states
    ins: list           # inputs, faults, disturbances, noise
    ys: list            # output symbols y1 … yp
    f_joint: object     # (x, ξ, v, p) → the joint state's next value (or derivative)
    f_y: object         # (x, v, p) → y
    f_out: object       # (ξ, y, v, p) → the observer's outputs; None without outputs


def _numeric_functions(m: PlantModel, observer: Observer | None, layout) -> _Functions:
    """The plant and observer equations as vectorised numeric functions; the observer
    sees y = h(x, w) and u, and its parameters are run-time arguments."""
    pars = list(layout.plant) + list(layout.observer)
    xs = list(m.states)
    ins = list(m.inputs) + list(m.faults) + list(m.disturbances) + list(m.noise)
    ys = list(output_symbols(len(m.outputs)))
    y_expr = list(m.outputs)
    obs_states = list(observer.states) if observer else []
    # numeric from here on: an exact CRootOf λ becomes its Float (lambdify has no CRootOf)
    obs_upd = [layout.observer_equation(algebraic_to_float(e))
               for e in (observer.update if observer else ())]
    obs_out = [layout.observer_equation(algebraic_to_float(e))
               for _, e in (observer.outputs if observer else ())]
    ysub = dict(zip(ys, y_expr))
    f_joint = _vector_fn(xs + obs_states + ins + pars,
                         list(m.dynamics) + [e.xreplace(ysub) for e in obs_upd])
    f_y = _vector_fn(xs + ins + pars, y_expr)
    f_out = _vector_fn(obs_states + ys + ins + pars, obs_out) if obs_out else None
    return _Functions(xs, obs_states, ins, ys, f_joint, f_y, f_out)


def _result_columns(m: PlantModel, observer: Observer | None, fns: _Functions, X, U, pvals,
                    t) -> tuple:
    """(columns (R, N), CSV order, delays) of the integrated runs: t, the states, the
    outputs, the signals, then the observer's outputs (a delayed one aligned)."""
    xs, ins, ys = fns.xs, fns.ins, fns.ys
    R, N = X.shape[1], X.shape[2]
    cols = {"t": np.broadcast_to(t, (R, N)).copy()}
    for j, s in enumerate(xs):
        cols[s.name] = X[j]
    allu = [U[j] for j in range(len(ins))]
    with np.errstate(all="ignore"):
        yv = fns.f_y(*[X[j] for j in range(len(xs))], *allu, *[v[:, None] for v in pvals])
    for name, v in zip(ys, yv):
        cols[str(name)] = np.asarray(v)
    for j, s in enumerate(ins):
        cols[s.name] = U[j]
    # CSV order: t, states, outputs, inputs, faults, disturbances (noise kept as a column
    # of the result but not in the CSV order), then the observer's outputs
    order = ["t"] + [s.name for s in xs] + [str(y) for y in ys] + \
        [s.name for s in ins if s not in m.noise]
    delays = {}
    if fns.f_out is not None:
        with np.errstate(all="ignore"):
            ov = fns.f_out(*[X[len(xs) + j] for j in range(len(fns.obs_states))], *yv, *allu,
                           *[v[:, None] for v in pvals])
        for (name, _), v in zip(observer.outputs, ov):
            delays[name] = int(observer.delays.get(name, 0))
            cols[name] = align_delay(np.array(v, dtype=float), delays[name])
            order.append(name)
    return cols, order, delays


def _all_finite(cols, delays) -> bool:
    """True when every value is finite (fast: a sum is finite only then; an overflowing
    sum of finite values just sends the caller to the exact search)."""
    with np.errstate(all="ignore"):
        for name, v in cols.items():
            k = int(delays.get(name, 0))
            a = v[..., :v.shape[-1] - k] if k else v
            if not math.isfinite(float(np.sum(a))):
                return False
    return True


def finish_result(cols, order, delays, t, model, observer, runs, keep_nonfinite, *,
                  where=None, units=None, finite=None):
    """The :class:`SimulationResult` of columns of shape (R, N), after the finiteness
    check (shared by the reference and the compiled simulator). ``finite=True``: the
    caller has checked that every value is finite; ``units``: the columns' units, when the
    caller has them already."""
    ins = list(model.inputs) + list(model.faults) + list(model.disturbances) + list(model.noise)
    twice = sorted({c for c in order if order.count(c) > 1})
    if twice:  # one column would hold the other's values: refuse, never write it
        raise UsageError(f"{where or 'simulation'}: the column name {twice[0]!r} is both a"
                         f" symbol of model {model.name!r} and an output of the observer"
                         " (e.g. an estimate named <symbol>_hat): rename the model's symbol")
    if finite is None:
        finite = _all_finite(cols, delays)
    msg = None if finite else find_nonfinite(
        cols, order, t=t, delays=delays, signals=[s.name for s in ins],
                         states=[s.name for s in model.states],
                         outputs=[str(y) for y in output_symbols(len(model.outputs))],
                         observer=[name for name, _ in observer.outputs] if observer else ())
    if msg is not None:
        msg = f"{where or 'simulation'}: {msg}"
        if not keep_nonfinite:
            raise NonFiniteError(msg)
    if runs is None:
        cols = {k: v[0] for k, v in cols.items()}
    return SimulationResult(cols, tuple(order), dict(delays), msg,
                            units=units if units is not None else column_units(model, observer, cols),
                            model=model.name,
                            time=model.time)
