"""Atomic CSV output of simulation results: ``signals.csv`` and, beside it, the units of
its columns in ``signals.units.json`` (the CSV itself stays plain: one header row)."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import atomic_write_text

__all__ = ["write_signals_csv", "UNITS_FILE"]

#: the sidecar beside ``signals.csv``: a JSON object column -> unit, in column order,
#: listing only the columns that have a unit
UNITS_FILE = "signals.units.json"


def write_signals_csv(result, out_dir) -> Path:
    """``DIR/signals.csv``: a header row, then one row per time step (NaN: not available,
    e.g. the last rows of a delayed estimate); and ``DIR/signals.units.json``
    (:data:`UNITS_FILE`), the units of the columns that have one (``{}`` when none do),
    rewritten every time so that it never describes an older CSV. Returns the CSV's path."""
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{out_dir}: cannot create the output directory: {exc.strerror}") from None
    cols = [c for c in result.order]
    data = [np.asarray(result[c], dtype=float) for c in cols]
    import io
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for i in range(data[0].shape[0]):
        w.writerow(["" if np.isnan(v[i]) else repr(float(v[i])) for v in data])
    path = out / "signals.csv"
    atomic_write_text(path, buf.getvalue())
    units = getattr(result, "units", None) or {}
    atomic_write_text(out / UNITS_FILE, json.dumps(
        {c: units[c] for c in cols if c in units}, indent=2, ensure_ascii=False) + "\n")
    return path
