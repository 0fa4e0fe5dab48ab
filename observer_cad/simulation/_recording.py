"""Recorded data for a monitor: the checks every row passes, the time grid and the
declared operating envelope.

A recording is a table with a time column ``t`` and one column per signal the observer
reads, named as in the model (``y1, y2, …`` for the outputs, the inputs by their
symbols). The checks, each a one-line :class:`~observer_cad.errors.UsageError` naming
the row (1 = the first data row; in a CSV file the line is one more, after the header)
and the column:

* every column the observer reads is present;
* every cell is a finite number (no text, no empty cell, no NaN, no ±inf);
* ``t`` increases, regularly: every interval ``t[k+1] − t[k]`` equals the sample time
  ``h`` within :data:`TIME_RTOL` · h, where h is the first interval;
* continuous time: the observer runs the discrete algorithm of the exported C
  (:func:`~observer_cad.codegen.observer_step`) at ``h``, inputs held over each interval
  (zero-order hold) and outputs sampled;
* discrete time: one row is one step of the model; ``t`` counts in units of
  ``sample_time`` (default 1: ``t`` is the step number ``k``), and ``h`` must equal it
  (within :data:`TIME_RTOL`) — a recording in seconds of a model in steps is refused
  with the hint to give the sample time.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import UsageError
from ..model import PlantModel

__all__ = ["TIME_RTOL", "declared_envelope", "declared_signal_bounds", "bounds_check", "check_times", "check_cells", "Recording",
           "recording_from_columns", "read_table", "parse_row", "PARQUET_SUFFIXES"]

#: a CSV longer than this (bytes) is parsed by pandas when it is installed (its C
#: parser is ~8× faster than numpy's loadtxt; importing it costs ~0.5 s)
PANDAS_FROM = 1 << 20

#: file name endings read as Parquet (with pyarrow); anything else is CSV
PARQUET_SUFFIXES = (".parquet", ".pq")

#: relative tolerance of the sample time: every interval of ``t`` equals the first one
#: within this fraction of it (0.1 %: a logger's rounded time stamps pass, a dropped or
#: repeated sample does not)
TIME_RTOL = 1e-3


def declared_envelope(model: PlantModel) -> dict:
    """The declared operating range of the recorded signals: name → (low, high) floats,
    for the model's inputs that have bounds, and for each output ``y1 …`` whose every
    state, input, disturbance and noise term has declared bounds (the operating envelope of
    the states included): the interval of its linear expression over them, faults taken as
    zero (a fault is what the monitor is there to see). Signals without a declared range
    are absent (not checked)."""
    env = {}
    for s in model.inputs:
        b = model.bounds.get(s)
        if b is not None:
            env[str(s)] = (float(b[0]), float(b[1]))
    faults = {f: 0 for f in model.faults}
    for i, h in enumerate(model.outputs):
        rng = _linear_range(sp.sympify(h).xreplace(faults).xreplace(dict(model.parameters)),
                            model.bounds)
        if rng is not None:
            env[f"y{i + 1}"] = rng
    return env


def _linear_range(e, bounds) -> tuple | None:
    """(low, high) of an affine expression over boxed symbols, or None (a symbol without
    bounds, or a term that is not affine)."""
    syms = sorted(e.free_symbols, key=str)
    if any(s not in bounds for s in syms):
        return None
    try:
        poly = sp.Poly(e, *syms) if syms else None
    except sp.PolynomialError:
        return None
    if poly is not None and poly.total_degree() > 1:
        return None
    lo = hi = e.xreplace({s: 0 for s in syms})
    for s in syms:
        c = e.coeff(s)
        a, b = c * bounds[s][0], c * bounds[s][1]
        lo, hi = lo + sp.Min(a, b), hi + sp.Max(a, b)
    try:
        return float(lo), float(hi)
    except TypeError:
        return None


def declared_signal_bounds(model: PlantModel) -> dict:
    """What a simulated run must stay in for the guaranteed threshold to hold: name →
    (low, high) floats for the disturbances and noise with declared bounds, and the
    signals of :func:`declared_envelope` (faults are not included: a fault is what the
    monitor is there to see)."""
    out = {str(s): (float(b[0]), float(b[1])) for s, b in model.bounds.items()
           if s in set(model.disturbances) | set(model.noise)}
    out.update(declared_envelope(model))
    return out


def bounds_check(ranges: Mapping, columns: Mapping, n: int) -> tuple:
    """(mask (n,) bool: every signal of ``ranges`` present in ``columns`` lies in its
    range (inclusive), the first violation as ``(index, name, value, low, high)`` or
    None)."""
    ok = np.ones(n, dtype=bool)
    first = None
    for name, (lo, hi) in ranges.items():
        if name not in columns:
            continue
        v = np.asarray(columns[name], dtype=float).reshape(-1)[:n]
        inside = (v >= lo) & (v <= hi)
        if not inside.all():
            k = int(np.flatnonzero(~inside)[0])
            if first is None or k < first[0]:
                first = (k, name, float(v[k]), lo, hi)
        ok &= inside
    return ok, first


def _where(source: str | None, row: int, column: str) -> str:
    line = f" (line {row + 1})" if source and not source.startswith("<") else ""
    return f"{source + ', ' if source else ''}row {row}{line}, column '{column}'"


def check_times(t: np.ndarray, *, time: str, sample_time: float | None, source: str | None,
                first_row: int = 1, h: float | None = None) -> float:
    """The sample time h of the time stamps ``t`` (their first interval, or ``h`` when
    given), after the checks of the module docstring; ``first_row`` is the row number of
    ``t[0]``."""
    t = np.asarray(t, dtype=float)
    if t.size < 2 and h is None:
        if time == "continuous":
            raise UsageError(f"{source or 'data'}: at least two rows are needed (the sample"
                             " time is the interval of t)")
        h = 1.0 if sample_time is None else float(sample_time)
    d = np.diff(t)
    if h is None and d.size and d[0] > 0 and d.max() - d[0] <= TIME_RTOL * d[0] \
            and d[0] - d.min() <= TIME_RTOL * d[0]:
        # every |d − d[0]| ≤ TIME_RTOL·d[0] (x ↦ x − d[0] is monotone in floating point, so
        # the extremes decide; NaN fails), hence also every d > 0: nothing to find below
        h = float(d[0])
        d = d[:0]
    bad = np.flatnonzero(~(d > 0))
    if bad.size:
        k = int(bad[0]) + 1
        raise UsageError(f"{_where(source, first_row + k, 't')}: t = {t[k]:.17g} does not increase"
                         f" (the row before has {t[k - 1]:.17g})")
    if h is None:
        h = float(d[0])
    bad = np.flatnonzero(np.abs(d - h) > TIME_RTOL * h) if d.size else d
    if bad.size:
        k = int(bad[0]) + 1
        raise UsageError(f"{_where(source, first_row + k, 't')}: the interval {d[k - 1]:.10g}"
                         f" differs from the sample time {h:.10g} (the first interval) by more"
                         f" than {TIME_RTOL:g}·h: t must be regular")
    if time == "discrete":
        step = 1.0 if sample_time is None else float(sample_time)
        if abs(h - step) > TIME_RTOL * step:
            hint = (" (t counts its steps; if t is in seconds, give the sample time, e.g."
                    f" --sample-time {h:.10g})" if sample_time is None else "")
            raise UsageError(f"{_where(source, first_row + 1, 't')}: t steps by {h:.10g} but the"
                             f" discrete-time model steps by {step:g}{hint}")
    return float(h)


def check_cells(name: str, v: np.ndarray, *, source: str | None, first_row: int = 1) -> None:
    """Every value of column ``name`` finite (one line naming the first that is not)."""
    with np.errstate(all="ignore"):
        if v.dtype.kind == "f" and np.isfinite(np.add.reduce(v, axis=None)):
            return   # a finite sum: no NaN or ±inf among the values (they propagate)
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size:
        k = int(bad[0])
        what = "empty or NaN" if np.isnan(v[k]) else f"{v[k]!r}, not a finite number"
        raise UsageError(f"{_where(source, first_row + k, name)}: {what}")


@dataclasses.dataclass(frozen=True, eq=False)
class Recording:
    """Checked recorded data: ``t`` (N,), ``columns`` name → (N,) float arrays (the
    observer's signals, and any other model input or output present), ``h`` the sample
    time (for a discrete model: its ``sample_time``), ``source`` where it came from."""

    t: np.ndarray
    columns: Mapping
    h: float
    source: str | None = None


def _as_float(name: str, v, source: str | None) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        for k, cell in enumerate(list(v)):
            _cell(cell if isinstance(cell, str) else repr(cell), source, k + 1, name)
        raise UsageError(f"{source or 'data'}, column '{name}': not numbers") from None
    if a.ndim != 1:
        raise UsageError(f"{source or 'data'}, column '{name}': a column must be one-"
                         f"dimensional, got shape {a.shape}")
    return a


def recording_from_columns(model: PlantModel, needed, data: Mapping, *,
                           rename: Mapping | None = None, sample_time: float | None = None,
                           source: str | None = None) -> Recording:
    """The :class:`Recording` of ``data`` (a mapping or pandas DataFrame of columns):
    ``t`` and the signals ``needed`` (names), renamed by ``rename`` (signal → column
    name in ``data``); the model's other inputs and outputs are kept when present."""
    rename = dict(rename or {})
    names = list(data.keys()) if hasattr(data, "keys") else list(data)
    others = [str(s) for s in model.inputs] + [f"y{i}" for i in range(1, len(model.outputs) + 1)]
    cols = {}
    for sig in ["t"] + list(needed) + [o for o in others if o not in needed]:
        col = rename.get(sig, sig)
        if col not in names:
            if sig == "t" or sig in needed:
                raise UsageError(f"{source or 'data'}: no column '{col}'"
                                 + (f" (the signal {sig})" if col != sig else "")
                                 + f"; columns: {', '.join(map(str, names)) or '(none)'}")
            continue
        a = _as_float(col, data[col], source)
        check_cells(col, a, source=source)
        cols[sig] = a
    n = cols["t"].size
    for k, a in cols.items():
        if a.size != n:
            raise UsageError(f"{source or 'data'}: column '{rename.get(k, k)}' has {a.size}"
                             f" rows, t has {n}")
    if n == 0:
        raise UsageError(f"{source or 'data'}: no rows")
    h = check_times(cols["t"], time=model.time, sample_time=sample_time, source=source)
    t = cols.pop("t")
    return Recording(t=t, columns=cols, h=h if math.isfinite(h) else 1.0, source=source)


def _cell(text: str, source, row: int, name: str) -> float:
    try:
        return float(text)
    except ValueError:
        what = "empty" if not text.strip() else f"{text.strip()!r} is not a number"
        raise UsageError(f"{_where(source, row, name)}: {what}") from None


def parse_row(cells, header, wanted, *, source, row: int) -> dict:
    """The cells of one CSV row (a list of text) for the columns ``wanted`` (names of
    ``header``) as floats; one line naming the row and column otherwise."""
    if len(cells) != len(header):
        raise UsageError(f"{source or 'data'}, row {row}: {len(cells)} cells, the header has"
                         f" {len(header)} columns")
    return {n: _cell(cells[header.index(n)], source, row, n) for n in wanted}


def _read_with_pandas(p, header) -> dict | None:
    """The columns by pandas' C parser when it is installed and every cell is a number
    (its parse is exact: the same doubles as ``float``); None otherwise."""
    try:
        import pandas as pd
    except ImportError:
        return None
    try:
        df = pd.read_csv(p, dtype=float, skip_blank_lines=True)
    except (ValueError, TypeError, pd.errors.ParserError):
        return None
    if [str(c).strip() for c in df.columns] != header:
        return None
    return {h: df.iloc[:, j].to_numpy(dtype=float) for j, h in enumerate(header)}


def _header_line(p) -> list | None:
    """The cells of the first line of the file ``p`` (stripped), or None when it cannot
    be read or decoded (the full read then says why)."""
    try:
        with open(p, "rb") as fh:
            first = fh.readline()
        first = first.decode("utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    import csv
    return [h.strip() for h in next(csv.reader(first[:1]), [])]


def _read_large(p) -> dict | None:
    """The columns of a large CSV (over :data:`PANDAS_FROM` bytes) by pandas, read
    straight from the file (no text copy in Python), when its header is sound and every
    cell a number; None otherwise (the full read checks it and names what is wrong)."""
    try:
        if p.stat().st_size <= PANDAS_FROM:
            return None
    except OSError:
        return None
    header = _header_line(p)
    if not header or header == [""] or len(set(header)) != len(header):
        return None
    return _read_with_pandas(p, header)


def read_table(path) -> dict:
    """The columns of a recorded table: ``path`` a CSV file (a header row, then one row
    per sample; numbers as text) or Parquet (``.parquet``, ``.pq``; needs pyarrow).
    Returns name → column: float arrays, or for a CSV column with a cell that is not a
    number, its text (the checks name the cell)."""
    import csv
    import io
    from pathlib import Path
    p = Path(path)
    if p.suffix.lower() in PARQUET_SUFFIXES:
        try:
            import pyarrow.parquet as pq
        except ImportError:
            raise UsageError(f"{path}: reading Parquet needs pyarrow, which is not installed:"
                             " python3 -m pip install pyarrow (or give a CSV file)") from None
        try:
            return {str(k): v for k, v in pq.read_table(p).to_pydict().items()}
        except (OSError, ValueError) as exc:
            raise UsageError(f"{path}: cannot read as Parquet: {str(exc).splitlines()[0]}") from None
    fast = _read_large(p)
    if fast is not None:
        return fast
    try:
        text = p.read_text(encoding="utf-8-sig")   # a spreadsheet's byte-order mark dropped
    except FileNotFoundError:
        raise UsageError(f"{path}: no such data file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{path}: cannot read the data:"
                         f" {getattr(exc, 'strerror', None) or type(exc).__name__}") from None
    first, _, body = text.partition("\n")
    header = [h.strip() for h in next(csv.reader([first]), [])]
    if not header or header == [""]:
        raise UsageError(f"{path}: empty (a header row naming the columns is needed)")
    twice = sorted({h for h in header if header.count(h) > 1})
    if twice:
        raise UsageError(f"{path}: the column '{twice[0]}' appears twice in the header")
    try:  # fast path without pandas: every cell a number
        a = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, dtype=float, quotechar='"')
        if a.size == 0:
            a = np.zeros((0, len(header)))
        if a.shape[1] == len(header):
            return {h: a[:, j] for j, h in enumerate(header)}
    except ValueError:
        pass
    rows = [r for r in csv.reader(io.StringIO(body)) if any(c.strip() for c in r)]
    for k, r in enumerate(rows):
        if len(r) != len(header):
            raise UsageError(f"{path}, row {k + 1} (line {k + 2}): {len(r)} cells, the header"
                             f" has {len(header)} columns")
    return {h: [r[j] for r in rows] for j, h in enumerate(header)}
