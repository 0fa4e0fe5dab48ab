"""Unknown-input estimators of seed 000 (observer_cad.uio): derived formulas, checked by
the computer algebra and on simulated trajectories.

What is checked against what
----------------------------
* The estimate is checked against the true input of the simulation (not against a formula).
* The k = 1 estimate is compared with the direct inversion D*⁻¹(y*(t+1) − J* y(t) − G* u(t))
  computed here in numpy from the PAPER's reduced model (seed 000 §9: R* = (−k4, k1),
  J* = (−k4, k1 k5), G* = k1 k6, D* = k1, checked against the defining identities in
  test_seed000.py), not from the derived formula.
* The CAS identity is rebuilt here from the observer's own update equations.
"""
import dataclasses
import math

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, design_canonical, load_model
from observer_cad.errors import InfeasibleDesignError, ObserverCadError, UsageError
from observer_cad.simulation import load_scenario, scenario_from_dict, simulate
from observer_cad.observers import ALPHA, ALPHA_PREV, combine_observers, default_gains, derive_estimate, unknown_input_observer, vector_unknown_input_observer
from observer_cad.synthesis import design_jordan_unknown_input

R = sp.Rational
k1, k2, k3, k4, k5, k6 = sp.symbols("k1:7")
x1, x2, x3, u, d, d1, d2, rho = sp.symbols("x1 x2 x3 u d d1 d2 rho")
TOL = 1e-9


@pytest.fixture(scope="module")
def drive(models_dir):
    return load_model(models_dir / "electric_drive.py")


@pytest.fixture(scope="module")
def scen(models_dir):
    return lambda name: load_scenario(models_dir / "scenarios" / f"{name}.json")


@pytest.fixture(scope="module")
def d_designs(drive):
    return {sym: design_canonical(drive, unknown_input="d", symbolic=sym) for sym in (False, True)}


@pytest.fixture(scope="module")
def rho_design(drive):
    return design_canonical(drive, unknown_input="rho", symbolic=True)


def _valid(v, delay):
    """Rows that hold an estimate (the last `delay` rows are NaN after the shift)."""
    assert np.all(np.isnan(v[len(v) - delay:]))
    out = v[:len(v) - delay]
    assert np.all(np.isfinite(out))
    return out


def _paper_fault_model(model):
    """Seed 000 §9's reduced model for d, at the model's default parameters (numpy)."""
    p = {s: float(v) for s, v in model.parameters.items()}
    K1, K4, K5, K6 = p[k1], p[k4], p[k5], p[k6]
    return np.array([-K4, K1]), np.array([-K4, K1 * K5]), K1 * K6, K1


# ---------------------------------------------------------------- (1) k = 1, Fig. 1 / 2
@pytest.mark.parametrize("fig", ["electric_drive_fig1", "electric_drive_fig2"])
@pytest.mark.parametrize("symbolic", [False, True])
def test_fault_estimate_exact_fig1_fig2(drive, d_designs, scen, fig, symbolic):
    des = d_designs[symbolic]
    assert des.k == 1
    obs = unknown_input_observer(drive, des)
    assert obs.kind == "unknown-input" and obs.time == "discrete"
    assert obs.delays == {"d_hat": 1}
    assert obs.parameters[sp.Symbol("g")] == R(-7, 10)
    par = {str(k): v for k, v in obs.parameters.items()}
    assert (par["d_min"], par["d_max"]) == (R(-2, 5), R(2, 5))
    sc = scen(fig)
    res = simulate(drive, obs, sc)
    dhat = _valid(res["d_hat"], 1)
    dtrue = res["d"][:-1]
    assert np.std(res["rho"]) > 0.02  # the disturbance is active
    assert np.max(np.abs(dtrue)) > 0.45  # and d leaves the declared bounds [-0.4, 0.4]
    err = np.abs(dhat - dtrue)
    assert err[1:].max() < TOL, err.max()  # every t >= 1 (t = 0 as well)
    assert err.max() < TOL


def test_fig2_signal_switches_to_seeded_uniform(drive, scen):
    res = simulate(drive, None, scen("electric_drive_fig2"))
    t, dv = res["t"], res["d"]
    assert np.allclose(dv[t <= 20], 0.3 * np.sin(t[t <= 20] / 2))
    late = dv[t > 20]
    assert late.min() >= -0.5 and late.max() < 0.5 and late.std() > 0.2


