#!/usr/bin/env python3
"""Compiled-observer benchmark: every route of simulating plant + observer, side by side.

    python3 benchmarks/bench_codegen.py            # measure, print the tables
    python3 benchmarks/bench_codegen.py --write    # ... and update benchmarks/README.md

Two cases, each the joint step of plant + observer exactly as the reference simulator
(observer_cad.simulation.simulate) runs them (``joint_step``: s = [x; xi], signals v held, the
observer reading y = h(x, w)):

* the electric drive (discrete) with the unknown-input estimator of d
  (``build_observer(model, design(model, observer='unknown-input', faults=['d']))``);
* the nonlinear three-tank (continuous, RK4) with the interval observer for x1
  (``build_observer(model, design(model, observer='interval', estimate='x1'))``).

If a builder fails (observer_cad.observers not importable or not
working) the case falls back to the diagnostic observer / the virtual sensor and the
table says so.

Routes, ns per step (medians over --repeat rounds; in each round every route of a case
runs once, one after the other, so they share the machine's state):

  (a) traj      compiled trajectory: the casadi-generated joint step inside a generated
                C loop over numpy buffers, one ctypes call      (codegen.trajectory)
  (a) mapaccum  compiled ``mapaccum`` of K = --k steps, called N/K times through
                ``Function.buffer()`` on numpy memory (no DM conversion)
  (f) hand C    a hand-written C loop of the same step, gcc -O3 (the practical limit);
                checked against the compiled trajectory before timing
  (b) compiled step called per step from Python: via ``Function.buffer()``, and with
                numpy in / out
  (c) interpreted casadi step called per step: via ``Function.buffer()``, numpy in/out
  (d) numpy     a plain numpy per-step loop: the joint equations lambdified (numpy)
                once, then per step one call (discrete) or four RK4 stages on numpy
                arrays; and the reference simulator itself (observer_cad.simulation.simulate, the
                same kind of loop, its set-up -- lambdify, signal generation -- timed)
  (e) dlsim     ``scipy.signal.dlsim`` on the joint linear state update (electric drive
                only: plant and estimator states are linear/affine) plus the output map
                evaluated vectorised with numpy afterwards

N = --n (10^6) for the compiled routes and hand C; the per-step Python routes run
--n-slow steps and are reported per step.  Times are the process's CPU time
(``time.process_time``): this machine is shared, and wall-clock time also counts the
time other processes hold the cores; wall-clock medians are given beside.  Also
timed, wall-clock: generate + compile + load of the compiled trajectory
(``CompiledSimulator``: sympy → casadi, C generation, cc -O3, dlopen) in a fresh
temporary OBSERVER_CAD_CACHE (median of --cold runs), and a cache hit (same, with
the library already in the cache: a fingerprint hit, which neither translates nor
generates C — asserted), in this process (5 times) and in 3 fresh processes (the
construction timed inside the process; interpreter start-up and imports excluded).
A hit passes when its *maximum* is under 50 ms.
"""
from __future__ import annotations

import argparse
import faulthandler
import ctypes
import datetime
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import casadi as ca  # noqa: E402
import scipy  # noqa: E402
import scipy.signal  # noqa: E402
import sympy as sp  # noqa: E402

from observer_cad.codegen import CompiledSimulator, compile_function, joint_step
from observer_cad.codegen import compile_source
from observer_cad.model import load_model
from observer_cad.observers import output_symbols
from observer_cad.observers import build_observer
from observer_cad.simulation import scenario_from_dict, simulate
from common import cpu_name, load as _load, write_section
from observer_cad.synthesis import design

README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN CODEGEN RESULTS (bench_codegen.py --write) -->"
END = "<!-- END CODEGEN RESULTS -->"

TARGET_HAND = 2.0      # compiled trajectory at most 2x the hand-written C loop
TARGET_NUMPY = 100.0   # ... and at least 100x faster than the numpy loop
TARGET_BUILD = 2.0     # generate + compile + load, seconds
TARGET_HIT = 0.050     # cache hit, seconds

