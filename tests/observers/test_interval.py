"""Interval observers: inclusion lower ≤ z ≤ upper on simulated trajectories (the
acceptance test of the interval observer), and companion tests showing that understated bounds do produce
violations, so the inclusion check is not vacuous.

Tolerance for "≤": TOL = 1e-9 absolute. The inclusion is exact in real arithmetic;
the simulator evaluates the plant and the observer in double precision, where the
quantities compared are at most O(10⁴) here (the electric drive with λ = −1/2 has
x* = x2 + 3250 x3) so rounding differences are below 1e-11. Where a bound is tight by
construction (x2_lower = y1 − w* = x2 + w1 − w* with w1 close to w*, or the
extreme-noise scenarios where the upper copy follows the plant exactly) the true gap
tends to 0 and only rounding separates the two sides; 1e-9 absorbs that and is still
far below every violation the understated bounds produce (≥ 1e-3).

Every check first asserts that the compared arrays are finite: NaN compares False
and would hide violations.
"""
from __future__ import annotations

import dataclasses

import json

import numpy as np
import pytest
import sympy as sp

from observer_cad import UsageError, load_model
from observer_cad.observers import full_state_intervals, interval_observer_nonlinear
from observer_cad.synthesis import design_jordan
from observer_cad.observers import interval_observer
from observer_cad.simulation import load_scenario, scenario_from_dict, simulate

TOL = 1e-9
# The acceptance size: 1,000 seeded runs × 2,000 steps. Each such run takes 2-8 s of CPU
# here (below the ~20 s threshold for @pytest.mark.slow), so they run by default.
RUNS = 1000


@pytest.fixture(scope="module")
def tank(models_dir):
    return load_model(models_dir / "three_tank.py")


@pytest.fixture(scope="module")
def tank_lin(models_dir):
    return load_model(models_dir / "three_tank_linear.py")


@pytest.fixture(scope="module")
def drive(models_dir):
    return load_model(models_dir / "electric_drive.py")


def scenario(models_dir, name):
    return load_scenario(models_dir / "scenarios" / f"{name}.json")


def violations(res, names, z=None):
    """Number of (run, step) pairs where z leaves [lower, upper] by more than TOL."""
    total = 0
    for nm in names:
        lo, hi = res[f"{nm}_lower"], res[f"{nm}_upper"]
        zz = res[nm] if z is None else z
        assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(np.isfinite(zz)), nm
        assert np.all(lo <= hi + TOL), f"{nm}: lower above upper"
        total += int(np.sum((zz < lo - TOL) | (zz > hi + TOL)))
    return total


def understate(model, factor, which=None):
    """A copy of the model whose declared bounds are scaled by ``factor``."""
    b = {s: (lo * sp.nsimplify(factor), hi * sp.nsimplify(factor)) if (which is None or s.name in which)
         else (lo, hi) for s, (lo, hi) in model.bounds.items()}
    return dataclasses.replace(model, bounds=b)


def assert_in_domain(res):
    """The nonlinear three-tank must stay in x1 > x2 > x3 > 0 (the observer's clipped
    arguments equal the true ones only there)."""
    for a in ("x1", "x2", "x3"):
        assert np.all(np.isfinite(res[a]))
    assert np.min(res["x1"] - res["x2"]) > 0.1
    assert np.min(res["x2"] - res["x3"]) > 0.1
    assert np.min(res["x3"]) > 0.1


def shape_ok(res, runs, steps=2000):
    assert res["t"].shape == (runs, steps + 1)


# ---------------------------------------------------------------- nonlinear three-tank
@pytest.fixture(scope="module")
def tank_observer(tank):
    d = design_jordan(tank, observer="interval", estimate="x1")
    return interval_observer_nonlinear(tank, d)


