#!/usr/bin/env python3
"""Decision and evaluation benchmark: the cost of deciding on residuals and of
a Monte-Carlo evaluation, side by side.

    python3 benchmarks/bench_decisions.py            # measure, print the table
    python3 benchmarks/bench_decisions.py --write    # ... and update benchmarks/README.md

1. ``decide`` on R = 1,000 runs × N = 2,000 samples × m = 3 residuals (random residuals
   and bands, persistence 3), three implementations compared on the same arrays:
   the numpy reference ``observer_cad.observers.decide`` (vectorised over runs and time),
   a plain Python loop over the samples (the obvious implementation; timed on 20 runs
   and scaled), and the exported C ``NAME_decide`` called in a C loop over all samples
   (``export_observer(..., rule=...)`` of the isolation bank, compiled ``-O2`` into a
   shared library, one ctypes call on numpy buffers). All three must give the same codes.
   Target: numpy ``decide`` ≤ 200 ns per sample of m = 3 residuals (it must stay a small
   part of a Monte-Carlo evaluation; the simulator costs several µs per sample).
2. ``evaluate_ensemble`` on the electric drive (discrete, residual generator for d,
   ρ and the noise uniform within their bounds): the fault-free case and d = 0.2 from
   t = 1,000, 1,000 runs × 2,000 steps each (the size of the evaluation test), constant band
   ±0.1; timed whole, and the share of the reference simulator in it. Target < 30 s.
"""
from __future__ import annotations

import argparse
import ctypes
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from observer_cad.codegen import export_observer  # noqa: E402
from observer_cad.model import load_model  # noqa: E402
from observer_cad.residuals import DecisionRule, decide, decision_rule
from observer_cad.observers import build_observer  # noqa: E402
from observer_cad import simulation as _sim  # noqa: E402
from observer_cad.simulation import evaluate_ensemble, scenario_from_dict  # noqa: E402
from observer_cad.synthesis import design
from observer_cad.analysis import design_bank  # noqa: E402
from common import load as _load, machine as _machine, publish  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN DECISION RESULTS (bench_decisions.py --write) -->"
END = "<!-- END DECISION RESULTS -->"
TARGET_DECIDE_NS = 200.0
TARGET_ENSEMBLE_S = 30.0

LOOP_C = r"""
#include "NAME.h"
/* r, lo, hi: [n][NRES] row-major; codes: [n]; one trajectory after another (counters
   reset at the start of each of the runs of length len) */
void bench_loop(long runs, long len, const double* r, const double* lo, const double* hi,
                int* codes) {
  long k, j;
  int counters[NAME_NRES], alarms[NAME_NRES], i;
  for (k = 0; k < runs; ++k) {
    for (i = 0; i < NAME_NRES; ++i) counters[i] = 0;
    for (j = 0; j < len; ++j) {
      long s = k * len + j;
      codes[s] = NAME_decide(r + s * NAME_NRES, lo + s * NAME_NRES, hi + s * NAME_NRES,
                             counters, alarms);
    }
  }
}
"""


def _python_loop(rule: DecisionRule, cols: dict) -> np.ndarray:
    m = len(rule.residuals)
    R, N = cols[rule.residuals[0]].shape
    codes = np.zeros((R, N), dtype=np.int64)
    for k in range(R):
        c = [0] * m
        for j in range(N):
            code = 0
            for i, name in enumerate(rule.residuals):
                v = cols[name][k, j]
                if v < cols[name + "_lower"][k, j] or v > cols[name + "_upper"][k, j]:
                    c[i] += 1
                else:
                    c[i] = 0
                if c[i] >= rule.persistence:
                    code |= 1 << i
            codes[k, j] = code
    return codes


