"""Per-run summaries of simulated runs: the few numbers per run an ensemble keeps.

An ensemble of 10^4–10^7 runs cannot keep its trajectories; what validates a monitor is a
handful of numbers per run, reduced chunk by chunk:

1. :func:`monitors` decides once, from the model and the observer's outputs, which
   summaries apply (:class:`Monitors`, with one :class:`SummaryField` per number);
2. :func:`summarise` reduces the columns of a chunk of R runs (arrays (R, N)) to
   :class:`RunSummaries` (one float64 per run and field);
3. :class:`observer_cad.ensemble.EnsembleStatistics` (a later stage) collects the per-run
   values of every chunk, in any order, and gives per-run rows (``summary.csv``), the worst
   runs (for replay) and the statistics of the ensemble (per case and overall).

Summaries and their truth
-------------------------
Observer outputs are named as the simulator writes them (columns convention of
:class:`~observer_cad.simulation.SimulationResult`). The truth of ``<s>_hat``,
``<s>_lower`` and ``<s>_upper`` is the column ``s`` when s is a state, input, fault or
disturbance of the model; for ``z`` it is z = M x, the design's ``estimate`` (text, read
by :func:`observer_cad.model.parse_expression` over the model's states, or a sympy
expression) evaluated from the state columns. An output without a truth (an estimate of a
parameter, ``z`` without a design) is listed in :attr:`Monitors.skipped` and has no
summary. The fields (names are the ``summary.csv`` headers):

- estimate ``<s>_hat``: ``<s>_hat.max_error`` (max abs(ŝ − s)), ``<s>_hat.rms_error``
  (sqrt of the mean of (ŝ − s)²), ``<s>_hat.final_error`` (abs(ŝ − s) at the last available
  sample);
- interval ``<s>_lower``/``<s>_upper``: ``<s>.violations`` (samples whose slack
  min(s − lower, upper − s) is < −tol — with tol = 0 exactly s < lower or s > upper — or
  NaN: a sample that shows no inclusion counts), ``<s>.min_slack`` (min of the slack;
  negative = violated; in a finite run, violations > 0 exactly when min_slack < −tol), ``<s>.max_width`` (max of upper − lower), ``<s>.first_violation`` (time; NaN
  when none);
- residual ``r``, ``r1`` …: ``<r>.max_abs`` (max abs(r)); with its band ``<r>_lower``/
  ``<r>_upper``: ``<r>.exceedances`` (samples with r < lower or r > upper, strict as in
  :func:`~observer_cad.observers.decide`: NaN is not out) and ``<r>.first_exceedance``
  (time; NaN when none);
- with a :class:`~observer_cad.observers.DecisionRule`: ``alarm.first`` (time of the first
  alarm; NaN when none), ``alarm.samples`` (samples with an alarm) and ``diagnosis.code``
  (the code at the last available sample of the residuals; :func:`decide` semantics, the
  persistence counters run from the start of the run);
- always: ``finite`` (1.0 when every value of the run is finite, else 0.0) and
  ``nonfinite.first`` (time of the first non-finite value; NaN when none).

Window: only samples with t ≥ ``settle`` count (``settle`` is the transient to ignore),
except ``finite`` and ``nonfinite.first``, which look at the whole run. Samples that are
not available (the last ``observer.delays[name]`` samples of a delayed output, NaN by the
columns convention) are excluded everywhere. A run that is not finite gets +inf in its
error, width and magnitude fields and −inf in ``min_slack``: never a silently small
number.

Determinism: a run's summary is bit-identical whether it is summarised alone or in any
batch of rows — every operand of a sum is a C-contiguous (R, n) array reduced along
axis 1 (one row at a time, in the same order), everything else is elementwise or an exact
reduction (max, min, counts); rows are processed in blocks of about 131,072 values (small
temporaries) and each row is reduced on its own. :class:`~observer_cad.ensemble.EnsembleStatistics`
orders the stored values by run index before computing anything, so its results do not
depend on the order of ``add``.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import re
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import UsageError
from ..model import PlantModel, parse_expression
from ..residuals import DecisionRule, decide
from ..observers import Observer
from ._simulate import column_units

__all__ = ["SummaryField", "Monitors", "monitors", "RunSummaries", "summarise",
           "SUMMARY_KINDS"]

#: the kinds of summary field: what a value measures (``count`` fields get the number and
#: fraction of runs with a value > 0 in :class:`~observer_cad.ensemble.Statistics`, ``code``
#: fields a histogram)
SUMMARY_KINDS = ("error", "slack", "width", "magnitude", "count", "time", "code", "flag")

_RESIDUAL = re.compile(r"r[0-9]*")


@dataclasses.dataclass(frozen=True)
class SummaryField:
    """One per-run summary: ``name`` (the ``summary.csv`` header), ``worse`` (``"max"``:
    larger is worse, ``"min"``: smaller is worse), ``kind`` (one of
    :data:`SUMMARY_KINDS`), ``unit`` (or None) and a one-line ``description``.

    Time fields (``*.first*``) are NaN when the event never happened; NaN ranks as the
    least bad value (see :meth:`observer_cad.ensemble.EnsembleStatistics.worst`).
    """

    name: str
    worse: str
    kind: str
    unit: str | None
    description: str

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise UsageError(f"summary field: the name must be non-empty text, got {self.name!r}")
        if self.worse not in ("max", "min"):
            raise UsageError(f"summary field {self.name}: worse must be 'max' or 'min',"
                             f" got {self.worse!r}")
        if self.kind not in SUMMARY_KINDS:
            raise UsageError(f"summary field {self.name}: kind must be one of"
                             f" {', '.join(SUMMARY_KINDS)}, got {self.kind!r}")

    def to_json(self) -> dict:
        return {"worse": self.worse, "kind": self.kind, "unit": self.unit,
                "description": self.description}


# ---------------------------------------------------------------- what is monitored

@dataclasses.dataclass(frozen=True, eq=False)
class _Truth:
    """The true value of a signal: a column (``column``) or an expression in the state
    columns (``expr`` over ``states``), evaluated elementwise. The numpy function is built
    once (and again after unpickling: a lambdified function does not pickle)."""

    column: str | None
    expr: sp.Basic | None = None
    states: tuple = ()

    def __post_init__(self):
        self._build()

    def _build(self):
        fn = None
        if self.expr is not None:
            fn = sp.lambdify([sp.Symbol(s) for s in self.states], self.expr, modules="numpy")
        object.__setattr__(self, "_fn", fn)

    def __getstate__(self):
        return {"column": self.column, "expr": self.expr, "states": self.states}

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)
        self._build()

    @property
    def needs(self) -> tuple:
        return (self.column,) if self.column is not None else self.states

    def evaluate(self, columns, sl: slice, shape) -> np.ndarray:
        if self.column is not None:
            return columns[self.column][:, sl]
        with np.errstate(all="ignore"):
            v = self._fn(*[columns[s][:, sl] for s in self.states])
        return np.broadcast_to(np.asarray(v, dtype=np.float64), shape)

    def describe(self) -> str:
        return self.column if self.column is not None else f"z = {self.expr}"


@dataclasses.dataclass(frozen=True)
class _Estimate:
    output: str        # <s>_hat
    prefix: str        # field name prefix (the output's name)
    truth: _Truth


@dataclasses.dataclass(frozen=True)
class _Interval:
    signal: str        # s (field prefix)
    lower: str
    upper: str
    truth: _Truth


@dataclasses.dataclass(frozen=True)
class _Residual:
    name: str
    lower: str | None
    upper: str | None


@dataclasses.dataclass(frozen=True, eq=False)
class Monitors:
    """What :func:`summarise` computes for one model and observer (see :func:`monitors`).

    ``fields``: the :class:`SummaryField` of every value, in ``summary.csv`` order;
    ``settle``, ``tolerance``, ``rule``: as given to :func:`monitors`; ``delays``: the
    observer's output delays (their last samples are not available); ``checked``: the
    columns whose finiteness decides ``finite`` (the model's states, outputs, inputs,
    faults, disturbances, noise and the observer's outputs; those absent from a chunk's
    columns are not checked); ``skipped``: observer outputs without a truth, with the
    reason.
    """

    model: str
    observer: str
    fields: tuple
    settle: float
    tolerance: float
    rule: DecisionRule | None
    delays: Mapping
    checked: tuple
    skipped: tuple
    estimates: tuple = ()
    intervals: tuple = ()
    residuals: tuple = ()

    @property
    def names(self) -> tuple:
        """The field names, in order."""
        return tuple(f.name for f in self.fields)

    def field(self, name: str) -> SummaryField:
        for f in self.fields:
            if f.name == name:
                return f
        raise UsageError(f"no summary field '{name}' (fields: {', '.join(self.names)})")

    @property
    def needs(self) -> tuple:
        """The columns :func:`summarise` needs (besides the ones it checks if present)."""
        out = []
        for e in self.estimates:
            out += [e.output, *e.truth.needs]
        for iv in self.intervals:
            out += [iv.lower, iv.upper, *iv.truth.needs]
        for r in self.residuals:
            out += [r.name] + ([r.lower, r.upper] if r.lower else [])
        if self.rule is not None:
            out += list(self.rule.residuals + self.rule.lower_names + self.rule.upper_names)
        return tuple(dict.fromkeys(out))

    def describe(self) -> str:
        lines = [f"summaries of {self.observer} on {self.model}: {len(self.fields)} fields,"
                 f" samples with t ≥ {self.settle:g}"
                 + (f", interval tolerance {self.tolerance:g}" if self.tolerance else "")]
        lines += [f"  {f.name}" + (f" [{f.unit}]" if f.unit else "") + f": {f.description}"
                  for f in self.fields]
        lines += [f"  (no summary of {s})" for s in self.skipped]
        return "\n".join(lines)


def _number(what: str, v, *, low: float = 0.0) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise UsageError(f"monitors: {what} must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x) or x < low:
        raise UsageError(f"monitors: {what} must be a finite number ≥ {low:g}, got {v!r}")
    return x


def _truth(model: PlantModel, observer: Observer, s: str):
    """The truth of signal ``s`` (a _Truth), or the reason there is none (str)."""
    known = {x.name for x in (list(model.states) + list(model.inputs) + list(model.faults)
                              + list(model.disturbances))}
    if s in known:
        return _Truth(column=s)
    if s == "z":
        d = observer.design
        if d is None or d.estimate is None:
            return "z: the observer has no design with an estimate z = M x"
        est = d.estimate
        if isinstance(est, str):   # text: the safe reader, never eval/sympify
            expr = parse_expression(est, model.states, where=f"{observer.name}: estimate")
        elif isinstance(est, sp.Basic):
            expr = est
        else:
            return f"z: the design's estimate {est!r} is not one expression"
        states = {x.name: x for x in model.states}
        extra = {str(v) for v in expr.free_symbols} - set(states)
        if extra:
            raise UsageError(f"monitors: the estimate z = {expr} of {observer.name} uses"
                             f" '{sorted(extra)[0]}', which is not a state of {model.name}")
        used = tuple(x.name for x in model.states if x in expr.free_symbols)
        return _Truth(column=None, expr=expr, states=used)
    return f"{s}: not a state, input, fault or disturbance of {model.name}"


def monitors(model: PlantModel, observer: Observer, *, settle: float = 0.0,
             rule: DecisionRule | None = None, tolerance: float = 0.0) -> Monitors:
    """The summaries that apply to ``observer``'s outputs on ``model``.

    Parameters
    ----------
    model : PlantModel
        The simulated plant (its states, inputs, faults and disturbances are the truths).
    observer : Observer
        The observer; its output names say what it estimates (module docstring).
    settle : float, default 0
        The transient to ignore: only samples with t ≥ settle count (not for ``finite``).
    rule : DecisionRule, optional
        Adds ``alarm.first``, ``alarm.samples`` and ``diagnosis.code``; its residuals and
        their bands must be outputs of the observer.
    tolerance : float, default 0
        An interval sample violates when s < lower − tolerance or s > upper + tolerance.

    Returns
    -------
    Monitors
        The fields, in ``summary.csv`` order; outputs without a truth are listed in
        ``skipped``. Invalid options raise a one-line UsageError.
    """
    if not isinstance(model, PlantModel):
        raise UsageError(f"monitors needs a PlantModel, not a {type(model).__name__}")
    if not isinstance(observer, Observer):
        raise UsageError(f"monitors needs an Observer, not a {type(observer).__name__}")
    settle = _number("settle", settle, low=-math.inf)
    tolerance = _number("tolerance", tolerance)
    if rule is not None and not isinstance(rule, DecisionRule):
        raise UsageError(f"monitors: rule must be a DecisionRule, not a {type(rule).__name__}")
    outs = observer.output_names
    found = _output_fields(model, observer, outs, tolerance)
    fields = (*found.fields, *_rule_fields(rule, observer, outs), *_RUN_FIELDS)
    checked = [s.name for s in model.states] + [f"y{i}" for i in range(1, len(model.outputs) + 1)]
    checked += [s.name for s in (list(model.inputs) + list(model.faults)
                                 + list(model.disturbances) + list(model.noise))]
    checked += list(outs)
    return Monitors(model=model.name, observer=observer.name, fields=tuple(fields),
                    settle=settle, tolerance=tolerance, rule=rule,
                    delays={k: int(v) for k, v in observer.delays.items()},
                    checked=tuple(dict.fromkeys(checked)), skipped=tuple(found.skipped),
                    estimates=tuple(found.estimates), intervals=tuple(found.intervals),
                    residuals=tuple(found.residuals))


@dataclasses.dataclass
class _Found:
    """What :func:`_output_fields` finds among the observer's outputs (built in output order)."""

    fields: list = dataclasses.field(default_factory=list)
    estimates: list = dataclasses.field(default_factory=list)
    intervals: list = dataclasses.field(default_factory=list)
    residuals: list = dataclasses.field(default_factory=list)
    skipped: list = dataclasses.field(default_factory=list)


