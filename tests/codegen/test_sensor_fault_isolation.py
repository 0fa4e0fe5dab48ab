"""Sensor faults end to end (models/three_tank_sensor_faults.py: a bias on each level
sensor, y = x + fs + w): a bank of two certified residuals (structure 10110,01111 over
fa1, fa2, fs1, fs2, fs3) detects a bias on sensor 1 and isolates it from the actuator
faults — in the reference simulation, in an ensemble of the compiled simulator, and in the
exported C, which reproduces the Python observer step on the simulated y, u."""
from __future__ import annotations

import csv
import io
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("casadi")

from observer_cad import build_observer, simulate
from observer_cad.analysis import design_bank
from observer_cad.codegen import EXAMPLE_FLAGS, export_observer, observer_step, split_signals
from observer_cad.ensemble import Backend, run_ensemble
from observer_cad.model import load_model
from observer_cad.residuals import ThresholdSpec, decision_rule
from observer_cad.simulation import apply_threshold, load_scenario, scenario_from_dict

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "models" / "three_tank_sensor_faults.py"
SCENARIO = ROOT / "models" / "scenarios" / "three_tank_sensor_faults.json"
CC = shutil.which("cc")


@pytest.fixture(scope="module")
def bank():
    m = load_model(MODEL)
    b = design_bank(m, structure="10110,01111")
    return m, b, build_observer(m, b)


def test_bank_rows_and_isolation(bank):
    m, b, _ = bank
    assert b.structure_matrix == ((1, 0, 1, 1, 0), (0, 1, 1, 1, 1))
    assert all(d.certificate.passed and d.k == 1 for d in b.designs)
    names = [i.name for i in b.designs[0].certificate.identities]
    assert "Phi D - J* Dy - D*" in names and "R* Ly" in names
    assert "model: R* dh/d(decoupled)" in names
    iso = dict(b.isolable)
    # a sensor-1 bias is isolated from both actuator faults
    assert iso[("fa1", "fs1")] and iso[("fa2", "fs1")] and iso[("fa1", "fa2")]


def test_simulated_bias_moves_both_residuals_only_after_it_appears(bank):
    m, _, o = bank
    sc = load_scenario(SCENARIO)
    res = simulate(m, o, sc)
    t = res["t"]
    for r in ("r1", "r2"):   # exactly decoupled from rho before the fault
        assert np.max(np.abs(res[r][t < 10])) < 1e-9, r
        assert np.max(np.abs(res[r][t > 10.5])) > 0.1, r
    # the plant's outputs carry the bias (y1 = x1 + fs1)
    after = t > 10
    np.testing.assert_allclose(res["y1"][after] - res["x1"][after], 0.3, atol=1e-12)
    # an actuator fault on pump 1 moves r1 only
    sc2 = scenario_from_dict({"t_end": 8, "dt": 0.01, "initial": {"x1": 0.5},
                              "signals": {"u1": "0.5", "rho": "0.2*sin(2*t)",
                                          "fa1": "Piecewise((0, t < 4), (0.5, True))"}})
    res2 = simulate(m, o, sc2)
    t2 = res2["t"]
    assert np.max(np.abs(res2["r1"][t2 > 5])) > 0.1
    assert np.max(np.abs(res2["r2"])) < 1e-9


@pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")
def test_ensemble_detects_and_isolates_the_sensor_bias(bank):
    m, b, o = bank
    o = apply_threshold(m, o, ThresholdSpec.parse("guaranteed"))
    sc = scenario_from_dict({
        "t_end": 6, "dt": 0.01, "seed": 3,
        "initial": {"x1": {"uniform": [0.4, 0.6]}, "x2": 0.2, "x3": 0.1},
        "signals": {"u1": "0.5", "u2": "0.3", "rho": {"uniform": [-0.2, 0.2]},
                    "w1": {"uniform": [-0.02, 0.02]}, "w2": {"uniform": [-0.02, 0.02]},
                    "w3": {"uniform": [-0.02, 0.02]}},
        "cases": {"fault-free": {}, "fs1": {"fs1": "Piecewise((0, t < 3), (0.3, True))"},
                  "fa1": {"fa1": "Piecewise((0, t < 3), (0.5, True))"}}})
    res = run_ensemble(m, o, sc, runs=20, rule=decision_rule(m, b), backend=Backend("serial"))
    cases = res.statistics.cases
    free, fs1, fa1 = (cases[c].fields for c in ("fault-free", "fs1", "fa1"))
    assert free["alarm.samples"].positive == 0
    # every run: the bias moves both residuals (column 11), the pump fault r1 only (10)
    assert fs1["r1.exceedances"].positive == 20 and fs1["r2.exceedances"].positive == 20
    assert fa1["r1.exceedances"].positive == 20 and fa1["r2.exceedances"].positive == 0


@pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")
def test_exported_c_reproduces_the_python_step_on_the_biased_sensor(bank, tmp_path):
    m, _, o = bank
    sc = load_scenario(SCENARIO)
    ref = simulate(m, o, sc)
    h = float(sc.dt)
    paths = export_observer(o, tmp_path, dt=h,
                            initial={s.name: float(sc.initial.get(s.name, 0.0))
                                     for s in m.states[:2]})
    c, _, ex = paths
    r = subprocess.run(["cc", *EXAMPLE_FLAGS, c.name, ex.name, "-lm"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    ys, us = split_signals(o)
    names = [str(s) for s in ys + us]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    sig = np.column_stack([ref[n] for n in names])
    for row in sig:
        w.writerow([repr(float(v)) for v in row])
    (tmp_path / "in.csv").write_text(buf.getvalue())
    run = subprocess.run([str(tmp_path / "a.out"), "in.csv", "trace"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    rows = list(csv.reader(io.StringIO(run.stdout)))
    data = np.array([[float(v) for v in row] for row in rows[1:]])
    out_c = data[:, 1 + len(o.states):]
    # the Python step on the same samples
    f = observer_step(o, h=h)
    ny = len(ys)
    x = np.array(data[0, 1:1 + len(o.states)], float)
    outs = []
    for row in sig:
        xn, out = f(x, row[:ny], row[ny:], [float(v) for v in o.parameters.values()])
        outs.append(np.array(out, float).ravel())
        x = np.array(xn, float).ravel()
    outs = np.array(outs)
    scale = max(float(np.max(np.abs(outs))), 1e-300)
    assert float(np.max(np.abs(outs - out_c))) / scale <= 1e-12
    t = ref["t"]
    r_names = list(o.output_names)
    i1, i2 = r_names.index("r1"), r_names.index("r2")
    # the C residuals see the bias too (held samples: small transients before t = 10)
    assert np.max(np.abs(out_c[t > 10.5][:, [i1, i2]]), axis=0).min() > 0.1
    assert np.max(np.abs(out_c[t < 9.5][:, [i1, i2]])) < 0.05


def test_guaranteed_threshold_sees_the_sensor_bias(bank):
    """The error system of the guaranteed threshold carries the sensor fault into both the
    observer (− J* Dy) and the residual (R* Dy): every fault has a finite smallest
    detectable step, and the dc gain of fs1 to r1 is its direct gain R* Dy = 1 (r1 = y1 −
    x*, x*' = −x* + y2 + u1: a bias on y1 enters r1 only directly)."""
    from observer_cad.residuals import min_detectable_fault
    m, b, o = bank
    ot = apply_threshold(m, o, ThresholdSpec.parse("guaranteed"))
    es = ot.threshold.error_system
    G = es.dc_gain()
    j = list(es.faults).index("fs1")
    assert G[0, j] == 1 and G[1, j] != 0
    found = min_detectable_fault(ot.threshold, [0.1, 0.1])
    assert all(v is not None and v > 0 for v in found.values())


@pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")
def test_inputs_in_the_outputs_through_simulation_and_the_compiled_ensemble():
    """y1 = x1 + u1/4 + f2 (from the matrices (A, B, C, D)): the simulated outputs carry the
    input's feedthrough, the residual r = R* (y − Gy u) − H* x* stays at zero without
    faults (reference simulator and compiled ensemble) and sees the sensor bias f2."""
    from observer_cad import PlantModel
    from observer_cad.synthesis import design
    A = [[-1.0, 0.0], [0.5, -2.0]]
    B = [[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
    C = [[1.0, 0.0], [0.0, 1.0]]
    D = [[0.25, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.5]]
    m = PlantModel.from_statespace((A, B, C, D), time="continuous", inputs=[0], faults=[1, 2],
                                   disturbances=[3])
    o = build_observer(m, design(m, observer="diagnostic", faults=["f1"]))
    sc = scenario_from_dict({"t_end": 5, "dt": 0.01, "initial": {"x1": 1},
                             "signals": {"u1": "1 + sin(3*t)", "rho1": "sin(t)"},
                             "cases": {"free": {},
                                       "f2": {"f2": "Piecewise((0, t < 2), (0.5, True))"}}})
    res = simulate(m, o, sc, case="free")
    np.testing.assert_allclose(res["y1"], res["x1"] + res["u1"] / 4, rtol=0, atol=1e-12)
    assert np.max(np.abs(res["r"])) < 1e-12
    ens = run_ensemble(m, o, sc, runs=3, backend=Backend("serial"))
    assert ens.statistics.cases["free"].fields["r.max_abs"].max < 1e-12
    assert abs(ens.statistics.cases["f2"].fields["r.max_abs"].max - 0.5) < 1e-9


@pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")
def test_zero_order_residual_exports_to_c(tmp_path):
    """A residual without observer states (r = y1 − y3 of three sensors on one level)
    compiles as standalone C and prints the residual of the recorded y."""
    from observer_cad import PlantModel
    from observer_cad.synthesis import design
    import sympy as sp
    x, u, f1, f2, f3 = sp.symbols("x u f1 f2 f3")
    m = PlantModel(name="triplex", time="continuous", states=[x], inputs=[u],
                   faults=[f1, f2, f3], outputs=[x + f1, x + f2, x + f3], dynamics=[-x + u])
    o = build_observer(m, design(m, observer="diagnostic", faults=["f1"], disturbances=["f2"]))
    assert not o.states
    sc = scenario_from_dict({"t_end": 1, "dt": 0.01, "initial": {"x": 1},
                             "signals": {"u": "1", "f1": "Piecewise((0, t < 0.5), (0.5, True))"}})
    ref = simulate(m, o, sc)
    c, _, ex = export_observer(o, tmp_path, dt=0.01)
    r = subprocess.run(["cc", *EXAMPLE_FLAGS, c.name, ex.name, "-lm"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    ys, us = split_signals(o)
    names = [str(s) for s in ys + us]
    lines = [",".join(names)] + [",".join(repr(float(ref[n][i])) for n in names)
                                 for i in range(ref["t"].shape[0])]
    (tmp_path / "in.csv").write_text("\n".join(lines) + "\n")
    run = subprocess.run([str(tmp_path / "a.out"), "in.csv", "trace"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    rows = list(csv.reader(io.StringIO(run.stdout)))
    assert rows[0] == ["step", "r"]
    got = np.array([float(row[1]) for row in rows[1:]])
    np.testing.assert_allclose(got, ref["r"], rtol=0, atol=1e-12)
