#!/usr/bin/env python3
"""Diagnosability-analysis benchmark: ``analyze`` on a 20-state,
6-fault model, target < 2 s.

    python3 benchmarks/bench_analyze.py            # measure, print the table
    python3 benchmarks/bench_analyze.py --write    # ... and update benchmarks/README.md

The models: F, H, L from ``observer_cad.model.random_matrices(n=20, l, p, seed)`` and six
fault columns drawn from the same kind of distribution with ``seed + 1``, in two
variants: small integers in −2..2, and dense rationals (N(0, 1) entries, F scaled by
1/√n, rounded to multiples of 1/1000 and kept exact). Each is analysed on the exact path
(``method="exact"``, rational arithmetic) and on the float path (``method="float"``, SVD
rank decisions); at n = 20 ``method="auto"`` takes the exact path (the float path is
automatic above ``FLOAT_AUTO_N`` = 20 states). Timed: ``analyze(model, method=...)`` as a
user calls it (structure extraction included, every pair, all 63 structure-matrix rows;
building the sympy model is not timed) — the first call in the process, then the median
of ``--runs`` further calls, wall-clock and process CPU time. The float answers are
compared with the exact ones (detectability, minimal orders, isolability, structure rows).
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
from observer_cad.analysis import analyze  # noqa: E402
from common import load as _load, machine as _machine, write_section

README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN ANALYSIS RESULTS (bench_analyze.py --write) -->"
END = "<!-- END ANALYSIS RESULTS -->"
TARGET = 2.0

#: (label of the entries, integer entries?, method)
CASES = (
    ("small integers in −2..2", True, "exact"),
    ("small integers in −2..2", True, "float"),
    ("dense rationals (N(0, 1), denominator 1000)", False, "float"),
    ("dense rationals (N(0, 1), denominator 1000)", False, "exact"),
)


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


def _answers(a) -> tuple:
    """What the float path must agree with the exact one on."""
    return (a.detectable, a.min_order,
            tuple((p.faults, p.a_from_b, p.b_from_a) for p in a.pairs),
            frozenset(tuple(sorted(s.sensitive)) for s in a.structure))


def _timed(model, method):
    t, c = time.perf_counter(), time.process_time()
    a = analyze(model, method=method)
    return time.perf_counter() - t, time.process_time() - c, a


def measure(case, runs: int, l: int, p: int, seed: int) -> dict:  # noqa: E741
    label, integer, method = case
    model = fault_model(l=l, p=p, seed=seed, integer=integer)
    first, first_cpu, a = _timed(model, method)
    walls, cpus = [], []
    for _ in range(runs):
        w, c, a = _timed(model, method)
        walls.append(w)
        cpus.append(c)
    return {"label": label, "integer": integer, "method": method, "model": model.name,
            "first": first, "first_cpu": first_cpu,
            "median": statistics.median(walls), "median_cpu": statistics.median(cpus),
            "analysis": a}


# ---------------------------------------------------------------- machine
# ---------------------------------------------------------------- report
def _fmt(t: float) -> str:
    return f"{t * 1e3:.0f} ms" if t < 1 else f"{t:.2f} s"


def _row(r) -> str:
    a = r["analysis"]
    worst = max(r["median"], r["first"])
    mark = "ok" if worst < TARGET else "**MISSED**"
    orders = sorted(set(k for k in a.min_order.values() if k is not None))
    return (f"| {r['label']} | {r['method']} |"
            f" {sum(a.detectable.values())}/{len(a.faults)} (k = {', '.join(map(str, orders)) or '—'}),"
            f" {sum(p.isolable for p in a.pairs)}/{len(a.pairs)}, {len(a.structure)} |"
            f" {_fmt(r['first'])} ({_fmt(r['first_cpu'])}) |"
            f" {_fmt(r['median'])} ({_fmt(r['median_cpu'])}) |"
            f" {TARGET:g} s | {worst / TARGET:.2f} ({mark}) |")


def run(runs: int, l: int, p: int, seed: int) -> str:  # noqa: E741
    info = _machine()
    load0 = _load()
    started = time.strftime("%Y-%m-%d %H:%M")
    results = []
    for case in CASES:
        r = measure(case, runs, l, p, seed)
        results.append(r)
        print(_row(r), flush=True)
    load1 = _load()

    agree = []
    for integer in (True, False):
        by = {r["method"]: r for r in results if r["integer"] == integer}
        if "exact" in by and "float" in by:
            same = _answers(by["exact"]["analysis"]) == _answers(by["float"]["analysis"])
            agree.append(f"{by['exact']['label']}: the float answers "
                         + ("equal the exact ones" if same else "**differ from the exact ones**"))
    loads = [float(x) for x in (load0 + " " + load1).split() if x != "?"]
    busy = max(loads) if loads else 0.0
    warn = ([f"**The machine was busy** (load average up to {busy:.1f} on {info['nproc']}"
             " CPUs; other work ran beside the benchmark): wall-clock times are inflated and"
             " noisy, the CPU times in parentheses are the better guide; re-run on a quiet"
             " machine before comparing with the target.", ""]
            if busy > 0.75 * info["nproc"] else [])
    model = results[0]["model"]
    head = warn + [
        f"Measured {started} by `python3 benchmarks/bench_analyze.py --write`:"
        f" {info['nproc']} CPUs ({info['cpu']}), Python {info['python']}, sympy {info['sympy']},"
        f" numpy {info['numpy']}, {info['platform']}. Load average (1, 5, 15 min) {load0} at"
        f" the start, {load1} at the end. Model {model} (n = 20 states, l = {l} outputs,"
        f" p = {p} disturbance, 6 faults; the same seed for both kinds of entries)."
        f" First: the first `analyze` call in the process; median: of {runs} further calls;"
        " wall-clock, CPU time of the process in parentheses. Ratio: the slower of the two"
        " wall-clock times over the target.",
        "",
        "| entries | path | detectable (k), isolable pairs, structure rows | first call | median |"
        " target | ratio |",
        "|---|---|---|---|---|---|---|",
    ]
    tail = ["", "Float against exact: " + "; ".join(agree) + "." if agree else ""]
    return "\n".join(head + [_row(r) for r in results] + tail).rstrip()


def write_readme(table: str) -> None:
    write_section(README, BEGIN, END, table)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--write", action="store_true",
                    help="update the 'Analysis time' table in benchmarks/README.md")
    ap.add_argument("--runs", type=int, default=5,
                    help="calls per case after the first (median; default 5)")
    ap.add_argument("--l", type=int, default=8, help="outputs (default 8)")
    ap.add_argument("--p", type=int, default=1, help="disturbances (default 1)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the model (default 0)")
    args = ap.parse_args(argv)
    table = run(args.runs, args.l, args.p, args.seed)
    print()
    print(table)
    if args.write:
        write_readme(table)
        print(f"\nwrote {README}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
