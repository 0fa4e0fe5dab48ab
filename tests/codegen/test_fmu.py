"""FMI 2.0 co-simulation export (export_fmu, ``codegen --fmu``), validated with FMPy.

* fmpy.validation of the model description; the variables (inputs y, u; outputs,
  bands, alarms, diagnosis code with its names; tunable parameters, fixed initial
  state; DefaultExperiment stepSize = the sample time);
* fmpy.simulate_fmu on recorded input data (a CSV written from a simulation, read with
  fmpy.util.read_csv): the FMU's outputs equal the Python reference run (reference_run:
  the step function stepped in Python, then decide) sample by sample, to 1e-12 for
  signals and exactly for alarms and codes — discrete time (the drive, guaranteed bands),
  continuous time (the three-tank bank, RK4 and exact ZOH, thresholds as inputs; the
  sliding-mode observer with a tuned parameter), a master step of half the sample time;
* the exported C example agrees with the same reference (compare_columns reused);
* the wrapper compiles against the standard's headers (FMPy's copies) with
  -Wall -Wextra -Werror; names that are not FMI names are mapped and documented; a
  missing C compiler is one line; a failed build leaves an existing FMU as it was.
Tested: FMI 2.0 and FMI 3.0 co-simulation (FMPy 0.3.x validation and simulation).
"""
from __future__ import annotations

import dataclasses
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings, strategies as st

from observer_cad.codegen import (EXAMPLE_FLAGS, compare_columns, export_fmu, export_observer,
                                  fmi_variable_name, fmu_samples, read_csv_columns,
                                  reference_run)
from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.residuals import ThresholdSpec, decision_rule
from observer_cad.simulation import apply_threshold, scenario_from_dict, simulate
from observer_cad.synthesis import design
from observer_cad.analysis import design_bank

fmpy = pytest.importorskip("fmpy")
import fmpy.util  # noqa: E402
from fmpy.util import read_csv  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler 'cc' on PATH")
pytestmark = needs_cc


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path_factory.getbasetemp() / "occache"))
    monkeypatch.delenv("CC", raising=False)


@pytest.fixture(scope="module")
def drive():
    """The drive's residual with guaranteed bands (discrete time), and a run with a fault."""
    m = load_model(ROOT / "models" / "electric_drive.py")
    d = design(m, observer="diagnostic")
    o = apply_threshold(m, build_observer(m, d), ThresholdSpec.parse("guaranteed"))
    sc = scenario_from_dict({"steps": 300, "seed": 4, "initial": {"x1": 0.1},
                             "signals": {"u": "sin(t/10)",
                                         "d": "Piecewise((0, t < 150), (0.02, True))",
                                         "rho": {"uniform": [-0.05, 0.05]},
                                         "w1": {"uniform": [-0.01, 0.01]},
                                         "w2": {"uniform": [-0.01, 0.01]}}})
    return m, d, o, simulate(m, o, sc)


@pytest.fixture(scope="module")
def bank():
    """The three-tank isolation bank (continuous time, no bands: thresholds are inputs)."""
    m = load_model(ROOT / "models" / "three_tank_isolation.py")
    b = design_bank(m, structure="011,101,110")
    o = build_observer(m, b)
    sc = scenario_from_dict({"t_end": 3, "dt": 0.01, "seed": 1,
                             "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
                             "signals": {"u1": 1, "u2": 0.5, "rho": {"uniform": [-0.2, 0.2]},
                                         "w1": {"uniform": [-0.02, 0.02]},
                                         "w2": {"uniform": [-0.02, 0.02]},
                                         "w3": {"uniform": [-0.02, 0.02]},
                                         "f3": "Piecewise((0, t < 1.5), (0.6, True))"}})
    return m, b, o, simulate(m, o, sc)


def write_csv(path: Path, columns: dict, ts: float, *, time: str = "time") -> Path:
    """A recorded-input CSV: ``time`` = k·Ts, then the columns (repr: exact doubles; NaN
    written as an empty cell is not what FMPy reads, so NaN as 'nan')."""
    names = list(columns)
    n = len(next(iter(columns.values())))
    lines = [",".join([time] + names)]
    for k in range(n):
        lines.append(",".join([repr(k * ts)] + [repr(float(columns[c][k])) for c in names]))
    path.write_text("\n".join(lines) + "\n")
    return path