def _output_fields(model: PlantModel, observer: Observer, outs, tolerance: float) -> _Found:
    """The summary fields of every output with a truth, in output order: an estimate
    ``<s>_hat``, an interval ``<s>_lower``/``<s>_upper`` (once per pair), a residual ``r…``
    (with its band); the other outputs are listed as skipped, with the reason."""
    units = column_units(model, observer, outs)
    found = _Found()
    done = set()
    for name in outs:
        if name in done:
            continue
        if name.endswith("_hat"):
            tr = _truth(model, observer, name[:-4])
            if isinstance(tr, str):
                found.skipped.append(f"{name} ({tr})")
                continue
            found.estimates.append(_Estimate(output=name, prefix=name, truth=tr))
            found.fields += _estimate_fields(name, tr, units.get(name))
        elif name.endswith(("_lower", "_upper")):
            s = name[:-6]
            lo, hi = f"{s}_lower", f"{s}_upper"
            done |= {lo, hi}
            if _RESIDUAL.fullmatch(s) and s in outs:
                continue   # a residual's band: with the residual
            if lo not in outs or hi not in outs:
                found.skipped.append(f"{name} (only one bound of {s})")
                continue
            tr = _truth(model, observer, s)
            if isinstance(tr, str):
                found.skipped.append(f"{lo}, {hi} ({tr})")
                continue
            found.intervals.append(_Interval(signal=s, lower=lo, upper=hi, truth=tr))
            found.fields += _interval_fields(s, tr, units.get(lo), tolerance)
        elif _RESIDUAL.fullmatch(name):
            lo, hi = f"{name}_lower", f"{name}_upper"
            band = lo in outs and hi in outs
            found.residuals.append(_Residual(name, lo if band else None, hi if band else None))
            found.fields += _residual_fields(name, band, units.get(name))
        else:
            found.skipped.append(f"{name} (not an estimate, interval bound or residual)")
    return found


