"""Interval, unknown-input and sliding-mode observers on plants whose outputs carry inputs,
faults and disturbances (y = H x + Gy u + Dy d + Ly ρ + W w, METHOD §2 and §3 with output
feedthrough): each design is certified and simulated, each refusal is one line."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, build_observer, design, simulate
from observer_cad.errors import InfeasibleDesignError, ModelError
from observer_cad.simulation import scenario_from_dict

R = sp.Rational
ROOT = Path(__file__).resolve().parents[2]
TOL = 1e-9
x1, x2, x3, u, fa, fs, rho, w1, w2 = sp.symbols("x1 x2 x3 u fa fs rho w1 w2")
BOUNDS = {fa: (-R(1, 20), R(1, 20)), fs: (-R(1, 10), R(1, 10)), rho: (-R(1, 5), R(1, 5)),
          w1: (-R(1, 50), R(1, 50)), w2: (-R(1, 50), R(1, 50))}


def _interval_plant(time: str, fs_bound=R(1, 10)) -> PlantModel:
    """Three states, two sensors: y1 carries the input (u/4) and a sensor bias fs, y2 the
    disturbance ρ/2; both measurement noise. z = x3 is not measured."""
    dyn = ([x1 / 2 + x2 / 4 + u + fa, x2 / 3 + u / 2 + rho, x1 / 4 + x3 / 2]
           if time == "discrete" else
           [-x1 + x2 / 4 + u + fa, -x2 + u / 2 + rho, x1 / 4 - 2 * x3 + x2])
    return PlantModel(name=f"interval_feedthrough_{time}", time=time, states=[x1, x2, x3],
                      inputs=[u], faults=[fa, fs], disturbances=[rho], noise=[w1, w2],
                      outputs=[x1 + u / 4 + fs + w1, x2 + rho / 2 + w2], dynamics=dyn,
                      bounds={**BOUNDS, fs: (-fs_bound, fs_bound)})


def _outside(res, name):
    lo, hi = res[f"{name}_lower"], res[f"{name}_upper"]
    for a in (res[name], lo, hi):
        assert np.all(np.isfinite(a))
    return int(np.sum((res[name] < lo - TOL) | (res[name] > hi + TOL)))


# ---------------------------------------------------------------- interval observers

@pytest.mark.parametrize("time", ["discrete", "continuous"])
def test_interval_observer_reads_y_minus_Gy_u_and_bounds_the_outputs_inputs(time):
    """The observer reads y − Gy u (u/4 of y1 removed exactly: the −u/16 of the discrete
    row is (Φ G − J* Gy) u + J* Gy u … with J* = (1/4, 0)); the bias fs and, in continuous
    time, ρ/2 of y2 widen the bounds like the noise."""
    m = _interval_plant(time)
    d = design(m, observer="interval", estimate="x3")
    assert d.certificate.passed
    names = [i.name for i in d.certificate.identities]
    assert "Phi G - J* Gy - G*" in names and "Phi L - L*" in names
    o = build_observer(m, d)
    lo, hi = (str(e) for e in o.update)
    if time == "discrete":  # x3(t+1) = x3/2 + x1/4, x1 = y1 − u/4 − fs − w1
        assert (lo, hi) == ("-u/16 + xl1/2 + y1/4 - 3/100", "-u/16 + xu1/2 + y1/4 + 3/100")
    else:  # x3' = −2 x3 + x1/4 + x2: (fs + w1)/4 + (ρ/2 + w2) = 3/20
        assert (lo, hi) == ("-u/16 - 2*xl1 + y1/4 + y2 - 3/20",
                            "-u/16 - 2*xu1 + y1/4 + y2 + 3/20")
    cond = {c.name: c for c in o.conditions}["inputs of the outputs bounded"]
    assert cond.holds and "fs" in cond.detail


@pytest.mark.parametrize("time", ["discrete", "continuous"])
def test_interval_inclusion_on_a_plant_with_feedthrough(time):
    """lower ≤ x3 ≤ upper at every sample, with u, fa, fs, ρ and the noise all acting."""
    m = _interval_plant(time)
    o = build_observer(m, design(m, observer="interval", estimate="x3"))
    grid = {"steps": 400} if time == "discrete" else {"t_end": 6, "dt": 0.002}
    sig = {"u": "0.5*sin(t/7)", "fa": "declared", "fs": "declared", "rho": "declared",
           "w1": "declared", "w2": "declared"}
    if time == "continuous":
        sig.update(u="0.5*sin(t)", fs="0.1*sin(3*t)", rho="0.2*cos(2*t)")
    sc = scenario_from_dict({**grid, "seed": 5, "signals": sig,
                             "initial": {"x1": 0.3, "x2": -0.2, "x3": 0.1}})
    res = simulate(m, o, sc, runs=6 if time == "discrete" else 2)
    assert np.ptp(res["fs"]) > 0.1 and np.ptp(res["u"]) > 0.5  # both acted
    assert _outside(res, "x3") == 0


@pytest.mark.parametrize("form", ["canonical", "jordan"])
def test_interval_inclusion_with_the_input_in_a_sensor_both_forms(form):
    """models/three_tank_linear.py with u1/2 in y1: the canonical design (seed 001
    method 1, diagonal form, G_diag − J_diag Gy) and the Jordan one both bound x1 while
    u1 varies."""
    from observer_cad import load_model
    t = load_model(ROOT / "models" / "three_tank_linear.py")
    u1 = t.inputs[0]
    s1, s2, s3 = t.states
    n1, n2 = t.noise
    m = PlantModel(name="three_tank_linear_input_in_y1", time="continuous", states=t.states,
                   inputs=t.inputs, disturbances=t.disturbances, noise=t.noise,
                   outputs=[s2 + u1 / 2 + n1, s3 + n2], dynamics=t.dynamics, bounds=t.bounds)
    kw = dict(form="canonical", eigenvalues=[-1, -2]) if form == "canonical" else {}
    d = design(m, observer="interval", estimate="x1", **kw)
    assert d.certificate.passed
    o = build_observer(m, d)
    assert all(u1 in sp.sympify(e).free_symbols for e in o.update)
    sc = scenario_from_dict({"t_end": 10, "dt": 0.01, "seed": 4,
                             "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
                             "signals": {"u1": "1 + sin(t)", "u2": "0.5", "rho": "declared",
                                         "w1": "declared", "w2": "declared"}})
    assert _outside(simulate(m, o, sc, runs=3), "x1") == 0


def test_nonlinear_interval_observer_with_the_input_in_a_sensor():
    """models/three_tank.py (√ outflows, seed 002 §4) with u1/4 in y1: the nonlinear term's
    argument x1 − x2 reads ỹ1 = y1 − u1/4 (clipped at the noise box's end) and x1 stays
    inside its bounds while u1 varies."""
    from observer_cad import load_model
    t = load_model(ROOT / "models" / "three_tank.py")
    u1 = t.inputs[0]
    m = PlantModel(name="three_tank_input_in_y1", time=t.time, states=t.states,
                   inputs=t.inputs, disturbances=t.disturbances, noise=t.noise,
                   linear_part=t.linear_part, domain=t.domain, dynamics=t.dynamics,
                   bounds=t.bounds, outputs=[t.outputs[0] + u1 / 4, t.outputs[1]])
    d = design(m, observer="interval", estimate="x1")
    assert d.certificate.passed and d.nonlinear
    o = build_observer(m, d)
    assert "sqrt(Max(0, u1/4 + xl1 - y1 + 1/100))" in str(o.update[0])
    sc = scenario_from_dict({"t_end": 10, "dt": 0.01, "seed": 4,
                             "initial": {"x1": 2, "x2": 1.2, "x3": 0.6},
                             "signals": {"u1": "0.5 + 0.3*sin(t)", "u2": "0.2",
                                         "rho1": "declared", "rho2": "declared",
                                         "w1": "declared", "w2": "declared"}})
    assert _outside(simulate(m, o, sc, runs=2), "x1") == 0


def test_interval_observer_ignoring_the_sensor_bias_is_violated():
    """Companion: the observer built for fs ∈ [0, 0] on the plant with fs at its bound
    leaves the trajectory, so the inclusion above is not vacuous."""
    plant = _interval_plant("discrete")
    blind = _interval_plant("discrete", fs_bound=0)
    o = build_observer(blind, design(blind, observer="interval", estimate="x3"))
    sig = {"u": "0.5*sin(t/7)", "fa": "0", "fs": "0.1", "rho": "0", "w1": "0", "w2": "0"}
    res = simulate(plant, o, scenario_from_dict({"steps": 200, "signals": sig,
                                                 "initial": {"x1": 0, "x2": 0, "x3": 0}}))
    assert _outside(res, "x3") > 0


@pytest.mark.parametrize("time", ["discrete", "continuous"])
def test_full_state_intervals_with_feedthrough(time):
    """seed 002 §4 with feedthrough: x1 = y1 − u/4 − fs − w1 and x2 = y2 − ρ/2 − w2 from
    the outputs (the bias and ρ bounded like the noise), x3 from the interval observer;
    lower ≤ x ≤ upper for every state at every sample."""
    from observer_cad.observers import full_state_intervals
    m = _interval_plant(time)
    o = full_state_intervals(m)
    outs = dict(o.outputs)
    u_, y1 = sp.Symbol("u"), sp.Symbol("y1")
    assert sp.expand(outs["x1_lower"] - (y1 - u_ / 4 - R(3, 25))) == 0  # fs + w1: 1/10 + 1/50
    assert "reads y − Gy u" in o.description
    grid = {"steps": 300} if time == "discrete" else {"t_end": 5, "dt": 0.002}
    sc = scenario_from_dict({**grid, "seed": 8, "initial": {"x1": 0.3, "x2": -0.2, "x3": 0.1},
                             "signals": {"u": "0.5*sin(t/3)", "fa": "declared",
                                         "fs": "0.1*sin(t)", "rho": "0.2*cos(t)",
                                         "w1": "declared", "w2": "declared"}})
    res = simulate(m, o, sc, runs=3 if time == "discrete" else 1)
    for x in ("x1", "x2", "x3"):
        assert _outside(res, x) == 0, x


def test_interval_observer_needs_bounds_on_a_fault_in_a_read_output():
    m = _interval_plant("discrete")
    bounds = {s: b for s, b in m.bounds.items() if s != fs}
    m2 = PlantModel(name=m.name, time=m.time, states=m.states, inputs=m.inputs,
                    faults=m.faults, disturbances=m.disturbances, noise=m.noise,
                    outputs=m.outputs, dynamics=m.dynamics, bounds=bounds)
    with pytest.raises(ModelError, match="bounds on the fault or disturbance in the outputs"
                       " 'fs'") as e:
        build_observer(m2, design(m2, observer="interval", estimate="x3"))
    assert "\n" not in str(e.value)


# ---------------------------------------------------------------- unknown-input estimators

def _drive_with_input_feedthrough():
    """The electric drive of seed 000 §9 (models/electric_drive.py) with the voltage u in
    both sensors: y1 = x1 + u/4 + w1, y2 = x3 + u/2 + w2."""
    from observer_cad import load_model
    drive = load_model(ROOT / "models" / "electric_drive.py")
    (u_,) = drive.inputs
    y1, y2 = drive.outputs
    return PlantModel(name="drive_input_feedthrough", time=drive.time, states=drive.states,
                      inputs=drive.inputs, faults=drive.faults,
                      disturbances=drive.disturbances, noise=drive.noise,
                      parameters=drive.parameters, outputs=[y1 + u_ / 4, y2 + u_ / 2],
                      dynamics=drive.dynamics, bounds=drive.bounds)


def _sliding_with_input_feedthrough(fault_in_y1=False):
    """models/sliding_example.py with u1/2 in y1 and u2/4 in y2 (and, for the refusal, the
    fault d in y1 too)."""
    from observer_cad import load_model
    sl = load_model(ROOT / "models" / "sliding_example.py")
    u1, u2 = sl.inputs
    (d_,) = sl.faults
    _, s2, s3 = sl.states
    w1_, w2_ = sl.noise
    return PlantModel(name="sliding_input_feedthrough", time="continuous", states=sl.states,
                      inputs=sl.inputs, faults=sl.faults, disturbances=sl.disturbances,
                      noise=sl.noise, dynamics=sl.dynamics, bounds=sl.bounds,
                      outputs=[s2 + u1 / 2 + w1_ + (d_ / 3 if fault_in_y1 else 0),
                               s3 + u2 / 4 + w2_])


SLIDING_SC = {"t_end": 5, "dt": 0.001, "initial": {"x1": 0.3, "x2": -0.2, "x3": 0.1},
              "signals": {"u1": "sin(t)", "u2": "0.5 + 0.5*sin(2*t)", "rho": "0.3*cos(2*t)",
                          "w1": "0", "w2": "0",
                          "d": "sin(3*t) + Piecewise((0, t < 2), (0.5, True))"}}


def test_discrete_unknown_input_estimate_is_exact_with_input_feedthrough():
    """seed 000 on the drive with u in both sensors: certified (Φ G − J* Gy − G*), the
    estimator reads y − Gy u (its copies and memory states), and d̂(t) = d(t) to rounding
    after the transient while u, d and ρ act."""
    m = _drive_with_input_feedthrough()
    d = design(m, observer="unknown-input", faults=["d"])
    assert d.certificate.passed
    assert "Phi G - J* Gy - G*" in [i.name for i in d.certificate.identities]
    o = build_observer(m, d)
    assert "reads y − Gy u" in o.description
    lag = dict(zip(o.states, o.update)).get(sp.Symbol("y1_lag1"))
    assert sp.expand(lag - (sp.Symbol("y1") - sp.Symbol("u") / 4)) == 0  # y1_lag1 holds ŷ1
    assert not o.failed_conditions
    sc = scenario_from_dict({"steps": 200, "seed": 1, "initial": {"x1": 0.1, "x2": 0, "x3": 0},
                             "signals": {"u": "0.3*sin(t/5)", "d": "0.2*sin(t/9)",
                                         "rho": "declared", "w1": "0", "w2": "0"}})
    res = simulate(m, o, sc)
    assert np.ptp(res["u"]) > 0.5 and np.ptp(res["d"]) > 0.3
    err = np.abs(res["d_hat"] - res["d"])[20:-1]  # (the last sample's d̂ needs y(t+m))
    assert np.all(np.isfinite(err)) and np.max(err) < 1e-9
    # the estimator of the drive without feedthrough reads y itself: wrong here
    from observer_cad import load_model
    plain = load_model(ROOT / "models" / "electric_drive.py")
    blind = build_observer(plain, design(plain, observer="unknown-input", faults=["d"]))
    off = np.abs(simulate(m, blind, sc)["d_hat"] - res["d"])[20:-1]
    assert np.max(off) > 0.01

@pytest.mark.parametrize("form", ["canonical", "jordan"])
def test_vector_unknown_input_estimates_with_input_feedthrough(form):
    """seed 000 Remark 7 (one estimator per component) with u in two sensors: each
    component's design is lifted (y − Gy u) and both estimates equal the inputs."""
    from observer_cad.observers import vector_unknown_input_observer
    s1, s2, s3, u_, d1, d2 = sp.symbols("x1 x2 x3 u d1 d2")
    m = PlantModel(name="vector_input_feedthrough", time="discrete", states=[s1, s2, s3],
                   inputs=[u_], faults=[d1, d2], outputs=[s1 + u_ / 2, s2, s3 - u_ / 4],
                   dynamics=[s1 / 2 + s2 / 4 + u_ + d1, s2 / 3 + s3 / 4 + d2, s1 / 4 + s3 / 2],
                   bounds={d1: (-1, 1), d2: (-1, 1)})
    o = vector_unknown_input_observer(m, form=form)
    sc = scenario_from_dict({"steps": 150, "initial": {"x1": 0.1, "x2": 0, "x3": 0},
                             "signals": {"u": "0.5*sin(t/5)", "d1": "0.3*sin(t/7)",
                                         "d2": "0.2*cos(t/4)"}})
    res = simulate(m, o, sc)
    for name in ("d1", "d2"):
        err = np.abs(res[f"{name}_hat"] - res[name])[20:-3]
        assert np.all(np.isfinite(err)) and np.max(err) < 1e-9, name


def _filtered(t, d, tau):
    """d through 1/(τ s + 1) from 0, exactly for a signal held over each step."""
    a = np.exp(-(t[1] - t[0]) / tau)
    out = np.zeros_like(d)
    for k in range(len(d) - 1):
        out[k + 1] = a * out[k] + (1 - a) * d[k]
    return out


def test_continuous_unknown_input_estimate_with_input_feedthrough():
    """The derivative-free estimator on the sliding example with u in the outputs: its
    computer-algebra condition holds and d̂ is d filtered by 1/(τ s + 1) to RK4 accuracy."""
    m = _sliding_with_input_feedthrough()
    d = design(m, observer="unknown-input", faults=["d"])
    assert d.certificate.passed
    o = build_observer(m, d)
    assert not o.failed_conditions
    cond = {c.name: c for c in o.conditions}["d̂ is d filtered by 1/(τ s + 1) (computer algebra)"]
    assert cond.holds
    r = simulate(m, o, scenario_from_dict(SLIDING_SC))
    df = _filtered(r["t"], r["d"], 0.1)
    assert np.max(np.abs(r["d_hat"] - df)) < 1e-8
    assert np.max(np.abs(r["u1"])) > 0.9


# ---------------------------------------------------------------- sliding-mode observers

def test_sliding_mode_observer_with_input_feedthrough():
    """seed 002 §5 with u in the outputs: certified, e = x̂* − R* (y − Gy u) → 0 (the
    residual r = −e stays in the boundary layer) and d̂ → d."""
    m = _sliding_with_input_feedthrough()
    d = design(m, observer="sliding-mode", faults=["d"])
    assert d.certificate.passed
    r_expr = dict(d.outputs)["r"]
    assert {sp.Symbol("u1"), sp.Symbol("u2")} <= r_expr.free_symbols
    o = build_observer(m, d)
    res = simulate(m, o, scenario_from_dict(SLIDING_SC))
    late = res["t"] > 3
    assert np.max(np.abs(res["r"][late])) < 0.01
    assert np.max(np.abs(res["d_hat"][late] - res["d"][late])) < 0.02
    assert np.max(np.abs(res["r"])) > 0.05 or np.max(np.abs(res["d_hat"])) > 0.5


@pytest.mark.parametrize("kind", ["sliding-mode", "unknown-input"])
def test_a_decoupled_sensor_fault_is_not_read(kind):
    """A redundant sensor y3 = x2 + fs whose bias fs is decoupled (the sliding-mode observer
    decouples every other fault; the estimator is told to with disturbances=["fs"]): the
    design does not read y3 (R* Ly = 0, J* Ly = 0) and the estimate of d is unaffected by
    a step of fs."""
    from observer_cad import load_model
    sl = load_model(ROOT / "models" / "sliding_example.py")
    u1 = sl.inputs[0]
    _, s2, s3 = sl.states
    n1, n2 = sl.noise
    fs_ = sp.Symbol("fs")
    m = PlantModel(name="sliding_redundant_sensor", time="continuous", states=sl.states,
                   inputs=sl.inputs, faults=list(sl.faults) + [fs_],
                   disturbances=sl.disturbances, noise=sl.noise, dynamics=sl.dynamics,
                   bounds=sl.bounds, outputs=[s2 + u1 / 2 + n1, s3 + n2, s2 + fs_])
    d = design(m, observer=kind, faults=["d"],
               disturbances=["fs"] if kind == "unknown-input" else [])
    assert d.certificate.passed
    assert d.matrices.R_star[0, 2] == 0 and all(e == 0 for e in d.matrices.J_star[:, 2])
    sig = dict(SLIDING_SC["signals"], fs="Piecewise((0, t < 1), (0.7, True))", d="sin(3*t)")
    res = simulate(m, build_observer(m, d), scenario_from_dict(dict(SLIDING_SC, signals=sig)))
    late = res["t"] > 3
    want = res["d"] if kind == "sliding-mode" else _filtered(res["t"], res["d"], 0.1)
    assert np.max(np.abs(res["d_hat"][late] - want[late])) < (0.02 if kind == "sliding-mode"
                                                              else 1e-6)


# ---------------------------------------------------------------- refusals (CLI: one line, exit 2)

def _model_file(tmp_path, outputs: str) -> str:
    """models/sliding_example.py with other outputs, as a model file."""
    text = (ROOT / "models" / "sliding_example.py").read_text()
    text = text.replace("outputs=[x2 + w1, x3 + w2],", f"outputs=[{outputs}],")
    assert f"outputs=[{outputs}]" in text
    path = tmp_path / "sliding_feedthrough.py"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("kind", ["unknown-input", "sliding-mode"])
def test_an_estimated_input_in_the_outputs_is_refused_in_one_line(tmp_path, capsys, kind):
    """d in y1 (a fault of the sensor as well as of the tank): the estimators take known
    inputs in the outputs only; the refusal names the diagnostic and interval observers."""
    from observer_cad.cli import main
    path = _model_file(tmp_path, "x2 + d/3 + u1/2 + w1, x3 + w2")
    rc = main(["design", path, "--observer", kind, "--fault", "d"])
    err = capsys.readouterr().err
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("observer-cad: error: ")
    assert "d enters the outputs directly" in lines[0]
    assert "--observer diagnostic --fault d" in lines[0] and "Traceback" not in err


def test_the_cli_designs_an_estimator_with_input_feedthrough(tmp_path, capsys):
    from observer_cad.cli import main
    path = _model_file(tmp_path, "x2 + u1/2 + w1, x3 + u2/4 + w2")
    for kind in ("unknown-input", "sliding-mode"):
        assert main(["design", path, "--observer", kind, "--fault", "d"]) == 0, \
            capsys.readouterr().err
        capsys.readouterr()


# ---------------------------------------------------------------- robust (approximate) designs

def _nodec_discrete():
    """Two disturbances that no exact design decouples from d (they enter x1, x2, both
    measured; METHOD §2d), the input u in both sensors."""
    s1, s2, s3, u_, d_, r1, r2 = sp.symbols("x1 x2 x3 u d r1 r2")
    return PlantModel(
        name="nodec_feedthrough", time="discrete", states=[s1, s2, s3], inputs=[u_],
        faults=[d_], disturbances=[r1, r2],
        outputs=[s1 + u_ / 2, s2 - u_ / 4],
        dynamics=[(-s1 + s2) / 4 + u_ + r1, (s1 - 2 * s2 + s3) / 4 + r2, (s2 - 3 * s3) / 4 + d_],
        bounds={d_: (-1, 1), r1: (-R(1, 10), R(1, 10)), r2: (-R(1, 10), R(1, 10))})


def test_robust_unknown_input_design_with_input_feedthrough():
    """No exact design: the approximate one (L* = Φ L its residual) is lifted for Gy u —
    certified (Φ G − J* Gy − G*, Φ L − L*) — and with ρ at zero its estimator gives d
    exactly (to rounding) while u acts through the outputs."""
    m = _nodec_discrete()
    with pytest.raises(InfeasibleDesignError):
        design(m, observer="unknown-input", faults=["d"])
    d = design(m, observer="unknown-input", faults=["d"], robust=True)
    assert d.approximate and d.residual_norm > 0 and d.certificate.passed
    names = [i.name for i in d.certificate.identities]
    assert "Phi G - J* Gy - G*" in names and "Phi L - L*" in names
    o = build_observer(m, d)
    sc = scenario_from_dict({"steps": 200, "initial": {"x1": 0.1, "x2": 0, "x3": 0},
                             "signals": {"u": "0.5*sin(t/5)", "d": "0.5*sin(t/9)",
                                         "r1": "0", "r2": "0"}})
    res = simulate(m, o, sc)
    err = np.abs(res["d_hat"] - res["d"])[20:-3]
    assert np.all(np.isfinite(err)) and np.max(err) < 1e-9


def test_robust_design_with_a_decoupled_input_in_the_outputs_is_refused(tmp_path, capsys):
    """r2 in y1 as well: the approximate designs take known inputs in the outputs only;
    the CLI says so in one line (exit 2), naming the interval observer."""
    from observer_cad.cli import main
    path = tmp_path / "nodec_r2.py"
    path.write_text(
        "import sympy as sp\nfrom observer_cad import PlantModel\n"
        "x1, x2, x3, u, d, r1, r2 = sp.symbols('x1 x2 x3 u d r1 r2')\n"
        "model = PlantModel(name='nodec_r2', time='discrete', states=[x1, x2, x3],"
        " inputs=[u], faults=[d], disturbances=[r1, r2],"
        " outputs=[x1 + u/2 + r2/2, x2 - u/4],"
        " dynamics=[(-x1 + x2)/4 + u + r1, (x1 - 2*x2 + x3)/4 + r2, (x2 - 3*x3)/4 + d],"
        " bounds={d: (-1, 1), r1: (-0.1, 0.1), r2: (-0.1, 0.1)})\n")
    rc = main(["design", str(path), "--observer", "unknown-input", "--fault", "d", "--robust"])
    err = capsys.readouterr().err
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("observer-cad: error: ")
    assert "r2 enters the outputs directly" in lines[0] and "--observer interval" in lines[0]


# ---------------------------------------------------------------- design files

@pytest.mark.parametrize("case", ["interval", "unknown-input", "sliding-mode", "robust"])
def test_design_json_with_feedthrough_reads_back_to_the_same_observer(case):
    """A design's JSON is re-certified on reading (Φ G − J* Gy − G*, and the equations
    against the matrices with y − Gy u): the observer built from it is the same."""
    from observer_cad.synthesis import Design
    m, kw = {"interval": (_interval_plant("continuous"),
                          dict(observer="interval", estimate="x3")),
             "unknown-input": (_drive_with_input_feedthrough(),
                               dict(observer="unknown-input", faults=["d"])),
             "sliding-mode": (_sliding_with_input_feedthrough(),
                              dict(observer="sliding-mode", faults=["d"])),
             "robust": (_nodec_discrete(),
                        dict(observer="unknown-input", faults=["d"], robust=True))}[case]
    d = design(m, **kw)
    back = Design.from_json(d.to_json(), m)
    assert back.certificate.passed
    o1, o2 = build_observer(m, d), build_observer(m, back)
    assert len(o1.update) == len(o2.update)
    for a, b in zip(o1.update + tuple(e for _, e in o1.outputs),
                    o2.update + tuple(e for _, e in o2.outputs)):
        diff = sp.expand(a - b)  # float designs: the same to rounding, at seeded points
        syms = sorted(diff.free_symbols, key=str)
        for point in np.random.default_rng(3).uniform(-1, 1, (5, len(syms))):
            assert abs(float(diff.xreplace(dict(zip(syms, point))))) < 1e-9


# ---------------------------------------------------------------- compiled step

@pytest.mark.slow
@pytest.mark.skipif(not shutil.which("cc"), reason="no C compiler")
@pytest.mark.parametrize("case", ["interval", "unknown-input"])
def test_compiled_observer_with_feedthrough_matches_the_reference(case):
    """The compiled joint step (casadi → C) reads y − Gy u as the reference simulator does."""
    from observer_cad.codegen import CompiledSimulator
    if case == "interval":
        m = _interval_plant("discrete")
        o = build_observer(m, design(m, observer="interval", estimate="x3"))
        sig, col = {"fa": "0.01", "fs": "0.05*sin(t/3)"}, "x3_upper"
    else:
        m = _drive_with_input_feedthrough()
        o = build_observer(m, design(m, observer="unknown-input", faults=["d"]))
        sig, col = {"d": "0.2*sin(t/9)"}, "d_hat"
    sc = scenario_from_dict({"steps": 100, "initial": {"x1": 0.1, "x2": 0, "x3": 0},
                             "signals": {"u": "0.3*sin(t/5)", "rho": "0.01", "w1": "0",
                                         "w2": "0", **sig}})
    ref, res = simulate(m, o, sc), CompiledSimulator(m, o).simulate(sc)
    assert np.nanmax(np.abs(ref[col])) > 0.01
    assert np.nanmax(np.abs(np.asarray(ref[col]) - np.asarray(res[col]))) < 1e-9