def run_fmu(fmu, csv_path: Path, n: int, *, step=None, start_values=None):
    """simulate_fmu over n samples with the recorded inputs; the result array."""
    signals = read_csv(str(csv_path))
    step = fmu.sample_time if step is None else step
    return fmpy.simulate_fmu(str(fmu.path), input=signals, stop_time=n * fmu.sample_time,
                             output_interval=step, output=[v.name for v in fmu.outputs],
                             start_values=start_values or {})


@pytest.mark.parametrize("version", ["2.0", "3.0"])
def test_drive_fmu_validates_and_equals_the_reference(drive, version, tmp_path):
    m, d, o, res = drive
    rule = decision_rule(m, d, persistence=2)
    fmu = export_fmu(o, tmp_path, rule=rule, sample_time=0.01, initial={"x1": 0.1},
                     fmi_version=version)
    assert validate_fmu(str(fmu.path)) == []
    md = fmpy.read_model_description(str(fmu.path))
    assert md.fmiVersion == version and md.coSimulation is not None
    assert md.defaultExperiment.stepSize == "0.01" or float(md.defaultExperiment.stepSize) == 0.01
    var = {v.name: v for v in md.modelVariables}
    assert [n for n, v in var.items() if v.causality == "input"] == ["y1", "y2", "u"]
    assert {"r", "r_lower", "r_upper", "r_alarm", "alarm", "diagnosis_code"} <= {
        n for n, v in var.items() if v.causality == "output"}
    assert var["diagnosis_code"].type == ("Integer" if version == "2.0" else "Int32")
    assert var["alarm"].type == "Boolean"
    for k, text in enumerate(rule.table()):
        assert f"{k} = {text}" in var["diagnosis_code"].description
    starts = [n for n, v in var.items() if v.causality == "parameter"]
    assert starts == [f"{x}_start" for x in o.states]
    assert all(var[s].variability == "fixed" for s in starts)
    n = res["t"].size
    cols = {c: np.asarray(res[c], dtype=float) for c in ("y1", "y2", "u")}
    ref = reference_run(o, cols, rule=rule, initial={"x1": 0.1})
    assert 0 < ref["alarm"].sum() < n                       # some alarms, not all
    result = run_fmu(fmu, write_csv(tmp_path / "in.csv", cols, 0.01), n)
    got = fmu_samples(result, fmu, n)
    cmp = compare_columns(ref, got, columns=["r", "r_lower", "r_upper", "r_alarm", "alarm",
                                             "diagnosis_code"])
    assert cmp.ok, cmp.summary()
    from_file = fmu_samples(result, fmu.path, n)         # names and types read from the FMU
    assert compare_columns(got, from_file, require_all=True).ok
    assert from_file["alarm"].dtype == bool
    # the same through FMPy's CSV (Booleans written True/False)
    fmpy.util.write_csv(str(tmp_path / "fmu.csv"), result)
    from_csv = {k: v[1:] for k, v in read_csv_columns(tmp_path / "fmu.csv").items()}
    assert compare_columns(ref, from_csv, columns=["r", "r_alarm", "alarm",
                                                   "diagnosis_code"]).ok
    # the reference is the Python simulation's observer, up to rounding
    assert np.allclose(ref["r"], res["r"], rtol=0, atol=1e-12)