# ---------------------------------------------------------------- hand-written C loops
# Same signature as the generated trajectory loop: S row 0 holds the initial state.
HAND_ED_UIO = r"""
#include <math.h>
/* electric drive + unknown-input estimator of d, discrete.
   s = x1 x2 x3 xl1 xu1 y1_lag1 y2_lag1 xl1_lag1 xu1_lag1,  v = u d rho w1 w2 */
int run(long long N, const double* t, const double* V, double* S, double* Y, double* O) {
  const double g = -0.7, dmin = -0.4, dmax = 0.4, eps = 1e-12;
  double x1 = S[0], x2 = S[1], x3 = S[2], xl = S[3], xu = S[4];
  double y1l = S[5], y2l = S[6], xll = S[7], xul = S[8];
  (void)t;
  for (long long i = 0; i < N; ++i) {
    const double* v = V + 5 * i;
    double* s = S + 9 * i;
    double y1 = x1 + v[3], y2 = x3 + v[4];
    s[0] = x1; s[1] = x2; s[2] = x3; s[3] = xl; s[4] = xu;
    s[5] = y1l; s[6] = y2l; s[7] = xll; s[8] = xul;
    Y[2 * i] = y1; Y[2 * i + 1] = y2;
    double alpha = fabs(xl - xu) > eps ? (y1 + 5 * y2 - xl) / (xu - xl) : 0.5;
    O[i] = dmin + g * (y1l - xll) / 5 + g * y2l + (dmax - dmin + g * (xll - xul) / 5) * alpha;
    double c = 0.2 * v[0] + (1 + g) * y1 + (5 * g + 4.8) * y2;
    double n1 = 0.002 * x2 + x1;
    double n2 = 0.02 * x3 + v[2] + 0.8 * x2;
    double n3 = -0.0004 * x2 + 0.04 * v[0] + v[1] + 0.96 * x3;
    double nl = 5 * dmin + c - g * xl, nu = 5 * dmax + c - g * xu;
    y1l = y1; y2l = y2; xll = xl; xul = xu;
    x1 = n1; x2 = n2; x3 = n3; xl = nl; xu = nu;
  }
  return 0;
}
"""

HAND_ED_DIAG = r"""
/* electric drive + diagnostic observer, discrete; s = x1 x2 x3 xs1, v = u d rho w1 w2 */
int run(long long N, const double* t, const double* V, double* S, double* Y, double* O) {
  double x1 = S[0], x2 = S[1], x3 = S[2], xs = S[3];
  (void)t;
  for (long long i = 0; i < N; ++i) {
    const double* v = V + 5 * i;
    double y1 = x1 + v[3], y2 = x3 + v[4];
    S[4 * i] = x1; S[4 * i + 1] = x2; S[4 * i + 2] = x3; S[4 * i + 3] = xs;
    Y[2 * i] = y1; Y[2 * i + 1] = y2;
    O[i] = y1 + 5 * y2 - xs;
    double n1 = 0.002 * x2 + x1;
    double n2 = 0.02 * x3 + v[2] + 0.8 * x2;
    double n3 = -0.0004 * x2 + 0.04 * v[0] + v[1] + 0.96 * x3;
    double ns = 0.2 * v[0] + 0.5 * y1 + 2.3 * y2 + 0.5 * xs;
    x1 = n1; x2 = n2; x3 = n3; xs = ns;
  }
  return 0;
}
"""

HAND_TT_INTERVAL = r"""
#include <math.h>
/* three-tank + nonlinear interval observer for x1, continuous, RK4 (the observer reads
   y1 = x2 + w1 inside the stages); s = x1 x2 x3 xl1 xu1, v = u1 u2 rho1 rho2 w1 w2 */
static inline void f(const double* s, const double* v, double* d) {
  double a = sqrt(s[0] - s[1]), b = sqrt(s[1] - s[2]), y1 = s[1] + v[4];
  double ml = fmax(0.0, s[3] - y1 + 0.01), mu = fmax(0.0, s[4] - y1 - 0.01);
  d[0] = v[0] - a;
  d[1] = v[1] + a - b + v[2];
  d[2] = b - sqrt(s[2]) + v[3];
  d[3] = v[0] - s[3] + y1 - sqrt(ml) + ml - 0.01;
  d[4] = v[0] - s[4] + y1 - sqrt(mu) + mu + 0.01;
}
int run(long long N, const double* t, const double* V, double* S, double* Y, double* O) {
  double s[5], k1[5], k2[5], k3[5], k4[5], z[5];
  int j;
  for (j = 0; j < 5; ++j) s[j] = S[j];
  for (long long i = 0; i < N; ++i) {
    const double* v = V + 6 * i;
    double h = (i + 1 < N) ? t[i + 1] - t[i] : 0.0;
    for (j = 0; j < 5; ++j) S[5 * i + j] = s[j];
    Y[2 * i] = s[1] + v[4]; Y[2 * i + 1] = s[2] + v[5];
    O[2 * i] = s[3]; O[2 * i + 1] = s[4];
    f(s, v, k1);
    for (j = 0; j < 5; ++j) z[j] = h / 2 * k1[j] + s[j];
    f(z, v, k2);
    for (j = 0; j < 5; ++j) z[j] = h / 2 * k2[j] + s[j];
    f(z, v, k3);
    for (j = 0; j < 5; ++j) z[j] = h * k3[j] + s[j];
    f(z, v, k4);
    for (j = 0; j < 5; ++j) s[j] = h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]) + s[j];
  }
  return 0;
}
"""

