"""Regenerate every benchmark table in benchmarks/README.md with one command:

    python3 benchmarks/run.py

(runs bench_synthesis.py, bench_analyze.py, bench_codegen.py, then
bench_jordan_minimality.py, each with --write; each rewrites its own section atomically).
"""
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

if __name__ == "__main__":
    for script in ("bench_synthesis.py", "bench_analyze.py", "bench_codegen.py",
                   "bench_jordan_minimality.py"):
        print(f"== {script}", flush=True)
        rc = subprocess.call([sys.executable, str(HERE / script), "--write"] + sys.argv[1:])
        if rc:
            sys.exit(rc)
