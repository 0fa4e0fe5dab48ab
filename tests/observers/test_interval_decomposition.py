"""Interval observers for Lipschitz non-monotone terms (METHOD §3): the γ-shift
(mixed-monotone) decomposition and the stability of the interval-width comparison system.

What is proven here, each by something that could fail:
- the refusal without the decomposition is still there (decomposition='none');
- the decomposition's premise, checked independently of the observer code: at random
  boxes x̲* ≤ x* ≤ x̄* and admissible noise/disturbance, the lower (upper) right-hand side
  is ≤ (≥) Φ_i times the plant's own right-hand side, with the plant state rebuilt from
  (x*, ỹ) through [Φ; H]⁻¹ (continuous time: x*_i on its face);
- Monte-Carlo inclusion lower ≤ x1 ≤ upper at every sample of many seeded disturbance/
  noise realisations, with the reference simulator and the compiled one, on a scenario
  that provably visits the non-monotone regions (x2 past ±π/2, x1 − x2 changing sign);
- understated bounds do give violations (the inclusion check is not vacuous);
- an unstable comparison system is refused, naming γ and α(M) (continuous) or ρ(M)
  (discrete).

TOL = 1e-9 as in test_interval.py (double-precision RK4 of plant and observer together).
"""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, UsageError, load_model
from observer_cad.errors import InfeasibleDesignError
from observer_cad.observers import interval_observer_nonlinear
from observer_cad.simulation import load_scenario, scenario_from_dict, simulate
from observer_cad.analysis import derivative_range, lipschitz
from observer_cad.synthesis import design_jordan

TOL = 1e-9
RUNS = 500


@pytest.fixture(scope="module")
def chain(models_dir):
    return load_model(models_dir / "nonmonotone_chain.py")


@pytest.fixture(scope="module")
def chain_design(chain):
    return design_jordan(chain, observer="interval", estimate="x1")


@pytest.fixture(scope="module")
def chain_observer(chain, chain_design):
    return interval_observer_nonlinear(chain, chain_design)


@pytest.fixture(scope="module")
def chain_scenario(models_dir):
    return load_scenario(models_dir / "scenarios" / "nonmonotone_chain_interval.json")


def _cond(obs, prefix):
    found = [c for c in obs.conditions if c.name.startswith(prefix)]
    assert len(found) == 1, prefix
    return found[0]


def violations(res, name="x1"):
    lo, hi, z = res[f"{name}_lower"], res[f"{name}_upper"], res[name]
    assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(np.isfinite(z))
    assert np.all(lo <= hi + TOL)
    return int(np.sum((z < lo - TOL) | (z > hi + TOL)))


def with_gains(model, a, b):
    pa, pb = sp.symbols("a b")
    return dataclasses.replace(model, parameters={pa: sp.nsimplify(a), pb: sp.nsimplify(b)})


def scaled_bounds(model, factor):
    f = sp.nsimplify(factor)
    return dataclasses.replace(model, bounds={s: (lo * f, hi * f) for s, (lo, hi) in model.bounds.items()})


# ---------------------------------------------------------------- range analysis of |·|
def test_abs_derivative_bounds_are_proven_not_sampled():
    """exp(−|s|) has φ' = −sign(s) e^(−|s|) ∈ [−1, 1]: exact on each side of the kink
    (the samples alone gave ≈ ±0.95 and no proof)."""
    r = sp.Symbol("r", real=True)
    assert derivative_range(sp.exp(-sp.Abs(r)), r, -sp.oo, sp.oo) == (-1, 1, "exact")
    lo, hi, kind = derivative_range(sp.exp(-2 * sp.Abs(r - 1)), r, 0, sp.oo)
    assert (lo, hi, kind) == (-2, 2, "exact")
    lo, hi, kind = derivative_range(sp.exp(-sp.Abs(r)), r, 1, 3)
    assert (lo, hi, kind) == (-sp.exp(-1), -sp.exp(-3), "exact")
    x1, x2 = sp.symbols("x1 x2")
    lip = lipschitz([sp.exp(-sp.Abs(x1 - x2))], [x1, x2])
    assert lip.lipschitz and lip.kind == "symbolic"
    assert float(lip.constant) == pytest.approx(np.sqrt(2), rel=1e-12)