HAND_TT_VS = r"""
#include <math.h>
/* three-tank + virtual sensor, continuous RK4; s = x1 x2 x3 xs1, v = u1 u2 rho1 rho2 w1 w2 */
static inline void f(const double* s, const double* v, double* d) {
  double a = sqrt(s[0] - s[1]), b = sqrt(s[1] - s[2]);
  d[0] = v[0] - a;
  d[1] = v[1] + a - b + v[2];
  d[2] = b - sqrt(s[2]) + v[3];
  d[3] = v[0] - sqrt(s[3] - (s[1] + v[4]));
}
int run(long long N, const double* t, const double* V, double* S, double* Y, double* O) {
  double s[4] = {S[0], S[1], S[2], S[3]}, k1[4], k2[4], k3[4], k4[4], z[4];
  for (long long i = 0; i < N; ++i) {
    const double* v = V + 6 * i;
    double h = (i + 1 < N) ? t[i + 1] - t[i] : 0.0;
    for (int j = 0; j < 4; ++j) S[4 * i + j] = s[j];
    Y[2 * i] = s[1] + v[4]; Y[2 * i + 1] = s[2] + v[5];
    O[i] = s[3];
    f(s, v, k1);
    for (int j = 0; j < 4; ++j) z[j] = h / 2 * k1[j] + s[j];
    f(z, v, k2);
    for (int j = 0; j < 4; ++j) z[j] = h / 2 * k2[j] + s[j];
    f(z, v, k3);
    for (int j = 0; j < 4; ++j) z[j] = h * k3[j] + s[j];
    f(z, v, k4);
    for (int j = 0; j < 4; ++j) s[j] = h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]) + s[j];
  }
  return 0;
}
"""


def _ed_scenario(n):
    return {"steps": n, "initial": {"x1": 0.1, "x3": 0.2},
            "signals": {"u": "sin(t/10)", "d": "Piecewise((0, t < 200), (0.2, True))",
                        "rho": "0.05*sin(t/7)", "w1": {"uniform": [-0.01, 0.01]},
                        "w2": {"uniform": [-0.01, 0.01]}}}


def _tt_scenario(n):
    return {"t_end": (n - 1) * 0.001, "dt": 0.001,
            "initial": {"x1": 1.53, "x2": 1.28, "x3": 0.64},
            "signals": {"u1": "0.5+0.05*sin(t)", "u2": 0.3, "rho1": "0.02*sin(3*t)",
                        "w1": {"uniform": [-0.01, 0.01]}, "w2": {"uniform": [-0.01, 0.01]}}}


# title, model, (design kwargs, hand C, label), fallback (design kwargs, hand C, label), scenario
CASES = [
    ("electric drive", "electric_drive.py",
     (dict(observer="unknown-input", faults=["d"]), HAND_ED_UIO,
      "unknown-input estimator of d (discrete)"),
     (dict(observer="diagnostic"), HAND_ED_DIAG,
      "diagnostic observer (discrete) - FALLBACK: the unknown-input estimator failed"),
     _ed_scenario),
    ("three-tank", "three_tank.py",
     (dict(observer="interval", estimate="x1"), HAND_TT_INTERVAL,
      "nonlinear interval observer for x1 (continuous, RK4)"),
     (dict(observer="virtual-sensor", estimate="x1"), HAND_TT_VS,
      "virtual sensor for x1 (continuous, RK4) - FALLBACK: the interval observer failed"),
     _tt_scenario),
]

