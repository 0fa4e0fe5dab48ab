"""Process noise in the dynamics (x' = … + Bw w): extracted into Bw and certified, not
decoupled, bounded by interval observers and guaranteed thresholds, drawn in simulate and
ensemble (METHOD §1, §3).

The model is the electric drive of seed 000 §9 with a bounded torque ripple w3 on the speed
equation and w4 on the current equation (tests/process_noise_models.py).
"""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, build_observer, design, simulate
from observer_cad.errors import ModelError
from observer_cad.model import extract_structure
from observer_cad.observers import interval_observer
from observer_cad.residuals import guaranteed_threshold
from observer_cad.simulation import scenario_from_dict
from observer_cad.synthesis import design_jordan

from process_noise_models import PROCESS_NOISE, drive_with_process_noise, w3, w4, x1, x2

TOL = 1e-9
NOISE = ("w1", "w2", "w3", "w4")


@pytest.fixture(scope="module")
def drive():
    return drive_with_process_noise()


@pytest.fixture(scope="module")
def quiet():
    """The same model with the process noise's bounds at zero (w3, w4 still declared)."""
    return drive_with_process_noise(0)


def _signals(model, how):
    """Fault-free signals: u known, ρ and the noise ``"declared"`` (uniform over the box) or
    ``"extreme"`` (a square wave at ± the bound: the noise sits at its bounds)."""
    sig = {"u": "0.2*sin(t/10)", "rho": "declared"}
    for name in NOISE:
        if how == "declared":
            sig[name] = "declared"
        else:
            hi = float(model.bounds[model.symbol(name)][1])
            period = {"w1": 7, "w2": 11, "w3": 13, "w4": 17}[name]
            parity = f"(floor(t/{period}) - 2*floor(t/{2 * period}))"  # 0, 1, 0, 1, …
            sig[name] = f"{hi}*(1 - 2*{parity})"
    return sig


def _outside(res, name, lower, upper):
    for key in (name, lower, upper):
        assert np.all(np.isfinite(res[key])), key
    return int(np.sum((res[name] < res[lower] - TOL) | (res[name] > res[upper] + TOL)))


# ---------------------------------------------------------------- the model and its certificate

def test_process_noise_is_extracted_into_Bw_and_certified(drive):
    st = extract_structure(drive)
    assert st.Bw == sp.ImmutableMatrix([[0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 2]])
    assert st.W == sp.ImmutableMatrix([[1, 0, 0, 0], [0, 1, 0, 0]])
    cert = st.certificate
    assert "Bw w" in cert.IDENTITY and cert.exact
    assert len(cert.checks) == 5 and all(c.exact for c in cert.checks)
    # the rebuilt right-hand side carries the process noise (the identity is not vacuous)
    assert st.rhs()[1].has(w3) and st.rhs()[2].coeff(w4) == 2


def test_show_prints_Bw_only_for_process_noise(drive, models_dir):
    from observer_cad import load_model
    from observer_cad.reporting import format_structure, structure_to_json
    st = extract_structure(drive)
    text = format_structure(st)
    assert "+ L rho + Bw w," in text and "Bw = [ 0  0  0  0 ]" in text
    assert structure_to_json(st)["matrices"]["Bw"][2] == ["0", "0", "0", "2"]
    plain = extract_structure(load_model(models_dir / "electric_drive.py"))
    assert "Bw =" not in format_structure(plain)
    assert structure_to_json(plain)["matrices"]["Bw"] == [["0", "0"]] * 3


def test_a_structure_without_process_noise_has_a_zero_Bw(models_dir):
    from observer_cad import load_model
    m = load_model(models_dir / "electric_drive.py")
    st = extract_structure(m)
    assert st.Bw.shape == (3, 2) and st.Bw.is_zero_matrix


def test_process_noise_must_enter_linearly_with_a_constant_coefficient():
    with pytest.raises(ModelError, match="noise 'w3' enters with the coefficient x1"):
        extract_structure(PlantModel(name="bad", time="discrete", states=[x1], outputs=[x1],
                                     dynamics=[x1 / 2 + x1 * w3], noise=[w3]))
    with pytest.raises(ModelError, match="noise 'w4' is declared but appears in no output and"
                                         " no dynamics equation"):
        PlantModel(name="bad", time="discrete", states=[x1], outputs=[x1], dynamics=[x1 / 2],
                   noise=[w4])


def test_designs_are_certified_with_the_process_noise_at_zero(drive):
    d = design(drive, observer="diagnostic")
    assert d.certificate.passed
    assert any(i.name.startswith("model: ") and i.holds for i in d.certificate.identities)


# ---------------------------------------------------------------- interval observer

