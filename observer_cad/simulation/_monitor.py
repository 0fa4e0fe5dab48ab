"""A monitor on recorded data: the observer (and its threshold and decision rule) stepped
over measured inputs and outputs, in one call over a table or one row at a time.

The algorithm is the discrete one the exported C runs
(:func:`~observer_cad.codegen.observer_step`): row k gives the observer's outputs at
its current state and the inputs and outputs of that row, then the state's next value.
For a continuous-time observer the step is RK4 of size h, the sample time of the data,
with the row's inputs and outputs held over the interval (zero-order hold); for a
discrete-time one a row is a step. The rows' checks are those of
:mod:`observer_cad.simulation` ``_recording``.

The numbers come from an *engine*: :class:`ReferenceMonitorEngine` (``_engine``: sympy →
Python floats, a loop over rows), or the compiled C of
:func:`observer_cad.codegen.compiled_monitor_engine` (the default of
``observer-cad monitor``), both with ``run(x0, V, h) -> (O, x)``: ``V`` (N, ny + nu)
rows of the observer's signals (measurements y1… first, then its known inputs, the
order of :attr:`Monitor.signals`), ``O`` (N, no) the outputs per row, ``x`` the state
after the last row. An engine that also has ``run_columns(x0, columns, h, decide)`` (the
compiled one) is given :meth:`Monitor.run`'s columns as they are (no copy into rows) and
the rule's output indices and persistence, and returns the decisions with the outputs:
``(O, x, code, alarm)`` (``code``, ``alarm`` None when ``decide`` is None).

Decisions follow :func:`~observer_cad.residuals.decide` (persistence counters carried
from row to row, so :meth:`Monitor.step` and :meth:`Monitor.run` agree).
"""
from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np

from ..errors import UsageError
from ..model import PlantModel
from ..observers import Observer
from ..residuals import DecisionRule, decide
from ._engine import (ReferenceMonitorEngine, check_band_step, monitor_initial_state,
                      monitor_signals)
from ._recording import TIME_RTOL, check_times, declared_envelope, recording_from_columns
from ._simulate import SimulationResult, align_delay, column_units

__all__ = ["Monitor", "MonitorStep", "ReferenceMonitorEngine", "monitor_signals",
           "monitor_signal_columns", "CategoricalColumn",
           "monitor_initial_state", "MONITOR_COLUMNS"]

#: the columns a monitor adds after the observer's outputs: with a decision rule
#: ``alarm`` (0/1) and ``diagnosis`` (text), then always ``in_bounds`` (1 while every
#: recorded signal with a declared range lies in it, else 0)
MONITOR_COLUMNS = ("alarm", "diagnosis", "in_bounds")


def monitor_signal_columns(observer: Observer) -> tuple:
    """The signals' columns of ``monitor.csv`` (and of the exported C's output), in order:
    the measurements by number (y1, y2, …), then the known inputs in the observer's order."""
    ys, us = monitor_signals(observer)
    return tuple(sorted(ys, key=lambda s: int(s[1:]))) + us


@dataclasses.dataclass(frozen=True, eq=False)
class CategoricalColumn:
    """A text column stored as codes into a small table of texts (a categorical):
    ``codes`` (N,) integers, ``texts`` the table; row k's text is ``texts[codes[k]]``.

    It reads as the object array of its texts, which it builds only when asked:
    ``np.asarray(col)``, ``len(col)``, iteration, ``col[k]`` (a text), ``col[a:b]`` or
    ``col[mask]`` (object arrays), ``col.tolist()`` and ``col == text`` (element-wise).
    The ``diagnosis`` column of :meth:`Monitor.run` is one (no string object per row)."""

    codes: np.ndarray
    texts: tuple

    def __array__(self, dtype=None, copy=None):
        a = np.array(self.texts, dtype=object)[self.codes]
        return a if dtype is None else a.astype(dtype)

    @property
    def shape(self) -> tuple:
        return self.codes.shape

    @property
    def ndim(self) -> int:
        return self.codes.ndim

    @property
    def size(self) -> int:
        return self.codes.size

    @property
    def dtype(self):
        return np.dtype(object)

    def __len__(self) -> int:
        return len(self.codes)

    def __iter__(self):
        t = self.texts
        return (t[c] for c in self.codes.tolist())

    def __getitem__(self, key):
        c = self.codes[key]
        if np.ndim(c) == 0:
            return self.texts[int(c)]
        return np.array(self.texts, dtype=object)[c]

    def tolist(self) -> list:
        return list(self)

    def __eq__(self, other):
        return np.asarray(self) == other

    def __ne__(self, other):
        return np.asarray(self) != other

    __hash__ = None

    def __repr__(self) -> str:
        return f"CategoricalColumn({self.size} rows, texts {self.texts!r})"


