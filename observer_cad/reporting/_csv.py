"""Atomic CSV output of simulation results."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import atomic_write_text

__all__ = ["atomic_write_text", "write_signals_csv"]


def write_signals_csv(result, out_dir) -> Path:
    """``DIR/signals.csv``: a header row, then one row per time step (NaN: not available,
    e.g. the last rows of a delayed estimate)."""
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
    return path