ROUTES = [
    ("traj", "(a) compiled trajectory: generated C loop, one ctypes call", "fast"),
    ("mapaccum", "(a) compiled mapaccum, K = {k}, via Function.buffer(), N/K calls", "fast"),
    ("hand", "(f) hand-written C loop, gcc -O3", "fast"),
    ("c_buffer", "(b) compiled step per step from Python, Function.buffer()", "slow"),
    ("c_numpy", "(b) compiled step per step from Python, numpy in/out", "slow"),
    ("i_buffer", "(c) interpreted casadi step per step, Function.buffer()", "slow"),
    ("i_numpy", "(c) interpreted casadi step per step, numpy in/out", "slow"),
    ("numpy", "(d) plain numpy per-step loop (lambdified equations; setup not timed)", "slow"),
    ("simulate", "(d) reference simulator `observer_cad.simulation.simulate` (numpy per-step loop;"
     " setup timed)", "slow"),
    ("dlsim", "(e) scipy.signal.dlsim + vectorised output map", "slow"),
]


# ---------------------------------------------------------------- helpers
def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(float(np.max(np.abs(a))), 1e-300)
    return float(np.max(np.abs(a - b))) / scale


def _timed(fn):
    w0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def _observer(m, primary, fallback):
    """(observer, hand C, label, note, design kwargs): the primary design or, if it
    fails, the fallback."""
    kw, hand, label = primary
    try:
        return build_observer(m, design(m, **kw)), hand, label, None, kw
    except Exception as exc:  # noqa: BLE001 - any failure of a concurrent module
        kw2, hand2, label2 = fallback
        return (build_observer(m, design(m, **kw2)), hand2, label2,
                f"{type(exc).__name__}: {exc}", kw2)


_FRESH = """
import sys, time
sys.path.insert(0, {root!r})
from observer_cad.model import load_model
from observer_cad.synthesis import design
from observer_cad.observers import build_observer
from observer_cad.codegen import CompiledSimulator
m = load_model({model!r})
o = build_observer(m, design(m, **{kw!r}))
t0, c0 = time.perf_counter(), time.process_time()
c = CompiledSimulator(m, o)
print(time.perf_counter() - t0, time.process_time() - c0, c.cached, c.translated)
"""


def _build_times(m, o, cold_runs, hit_runs, model_path, kw):
    """Wall-clock generate + compile + load in fresh caches; cache hits in this process
    (fingerprint hits: no translation, no C generation, no compiler) and in fresh
    processes (the construction only, timed inside the process)."""
    import subprocess
    old = os.environ.get("OBSERVER_CAD_CACHE")
    cold, hits, fresh = [], [], []
    try:
        for _ in range(cold_runs):
            with tempfile.TemporaryDirectory(prefix="ocad-bench-") as d:
                os.environ["OBSERVER_CAD_CACHE"] = d
                t0 = time.perf_counter()
                cs = CompiledSimulator(m, o)
                cold.append(time.perf_counter() - t0)
                assert not cs.cached
                if hits:
                    continue
                for _ in range(hit_runs):
                    t0, c0 = time.perf_counter(), time.process_time()
                    c2 = CompiledSimulator(m, o)
                    hits.append((time.perf_counter() - t0, time.process_time() - c0))
                    assert c2.cached and not c2.translated and c2.path == cs.path
                script = _FRESH.format(root=str(ROOT), model=str(model_path), kw=kw)
                for _ in range(3):
                    r = subprocess.run([sys.executable, "-c", script], capture_output=True,
                                       text=True, env=dict(os.environ), timeout=600)
                    w, c, cached, translated = r.stdout.split()
                    assert cached == "True" and translated == "False", r.stdout + r.stderr
                    fresh.append((float(w), float(c)))
    finally:
        if old is None:
            os.environ.pop("OBSERVER_CAD_CACHE", None)
        else:
            os.environ["OBSERVER_CAD_CACHE"] = old
    return cold, hits, fresh


