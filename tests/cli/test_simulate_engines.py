"""``observer-cad simulate`` runs the compiled engine by default; the
reference simulator stays available (``--engine reference``) and both write the same CSV;
``--case`` / ``--run`` replay one run of an ensemble."""
from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from observer_cad.cli import main

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")

SCEN = {"steps": 150, "seed": 4,
        "initial": {"x1": {"uniform": [-0.1, 0.1]}},
        "parameters": {"k5": "declared"},
        "signals": {"u": "2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                    "w1": {"normal": [0.01, 0.003]}, "w2": {"uniform": [-0.01, 0.01]}},
        "cases": {"fault-free": {}, "d step": {"d": "Piecewise((0, t < 100), (0.2, True))"}}}


def run(capsys, argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return rc, cap.out, cap.err


def read(path):
    rows = list(csv.DictReader(open(path)))
    return {k: np.array([float(r[k]) if r[k] else np.nan for r in rows]) for k in rows[0]}


@pytest.fixture
def scenario(tmp_path):
    p = tmp_path / "sc.json"
    p.write_text(json.dumps(SCEN))
    return p


@needs_cc
def test_compiled_default_and_reference_write_the_same_csv(capsys, tmp_path, scenario):
    base = ["simulate", MODELS / "electric_drive_uncertain.py", "--observer", "diagnostic",
            "--scenario", scenario, "--case", "d step", "--run", "3"]
    rc, out, err = run(capsys, base + ["--out", tmp_path / "c"])
    assert rc == 0, err
    assert "compiled C" in out
    rc, out, err = run(capsys, base + ["--engine", "reference", "--out", tmp_path / "r"])
    assert rc == 0, err
    assert "reference simulator (numpy)" in out
    c, r = read(tmp_path / "c" / "signals.csv"), read(tmp_path / "r" / "signals.csv")
    assert list(c) == list(r)
    for k in c:
        np.testing.assert_allclose(c[k], r[k], rtol=1e-12, atol=1e-13, err_msg=k)
    assert np.max(np.abs(c["r"][c["t"] >= 101])) > 0.05  # the fault case is simulated


@needs_cc
def test_run_and_case_select_the_ensemble_sample(capsys, tmp_path, scenario):
    base = ["simulate", MODELS / "electric_drive_uncertain.py", "--observer", "diagnostic",
            "--scenario", scenario]
    outs = {}
    for label, extra in (("a", ["--run", "0"]), ("b", ["--run", "1"]),
                         ("c", ["--run", "1", "--case", "fault-free"])):
        rc, out, err = run(capsys, base + extra + ["--out", tmp_path / label])
        assert rc == 0, err
        outs[label] = read(tmp_path / label / "signals.csv")
    assert not np.array_equal(outs["a"]["rho"], outs["b"]["rho"])
    # the first case is the default: runs 1 of the default and of "fault-free" are one run
    for k in outs["b"]:
        np.testing.assert_array_equal(outs["b"][k], outs["c"][k])


def test_bad_case_and_run_are_one_line_errors(capsys, tmp_path, scenario):
    base = ["simulate", MODELS / "electric_drive_uncertain.py", "--observer", "diagnostic",
            "--scenario", scenario, "--out", tmp_path]
    rc, out, err = run(capsys, base + ["--case", "nope"])
    assert rc == 2 and "no case 'nope'" in err and len(err.strip().splitlines()) == 1
    rc, out, err = run(capsys, base + ["--run", "-1"])
    assert rc == 2 and "--run -1: must be ≥ 0" in err


@needs_cc
def test_lhs_replay_needs_the_ensembles_size(capsys, tmp_path):
    """With a Latin hypercube a run's draws depend on the ensemble's size: --run needs
    --samples, and then gives the ensemble's sample."""
    from observer_cad.ensemble import Backend, run_ensemble
    from observer_cad.model import load_model
    from observer_cad.observers import build_observer
    from observer_cad.simulation import load_scenario
    from observer_cad.synthesis import design
    p = tmp_path / "lhs.json"
    p.write_text(json.dumps({**{k: v for k, v in SCEN.items() if k != "cases"},
                             "sampling": "lhs"}))
    base = ["simulate", MODELS / "electric_drive_uncertain.py", "--observer", "diagnostic",
            "--scenario", p, "--run", "7"]
    rc, out, err = run(capsys, base + ["--out", tmp_path / "a"])
    assert rc == 2 and "give --samples N" in err
    rc, out, err = run(capsys, base + ["--samples", "20", "--out", tmp_path / "b"])
    assert rc == 0, err
    m = load_model(MODELS / "electric_drive_uncertain.py")
    o = build_observer(m, design(m, observer="diagnostic"))
    ens = run_ensemble(m, o, load_scenario(p), runs=20, backend=Backend("serial"), keep=0)
    cols = ens.accumulator.columns()
    csv_r = read(tmp_path / "b" / "signals.csv")["r"]
    assert float(np.max(np.abs(csv_r))) == cols["r.max_abs"][7]