def _estimate_fields(name: str, tr: _Truth, u) -> list:
    """``<s>_hat.max_error``, ``.rms_error``, ``.final_error``."""
    return [SummaryField(f"{name}.max_error", "max", "error", u, f"max |{name} − {tr.describe()}|"),
            SummaryField(f"{name}.rms_error", "max", "error", u,
                         f"root mean square of {name} − {tr.describe()}"),
            SummaryField(f"{name}.final_error", "max", "error", u,
                         f"|{name} − {tr.describe()}| at the last available sample")]


def _interval_fields(s: str, tr: _Truth, u, tolerance: float) -> list:
    """``<s>.violations``, ``.min_slack``, ``.max_width``, ``.first_violation``."""
    lo, hi = f"{s}_lower", f"{s}_upper"
    tol = f" ± {tolerance:g}" if tolerance else ""
    return [SummaryField(f"{s}.violations", "max", "count", None,
                         f"samples with {tr.describe()} outside [{lo}, {hi}]{tol}"),
            SummaryField(f"{s}.min_slack", "min", "slack", u,
                         f"min of min({s} − {lo}, {hi} − {s}) (negative: violated)"),
            SummaryField(f"{s}.max_width", "max", "width", u, f"max of {hi} − {lo}"),
            SummaryField(f"{s}.first_violation", "min", "time", None,
                         f"time of the first violation of {lo} ≤ {s} ≤ {hi} (NaN: none)")]