def test_the_c_example_agrees_with_the_same_reference(drive, tmp_path):
    m, d, o, res = drive
    rule = decision_rule(m, d, persistence=2)
    paths = export_observer(o, tmp_path, rule=rule, initial={"x1": 0.1})
    r = subprocess.run(["cc", *EXAMPLE_FLAGS, paths[0].name, paths[2].name, "-lm", "-o", "ex"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    cols = {c: np.asarray(res[c], dtype=float) for c in ("y1", "y2", "u")}
    # the example reads the monitor's CSV: t (steps of a discrete model), then the signals
    write_csv(tmp_path / "in.csv", cols, 1, time="t")
    with open(tmp_path / "out.csv", "w") as fh:
        p = subprocess.run(["./ex", "in.csv", "trace"], cwd=tmp_path, stdout=fh,
                           stderr=subprocess.PIPE,
                           text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    got = read_csv_columns(tmp_path / "out.csv")
    ref = reference_run(o, cols, rule=rule, initial={"x1": 0.1})
    cmp = compare_columns(ref, got, require_all=True)
    assert cmp.ok, cmp.summary()
    assert set(cmp.columns) >= {"r", "r_alarm", "alarm", "diagnosis_code", "diagnosis",
                                *map(str, o.states)}
    # a changed cell is found, with its sample
    got["diagnosis"] = got["diagnosis"].copy()
    got["diagnosis"][7] = "d"
    assert compare_columns(ref, got).mismatches == ("diagnosis: sample 7: 'd', reference"
                                                    " 'no fault'",)


@pytest.mark.slow
@pytest.mark.parametrize("discretisation, version", [("rk4", "2.0"), ("zoh", "2.0"),
                                                     ("rk4", "3.0")])
def test_continuous_bank_with_threshold_inputs(bank, discretisation, version, tmp_path):
    m, b, o, res = bank
    rule = decision_rule(m, b, persistence=3)
    fmu = export_fmu(o, tmp_path, dt=0.01, rule=rule, discretisation=discretisation,
                     fmi_version=version)
    assert validate_fmu(str(fmu.path)) == []
    assert [v.name for v in fmu.inputs] == ["y1", "y2", "y3", "u1", "u2"] + [
        f"{r}_{s}" for r in rule.residuals for s in ("lower", "upper")]
    assert np.isnan(fmu.variable("r1_lower").start)      # not set: not out
    n = res["t"].size
    cols = {c: np.asarray(res[c], dtype=float) for c in ("y1", "y2", "y3", "u1", "u2")}
    for r in rule.residuals:
        cols[f"{r}_lower"] = np.full(n, -0.03)
        cols[f"{r}_upper"] = np.full(n, 0.03)
    ref = reference_run(o, cols, dt=0.01, rule=rule, discretisation=discretisation)
    assert "f3" in set(rule.table()[c] for c in ref["diagnosis_code"])   # f3 isolated
    got = fmu_samples(run_fmu(fmu, write_csv(tmp_path / "in.csv", cols, 0.01), n), fmu, n)
    cmp = compare_columns(ref, got, require_all=False)
    assert cmp.ok, cmp.summary()
    assert {"r1", "r2", "r3", "r1_alarm", "alarm", "diagnosis_code"} <= set(cmp.columns)


def test_master_step_of_half_the_sample_time(bank, tmp_path):
    """Samples only at t_start + k·Ts: with h = Ts/2 every second step takes none and
    the outputs are held."""
    m, b, o, res = bank
    rule = decision_rule(m, b, persistence=1)
    fmu = export_fmu(o, tmp_path, dt=0.01, rule=rule)
    n = 120
    cols = {c: np.asarray(res[c][:n], dtype=float) for c in ("y1", "y2", "y3", "u1", "u2")}
    for r in rule.residuals:
        cols[f"{r}_lower"] = np.full(n, -0.02)
        cols[f"{r}_upper"] = np.full(n, 0.02)
    ref = reference_run(o, cols, dt=0.01, rule=rule)
    result = run_fmu(fmu, write_csv(tmp_path / "in.csv", cols, 0.01), n, step=0.005)
    assert len(result) == 2 * n + 1
    at_samples = fmu_samples(result[0::2], fmu, n)     # rows at t = (k+1)·Ts: sample k
    cmp = compare_columns(ref, at_samples)
    assert cmp.ok and "alarm" in cmp.columns, cmp.summary()
    between = {v.source: np.asarray(result[v.name][1::2]) for v in fmu.outputs}
    cmp = compare_columns(ref, between)                 # rows at (k + 1/2)·Ts: still k
    assert cmp.ok and "alarm" in cmp.columns, cmp.summary()


def test_master_step_of_two_sample_times(bank, tmp_path):
    """h = 2 Ts: two samples per step, both with the inputs set at its start (held)."""
    m, b, o, res = bank
    rule = decision_rule(m, b, persistence=2)
    fmu = export_fmu(o, tmp_path, dt=0.01, rule=rule)
    n = 120
    cols = {c: np.asarray(res[c][:n], dtype=float) for c in ("y1", "y2", "y3", "u1", "u2")}
    for r in rule.residuals:
        cols[f"{r}_lower"] = np.full(n, -0.02)
        cols[f"{r}_upper"] = np.full(n, 0.02)
    result = run_fmu(fmu, write_csv(tmp_path / "in.csv", cols, 0.01), n, step=0.02)
    assert len(result) == n // 2 + 1
    held = {c: np.repeat(v[0::2], 2) for c, v in cols.items()}
    ref = reference_run(o, held, dt=0.01, rule=rule)
    odd = {c: v[1::2] for c, v in ref.items()}          # the row at 2(j+1)·Ts: sample 2j+1
    cmp = compare_columns(odd, fmu_samples(result, fmu))
    assert cmp.ok and "diagnosis_code" in cmp.columns, cmp.summary()


@settings(max_examples=60, deadline=None)
@given(st.text(max_size=12))
def test_fmi_variable_names_are_identifiers(text):
    name = fmi_variable_name(text)
    assert re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name)
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", text):
        assert name == text                              # valid names are kept


def test_sliding_mode_parameters_are_tunable(tmp_path):
    m = load_model(ROOT / "models" / "sliding_example.py")
    o = build_observer(m, design(m, observer="sliding-mode", faults=["d"]))
    assert {str(p) for p in o.parameters} == {"k_sm", "eps_sm"}
    fmu = export_fmu(o, tmp_path, dt=0.005)
    assert validate_fmu(str(fmu.path)) == []
    k = fmu.variable("k_sm")
    assert (k.causality, k.variability, k.start) == ("parameter", "tunable", 2.14)
    rng = np.random.default_rng(7)
    n = 200
    t = np.arange(n) * 0.005
    cols = {"y1": np.sin(t) + rng.uniform(-0.01, 0.01, n), "y2": 0.5 * np.cos(2 * t),
            "u1": np.ones(n), "u2": np.sin(3 * t)}
    path = write_csv(tmp_path / "in.csv", cols, 0.005)
    for start in ({}, {"k_sm": 3.5}):
        ref = reference_run(o, cols, dt=0.005, parameters=start)
        got = fmu_samples(run_fmu(fmu, path, n, start_values=start), fmu, n)
        cmp = compare_columns(ref, got, require_all=False)
        assert cmp.ok and set(cmp.columns) == {"d_hat", "r"}, cmp.summary()
    assert not np.allclose(reference_run(o, cols, dt=0.005)["d_hat"], ref["d_hat"])


@pytest.mark.slow
@pytest.mark.parametrize("version, with_rule", [("2.0", True), ("3.0", True), ("2.0", False),
                                               ("3.0", False)])
def test_wrapper_compiles_against_the_standard_headers(drive, version, with_rule, tmp_path):
    """-Wall -Wextra -Werror (and -pedantic), with and without decisions (no always-false
    comparison when a range of value references is empty)."""
    m, d, o, res = drive
    fmu = export_fmu(o, tmp_path, rule=decision_rule(m, d) if with_rule else None,
                     fmi_version=version)
    with zipfile.ZipFile(fmu.path) as z:
        names = set(z.namelist())
        z.extractall(tmp_path / "x")
    N = fmu.name
    assert {"modelDescription.xml", f"sources/{N}.c", f"sources/{N}.h", f"sources/{N}_fmu.c",
            f"binaries/{fmu.platform}/{N}.so", "documentation/index.html"} <= names
    headers = Path(fmpy.__file__).parent / "c-code"
    v = version[0]
    assert (headers / f"fmi{v}Functions.h").is_file()
    src = tmp_path / "x" / "sources"
    for extra in ([f"-DOBSERVER_CAD_FMI{v}_HEADERS", f"-I{headers}"], []):
        r = subprocess.run(["cc", *EXAMPLE_FLAGS, "-pedantic", "-fPIC", "-shared", *extra, f"{N}.c",
                            f"{N}_fmu.c", "-lm", "-o", "lib.so"], cwd=src,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0 and r.stderr == "", r.stderr
    # only the FMI functions are exported from the binary
    nm = shutil.which("nm")
    if nm:
        r = subprocess.run([nm, "-D", "--defined-only",
                            str(tmp_path / "x" / "binaries" / fmu.platform / f"{N}.so")],
                           capture_output=True, text=True)
        syms = {ln.split()[-1] for ln in r.stdout.splitlines() if " T " in ln}
        assert syms and all(s.startswith(f"fmi{v}") for s in syms), sorted(syms)
        if version == "3.0":   # every function of the FMI 3.0 API (FMPy loads them all)
            declared = set(re.findall(r"#define (fmi3\w+) +fmi3FullName",
                                      (headers / "fmi3Functions.h").read_text()))
            assert len(declared) > 60 and declared <= syms, sorted(declared - syms)


def test_names_that_are_not_fmi_names_are_mapped(drive, tmp_path):
    m, d, o, res = drive
    o2 = dataclasses.replace(o, outputs=o.outputs + (("ξ hat", sp.Float(1.5)),
                                                     ("alarm", sp.Float(2.0)),
                                                     ("2nd", sp.Float(3.0))))
    fmu = export_fmu(o2, tmp_path, rule=decision_rule(m, d))
    assert validate_fmu(str(fmu.path)) == []
    ren = dict(fmu.renamed)
    assert ren["ξ hat"] == "xi_hat" and ren["2nd"] == "_2nd"
    assert fmu.variable("alarm").type == "Real" and fmu.variable("alarm").name == "alarm"
    assert [v.name for v in fmu.variables if v.source == "alarm" and v.type == "Boolean"] == [
        "alarm_2"]
    assert "observer name 'ξ hat'" in fmu.variable("ξ hat").description
    with zipfile.ZipFile(fmu.path) as z:
        doc = z.read("documentation/index.html").decode()
    assert "ξ hat &rarr; xi_hat" in doc and "alarm &rarr; alarm_2" in doc
    assert fmi_variable_name("a.b[1]") == "a_b_1_" and fmi_variable_name("") == "_"


@pytest.mark.slow
def test_missing_compiler_is_one_line_and_nothing_is_written(drive, tmp_path, monkeypatch):
    m, d, o, res = drive
    monkeypatch.setenv("CC", "no-such-cc")
    with pytest.raises(UsageError, match=r"^fmu: C compiler 'no-such-cc' not found") as e:
        export_fmu(o, tmp_path / "out")
    assert "\n" not in str(e.value)
    assert not (tmp_path / "out").exists()
    env = dict(os.environ, CC="no-such-cc", PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-m", "observer_cad", "codegen",
                        str(ROOT / "models" / "electric_drive.py"), "--observer", "diagnostic",
                        "--fmu", "--out", str(tmp_path / "cli")], capture_output=True,
                       text=True, env=env, timeout=600)
    assert p.returncode == 2
    assert p.stderr.count("\n") == 1 and "C compiler 'no-such-cc' not found" in p.stderr
    assert not (tmp_path / "cli").exists()


def test_a_failed_build_leaves_the_old_fmu(drive, tmp_path, monkeypatch):
    m, d, o, res = drive
    fmu = export_fmu(o, tmp_path)
    before = fmu.path.read_bytes()
    again = export_fmu(o, tmp_path)                     # reproducible: same archive
    assert again.path.read_bytes() == before and again.guid == fmu.guid
    monkeypatch.setenv("CC", "false")                   # a "compiler" that fails
    with pytest.raises(Exception, match="compiling the FMU's binary failed"):
        export_fmu(o, tmp_path)
    assert fmu.path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [fmu.path.name]


@pytest.mark.slow
@pytest.mark.parametrize("version", ["2.0", "3.0"])
def test_cli_codegen_fmu(version, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("CC", None)
    p = subprocess.run([sys.executable, "-m", "observer_cad", "codegen",
                        str(ROOT / "models" / "electric_drive.py"), "--observer", "diagnostic",
                        "--threshold", "0.05", "--persistence", "2", "--dt", "0.001", "--fmu",
                        "--fmi-version", version, "--out", str(tmp_path)],
                       capture_output=True, text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    N = "electric_drive_diagnostic"
    assert p.stdout.splitlines() == [f"wrote {tmp_path / N}{s}" for s in
                                     (".c", ".h", "_example.c", ".fmu")]
    assert validate_fmu(str(tmp_path / f"{N}.fmu")) == []
    md = fmpy.read_model_description(str(tmp_path / f"{N}.fmu"))
    assert md.fmiVersion == version and float(md.defaultExperiment.stepSize) == 0.001
    assert {"r_alarm", "alarm", "diagnosis_code", "r_lower", "r_upper"} <= {
        v.name for v in md.modelVariables if v.causality == "output"}


def test_fmi_calls_directly(drive, tmp_path, capfd):
    """The FMI 2.0 calls a master makes: outputs held between samples (no direct
    feedthrough), the fixed initial state, errors logged by the FMU."""
    from fmpy import extract
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave
    m, d, o, res = drive
    rule = decision_rule(m, d, persistence=1)
    fmu = export_fmu(o, tmp_path, rule=rule)
    md = fmpy.read_model_description(str(fmu.path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu.path)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="m")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    x0 = [vr[f"{x}_start"] for x in o.states]
    slave.setReal(x0, [0.0] * len(x0))
    slave.setReal([vr["y1"], vr["y2"], vr["u"]], [1.0, 0.0, 0.0])
    preview = slave.getReal([vr["r"]])[0]
    slave.exitInitializationMode()
    assert slave.getReal([vr["r"]])[0] == preview
    slave.setReal([vr["y1"]], [5.0])                     # no direct feedthrough: held
    assert slave.getReal([vr["r"]])[0] == preview
    slave.doStep(0.0, 1.0)                               # sample 0 with y1 = 5
    ref = reference_run(o, {"y1": [5.0], "y2": [0.0], "u": [0.0]}, rule=rule,
                        x0=[0.0] * len(o.states))
    assert slave.getReal([vr["r"]])[0] == pytest.approx(ref["r"][0], abs=1e-15)
    assert slave.getBoolean([vr["alarm"]])[0] == bool(ref["alarm"][0])
    assert slave.getInteger([vr["diagnosis_code"]])[0] == int(ref["diagnosis_code"][0])
    with pytest.raises(FMICallException):
        slave.setReal(x0[:1], [1.0])                     # fixed after initialization
    with pytest.raises(FMICallException):
        slave.setReal([vr["r"]], [1.0])                  # an output
    out = capfd.readouterr().out
    assert "initial state is fixed after initialization" in out
    assert "not an input or parameter" in out
    slave.terminate()
    slave.freeInstance()


def test_cli_fmi_version_needs_fmu(tmp_path, capsys):
    from observer_cad.cli import main
    code = main(["codegen", str(ROOT / "models" / "electric_drive.py"), "--observer",
                 "diagnostic", "--fmi-version", "3.0", "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert code == 2 and err == "observer-cad: error: --fmi-version applies with --fmu\n"
    assert not (tmp_path / "c").exists()
    with pytest.raises(UsageError, match="FMI version must be one of 2.0, 3.0"):
        export_fmu(build_observer(load_model(ROOT / "models" / "electric_drive.py"),
                                  design(load_model(ROOT / "models" / "electric_drive.py"),
                                         observer="diagnostic")),
                   tmp_path, fmi_version="1.0")


def test_unknown_input_estimate_with_its_delay(tmp_path):
    """The drive's estimator of d (an output delayed by one sample, no decisions)."""
    m = load_model(ROOT / "models" / "electric_drive.py")
    o = build_observer(m, design(m, observer="unknown-input", faults=["d"]))
    fmu = export_fmu(o, tmp_path)
    assert validate_fmu(str(fmu.path)) == []
    assert fmu.variable("d_hat").description.endswith("(the estimate for sample k - 1)")
    assert [v.type for v in fmu.variables if v.causality == "output"] == ["Real"]
    rng = np.random.default_rng(3)
    n = 150
    cols = {"y1": rng.uniform(-1, 1, n), "y2": rng.uniform(-1, 1, n),
            "u": 0.2 * np.sin(np.arange(n) / 10)}
    got = fmu_samples(run_fmu(fmu, write_csv(tmp_path / "in.csv", cols, 1.0), n), fmu, n)
    cmp = compare_columns(reference_run(o, cols), got)
    assert cmp.ok and cmp.columns == ("d_hat",), cmp.summary()


def test_reference_run_is_the_step_function_row_by_row():
    """reference_run (accumulated over chunks of rows) = observer_step called per row, bit
    for bit, across a chunk boundary; with a tuned parameter."""
    from observer_cad.codegen import observer_step
    m = load_model(ROOT / "models" / "sliding_example.py")
    o = build_observer(m, design(m, observer="sliding-mode", faults=["d"]))
    rng = np.random.default_rng(11)
    n = 1100
    cols = {c: rng.uniform(-1, 1, n) for c in ("y1", "y2", "u1", "u2")}
    ref = reference_run(o, cols, dt=0.005, parameters={"eps_sm": 0.01}, x0=[0.25])
    f = observer_step(o, h=0.005)
    p = [float(o.parameters[s]) if str(s) != "eps_sm" else 0.01 for s in o.parameters]
    x = np.array([0.25])
    for k in range(n):
        assert ref["xs1"][k] == x[0]
        xn, out = f(x, [cols["y1"][k], cols["y2"][k]], [cols["u1"][k], cols["u2"][k]], p)
        assert [ref[name][k] for name in o.output_names] == list(np.asarray(out).ravel())
        x = np.asarray(xn).ravel()


def test_fmu_on_simulate_signals_csv(tmp_path, monkeypatch, capsys):
    """The command-line path: `observer-cad simulate` writes signals.csv, `codegen --fmu`
    the FMU; FMPy runs the FMU on the CSV's y/u columns. Its residual, bands and alarms
    equal the reference run and the simulation's own columns (to 1e-12, alarms exactly)."""
    from observer_cad.cli import main
    monkeypatch.chdir(tmp_path)
    common = [str(ROOT / "models" / "electric_drive.py"), "--observer", "diagnostic",
              "--threshold", "guaranteed"]
    assert main(["simulate", *common, "--scenario",
                 str(ROOT / "models" / "scenarios" / "electric_drive_diagnostic.json"),
                 "--out", "sim"]) == 0
    assert main(["codegen", *common, "--fmu", "--out", "c"]) == 0
    capsys.readouterr()
    sim = read_csv_columns("sim/signals.csv")
    n = sim["t"].size
    assert np.array_equal(sim["t"], np.arange(n))              # discrete: t = k, Ts = 1
    inp = np.rec.fromarrays([sim[c] for c in ("t", "y1", "y2", "u")], names="time,y1,y2,u")
    result = fmpy.simulate_fmu("c/electric_drive_diagnostic.fmu", input=inp,
                               stop_time=sim["t"][-1] + 1)
    got = fmu_samples(result, "c/electric_drive_diagnostic.fmu", n)   # types from the file
    assert got["alarm"].dtype == bool and got["diagnosis_code"].dtype == np.int64
    assert 0 < got["alarm"].sum() < n
    cmp = compare_columns(sim, got, columns=["r", "r_lower", "r_upper", "alarm"])
    assert cmp.ok, cmp.summary()
    assert list(got["diagnosis_code"]) == [1 if d == "d" else 0 for d in sim["diagnosis"]]


@pytest.mark.slow
def test_fmu_equals_the_monitor_on_the_recorded_example(tmp_path, monkeypatch, capsys):
    """The FMU of the monitor example, run by FMPy on the recorded data
    (examples/three_tank_recording.csv), gives ``observer-cad monitor``'s monitor.csv: the
    residuals and their bands to 1e-12, the alarms exactly."""
    from observer_cad.cli import main
    monkeypatch.chdir(tmp_path)
    model = str(ROOT / "models" / "three_tank_isolation.py")
    recording = ROOT / "examples" / "three_tank_recording.csv"
    common = [model, "--observer", "diagnostic", "--isolate", "--threshold", "guaranteed"]
    assert main(["monitor", *common, "--data", str(recording), "--out", "mon"]) == 0
    assert main(["codegen", *common, "--dt", "0.05", "--fmu", "--out", "c"]) == 0
    capsys.readouterr()
    mon = read_csv_columns(tmp_path / "mon" / "monitor.csv")
    n = mon["t"].size
    fmu_path = next((tmp_path / "c").glob("*.fmu"))
    md = fmpy.read_model_description(str(fmu_path))
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert float(md.defaultExperiment.stepSize) == 0.05
    cols = {c: mon[c] for c in inputs}
    signals = read_csv(str(write_csv(tmp_path / "in.csv", cols, 0.05)))
    result = fmpy.simulate_fmu(str(fmu_path), input=signals, stop_time=n * 0.05,
                               output_interval=0.05, output=outputs)
    got = fmu_samples(result, fmu_path, n)
    bands = [c for c in mon if c.startswith("r") and c[1:2].isdigit()]
    assert {"r1", "r1_lower", "r1_upper"} <= set(bands)
    cmp = compare_columns(mon, got, columns=[*bands, "alarm"])
    assert cmp.ok, cmp.summary()
    assert 0 < np.asarray(got["alarm"], dtype=bool).sum() < n   # the fault at t = 20 is seen
