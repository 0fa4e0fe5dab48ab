"""Reference simulator, scenarios and the simulate CLI."""
import csv
import json

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, UsageError, load_model
from observer_cad.cli import main
from observer_cad.observers import Observer, virtual_sensor_observer
from observer_cad.simulation import scenario_from_dict, simulate
from observer_cad.synthesis import design


def test_discrete_plant_matches_hand_recursion(models_dir):
    m = load_model(models_dir / "electric_drive.py")
    sc = scenario_from_dict({"steps": 30, "seed": 3, "initial": {"x1": 0.1},
                             "signals": {"u": "0.2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                                         "d": "Piecewise((0.3*sin(t/2), t <= 20), (1, True))"}})
    r = simulate(m, None, sc)
    k = {str(p): float(v) for p, v in m.parameters.items()}
    x = np.array([0.1, 0.0, 0.0])
    for i in range(29):
        u, rho, d = r["u"][i], r["rho"][i], r["d"][i]
        x = np.array([x[0] + k["k1"] * x[1], k["k2"] * x[1] + k["k3"] * x[2] + rho,
                      k["k4"] * x[1] + k["k5"] * x[2] + k["k6"] * u + d])
        assert np.allclose([r["x1"][i + 1], r["x2"][i + 1], r["x3"][i + 1]], x, rtol=0, atol=1e-14)
    assert np.allclose(r["u"], 0.2 * np.sin(np.arange(30) / 10))
    assert r["d"][25] == 1.0 and abs(r["d"][4] - 0.3 * np.sin(2)) < 1e-15


def test_continuous_rk4_converges_to_exact_solution():
    x = sp.Symbol("x")
    m = PlantModel(name="decay", time="continuous", states=[x], outputs=[x], dynamics=[-x])
    errs = []
    for dt in (0.1, 0.05):
        r = simulate(m, None, scenario_from_dict({"t_end": 1, "dt": dt, "initial": {"x": 1}}))
        errs.append(abs(r["x"][-1] - np.exp(-1)))
    assert errs[0] < 1e-6 and errs[1] < errs[0] / 10  # fourth order


@pytest.mark.parametrize("t_end, dt, ok", [(1, 0.3, False), (1, 0.35, False), (1, 0.4, False),
                                         (20, 0.01, True), (1, 0.1, True), (3, 1 / 3, True)])
def test_t_end_must_be_a_whole_number_of_steps(t_end, dt, ok):
    """t_end = 1, dt = 0.3 stopped at t = 0.9 (and dt = 0.35 ran to 1.05) without a word:
    the grid must end at t_end, so a t_end that is not a whole number of steps is one
    line naming both (rounding of t_end / dt, as 20 / 0.01, is allowed)."""
    x = sp.Symbol("x")
    m = PlantModel(name="decay", time="continuous", states=[x], outputs=[x], dynamics=[-x])
    sc = scenario_from_dict({"t_end": t_end, "dt": dt, "initial": {"x": 1}}, source="s.json")
    if ok:
        r = simulate(m, None, sc)
        assert abs(r["t"][-1] - t_end) < 1e-9 * t_end
        return
    with pytest.raises(UsageError) as info:
        simulate(m, None, sc)
    msg = str(info.value)
    assert "s.json" in msg and "whole number of steps" in msg and "\n" not in msg


def test_seeded_runs_are_reproducible_and_vectorised(models_dir):
    m = load_model(models_dir / "three_tank_linear.py")
    sc = scenario_from_dict({"t_end": 1, "dt": 0.1, "seed": 9,
                             "signals": {"rho": {"uniform": [-0.2, 0.2]}}})
    a = simulate(m, None, sc, runs=4)
    b = simulate(m, None, sc, runs=4)
    assert a["rho"].shape == (4, 11)
    assert np.array_equal(a["x3"], b["x3"])
    assert not np.allclose(a["rho"][0], a["rho"][1])
    assert a["rho"].min() >= -0.2 and a["rho"].max() <= 0.2


def test_virtual_sensor_exact_on_nonlinear_tank(models_dir):
    m = load_model(models_dir / "three_tank.py")
    d = design(m, observer="virtual-sensor", estimate="x1")
    ob = virtual_sensor_observer(m, d)
    sc = scenario_from_dict({"t_end": 10, "dt": 0.01, "initial": {"x1": 3, "x2": 2, "x3": 1},
                             "observer_initial": {"xs1": 3},
                             "signals": {"u1": "1", "u2": "0.5", "rho1": "-0.3", "rho2": "-0.4"}})
    r = simulate(m, ob, sc)
    assert np.max(np.abs(r["x1_hat"] - r["x1"])) < 1e-9
    # started wrong, the error decays like exp(-t) only while the dynamics allow; it shrinks
    sc2 = scenario_from_dict({**json.loads(json.dumps({"t_end": 10, "dt": 0.01,
                             "initial": {"x1": 3, "x2": 2, "x3": 1}, "observer_initial": {"xs1": 3.5},
                             "signals": {"u1": "1", "u2": "0.5"}}))})
    r2 = simulate(m, ob, sc2)
    e = np.abs(r2["x1_hat"] - r2["x1"])
    assert e[-1] < e[0] / 2


def test_delayed_outputs_are_aligned():
    x, u = sp.symbols("x u")
    m = PlantModel(name="m", time="discrete", states=[x], inputs=[u], outputs=[x], dynamics=[u])
    xi = sp.Symbol("prev")
    y1 = sp.Symbol("y1")
    # an 'estimate' of u(t-1) = x(t) = y1(t): produced at step t, refers to t-1
    ob = Observer(name="o", kind="test", time="discrete", states=(xi,), signals=(y1, u),
                  parameters={}, update=(y1,), outputs=(("u_hat", y1),), delays={"u_hat": 1})
    r = simulate(m, ob, scenario_from_dict({"steps": 6, "signals": {"u": "t**2"}}))
    assert np.allclose(r["u_hat"][:-1], r["u"][:-1])
    assert np.isnan(r["u_hat"][-1])


@pytest.mark.parametrize("data,needle", [
    ({"steps": 5, "signals": {"nope": "1"}}, "nope"),
    ({"steps": 5, "signals": {"u": "t + z"}}, "'z'"),
    ({"steps": 5, "signals": {"u": {"gauss": [0, 1]}}}, "uniform"),
    ({"steps": 5, "initial": {"x9": 1}}, "x9"),
    ({"t_end": 5}, "steps"),
    ({"steps": 5, "colour": 1}, "colour"),
])
def test_bad_scenarios_are_one_line_errors(models_dir, data, needle):
    m = load_model(models_dir / "electric_drive.py")
    with pytest.raises(UsageError) as info:
        simulate(m, None, scenario_from_dict(data, source="bad.json"))
    assert needle in str(info.value) and "bad.json" in str(info.value)
    assert "\n" not in str(info.value)


def test_cli_simulate_writes_csv(models_dir, tmp_path, capsys):
    sc = tmp_path / "sc.json"
    sc.write_text(json.dumps({"t_end": 2, "dt": 0.01, "seed": 1, "initial": {"x1": 1},
                              "signals": {"u1": "1", "rho": {"uniform": [-0.2, 0.2]},
                                          "w1": {"uniform": [-0.02, 0.02]}}}))
    out = tmp_path / "out"
    rc = main(["simulate", str(models_dir / "three_tank_linear.py"), "--observer", "interval",
               "--estimate", "x1", "--scenario", str(sc), "--out", str(out)])
    assert rc == 0
    rows = list(csv.reader((out / "signals.csv").open()))
    assert rows[0] == ["t", "x1", "x2", "x3", "y1", "y2", "u1", "u2", "rho", "x1_lower", "x1_upper"]
    assert len(rows) == 202
    data = np.array(rows[1:], dtype=float)
    assert np.all(data[:, 9] <= data[:, 1] + 1e-12) and np.all(data[:, 1] <= data[:, 10] + 1e-12)
    assert not list(out.glob(".*tmp"))  # no temporary files left behind


def test_cli_simulate_missing_scenario_is_one_line(models_dir, tmp_path, capsys):
    rc = main(["simulate", str(models_dir / "three_tank_linear.py"), "--observer", "interval",
               "--estimate", "x1", "--scenario", str(tmp_path / "none.json"), "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "none.json" in err


def test_piecewise_signal_with_random_segment(models_dir):
    m = load_model(models_dir / "electric_drive.py")
    sc = scenario_from_dict({"steps": 60, "seed": 5, "signals": {
        "d": {"piecewise": [["0.3*sin(t/2)", "t <= 20"], [{"uniform": [-0.5, 0.5]}, True]]}}})
    r = simulate(m, None, sc, runs=3)
    t = r["t"][0]
    assert np.allclose(r["d"][:, t <= 20], 0.3 * np.sin(t[t <= 20] / 2))
    late = r["d"][:, t > 20]
    assert late.min() >= -0.5 and late.max() <= 0.5 and not np.allclose(late[0], late[1])
    again = simulate(m, None, sc, runs=3)
    assert np.array_equal(again["d"], r["d"])


@pytest.mark.parametrize("time,keys,msg", [
    ("continuous", {"t_end": 1, "dt": 0.1, "steps": 5}, "'steps' does not apply"),
    ("discrete", {"steps": 5, "t_end": 3}, "do not apply to a discrete-time"),
])
def test_keys_that_do_not_apply_to_the_time_domain_are_refused(time, keys, msg):
    """A scenario key the model's time domain ignores is an error, not silently dropped."""
    from observer_cad import UsageError
    from observer_cad.simulation import scenario_from_dict
    sc = scenario_from_dict(dict(keys, signals={}), source="s.json")
    with pytest.raises(UsageError, match=msg):
        sc.size(time)
