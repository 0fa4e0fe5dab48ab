"""Standalone C export (observer_cad.codegen.export): NAME.c, NAME.h, NAME_example.c.

The exported files are compiled with exactly ``cc -std=c99 -Wall -Wextra -Werror NAME.c
NAME_example.c -lm``; the example is run on an input CSV holding the y and u columns of
a reference simulation (observer_cad.simulate.simulate) and its printed trajectory
(``%.17g``) is compared with the Python path to 1e-12 relative (per column, relative to
the column's largest magnitude, as in tests/test_codegen.py):

* the interpreted casadi observer step (observer_step) iterated from Python on the same
  inputs (every case) and the compiled one (continuous cases);
* the reference simulator's observer outputs (discrete cases, where the observer alone
  on the recorded y, u is exactly what the simulator runs; delayed outputs shifted).

In continuous time the reference simulator integrates plant and observer jointly (the
observer reads y inside the RK4 stages) while the exported observer holds the sampled
y, u over a step, as it must when embedded: there the Python reference is observer_step.
"""
from __future__ import annotations

import csv
import ctypes
import io
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

casadi = pytest.importorskip("casadi")

from observer_cad.codegen import compile_function, observer_step
from observer_cad.codegen import EXAMPLE_FLAGS, export_observer, export_sources, silence_unused_parameters
from observer_cad.codegen import split_signals
from observer_cad.reporting import write_signals_csv
from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.simulation import scenario_from_dict, simulate
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "models" / "scenarios"
RTOL = 1e-12
CC = shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")
VALGRIND = shutil.which("valgrind")

TANK = {"initial": {"x1": 3, "x2": 2, "x3": 1},
        "signals": {"u1": "0.5+0.1*sin(t)", "u2": 0.3, "rho1": {"uniform": [-0.05, 0.05]},
                    "w1": {"uniform": [-0.01, 0.01]}, "w2": {"uniform": [-0.01, 0.01]}}}
DRIVE = {"steps": 400, "initial": {"x1": 0.1, "x3": 0.2},
         "signals": {"u": "sin(t/10)", "d": "Piecewise((0, t < 200), (0.2, True))",
                     "rho": {"uniform": [-0.05, 0.05]}, "w1": {"uniform": [-0.01, 0.01]},
                     "w2": {"uniform": [-0.01, 0.01]}}}

# kind: model file, design kwargs, scenario, dt baked into the export (None: dt= argument)
CASES = {
    "diagnostic": ("electric_drive.py", dict(observer="diagnostic"), DRIVE, None),
    "virtual-sensor": ("three_tank.py", dict(observer="virtual-sensor", estimate="x1"),
                       {**TANK, "t_end": 4, "dt": 0.01, "observer_initial": {"xs1": 2.5}}, 0.01),
    "unknown-input": ("electric_drive.py", dict(observer="unknown-input", faults=["d"]),
                      DRIVE, None),
    "interval": ("three_tank.py", dict(observer="interval", estimate="x1"),
                 {**TANK, "t_end": 4, "dt": 0.02}, "arg"),
    "interval-linear": ("three_tank_linear.py", dict(observer="interval", estimate="x1"),
                        {"t_end": 5, "dt": 0.05, "initial": {"x1": 1},
                         "signals": {"u1": "0.2*sin(t)", "rho": {"uniform": [-0.2, 0.2]},
                                     "w1": {"uniform": [-0.02, 0.02]}}}, 0.05),
    # the sliding-mode estimator (Abs, regularised sign, parameters k_sm, eps_sm) on the
    # paper-style scenario, cut after the fault has appeared (t = 5)
    "sliding-mode": ("sliding_example.py", dict(observer="sliding-mode", faults=["d"]),
                     {**{k: v for k, v in json.loads((SCEN / "sliding_example.json")
                                                     .read_text()).items()
                         if k != "description"}, "t_end": 7}, 0.001),
    # exact zero-order hold of the canonical interval observer (linear three-tank)
    "interval-canonical-zoh": ("three_tank_linear.py",
                               dict(observer="interval", estimate="x1", form="canonical",
                                    eigenvalues=["-1", "-2"]),
                               {**{k: v for k, v in json.loads(
                                   (SCEN / "three_tank_linear_interval.json").read_text())
                                   .items() if k != "description"}, "t_end": 8}, 0.01),
}
#: continuous cases exported with another discretisation than RK4
DISC = {"interval-canonical-zoh": "zoh"}


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path_factory.getbasetemp() / "occache"))


