"""Compiled observers: sympy→casadi translation, compilation cache, compiled trajectories.

Parity is checked compiled vs interpreted casadi vs the reference numpy simulator
(observer_cad.simulate) to 1e-12 relative, per column relative to the column's largest
magnitude (residuals are ≈ 0 fault-free, so an elementwise relative error means nothing
there).
"""
from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

casadi = pytest.importorskip("casadi")

from observer_cad.errors import ObserverCadError
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.simulation import scenario_from_dict, simulate
from observer_cad.synthesis import design
from observer_cad.codegen import CodegenError, CompiledSimulator, STATS, compile_function, joint_step, observer_step, plant_step, to_casadi
from observer_cad.codegen import split_signals

ROOT = Path(__file__).resolve().parents[2]
RTOL = 1e-12
HAVE_CC = any(os.path.exists(os.path.join(d, "cc")) for d in os.environ.get("PATH", "").split(":"))
needs_cc = pytest.mark.skipif(not HAVE_CC, reason="no C compiler")

CASES = {
    "virtual-sensor": ("three_tank.py", dict(observer="virtual-sensor", estimate="x1"),
                       {"t_end": 5, "dt": 0.01, "initial": {"x1": 3, "x2": 2, "x3": 1},
                        "observer_initial": {"xs1": 2.5},
                        "signals": {"u1": "0.5+0.1*sin(t)", "u2": 0.3,
                                    "rho1": {"uniform": [-0.05, 0.05]},
                                    "w1": {"uniform": [-0.01, 0.01]}}}),
    "diagnostic": ("electric_drive.py", dict(observer="diagnostic", faults=["d"], disturbances=["rho"]),
                   {"steps": 500, "initial": {"x1": 0.1},
                    "signals": {"u": "sin(t/10)", "d": "Piecewise((0, t < 200), (0.2, True))",
                                "rho": {"uniform": [-0.05, 0.05]},
                                "w2": {"uniform": [-0.01, 0.01]}}}),
    "interval": ("three_tank_linear.py", dict(observer="interval", estimate="x1"),
                 {"t_end": 10, "dt": 0.05, "initial": {"x1": 1},
                  "signals": {"u1": "0.2*sin(t)", "rho": {"uniform": [-0.2, 0.2]},
                              "w1": {"uniform": [-0.02, 0.02]}}}),
}


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path_factory.getbasetemp() / "occache"))


@pytest.fixture(scope="module")
def built():
    out = {}
    for kind, (path, kw, scd) in CASES.items():
        m = load_model(ROOT / "models" / path)
        out[kind] = (m, build_observer(m, design(m, **kw)), scenario_from_dict(scd))
    return out


def _close(a, b, rtol=RTOL):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(float(np.max(np.abs(a))) if a.size else 0.0, 1e-300)
    err = float(np.max(np.abs(a - b))) / scale if a.size else 0.0
    assert err <= rtol, f"relative error {err:.3g} > {rtol}"
    return err


def _random_point(kind, m, o, rng):
    """A random joint state (plant then observer) inside the model's domain."""
    if kind == "virtual-sensor":
        x3 = rng.uniform(0.5, 1.0)
        x2 = x3 + rng.uniform(0.5, 1.0)
        x1 = x2 + rng.uniform(0.5, 1.0)
        x = [x1, x2, x3]
        xi = [x2 + rng.uniform(0.2, 1.0) for _ in o.states]
    else:
        x = list(rng.uniform(-2, 2, len(m.states)))
        xi = list(rng.uniform(-2, 2, len(o.states)))
    return x, xi


