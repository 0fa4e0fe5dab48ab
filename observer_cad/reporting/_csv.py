"""Atomic CSV output of simulation results."""
from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import atomic_write_text

__all__ = ["atomic_write_text", "write_signals_csv"]


def _cell(v: float) -> str:
    if np.isnan(v):
        return "nan"
    if np.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(float(v))


def write_signals_csv(result, out_dir) -> Path:
    """``DIR/signals.csv``: a header row, then one row per time step.

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
    try:
        atomic_write_text(path, buf.getvalue())
    except OSError as exc:
        raise UsageError(f"{path}: cannot write: {exc.strerror or exc}") from None
    return path
