"""The monitor's step: the observer's discrete algorithm over rows of measured signals
(:class:`ReferenceMonitorEngine`, sympy → Python floats), shared by
:class:`~observer_cad.simulation.Monitor` and by :func:`~observer_cad.simulation.simulate`
with ``sample_time`` (the plant simulated, the observer stepped as deployed), so the two
run the same algorithm as the exported C (:func:`~observer_cad.codegen.observer_step`).

An *engine* has ``run(x0, V, h) -> (O, x)``: ``V`` (N, ny + nu) rows of the observer's
signals (measurements y1… first, then its known inputs: :func:`monitor_signals`), ``O``
(N, no) the outputs per row, ``x`` the state after the last row.
"""
from __future__ import annotations

import math
import numbers
import re
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import NonFiniteError, UsageError
from ..model import PlantModel
from ..numerics import algebraic_to_float
from ..observers import Observer

__all__ = ["monitor_signals", "monitor_initial_state", "ReferenceMonitorEngine", "check_band_step",
           "step_runs", "sample_steps", "hold_ranges"]


def monitor_signals(observer: Observer) -> tuple:
    """(measurements y1…, known inputs) the observer reads, as names in its order (the
    order of the exported C's ``y`` and ``u`` arguments)."""
    names = [str(s) for s in observer.signals]
    ys = [s for s in names if re.fullmatch(r"y\d+", s)]
    return tuple(ys), tuple(s for s in names if s not in ys)


def monitor_initial_state(observer: Observer, initial: Mapping | None = None, *,
                          zeroed: list | None = None) -> np.ndarray:
    """The observer's initial state: ``observer.initial`` with the plant symbols it
    mentions set from ``initial`` (name → value; an observer state's name sets that
    state) and the rest 0 — the default of the exported C. ``zeroed``: a list that
    receives the names taken as 0."""
    given = {str(k): float(v) for k, v in (initial or {}).items()}
    par = dict(observer.parameters)
    x0 = []
    taken = set()
    for s in observer.states:
        if str(s) in given:
            x0.append(given[str(s)])
            continue
        e = algebraic_to_float(sp.sympify(observer.initial.get(s, 0))).xreplace(par)
        sub = {v: given.get(str(v), 0.0) for v in e.free_symbols}
        taken.update(str(v) for v in e.free_symbols if str(v) not in given)
        try:
            x0.append(float(e.xreplace(sub)))
        except TypeError:
            raise UsageError(f"monitor: the initial value of {s} ({e}) is not a number") from None
    if zeroed is not None:
        zeroed.extend(sorted(taken))
    return np.array(x0, dtype=float)


class ReferenceMonitorEngine:
    """The observer's step in Python floats (sympy lambdify; a loop over rows): the
    reference the compiled engine is tested against."""

    kind = "reference (Python)"

    def __init__(self, observer: Observer):
        ys, us = monitor_signals(observer)
        par = dict(observer.parameters)
        xs = list(observer.states)
        sig = [sp.Symbol(n) for n in ys + us]
        sym = {str(s): s for s in observer.signals}
        args = xs + [sym[n] for n in ys + us]
        fix = [algebraic_to_float(sp.sympify(e)).xreplace(par) for e in observer.update]
        out = [algebraic_to_float(sp.sympify(e)).xreplace(par) for _, e in observer.outputs]
        self._upd = sp.lambdify(args, fix or [0], modules="math")
        self._out = sp.lambdify(args, out or [0], modules="math")
        self.nx, self.no, self.nv = len(xs), len(out), len(sig)
        self.continuous = observer.time == "continuous"

    def run(self, x0, V, h: float):
        x = [float(v) for v in x0]
        V = np.asarray(V, dtype=float).reshape(-1, self.nv)
        O = np.empty((V.shape[0], self.no))
        upd, fo, n = self._upd, self._out, self.nx
        for k, row in enumerate(V.tolist()):
            O[k] = fo(*x, *row)[:self.no] if self.no else ()
            if not n:
                continue
            if not self.continuous:
                x = list(upd(*x, *row))
                continue
            k1 = upd(*x, *row)   # RK4 in the operation order of codegen.rk4
            k2 = upd(*[h / 2 * a + b for a, b in zip(k1, x)], *row)
            k3 = upd(*[h / 2 * a + b for a, b in zip(k2, x)], *row)
            k4 = upd(*[h * a + b for a, b in zip(k3, x)], *row)
            x = [h / 6 * (a + 2 * b + 2 * c + d) + xv
                 for a, b, c, d, xv in zip(k1, k2, k3, k4, x)]
        return O, np.array(x, dtype=float)


