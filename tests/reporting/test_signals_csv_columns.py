"""signals.csv / monitor.csv written a column at a time are the text the row-by-row
writer gives (csv.writer over the cell texts: nan, inf, -inf, else the float's repr;
str(int); the texts): every float kind (nan,
±inf, −0, subnormal, 17 digits), integer and 0/1 columns, texts the csv module must
quote, a categorical diagnosis, delayed columns with their empty cells."""
from __future__ import annotations

import csv
import io

import numpy as np
from hypothesis import given, settings, strategies as st

from observer_cad.reporting import write_signals_csv
from observer_cad.simulation import CategoricalColumn, SimulationResult

TEXTS = ("no fault", "f1 or f2", "f1, f2", 'say "x"', "", " lead", "a\nb", "ü")


def _cell(v: float) -> str:
    if np.isnan(v):
        return "nan"
    if np.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(float(v))


def _reference(cols: dict, order, delays) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(order)
    n = len(cols["t"])
    for i in range(n):
        row = []
        for c in order:
            v = np.asarray(cols[c])
            if i >= n - delays.get(c, 0):
                row.append("")
            elif v.dtype.kind == "O":
                row.append(str(v[i]))
            elif c in ("alarm", "in_bounds"):
                row.append(str(int(v[i])))
            else:
                row.append(_cell(float(v[i])))
        w.writerow(row)
    return buf.getvalue()


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2 ** 16), n=st.integers(1, 80), delay=st.integers(0, 90))
def test_column_writer_equals_the_row_writer(tmp_path_factory, seed, n, delay):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-320, 300, n)
    for k, special in zip(rng.integers(0, n, 4), (np.nan, np.inf, -np.inf, -0.0)):
        x[k] = special
    cols = {"t": np.arange(n) * 0.1, "x": x, "z": rng.standard_normal(n).astype(np.float32),
            "alarm": rng.integers(0, 2, n), "in_bounds": rng.integers(0, 2, n).astype(bool),
            "diagnosis": CategoricalColumn(rng.integers(0, len(TEXTS), n), TEXTS)}
    order = tuple(cols)
    delays = {"x": delay, "diagnosis": delay // 2}
    res = SimulationResult(cols, order, delays)
    out = tmp_path_factory.mktemp("csv")
    got = write_signals_csv(res, out, name="monitor.csv").read_bytes().decode("utf-8")
    assert got == _reference(cols, order, delays)
    rows = list(csv.reader(io.StringIO(got, newline="")))
    assert len(rows) == n + 1
    keep = max(n - delays["diagnosis"], 0)
    assert [r[order.index("diagnosis")] for r in rows[1:keep + 1]] == list(cols["diagnosis"])[:keep]


def test_a_single_column_is_written_as_before(tmp_path):
    res = SimulationResult({"t": np.array([0.0, 0.5, np.nan])}, ("t",))
    got = write_signals_csv(res, tmp_path).read_text()
    assert got == "t\n0.0\n0.5\nnan\n"