# ------------------------------------------------------------------ translation
def test_translate_functions_match_numpy():
    a, b = sp.symbols("a b")
    exprs = [a + b ** 2 - 3 * a * b / 7, sp.sqrt(a) + a ** sp.Rational(-1, 2), a ** 3 - b ** -2,
             sp.sin(a) * sp.cos(b) + sp.exp(-a) - sp.log(a) + sp.tanh(b),
             sp.Abs(b) + sp.sign(b), sp.Max(a, b, 1) - sp.Min(a, b),
             sp.Piecewise((a, b < 0), (2 * a, b <= 0.5), (a * b, True)),
             sp.Float("0.125") * a + sp.Rational(1, 3), a ** sp.Rational(3, 2), sp.atan2(a, b)]
    A, B = casadi.SX.sym("a"), casadi.SX.sym("b")
    sx = to_casadi(exprs, {a: A, b: B}, state_symbols=[a])
    f = casadi.Function("f", [A, B], [casadi.vertcat(*sx)])
    g = sp.lambdify((a, b), exprs, "numpy")
    rng = np.random.default_rng(0)
    for _ in range(50):
        va, vb = rng.uniform(0.1, 3), rng.uniform(-2, 2)
        _close(np.array(g(va, vb), float), np.array(f(va, vb)).ravel())


def test_translate_shares_subexpressions():
    x1, x2 = sp.symbols("x1 x2")
    s = sp.sqrt(x1 - x2)
    X = casadi.SX.sym("x", 2)
    out = to_casadi([1 - s, s + x2, s * 3], {x1: X[0], x2: X[1]})
    f = casadi.Function("f", [X], [casadi.vertcat(*out)])
    ops = [f.instruction_id(k) for k in range(f.n_instructions())]
    assert ops.count(casadi.OP_SQRT) == 1      # sqrt(x1 - x2) computed once
    assert ops.count(casadi.OP_SUB) == 2       # x1 - x2 once, 1 - s once


def test_step_functions_have_docstrings(built):
    m, o, _ = built["virtual-sensor"]
    for f in (observer_step(o), plant_step(m), joint_step(m, o)):
        doc = f.__doc__
        assert doc.startswith(f.name() + "(")
        for i in range(f.n_in()):
            assert f"  {f.name_in(i)} " in doc
        for i in range(f.n_out()):
            assert f"  {f.name_out(i)} " in doc
    f = observer_step(o)
    assert [f.name_in(i) for i in range(f.n_in())] == ["x", "y", "u", "p", "h"]
    assert [f.name_out(i) for i in range(f.n_out())] == ["x_next", "out"]


# ------------------------------------------------------------------ single steps
def _numpy_observer_step(o, x, y, u, h):
    """Observer alone, y and u held: numpy RK4 (continuous) or the map (discrete)."""
    ys, us = split_signals(o)
    args = list(o.states) + ys + us
    fu = sp.lambdify(args, list(o.update), "numpy")
    fo = sp.lambdify(args, [e for _, e in o.outputs], "numpy")
    f = lambda xv: np.array(fu(*xv, *y, *u), float)  # noqa: E731
    out = np.array(fo(*x, *y, *u), float)
    x = np.asarray(x, float)
    if o.time == "discrete":
        return f(x), out
    k1 = f(x)
    k2 = f(x + h / 2 * k1)
    k3 = f(x + h / 2 * k2)
    k4 = f(x + h * k3)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), out


