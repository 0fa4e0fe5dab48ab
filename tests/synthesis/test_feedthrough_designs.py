"""Designs with faults, disturbances and inputs in the outputs (y = H x + Gy u + Dy d +
Ly ρ + W w): the certificate re-checks the decoupling conditions with the feedthrough
(Φ L − J* Ly = 0, R* Ly = 0, G* = Φ G − J* Gy, D* = Φ D − J* Dy), a wrong matrix fails
it, a residual on the sensor-fault three-tank is checked against a simulation written
here (plant and observer integrated from the matrices, not by the tool's simulator),
random plants with feedthrough satisfy the identities in numpy, and what is not designed
with feedthrough is refused in one line."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import assume, HealthCheck, given, settings
from hypothesis import strategies as st_

from observer_cad import PlantModel, extract_structure
from observer_cad.errors import CertificateError, InfeasibleDesignError, UsageError
from observer_cad.model import load_model
from observer_cad.synthesis import certify_design, design

ROOT = Path(__file__).resolve().parents[2]
TANKS = ROOT / "models" / "three_tank_sensor_faults.py"


def _f(M):
    return np.array(sp.Matrix(M).evalf(), dtype=float)


@pytest.fixture(scope="module")
def tanks():
    return load_model(TANKS)


def test_certificate_checks_the_feedthrough_identities(tanks):
    d = design(tanks, observer="diagnostic", faults=["fa1", "fs1", "fs2"],
               disturbances=["fa2", "fs3"])
    names = [i.name for i in d.certificate.identities]
    for want in ("Phi G - J* Gy - G*", "Phi D - J* Dy - D*", "Phi L - J* Ly", "R* Ly",
                 "model: Phi df/d(decoupled) - J* dh/d(decoupled)",
                 "model: R* dh/d(decoupled)", "model: Phi df/dd - J* dh/dd - D*"):
        assert want in names, want
    st = d.structure
    m = d.matrices
    T, dec = list(d.task.targets), list(d.task.decoupled)
    plant = {"F": st.F, "G": st.G, "H": st.H, "C": st.C, "D": st.unknown_input_columns(T),
             "L": st.unknown_input_columns(dec), "Gy": st.Gy, "Dy": st.output_columns(T),
             "Ly": st.output_columns(dec)}
    mats = dict(m.as_dict())
    assert certify_design(plant, mats).passed
    # D* without the − J* Dy term (what a designer ignoring the feedthrough would give)
    wrong = dict(mats, D_star=sp.Matrix(m.Phi) * plant["D"])
    assert not sp.Matrix(m.J_star * plant["Dy"]).is_zero_matrix
    with pytest.raises(CertificateError, match="Phi D - J\\* Dy - D\\*"):
        certify_design(plant, wrong)
    # a residual reading the decoupled sensor (R* Ly ≠ 0) fails R* Ly
    bad = dict(mats, R_star=sp.Matrix(m.R_star) + sp.Matrix([[0, 0, 1]]))
    with pytest.raises(CertificateError, match="R\\* Ly"):
        certify_design(plant, bad)


def _simulate(F, G, D, L, H, Dy, Ly, obs, u, d, rho, x0, dt, steps):
    """RK4 of plant and observer together, from their matrices: x' = F x + G u + D d + L ρ,
    y = H x + Dy d + Ly ρ; x*' = F* x* + J* y + G* u; r = R* y − H* x*."""
    Fs, J, Gs, R, Hs, _ = obs
    n = F.shape[0]

    def rhs(t, z):
        x, xs = z[:n], z[n:]
        y = H @ x + Dy @ d(t) + Ly @ rho(t)
        return np.concatenate([F @ x + G @ u(t) + D @ d(t) + L @ rho(t),
                               Fs @ xs + J @ y + Gs @ u(t)])
    z = np.concatenate([x0, obs[5] @ x0])
    out = []
    for i in range(steps):
        t = i * dt
        x, xs = z[:n], z[n:]
        y = H @ x + Dy @ d(t) + Ly @ rho(t)
        out.append((t, float((R @ y - Hs @ xs)[0])))
        k1 = rhs(t, z)
        k2 = rhs(t + dt / 2, z + dt / 2 * k1)
        k3 = rhs(t + dt / 2, z + dt / 2 * k2)
        k4 = rhs(t + dt, z + dt * k3)
        z = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return np.array(out)


