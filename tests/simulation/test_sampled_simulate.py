"""``simulate(..., sample_time=h)``: the plant on the scenario's grid with its inputs held
over each sample, the outputs sampled every h, the observer stepped once per sample by the
monitor's step; its checks are one line each."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from observer_cad import Monitor, build_observer, design, load_model
from observer_cad.errors import UsageError
from observer_cad.residuals import sampled_threshold
from observer_cad.simulation import ReferenceMonitorEngine, scenario_from_dict, simulate

ROOT = Path(__file__).resolve().parents[2]
NOISE = {"uniform": [-0.01, 0.01]}


@pytest.fixture(scope="module")
def motor():
    m = load_model(ROOT / "models" / "dc_motor_sampled.py")
    o = build_observer(m, design(m, observer="diagnostic", lambdas=[-4]))
    return m, o, sampled_threshold(m, o, sp.Rational(1, 100))


def _scenario(seed=1, t_end=2, dt=0.002, **extra):
    return scenario_from_dict({
        "t_end": t_end, "dt": dt, "seed": seed,
        "initial": {"i": {"uniform": [-0.5, 0.5]}, "w": {"uniform": [-1, 1]},
                    "wl": {"uniform": [-1, 1]}},
        "parameters": {"b": "declared"},
        "signals": {"u": "4*sin(3*t)", "rho": {"uniform": [-0.5, 0.5]}, "w1": NOISE,
                    "w2": NOISE, "w3": NOISE}, **extra})


def test_the_plant_is_sampled_with_its_input_held(motor):
    """Without noise, disturbance and fault the samples are those of the exact ZOH
    discretisation x(k+1) = e^{Ah} x(k) + ∫₀ʰ e^{As} ds B u(k) (RK4 on the grid of dt = h/5
    to 1e-9); an input that moved within the sample would miss it by about h·|u'|."""
    m, o, _ = motor
    sc = scenario_from_dict({"t_end": 1, "dt": 0.002, "initial": {"i": 0.3, "w": -0.5},
                             "signals": {"u": "4*sin(3*t)"}})
    res = simulate(m, o, sc, sample_time=0.01)
    t = np.asarray(res["t"])
    assert t.size == 101 and abs(t[-1] - 1) < 1e-12
    np.testing.assert_array_equal(res["u"], 4 * np.sin(3 * t))
    A = np.array([[-4, -1, 0], [5, -5, 3], [0, 3, -4]], dtype=float)
    B = np.array([2.0, 0, 0])
    M = scipy.linalg.expm(np.block([[A, B[:, None]], [np.zeros((1, 4))]]) * 0.01)
    x = np.array([0.3, -0.5, 0.0])
    X = np.array([res["i"], res["w"], res["wl"]])
    for k in range(t.size - 1):
        x = M[:3, :3] @ x + M[:3, 3] * res["u"][k]
        np.testing.assert_allclose(X[:, k + 1], x, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(res["y1"], res["i"])


def test_the_observer_is_the_monitor_on_the_sampled_data(motor):
    """Every observer column equals the Monitor's on simulate's own t, u, y columns (the same
    step, bit for bit), run 0 of a batch equals the run alone, and an engine passed in is
    the one used."""
    m, _, ot = motor
    res = simulate(m, ot, _scenario(3), sample_time=0.01)
    table = Monitor(m, ot).run({c: res[c] for c in ("t", "u", "y1", "y2", "y3")})
    for c in ("r", "r_lower", "r_upper"):
        np.testing.assert_array_equal(table[c], res[c])
    batch = simulate(m, ot, _scenario(3), sample_time=0.01, runs=3)
    assert batch["r"].shape == (3, 201)
    np.testing.assert_array_equal(batch["r"][0], res["r"])
    assert not np.array_equal(batch["r"][1], res["r"])

    class Counting(ReferenceMonitorEngine):
        calls = 0

        def run(self, x0, V, h):
            Counting.calls += 1
            assert h == 0.01 and V.shape == (201, 4)
            return super().run(x0, V, h)
    again = simulate(m, ot, _scenario(3), sample_time=0.01, engine=Counting(ot))
    assert Counting.calls == 1
    np.testing.assert_array_equal(again["r"], res["r"])


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**32))
def test_no_false_alarm_on_the_true_plant_sampled(motor, seed):
    """The sampled band holds on the deployed algorithm: with x(0) in its box, the friction
    in its range and every signal in its bounds, no sample leaves the band."""
    m, _, ot = motor
    res = simulate(m, ot, _scenario(seed, t_end=3), sample_time=0.01)
    r = np.asarray(res["r"])
    assert not np.any((r < res["r_lower"]) | (r > res["r_upper"]))


def test_the_continuous_band_is_not_the_sampled_one(motor):
    """The joint simulation (the observer seeing y inside the RK4 stages) and the sampled
    one differ: the residual of the deployed algorithm is not the continuous one."""
    m, _, ot = motor
    joint = simulate(m, ot, _scenario(4, dt=0.01))
    sampled = simulate(m, ot, _scenario(4, dt=0.01), sample_time=0.01)
    assert np.max(np.abs(joint["r"] - sampled["r"])) > 1e-6


