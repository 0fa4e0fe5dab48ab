#!/usr/bin/env python3
"""Latency benchmark: cold compile time of large observers, and
the wall-clock time of the command line.

    python3 benchmarks/bench_latency.py                          # measure, print the tables
    python3 benchmarks/bench_latency.py --write                  # ... and update benchmarks/README.md
    python3 benchmarks/bench_latency.py --baseline /path/to/old  # CLI: also time another tree

**Compile.**  For each case (plant + observer, the joint step that
``CompiledSimulator`` compiles: the casadi step and the C trajectory loop) the cold
construction ``CompiledSimulator(model, observer)`` in a fresh temporary cache — sympy →
casadi, C generation, the compiler, dlopen — is timed with the old fixed flags (``-O3
-shared -fPIC -fno-semantic-interposition``, passed explicitly) and with the new default
(``flags=None``: the same flags made size-aware, ``-O1`` above
``codegen.LARGE_SOURCE`` characters of C), one after the other in every round, so both
share the machine's state.  Reported: wall-clock median of the construction, the
compiler's CPU time (children's user + sys), and the runtime per step of the compiled
trajectory (N steps on zero inputs, median of the process CPU time) with each
library, so that the level chosen is justified by both.  Target: the 60-state observer
compiles cold in < 3 s wall.

**CLI.**  Each command runs as ``python3 -m observer_cad ...`` in a fresh process (the
package of this tree, or of ``--baseline DIR``), rounds interleaved, after one warm-up
run each; byte code is cached in a temporary ``PYTHONPYCACHEPREFIX`` (this machine sets
``PYTHONDONTWRITEBYTECODE``, an installed package has its ``.pyc``).  Reported: the
wall-clock median and the CPU time (user + sys) of the child.  Floors:
``python3 -c pass`` and ``python3 -c "import sympy"`` (every model file imports sympy).

The machine is shared (2 cores, other jobs): the load average is printed at the start
and the end; CPU times are the steadier figure when the load is high.
"""
from __future__ import annotations

import argparse
import datetime
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from common import cpu_name, load as _load, machine, publish  # noqa: E402

README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN LATENCY RESULTS (bench_latency.py --write) -->"
END = "<!-- END LATENCY RESULTS -->"

OLD_FLAGS = ("-O3", "-shared", "-fPIC", "-fno-semantic-interposition")
TARGET_COMPILE_60 = 3.0     # s, cold, wall-clock, the 60-state observer
CLI_TARGETS = {"design": 1.0, "analyze": 1.0, "show": 1.0, "simulate": 2.5}
CLI = [
    ("design", "design models/electric_drive.py --observer diagnostic"),
    ("design", "design models/electric_drive.py --observer unknown-input --fault d"),
    ("analyze", "analyze models/three_tank_faults.py"),
    ("show", "show models/electric_drive.py"),
    ("simulate", "simulate models/electric_drive.py --observer unknown-input --fault d "
                 "--scenario models/scenarios/electric_drive_fig1.json --out {out}"),
]
FLOORS = [("python3 -c pass", ["-c", "pass"]),
          ("python3 -c \"import sympy\"", ["-c", "import sympy"]),
          ("python3 -c \"import observer_cad\"", ["-c", "import observer_cad"])]


# ------------------------------------------------------------------ compile cases
def _cases(sizes):
    from observer_cad import build_observer, design, load_model
    from observer_cad.model import random_model
    from observer_cad.observers import drem_design, load_drem
    out = []
    m = load_model(ROOT / "models" / "electric_drive.py")
    out.append(("electric drive + unknown-input estimator of d", m,
                build_observer(m, design(m, observer="unknown-input", faults=["d"]))))
    m, spec = load_drem(ROOT / "models" / "drem_example.py")
    out.append(("DREM example (models/drem_example.py)", m, drem_design(m, spec).observer))
    for n in sizes:
        m = random_model(n, 8, 1, seed=0, integer=False)
        d = design(m, observer="diagnostic", method="float")
        out.append((f"random n = {n}, l = 8 + diagnostic observer (k = {d.k})", m,
                    build_observer(m, d)))
    return out


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _build(m, obs, flags):
    from observer_cad.codegen import CompiledSimulator
    d = tempfile.mkdtemp(prefix="bench_latency_cache_")
    try:
        c0, p0, t0 = _children_cpu(), time.process_time(), time.perf_counter()
        cs = CompiledSimulator(m, obs, cache=d, flags=flags)
        wall, cc = time.perf_counter() - t0, _children_cpu() - c0
        cpu = time.process_time() - p0 + cc
        assert not cs.cached
        return cs, wall, cpu, cc, len(cs.source), d   # the loaded library outlives its file
    except Exception:
        shutil.rmtree(d, ignore_errors=True)
        raise