# ---------------------------------------------------------------- the continuous chain
def test_chain_without_decomposition_is_refused(chain, chain_design):
    with pytest.raises(UsageError, match="not monotone in xs2"):
        interval_observer_nonlinear(chain, chain_design, decomposition="none")
    with pytest.raises(UsageError, match="decomposition: expected 'auto' or 'none'"):
        interval_observer_nonlinear(chain, chain_design, decomposition="lipschitz")


def test_chain_conditions_list_gamma_and_stability(chain, chain_design, chain_observer):
    d, o = chain_design, chain_observer
    assert d.k == 2  # sin(x2) needs x2 in the span of [Φ; H]
    emb = _cond(o, "mixed-monotone embedding")
    assert not emb.holds and not emb.required and "γ-shift" in emb.detail
    dec = _cond(o, "γ-shift decomposition")
    assert dec.holds and dec.required
    # the γ of every shifted (row, argument), exact, with its derivative bound and domain
    for part in ("row 1, xs2: ∂f/∂xs2 ∈ [-3/8, 3/8], γ = 3/8", "row 1, ytilde1: ∂f/∂ytilde1 ∈"
                 " [-1/8, 1/8], γ = 1/8", "row 2, xs1: ∂f/∂xs1 ∈ [-1/8, 1/8], γ = 1/8"):
        assert part in dec.detail
    assert "domain Rⁿ" in dec.detail and "proven" in dec.detail
    cmp_ = _cond(o, "comparison system of the interval width stable")
    assert cmp_.holds and cmp_.required
    assert "M = [-7/8, 9/8; 3/8, -21/8]" in cmp_.detail
    # independent check of the stated α(M): the Metzler matrix is Hurwitz
    M = np.array([[-7 / 8, 9 / 8], [3 / 8, -21 / 8]])
    alpha = float(np.max(np.linalg.eigvals(M).real))
    assert alpha < 0 and f"α(M) = {alpha:.6g}" in cmp_.detail
    # the generic Lipschitz check now bounds exp(−|·|) rigorously too
    lip = _cond(o, "Lipschitz constant of C*Ψ* (in x*)")
    assert lip.holds and "rigorous" in lip.detail


def _premise_check(model, design, obs, rng, n=4000, noise_factor=1):
    """Count samples where lower_i > Φ_i f(x) or upper_i < Φ_i f(x) (continuous time:
    x*_i on its face). Plant states are rebuilt from (x*, ỹ) by [Φ; H]⁻¹; disturbance
    and noise are drawn from their boxes (noise scaled by noise_factor)."""
    m = model.substitute_parameters()
    st = design.structure
    Phi = np.array(sp.Matrix(design.matrices.Phi).evalf(), dtype=float)
    H = np.array(sp.Matrix(st.H).evalf(), dtype=float)
    T = np.linalg.inv(np.vstack([Phi, H]))
    k = Phi.shape[0]
    xl, xu = obs.states[:k], obs.states[k:]
    y1, u, rho, w = sp.symbols("y1 u rho w")
    upd = sp.lambdify([list(obs.states), y1, u], list(obs.update), "numpy")
    dyn = sp.lambdify([list(m.states), u, rho], list(m.dynamics), "numpy")
    (r_lo, r_hi), (w_lo, w_hi) = [tuple(float(v) for v in m.bounds[s]) for s in (rho, w)]
    bad = 0
    for _ in range(n):
        lo = rng.uniform(-4, 4, k)
        hi = lo + rng.exponential(0.5, k) * (rng.random(k) < 0.8)
        xs = lo + (hi - lo) * rng.random(k)
        ytil = rng.uniform(-3, 3)
        wv = rng.uniform(w_lo, w_hi) * noise_factor
        uv, rv = rng.uniform(-12, 12), rng.uniform(r_lo, r_hi)
        vals = np.array(upd(list(lo) + list(hi), ytil + wv, uv), dtype=float)
        for i in range(k):
            for face, bound, sgn in ((lo, vals[i], 1), (hi, vals[k + i], -1)):
                xi = xs.copy()
                xi[i] = face[i]
                x = T @ np.concatenate([xi, [ytil]])
                true = Phi[i] @ np.array(dyn(list(x), uv, rv), dtype=float)
                if sgn * (true - bound) < -TOL:
                    bad += 1
    return bad


