"""Thresholds on simulated ensembles: the guaranteed threshold over
1,000 runs × 2,000 steps of the electric drive, the step fault it detects, and the
Monte-Carlo quantile threshold."""
import dataclasses

import numpy as np
import pytest

from observer_cad import build_observer, design, load_model, simulate
from observer_cad.errors import UsageError
from observer_cad.residuals import ThresholdSpec, guaranteed_threshold
from observer_cad.simulation import apply_threshold, fault_free, quantile_threshold, scenario_from_dict

RANDOM = {"u": "0.2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
          "w1": {"uniform": [-0.01, 0.01]}, "w2": {"uniform": [-0.01, 0.01]}}


@pytest.fixture(scope="module")
def drive(models_dir):
    m = load_model(models_dir / "electric_drive.py")
    return m, build_observer(m, design(m, observer="diagnostic"))


def test_no_false_alarm_in_1000_runs_of_2000_steps(drive):
    """ρ and the noise uniformly random within their declared bounds (seeded), 4 × 250 runs ×
    2,000 steps: the fault-free residual never leaves the guaranteed band."""
    m, o = drive
    ot = guaranteed_threshold(m, o)
    outside = samples = 0
    for seed in range(4):
        sc = scenario_from_dict({"steps": 2000, "seed": seed, "signals": RANDOM})
        res = simulate(m, ot, sc, runs=250)
        r = res["r"]
        outside += int(np.sum((r < res["r_lower"]) | (r > res["r_upper"])))
        samples += r.size
    assert samples == 1000 * 2000
    assert outside == 0


def test_step_fault_is_detected_in_every_run(drive):
    """d = 0.2 from t = 1000 (seed 000's fault size): every one of 200 noisy runs leaves the band
    within a few steps, none before the fault."""
    m, o = drive
    ot = guaranteed_threshold(m, o)
    sig = dict(RANDOM, d="Piecewise((0, t < 1000), (0.2, True))")
    res = simulate(m, ot, scenario_from_dict({"steps": 2000, "seed": 9, "signals": sig}), runs=200)
    out = (res["r"] < res["r_lower"]) | (res["r"] > res["r_upper"])
    assert not out[:, :1000].any()
    first = np.argmax(out[:, 1000:], axis=1)
    assert out[:, 1000:].any(axis=1).all()
    # the step reaches the residual one step later (r = e, e⁺ = e/2 + 5 d); with the band
    # half-width ≤ 0.116 and Φ D d = 1, it is out at the first step it can be
    assert first.max() <= 2


def test_quantile_threshold_rate(drive):
    """τ is the (1 − rate) quantile of |r| on the fault-free ensemble: on that ensemble at most
    `rate` of the samples exceed it, and on fresh realisations the rate is close."""
    m, o = drive
    sc = scenario_from_dict({"steps": 500, "seed": 1, "signals": RANDOM})
    oq = quantile_threshold(m, o, sc, rate=0.01, runs=100)
    assert oq.threshold.kind == "quantile"
    tau = oq.threshold.values[0]
    res = simulate(m, oq, sc, runs=100)
    above = np.mean(np.abs(res["r"]) > tau)
    assert above <= 0.01 and above > 0.005
    fresh = simulate(m, oq, dataclasses.replace(sc, seed=77), runs=100)
    assert 0.005 < np.mean(np.abs(fresh["r"]) > tau) < 0.02
    # the guaranteed band is wider than any sampled quantile
    ot = guaranteed_threshold(m, o)
    resg = simulate(m, ot, sc, runs=5)
    assert np.min(resg["r_upper"][:, 50:]) > tau


def test_quantile_threshold_ignores_the_scenario_faults(drive):
    m, o = drive
    sc = scenario_from_dict({"steps": 300, "seed": 1,
                             "signals": dict(RANDOM, d="Piecewise((0, t < 100), (0.2, True))")})
    assert "d" not in fault_free(m, sc).signals
    a = quantile_threshold(m, o, sc, rate=0.05, runs=20).threshold.values
    b = quantile_threshold(m, o, fault_free(m, sc), rate=0.05, runs=20).threshold.values
    assert a == b


def test_quantile_refusals(drive):
    m, o = drive
    sc = scenario_from_dict({"steps": 100, "signals": RANDOM})
    with pytest.raises(UsageError, match="needs at least 10000 samples"):
        quantile_threshold(m, o, sc, rate=0.001, runs=10)
    with pytest.raises(UsageError, match=r"lie in \(0, 1\)"):
        quantile_threshold(m, o, sc, rate=1.5)
    with pytest.raises(UsageError, match="estimated on a scenario"):
        apply_threshold(m, o, ThresholdSpec("quantile", rate=0.01))


def test_threshold_spec_parsing():
    assert ThresholdSpec.parse("guaranteed").kind == "guaranteed"
    assert ThresholdSpec.parse("quantile:1e-3").rate == pytest.approx(1e-3)
    assert ThresholdSpec.parse("0.05").value == pytest.approx(0.05)
    for bad in ("quantile:2", "quantile:x", "-1", "inf", "__import__('os')", "guaranteed:1"):
        with pytest.raises(UsageError, match="--threshold"):
            ThresholdSpec.parse(bad)
