"""Guaranteed adaptive thresholds (METHOD §3, residual evaluation): the band of the
fault-free residual.

Checked independently of the code that builds the band: by simulation (the residual of a
plant with random noise, disturbances and parameters inside their declared boxes never
leaves the band), by a worst-case noise sequence that attains the band (so it is tight, and a
sign error in any term would cross it), and by hand-computed band constants.
"""
import dataclasses

import numpy as np
import pytest
import sympy as sp

from observer_cad import build_observer, design, load_model, simulate
from observer_cad.errors import ModelError, UsageError
from observer_cad.residuals import (constant_threshold, guaranteed_threshold, min_detectable_fault,
                                    residual_names)
from observer_cad.simulation import scenario_from_dict
from observer_cad.analysis import design_bank


@pytest.fixture(scope="module")
def drive(models_dir):
    m = load_model(models_dir / "electric_drive.py")
    return m, build_observer(m, design(m, observer="diagnostic"))


@pytest.fixture(scope="module")
def uncertain(models_dir):
    m = load_model(models_dir / "electric_drive_uncertain.py")
    return m, build_observer(m, design(m, observer="diagnostic"))


def _outside(res, names):
    return sum(int(np.sum((res[r] < res[f"{r}_lower"]) | (res[r] > res[f"{r}_upper"])))
               for r in names)


def test_band_constants_by_hand(drive):
    """Electric drive, Φ = [1 0 5], λ = 1/2, J* = [1/2, 23/10], R* = [1, 5]: e⁺ = e/2 − J* w,
    r = e + R* w, |w| ≤ 0.01: the error bound grows by 0.005 + 0.023 = 0.028 per step and
    the residual adds 0.01 + 0.05 = 0.06."""
    m, o = drive
    ot = guaranteed_threshold(m, o, margin=0)
    eq = dict(zip(ot.states, ot.update))
    elo, ehi = sp.symbols("xs1_elo xs1_ehi")
    assert sp.simplify(eq[elo] - (elo / 2 - sp.Rational(7, 250))) == 0
    assert sp.simplify(eq[ehi] - (ehi / 2 + sp.Rational(7, 250))) == 0
    out = dict(ot.outputs)
    assert sp.simplify(out["r_upper"] - (ehi + sp.Rational(3, 50))) == 0
    assert sp.simplify(out["r_lower"] - (elo - sp.Rational(3, 50))) == 0
    assert ot.threshold.kind == "guaranteed"
    names = [c.name for c in ot.threshold.conditions]
    assert {"fault-free residual identity", "declared bounds", "comparison system stable",
            "initial error"} <= set(names)
    assert all(c.holds for c in ot.threshold.conditions)
    # steady width 2·0.028/(1 − 1/2) + 2·0.06 = 0.232; a step fault d has dc gain
    # Φ D/(1 − λ) = 10, so d ≥ 0.0232 is detected for sure once settled
    assert ot.threshold.error_system.dc_gain()[0, 0] == 10
    assert min_detectable_fault(ot.threshold, [0.232])["d"] == pytest.approx(0.0232)


def test_worst_case_noise_attains_the_band(drive):
    """Noise that maximises the residual at t = 60 (w2 = −0.01·sign… chosen by hand): the
    residual reaches r_upper to within 1e-9 and never exceeds it (sharp: a band too narrow by
    any term, or with a wrong sign, is crossed)."""
    m, o = drive
    ot = guaranteed_threshold(m, o)
    # e⁺ = e/2 − (w1/2 + 23 w2/10): push e up with w = −0.01 before t = 60, then r = e + w1 + 5 w2
    # is largest with w = +0.01 at t = 60
    sc = scenario_from_dict({"steps": 61, "signals": {
        "w1": "Piecewise((-0.01, t < 60), (0.01, True))",
        "w2": "Piecewise((-0.01, t < 60), (0.01, True))",
        "u": "sin(t/7)", "rho": "0.05*cos(t)"}})
    res = simulate(m, ot, sc)
    assert _outside(res, ["r"]) == 0
    assert res["r_upper"][60] - res["r"][60] == pytest.approx(0, abs=2e-9)
    assert res["r"][60] == pytest.approx(0.056 * (1 - 0.5 ** 59) + 0.06, abs=1e-12)


