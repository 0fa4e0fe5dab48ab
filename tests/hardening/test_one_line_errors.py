"""Users' mistakes of the second hardening round, each one line and exit 2 (never an
internal error): Dask addresses, a threshold near the float range, names with control
characters, a continuous-time unknown-input request (refused before any design work),
huge bounds, a failed required condition in build_observer, sliding-mode gains out of
range."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from observer_cad.cli import main
from observer_cad.ensemble._backends import Backend, dask_address_problem
from observer_cad.errors import FailedConditionError, ModelError, UsageError
from observer_cad.model import MAX_BOUND, PlantModel, load_model
from observer_cad.observers import build_observer
from observer_cad.synthesis import Design, design

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
DRIVE = MODELS / "electric_drive.py"
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")


def _one_line(rc, err, *needles):
    assert rc == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("observer-cad: error:"), err
    assert "internal error" not in err and "Traceback" not in err
    for n in needles:
        assert n in lines[0], lines[0]


# ------------------------------------------------------------------------------ Dask
@pytest.mark.parametrize("address, needle", [
    ("garbage", "host:port"), ("tcp://", "host:port"), ("inproc://x", "scheme 'inproc'"),
    ("tcp://[::1", "closing ']'"), ("tcp://host:0", "port"), ("tcp://host:99999", "port"),
    ("tcp://ho st:1", "white space"), ("tcp://-bad:1", "host"), ("tcp://h:8786\n", "control"),
])
def test_bad_dask_addresses_are_refused_before_any_connection(address, needle):
    assert needle in dask_address_problem(address)


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "tcp://[::1]:8786",
                                     "localhost:8786", "tls://scheduler.example.org:8786"])
def test_good_dask_addresses_pass(address):
    assert dask_address_problem(address) is None


@pytest.mark.parametrize("address", ["garbage", "tcp://", "inproc://x", "tcp://[::1"])
def test_cli_dask_garbage_is_one_line(tmp_path, capsys, address):
    rc = main(["ensemble", str(MODELS / "three_tank.py"), "--observer", "interval", "--estimate",
               "x1", "--scenario", str(MODELS / "scenarios" / "three_tank_ensemble.json"),
               "--runs", "2", "--dask", address, "--out", str(tmp_path / "out")])
    _one_line(rc, capsys.readouterr().err)
    assert not (tmp_path / "out").exists()


def test_backend_refuses_a_bad_address_but_takes_its_own_processes_inproc():
    pytest.importorskip("distributed")
    with pytest.raises(UsageError, match="Dask scheduler address 'tcp://' is not an address"):
        Backend("dask", address="tcp://")
    # (a LocalCluster(processes=False) made from Python has an inproc:// address)
    assert Backend("dask", address="inproc://10.0.0.1/123/1").address.startswith("inproc")
    assert dask_address_problem("inproc://x") is not None


# ------------------------------------------------------------------------------ threshold
@needs_cc
def test_a_threshold_near_the_float_range_is_plotted_not_an_internal_error(tmp_path, capsys):
    out = tmp_path / "out"
    rc = main(["simulate", str(MODELS / "electric_drive_uncertain.py"), "--observer",
               "diagnostic", "--threshold", "1e308", "--scenario",
               str(MODELS / "scenarios" / "electric_drive_uncertain.json"), "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "internal error" not in cap.err and (out / "residual.png").is_file()
    assert "NOT detected" in cap.out  # a band that wide sees nothing, and says so


def test_plot_values_are_clipped():
    import numpy as np
    from observer_cad.reporting._plots import PLOT_LIMIT, _plottable
    v = _plottable([1e308, -1e308, np.nan, 2.0])
    assert v[0] == PLOT_LIMIT and v[1] == -PLOT_LIMIT and np.isnan(v[2]) and v[3] == 2.0


# ------------------------------------------------------------------------------ names
@pytest.mark.parametrize("old, new, needle", [
    ('x1, x2, x3 = sp.symbols("x1 x2 x3")',
     'x1, x2 = sp.symbols("x1 x2"); x3 = sp.Symbol("x\\n3")', "state name 'x\\n3'"),
    ('w1, w2 = sp.symbols("w1 w2")', 'w1, w2 = sp.Symbol("w\\t1"), sp.Symbol("w2")',
     "noise name"),
    ('name="electric_drive"', 'name="electric\\ndrive"', "control character"),
])
def test_names_with_control_characters_are_refused_at_load(tmp_path, capsys, old, new, needle):
    text = DRIVE.read_text()
    assert old in text
    f = tmp_path / "m.py"
    f.write_text(text.replace(old, new))
    with pytest.raises(ModelError, match="control character"):
        load_model(f)
    rc = main(["show", str(f)])
    _one_line(rc, capsys.readouterr().err, needle)


# ------------------------------------------------------------------------------ unknown input
@pytest.mark.parametrize("extra", [["--method", "exact"], []])
def test_unservable_continuous_estimation_is_refused_before_any_design_work(capsys, monkeypatch,
                                                                          extra):
    """f1 of the continuous three-tank does not reach a measured output directly: no
    continuous-time estimator can serve it, and that is said before any designer runs."""
    import observer_cad.synthesis.jordan as jordan
    import observer_cad.synthesis.canonical as canonical

    def never(*args, **kwargs):  # pragma: no cover - the point: not reached
        raise AssertionError("a designer ran")

    for mod in (jordan, canonical):
        for name in [n for n in getattr(mod, "__all__", ()) if n.startswith("design")]:
            monkeypatch.setattr(mod, name, never, raising=False)
    rc = main(["design", str(MODELS / "three_tank_faults.py"), "--observer", "unknown-input",
               "--fault", "f1", *extra])
    _one_line(rc, capsys.readouterr().err, "continuous-time estimation of 'f1'")


# ------------------------------------------------------------------------------ bounds
def test_huge_bounds_are_refused(capsys):
    rc = main(["design", str(MODELS / "three_tank.py"), "--observer", "interval",
               "--estimate", "x1", "--bound", "rho1=-1e15,1e15"])
    _one_line(rc, capsys.readouterr().err, "--bound", "1e+15")
    m = load_model(DRIVE)
    import dataclasses
    d = m.symbol("d")
    with pytest.raises(ModelError, match="above"):
        dataclasses.replace(m, bounds={**m.bounds, d: (-10 * MAX_BOUND, 0)})
    assert dataclasses.replace(m, bounds={**m.bounds, d: (-MAX_BOUND, MAX_BOUND)}).bounds[d]


# ------------------------------------------------------------------------------ failed conditions
def test_build_observer_raises_on_a_failed_required_condition():
    m = load_model(DRIVE)
    d = design(m, observer="unknown-input", faults=["d"])
    with pytest.raises(FailedConditionError, match="observer stable") as exc:
        build_observer(m, d, g=3)
    assert "\n" not in str(exc.value) and exc.value.observer.failed_conditions
    ob = build_observer(m, d, g=3, allow_failed=True)
    assert ob.failed_conditions
    assert not build_observer(m, d).failed_conditions


# ------------------------------------------------------------------------------ sliding gains
@pytest.fixture(scope="module")
def sliding():
    m = load_model(MODELS / "sliding_example.py")
    return m, design(m, observer="sliding-mode", faults=["d"])


def test_sliding_gains_above_the_limit_are_refused(sliding):
    m, d = sliding
    gains = [n for n in ("k_sm", "eps_sm", "tau_sm") if n in d.to_json()["parameters"]]
    assert gains, "the sliding design records its gains"
    for name in gains:
        data = json.loads(json.dumps(d.to_json()))
        data["parameters"][name] = "1e7"
        with pytest.raises(UsageError, match="above 1e\\+06"):
            build_observer(m, Design.from_json(data, m), allow_failed=True)


def test_a_name_with_a_newline_on_the_command_line_is_shown_escaped(capsys):
    rc = main(["design", str(DRIVE), "--observer", "unknown-input", "--fault", "d\nx"])
    _one_line(rc, capsys.readouterr().err, "unknown fault or disturbance 'd\\nx'")
