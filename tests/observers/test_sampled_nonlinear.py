"""Sampled-data guaranteed bands of nonlinear plants (METHOD §3, residual evaluation): the band
of the discrete algorithm that runs deployed (observer_step at h, y and u held over each step)
on the true continuous nonlinear plant, its intersample terms bounded by interval enclosures
over the operating envelope.

Checked independently of the code that builds the band: on records of the true plant
integrated by a fine fixed-step RK4 (fifty sub-steps per sample, far below the band's
resolution), with the input switching at every sample and the noise at its bounds; the
interval enclosures against sampled values of the expressions.
"""
import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from observer_cad import PlantModel, build_observer, design
from observer_cad.codegen import observer_step, split_signals
from observer_cad.errors import UsageError
from observer_cad.residuals import sampled_band_refusal, sampled_threshold

x1, x2, u, f, w1, w2 = sp.symbols("x1 x2 u f w1 w2")
H = sp.Rational(1, 100)


def pendulum_like(**bounds):
    """x1' = x2, x2' = −x1 + x1³/6 − x2 + u + f (a softening spring), both states measured."""
    b = {x1: (-1, 1), x2: (-2, 2), u: (-1, 1), f: (-1, 1), w1: (-0.01, 0.01), w2: (-0.01, 0.01)}
    b.update(bounds)
    return PlantModel(name="pendulum_like", time="continuous", states=[x1, x2], inputs=[u],
                      faults=[f], noise=[w1, w2], outputs=[x1 + w1, x2 + w2],
                      dynamics=[x2, -x1 + x1 ** 3 / 6 - x2 + u + f], bounds=b)


@pytest.fixture(scope="module")
def plant():
    m = pendulum_like()
    o = build_observer(m, design(m, observer="diagnostic"))
    return m, o, sampled_threshold(m, o, H)


def _records(n, T, seed, fault=0.0, fault_time=None, h=0.01, sub=50):
    """n records of the true plant: u a new random level in [−0.5, 0.5] every sample (held),
    the noise at ±its bound (random signs) at every sample, x(0) = 0; integrated by RK4 with
    ``sub`` steps per sample. Returns t, u (samples × n), y (samples × n × 2), x."""
    rng = np.random.default_rng(seed)
    K = int(round(T / h))
    U = rng.uniform(-0.5, 0.5, (K, n))
    W = 0.01 * rng.choice([-1.0, 1.0], (K, n, 2))
    t = np.arange(K) * h
    F = np.where(t[:, None] >= (fault_time if fault_time is not None else np.inf), fault, 0.0)
    F = np.broadcast_to(F, (K, n))
    X = np.zeros((K, n, 2))
    x = np.zeros((n, 2))

    def rhs(x, uu, ff):
        return np.stack([x[:, 1], -x[:, 0] + x[:, 0] ** 3 / 6 - x[:, 1] + uu + ff], axis=1)
    dt = h / sub
    for k in range(K):
        X[k] = x
        for _ in range(sub):
            k1 = rhs(x, U[k], F[k])
            k2 = rhs(x + dt / 2 * k1, U[k], F[k])
            k3 = rhs(x + dt / 2 * k2, U[k], F[k])
            k4 = rhs(x + dt * k3, U[k], F[k])
            x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return t, U, X + W, X


def _run(ot, U, Y):
    """r, r_lower, r_upper (samples × records) of observer_step over the records."""
    fstep = observer_step(ot, h=0.01)
    ys, us = split_signals(ot)
    K, n = U.shape
    xi = np.array([[float(ot.initial[s].xreplace({x1: 0, x2: 0})) if hasattr(ot.initial[s], "xreplace")
                    else float(ot.initial[s]) for s in ot.states]] * n).T
    yidx = [int(str(s)[1:]) - 1 for s in ys]
    names = [nm for nm, _ in ot.outputs]
    outs = []
    for k in range(K):
        Xn, O = fstep(xi, Y[k][:, yidx].T, U[k][None, :], np.zeros((0, n)))
        outs.append(np.array(O))
        xi = np.array(Xn)
    O = np.stack(outs)
    return (O[:, names.index("r")], O[:, names.index("r_lower")], O[:, names.index("r_upper")])


