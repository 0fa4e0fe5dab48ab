"""Metrics of decisions (observer_cad.residuals.evaluate_result and
observer_cad.simulation.evaluate_ensemble): onset, true label, detection delay, false
alarms, missed detections, confusion matrix, on a crafted result checked by hand; the
Monte-Carlo driver on the isolation bank."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.residuals import (NO_FAULT, UNKNOWN_PATTERN, DecisionRule, FaultCase, Metrics,
                                    decide, decision_rule, evaluate_result, fault_onsets,
                                    true_labels)
from observer_cad.observers import build_observer
from observer_cad.simulation import SimulationResult, evaluate_ensemble, scenario_from_dict

ROOT = Path(__file__).resolve().parents[2]
GOS = DecisionRule(residuals=("r1", "r2", "r3"), faults=("f1", "f2", "f3"),
                   structure=((0, 1, 1), (1, 0, 1), (1, 1, 0)))


def crafted():
    """4 runs × 8 samples, dt = 0.5: run 0 fault-free with a false alarm at k = 2;
    run 1 f2 from k = 3, alarms from k = 5 (delay 1.0), ends diagnosed f2, plus a false
    alarm at k = 1; run 2 f1 from k = 4, never alarmed (missed); run 3 f3 from k = 2,
    alarm pattern at the end only r1 out (unknown pattern), last sample NaN (not
    available: the end diagnosis is taken at k = 6)."""
    R, N = 4, 8
    t = np.tile(np.arange(N) * 0.5, (R, 1))
    f = {n: np.zeros((R, N)) for n in ("f1", "f2", "f3")}
    f["f2"][1, 3:] = 0.3
    f["f1"][2, 4:] = -0.1
    f["f3"][3, 2:] = 0.2
    out = np.zeros((3, R, N))       # which residual is out
    out[:, 0, 2] = [1, 0, 0]
    out[:, 1, 1] = [0, 1, 0]
    out[:, 1, 5:] = np.array([1, 0, 1])[:, None]   # column of f2: (1, 0, 1)
    out[:, 3, 4:] = np.array([1, 0, 0])[:, None]
    cols = {"t": t, **f}
    for i in range(3):
        r = 2.0 * out[i]
        r[3, -1] = np.nan if i == 0 else r[3, -1]
        cols[f"r{i + 1}"] = r
        cols[f"r{i + 1}_lower"] = np.full((R, N), -1.0)
        cols[f"r{i + 1}_upper"] = np.full((R, N), 1.0)
    cols["r2"][3, -1] = np.nan
    cols["r3"][3, -1] = np.nan
    return SimulationResult(cols, tuple(cols), time="continuous")


def test_onsets_and_labels():
    res = crafted()
    assert fault_onsets(res, GOS.faults).tolist() == [-1, 3, 4, 2]
    assert true_labels(res, GOS.faults) == (NO_FAULT, "f2", "f1", "f3")


def test_metrics_of_a_crafted_result():
    res = crafted()
    m = evaluate_result(res, decide(GOS, res))
    assert m.runs == 4 and m.faulty_runs == 3
    o = m.runs_
    assert [x.delay for x in o] == [None, 1.0, None, 0.0 + 1.0]   # run 3: onset t=1, alarm t=2
    assert [x.false_alarm_samples for x in o] == [1, 1, 0, 0]
    assert [x.fault_free_samples for x in o] == [8, 3, 4, 2]
    assert m.false_alarm_samples == 2
    assert m.false_alarm_rate == pytest.approx(2 / 17)
    assert m.false_alarm_runs == 2 and m.false_alarm_run_rate == 0.5
    assert m.missed_detections == 1 and m.missed_detection_rate == pytest.approx(1 / 3)
    assert [x.diagnosis for x in o] == [NO_FAULT, "f2", NO_FAULT, UNKNOWN_PATTERN]
    assert m.isolation_accuracy == 0.5
    assert m.labels[:4] == (NO_FAULT, "f1", "f2", "f3")
    assert m.diagnoses == (NO_FAULT, "f1", "f2", "f3", UNKNOWN_PATTERN)
    C = dict(zip(m.labels, m.confusion))
    assert C[NO_FAULT] == (1, 0, 0, 0, 0)
    assert C["f1"] == (1, 0, 0, 0, 0)
    assert C["f2"] == (0, 0, 1, 0, 0)
    assert C["f3"] == (0, 0, 0, 0, 1)
    assert m.delay_stats() == (1.0, 1.0)
    md = m.to_markdown()
    assert "| f3 | 0 | 0 | 0 | 0 | 1 |" in md and "unknown pattern" in md
    assert "1 s" in m.to_text()


def test_metrics_combine_and_split_by_case():
    res = crafted()
    d = decide(GOS, res)
    a = evaluate_result(res, d, case="A")
    b = evaluate_result(res, d, case="B")
    both = a + b
    assert both.runs == 8 and both.cases() == ("A", "B")
    assert both.case("B").false_alarm_samples == 2
    assert both.confusion[0][0] == 2 * a.confusion[0][0]
    with pytest.raises(UsageError, match="no case 'C'"):
        both.case("C")


def test_single_run_result():
    t = np.arange(6.0)
    cols = {"t": t, "d": np.array([0, 0, 0.2, 0.2, 0.2, 0.2]),
            "r": np.array([0, 0, 0, 5, 5, 5.0]), "r_lower": -np.ones(6), "r_upper": np.ones(6)}
    res = SimulationResult(cols, tuple(cols), time="discrete")
    rule = DecisionRule(("r",), ("d",), ((1,),), persistence=2)
    m = evaluate_result(res, decide(rule, res))
    (o,) = m.runs_
    assert o.onset == 2.0 and o.delay == 2.0 and o.diagnosis == "d"
    assert m.time_unit == "steps"


def test_fault_case_validation():
    with pytest.raises(UsageError, match="size 0"):
        FaultCase("f1", 0, 1)
    with pytest.raises(UsageError, match="onset must be a finite number"):
        FaultCase("f1", 0.1, float("nan"))


@pytest.fixture(scope="module")
def tanks():
    from observer_cad.analysis import design_bank
    m = load_model(ROOT / "models" / "three_tank_isolation.py")
    bank = design_bank(m, structure="011,101,110")
    return m, bank, build_observer(m, bank)


SC = {"t_end": 3, "dt": 0.01, "seed": 0, "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
      "signals": {"u1": 1, "u2": 0.5, "rho": {"uniform": [-0.2, 0.2]},
                  "w1": {"uniform": [-0.02, 0.02]}, "w2": {"uniform": [-0.02, 0.02]},
                  "w3": {"uniform": [-0.02, 0.02]}, "f2": 0.4}}


def _band(value):
    def add(res):
        out = {}
        for i in (1, 2, 3):
            r = res[f"r{i}"]
            out[f"r{i}_lower"] = np.full_like(r, -value)
            out[f"r{i}_upper"] = np.full_like(r, value)
        return out
    return add


def test_ensemble_isolates_every_fault_of_the_bank(tanks, monkeypatch):
    m, bank, obs = tanks
    rule = decision_rule(m, bank, persistence=3)
    sc = scenario_from_dict(SC)
    # noise ±0.02 on every level: a residual R* y − H* x* moves by a few hundredths
    free = evaluate_ensemble(m, obs, sc, rule, cases={}, runs=8, seed=2, add_columns=_band(1e-9))
    assert free.false_alarm_runs == 8          # a tight band: every fault-free run alarms
    # the memory limit forces chunks of one or two runs: same totals, same seeds per case
    monkeypatch.setenv("OBSERVER_CAD_MEMORY_LIMIT", str(4 * 301 * 40 * 8 * 2))
    cases = {f: (0.5, 1.0) for f in ("f1", "f2", "f3")}
    mt = evaluate_ensemble(m, obs, sc, rule, cases=cases, runs=6, seed=2, add_columns=_band(0.2))
    assert mt.cases() == (NO_FAULT, "f1 = 0.5 from t = 1", "f2 = 0.5 from t = 1",
                          "f3 = 0.5 from t = 1")
    assert mt.runs == 24 and mt.faulty_runs == 18
    assert mt.false_alarm_samples == 0
    assert mt.missed_detections == 0
    assert mt.isolation_accuracy == 1.0
    C = dict(zip(mt.labels, mt.confusion))
    assert C["f2"][mt.diagnoses.index("f2")] == 6
    med, mx = mt.delay_stats()
    assert 0 < med <= mx < 2.0
    # the scenario's own f2 = 0.4 is replaced: the fault-free case has no fault at all
    assert mt.case(NO_FAULT).faulty_runs == 0


def test_ensemble_arguments_are_checked(tanks):
    m, bank, obs = tanks
    rule = decision_rule(m, bank)
    sc = scenario_from_dict(SC)
    with pytest.raises(UsageError, match="'g' is not a fault"):
        evaluate_ensemble(m, obs, sc, rule, cases={"g": (1, 1)}, runs=1)
    with pytest.raises(UsageError, match="runs must be"):
        evaluate_ensemble(m, obs, sc, rule, cases={}, runs=0)
    with pytest.raises(UsageError, match="give \\(size, onset\\)"):
        evaluate_ensemble(m, obs, sc, rule, cases={"f1": 1}, runs=1)