@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("kind", list(CASES))
def test_single_step_parity(kind, built):
    m, o, _ = built[kind]
    rng = np.random.default_rng(1)
    h = 0.01
    js = joint_step(m, o)
    jc = compile_function(js).function
    os_ = observer_step(o)
    oc = compile_function(os_).function
    ps = plant_step(m, substitute_parameters=True)
    pc = compile_function(ps).function
    ins = list(m.inputs) + list(m.faults) + list(m.disturbances) + list(m.noise)
    ys, us = split_signals(o)
    for trial in range(10):
        x, xi = _random_point(kind, m, o, rng)
        v = rng.uniform(-0.05, 0.05, len(ins))
        if kind == "virtual-sensor":
            v[:2] = rng.uniform(0.2, 1.0, 2)
        # reference: two grid points of the reference simulator
        sc = {"initial": {str(s): float(val) for s, val in zip(m.states, x)},
              "observer_initial": {str(s): float(val) for s, val in zip(o.states, xi)},
              "signals": {str(s): float(val) for s, val in zip(ins, v)}}
        sc.update({"steps": 2} if m.time == "discrete" else {"t_end": h, "dt": h})
        ref = simulate(m, o, scenario_from_dict(sc))
        s_ref = [ref[str(s)][1] for s in m.states]  # observer states are not columns
        for f in (js, jc):
            sn, yv, out = (np.array(r, float).ravel() for r in f(x + xi, v, h))
            _close([ref[str(s)][1] for s in m.states], sn[:len(x)])
            _close([ref[f"y{i + 1}"][0] for i in range(len(m.outputs))], yv)
            _close([ref[n][0] for n in o.output_names], out)
        # the interpreted and compiled joint steps agree on the whole next state
        a = np.array(js(x + xi, v, h)[0], float).ravel()
        b = np.array(jc(x + xi, v, h)[0], float).ravel()
        _close(a, b)
        # plant step
        for f in (ps, pc):
            args = (x, v, np.zeros(0)) + ((h,) if m.time == "continuous" else ())
            xn, yv = (np.array(r, float).ravel() for r in f(*args))
            _close(s_ref, xn)
        # observer alone (y, u held) against a numpy implementation
        yval = np.array(js(x + xi, v, h)[1], float).ravel()
        uval = [v[ins.index(s)] for s in us]
        xn_ref, out_ref = _numpy_observer_step(o, xi, yval, uval, h)
        for f in (os_, oc):
            args = (xi, yval, uval, np.zeros(0)) + ((h,) if o.time == "continuous" else ())
            xn, out = (np.array(r, float).ravel() for r in f(*args))
            _close(xn_ref, xn)
            _close(out_ref, out)
        if o.time == "discrete":  # alone == joint in discrete time
            _close(a[len(x):], np.array(os_(xi, yval, uval, np.zeros(0))[0], float).ravel())


# ------------------------------------------------------------------ trajectories
@needs_cc
@pytest.mark.parametrize("kind", list(CASES))
def test_trajectory_parity(kind, built):
    m, o, sc = built[kind]
    ref = simulate(m, o, sc)
    cs = CompiledSimulator(m, o)
    res = cs.simulate(sc)
    assert res.order == ref.order
    assert set(res.columns) == set(ref.columns)
    for c in ref.columns:
        assert res[c].shape == ref[c].shape
        _close(ref[c], res[c])
    # Monte-Carlo runs on threads
    refR = simulate(m, o, sc, runs=5)
    resR = cs.simulate(sc, runs=5, threads=2)
    for c in refR.columns:
        _close(refR[c], resR[c])


@needs_cc
def test_trajectory_matches_interpreted_casadi_and_many_scenarios(built):
    m, o, sc = built["diagnostic"]
    cs = CompiledSimulator(m, o)
    res = cs.simulate(sc)
    # interpreted casadi loop over the same joint step (first 50 steps), from the joint
    # initial state the simulator uses (the observer's default x*(0) may depend on x(0))
    x0 = {x: float(res[str(x)][0]) for x in m.states}
    s = list(x0.values()) + [float(sp.sympify(o.initial.get(x, 0)).xreplace(x0))
                             for x in o.states]
    ins = cs.inputs
    for i in range(50):
        v = [res[str(u)][i] for u in ins]
        sn, yv, out = cs.step(s, v, cs.nominal, 1.0)
        _close([res[n][i] for n in o.output_names], np.array(out, float).ravel())
        s = np.array(sn, float).ravel()
    scs = [dataclasses.replace(sc, seed=k) for k in range(6)]
    many = cs.simulate_many(scs, threads=2)
    for k, r in enumerate(many):
        ref = simulate(m, o, scs[k])
        for c in ref.columns:
            _close(ref[c], r[c])


@needs_cc
def test_run_arrays_writes_into_given_buffers(built):
    m, o, _ = built["interval"]
    cs = CompiledSimulator(m, o)
    N = 1000
    t = np.arange(N) * 0.01
    V = np.zeros((N, cs.nv))
    S, Y, O = np.empty((N, cs.ns)), np.empty((N, cs.ny)), np.empty((N, cs.no))
    S2, Y2, O2 = cs.run_arrays(t, V, np.ones(cs.ns), S=S, Y=Y, O=O)
    assert S2 is S and Y2 is Y and O2 is O
    assert np.all(np.isfinite(S))
    with pytest.raises(ObserverCadError):
        cs.run_arrays(t, V, S=np.empty((cs.ns, N)).T)  # not C-contiguous
    with pytest.raises(ObserverCadError):
        cs.run_arrays(t, V[:, :-1])