@pytest.fixture(scope="module")
def built():
    out = {}
    for kind, (path, kw, scd, dt) in CASES.items():
        m = load_model(ROOT / "models" / path)
        o = build_observer(m, design(m, **kw))
        sc = scenario_from_dict(scd)
        out[kind] = (m, o, sc, simulate(m, o, sc), dt)
    return out


def _close(a, b, rtol=RTOL):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (a.shape, b.shape)
    scale = max(float(np.max(np.abs(a))) if a.size else 0.0, 1e-300)
    err = float(np.max(np.abs(a - b))) / scale if a.size else 0.0
    assert err <= rtol, f"relative error {err:.3g} > {rtol}"
    return err


def _build(paths, cwd):
    """Compile exactly as documented:
    cc -std=c99 -Wall -Wextra -Werror NAME.c NAME_example.c -lm."""
    c, _, ex = paths
    cmd = ["cc", *EXAMPLE_FLAGS, c.name, ex.name, "-lm"]
    assert cmd[1:5] == ["-std=c99", "-Wall", "-Wextra", "-Werror"]
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", r.stderr          # not even a note
    return cwd / "a.out"


def _input_csv(o, res, path):
    ys, us = split_signals(o)
    names = [str(s) for s in ys + us]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    for i in range(res["t"].shape[0]):
        w.writerow([repr(float(res[n][i])) for n in names])
    path.write_text(buf.getvalue())
    return np.column_stack([res[n] for n in names])


def _run(exe, args, cwd, valgrind=False):
    cmd = [str(exe), *args, "trace"]   # step, states, outputs (not the monitor format)
    if valgrind:
        cmd = [VALGRIND, "-q", "--error-exitcode=1", "--leak-check=full", *cmd]
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=600)
    return r


def _parse(stdout):
    rows = list(csv.reader(io.StringIO(stdout)))
    return rows[0], np.array([[float(v) for v in row] for row in rows[1:]])


def _python_path(f, o, sig, x0, h):
    """The observer step (casadi Function) iterated from Python on the recorded signals."""
    ny = len(split_signals(o)[0])
    p = [float(v) for v in o.parameters.values()]
    x = np.array(x0, float)
    X, OUT = [], []
    for row in sig:
        args = [x, row[:ny], row[ny:], p] + ([h] if f.n_in() == 5 else [])
        xn, out = f(*args)
        X.append(x)
        OUT.append(np.array(out, float).ravel())
        x = np.array(xn, float).ravel()
    return np.array(X), np.array(OUT)


def _initial_symbols(o):
    """The (plant) symbols the observer's initial state depends on."""
    syms = set()
    for v in o.initial.values():
        syms |= sp.sympify(v).free_symbols
    return sorted(syms, key=str)


def _observer_x0(o, sc):
    """The observer's initial state as the reference simulator computes it."""
    xs = {s: float(sc.initial.get(s.name, 0.0)) for s in _initial_symbols(o)}
    oinit = dict(sc.observer_initial or {})
    return [float(oinit[str(s)]) if str(s) in oinit
            else float(sp.sympify(o.initial.get(s, 0)).xreplace(xs)) for s in o.states]


# ------------------------------------------------------------------ parity
@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("kind", [  # the sliding-mode run takes ~2.5 s: slow step
    pytest.param(c, marks=pytest.mark.slow) if c == "sliding-mode" else c for c in CASES])
