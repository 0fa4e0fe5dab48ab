"""The exported C example reads the file ``observer-cad monitor --data`` reads (t, the
inputs, the outputs) and prints the columns of monitor.csv; its alarms equal the Python
monitor's on the same file, its signals to 1e-12."""
from __future__ import annotations

import csv
import dataclasses
import io
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from observer_cad import Monitor, build_observer, design, design_bank, load_model
from observer_cad.codegen import CompiledMonitorEngine, export_observer
from observer_cad.residuals import ThresholdSpec, decision_rule
from observer_cad.simulation import apply_threshold, declared_envelope, read_table

ROOT = Path(__file__).resolve().parents[2]
RECORDING = ROOT / "examples" / "three_tank_recording.csv"
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")


def _build(paths, tmp_path) -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    exe = tmp_path / "monitor_example"
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Werror", *map(str, paths[::2]), "-lm",
                    "-o", str(exe)], check=True, capture_output=True, text=True, cwd=tmp_path,
                   timeout=300)
    return exe


def _rows(text: str) -> dict:
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], {h: [r[i] for r in rows[1:]] for i, h in enumerate(rows[0])}


def _compare(header, got, table):
    assert tuple(header) == table.order
    for c in table.order:
        if c == "diagnosis":
            assert got[c] == list(table[c])
        elif c in ("alarm", "in_bounds"):
            assert np.array_equal(np.array(got[c], dtype=int), np.asarray(table[c])), c
        else:
            np.testing.assert_allclose(np.array(got[c], dtype=float), np.asarray(table[c]),
                                       rtol=0, atol=1e-12, err_msg=c)


@needs_cc
def test_c_example_equals_the_python_monitor_continuous(tmp_path):
    m = load_model(ROOT / "models" / "three_tank_isolation.py")
    bank = design_bank(m)
    obs = apply_threshold(m, build_observer(m, bank), ThresholdSpec.parse("guaranteed"))
    rule = decision_rule(m, bank, persistence=2)
    data = read_table(RECORDING)
    h = float(data["t"][1] - data["t"][0])
    paths = export_observer(obs, tmp_path, dt=h, rule=rule, envelope=declared_envelope(m))
    exe = _build(paths, tmp_path)
    r = subprocess.run([str(exe), str(RECORDING)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    header, got = _rows(r.stdout)
    for engine in (None, CompiledMonitorEngine(obs)):
        table = Monitor(m, obs, rule=rule, engine=engine).run(data)
        _compare(header, got, table)
    alarm = np.array(got["alarm"], dtype=int)
    t = np.array(got["t"], dtype=float)
    assert alarm[t < 20].sum() == 0 and alarm[-1] == 1 and got["diagnosis"][-1] == "f2"
    # the checks of t: as observer-cad monitor's, exit status 2 naming the line
    lines = RECORDING.read_text().splitlines()
    for name, rows, words in (("gap.csv", lines[:30] + lines[31:], "line 31: t is not regular"),
                              ("back.csv", lines[:30] + [lines[28]] + lines[31:],
                               "line 31: t does not increase"),
                              ("slow.csv", [lines[0]] + [",".join([repr(0.1 * k)] + ln.split(",")[1:])
                                                         for k, ln in enumerate(lines[1:])],
                               "line 3: the sample time 0.1")):
        (tmp_path / name).write_text("\n".join(rows) + "\n")
        r = subprocess.run([str(exe), str(tmp_path / name)], capture_output=True, text=True,
                           timeout=120)
        assert r.returncode == 2 and words in r.stderr, (name, r.stderr)


@needs_cc
def test_c_example_equals_the_python_monitor_discrete_with_envelope(tmp_path):
    m = load_model(ROOT / "models" / "electric_drive_uncertain.py")
    m = dataclasses.replace(m, bounds={**m.bounds, m.inputs[0]: (-1.5, 1.5)})
    d = design(m, observer="diagnostic")
    obs = apply_threshold(m, build_observer(m, d), ThresholdSpec.parse("guaranteed"))
    rule = decision_rule(m, d)
    rng = np.random.default_rng(3)
    n = 300
    t = np.arange(n, dtype=float)
    cols = {"t": t, "u": 2 * np.sin(t / 10), "y2": rng.uniform(-0.5, 0.5, n),
            "y1": np.cumsum(rng.uniform(-0.01, 0.01, n))}
    path = tmp_path / "drive.csv"   # columns in another order than monitor.csv's
    path.write_text("y2,t,u,y1\n" + "".join(
        ",".join(repr(float(cols[c][k])) for c in ("y2", "t", "u", "y1")) + "\n"
        for k in range(n)))
    paths = export_observer(obs, tmp_path, rule=rule, envelope=declared_envelope(m))
    exe = _build(paths, tmp_path)
    r = subprocess.run([str(exe), str(path)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    header, got = _rows(r.stdout)
    table = Monitor(m, obs, rule=rule).run(read_table(path))
    _compare(header, got, table)
    assert 0 < np.sum(table["in_bounds"]) < n and 0 < np.sum(table["alarm"])
    # without t the monitor format is refused; trace still reads it
    path.write_text("y2,u,y1\n1,2,3\n")
    r = subprocess.run([str(exe), str(path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "no column 't'" in r.stderr
    r = subprocess.run([str(exe), str(path), "trace"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.startswith("step,")