def _median(f, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def bench_decide(R: int, N: int, repeat: int) -> list:
    tanks = load_model(ROOT / "models" / "three_tank_isolation.py")
    bank = design_bank(tanks, structure="011,101,110")
    rule = decision_rule(tanks, bank, persistence=3)
    rng = np.random.default_rng(0)
    cols = {}
    for r in rule.residuals:
        cols[r] = rng.uniform(-1.2, 1.2, (R, N))
        cols[r + "_lower"] = np.full((R, N), -1.0)
        cols[r + "_upper"] = rng.uniform(0.9, 1.1, (R, N))
    samples = R * N
    t_np, ref = _median(lambda: decide(rule, cols), repeat)
    sub = 20
    t_py, codes_py = _median(lambda: _python_loop(rule, {k: v[:sub] for k, v in cols.items()}), 1)
    t_py *= R / sub
    rows = [("numpy `decide` (reference)", t_np, True),
            ("Python loop over samples (20 runs, scaled)", t_py,
             bool(np.array_equal(codes_py, ref.code[:sub])))]
    cc = shutil.which("cc")
    if cc:
        obs = build_observer(tanks, bank)
        with tempfile.TemporaryDirectory() as tmp:
            paths = export_observer(obs, tmp, dt=0.01, rule=rule)
            name = paths[0].stem
            (Path(tmp) / "loop.c").write_text(LOOP_C.replace("NAME", name))
            lib = Path(tmp) / "libdecide.so"
            subprocess.run([cc, "-O2", "-std=c99", "-shared", "-fPIC", str(paths[0]),
                            str(Path(tmp) / "loop.c"), "-o", str(lib), "-lm"], check=True)
            so = ctypes.CDLL(str(lib))
            f = so.bench_loop
            f.restype = None
            P = ctypes.POINTER(ctypes.c_double)
            f.argtypes = [ctypes.c_long, ctypes.c_long, P, P, P, ctypes.POINTER(ctypes.c_int)]
            r = np.ascontiguousarray(np.stack([cols[n] for n in rule.residuals], axis=-1))
            lo = np.ascontiguousarray(np.stack([cols[n] for n in rule.lower_names], axis=-1))
            hi = np.ascontiguousarray(np.stack([cols[n] for n in rule.upper_names], axis=-1))
            codes = np.zeros((R, N), dtype=np.intc)

            def run_c():
                f(R, N, r.ctypes.data_as(P), lo.ctypes.data_as(P), hi.ctypes.data_as(P),
                  codes.ctypes.data_as(ctypes.POINTER(ctypes.c_int)))
                return codes
            t_c, got = _median(run_c, repeat)
            rows.append(("exported C `NAME_decide` in a C loop (-O2, one ctypes call)", t_c,
                         bool(np.array_equal(got, ref.code))))
    return [(label, t, t / samples * 1e9, same) for label, t, same in rows]


def bench_ensemble(runs: int, steps: int) -> dict:
    drive = load_model(ROOT / "models" / "electric_drive.py")
    d = design(drive, observer="diagnostic")
    obs = build_observer(drive, d)
    rule = decision_rule(drive, d, persistence=1)
    sc = scenario_from_dict({"steps": steps, "seed": 0, "initial": {"x1": 0.1},
                             "signals": {"u": "sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                                         "w1": {"uniform": [-0.01, 0.01]},
                                         "w2": {"uniform": [-0.01, 0.01]}}})
    band = 0.1

    def add(res):
        return {"r_lower": np.full_like(res["r"], -band), "r_upper": np.full_like(res["r"], band)}

    spent = [0.0]
    original = _sim._evaluation.simulate

    def timed_simulate(*a, **k):
        t = time.perf_counter()
        out = original(*a, **k)
        spent[0] += time.perf_counter() - t
        return out
    _sim._evaluation.simulate = timed_simulate
    try:
        t = time.perf_counter()
        m = evaluate_ensemble(drive, obs, sc, rule, cases={"d": (0.2, steps // 2)}, runs=runs,
                              seed=1, add_columns=add)
        total = time.perf_counter() - t
    finally:
        _sim._evaluation.simulate = original
    return {"total": total, "simulate": spent[0], "metrics": m, "band": band}


def run(args) -> str:
    info = _machine()
    load0 = _load()
    started = time.strftime("%Y-%m-%d %H:%M")
    dec = bench_decide(args.runs, args.steps, args.repeat)
    for row in dec:
        print(row, flush=True)
    ens = bench_ensemble(args.runs, args.steps)
    print(ens["total"], ens["simulate"], flush=True)
    print(ens["metrics"].to_text(), flush=True)
    load1 = _load()
    loads = [float(x) for x in (load0 + " " + load1).split() if x != "?"]
    busy = max(loads) if loads else 0.0
    lines = []
    if busy > 0.75 * info["nproc"]:
        lines += [f"**The machine was busy** (load average up to {busy:.1f} on {info['nproc']}"
                  " CPUs; other work ran beside the benchmark): times are inflated and noisy.", ""]
    lines += [f"Measured {started} by `python3 benchmarks/bench_decisions.py --write`:"
              f" {info['nproc']} CPUs ({info['cpu']}), Python {info['python']}, numpy"
              f" {info['numpy']}, {info['platform']}. Load average (1, 5, 15 min) {load0} at the"
              f" start, {load1} at the end.", "",
              f"**decide**: R = {args.runs} runs × N = {args.steps} samples × m = 3 residuals,"
              f" persistence 3; median of {args.repeat} (the Python loop: once, on 20 runs,"
              " scaled).", "",
              "| implementation | time | ns per sample (3 residuals) | × numpy | codes equal"
              " the reference | target | ratio |",
              "|---|---|---|---|---|---|---|"]
    t_np = dec[0][1]
    for label, t, ns, same in dec:
        target = (f"≤ {TARGET_DECIDE_NS:g} ns" if label.startswith("numpy") else "—")
        ratio = (f"{ns / TARGET_DECIDE_NS:.2f} ({'met' if ns <= TARGET_DECIDE_NS else '**MISSED**'})"
                 if label.startswith("numpy") else "—")
        lines.append(f"| {label} | {t:.3g} s | {ns:.3g} | {t / t_np:.3g} | {'yes' if same else '**no**'}"
                     f" | {target} | {ratio} |")
    m = ens["metrics"]
    med, mx = m.delay_stats()
    ok = ens["total"] < TARGET_ENSEMBLE_S
    lines += ["",
              f"**evaluate_ensemble**: electric drive residual generator, fault-free and d = 0.2"
              f" from t = {args.steps // 2}, {args.runs} runs × {args.steps} steps each, constant"
              f" band ±{ens['band']:g}.", "",
              "| measured | value |", "|---|---|",
              f"| total | {ens['total']:.3g} s |",
              f"| of which the reference simulator | {ens['simulate']:.3g} s"
              f" ({ens['simulate'] / ens['total']:.0%}) |",
              f"| decide + metrics + scenario building | {ens['total'] - ens['simulate']:.3g} s |",
              f"| target | < {TARGET_ENSEMBLE_S:g} s: {ens['total'] / TARGET_ENSEMBLE_S:.2f}"
              f" ({'met' if ok else '**MISSED**'}) |",
              f"| false alarms (fault-free samples) | {m.false_alarm_samples} in"
              f" {m.false_alarm_runs} runs (the constant band is a stand-in, not a guaranteed"
              " threshold) |",
              f"| missed detections | {m.missed_detections}/{m.faulty_runs} |",
              f"| detection delay median / max | {med} / {mx} steps |",
              f"| isolation accuracy | {m.isolation_accuracy:.3g} |"]
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="update benchmarks/README.md")
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    table = run(args)
    publish(table, README, BEGIN, END, write=args.write)


if __name__ == "__main__":
    main()
