"""What every benchmark script shares: the machine it ran on, the load average, and the
atomic rewrite of its own results section of benchmarks/README.md."""
import os
import platform
from pathlib import Path

import numpy
import sympy

from observer_cad.files import atomic_write_text


def cpu_name() -> str:
    """The CPU model from /proc/cpuinfo (Linux), else platform.processor()."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def machine() -> dict:
    """CPUs usable by this process, CPU model, Python, sympy, numpy and the platform."""
    try:
        nproc = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        nproc = os.cpu_count()
    return {"nproc": nproc, "cpu": cpu_name(), "python": platform.python_version(),
            "sympy": sympy.__version__, "numpy": numpy.__version__,
            "platform": platform.platform()}


def load() -> str:
    """The 1, 5 and 15 minute load averages, or "?"."""
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover
        return "?"


def write_section(readme: Path, begin: str, end: str, table: str) -> None:
    """Replace the text between ``begin`` and ``end`` in ``readme`` with ``table``."""
    text = readme.read_text() if readme.exists() else ""
    if begin not in text or end not in text:
        raise SystemExit(f"{readme}: the markers {begin!r} and {end!r} are missing")
    before, rest = text.split(begin, 1)
    _, after = rest.split(end, 1)
    atomic_write_text(readme, before + begin + "\n" + table + "\n" + end + after)


def publish(table: str, readme: Path, begin: str, end: str, *, write: bool) -> None:
    """Print the table and, with ``write``, replace its section of ``readme``."""
    print()
    print(table)
    if write:
        write_section(readme, begin, end, table)
        print(f"\nwrote {readme}")