# ------------------------------------------------------------------ cache
@needs_cc
def test_cache_hit_reuses_library_and_changed_model_recompiles(built, tmp_path, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    m, o, _ = built["diagnostic"]
    f = joint_step(m, o)
    c1 = compile_function(f)
    assert not c1.cached
    mtime = c1.path.stat().st_mtime_ns
    n = STATS["compiles"]
    t0 = time.perf_counter()
    c2 = compile_function(f)
    hit = time.perf_counter() - t0
    assert c2.cached and c2.path == c1.path
    assert STATS["compiles"] == n
    assert c1.path.stat().st_mtime_ns == mtime
    assert hit < 0.5
    # a changed model (one coefficient) → different C → new library
    k2 = sp.Symbol("k2")
    m2 = dataclasses.replace(m, parameters={**m.parameters, k2: sp.Rational(3, 4)})
    c3 = compile_function(joint_step(m2, o))
    assert not c3.cached and c3.path != c1.path
    assert STATS["compiles"] == n + 1
    # no temporary files left behind
    assert not list(tmp_path.glob(".tmp-*"))


@needs_cc
def test_corrupt_entry_is_rebuilt(built, tmp_path):
    m, o, _ = built["interval"]
    f = joint_step(m, o)
    c1 = compile_function(f, cache=tmp_path / "a")
    # a garbage file where the entry of a second cache would be (a library already loaded
    # in this process is served by the loader from memory, so use a path not loaded yet)
    (tmp_path / "b").mkdir()
    bad = tmp_path / "b" / c1.path.name
    bad.write_bytes(b"\x7fELF garbage")
    c2 = compile_function(f, cache=tmp_path / "b")
    assert not c2.cached and c2.path == bad
    np.testing.assert_allclose(np.array(c2.function([1, 2, 3, 0, 0], [0] * 5, 0.1)[0]),
                               np.array(f([1, 2, 3, 0, 0], [0] * 5, 0.1)[0]), rtol=1e-14)


_WRAPPER = """#!/bin/sh
# compiler wrapper: with HANG set, write half an output file and hang
if [ -n "$OCAD_HANG" ]; then
  out=""
  prev=""
  for a in "$@"; do
    if [ "$prev" = "-o" ]; then out="$a"; fi
    prev="$a"
  done
  printf 'partial' > "$out"
  touch "$OCAD_HANG"
  sleep 60
  exit 1
fi
exec {cc} "$@"
"""


def _which(name):
    for d in os.environ.get("PATH", "").split(":"):
        p = os.path.join(d, name)
        if os.path.isfile(p) and os.access(p, os.X_OK):
            return p
    return None


@pytest.mark.slow  # a subprocess compiles and is killed, ~4 s
@needs_cc
def test_killed_compile_leaves_no_corrupt_entry(built, tmp_path):
    cache = tmp_path / "cache"
    wrapper = tmp_path / "cc-wrapper"
    wrapper.write_text(_WRAPPER.format(cc=_which("cc")))
    wrapper.chmod(0o755)
    flag = tmp_path / "started"
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(ROOT)!r})
        from observer_cad.model import load_model
        from observer_cad.synthesis import design
        from observer_cad.observers import build_observer
        from observer_cad.codegen import joint_step, compile_function
        m = load_model({str(ROOT / 'models' / 'electric_drive.py')!r})
        o = build_observer(m, design(m, observer='diagnostic', faults=['d'], disturbances=['rho']))
        c = compile_function(joint_step(m, o))
        print(c.cached, c.path)
    """)
    env = dict(os.environ, OBSERVER_CAD_CACHE=str(cache), CC=str(wrapper), OCAD_HANG=str(flag))
    p = subprocess.Popen([sys.executable, "-c", script], env=env, start_new_session=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        for _ in range(600):
            if flag.exists():
                break
            time.sleep(0.05)
        assert flag.exists(), p.communicate(timeout=5)
    finally:
        os.killpg(p.pid, signal.SIGKILL)   # the session this test started: python + wrapper
        p.wait()
    assert not [f for f in cache.glob("*.so")], "a killed compile left a cache entry"
    # the same compiler, now working: compiles (not a hit), loads and runs
    env.pop("OCAD_HANG")
    r = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("False")
    r = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.startswith("True"), r.stderr


@pytest.mark.slow  # two subprocesses compile, ~4 s
@needs_cc
def test_two_processes_compiling_at_once_both_succeed(tmp_path):
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(ROOT)!r})
        from observer_cad.model import load_model
        from observer_cad.codegen import plant_step, compile_function
        m = load_model({str(ROOT / 'models' / 'three_tank.py')!r})
        c = compile_function(plant_step(m))
        x = c.function([3, 2, 1], [0.5, 0.3, 0, 0, 0, 0], [], 0.01)[0]
        print(float(x[0]))
    """)
    env = dict(os.environ, OBSERVER_CAD_CACHE=str(tmp_path))
    ps = [subprocess.Popen([sys.executable, "-c", script], env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True) for _ in range(3)]
    outs = [p.communicate(timeout=120) for p in ps]
    assert all(p.returncode == 0 for p in ps), outs
    assert len({o for o, _ in outs}) == 1
    assert len(list(tmp_path.glob("*.so"))) == 1
    assert not list(tmp_path.glob(".tmp-*"))


