"""The monitor on recorded data (observer_cad.simulation.Monitor): the same numbers as the
simulation on the simulation's own inputs and outputs, the compiled engine equal to the
reference, row by row equal to a whole table, and bad data refused in one line naming
the row and the column."""
from __future__ import annotations

import dataclasses
import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest

from observer_cad import Monitor, build_observer, design, load_model, load_scenario, simulate
from observer_cad.errors import UsageError
from observer_cad.residuals import ThresholdSpec, decide, decision_rule
from observer_cad.simulation import (TIME_RTOL, ReferenceMonitorEngine, apply_threshold,
                                     declared_envelope, read_table)

ROOT = Path(__file__).resolve().parents[2]
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")


@pytest.fixture(scope="module")
def drive():
    m = load_model(ROOT / "models" / "electric_drive_uncertain.py")
    d = design(m, observer="diagnostic")
    obs = apply_threshold(m, build_observer(m, d), ThresholdSpec.parse("guaranteed"))
    res = simulate(m, obs, load_scenario(ROOT / "models" / "scenarios"
                                         / "electric_drive_uncertain.json"))
    return m, obs, decision_rule(m, d), res


@pytest.fixture(scope="module")
def tanks():
    m = load_model(ROOT / "models" / "three_tank_isolation.py")
    from observer_cad import design_bank
    bank = design_bank(m)
    obs = apply_threshold(m, build_observer(m, bank), ThresholdSpec.parse("guaranteed"))
    data = read_table(ROOT / "examples" / "three_tank_recording.csv")
    return m, obs, decision_rule(m, bank), data


def _data(res):
    return {k: np.asarray(res[k]) for k in ("t", "u", "y1", "y2")}


def test_discrete_monitor_reproduces_the_simulation(drive):
    m, obs, rule, res = drive
    out = Monitor(m, obs, rule=rule).run(_data(res))
    assert out.order == ("t", "y1", "y2", "u", "r", "r_lower", "r_upper", "alarm", "diagnosis",
                         "in_bounds")
    for c in ("r", "r_lower", "r_upper"):
        np.testing.assert_allclose(out[c], res[c], rtol=0, atol=1e-12)
    dec = decide(rule, res.columns)
    assert np.array_equal(out["alarm"], dec.alarm.astype(int))
    assert list(out["diagnosis"]) == list(dec.diagnosis)
    assert out["alarm"][:100].sum() == 0 and out["diagnosis"][-1] == "d"


@needs_cc
def test_compiled_engine_equals_the_reference(drive, tanks):
    from observer_cad.codegen import CompiledMonitorEngine
    for m, obs, rule, data in (drive[:3] + (_data(drive[3]),), tanks):
        a = Monitor(m, obs, rule=rule).run(data)
        b = Monitor(m, obs, rule=rule, engine=CompiledMonitorEngine(obs)).run(data)
        for c in a.order:
            if c != "diagnosis":
                np.testing.assert_allclose(np.asarray(b[c], float), np.asarray(a[c], float),
                                           rtol=0, atol=1e-12, err_msg=c)
        assert list(a["diagnosis"]) == list(b["diagnosis"])


def test_step_by_step_equals_the_table(tanks):
    m, obs, rule, data = tanks
    whole = Monitor(m, obs, rule=rule, engine=ReferenceMonitorEngine(obs)).run(data)
    mon = Monitor(m, obs, rule=rule)
    changes = []
    for k in range(len(data["t"])):
        s = mon.step(data["t"][k], {"u1": data["u1"][k], "u2": data["u2"][k]},
                     [data["y1"][k], data["y2"][k], data["y3"][k]])
        assert s.alarm == bool(whole["alarm"][k]) and s.diagnosis == whole["diagnosis"][k]
        if s.changed:
            changes.append((s.t, s.diagnosis))
    rows = mon.result()
    for c in whole.order:
        assert np.array_equal(np.asarray(rows[c]), np.asarray(whole[c])), c
    assert changes[0] == (0.0, "no fault") and changes[-1][1] == "f2"
    assert all(t >= 20 for t, _ in changes[1:])   # the fault starts at t = 20


