"""Units declared in model files reach the simulation result, signals.units.json and the
plots; SimulationResult.to_pandas(); short reprs and notebook renderings of PlantModel and
SimulationResult."""
from __future__ import annotations

import builtins
import csv
import json
import sys

import numpy as np
import pytest
import sympy as sp

from observer_cad import ModelError, PlantModel, build_observer, design, load_model, simulate
from observer_cad.reporting import UNITS_FILE, plot_simulation, write_signals_csv
from observer_cad.simulation import column_units, scenario_from_dict

x1, x2 = sp.symbols("x1 x2")
u, d, rho, w = sp.symbols("u d rho w")


def _model(**kw):
    base = dict(name="two", time="discrete", states=[x1, x2], inputs=[u], faults=[d],
                disturbances=[rho], noise=[w], outputs=[x1 + w],
                dynamics=[x1 / 2 + x2 / 4 + u, x2 / 2 + d + rho])
    base.update(kw)
    return PlantModel(**base)


# ------------------------------------------------------------------ declaring units
def test_units_by_symbol_or_name():
    m = _model(units={x1: "rad", "u": "V"})
    assert dict(m.units) == {x1: "rad", u: "V"}
    assert m.unit_of("x1") == "rad" and m.unit_of("u") == "V" and m.unit_of("x2") is None


@pytest.mark.parametrize("units, words", [
    ({sp.Symbol("q"): "m"}, "'q', which is not a declared symbol"),
    ({"nope": "m"}, "'nope', which is not a declared symbol"),
    ({x1: 3}, "unit of 'x1' must be a non-empty one-line string"),
    ({x1: "  "}, "unit of 'x1' must be a non-empty one-line string"),
    ({x1: "m\nrad"}, "unit of 'x1' must be a non-empty one-line string"),
    ({x1: "m", "x1": "rad"}, "units of 'x1' are given twice"),
    (["x1"], "units must be a mapping"),
])
def test_bad_units_are_model_errors(units, words):
    with pytest.raises(ModelError, match="model 'two'") as exc:
        _model(units=units)
    assert words in str(exc.value)


def test_output_unit_is_the_unit_its_states_share():
    m = _model(outputs=[x1 + w, x1 - 2 * x2], units={x1: "m", x2: "m"})
    assert m.output_unit(0) == "m" and m.output_unit(1) == "m"
    m = _model(outputs=[x1 + w, x1 - x2], units={x1: "m", x2: "rad"})
    assert m.output_unit(1) is None       # mixed units: none rather than a guess
    m = _model(outputs=[x1 + w, x1 - x2], units={x1: "m"})
    assert m.output_unit(1) is None       # a state without a unit
    assert m.unit_of("y1") == "m"


def test_parameter_units_survive_substitution():
    k = sp.Symbol("k")
    m = _model(dynamics=[k * x1 + u, x2 / 2 + d + rho], parameters={k: sp.Rational(1, 2)},
               units={x1: "m", k: "1/s"})
    assert dict(m.substitute_parameters().units) == {x1: "m"}


def test_example_models_declare_units_only_where_their_source_gives_them(models_dir):
    drive = load_model(models_dir / "electric_drive.py")
    # the model file's docstring: x1 angle [rad], x2 speed [rad/s], x3 current [A], u voltage [V]
    declared = {str(s): v for s, v in drive.units.items()}
    assert declared.items() >= {"x1": "rad", "x2": "rad/s", "x3": "A", "u": "V"}.items()
    for name in ("three_tank.py", "three_tank_linear.py"):
        assert not load_model(models_dir / name).units, f"{name}: the papers give no units"


# ------------------------------------------------------------------ units of columns
@pytest.fixture(scope="module")
def drive_run(models_dir):
    model = load_model(models_dir / "electric_drive.py")
    obs = build_observer(model, design(model, observer="unknown-input", faults=["d"]))
    sc = scenario_from_dict({"steps": 30, "signals": {"u": "0.2*sin(t/10)", "d": "0.1*sin(t/3)"}})
    return model, obs, simulate(model, obs, sc)


def test_estimates_inherit_their_signals_unit(drive_run):
    model, obs, res = drive_run
    assert res.units["d_hat"] == "A" and res.units["d"] == "A"
    assert res.units["y1"] == "rad" and res.units["y2"] == "A"
    assert res.model == "electric_drive" and res.time == "discrete"