def test_uncertain_parameter_inclusion_over_sampled_plants(uncertain):
    """k5 uniform in its declared ±1 % box (one value per run), asymmetric noise w1 ∈ [0, 0.02],
    random ρ, and an initial error: 200 runs × 1,500 steps, the residual never leaves the band;
    the band is not vacuous (the residual comes within 10 % of its width)."""
    m, o = uncertain
    ot = guaranteed_threshold(m, o, initial_error=0.05)
    sc = scenario_from_dict({"steps": 1500, "seed": 4, "observer_initial": {"xs1": 0.05},
                             "parameters": {"k5": {"uniform": [0.9504, 0.9696]}},
                             "signals": {"u": "2*sin(t/10)", "rho": {"uniform": [-0.05, 0.05]},
                                         "w1": {"uniform": [0, 0.02]},
                                         "w2": {"uniform": [-0.01, 0.01]}}})
    res = simulate(m, ot, sc, runs=200)
    assert _outside(res, ["r"]) == 0
    width = res["r_upper"] - res["r_lower"]
    slack = np.minimum(res["r"] - res["r_lower"], res["r_upper"] - res["r"])
    assert np.all(np.isfinite(width)) and np.max(width) < 1.0
    assert np.min(slack) < 0.1 * np.median(width)
    assert res.parameters["k5"].shape == (200,)
    text = " ".join(c.detail for c in ot.threshold.conditions)
    assert "k5 ∈ [594/625, 606/625]" in text and "x3 from y2" in text


def test_uncertainty_is_what_the_band_absorbs(uncertain):
    """Without the declared uncertainty the band is narrower, and a plant at the edge of the
    uncertainty box leaves it: the uncertain term is really what the band covers."""
    m, o = uncertain
    nominal = dataclasses.replace(m, uncertainty={})
    narrow = guaranteed_threshold(nominal, build_observer(nominal, design(nominal, observer="diagnostic")))
    wide = guaranteed_threshold(m, o)
    sc = {"steps": 400, "seed": 2, "parameters": {"k5": 0.9504},
          "signals": {"u": "10*sin(t/10)", "w1": 0.01}}
    assert _outside(simulate(m, wide, scenario_from_dict(sc)), ["r"]) == 0
    assert _outside(simulate(nominal, narrow, scenario_from_dict(sc)), ["r"]) > 0


def test_bank_bands_continuous_time(models_dir):
    """The isolating bank of the three-tank (continuous time, RK4): every residual in its band
    over 40 noisy runs; the dc gains have the structure matrix's zero pattern."""
    m = load_model(models_dir / "three_tank_isolation.py")
    bank = design_bank(m)
    ot = guaranteed_threshold(m, build_observer(m, bank))
    assert residual_names(ot) == ("r1", "r2", "r3")
    sc = scenario_from_dict({"t_end": 10, "dt": 0.01, "seed": 8,
                             "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
                             "signals": {"u1": "1", "u2": "0.5*sin(t)",
                                         "rho": {"uniform": [-0.2, 0.2]},
                                         "w1": {"uniform": [-0.02, 0.02]},
                                         "w2": {"uniform": [-0.02, 0.02]},
                                         "w3": {"uniform": [-0.02, 0.02]}}})
    res = simulate(m, ot, sc, runs=40)
    assert _outside(res, ["r1", "r2", "r3"]) == 0
    G = ot.threshold.error_system.dc_gain()
    pattern = tuple(tuple(int(G[i, j] != 0) for j in range(3)) for i in range(3))
    assert pattern == tuple(tuple(r) for r in bank.structure_matrix)


