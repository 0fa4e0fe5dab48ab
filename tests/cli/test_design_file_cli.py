"""--design FILE on simulate, ensemble and codegen: the frozen design (every kind, a residual
bank, a DREM design) gives the same outputs as designing again; design options beside it
must agree; a changed model or a tampered file is one line, exit 2."""
import csv
import json
from pathlib import Path

import pytest

from observer_cad.cli import main

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
SCEN = MODELS / "scenarios"

SCENARIOS = {
    "drive": {"steps": 60, "seed": 2, "signals": {"u": "0.2*sin(t/10)",
              "rho": {"uniform": [-0.05, 0.05]}, "d": "Piecewise((0, t < 30), (0.5, True))"}},
    "tank": {"t_end": 0.5, "dt": 0.01, "seed": 4, "initial": {"x1": 2, "x2": 1.2, "x3": 0.6},
             "signals": {"u1": "0.5", "u2": "0.2", "w1": {"uniform": [-0.01, 0.01]},
                         "w2": {"uniform": [-0.01, 0.01]}}},
    "sliding": {"t_end": 0.5, "dt": 0.001, "seed": 1, "initial": {"x1": 0, "x2": 1, "x3": 0},
                "signals": {"d": "Piecewise((0, t < 0.5), (0.8*sin(t - 0.5), True))",
                            "rho": "0.3*sin(3*t)"}},
    "isolation": {"t_end": 3, "dt": 0.01, "seed": 0, "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
                  "signals": {"u1": "1", "u2": "0.5", "rho": "0.2*sin(2*t)",
                              "f2": "Piecewise((0, t < 1.5), (0.3, True))"}},
    "drem": {"t_end": 12, "dt": 0.02, "seed": 0, "initial": {"x1": 1, "x2": -0.5},
             "signals": {"u": "2*sin(t) + sin(2.7*t) + 1.6*cos(0.6*t)"}},
}

CASES = {
    # name: (model, design options, scenario (a key of SCENARIOS or a file), extra options)
    "unknown-input": ("electric_drive.py", ["--observer", "unknown-input", "--fault", "d"],
                      "drive", []),
    "diagnostic-guaranteed": ("electric_drive_uncertain.py", ["--observer", "diagnostic"],
                              SCEN / "electric_drive_uncertain.json",
                              ["--threshold", "guaranteed"]),
    "virtual-sensor": ("three_tank.py", ["--observer", "virtual-sensor", "--estimate", "x1"],
                       "tank", []),
    "interval": ("three_tank.py", ["--observer", "interval", "--estimate", "x1"], "tank", []),
    "sliding-mode": ("sliding_example.py", ["--observer", "sliding-mode"], "sliding", []),
    "bank": ("three_tank_isolation.py", ["--observer", "diagnostic", "--isolate"],
             "isolation", ["--threshold", "guaranteed"]),
    "drem": ("drem_example.py", ["--observer", "drem"], "drem", []),
}


def _run(capsys, argv, code=0):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert rc == code, cap.err
    return cap


def _frozen(tmp_path, capsys, model, options):
    """The design's JSON, as 'design --json' prints it, in a file."""
    out = _run(capsys, ["design", MODELS / model, *options, "--json"]).out
    path = tmp_path / "design.json"
    path.write_text(out)
    return path


def _scenario(tmp_path, scen):
    if isinstance(scen, Path):
        return scen
    path = tmp_path / "scenario.json"
    path.write_text(json.dumps(SCENARIOS[scen]))
    return path


#: the cases whose design, threshold or reference simulation take more than ~10 s
SLOW = ("bank", "drem", "interval")


@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n
                                  for n in sorted(CASES)])
def test_simulate_with_a_frozen_design_writes_the_same_csv(tmp_path, capsys, name):
    model, options, scen, extra = CASES[name]
    path = _frozen(tmp_path, capsys, model, options)
    scenario = _scenario(tmp_path, scen)
    common = ["--scenario", scenario, "--engine", "reference", *extra]
    first = _run(capsys, ["simulate", MODELS / model, *options, *common, "--out", tmp_path / "a"],
                 code=0)
    again = _run(capsys, ["simulate", MODELS / model, "--observer", options[1], "--design", path,
                          *common, "--out", tmp_path / "b"])
    a = (tmp_path / "a" / "signals.csv").read_bytes()
    assert a == (tmp_path / "b" / "signals.csv").read_bytes()
    # what it prints (the first alarm, the evaluation) is the same but for the folder
    assert first.out.replace(str(tmp_path / "a"), "") == again.out.replace(str(tmp_path / "b"), "")
    assert first.err.replace(str(tmp_path / "a"), "") == again.err.replace(str(tmp_path / "b"), "")