def _per_step(cs, n_steps, repeat=7):
    t = np.arange(n_steps, dtype=float) * 0.01
    V = np.zeros((n_steps, cs.nv))
    s0 = np.zeros(cs.ns)
    S, Y, O = np.empty((n_steps, cs.ns)), np.empty((n_steps, cs.ny)), np.empty((n_steps, cs.no))
    times = []
    for _ in range(repeat):
        c0 = time.process_time()
        cs.run_arrays(t, V, s0, S=S, Y=Y, O=O)
        times.append(time.process_time() - c0)
    return statistics.median(times) / n_steps * 1e9


def bench_compile(sizes, repeat):
    rows = []
    for label, m, obs in _cases(sizes):
        walls = {"old": [], "new": []}
        ccs = {"old": [], "new": []}
        cpus = {"old": [], "new": []}
        info = {}
        for r in range(repeat):
            for which, flags in (("old", OLD_FLAGS), ("new", None)):
                cs, wall, cpu, cc, size, d = _build(m, obs, flags)
                walls[which].append(wall)
                cpus[which].append(cpu)
                ccs[which].append(cc)
                if r == 0:
                    # about 0.1 s per run: a step costs roughly 0.01 ns per character of C
                    n_steps = max(5000, min(1_000_000, int(1e10 / max(size, 1))))
                    info[which] = (cs.flags, size, _per_step(cs, n_steps), n_steps)
                shutil.rmtree(d, ignore_errors=True)
        rows.append(dict(label=label, states=len(m.states), obs_states=len(obs.states),
                         size=info["new"][1], old_flags=info["old"][0], new_flags=info["new"][0],
                         old_wall=statistics.median(walls["old"]),
                         new_wall=statistics.median(walls["new"]),
                         old_cc=statistics.median(ccs["old"]), new_cc=statistics.median(ccs["new"]),
                         old_cpu=statistics.median(cpus["old"]),
                         new_cpu=statistics.median(cpus["new"]),
                         old_ns=info["old"][2], new_ns=info["new"][2], steps=info["new"][3]))
        print(f"  {label}: {info['new'][1]:,} chars; CPU old {rows[-1]['old_cpu']:.2f} s new"
              f" {rows[-1]['new_cpu']:.2f} s; old {rows[-1]['old_wall']:.2f} s"
              f" ({rows[-1]['old_cc']:.2f} s cc) {rows[-1]['old_ns']:,.0f} ns/step;"
              f" new {' '.join(info['new'][0][:1])} {rows[-1]['new_wall']:.2f} s"
              f" ({rows[-1]['new_cc']:.2f} s cc) {rows[-1]['new_ns']:,.0f} ns/step", flush=True)
    return rows


# ------------------------------------------------------------------ CLI
def _env(tree: Path, pyc: Path) -> dict:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPYCACHEPREFIX"] = str(pyc)
    env["PYTHONPATH"] = str(tree)
    env["MPLBACKEND"] = "Agg"
    env.setdefault("OBSERVER_CAD_CACHE", str(pyc / "occache"))
    return env