def test_the_band_names_its_nonlinear_terms(plant):
    m, o, ot = plant
    conds = {c.name: c.detail for c in ot.threshold.conditions}
    assert "nominal nonlinear plant" in conds["fault-free residual identity"]
    assert "x1 ∈ [-1, 1], x2 ∈ [-2, 2], u ∈ [-1, 1]" in conds["operating envelope"]
    assert ot.threshold.sample_time == 0.01 and ot.threshold.discretisation == "rk4"
    assert sampled_band_refusal(m, o) == ""
    upper = float(dict(ot.outputs)["r_upper"])
    # the noise alone reaches 0.01 directly in r (y2); the band is that plus the filtered rest
    assert 0.02 < upper < 0.1


@pytest.mark.slow
def test_no_false_alarm_on_records_of_the_true_nonlinear_plant(plant):
    """200 fault-free records (4 s each) with the input switching at every sample and the
    noise at ±its bounds: no sample leaves the band; the records stay in the envelope; the
    residual uses a fair part of the band."""
    m, o, ot = plant
    t, U, Y, X = _records(200, 4.0, seed=5)
    assert np.all(np.abs(X[..., 0]) <= 1) and np.all(np.abs(X[..., 1]) <= 2)
    r, lo, up = _run(ot, U, Y)
    assert int(np.sum((r < lo) | (r > up))) == 0
    assert np.max(np.abs(r)) > 0.3 * up[-1, 0]


def test_a_step_fault_is_detected(plant):
    """A step fault f = ±0.5 from t = 1 s: an alarm after it in every record, none before."""
    m, o, ot = plant
    t, U, Y, X = _records(20, 3.0, seed=8, fault=np.where(np.arange(20) % 2, 0.5, -0.5),
                          fault_time=1.0)
    r, lo, up = _run(ot, U, Y)
    alarm = (r < lo) | (r > up)
    assert not alarm[:100].any()
    assert alarm[100:].any(axis=0).all()


def test_a_term_without_a_finite_bound_is_refused_in_one_line():
    """A square-root drain sqrt(x1 + 1): its slope is unbounded where x1 = −1. With that point
    in the envelope the band is refused in one line naming the slope (monitor and codegen then
    keep the band of continuous observation, with a note); with x1 ≥ −1/2 it is computed."""
    def tank(lo):
        return PlantModel(name="drain", time="continuous", states=[x1, x2], inputs=[u],
                          faults=[f], noise=[w1, w2], outputs=[x1 + w1, x2 + w2],
                          dynamics=[x2, -sp.sqrt(x1 + 1) - x2 + u + f],
                          bounds={x1: (lo, 1), x2: (-2, 2), u: (-1, 2), f: (-1, 1),
                                  w1: (-0.01, 0.01), w2: (-0.01, 0.01)})
    m = tank(-1)
    o = build_observer(m, design(m, observer="diagnostic"))
    with pytest.raises(UsageError) as exc:
        sampled_threshold(m, o, H)
    msg = str(exc.value)
    assert "\n" not in msg and "no finite bound" in msg and "∂p1/∂x1" in msg
    assert "no finite bound" in sampled_band_refusal(m, o)
    m = tank(sp.Rational(-1, 2))
    o = build_observer(m, design(m, observer="diagnostic"))
    assert sampled_band_refusal(m, o) == ""
    assert float(dict(sampled_threshold(m, o, H).outputs)["r_upper"]) > 0


@settings(max_examples=30, deadline=None)
@given(st.integers(min_value=0, max_value=10 ** 6))
def test_interval_enclosures_contain_the_values(seed):
    """The enclosure of a random expression over a box contains its value at random points."""
    from observer_cad.residuals import interval_range
    rng = np.random.default_rng(seed)
    a, b = sp.symbols("a b")
    terms = [a * b, a ** 3, sp.sin(a) * sp.exp(b), sp.cos(a - b), sp.sqrt(b + 3), a ** 2 / (b + 5),
             sp.Abs(a - b) * a]
    e = sum(int(rng.integers(-3, 4)) * terms[i] for i in rng.choice(len(terms), 3, replace=False))
    lo_a, lo_b = rng.uniform(-2, 1, 2)
    box = {a: (sp.Rational(lo_a).limit_denominator(100), sp.Rational(lo_a + 1).limit_denominator(100)),
           b: (sp.Rational(lo_b).limit_denominator(100), sp.Rational(lo_b + 1.5).limit_denominator(100))}
    lo, hi = interval_range(e, box, where="test", what="e")
    fn = sp.lambdify((a, b), e, "numpy")
    pa = rng.uniform(float(box[a][0]), float(box[a][1]), 200)
    pb = rng.uniform(float(box[b][0]), float(box[b][1]), 200)
    v = fn(pa, pb)
    assert np.all(v >= lo) and np.all(v <= hi)