def test_chain_decomposition_premise_holds_pointwise(chain, chain_design, chain_observer):
    assert _premise_check(chain, chain_design, chain_observer, np.random.default_rng(0)) == 0


def test_chain_premise_check_detects_understated_noise(chain, chain_design, chain_observer):
    """The same oracle with noise 5× its declared bound finds violations."""
    assert _premise_check(chain, chain_design, chain_observer, np.random.default_rng(1),
                          noise_factor=5) > 0


@pytest.mark.slow
def test_chain_monte_carlo_inclusion_reference(chain, chain_observer, chain_scenario):
    res = simulate(chain, chain_observer, chain_scenario, runs=RUNS)
    assert res["t"].shape == (RUNS, 2001)
    # the runs visit the non-monotone regions: sin(x2) past its maxima, x1 − x2 crossing 0
    assert np.max(np.abs(res["x2"])) > np.pi / 2 + 0.2
    assert np.sum(np.diff(np.sign(res["x1"][0] - res["x2"][0])) != 0) >= 2
    assert violations(res) == 0
    width = res["x1_upper"][:, -1] - res["x1_lower"][:, -1]
    assert np.all(width < 0.3)  # informative: ≈ 0.22 once the initial box has decayed


def test_chain_monte_carlo_inclusion_extreme_noise(chain, chain_observer):
    """Noise held at its bound and the disturbance switching between its ends (worst
    cases that uniform samples rarely reach)."""
    for sign in (1, -1):
        sc = scenario_from_dict({
            "t_end": 20, "dt": 0.01, "seed": 0, "initial": {"x1": -1, "x2": 0.4, "x3": -0.2},
            "signals": {"u": "12*sin(t/2) + 3*sin(3*t)", "w": str(sign * 0.01),
                        "rho": f"{sign}*0.1*sign(sin(7*t))"}})
        assert violations(simulate(chain, chain_observer, sc, runs=1)) == 0


@pytest.mark.slow
def test_chain_monte_carlo_inclusion_compiled(chain, chain_observer, chain_scenario, tmp_path,
                                              monkeypatch):
    pytest.importorskip("casadi")
    from observer_cad.codegen import CompiledSimulator
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    try:
        sim = CompiledSimulator(chain, chain_observer)
    except Exception as exc:  # noqa: BLE001 - no C compiler on this machine
        pytest.skip(f"the observer does not compile here: {exc}")
    res = sim.simulate(chain_scenario, runs=1000)
    assert violations(res) == 0
    ref = simulate(chain, chain_observer, chain_scenario, runs=2)
    small = sim.simulate(chain_scenario, runs=2)
    for c in ("x1", "x1_lower", "x1_upper"):
        assert np.max(np.abs(ref[c] - small[c])) < 1e-9


def test_chain_understated_bounds_are_violated(chain, chain_scenario):
    """Declared bounds set to zero: the observer then tracks the undisturbed plant and
    the disturbed one leaves the interval — the inclusion check can fail."""
    m = scaled_bounds(chain, 0)
    o = interval_observer_nonlinear(m, design_jordan(m, observer="interval", estimate="x1"))
    assert violations(simulate(chain, o, chain_scenario, runs=20)) > 0


