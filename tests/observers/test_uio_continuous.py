"""Continuous-time unknown-input estimation: the derivative-free estimator whose output is
d filtered by 1/(τ s + 1) (METHOD §3), and the refusals that name what to use instead.

Checked independently of the construction: by simulation, against the exact
zero-order-hold discretisation of the filter applied to the simulated d (signals are held
over a step, so d_f(t+dt) = e^{−dt/τ} d_f(t) + (1 − e^{−dt/τ}) d(t) is the filter's exact
response; the estimator is integrated by RK4, so they agree to integration accuracy), and
by the compiled step against the reference simulator.
"""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import sympy as sp

from observer_cad import design, load_model, simulate
from observer_cad.cli import main
from observer_cad.errors import InfeasibleDesignError, UsageError
from observer_cad.observers import DEFAULT_TAU, build_observer, unknown_input_observer
from observer_cad.simulation import scenario_from_dict
from observer_cad.synthesis import continuous_estimation_check


def _filtered(t, d, tau):
    """d through 1/(τ s + 1) from 0, exactly for a signal held over each step."""
    a = np.exp(-(t[1] - t[0]) / tau)
    out = np.zeros_like(d)
    for k in range(len(d) - 1):
        out[k + 1] = a * out[k] + (1 - a) * d[k]
    return out


@pytest.fixture(scope="module")
def sliding(models_dir):
    return load_model(models_dir / "sliding_example.py")


@pytest.fixture(scope="module")
def tank(models_dir):
    return load_model(models_dir / "three_tank.py")


SLIDING_SC = {"t_end": 5, "dt": 0.001, "initial": {"x1": 0.3, "x2": -0.2, "x3": 0.1},
              "signals": {"u1": "sin(t)", "u2": "0.5", "rho": "0.3*cos(2*t)",
                          "d": "sin(3*t) + Piecewise((0, t < 2), (0.5, True))"}}


@pytest.mark.parametrize("form", ["canonical", "jordan"])
def test_estimator_equations_and_conditions(sliding, form):
    """sliding_example: x* = ±(x2 − x3) = ±(y1 − y2) sees d with D* = ±1, decoupled from ρ."""
    o = build_observer(sliding, design(sliding, observer="unknown-input", faults=["d"], form=form))
    assert o.time == "continuous" and o.kind == "unknown-input"
    assert o.output_names == ("d_hat",) and not o.delays
    assert o.parameters[sp.Symbol("tau")] == DEFAULT_TAU
    eta = sp.Symbol("eta")
    assert o.states == (eta,)
    x2, x3 = sp.symbols("x2 x3")
    assert sp.expand(o.initial[eta] ** 2 - (x2 - x3) ** 2) == 0
    cond = {c.name: c for c in o.own_conditions}
    filt = cond["d̂ is d filtered by 1/(τ s + 1) (computer algebra)"]
    assert filt.holds and "simplifies to 0" in filt.detail
    assert "bandwidth 1/τ = 10" in cond["filter time constant τ > 0"].detail
    assert not o.failed_conditions
    assert "filtered by 1/(tau s + 1), tau = 1/10" in o.description


@pytest.mark.parametrize("tau", [sp.Rational(1, 10), sp.Rational(1, 20)])
def test_estimate_is_the_filtered_input(sliding, tau):
    """d̂ equals d filtered by 1/(τ s + 1) to RK4 accuracy (1e-8), with ρ acting (decoupled)
    and a step in d; d̂ itself differs from d by far more (the filter's lag is real)."""
    o = build_observer(sliding, design(sliding, observer="unknown-input", faults=["d"]), tau=tau)
    r = simulate(sliding, o, scenario_from_dict(SLIDING_SC))
    t, d = r["t"], r["d"]
    df = _filtered(t, d, float(tau))
    assert np.all(np.isfinite(r["d_hat"]))
    assert np.max(np.abs(r["d_hat"] - df)) < 1e-8
    assert np.max(np.abs(r["d_hat"] - d)) > 0.3  # right after the step at t = 2
    late = t > 2 + 10 * float(tau)
    assert np.max(np.abs(r["d_hat"][late] - d[late])) < 3 * 3 * float(tau) + 1e-3  # lag ≈ τ ḋ


