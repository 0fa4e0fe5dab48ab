#!/usr/bin/env python3
"""Exact pole placement benchmark: ``place_poles`` for k = 4, 6, 8, 12,
target k = 8 < 1 s, the previous implementation side by side.

    python3 benchmarks/bench_poles.py            # measure, print the table
    python3 benchmarks/bench_poles.py --write    # ... and update benchmarks/README.md

Cases: a dense rational F* (entries a/b, |a| ≤ 9, 1 ≤ b ≤ 9, seeded) with a dense rational
row h and μ = −1, …, −k, for k = 4, 6, 8, 12 — the general case, where the previous code's
cost explodes (the issue's figures); at k = 8 also F* = the shift, H* = e1ᵀ (what canonical
designs have) with the continuous and the discrete default eigenvalues, a complex pair
and irrational eigenvalues (−1 ± 2i, −√2, −√3, −4 … −7: an algebraic field), and two output
rows with a non-cyclic F* = diag(1, 1, 2, 2, 3, 3, 4, 4) (the seeded combination plus the
preliminary gain K₀).
"new": :func:`observer_cad.synthesis.place_poles` (observer-form Ackermann over the exact
field, certificate included) — the first call in the process, then the median of ``--runs``
calls, wall-clock and process CPU time. "previous": the implementation on main before
this change (``sympy.solve`` of the coefficient equations of det(sI − F* + K H*) with
symbolic K, then the same exact check), copied below, run once per case in a subprocess
with a time limit (``--limit``, default 120 s); it raises sympy's ``ShapeError`` for
several output rows. Finally a whole canonical virtual-sensor design at k = 8 (the chain
model of tests/synthesis/test_poles.py, where the placement is one step).
"""
from __future__ import annotations

import argparse
import random
import statistics
import subprocess
import sys
import time
from pathlib import Path

import sympy as sp

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from observer_cad import PlantModel  # noqa: E402
from observer_cad.synthesis import design_virtual_sensor_canonical, pole_placement  # noqa: E402
from common import load as _load, machine as _machine, publish  # noqa: E402

README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN POLES RESULTS (bench_poles.py --write) -->"
END = "<!-- END POLES RESULTS -->"
TARGET_K = 8
TARGET = 1.0
S = sp.Dummy("s")


def shift(k):
    return sp.Matrix(k, k, lambda i, j: 1 if j == i + 1 else 0)