def _run(args, env, cwd):
    c0, t0 = _children_cpu(), time.perf_counter()
    r = subprocess.run([sys.executable, *args], env=env, cwd=cwd, stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed ({r.returncode}): {r.stderr.strip()[-500:]}")
    return wall, cpu


def bench_cli(trees: dict, repeat: int):
    """{tree label: {command: (wall median, cpu median)}} and the floors (this tree)."""
    pyc = Path(tempfile.mkdtemp(prefix="bench_latency_pyc_"))
    out_dir = Path(tempfile.mkdtemp(prefix="bench_latency_out_"))
    try:
        jobs = []
        for label, tree in trees.items():
            env = _env(tree, pyc / label)
            for kind, cmd in CLI:
                args = ["-m", "observer_cad"] + cmd.format(out=out_dir / f"{label}-sim").split()
                # cwd = the tree: ``python3 -m`` puts the working directory first on sys.path
                jobs.append((label, cmd, args, env, tree))
        env0 = _env(ROOT, pyc / "floor")
        floors = [("floor", name, args, env0, ROOT) for name, args in FLOORS]
        for label, _, _, env, tree in jobs:
            where = subprocess.run([sys.executable, "-c", "import observer_cad; print(observer_cad.__file__)"],
                                   env=env, cwd=tree, capture_output=True, text=True).stdout.strip()
            if not where.startswith(str(tree)):
                raise SystemExit(f"{label}: observer_cad comes from {where}, not {tree}")
        for _, _, args, env, tree in jobs + floors:      # warm-up: byte code, compile cache
            _run(args, env, tree)
        res: dict = {}
        for _ in range(repeat):
            for label, cmd, args, env, tree in jobs + floors:
                res.setdefault((label, cmd), []).append(_run(args, env, tree))
        return {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
                for k, v in res.items()}
    finally:
        shutil.rmtree(pyc, ignore_errors=True)
        shutil.rmtree(out_dir, ignore_errors=True)


def _git_head(tree: Path) -> str:
    try:
        return subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True).stdout.strip() or "?"
    except OSError:
        return "?"