# ---------------------------------------------------------------- (2) = direct inversion
@pytest.mark.parametrize("symbolic", [False, True])
def test_fault_estimate_equals_direct_inversion(drive, d_designs, scen, symbolic):
    obs = unknown_input_observer(drive, d_designs[symbolic])
    res = simulate(drive, obs, scen("electric_drive_fig2"))
    Rs, Js, Gs, Ds = _paper_fault_model(drive)
    Y = np.stack([res["y1"], res["y2"]])
    ystar = Rs @ Y
    direct = (ystar[1:] - Js @ Y[:, :-1] - Gs * res["u"][:-1]) / Ds
    dhat = _valid(res["d_hat"], 1)
    scale = max(1.0, np.max(np.abs(direct)))
    assert np.max(np.abs(dhat - direct)) < TOL * scale


# ---------------------------------------------------------------- (3) the CAS identity
def test_cas_identity_k1(drive, d_designs):
    des = d_designs[True]
    der = derive_estimate(drive, des)
    assert der.exact and der.delay == 1 and der.row == 1
    assert der.residual == 0
    assert der.formula.has(ALPHA)  # the α form, not the inversion typed in
    # rebuild independently: α(t+1) from the observer's own update equations
    obs = unknown_input_observer(drive, des)
    st = {str(s): s for s in obs.states}
    y1, y2 = sp.symbols("y1 y2")
    lag = {y1: st["y1_lag1"], y2: st["y2_lag1"], u: sp.Symbol("u_lag1"),
           st["xl1"]: st["xl1_lag1"], st["xu1"]: st["xu1_lag1"]}
    upd = dict(zip(obs.states, obs.update))
    xl_next = upd[st["xl1"]].xreplace(lag)  # x̲(t+1) in values at t
    xu_next = upd[st["xu1"]].xreplace(lag)
    ystar_next = -k4 * y1 + k1 * y2  # the paper's R* (any nonzero multiple works)
    ystar_next_ours = (des.matrices.R_star * sp.Matrix([y1, y2]))[0, 0]
    alpha = (ystar_next_ours - xl_next) / (xu_next - xl_next)
    est = der.formula.xreplace(der.bound_terms).xreplace({ALPHA: alpha}).xreplace(
        {sp.Symbol("u"): sp.Symbol("u_lag1")})
    # the paper's direct inversion D*⁻¹(y*(t+1) − J* y(t) − G* u(t))
    direct = (ystar_next - (-k4 * lag[y1] + k1 * k5 * lag[y2]) - k1 * k6 * lag[u]) / k1
    diff = sp.simplify(sp.cancel(sp.together(est - direct)))
    assert diff == 0, diff


def test_printed_formula_4_6_has_swapped_weights(drive, d_designs, scen):
    """Seed 000 (4.6) as printed pairs α with the lower bound; (4.4) pairs it with the
    upper one. The derived formula is exact; the printed one is not."""
    des = d_designs[False]
    obs = unknown_input_observer(drive, des)
    xl1, xu1 = sp.symbols("xl1 xu1")
    obs2 = dataclasses.replace(obs, outputs=obs.outputs + (("xl", xl1), ("xu", xu1)))
    res = simulate(drive, obs2, scen("electric_drive_fig1"))
    Dn = float(des.matrices.D_star[0, 0])
    Rn = np.array(des.matrices.R_star, dtype=float)[0]
    ys = Rn[0] * res["y1"] + Rn[1] * res["y2"]
    xl, xu = res["xl"], res["xu"]
    a = (ys[1:] - xl[1:]) / (xu[1:] - xl[1:])
    el, eu = ys[:-1] - xl[:-1], ys[:-1] - xu[:-1]
    g, blo, bhi = -0.7, min(Dn * -0.4, Dn * 0.4), max(Dn * -0.4, Dn * 0.4)
    printed = (g * (a * el + (1 - a) * eu) + a * blo + (1 - a) * bhi) / Dn
    assert np.max(np.abs(printed - res["d"][:-1])) > 0.1
    assert np.max(np.abs(_valid(res["d_hat"], 1) - res["d"][:-1])) < TOL


