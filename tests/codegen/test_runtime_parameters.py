"""The compiled trajectory takes the plant's and the observer's
parameters at run time (one library for every sample), generates the scenario's random
signals in C with the reference's generator, and agrees with the reference simulator."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from observer_cad.codegen import STATS, CompiledSimulator
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.simulation import scenario_from_dict, simulate
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="no C compiler")

SCEN = {"steps": 120, "seed": 9,
        "initial": {"x1": {"uniform": [-0.1, 0.1]}, "x3": {"normal": [0, 0.05]}},
        "parameters": {"k5": "declared"},
        "signals": {"u": "2*sin(t/10)", "rho": {"normal": [0, 0.01]},
                    "w1": {"uniform": [0, 0.02]},
                    "w2": {"piecewise": [[{"uniform": [-0.01, 0.01]}, "t < 60"], [0.005, True]]}},
        "cases": {"none": {}, "d step": {"d": "Piecewise((0, t < 50), (0.2, True))"}}}


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    m = load_model(ROOT / "models" / "electric_drive_uncertain.py")
    o = build_observer(m, design(m, observer="diagnostic"))
    return m, o, CompiledSimulator(m, o, cache=tmp_path_factory.mktemp("cache"))


@pytest.mark.parametrize("case", ["none", "d step"])
def test_compiled_matches_reference_with_sampled_parameters_and_signals(drive, case):
    m, o, cs = drive
    sc = scenario_from_dict(SCEN)
    ref = simulate(m, o, sc, runs=5, first_run=2, case=case)
    got = cs.simulate(sc, runs=5, first_run=2, case=case)
    assert got.order == ref.order and set(got.columns) == set(ref.columns)
    np.testing.assert_array_equal(got.parameters["k5"], ref.parameters["k5"])
    assert np.ptp(ref.parameters["k5"]) > 0  # the runs really have different plants
    for name in ("u", "w1", "w2", "d"):  # uniform and deterministic: the same bits
        np.testing.assert_array_equal(got[name], ref[name])
    np.testing.assert_allclose(got["rho"], ref["rho"], rtol=1e-14, atol=1e-16)  # normal
    for c in ref.columns:
        scale = max(1.0, float(np.nanmax(np.abs(ref[c]))))
        np.testing.assert_allclose(got[c], ref[c], rtol=0, atol=1e-12 * scale, err_msg=c)


def test_one_library_for_every_parameter_sample(drive):
    m, o, cs = drive
    n = STATS["compiles"]
    a = cs.simulate(scenario_from_dict({**SCEN, "parameters": {"k5": 0.951}}), case="none")
    b = cs.simulate(scenario_from_dict({**SCEN, "parameters": {"k5": 0.969}}), case="none")
    assert STATS["compiles"] == n
    assert not np.array_equal(a["x3"], b["x3"])
    # the observer's parameters are run-time inputs too (its nominal values by default)
    assert cs.np == len(m.parameters) + len(o.parameters)
    assert list(cs.layout.names[:len(m.parameters)]) == [p.name for p in m.parameters]


def test_batch_runs_are_bit_identical_in_any_batch(drive):
    m, o, cs = drive
    sc = scenario_from_dict(SCEN)
    whole = cs.simulate(sc, runs=7, case="d step", threads=2)
    for first, count in ((0, 1), (3, 2), (6, 1)):
        part = cs.simulate(sc, runs=count, first_run=first, case="d step", threads=1)
        for c in whole.columns:
            np.testing.assert_array_equal(part[c], whole[c][first:first + count], err_msg=c)


def test_run_arrays_takes_parameters(drive):
    m, o, cs = drive
    sc = scenario_from_dict({**SCEN, "parameters": {"k5": 0.955}})
    t, _, N, V, s0 = cs.prepare(sc, case="none")
    d = cs.draws(sc, 1)
    S, Y, O = cs.run_arrays(t, V[0], s0, p=d.P[0])
    res = cs.simulate(sc, case="none")
    np.testing.assert_array_equal(S[:, 2], res["x3"])
    S2, _, _ = cs.run_arrays(t, V[0], s0)  # nominal k5 = 0.96
    assert not np.array_equal(S2[:, 2], S[:, 2])
    with pytest.raises(Exception, match="p must have shape"):
        cs.run_arrays(t, V[0], s0, p=[1.0])