def _residual_fields(name: str, band: bool, u) -> list:
    """``<r>.max_abs``; with a band, ``<r>.exceedances`` and ``<r>.first_exceedance``."""
    lo, hi = f"{name}_lower", f"{name}_upper"
    out = [SummaryField(f"{name}.max_abs", "max", "magnitude", u, f"max |{name}|")]
    if band:
        out += [SummaryField(f"{name}.exceedances", "max", "count", None,
                             f"samples with {name} < {lo} or {name} > {hi}"),
                SummaryField(f"{name}.first_exceedance", "min", "time", None,
                             f"time {name} first leaves [{lo}, {hi}] (NaN: never)")]
    return out


def _rule_fields(rule: DecisionRule | None, observer: Observer, outs) -> list:
    """``alarm.first``, ``alarm.samples``, ``diagnosis.code`` with a decision rule (whose
    columns the observer must output), else none."""
    if rule is None:
        return []
    for n in rule.residuals + rule.lower_names + rule.upper_names:
        if n not in outs:
            raise UsageError(f"monitors: the decision rule needs the column '{n}', which"
                             f" {observer.name} does not output (outputs: {', '.join(outs)})")
    return [SummaryField("alarm.first", "min", "time", None, "time of the first alarm (NaN: none)"),
            SummaryField("alarm.samples", "max", "count", None, "samples with an alarm"),
            SummaryField("diagnosis.code", "max", "code", None,
                         "diagnosis code at the last available sample (Σ alarm_i 2^(i−1))")]