def test_nonlinear_tank_observer_equations(tank, tank_observer):
    """x*' = u1 − √(x* − ỹ1) (seed 002 §8) with ỹ1 at the end of the noise box that
    makes the right-hand side smallest / largest; arguments clipped to ≥ 0."""
    o = tank_observer
    xl1, xu1, y1, u1 = sp.symbols("xl1 xu1 y1 u1")
    w = sp.Rational(1, 100)
    lower, upper = o.update
    # on the domain (argument ≥ 0) the copies are u1 − √(x − (y1 ∓ w*))
    for e, x, yt in ((lower, xl1, y1 - w), (upper, xu1, y1 + w)):
        for xv, yv, uv in ((1.7, 1.0, 0.5), (3.0, 2.2, 1.0)):
            got = float(e.subs({x: xv, y1: yv, u1: uv}))
            assert got == pytest.approx(uv - np.sqrt(xv - float(yt.subs(y1, yv))), abs=1e-12)
    # off the domain (lower bound below y1) the clipped equation stays finite and real
    v = complex(lower.subs({xl1: 0.0, y1: 1.0, u1: 0.5}))
    assert v.imag == 0 and np.isfinite(v.real)
    assert dict(o.outputs) == {"x1_lower": xl1, "x1_upper": xu1}
    names = {c.name: c for c in o.conditions}
    emb = next(c for n, c in names.items() if n.startswith("mixed-monotone embedding"))
    assert emb.holds and emb.required
    mono = next(c for n, c in names.items() if n.startswith("C*Ψ* monotone"))
    assert not mono.holds and not mono.required  # −√a + a is not monotone near a = 0
    kstar = names["k*: Lipschitz constant of C*Ψ* in y on the domain"]
    assert not kstar.holds and "not Lipschitz" in kstar.detail
    assert any("stays in its domain" in a for a in o.assumptions)


@pytest.mark.slow
def test_nonlinear_tank_inclusion(tank, tank_observer, models_dir):
    sc = scenario(models_dir, "three_tank_interval")
    res = simulate(tank, tank_observer, sc, runs=RUNS)
    shape_ok(res, RUNS)
    assert_in_domain(res)
    assert violations(res, ["x1"]) == 0
    # the interval is informative: it settles to ≈ 2 w* = 0.02 wide
    width = res["x1_upper"][:, -1] - res["x1_lower"][:, -1]
    assert np.all(width < 0.05)


def test_nonlinear_tank_understated_noise_bound(tank, models_dir):
    """Noise bound understated ten-fold: iid noise rarely sits at its bound, so the
    declared bound leaves slack (the gap stays ≥ 0.008 of the 0.01 margin in the run
    above) and only a large understatement shows on random noise."""
    sc = scenario(models_dir, "three_tank_interval")
    m = understate(tank, 0.1, {"w1", "w2"})
    o = interval_observer_nonlinear(m, design_jordan(m, observer="interval", estimate="x1"))
    res = simulate(tank, o, sc, runs=100)
    assert_in_domain(res)
    assert violations(res, ["x1"]) > 0


def _extreme_tank(sign):
    """Admissible worst case: the noise sits at its bound for the whole run."""
    return scenario_from_dict({
        "t_end": 20, "dt": 0.01, "seed": 0, "initial": {"x1": 2, "x2": 1.2, "x3": 0.6},
        "signals": {"u1": "0.5", "u2": "0.2", "w1": str(sign * 0.01), "w2": str(sign * 0.01),
                    "rho1": {"uniform": [-0.5, 0.5]}, "rho2": {"uniform": [-0.5, 0.5]}}})


@pytest.mark.parametrize("sign", [1, pytest.param(-1, marks=pytest.mark.slow)])
def test_nonlinear_tank_bound_is_tight(tank, tank_observer, sign):
    """With w1 ≡ ∓w* one copy obeys the plant's own equation: the declared bound is
    exactly enough (zero violations) and 10 % less is not."""
    sc = _extreme_tank(sign)
    res = simulate(tank, tank_observer, sc, runs=5)
    assert_in_domain(res)
    assert violations(res, ["x1"]) == 0
    tight = res["x1"] - res["x1_lower"] if sign > 0 else res["x1_upper"] - res["x1"]
    assert np.min(tight[:, 1000:]) < 1e-4  # the gap closes: no slack in the declared bound
    m = understate(tank, sp.Rational(9, 10), {"w1", "w2"})
    o = interval_observer_nonlinear(m, design_jordan(m, observer="interval", estimate="x1"))
    res = simulate(tank, o, sc, runs=5)
    assert violations(res, ["x1"]) > 0


