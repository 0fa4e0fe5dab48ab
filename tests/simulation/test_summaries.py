"""Per-run summaries (simulation) and the streaming ensemble statistics built on them.

Grouped by what they prove: the fields on hand-made arrays (values worked out by hand);
the reference simulator on the papers' examples (interval observer of the three-tank, the
electric drive's unknown-input estimator, a guaranteed threshold with a decision rule),
checked against numpy computed here independently; the determinism the ensemble rests on
(a row's summary is the same bits in any batch; statistics do not depend on add order);
worst-case ranking; bad input.
"""
from __future__ import annotations

import dataclasses
import json
import pickle
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import observer_cad.simulation._summaries as summaries_module  # block size patched below
from observer_cad import build_observer, design, load_model, simulate
from observer_cad.errors import UsageError
from observer_cad.model import PlantModel
from observer_cad.residuals import DecisionRule, decide, decision_rule, guaranteed_threshold
from observer_cad.observers import Observer
from observer_cad.ensemble import EnsembleStatistics
from observer_cad.simulation import (Monitors, RunSummaries, SummaryField, load_scenario, monitors,
                                     scenario_from_dict, summarise)

ROOT = Path(__file__).resolve().parents[2]
NAN = float("nan")


# ---------------------------------------------------------------- a hand-made plant

def _toy():
    """A discrete plant (states x1, x2, input u, fault f, one output y1 = x1) and an
    observer whose outputs cover every kind of summary: x1_hat (delayed by one sample),
    x2_lower/x2_upper, r with its band r_lower/r_upper, theta_hat (no truth). The equations
    do not matter: the tests hand the columns in."""
    x1, x2, u, f = sp.symbols("x1 x2 u f")
    model = PlantModel(name="toy", time="discrete", states=[x1, x2], inputs=[u], faults=[f],
                       outputs=[x1], dynamics=[x1 / 2 + u, x2 / 2 + f],
                       units={x1: "m", x2: "m"})
    xi, y1 = sp.symbols("xi y1")
    outs = (("x1_hat", xi), ("x2_lower", xi - 1), ("x2_upper", xi + 1), ("r", y1 - xi),
            ("r_lower", sp.Integer(-1)), ("r_upper", sp.Integer(1)), ("theta_hat", xi))
    obs = Observer(name="toy_obs", kind="test", time="discrete", states=(xi,),
                   signals=(y1, u), parameters={}, update=(xi / 2 + u,), outputs=outs,
                   delays={"x1_hat": 1})
    return model, obs


RULE = DecisionRule(residuals=("r",), faults=("f",), structure=((1,),), persistence=2)


def _columns(R=2, N=6):
    """Two runs, t = 0 … 5 (values chosen so that every field can be checked by hand)."""
    z = np.zeros((R, N))
    c = {n: z.copy() for n in ("x1", "x2", "u", "f", "y1", "x1_hat", "x2_lower", "x2_upper",
                                "r", "r_lower", "r_upper", "theta_hat")}
    c["x1"][:] = [[1, 2, 3, 4, 5, 6], [0, 0, 0, 0, 0, 0]]
    c["y1"][:] = c["x1"]
    # errors of x1_hat: run 0: 0, 1, −2, 0, 3 (sample 5 not available: delayed)
    c["x1_hat"][:] = [[1, 3, 1, 4, 8, NAN], [0, 0, 0, 0, 0.5, NAN]]
    c["x2"][:] = [[0, 0, 0, 0, 0, 0], [1, 1, 1, 1, 1, 1]]
    c["x2_lower"][:] = [[-1, -1, 0.5, -1, -2, -1], [0, 0, 0, 0, 0, 0]]
    c["x2_upper"][:] = [[1, 1, 1, 1, 2, -0.25], [2, 2, 2, 2, 2, 3]]
    c["r"][:] = [[0, 2, 2, 2, -3, 0], [0, 1, 0, 0, 0, 0]]   # run 1: 1 is on the band: in
    c["r_lower"][:] = -1.0
    c["r_upper"][:] = 1.0
    return c, np.arange(N, dtype=float)