# ---------------------------------------------------------------- (4) ρ, mismatched k = 2
def test_rho_design_is_mismatched(drive, rho_design):
    des = rho_design
    assert des.k == 2
    assert des.matrices.D_star[0, 0] == 0 and des.matrices.D_star[1, 0] != 0
    # seed 000 §9: y* = y1, J*_1 = (0, K), K = k1 (1 + k2) / k4
    assert list(des.matrices.R_star) == [1, 0]
    assert sp.cancel(des.matrices.J_star[0, 1] - k1 * (1 + k2) / k4) == 0
    der = derive_estimate(drive, des)
    assert der.delay == 2 and der.row == 2 and der.exact and der.residual == 0


def test_rho_estimate_fig3_exact_after_delay(drive, rho_design, scen):
    obs = unknown_input_observer(drive, rho_design, bounds={"rho": (-0.2, 0.2)})
    assert obs.delays == {"rho_hat": 2}
    g1, g2 = sp.symbols("g1 g2")
    assert (obs.parameters[g1], obs.parameters[g2]) == (R(-2, 5), R(-1, 10))
    assert obs.parameters[sp.Symbol("rho_max")] == R(1, 5)
    res = simulate(drive, obs, scen("electric_drive_rho_fig3"))
    err = np.abs(_valid(res["rho_hat"], 2) - res["rho"][:-2])
    # tolerance 1e-9 on every estimate: ρ(t) is estimated at step t + 2 (delay 2), and
    # the mismatched formula has no unmeasured state, so it is exact from t = 0
    assert err.max() < TOL, err.max()
    assert np.max(res["rho"]) == 1.0  # rho leaves the bound 0.2: the estimate does not care


def test_rho_estimate_fig4_noise_bounded(drive, rho_design, scen):
    obs = unknown_input_observer(drive, rho_design, bounds={"rho": (-0.2, 0.2)})
    res = simulate(drive, obs, scen("electric_drive_rho_fig4"))
    err = _valid(res["rho_hat"], 2) - res["rho"][:-2]
    # the estimate is the direct inversion of the noisy outputs: its error is
    # D2⁻¹ (R* w(t+2) − J*_1 w(t+1) − J*_2 w(t)) — computed here from the design's matrices
    p = {s: v for s, v in drive.parameters.items()}
    num = lambda M: np.array(sp.Matrix(M).xreplace(p), dtype=float)  # noqa: E731
    Rn, Jn, Dn = num(rho_design.matrices.R_star)[0], num(rho_design.matrices.J_star), \
        num(rho_design.matrices.D_star)[1, 0]
    W = np.stack([res["w1"], res["w2"]])
    pred = (Rn @ W[:, 2:] - Jn[0] @ W[:, 1:-1] - Jn[1] @ W[:, :-2]) / Dn
    assert np.max(np.abs(err - pred)) < 1e-6 * max(1.0, np.max(np.abs(pred)))
    bound = 0.01 * (np.abs(Rn).sum() + np.abs(Jn).sum()) / abs(Dn)
    assert np.max(np.abs(err)) <= bound * (1 + 1e-9)  # bounded (loose: about 98)
    assert np.max(np.abs(err)) > 1.0  # visibly worse than without noise (1e-9)


# ---------------------------------------------------------------- (5) k > 1, matched
def _matched2(nonlinear=False):
    return PlantModel(
        name="matched2", time="discrete", states=[x1, x2, x3], inputs=[u], faults=[d],
        disturbances=[rho], outputs=[x1],
        dynamics=[R(1, 2) * x1 + x2 + d,
                  R(1, 5) * x1 + u + (R(1, 10) * sp.sin(x2) if nonlinear else 0),
                  R(1, 10) * x1 + R(1, 2) * x3 + rho],
        bounds={d: (-1, 1), rho: (-0.5, 0.5)})


_M2_SCEN = {"steps": 60, "seed": 3, "initial": {"x1": 0.5, "x2": -1, "x3": 2},
            "observer_initial": {"xl1": -2, "xu1": 3, "xl2": 4, "xu2": -3},
            "signals": {"u": "sin(t/3)", "d": "Piecewise((0.5*sin(t/2), t <= 20), (0.8, True))",
                        "rho": {"uniform": [-0.5, 0.5]}}}


