#!/usr/bin/env python3
"""Ensemble backends benchmark: runs per second of a compiled task on
serial, threads, loky processes and a Dask LocalCluster, side by side in one run.

    python3 benchmarks/bench_backends.py            # measure, print the table
    python3 benchmarks/bench_backends.py --write    # ... and update benchmarks/README.md

The task is what an ensemble chunk does: a C loop (3 nonlinear states, a few libm calls
per step, :data:`STEPS` steps per run, ≈ 0.3 ms per run) compiled once with
``compile_source``, sent to the workers as a ``LibrarySpec`` inside the payload, loaded
there with ``load_library`` from the content-hashed cache, and called through ctypes on
a numpy buffer for each chunk of runs (``chunk = (first, count)``).

1. **Throughput**: :data:`RUNS` runs per map, chunk sizes 1, 16 and 256, on serial,
   threads(2), processes(2) (loky, pool warm) and Dask (a 2-process LocalCluster started
   once, ``threads_per_worker=1``; each map connects a Client and scatters the payload,
   which is counted).  Runs per second (median of :data:`REPEATS`), the speed-up over
   the serial backend at the same chunk size, and the "direct" figure: the same runs in
   one ctypes call in this process (no backend at all).  Every backend's results are
   checked bit for bit against the direct call.
   Targets: threads(2) and processes(2) ≥ :data:`TARGET_SPEEDUP` × serial at chunk 16,
   Dask ≥ :data:`TARGET_SPEEDUP` × at chunk 256 (a 2-core machine).
2. **Per-chunk overhead**: the same maps with ``steps = 0`` (the task does nothing but
   the call): wall time per chunk, chunk size 1.
3. **Start-up**: the first map of one chunk on a cold backend: a new loky pool (spawn,
   imports, payload), a new Dask LocalCluster (started and closed by ``map_chunks``).
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

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from observer_cad.codegen import compile_source, library_spec, load_library  # noqa: E402
from observer_cad.ensemble import Backend, map_chunks  # noqa: E402
from common import load as _load, machine as _machine, publish  # noqa: E402

README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN BACKENDS RESULTS (bench_backends.py --write) -->"
END = "<!-- END BACKENDS RESULTS -->"
RUNS = 2048
STEPS = 3000
CHUNKS = (1, 16, 256)
REPEATS = 3
WORKERS = 2
TARGET_SPEEDUP = 1.6

SOURCE = r"""
#include <math.h>
/* out[k]: a functional of run first + k (3 nonlinear states, `steps` steps) */
void bench_runs(long first, long count, long steps, double* out) {
  long k, s;
  for (k = 0; k < count; ++k) {
    long i = first + k;
    double x1 = 0.1 + 1e-3 * (double)(i % 997), x2 = 0.0, x3 = 0.5, acc = 0.0;
    for (s = 0; s < steps; ++s) {
      double t = 0.001 * (double)s + 1e-3 * (double)i;
      double u = sin(t) + 0.3 * cos(3.0 * t) + 0.1 * sin(7.0 * t + x3);
      double n1 = x1 + 0.002 * x2;
      double n2 = 0.8 * x2 + 0.02 * x3 + 0.05 * tanh(x1) * exp(-0.1 * x2 * x2);
      double n3 = -0.0004 * x2 + 0.96 * x3 + 0.04 * u + 0.01 * sqrt(1.0 + x1 * x1);
      x1 = n1; x2 = n2; x3 = n3;
      acc += fabs(x1 - x3) + log1p(x2 * x2) + 0.01 * atan(x1 * x3);
    }
    out[k] = acc;
  }
}
"""

def _function(spec):
    """The loop, from this process's load_library memo (its argtypes set once: ctypes
    keeps the function object on the library).  No module-level memo: the task is
    pickled by value from __main__, with the globals it uses."""
    fn = load_library(spec).bench_runs
    if fn.argtypes is None:
        fn.restype = None
        fn.argtypes = [ctypes.c_long, ctypes.c_long, ctypes.c_long,
                       np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")]
    return fn


def task(payload, chunk):
    """One chunk: runs first … first + count − 1 of the compiled loop."""
    spec, steps = payload
    first, count = chunk
    out = np.empty(count)
    _function(spec)(first, count, steps, out)
    return out


def _chunks(size: int, runs: int = RUNS):
    return [(f, min(size, runs - f)) for f in range(0, runs, size)]


def _map(backend, payload, size, runs=RUNS):
    t = time.perf_counter()
    pairs = list(map_chunks(task, payload, _chunks(size, runs), backend=backend))
    dt = time.perf_counter() - t
    pairs.sort(key=lambda p: p[0][0])
    return dt, np.concatenate([r for _, r in pairs])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="update benchmarks/README.md")
    args = ap.parse_args()

    import distributed
    with tempfile.TemporaryDirectory(prefix="bench_backends-") as cache:
        os.environ["OBSERVER_CAD_CACHE"] = cache  # the workers inherit it
        r = compile_source(SOURCE, "bench_backends")
        spec = library_spec(SOURCE, "bench_backends", r)
        payload, empty = (spec, STEPS), (spec, 0)

        # the direct call: no backend
        direct = []
        for _ in range(REPEATS):
            t = time.perf_counter()
            ref = task(payload, (0, RUNS))
            direct.append(time.perf_counter() - t)
        t_direct = statistics.median(direct)
        ms_per_run = t_direct / RUNS * 1e3

        # start-up: cold loky pool (a new payload forces a fresh pool), cold LocalCluster
        t = time.perf_counter()
        list(map_chunks(task, (spec, 1), [(0, 1)], backend=Backend("processes", WORKERS)))
        startup_loky = time.perf_counter() - t
        t = time.perf_counter()
        list(map_chunks(task, (spec, 1), [(0, 1)], backend=Backend("dask", WORKERS)))
        startup_dask = time.perf_counter() - t

        cluster = distributed.LocalCluster(n_workers=WORKERS, threads_per_worker=1,
                                           processes=True, dashboard_address=None)
        try:
            backends = {"serial": Backend("serial"),
                        "threads(2)": Backend("threads", WORKERS),
                        "processes(2)": Backend("processes", WORKERS),
                        "dask LocalCluster(2)": Backend("dask", WORKERS,
                                                        address=cluster.scheduler_address)}
            rate, overhead = {}, {}
            for name, b in backends.items():
                _map(b, payload, 256, runs=512)  # warm: pool up, library loaded
                for size in CHUNKS:
                    times = []
                    for _ in range(REPEATS):
                        dt, vals = _map(b, payload, size)
                        if not np.array_equal(vals, ref):
                            raise SystemExit(f"{name}, chunk {size}: results differ from"
                                             " the direct call")
                        times.append(dt)
                    rate[name, size] = RUNS / statistics.median(times)
                    print(f"{name:22s} chunk {size:4d}: {rate[name, size]:8.0f} runs/s",
                          flush=True)
                times = [_map(b, empty, 1)[0] for _ in range(REPEATS)]
                overhead[name] = statistics.median(times) / RUNS * 1e6
        finally:
            cluster.close()

    m = _machine()
    lines = [f"Measured {time.strftime('%Y-%m-%d')} on {m['nproc']} CPUs ({m['cpu']}),"
             f" Python {m['python']}, numpy {m['numpy']}; load average {_load()}"
             f" (other work may share the machine). {RUNS} runs of {STEPS} steps per map,"
             f" {ms_per_run:.3f} ms per run; medians of {REPEATS}. Results identical"
             " (bit for bit) to the direct call on every backend and chunk size.", "",
             f"Direct call (one ctypes call in this process, no backend):"
             f" {RUNS / t_direct:,.0f} runs/s.", "",
             "| backend | " + " | ".join(f"chunk {c}: runs/s (× serial)" for c in CHUNKS)
             + " | overhead per chunk (steps = 0) | target | met |",
             "|---|" + "---|" * len(CHUNKS) + "---|---|---|"]
    for name in backends:
        cells = [f"{rate[name, c]:,.0f} ({rate[name, c] / rate['serial', c]:.2f}×)"
                 for c in CHUNKS]
        if name == "serial":
            target, met = "—", "—"
        else:
            at = 256 if name.startswith("dask") else 16
            ok = rate[name, at] / rate["serial", at] >= TARGET_SPEEDUP
            target, met = f"≥ {TARGET_SPEEDUP}× serial at chunk {at}", "met" if ok else "MISSED"
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {overhead[name]:,.1f} µs"
                     f" | {target} | {met} |")
    lines += ["", f"Start-up (first map of one chunk, cold): loky pool of {WORKERS}"
              f" {startup_loky:.2f} s; Dask LocalCluster of {WORKERS} processes started and"
              f" closed by `map_chunks` {startup_dask:.2f} s. A Dask map on a running"
              " cluster connects a Client and scatters the payload each time (included in"
              " the rates above)."]
    publish("\n".join(lines), README, BEGIN, END, write=args.write)


if __name__ == "__main__":
    main()