@pytest.fixture(scope="module")
def toy():
    return _toy()


def test_fields_by_hand(toy):
    model, obs = toy
    mon = monitors(model, obs, rule=RULE)
    assert mon.names == (
        "x1_hat.max_error", "x1_hat.rms_error", "x1_hat.final_error",
        "x2.violations", "x2.min_slack", "x2.max_width", "x2.first_violation",
        "r.max_abs", "r.exceedances", "r.first_exceedance",
        "alarm.first", "alarm.samples", "diagnosis.code", "finite", "nonfinite.first")
    assert any(s.startswith("theta_hat") for s in mon.skipped)
    assert mon.field("x1_hat.max_error").unit == "m"
    assert mon.field("x2.min_slack").worse == "min"
    assert mon.field("x2.violations").kind == "count"
    cols, t = _columns()
    s = summarise(mon, cols, t)
    assert isinstance(s, RunSummaries) and s.runs == 2
    assert s["x1_hat.max_error"].tolist() == [3, 0.5]
    assert s["x1_hat.rms_error"].tolist() == pytest.approx([np.sqrt(14 / 5), np.sqrt(0.25 / 5)])
    assert s["x1_hat.final_error"].tolist() == [3, 0.5]        # sample 4: 5 is not available
    # run 0: x2 = 0 outside [0.5, 1] at t = 2 and [−1, −0.25] at t = 5
    assert s["x2.violations"].tolist() == [2, 0]
    assert s["x2.first_violation"][0] == 2 and np.isnan(s["x2.first_violation"][1])
    assert s["x2.min_slack"].tolist() == [-0.5, 1]
    assert s["x2.max_width"].tolist() == [4, 3]
    assert s["r.max_abs"].tolist() == [3, 1]
    assert s["r.exceedances"].tolist() == [4, 0]
    assert s["r.first_exceedance"][0] == 1 and np.isnan(s["r.first_exceedance"][1])
    # persistence 2: run 0 out at 1, 2, 3, 4 → alarm at 2, 3, 4; back in at 5 → code 0
    assert s["alarm.first"][0] == 2 and np.isnan(s["alarm.first"][1])
    assert s["alarm.samples"].tolist() == [3, 0]
    assert s["diagnosis.code"].tolist() == [0, 0]
    assert s["finite"].tolist() == [1, 1]                      # the delayed NaN tail is skipped
    assert np.isnan(s["nonfinite.first"]).all()
    assert all(v.dtype == np.float64 and v.shape == (2,) for v in s.values.values())


def test_settle_and_tolerance(toy):
    model, obs = toy
    cols, t = _columns()
    s = summarise(monitors(model, obs, settle=3, tolerance=0.3, rule=RULE), cols, t)
    assert s["x1_hat.max_error"].tolist() == [3, 0.5]           # samples 3, 4
    assert s["x1_hat.rms_error"][0] == pytest.approx(np.sqrt(9 / 2))
    # only t = 5 is left for x2, and 0 > −0.25 + 0.3: inside with the tolerance
    assert s["x2.violations"].tolist() == [0, 0]
    assert s["x2.min_slack"][0] == -0.25                        # the slack ignores the tolerance
    assert s["r.exceedances"].tolist() == [2, 0]
    assert s["r.first_exceedance"][0] == 3
    assert s["alarm.first"][0] == 3 and s["alarm.samples"][0] == 2   # counters ran from t = 0
    s2 = summarise(monitors(model, obs, settle=2.5, tolerance=0.2), cols, t)
    assert s2["x2.violations"].tolist() == [1, 0] and s2["x2.first_violation"][0] == 5


def test_a_run_that_is_not_finite_is_worst(toy):
    model, obs = toy
    cols, t = _columns()
    cols["x2"][1, 3] = np.inf
    cols["u"][0, 4] = np.nan
    s = summarise(monitors(model, obs), cols, t)
    assert s["finite"].tolist() == [0, 0]
    assert s["nonfinite.first"].tolist() == [4, 3]
    assert s["x1_hat.max_error"].tolist() == [np.inf, np.inf]
    assert s["x1_hat.rms_error"].tolist() == [np.inf, np.inf]
    assert s["x2.min_slack"].tolist() == [-np.inf, -np.inf]
    assert s["x2.max_width"].tolist() == [np.inf, np.inf]
    assert s["r.max_abs"].tolist() == [np.inf, np.inf]
    assert s["x2.violations"][1] == 1                           # the inf sample shows no inclusion


