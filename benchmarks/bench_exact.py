#!/usr/bin/env python3
"""Exact-synthesis benchmark: the exact canonical design of random
dense-rational plants, n = 40 and 60, l = 8, one disturbance, side by side on the two
rational backends, and the elimination itself on the largest Krylov matrix.

    python3 benchmarks/bench_exact.py            # measure, print the tables
    python3 benchmarks/bench_exact.py --write    # ... and update benchmarks/README.md

Design: ``design_canonical(model, unknown_input="d", method="exact")`` on
``random_model(n, 8, 1, seed=0, integer=False)`` (structure extracted beforehand, not
timed), each run in a fresh process after the imports, wall-clock and CPU time:

* ``flint`` — the default when python-flint is installed: sympy's ground types are flint
  and ``observer_cad.numerics`` eliminates with FLINT's ``fmpq_mat.rref``;
* ``sympy-CD (gmpy2)`` — the same code with ``SYMPY_GROUND_TYPES=gmpy``: elimination by
  sympy's ``DomainMatrix.rref(method="CD")`` on gmpy2 integers (what a machine without
  python-flint gets).

Incremental over k (flint ground types): the same design with the search over k done as
now (``krylov_null_spaces``: the null space of (W⁽ᵏ⁾ L⁽ᵏ⁾) grown from that of k − 1 by
``GrowingLeftNull``) and from scratch (as before: (W⁽ᵏ⁾ L⁽ᵏ⁾) built and eliminated at
each k, H Fʲ kept), fresh processes alternating between the two, the ratio the median of
the paired ratios; then the cost of each k in this process (CPU, median, the two
interleaved): the elimination of (W⁽ᵏ⁾ L⁽ᵏ⁾) from scratch (``rational_left_null``)
against the step from k − 1 (``GrowingLeftNull.grow``), with the path the step took.

Elimination: one reduced row echelon form of (W⁽ᵏ⁾ L⁽ᵏ⁾)ᵀ at the k the design stops at,
in this process (flint ground types): the hand-written Gauss–Jordan that the exact path
used before (``_gauss_jordan``, still the elimination over QQ(parameters)), sympy's
``DomainMatrix.rref`` (default method and ``method="CD"``), and ``fmpq_mat.rref``.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from common import load as _load, machine as _machine, publish  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN EXACT RESULTS (bench_exact.py --write) -->"
END = "<!-- END EXACT RESULTS -->"
#: n → target (s) for the exact design
TARGETS = {40: 1.0, 60: 5.0}
#: measured on main at 6cfb86b (hand-written Gauss–Jordan, sympy products), for reference
BEFORE = {40: "15 s CPU", 60: "142 s CPU (216 s wall)"}
BACKENDS = (("flint", {}), ("sympy-CD (gmpy2)", {"SYMPY_GROUND_TYPES": "gmpy"}))


def _model(n):
    from observer_cad.model import extract_structure, random_model

    model = random_model(n, 8, 1, seed=0, integer=False)
    return model, extract_structure(model)


def _from_scratch(F, H, L, *, H0=None):
    """The search over k as before ``krylov_null_spaces``: (W⁽ᵏ⁾ L⁽ᵏ⁾) built and
    eliminated at each k, H Fʲ kept across k (rational F, H, L; H0 = H)."""
    import itertools

    from observer_cad.numerics import as_rational, left_null_echelon
    from observer_cad.synthesis.canonical._krylov import _krylov_rational

    Fq, Hq, Lq = (as_rational(A) for A in (F, H, L))
    HF = [Hq]
    for k in itertools.count(1):
        W, Lk = _krylov_rational(Fq, Hq, Lq, k, HF)
        members, rk = left_null_echelon(W.hstack(Lk) if Lk.shape[1] else W)
        yield members, rk.rank, rk.conditions


def _child(n: int, scratch: bool = False) -> None:
    from sympy.external.gmpy import GROUND_TYPES

    from observer_cad import design_canonical
    from observer_cad.numerics import RATIONAL_BACKEND
    from observer_cad.synthesis.canonical import _exact  # where the exact search looks it up

    if scratch:
        _exact.krylov_null_spaces = _from_scratch
    model, st = _model(n)
    t, c = time.perf_counter(), time.process_time()
    d = design_canonical(model, unknown_input="d", symbolic=True, method="exact", structure=st)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    print(json.dumps({"t": wall, "cpu": cpu, "k": d.k, "ground": GROUND_TYPES,
                      "backend": RATIONAL_BACKEND}))


def _cold(n: int, env: dict, runs: int, scratch: bool = False) -> list:
    out = []
    for _ in range(runs):
        res = subprocess.run([sys.executable, __file__, "--child", str(n)]
                             + (["--scratch"] if scratch else []), cwd=ROOT,
                             capture_output=True, text=True, check=True,
                             env={**os.environ, **env})
        out.append(json.loads(res.stdout.strip().splitlines()[-1]))
    return out


def _incremental(n: int, pairs: int) -> tuple:
    """Fresh processes alternating from scratch / incremental (the order swapped every
    pair): (k, medians from scratch, medians incremental, median paired CPU ratio)."""
    a, b = [], []
    for i in range(pairs):
        order = (True, False) if i % 2 == 0 else (False, True)
        got = {scratch: _cold(n, {}, 1, scratch=scratch)[0] for scratch in order}
        a.append(got[True])
        b.append(got[False])
    med = lambda rs, key: statistics.median(r[key] for r in rs)  # noqa: E731
    ratio = statistics.median(y["cpu"] / x["cpu"] for x, y in zip(a, b))
    assert {r["k"] for r in a + b} == {a[0]["k"]}
    return a[0]["k"], (med(a, "t"), med(a, "cpu")), (med(b, "t"), med(b, "cpu")), ratio


def _per_k(n: int, k_max: int, runs: int) -> list:
    """For k = 1 … k_max: (k, shape, members, CPU from scratch, CPU of the step, path),
    medians of ``runs``, the two interleaved at each k."""
    import sympy as sp

    from observer_cad.numerics import (RATIONAL_BACKEND, GrowingLeftNull, as_rational,
                                       rational_left_null)
    from observer_cad.synthesis.canonical._krylov import _krylov_rational

    _, st = _model(n)
    F, H, L = (as_rational(sp.Matrix(A)) for A in (st.F, st.H, st.unknown_input_columns(
        [sp.Symbol("rho1")])))
    p = L.shape[1]
    states, tops, HF, HFL = [GrowingLeftNull.of(H)], [None], [H], []
    for k in range(1, k_max + 1):  # the states the search passes through, and the new rows
        HFL.append(HF[-1] * L)
        HF.append(HF[-1] * F)
        tops.append(HF[k].hstack(*HFL))
        states.append(states[-1].grow(tops[k], at=st.n, width=p))
    out = []
    for k in range(1, k_max + 1):
        ta, tb = [], []
        for _ in range(runs):
            c = time.process_time()
            W, Lk = _krylov_rational(F, H, L, k, HF)  # as the search did, H Fʲ at hand
            M = W.hstack(Lk)
            N = rational_left_null(M)
            ta.append(time.process_time() - c)
            c = time.process_time()
            S = states[k - 1].grow(tops[k], at=st.n, width=p)
            tb.append(time.process_time() - c)
        assert S.null.to_list() == N.to_list()  # the same members, exactly
        path = ("incremental" if S.kernel is not None else "full rank (certificate)"
                if not S.null.shape[0] and RATIONAL_BACKEND == "flint" else "from scratch")
        out.append((k, M.shape, N.shape[0], statistics.median(ta), statistics.median(tb), path))
    return out


def _fmt(t: float) -> str:
    return f"{t * 1e3:.0f} ms" if t < 1 else f"{t:.2f} s" if t < 10 else f"{t:.1f} s"


def _eliminations(n: int, k: int) -> list:
    """Median times of one RREF of (W L)ᵀ at this k, by each elimination."""
    import sympy as sp

    from observer_cad.numerics import as_rational
    from observer_cad.numerics._linalg import _gauss_jordan
    from observer_cad.synthesis.canonical._krylov import _krylov_rational

    _, st = _model(n)
    F, H, L = (as_rational(sp.Matrix(A)) for A in (st.F, st.H, st.unknown_input_columns(
        [sp.Symbol("rho1")])))
    W, Lk = _krylov_rational(F, H, L, k)
    dm = W.hstack(Lk).transpose()
    fm = dm.to_dense().rep.rep
    ways = [
        ("hand-written Gauss–Jordan (before)", lambda: _gauss_jordan(dm, set(), full=True), 1),
        ("sympy `DomainMatrix.rref()`", lambda: dm.rref(), 1),
        ("sympy `DomainMatrix.rref(method=\"CD\")`", lambda: dm.rref(method="CD"), 3),
        ("FLINT `fmpq_mat.rref()` (now)", lambda: fm.rref(), 5),
    ]
    out = []
    for name, fn, runs in ways:
        ts = []
        for _ in range(runs):
            c = time.process_time()
            fn()
            ts.append(time.process_time() - c)
        out.append((name, statistics.median(ts)))
    return dm.shape, out


def _ms(t: float) -> str:
    return f"{t * 1e3:.1f} ms"


def run(runs: int, pairs: int) -> str:
    info = _machine()
    load0 = _load()
    started = time.strftime("%Y-%m-%d %H:%M")
    rows, ks = [], {}
    for n, target in TARGETS.items():
        for name, env in BACKENDS:
            res = _cold(n, env, runs)
            wall = statistics.median(r["t"] for r in res)
            cpu = statistics.median(r["cpu"] for r in res)
            ks[n] = res[0]["k"]
            mark = "ok" if wall < target else ("**MISSED** (wall; CPU " +
                                               ("ok)" if cpu < target else "missed too)"))
            rows.append(f"| n = {n}, l = 8 | {name} (ground types {res[0]['ground']}) |"
                        f" {res[0]['k']} | {_fmt(wall)} ({_fmt(cpu)}) | {BEFORE[n]} |"
                        f" {target:g} s | {wall / target:.2f} / {cpu / target:.2f} ({mark}) |")
            print(rows[-1], flush=True)
    inc_rows, perk_rows = [], []
    for n in TARGETS:
        k, (ta, ca), (tb, cb), ratio = _incremental(n, pairs)
        inc_rows.append(f"| n = {n}, l = 8 | {k} | {_fmt(ta)} ({_fmt(ca)}) | {_fmt(tb)} ({_fmt(cb)})"
                        f" | {ratio:.2f} |")
        print(inc_rows[-1], flush=True)
    for n, k in ks.items():
        for kk, shape, dim, ta, tb, path in _per_k(n, k, 5):
            perk_rows.append(f"| n = {n} | {kk} | {shape[0]}×{shape[1]} | {dim} | {_ms(ta)} |"
                             f" {_ms(tb)} | {path} |")
            print(perk_rows[-1], flush=True)
    elim = []
    for n, k in ks.items():
        shape, times = _eliminations(n, k)
        ref = times[-1][1]
        for name, t in times:
            elim.append(f"| n = {n}, k = {k}: {shape[0]}×{shape[1]} | {name} | {_fmt(t)} |"
                        f" {t / ref:.0f}× |")
            print(elim[-1], flush=True)
    load1 = _load()
    busy = max(float(x) for x in (load0 + " " + load1).split() if x != "?") \
        if "?" not in (load0 + load1) else 0.0
    warn = ([f"**The machine was busy** (load average up to {busy:.1f} on {info['nproc']}"
             " CPUs; other work ran beside the benchmark): wall-clock times are inflated, the"
             " CPU times in parentheses are the better guide; re-run on a quiet machine before"
             " comparing with the targets.", ""] if busy > 0.75 * info["nproc"] else [])
    head = warn + [
        f"Measured {started} by `python3 benchmarks/bench_exact.py --write`: {info['nproc']}"
        f" CPUs ({info['cpu']}), Python {info['python']}, sympy {info['sympy']},"
        f" {info['platform']}. Load average (1, 5, 15 min) {load0} at the start, {load1} at"
        f" the end. Exact canonical design of `random_model(n, 8, 1, seed=0, integer=False)`"
        f" (structure extracted first, not timed): median of {runs} fresh processes, wall-clock"
        " (CPU time of the process in parentheses). Ratio: wall / target and CPU / target."
        " Before: main at 6cfb86b.",
        "",
        "| plant | backend | k | exact design | before | target | ratio wall / CPU |",
        "|---|---|---|---|---|---|---|",
    ]
    inc = ["", f"Incremental over k (flint ground types): the exact design with the search over k"
           f" from scratch (as before: (W⁽ᵏ⁾ L⁽ᵏ⁾) eliminated at each k) and incremental (now),"
           f" {pairs} fresh processes each, alternating; median wall-clock (CPU); ratio: median of"
           f" the {pairs} paired CPU ratios incremental / from scratch.", "",
           "| plant | k | from scratch | incremental | ratio |", "|---|---|---|---|---|"]
    perk = ["", "Each k of that search (CPU, median of 5, the two interleaved, in this process):"
            " building and eliminating (W⁽ᵏ⁾ L⁽ᵏ⁾) from scratch (`rational_left_null`) against"
            " the step from k − 1 (`GrowingLeftNull.grow`, which builds the grown matrix from"
            " the new rows), the same members; the path the step took: a"
            " full-rank certificate (no members), an elimination from scratch (no null space to"
            " reuse at k − 1), or incremental.", "",
            "| plant | k | (W L) | members | from scratch | step | path |",
            "|---|---|---|---|---|---|---|"]
    tail = ["", "One reduced row echelon form of (W⁽ᵏ⁾ L⁽ᵏ⁾)ᵀ at the design's k (CPU time,"
            " median; flint ground types in this process):", "",
            "| matrix | elimination | CPU | × FLINT |", "|---|---|---|---|"]
    return "\n".join(head + rows + inc + inc_rows + perk + perk_rows + tail + elim)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--write", action="store_true", help="update the table in benchmarks/README.md")
    ap.add_argument("--runs", type=int, default=3, help="fresh processes per row (default 3)")
    ap.add_argument("--pairs", type=int, default=5,
                    help="alternating from-scratch / incremental pairs per plant (default 5)")
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--scratch", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        _child(args.child, args.scratch)
        return 0
    table = run(args.runs, args.pairs)
    publish(table, README, BEGIN, END, write=args.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