#: the fields of every run, last
_RUN_FIELDS = (
    SummaryField("finite", "min", "flag", None, "1 if every value of the run is finite, else 0"),
    SummaryField("nonfinite.first", "min", "time", None,
                 "time of the first non-finite value (NaN: none)"))


# ---------------------------------------------------------------- per-run summaries

@dataclasses.dataclass(frozen=True, eq=False)
class RunSummaries:
    """The summaries of R runs: ``fields`` (the :class:`SummaryField` of each) and
    ``values`` (name → (R,) float64); picklable (chunks come back from worker processes)."""

    fields: tuple
    values: Mapping

    def __post_init__(self):
        object.__setattr__(self, "values", dict(self.values))

    @property
    def runs(self) -> int:
        return int(next(iter(self.values.values())).shape[0]) if self.values else 0

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.values[name]
        except KeyError:
            raise UsageError(f"no summary '{name}' (fields:"
                             f" {', '.join(f.name for f in self.fields)})") from None

    def matrix(self) -> np.ndarray:
        """The values as an (R, F) float64 array, columns in field order."""
        return np.column_stack([self.values[f.name] for f in self.fields]) if self.fields \
            else np.zeros((self.runs, 0))


def _rows(columns) -> Mapping:
    cols = getattr(columns, "columns", columns)   # a SimulationResult works
    if not isinstance(cols, Mapping):
        raise UsageError("summarise: columns must map names to arrays (R, N)")
    return cols