def test_matched_k2_linear_exact_after_k_minus_1_steps():
    m = _matched2()
    des = design_canonical(m, unknown_input="d")
    assert des.k == 2 and des.matrices.D_star[1, 0] == 0 and des.matrices.D_star[0, 0] != 0
    der = derive_estimate(m, des)
    assert not der.exact and der.delay == 1 and len(der.unknown_states) == 1
    obs = unknown_input_observer(m, des)
    assert [obs.parameters[s] for s in sp.symbols("g1 g2")] == default_gains("canonical", 2, 0)
    err = np.abs(_valid(simulate(m, obs, scenario_from_dict(_M2_SCEN))["d_hat"], 1)
                 - simulate(m, None, scenario_from_dict(_M2_SCEN))["d"][:-1])
    assert err[0] > 0.1  # the copies start away from the model
    assert err[1:].max() < TOL  # g** = 0: copies equal the model after k − 1 = 1 step


def test_matched_k2_nonlinear_converges():
    m = _matched2(nonlinear=True)
    des = design_canonical(m, unknown_input="d")
    assert des.k == 2 and des.nonlinear
    obs = unknown_input_observer(m, des)
    res = simulate(m, obs, scenario_from_dict(_M2_SCEN))
    err = np.abs(_valid(res["d_hat"], 1) - res["d"][:-1])
    assert err[0] > 0.1
    assert err[15:].max() < TOL  # asymptotic: sin(x2)/10 contracts the copies' error
    assert np.all(np.diff(np.log10(err[1:10] + 1e-300)) < 0)  # decreasing


def test_matched_k2_nonzero_later_gain_leaves_error():
    """The paper's (5.1) with g** ≠ 0: the unmeasured rows are driven by e(t) = y* − x̲_1,
    which never vanishes, so the estimate does not converge (reported as a condition)."""
    m = _matched2()
    des = design_canonical(m, unknown_input="d")
    obs = unknown_input_observer(m, des, g=[-0.5, -0.1])
    cond = [c for c in obs.conditions if c.name.startswith("gains after")]
    assert cond and not cond[0].holds
    res = simulate(m, obs, scenario_from_dict(_M2_SCEN))
    err = np.abs(_valid(res["d_hat"], 1) - res["d"][:-1])
    assert err[30:].max() > 1e-3


# ---------------------------------------------------------------- (6) Jordan variant
def _nl_drive():
    """A small drive-like system with a nonlinearity in the measured x1."""
    return PlantModel(
        name="nl1", time="discrete", states=[x1, x2, x3], inputs=[u], faults=[d],
        disturbances=[rho], outputs=[x1, x3],
        dynamics=[x1 + R(1, 10) * x2, R(4, 5) * x2 + R(1, 50) * x3 + rho,
                  -R(1, 100) * x2 + R(9, 10) * x3 + R(1, 20) * u - R(1, 10) * sp.sin(x1) + d],
        bounds={d: (-0.5, 0.5), rho: (-0.1, 0.1)})


_NL_SCEN = {"steps": 80, "seed": 5, "initial": {"x1": 0.5, "x2": -1, "x3": 2},
            "observer_initial": {"xl1": -1, "xu1": 1},
            "signals": {"u": "sin(t/3)", "d": "0.5*sin(t/2)", "rho": {"uniform": [-0.1, 0.1]}}}


@pytest.mark.parametrize("symbolic", [False, True])
def test_jordan_variant_electric_drive(drive, scen, symbolic):
    lam = R(1, 2)
    des = design_jordan_unknown_input(drive, "d", lam, symbolic=symbolic)
    assert des.form == "jordan" and des.k == 1 and des.matrices.F_star[0, 0] == lam
    der = derive_estimate(drive, des)
    assert der.formula.has(ALPHA) and der.formula.has(ALPHA_PREV)
    assert der.lambda_term_verified and der.residual == 0
    # the λ term: D*⁻¹ λ (x̄(t) − x̲(t)) (α(t+1) − α(t))
    xl, xu = sp.Symbol("xl1_lag1"), sp.Symbol("xu1_lag1")
    Ds = des.matrices.D_star[0, 0]
    assert sp.cancel(der.lambda_term - lam * (xu - xl) * (ALPHA - ALPHA_PREV) / Ds) == 0
    obs = unknown_input_observer(drive, des)
    assert obs.parameters[sp.Symbol("g")] == lam - R(7, 10)
    res = simulate(drive, obs, scen("electric_drive_fig1"))
    assert np.max(np.abs(_valid(res["d_hat"], 1) - res["d"][:-1])) < TOL


