"""Parity of the deployed algorithm: ``simulate(..., sample_time=h)`` on the DC motor (a
continuous plant with its operating envelope and initial box), its t, u and y columns
written as the monitor's CSV, then the Python monitor (reference and compiled engines) and
the exported C example on that file give simulate's residuals and bands (rtol 1e-12) and
its alarms, sample for sample."""
from __future__ import annotations

import dataclasses
import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad import Monitor, build_observer, design, load_model
from observer_cad.codegen import CompiledMonitorEngine, export_observer
from observer_cad.residuals import decide, decision_rule, sampled_threshold
from observer_cad.simulation import declared_envelope, read_table, scenario_from_dict, simulate

from tests.codegen.test_export_monitor import _build, _rows, needs_cc

ROOT = Path(__file__).resolve().parents[2]
H = 0.01
NOISE = {"uniform": [-0.01, 0.01]}


def _close(got, want, what):
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    scale = float(np.max(np.abs(want)))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * scale, err_msg=what)


@pytest.fixture(scope="module")
def motor():
    m = load_model(ROOT / "models" / "dc_motor_sampled.py")
    d = design(m, observer="diagnostic", lambdas=[-4])
    obs = sampled_threshold(m, build_observer(m, d), sp.Rational(1, 100))
    return m, obs, decision_rule(m, d, persistence=2)


def _scenario(seed):
    """4 s at dt = 2 ms (five grid steps per sample), x(0) in the declared box, the friction
    anywhere in its uncertainty, noise and load torque in their bounds, and a step of the
    actuator fault from t = 2.5 s."""
    return scenario_from_dict({
        "t_end": 4, "dt": 0.002, "seed": seed,
        "initial": {"i": {"uniform": [-0.5, 0.5]}, "w": {"uniform": [-1, 1]},
                    "wl": {"uniform": [-1, 1]}},
        "parameters": {"b": "declared"},
        "signals": {"u": "3*sin(2*t) + 1", "rho": "0.45*sin(7*t)", "w1": NOISE, "w2": NOISE,
                    "w3": NOISE, "d": {"piecewise": [[0, "t < 2.5"], [1.8, True]]}}})


@needs_cc
def test_simulate_monitor_and_exported_c_run_the_same_algorithm(motor, tmp_path):
    m, obs, rule = motor
    res = simulate(m, obs, _scenario(5), sample_time=H)
    t = np.asarray(res["t"])
    assert t.size == 401 and np.allclose(np.diff(t), H, rtol=0, atol=1e-12)
    dec = decide(rule, res.columns)
    alarm = np.asarray(dec.alarm, dtype=int)
    # the band holds on the true plant before the fault (none of the 250 samples alarms),
    # and the fault is caught
    assert alarm[t < 2.5].sum() == 0 and alarm[t >= 2.6].all()
    path = tmp_path / "motor.csv"
    names = ("t", "u", "y1", "y2", "y3")
    path.write_text(",".join(names) + "\n" + "".join(
        ",".join(repr(float(res[c][k])) for c in names) + "\n" for k in range(t.size)))
    data = read_table(path)
    paths = export_observer(obs, tmp_path, dt=H, rule=rule, envelope=declared_envelope(m))
    r = subprocess.run([str(_build(paths, tmp_path)), str(path)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    header, c_out = _rows(r.stdout)
    tables = {"reference": Monitor(m, obs, rule=rule).run(data),
              "compiled": Monitor(m, obs, rule=rule, engine=CompiledMonitorEngine(obs)).run(data),
              "C example": {h: np.array(c_out[h], dtype=float if h != "diagnosis" else object)
                            for h in header}}
    for how, table in tables.items():
        for c in ("r", "r_lower", "r_upper"):
            _close(table[c], res[c], f"{how}: {c}")
        assert np.array_equal(np.asarray(table["alarm"], dtype=int), alarm), how
        assert list(table["diagnosis"]) == list(dec.diagnosis), how
    # the compiled engine inside simulate: the same numbers again
    again = simulate(m, obs, _scenario(5), sample_time=H, engine=CompiledMonitorEngine(obs))
    for c in ("r", "r_lower", "r_upper"):
        _close(again[c], res[c], f"simulate, compiled engine: {c}")


@needs_cc
def test_the_joint_compiled_trajectory_refuses_a_sampled_scenario(motor):
    """CompiledSimulator integrates plant and observer together: a scenario with
    "sample_time" is refused in one line naming the way that runs it."""
    from observer_cad import CompiledSimulator
    from observer_cad.errors import UsageError
    m, obs, _ = motor
    sc = dataclasses.replace(_scenario(1), sample_time=H)
    with pytest.raises(UsageError, match="engine=CompiledMonitorEngine") as err:
        CompiledSimulator(m, obs).simulate(sc)
    assert "\n" not in str(err.value)


def _records_module():
    import importlib.util
    spec = importlib.util.spec_from_file_location("dc_motor_data", ROOT / "examples" / "dc_motor_data.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _c_alarms(exe, rec, tmp_path) -> np.ndarray:
    """The exported C example's alarm column on each record (written as the monitor's
    CSV: t, u, y1, y2, y3), records × samples."""
    out = []
    path = tmp_path / "record.csv"
    for j in range(rec["u"].shape[0]):
        table = np.column_stack([rec["t"], rec["u"][j], rec["y"][j]])
        np.savetxt(path, table, delimiter=",", fmt="%.17g", header="t,u,y1,y2,y3", comments="")
        r = subprocess.run([str(exe), str(path)], capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, r.stderr
        header, cols = _rows(r.stdout)
        out.append(np.array(cols["alarm"], dtype=int))
    return np.array(out)


@needs_cc
@pytest.mark.slow
def test_the_exported_c_on_1000_records_of_the_continuous_plant(motor, tmp_path):
    """The worked example's guarantee in the exported C: on 1,000 fault-free records of the
    true continuous plant (solve_ivp, examples/dc_motor_data.py: ZOH input, smooth load
    torque, friction and x(0) drawn from their boxes) the C example never alarms; on 60
    records with a step fault 1.3× the guaranteed detectable size (either sign) from
    t = 1 s it alarms in every one after the fault and never before."""
    from observer_cad.residuals import min_detectable_fault
    m, _, _ = motor
    d = design(m, observer="diagnostic", lambdas=[-4])
    obs = sampled_threshold(m, build_observer(m, d), sp.Rational(1, 100))
    rule = decision_rule(m, d, persistence=1)
    paths = export_observer(obs, tmp_path, dt=H, rule=rule, envelope=declared_envelope(m))
    exe = _build(paths, tmp_path)
    data = _records_module()
    alarms = _c_alarms(exe, data.records(1000, 5.0, seed=11), tmp_path)
    assert alarms.shape == (1000, 501) and int(alarms.sum()) == 0
    z = {s: 0 for s in obs.states if str(s).endswith("_decay")}
    width = float(dict(obs.outputs)["r_upper"].xreplace(z)) - float(
        dict(obs.outputs)["r_lower"].xreplace(z))
    dmin = min_detectable_fault(obs.threshold, [width])["d"]
    sizes = 1.3 * dmin * np.where(np.arange(60) % 2 == 0, 1.0, -1.0)
    alarms = _c_alarms(exe, data.records(60, 4.0, seed=3, fault=sizes, fault_time=1.0), tmp_path)
    assert not alarms[:, :100].any() and alarms[:, 100:].any(axis=1).all()