@pytest.mark.parametrize("faults, dec", [(["fa1", "fs1", "fs2"], ["fa2", "fs3"]),
                                        (["fa2", "fs1", "fs2", "fs3"], ["fa1"])])
def test_residual_against_an_independent_simulation(tanks, faults, dec):
    d = design(tanks, observer="diagnostic", faults=faults, disturbances=dec)
    st = extract_structure(tanks)
    m = d.matrices
    obs = tuple(_f(M) for M in (m.F_star, m.J_star, m.G_star, m.R_star, m.H_star, m.Phi))
    F, G, D, L, H, Dy, Ly = (_f(M) for M in (st.F, st.G, st.D, st.L, st.H, st.Dy, st.Ly))
    rng = np.random.default_rng(7)
    amp = rng.uniform(0.1, 0.5, size=6)

    def u(t):
        return np.array([0.5 + 0.2 * np.sin(t), 0.3])

    def rho(t):
        return np.array([0.2 * np.sin(3 * t)])

    names = [f.name for f in tanks.faults]

    def faults_at(active):
        def d_(t):
            v = np.zeros(len(names))
            for j, nm in enumerate(names):
                if nm in active and t >= 2.0:
                    v[j] = amp[j] * (1 + np.sin(1.3 * t + j))
            return v
        return d_
    x0 = np.array([0.5, 0.2, 0.1])
    # disturbance and the decoupled faults active: the residual stays exactly zero
    r = _simulate(F, G, D, L, H, Dy, Ly, obs, u, faults_at(dec), rho, x0, 0.01, 600)
    assert np.max(np.abs(r[:, 1])) < 1e-12
    # each detected fault alone moves it (a sensor bias directly through R* Dy, or
    # through the observer's input J* Dy)
    for f in faults:
        r = _simulate(F, G, D, L, H, Dy, Ly, obs, u, faults_at([f]), rho, x0, 0.01, 600)
        assert np.max(np.abs(r[r[:, 0] < 2.0, 1])) < 1e-12
        assert np.max(np.abs(r[r[:, 0] > 2.5, 1])) > 1e-3, f


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st_.integers(0, 10_000))
def test_random_plants_with_feedthrough_satisfy_the_identities(seed):
    """Random integer plants, 3 states, 3 outputs, a fault in the dynamics, a sensor fault
    and a disturbance in both the dynamics and one output; every design found satisfies
    the feedthrough identities in floating point, and its residual's transfer from the
    detected fault, R* Dy + H* (sI − F*)⁻¹ (Φ D − J* Dy), is nonzero."""
    rng = np.random.default_rng(seed)
    n, l = 3, 3
    xs = sp.symbols("x1:4")
    u, f, fs, rho = sp.symbols("u f fs rho")
    Fm = rng.integers(-3, 4, size=(n, n)) - 4 * np.eye(n, dtype=int)
    Hm = rng.integers(-1, 2, size=(l, n))
    Hm[np.arange(l), np.arange(l)] = 1
    g, dcol, lcol = (rng.integers(-2, 3, size=n) for _ in range(3))
    dcol[rng.integers(n)] = 1
    gy, ly = rng.integers(-1, 2, size=l), np.zeros(l, dtype=int)
    ly[rng.integers(l)] = 1
    sensor = rng.integers(l)
    dyn = [sum(int(Fm[i, j]) * xs[j] for j in range(n)) + int(g[i]) * u + int(dcol[i]) * f
           + int(lcol[i]) * rho for i in range(n)]
    outs = [sum(int(Hm[i, j]) * xs[j] for j in range(n)) + int(gy[i]) * u + int(ly[i]) * rho
            + (fs if i == sensor else 0) for i in range(l)]
    if not any(e.has(rho) for e in dyn):
        dyn[0] += rho
    m = PlantModel(name="rnd", time="continuous", states=list(xs), inputs=[u],
                   faults=[f, fs], disturbances=[rho], outputs=outs, dynamics=dyn)
    try:
        d = design(m, observer="diagnostic", faults=["f", "fs"])
    except InfeasibleDesignError:
        assume(False)  # not counted: hypothesis draws another plant (or fails as unsatisfiable)
    st = extract_structure(m)
    P, Fs, J, R, Hs, Gs, Ds = (_f(M) for M in (d.matrices.Phi, d.matrices.F_star,
                                                d.matrices.J_star, d.matrices.R_star,
                                                d.matrices.H_star, d.matrices.G_star,
                                                d.matrices.D_star))
    F, G, D, L, H, Gy, Dy, Ly = (_f(M) for M in (st.F, st.G, st.D, st.L, st.H, st.Gy, st.Dy,
                                                  st.Ly))
    for res in (P @ F - Fs @ P - J @ H, P @ L - J @ Ly, R @ Ly, R @ H - Hs @ P,
                P @ G - J @ Gy - Gs, P @ D - J @ Dy - Ds):
        assert np.max(np.abs(res)) < 1e-9
    s = 0.37 + 1.1j
    T = R @ Dy + Hs @ np.linalg.solve(s * np.eye(Fs.shape[0]) - Fs, P @ D - J @ Dy)
    assert np.max(np.abs(T)) > 1e-9