def test_refusals_are_one_line(models_dir, drive):
    m, o = drive
    with pytest.raises(UsageError, match="w1' reaches the residual but has no declared bounds"):
        b = {k: v for k, v in m.bounds.items() if str(k) != "w1"}
        guaranteed_threshold(dataclasses.replace(m, bounds=b), o)
    k1 = sp.Symbol("k1")  # k1 x2 enters Φ f through Φ = [1 0 5]
    mk = dataclasses.replace(m, uncertainty={k1: (0.0019, 0.0021)})
    with pytest.raises(UsageError, match=r"needs bounds on x2 .*domain \(x2 >= low, x2 <= high\)"):
        guaranteed_threshold(mk, build_observer(mk, design(mk, observer="diagnostic")))
    tank = load_model(models_dir / "three_tank.py")
    tobs = build_observer(tank, design(tank, observer="interval", estimate="x1"))
    with pytest.raises(UsageError, match="no residual output"):
        guaranteed_threshold(tank, tobs)
    with pytest.raises(UsageError, match="nonnegative"):
        guaranteed_threshold(m, o, initial_error=-1)


def test_domain_bounds_an_unmeasured_state(drive):
    """Uncertainty multiplying an unmeasured state is accepted when the model's domain bounds
    it; the band then holds on plants inside that domain."""
    m, _ = drive
    x2, k1 = sp.symbols("x2 k1")
    mk = dataclasses.replace(m, uncertainty={k1: (sp.Rational(19, 10000), sp.Rational(21, 10000))},
                             domain=(x2 >= -1, x2 <= 1))
    ot = guaranteed_threshold(mk, build_observer(mk, design(mk, observer="diagnostic")))
    assert "x2 ∈ [-1, 1] (model domain)" in " ".join(c.detail for c in ot.threshold.conditions)


def test_constant_threshold(drive):
    m, o = drive
    oc = constant_threshold(o, 0.1)
    out = dict(oc.outputs)
    assert float(out["r_lower"]) == -0.1 and float(out["r_upper"]) == 0.1
    with pytest.raises(UsageError, match="positive finite"):
        constant_threshold(o, 0)
    with pytest.raises(UsageError, match="2 threshold values for 1 residuals"):
        constant_threshold(o, [0.1, 0.2])


def test_model_uncertainty_validation(drive):
    m, _ = drive
    k5, x1 = sp.symbols("k5 x1")
    with pytest.raises(ModelError, match="does not contain its nominal value 24/25"):
        dataclasses.replace(m, uncertainty={k5: (0.97, 0.98)})
    with pytest.raises(ModelError, match="'x1', which is not a parameter"):
        dataclasses.replace(m, uncertainty={x1: (0, 1)})
    with pytest.raises(ModelError, match="low 1 > high 0"):
        dataclasses.replace(m, uncertainty={k5: (1, 0)})
    assert dataclasses.replace(m, uncertainty={"k5": (0.9, 1)}).uncertainty[k5] == (sp.Rational(9, 10), 1)


def test_scenario_parameters_validation(uncertain):
    m, o = uncertain
    with pytest.raises(UsageError, match="parameter 'k9' is not a parameter"):
        simulate(m, o, scenario_from_dict({"steps": 3, "parameters": {"k9": 1}}))
    with pytest.raises(UsageError, match=r"leaves the model's declared uncertainty"):
        simulate(m, o, scenario_from_dict({"steps": 3, "parameters": {"k5": 0.9}}))
    with pytest.raises(UsageError, match="must be a number,"):
        scenario_from_dict({"steps": 3, "parameters": {"k5": "0.96"}})
    # the signals' realisations do not change when parameters are drawn
    base = {"steps": 5, "seed": 3, "signals": {"w2": {"uniform": [-0.01, 0.01]}}}
    a = simulate(m, o, scenario_from_dict(base), runs=3)
    b = simulate(m, o, scenario_from_dict({**base, "parameters": {"k5": {"uniform": [0.951, 0.969]}}}),
                 runs=3)
    assert np.array_equal(a["w2"], b["w2"])


def test_residual_generator_nonlinear_in_its_states_is_refused(drive):
    m, o = drive
    xs1 = o.states[0]
    bent = dataclasses.replace(o, update=(o.update[0] + xs1 ** 3 / 100,))
    with pytest.raises(UsageError, match="linear in its own states"):
        guaranteed_threshold(m, bent)
    # an observer that does not reproduce the plant (a wrong gain) has no fault-free band
    wrong = dataclasses.replace(o, update=(o.update[0] + sp.Symbol("y1") / 10,))
    with pytest.raises(UsageError, match="does not reproduce the plant"):
        guaranteed_threshold(m, wrong)