def _get(cols: Mapping, name: str, R: int | None, N: int) -> np.ndarray:
    try:
        v = cols[name]
    except KeyError:
        raise UsageError(f"summarise: no column '{name}' (columns: {', '.join(map(str, cols))})") \
            from None
    a = np.asarray(v)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != N or (R is not None and a.shape[0] != R):
        want = f"({R if R is not None else 'R'}, {N})"
        raise UsageError(f"summarise: column '{name}' has shape {np.shape(v)}, expected {want}")
    if a.dtype != np.float64:
        a = a.astype(np.float64)
    return a


def _first_time(mask: np.ndarray, t: np.ndarray, offset: int) -> np.ndarray:
    """Per row, t at the first True of ``mask`` (columns start at ``offset``); NaN if none."""
    out = np.full(mask.shape[0], np.nan)
    has = mask.any(axis=1)
    if has.any():
        out[has] = t[offset + np.argmax(mask[has], axis=1)]
    return out


def _c(a: np.ndarray) -> np.ndarray:
    """A float64 (R, n) array whose rows are contiguous (C-contiguous, or a view of
    contiguous rows such as ``S[:, j, :]`` of the compiled batch's (R, k, N) arrays, used
    as is): reductions along axis 1 then sum each row in the same order whatever R is
    (bit-identical per row; tested)."""
    if a.dtype == np.float64 and a.ndim == 2 and (a.shape[1] <= 1 or a.strides[1] == 8):
        return a
    return np.ascontiguousarray(a, dtype=np.float64)