def test_jordan_variant_nonlinear_small_system():
    m = _nl_drive()
    des = design_jordan_unknown_input(m, "d", R(3, 10))
    assert des.nonlinear
    der = derive_estimate(m, des)
    assert der.lambda_term_verified and der.residual == 0
    obs = unknown_input_observer(m, des)
    res = simulate(m, obs, scenario_from_dict(_NL_SCEN))
    assert np.max(np.abs(_valid(res["d_hat"], 1) - res["d"][:-1])) < TOL


# ---------------------------------------------------------------- nonlinear k = 1 (§6)
def test_nonlinear_k1_exact():
    m = _nl_drive()
    des = design_canonical(m, unknown_input="d")
    assert des.k == 1 and des.nonlinear
    der = derive_estimate(m, des)
    assert der.exact and der.residual == 0
    assert der.direct.has(sp.sin)  # C* Ψ*(y*) is part of the inversion
    obs = unknown_input_observer(m, des)
    assert any(e.has(sp.sin) for e in obs.update)
    res = simulate(m, obs, scenario_from_dict(_NL_SCEN))
    assert np.max(np.abs(_valid(res["d_hat"], 1) - res["d"][:-1])) < TOL


# ---------------------------------------------------------------- (7) vector d
def _vector_model():
    return PlantModel(
        name="vec", time="discrete", states=[x1, x2, x3], inputs=[u], faults=[d1, d2],
        outputs=[x1, x3],
        dynamics=[R(1, 2) * x1 + R(1, 5) * x3 + R(1, 10) * u + d1,
                  R(3, 10) * x1 + d2,
                  R(1, 10) * x1 + R(1, 2) * x2 + R(3, 5) * x3 + R(1, 20) * u],
        bounds={d1: (-1, 1), d2: (-1, 1)})


def test_vector_unknown_input():
    m = _vector_model()
    obs = vector_unknown_input_observer(m)
    assert [n for n, _ in obs.outputs] == ["d1_hat", "d2_hat"]
    assert obs.delays == {"d1_hat": 1, "d2_hat": 2}  # d2 is mismatched (k = 2)
    names = {str(s) for s in obs.parameters}
    assert {"d1_g", "d2_g1", "d2_g2"} <= names and "g" not in names
    assert all(str(s).startswith(("d1_", "d2_")) for s in obs.states)
    sc = scenario_from_dict({"steps": 60, "seed": 7, "initial": {"x1": 0.5, "x2": -1, "x3": 2},
                             "signals": {"u": "sin(t/3)", "d1": "0.5*sin(t/2)",
                                         "d2": {"uniform": [-1, 1]}}})
    res = simulate(m, obs, sc)
    assert np.max(np.abs(_valid(res["d1_hat"], 1) - res["d1"][:-1])) < TOL
    assert np.max(np.abs(_valid(res["d2_hat"], 2) - res["d2"][:-2])) < TOL


def test_vector_unknown_input_jordan_form():
    """form="jordan" (the one-row λ-model per component) was a NameError; d1 has a
    one-row estimator, which tracks d1 exactly after its delay; d2 (mismatched) has none
    with one row, and the refusal names it."""
    m = _vector_model()
    obs = vector_unknown_input_observer(m, ["d1"], form="jordan", lambdas={"d1": R(1, 4)})
    assert [n for n, _ in obs.outputs] == ["d1_hat"] and obs.delays == {"d1_hat": 1}
    sc = scenario_from_dict({"steps": 60, "seed": 7, "initial": {"x1": 0.5, "x2": -1, "x3": 2},
                             "signals": {"u": "sin(t/3)", "d1": "0.5*sin(t/2)",
                                         "d2": {"uniform": [-1, 1]}}})
    res = simulate(m, obs, sc)
    assert np.max(np.abs(_valid(res["d1_hat"], 1) - res["d1"][:-1])) < TOL
    with pytest.raises(InfeasibleDesignError, match="d2"):
        vector_unknown_input_observer(m, form="jordan")
    with pytest.raises(UsageError, match="form must be"):
        vector_unknown_input_observer(m, form="diagonal")