def test_chain_unstable_comparison_is_refused(chain):
    m = with_gains(chain, sp.Rational(1, 2), sp.Rational(1, 2))
    d = design_jordan(m, observer="interval", estimate="x1")
    with pytest.raises(InfeasibleDesignError) as exc:
        interval_observer_nonlinear(m, d)
    msg = str(exc.value)
    assert "\n" not in msg
    assert "unstable comparison system" in msg
    assert "γ = 3/4" in msg and "spectral abscissa α(M) = 0, not < 0" in msg


# ---------------------------------------------------------------- discrete time
def _discrete(c_sin):
    x1, x2 = sp.symbols("x1 x2")
    u, rho, w = sp.symbols("u rho w")
    return PlantModel(
        name="discrete_sine", time="discrete", states=[x1, x2], inputs=[u],
        disturbances=[rho], noise=[w], outputs=[x2 + w],
        dynamics=[sp.Rational(1, 10) * x1 + c_sin * sp.sin(x1) + u + rho,
                  x1 + sp.Rational(1, 2) * x2],
        bounds={rho: (-0.05, 0.05), w: (-0.01, 0.01)})


def test_discrete_sine_decomposed_and_included():
    """λ = 1/10, x* = x1: x*(t+1) = x*/10 + (3/10) sin x* + u + ρ, ∂f/∂x* ∈ [−1/5, 2/5]
    changes sign (in discrete time x*_i itself needs a sign): γ = 1/5, M = 2/5 + 1/5 +
    1/5 = 4/5 < 1. The default design (λ = 1/2, x* = x1 + 2x2/5) is monotone in x* and
    shifts the output instead: ∂f/∂ỹ = −(3/25) cos(·) ∈ [−3/25, 3/25], M = 4/5."""
    m = _discrete(sp.Rational(3, 10))
    sc = scenario_from_dict({"steps": 300, "seed": 7, "initial": {"x1": 2, "x2": 0},
                             "signals": {"u": "3*sin(t/5)", "rho": {"uniform": [-0.05, 0.05]},
                                         "w": {"uniform": [-0.01, 0.01]}}})
    for lambdas, shifted in (([sp.Rational(1, 10)], "∂f/∂xs1 ∈ [-1/5, 2/5], γ = 1/5"),
                             (None, "∂f/∂ytilde1 ∈ [-3/25, 3/25], γ = 3/25")):
        d = design_jordan(m, observer="interval", estimate="x1", lambdas=lambdas)
        o = interval_observer_nonlinear(m, d)
        assert d.k == 1
        assert shifted in _cond(o, "γ-shift decomposition").detail
        cmp_ = _cond(o, "comparison system of the interval width stable")
        assert cmp_.holds and cmp_.required and "M = [4/5]" in cmp_.detail
        assert "spectral radius ρ(M) = 0.8 < 1" in cmp_.detail
        res = simulate(m, o, sc, runs=RUNS)
        assert np.max(np.abs(res["x1"])) > np.pi  # past the turns of sin
        assert violations(res) == 0
        width = res["x1_upper"][:, -1] - res["x1_lower"][:, -1]
        assert np.all(width < 1)


def test_discrete_sine_unstable_is_refused():
    m = _discrete(sp.Rational(6, 10))  # ∂f/∂x* ∈ [−1/2, 7/10]: γ = 1/2, M = 17/10
    d = design_jordan(m, observer="interval", estimate="x1", lambdas=[sp.Rational(1, 10)])
    with pytest.raises(InfeasibleDesignError, match=r"γ = 1/2 .*spectral radius ρ\(M\) = 1\.7, not < 1"):
        interval_observer_nonlinear(m, d)


# ---------------------------------------------------------------- command line
def test_cli_design_lists_the_decomposition(models_dir, capsys):
    from observer_cad.cli import main
    rc = main(["design", str(models_dir / "nonmonotone_chain.py"), "--observer", "interval",
               "--estimate", "x1", "--json"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    j = json.loads(cap.out)
    names = {c["name"]: c for c in j["observer_conditions"]}
    cmp_ = next(c for n, c in names.items() if n.startswith("comparison system"))
    assert cmp_["holds"] and cmp_["required"]