def summarise(monitors: Monitors, columns, t, *, finite=None, intervals=None) -> RunSummaries:
    """The per-run summaries of a chunk of runs.

    Parameters
    ----------
    monitors : Monitors
        From :func:`monitors`.
    columns : mapping name → array (R, N), or a SimulationResult
        The runs' columns (views, also non-contiguous ones such as ``S[:, :, j]``, are
        fine); a single run's (N,) arrays count as R = 1.
    t : array (N,)
        The time grid (increasing).
    finite : array (R,) of bool, optional
        Runs already known to be finite in every value (the compiled loop's check): their
        columns are not scanned again; the others are checked exactly.
    intervals : mapping signal → (violations, min_slack, max_width, first index), optional
        Interval summaries the compiled loop computed while the samples were in the cache
        (the same operations as here: s − lower, upper − s, their minimum, upper − lower;
        first index −1 when none), used when every run is known finite (else recomputed).

    Returns
    -------
    RunSummaries
        One float64 per run and field (module docstring). A row's values are
        bit-identical whether it is summarised alone or in any batch. Vectorised over
        runs and samples.
    """
    if not isinstance(monitors, Monitors):
        raise UsageError(f"summarise needs Monitors (from monitors()), not a"
                         f" {type(monitors).__name__}")
    cols = _rows(columns)
    t = _time_grid(t)
    N = t.size
    arrays, R = _gather(monitors, cols, N)
    windows = _windows(monitors, t)
    values = {f.name: np.empty(R, dtype=np.float64) for f in monitors.fields}
    known = None
    if finite is not None:
        known = np.asarray(finite, dtype=bool)
        if known.shape != (R,):
            raise UsageError(f"summarise: finite must have shape ({R},), got {known.shape}")
    # blocks of rows small enough for the cache: no large temporaries, and every row is
    # reduced on its own whatever the block (the result does not depend on R)
    # (a view of contiguous rows — the compiled batch's columns — is read in place: its
    # rows count, not its parent's)
    row_bytes = max([8 * N] + [abs(v.strides[0]) for v in arrays.values()
                               if not (v.ndim == 2 and v.strides[1] == 8)])
    B = max(1, (8 * _BLOCK_ELEMENTS) // row_bytes)   # strided views: the parent's rows count
    given = {}
    if intervals and known is not None and known.all():
        given = _given_intervals(monitors, intervals, t, values)
    with np.errstate(all="ignore"):
        for a in range(0, R, B):
            b = min(a + B, R)
            _summarise_block(monitors, {k: _c(v[a:b]) for k, v in arrays.items()}, t, N, windows,
                             {k: v[a:b] for k, v in values.items()},
                             None if known is None else known[a:b], skip=given)
    return RunSummaries(fields=monitors.fields, values=values)


def _time_grid(t) -> np.ndarray:
    """The (N,) time grid of :func:`summarise` (the first row of an (R, N) one)."""
    t = np.asarray(t, dtype=np.float64)
    if t.ndim == 2:
        t = t[0]
    if t.ndim != 1 or t.size == 0:
        raise UsageError(f"summarise: t must be the (N,) time grid, got shape {t.shape}")
    return t


def _gather(monitors: Monitors, cols: Mapping, N: int) -> tuple:
    """(name → (R, N) float64 array, R): the columns the summaries need (all required, of
    one R), then the other checked columns that are present (for ``finite``)."""
    R = None
    arrays = {}
    for name in monitors.needs:
        arrays[name] = _get(cols, name, R, N)
        R = arrays[name].shape[0]
    for name in monitors.checked:
        if name not in arrays and name in cols:
            arrays[name] = _get(cols, name, R, N)
            R = arrays[name].shape[0]
    if R is None:
        raise UsageError(f"summarise: none of the columns of {monitors.observer} on"
                         f" {monitors.model} is present")
    return arrays, R


def _windows(monitors: Monitors, t: np.ndarray) -> dict:
    """The samples each summary looks at: per estimate output, interval signal and
    residual (and ``alarm`` with a rule), the slice with t ≥ settle that every column it
    reads has (a delayed column lacks its last samples)."""
    N = t.size
    start = int(np.searchsorted(t, monitors.settle, side="left"))
    delays = monitors.delays

    def window(*names):
        d = max((delays.get(n, 0) for n in names), default=0)
        stop = N - d
        if start >= stop:
            raise UsageError(f"summarise: settle = {monitors.settle:g} leaves no sample of"
                             f" {', '.join(names)} (available until t = {t[stop - 1]:g})"
                             if stop > 0 else
                             f"summarise: {names[0]} is delayed by {d} of {N} samples")
        return slice(start, stop)

    windows = {}
    for e in monitors.estimates:
        windows[e.output] = window(e.output, *e.truth.needs)
    for iv in monitors.intervals:
        windows[iv.signal] = window(iv.lower, iv.upper, *iv.truth.needs)
    for r in monitors.residuals:
        windows[r.name] = window(r.name, *((r.lower, r.upper) if r.lower else ()))
    if monitors.rule is not None:
        rule = monitors.rule
        windows["alarm"] = window(*(rule.residuals + rule.lower_names + rule.upper_names))
    return windows


def _given_intervals(monitors: Monitors, intervals: Mapping, t: np.ndarray, values: dict) -> dict:
    """Writes the interval summaries the compiled loop computed into ``values``; returns
    them (signal → (violations, min_slack, max_width, first index)), to be skipped."""
    given = {iv.signal: intervals[iv.signal] for iv in monitors.intervals
             if iv.signal in intervals}
    for sig, (viol, slack, width, first) in given.items():
        values[f"{sig}.violations"][:] = viol
        values[f"{sig}.min_slack"][:] = slack
        values[f"{sig}.max_width"][:] = width
        first = np.asarray(first, dtype=np.int64)
        values[f"{sig}.first_violation"][:] = np.where(first >= 0, t[np.maximum(first, 0)],
                                                       np.nan)
    return given


#: rows × samples per block of :func:`summarise`: 1 MB of float64 per temporary (of the
#: parent array's rows for strided views such as ``S[:, :, j]``, so that a block stays in
#: the cache while each of its columns is copied): measured fastest of 8,192 … 10⁹ on the
#: three-tank interval observer, N = 2,001)
_BLOCK_ELEMENTS = 131072


def _summarise_block(monitors: Monitors, arrays: dict, t: np.ndarray, N: int, windows: dict,
                     out: dict, known=None, skip=()) -> None:
    """The summaries of a block of rows, written into ``out`` (views of the result);
    ``known``: rows known to be finite (not scanned)."""
    delays = monitors.delays
    # finiteness over the whole run (the NaN tail of delayed outputs is not available)
    R = next(iter(out.values())).shape[0]
    finite = np.ones(R, dtype=bool)
    first_bad = np.full(R, N, dtype=np.int64)
    scan = np.arange(R) if known is None else np.flatnonzero(~known)
    for name in monitors.checked if scan.size else ():
        if name not in arrays:
            continue
        v = arrays[name][:, :N - delays.get(name, 0)]
        if scan.size < R:
            v = v[scan]
        ok = np.isfinite(v).all(axis=1)
        if not ok.all():
            bad = ~ok
            idx = np.argmax(~np.isfinite(v[bad]), axis=1)
            rows = scan[bad]
            first_bad[rows] = np.minimum(first_bad[rows], idx)
            finite[scan] &= ok
    broken = ~finite
    anybroken = bool(broken.any())
    for e in monitors.estimates:
        sl = windows[e.output]
        est = arrays[e.output][:, sl]
        err = _c(est - e.truth.evaluate(arrays, sl, est.shape))
        np.abs(err, out=err)
        n = err.shape[1]
        p = e.prefix
        np.max(err, axis=1, out=out[f"{p}.max_error"])
        out[f"{p}.final_error"][:] = err[:, -1]
        np.multiply(err, err, out=err)
        out[f"{p}.rms_error"][:] = np.sqrt(np.sum(err, axis=1) / n)
        if anybroken:
            for k in ("max_error", "rms_error", "final_error"):
                out[f"{p}.{k}"][broken] = np.inf
    tol = monitors.tolerance
    for iv in monitors.intervals:
        if iv.signal in skip:  # computed by the compiled loop
            continue
        sl = windows[iv.signal]
        lo, hi = arrays[iv.lower][:, sl], arrays[iv.upper][:, sl]
        s = iv.truth.evaluate(arrays, sl, lo.shape)
        slack = np.subtract(s, lo)
        np.minimum(slack, hi - s, out=slack)             # min(s − lower, upper − s)
        viol = slack >= -tol
        np.logical_not(viol, out=viol)                  # slack < −tol, or NaN
        p = iv.signal
        out[f"{p}.violations"][:] = np.count_nonzero(viol, axis=1)
        np.min(slack, axis=1, out=out[f"{p}.min_slack"])
        np.subtract(hi, lo, out=slack)
        np.max(slack, axis=1, out=out[f"{p}.max_width"])
        out[f"{p}.first_violation"][:] = _first_time(viol, t, sl.start)
        if anybroken:
            out[f"{p}.min_slack"][broken] = -np.inf
            out[f"{p}.max_width"][broken] = np.inf
    for r in monitors.residuals:
        sl = windows[r.name]
        rv = arrays[r.name][:, sl]
        np.max(np.abs(rv), axis=1, out=out[f"{r.name}.max_abs"])
        if anybroken:
            out[f"{r.name}.max_abs"][broken] = np.inf
        if r.lower:
            o = (rv < arrays[r.lower][:, sl]) | (rv > arrays[r.upper][:, sl])
            out[f"{r.name}.exceedances"][:] = np.count_nonzero(o, axis=1)
            out[f"{r.name}.first_exceedance"][:] = _first_time(o, t, sl.start)
    if monitors.rule is not None:
        rule = monitors.rule
        dec = decide(rule, {n: arrays[n] for n in
                            rule.residuals + rule.lower_names + rule.upper_names})
        sl = windows["alarm"]
        alarm = dec.alarm[:, sl]
        out["alarm.first"][:] = _first_time(alarm, t, sl.start)
        out["alarm.samples"][:] = np.count_nonzero(alarm, axis=1)
        out["diagnosis.code"][:] = dec.code[:, sl.stop - 1]
    out["finite"][:] = finite
    nf = np.full(R, np.nan)
    nf[broken] = t[first_bad[broken]]
    out["nonfinite.first"][:] = nf