def _linear_joint(m, o):
    """A, B (with a constant column) of the joint state update if it is affine, else None."""
    mm = m.substitute_parameters() if m.parameters else m
    if mm.time != "discrete":
        return None
    par = dict(o.parameters)
    ys = output_symbols(len(mm.outputs))
    ysub = dict(zip(ys, mm.outputs))
    s = list(mm.states) + list(o.states)
    v = list(mm.inputs) + list(mm.faults) + list(mm.disturbances) + list(mm.noise)
    upd = list(mm.dynamics) + [sp.sympify(e).xreplace(par).xreplace(ysub) for e in o.update]
    F = sp.Matrix(upd)
    A, B = F.jacobian(s), F.jacobian(v)
    if A.free_symbols or B.free_symbols:
        return None
    c = F.xreplace({x: 0 for x in s + v})
    if c.free_symbols:
        return None
    Bc = B.row_join(c)
    Cy = sp.Matrix(mm.outputs).jacobian(s)
    Dy = sp.Matrix(mm.outputs).jacobian(v).row_join(sp.zeros(len(ys), 1))
    outs = [sp.sympify(e).xreplace(par).xreplace(ysub) for _, e in o.outputs]
    fout = sp.lambdify(s + v, outs, "numpy")
    f = lambda M: np.array(M.tolist(), dtype=float)  # noqa: E731
    return f(A), f(Bc), f(Cy), f(Dy), fout


def _numpy_loop(m, o, s0, V, H):
    """A plain numpy per-step loop of the joint step (the equations lambdified once)."""
    mm = m.substitute_parameters() if m.parameters else m
    par = dict(o.parameters)
    ys = output_symbols(len(mm.outputs))
    ysub = dict(zip(ys, mm.outputs))
    s = list(mm.states) + list(o.states)
    v = list(mm.inputs) + list(mm.faults) + list(mm.disturbances) + list(mm.noise)
    rhs = list(mm.dynamics) + [sp.sympify(e).xreplace(par).xreplace(ysub) for e in o.update]
    outs = list(mm.outputs) + [sp.sympify(e).xreplace(par).xreplace(ysub) for _, e in o.outputs]
    f = sp.lambdify(s + v, rhs, "numpy")
    g = sp.lambdify(s + v, outs, "numpy")
    n, ns, ny = V.shape[0], len(s), len(mm.outputs)
    S, YO = np.empty((n, ns)), np.empty((n, len(outs)))
    discrete = mm.time == "discrete"

    def go():
        x = np.array(s0, float)
        with np.errstate(all="ignore"):
            for i in range(n):
                vi = V[i]
                S[i] = x
                YO[i] = g(*x, *vi)
                if discrete:
                    x = np.array(f(*x, *vi), float)
                else:
                    h = H[i]
                    k1 = np.array(f(*x, *vi), float)
                    k2 = np.array(f(*(h / 2 * k1 + x), *vi), float)
                    k3 = np.array(f(*(h / 2 * k2 + x), *vi), float)
                    k4 = np.array(f(*(h * k3 + x), *vi), float)
                    x = h / 6 * (k1 + 2 * k2 + 2 * k3 + k4) + x
        go.last = (S, YO[:, :ny], YO[:, ny:])
    return go