# ---------------------------------------------------------------- full-state intervals
@pytest.fixture(scope="module")
def tank_full(tank):
    return full_state_intervals(tank)


def test_full_state_structure(tank_full):
    o = tank_full
    assert o.output_names == ("x1_lower", "x1_upper", "x2_lower", "x2_upper", "x3_lower", "x3_upper")
    outs = dict(o.outputs)
    y1, y2 = sp.symbols("y1 y2")
    w = sp.Rational(1, 100)
    assert outs["x2_lower"] == y1 - w and outs["x2_upper"] == y1 + w  # seed 002 §8
    assert outs["x3_lower"] == y2 - w and outs["x3_upper"] == y2 + w
    names = [c.name for c in o.conditions]
    assert "H = (H0 0) with H0 invertible" in names and "H0⁻¹ ≥ 0" in names


@pytest.mark.slow
def test_full_state_inclusion(tank, tank_full, models_dir):
    sc = scenario(models_dir, "three_tank_interval")
    res = simulate(tank, tank_full, sc, runs=RUNS)
    shape_ok(res, RUNS)
    assert_in_domain(res)
    assert violations(res, ["x1", "x2", "x3"]) == 0


def test_full_state_understated(tank, models_dir):
    sc = scenario(models_dir, "three_tank_interval")
    o = full_state_intervals(understate(tank, sp.Rational(1, 2), {"w1", "w2"}))
    res = simulate(tank, o, sc, runs=100)
    # the measured states' bounds y ∓ w*/2 miss every sample with |w| > w*/2
    assert violations(res, ["x2"]) > 0 and violations(res, ["x3"]) > 0


def test_full_state_linear_tank(tank_lin, models_dir):
    o = full_state_intervals(tank_lin)
    res = simulate(tank_lin, o, scenario(models_dir, "three_tank_linear_interval"), runs=100)
    assert violations(res, ["x1", "x2", "x3"]) == 0


# ---------------------------------------------------------------- linear three-tank
@pytest.fixture(scope="module")
def lin_design(tank_lin):
    return design_jordan(tank_lin, observer="interval", estimate="x1")


def test_linear_tank_builders_agree(tank_lin, lin_design):
    """Without nonlinear terms and faults the general builder reproduces the linear one."""
    a = interval_observer_nonlinear(tank_lin, lin_design)
    b = interval_observer(tank_lin, lin_design)
    assert [sp.expand(e) for e in a.update] == [sp.expand(e) for e in b.update]
    assert [(n, sp.expand(e)) for n, e in a.outputs] == [(n, sp.expand(e)) for n, e in b.outputs]


@pytest.mark.slow
def test_linear_tank_inclusion(tank_lin, lin_design, models_dir):
    o = interval_observer_nonlinear(tank_lin, lin_design)
    res = simulate(tank_lin, o, scenario(models_dir, "three_tank_linear_interval"), runs=RUNS)
    shape_ok(res, RUNS)
    assert violations(res, ["x1"]) == 0


def test_linear_tank_understated(tank_lin, models_dir):
    sc = scenario(models_dir, "three_tank_linear_interval")
    m = understate(tank_lin, sp.Rational(1, 10))
    o = interval_observer_nonlinear(m, design_jordan(m, observer="interval", estimate="x1"))
    res = simulate(tank_lin, o, sc, runs=100)
    assert violations(res, ["x1"]) > 0


def test_linear_tank_bound_is_tight(tank_lin, lin_design):
    """w1 ≡ −w*: the upper copy x̄' = −x̄ + y1 + w* + u1 follows x1 exactly."""
    sc = scenario_from_dict({"t_end": 20, "dt": 0.01, "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
                             "signals": {"u1": "1", "u2": "0.5", "w1": "-0.02", "w2": "0.02",
                                         "rho": {"uniform": [-0.2, 0.2]}}})
    o = interval_observer_nonlinear(tank_lin, lin_design)
    assert violations(simulate(tank_lin, o, sc, runs=5), ["x1"]) == 0
    m = understate(tank_lin, sp.Rational(9, 10), {"w1", "w2"})
    o = interval_observer_nonlinear(m, design_jordan(m, observer="interval", estimate="x1"))
    assert violations(simulate(tank_lin, o, sc, runs=5), ["x1"]) > 0


