"""Sampled-data guaranteed thresholds (METHOD §3, residual evaluation): the band of the
discrete algorithm that runs deployed (observer_step at the sample time h, y and u held over
each step) on the true continuous plant.

Checked independently of the code that builds the band: on data of the true continuous plant
integrated by scipy's solve_ivp (examples/dc_motor_data.py), the worst-case sums against
brute force over every bang-bang input sequence, the step matrix against observer_step itself,
and the known worst case of three_tank_faults (0.040: one noise symbol used with opposite signs).
"""
import dataclasses
import importlib.util
import itertools
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from observer_cad import build_observer, design, load_model, simulate
from observer_cad.analysis import design_bank
from observer_cad.codegen import observer_step, split_signals
from observer_cad.errors import UsageError
from observer_cad.residuals import (min_detectable_fault, sampled_threshold, transient_envelope,
                                    worst_case_sums)
from observer_cad.simulation import scenario_from_dict

ROOT = Path(__file__).resolve().parents[2]
H = sp.Rational(1, 100)


def _data_module():
    spec = importlib.util.spec_from_file_location("dc_motor_data", ROOT / "examples" / "dc_motor_data.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def motor(models_dir):
    m = load_model(models_dir / "dc_motor_sampled.py")
    o = build_observer(m, design(m, observer="diagnostic", lambdas=[-4]))
    return m, o, sampled_threshold(m, o, H)


def _steady(ot, name):
    """The constant part of a band output (its transient term, a decaying state, at 0)."""
    e = dict(ot.outputs)[name]
    return float(e.xreplace({s: 0 for s in ot.states if str(s).endswith("_decay")}))


def _run(ot, rec, h=0.01, discretisation="rk4"):
    """The discrete algorithm (observer_step, mapped over the records): r, r_lower, r_upper
    as (samples × records) arrays."""
    f = observer_step(ot, h=h, discretisation=discretisation)
    ys, us = split_signals(ot)
    n = rec["u"].shape[0]
    F = f.map(n)
    X = np.array([[float(ot.initial[s]) for s in ot.states]] * n).T
    yidx = [int(str(s)[1:]) - 1 for s in ys]
    names = [nm for nm, _ in ot.outputs]
    outs = []
    for k in range(len(rec["t"])):
        U = rec["u"][:, k][None, :] if us else np.zeros((0, n))
        Xn, O = F(X, rec["y"][:, k, yidx].T, U, np.zeros((0, n)))
        outs.append(np.array(O))
        X = np.array(Xn)
    O = np.stack(outs)
    return (O[:, names.index("r")], O[:, names.index("r_lower")], O[:, names.index("r_upper")])


def test_the_band_is_for_the_algorithm_that_runs(motor):
    """The sampled error system z = [x; e]: its plant block is e^{A0 h} and its error block is
    what observer_step computes (RK4, y and u held); the conditions list the sample time, the
    envelope and the initial box."""
    import scipy.linalg
    m, o, ot = motor
    F = np.array(ot.threshold.error_system.A, dtype=float)
    assert F.shape == (4, 4)
    A0 = np.array([[-4, -1, 0], [5, -5, 3], [0, 3, -4]], dtype=float)
    assert F[:3, :3] == pytest.approx(scipy.linalg.expm(A0 * 0.01), rel=1e-13)
    assert np.all(F[:3, 3:] == 0)
    f = observer_step(o, h=0.01)
    xi = np.array([0.3])
    nxt = np.array(f(xi, np.zeros(3), np.zeros(1), np.zeros(0))[0]).ravel()
    assert nxt == pytest.approx(F[3:, 3:] @ xi, rel=1e-15)
    assert ot.threshold.sample_time == 0.01 and ot.threshold.discretisation == "rk4"
    conds = {c.name: c.detail for c in ot.threshold.conditions}
    assert "h = 1/100 by RK4" in conds["sample time"]
    assert "u ∈ [-5, 5]" in conds["operating envelope"] and "i ∈ [-4, 4]" in conds["operating envelope"]
    assert "initial box" in conds["initial state"] and "b ∈ [19/10, 21/10]" in conds["declared bounds"]
    assert all(c.holds for c in ot.threshold.conditions)
    assert ot.initial[ot.states[0]] == 0  # started at Φ c, c the box centre
    assert "sampled algorithm at h = 0.01" in ot.threshold.text()


@pytest.mark.slow
def test_no_false_alarm_on_1000_records_of_the_continuous_plant(motor):
    """1,000 fault-free records (5 s each) of the true continuous plant (solve_ivp, ZOH input,
    smooth load torque, friction and x(0) drawn from their boxes): no sample leaves the band;
    the records stay in the envelope; the residual uses a fair part of the band."""
    m, o, ot = motor
    rec = _data_module().records(1000, 5.0, seed=11)
    assert np.all(np.abs(rec["x"]).max(axis=(0, 1)) <= [4, 5, 5])
    r, lo, up = _run(ot, rec)
    assert int(np.sum((r < lo) | (r > up))) == 0
    assert np.max(np.abs(r)) > 0.1  # the initial error is felt
    assert np.max(np.abs(r[200:])) > 0.1 * up[-1, 0]


def test_no_false_alarm_with_the_exact_hold(motor):
    """The same on 100 records with the observer stepped by the exact zero-order hold."""
    m, o, _ = motor
    ot = sampled_threshold(m, o, H, discretisation="zoh")
    rec = _data_module().records(100, 5.0, seed=12)
    r, lo, up = _run(ot, rec, discretisation="zoh")
    assert int(np.sum((r < lo) | (r > up))) == 0
    assert np.max(np.abs(r[200:])) > 0.1 * up[-1, 0]


@pytest.mark.slow
def test_no_false_alarm_with_bang_bang_signals_between_samples(motor):
    """Adversarial records: the input switching between random levels at every sample, the
    load torque a ±0.5 square wave of 37 Hz (it switches inside the sample intervals, which
    the band's intersample remainder covers): still no sample leaves the band."""
    m, o, ot = motor
    n = 20

    def square(tt):
        return np.full(n, 0.5 * np.sign(np.sin(2 * np.pi * (37 * tt + 0.3)) + 1e-12))
    rec = _data_module().records(n, 1.0, seed=6, hold=0.01, rho=square)
    assert np.all(np.abs(rec["x"]).max(axis=(0, 1)) <= [4, 5, 5])
    r, lo, up = _run(ot, rec)
    assert int(np.sum((r < lo) | (r > up))) == 0


def test_step_faults_above_the_guaranteed_size_are_detected(motor):
    """Step faults 1.3× the guaranteed detectable size (either sign) from t = 1 s: every
    record raises an alarm after the fault and none before."""
    m, o, ot = motor
    width = _steady(ot, "r_upper") - _steady(ot, "r_lower")
    dmin = min_detectable_fault(ot.threshold, [width])["d"]
    assert 0.1 < dmin < 0.5
    n = 60
    sizes = 1.3 * dmin * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    rec = _data_module().records(n, 4.0, seed=3, fault=sizes, fault_time=1.0)
    r, lo, up = _run(ot, rec)
    alarm = (r < lo) | (r > up)
    assert not alarm[:100].any()
    assert alarm[100:].any(axis=0).all()


def test_worst_case_sums_equal_brute_force():
    """The L1 sums against every bang-bang sequence of 7 steps (the tail beyond is below
    1e-4): upper ≥ the best sequence, and within the tail of it; a symbol used twice with
    opposite signs cancels."""
    rng = np.random.default_rng(0)
    F = np.array([[0.1, 0.15], [-0.1, 0.12]])
    N = np.array([[1.0, -0.7]])
    B = rng.normal(size=(2, 2))
    Cd = np.array([[0.5, -0.3]])
    lo, hi = np.array([-1.0, -0.2]), np.array([1.0, 0.6])
    wc = worst_case_sums(F, N, B, Cd, lo, hi)
    best, worst = -np.inf, np.inf
    K = 7
    for seq in itertools.product((0, 1), repeat=2 * K):
        psi = np.where(np.array(seq).reshape(K, 2) == 0, lo, hi)
        e = np.zeros(2)
        for k in range(K - 1):
            e = F @ e + B @ psi[k]
        r = float((N @ e + Cd @ psi[K - 1])[0])
        best, worst = max(best, r), min(worst, r)
    assert best <= wc.upper[0] <= best + 1e-4
    assert worst >= wc.lower[0] >= worst - 1e-4
    # one symbol into e and r with opposite signs: r = w − e, e⁺ = 0.5 e + w
    same = worst_case_sums(np.array([[0.5]]), np.array([[-1.0]]), np.array([[1.0]]),
                           np.array([[1.0]]), [-1.0], [1.0])
    assert same.upper[0] == pytest.approx(1 + 1 / (1 - 0.5), rel=1e-9)  # |1| + Σ 0.5^j
    split = worst_case_sums(np.array([[0.5]]), np.array([[-1.0]]), np.array([[1.0, 0.0]]),
                            np.array([[0.0, 1.0]]), [-1.0, -1.0], [1.0, 1.0])
    assert split.upper[0] == pytest.approx(same.upper[0], rel=1e-9)


def test_transient_envelope_bounds_every_step():
    F = np.array([[0.9, 0.5], [0.0, 0.8]])
    N = np.array([[1.0, 1.0]])
    V0 = np.diag([0.5, 1.0])
    q = 0.95
    K = transient_envelope(F, N, V0, q)
    V = V0.copy()
    for k in range(400):
        assert np.sum(np.abs(N @ V)) <= K[0] * q ** k * (1 + 1e-12)
        V = F @ V


@pytest.mark.slow
def test_correlated_noise_is_bounded_exactly(models_dir):
    """three_tank_faults, bank residual r1 = y1 − ξ1 (+ terms): the same w1 drives e1, e2 and r
    with opposite signs; the exact worst case is 0.040 (the interval band of the
    continuous-time threshold: 0.060). The sampled band tends to 0.040 as h → 0."""
    m = load_model(models_dir / "three_tank_faults.py")
    o = build_observer(m, design_bank(m))
    x1, x2, x3 = m.states
    u1, u2 = m.inputs
    env = dataclasses.replace(m, bounds={**m.bounds, x1: (0, 2), x2: (0, 2), x3: (0, 2),
                                         u1: (0, 1), u2: (0, 1)})
    ot = sampled_threshold(env, o, sp.Rational(1, 500), discretisation="zoh")
    up, lo = _steady(ot, "r1_upper"), _steady(ot, "r1_lower")
    assert 0.040 < up < 0.044 and -0.044 < lo < -0.040


def test_discrete_plant_simulated(models_dir):
    """A discrete-time plant (electric_drive_uncertain with an envelope): no hold terms; 100
    simulated runs with the friction-like k5 and the noise drawn in their boxes stay in the
    band, and the band is not vacuous."""
    m = load_model(models_dir / "electric_drive_uncertain.py")
    x1, x2, x3 = m.states
    u = m.inputs[0]
    m = dataclasses.replace(m, bounds={**m.bounds, x1: (-10, 10), x2: (-1, 1), x3: (-3, 3),
                                       u: (-2, 2)})
    o = build_observer(m, design(m, observer="diagnostic"))
    ot = sampled_threshold(m, o)
    assert ot.threshold.discretisation == "discrete"
    sc = scenario_from_dict({"steps": 600, "seed": 2,
                             "parameters": {"k5": {"uniform": [0.9504, 0.9696]}},
                             "signals": {"u": "2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                                         "w1": {"uniform": [0, 0.02]},
                                         "w2": {"uniform": [-0.01, 0.01]}}})
    res = simulate(m, ot, sc, runs=100)
    assert np.max(np.abs(res["x3"])) <= 3 and np.max(np.abs(res["x2"])) <= 1
    assert np.max(np.abs(res["x1"])) <= 10
    assert int(np.sum((res["r"] < res["r_lower"]) | (res["r"] > res["r_upper"]))) == 0
    assert np.max(np.abs(res["r"])) > 0.1 * float(np.max(res["r_upper"]))


def test_refusals_are_one_line(models_dir, motor):
    m, o, _ = motor
    no_env = dataclasses.replace(m, bounds={s: b for s, b in m.bounds.items() if s not in m.states})
    with pytest.raises(UsageError, match=r"operating envelope: declare bounds=\{i: \(low, high\)\}"):
        sampled_threshold(no_env, o, H)
    with pytest.raises(UsageError, match="needs the sample time h"):
        sampled_threshold(m, o)
    with pytest.raises(UsageError, match="discretisation must be one of"):
        sampled_threshold(m, o, H, discretisation="euler")
    with pytest.raises(UsageError, match="sample time h must be positive"):
        sampled_threshold(m, o, -1)
    wl = m.states[2]
    cubic = dataclasses.replace(m, dynamics=list(m.dynamics[:2]) + [m.dynamics[2] - wl ** 3 / 100])
    # a cubic term the residual generator does not see (Φ has no wl column): the identity
    # Φ f0 = A Φ x + p still holds exactly, and the band is the nonlinear plant's
    ot = sampled_threshold(cubic, o, H)
    conds = {c.name: c.detail for c in ot.threshold.conditions}
    assert "nominal nonlinear plant" in conds["fault-free residual identity"]
    # a cubic term in the current's equation, which it does see (x*(0) = i): the observer
    # does not reproduce the plant, refused in one line
    i = m.states[0]
    assert o.initial[o.states[0]] == i
    seen = dataclasses.replace(m, dynamics=[m.dynamics[0] - i ** 3 / 100] + list(m.dynamics[1:]))
    with pytest.raises(UsageError, match="does not reproduce the nominal plant") as err:
        sampled_threshold(seen, o, H)
    assert "\n" not in str(err.value)


def test_without_an_initial_box_the_band_rests_on_a_known_state(motor):
    m, o, _ = motor
    known = dataclasses.replace(m, initial={})
    ot = sampled_threshold(known, o, H, discretisation="zoh")
    conds = {c.name: c.detail for c in ot.threshold.conditions}
    assert conds["initial state"].startswith("x(0) known")
    assert ot.initial[ot.states[0]] == o.initial[o.states[0]]


def test_large_input_tiny_bounds_no_false_alarm(models_dir):
    """Tiny declared bounds and an input 1e8·sin(t/10): the roundoff allowance scales with the
    signals, so neither the adaptive nor the sampled band raises a false alarm (a fixed 1e-9
    margin raised one at about half the samples), and neither is wider than 1e-3."""
    from observer_cad.residuals import guaranteed_threshold
    m = load_model(models_dir / "electric_drive.py")
    tiny = {s: (sp.Rational(-1, 10 ** 12), sp.Rational(1, 10 ** 12))
            for s in tuple(m.disturbances) + tuple(m.noise)}
    m = dataclasses.replace(m, bounds={**m.bounds, **tiny})
    o = build_observer(m, design(m, observer="diagnostic"))
    sc = scenario_from_dict({"steps": 300, "signals": {"u": "100000000*sin(t/10)"}})
    base = simulate(m, o, sc)
    assert np.max(np.abs(base["r"])) > 1e-9  # the roundoff that a fixed 1e-9 missed
    env = {x: (-int(np.max(np.abs(base[str(x)]))) - 1, int(np.max(np.abs(base[str(x)]))) + 1)
           for x in m.states}
    env[m.inputs[0]] = (-10 ** 8, 10 ** 8)
    menv = dataclasses.replace(m, bounds={**m.bounds, **env})
    for ot in (guaranteed_threshold(m, o), sampled_threshold(menv, o)):
        res = simulate(m, ot, sc)
        assert int(np.sum((res["r"] < res["r_lower"]) | (res["r"] > res["r_upper"]))) == 0
        assert np.max(res["r_upper"]) < 1e-3


def test_monitor_on_the_recorded_example_uses_the_sampled_band(models_dir, tmp_path, capsys):
    """observer-cad monitor on examples/dc_motor_sampled.csv (solve_ivp of the continuous
    plant, x(0) unknown in its box): the guaranteed band is the sampled one at the data's
    h = 0.01, and no sample alarms (the continuous-time band alarmed on about a fifth)."""
    from observer_cad.cli import main
    code = main(["monitor", str(models_dir / "dc_motor_sampled.py"), "--observer", "diagnostic",
                 "--lambda=-4", "--data", str(ROOT / "examples" / "dc_motor_sampled.csv"),
                 "--out", str(tmp_path), "--threshold", "guaranteed", "--engine", "reference"])
    out = capsys.readouterr().out
    assert code == 0
    assert "sampled algorithm at h = 0.01 (RK4)" in out
    assert "no alarm in 501 samples" in out


def test_monitor_refuses_data_at_another_sample_time(motor):
    """A sampled band holds at its own h only: data at 0.02 s is refused in one line."""
    from observer_cad.simulation import Monitor
    m, o, ot = motor
    t = np.arange(5) * 0.02
    data = {"t": t, "u": np.zeros(5), "y1": np.zeros(5), "y2": np.zeros(5), "y3": np.zeros(5)}
    with pytest.raises(UsageError, match="band holds for the algorithm stepped at h = 0.01;"
                                         " the data's sample time is 0.02"):
        Monitor(m, ot).run(data)
    mon = Monitor(m, ot)
    mon.step(0.0, u=[0], y=[0, 0, 0])
    with pytest.raises(UsageError, match="sample time is 0.02"):
        mon.step(0.02, u=[0], y=[0, 0, 0])
    assert "r_upper" in Monitor(m, ot).run({**data, "t": np.arange(5) * 0.01}).columns


@settings(max_examples=15, deadline=None)
@given(a=st.floats(-0.9, 0.9), c=st.floats(-2, 2), lo=st.floats(-1, 0), hi=st.floats(0, 1))
def test_scalar_worst_case_sum_is_the_closed_form(a, c, lo, hi):
    """e⁺ = a e + ψ, r = e + c ψ, ψ ∈ [lo, hi] with lo ≤ 0 ≤ hi: the largest r is
    max(c lo, c hi) + Σ_j max(a^j lo, a^j hi) (every term ≥ 0, so the sup is the full sum)."""
    wc = worst_case_sums(np.array([[a]]), np.array([[1.0]]), np.array([[1.0]]),
                         np.array([[c]]), [lo], [hi])
    J = np.arange(4000)
    p = a ** J
    expect = max(c * lo, c * hi) + np.sum(np.maximum(p * lo, p * hi))
    assert expect - 1e-9 <= wc.upper[0] <= expect + 1e-9
    expect_lo = min(c * lo, c * hi) + np.sum(np.minimum(p * lo, p * hi))
    assert expect_lo - 1e-9 <= wc.lower[0] <= expect_lo + 1e-9


def test_the_continuous_band_starts_from_the_initial_box(motor):
    """The band of continuous observation reads the model's initial box too: the observer
    starts at Φ c (c the box centre) with the error bounds ±|Φ| (half-widths), so runs whose
    x(0) is anywhere in the box stay inside it (the initial error is felt), and the condition
    says what it rests on."""
    from observer_cad.residuals import guaranteed_threshold
    m, o, _ = motor
    i, w, wl = m.states
    boxed = dataclasses.replace(m, initial={i: (0, 1), w: (-1, 1), wl: (-1, 1)})
    ot = guaranteed_threshold(boxed, o)
    xi = o.states[0]
    assert o.initial[xi] == i and ot.initial[xi] == sp.Rational(1, 2)  # Φ = (1, 0, 0), c = (1/2, 0, 0)
    assert ot.initial[sp.Symbol(f"{xi}_elo")] == -sp.Rational(1, 2)
    assert ot.initial[sp.Symbol(f"{xi}_ehi")] == sp.Rational(1, 2)
    cond = {c.name: c.detail for c in ot.threshold.conditions}["initial error"]
    assert cond.startswith("x(0) in the initial box i ∈ [0, 1]") and "Φ c" in cond
    sc = scenario_from_dict({"t_end": 3, "dt": 0.01, "seed": 4,
                             "initial": {"i": {"uniform": [0, 1]}, "w": {"uniform": [-1, 1]},
                                         "wl": {"uniform": [-1, 1]}},
                             "signals": {"u": "2*sin(3*t)", "rho": {"uniform": [-0.5, 0.5]}}})
    res = simulate(boxed, ot, sc, runs=40)
    r, lo, up = res["r"], res["r_lower"], res["r_upper"]
    assert int(np.sum((r < lo) | (r > up))) == 0
    assert np.max(np.abs(r[:, :20])) > 0.2  # the initial error is felt
    known = {c.name: c.detail for c in guaranteed_threshold(dataclasses.replace(m, initial={}),
                                                             o).threshold.conditions}
    assert known["initial error"].startswith("x(0) known")
