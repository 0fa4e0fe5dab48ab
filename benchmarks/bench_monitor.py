#!/usr/bin/env python3
"""Monitor throughput on recorded data against the compiled simulation loop.

    python3 benchmarks/bench_monitor.py            # measure, print the table
    python3 benchmarks/bench_monitor.py --write    # ... and update benchmarks/README.md

For each case (a model, its observer with the guaranteed threshold and decision rule):

* *compiled loop*: ``CompiledSimulator(model, observer).simulate(scenario)`` over N steps —
  plant and observer stepped together in one compiled C call, the result's columns
  built (what ``observer-cad simulate`` runs);
* *monitor, arrays*: ``Monitor(...).run(columns)`` with the compiled engine on N recorded
  rows already in memory (the checks of every row, the compiled observer loop, the
  decisions with persistence, the table);
* *monitor, CSV*: ``read_table(file)`` of those rows written as CSV (``%.17g``), then the
  same run (what ``observer-cad monitor --data FILE`` does after the design, without
  writing);
* *monitor, CSV → monitor.csv*: the same, then ``write_signals_csv`` of the table (the
  CLI's ``monitor.csv``; its figure not drawn);
* *C example, CSV → stdout*: the exported C example (``export_observer``, compiled with
  ``cc -O2``) run as a process on the same file: it parses the CSV, steps the observer,
  decides and prints the same columns (``%.17g``) to stdout, here ``/dev/null``.

Reported: rows per second (the best of ``--repeats`` runs, wall clock; the library is
compiled and pandas imported before the timing) and two ratios of times: monitor /
compiled loop (goal ≤ 2: the monitor within 2× of the compiled loop; measured, not
asserted) and, for recorded data in a file, monitor (CSV → monitor.csv) / C example
(both read the CSV and write the table as text).
"""
from __future__ import annotations

import argparse
import datetime
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from common import load as _load, machine, publish  # noqa: E402

README = Path(__file__).resolve().parent / "README.md"
BEGIN = "<!-- BEGIN MONITOR RESULTS (bench_monitor.py --write) -->"
END = "<!-- END MONITOR RESULTS -->"
GOAL = 2.0


def _cases():
    from observer_cad import build_observer, design, design_bank, load_model
    from observer_cad.residuals import ThresholdSpec, decision_rule
    from observer_cad.simulation import apply_threshold
    g = ThresholdSpec.parse("guaranteed")
    m = load_model(ROOT / "models" / "electric_drive_uncertain.py")
    d = design(m, observer="diagnostic")
    yield ("electric_drive_uncertain, diagnostic (discrete)", m,
           apply_threshold(m, build_observer(m, d), g), decision_rule(m, d),
           {"seed": 1, "initial": {}, "signals": {"u": "2*sin(t/10)",
                                                  "rho": {"uniform": [-0.05, 0.05]},
                                                  "w1": {"uniform": [0, 0.02]},
                                                  "w2": {"uniform": [-0.01, 0.01]}}})
    m = load_model(ROOT / "models" / "three_tank_isolation.py")
    b = design_bank(m)
    yield ("three_tank_isolation, bank of 3 (continuous, h = 0.01)", m,
           apply_threshold(m, build_observer(m, b), g), decision_rule(m, b),
           {"seed": 1, "initial": {}, "signals": {"u1": "1 + 0.5*sin(0.3*t)", "u2": "0.5",
                                                  "rho": "0.1*sin(0.7*t)"}})