# ---------------------------------------------------------------- electric drive (discrete)
def drive_design(drive, lam):
    return design_jordan(drive, observer="interval", estimate="x2", lambdas=[lam])


@pytest.mark.slow
@pytest.mark.parametrize("lam", [sp.Rational(4, 5), pytest.param(sp.Rational(3, 4), marks=pytest.mark.slow),
                                 sp.Rational(-1, 2)])
def test_drive_inclusion(drive, models_dir, lam):
    """λ = 4/5: Φ = (0, 1, 0), the fault does not enter (D* = 0); λ = 3/4: D* = Φ D = 125,
    the fault d bounded by its declared interval; λ = −1/2: F* < 0, both bounds use the
    F*⁺/F*⁻ split (lower(t+1) = −½ x̄* + …)."""
    d = drive_design(drive, lam)
    o = interval_observer_nonlinear(drive, d)
    res = simulate(drive, o, scenario(models_dir, "electric_drive_interval"), runs=RUNS)
    shape_ok(res, RUNS)
    assert violations(res, ["x2"]) == 0


def test_drive_split_and_fault_terms(drive):
    xl1, xu1 = sp.symbols("xl1 xu1")
    # z = 2 x2 + x3: every admissible row sees the fault d (D* = Φ D ≠ 0)
    o = interval_observer_nonlinear(drive, design_jordan(
        drive, observer="interval", estimate="2*x2 + x3", lambdas=[sp.Rational(-1, 2)]))
    lower, upper = o.update
    assert lower.coeff(xl1) == 0 and lower.coeff(xu1) == sp.Rational(-1, 2)
    assert upper.coeff(xu1) == 0 and upper.coeff(xl1) == sp.Rational(-1, 2)
    cond = {c.name: c for c in o.conditions}
    assert cond["unknown inputs bounded"].holds
    assert "d" in cond["unknown inputs bounded"].detail
    # λ = 4/5: D* = 0 and the result equals the linear builder's (which ignores faults)
    d45 = drive_design(drive, sp.Rational(4, 5))
    a, b = interval_observer_nonlinear(drive, d45), interval_observer(drive, d45)
    assert [sp.expand(e) for e in a.update] == [sp.expand(e) for e in b.update]


def test_drive_understated(drive, models_dir):
    sc = scenario(models_dir, "electric_drive_interval")
    m = understate(drive, sp.Rational(1, 4), {"rho"})
    res = simulate(drive, interval_observer_nonlinear(m, drive_design(m, sp.Rational(4, 5))), sc,
                   runs=100)
    assert violations(res, ["x2"]) > 0
    # the fault's bound understated: z = 2 x2 + x3, whose rows see d (noise-free, so the
    # noise margin leaves no slack that could hide the understated fault bound)
    from observer_cad.simulation import scenario_from_dict
    quiet = json.loads(json.dumps({k: v for k, v in json.load(open(
        models_dir / "scenarios" / "electric_drive_interval.json")).items() if k != "description"}))
    quiet["signals"].update({"w1": "0", "w2": "0"})
    sc = scenario_from_dict(quiet)
    m = understate(drive, sp.Rational(1, 4), {"d", "w1", "w2"})
    o = interval_observer_nonlinear(m, design_jordan(m, observer="interval", estimate="2*x2 + x3",
                                                     lambdas=[sp.Rational(3, 4)]))
    res = simulate(drive, o, sc, runs=100)
    z = 2 * res["x2"] + res["x3"]
    bad = np.sum(res["z_lower"] > z + 1e-9) + np.sum(res["z_upper"] < z - 1e-9)
    assert bad > 0
    # and with the declared bound: none
    o = interval_observer_nonlinear(drive, design_jordan(drive, observer="interval",
                                                         estimate="2*x2 + x3", lambdas=[sp.Rational(3, 4)]))
    res = simulate(drive, o, sc, runs=100)
    z = 2 * res["x2"] + res["x3"]
    assert np.sum(res["z_lower"] > z + 1e-9) + np.sum(res["z_upper"] < z - 1e-9) == 0