# ---------------------------------------------------------------- one case
def bench_case(title, path, primary, fallback, scen, a):
    m = load_model(ROOT / "models" / path)
    o, hand_src, label, note, kw = _observer(m, primary, fallback)
    row = {"case": f"{title}, {label}", "note": note, "short": title,
           "observer": o.name, "kind": o.kind}
    cold, hits, fresh = _build_times(m, o, a.cold, 5, ROOT / "models" / path, kw)
    row["build"], row["build_all"] = statistics.median(cold), cold
    row["hit"] = statistics.median(h for h, _ in hits)
    row["hit_all"] = [h for h, _ in hits]
    row["hit_cpu"] = statistics.median(c for _, c in hits)
    row["fresh"] = statistics.median(h for h, _ in fresh)
    row["fresh_all"] = [h for h, _ in fresh]
    row["fresh_cpu"] = statistics.median(c for _, c in fresh)

    work = tempfile.TemporaryDirectory(prefix="ocad-bench-")
    cache = work.name
    cs = CompiledSimulator(m, o, cache=cache)
    hand_lib = ctypes.CDLL(str(compile_source(hand_src, f"hand_{path[:-3]}", cache=cache).path))
    run = hand_lib.run
    run.restype = ctypes.c_int
    run.argtypes = [ctypes.c_longlong] + [ctypes.c_void_p] * 5
    K = a.k
    # the per-step routes use the joint step with the parameters substituted (s, v, h),
    # as before run-time parameters (the trajectory library takes them at run time: s, v, p, h)
    js = joint_step(m, o)
    Fm = compile_function(js.mapaccum(K), cache=cache).function
    step_c = compile_function(js, cache=cache).function
    step_i = js

    # ---- inputs: N grid points, signals as the reference simulator builds them
    N = a.n
    sc = scenario_from_dict(scen(N))
    t, _, n_grid, V3, s0 = cs.prepare(sc)
    assert n_grid == N, (n_grid, N)
    V = np.ascontiguousarray(V3[0])
    H = np.zeros(N)
    H[:-1] = np.diff(t)
    ns_, ny, no, nv = cs.ns, cs.ny, cs.no, cs.nv
    S = np.empty((N, ns_)); Y = np.empty((N, ny)); O = np.empty((N, no))
    S2 = np.empty_like(S); Y2 = np.empty_like(Y); O2 = np.empty_like(O)
    S3 = np.empty((N + 1, ns_)); Y3 = np.empty_like(Y); O3 = np.empty_like(O)

    def traj():
        cs.run_arrays(t, V, s0, S=S, Y=Y, O=O)

    def hand():
        S2[0] = s0
        run(N, t.ctypes.data, V.ctypes.data, S2.ctypes.data, Y2.ctypes.data, O2.ctypes.data)

    buf_m, trig_m = Fm.buffer()
    nfull = N - N % K
    # the numpy memory of every chunk, as memoryviews made once (not timed)
    chunks = [(memoryview(S3[i0]), memoryview(V[i0:i0 + K]), memoryview(H[i0:i0 + K]),
               memoryview(S3[i0 + 1:i0 + K + 1]), memoryview(Y3[i0:i0 + K]),
               memoryview(O3[i0:i0 + K])) for i0 in range(0, nfull, K)]
    set_arg, set_res = buf_m.set_arg, buf_m.set_res

    def mapaccum():
        S3[0] = s0
        for s_, v_, h_, sn_, y_, o_ in chunks:
            set_arg(0, s_)
            set_arg(1, v_)
            set_arg(2, h_)
            set_res(0, sn_)
            set_res(1, y_)
            set_res(2, o_)
            trig_m()
        if nfull < N:     # remainder (N not a multiple of K): the compiled loop
            cs.run_arrays(t[nfull:], V[nfull:], S3[nfull], S=S3[nfull:N], Y=Y3[nfull:],
                          O=O3[nfull:])

    traj(); hand(); mapaccum()
    row["hand_err"] = max(_rel(S, S2), _rel(Y, Y2), _rel(O, O2))
    row["map_err"] = max(_rel(S, S3[:N]), _rel(Y, Y3), _rel(O, O3))

    # ---- per-step Python routes, n_slow steps
    n_s = min(a.n_slow, N)
    h0 = float(H[0]) if N > 1 else 1.0
    Vs = V[:n_s]

    def buffer_route(f):
        buf, trig = f.buffer()
        s = np.array(s0, float)
        sn = np.empty(ns_); yb = np.empty(ny); ob = np.empty(no)
        vrow = np.empty(nv); hb = np.array([h0])
        buf.set_arg(0, memoryview(s)); buf.set_arg(1, memoryview(vrow))
        buf.set_arg(2, memoryview(hb))
        buf.set_res(0, memoryview(sn)); buf.set_res(1, memoryview(yb))
        buf.set_res(2, memoryview(ob))

        def go():
            s[:] = s0
            for i in range(n_s):
                vrow[:] = Vs[i]
                trig()
                s[:] = sn
            go.last = s.copy()
        go.keep = (buf, trig, s, sn, yb, ob, vrow, hb)   # the buffer points into these
        return go

    def numpy_call(f):
        def go():
            x = s0
            for i in range(n_s):
                x = np.asarray(f(x, Vs[i], h0)[0]).ravel()
            go.last = x
        return go

    sc_slow = scenario_from_dict(scen(n_s))

    def simulate_route():
        simulate_route.last = simulate(m, o, sc_slow)

    numpy_loop = _numpy_loop(m, o, s0, Vs, H[:n_s])

    routes = {"traj": (traj, N), "mapaccum": (mapaccum, N), "hand": (hand, N),
              "c_buffer": (buffer_route(step_c), n_s), "c_numpy": (numpy_call(step_c), n_s),
              "i_buffer": (buffer_route(step_i), n_s), "i_numpy": (numpy_call(step_i), n_s),
              "numpy": (numpy_loop, n_s), "simulate": (simulate_route, n_s)}
    lin = _linear_joint(m, o)
    if lin is not None:
        A, Bc, Cy, Dy, fout = lin
        U = np.column_stack([Vs, np.ones(n_s)])
        sys_d = (A, Bc, Cy, Dy, 1.0)

        def dlsim_route():
            _, yout, xout = scipy.signal.dlsim(sys_d, U, x0=s0)
            with np.errstate(all="ignore"):
                outs = fout(*xout.T, *Vs.T)
            dlsim_route.last = (xout, yout, np.column_stack(
                [np.broadcast_to(np.asarray(q, float), (n_s,)) for q in outs]))
        routes["dlsim"] = (dlsim_route, n_s)

    cpu = {k: [] for k in routes}
    wall = {k: [] for k in routes}
    for r in range(a.repeat):
        for k, (fn, _) in routes.items():
            if ROUTES_KIND[k] == "slow" and r >= a.slow_repeat:
                continue
            c, w = _timed(fn)
            cpu[k].append(c)
            wall[k].append(w)
    for k, (_, n) in routes.items():
        row[k] = statistics.median(cpu[k]) / n * 1e9
        row[k + "_wall"] = statistics.median(wall[k]) / n * 1e9
        row[k + "_n"] = n
    # the slow routes reproduce the compiled trajectory (state after n_s steps)
    s_end = S[n_s] if n_s < N else None
    errs = {}
    if s_end is not None:
        for k in ("c_buffer", "c_numpy", "i_buffer", "i_numpy"):
            errs[k] = _rel(s_end, routes[k][0].last)
    Sn, Yn, On = numpy_loop.last
    errs["numpy"] = max(_rel(S[:n_s], Sn), _rel(Y[:n_s], Yn), _rel(O[:n_s], On))
    ref, res = simulate_route.last, cs.simulate(sc_slow)
    errs["simulate"] = max(_rel(ref[c][np.isfinite(ref[c])], res[c][np.isfinite(ref[c])])
                           for c in ref.columns)
    if lin is not None:
        xo, yo, oo = routes["dlsim"][0].last
        errs["dlsim"] = max(_rel(S[:n_s], xo), _rel(Y[:n_s], yo), _rel(O[:n_s], oo))
    row["route_err"] = errs
    row["dlsim_note"] = None if lin is not None else "not linear"
    work.cleanup()
    return row


