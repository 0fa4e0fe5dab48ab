"""``observer-cad simulate --sample-time H`` (or a scenario's ``"sample_time"``): the observer
as deployed, the guaranteed band of the sampled algorithm, and the same residuals and alarms
as ``observer-cad monitor`` on the simulated t, u, y; bad sample times are one line, exit 2."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from observer_cad.cli import main

ROOT = Path(__file__).resolve().parents[2]
MOTOR = ROOT / "models" / "dc_motor_sampled.py"
DESIGN = ["--observer", "diagnostic", "--lambda=-4"]
NOISE = {"uniform": [-0.01, 0.01]}
SCEN = {"t_end": 3, "dt": 0.002, "seed": 7,
        "initial": {"i": {"uniform": [-0.5, 0.5]}, "w": {"uniform": [-1, 1]},
                    "wl": {"uniform": [-1, 1]}},
        "parameters": {"b": "declared"},
        "signals": {"u": "2*sin(3*t) - 1", "rho": "0.45*cos(5*t)", "w1": NOISE, "w2": NOISE,
                    "w3": NOISE, "d": {"piecewise": [[0, "t < 2"], [-1.9, True]]}}}


def run(capsys, argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return rc, cap.out, cap.err


def read(path):
    rows = list(csv.DictReader(open(path)))
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


@pytest.fixture
def scenario(tmp_path):
    def write(**extra):
        p = tmp_path / f"sc{len(extra)}.json"
        p.write_text(json.dumps({**SCEN, **extra}))
        return p
    return write


def test_simulate_sampled_is_what_monitor_computes_on_its_data(capsys, tmp_path, scenario):
    rc, out, err = run(capsys, ["simulate", MOTOR, *DESIGN, "--scenario", scenario(),
                                "--sample-time", "0.01", "--threshold", "guaranteed",
                                "--engine", "reference", "--out", tmp_path / "sim"])
    assert rc == 0, err
    assert "sampled at h = 0.01" in out
    assert "guaranteed threshold of the sampled algorithm at h = 0.01 (RK4)" in out
    assert "false alarms before it: 0 samples" in out
    sim = read(tmp_path / "sim" / "signals.csv")
    t = sim["t"].astype(float)
    assert t.size == 301 and np.allclose(np.diff(t), 0.01, rtol=0, atol=1e-12)
    data = tmp_path / "data.csv"
    with open(data, "w") as f:
        f.write("t,u,y1,y2,y3\n" + "".join(",".join(sim[c][k] for c in ("t", "u", "y1", "y2", "y3"))
                                           + "\n" for k in range(t.size)))
    rc, out, err = run(capsys, ["monitor", MOTOR, *DESIGN, "--data", data, "--threshold",
                                "guaranteed", "--engine", "reference", "--out", tmp_path / "mon"])
    assert rc == 0, err
    mon = read(tmp_path / "mon" / "monitor.csv")
    for c in ("r", "r_lower", "r_upper"):
        np.testing.assert_allclose(mon[c].astype(float), sim[c].astype(float), rtol=1e-12,
                                   atol=1e-15, err_msg=c)
    assert list(mon["alarm"]) == list(sim["alarm"])
    assert list(mon["diagnosis"]) == list(sim["diagnosis"])
    alarm = sim["alarm"].astype(int)
    assert alarm[t < 2].sum() == 0 and alarm[-1] == 1


def test_the_scenario_may_carry_the_sample_time(capsys, tmp_path, scenario):
    base = ["simulate", MOTOR, *DESIGN, "--engine", "reference"]
    rc, _, err = run(capsys, base + ["--scenario", scenario(sample_time=0.02),
                                     "--out", tmp_path / "a"])
    assert rc == 0, err
    rc, _, err = run(capsys, base + ["--scenario", scenario(), "--sample-time", "0.02",
                                     "--out", tmp_path / "b"])
    assert rc == 0, err
    a, b = read(tmp_path / "a" / "signals.csv"), read(tmp_path / "b" / "signals.csv")
    assert list(a) == list(b) and a["t"].size == 151
    for c in a:
        assert list(a[c]) == list(b[c]), c


@pytest.mark.parametrize("argv, extra, words", [
    (["--sample-time", "0.003"], {}, "the sample time 0.003 is not a whole multiple of the"
                                     " scenario's dt = 0.002"),
    (["--sample-time", "4"], {}, "the sample time 4 is longer than 't_end' = 3"),
    ([], {"sample_time": -0.01}, "'sample_time' must be > 0"),
    ([], {"sample_time": "0.01"}, "'sample_time' must be a number"),
])
def test_bad_sample_times_are_refused_in_one_line(capsys, tmp_path, scenario, argv, extra, words):
    rc, out, err = run(capsys, ["simulate", MOTOR, *DESIGN, "--scenario", scenario(**extra),
                                "--out", tmp_path / "o", *argv])
    assert rc == 2 and words in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "o").exists()


def test_discrete_models_and_process_ensembles_refuse_it(capsys, tmp_path, scenario):
    sc = tmp_path / "drive.json"
    sc.write_text(json.dumps({"steps": 20}))
    rc, _, err = run(capsys, ["simulate", ROOT / "models" / "electric_drive_uncertain.py",
                              "--observer", "diagnostic", "--scenario", sc, "--sample-time", "1",
                              "--out", tmp_path / "o"])
    assert rc == 2 and "a sample time applies to a continuous-time model" in err
    rc, _, err = run(capsys, ["ensemble", MOTOR, *DESIGN, "--scenario", scenario(sample_time=0.01),
                              "--runs", "2", "--backend", "processes", "--out", tmp_path / "e"])
    assert rc == 2 and "a sampled scenario (\"sample_time\") runs in this process only" in err
    assert len(err.strip().splitlines()) == 1


def test_a_disturbance_out_of_bounds_between_samples_is_flagged(capsys, tmp_path, scenario):
    """in_bounds looks at each sample's hold, not only at the sample: a load torque of 0.8
    (bound 0.5) for 4 ms between two samples makes that sample out, with the warning."""
    pulse = {"piecewise": [[0, "t < 1.003"], [0.8, "t < 1.007"], [0, True]]}
    sc = scenario(sample_time=0.01, signals={"u": "sin(t)", "rho": pulse})
    rc, _, err = run(capsys, ["simulate", MOTOR, *DESIGN, "--scenario", sc, "--threshold",
                              "guaranteed", "--engine", "reference", "--out", tmp_path / "o"])
    assert rc == 0, err
    sim = read(tmp_path / "o" / "signals.csv")
    out = sim["t"][sim["in_bounds"] == "0"]
    assert out.tolist() == ["1.0"] and not np.any(sim["rho"].astype(float))
    assert "leaves the declared bounds at t = 1 (rho = 0.8 outside [-0.5, 0.5])" in err
