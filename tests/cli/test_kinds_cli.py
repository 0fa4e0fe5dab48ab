"""Every observer kind designs, simulates and passes its property test from a model file
and one CLI call; `design --json` carries the observer's equations
and outputs."""
import csv
import json

import numpy as np
import pytest
import sympy as sp

from observer_cad.cli import main

SCEN = {
    "tank_lin": {"t_end": 10, "dt": 0.01, "seed": 4, "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
                 "signals": {"u1": "1", "u2": "0.5", "rho": {"uniform": [-0.2, 0.2]},
                             "w1": {"uniform": [-0.02, 0.02]}, "w2": {"uniform": [-0.02, 0.02]}}},
    "tank": {"t_end": 10, "dt": 0.01, "seed": 4, "initial": {"x1": 2, "x2": 1.2, "x3": 0.6},
             "signals": {"u1": "0.5", "u2": "0.2", "w1": {"uniform": [-0.01, 0.01]},
                         "w2": {"uniform": [-0.01, 0.01]}}},
    "drive": {"steps": 100, "seed": 2, "signals": {"u": "0.2*sin(t/10)",
              "rho": {"uniform": [-0.05, 0.05]},
              "d": "Piecewise((0.3*sin(t/2), t <= 20), (1, True))"}},
    "drive_nofault": {"steps": 60, "seed": 2, "signals": {"u": "0.2*sin(t/10)",
                      "rho": {"uniform": [-0.05, 0.05]}, "d": "Piecewise((0, t < 30), (0.5, True))"}},
    "sliding": {"t_end": 8, "dt": 0.001, "seed": 1, "initial": {"x1": 0, "x2": 1, "x3": 0},
                "signals": {"d": "Piecewise((0, t < 3), (0.8*sin(t - 3), True))", "rho": "0.3*sin(3*t)"}},
}


def _run(capsys, argv):
    rc = main(argv)
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    return cap.out


def _csv(path):
    rows = list(csv.DictReader(open(path)))
    return {k: np.array([float(r[k]) if r[k] != "" else np.nan for r in rows]) for k in rows[0]}


CASES = [
    # (model, design args, scenario, property)
    ("three_tank_linear.py", ["--observer", "virtual-sensor", "--estimate", "x1"], "tank_lin", "vs"),
    ("three_tank.py", ["--observer", "virtual-sensor", "--estimate", "x1"], "tank", "vs"),
    ("three_tank_linear.py", ["--observer", "interval", "--estimate", "x1"], "tank_lin", "interval"),
    ("three_tank.py", ["--observer", "interval", "--estimate", "x1"], "tank", "interval"),
    ("three_tank_linear.py", ["--observer", "interval", "--estimate", "x1", "--form", "canonical",
                              "--eigenvalues", "-1", "-2"], "tank_lin", "interval"),
    ("electric_drive.py", ["--observer", "unknown-input", "--fault", "d"], "drive", "uio"),
    ("electric_drive.py", ["--observer", "unknown-input", "--fault", "d", "--form", "jordan",
                           "--lambda", "1/2"], "drive", "uio"),
    ("electric_drive.py", ["--observer", "diagnostic"], "drive_nofault", "residual"),
    ("electric_drive.py", ["--observer", "diagnostic", "--form", "canonical", "--eigenvalues", "1/2"],
     "drive_nofault", "residual"),
    ("sliding_example.py", ["--observer", "sliding-mode", "--fault", "d"], "sliding", "sliding"),
]


@pytest.mark.slow
@pytest.mark.parametrize("model,args,scen,prop", CASES,
                         ids=[f"{c[0]}-{' '.join(c[1][1:4])}" for c in CASES])
def test_kind_designs_simulates_and_holds(models_dir, tmp_path, capsys, model, args, scen, prop):
    path = str(models_dir / model)
    j = json.loads(_run(capsys, ["design", path] + args + ["--json"]))
    assert j["equations"] and j["outputs"] and "observer_equations" in j
    loc = {n: sp.Symbol(n) for n in j["states"]}
    for e in j["equations"]:
        sp.sympify(e, locals=loc)  # parses
    sc = tmp_path / "sc.json"
    sc.write_text(json.dumps(SCEN[scen]))
    out = tmp_path / "out"
    _run(capsys, ["simulate", path] + args + ["--scenario", str(sc), "--out", str(out)])
    data = _csv(out / "signals.csv")
    for name in j["observer_equations"]["outputs"]:
        assert name in data, name
    assert list(out.glob("*.png"))
    if prop == "interval":
        lo, hi, x = data["x1_lower"], data["x1_upper"], data["x1"]
        assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))
        assert np.all(lo <= x + 1e-9) and np.all(x <= hi + 1e-9)
    elif prop == "vs":
        e = np.abs(data["x1_hat"] - data["x1"])
        assert np.all(np.isfinite(e))
        assert e.max() < 0.05  # started at Φ x(0); only the noise on y moves it away
    elif prop == "uio":
        dh, d = data["d_hat"], data["d"]
        ok = ~np.isnan(dh)
        assert np.max(np.abs(dh[ok][1:] - d[ok][1:])) < 1e-9
    elif prop == "residual":
        r, t = data["r"], data["t"]
        before = np.abs(r[(t > 10) & (t < 30)])
        after = np.abs(r[t > 31])
        assert before.max() < 1e-9 and after.max() > 1e-3  # silent, then sees the fault
    elif prop == "sliding":
        t, dh, d = data["t"], data["d_hat"], data["d"]
        late = t > 4
        assert np.max(np.abs(dh[late] - d[late])) < 0.02


@pytest.mark.slow  # full-length DREM simulation, ~10 s
def test_drem_cli_reports_insufficient_excitation(models_dir, tmp_path, capsys):
    """A constant input gives no excitation: simulate says so (one line, exit 3) instead of
    silently returning estimates; design --json carries the observer's equations."""
    j = json.loads(_run(capsys, ["design", str(models_dir / "drem_example.py"), "--observer",
                                 "drem", "--json"]))
    assert j["equations"] and "x1_hat" in j["outputs"]
    rc = main(["simulate", str(models_dir / "drem_example.py"), "--observer", "drem",
               "--scenario", str(models_dir / "scenarios" / "drem_constant_input.json"),
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 3
    assert "insufficient excitation" in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "o" / "signals.csv").exists()


@pytest.mark.slow
@pytest.mark.parametrize("model,args", [(c[0], c[1]) for c in CASES],
                         ids=[f"{c[0]}-{' '.join(c[1][1:4])}" for c in CASES])
def test_design_json_reads_back_and_builds(models_dir, capsys, model, args):
    """What `design --json` prints is a design: Design.from_json re-certifies it against the
    model and build_observer gives the same observer equations the command printed."""
    from observer_cad import build_observer, load_model
    from observer_cad.synthesis import Design
    path = str(models_dir / model)
    j = json.loads(_run(capsys, ["design", path] + args + ["--json"]))
    plant = load_model(path)
    d = Design.from_json(j, plant)
    assert d.certificate.passed and d.k == j["k"]
    ob = build_observer(plant, d).to_json()
    assert ob["outputs"] == j["observer_equations"]["outputs"]
    assert ob["equations"] == j["observer_equations"]["equations"]
