"""Monte-Carlo quantile thresholds: a constant band abs(r_I) ≤ τ_I for a target false-alarm rate.

The scenario is run fault-free (every fault signal removed) over ``runs`` seeded realisations
of its random signals; τ_I is the (1 − rate) quantile of abs(r_I) over every sample of every run
(the ``higher`` order statistic, so that at most ``rate`` of the simulated samples lie above
it). ``rate`` is a per-residual, per-sample false-alarm rate *on the simulated ensemble*: unlike
the guaranteed threshold (:func:`observer_cad.observers.guaranteed_threshold`) it promises
nothing outside it.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import UsageError
from ..model import PlantModel
from ..observers import Observer
from ..residuals import ThresholdSpec, constant_threshold, guaranteed_threshold, residual_names
from ._simulate import Scenario, simulate

__all__ = ["quantile_threshold", "fault_free", "apply_threshold"]


def fault_free(model: PlantModel, scenario: Scenario) -> Scenario:
    """The scenario with every fault signal removed (faults are zero), and without its
    fault cases (their signal overrides, faults removed, are not applied either: the base
    signals)."""
    faults = {f.name for f in model.faults}
    return dataclasses.replace(scenario, signals={k: v for k, v in scenario.signals.items()
                                                  if k not in faults}, cases=None)


def quantile_threshold(model: PlantModel, observer: Observer, scenario: Scenario, *,
                       rate: float, runs: int = 200, seed: int | None = None) -> Observer:
    """The observer with constant bands from the (1 − ``rate``) quantile of abs(r_I) over
    ``runs`` fault-free realisations of ``scenario`` (seeded by ``seed``, default the
    scenario's). Needs runs × samples ≥ 10 / rate."""
    try:
        rate = float(rate)
    except (TypeError, ValueError):
        raise UsageError(f"a false-alarm rate must be a number, got {rate!r}") from None
    if not (0 < rate < 1):
        raise UsageError(f"a false-alarm rate must lie in (0, 1), got {rate:g}")
    if int(runs) < 1:
        raise UsageError(f"runs must be at least 1, got {runs}")
    residuals = residual_names(observer)
    sc = fault_free(model, scenario)
    if seed is not None:
        sc = dataclasses.replace(sc, seed=int(seed))
    samples = int(runs) * sc.size(model.time)
    if samples * rate < 10:
        raise UsageError(f"a quantile for the rate {rate:g} needs at least {int(np.ceil(10 / rate))}"
                         f" samples (runs × time points); this ensemble has {samples}: raise the"
                         " runs or the scenario's length")
    res = simulate(model, observer, sc, runs=int(runs))
    taus = []
    for r in residuals:
        v = np.abs(np.asarray(res[r], dtype=float))
        v = v[np.isfinite(v)]
        tau = float(np.quantile(v, 1 - rate, method="higher"))
        if not tau > 0:
            tau = float(np.finfo(float).eps) * 1e3  # an exactly zero fault-free residual
        taus.append(tau)
    return constant_threshold(
        observer, taus, kind="quantile",
        description=f"(1 − {rate:g}) quantile of |r| over {runs} fault-free runs of"
                    f" {sc.source or 'the scenario'} (seed {sc.seed})")


def apply_threshold(model: PlantModel, observer: Observer, spec: ThresholdSpec, *,
                    scenario: Scenario | None = None, initial_error=0, runs: int = 200,
                    seed: int | None = None) -> Observer:
    """The observer with the bands ``spec`` asks for (a quantile needs the ``scenario`` whose
    fault-free realisations it is estimated on; ``seed`` their seed, default the
    scenario's)."""
    if not isinstance(spec, ThresholdSpec):
        spec = ThresholdSpec.parse(spec)
    if spec.kind == "guaranteed":
        return guaranteed_threshold(model, observer, initial_error=initial_error)
    if spec.kind == "quantile":
        if scenario is None:
            raise UsageError("a quantile threshold is estimated on a scenario: give one")
        return quantile_threshold(model, observer, scenario, rate=spec.rate, runs=runs, seed=seed)
    return constant_threshold(observer, spec.value)
