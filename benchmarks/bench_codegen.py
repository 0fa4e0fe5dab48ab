"""Benchmark: compiled observer trajectories against the other routes.

    python3 benchmarks/bench_codegen.py [--n 1000000] [--repeat 5]

For each case (plant + observer as one joint step, as the reference simulator runs them)
it measures, side by side in one run, the median ns per step of

  traj     the compiled trajectory: casadi-generated joint step inside a generated C
           loop over numpy buffers, one ctypes call   (observer_cad.codegen.trajectory)
  handC    a hand-written C loop of the same step, -O3 (the practical limit); its
           result is checked against the compiled trajectory before timing
  buffer   the compiled casadi step called per step from Python via Function.buffer()
  np-call  the compiled casadi step called per step with numpy in/out
  interp   the interpreted casadi step called per step with numpy in/out
  numpy    the reference numpy simulator (observer_cad.simulate: a per-step numpy loop)

N = --n for traj/handC; the per-step Python routes run --n-slow steps (default 20 000)
and are reported per step.  Also: generate + compile + load (cold cache) and a cache
hit.  Prints a markdown table.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from observer_cad.codegen import CompiledSimulator, compile_function  # noqa: E402
from observer_cad.codegen.compile import compile_source  # noqa: E402
from observer_cad.model import load_model  # noqa: E402
from observer_cad.pipeline import build_observer  # noqa: E402
from observer_cad.simulate import scenario_from_dict, simulate  # noqa: E402
from observer_cad.synthesis import design  # noqa: E402

HAND_ED = r"""
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

HAND_TT = r"""
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

CASES = [
    ("electric drive, diagnostic observer (discrete)", "electric_drive.py",
     dict(observer="diagnostic", faults=["d"], disturbances=["rho"]), HAND_ED,
     lambda n: {"steps": n, "initial": {"x1": 0.1}, "signals": {"u": "sin(t/10)"}}),
    ("three-tank, nonlinear virtual sensor (RK4)", "three_tank.py",
     dict(observer="virtual-sensor", estimate="x1"), HAND_TT,
     lambda n: {"t_end": n * 0.001, "dt": 0.001,
                "initial": {"x1": 1.53, "x2": 1.28, "x3": 0.64},
                "observer_initial": {"xs1": 1.6},
                "signals": {"u1": 0.5, "u2": 0.3}}),
]


def median_time(fn, repeat):
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def bench_case(title, path, kw, hand, scen, n, n_slow, repeat):
    m = load_model(ROOT / "models" / path)
    o = build_observer(m, design(m, **kw))
    row = {"case": title}
    with tempfile.TemporaryDirectory() as cache:
        t0 = time.perf_counter()
        cs = CompiledSimulator(m, o, cache=cache)
        row["build"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        CompiledSimulator(m, o, cache=cache)
        row["hit"] = time.perf_counter() - t0
        step_c = compile_function(cs.step, cache=cache).function
        hand_lib = ctypes.CDLL(str(compile_source(hand, f"hand_{path[:-3]}", cache=cache).path))
    run = hand_lib.run
    run.restype = ctypes.c_int
    run.argtypes = [ctypes.c_longlong] + [ctypes.c_void_p] * 5

    sc = scenario_from_dict(scen(n))
    t, R, N, V, s0 = cs._prepare(sc, None)
    V = np.ascontiguousarray(V[0])
    S, Y, O = np.empty((N, cs.ns)), np.empty((N, cs.ny)), np.empty((N, cs.no))
    S2, Y2, O2 = np.empty_like(S), np.empty_like(Y), np.empty_like(O)

    def traj():
        cs.run_arrays(t, V, s0, S=S, Y=Y, O=O)

    def handc():
        S2[0] = s0
        run(N, t.ctypes.data, V.ctypes.data, S2.ctypes.data, Y2.ctypes.data, O2.ctypes.data)

    traj()
    handc()
    scale = np.max(np.abs(S))
    row["hand_err"] = float(np.max(np.abs(S - S2)) / scale)
    row["traj"] = median_time(traj, repeat) / N * 1e9
    row["handC"] = median_time(handc, repeat) / N * 1e9

    # per-step Python routes on n_slow steps
    ns = min(n_slow, N)
    h = float(t[1] - t[0]) if t.size > 1 else 1.0
    s = np.array(s0)
    sn = np.empty(cs.ns)
    yb, ob = np.empty(cs.ny), np.empty(cs.no)
    hb = np.array([h])
    buf, trig = step_c.buffer()
    buf.set_arg(0, memoryview(s))
    vrow = np.empty(cs.nv)
    buf.set_arg(1, memoryview(vrow))
    buf.set_arg(2, memoryview(hb))
    buf.set_res(0, memoryview(sn))
    buf.set_res(1, memoryview(yb))
    buf.set_res(2, memoryview(ob))

    def buffer_route():
        for i in range(ns):
            vrow[:] = V[i]
            trig()
            s[:] = sn

    def npcall(f):
        def go():
            x = s0
            for i in range(ns):
                x = np.asarray(f(x, V[i], h)[0]).ravel()
        return go

    slow_rep = max(1, repeat // 2)
    row["buffer"] = median_time(buffer_route, slow_rep) / ns * 1e9
    row["np-call"] = median_time(npcall(step_c), slow_rep) / ns * 1e9
    row["interp"] = median_time(npcall(cs.step), slow_rep) / ns * 1e9
    sc_slow = scenario_from_dict(scen(ns))
    row["numpy"] = median_time(lambda: simulate(m, o, sc_slow), slow_rep) / ns * 1e9
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10**6)
    ap.add_argument("--n-slow", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args(argv)
    rows = [bench_case(*c, a.n, a.n_slow, a.repeat) for c in CASES]
    routes = ["traj", "handC", "buffer", "np-call", "interp", "numpy"]
    print(f"ns per step (median of {a.repeat}; traj/handC N = {a.n}, per-step routes N ="
          f" {a.n_slow}); ratio to handC in parentheses\n")
    print("| case | " + " | ".join(routes) + " | numpy/traj | build (s) | cache hit (ms) |")
    print("|---" * (len(routes) + 4) + "|")
    for r in rows:
        cells = [f"{r[k]:.1f} ({r[k] / r['handC']:.1f}×)" for k in routes]
        print(f"| {r['case']} | " + " | ".join(cells) +
              f" | {r['numpy'] / r['traj']:.0f}× | {r['build']:.3f} | {r['hit'] * 1e3:.1f} |")
    print()
    for r in rows:
        print(f"{r['case']}: hand C vs compiled trajectory max relative state difference"
              f" {r['hand_err']:.2g}")


if __name__ == "__main__":
    main()
