"""What makes ``CompiledSimulator.simulate(scenario)`` cheap to repeat —
the per-scenario preparation kept with the scenario, a result's memory reused once the
result is gone, the finiteness decided inside the compiled loop — must not change a
result: every value equals a fresh simulator's, a kept result is never overwritten, a
cached input is never changed by editing a result, and a run that the loop cannot prove
finite is still checked exactly."""
from __future__ import annotations

import gc
import shutil
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel
from observer_cad.codegen import CompiledSimulator
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.errors import NonFiniteError
from observer_cad.simulation import scenario_from_dict, simulate
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")

# a delayed observer output (d_hat, one step), random and deterministic signals
UIO_SCEN = {"steps": 300, "seed": 5, "initial": {"x1": 0, "x2": 0, "x3": 0},
            "observer_initial": {"xl1": -1, "xu1": 1},
            "signals": {"u": "0.2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                        "d": "Piecewise((0.3*sin(t/2), t <= 20), (1, True))"}}
# sampled plant parameter, normal and piecewise signals, cases
PAR_SCEN = {"steps": 80, "seed": 9,
            "initial": {"x1": {"uniform": [-0.1, 0.1]}},
            "parameters": {"k5": "declared"},
            "signals": {"u": "2*sin(t/10)", "rho": {"normal": [0, 0.01]},
                        "w1": {"uniform": [0, 0.02]}},
            "cases": {"none": {}, "d step": {"d": "Piecewise((0, t < 40), (0.2, True))"}}}


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def uio(cache):
    m = load_model(ROOT / "models" / "electric_drive.py")
    o = build_observer(m, design(m, observer="unknown-input", faults=["d"]))
    assert o.delays  # the point: a delayed output
    return m, o, CompiledSimulator(m, o, cache=cache)


@pytest.fixture(scope="module")
def uncertain(cache):
    m = load_model(ROOT / "models" / "electric_drive_uncertain.py")
    o = build_observer(m, design(m, observer="diagnostic"))
    return m, o, CompiledSimulator(m, o, cache=cache)


def _copy(res):
    return {k: np.array(v, copy=True) for k, v in res.columns.items()}


def _same(a: dict, b) -> None:
    assert set(a) == set(b.columns)
    for k, v in a.items():
        np.testing.assert_array_equal(b[k], v, err_msg=k)


def _address(res) -> int:
    return res["t"].__array_interface__["data"][0]


def test_repeated_calls_equal_a_fresh_simulator(uio, cache):
    m, o, cs = uio
    sc = scenario_from_dict(UIO_SCEN)
    fresh = CompiledSimulator(m, o, cache=cache).simulate(scenario_from_dict(UIO_SCEN))
    for _ in range(3):  # first call, then the kept preparation and a reused block
        _same(_copy(fresh), cs.simulate(sc))
    # the delayed output is shifted in place: NaN exactly where the reference has it
    ref = simulate(m, o, sc)
    for name, k in o.delays.items():
        assert np.isnan(fresh[name][-k:]).all() and np.isfinite(fresh[name][:-k]).all()
        np.testing.assert_array_equal(np.isnan(fresh[name]), np.isnan(ref[name]))


def test_a_result_still_held_is_never_overwritten(uio):
    m, o, cs = uio
    sc = scenario_from_dict(UIO_SCEN)
    first = cs.simulate(sc)
    kept = _copy(first)
    x1 = first["x1"]
    del first
    gc.collect()
    second = cs.simulate(sc)  # a column of the first result lives: new memory
    assert not np.shares_memory(x1, second["x1"])
    second["x1"][:] = -7.0
    np.testing.assert_array_equal(x1, kept["x1"])
    x1[:] = 3.0  # editing one result does not reach the next one
    third = cs.simulate(sc)
    _same(kept, third)


def test_the_memory_of_a_dropped_result_is_reused_and_rewritten(uio):
    m, o, cs = uio
    sc = scenario_from_dict(UIO_SCEN)
    res = cs.simulate(sc)
    kept = _copy(res)
    address = _address(res)
    for name in res.columns:  # scribble over everything before dropping it
        res[name][...] = np.nan if name == "t" else 1e300
    del res
    gc.collect()
    again = cs.simulate(sc)
    assert _address(again) == address  # reused …
    _same(kept, again)                 # … and every value written again


def test_editing_a_results_parameters_does_not_change_the_next_call(uncertain):
    m, o, cs = uncertain
    sc = scenario_from_dict(PAR_SCEN)
    a = cs.simulate(sc, runs=4, case="d step", threads=2)
    kept, k5 = _copy(a), a.parameters["k5"].copy()
    assert np.ptp(k5) > 0
    a.parameters["k5"][:] = 0.0
    b = cs.simulate(sc, runs=4, case="d step", threads=2)
    np.testing.assert_array_equal(b.parameters["k5"], k5)
    _same(kept, b)
    one = cs.simulate(sc, case="d step", first_run=2)
    assert one.parameters["k5"] == k5[2]
    for name in kept:
        np.testing.assert_array_equal(one[name], kept[name][2], err_msg=name)


def test_threads_and_runs_give_the_same_rows(uncertain):
    m, o, cs = uncertain
    sc = scenario_from_dict(PAR_SCEN)
    whole = cs.simulate(sc, runs=5, threads=3, case="none")
    for r in range(5):
        row = cs.simulate(sc, first_run=r, case="none", threads=1)
        for name in whole.columns:
            np.testing.assert_array_equal(row[name], whole[name][r], err_msg=name)


@pytest.fixture(scope="module")
def huge(cache):
    """Two tanks at rest at ±1e308: every value finite, their sum is not."""
    x1, x2, u = sp.symbols("x1 x2 u")
    m = PlantModel(name="huge_levels", time="continuous", states=[x1, x2], inputs=[u],
                   outputs=[x1, x2], dynamics=[u, u])
    return m, CompiledSimulator(m, None, cache=cache)


def test_a_run_whose_sum_overflows_is_checked_exactly(huge):
    m, cs = huge
    sc = scenario_from_dict({"t_end": 1, "dt": 0.1, "initial": {"x1": 1e308, "x2": 1e308},
                             "signals": {"u": 0}})
    res = cs.simulate(sc)  # the loop cannot prove it finite; the exact check does
    assert res.nonfinite is None
    np.testing.assert_array_equal(res["x1"], np.full(11, 1e308))
    _same(_copy(simulate(m, None, sc)), res)


def test_a_value_that_overflows_is_still_reported(huge):
    m, cs = huge
    sc = scenario_from_dict({"t_end": 2, "dt": 0.1, "initial": {"x1": 1e308, "x2": 0},
                             "signals": {"u": 1e308}})  # x1 = 1e308 (1 + t): inf at t ≈ 0.8
    with pytest.raises(NonFiniteError) as got:
        cs.simulate(sc)
    with pytest.raises(NonFiniteError) as want:
        simulate(m, None, sc)
    assert "x1 became inf" in str(got.value)
    assert str(got.value) == str(want.value)