def test_missing_compiler_gives_clear_error(built, monkeypatch, tmp_path):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    monkeypatch.setenv("CC", "/nonexistent/bin/cc")
    m, o, sc = built["diagnostic"]
    f = observer_step(o)
    with pytest.raises(CodegenError, match=r"C compiler '/nonexistent/bin/cc' not found") as ei:
        compile_function(f)
    assert isinstance(ei.value, ObserverCadError)
    assert "\n" not in str(ei.value)
    with pytest.raises(CodegenError):
        CompiledSimulator(m, o)
    # the interpreted function still works
    xn, out = f([0.5], [1.0, 2.0], [0.1], [])
    assert np.isfinite(float(xn)) and np.isfinite(float(out))


def test_compiler_error_gives_clear_error(built, monkeypatch, tmp_path):
    bad = tmp_path / "badcc"
    bad.write_text("#!/bin/sh\nif [ \"$1\" = --version ]; then echo badcc 1.0; exit 0; fi\n"
                   "echo 'x.c:1:1: error: something is wrong' >&2\nexit 1\n")
    bad.chmod(0o755)
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", str(bad))
    m, o, _ = built["interval"]
    with pytest.raises(CodegenError, match="error: something is wrong"):
        compile_function(observer_step(o))
    assert not list((tmp_path / "cache").glob("*.so"))
    assert not list((tmp_path / "cache").glob(".tmp-*"))


# ------------------------------------------------------------------ fingerprint cache
class _Counter:
    """Counts Translator constructions and C generations (monkeypatched wrappers)."""

    def __init__(self, monkeypatch):
        import observer_cad.codegen._compile as cmod  # counters wrapped around internals
        import observer_cad.codegen._trajectory as tmod
        import observer_cad.codegen._translate as trmod
        self.translators = 0
        self.generated = 0
        orig_init = trmod.Translator.__init__
        orig_gen = cmod.generate_c

        def init(obj, *a, **k):
            self.translators += 1
            orig_init(obj, *a, **k)

        def gen(*a, **k):
            self.generated += 1
            return orig_gen(*a, **k)
        monkeypatch.setattr(trmod.Translator, "__init__", init)
        monkeypatch.setattr(cmod, "generate_c", gen)
        monkeypatch.setattr(tmod, "generate_c", gen)

    def reset(self):
        self.translators = self.generated = 0