def _best(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _write_csv(cols: dict, path: Path) -> None:
    names = list(cols)
    a = np.column_stack([np.asarray(cols[c], dtype=float) for c in names])
    np.savetxt(path, a, delimiter=",", header=",".join(names), comments="", fmt="%.17g")


def _c_example(m, obs, rule, h, d: Path):
    """The exported C example (``export_observer``: NAME.c and NAME_example.c), compiled
    with ``cc -O2``: its path, or None without a C compiler."""
    from observer_cad.codegen import export_observer
    from observer_cad.simulation import declared_envelope
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    paths = export_observer(obs, d, dt=h if m.time == "continuous" else None, rule=rule,
                            envelope=declared_envelope(m))
    exe = d / "example"
    subprocess.run([cc, "-O2", "-std=c99", *map(str, paths[::2]), "-lm", "-o", str(exe)],
                   check=True, capture_output=True, cwd=d)
    return exe


def _run_c(exe: Path, csv: Path) -> None:
    """The C example over ``csv``, its table (written to stdout) discarded."""
    subprocess.run([str(exe), str(csv)], check=True, stdout=subprocess.DEVNULL)


def measure(n: int, repeats: int) -> list:
    from observer_cad import Monitor
    from observer_cad.codegen import CompiledMonitorEngine, CompiledSimulator
    from observer_cad.reporting import write_signals_csv
    from observer_cad.simulation import read_table, scenario_from_dict
    rows = []
    for name, m, obs, rule, spec in _cases():
        spec = dict(spec)
        if m.time == "discrete":
            spec["steps"] = n
        else:
            spec.update(dt=0.01, t_end=0.01 * (n - 1))
        sc = scenario_from_dict(spec, source="bench")
        sim = CompiledSimulator(m, obs)
        res = sim.simulate(sc)
        t_sim = _best(lambda: sim.simulate(sc), repeats)
        eng = CompiledMonitorEngine(obs)
        mon = Monitor(m, obs, rule=rule, engine=eng)
        cols = {"t": np.asarray(res["t"])}
        cols.update({s: np.asarray(res[s]) for s in mon.signals})
        t_arr = _best(lambda: mon.run(cols), repeats)
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "rec.csv"
            _write_csv(cols, path)
            t_csv = _best(lambda: mon.run(read_table(path)), repeats)
            out = Path(d) / "out"
            t_out = _best(lambda: write_signals_csv(mon.run(read_table(path)), out,
                                                    name="monitor.csv"), repeats)
            exe = _c_example(m, obs, rule, float(cols["t"][1] - cols["t"][0]), Path(d))
            t_c = _best(lambda: _run_c(exe, path), repeats) if exe else float("nan")
        rows.append((name, n, t_sim, t_arr, t_csv, t_out, t_c))
    return rows


def table(rows, repeats: int) -> str:
    mach = machine()
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")
    head = (f"Measured {when} UTC by `python3 benchmarks/bench_monitor.py --write`:"
            f" {mach['nproc']} CPUs ({mach['cpu']}), Python {mach['python']}, numpy"
            f" {mach['numpy']}. Load average {_load()}. Best of {repeats} runs, wall clock;"
            f" rows per second; × loop = monitor time / compiled-loop time (goal ≤ {GOAL:g});"
            " × C = monitor (CSV → monitor.csv) time / C example time.\n\n")
    out = ["| case | rows | compiled loop | monitor, arrays | × loop | monitor, CSV | × loop"
           " | monitor, CSV → monitor.csv | C example, CSV → stdout | × C |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for name, n, ts, ta, tc, to, te in rows:
        c = (f"{n / te:,.0f}/s | {to / te:.2f}" if np.isfinite(te) else "(no C compiler) | –")
        out.append(f"| {name} | {n:,} | {n / ts:,.0f}/s | {n / ta:,.0f}/s | {ta / ts:.2f}"
                   f" | {n / tc:,.0f}/s | {tc / ts:.2f} | {n / to:,.0f}/s | {c} |")
    return head + "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=100_000, help="rows per case (default 100000)")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs, best kept (default 3)")
    ap.add_argument("--write", action="store_true", help="update benchmarks/README.md")
    a = ap.parse_args()
    publish(table(measure(a.rows, a.repeats), a.repeats), README, BEGIN, END, write=a.write)


if __name__ == "__main__":
    main()