def test_every_observer_kind_takes_the_feedthrough(tanks):
    """The unknown-input estimator of fa1 designs (fs1 of y1 is a fault the task assumes
    zero); the sliding-mode observer of fa1 decouples every other fault, and each sensor
    carries one: infeasible, said in one line (tests/observers/test_feedthrough_kinds.py
    designs and simulates each kind)."""
    assert design(tanks, observer="unknown-input", faults=["fa1"]).certificate.passed
    with pytest.raises(InfeasibleDesignError, match="every output carries") as e:
        design(tanks, observer="sliding-mode", faults=["fa1"])
    assert "\n" not in str(e.value)


def test_a_fault_of_the_outputs_alone_gets_a_dynamic_residual(tanks):
    """fs1 (a bias on y1) has no zero-order residual with ρ decoupled; the residual of
    order 1 (x1 rebuilt from y2 and u1) sees it through the outputs
    (tests/synthesis/test_feedthrough_sensor_residuals.py tests these residuals)."""
    d = design(tanks, observer="diagnostic", faults=["fs1"])
    assert d.k == 1 and d.certificate.passed and d.signature_map["fs1"]


def test_robust_designs_take_the_feedthrough(tanks):
    """--robust with feedthrough: the exact design when there is one (the approximate
    ones and their refusal: tests/observers/test_feedthrough_kinds.py)."""
    d = design(tanks, observer="virtual-sensor", estimate="x2", robust=True, form="canonical")
    assert d.certificate.passed and not d.approximate