@pytest.fixture(scope="module")
def x2_observer(drive):
    """x2 with λ = 3/4: Φ Bw = (1, 0) on (w3, w4): the process noise w3 reaches x*."""
    return interval_observer(drive, design_jordan(drive, observer="interval", estimate="x2",
                                                  lambdas=[sp.Rational(3, 4)]))


def test_interval_observer_bounds_the_process_noise(drive, quiet, x2_observer):
    cond = {c.name: c for c in x2_observer.conditions}["unknown inputs bounded"]
    assert cond.holds and "Φ [L D Bw]" in cond.detail and "w3" in cond.detail
    q = interval_observer(quiet, design_jordan(quiet, observer="interval", estimate="x2",
                                               lambdas=[sp.Rational(3, 4)]))
    # the bounds' offset grows by max |Φ Bw w| = 1/500 per step
    xl1 = sp.Symbol("xl1")
    gap = sp.expand(q.update[0] - x2_observer.update[0])
    assert gap == PROCESS_NOISE[w3] and not gap.has(xl1)


@pytest.mark.parametrize("how", ["declared", "extreme"])
def test_interval_inclusion_with_bounded_process_noise(drive, x2_observer, how):
    """lower ≤ x2 ≤ upper at every sample of 40 seeded runs × 600 steps."""
    sc = scenario_from_dict({"steps": 600, "seed": 11, "initial": {"x1": 0, "x2": 0, "x3": 0},
                             "signals": {**_signals(drive, how), "d": "declared"}})
    res = simulate(drive, x2_observer, sc, runs=40)
    assert _outside(res, "x2", "x2_lower", "x2_upper") == 0
    assert np.ptp(res["w3"]) > 1.9 * float(PROCESS_NOISE[w3])  # the process noise was drawn


def test_interval_observer_ignoring_the_process_noise_is_violated(drive):
    """Companion check: the observer built for zero noise, on the plant with w3 held at its
    upper bound (ρ at its own, so the upper bound has no slack), leaves the trajectory: the
    inclusion test above is not vacuous."""
    silent = drive_with_process_noise(0, 0)
    q = interval_observer(silent, design_jordan(silent, observer="interval", estimate="x2",
                                                lambdas=[sp.Rational(3, 4)]))
    sig = {"u": "0.2*sin(t/10)", "rho": "0.05", "d": "0", "w1": "0", "w2": "0",
           "w3": str(float(PROCESS_NOISE[w3])), "w4": "0"}
    res = simulate(drive, q, scenario_from_dict({"steps": 400, "signals": sig}))
    assert _outside(res, "x2", "x2_lower", "x2_upper") > 0


# ---------------------------------------------------------------- guaranteed thresholds

@pytest.fixture(scope="module")
def residual(drive):
    return guaranteed_threshold(drive, build_observer(drive, design(drive, observer="diagnostic")))


def test_threshold_band_grows_by_the_process_noise(drive, quiet, residual):
    """Φ = [1 0 5], λ = 1/2: Φ Bw w = 10 w4, |w4| ≤ 1/1000 adds 1/100 per step to the error
    bound (0.028 from the measurement noise, seed 000 §9 values): 0.038; w3 is not seen."""
    q = guaranteed_threshold(quiet, build_observer(quiet, design(quiet, observer="diagnostic")))
    elo, ehi = sp.symbols("xs1_elo xs1_ehi")
    def exact(e):  # the magnitude-scaled roundoff allowance (its abs terms) set aside
        return e.replace(sp.Abs, lambda a: 0)

    eq = {s: exact(e) for s, e in zip(residual.states, residual.update)}
    eq0 = {s: exact(e) for s, e in zip(q.states, q.update)}
    assert sp.expand(eq[ehi] - (ehi / 2 + sp.Rational(19, 500))) == 0
    assert sp.expand(eq0[ehi] - (ehi / 2 + sp.Rational(7, 250))) == 0
    assert sp.expand(eq[elo] - (elo / 2 - sp.Rational(19, 500))) == 0
    cond = {c.name: c for c in residual.threshold.conditions}["process noise bounded"]
    assert cond.holds and "[[0, 10]]" in cond.detail and "w4 widen" in cond.detail
    # in simulation: the band with process noise is wider at every sample after the start
    sc = scenario_from_dict({"steps": 200, "signals": {"u": "0.2*sin(t/10)"}})
    wide, narrow = simulate(drive, residual, sc), simulate(quiet, q, sc)
    width = wide["r_upper"] - wide["r_lower"]
    width0 = narrow["r_upper"] - narrow["r_lower"]
    assert np.all(width[1:] > width0[1:] + 0.019)
    assert width[-1] == pytest.approx(2 * 0.038 / (1 - 0.5) + 2 * 0.06, abs=1e-8)