@pytest.mark.parametrize("h, words", [
    (0.003, "0.003 is not a whole multiple of the scenario's dt = 0.002"),
    (3.0, "longer than 't_end' = 2"),
    (-0.01, "a positive finite number"),
    (float("nan"), "a positive finite number"),
    (0.02, "stepped at h = 0.01; the data's sample time is 0.02"),
    (None, "give sample_time"),
])
def test_bad_sample_times_are_one_line_errors(motor, h, words):
    m, _, ot = motor
    kw = {"sample_time": h} if h is not None else {"engine": ReferenceMonitorEngine(ot)}
    with pytest.raises(UsageError) as err:
        simulate(m, ot, _scenario(), **kw)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_discrete_models_and_observer_parameters_are_refused(motor, models_dir):
    m, o, _ = motor
    sc = _scenario()
    sc = dataclasses.replace(sc, observer_parameters={"b": 2})
    with pytest.raises(UsageError, match="'observer_parameters' does not apply"):
        simulate(m, o, sc, sample_time=0.01)
    dm = load_model(models_dir / "electric_drive_uncertain.py")
    with pytest.raises(UsageError, match="applies to a continuous-time model"):
        simulate(dm, None, scenario_from_dict({"steps": 10}), sample_time=1.0)


def test_without_an_observer_the_plant_alone_is_sampled(motor):
    m, _, _ = motor
    res = simulate(m, None, _scenario(2), sample_time=0.01)
    assert res.order == ("t", "i", "w", "wl", "y1", "y2", "y3", "u", "d", "rho")
    assert np.asarray(res["t"]).size == 201


def test_the_observer_starts_where_the_monitor_starts(motor):
    """The plain observer starts at Φ x(0) = i(0) in the joint simulation; deployed, x(0) is
    not known and it starts as the monitor and the exported C do (plant states at 0), unless
    the scenario's observer_initial says otherwise."""
    m, o, _ = motor
    assert str(dict(o.initial)[o.states[0]]) == "i"
    sc = scenario_from_dict({"t_end": 1, "dt": 0.002, "initial": {"i": 0.3, "w": -0.5},
                             "signals": {"u": "sin(t)"}})
    assert simulate(m, o, sc)["r"][0] == 0
    res = simulate(m, o, sc, sample_time=0.01)
    table = Monitor(m, o).run({c: res[c] for c in ("t", "u", "y1", "y2", "y3")})
    np.testing.assert_array_equal(table["r"], res["r"])
    assert res["r"][0] == pytest.approx(0.3)
    given = dataclasses.replace(sc, observer_initial={str(o.states[0]): 0.7})
    assert simulate(m, o, given, sample_time=0.01)["r"][0] == pytest.approx(0.3 - 0.7)


def test_holds_say_what_the_disturbances_did_between_samples(motor):
    """A load torque pulse of 4 ms inside one 10 ms hold is invisible at the samples; the
    result's holds give each sample's (min, max) over its hold."""
    m, o, _ = motor
    sc = scenario_from_dict({"t_end": 0.1, "dt": 0.002, "signals": {"rho": {"piecewise": [
        [0, "t < 0.043"], [0.8, "t < 0.047"], [0, True]]}}})
    res = simulate(m, o, sc, sample_time=0.01)
    assert not np.any(res["rho"])
    lo, hi = res.holds["rho"]
    assert lo.shape == hi.shape == (11,) and set(res.holds) == {"rho", "w1", "w2", "w3"}
    assert np.flatnonzero(hi).tolist() == [4] and hi[4] == 0.8 and not np.any(lo)
    batch = simulate(m, o, sc, sample_time=0.01, runs=2)
    assert batch.holds["rho"][1].shape == (2, 11)
    assert simulate(m, o, sc).holds == {}


def test_a_nonlinear_plant_runs_sampled_too():
    """x2' = −x1 + x1³/6 − x2 + u + f: the sampled band of the nonlinear plant holds on
    simulate's sampled runs (input switching at every sample, noise at random in its
    bounds), and the monitor on their t, u, y gives the same residual."""
    from observer_cad import PlantModel
    x1, x2, u, f, w1, w2 = sp.symbols("x1 x2 u f w1 w2")
    m = PlantModel(name="pendulum_like", time="continuous", states=[x1, x2], inputs=[u],
                   faults=[f], noise=[w1, w2], outputs=[x1 + w1, x2 + w2],
                   dynamics=[x2, -x1 + x1 ** 3 / 6 - x2 + u + f],
                   bounds={x1: (-1, 1), x2: (-2, 2), u: (-1, 1), f: (-1, 1),
                           w1: (-0.01, 0.01), w2: (-0.01, 0.01)})
    ot = sampled_threshold(m, build_observer(m, design(m, observer="diagnostic")),
                           sp.Rational(1, 100))
    sc = scenario_from_dict({"t_end": 3, "dt": 0.002, "seed": 4, "signals": {
        "u": "0.5*sin(40*t)", "w1": NOISE, "w2": NOISE}})
    res = simulate(m, ot, sc, sample_time=0.01, runs=3)
    r = np.asarray(res["r"])
    assert not np.any((r < res["r_lower"]) | (r > res["r_upper"]))
    assert np.max(np.abs(res["x1"])) < 1
    one = simulate(m, ot, sc, sample_time=0.01)
    table = Monitor(m, ot).run({c: one[c] for c in ("t", "u", "y1", "y2")})
    np.testing.assert_array_equal(table["r"], one["r"])


def test_a_step_that_fails_in_python_floats_is_one_line(motor):
    """The monitor's Python step raises on 1/0 (Python floats do): one NonFiniteError line
    (exit status 4 in the CLI), not a traceback."""
    from observer_cad.errors import NonFiniteError
    m, o, _ = motor
    name, e = o.outputs[0]
    u = next(s for s in o.signals if str(s) == "u")
    bad = dataclasses.replace(o, outputs=((name, e / u),))
    sc = scenario_from_dict({"t_end": 0.1, "dt": 0.01, "signals": {"u": "sin(t)"}})
    with pytest.raises(NonFiniteError, match="float division by zero") as err:
        simulate(m, bad, sc, sample_time=0.01)
    assert "\n" not in str(err.value)
