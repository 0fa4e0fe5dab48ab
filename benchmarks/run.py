"""Regenerate every benchmark table in benchmarks/README.md with one command:

    python3 benchmarks/run.py

(runs bench_synthesis.py --write, bench_analyze.py --write, bench_exact.py --write,
bench_codegen.py --write, bench_poles.py --write, bench_scale.py --write,
bench_decisions.py --write, bench_latency.py --write, bench_jordan_minimality.py --write,
bench_summaries.py --write, bench_backends.py --write, bench_monitor.py --write, then
bench_ensemble.py --write;
each rewrites its own section atomically).
"""
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

if __name__ == "__main__":
    for script in ("bench_synthesis.py", "bench_analyze.py", "bench_exact.py", "bench_codegen.py",
                   "bench_poles.py", "bench_scale.py", "bench_decisions.py",
                   "bench_latency.py", "bench_jordan_minimality.py", "bench_summaries.py",
                   "bench_backends.py", "bench_monitor.py", "bench_ensemble.py"):
        print(f"== {script}", flush=True)
        rc = subprocess.call([sys.executable, str(HERE / script), "--write"] + sys.argv[1:])
        if rc:
            sys.exit(rc)