@dataclasses.dataclass(frozen=True)
class MonitorStep:
    """One row's result: ``t``; ``outputs`` the observer's outputs by name (residuals,
    their bands, estimates); ``alarm`` and ``diagnosis`` (None without a rule);
    ``in_bounds`` whether the row's signals lie in their declared ranges; ``changed``
    whether the alarm or the diagnosis differs from the row before."""

    t: float
    outputs: Mapping
    alarm: bool | None
    diagnosis: str | None
    in_bounds: bool
    changed: bool


class Monitor:
    """The observer over recorded data (module docstring).

    ``rule``: a :class:`~observer_cad.residuals.DecisionRule` over the observer's
    residuals (needs their bands ``<r>_lower``/``<r>_upper``: a threshold), or None;
    ``h``: the sample time of a continuous-time observer (default: the data's first
    interval); ``sample_time``: for a discrete-time model, the unit ``t`` counts in
    (default 1: ``t`` is the step number); ``initial``: values of the plant states the
    observer's initial state depends on (default 0, as the exported C); ``engine``: an
    object with ``run(x0, V, h)`` (default :class:`ReferenceMonitorEngine`).
    ``record=False``: :meth:`step` keeps no history (then :meth:`result` is empty).

        mon = Monitor(model, observer, rule=rule)
        table = mon.run(df)             # pandas DataFrame or mapping: t, u…, y1…
        s = mon.step(t, u=[...], y=[...])
    """

    def __init__(self, model: PlantModel, observer: Observer, *, rule: DecisionRule | None = None,
                 h: float | None = None, sample_time: float | None = None,
                 initial: Mapping | None = None, engine=None, record: bool = True):
        if observer.time != model.time:
            raise UsageError(f"observer is {observer.time}-time but the model is {model.time}-time")
        self.model, self.observer, self.rule = model, observer, rule
        self.ys, self.us = monitor_signals(observer)
        self.signals = self.ys + self.us
        self.outputs = tuple(n for n, _ in observer.outputs)
        if rule is not None:
            missing = [n for n in rule.residuals + rule.lower_names + rule.upper_names
                       if n not in self.outputs]
            if missing:
                raise UsageError(f"monitor: the observer has no output '{missing[0]}' for the"
                                 " decision rule (a threshold gives <r>_lower, <r>_upper)")
        if h is not None and not (np.isfinite(h) and h > 0):
            raise UsageError(f"monitor: h must be a positive finite sample time, got {h!r}")
        self.h0, self.sample_time = h, sample_time
        #: the plant symbols the observer's initial state depends on that were taken as 0
        #: (not given in ``initial``): an assumption the CLI states
        self.assumed_zero = []
        self.x0 = monitor_initial_state(observer, initial, zeroed=self.assumed_zero)
        self.engine = engine if engine is not None else ReferenceMonitorEngine(observer)
        self.envelope = declared_envelope(model)
        self._units = {}        # column names -> their units (column_units), per table shape
        self._texts = None      # the diagnosis of every code, when a table of them is small
        sig = list(monitor_signal_columns(observer))
        dec = list(MONITOR_COLUMNS[:2]) if rule is not None else []
        self._columns = tuple(["t"] + sig + list(self.outputs) + dec + ["in_bounds"])
        self._names = {"u": [str(s) for s in model.inputs],
                       "y": [f"y{i}" for i in range(1, len(model.outputs) + 1)]}
        self.record = record
        #: the name the row checks of :meth:`step` give (e.g. ``<stdin>``)
        self.source = "monitor.step"
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Back to the initial state, before the first row."""
        self.x = self.x0.copy()
        self.h = self.h0 if self.model.time == "continuous" else None
        self._t = []
        self._pending = None          # (t, V row) of the first row while h is unknown
        self._counters = np.zeros(len(self.rule.residuals) if self.rule else 0, dtype=np.int64)
        self._last = (None, None)
        self._rows = {"t": [], "V": [], "O": [], "code": [], "in": []}
        self._extra = {}

    @property
    def columns(self) -> tuple:
        """The columns of :meth:`run`'s table (and monitor.csv), in order."""
        return self._columns

    # ------------------------------------------------------------------ a table
    def run(self, data, *, rename: Mapping | None = None, source: str | None = None):
        """The monitor over a whole table, from the initial state (``data``: a pandas
        DataFrame or a mapping name → column, with ``t`` and the observer's signals;
        ``rename``: signal → the column holding it). Returns a
        :class:`~observer_cad.simulation.SimulationResult` with :attr:`columns`
        (``.to_pandas()`` for a DataFrame), the table ``monitor.csv`` holds."""
        rec = recording_from_columns(self.model, self.signals, data, rename=rename,
                                     sample_time=self.sample_time, source=source)
        self.reset()
        if self.h0 is not None and rec.h is not None and self.model.time == "continuous" \
                and abs(float(rec.h) - self.h0) > TIME_RTOL * self.h0:
            raise UsageError(f"monitor: the data's sample time is {float(rec.h):g}, the"
                             f" monitor's h = {self.h0:g}")
        h = self.h0 if self.h0 is not None else rec.h
        self._check_band_step(h)
        self._check_band_step(rec.h)
        hb = getattr(getattr(self.observer, "threshold", None), "sample_time", None)
        if hb is not None and self.model.time == "continuous" and rec.t.size > 1:
            # the sampled band holds for steps of exactly hb, not within the 0.1 % the
            # regularity check allows
            dev = np.abs(np.diff(rec.t) - hb)
            k = int(np.argmax(dev))
            if dev[k] > 1e-9 * hb + 4 * np.finfo(float).eps * abs(float(rec.t[k + 1])):
                raise UsageError(f"monitor: the guaranteed band holds for steps of exactly"
                                 f" h = {hb:g}; the interval before t = {float(rec.t[k + 1]):g}"
                                 f" (row {k + 2}) is {float(rec.t[k + 1] - rec.t[k]):.12g}")
        sig = [rec.columns[s] for s in self.signals]
        code = alarm = None
        with np.errstate(all="ignore"):
            if hasattr(self.engine, "run_columns"):   # the columns read in place
                O, x, code, alarm = self.engine.run_columns(self.x0, sig, h,
                                                            self._loop_decisions())
            else:
                V = np.column_stack(sig) if sig else np.zeros((rec.t.size, 0))
                O, x = self.engine.run(self.x0, np.ascontiguousarray(V), h)
        self.x, self.h = x, h
        return self._table(rec.t, rec.columns, O, code=code, alarm=alarm)

    def _loop_decisions(self):
        """(output indices (residual, lower, upper) per residual, persistence) for an
        engine that decides in its loop, or None (no rule; a delayed output, whose
        column is shifted after the loop; more residuals than an int64 code holds)."""
        r = self.rule
        if r is None or len(r.residuals) > 62:
            return None
        names = r.residuals + r.lower_names + r.upper_names
        if any(int(self.observer.delays.get(n, 0)) for n in names):
            return None
        idx = [self.outputs.index(n) for trio in zip(r.residuals, r.lower_names, r.upper_names)
               for n in trio]
        return idx, r.persistence

    def _check_band_step(self, h) -> None:
        """A sampled-data band (threshold.sample_time) holds only at its own step."""
        check_band_step(self.model, self.observer, h)

    def _check_exact_step(self, t0: float, t1: float, row: int) -> None:
        """A sampled-data band holds for steps of exactly its h (as :meth:`run` checks)."""
        hb = getattr(getattr(self.observer, "threshold", None), "sample_time", None)
        if hb is not None and self.model.time == "continuous" and \
                abs((t1 - t0) - hb) > 1e-9 * hb + 4 * np.finfo(float).eps * abs(t1):
            raise UsageError(f"{self.source}: the guaranteed band holds for steps of exactly"
                             f" h = {hb:g}; the interval before t = {t1:g} (row {row + 1}) is"
                             f" {t1 - t0:.12g}")

    def _in_bounds(self, cols: Mapping, n: int) -> np.ndarray:
        ok = np.ones(n, dtype=bool)
        for name, (lo, hi) in self.envelope.items():
            if name in cols:
                v = np.asarray(cols[name], dtype=float)
                ok &= (v >= lo) & (v <= hi)
        return ok

    def _diagnosis(self, code: np.ndarray) -> CategoricalColumn:
        """The diagnosis texts of the codes, as a categorical column."""
        if len(self.rule.residuals) <= 12:   # a table of every code: no sort
            if self._texts is None:
                self._texts = tuple(self.rule.diagnosis(c) for c in range(self.rule.codes))
            return CategoricalColumn(code, self._texts)
        seen, inv = np.unique(code, return_inverse=True)
        return CategoricalColumn(inv.reshape(code.shape),
                                 tuple(self.rule.diagnosis(int(c)) for c in seen))

    def _table(self, t, sigs: Mapping, O, *, code=None, alarm=None) -> SimulationResult:
        cols = {"t": np.asarray(t, dtype=float)}
        n = cols["t"].size
        for s in self.columns:
            if s in sigs:
                cols[s] = np.asarray(sigs[s], dtype=float)
        delays = {}
        for j, name in enumerate(self.outputs):
            delays[name] = int(self.observer.delays.get(name, 0))
            v = np.ascontiguousarray(O[:, j], dtype=float)
            cols[name] = align_delay(v[None, :], delays[name])[0] if delays[name] else v
        if self.rule is not None:
            if code is None:
                dec = decide(self.rule, cols)
                code, alarm = dec.code, dec.alarm.astype(np.int64)
            cols["alarm"] = alarm
            cols["diagnosis"] = self._diagnosis(code)
        cols["in_bounds"] = self._in_bounds(sigs, n).astype(np.int64)
        order = self.columns
        key = tuple(cols)
        if key not in self._units:
            self._units[key] = column_units(self.model, self.observer, cols)
        return SimulationResult(cols, order, delays, None, units=dict(self._units[key]),
                                model=self.model.name, time=self.model.time)

    # ------------------------------------------------------------------ a row
    def _row(self, u, y) -> np.ndarray:
        vals = {}
        for what, v, names in (("u", u, self._names["u"]), ("y", y, self._names["y"])):
            if isinstance(v, Mapping):
                vals.update({str(k): float(x) for k, x in v.items()})
            else:
                v = [] if v is None else list(np.atleast_1d(np.asarray(v, dtype=float)))
                if len(v) != len(names):
                    raise UsageError(f"monitor.step: {what} needs {len(names)} values"
                                     f" ({', '.join(names) or 'none'}), got {len(v)}")
                vals.update(zip(names, (float(x) for x in v)))
        for s in self.signals:
            if s not in vals:
                raise UsageError(f"monitor.step: no value for {s}")
            if not np.isfinite(vals[s]):
                raise UsageError(f"monitor.step: {s} = {vals[s]!r} is not a finite number")
        return vals

    def step(self, t: float, u=None, y=None) -> MonitorStep:
        """One row: time ``t``, the inputs ``u`` and outputs ``y`` (sequences in the
        model's order, or mappings name → value). Returns the row's
        :class:`MonitorStep`; the rows' times are checked as :meth:`run` checks them."""
        vals = self._row(u, y)
        t = float(t)
        if not np.isfinite(t):
            raise UsageError(f"monitor.step: t = {t!r} is not a finite number")
        row = np.array([[vals[s] for s in self.signals]], dtype=float).reshape(1, -1)
        n = len(self._t)
        if n:
            h = check_times(np.array([self._t[-1], t]), time=self.model.time,
                            sample_time=self.sample_time, source=self.source, first_row=n,
                            h=self.h)
            self._check_band_step(h)
            self._check_exact_step(self._t[-1], t, n)
            if self._pending is not None:  # the first interval gives h: the first step now
                with np.errstate(all="ignore"):
                    _, self.x = self.engine.run(self.x, self._pending, h)
                self._pending = None
            self.h = h
        elif self.model.time == "discrete":
            pass
        with np.errstate(all="ignore"):
            if self.model.time == "continuous" and self.h is None:
                O, _ = self.engine.run(self.x, row, 0.0)   # outputs only; the step waits for h
                self._pending = row
            else:
                O, self.x = self.engine.run(self.x, row, self.h if self.h is not None else 1.0)
        self._t.append(t)
        return self._decide(t, vals, O[0])

    def _decide(self, t: float, vals: Mapping, o) -> MonitorStep:
        outs = dict(zip(self.outputs, (float(v) for v in o)))
        alarm = diag = None
        code = 0
        if self.rule is not None:
            for i, (r, lo, hi) in enumerate(zip(self.rule.residuals, self.rule.lower_names,
                                                self.rule.upper_names)):
                out = outs[r] < outs[lo] or outs[r] > outs[hi]   # NaN: not out
                self._counters[i] = self._counters[i] + 1 if out else 0
                if self._counters[i] >= self.rule.persistence:
                    code |= 1 << i
            alarm, diag = code != 0, self.rule.diagnosis(code)
        ok = bool(self._in_bounds({k: [v] for k, v in vals.items()}, 1)[0])
        changed = (alarm, diag) != self._last
        self._last = (alarm, diag)
        if self.record:
            r = self._rows
            r["t"].append(t)
            r["V"].append([vals.get(c) for c in self.columns if c in vals])
            r["O"].append(list(o))
            self._extra.update({k: None for k in vals})
        return MonitorStep(t, outs, alarm, diag, ok, changed)

    def result(self) -> SimulationResult:
        """The table of the rows :meth:`step` has seen (as :meth:`run` returns it)."""
        r = self._rows
        # the rows recorded whole: an interruption (Ctrl-C, SIGTERM) inside step() may leave
        # a row's t appended without its values
        n = min(len(r["t"]), len(r["V"]), len(r["O"]))
        names = [c for c in self.columns if c in self._extra]
        V = np.array(r["V"][:n], dtype=float).reshape(n, len(names))
        sigs = {c: V[:, j] for j, c in enumerate(names)}
        O = np.array(r["O"][:n], dtype=float).reshape(n, len(self.outputs))
        return self._table(np.array(r["t"][:n], dtype=float), sigs, O)