def test_recorded_continuous_plant_no_false_alarm_then_f2(tanks):
    m, obs, rule, data = tanks
    out = Monitor(m, obs, rule=rule).run(data)
    t, alarm = out["t"], out["alarm"]
    assert alarm[t < 20].sum() == 0
    assert alarm[t >= 21].all() and out["diagnosis"][-1] == "f2"


@pytest.mark.skipif(importlib.util.find_spec("pandas") is None, reason="pandas missing")
def test_run_takes_a_dataframe_and_renamed_columns(drive):
    import pandas as pd
    m, obs, rule, res = drive
    df = pd.DataFrame(_data(res)).rename(columns={"y1": "angle", "t": "time"})
    out = Monitor(m, obs, rule=rule).run(df, rename={"y1": "angle", "t": "time"})
    np.testing.assert_allclose(out["r"], res["r"], atol=1e-12)
    assert list(out.to_pandas().columns) == list(out.order[1:])  # indexed by t


@pytest.mark.parametrize("edit, words", [
    (lambda d: d.pop("y2"), ["no column 'y2'"]),
    (lambda d: d.__setitem__("y1", ["0.1"] * 5 + ["abc"] + ["0.1"] * 194), ["row 6", "'y1'", "abc"]),
    (lambda d: d["y1"].__setitem__(7, np.nan), ["row 8", "'y1'", "NaN"]),
    (lambda d: d["u"].__setitem__(3, np.inf), ["row 4", "'u'", "inf"]),
    (lambda d: d["t"].__setitem__(10, 8.0), ["row 11", "'t'", "does not increase"]),
    (lambda d: d["t"].__setitem__(slice(50, None), d["t"][50:] + 0.5), ["row 51", "'t'", "regular"]),
    (lambda d: d.__setitem__("t", d["t"] * 0.02), ["row 2", "'t'", "--sample-time 0.02"]),
])
def test_bad_data_one_line_naming_row_and_column(drive, edit, words):
    m, obs, rule, res = drive
    data = {k: np.array(v, dtype=float) for k, v in _data(res).items()}
    edit(data)
    with pytest.raises(UsageError) as e:
        Monitor(m, obs, rule=rule).run(data)
    msg = str(e.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, msg


def test_sample_time_of_a_discrete_model(drive):
    m, obs, rule, res = drive
    data = _data(res)
    data["t"] = data["t"] * 0.02 + 3.0
    out = Monitor(m, obs, rule=rule, sample_time=0.02).run(data)
    np.testing.assert_allclose(out["r"], res["r"], atol=1e-12)
    jitter = dict(data, t=data["t"].copy())
    jitter["t"][5] += 3 * TIME_RTOL * 0.02   # an interval beyond the stated tolerance
    with pytest.raises(UsageError, match="not regular|regular"):
        Monitor(m, obs, rule=rule, sample_time=0.02).run(jitter)


def test_the_envelope_of_the_outputs_comes_from_the_state_bounds():
    """dc_motor_sampled bounds its states and noise: each output's range is its interval
    (y1 = x1 + w1 with x1 in [-4, 4], w1 in [-0.01, 0.01]), and a recorded output beyond it
    is flagged."""
    m = load_model(Path(__file__).resolve().parents[2] / "models" / "dc_motor_sampled.py")
    env = declared_envelope(m)
    assert {"y1", "y2", "y3", "u"} <= set(env)
    y1 = m.outputs[0]
    lo = sum(float(y1.coeff(s)) * float(m.bounds[s][0 if y1.coeff(s) > 0 else 1])
             for s in y1.free_symbols)
    assert env["y1"][0] == pytest.approx(lo)


def test_data_out_of_the_declared_envelope_are_flagged(drive):
    m, obs, rule, res = drive
    m2 = dataclasses.replace(m, bounds={**m.bounds, m.inputs[0]: (-1.5, 1.5)})
    assert declared_envelope(m2) == {"u": (-1.5, 1.5)}
    out = Monitor(m2, obs, rule=rule).run(_data(res))
    inside = np.abs(np.asarray(res["u"])) <= 1.5
    assert np.array_equal(out["in_bounds"], inside.astype(int)) and not inside.all()
    mon = Monitor(m2, obs, rule=rule)
    flags = [mon.step(t, [u], [a, b]).in_bounds for t, u, a, b in
             zip(res["t"], res["u"], res["y1"], res["y2"])]
    assert flags == list(inside)


def test_step_refuses_wrong_rows(drive):
    m, obs, rule, _ = drive
    mon = Monitor(m, obs, rule=rule)
    with pytest.raises(UsageError, match="u needs 1"):
        mon.step(0, [1.0, 2.0], [0.0, 0.0])
    mon.step(0, [1.0], [0.0, 0.0])
    with pytest.raises(UsageError, match="does not increase"):
        mon.step(0, [1.0], [0.0, 0.0])
    with pytest.raises(UsageError, match="not a finite number"):
        mon.step(1, [float("nan")], [0.0, 0.0])


def test_parquet_is_read_through_pyarrow(tmp_path, monkeypatch):
    """A .parquet file goes to pyarrow.parquet.read_table (a stand-in module here)."""
    import sys
    import types

    class Table:
        def to_pydict(self):
            return {"t": [0.0, 1.0], "u": [1.0, 2.0]}
    pq = types.ModuleType("pyarrow.parquet")
    pq.read_table = lambda path: Table()
    pa = types.ModuleType("pyarrow")
    pa.parquet = pq
    monkeypatch.setitem(sys.modules, "pyarrow", pa)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", pq)
    path = tmp_path / "rec.parquet"
    path.write_bytes(b"PAR1")
    assert read_table(path) == {"t": [0.0, 1.0], "u": [1.0, 2.0]}


from hypothesis import given, settings, strategies as st  # noqa: E402


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2 ** 16), persistence=st.integers(1, 4), n=st.integers(1, 60))
def test_rows_one_at_a_time_equal_the_table(drive, seed, persistence, n):
    """Whatever the data and the persistence, step() row by row gives run()'s alarms,
    diagnoses and numbers (the counters carried from row to row as decide() counts)."""
    m, obs, _, _ = drive
    from observer_cad.residuals import DecisionRule
    rule0 = drive[2]
    rule = DecisionRule(residuals=rule0.residuals, faults=rule0.faults,
                        structure=rule0.structure, persistence=persistence)
    rng = np.random.default_rng(seed)
    data = {"t": np.arange(n, dtype=float), "u": rng.uniform(-2, 2, n),
            "y1": rng.uniform(-0.05, 0.05, n), "y2": rng.uniform(-0.1, 0.1, n)}
    whole = Monitor(m, obs, rule=rule).run(data)
    mon = Monitor(m, obs, rule=rule)
    for k in range(n):
        s = mon.step(data["t"][k], [data["u"][k]], [data["y1"][k], data["y2"][k]])
        assert s.alarm == bool(whole["alarm"][k]) and s.diagnosis == whole["diagnosis"][k]
        assert s.outputs["r"] == whole["r"][k]


def test_read_table_text_cells_and_byte_order_mark(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("\ufefft,u\n0,1\n1,x\n", encoding="utf-8")
    cols = read_table(p)
    assert list(cols) == ["t", "u"] and list(cols["u"]) == ["1", "x"]
    p.write_text("t,u\n0,1\n1,2,3\n")
    with pytest.raises(UsageError, match=r"row 2 \(line 3\): 3 cells, the header has 2"):
        read_table(p)
    p.write_text("t,t\n0,1\n")
    with pytest.raises(UsageError, match="appears twice"):
        read_table(p)