def test_an_estimate_of_z_from_the_design(models_dir):
    """z = x1 + x2 (text in the design) is parsed and evaluated from the state columns."""
    m = load_model(models_dir / "three_tank_linear.py")
    o = build_observer(m, design(m, observer="virtual-sensor", estimate="x1 + x2"))
    mon = monitors(m, o)
    assert mon.names[:3] == ("z_hat.max_error", "z_hat.rms_error", "z_hat.final_error")
    rng = np.random.default_rng(0)
    cols = {n: rng.normal(size=(3, 7)) for n in ("x1", "x2", "x3", "z_hat")}
    s = summarise(mon, cols, np.arange(7.0))
    err = np.abs(cols["z_hat"] - (cols["x1"] + cols["x2"]))
    assert s["z_hat.max_error"].tolist() == err.max(axis=1).tolist()
    assert s["z_hat.final_error"].tolist() == err[:, -1].tolist()
    again = pickle.loads(pickle.dumps(mon))      # travels to worker processes
    assert isinstance(again, Monitors)
    s2 = summarise(again, cols, np.arange(7.0))
    assert all(np.array_equal(s.values[k], s2.values[k], equal_nan=True) for k in s.values)


# ---------------------------------------------------------------- the papers' examples

@pytest.fixture(scope="module")
def tank(models_dir):
    m = load_model(models_dir / "three_tank.py")
    o = build_observer(m, design(m, observer="interval", estimate="x1"))
    sc = dataclasses.replace(load_scenario(models_dir / "scenarios" / "three_tank_interval.json"),
                             t_end=2.0)     # 200 steps of 0.01
    return m, o, simulate(m, o, sc, runs=20)


def test_three_tank_interval_includes_the_level(tank):
    m, o, res = tank
    mon = monitors(m, o)
    s = summarise(mon, res, res["t"][0])
    assert s.runs == 20
    assert (s["x1.violations"] == 0).all()
    assert (s["x1.min_slack"] > 0).all()
    assert np.isnan(s["x1.first_violation"]).all()
    assert (s["finite"] == 1).all()
    # the same numbers, computed here without the summaries
    x, lo, hi = res["x1"], res["x1_lower"], res["x1_upper"]
    assert s["x1.min_slack"].tolist() == np.minimum(x - lo, hi - x).min(axis=1).tolist()
    assert s["x1.max_width"].tolist() == (hi - lo).max(axis=1).tolist()
    # a too-narrow interval is caught: shift the upper bound below the level
    bad = dict(res.columns, x1_upper=res["x1"] - 1e-3)
    sb = summarise(mon, bad, res["t"][0])
    assert (sb["x1.violations"] == 201).all() and (sb["x1.first_violation"] == 0).all()
    assert sb["x1.min_slack"] == pytest.approx(np.full(20, -1e-3))


def test_electric_drive_unknown_input_estimate(models_dir):
    m = load_model(models_dir / "electric_drive.py")
    o = build_observer(m, design(m, observer="unknown-input", faults=["d"]), g=-0.7)
    res = simulate(m, o, load_scenario(models_dir / "scenarios" / "electric_drive_fig1.json"),
                   runs=3)
    mon = monitors(m, o)
    assert mon.delays == {"d_hat": 1}
    assert mon.field("d_hat.max_error").unit == "A"
    s = summarise(mon, res, res["t"][0])
    assert (s["finite"] == 1).all()                              # the NaN tail is not counted
    assert (s["d_hat.max_error"] < 1e-12).all()                  # seed 000: exact for k = 1
    err = np.abs(res["d_hat"][:, :-1] - res["d"][:, :-1])
    assert s["d_hat.max_error"].tolist() == err.max(axis=1).tolist()
    assert s["d_hat.final_error"].tolist() == err[:, -1].tolist()
    # a wrong estimate is seen: the error of d_hat = 0 is |d|
    s0 = summarise(mon, dict(res.columns, d_hat=np.zeros_like(res["d"])), res["t"][0])
    assert s0["d_hat.max_error"].tolist() == np.abs(res["d"][:, :-1]).max(axis=1).tolist()


