"""``observer-cad monitor``: a recorded CSV in, monitor.csv and monitor.png out, the first
alarm and the diagnosis printed; bad data refused in one line (exit 2, nothing written);
``--data -`` streams rows from stdin and prints each change at once."""
from __future__ import annotations

import csv
import importlib.util
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from observer_cad.cli import main

ROOT = Path(__file__).resolve().parents[2]
TANKS = ROOT / "models" / "three_tank_isolation.py"
DRIVE = ROOT / "models" / "electric_drive_uncertain.py"
RECORDING = ROOT / "examples" / "three_tank_recording.csv"
BANK = ["--observer", "diagnostic", "--isolate", "--threshold", "guaranteed"]


def run(capsys, argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return rc, cap.out, cap.err


def read(path):
    rows = list(csv.DictReader(open(path)))
    return rows


def test_monitor_writes_the_table_and_the_figure(capsys, tmp_path):
    out = tmp_path / "mon"
    rc, so, se = run(capsys, ["monitor", TANKS, *BANK, "--data", RECORDING, "--out", out])
    assert rc == 0, se
    rows = read(out / "monitor.csv")
    assert list(rows[0]) == ["t", "y1", "y2", "y3", "u1", "u2", "r1", "r2", "r3", "r1_lower",
                             "r1_upper", "r2_lower", "r2_upper", "r3_lower", "r3_upper", "alarm",
                             "diagnosis", "in_bounds"]
    assert len(rows) == 601 and (out / "monitor.png").stat().st_size > 1000
    assert all(r["alarm"] == "0" for r in rows if float(r["t"]) < 20)
    assert rows[-1]["diagnosis"] == "f2" and rows[-1]["in_bounds"] == "1"
    assert "sample time h = 0.05 s" in so
    first = [ln for ln in so.splitlines() if ln.startswith("first alarm at t = ")]
    assert first and 20 <= float(first[0].split()[5]) < 21
    assert "diagnosis at the end (t = 30 s): f2" in so
    # no operating envelope: the band of continuous observation says what it leaves out
    assert ("note: this band is that of continuous observation: the sampling at h = 0.05 s"
            " (y and u held over each step) is not covered; declare bounds for every state and"
            " input (the operating envelope; x1 has none)") in so


def _rewrite(src: Path, dst: Path, edit) -> Path:
    lines = src.read_text().splitlines()
    dst.write_text("\n".join(edit(lines)) + "\n")
    return dst


@pytest.mark.parametrize("edit, words", [
    (lambda ls: [ls[0].replace("y2", "level2")] + ls[1:], ["no column 'y2'"]),
    (lambda ls: ls[:5] + [ls[5].replace(ls[5].split(",")[3], "oops")] + ls[6:],
     ["row 5 (line 6)", "'y1'", "oops"]),
    (lambda ls: ls[:9] + [",".join(ls[9].split(",")[:4] + ["", *ls[9].split(",")[5:]])] + ls[10:],
     ["row 9 (line 10)", "'y2'", "empty"]),
    (lambda ls: ls[:3] + [ls[3].replace(ls[3].split(",")[5], "nan")] + ls[4:],
     ["row 3 (line 4)", "'y3'", "NaN"]),
    (lambda ls: ls[:20] + ls[21:], ["row 20 (line 21)", "'t'", "regular"]),
    (lambda ls: ls[:20] + [ls[19]] + ls[21:], ["row 20 (line 21)", "'t'", "does not increase"]),
])
def test_bad_data_one_line_exit_2_nothing_written(capsys, tmp_path, edit, words):
    data = _rewrite(RECORDING, tmp_path / "bad.csv", edit)
    out = tmp_path / "mon"
    rc, so, se = run(capsys, ["monitor", TANKS, *BANK, "--data", data, "--out", out])
    assert rc == 2 and not out.exists()
    assert len(se.strip().splitlines()) == 1, se
    for w in words:
        assert w in se, se


def test_renamed_columns(capsys, tmp_path):
    data = _rewrite(RECORDING, tmp_path / "renamed.csv",
                    lambda ls: [ls[0].replace("t,", "time,").replace("y3", "level3")] + ls[1:])
    out = tmp_path / "mon"
    rc, so, se = run(capsys, ["monitor", TANKS, *BANK, "--data", data, "--out", out,
                              "--column", "t=time", "--column", "y3=level3"])
    assert rc == 0, se
    rc, _, se = run(capsys, ["monitor", TANKS, *BANK, "--data", data, "--out", out,
                             "--column", "z9=level3"])
    assert rc == 2 and "'z9' is neither t nor an input or output" in se


def test_discrete_model_in_seconds_needs_the_sample_time(capsys, tmp_path):
    data = tmp_path / "drive.csv"
    t = np.arange(50) * 0.02
    rows = ["t,u,y1,y2"] + [f"{float(v)!r},{float(np.sin(v))!r},0.0,0.0" for v in t]
    data.write_text("\n".join(rows) + "\n")
    argv = ["monitor", DRIVE, "--observer", "diagnostic", "--threshold", "guaranteed", "--data",
            data, "--out", tmp_path / "mon"]
    rc, _, se = run(capsys, argv)
    assert rc == 2 and "--sample-time 0.02" in se and "discrete-time model steps by 1" in se
    rc, so, se = run(capsys, argv + ["--sample-time", "0.02"])
    assert rc == 0, se
    assert len(read(tmp_path / "mon" / "monitor.csv")) == 50


@pytest.mark.skipif(importlib.util.find_spec("pyarrow") is not None, reason="pyarrow installed")
def test_parquet_without_pyarrow_is_one_line(capsys, tmp_path):
    data = tmp_path / "rec.parquet"
    data.write_bytes(b"PAR1")
    rc, _, se = run(capsys, ["monitor", TANKS, *BANK, "--data", data, "--out", tmp_path / "m"])
    assert rc == 2 and "pyarrow" in se and len(se.strip().splitlines()) == 1


@pytest.mark.slow
def test_streaming_prints_each_change_as_it_happens(tmp_path):
    """Rows written over a pipe with pauses: the alarm line arrives while stdin is still
    open (before the rest is sent), and the files at the end equal those of the file."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = tmp_path / "stream"
    p = subprocess.Popen([sys.executable, "-m", "observer_cad", "monitor", str(TANKS), *BANK,
                          "--data", "-", "--out", str(out)], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                         env=env)
    lines = RECORDING.read_text().splitlines()
    seen = []
    reader = threading.Thread(target=lambda: seen.extend(iter(p.stdout.readline, "")))
    reader.start()
    p.stdin.write(lines[0] + "\n")
    p.stdin.flush()
    cut = 1 + 430   # rows up to t = 21.45: past the fault (t = 20) and its first alarm
    for k in range(1, cut, 50):
        p.stdin.write("\n".join(lines[k:min(k + 50, cut)]) + "\n")
        p.stdin.flush()
        time.sleep(0.05)
    deadline = time.monotonic() + 120
    while not any("alarm, diagnosis f2" in s for s in seen) and time.monotonic() < deadline \
            and p.poll() is None:
        time.sleep(0.1)
    alarmed = [s for s in seen if s.startswith("t = ")]
    assert any("alarm, diagnosis f2" in s for s in alarmed), (seen, p.poll())
    assert p.poll() is None  # still running: stdin is open
    p.stdin.write("\n".join(lines[cut:]) + "\n")
    p.stdin.close()
    assert p.wait(timeout=120) == 0, p.stderr.read()
    reader.join(timeout=10)
    assert float(alarmed[0].split()[2].rstrip(":")) >= 20
    ref = tmp_path / "file"
    assert main(["monitor", str(TANKS), *BANK, "--data", str(RECORDING), "--out", str(ref)]) == 0
    assert (out / "monitor.csv").read_text() == (ref / "monitor.csv").read_text()


@pytest.mark.slow
def test_streaming_bad_row_one_line_nothing_written(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    lines = RECORDING.read_text().splitlines()
    bad = lines[:30] + [lines[30].replace(lines[30].split(",")[4], "x")] + lines[31:]
    r = subprocess.run([sys.executable, "-m", "observer_cad", "monitor", str(TANKS), *BANK,
                        "--data", "-", "--out", str(tmp_path / "m")], input="\n".join(bad) + "\n",
                       capture_output=True, text=True, env=env, cwd=tmp_path)
    assert r.returncode == 2 and not (tmp_path / "m").exists()
    assert "row 30, column 'y2'" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_simulate_flags_noise_beyond_its_declared_bounds(capsys, tmp_path):
    """A scenario drawing the current sensor's noise from ±0.05 against the declared
    ±0.01: a warning line with the first time, and in_bounds = 0 in those rows."""
    import json
    scen = {"steps": 120, "seed": 11, "initial": {"x1": 0, "x2": 0, "x3": 0},
            "signals": {"u": "2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                        "w1": {"uniform": [0, 0.02]},
                        "w2": "Piecewise((0, t < 50), (0.04, True))"}}
    path = tmp_path / "noisy.json"
    path.write_text(json.dumps(scen))
    rc, so, se = run(capsys, ["simulate", DRIVE, "--observer", "diagnostic", "--threshold",
                              "guaranteed", "--scenario", path, "--out", tmp_path / "sim"])
    assert rc == 0, se
    rows = read(tmp_path / "sim" / "signals.csv")
    assert list(rows[0])[-3:] == ["alarm", "diagnosis", "in_bounds"]
    assert [r["in_bounds"] for r in rows] == ["1"] * 50 + ["0"] * 70
    line = [ln for ln in se.splitlines() if "declared bounds" in ln]
    assert len(line) == 1 and "at t = 50 (w2 = 0.04 outside [-0.01, 0.01]); 70 of 120" in line[0]
    # within the bounds: no warning, every row in
    scen["signals"]["w2"] = {"uniform": [-0.01, 0.01]}
    path.write_text(json.dumps(scen))
    rc, so, se = run(capsys, ["simulate", DRIVE, "--observer", "diagnostic", "--threshold",
                              "guaranteed", "--scenario", path, "--out", tmp_path / "sim2"])
    assert rc == 0 and "declared bounds" not in se
    assert {r["in_bounds"] for r in read(tmp_path / "sim2" / "signals.csv")} == {"1"}


@pytest.mark.slow
def test_streaming_terminated_writes_the_rows_read(tmp_path):
    """SIGTERM while rows arrive: the rows read so far are written, nothing lost."""
    import signal
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = tmp_path / "stream"
    p = subprocess.Popen([sys.executable, "-m", "observer_cad", "monitor", str(TANKS), *BANK,
                          "--data", "-", "--out", str(out)], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                         env=env)
    lines = RECORDING.read_text().splitlines()
    p.stdin.write("\n".join(lines[:431]) + "\n")   # up to t = 21.45, past the first alarm
    p.stdin.flush()
    assert p.stdout.readline().startswith("monitoring rows from stdin")
    # the band of the data's h, made once two rows have arrived
    assert p.stdout.readline().startswith("sample time h = 0.05 s (the first two rows")
    assert p.stdout.readline().startswith("t = 20.55: alarm")   # row 412 has been read
    p.send_signal(signal.SIGTERM)
    rc = p.wait(timeout=120)
    assert rc == 143, p.stderr.read()
    rows = read(out / "monitor.csv")
    assert 412 <= len(rows) <= 430
    assert [float(r["t"]) for r in rows] == [float(ln.split(",")[0])
                                             for ln in lines[1:len(rows) + 1]]


def test_the_initial_state_assumption_is_stated(capsys, tmp_path):
    """The observer's initial state rests on plant states nobody measured: the run says
    which were taken as 0; --initial sets them (a wrong x1(0) then shows as an alarm)."""
    base = ["monitor", TANKS, *BANK, "--data", RECORDING, "--out", tmp_path / "m"]
    rc, so, se = run(capsys, base)
    assert rc == 0 and "the observer starts as if x1 = x2 = x3 = 0 at t = 0" in so
    rc, so, se = run(capsys, base + ["--initial", "x1=0.1"])
    assert rc == 0 and "as if x2 = x3 = 0" in so
    assert "first alarm at t = 0 s" in so


@pytest.mark.slow
def test_monitor_runs_a_frozen_design_like_a_fresh_one(capsys, tmp_path):
    """``--design FILE``: the bank saved by ``design --json`` gives the same monitor.csv as
    designing again (the file is recomputed at load, never believed)."""
    rc, so, se = run(capsys, ["design", TANKS, "--observer", "diagnostic", "--isolate", "--json"])
    assert rc == 0, se
    frozen = tmp_path / "bank.json"
    frozen.write_text(so)
    rc, _, se = run(capsys, ["monitor", TANKS, *BANK, "--data", RECORDING, "--out",
                             tmp_path / "fresh"])
    assert rc == 0, se
    rc, _, se = run(capsys, ["monitor", TANKS, "--observer", "diagnostic", "--threshold",
                             "guaranteed", "--design", frozen, "--data", RECORDING, "--out",
                             tmp_path / "frozen"])
    assert rc == 0, se
    assert (tmp_path / "frozen" / "monitor.csv").read_bytes() == \
        (tmp_path / "fresh" / "monitor.csv").read_bytes()
    # a changed model is refused in one line, nothing written
    changed = _rewrite(TANKS, tmp_path / "changed.py",
                       lambda ls: [ln.replace("-x1 + x2 + u1", "-2 * x1 + x2 + u1") for ln in ls])
    rc, _, se = run(capsys, ["monitor", changed, "--observer", "diagnostic", "--threshold",
                             "guaranteed", "--design", frozen, "--data", RECORDING, "--out",
                             tmp_path / "bad"])
    assert rc == 2 and len(se.strip().splitlines()) == 1 and "different model" in se, se
    assert not (tmp_path / "bad").exists()


MOTOR = ROOT / "models" / "dc_motor_sampled.py"
MOTOR_DATA = ROOT / "examples" / "dc_motor_sampled.csv"
MOTOR_BAND = ["--observer", "diagnostic", "--lambda=-4", "--threshold", "guaranteed"]


def test_stream_makes_the_sampled_band_from_its_first_two_rows(capsys, tmp_path, monkeypatch):
    """A continuous-time model with an operating envelope gets the sampled-data band of the
    data's own sample time: a stream makes it once its first two rows give h = t1 − t0 (not
    the continuous band, which false-alarms on this recording), and writes the file's
    monitor.csv."""
    import io
    monkeypatch.setattr(sys, "stdin", io.StringIO(MOTOR_DATA.read_text()))
    rc, so, se = run(capsys, ["monitor", MOTOR, *MOTOR_BAND, "--data", "-", "--out",
                              tmp_path / "m", "--engine", "reference"])
    assert rc == 0, se
    assert "sample time h = 0.01 s (the first two rows" in so
    assert "sampled algorithm at h = 0.01 (RK4)" in so and "no alarm in 501 samples" in so
    rc, _, se = run(capsys, ["monitor", MOTOR, *MOTOR_BAND, "--data", MOTOR_DATA, "--out",
                             tmp_path / "f", "--engine", "reference"])
    assert rc == 0, se
    assert (tmp_path / "m" / "monitor.csv").read_text() == \
        (tmp_path / "f" / "monitor.csv").read_text()


@pytest.mark.parametrize("edit, words", [
    (lambda lines: lines[:2], "one row: the guaranteed band is that of the data's sample time"),
    (lambda lines: lines[:3] + [lines[3].replace(lines[3].split(",")[0], "0.0200001", 1)]
     + lines[4:], "steps of exactly h = 0.01; the interval before t = 0.0200001 (row 3)"),
])
def test_stream_with_a_sampled_band_refuses_in_one_line(capsys, tmp_path, monkeypatch, edit,
                                                         words):
    import io
    lines = MOTOR_DATA.read_text().splitlines()
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n".join(edit(lines)) + "\n"))
    rc, _, se = run(capsys, ["monitor", MOTOR, *MOTOR_BAND, "--data", "-", "--out",
                             tmp_path / "m", "--engine", "reference"])
    assert rc == 2 and len(se.strip().splitlines()) == 1 and words in se, se
    assert not (tmp_path / "m").exists()


@pytest.mark.slow
def test_exported_c_runs_the_sampled_band_of_its_step(capsys, tmp_path):
    """codegen's band is the sampled one of the RK4 step the C runs (--dt, 0.01 s, the
    recording's interval): the compiled example raises exactly the monitor's alarms (none)
    on the true continuous plant's recording."""
    rc, so, se = run(capsys, ["monitor", MOTOR, *MOTOR_BAND, "--data", MOTOR_DATA, "--out",
                              tmp_path / "mon"])
    assert rc == 0 and "sampled algorithm at h = 0.01" in so, so
    rc, _, se = run(capsys, ["codegen", MOTOR, *MOTOR_BAND, "--out", tmp_path / "c"])
    assert rc == 0, se
    srcs = sorted(str(p) for p in (tmp_path / "c").glob("*.c"))
    r = subprocess.run(["cc", "-std=c99", "-O1", *srcs, "-lm", "-o", str(tmp_path / "ex")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    out = subprocess.run([str(tmp_path / "ex"), str(MOTOR_DATA)], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    c_rows = list(csv.DictReader(out.stdout.splitlines()))
    py_rows = read(tmp_path / "mon" / "monitor.csv")
    assert len(c_rows) == len(py_rows) == 501
    assert [r["alarm"] for r in c_rows] == [r["alarm"] for r in py_rows] == ["0"] * 501
    for name in ("r", "r_lower", "r_upper"):
        assert np.allclose([float(r[name]) for r in c_rows], [float(r[name]) for r in py_rows],
                           rtol=0, atol=1e-12), name


def test_a_sampled_band_needs_exactly_regular_samples(capsys, tmp_path):
    """Jitter the regularity check tolerates (0.05 % of h) still voids a band computed for
    steps of exactly h: refused in one line naming the row, nothing written."""
    def jitter(lines):
        cells = lines[100].split(",")
        cells[0] = repr(float(cells[0]) + 5e-6)
        return lines[:100] + [",".join(cells)] + lines[101:]
    data = _rewrite(MOTOR_DATA, tmp_path / "jitter.csv", jitter)
    rc, _, se = run(capsys, ["monitor", MOTOR, *MOTOR_BAND, "--data", data, "--out",
                             tmp_path / "m"])
    assert rc == 2 and len(se.strip().splitlines()) == 1 and "exactly" in se, se
    assert "row 100" in se or "row 101" in se, se
    assert not (tmp_path / "m").exists()


def test_codegen_says_when_its_band_leaves_the_sampling_out(capsys, tmp_path):
    """The exported C steps a continuous-time observer at --dt: without an operating
    envelope its guaranteed band is that of continuous observation, and codegen says so;
    with one (models/dc_motor_sampled.py) the band is the sampled-data one, no note."""
    rc, so, se = run(capsys, ["codegen", TANKS, *BANK, "--out", tmp_path / "c1"])
    assert rc == 0, se
    assert "note: this band is that of continuous observation: the sampling at h = 0.01 s" in so
    motor = ROOT / "models" / "dc_motor_sampled.py"
    rc, so, se = run(capsys, ["codegen", motor, "--observer", "diagnostic", "--lambda=-4",
                              "--threshold", "guaranteed", "--out", tmp_path / "c2"])
    assert rc == 0, se
    assert "note:" not in so and "wrote" in so


DRAIN = '''
import sympy as sp
from observer_cad import PlantModel
x1, x2, u, f, w1, w2 = sp.symbols("x1 x2 u f w1 w2")
model = PlantModel(
    name="drain", time="continuous", states=[x1, x2], inputs=[u], faults=[f],
    noise=[w1, w2], outputs=[x1 + w1, x2 + w2],
    dynamics=[x2, -sp.sqrt(x1 + 1) - x2 + u + f],
    bounds={x1: (LOW, 1), x2: (-2, 2), u: (-1, 2), f: (-1, 1), w1: (-0.01, 0.01),
            w2: (-0.01, 0.01)})
'''


def test_a_nonlinear_plant_gets_the_sampled_band_or_one_line(capsys, tmp_path):
    """A nonlinear plant with its envelope: the sampled-data band where every term has a
    finite bound over it (x1 ≥ −1/2: a square root the band of continuous observation does
    not take); where the drain's slope is unbounded (x1 = −1 in the envelope) one line,
    exit 2, nothing written."""
    import numpy as np
    t = np.arange(0, 2.001, 0.01)
    data = tmp_path / "data.csv"
    np.savetxt(data, np.column_stack([t, 1 + 0 * t, 0 * t, 0 * t]), delimiter=",",
               header="t,u,y1,y2", comments="")
    for low, sampled in (("-1", False), ("-0.5", True)):
        path = tmp_path / f"drain{low}.py"
        path.write_text(DRAIN.replace("LOW", low))
        out = tmp_path / f"mon{low}"
        rc, so, se = run(capsys, ["monitor", path, "--observer", "diagnostic", "--threshold",
                                  "guaranteed", "--data", data, "--out", out])
        if sampled:
            assert rc == 0, se
            assert "threshold: guaranteed threshold of the sampled algorithm at h = 0.01" in so
            assert "note:" not in so
        else:
            assert rc == 2 and se.count("\n") == 1 and se.startswith("observer-cad: error:")
            assert "no sampled-data band" in se and "no finite bound" in se
            assert not out.exists()