def test_nonlinear_three_tank_estimates_a_disturbance(tank):
    """Three-tank (seed 002 §8): ρ2 enters the measured x3 = y2, whose equation reads only
    measured arguments (√(y1 − y2), √y2); ρ1 is decoupled. d̂ = ρ2 filtered, to 1e-8."""
    o = build_observer(tank, design(tank, observer="unknown-input", faults=["rho2"]),
                       tau=sp.Rational(1, 20))
    sc = scenario_from_dict({"t_end": 4, "dt": 0.001, "initial": {"x1": 3, "x2": 2, "x3": 1},
                             "signals": {"u1": "1", "u2": "0.5", "rho1": "0.3*cos(2*t)",
                                         "rho2": "0.2*sin(3*t) + Piecewise((0, t < 2), (0.1, True))"}})
    r = simulate(tank, o, sc)
    assert np.max(np.abs(r["rho2_hat"] - _filtered(r["t"], r["rho2"], 0.05))) < 1e-8


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                    reason="no C compiler")
def test_compiled_step_equals_the_reference(sliding):
    from observer_cad.codegen import CompiledSimulator
    o = build_observer(sliding, design(sliding, observer="unknown-input", faults=["d"]))
    sc = scenario_from_dict(SLIDING_SC)
    ref = simulate(sliding, o, sc)
    got = CompiledSimulator(sliding, o).simulate(sc)
    assert np.max(np.abs(got["d_hat"] - ref["d_hat"])) < 1e-12


# ---------------------------------------------------------------- refusals

def test_structural_refusals_name_what_to_use(models_dir):
    """three_tank_faults: f1 enters the unmeasured tank 1 (H D = 0), f3 enters tank 3 exactly
    as ρ does (H D ∈ span H L), f2 enters the measured tank 2 whose derivative reads the
    unmeasured x1: no measured row, so neither this estimator nor the sliding-mode observer."""
    m = load_model(models_dir / "three_tank_faults.py")
    for f, what in (("f1", "relative degree one"), ("f3", "relative degree one"),
                    ("f2", "no unmeasured state")):
        with pytest.raises(InfeasibleDesignError, match=what) as exc:
            continuous_estimation_check(m, f)
        assert "--observer diagnostic" in str(exc.value) and "\n" not in str(exc.value)


def test_structural_check_passes_where_the_estimator_works(sliding, tank, models_dir):
    continuous_estimation_check(sliding, "d")
    continuous_estimation_check(tank, "rho2")
    continuous_estimation_check(load_model(models_dir / "electric_drive.py"), "d")  # discrete


def test_options_belong_to_their_time_domain(sliding, models_dir):
    d = design(sliding, observer="unknown-input", faults=["d"])
    with pytest.raises(UsageError, match="--tau"):
        unknown_input_observer(sliding, d, g=-0.5)
    with pytest.raises(UsageError, match="positive time constant"):
        unknown_input_observer(sliding, d, tau=0)
    drive = load_model(models_dir / "electric_drive.py")
    with pytest.raises(UsageError, match="continuous-time"):
        unknown_input_observer(drive, design(drive, observer="unknown-input", faults=["d"]),
                               tau=sp.Rational(1, 2))


def test_cli_design_and_refusal(capsys, models_dir):
    rc = main(["design", str(models_dir / "sliding_example.py"), "--observer", "unknown-input",
               "--fault", "d", "--tau", "0.05"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "d_hat is d filtered by 1/(tau s + 1), tau = 1/20" in out
    rc = main(["design", str(models_dir / "three_tank_faults.py"), "--observer", "unknown-input",
               "--fault", "f1"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "--observer diagnostic" in err
    assert "Traceback" not in err


def test_design_refuses_before_any_design_work(models_dir, monkeypatch):
    """The Python entry point runs the rank tests before the designer: with the designer
    replaced by one that fails loudly, the refusal is still the structural one."""
    import observer_cad.synthesis._dispatch as dispatch
    m = load_model(models_dir / "three_tank_faults.py")

    def no_design(*args, **kwargs):
        raise AssertionError("the designer ran")
    monkeypatch.setattr(dispatch, "_exact", no_design)
    with pytest.raises(InfeasibleDesignError, match="--observer diagnostic"):
        design(m, observer="unknown-input", faults=["f1"])


def test_cli_simulate_writes_the_filtered_estimate(tmp_path, capsys, models_dir):
    import csv
    import json
    sc = tmp_path / "sc.json"
    sc.write_text(json.dumps(SLIDING_SC))
    out = tmp_path / "sim"
    rc = main(["simulate", str(models_dir / "sliding_example.py"), "--observer", "unknown-input",
               "--fault", "d", "--tau", "0.05", "--scenario", str(sc), "--out", str(out)])
    capsys.readouterr()
    assert rc == 0
    rows = list(csv.DictReader((out / "signals.csv").open()))
    t = np.array([float(r["t"]) for r in rows])
    d = np.array([float(r["d"]) for r in rows])
    dhat = np.array([float(r["d_hat"]) for r in rows])
    assert np.max(np.abs(dhat - _filtered(t, d, 0.05))) < 1e-8