def _fmt_flags(flags):
    return "`" + " ".join(f for f in flags if f.startswith("-O")) + "`"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="update benchmarks/README.md")
    ap.add_argument("--repeat", type=int, default=3, help="compile rounds per case")
    ap.add_argument("--cli-repeat", type=int, default=7, help="runs per command")
    ap.add_argument("--sizes", type=int, nargs="*", default=[30, 45, 60],
                    help="states of the random plants")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="another source tree (e.g. a checkout of main before the change) whose"
                         " CLI is timed beside this one")
    ap.add_argument("--baseline-label", default=None,
                    help="how the baseline is named in the table (default: its git HEAD)")
    ap.add_argument("--skip-compile", action="store_true")
    args = ap.parse_args()

    from observer_cad.codegen import LARGE_LEVEL, LARGE_SOURCE, compiler
    load0 = _load()
    started = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
    mc = machine()
    cc_ver = subprocess.run([compiler(), "--version"], capture_output=True,
                            text=True).stdout.splitlines()[0]
    print(f"load average at the start: {load0}")
    comp = [] if args.skip_compile else bench_compile(args.sizes, args.repeat)
    trees = {"this": ROOT}
    if args.baseline is not None:
        trees = {"baseline": args.baseline.resolve(), "this": ROOT}
    cli = bench_cli(trees, args.cli_repeat)
    load1 = _load()

    lines = [f"Measured {started} by `python3 benchmarks/bench_latency.py --write"
             + (f" --baseline {args.baseline}" if args.baseline else "") + "`: "
             f"{mc['nproc']} CPUs ({cpu_name()}), Python {mc['python']}, sympy {mc['sympy']}, "
             f"numpy {mc['numpy']}, {cc_ver}. Load average (1, 5, 15 min) {load0} at the start, "
             f"{load1} at the end.", ""]
    if comp:
        lines += [
            f"**Compile** (cold `CompiledSimulator`: translation, C generation, compiler, "
            f"dlopen; median of {args.repeat} fresh caches, old and new alternating). "
            f"Old: {_fmt_flags(OLD_FLAGS)} always; new: size-aware, `{LARGE_LEVEL}` above "
            f"{LARGE_SOURCE:,} characters of C. *CPU (cc)*: CPU time of the whole construction, "
            "this process plus the compiler (the compiler's share in parentheses). "
            "*ns/step*: the compiled trajectory on zero inputs (median CPU time of 7 runs).", "",
            "| case | states (plant + observer) | C chars | old: wall | old: CPU (cc) | old: ns/step "
            "| new flags | new: wall | new: CPU (cc) | new: ns/step | compiler CPU old/new "
            "| step time new/old |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in comp:
            lines.append(
                f"| {r['label']} | {r['states']} + {r['obs_states']} | {r['size']:,} "
                f"| {r['old_wall']:.2f} s | {r['old_cpu']:.2f} s ({r['old_cc']:.2f} s) | {r['old_ns']:,.0f} "
                f"| {_fmt_flags(r['new_flags'])} | {r['new_wall']:.2f} s "
                f"| {r['new_cpu']:.2f} s ({r['new_cc']:.2f} s) "
                f"| {r['new_ns']:,.0f} | {r['old_cc'] / max(r['new_cc'], 1e-9):.1f}× "
                f"| {r['new_ns'] / max(r['old_ns'], 1e-9):.2f} |")
        lines.append("")
        big = [r for r in comp if r["states"] == 60]
        lines += ["| target | measured | result |", "|---|---|---|"]
        for r in big:
            ok = r["new_wall"] < TARGET_COMPILE_60
            lines.append(f"| {r['label']}: cold compile < {TARGET_COMPILE_60:g} s wall "
                         f"| {r['new_wall']:.2f} s (old flags {r['old_wall']:.2f} s) "
                         f"| {'met' if ok else '**MISSED**'} |")
            ok = r["new_cpu"] < TARGET_COMPILE_60
            lines.append(f"| {r['label']}: cold compile < {TARGET_COMPILE_60:g} s CPU (the wall "
                         f"time of an idle machine) | {r['new_cpu']:.2f} s, compiler "
                         f"{r['new_cc']:.2f} s (old flags {r['old_cpu']:.2f} s) "
                         f"| {'met' if ok else '**MISSED**'} |")
        lines.append("")
    lines += [
        f"**Command line** (`python3 -m observer_cad ...`, fresh process, median of "
        f"{args.cli_repeat} after a warm-up; byte code cached; wall-clock and the child's "
        "CPU time).", ""]
    labels = list(trees)
    names = {lb: f"{lb} ({_git_head(trees[lb])})" for lb in labels}
    if args.baseline_label and "baseline" in names:
        names["baseline"] = f"baseline ({args.baseline_label})"
    head = "| command | " + " | ".join(
        f"{names[lb]}: wall | CPU" for lb in labels) \
        + (" | speed-up wall / CPU" if len(labels) == 2 else "") + " | target | result |"
    lines += [head,
              "|---|" + "---|---|" * len(labels) + ("---|" if len(labels) == 2 else "")
              + "---|---|"]
    for kind, cmd in CLI:
        cells = []
        for lb in labels:
            w, c = cli[(lb, cmd)]
            cells.append(f"{w:.2f} s | {c:.2f} s")
        if len(labels) == 2:
            (wb, cb), (wn, cn) = cli[("baseline", cmd)], cli[("this", cmd)]
            cells.append(f"{wb / wn:.2f}× / {cb / cn:.2f}×")
        w_new = cli[("this", cmd)][0]
        target = CLI_TARGETS[kind]
        shown = cmd.replace("{out}", "DIR")
        lines.append(f"| `{shown}` | " + " | ".join(cells)
                     + f" | < {target:g} s wall | {'met' if w_new < target else '**MISSED**'} |")
    lines.append("")
    lines += ["| floor (this tree) | wall | CPU |", "|---|---|---|"]
    for name, _ in FLOORS:
        w, c = cli[("floor", name)]
        lines.append(f"| `{name}` | {w:.2f} s | {c:.2f} s |")
    table = "\n".join(lines)
    publish(table, README, BEGIN, END, write=args.write)


if __name__ == "__main__":
    main()