ROUTES_KIND = {k: kind for k, _, kind in ROUTES}


# ---------------------------------------------------------------- tables
def _ns(v):
    if v >= 100:
        return f"{v:,.0f}"
    return f"{v:.1f}"


def _ok(flag):
    return "pass" if flag else "**FAIL**"


def render(rows, a, load0, load1) -> str:
    now = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
    lines = [f"Measured {now} by `python3 benchmarks/bench_codegen.py --write`: {os.cpu_count()}"
             f" CPUs ({cpu_name()}), Python {platform.python_version()}, CasADi {ca.__version__},"
             f" numpy {np.__version__}, scipy {scipy.__version__}, gcc -O3."
             f" Load average (1, 5, 15 min) {load0} at the start, {load1} at the end.",
             "",
             f"ns per step: median CPU time of the process over {a.repeat} rounds (per-step"
             f" Python routes: {a.slow_repeat} rounds), wall-clock median in the `wall` column;"
             f" compiled routes and hand C run N = {a.n:,} steps, the per-step Python routes"
             f" N = {a.n_slow:,} steps (reported per step). × = ratio to the hand-written"
             " C loop.", ""]
    for r in rows:
        if r["note"]:
            lines.append(f"**Fallback** for the {r['short']}: {r['note']}")
            lines.append("")
    head = "| route | N |"
    sep = "|---|---|"
    for r in rows:
        head += f" {r['short']}: ns/step | × | wall |"
        sep += "---|---|---|"
    lines += [head, sep]
    for key, text, kind in ROUTES:
        n = a.n if kind == "fast" else a.n_slow
        cells = f"| {text.format(k=a.k)} | {n:,} |"
        for r in rows:
            if key not in r or r.get(key) is None:
                cells += " n/a (not linear) | | |"
            else:
                cells += (f" {_ns(r[key])} | {r[key] / r['hand']:.1f} |"
                          f" {_ns(r[key + '_wall'])} |")
        lines.append(cells)
    lines += ["", "Cases:"]
    for r in rows:
        lines.append(f"- **{r['short']}**: {r['case']} (`{r['observer']}`); joint plant +"
                     " observer step as the reference simulator runs it.")
    lines += ["", "| case | target | measured | result |", "|---|---|---|---|"]
    for r in rows:
        q = r["traj"] / r["hand"]
        qm = r["mapaccum"] / r["hand"]
        sp_ = r["numpy"] / r["traj"]
        spm = r["numpy"] / r["mapaccum"]
        lines += [
            f"| {r['short']} | compiled trajectory (C loop) ≤ {TARGET_HAND:g}× hand C |"
            f" {q:.2f}× | {_ok(q <= TARGET_HAND)} |",
            f"| {r['short']} | compiled trajectory (mapaccum) ≤ {TARGET_HAND:g}× hand C |"
            f" {qm:.2f}× | {_ok(qm <= TARGET_HAND)} |",
            f"| {r['short']} | compiled trajectory (C loop) ≥ {TARGET_NUMPY:g}× faster than"
            f" the plain numpy loop | {sp_:,.0f}× | {_ok(sp_ >= TARGET_NUMPY)} |",
            f"| {r['short']} | compiled trajectory (mapaccum) ≥ {TARGET_NUMPY:g}× faster than"
            f" the plain numpy loop | {spm:,.0f}× | {_ok(spm >= TARGET_NUMPY)} |",
            f"| {r['short']} | generate + compile + load < {TARGET_BUILD:g} s (median of"
            f" {len(r['build_all'])} cold caches, wall-clock) | {r['build']:.2f} s (max"
            f" {max(r['build_all']):.2f} s) | {_ok(r['build'] < TARGET_BUILD)} |",
            f"| {r['short']} | cache hit < {TARGET_HIT * 1e3:g} ms, same process (median of"
            f" {len(r['hit_all'])}, wall-clock) | {r['hit'] * 1e3:.2f} ms (max"
            f" {max(r['hit_all']) * 1e3:.2f} ms; CPU {r['hit_cpu'] * 1e3:.2f} ms) |"
            f" {_ok(max(r['hit_all']) < TARGET_HIT)} |",
            f"| {r['short']} | cache hit < {TARGET_HIT * 1e3:g} ms, fresh process (median of"
            f" {len(r['fresh_all'])}, wall-clock) | {r['fresh'] * 1e3:.2f} ms (max"
            f" {max(r['fresh_all']) * 1e3:.2f} ms; CPU {r['fresh_cpu'] * 1e3:.2f} ms) |"
            f" {_ok(max(r['fresh_all']) < TARGET_HIT)} |"]
    lines += ["", "Agreement with the compiled trajectory (max error relative to each array's"
              " largest magnitude):"]
    for r in rows:
        e = r["route_err"]
        parts = [f"hand C {r['hand_err']:.1g}", f"mapaccum {r['map_err']:.1g}"]
        parts += [f"{k} {v:.1g}" for k, v in e.items()]
        lines.append(f"- {r['short']}: " + ", ".join(parts))
    return "\n".join(lines)


def write_readme(table: str) -> None:
    write_section(README, BEGIN, END, table)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10**6, help="steps of the compiled routes")
    ap.add_argument("--n-slow", type=int, default=20000, help="steps of the per-step routes")
    ap.add_argument("--k", type=int, default=1000, help="mapaccum chunk length")
    ap.add_argument("--repeat", type=int, default=7, help="rounds (compiled routes)")
    ap.add_argument("--slow-repeat", type=int, default=3, help="rounds (per-step routes)")
    ap.add_argument("--cold", type=int, default=3, help="cold-cache builds")
    ap.add_argument("--write", action="store_true", help="update benchmarks/README.md")
    a = ap.parse_args(argv)
    faulthandler.enable()
    a.slow_repeat = min(a.slow_repeat, a.repeat)
    load0 = _load()
    rows = [bench_case(*c, a) for c in CASES]
    table = render(rows, a, load0, _load())
    print(table)
    if a.write:
        write_readme(table)
        print(f"\nwrote {README}")


if __name__ == "__main__":
    main()
