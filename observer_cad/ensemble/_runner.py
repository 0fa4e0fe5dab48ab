"""Ensembles: thousands to millions of runs of plant + observer, summarised as they finish.

An ensemble runs ``runs`` samples of every fault case of a scenario (``"cases"``; one case
without them): run ``i = c·runs + k`` is sample k of case c, and what is random about it —
the true plant's parameters, the observer's free parameters, the initial states, every
random signal sample — is drawn from (seed, k) alone (:mod:`observer_cad.simulation`
sampling). The runs are cut into chunks; a worker (a thread, a process, a Dask worker)
simulates a chunk in one compiled call (:class:`~observer_cad.codegen.TrajectoryEngine`,
the signals generated in C) and reduces it to per-run summaries
(:func:`~observer_cad.simulation.summarise`) before the next: memory is O(runs ×
summaries), never O(runs × steps). The summaries, and so the statistics, do not depend on
the chunk size, the backend or the number of workers: a run is the same computation
wherever it happens (tested bit for bit).

A scenario with ``"sample_time"`` runs as :func:`~observer_cad.simulation.simulate` runs it
(the plant in numpy, the observer stepped by the monitor's engine — compiled C under
``engine="compiled"``), in chunks on threads.

The worst runs are replayed afterwards (:func:`replay`: the same run alone, bit-identical
summary — checked) to keep their full trajectories.
"""
from __future__ import annotations

import dataclasses
import math
import threading
import time
from typing import Callable

import numpy as np

from ..errors import UsageError
from ..model import PlantModel
from ..residuals import DecisionRule
from ..observers import Observer, output_symbols
from ..simulation import (MEMORY_LIMIT_ENV, DrawPlan, Monitors, RunSummaries, Scenario,
                          check_memory, memory_limit, monitors, signal_program, simulate,
                          summarise)
from ._backends import Backend, Interrupted, map_chunks
from ._statistics import EnsembleStatistics

__all__ = ["Chunk", "EnsembleResult", "run_ensemble", "replay", "replay_worst", "ReplayError", "ENGINES",
           "default_chunk", "CHUNK_BYTES", "default_worst_field", "held_runs"]

ENGINES = ("compiled", "reference")
#: the default chunk keeps a worker's trajectory buffers near this size (they are reused;
#: measured on the three-tank interval observer: chunks of 8, 29, 64, 128 runs gave 368,
#: 308, 290, 284 µs per run and core — larger chunks amortise the per-chunk Python work)
CHUNK_BYTES = 32 * 1024 ** 2


class ReplayError(RuntimeError):
    """A run replayed alone did not reproduce its summary: a bug, never a result (the
    command line reports it as an internal error, exit status 1)."""


@dataclasses.dataclass(frozen=True)
class Chunk:
    """Samples ``first … first + count − 1`` of case ``case`` (an index into the cases).
    The worker draws their parameters and initial states itself (from (seed, sample):
    the same values wherever it runs)."""

    case: int
    first: int
    count: int

    def samples(self) -> np.ndarray:
        return np.arange(self.first, self.first + self.count)


@dataclasses.dataclass(frozen=True, eq=False)
class _Layout:
    """Column names of the joint arrays (S, Y, O, V) and the observer outputs' delays."""

    states: tuple
    outputs: tuple
    inputs: tuple
    observer: tuple
    delays: tuple


def _layout(model: PlantModel, observer: Observer | None) -> _Layout:
    return _Layout(tuple(s.name for s in model.states),
                   tuple(str(y) for y in output_symbols(len(model.outputs))),
                   tuple(s.name for s in list(model.inputs) + list(model.faults)
                         + list(model.disturbances) + list(model.noise)),
                   tuple(observer.output_names) if observer is not None else (),
                   tuple(int(observer.delays.get(n, 0)) for n in observer.output_names)
                   if observer is not None else ())


def _columns(layout: _Layout, S, Y, O, V) -> dict:
    """The columns of a chunk, (R, N) views of the batch's (R, k, N) arrays (contiguous
    rows; the batch stores delayed outputs shifted already)."""
    cols = {}
    for j, name in enumerate(layout.states):
        cols[name] = S[:, j, :]
    for j, name in enumerate(layout.outputs):
        cols[name] = Y[:, j, :]
    for j, name in enumerate(layout.inputs):
        cols[name] = V[:, j, :]
    for j, name in enumerate(layout.observer):
        cols[name] = O[:, j, :]
    return cols


