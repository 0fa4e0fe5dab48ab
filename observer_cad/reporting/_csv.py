"""Atomic CSV output of simulation results: ``signals.csv`` and, beside it, the units of
its columns in ``signals.units.json`` (the CSV itself stays plain: one header row)."""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import atomic_write_text

__all__ = ["write_signals_csv", "UNITS_FILE"]

#: the sidecar beside ``signals.csv``: a JSON object column -> unit, in column order,
#: listing only the columns that have a unit
UNITS_FILE = "signals.units.json"


def _cell(v: float) -> str:
    if np.isnan(v):
        return "nan"
    if np.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(float(v))


def write_signals_csv(result, out_dir) -> Path:
    """``DIR/signals.csv``: a header row, then one row per time step; and
    ``DIR/signals.units.json`` (:data:`UNITS_FILE`), the units of the columns that have one
    (``{}`` when none do), rewritten every time so that it never describes an older CSV.
    Returns the CSV's path.

    An empty cell means *not available*: the last rows of an estimate produced
    ``delay`` steps late (``result.delays``). Any other value that is not finite — only
    present when the simulation was asked to keep them — is written literally as
    ``nan``, ``inf`` or ``-inf``, never as an empty cell.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{out_dir}: cannot create the output directory:"
                         f" {exc.strerror or exc}") from None
    cols = list(result.order)
    data = [np.asarray(result[c], dtype=float) for c in cols]
    n = data[0].shape[0]
    delays = dict(getattr(result, "delays", None) or {})
    avail = [n - int(delays.get(c, 0)) for c in cols]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for i in range(n):
        w.writerow(["" if i >= a else _cell(v[i]) for v, a in zip(data, avail)])
    path = out / "signals.csv"
    units = getattr(result, "units", None) or {}
    try:
        atomic_write_text(path, buf.getvalue())
        atomic_write_text(out / UNITS_FILE, json.dumps(
            {c: units[c] for c in cols if c in units}, indent=2, ensure_ascii=False) + "\n")
    except OSError as exc:
        raise UsageError(f"{path}: cannot write: {exc.strerror or exc}") from None
    return path
