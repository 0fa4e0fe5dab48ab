"""Monte-Carlo evaluation of a decision rule over fault cases: :func:`evaluate_ensemble`
runs, for the fault-free case and each :class:`~observer_cad.residuals.FaultCase` (one
fault, a constant size from an onset time, the other faults zero), ``runs`` seeded
realisations of the scenario's uniform random signals with the reference simulator
(vectorised over runs, in chunks below the memory limit) and adds up their
:class:`~observer_cad.residuals.Metrics` — detection delay, false alarms, missed
detections, isolation, as defined where :func:`~observer_cad.residuals.evaluate_result`
computes them from one result's columns.
"""
from __future__ import annotations

import dataclasses
import numbers
from typing import Callable, Mapping

from ..errors import UsageError
from ..model import PlantModel
from ..residuals import NO_FAULT, DecisionRule, FaultCase, Metrics, decide, evaluate_result
from ..observers import Observer
from ._simulate import Scenario, memory_limit, simulate

__all__ = ["evaluate_ensemble"]


def _cases(model: PlantModel, cases) -> tuple:
    if isinstance(cases, Mapping):
        items = []
        for f, v in cases.items():
            if isinstance(v, FaultCase):
                items.append(v)
                continue
            try:
                size, onset = v
            except (TypeError, ValueError):
                raise UsageError(f"fault case {f}: give (size, onset), got {v!r}") from None
            items.append(FaultCase(f, size, onset))
    else:
        items = list(cases)
    names = [s.name for s in model.faults]
    for c in items:
        if not isinstance(c, FaultCase):
            raise UsageError(f"evaluate_ensemble: a case is a FaultCase, not {c!r}")
        if c.fault not in names:
            raise UsageError(f"fault case: '{c.fault}' is not a fault of {model.name}"
                             f" (faults: {', '.join(names) or 'none'})")
    return tuple(items)


def _case_scenario(scenario: Scenario, faults, case: FaultCase | None) -> Scenario:
    """The scenario with the fault signals of ``case`` (the others zero; its own cases
    dropped)."""
    signals = {**scenario.signals, **{f: 0 for f in faults}}
    if case is not None:
        signals[case.fault] = {"piecewise": [[0, f"t < {case.onset!r}"], [case.size, True]]}
    return dataclasses.replace(scenario, signals=signals, cases=None)


def _chunk_runs(model: PlantModel, observer: Observer, scenario: Scenario, runs: int) -> int:
    """Runs per simulate() call: a quarter of the memory limit (the simulator's arrays
    plus the decisions' temporaries)."""
    n = scenario.size(model.time)
    nsig = len(model.inputs) + len(model.faults) + len(model.disturbances) + len(model.noise)
    ncols = (1 + 2 * len(model.states) + len(model.outputs) + 2 * nsig
             + 2 * len(observer.states) + len(observer.outputs))
    per_run = n * ncols * 8
    return max(1, min(runs, memory_limit() // (4 * per_run)))


def evaluate_ensemble(model: PlantModel, observer: Observer, scenario: Scenario,
                      rule: DecisionRule, *, cases, runs: int, seed: int = 0,
                      add_columns: Callable | None = None) -> Metrics:
    """Monte-Carlo metrics of ``rule`` on ``observer`` over the fault-free case and
    ``cases``.

    ``cases``: :class:`FaultCase` values, or a mapping fault name → (size, onset). Each
    case (and the fault-free one) runs the scenario with that fault as a step (the other
    faults zero; the scenario's own fault signals are replaced) over ``runs`` seeded
    realisations of its random signals and per-run values, seeded by ``seed``
    (:func:`simulate` with ``runs=R, first_run=…`` in chunks below the memory limit: run k
    is the same whatever the chunks, and the same for every case — common random
    numbers). ``add_columns``: optional callable
    result → mapping of further columns (e.g. thresholds ``r_lower``/``r_upper`` when
    the observer does not output them), merged before :func:`decide`.
    """
    if not isinstance(rule, DecisionRule):
        raise UsageError(f"evaluate_ensemble needs a DecisionRule, not {type(rule).__name__}")
    if isinstance(runs, bool) or not isinstance(runs, numbers.Integral) or runs < 1:
        raise UsageError(f"evaluate_ensemble: runs must be a whole number ≥ 1, got {runs!r}")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise UsageError(f"evaluate_ensemble: seed must be a whole number ≥ 0, got {seed!r}")
    items = _cases(model, cases)
    faults = tuple(s.name for s in model.faults)
    chunk = _chunk_runs(model, observer, scenario, int(runs))
    total = None
    base = dataclasses.replace(scenario, seed=int(seed))
    for case in (None,) + items:
        sc = _case_scenario(base, faults, case)
        done = 0
        while done < runs:
            r = min(chunk, runs - done)
            res = simulate(model, observer, sc, runs=r, first_run=done, samples=int(runs))
            columns = dict(res.columns)
            if add_columns is not None:
                columns.update(add_columns(res))
            view = dataclasses.replace(res, columns=columns)
            m = evaluate_result(view, decide(rule, columns), faults=faults,
                                case=NO_FAULT if case is None else case.name)
            total = m if total is None else total + m
            done += r
    return total