def test_column_units_for_every_observer_output_kind():
    m = _model(outputs=[x1 + w, x2], units={x1: "m", x2: "m", d: "A"})
    y1, y2 = sp.symbols("y1 y2")
    xs = sp.Symbol("xs")

    class Obs:  # the only attribute column_units reads
        outputs = (("r", xs - y1 + 2 * y2), ("r2", xs - y1))
    names = ["x1_hat", "x1_lower", "x1_upper", "d_hat", "z_hat", "r", "r2", "t"]
    assert column_units(m, Obs(), names) == {
        "x1_hat": "m", "x1_lower": "m", "x1_upper": "m", "d_hat": "A", "r": "m", "r2": "m"}
    m2 = _model(outputs=[x1 + w, x2], units={x1: "m", x2: "rad"})
    assert "r" not in column_units(m2, Obs(), ["r"])   # compares outputs of two units


def test_units_sidecar_beside_an_unchanged_csv(drive_run, tmp_path):
    _, _, res = drive_run
    path = write_signals_csv(res, tmp_path)
    with open(path, newline="") as f:
        header = next(csv.reader(f))
    assert header == list(res.order)                     # the CSV's columns are untouched
    side = json.loads((tmp_path / UNITS_FILE).read_text())
    assert side["d_hat"] == "A" and side["x1"] == "rad"
    assert list(side) == [c for c in res.order if c in side]
    assert set(side) <= set(header)                      # noise columns are not in the CSV


def test_units_sidecar_is_rewritten_when_a_model_has_none(tmp_path):
    m = _model()
    res = simulate(m, None, scenario_from_dict({"steps": 5}))
    write_signals_csv(res, tmp_path)
    assert json.loads((tmp_path / UNITS_FILE).read_text()) == {}


def test_plots_label_axes_with_units(drive_run, tmp_path, monkeypatch):
    _, _, res = drive_run
    import matplotlib.axes
    labels = []
    orig = matplotlib.axes.Axes.set_ylabel
    monkeypatch.setattr(matplotlib.axes.Axes, "set_ylabel",
                        lambda self, text, *a, **k: (labels.append(text), orig(self, text, *a, **k))[1])
    plot_simulation(res, tmp_path, time="discrete")
    assert "d [A]" in labels and "error [A]" in labels


# ------------------------------------------------------------------ to_pandas
def test_to_pandas_one_run(drive_run):
    pd = pytest.importorskip("pandas")
    _, _, res = drive_run
    df = res.to_pandas()
    assert list(df.columns) == [c for c in res.order if c != "t"]
    assert df.index.name == "t" and len(df) == len(res["t"])
    np.testing.assert_array_equal(df["d_hat"].to_numpy(), np.asarray(res["d_hat"]))
    assert df.attrs["units"]["d_hat"] == "A"
    assert isinstance(df, pd.DataFrame)


def test_to_pandas_many_runs(models_dir):
    pytest.importorskip("pandas")
    model = load_model(models_dir / "electric_drive.py")
    sc = scenario_from_dict({"steps": 10, "seed": 3, "signals": {"rho": {"uniform": [-0.05, 0.05]}}})
    res = simulate(model, None, sc, runs=3)
    df = res.to_pandas()
    assert df.index.names == ["run", "t"] and len(df) == 30
    np.testing.assert_array_equal(df.loc[2]["rho"].to_numpy(), res["rho"][2])


def test_to_pandas_without_pandas_says_how_to_install(drive_run, monkeypatch):
    _, _, res = drive_run
    real_import = builtins.__import__

    def no_pandas(name, *a, **k):
        if name == "pandas" or name.startswith("pandas."):
            raise ImportError("No module named 'pandas'")
        return real_import(name, *a, **k)
    monkeypatch.delitem(sys.modules, "pandas", raising=False)
    monkeypatch.setattr(builtins, "__import__", no_pandas)
    with pytest.raises(ImportError) as exc:
        res.to_pandas()
    msg = str(exc.value)
    assert "pip install pandas" in msg and "\n" not in msg


# ------------------------------------------------------------------ reprs
def test_plant_model_repr_is_short(models_dir):
    m = load_model(models_dir / "electric_drive.py")
    r = repr(m)
    assert r == ("<PlantModel 'electric_drive': discrete time, 3 states, 2 outputs, 1 input,"
                 " 1 fault, 1 disturbance, 2 noise, 6 parameters>")
    md = m._repr_markdown_()
    assert "x1 [rad]" in md and "electric_drive" in md and len(md) < 2000
    tex = m._repr_latex_()
    assert tex.startswith("$$") and r"x_{1}(t+1)" in tex


def test_simulation_result_repr_is_short(drive_run):
    _, _, res = drive_run
    r = repr(res)
    assert r == "<SimulationResult 'electric_drive', discrete time, 30 samples, t = 0 … 29 steps, 9 signals>"
    assert "`d_hat [A]`" in res._repr_markdown_()
    assert res._repr_latex_().startswith("$") and len(res._repr_latex_()) < 1000
