"""Atomic CSV output of simulation results: ``signals.csv`` and, beside it, the units of
its columns in ``signals.units.json`` (the CSV itself stays plain: one header row)."""
from __future__ import annotations

import csv
import dataclasses
import io
import json
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import atomic_write_text

__all__ = ["write_signals_csv", "UNITS_FILE", "with_decisions", "DECISION_COLUMNS", "csv_cell"]

#: the columns :func:`with_decisions` adds: the any-alarm (0/1) and the diagnosis (text)
DECISION_COLUMNS = ("alarm", "diagnosis")

#: the sidecar beside ``signals.csv``: a JSON object column -> unit, in column order,
#: listing only the columns that have a unit
UNITS_FILE = "signals.units.json"


def csv_cell(v: float, *, nan: str = "nan") -> str:
    """A float as a CSV cell: shortest round-trip text, ``inf``/``-inf``, and ``nan`` as
    given (``signals.csv`` writes ``nan``; an empty cell there means "not available").

    Examples
    --------
    >>> from observer_cad.reporting import csv_cell
    >>> csv_cell(0.1), csv_cell(float("-inf")), csv_cell(float("nan"), nan="")
    ('0.1', '-inf', '')
    """
    if np.isnan(v):
        return nan
    if np.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(float(v))





def with_decisions(result, decisions, *, per_residual: bool = False):
    """The result (a :class:`~observer_cad.simulation.SimulationResult`) with the columns
    of :class:`~observer_cad.observers.Decisions` appended for the writer: ``alarm``
    (0/1, any residual alarms) and ``diagnosis`` (text, e.g. ``f1 or f2``); with
    ``per_residual=True`` also ``<r>_alarm`` (0/1) per residual, before them. The
    decisions must have the result's shape. A column already present is refused."""
    t = np.asarray(result["t"])
    if np.shape(decisions.alarm) != t.shape:
        raise UsageError(f"with_decisions: the decisions have shape {np.shape(decisions.alarm)}"
                         f" but the result {t.shape}")
    dec = decisions.columns()
    names = ([f"{r}_alarm" for r in decisions.rule.residuals] if per_residual else []) \
        + list(DECISION_COLUMNS)
    for n in names:
        if n in result.order:
            raise UsageError(f"with_decisions: the result already has a column '{n}'")
    cols = dict(result.columns)
    cols.update({n: dec[n] for n in names})
    return dataclasses.replace(result, columns=cols, order=tuple(result.order) + tuple(names))


def _column(name: str, v) -> np.ndarray:
    """Text columns stay text; the decision flags (``alarm``, ``<r>_alarm``,
    ``diagnosis_code``) integers; everything else float (as before decisions existed)."""
    a = np.asarray(v)
    if a.dtype.kind in "OUS":
        return a.astype(object)
    if a.dtype.kind in "bi" and (name in DECISION_COLUMNS or name.endswith("_alarm")
                                 or name in ("diagnosis_code", "in_bounds")):
        return a
    return np.asarray(v, dtype=float)


def _any_cell(v: np.ndarray, i: int) -> str:
    if v.dtype.kind == "O":
        return str(v[i])
    if v.dtype.kind in "bi":
        return str(int(v[i]))
    return csv_cell(v[i])


def _csv_field(text: str) -> str:
    """``text`` as the csv module writes it as one field of a row of several."""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow([text, ""])
    return buf.getvalue()[:-2]


def _cells(v: np.ndarray, avail: int) -> list:
    """The cells of a one-dimensional column, as :func:`_any_cell` writes them one by one
    (``repr`` of a Python float is :func:`csv_cell`'s text, ``nan`` and ``±inf``
    included), with an empty cell from row ``avail`` on — a column at a time."""
    a = max(min(avail, v.shape[0]), 0)
    if v.dtype.kind == "O":   # text, quoted as the csv module quotes it (once per text)
        cells = [str(x) for x in v[:a].tolist()]
        quoted = {x: _csv_field(x) for x in set(cells)}
        cells = [quoted[x] for x in cells]
    elif v.dtype.kind in "bi":
        cells = list(map(str, v[:a].astype(np.int64).tolist()))
    else:
        cells = list(map(repr, v[:a].astype(float).tolist()))
    cells.extend([""] * (v.shape[0] - a))
    return cells


def write_signals_csv(result, out_dir, *, name: str = "signals.csv") -> Path:
    """``DIR/signals.csv``: a header row, then one row per time step; and
    ``DIR/signals.units.json`` (:data:`UNITS_FILE`), the units of the columns that have one
    (``{}`` when none do), rewritten every time so that it never describes an older CSV.
    Returns the CSV's path. ``name``: another file name (``monitor.csv``; its units then
    in ``monitor.units.json``).

    An empty cell means *not available*: the last rows of an estimate produced
    ``delay`` steps late (``result.delays``). Any other value that is not finite — only
    present when the simulation was asked to keep them — is written literally as
    ``nan``, ``inf`` or ``-inf``, never as an empty cell. Text columns (``diagnosis``,
    see :func:`with_decisions`) are written as text, quoted by the csv module when
    needed; integer columns (``alarm``) as integers.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{out_dir}: cannot create the output directory:"
                         f" {exc.strerror or exc}") from None
    cols = list(result.order)
    data = [_column(c, result[c]) for c in cols]
    n = data[0].shape[0]
    delays = dict(getattr(result, "delays", None) or {})
    avail = [n - int(delays.get(c, 0)) for c in cols]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    if len(data) > 1 and all(v.ndim == 1 and v.shape[0] == n for v in data):
        # a column at a time; the rows joined as csv.writer joins them (only text needs
        # quoting, done once per distinct text)
        buf.write("".join(map("{}\n".format, map(",".join, zip(
            *[_cells(v, a) for v, a in zip(data, avail)])))))
    else:
        for i in range(n):
            w.writerow(["" if i >= a else _any_cell(v, i) for v, a in zip(data, avail)])
    path = out / name
    units = getattr(result, "units", None) or {}
    units_file = UNITS_FILE if name == "signals.csv" else f"{Path(name).stem}.units.json"
    try:
        atomic_write_text(path, buf.getvalue())
        atomic_write_text(out / units_file, json.dumps(
            {c: units[c] for c in cols if c in units}, indent=2, ensure_ascii=False) + "\n")
    except OSError as exc:
        raise UsageError(f"{path}: cannot write: {exc.strerror or exc}") from None
    return path