def check_band_step(model: PlantModel, observer: Observer, h, *, where: str = "monitor") -> None:
    """A sampled-data band (``observer.threshold.sample_time``) holds only for the RK4 step
    the monitor runs, at its own step size: anything else is refused in one line."""
    th = getattr(observer, "threshold", None)
    how = getattr(th, "discretisation", "") or ""
    if how not in ("", "rk4", "discrete"):
        raise UsageError(f"{where}: the guaranteed band holds for the {how} discretisation;"
                         " the monitor steps RK4 (build the threshold with"
                         " discretisation='rk4')")
    hb = getattr(th, "sample_time", None)
    if hb is not None and h is not None and model.time == "continuous" \
            and abs(float(h) - hb) > 1e-9 * hb:
        raise UsageError(f"{where}: the guaranteed band holds for the algorithm stepped at"
                         f" h = {hb:g}; the data's sample time is {float(h):g} (build the"
                         " threshold at the data's sample time)")


def step_runs(engine, observer: Observer, signals: Mapping, x0: np.ndarray, h: float,
              n: int) -> np.ndarray:
    """The engine over R runs of ``n`` sampled rows: ``signals`` name → (R, n) (every name of
    :func:`monitor_signals`), ``x0`` (R, nξ) the initial states; returns (R, n, no), the
    observer's outputs per run and row, as :class:`~observer_cad.simulation.Monitor` has
    them (each run from its own initial state, row after row)."""
    names = [s for group in monitor_signals(observer) for s in group]
    missing = [s for s in names if s not in signals]
    if missing:
        raise UsageError(f"the observer reads {missing[0]}, which is not a measured signal")
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    out = np.empty((x0.shape[0], n, len(observer.outputs)))
    for r in range(x0.shape[0]):
        V = np.ascontiguousarray(np.column_stack([np.asarray(signals[s], dtype=float)[r]
                                                  for s in names])
                                 if names else np.zeros((n, 0)))
        try:
            O, _ = engine.run(x0[r], V, h)
        except (ArithmeticError, ValueError) as exc:  # Python floats: 1/0, sqrt(−1) raise
            raise NonFiniteError(f"the observer's step failed in run {r} ({exc}): it left"
                                 " its domain (a division by zero, sqrt or log of a negative"
                                 " argument) or diverged") from None
        out[r] = O
    return out


def sample_steps(m: PlantModel, observer, scenario, h, engine=None) -> int:
    """Grid steps of ``scenario`` (a :class:`~observer_cad.simulation.Scenario`) per
    sample of the sample time h of :func:`~observer_cad.simulation.simulate` (0 without
    it), after its checks (one line each): a continuous-time model, h a whole multiple of
    the scenario's dt and no longer than its t_end, a sampled band made for h, the
    observer's own parameters."""
    where = scenario.source or "scenario"
    if h is None:
        if engine is not None:
            raise UsageError("simulate: an engine steps the observer as deployed: give"
                             " sample_time")
        return 0
    if m.time != "continuous":
        raise UsageError(f"{where}: a sample time applies to a continuous-time model (a"
                         " discrete-time model's step is its sample)")
    if isinstance(h, bool) or not isinstance(h, numbers.Real) \
            or not (math.isfinite(float(h)) and float(h) > 0):
        raise UsageError(f"{where}: the sample time must be a positive finite number, got {h!r}")
    scenario.size(m.time)  # t_end and dt given, consistent
    h, dt = float(h), float(scenario.dt)
    ratio = h / dt
    steps = int(round(ratio))
    if steps < 1 or abs(ratio - steps) > 1e-9 * ratio:
        raise UsageError(f"{where}: the sample time {h:g} is not a whole multiple of the"
                         f" scenario's dt = {dt:g} (h / dt = {ratio:.6g})")
    if h > float(scenario.t_end) * (1 + 1e-12):
        raise UsageError(f"{where}: the sample time {h:g} is longer than 't_end' ="
                         f" {scenario.t_end:g}")
    if observer is not None:
        if scenario.observer_parameters:
            raise UsageError(f"{where}: 'observer_parameters' does not apply with a sample time"
                             " (the deployed observer runs with its own parameters)")
        check_band_step(m, observer, h, where=where)
    return steps


def hold_ranges(model: PlantModel, names, U: np.ndarray, steps: int, single: bool) -> dict:
    """What a sampled run's disturbances and noise did between the samples: name → (min,
    max) over each sample's hold (grid points k·steps … (k + 1)·steps − 1 of ``U``,
    signals × runs × grid points, in the order of ``names``), each (R, n), or (n,) when
    ``single``."""
    which = set(model.disturbances) | set(model.noise)
    idx = np.arange(0, U.shape[-1], steps)
    out = {}
    for j, s in enumerate(names):
        if s in which:
            lo, hi = (np.minimum.reduceat(U[j], idx, axis=-1),
                      np.maximum.reduceat(U[j], idx, axis=-1))
            out[str(s)] = (lo[0], hi[0]) if single else (lo, hi)
    return out