def case(name: str):
    """(F*, H*, eigenvalues) of a named case."""
    kind, k = name.split(":")
    k = int(k)
    if kind == "shift":
        return shift(k), sp.Matrix([[1] + [0] * (k - 1)]), [sp.Integer(-i) for i in range(1, k + 1)]
    if kind == "discrete":
        return shift(k), sp.Matrix([[1] + [0] * (k - 1)]), [sp.Rational(1, 2 ** i) for i in range(1, k + 1)]
    if kind == "dense":  # dense rational F* (e.g. variant 004: F* = shift + J_v H_z), row h
        rng = random.Random(k)
        F = sp.Matrix(k, k, lambda i, j: sp.Rational(rng.randint(-9, 9), rng.randint(1, 9)))
        h = sp.Matrix([[sp.Rational(rng.randint(1, 9), rng.randint(1, 9)) for _ in range(k)]])
        return F, h, [sp.Integer(-i) for i in range(1, k + 1)]
    if kind == "algebraic":
        eigs = [-1 + 2 * sp.I, -1 - 2 * sp.I, -sp.sqrt(2), -sp.sqrt(3)] + \
            [sp.Integer(-i) for i in range(4, k)]
        return shift(k), sp.Matrix([[1] + [0] * (k - 1)]), eigs
    if kind == "two-rows":
        F = sp.diag(*[sp.Integer(1 + i // 2) for i in range(k)])
        H = sp.Matrix(2, k, lambda i, j: 1 if j % 2 == i else 0)
        return F, H, [sp.Integer(-i) for i in range(1, k + 1)]
    raise SystemExit(f"unknown case {name}")


CASES = (("dense:4", "dense rational F*, dense row h, μ = −1 … −k"), ("dense:6", ""),
         ("dense:8", ""), ("dense:12", ""),
         ("shift:8", "F* shift, H* = e1ᵀ (canonical designs), μ = −1 … −k"),
         ("discrete:8", "F* shift, H* = e1ᵀ, μ = 1/2 … 1/2^k (discrete defaults)"),
         ("algebraic:8", "shift, μ = −1 ± 2i, −√2, −√3, −4 … −7"),
         ("two-rows:8", "two rows, F* = diag(1, 1, 2, 2, …) not cyclic"))


def previous_place_poles(Fs, Hs, eigenvalues):
    """main before the fraction-free placement (observer_cad/synthesis/core/_poles.py), verbatim but for
    the error classes."""
    Fs, Hs = sp.Matrix(Fs), sp.Matrix(Hs)
    k = Fs.rows
    Ks = tuple(sp.Dummy(f"K{i}") for i in range(1, k + 1))
    K = sp.Matrix(Ks)
    target = sp.Poly(sp.expand(sp.prod([S - mu for mu in eigenvalues])), S)
    cp = sp.Poly((S * sp.eye(k) - Fs + K * Hs).det(method="berkowitz"), S)
    eqs = [sp.expand(a - b) for a, b in zip(cp.all_coeffs(), target.all_coeffs())]
    sol = sp.solve(eqs, Ks, dict=True)
    if not sol:
        raise RuntimeError("not observable")
    K = K.xreplace({s: sp.expand(sol[0].get(s, 0)).xreplace({t: 0 for t in Ks}) for s in Ks})
    K = K.applyfunc(lambda e: sp.expand(e.xreplace({t: 0 for t in Ks})))
    check = sp.Poly((S * sp.eye(k) - Fs + K * Hs).det(method="berkowitz"), S)
    if sp.expand(check.as_expr() - target.as_expr()) != 0:
        raise RuntimeError("failed its exact check")
    return K


def _previous(name: str, limit: float) -> str:
    """Time the previous implementation on one case in a subprocess (killed at ``limit``)."""
    try:
        out = subprocess.run([sys.executable, __file__, "--previous", name], capture_output=True,
                             text=True, timeout=limit)
    except subprocess.TimeoutExpired:
        return f"> {limit:g} s (killed)"
    last = (out.stdout.strip().splitlines() or ["?"])[-1]
    return last if out.returncode == 0 else (out.stderr.strip().splitlines() or ["error"])[-1]


def _run_previous(name: str) -> None:
    F, H, eigs = case(name)
    t, c = time.perf_counter(), time.process_time()
    try:
        previous_place_poles(F, H, eigs)
    except Exception as e:  # noqa: BLE001 - report what the old code raised
        print(f"{type(e).__name__}", flush=True)
        return
    print(f"{_fmt(time.perf_counter() - t)} ({_fmt(time.process_time() - c)})", flush=True)


def _timed(fn):
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - t, time.process_time() - c, out


def _fmt(t: float) -> str:
    return f"{t * 1e3:.1f} ms" if t < 0.1 else (f"{t * 1e3:.0f} ms" if t < 1 else f"{t:.2f} s")


def measure(name: str, runs: int, limit: float, previous: bool) -> dict:
    F, H, eigs = case(name)
    first, first_cpu, pp = _timed(lambda: pole_placement(F, H, eigs))
    walls, cpus = [], []
    for _ in range(runs):
        w, c, pp = _timed(lambda: pole_placement(F, H, eigs))
        walls.append(w)
        cpus.append(c)
    return {"name": name, "k": F.rows, "p": H.rows, "first": first, "first_cpu": first_cpu,
            "median": statistics.median(walls), "median_cpu": statistics.median(cpus),
            "method": pp.method, "previous": _previous(name, limit) if previous else "not run"}


def chain(n):
    xs = sp.symbols(f"x1:{n + 1}")
    u, d = sp.symbols("u d")
    dyn = [xs[i + 1] for i in range(n - 1)] + [-xs[0] - xs[1] + u + d]
    return PlantModel(name=f"chain{n}", time="continuous", states=list(xs), inputs=[u],
                      faults=[d], outputs=[xs[0], xs[1]], dynamics=dyn)


def _row(r, labels) -> str:
    k = r["k"]
    target = f"{TARGET:g} s" if k == TARGET_K else "—"
    worst = max(r["first"], r["median"])
    mark = ((f"{worst / TARGET:.3f} (ok)" if worst < TARGET else f"{worst / TARGET:.2f} (**MISSED**)")
            if k == TARGET_K else "—")
    return (f"| {labels.get(r['name']) or r['name'].split(':')[0]} | {k} | {r['p']} |"
            f" {r['previous']} | {_fmt(r['first'])} ({_fmt(r['first_cpu'])}) |"
            f" {_fmt(r['median'])} ({_fmt(r['median_cpu'])}) | {target} | {mark} |")


def run(runs: int, limit: float) -> str:
    info = _machine()
    load0 = _load()
    started = time.strftime("%Y-%m-%d %H:%M")
    labels = dict(CASES)
    results = []
    gave_up = False
    for name, _ in CASES:
        # the previous code: once a shift case exceeds the limit, larger k are not run
        r = measure(name, runs, limit, previous=not (gave_up and name.startswith("dense")))
        gave_up |= name.startswith("dense") and r["previous"].startswith(">")
        if r["previous"] == "not run":
            r["previous"] = "not run (a smaller k exceeded the limit)"
        results.append(r)
        print(_row(r, labels), flush=True)
    m = chain(TARGET_K + 1)
    w, c, d = _timed(lambda: design_virtual_sensor_canonical(m, estimate=f"x{TARGET_K + 1}"))
    load1 = _load()
    loads = [float(x) for x in (load0 + " " + load1).split() if x != "?"]
    busy = max(loads) if loads else 0.0
    warn = ([f"**The machine was busy** (load average up to {busy:.1f} on {info['nproc']}"
             " CPUs; other work ran beside the benchmark): wall-clock times are inflated and"
             " noisy, the CPU times in parentheses are the better guide.", ""]
            if busy > 0.75 * info["nproc"] else [])
    head = warn + [
        f"Measured {started} by `python3 benchmarks/bench_poles.py --write`:"
        f" {info['nproc']} CPUs ({info['cpu']}), Python {info['python']}, sympy {info['sympy']},"
        f" numpy {info['numpy']}, {info['platform']}. Load average (1, 5, 15 min) {load0} at"
        f" the start, {load1} at the end. New: `place_poles` (Ackermann over the exact field,"
        f" certificate included), the first call in the process and the median of {runs}"
        " further calls; previous: main's `sympy.solve` route, one call in a subprocess,"
        f" killed after {limit:g} s. Wall-clock, process CPU time in parentheses. Ratio: the"
        " slower of the two new wall-clock times over the target.",
        "",
        "| case | k | rows of H* | previous | new, first call | new, median | target | ratio |",
        "|---|---|---|---|---|---|---|---|",
    ]
    tail = ["", f"Whole canonical virtual-sensor design of the {m.name} model (k = {d.k}, pole"
            f" placement one step of it): {_fmt(w)} ({_fmt(c)} CPU)."]
    return "\n".join(head + [_row(r, labels) for r in results] + tail)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--write", action="store_true",
                    help="update the 'Pole placement' table in benchmarks/README.md")
    ap.add_argument("--runs", type=int, default=5, help="calls per case after the first (default 5)")
    ap.add_argument("--limit", type=float, default=120.0,
                    help="seconds the previous implementation gets per case (default 120)")
    ap.add_argument("--previous", metavar="CASE", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.previous:
        _run_previous(args.previous)
        return 0
    table = run(args.runs, args.limit)
    publish(table, README, BEGIN, END, write=args.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
