#!/usr/bin/env python3
"""Synthesis benchmark: every example design and the float synthesis at n = 60.

    python3 benchmarks/bench_synthesis.py            # measure, print the table
    python3 benchmarks/bench_synthesis.py --write    # ... and update benchmarks/README.md

Two numbers per design, medians of repeated runs:

* warm — repeated calls in one process (sympy's cache kept, as in a long session);
* cold — the first design call in a fresh Python process, after the imports and the
  model are loaded (what one ``observer-cad design`` invocation pays for the design).

The random system (n = 60, l = 8, one disturbance, ``observer_cad.model.random_model``, seed 0) is
timed in three parts: building the exact sympy PlantModel, extracting its structure
(sympy), and the float synthesis proper (``design_canonical(..., method="float")`` given
the structure); plus the plain call ``design_canonical(model, symbolic=False,
method="float")``, which extracts the structure itself.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path
from common import load as _load, machine as _machine, write_section

ROOT = Path(__file__).resolve().parent.parent
README = Path(__file__).resolve().parent / "README.md"
BEGIN, END = "<!-- BEGIN RESULTS (bench_synthesis.py --write) -->", "<!-- END RESULTS -->"

EXAMPLE_TARGET = 0.5
FLOAT_TARGET = 1.0
RANDOM = dict(n=60, l=8, p=1, seed=0)

# name, model file, unknown input, symbolic
EXAMPLES = [
    ("electric_drive d symbolic", "models/electric_drive.py", "d", True),
    ("electric_drive d numeric", "models/electric_drive.py", "d", False),
    ("electric_drive rho symbolic", "models/electric_drive.py", "rho", True),
    ("electric_drive rho numeric", "models/electric_drive.py", "rho", False),
    ("three_tank_linear rho numeric", "models/three_tank_linear.py", "rho", False),
    ("three_tank rho2 numeric", "models/three_tank.py", "rho2", False),
    ("three_tank rho2 symbolic", "models/three_tank.py", "rho2", True),
]


# ---------------------------------------------------------------- the measured calls
def _example_call(spec):
    from observer_cad import design_canonical, load_model

    _, path, unknown, symbolic = spec
    model = load_model(ROOT / path)
    return lambda: design_canonical(model, unknown_input=unknown, symbolic=symbolic)


def _random_parts():
    from observer_cad.model import random_model
    from observer_cad.model import extract_structure

    t0 = time.perf_counter()
    model = random_model(RANDOM["n"], RANDOM["l"], RANDOM["p"], seed=RANDOM["seed"], integer=False)
    t1 = time.perf_counter()
    st = extract_structure(model)
    t2 = time.perf_counter()
    return model, st, t1 - t0, t2 - t1


def _float_call(model, st):
    from observer_cad import design_canonical

    # no parameters: symbolic=True only makes design_canonical reuse the given structure
    return lambda: design_canonical(model, unknown_input="d", symbolic=True, method="float",
                                    structure=st)


def _timed(fn, cpu=False):
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    wall, used = time.perf_counter() - t, time.process_time() - c
    return ((wall, used) if cpu else wall), out


def _child(which: str) -> None:
    """One cold measurement in this (fresh) process; prints JSON."""
    if which == "random":
        model, st, t_build, t_extract = _random_parts()
        (t, c), d = _timed(_float_call(model, st), cpu=True)
        print(json.dumps({"t": t, "cpu": c, "k": d.k, "build": t_build, "extract": t_extract}))
    elif which == "random-plain":
        from observer_cad import design_canonical
        from observer_cad.model import random_model

        model = random_model(RANDOM["n"], RANDOM["l"], RANDOM["p"], seed=RANDOM["seed"],
                             integer=False)
        (t, c), d = _timed(lambda: design_canonical(model, unknown_input="d", symbolic=False,
                                                    method="float"), cpu=True)
        print(json.dumps({"t": t, "cpu": c, "k": d.k}))
    else:
        spec = EXAMPLES[int(which)]
        fn = _example_call(spec)
        (t, c), d = _timed(fn, cpu=True)
        print(json.dumps({"t": t, "cpu": c, "k": d.k, "method": d.method}))


def _cold(which: str, runs: int) -> list:
    out = []
    for _ in range(runs):
        res = subprocess.run([sys.executable, __file__, "--child", which], cwd=ROOT,
                             capture_output=True, text=True, check=True)
        out.append(json.loads(res.stdout.strip().splitlines()[-1]))
    return out


def _warm(fn, repeats: int) -> tuple:
    fn()  # first call: not counted
    ts = []
    for _ in range(repeats):
        t, d = _timed(fn)
        ts.append(t)
    return statistics.median(ts), d


# ---------------------------------------------------------------- machine
# ---------------------------------------------------------------- report
def _fmt(t: float) -> str:
    return f"{t * 1e3:.0f} ms" if t < 10 else f"{t:.1f} s"


def _row(name, method, k, warm, cold, cold_cpu, target):
    worst = max(warm, cold)
    mark = "ok" if worst < target else "**MISSED**"
    return (f"| {name} | {method} | {k} | {_fmt(warm)} | {_fmt(cold)} ({_fmt(cold_cpu)}) |"
            f" {target:g} s | {warm / target:.2f} / {cold / target:.2f} ({mark}) |")


def run(repeats: int, cold_runs: int) -> str:
    info = _machine()
    load0 = _load()
    started = time.strftime("%Y-%m-%d %H:%M")
    rows = []
    for i, spec in enumerate(EXAMPLES):
        warm, d = _warm(_example_call(spec), repeats)
        res = _cold(str(i), cold_runs)
        cold = statistics.median(r["t"] for r in res)
        cpu = statistics.median(r["cpu"] for r in res)
        rows.append(_row(spec[0], d.method, d.k, warm, cold, cpu, EXAMPLE_TARGET))
        print(rows[-1], flush=True)

    model, st, t_build, t_extract = _random_parts()
    warm, d = _warm(_float_call(model, st), repeats)
    cold_res = _cold("random", cold_runs)
    cold = statistics.median(r["t"] for r in cold_res)
    cpu = statistics.median(r["cpu"] for r in cold_res)
    name = (f"random n={RANDOM['n']} l={RANDOM['l']} p={RANDOM['p']} seed {RANDOM['seed']}:"
            " float synthesis")
    rows.append(_row(name, d.method, d.k, warm, cold, cpu, FLOAT_TARGET))
    print(rows[-1], flush=True)
    del t_build, t_extract  # in-process, first call: the cold runs' medians are reported
    rows.append(f"| … building its exact sympy PlantModel (not synthesis) | – | – | – |"
                f" {_fmt(statistics.median(r['build'] for r in cold_res))} | – | – |")
    rows.append(f"| … `extract_structure` of that model (not synthesis) | – | – | – |"
                f" {_fmt(statistics.median(r['extract'] for r in cold_res))} | – | – |")
    plain = _cold("random-plain", max(1, cold_runs - 1))
    t_plain = statistics.median(r["t"] for r in plain)
    c_plain = statistics.median(r["cpu"] for r in plain)
    rows.append("| … `design_canonical(model, symbolic=False, method=\"float\")` (extracts"
                f" the structure itself) | float | {plain[0]['k']} | – | {_fmt(t_plain)} ({_fmt(c_plain)}) |"
                " – | – |")
    print("\n".join(rows[-3:]), flush=True)
    load1 = _load()

    busy = max(float(x) for x in (load0 + " " + load1).split() if x != "?") \
        if "?" not in (load0 + load1) else 0.0
    warn = ([f"**The machine was busy** (load average up to {busy:.1f} on {info['nproc']}"
             " CPUs): wall-clock times are inflated, the CPU times in parentheses are the"
             " better guide; re-run on a quiet machine before comparing with the targets.", ""]
            if busy > 0.75 * info["nproc"] else [])
    head = warn + [
        f"Measured {started} by `python3 benchmarks/bench_synthesis.py --write`: "
        f"{info['nproc']} CPUs ({info['cpu']}), Python {info['python']}, sympy {info['sympy']},"
        f" numpy {info['numpy']}, {info['platform']}. Load average (1, 5, 15 min) {load0} at"
        f" the start, {load1} at the end. Warm: median of {repeats} calls in one process"
        f" after a first, uncounted one. Cold: median of {cold_runs} fresh processes, the"
        " first design call after imports and model loading, wall-clock (CPU time of the"
        " process in parentheses: wall ≫ CPU means other processes held the cores)."
        " Ratio: warm / cold wall-clock time over the target; a target is met when both are"
        " below it.",
        "",
        "| design | method | k | warm | cold | target | ratio warm / cold |",
        "|---|---|---|---|---|---|---|",
    ]
    return "\n".join(head + rows)


def write_readme(table: str) -> None:
    write_section(README, BEGIN, END, table)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--write", action="store_true", help="update the table in benchmarks/README.md")
    ap.add_argument("--repeats", type=int, default=7, help="warm calls per design (default 7)")
    ap.add_argument("--cold", type=int, default=3, help="fresh processes per design (default 3)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        _child(args.child)
        return 0
    table = run(args.repeats, args.cold)
    print()
    print(table)
    if args.write:
        write_readme(table)
        print(f"\nwrote {README}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