@pytest.fixture(scope="module")
def uncertain(models_dir):
    m = load_model(models_dir / "electric_drive_uncertain.py")
    d = design(m, observer="diagnostic")
    return m, guaranteed_threshold(m, build_observer(m, d)), decision_rule(m, d, persistence=2)


def test_guaranteed_threshold_with_a_rule(models_dir, uncertain):
    m, o, rule = uncertain
    sc = load_scenario(models_dir / "scenarios" / "electric_drive_uncertain.json")
    faulty = simulate(m, o, sc, runs=4)
    free = simulate(m, o, dataclasses.replace(sc, signals={**sc.signals, "d": "0"}), runs=4)
    mon = monitors(m, o, rule=rule)
    sf = summarise(mon, free, free["t"][0])
    assert (sf["r.exceedances"] == 0).all()                      # the band holds fault-free
    assert np.isnan(sf["alarm.first"]).all() and (sf["diagnosis.code"] == 0).all()
    s = summarise(mon, faulty, faulty["t"][0])
    dec = decide(rule, faulty)
    assert s["alarm.samples"].tolist() == dec.alarm.sum(axis=1).tolist()
    assert s["diagnosis.code"].tolist() == dec.code[:, -1].tolist() == [1] * 4
    assert ((s["alarm.first"] >= 100) & (s["alarm.first"] <= 110)).all()
    assert (s["r.first_exceedance"] <= s["alarm.first"] - 1).all()   # persistence 2


# ---------------------------------------------------------------- determinism

def _random_columns(rng, R, N):
    names = ("x1", "x2", "u", "f", "y1", "x1_hat", "x2_lower", "x2_upper", "r", "r_lower",
             "r_upper", "theta_hat")
    cols = {k: rng.normal(size=(R, N)) * rng.uniform(0.1, 10) for k in names}
    t = np.arange(N, dtype=float)
    cols["x1_hat"][:, -1] = np.nan
    cols["x2_lower"] -= 2
    cols["x2_upper"] += 2
    cols["r_lower"] = -np.abs(cols["r_lower"]) - 1
    cols["r_upper"] = np.abs(cols["r_upper"]) + 1
    bad = rng.integers(0, R)
    cols["x2"][bad, rng.integers(0, N)] = np.inf
    return cols, t