# ---------------------------------------------------------------- margins
def test_lipschitz_margin_refused_when_not_lipschitz(tank):
    d = design_jordan(tank, observer="interval", estimate="x1")
    with pytest.raises(UsageError, match="not Lipschitz in y"):
        interval_observer_nonlinear(tank, d, margin="lipschitz")


@pytest.mark.slow
def test_lipschitz_margin_on_domain_away_from_zero(tank, models_dir):
    """On x1 − x2 ≥ 1/100 (where the plant stays) ∂f/∂ỹ1 = 1/(2√(x* − ỹ1)) ≤ 5 on the
    clipped extension: margin K w* = 5 · 0.01; the bounds contain x1 but are wider
    than the exact corners."""
    x1, x2, x3 = tank.states
    a = sp.Rational(1, 100)
    dom = [x1 - x2 >= a, x2 - x3 >= a, x3 >= a]
    d = design_jordan(tank, observer="interval", estimate="x1")
    o = interval_observer_nonlinear(tank, d, margin="lipschitz", domain=dom)
    sc = scenario(models_dir, "three_tank_interval")
    res = simulate(tank, o, sc, runs=20)
    assert_in_domain(res)
    assert violations(res, ["x1"]) == 0
    exact = simulate(tank, interval_observer_nonlinear(tank, d, domain=dom), sc, runs=20)
    assert np.all(res["x1_upper"][:, -1] - res["x1_lower"][:, -1]
                  >= exact["x1_upper"][:, -1] - exact["x1_lower"][:, -1] - TOL)


def test_user_margin_reported_unverifiable(tank):
    d = design_jordan(tank, observer="interval", estimate="x1")
    o = interval_observer_nonlinear(tank, d, margin=0.5)  # the paper's k* w*_1 = 0.5
    c = next(c for c in o.conditions if "given margin" in c.name)
    assert not c.holds and c.required and "not verifiable" in c.detail


def test_drive_full_state(drive, models_dir):
    """H = [[1,0,0],[0,0,1]]: x1, x3 from y ∓ w*, x2 from the interval observer (which
    bounds the fault d through D* = Φ D)."""
    o = full_state_intervals(drive)
    res = simulate(drive, o, scenario(models_dir, "electric_drive_interval"), runs=100)
    assert violations(res, ["x1", "x2", "x3"]) == 0


def test_discrete_nonlinear_toy():
    """A discrete plant with a nonlinear term in the measured state: the copies use
    √max(0, y1 ∓ w*) (monotone in y1) and F* = 1/2 ≥ 0."""
    from observer_cad import PlantModel
    a, b, u, rho, w = sp.symbols("a b u rho w")
    m = PlantModel(name="toy", time="discrete", states=[a, b], inputs=[u], disturbances=[rho],
                   noise=[w], outputs=[b + w],
                   dynamics=[a / 2 + sp.sqrt(b) / 10 + u, b / 2 + 1 + rho],
                   domain=[b >= 0], bounds={rho: (-0.1, 0.1), w: (-0.05, 0.05)})
    d = design_jordan(m, observer="interval", estimate="a")
    o = interval_observer_nonlinear(m, d)
    y1, xl1, xu1 = sp.symbols("y1 xl1 xu1")
    assert sp.simplify(o.update[0] - (u + xl1 / 2 + sp.sqrt(sp.Max(0, y1 - sp.Rational(1, 20))) / 10)) == 0
    sc = scenario_from_dict({"steps": 2001, "seed": 1, "initial": {"a": 0, "b": 1},
                             "signals": {"u": "sin(t/10)", "rho": {"uniform": [-0.1, 0.1]},
                                         "w": {"uniform": [-0.05, 0.05]}}})
    res = simulate(m, o, sc, runs=100)
    assert np.min(res["b"]) > 0
    assert violations(res, ["a"]) == 0
    res = simulate(m, full_state_intervals(m), sc, runs=100)
    assert violations(res, ["a", "b"]) == 0


def test_refuses_symbolic_and_feedback_designs(drive):
    d = design_jordan(drive, observer="interval", estimate="x2", symbolic=True)
    with pytest.raises(UsageError, match="numeric design"):
        interval_observer_nonlinear(drive, d)