def test_example_reproduces_python_path(kind, built, tmp_path):
    m, o, sc, ref, dt = built[kind]
    h = float(sc.dt) if o.time == "continuous" else None
    x0 = _observer_x0(o, sc)
    # the plant's initial values the observer's initial state depends on are baked in
    initial = {s.name: float(sc.initial.get(s.name, 0.0)) for s in _initial_symbols(o)}
    if sc.observer_initial:
        initial.update(sc.observer_initial)
    disc = DISC.get(kind, "rk4")
    paths = export_observer(o, tmp_path, dt=h if dt not in (None, "arg") else None,
                            initial=initial or None, discretisation=disc)
    assert [p.name for p in paths] == [f"{o.name}.c", f"{o.name}.h", f"{o.name}_example.c"]
    assert not list(tmp_path.glob(".*.tmp"))
    exe = _build(paths, tmp_path)
    sig = _input_csv(o, ref, tmp_path / "in.csv")
    args = ["in.csv"] + ([f"dt={h!r}"] if dt == "arg" else [])
    r = _run(exe, args, tmp_path)
    assert r.returncode == 0, r.stderr
    header, data = _parse(r.stdout)
    xs = [str(s) for s in o.states]
    assert header == ["step"] + xs + list(o.output_names)
    N = ref["t"].shape[0]
    assert data.shape == (N, 1 + len(xs) + len(o.output_names))
    np.testing.assert_array_equal(data[:, 0], np.arange(N))
    Xc, Oc = data[:, 1:1 + len(xs)], data[:, 1 + len(xs):]
    np.testing.assert_array_equal(Xc[0], x0)
    # interpreted casadi, same step (baked dt or h argument as exported)
    f = observer_step(o, h=h if dt not in (None, "arg") else None, discretisation=disc)
    Xp, Op = _python_path(f, o, sig, x0, h)
    _close(Xp, Xc)
    _close(Op, Oc)
    if o.time == "continuous":
        fc = compile_function(f).function
        Xq, Oq = _python_path(fc, o, sig, x0, h)
        _close(Xq, Xc)
        _close(Oq, Oc)
    else:
        # discrete: the reference simulator runs exactly this recursion
        for j, name in enumerate(o.output_names):
            k = int(o.delays.get(name, 0))
            want = ref[name]
            got = Oc[:, j]
            if k:
                want, got = want[:-k], got[k:]   # printed raw: row t estimates step t - k
                assert np.all(np.isnan(ref[name][-k:]))
            _close(want, got)


@needs_cc
def test_example_reads_simulator_csv_with_extra_columns_and_overrides(built, tmp_path):
    """The simulator's own signals.csv (t, states, y, inputs, outputs) works as input:
    columns are found by name; x0= and p= override the baked-in values."""
    m, o, sc, ref, _ = built["unknown-input"]
    csv_path = write_signals_csv(ref, tmp_path / "sim")
    paths = export_observer(o, tmp_path, name="uio")   # initial state with x1 = x3 = 0
    exe = _build(paths, tmp_path)
    x0 = _observer_x0(o, sc)
    r = _run(exe, [str(csv_path), "x0=" + ",".join(repr(v) for v in x0)], tmp_path)
    assert r.returncode == 0, r.stderr
    _, data = _parse(r.stdout)
    _close(ref["d_hat"][:-1], data[1:, -1])
    # other parameters: the same as the Python step with those parameters
    p = [float(v) * 1.5 for v in o.parameters.values()]
    r2 = _run(exe, [str(csv_path), "p=" + ",".join(repr(v) for v in p)], tmp_path)
    assert r2.returncode == 0, r2.stderr
    _, d2 = _parse(r2.stdout)
    f = observer_step(o)
    ys, us = split_signals(o)
    x = np.array(d2[0, 1:1 + len(o.states)])
    for i in range(20):
        xn, out = f(x, [ref[str(s)][i] for s in ys], [ref[str(s)][i] for s in us], p)
        _close(np.array(out, float).ravel(), d2[i, 1 + len(o.states):])
        x = np.array(xn, float).ravel()
        _close(x, d2[i + 1, 1:1 + len(o.states)])