@dataclasses.dataclass(frozen=True, eq=False)
class _Payload:
    """What every worker needs once (the library travels as its spec)."""

    engine: object
    t: np.ndarray
    programs: tuple
    plan: DrawPlan
    runs: int
    seed: int
    monitors: Monitors
    layout: _Layout
    intervals: tuple = ()   # (signals, (nI, 4) spec, start): summarised in the loop


_BUFFERS = threading.local()


def _buffers(R, N, engine, nx):
    """Per-thread trajectory buffers (R, k, N), reused from chunk to chunk (allocating
    and page-faulting megabytes per chunk costs as much as simulating it); S holds the
    plant's nx states (the observer's are not columns)."""
    shape = (R, N, nx, engine.ny, engine.no, engine.nv)
    got = getattr(_BUFFERS, "arrays", None)
    if got is None or got[0] != shape:
        got = (shape, np.empty((R, nx, N)), np.empty((R, engine.ny, N)),
               np.empty((R, engine.no, N)), np.empty((R, engine.nv, N)))
        _BUFFERS.arrays = got
    return got[1:]


def _compiled_chunk(payload: _Payload, chunk: Chunk) -> RunSummaries:
    """One chunk on the compiled engine: draw, simulate, reduce to per-run summaries."""
    N = payload.t.size
    d = payload.plan.draw(chunk.samples(), total=payload.runs)
    S0 = np.concatenate([d.x0, d.xi0], axis=1)
    S, Y, O, V = _buffers(chunk.count, N, payload.engine, len(payload.layout.states))
    finite = np.zeros(chunk.count, dtype=bool)
    given = ivs = None
    if payload.intervals:
        signals, spec, start = payload.intervals
        out = np.empty((chunk.count, len(signals), 4))
        ivs = (spec, start, payload.monitors.tolerance, out)
    mon = payload.monitors
    # when the loop's summaries are all there is to compute, the trajectories are not
    # stored (a run that is not finite is simulated again, stored, and summarised from
    # its columns: the same numbers, found exactly)
    store = not (ivs is not None and not mon.estimates and not mon.residuals
                 and mon.rule is None and len(payload.intervals[0]) == len(mon.intervals))
    run = (payload.t, payload.programs[chunk.case], payload.seed, d.samples, d.P, S0)
    buffers = dict(S=S, Y=Y, O=O, V=V, delays=payload.layout.delays, finite=finite,
                   intervals=ivs)
    payload.engine.run_batch(*run, store=store, **buffers)
    if not store and not finite.all():
        payload.engine.run_batch(*run, **buffers)
    if ivs is not None:
        given = {sig: tuple(out[:, m, q] for q in range(4)) for m, sig in enumerate(signals)}
    return summarise(payload.monitors, _columns(payload.layout, S, Y, O, V), payload.t,
                     finite=finite, intervals=given)


def _loop_intervals(mon: Monitors, layout: _Layout, t: np.ndarray) -> tuple:
    """The intervals the compiled loop can summarise itself — truth a state or a signal
    column, bounds not delayed — as (signals, (nI, 4) spec, first sample ≥ settle); ()
    when none (the others are summarised from the stored columns)."""
    rows, signals = [], []
    for iv in mon.intervals:
        col = iv.truth.column
        if col is None or mon.delays.get(iv.lower, 0) or mon.delays.get(iv.upper, 0):
            continue
        if col in layout.states:
            kind, idx = 0, layout.states.index(col)
        elif col in layout.inputs:
            kind, idx = 1, layout.inputs.index(col)
        else:
            continue
        rows.append((kind, idx, layout.observer.index(iv.lower), layout.observer.index(iv.upper)))
        signals.append(iv.signal)
    start = int(np.searchsorted(t, mon.settle, side="left"))
    if not rows or start >= t.size:
        return ()
    return tuple(signals), np.asarray(rows, dtype=np.intc), start


@dataclasses.dataclass(frozen=True, eq=False)
class _ReferencePayload:
    model: PlantModel
    observer: Observer
    scenario: Scenario
    cases: tuple
    runs: int
    monitors: Monitors
    step: object = None     # a sampled scenario: the monitor's engine


def _reference_chunk(payload: _ReferencePayload, chunk: Chunk) -> RunSummaries:
    res = simulate(payload.model, payload.observer, payload.scenario, runs=chunk.count,
                   first_run=chunk.first, case=payload.cases[chunk.case],
                   samples=payload.runs, keep_nonfinite=True,
                   **({} if payload.step is None else {"engine": payload.step}))
    t = np.asarray(res["t"])[0]
    return summarise(payload.monitors, res.columns, t)