@pytest.mark.parametrize("name", ["unknown-input", "bank", "sliding-mode"])
def test_codegen_with_a_frozen_design_writes_the_same_c(tmp_path, capsys, name):
    model, options, _, extra = CASES[name]
    path = _frozen(tmp_path, capsys, model, options)
    _run(capsys, ["codegen", MODELS / model, *options, *extra, "--out", tmp_path / "a"])
    _run(capsys, ["codegen", MODELS / model, "--observer", options[1], "--design", path, *extra,
                  "--out", tmp_path / "b"])
    files = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert files and files == sorted(p.name for p in (tmp_path / "b").iterdir())
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def _rows(path):
    return list(csv.reader(open(path)))


@pytest.mark.parametrize("name", ["unknown-input", pytest.param("bank", marks=pytest.mark.slow)])
def test_ensemble_with_a_frozen_design_gives_the_same_summary(tmp_path, capsys, name):
    model, options, scen, extra = CASES[name]
    path = _frozen(tmp_path, capsys, model, options)
    common = ["--scenario", _scenario(tmp_path, scen), "--runs", "3", "--engine", "reference",
              "--backend", "serial", "--keep", "0", *extra]
    _run(capsys, ["ensemble", MODELS / model, *options, *common, "--out", tmp_path / "a"])
    _run(capsys, ["ensemble", MODELS / model, "--observer", options[1], "--design", path,
                  *common, "--out", tmp_path / "b"])
    assert _rows(tmp_path / "a" / "summary.csv") == _rows(tmp_path / "b" / "summary.csv")


def test_design_options_beside_the_file_must_agree(tmp_path, capsys):
    model, options, scen, _ = CASES["unknown-input"]
    path = _frozen(tmp_path, capsys, model, options)
    ok = _run(capsys, ["design", MODELS / model, *options, "--design", path])  # they agree
    assert "estimate d" in ok.out
    for bad, names in ((["--observer", "diagnostic"], "--observer diagnostic"),
                       (["--observer", "unknown-input", "--fault", "rho"], "--fault rho"),
                       (["--observer", "unknown-input", "--form", "jordan"], "--form jordan"),
                       (["--observer", "unknown-input", "--isolate"], "--isolate"),
                       (["--observer", "unknown-input", "--structure", "1"], "--structure"),
                       (["--observer", "unknown-input", "--eigenvalues", "1/3"],
                        "--eigenvalues 1/3")):
        err = _run(capsys, ["design", MODELS / model, *bad, "--design", path], code=2).err
        assert err.count("\n") == 1 and names in err and "does not agree" in err, err


def test_a_changed_model_or_a_tampered_file_is_one_line(tmp_path, capsys):
    model, options, scen, _ = CASES["unknown-input"]
    path = _frozen(tmp_path, capsys, model, options)
    other = _run(capsys, ["simulate", MODELS / "three_tank.py", "--observer", "unknown-input",
                          "--design", path, "--scenario", _scenario(tmp_path, "tank"),
                          "--out", tmp_path / "x"], code=2).err
    assert other.count("\n") == 1 and "different model" in other
    assert not (tmp_path / "x").exists()
    data = json.loads(path.read_text())
    data["conditions"].append({"name": "everything fine: trust me", "holds": True})
    path.write_text(json.dumps(data))
    err = _run(capsys, ["codegen", MODELS / model, "--observer", "unknown-input", "--design",
                        path, "--out", tmp_path / "c"], code=2).err
    assert err.count("\n") == 1 and "trust me" in err and not (tmp_path / "c").exists()
    data = json.loads(path.read_text())
    data["conditions"].pop()
    data["observer_conditions"][0]["holds"] = not data["observer_conditions"][0]["holds"]
    path.write_text(json.dumps(data))
    err = _run(capsys, ["design", MODELS / model, "--observer", "unknown-input", "--design",
                        path], code=2).err
    assert err.count("\n") == 1 and "observer condition" in err


def test_a_symbolic_file_is_refused_where_numbers_are_needed(tmp_path, capsys):
    path = _frozen(tmp_path, capsys, "electric_drive.py",
                   ["--observer", "unknown-input", "--fault", "rho", "--symbolic"])
    shown = _run(capsys, ["design", MODELS / "electric_drive.py", "--observer", "unknown-input",
                          "--design", path])
    assert "Ne(k1, 0)" in shown.out
    err = _run(capsys, ["codegen", MODELS / "electric_drive.py", "--observer", "unknown-input",
                        "--design", path, "--out", tmp_path / "c"], code=2).err
    assert err.count("\n") == 1 and "symbolic" in err