@settings(max_examples=20, deadline=None)
@given(st.integers(1, 24), st.integers(0, 2 ** 32 - 1), st.data())
def test_a_rows_summary_does_not_depend_on_its_batch(R, seed, data):
    """Columns as strided views of one (R, N, C) array, summarised whole, in random row
    splits, row by row, and as Fortran-ordered arrays, with blocks of 1 … 10⁶ rows: the
    same bits."""
    model, obs = _toy()
    mon = monitors(model, obs, rule=RULE, settle=3.5)
    rng = np.random.default_rng(seed)
    N = int(rng.integers(6, 300))
    cols, t = _random_columns(rng, R, N)
    names = list(cols)
    S = np.stack([cols[n] for n in names], axis=2)              # (R, N, C)
    rows_per_block = data.draw(st.sampled_from([1, 3, 7, 10 ** 6]))
    saved = summaries_module._BLOCK_ELEMENTS
    summaries_module._BLOCK_ELEMENTS = rows_per_block * N       # rows are processed in blocks
    try:
        whole = summarise(mon, {n: S[:, :, j] for j, n in enumerate(names)}, t).matrix()
    finally:
        summaries_module._BLOCK_ELEMENTS = saved
    cuts = sorted(data.draw(st.lists(st.integers(1, max(R - 1, 1)), max_size=5)))
    bounds = [0] + [c for c in cuts if 0 < c < R] + [R]
    parts = [summarise(mon, {n: cols[n][a:b] for n in names}, t).matrix()
             for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
    split = np.concatenate(parts)
    single = np.concatenate([summarise(mon, {n: cols[n][i] for n in names}, t).matrix()
                             for i in range(R)])
    fortran = summarise(mon, {n: np.asfortranarray(cols[n]) for n in names}, t).matrix()
    # the compiled batch's layout (R, C, N): views of contiguous rows, used without a copy
    K = np.ascontiguousarray(np.stack([cols[n] for n in names], axis=1))
    rowviews = summarise(mon, {n: K[:, j, :] for j, n in enumerate(names)}, t).matrix()
    assert whole.view(np.uint64).tolist() == rowviews.view(np.uint64).tolist()
    assert whole.view(np.uint64).tolist() == split.view(np.uint64).tolist()
    assert whole.view(np.uint64).tolist() == single.view(np.uint64).tolist()
    assert whole.view(np.uint64).tolist() == fortran.view(np.uint64).tolist()


def _ensemble(R=60, seed=3):
    model, obs = _toy()
    mon = monitors(model, obs, rule=RULE)
    rng = np.random.default_rng(seed)
    cols, t = _random_columns(rng, R, 40)
    return mon, summarise(mon, cols, t)


def _chunks(s: RunSummaries, bounds):
    for a, b in zip(bounds[:-1], bounds[1:]):
        case = "nominal" if a < 30 else "f"
        yield np.arange(a, b), case, RunSummaries(s.fields, {k: v[a:b] for k, v in s.values.items()})


def test_statistics_do_not_depend_on_add_order():
    mon, s = _ensemble()
    bounds = [0, 7, 20, 30, 31, 45, 60]
    a = EnsembleStatistics(mon)
    for runs, case, part in _chunks(s, bounds):
        a.add(runs, case, part)
    b = EnsembleStatistics(mon.fields)
    chunks = list(_chunks(s, bounds))
    for i in np.random.default_rng(1).permutation(len(chunks)):
        b.add(*chunks[i])
    ja, jb = a.result().dumps(), b.result().dumps()
    assert ja == jb
    assert repr(list(a.rows())) == repr(list(b.rows()))
    assert a.result().to_text() == b.result().to_text()
    assert tuple(a.result().cases) == ("nominal", "f")           # by smallest run index


def test_statistics_by_hand():
    f = (SummaryField("e", "max", "error", "m", "an error"),
         SummaryField("n", "max", "count", None, "a count"),
         SummaryField("first", "min", "time", None, "a time"),
         SummaryField("finite", "min", "flag", None, "finite"))
    acc = EnsembleStatistics(f, quantiles=(0.5, 1.0))
    acc.add([3, 1], "a", {"e": [4.0, 1.0], "n": [0.0, 2.0], "first": [NAN, 1.5],
                          "finite": [1.0, 1.0]})
    acc.add([0, 2], "b", {"e": [np.inf, 2.0], "n": [0.0, 0.0], "first": [NAN, NAN],
                          "finite": [0.0, 1.0]})
    r = acc.result()
    e = r.overall["e"]
    assert (e.count, e.finite, e.undefined) == (4, 3, 0)
    assert e.min == 1 and e.max == np.inf
    assert e.mean == pytest.approx(7 / 3) and e.std == pytest.approx(np.std([4, 1, 2], ddof=1))
    assert e.quantiles == ((0.5, 2.0), (1.0, np.inf))            # observed values
    assert (e.worst_run, e.worst_value) == (0, np.inf)
    n = r.overall["n"]
    assert (n.positive, n.positive_fraction) == (1, 0.25)
    assert r.cases["a"]["n"].positive_fraction == 0.5
    first = r.overall["first"]
    assert (first.undefined, first.min, first.worst_run) == (3, 1.5, 0)   # run 0 is not finite
    assert r.cases["b"]["first"].worst_run == 0
    assert r.cases["a"]["first"].worst_run == 1
    assert r.overall.nonfinite == 1 and r.cases["a"].nonfinite == 0
    assert [row.run for row in acc.rows()] == [0, 1, 2, 3]
    assert [row.case for row in acc.rows()] == ["b", "a", "b", "a"]
    assert list(acc.rows())[1].values == (1.0, 2.0, 1.5, 1.0)
    js = r.to_json()
    text = json.dumps(js, allow_nan=False)                       # JSON-safe
    assert js["overall"]["fields"]["e"]["max"] is None and "null" in js["note"]
    assert "e" in r.to_text() and "case a" in r.to_text()
    assert acc.columns()["case"].tolist() == ["b", "a", "b", "a"]
    assert json.loads(text)["quantiles"] == [0.5, 1.0]


def test_worst_runs():
    f = (SummaryField("slack", "min", "slack", None, "s"),
         SummaryField("err", "max", "error", None, "e"),
         SummaryField("finite", "min", "flag", None, "f"))
    acc = EnsembleStatistics(f)
    acc.add([5, 2, 9, 7], "c1", {"slack": [0.1, -0.5, 0.1, 0.3], "err": [1, 1, 3, NAN],
                                 "finite": [1, 1, 1, 1]})
    acc.add([4, 1], "c2", {"slack": [-np.inf, 0.0], "err": [np.inf, 2], "finite": [0, 1]})
    assert acc.worst("slack") == (4,)
    assert acc.worst("slack", k=4) == (4, 2, 1, 5)               # tie 0.1: lower run first
    assert acc.worst("err", k=6) == (4, 9, 1, 2, 5, 7)           # NaN last
    assert acc.worst("slack", k=2, case="c1") == (2, 5)
    assert acc.worst("err", k=10, case="c2") == (4, 1)
    with pytest.raises(UsageError, match="no case 'c3'"):
        acc.worst("err", case="c3")
    with pytest.raises(UsageError, match="no summary field 'x'"):
        acc.worst("x")


def test_worst_run_of_the_ensemble_is_replayed_by_its_index():
    """worst() names global run indices: the worst chunked run is the worst of the whole."""
    mon, s = _ensemble()
    acc = EnsembleStatistics(mon)
    for runs, case, part in _chunks(s, [0, 13, 30, 60]):
        acc.add(runs, case, part)
    for name in ("x2.min_slack", "x1_hat.max_error"):
        w = acc.worst(name, k=3)
        broken = s["finite"] == 0
        assert broken[w[0]]
        v = s[name]
        order = np.argsort(v if mon.field(name).worse == "min" else -v, kind="stable")
        order = [i for i in order if not broken[i]]
        assert list(w[1:]) == order[:2]


# ---------------------------------------------------------------- bad input

def test_bad_input(toy):
    model, obs = toy
    with pytest.raises(UsageError, match="settle must be a number"):
        monitors(model, obs, settle="1")
    with pytest.raises(UsageError, match="tolerance must be a finite number ≥ 0"):
        monitors(model, obs, tolerance=-1)
    with pytest.raises(UsageError, match="needs the column 'r2'"):
        monitors(model, obs, rule=DecisionRule(("r2",), ("f",), ((1,),)))
    mon = monitors(model, obs)
    cols, t = _columns()
    with pytest.raises(UsageError, match="no column 'x2_upper'"):
        summarise(mon, {k: v for k, v in cols.items() if k != "x2_upper"}, t)
    with pytest.raises(UsageError, match=r"column 'r' has shape \(2, 5\)"):
        summarise(mon, dict(cols, r=cols["r"][:, :5]), t)
    with pytest.raises(UsageError, match="settle = 9 leaves no sample"):
        summarise(monitors(model, obs, settle=9), cols, t)
    acc = EnsembleStatistics(mon)
    part = summarise(mon, cols, t)
    acc.add([0, 1], "nominal", part)
    with pytest.raises(UsageError, match="run 1 was added before"):
        acc.add([1, 2], "nominal", part)
    with pytest.raises(UsageError, match="has shape"):
        acc.add([5, 6, 7], "nominal", part)
    with pytest.raises(UsageError, match="quantile must be in"):
        EnsembleStatistics(mon, quantiles=(1.5,))
    with pytest.raises(UsageError, match="worse must be"):
        SummaryField("a", "up", "error", None, "")