@dataclasses.dataclass(frozen=True, eq=False)
class EnsembleResult:
    """What an ensemble produced.

    ``statistics`` (:class:`~observer_cad.ensemble.Statistics`) over the finished runs;
    ``accumulator`` the per-run summaries (``rows()``, ``worst()``); ``runs`` samples per
    case, ``cases`` the case names (run i is sample i mod runs of case i div runs);
    ``completed`` runs finished (all of them unless ``interrupted``); ``seconds`` wall
    clock of the simulation; ``engine``, ``backend``, ``chunk`` how it ran;
    ``kept``: replayed worst runs, tuples (run, case, sample, SimulationResult)."""

    statistics: object
    accumulator: EnsembleStatistics
    runs: int
    cases: tuple
    completed: int
    interrupted: bool
    seconds: float
    engine: str
    backend: Backend
    chunk: int
    seed: int
    sampling: str
    kept: tuple = ()

    @property
    def total(self) -> int:
        return self.runs * len(self.cases)

    def locate(self, run: int) -> tuple:
        """(case name, sample index) of the global run index."""
        c, k = divmod(int(run), self.runs)
        return self.cases[c], k


def _columns_per_run(model: PlantModel, observer: Observer | None) -> int:
    """Time series a worker keeps per run of a chunk (states, outputs, signals, observer
    states and outputs) plus its temporaries (delayed outputs, summaries)."""
    cols = (2 * len(model.states) + len(model.outputs) + len(model.inputs) + len(model.faults)
            + len(model.disturbances) + len(model.noise))
    if observer is not None:
        cols += len(observer.states) + len(observer.outputs)
    return cols


