"""Dynamic residuals for faults seen through the outputs (y = H x + Gy u + Dy d + Ly ρ).

A residual of order k ≥ 1 may see a fault only through the outputs: Φ D = 0, yet R* Dy ≠ 0
or D*_i = Φ_i D − J*_i Dy ≠ 0. Such residuals are the members v = (R*, −J*_1, …, −J*_k) of
the left null space of (W⁽ᵏ⁾ | L_y⁽ᵏ⁾) with v C_f ≠ 0 (observer_cad.synthesis.canonical,
the identification canonical form generalised to feedthrough).

Grouped by what they prove:
* a published example (docs/REFERENCES.md: "FaultDetectionTools.jl", Xiong and Saif 2000,
  Example 1, whose least orders ``fdichkspec`` asserts): row 01 — the sensor fault f2
  with f1 decoupled — designed at its least order 1, certified, its residual in the tool's
  simulation equal to f2 (and zero under f1 and the disturbances); the Boeing 747's rows
  with f5 (in an output) keep their published least orders;
* a plant on which the designers' residual (seeing the fault through Φ D̃ on the measured
  part) has order 2 while one of order 1 sees it through the outputs: the least is made;
* random plants with the fault in the outputs: designed order = analysis' least order
  (observer_cad.analysis.feedthrough_orders) whenever it is below n, refused in one line
  otherwise; the residual stays at zero under ρ and u in a simulation written here, and
  its numerator (R* Dy, Φ D − J* Dy), recomputed from the matrices, is not zero; with two
  faults to detect, the largest of their least orders;
* nonlinear plants and --symbolic designs are refused in one line.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st_

from observer_cad import PlantModel, build_observer, extract_structure, simulate
from observer_cad.analysis import feedthrough_orders
from observer_cad.errors import InfeasibleDesignError, UsageError
from observer_cad.simulation import scenario_from_dict
from observer_cad.synthesis import Design, design, load_design_data

from ..analysis.varga_examples import boeing_747, rows, xiong_saif_1
from .test_feedthrough_orders import plant, row_least_order


def _f(M):
    return np.array(sp.Matrix(M).evalf(), dtype=float).reshape(sp.Matrix(M).shape)


def _numerator(d, st) -> sp.Matrix:
    """(R* Dy, Φ D − J* Dy) for the designed faults, from the matrices (in the canonical
    form the coefficients of the residual's transfer numerator R* Dy sᵏ + Σ D*_i s^{k−i})."""
    m, task = d.matrices, d.task
    Dy = sp.Matrix(st.output_columns(task.targets))
    Ds = sp.Matrix(m.Phi) * task.D(st) - sp.Matrix(m.J_star) * Dy
    return sp.Matrix.vstack(sp.Matrix(m.R_star) * Dy, Ds)


# ------------------------------------------------------------------ published example
def test_xiong_saif_row_01_at_its_published_least_order():
    """Xiong & Saif 2000, Example 1 (FaultDetectionTools.jl): f2 is a fault of sensor y3;
    the row 01 (f2 detected, f1 and the disturbances decoupled) has the least order 1. No
    zero-order residual exists and no design of the measured part sees f2 through Φ D̃:
    the residual of order 1 sees it through the outputs (R* Dy = 1, D* = Φ D − J* Dy)."""
    st = xiong_saif_1()
    (sensitive,) = rows(["01"])
    assert row_least_order(st, sensitive) == 1
    m = plant(st)
    d = design(m, observer="diagnostic", faults=["f2"], disturbances=["f1"])
    assert d.k == 1 and d.certificate.passed and d.form.value == "canonical"
    assert d.signature_map == {"f1": False, "f2": True}
    mats = d.matrices
    assert (sp.Matrix(mats.Phi) * st.D[:, 1]).is_zero_matrix  # not through Φ D
    assert not _numerator(d, st).is_zero_matrix
    names = {c.name for c in d.conditions}
    assert {"faults seen through the outputs", "k is minimal", "certificate"} <= names
    assert "least order" in d.choice and "through the outputs" in d.choice
    # the tool's simulation: r = f2 exactly here (numerator s + 1 over F* − K H* = −1)
    sc = scenario_from_dict({
        "t_end": 4, "dt": 0.005, "initial": {"x1": 0.1, "x3": -0.2},
        "signals": {"rho1": "0.3*sin(2*t)", "rho2": "0.2*cos(3*t) - 0.1",
                    "f1": "Piecewise((0, t < 0.5), (0.4, True))",
                    "f2": "Piecewise((0, t < 2), (0.5, True))"}})
    res = simulate(m, build_observer(m, d), sc)
    t, r = res["t"], res["r"]
    scale = max(1.0, float(np.max(np.abs(res["y3"]))))
    assert np.max(np.abs(r[t < 2])) < 1e-9 * scale  # f1, ρ and x(0) leave r at zero
    np.testing.assert_allclose(r[t > 2.01], 0.5, atol=1e-9 * scale)
    # the same request with --form canonical is the same design; the file reads back
    assert design(m, observer="diagnostic", faults=["f2"], disturbances=["f1"],
                  form="canonical").matrices == mats
    data = json.loads(json.dumps(d.to_json()))
    assert Design.from_json(data, m).k == 1
    assert load_design_data(data, m).matrices == mats
    # Jordan λ do not apply to the canonical-form residual: one line
    with pytest.raises(UsageError, match="--form canonical --eigenvalues") as e:
        design(m, observer="diagnostic", faults=["f2"], disturbances=["f1"], lambdas=[-2])
    assert "\n" not in str(e.value)
    # chosen closed-loop eigenvalue
    d3 = design(m, observer="diagnostic", faults=["f2"], disturbances=["f1"],
                form="canonical", eigenvalues=[-3])
    assert d3.k == 1 and [str(e) for e in d3.closed_loop_eigenvalues] == ["-3"]


# (the Boeing 747, Varga 2007, as in FaultDetectionTools.jl: f5 enters the second output;
# fdichkspec's least orders of the weak rows that detect f5)
BOEING_F5_ROWS = [("00001", 1), ("00111", 1), ("11001", 1), ("11111", 1)]


@pytest.mark.parametrize("pattern, published", BOEING_F5_ROWS, ids=[p for p, _ in BOEING_F5_ROWS])
def test_boeing_rows_with_the_fault_in_an_output_keep_their_least_order(pattern, published):
    """f5 enters the dynamics and an output: the designers' residuals of the published
    least order stay (no lower order exists); each sees exactly its row's faults."""
    st = boeing_747()
    (sensitive,) = rows([pattern])
    assert row_least_order(st, sensitive) == published
    m = plant(st)
    names = [f.name for f in m.faults]
    d = design(m, observer="diagnostic", faults=list(sensitive),
               disturbances=[f for f in names if f not in sensitive])
    assert d.k == published and d.certificate.passed
    assert {s.name for s in d.signature if s.sensitive} == set(sensitive)


def test_nonlinear_and_symbolic_plants_are_refused_in_one_line():
    """The search is for linear plants with numeric matrices: a sensor bias on the
    nonlinear three-tank (√ outflows), or on a linear one designed with --symbolic, is
    refused in one line saying so (the same plant with numeric parameters is designed)."""
    x1, x2, x3, u1, u2, fs, rho, k = sp.symbols("x1 x2 x3 u1 u2 fs rho k")
    nl = PlantModel(name="nl", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
                    faults=[fs], disturbances=[rho], outputs=[x1 + fs, x2, x3],
                    dynamics=[-sp.sqrt(x1 - x2) + u1,
                              sp.sqrt(x1 - x2) - sp.sqrt(x2 - x3) + u2 + rho,
                              sp.sqrt(x2 - x3) - sp.sqrt(x3)],
                    domain=[x1 >= x2, x2 >= x3, x3 >= 0])
    lin = PlantModel(name="lin", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
                     faults=[fs], disturbances=[rho], outputs=[x1 + fs, x2, x3],
                     parameters={k: 2}, dynamics=[-k * x1 + x2 + u1,
                                                  x1 - 2 * x2 + x3 + u2 + rho, x2 - 2 * x3])
    for m, symbolic in ((nl, False), (lin, True)):
        with pytest.raises(InfeasibleDesignError, match="linear plants with numeric") as e:
            design(m, observer="diagnostic", faults=["fs"], symbolic=symbolic)
        assert "\n" not in str(e.value)
    assert design(lin, observer="diagnostic", faults=["fs"]).k == 1


# ------------------------------------------------------------------ lower than the designers
def _lower_plant() -> PlantModel:
    """f in the outputs only, ρ in the dynamics and in sensor 2 (a random plant, seed 29 of
    a draw like the property's): the designers see f through D̃ = −L₁ Y₁⁻¹ M Dy and make
    order 2; order 1 sees f through the outputs."""
    x1, x2, x3, u, f, rho = sp.symbols("x1 x2 x3 u f rho")
    return PlantModel(name="lower", time="continuous", states=[x1, x2, x3], inputs=[u],
                      faults=[f], disturbances=[rho],
                      outputs=[-f - x1, f - rho - x1, f - u - x1 - x2 - x3],
                      dynamics=[-2 * rho - 2 * u - x3, 2 * rho + u + x2 - x3,
                                2 * rho - 2 * u - 2 * x2 + 2 * x3])


def test_lower_order_than_the_designers_through_the_outputs():
    m = _lower_plant()
    st = extract_structure(m)
    (least,), _ = feedthrough_orders(st.F, st.H, st.L, st.Ly, st.D, st.Dy)
    assert least == 1
    for form in ("jordan", "canonical"):
        d = design(m, observer="diagnostic", faults=["f"], form=form)
        assert d.k == 1 and d.certificate.passed and d.signature_map == {"f": True}
        cond = next(c for c in d.conditions if c.name == "faults seen through the outputs")
        assert "have order 2" in cond.detail
    # with Jordan λ asked for, the designers' design stays (order 2)
    assert design(m, observer="diagnostic", faults=["f"], lambdas=[-1, -2]).k == 2
    r = _residual_run(d, st, 3, fault=False)
    assert np.max(np.abs(r)) < 1e-9
    assert np.max(np.abs(_residual_run(d, st, 3, fault=True))) > 1e-3


def test_a_steady_state_gain_is_kept_where_a_member_has_one():
    """f in every output (a random draw, seed 239 of the property's generator): of the two
    members of V_1 that see f, the first basis row does so as a transient only; a member
    with a nonzero steady-state gain exists and is the one chosen (the gain recomputed
    from the matrices: R* Dy · 0 + D*_1 at s = 0)."""
    x1, x2, x3, u, f, rho = sp.symbols("x1 x2 x3 u f rho")
    m = PlantModel(name="dc", time="continuous", states=[x1, x2, x3], inputs=[u], faults=[f],
                   disturbances=[rho],
                   outputs=[f - u - x1, f - u + x1 - x2 + x3, f + u + x1 - x2],
                   dynamics=[-rho - x1 - x2 - x3, rho + 2 * u + x1 + x2, rho + 2 * x1 + 2 * x2])
    d = design(m, observer="diagnostic", faults=["f"])
    st = d.structure
    assert d.k == 1 and d.certificate.passed
    assert (sp.Matrix(d.matrices.Phi) * st.D - sp.Matrix(d.matrices.J_star) * st.Dy)[0] != 0
    (sig,) = d.signature
    assert sig.sensitive and not sig.transient_only
    assert "with a nonzero steady-state gain to each" in d.choice


# ------------------------------------------------------------------ random plants
def _random_plant(seed: int) -> PlantModel:
    """Three states, two or three outputs, a control u in the dynamics and the outputs, a
    fault f in some output (sometimes in the dynamics too), a disturbance ρ in the
    dynamics and sometimes in the outputs."""
    rng = np.random.default_rng(seed)
    n, l = 3, int(rng.integers(2, 4))  # noqa: E741
    time = ("continuous", "discrete")[int(rng.integers(2))]
    xs = sp.symbols("x1:4")
    u, f, rho = sp.symbols("u f rho")
    Fm = rng.integers(-2, 3, size=(n, n))
    Hm = rng.integers(-1, 2, size=(l, n))
    g, dcol, lcol = (rng.integers(-2, 3, size=n) for _ in range(3))
    dcol = dcol * int(rng.integers(2))
    lcol[rng.integers(n)] = 1
    gy, fy = rng.integers(-1, 2, size=l), rng.integers(-1, 2, size=l)
    fy[rng.integers(l)] = 1
    ly = rng.integers(-1, 2, size=l) * int(rng.integers(2))
    scale = 1 if time == "continuous" else sp.Rational(1, 2)
    dyn = [scale * sum(int(Fm[i, j]) * xs[j] for j in range(n)) + int(g[i]) * u
           + int(dcol[i]) * f + int(lcol[i]) * rho for i in range(n)]
    outs = [sum(int(Hm[i, j]) * xs[j] for j in range(n)) + int(gy[i]) * u + int(fy[i]) * f
            + int(ly[i]) * rho for i in range(l)]
    return PlantModel(name="rnd", time=time, states=list(xs), inputs=[u], faults=[f],
                      disturbances=[rho], outputs=outs, dynamics=dyn)


def _residual_run(d, st, seed: int, *, fault: bool) -> np.ndarray:
    """Plant and observer (with its output injection K r) from their matrices, RK4 or the
    recursion in discrete time, under a random ρ and u, f a unit step at the start when
    ``fault`` (else 0), x*(0) = Φ x(0): r = R* (y − Gy u) − H* x* at every step, divided
    by the largest |y| so far when there is no fault (a random plant may be unstable)."""
    m = d.matrices
    P, Fs, J, Gs, R, Hs = (_f(M) for M in (m.Phi, m.F_star, m.J_star, m.G_star, m.R_star,
                                           m.H_star))
    K = _f(m.K) if m.K is not None else np.zeros((d.k, 1))  # (Jordan: F* stable, no K)
    F, G, L, H, Gy, Ly = (_f(M) for M in (st.F, st.G, st.L, st.H, st.Gy, st.Ly))
    D, Dy = _f(st.D), _f(st.Dy)
    rng = np.random.default_rng(seed)
    a, w, ph = rng.uniform(0.5, 2, 3), rng.uniform(0.5, 4, 3), rng.uniform(0, 6, 3)

    def sig(t):
        return (np.array([np.cos(0.7 * t)]), np.array([np.sum(a * np.sin(w * t + ph))]),
                np.array([1.0 if fault else 0.0]))

    def outputs(t, x):
        u, rho, f = sig(t)
        return H @ x + Gy @ u + Ly @ rho + Dy @ f, u

    def rhs(t, z):
        x, xs = z[:st.n], z[st.n:]
        u, rho, f = sig(t)
        y, _ = outputs(t, x)
        r = R @ (y - Gy @ u) - Hs @ xs
        return np.concatenate([F @ x + G @ u + L @ rho + D @ f, Fs @ xs + J @ y + Gs @ u + K @ r])
    x0 = rng.uniform(-1, 1, st.n) * (0.0 if fault else 1.0)
    z, out, dt, scale = np.concatenate([x0, P @ x0]), [], 0.01, 1.0
    discrete = st.model.time == "discrete"
    for i in range(40 if discrete else 300):
        t = float(i) if discrete else i * dt
        y, u = outputs(t, z[:st.n])
        scale = scale if fault else max(scale, float(np.max(np.abs(y))))
        out.append((R @ (y - Gy @ u) - Hs @ z[st.n:]) / scale)
        if discrete:
            z = rhs(t, z)
            continue
        k1 = rhs(t, z)
        k2 = rhs(t + dt / 2, z + dt / 2 * k1)
        k3 = rhs(t + dt / 2, z + dt / 2 * k2)
        k4 = rhs(t + dt, z + dt * k3)
        z = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return np.array(out)


@settings(max_examples=10, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(seed=st_.integers(0, 100_000))
def test_random_plants_with_faults_in_the_outputs_get_the_least_order(seed):
    """Designed order = analysis' least order below n (a refusal in one line otherwise);
    certified; r stays at zero under ρ and u and its transfer numerator is not zero."""
    m = _random_plant(seed)
    st = extract_structure(m)
    (least,), _ = feedthrough_orders(st.F, st.H, st.L, st.Ly, st.D, st.Dy, time=m.time)
    if least is None or least >= st.n:
        with pytest.raises(InfeasibleDesignError) as e:
            design(m, observer="diagnostic", faults=["f"])
        assert "\n" not in str(e.value)
        return
    d = design(m, observer="diagnostic", faults=["f"])
    assert d.certificate.passed and d.k == least
    assert d.signature_map == {"f": True}
    assert not _numerator(d, st).is_zero_matrix
    if d.k:
        assert np.max(np.abs(_residual_run(d, st, seed, fault=False))) < 1e-9


def _random_two_fault_plant(seed: int) -> PlantModel:
    """As :func:`_random_plant` with a second fault g in the dynamics (sometimes in the
    outputs too); both are to be detected."""
    rng = np.random.default_rng(seed)
    n, l = 3, int(rng.integers(2, 4))  # noqa: E741
    time = ("continuous", "discrete")[int(rng.integers(2))]
    xs = sp.symbols("x1:4")
    u, f, g, rho = sp.symbols("u f g rho")
    Fm, Hm = rng.integers(-2, 3, size=(n, n)), rng.integers(-1, 2, size=(l, n))
    gc, dcol, ecol, lcol = (rng.integers(-2, 3, size=n) for _ in range(4))
    dcol = dcol * int(rng.integers(2))
    lcol[rng.integers(n)] = 1
    ecol[rng.integers(n)] = 1
    gy, fy = rng.integers(-1, 2, size=l), rng.integers(-1, 2, size=l)
    ey = rng.integers(-1, 2, size=l) * int(rng.integers(2))
    fy[rng.integers(l)] = 1
    ly = rng.integers(-1, 2, size=l) * int(rng.integers(2))
    dyn = [sum(int(Fm[i, j]) * xs[j] for j in range(n)) + int(gc[i]) * u + int(dcol[i]) * f
           + int(ecol[i]) * g + int(lcol[i]) * rho for i in range(n)]
    outs = [sum(int(Hm[i, j]) * xs[j] for j in range(n)) + int(gy[i]) * u + int(fy[i]) * f
            + int(ey[i]) * g + int(ly[i]) * rho for i in range(l)]
    return PlantModel(name="rnd2", time=time, states=list(xs), inputs=[u], faults=[f, g],
                      disturbances=[rho], outputs=outs, dynamics=dyn)


@pytest.mark.parametrize("seed", [6, 8, 20, 45, 66, 19])
def test_two_faults_to_detect_get_the_largest_of_their_least_orders(seed):
    """Several faults to detect: a generic combination of the basis rows sees them all at
    the largest of their least orders (the spaces are nested). Seeds 6 and 45 the
    designers refused, 20 and 66 they made at order 2 (least 1), 8 has a sensor reading
    g alone (y1 = g, whose measured part is 0), 19 is refused (least order n)."""
    m = _random_two_fault_plant(seed)
    st = extract_structure(m)
    orders, _ = feedthrough_orders(st.F, st.H, st.L, st.Ly, st.D, st.Dy, time=m.time)
    least = None if None in orders else max(orders)
    if least is None or least >= st.n:
        with pytest.raises(InfeasibleDesignError):
            design(m, observer="diagnostic", faults=["f", "g"])
        return
    d = design(m, observer="diagnostic", faults=["f", "g"])
    assert d.k == least and d.certificate.passed
    assert d.signature_map == {"f": True, "g": True}
    assert all(not _numerator(d, st)[:, j].is_zero_matrix for j in range(2))


@pytest.mark.parametrize("seed", [100, 229, 1, 97, 5])
def test_random_plants_fixed_seeds(seed):
    """The property on fixed draws: 100 and 229 the designers made at order 2 (least 1),
    1 they refused (least 1), 97 undetectable, 5 of least order n (both refused)."""
    test_random_plants_with_faults_in_the_outputs_get_the_least_order.hypothesis.inner_test(
        seed=seed)