@needs_cc
def test_step_wrapper_and_work_sizes(built, tmp_path):
    """NAME_step (work vectors on the stack) equals the casadi Function; the header's
    work-vector sizes are the Function's sz_arg/sz_res/sz_iw/sz_w and bound NAME_work()."""
    m, o, sc, ref, _ = built["interval"]
    paths = export_observer(o, tmp_path, name="ival")     # h is an argument
    src = export_sources(o, name="ival")
    f = src.function
    h_text = paths[1].read_text()
    for key, val in (("SZ_ARG", f.sz_arg()), ("SZ_RES", f.sz_res()), ("SZ_IW", f.sz_iw()),
                     ("SZ_W", f.sz_w())):
        assert f"#define ival_{key} {val}\n" in h_text
    for what in ("x ", "y ", "u ", "p ", "h ", "x_next", "out "):
        assert f"  {what}" in h_text
    lib_path = tmp_path / "libival.so"
    r = subprocess.run(["cc", *EXAMPLE_FLAGS, "-shared", "-fPIC", "-o", str(lib_path),
                        str(paths[0]), "-lm"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    lib = ctypes.CDLL(str(lib_path))
    szs = [ctypes.c_longlong() for _ in range(4)]
    assert lib.ival_work(*[ctypes.byref(s) for s in szs]) == 0
    assert [s.value for s in szs][:2] == [f.sz_arg(), f.sz_res()]
    assert all(s.value <= b for s, b in zip(szs, (f.sz_arg(), f.sz_res(), f.sz_iw(), f.sz_w())))
    D = ctypes.POINTER(ctypes.c_double)
    lib.ival_step.argtypes = [D, D, D, D, ctypes.c_double, D, D]
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = rng.uniform(1, 3, 2)
        y = rng.uniform(0.5, 2, 2)
        u = rng.uniform(0, 1, 2)
        p = np.zeros(1)
        xn, out = np.empty(2), np.empty(2)
        ptr = lambda a: a.ctypes.data_as(D)  # noqa: E731
        assert lib.ival_step(ptr(x), ptr(y), ptr(u), ptr(p), 0.05, ptr(xn), ptr(out)) == 0
        want = f(x, y, u, [], 0.05)
        _close(np.array(want[0], float).ravel(), xn)
        _close(np.array(want[1], float).ravel(), out)


# ------------------------------------------------------------------ valgrind
@pytest.mark.slow  # valgrind runs, 1–3 s each
@needs_cc
@pytest.mark.skipif(VALGRIND is None, reason="valgrind not installed (apt-get install -y"
                    " valgrind); the exported example is not checked for memory errors")
@pytest.mark.parametrize("kind", ["diagnostic", "virtual-sensor", "interval", "sliding-mode",
                                  "interval-canonical-zoh"])
def test_example_runs_clean_under_valgrind(kind, built, tmp_path):
    m, o, sc, ref, dt = built[kind]
    h = float(sc.dt) if o.time == "continuous" else None
    paths = export_observer(o, tmp_path, dt=h if dt not in (None, "arg") else None,
                            discretisation=DISC.get(kind, "rk4"))
    exe = _build(paths, tmp_path)
    _input_csv(o, ref, tmp_path / "in.csv")
    args = ["in.csv"] + ([f"dt={h!r}"] if dt == "arg" else [])
    r = _run(exe, args, tmp_path, valgrind=True)
    assert r.returncode == 0, r.stderr
    plain = _run(exe, args, tmp_path)
    assert plain.stdout == r.stdout
    # error paths free what they allocated too
    (tmp_path / "bad.csv").write_text("y1,zz\n1,2\n")
    r = _run(exe, ["bad.csv"] + args[1:], tmp_path, valgrind=True)
    assert r.returncode == 2 and "has no column" in r.stderr


# ------------------------------------------------------------------ errors and files
@needs_cc
def test_example_rejects_bad_input(built, tmp_path):
    m, o, sc, ref, _ = built["diagnostic"]
    exe = _build(export_observer(o, tmp_path, name="diag"), tmp_path)
    (tmp_path / "a.csv").write_text("y1,y2\n1,2\n")
    r = _run(exe, ["a.csv"], tmp_path)
    assert r.returncode == 2 and "no column 'u'" in r.stderr
    (tmp_path / "b.csv").write_text("u,y2,y1\n1,2,x\n")
    r = _run(exe, ["b.csv"], tmp_path)
    assert r.returncode == 2 and "line 2: column 'y1' is not a number" in r.stderr
    (tmp_path / "c.csv").write_text("u,y2,y1\n1,2\n")
    r = _run(exe, ["c.csv"], tmp_path)
    assert r.returncode == 2 and "too few columns" in r.stderr
    r = _run(exe, ["nonexistent.csv"], tmp_path)
    assert r.returncode == 2 and "cannot open" in r.stderr
    r = _run(exe, ["a.csv", "x0=1,2"], tmp_path)
    assert r.returncode == 2 and "x0= needs 1" in r.stderr
    r = _run(exe, ["a.csv", "dt=0.1"], tmp_path)       # discrete: no dt option
    assert r.returncode == 2 and "unknown argument" in r.stderr
    # columns in another order, CRLF line ends, blank lines: same result
    (tmp_path / "d.csv").write_text("u,y2,y1\r\n1,2,3\r\n\r\n0.5,0.25,1\r\n")
    r = _run(exe, ["d.csv"], tmp_path)
    assert r.returncode == 0, r.stderr
    _, data = _parse(r.stdout)
    f = observer_step(o)
    x1, out0 = f([0.0], [3, 2], [1], [])
    assert data[0, 2] == float(out0) and data[1, 1] == float(x1)
    # continuous export with h as an argument needs dt=
    m2, o2, *_ = built["interval"]
    sub = tmp_path / "ival"
    exe2 = _build(export_observer(o2, sub), sub)
    (sub / "in.csv").write_text("y1,y2,u1,u2\n1,1,1,1\n")
    r = _run(exe2, ["in.csv"], sub)
    assert r.returncode == 2 and "dt=H is required" in r.stderr
    r = _run(exe2, ["in.csv", "dt=-1"], sub)
    assert r.returncode == 2 and "dt must be a positive number" in r.stderr


def test_export_arguments_are_checked(built, tmp_path):
    m, o, *_ = built["diagnostic"]
    with pytest.raises(UsageError, match="dt applies to continuous-time"):
        export_observer(o, tmp_path, dt=0.1)
    # (int, a__b and _a compiled to a C error or a casadi assertion: an audit)
    for bad in ("2bad-name", "casadi_f0", "int", "double", "a__b", "_a"):
        with pytest.raises(UsageError, match="not a name casadi and C accept"):
            export_observer(o, tmp_path, name=bad)
    with pytest.raises(UsageError, match="needs an Observer"):
        export_observer(m, tmp_path)
    m2, o2, *_ = built["virtual-sensor"]
    for bad in (0, -0.1, float("nan"), "x"):
        with pytest.raises(UsageError, match="dt must be"):
            export_observer(o2, tmp_path, dt=bad)
    m3, o3, *_ = built["unknown-input"]
    with pytest.raises(UsageError, match="initial value for 'zz'"):
        export_observer(o3, tmp_path, initial={"zz": 1})
    assert not list(tmp_path.iterdir())       # nothing written on an error


def test_files_written_atomically_and_documented(built, tmp_path):
    m, o, *_ = built["unknown-input"]
    out = tmp_path / "new" / "dir"
    paths = export_observer(o, out, name="uio", initial={"x1": 0.5, "x3": 0.1})
    assert all(p.is_file() for p in paths)
    assert sorted(p.name for p in out.iterdir()) == ["uio.c", "uio.h", "uio_example.c"]
    h = paths[1].read_text()
    assert "Delay: out 'd_hat' (index 0) at step t is the estimate for step t - 1." in h
    assert "uio_x0 = [0.0, 2.0, 0.0, 0.0, 0.0, 0.0]" in h      # x1 + 5 x3 -+ 1
    assert "alpha_eps" in h and "#define uio_NP 4" in h
    assert h.isascii() and paths[0].read_text().isascii() and paths[2].read_text().isascii()
    assert '#include "uio.h"' in paths[0].read_text()
    # rewriting replaces the files whole (same content: same bytes), no temporaries left
    before = [p.read_bytes() for p in paths]
    export_observer(o, out, name="uio", initial={"x1": 0.5, "x3": 0.1})
    assert [p.read_bytes() for p in paths] == before
    assert sorted(p.name for p in out.iterdir()) == ["uio.c", "uio.h", "uio_example.c"]


def test_silence_unused_parameters():
    src = ("static int f(const double** arg, double* w, int mem) {\n  return 0;\n}\n"
           "int g(void) {\n  return 1;\n}\n"
           "  if (x) {\n"
           "casadi_real casadi_sq(casadi_real x) { return x*x;}\n")
    out = silence_unused_parameters(src)
    assert "static int f(const double** arg, double* w, int mem) {\n  (void)arg; (void)w;" \
           " (void)mem;\n" in out
    assert "int g(void) {\n  return 1;" in out
    assert "  if (x) {\n" in out and "(void)x" not in out


def test_zoh_export_documents_the_matrices_and_checks_arguments(built, tmp_path):
    m, o, sc, ref, dt = built["interval-canonical-zoh"]
    src = export_sources(o, name="ivz", dt=0.01, discretisation="zoh")
    assert "exact zero-order hold" in src.h and "Ad    = e^(A dt)" in src.h
    assert "#define ivz_DT 0.01   /* the step size baked in (exact ZOH) */" in src.h
    with pytest.raises(UsageError, match="needs dt"):
        export_sources(o, discretisation="zoh")
    with pytest.raises(UsageError, match="must be one of"):
        export_sources(o, dt=0.01, discretisation="euler")
    m2, o2, *_ = built["sliding-mode"]
    with pytest.raises(UsageError, match="affine in its states"):
        export_observer(o2, tmp_path, dt=0.001, discretisation="zoh")
    m3, o3, *_ = built["diagnostic"]
    with pytest.raises(UsageError, match="continuous-time"):
        export_observer(o3, tmp_path, discretisation="zoh")
    assert not list(tmp_path.iterdir())


def test_c_names_from_any_model_name_are_accepted_by_casadi():
    """Model, fault and observer names become C and casadi names; casadi refuses double
    underscores, a leading underscore and non-ASCII letters (an audit found fault d_,
    models drive__2, привод and ../x ending as internal errors), and very long names made
    file names the file system refused. c_name keeps letters, digits and single
    underscores, starts with a letter, stays short, and keeps long names apart."""
    import casadi as ca

    from observer_cad.codegen._translate import MAX_C_NAME, c_name

    x = ca.SX.sym("x")
    names = ["d__step", "drive__2_sim_step", "привод_step", "../x_step", "_a", "2x", "", "___",
             "a" * 5000, "a" * 4999 + "b", "ok_name"]
    made = [c_name(n) for n in names]
    for n, c in zip(names, made):
        ca.Function(c, [x], [x])  # raises if casadi refuses the name
        assert len(c) <= MAX_C_NAME and c[0].isalpha() and "__" not in c, (n, c)
    assert made[-1] == "ok_name" and made[8] != made[9]