def _input_feedthrough_plant():
    """x1' = −x1 + u + f1, x2' = x1/2 − 2 x2; y1 = x1 + u/4 + f2 (a bias), y2 = x2 + ρ/2
    (ρ a disturbance of sensor 2 only), from the matrices (A, B, C, D)."""
    A = [[-1.0, 0.0], [0.5, -2.0]]
    B = [[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
    C = [[1.0, 0.0], [0.0, 1.0]]
    D = [[0.25, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.5]]
    return PlantModel.from_statespace((A, B, C, D), time="continuous", inputs=[0],
                                      faults=[1, 2], disturbances=[3])


@pytest.mark.parametrize("kw", [dict(form="jordan"),
                                dict(form="canonical", eigenvalues=[-3])])
def test_inputs_in_the_outputs_and_the_design_file_round_trip(kw):
    import json
    from observer_cad.synthesis import Design
    m = _input_feedthrough_plant()
    d = design(m, observer="diagnostic", faults=["f1"], **kw)
    u = m.inputs[0]
    (_, r), = d.outputs
    xs = d.observer_states[0]
    y1 = sp.Symbol("y1")
    # r reads y1 − u/4; the observer's input matrix is G* = Φ G − J* Gy
    assert sp.expand(r.subs(y1, y1 + u / 4)).coeff(u) == 0
    st = d.structure
    assert sp.Matrix(d.matrices.G_star) == sp.Matrix(d.matrices.Phi) * st.G \
        - sp.Matrix(d.matrices.J_star) * st.Gy
    if kw["form"] == "canonical":
        assert d.matrices.K is not None and d.matrices.K != sp.zeros(1, 1)
    back = Design.from_json(json.loads(json.dumps(d.to_json())), m)
    assert back.certificate.passed
    assert [i.name for i in back.certificate.identities if not i.name.startswith("model")] \
        == [i.name for i in d.certificate.identities if not i.name.startswith("model")]
    # a file whose residual forgets the feedthrough is refused
    data = d.to_json()
    data["outputs"] = {"r": str(sp.expand(r + sp.expand(r).coeff(y1) * u / 4))}
    with pytest.raises((UsageError, CertificateError), match="output r (is not the one|does not"
                       " read)"):
        Design.from_json(json.loads(json.dumps(data)), m)


def test_nonlinear_plant_with_feedthrough_is_certified_and_decoupled():
    """The nonlinear three-tank (√ outflows) with a bias on sensor 1 and the second pump's
    command read by sensor 2 (y2 = x2 + u2/2): the argument substitution reads y2 − u2/2,
    the design is certified against the model's own equations, and in simulation the
    residual stays at zero under the disturbance until the pump fault appears."""
    from observer_cad import build_observer, simulate
    from observer_cad.simulation import scenario_from_dict
    x1, x2, x3, u1, u2, f, fs, rho = sp.symbols("x1 x2 x3 u1 u2 f fs rho")
    m = PlantModel(name="nl", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
                   faults=[f, fs], disturbances=[rho], outputs=[x1 + fs, x2 + u2 / 2, x3],
                   dynamics=[-sp.sqrt(x1 - x2) + u1 + f,
                             sp.sqrt(x1 - x2) - sp.sqrt(x2 - x3) + u2,
                             sp.sqrt(x2 - x3) - sp.sqrt(x3) + rho],
                   domain=[x1 >= x2, x2 >= x3, x3 >= 0])
    d = design(m, observer="diagnostic", faults=["f"])
    names = [i.name for i in d.certificate.identities]
    assert "model: Phi f - F* Phi x - J* h - G* u - C* Psi* - D* d" in names
    assert "Phi G - J* Gy - G*" in names and d.certificate.passed
    y2 = sp.Symbol("y2")
    assert any(e.has(sp.sqrt(d.observer_states[0] - y2 + u2 / 2)) for e in d.equations)
    assert d.signature_map == {"f": True, "fs": True}
    sc = scenario_from_dict({"t_end": 10, "dt": 0.01, "initial": {"x1": 3, "x2": 2, "x3": 1},
                             "signals": {"u1": "0.5", "u2": "0.3", "rho": "0.05*sin(t)",
                                         "f": "Piecewise((0, t < 6), (0.2, True))"}})
    res = simulate(m, build_observer(m, d), sc)
    t = res["t"]
    assert np.max(np.abs(res["r"][t < 6])) < 1e-9
    assert np.max(np.abs(res["r"][t > 7])) > 0.05


def test_symbolic_feedthrough_parameter_conditions_the_signature():
    """Discrete time, y1 = x1 + k fs + u1/4: kept symbolic, the bias is seen if k ≠ 0."""
    x1, x2, u1, f, fs, rho, k = sp.symbols("x1 x2 u1 f fs rho k")
    m = PlantModel(name="sym", time="discrete", states=[x1, x2], inputs=[u1],
                   faults=[f, fs], disturbances=[rho], outputs=[x1 + k * fs + u1 / 4, x2],
                   dynamics=[x1 / 2 + u1 + f, x1 / 3 + x2 / 4 + rho], parameters={k: 2})
    sig = {s.name: s.describe() for s in design(m, observer="diagnostic", faults=["f"],
                                                symbolic=True).signature}
    assert sig == {"f": "sensitive", "fs": "sensitive if Ne(k, 0)"}
    d = design(m, observer="diagnostic", faults=["f"])
    (_, r), = d.outputs
    assert sp.expand(r).coeff(u1) == -sp.Rational(1, 4) * sp.expand(r).coeff(sp.Symbol("y1"))


def test_a_designer_called_directly_cannot_ignore_the_inputs_feedthrough():
    """design_jordan called on the plant itself leaves R* Gy u in r: the design's model check
    refuses it in one line (the entry point design() lifts it correctly)."""
    from observer_cad.synthesis import design_jordan
    m = _input_feedthrough_plant()
    with pytest.raises(CertificateError, match="y − Gy u") as e:
        design_jordan(m, observer="diagnostic", faults=["f1"])
    assert "\n" not in str(e.value)
    assert design(m, observer="diagnostic", faults=["f1"]).certificate.passed


def test_full_state_intervals_need_bounds_on_the_sensor_faults(tanks):
    """Full-state intervals read y − Gy u and bound the faults of the outputs like the
    noise: the sensor biases of the three-tank have no declared bounds, said in one line
    (tests/observers/test_feedthrough_kinds.py bounds a plant that declares them)."""
    from observer_cad.errors import ModelError
    from observer_cad.observers import full_state_intervals
    with pytest.raises(ModelError, match="bounds on the fault or disturbance in the outputs"
                       " 'fs1'") as e:
        full_state_intervals(tanks)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("form", ["jordan", "canonical"])
def test_virtual_sensor_decoupled_from_a_disturbed_sensor(form):
    """The linear three-tank with a second level sensor on tank 3 that a disturbance ρ2
    reaches directly (y3 = x3 + ρ2/2): the virtual sensor for x1 does not read y3
    (J* Ly = 0, Q Ly = 0) and its estimate equals x1 in simulation while ρ, ρ2 act."""
    from observer_cad import build_observer, simulate
    from observer_cad.simulation import scenario_from_dict
    x1, x2, x3, u1, u2, rho, rho2 = sp.symbols("x1 x2 x3 u1 u2 rho rho2")
    m = PlantModel(name="tanks_vs", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
                   disturbances=[rho, rho2], outputs=[x2, x3, x3 + rho2 / 2],
                   dynamics=[-x1 + x2 + u1, x1 - 2 * x2 + x3 + u2, x2 - 2 * x3 + rho])
    d = design(m, observer="virtual-sensor", estimate="x1", form=form)
    st = d.structure
    assert d.certificate.passed and "Q Ly" in [i.name for i in d.certificate.identities]
    assert (sp.Matrix(d.matrices.J_star) * st.Ly).is_zero_matrix
    assert (sp.Matrix(d.matrices.Q) * st.Ly).is_zero_matrix
    sc = scenario_from_dict({"t_end": 6, "dt": 0.01, "initial": {"x1": 0.5, "x2": 0.2},
                             "signals": {"u1": "0.5", "u2": "0.2*sin(t)", "rho": "0.2*sin(2*t)",
                                         "rho2": "Piecewise((0, t < 2), (0.4, True))"}})
    res = simulate(m, build_observer(m, d), sc)
    assert np.max(np.abs(res["x1_hat"] - res["x1"])) < 1e-9


def _triplex():
    """One state measured by three sensors, each with its own bias (a redundant-sensor
    plant): x' = −x + u, y_i = x + f_i, sensor 2 also reading u/2."""
    x, u, f1, f2, f3 = sp.symbols("x u f1 f2 f3")
    return PlantModel(name="triplex", time="continuous", states=[x], inputs=[u],
                      faults=[f1, f2, f3], outputs=[x + f1, x + f2 + u / 2, x + f3],
                      dynamics=[-x + u])


def test_zero_order_residual_for_sensor_faults():
    """Faults that enter the outputs only get r = R* (y − Gy u) with R* H = 0: no observer
    state, certified, read back from its JSON, exact in simulation; refused in one line
    when the outputs alone cannot give one."""
    import json
    from observer_cad import build_observer, simulate
    from observer_cad.simulation import scenario_from_dict
    from observer_cad.synthesis import Design
    m = _triplex()
    d = design(m, observer="diagnostic", faults=["f1"], disturbances=["f2"])
    assert d.k == 0 and d.certificate.passed and not d.equations
    (_, r), = d.outputs
    y1, y3 = sp.symbols("y1 y3")
    assert sp.expand(r - (y1 - y3)) == 0
    assert d.signature_map == {"f1": True, "f2": False, "f3": True}
    assert Design.from_json(json.loads(json.dumps(d.to_json())), m).k == 0
    # with f2 decoupled the residual uses y2 − u/2 when it needs sensor 2
    d2 = design(m, observer="diagnostic", faults=["f2"], disturbances=["f1"])
    (_, r2), = d2.outputs
    assert sp.expand(r2).coeff(m.inputs[0]) == -sp.expand(r2).coeff(sp.Symbol("y2")) / 2
    sc = scenario_from_dict({"t_end": 3, "dt": 0.01, "initial": {"x": 1},
                             "signals": {"u": "sin(t)", "f2": 0.3,
                                         "f1": "Piecewise((0, t < 1), (0.5, True))"}})
    res = simulate(m, build_observer(m, d), sc)
    t = res["t"]
    assert np.max(np.abs(res["r"][t < 1])) < 1e-12
    np.testing.assert_allclose(res["r"][t > 1.01], 0.5, atol=1e-12)
    with pytest.raises(InfeasibleDesignError, match="no zero-order residual") as e:
        design(m, observer="diagnostic", faults=["f1"], disturbances=["f2", "f3"])
    assert "\n" not in str(e.value)


def test_zero_order_residual_found_where_one_weighted_sum_cancels():
    """Three sensor faults on three sensors of one state: the left null space of H has the
    basis b1 = (−1, 1, 0), b2 = (−1, 0, 1) with b1 Dy = (2, 0, 1), b2 Dy = (−1, 1, 0); the
    combination b1 + 2 b2 misses fa (0), b1 + b2 sees every fault (1, 1, 1). A residual
    r = R* y with R* H = 0 and every R* Dy_t ≠ 0 exists, and is found."""
    x, u, fa, fb, fc = sp.symbols("x u fa fb fc")
    m = PlantModel(name="three_sensors", time="continuous", states=[x], inputs=[u],
                   faults=[fa, fb, fc], outputs=[x, x + 2 * fa + fc, x - fa + fb],
                   dynamics=[-x + u])
    d = design(m, observer="diagnostic", faults=["fa", "fb", "fc"])
    R = sp.Matrix(d.matrices.R_star)
    st = extract_structure(m)
    assert d.k == 0 and (R * sp.Matrix(st.H)).is_zero_matrix
    assert all(e != 0 for e in R * sp.Matrix(st.Dy))
