"""The fast paths of the monitor on recorded data give what the plain definitions give:
the decisions in the compiled loop equal decide() on the same outputs (any persistence),
the diagnosis as a categorical column reads as the texts, the one-pass checks of t and of
finite cells find the same first bad row, and a large CSV read by pandas straight from
the file gives the columns (and the one-line errors) of the small-file route."""
from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from observer_cad import Monitor, build_observer, design, load_model
from observer_cad.errors import UsageError
from observer_cad.residuals import DecisionRule, ThresholdSpec, decide, decision_rule
from observer_cad.simulation import (TIME_RTOL, CategoricalColumn, ReferenceMonitorEngine,
                                     apply_threshold, read_table)
from observer_cad.simulation import _recording as recording

ROOT = Path(__file__).resolve().parents[2]
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")
needs_pandas = pytest.mark.skipif(importlib.util.find_spec("pandas") is None,
                                  reason="pandas missing")


@pytest.fixture(scope="module")
def drive():
    m = load_model(ROOT / "models" / "electric_drive_uncertain.py")
    d = design(m, observer="diagnostic")
    obs = apply_threshold(m, build_observer(m, d), ThresholdSpec.parse("guaranteed"))
    return m, obs, decision_rule(m, d)


@pytest.fixture(scope="module")
def engine(drive):
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler")
    from observer_cad.codegen import CompiledMonitorEngine
    return CompiledMonitorEngine(drive[1])


def _rows(seed: int, n: int) -> dict:
    rng = np.random.default_rng(seed)
    return {"t": np.arange(n, dtype=float), "u": rng.uniform(-2, 2, n),
            "y1": np.cumsum(rng.uniform(-0.02, 0.02, n)), "y2": rng.uniform(-0.2, 0.2, n)}


@needs_cc
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2 ** 16), persistence=st.integers(1, 5), n=st.integers(1, 400))
def test_decisions_in_the_compiled_loop_equal_decide(drive, engine, seed, persistence, n):
    """Whatever the data and the persistence, the codes and alarms the C loop writes are
    decide()'s on the loop's own outputs, and the table equals the reference engine's."""
    m, obs, r0 = drive
    rule = DecisionRule(residuals=r0.residuals, faults=r0.faults, structure=r0.structure,
                        persistence=persistence)
    data = _rows(seed, n)
    fast = Monitor(m, obs, rule=rule, engine=engine).run(data)
    assert isinstance(fast["diagnosis"], CategoricalColumn)
    dec = decide(rule, fast.columns)
    assert fast["alarm"].dtype == np.int64
    assert np.array_equal(fast["alarm"], dec.alarm.astype(np.int64))
    assert np.array_equal(fast["diagnosis"].codes, dec.code)
    assert list(fast["diagnosis"]) == list(dec.diagnosis)
    ref = Monitor(m, obs, rule=rule, engine=ReferenceMonitorEngine(obs)).run(data)
    assert fast.order == ref.order
    for c in ref.order:
        if c == "diagnosis":
            assert np.array_equal(np.asarray(fast[c]), np.asarray(ref[c]))
        else:
            np.testing.assert_allclose(np.asarray(fast[c], float), np.asarray(ref[c], float),
                                       rtol=0, atol=1e-12, err_msg=c)


@needs_cc
def test_run_columns_reads_the_columns_as_the_row_loop_reads_rows(drive, engine):
    m, obs, rule = drive
    data = _rows(5, 300)
    mon = Monitor(m, obs, rule=rule, engine=engine)
    cols = [data[s] for s in mon.signals]
    O1, x1 = engine.run(mon.x0, np.column_stack(cols), 1.0)
    O2, x2, code, alarm = engine.run_columns(mon.x0, cols, 1.0)
    assert np.array_equal(O1, O2) and np.array_equal(x1, x2) and code is None and alarm is None
    _, _, code, alarm = engine.run_columns(mon.x0, [c[:0] for c in cols], 1.0, ([0, 1, 2], 1))
    assert code.shape == alarm.shape == (0,)
    with pytest.raises(Exception, match="one-dimensional columns"):
        engine.run_columns(mon.x0, cols[:-1], 1.0)


def test_categorical_column_reads_as_its_texts():
    col = CategoricalColumn(np.array([0, 2, 1, 2]), ("no fault", "f1", "f2"))
    want = np.array(["no fault", "f2", "f1", "f2"], dtype=object)
    assert np.asarray(col).dtype == object and np.array_equal(np.asarray(col), want)
    assert len(col) == 4 and col.shape == (4,) and col.size == 4 and col.ndim == 1
    assert col[1] == "f2" and col[-1] == "f2" and col[np.int64(2)] == "f1"
    assert list(col) == col.tolist() == list(want)
    assert np.array_equal(col[1:3], want[1:3]) and col[1:3].dtype == object
    assert np.array_equal(col[np.array([True, False, False, True])], want[[0, 3]])
    assert np.array_equal(col == "f2", [False, True, False, True])
    assert np.array_equal(col != "f2", [True, False, True, False])
    assert set(col[:2]) == {"no fault", "f2"}
    assert np.asarray(col, dtype=str).dtype.kind == "U"