@needs_cc
def test_second_simulator_skips_translation_and_loads_the_same_library(built, tmp_path,
                                                                        monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    m, o, sc = built["virtual-sensor"]
    cnt = _Counter(monkeypatch)
    cs1 = CompiledSimulator(m, o)
    assert cs1.translated and not cs1.cached and cnt.translators > 0 and cnt.generated > 0
    assert len(list(tmp_path.glob("*.ref"))) == 1
    cnt.reset()
    n_comp, n_fp = STATS["compiles"], STATS["fingerprint_hits"]
    hits = []
    for _ in range(5):
        t0 = time.perf_counter()
        cs2 = CompiledSimulator(m, o)
        hits.append(time.perf_counter() - t0)
        assert cs2.cached and not cs2.translated and cs2.path == cs1.path
    assert cnt.translators == 0 and cnt.generated == 0, "a hit translated or generated C"
    assert STATS["compiles"] == n_comp and STATS["fingerprint_hits"] == n_fp + 5
    assert sorted(hits)[2] < 0.050, f"cache hit median {sorted(hits)[2] * 1e3:.1f} ms"
    r1, r2 = cs1.simulate(sc), cs2.simulate(sc)
    for c in r1.columns:
        np.testing.assert_array_equal(r1[c], r2[c])
    assert cs2.source == cs1.source          # read back from the .c kept beside the .so
    assert cnt.translators == 0
    # the interpreted step is still there, built on first use
    sn = cs2.step([3, 2, 1, 2.5], [0.5, 0.3, 0, 0, 0, 0], cs2.nominal, 0.01)[0]
    assert cnt.translators > 0 and cs2.translated
    np.testing.assert_array_equal(np.array(sn), np.array(cs1.step([3, 2, 1, 2.5],
                                                                  [0.5, 0.3, 0, 0, 0, 0], cs1.nominal, 0.01)[0]))


@needs_cc
def test_compile_observer_step_hit_skips_translation(built, tmp_path, monkeypatch):
    from observer_cad.codegen import compile_observer_step, compile_plant_step
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    m, o, _ = built["interval"]
    f = observer_step(o, h=0.05)
    cnt = _Counter(monkeypatch)
    c1 = compile_observer_step(o, h=0.05)
    assert c1.translated and not c1.cached and cnt.translators > 0
    cnt.reset()
    c2 = compile_observer_step(o, h=0.05)
    assert c2.cached and not c2.translated and c2.path == c1.path
    assert cnt.translators == 0 and cnt.generated == 0
    assert c2.function.__doc__ == f.__doc__
    x, y, u = [0.2, -0.1], [0.5, 0.25], [0.1, 0.0]
    for g in (c1.function, c2.function):
        np.testing.assert_array_equal(np.array(g(x, y, u, [])[0]), np.array(f(x, y, u, [])[0]))
    # other options are other functions
    c3 = compile_observer_step(o, h=0.1)
    assert c3.translated and c3.path != c1.path
    c4 = compile_plant_step(m, h=0.05)
    cnt.reset()
    c5 = compile_plant_step(m, h=0.05)
    assert not c5.translated and c5.path == c4.path and cnt.translators == 0


@needs_cc
def test_changed_model_misses_the_fingerprint_and_recompiles(built, tmp_path, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    m, o, sc = built["diagnostic"]
    cs1 = CompiledSimulator(m, o)
    k = next(iter(m.parameters))
    # a parameter's value is a run-time input: same library, no compile
    m2 = dataclasses.replace(m, parameters={**m.parameters, k: m.parameters[k] * 2})
    n = STATS["compiles"]
    cs2 = CompiledSimulator(m2, o)
    assert cs2.cached and not cs2.translated and cs2.path == cs1.path
    assert STATS["compiles"] == n
    assert not np.array_equal(cs1.simulate(sc)["x1"], cs2.simulate(sc)["x1"])
    # an equation changed (a coefficient that is not a parameter): a miss, a new library
    m3 = dataclasses.replace(m, dynamics=(m.dynamics[0] * 2,) + tuple(m.dynamics[1:]))
    cs2 = CompiledSimulator(m3, o)
    assert cs2.translated and not cs2.cached and cs2.path != cs1.path
    assert STATS["compiles"] == n + 1
    # the observer changed (a coefficient): also a miss
    o2 = dataclasses.replace(o, update=tuple(sp.sympify(e) * 2 for e in o.update))
    cs3 = CompiledSimulator(m, o2)
    assert cs3.translated and cs3.path not in (cs1.path, cs2.path)


@needs_cc
def test_missing_or_bad_fingerprint_record_falls_back_to_the_content_key(built, tmp_path,
                                                                         monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path))
    m, o, _ = built["interval"]
    cs1 = CompiledSimulator(m, o)
    ref = next(tmp_path.glob("*.ref"))
    n = STATS["compiles"]
    # no record: translated, C generated, content-key hit (no compiler run), record rewritten
    ref.unlink()
    cs2 = CompiledSimulator(m, o)
    assert cs2.translated and cs2.cached and cs2.path == cs1.path and ref.is_file()
    # a corrupt record: ignored the same way
    ref.write_text("{not json")
    cs3 = CompiledSimulator(m, o)
    assert cs3.translated and cs3.cached and cs3.path == cs1.path
    assert json.loads(ref.read_text())["library"] == cs1.path.name
    assert STATS["compiles"] == n
    # a record whose library is gone: rebuilt
    cs1.path.unlink()
    cs4 = CompiledSimulator(m, o, cache=tmp_path)
    assert cs4.translated and not cs4.cached and cs4.path.is_file()
    assert STATS["compiles"] == n + 1
    assert not list(tmp_path.glob(".tmp-*"))


@pytest.mark.slow  # a fresh interpreter, ~5 s
@needs_cc
def test_fingerprint_hit_in_a_fresh_process(built, tmp_path):
    """The fingerprint is the same in another process (no hash randomisation in it): a
    fresh process finds the library without translating."""
    cache = tmp_path / "cache"
    script = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(ROOT)!r})
        from observer_cad.model import load_model
        from observer_cad.synthesis import design
        from observer_cad.observers import build_observer
        from observer_cad.codegen import CompiledSimulator
        m = load_model({str(ROOT / 'models' / 'three_tank.py')!r})
        o = build_observer(m, design(m, observer='interval', estimate='x1'))
        t0 = time.perf_counter()
        c = CompiledSimulator(m, o)
        print(c.cached, c.translated, c.path, time.perf_counter() - t0)
    """)
    env = dict(os.environ, OBSERVER_CAD_CACHE=str(cache), PYTHONHASHSEED="random")
    outs = []
    for _ in range(2):
        r = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                           text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        outs.append(r.stdout.split())
    assert outs[0][:2] == ["False", "True"]
    assert outs[1][:2] == ["True", "False"] and outs[1][2] == outs[0][2]
    assert float(outs[1][3]) < 0.5


def test_structure_serialisation_distinguishes_what_matters():
    from observer_cad.codegen import structure
    x, y = sp.symbols("x y")
    xr = sp.Symbol("x", real=True)
    assert structure(x + 2 * y) == structure(sp.sympify("2*y + x"))
    differ = [x + 2 * y, x + 3 * y, x + sp.Float(2) * y, x + sp.Rational(1, 2) * y,
              xr + 2 * y, sp.sqrt(x) + y, x ** sp.Rational(1, 2) * 2 + y,
              sp.Piecewise((x, y < 0), (y, True)), sp.Piecewise((x, y <= 0), (y, True)),
              sp.Max(x, y), sp.Min(x, y), sp.Abs(x) * y]
    reps = [structure(e) for e in differ]
    assert len(set(reps)) == len(reps)
    # floats exactly (not their printed digits), shared subtrees written once
    assert structure(sp.Float(0.1)) != structure(sp.Float(0.1 + 2 ** -55))
    s = sp.sqrt(x - y)
    assert structure([s + 1, s * 2]).count("Pow(") == 1
    assert structure(("a", 1, None)) != structure(("a", 1.0, None))
