"""Complete assumptions: every denominator of everything a symbolic
design reports is excluded by its assumptions, checked by an independent oracle
(:mod:`assumption_oracle`) over every symbolic design of the example models and of
parametrised variants built here. (``conftest.py`` runs the same oracle on every
symbolic design any other test makes.)"""
from __future__ import annotations

import itertools

import pytest
import sympy as sp

from assumption_oracle import check_design
from observer_cad import PlantModel, design, load_model
from observer_cad.errors import InfeasibleDesignError, UsageError
from observer_cad.synthesis import complete_assumptions, denominator_assumptions


def _electric_drive(models_dir):
    return load_model(models_dir / "electric_drive.py")


def _three_tank_parametrised():
    """The linear three-tank of seed 001 §7 with its coefficients as parameters."""
    x1, x2, x3 = sp.symbols("x1 x2 x3")
    u1, u2, rho = sp.symbols("u1 u2 rho")
    a, b, c, e = sp.symbols("a b c e")
    return PlantModel(
        name="three_tank_param", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
        disturbances=[rho], outputs=[x2, x3],
        dynamics=[-a * x1 + b * x2 + u1, x1 - c * x2 + x3 + u2, e * x2 - 2 * x3 + rho],
        parameters={a: 1, b: 1, c: 2, e: 1})


def _uio_parametrised():
    """A discrete plant with a fault to estimate and a parameter in every matrix."""
    x1, x2, x3 = sp.symbols("x1 x2 x3")
    u, d, rho = sp.symbols("u d rho")
    p, q, r, s = sp.symbols("p q r s")
    return PlantModel(
        name="uio_param", time="discrete", states=[x1, x2, x3], inputs=[u], faults=[d],
        disturbances=[rho], outputs=[x1, p * x2 + x3],
        dynamics=[q * x1 + x2, r * x2 + x3 + rho, s * x1 + x3 / 2 + u + d],
        parameters={p: 1, q: sp.Rational(1, 2), r: sp.Rational(1, 3), s: 2})


_OPTIONS = (
    [dict(observer="unknown-input", faults=[f], form=form)
     for f in ("d", "rho") for form in ("canonical", "jordan")]
    + [dict(observer="diagnostic", faults=["d"], form=form) for form in ("canonical", "jordan")]
    + [dict(observer=kind, estimate=z, form=form)
       for kind in ("virtual-sensor", "interval") for z in ("x1", "x2", "x3", "x1 - x2")
       for form in ("canonical", "jordan")]
    + [dict(observer="virtual-sensor", estimate=z, form="canonical", variant="004")
       for z in ("x1", "x2")]
)


def _symbolic_designs(model):
    made = []
    for opts in _OPTIONS:
        if opts.get("faults") and not all(model.symbol(f) for f in opts["faults"]):
            continue
        try:
            made.append((opts, design(model, symbolic=True, **opts)))
        except (InfeasibleDesignError, UsageError):
            continue
    return made


@pytest.mark.slow
@pytest.mark.parametrize("which", [  # the two parametrised plants take 4–7 s each: slow step
    "electric_drive", pytest.param("three_tank_param", marks=pytest.mark.slow),
    pytest.param("uio_param", marks=pytest.mark.slow)])
def test_every_symbolic_design_excludes_its_denominators(which, models_dir):
    model = {"electric_drive": lambda: _electric_drive(models_dir),
             "three_tank_param": _three_tank_parametrised,
             "uio_param": _uio_parametrised}[which]()
    made = _symbolic_designs(model)
    assert len(made) >= 4, f"{which}: only {len(made)} symbolic designs"
    for opts, d in made:
        problems = check_design(d)
        assert not problems, f"{which} {opts}: {problems[0]}"


def test_canonical_virtual_sensor_divides_by_k4_and_says_so(models_dir):
    """The issue's example: Φ = [1 0 −k1/k4] must come with k4 ≠ 0."""
    model = _electric_drive(models_dir)
    d = design(model, observer="virtual-sensor", estimate="x1", form="canonical",
               symbolic=True)
    k1, k4 = sp.symbols("k1 k4")
    assert d.matrices.Phi[0, 2] == -k1 / k4
    assert sp.Ne(k4, 0) in d.assumptions


def test_the_cli_prints_the_assumption(models_dir, capsys):
    from observer_cad.cli import main
    rc = main(["design", str(models_dir / "electric_drive.py"), "--observer",
               "virtual-sensor", "--estimate", "x1", "--form", "canonical", "--symbolic"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "Assumptions: none" not in out
    assert "Ne(k4, 0)" in out.split("Assumptions", 1)[1]


def test_design_json_carries_the_completed_assumptions(models_dir):
    from observer_cad import Design
    model = _electric_drive(models_dir)
    d = design(model, observer="virtual-sensor", estimate="x3", form="canonical", symbolic=True)
    again = Design.from_json(d.to_json(), model)
    assert set(map(str, again.assumptions)) == set(map(str, d.assumptions))
    assert "Ne(k4, 0)" in map(str, d.assumptions)


def test_denominators_in_the_signals_are_not_parameter_assumptions():
    k, xs1 = sp.symbols("k xs1")
    got = denominator_assumptions([1 / k, 1 / (xs1 - 1), 1 / (k * xs1 + 1), sp.Integer(3)],
                                  {k})
    assert got == frozenset({sp.Ne(k, 0)})


def test_complete_assumptions_merges_without_duplicates():
    k1, k4 = sp.symbols("k1 k4")
    out = complete_assumptions((sp.Ne(k4, 0),), matrices=[sp.Matrix([[1 / k4, k1 / (k1 + k4)]])],
                               parameters={k1, k4})
    assert out == (sp.Ne(k1 + k4, 0), sp.Ne(k4, 0))


def test_a_numeric_design_has_no_assumptions(models_dir):
    d = design(_electric_drive(models_dir), observer="virtual-sensor", estimate="x1",
               form="canonical")
    assert d.assumptions == ()


def test_a_parameter_named_s_does_not_confuse_pole_placement():
    """The characteristic polynomial's variable is private: a model parameter ``s``
    used to merge with it and gave a wrong gain K (F* − K H* not the requested poles)."""
    d = design(_uio_parametrised(), observer="virtual-sensor", estimate="x1",
               form="canonical", variant="004", symbolic=True)
    t = sp.Symbol("t_oracle")
    Fcl = sp.Matrix(d.matrices.F_star) - sp.Matrix(d.matrices.K) * sp.Matrix(d.matrices.H_star)
    cp = sp.expand(sp.cancel((t * sp.eye(Fcl.rows) - Fcl).det()))
    assert cp == sp.expand((t - sp.Rational(1, 2)) * (t - sp.Rational(1, 4)))


def test_the_oracle_catches_a_missing_assumption(models_dir):
    d = design(_electric_drive(models_dir), observer="virtual-sensor", estimate="x1",
               form="canonical", symbolic=True)
    stripped = object.__new__(type(d))
    for f in d.__dataclass_fields__:
        object.__setattr__(stripped, f, getattr(d, f))
    object.__setattr__(stripped, "assumptions", ())
    problems = check_design(stripped)
    assert problems and "k4" in problems[0]