def test_monitor_table_writes_the_diagnosis_as_text(drive, tmp_path):
    """The categorical column goes through the CSV writer and to_pandas as text."""
    from observer_cad.reporting import write_signals_csv
    m, obs, rule = drive
    out = Monitor(m, obs, rule=rule).run(_rows(1, 50))
    text = write_signals_csv(out, tmp_path, name="monitor.csv").read_text().splitlines()
    j = text[0].split(",").index("diagnosis")
    assert [ln.split(",")[j] for ln in text[1:]] == list(out["diagnosis"])
    if importlib.util.find_spec("pandas") is not None:
        df = out.to_pandas()
        assert df["diagnosis"].tolist() == list(out["diagnosis"])


def _times_by_definition(t):
    """(h, None) or (None, (the row named, 'increase' | 'regular')) as the docstring
    of check_times defines them (row 1 = t[0])."""
    d = np.diff(t)
    bad = np.flatnonzero(~(d > 0))
    if bad.size:
        return None, (int(bad[0]) + 2, "does not increase")
    bad = np.flatnonzero(np.abs(d - d[0]) > TIME_RTOL * d[0])
    if bad.size:
        return None, (int(bad[0]) + 2, "t must be regular")
    return float(d[0]), None


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 16), n=st.integers(2, 60), spread=st.sampled_from(
    [0.0, 0.5e-3, 0.999e-3, 1.001e-3, 2e-3, 1.5]), h=st.sampled_from([0.01, 1.0, 1e-7]))
def test_time_checks_find_the_first_bad_row(seed, n, spread, h):
    rng = np.random.default_rng(seed)
    d = h * (1 + spread * rng.uniform(-1, 1, n - 1))
    d[0] = h
    t = np.concatenate([[5.0], 5.0 + np.cumsum(d)])
    if seed % 5 == 0:
        t[rng.integers(0, n)] = np.nan
    want, err = _times_by_definition(t)
    if err is None:
        assert recording.check_times(t, time="continuous", sample_time=None,
                                     source="x.csv") == want
    else:
        with pytest.raises(UsageError, match=rf"row {err[0]} \(line {err[0] + 1}\), column 't'"
                                             rf".*{err[1]}"):
            recording.check_times(t, time="continuous", sample_time=None, source="x.csv")


def test_finite_cell_check_names_the_first_bad_row():
    big = np.full(10, 1e308)              # a sum that overflows: every cell still finite
    recording.check_cells("y1", big, source="x.csv")
    for bad, words in ((np.nan, "empty or NaN"), (np.inf, "not a finite number"),
                       (-np.inf, "not a finite number")):
        v = big.copy()
        v[6] = bad
        v[8] = np.nan
        with pytest.raises(UsageError, match=rf"x.csv, row 7 \(line 8\), column 'y1': .*{words}"):
            recording.check_cells("y1", v, source="x.csv")


@needs_pandas
def test_a_large_csv_reads_as_a_small_one(tmp_path, monkeypatch):
    """Above PANDAS_FROM bytes pandas parses the file: the same doubles, and a bad cell
    still gets one line naming its row and column."""
    rng = np.random.default_rng(7)
    n = 500
    cols = {"t": np.arange(n, dtype=float), "u": rng.standard_normal(n) * 1e5,
            "y1": rng.standard_normal(n) * 1e-9, "y2": rng.uniform(-1, 1, n)}
    lines = ["t,u,y1,y2"] + [",".join(repr(float(cols[c][k])) for c in cols) for k in range(n)]
    p = tmp_path / "rec.csv"
    p.write_bytes(("\ufeff" + "\r\n".join(lines) + "\r\n").encode("utf-8"))
    small = read_table(p)
    monkeypatch.setattr(recording, "PANDAS_FROM", 100)
    large = read_table(p)
    assert list(small) == list(large) == list(cols)
    for c in cols:
        assert np.array_equal(small[c], cols[c]) and np.array_equal(large[c], cols[c]), c
    m = load_model(ROOT / "models" / "electric_drive_uncertain.py")
    mon = Monitor(m, build_observer(m, design(m, observer="diagnostic")))
    assert np.array_equal(mon.run(large)["y1"], cols["y1"])
    for cell, words in (("abc", "'abc' is not a number"), ("", "empty"), ("nan", "empty or NaN")):
        bad = list(lines)
        cells = bad[40].split(",")
        cells[1] = cell
        bad[40] = ",".join(cells)
        p.write_text("\n".join(bad) + "\n")
        with pytest.raises(UsageError, match=rf"row 40 \(line 41\), column 'u': {words}"):
            mon.run(read_table(p), source=str(p))


@needs_cc
def test_a_delayed_residual_is_decided_after_its_shift(drive):
    """A residual produced late is shifted after the loop: the decisions are then made on
    the shifted columns (decide), as the reference engine's."""
    import dataclasses
    from observer_cad.codegen import CompiledMonitorEngine
    m, obs, rule = drive
    late = dataclasses.replace(obs, delays={"r": 2, "r_lower": 2, "r_upper": 2})
    data = _rows(11, 200)
    fast = Monitor(m, late, rule=rule, engine=CompiledMonitorEngine(late)).run(data)
    ref = Monitor(m, late, rule=rule, engine=ReferenceMonitorEngine(late)).run(data)
    assert np.isnan(fast["r"][-2:]).all() and 0 < fast["alarm"].sum() < 198
    assert np.array_equal(fast["alarm"], ref["alarm"])
    assert list(fast["diagnosis"]) == list(ref["diagnosis"])
    assert np.array_equal(fast["alarm"], decide(rule, fast.columns).alarm.astype(np.int64))