def test_combine_observers_matches_separate_ones(drive, d_designs, rho_design, scen):
    """Joining two estimators changes nothing: same outputs as run separately."""
    a = unknown_input_observer(drive, d_designs[False])
    b = unknown_input_observer(drive, design_jordan_unknown_input(drive, "d", R(1, 4)))
    with pytest.raises(UsageError, match="twice"):  # the same output name twice
        combine_observers({"c": a, "j": b})
    sc = scen("electric_drive_fig1")
    sc = dataclasses.replace(sc, observer_initial={"c_xl1": -1, "c_xu1": 1,
                                                   "j_xl1": -1, "j_xu1": 1})
    b2 = dataclasses.replace(b, outputs=(("d_hat_jordan", b.outputs[0][1]),),
                             delays={"d_hat_jordan": 1})
    both = combine_observers({"c": a, "j": b2})
    res = simulate(drive, both, sc)
    assert np.max(np.abs(_valid(res["d_hat"], 1) - _valid(res["d_hat_jordan"], 1))) < TOL


# ---------------------------------------------------------------- degenerate α, errors
def test_degenerate_alpha_denominator_does_not_crash(drive, d_designs, scen):
    des = d_designs[False]
    obs = unknown_input_observer(drive, des, g=0, bounds={"d": (0.1, 0.1)})
    cond = [c for c in obs.conditions if c.name.startswith("bounds d_min")]
    assert cond and not cond[0].holds
    with np.errstate(all="raise"):  # no division by zero, no invalid value
        res = simulate(drive, obs, scen("electric_drive_fig1"))
    dhat = _valid(res["d_hat"], 1)  # finite everywhere: the guard acted (width exactly 0)
    assert np.allclose(dhat, 0.1)  # and the "estimate" is the bound: no information left


def test_wrong_inputs(drive, d_designs, rho_design, models_dir):
    with pytest.raises(ObserverCadError, match="g must have 2"):
        unknown_input_observer(drive, rho_design, g=[-0.4])
    three = load_model(models_dir / "three_tank_linear.py")
    if three.time != "discrete":
        des = design_canonical(three, unknown_input=three.disturbances[-1].name)
        # continuous time: the discrete-time gains are refused; the filtered estimator is built
        with pytest.raises(ObserverCadError, match="discrete-time estimator"):
            unknown_input_observer(three, des, g=-0.7)
        assert unknown_input_observer(three, des).time == "continuous"


def test_observer_json_and_no_wallclock(drive, d_designs):
    obs = unknown_input_observer(drive, d_designs[True])
    js = obs.to_json()
    assert js["kind"] == "unknown-input" and js["delays"] == {"d_hat": 1}
    assert "k1" in js["parameters"] and "d_hat" in js["outputs"]
    assert math.isclose(float(sp.sympify(js["parameters"]["alpha_eps"])), 1e-12)


def test_approximate_design_error_bounded_by_residual():
    """A robust (approximate, METHOD §2d) design: L* ρ is not decoupled; the estimate's
    error is D*⁻¹ L* ρ(t), bounded by |L*/D*| ρ*."""
    from observer_cad.synthesis import design_robust_canonical
    m = PlantModel(
        name="rob", time="discrete", states=[x1, x2, x3], inputs=[u], faults=[d],
        disturbances=[rho], outputs=[x1, x3],
        dynamics=[R(1, 2) * x1 + R(1, 5) * x2 + d + R(1, 100) * rho,
                  R(3, 10) * x1 + R(1, 2) * x2 + u + rho,
                  R(1, 10) * x1 + R(1, 5) * x2 + R(1, 2) * x3 + R(1, 50) * rho],
        bounds={d: (-1, 1), rho: (-0.1, 0.1)})
    des = design_robust_canonical(m, unknown_input="d")
    assert des.approximate and des.k == 1
    obs = unknown_input_observer(m, des)
    cond = [c for c in obs.conditions if c.name.startswith("approximate")]
    assert cond and not cond[0].holds
    sc = scenario_from_dict({"steps": 60, "seed": 3, "signals": {
        "u": "sin(t/3)", "d": "0.5*sin(t/2)", "rho": {"uniform": [-0.1, 0.1]}}})
    res = simulate(m, obs, sc)
    err = _valid(res["d_hat"], 1) - res["d"][:-1]
    ratio = float(des.matrices.L_star[0, 0]) / float(des.matrices.D_star[0, 0])
    assert np.max(np.abs(err - ratio * res["rho"][:-1])) < TOL
    assert np.max(np.abs(err)) <= abs(ratio) * 0.1 + TOL
