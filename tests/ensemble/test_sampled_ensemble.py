"""Ensembles of a sampled scenario (``"sample_time"``, ``ensemble --sample-time H``): every
run is :func:`simulate`'s sampled run (the observer stepped by the monitor's engine), the
summaries do not depend on the chunks, the worst run is replayed exactly, the sampled band
raises no false alarm, and what cannot run so is refused in one line."""
from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad.cli import main
from observer_cad.ensemble import Backend, replay, run_ensemble
from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.residuals import decision_rule, sampled_threshold
from observer_cad.simulation import monitors, scenario_from_dict, simulate, summarise
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
MOTOR = ROOT / "models" / "dc_motor_sampled.py"
NOISE = {"uniform": [-0.01, 0.01]}
SCEN = {"t_end": 2, "dt": 0.002, "seed": 11, "sample_time": 0.01,
        "initial": {"i": {"uniform": [-0.5, 0.5]}, "w": {"uniform": [-1, 1]},
                    "wl": {"uniform": [-1, 1]}},
        "parameters": {"b": "declared"},
        "signals": {"u": "3*sin(2*t)", "rho": {"uniform": [-0.5, 0.5]}, "w1": NOISE,
                    "w2": NOISE, "w3": NOISE},
        "cases": {"fault-free": {}, "d": {"d": {"piecewise": [[0, "t < 1.5"], [1.9, True]]}}}}


@pytest.fixture(scope="module")
def motor():
    m = load_model(MOTOR)
    d = design(m, observer="diagnostic", lambdas=[-4])
    obs = sampled_threshold(m, build_observer(m, d), sp.Rational(1, 100))
    return m, obs, decision_rule(m, d), scenario_from_dict(SCEN)


def _table(res):
    cols = res.accumulator.columns()
    return {k: np.asarray(v) for k, v in cols.items()}


def test_runs_are_simulate_sampled_runs_whatever_the_chunks(motor):
    m, obs, rule, sc = motor
    ref = run_ensemble(m, obs, sc, runs=5, engine="reference", backend=Backend("serial"),
                       chunk=5, rule=rule)
    assert ref.engine.startswith("sampled at h = 0.01")
    got = run_ensemble(m, obs, sc, runs=5, engine="reference",
                       backend=Backend("threads", workers=2), chunk=2, rule=rule)
    a, b = _table(ref), _table(got)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)   # bit for bit (NaN = NaN)
    mon = monitors(m, obs, rule=rule)
    one = simulate(m, obs, sc, first_run=3, case="d", samples=5)
    summ = summarise(mon, one.columns, np.asarray(one["t"]))
    at = int(np.flatnonzero(a["run"] == 5 + 3)[0])
    for f in summ.fields:
        v, w = float(summ.values[f.name][0]), float(a[f.name][at])
        assert v == w or (np.isnan(v) and np.isnan(w)), f.name
    # the sampled band: no fault-free run alarms; every faulty one does, after the onset
    free = a["case"] == "fault-free"
    assert np.all(a["alarm.samples"][free] == 0)
    assert np.all(a["alarm.first"][~free] >= 1.5)


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                    reason="no C compiler")
def test_compiled_monitor_engine_and_exact_replay(motor):
    m, obs, rule, sc = motor
    res = run_ensemble(m, obs, sc, runs=4, rule=rule, keep=1,
                       backend=Backend("threads", workers=2))
    assert "compiled C" in res.engine and len(res.kept) == 1
    run, case, k, traj = res.kept[0]
    assert np.asarray(traj["t"]).size == 201
    again = replay(m, obs, sc, run, runs=4, expect=res.accumulator, rule=rule)
    np.testing.assert_array_equal(again["r"], traj["r"])
    ref = _table(run_ensemble(m, obs, sc, runs=4, rule=rule, engine="reference",
                              backend=Backend("serial")))
    np.testing.assert_allclose(_table(res)["r.max_abs"], ref["r.max_abs"], rtol=1e-12)


def test_what_cannot_run_sampled_is_refused(motor):
    m, obs, rule, sc = motor
    with pytest.raises(UsageError, match="a sampled scenario .* in this process only"):
        run_ensemble(m, obs, sc, runs=2, backend=Backend("processes", workers=2))
    with pytest.raises(UsageError, match="not a whole multiple of the scenario's dt"):
        run_ensemble(m, obs, dataclasses.replace(sc, sample_time=0.003), runs=2,
                     engine="reference", backend=Backend("serial"))


@pytest.mark.slow
def test_ensemble_command_takes_the_sample_time(capsys, tmp_path):
    sc = tmp_path / "sc.json"
    sc.write_text(json.dumps({k: v for k, v in SCEN.items() if k != "sample_time"}))
    rc = main(["ensemble", str(MOTOR), "--observer", "diagnostic", "--lambda=-4", "--scenario",
               str(sc), "--runs", "3", "--threshold", "guaranteed", "--sample-time", "0.01",
               "--engine", "reference", "--backend", "serial", "--out", str(tmp_path / "e")])
    out = capsys.readouterr().out
    assert rc == 0
    assert "sampled at h = 0.01" in out and "false alarms: 0/6" in out
    assert "detected: 3/3" in out
