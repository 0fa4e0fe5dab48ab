"""``--threshold`` on the command line: the CSV's r_lower/r_upper,
alarm and diagnosis columns, the summary lines, the exported C computing the same bands and
decisions as the Python simulation, and one-line refusals."""
from __future__ import annotations

import csv
import io
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from observer_cad.cli import main

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
UNCERTAIN = str(MODELS / "electric_drive_uncertain.py")
DRIVE = str(MODELS / "electric_drive.py")
BANK = str(MODELS / "three_tank_isolation.py")


def run(capsys, argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return rc, cap.out, cap.err


def read_csv(path):
    rows = list(csv.DictReader(open(path)))
    return {k: [r[k] for r in rows] for k in rows[0]}


def test_simulate_guaranteed_writes_alarm_and_diagnosis(capsys, tmp_path):
    rc, out, err = run(capsys, ["simulate", UNCERTAIN, "--observer", "diagnostic", "--threshold",
                                "guaranteed", "--scenario",
                                MODELS / "scenarios" / "electric_drive_uncertain.json",
                                "--out", tmp_path])
    assert rc == 0, err
    assert "columns: t, x1, x2, x3, y1, y2, u, d, rho, r, r_lower, r_upper, alarm, diagnosis" in out
    assert "fault (d) from t = 100: detected after 1 steps; false alarms before it: 0 samples;" \
           " diagnosis at the end: d" in out
    c = read_csv(tmp_path / "signals.csv")
    r, lo, hi = (np.array(c[k], dtype=float) for k in ("r", "r_lower", "r_upper"))
    # the widest band before the fault (t < 100) over the dc gain Φ D / (1 − λ) = 10
    width = float(np.max((hi - lo)[np.array(c["t"], dtype=float) < 100]))
    assert 0.3 < width < 0.5
    assert f"(band width on the fault-free part of this run / dc gain): d ≥ {width / 10:.3g}" in out
    alarm = np.array(c["alarm"], dtype=int)
    assert np.array_equal(alarm, ((r < lo) | (r > hi)).astype(int))
    assert not alarm[:100].any() and alarm[101:].all()
    assert set(c["diagnosis"][:100]) == {"no fault"} and set(c["diagnosis"][101:]) == {"d"}
    assert (tmp_path / "residuals.png").is_file()


def test_persistence_delays_the_alarm(capsys, tmp_path):
    rc, out, err = run(capsys, ["simulate", UNCERTAIN, "--observer", "diagnostic", "--threshold",
                                "guaranteed", "--persistence", "3", "--scenario",
                                MODELS / "scenarios" / "electric_drive_uncertain.json",
                                "--out", tmp_path])
    assert rc == 0, err
    assert "detected after 3 steps" in out  # out from t = 101, alarm at the third sample out
    assert "persistence 3" in out


def test_bank_constant_threshold_isolates(capsys, tmp_path):
    rc, out, err = run(capsys, ["simulate", BANK, "--observer", "diagnostic", "--isolate",
                                "--threshold", "0.05", "--scenario",
                                MODELS / "scenarios" / "three_tank_isolation.json", "--out", tmp_path])
    assert rc == 0, err
    c = read_csv(tmp_path / "signals.csv")
    assert {"r1_lower", "r3_upper", "alarm", "diagnosis"} <= set(c)
    assert float(c["r2_upper"][0]) == 0.05
    assert c["diagnosis"][-1] == "f2"
    assert "constant threshold: |r1| ≤ 0.05" in out


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler 'cc' on PATH")
def test_exported_c_computes_the_same_bands_and_decisions(capsys, tmp_path):
    """codegen --threshold guaranteed --persistence 2: the standalone C, run on the y/u columns
    of the Python simulation, reproduces r, r_lower, r_upper (to 1e-12) and the alarm and
    diagnosis columns exactly."""
    sc = {"steps": 300, "seed": 3, "signals": {
        "u": "0.2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
        "w1": {"uniform": [-0.01, 0.01]}, "w2": {"uniform": [-0.01, 0.01]},
        "d": "Piecewise((0, t < 150), (0.05*sin(t/5), True))"}}
    sp_ = tmp_path / "sc.json"
    sp_.write_text(json.dumps(sc))
    rc, out, err = run(capsys, ["simulate", DRIVE, "--observer", "diagnostic", "--threshold",
                                "guaranteed", "--persistence", "2", "--scenario", sp_,
                                "--out", tmp_path / "sim"])
    assert rc == 0, err
    rc, out, err = run(capsys, ["codegen", DRIVE, "--observer", "diagnostic", "--threshold",
                                "guaranteed", "--persistence", "2", "--out", tmp_path / "c"])
    assert rc == 0, err
    cdir = tmp_path / "c"
    srcs = sorted(str(p) for p in cdir.glob("*.c"))
    exe = cdir / "monitor"
    subprocess.run(["cc", "-std=c99", "-O2", *srcs, "-lm", "-o", str(exe)], check=True,
                   capture_output=True, timeout=300)
    p = subprocess.run([str(exe), str(tmp_path / "sim" / "signals.csv")], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    rows = list(csv.reader(io.StringIO(p.stdout)))
    got = {h: [r[i] for r in rows[1:]] for i, h in enumerate(rows[0])}
    ref = read_csv(tmp_path / "sim" / "signals.csv")
    for k in ("r", "r_lower", "r_upper"):
        np.testing.assert_allclose(np.array(got[k], dtype=float), np.array(ref[k], dtype=float),
                                   rtol=0, atol=1e-12)
    alarm = np.array(ref["alarm"], dtype=int)
    assert 0 < alarm.sum() < alarm.size  # some alarms, not all: a meaningful comparison
    assert np.array_equal(np.array(got["alarm"], dtype=int), alarm)
    assert got["diagnosis"] == ref["diagnosis"]


def test_design_prints_the_threshold_conditions(capsys):
    rc, out, err = run(capsys, ["design", UNCERTAIN, "--observer", "diagnostic",
                                "--threshold", "guaranteed", "--initial-error", "0.1"])
    assert rc == 0, err
    assert "[ ok ] comparison system stable" in out
    assert "k5 ∈ [594/625, 606/625] (nominal 24/25)" in out
    assert "|e_i(0)| ≤ 1/10" in out
    assert "xs1_ehi(t+1) = " in out


@pytest.mark.parametrize("argv, message", [
    (["simulate", DRIVE, "--observer", "diagnostic", "--persistence", "2"],
     "--persistence applies with --threshold"),
    (["simulate", DRIVE, "--observer", "diagnostic", "--threshold", "quantile:7"],
     r"--threshold quantile:7: the false-alarm rate must lie in \(0, 1\)"),
    (["simulate", DRIVE, "--observer", "diagnostic", "--threshold", "open('x')"],
     "use guaranteed, quantile:RATE or a positive number"),
    (["simulate", DRIVE, "--observer", "diagnostic", "--initial-error", "0.1"],
     "--initial-error applies to --threshold guaranteed"),
    (["simulate", DRIVE, "--observer", "unknown-input", "--fault", "d", "--threshold",
      "guaranteed"], "has no residual output"),
])
def test_threshold_refusals_are_one_line(capsys, tmp_path, argv, message):
    scen = MODELS / "scenarios" / "electric_drive_diagnostic.json"
    rc, out, err = run(capsys, argv + ["--scenario", scen, "--out", tmp_path / "o"])
    assert rc == 2
    assert len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
    assert not (tmp_path / "o").exists()


def test_codegen_quantile_needs_a_scenario(capsys, tmp_path):
    rc, out, err = run(capsys, ["codegen", DRIVE, "--observer", "diagnostic", "--threshold",
                                "quantile:0.01", "--out", tmp_path / "c"])
    assert rc == 2 and "give --scenario FILE" in err