def default_chunk(model: PlantModel, observer: Observer | None, scenario: Scenario) -> int:
    """Runs per chunk: trajectory buffers of about :data:`CHUNK_BYTES` (1 … 256 runs)."""
    n = scenario.size(model.time)
    cols = _columns_per_run(model, observer)
    return int(max(1, min(256, CHUNK_BYTES // max(1, n * cols * 8))))


def default_worst_field(mon: Monitors) -> str:
    """The field that ranks runs by default: an interval's smallest slack, else an
    estimate's largest error, else a residual's samples out of its band (or its largest
    magnitude), else the first field."""
    names = [f.name for f in mon.fields]
    for suffix in (".min_slack", ".max_error", ".exceedances", "alarm.samples", ".max_abs"):
        for n in names:
            if n.endswith(suffix):
                return n
    return names[0]


def _whole(what, v, low):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
        raise UsageError(f"ensemble: {what} must be a whole number ≥ {low}, got {v!r}")
    return int(v)



#: bytes kept per run and summary field (the value, and the run's share of its index)
_SUMMARY_BYTES = 16


def held_runs(total: int, chunk: int, workers: int) -> int:
    """Runs whose trajectories are in memory at once: one chunk per worker, never more
    than the runs there are (``--runs 20 --workers 1000`` holds 20, not 1000 chunks)."""
    return max(1, min(total, chunk * workers))


def _check_summary_memory(total: int, fields: int, scenario) -> None:
    """Refuse an ensemble whose per-run summaries (kept for summary.csv and the
    statistics: runs × fields values) would exceed :func:`memory_limit` — before any run,
    not after the machine runs out of memory (``--runs 999999999999`` grew to 3 GB in
    30 s, found by an audit)."""
    need = int(total) * (int(fields) + 2) * _SUMMARY_BYTES
    limit = memory_limit()
    if need > limit:
        raise UsageError(f"{scenario.source or 'ensemble'}: {total:,} runs × {fields} summary"
                         f" fields would keep about {need / 2**30:,.1f} GiB, above the limit of"
                         f" {limit / 2**30:,.1f} GiB; use fewer runs, or raise the limit with"
                         f" {MEMORY_LIMIT_ENV}")

def run_ensemble(model: PlantModel, observer: Observer, scenario: Scenario, *, runs: int,
                 engine: str = "compiled", backend: Backend | None = None,
                 chunk: int | None = None, settle: float = 0.0,
                 rule: DecisionRule | None = None, keep: int = 0, worst_by: str | None = None,
                 progress: Callable[[int], None] | None = None, simulator=None
                 ) -> EnsembleResult:
    """Run ``runs`` samples of every case of ``scenario`` and summarise each run.

    ``engine``: ``"compiled"`` (default; one C library for every sample, loaded by every
    worker from the content-hashed cache) or ``"reference"`` (the numpy simulator, for
    validation: serial and thread backends only). ``backend``: a
    :class:`~observer_cad.ensemble.Backend` (default: threads on every core).
    ``chunk``: runs per chunk (default :func:`default_chunk`). ``settle``: summaries
    ignore samples before this time. ``rule``: a decision rule for alarm summaries
    (thresholds must be columns). ``keep``: replay the ``keep`` worst runs by
    ``worst_by`` (default :func:`default_worst_field`) and keep their trajectories.
    ``progress(n)``: called with the number of runs of every finished chunk (in this
    thread).
    ``simulator``: a :class:`~observer_cad.codegen.CompiledSimulator` already built.

    A Ctrl-C stops the ensemble: the result then holds the finished runs
    (``interrupted=True``), in run order, and the statistics over them.
    """
    runs = _whole("runs", runs, 1)
    keep = _whole("keep", keep, 0)
    if engine not in ENGINES:
        raise UsageError(f"ensemble: engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    backend = backend or Backend("threads")
    if not isinstance(backend, Backend):
        raise UsageError(f"ensemble: backend must be a Backend, got {type(backend).__name__}")
    if not (isinstance(settle, (int, float)) and math.isfinite(settle) and settle >= 0):
        raise UsageError(f"ensemble: settle must be a finite time ≥ 0, got {settle!r}")
    chunk = default_chunk(model, observer, scenario) if chunk is None else _whole("chunk", chunk, 1)
    cases = scenario.case_names
    t = scenario.grid(model.time)
    mon = monitors(model, observer, settle=float(settle), rule=rule)
    field = worst_by or default_worst_field(mon)
    mon.field(field)  # an unknown field is refused before anything runs
    _check_summary_memory(runs * len(cases), len(mon.fields), scenario)
    # the trajectory buffers every worker holds (one chunk each, of at most the runs
    # there are), like a simulation's
    ncols = _columns_per_run(model, observer)
    check_memory(scenario, model.time, runs=held_runs(runs * len(cases), min(chunk, runs),
                                                      1 if backend.kind == "serial" else
                                                      backend.workers), columns=ncols)
    sim = None
    if engine == "compiled" and scenario.sample_time is None:
        from ..codegen import CompiledSimulator
        sim = simulator if simulator is not None else CompiledSimulator(model, observer)
        programs = tuple(signal_program(model, scenario, t, case=c) for c in cases)
        layout = _layout(model, observer)
        payload = _Payload(sim.engine() if backend.kind in ("processes", "dask") else
                           sim.local_engine(), t, programs, sim.plan(scenario), runs,
                           int(scenario.seed), mon, layout, _loop_intervals(mon, layout, t))
        task = _compiled_chunk
        desc = "compiled C" + (" (cache hit)" if sim.cached else "")
    else:
        if backend.kind not in ("serial", "threads"):
            what = "the reference engine runs" if scenario.sample_time is None else \
                "a sampled scenario (\"sample_time\") runs"
            raise UsageError(f"ensemble: {what} in this process only (backend serial or threads)")
        for c in cases:  # check every case before starting
            signal_program(model, scenario, t[:1], case=c)
        step, desc = _monitor_engine(model, observer, scenario, engine)
        payload = _ReferencePayload(model, observer, scenario, cases, runs, mon, step)
        task = _reference_chunk
    acc = EnsembleStatistics(mon)
    done = 0
    interrupted = False
    chunks = [Chunk(c, first, min(chunk, runs - first))
              for c in range(len(cases)) for first in range(0, runs, chunk)]

    def take(ch: Chunk, summaries: RunSummaries):
        nonlocal done
        acc.add(ch.case * runs + ch.samples(), cases[ch.case], summaries)
        done += ch.count
        if progress is not None:
            progress(ch.count)

    t0 = time.perf_counter()
    try:
        for ch, summaries in map_chunks(task, payload, chunks, backend=backend):
            take(ch, summaries)
    except Interrupted as exc:
        interrupted = True
        for ch, summaries in exc.done:
            take(ch, summaries)
    seconds = time.perf_counter() - t0
    result = EnsembleResult(acc.result(), acc, runs, cases, done, interrupted, seconds, desc,
                            backend, chunk, int(scenario.seed), scenario.sampling)
    if keep and not interrupted and done:
        result = dataclasses.replace(result, kept=replay_worst(
            result, model, observer, scenario, keep, worst_by=field, engine=engine,
            simulator=sim if engine == "compiled" else None, monitors_=mon,
            monitor_engine=payload.step if sim is None else None))
    return result


def _monitor_engine(model: PlantModel, observer: Observer, scenario: Scenario,
                    engine: str) -> tuple:
    """(the monitor's engine a sampled scenario steps the observer by — None otherwise —,
    the description of how the runs are simulated)."""
    if scenario.sample_time is None:
        return None, "reference simulator (numpy)"
    from ..simulation import ReferenceMonitorEngine, sample_steps
    sample_steps(model, observer, scenario, scenario.sample_time)
    how = f"sampled at h = {scenario.sample_time:g}: the plant by the reference simulator"
    if engine == "compiled" and observer is not None:
        from ..codegen import CodegenError, CompiledMonitorEngine
        try:
            step = CompiledMonitorEngine(observer)
        except CodegenError as exc:  # no C compiler: the same step in Python
            how += f" (not compiled: {str(exc).splitlines()[0]})"
        else:
            return step, how + ", the observer by the monitor's compiled C step" + (
                " (cache hit)" if step.cached else "")
    step = ReferenceMonitorEngine(observer) if observer is not None else None
    return step, how + ", the observer by the monitor's step (Python)"


def replay_worst(result: EnsembleResult, model: PlantModel, observer: Observer,
                 scenario: Scenario, k: int, *, worst_by: str | None = None,
                 engine: str = "compiled", simulator=None, monitors_: Monitors | None = None,
                 settle: float = 0.0, rule: DecisionRule | None = None,
                 monitor_engine=None) -> tuple:
    """The ``k`` worst runs of ``result`` by ``worst_by`` (default
    :func:`default_worst_field`), replayed: tuples (run, case, sample, SimulationResult),
    each checked to reproduce its recorded summary bit for bit (:class:`ReplayError`).
    Where every run has the same value of the field, these are the first runs (ties go
    to the lower index); ``result.statistics`` then names no worst run."""
    mon = monitors_ or monitors(model, observer, settle=settle, rule=rule)
    field = worst_by or default_worst_field(mon)
    mon.field(field)
    kept = []
    for run in result.accumulator.worst(field, min(int(k), result.completed)):
        case, sample = result.locate(run)
        res = replay(model, observer, scenario, run, runs=result.runs, engine=engine,
                     simulator=simulator, monitors_=mon, expect=result.accumulator,
                     monitor_engine=monitor_engine)
        kept.append((int(run), case, sample, res))
    return tuple(kept)


def replay(model: PlantModel, observer: Observer, scenario: Scenario, run: int, *, runs: int,
           engine: str = "compiled", simulator=None, monitors_: Monitors | None = None,
           expect: EnsembleStatistics | None = None, settle: float = 0.0,
           rule: DecisionRule | None = None, monitor_engine=None):
    """The full trajectories of run ``run`` of an ensemble of ``runs`` samples per case
    (a :class:`~observer_cad.simulation.SimulationResult` of one run: (N,) columns). With ``expect``
    (the ensemble's accumulator), the replayed run's summary must equal the recorded one
    bit for bit — :class:`ReplayError` otherwise."""
    cases = scenario.case_names
    c, k = divmod(_whole("run", run, 0), runs)
    if c >= len(cases):
        raise UsageError(f"ensemble: run {run} does not exist ({runs} runs × {len(cases)} cases)")
    kw = dict(first_run=k, case=cases[c], samples=runs, keep_nonfinite=True)
    if scenario.sample_time is not None:  # the plant in numpy, the observer by the monitor's step
        if monitor_engine is None:
            monitor_engine, _ = _monitor_engine(model, observer, scenario, engine)
        res = simulate(model, observer, scenario, engine=monitor_engine, **kw)
    elif engine == "compiled":
        from ..codegen import CompiledSimulator
        sim = simulator if simulator is not None else CompiledSimulator(model, observer)
        res = sim.simulate(scenario, threads=1, **kw)
    else:
        res = simulate(model, observer, scenario, **kw)
    if expect is not None:
        mon = monitors_ or monitors(model, observer, settle=settle, rule=rule)
        got = summarise(mon, res.columns, np.asarray(res["t"]))
        cols = expect.columns()
        at = np.flatnonzero(cols["run"] == int(run))
        if not at.size:
            raise UsageError(f"replay: run {run} is not in the ensemble's summaries")
        for f in got.fields:
            a, b = float(got.values[f.name][0]), float(cols[f.name][at[0]])
            if not (a == b or (math.isnan(a) and math.isnan(b))):
                raise ReplayError(f"replay of run {run}: {f.name} = {a!r}, the ensemble recorded"
                                  f" {b!r}")
    return res