@pytest.mark.parametrize("how", ["declared", "extreme"])
def test_no_false_alarm_with_process_noise_at_its_bounds(drive, residual, how):
    """40 seeded fault-free runs × 600 steps: r never leaves [r_lower, r_upper]."""
    sc = scenario_from_dict({"steps": 600, "seed": 7, "initial": {"x1": 0, "x2": 0, "x3": 0},
                             "signals": _signals(drive, how)})
    res = simulate(drive, residual, sc, runs=40)
    assert _outside(res, "r", "r_lower", "r_upper") == 0
    assert np.max(np.abs(res["w4"])) > 0.99 * float(PROCESS_NOISE[w4])


def test_worst_case_process_noise_attains_the_band(drive, residual):
    """w4 = +1/1000 throughout and the measurement noise pushing the same way: the residual
    reaches r_upper (to 2e-9), so the band is tight and the process-noise term has its sign."""
    sig = {"u": "sin(t/7)", "rho": "0.05*cos(t)", "w3": "0.002*cos(t)",
           "w1": "Piecewise((-0.01, t < 60), (0.01, True))",
           "w2": "Piecewise((-0.01, t < 60), (0.01, True))",
           "w4": "Piecewise((0.001, t < 60), (0, True))"}
    res = simulate(drive, residual, scenario_from_dict({"steps": 61, "signals": sig}))
    assert _outside(res, "r", "r_lower", "r_upper") == 0
    assert res["r_upper"][60] - res["r"][60] == pytest.approx(0, abs=2e-9)


def test_continuous_time_threshold_bounds_the_process_noise():
    """A continuous first-order chain with process noise on x2: the guaranteed band of the
    diagnostic residual holds under noise at its bounds."""
    a, b = sp.symbols("a b")
    w = sp.Symbol("w")
    v = sp.Symbol("v")
    u, f = sp.symbols("u f")
    m = PlantModel(name="chain_noise", time="continuous", states=[a, b], inputs=[u],
                   faults=[f], noise=[w, v], outputs=[a + v, b],
                   dynamics=[-a + b + u, -2 * b + f + w],
                   bounds={w: (-0.1, 0.1), v: (-0.01, 0.01), f: (-1, 1)})
    o = guaranteed_threshold(m, build_observer(m, design(m, observer="diagnostic")))
    names = [c.name for c in o.threshold.conditions]
    assert "process noise bounded" in names
    sig = {"u": "sin(t)", "f": "0", "v": "declared",
           "w": "0.1*(1 - 2*(floor(t) - 2*floor(t/2)))"}
    res = simulate(m, o, scenario_from_dict({"t_end": 10, "dt": 0.001, "seed": 3,
                                             "signals": sig}), runs=5)
    assert _outside(res, "r", "r_lower", "r_upper") == 0


# ---------------------------------------------------------------- ensemble

@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                    reason="no C compiler")
def test_ensemble_draws_the_process_noise_and_has_no_false_alarm(drive, residual):
    from observer_cad.ensemble import Backend, run_ensemble
    sc = scenario_from_dict({"steps": 400, "seed": 5, "signals": _signals(drive, "declared")})
    res = run_ensemble(drive, residual, sc, runs=30, backend=Backend("serial"), keep=1)
    fields = res.statistics.overall.fields
    assert fields["r.exceedances"].positive == 0
    (_, _, _, worst), = res.kept
    assert np.ptp(worst["w3"]) > 1.9 * float(PROCESS_NOISE[w3])
    assert _outside(worst, "r", "r_lower", "r_upper") == 0


def test_a_noise_column_of_B_from_statespace_is_process_noise():
    """PlantModel.from_statespace: a noise column of B enters Bw, of D enters W."""
    A = [[0, 1], [-2, -3]]
    B = [[0, 0, 1], [1, 1, 0]]
    C = [[1, 0]]
    D = [[0, 0, 1]]
    m = PlantModel.from_statespace((A, B, C, D), inputs=[0], noise=[1, 2], time="continuous",
                                   name="ss_noise")
    st = extract_structure(m)
    assert st.Bw == sp.ImmutableMatrix([[0, 1], [1, 0]])
    assert st.W == sp.ImmutableMatrix([[0, 1]])
    assert st.certificate.exact


