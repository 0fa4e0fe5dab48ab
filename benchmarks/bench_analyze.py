#!/usr/bin/env python3
"""Diagnosability-analysis benchmark (issue 12 item 7): ``analyze`` on a 20-state,
6-fault random model, target < 2 s.

    python3 benchmarks/bench_analyze.py [--runs 5] [--l 8] [--p 1] [--seed 0] [--gauss]

The model: F, H, L from ``observer_cad.model.random_matrices(n=20, l, p, seed)`` (small
integers in −2..2, or with ``--gauss`` N(0, 1)-based rationals with denominator 1000) and
six fault columns drawn from the same kind of distribution with ``seed + 1``. Timed:
``analyze(model)`` as a user calls it (structure extraction included, every pair, all
63 structure-matrix rows), the median of ``--runs`` calls in one process, and the first
call separately. Prints one line per number; the benchmark tables are not updated.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import sympy as sp

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from observer_cad import PlantModel  # noqa: E402
from observer_cad.model import random_matrices  # noqa: E402
from observer_cad.synthesis import analyze  # noqa: E402

TARGET = 2.0


def fault_model(n=20, l=8, p=1, m=6, seed=0, integer=True):  # noqa: E741
    mats = random_matrices(n, l, p, seed=seed, m=0, integer=integer)
    rng = np.random.default_rng(seed + 1)
    if integer:
        D = sp.Matrix(n, m, [int(v) for v in rng.integers(-2, 3, size=n * m)])
    else:
        D = sp.Matrix(n, m, [sp.Rational(int(round(v * 1000)), 1000)
                             for v in rng.standard_normal(n * m)])
    xs = sp.symbols(f"x1:{n + 1}")
    fs = sp.symbols(f"f1:{m + 1}")
    rs = sp.symbols(f"rho1:{p + 1}") if p else ()
    F, H, L = mats["F"], mats["H"], mats["L"]
    dyn = [sp.Add(*[F[i, j] * xs[j] for j in range(n)], *[D[i, j] * fs[j] for j in range(m)],
                  *[L[i, j] * rs[j] for j in range(p)]) for i in range(n)]
    outs = [sp.Add(*[H[i, j] * xs[j] for j in range(n)]) for i in range(l)]
    return PlantModel(name=f"random_n{n}_l{l}_p{p}_m{m}_seed{seed}", time="discrete",
                      states=list(xs), faults=list(fs), disturbances=list(rs),
                      outputs=outs, dynamics=dyn)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--l", type=int, default=8)
    ap.add_argument("--p", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--gauss", action="store_true")
    args = ap.parse_args(argv)
    model = fault_model(l=args.l, p=args.p, seed=args.seed, integer=not args.gauss)
    times = []
    for i in range(args.runs):
        t0 = time.perf_counter()
        a = analyze(model)
        times.append(time.perf_counter() - t0)
        if i == 0:
            first = times[0]
    med = statistics.median(times)
    print(f"model: {model.name} ({'gauss' if args.gauss else 'integer'} entries)")
    print(f"detectable: {a.detectable}")
    print(f"min_order: {a.min_order}")
    print(f"isolable pairs: {sum(p.isolable for p in a.pairs)}/{len(a.pairs)};"
          f" achievable structure rows: {len(a.structure)}")
    print(f"analyze first call: {first:.3f} s")
    print(f"analyze median of {args.runs}: {med:.3f} s (target < {TARGET:.0f} s:"
          f" {'met' if med < TARGET else 'NOT met'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