def test_sliding_mode_gain_bound_covers_the_process_noise(models_dir):
    """sliding_example (x* = x2 − x3) with process noise w3 on tank 2, |w3| ≤ 1/10: the
    bound on k1 grows by |Φ_1 Bw| w* = 0.1 (1.07 without it)."""
    from observer_cad import load_model
    from observer_cad.synthesis import gain_bound
    m = load_model(models_dir / "sliding_example.py")
    w = sp.Symbol("w3")
    dyn = list(m.dynamics)
    dyn[1] = dyn[1] + w
    noisy = PlantModel(name="sliding_noise", time="continuous", states=m.states,
                       inputs=m.inputs, faults=m.faults, disturbances=m.disturbances,
                       noise=tuple(m.noise) + (w,), outputs=m.outputs, dynamics=dyn,
                       bounds={**m.bounds, w: (-sp.Rational(1, 10), sp.Rational(1, 10))})
    base = gain_bound(m, design(m, observer="sliding-mode", faults=["d"]))
    gb = gain_bound(noisy, design(noisy, observer="sliding-mode", faults=["d"]))
    terms = {t.name: t.value for t in gb.terms}
    assert terms["w*|Φ_1 Bw|"] == pytest.approx(0.1)
    assert gb.bound == pytest.approx(base.bound + 0.1)


def _chain():
    """Continuous chain a' = −a + b + w, b' = −2 b + u + w/2, y = b + v: w is process noise
    (two equations), v measurement noise."""
    a, b, u, w, v = sp.symbols("a b u w v")
    return PlantModel(name="ct_noise", time="continuous", states=[a, b], inputs=[u],
                      noise=[w, v], outputs=[b + v], dynamics=[-a + b + w, -2 * b + u + w / 2],
                      bounds={w: (-sp.Rational(1, 5), sp.Rational(1, 5)),
                              v: (-sp.Rational(1, 100), sp.Rational(1, 100))})


def test_continuous_interval_inclusion_with_process_noise():
    """x* = a, F* = −1: the bounds carry ∓ (|Φ Bw| w* = 1/5) + (the noise through y, 1/100)."""
    m = _chain()
    o = interval_observer(m, design_jordan(m, observer="interval", estimate="a"))
    assert [str(e) for e in o.update] == ["-xl1 + y1 - 21/100", "-xu1 + y1 + 21/100"]
    sc = scenario_from_dict({"t_end": 10, "dt": 0.001, "seed": 2,
                             "initial": {"a": 0.5, "b": 0},
                             "signals": {"u": "sin(t)", "v": "declared",
                                         "w": "0.2*(1 - 2*(floor(t) - 2*floor(t/2)))"}})
    res = simulate(m, o, sc, runs=5)
    assert _outside(res, "a", "a_lower", "a_upper") == 0


def test_one_draw_drives_both_uses_of_a_noise_symbol():
    """w1 in the output and in the dynamics: the simulated plant uses the same sample in both
    (discrete: x(t+1) = x/2 + w(t), y(t) = x(t) + w(t))."""
    x, w = sp.symbols("x w1")
    m = PlantModel(name="both", time="discrete", states=[x], outputs=[x + w],
                   dynamics=[x / 2 + w], noise=[w], bounds={w: (-1, 1)})
    assert extract_structure(m).Bw == sp.ImmutableMatrix([[1]])
    res = simulate(m, None, scenario_from_dict({"steps": 50, "seed": 9,
                                                "signals": {"w1": "declared"}}), runs=3)
    assert np.ptp(res["w1"]) > 1
    assert np.array_equal(res["y1"], res["x"] + res["w1"])
    assert np.allclose(res["x"][:, 1:], res["x"][:, :-1] / 2 + res["w1"][:, :-1], atol=0, rtol=0)


def test_discrete_unknown_input_estimator_reports_the_process_noise(drive):
    """The seed 000 estimator of d (Φ = (0, 0, 1) sees w4 through Bw) says that the process
    noise reaches its estimate; the model without process noise has no such condition."""
    o = build_observer(drive, design(drive, observer="unknown-input", faults=["d"]))
    cond = {c.name: c for c in o.conditions}["process noise not decoupled"]
    assert not cond.holds and not cond.required and "Φ Bw" in cond.detail
    from observer_cad import load_model
    from pathlib import Path
    plain = load_model(Path(__file__).resolve().parents[2] / "models" / "electric_drive.py")
    names = [c.name for c in build_observer(plain, design(plain, observer="unknown-input",
                                                          faults=["d"])).conditions]
    assert "process noise not decoupled" not in names


def test_interval_observer_needs_the_process_noise_bounds(drive):
    """An unbounded process noise that reaches x* is named (one line)."""
    bounds = {s: b for s, b in drive.bounds.items() if s != w3}
    m = PlantModel(name=drive.name, time=drive.time, states=drive.states, inputs=drive.inputs,
                   faults=drive.faults, disturbances=drive.disturbances, noise=drive.noise,
                   outputs=drive.outputs, dynamics=drive.dynamics, parameters=drive.parameters,
                   bounds=bounds)
    with pytest.raises(ModelError, match="bounds on the process noise 'w3'"):
        interval_observer(m, design_jordan(m, observer="interval", estimate="x2",
                                           lambdas=[sp.Rational(3, 4)]))
