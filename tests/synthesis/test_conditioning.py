"""Conditioning: every design reports the scale of Φ and the noise gain
of its output as a non-required condition, in text and JSON; above the documented level
(README "Conditioning") it does not hold and the CLI prints one warning line."""
from __future__ import annotations

import dataclasses
import json

import pytest
import sympy as sp

from observer_cad import design, load_model
from observer_cad.cli import main
from observer_cad.synthesis import (CONDITIONING_LEVEL, CONDITIONING_NAME, DesignMatrices,
                                    conditioning_numbers)


@pytest.fixture
def drive(models_dir):
    return load_model(models_dir / "electric_drive.py")


@pytest.fixture
def drive_k4_tiny(drive, tmp_path):
    """The electric drive with k4 = 1e−12, as a model file for the CLI."""
    src = tmp_path / "drive_k4.py"
    src.write_text(
        '"""The electric drive with k4 = 1e-12: exact, but ill-conditioned."""\n'
        "import dataclasses\nimport sympy as sp\nfrom observer_cad import load_model\n"
        f"_m = load_model({str(drive.source)!r})\n"
        "model = dataclasses.replace(_m, parameters={**_m.parameters,"
        " sp.Symbol('k4'): sp.Rational(1, 10**12)})\n")
    return src


def _conditions(d):
    return [c for c in d.conditions if c.name == CONDITIONING_NAME]


def test_rho_design_with_tiny_k4_warns(drive_k4_tiny, capsys):
    rc = main(["design", str(drive_k4_tiny), "--observer", "unknown-input", "--fault", "rho"])
    out, err = capsys.readouterr()
    assert rc == 0
    line = next(l for l in out.splitlines() if CONDITIONING_NAME in l)
    assert line.strip().startswith("[ -- ]")
    assert "max|Φ|/max|H| = 3.6e+09" in line
    warnings = [l for l in err.splitlines() if "warning" in l]
    assert len(warnings) == 1 and "ill-conditioned" in warnings[0]


def test_rho_design_with_tiny_k4_json(drive_k4_tiny, capsys):
    rc = main(["design", str(drive_k4_tiny), "--observer", "unknown-input", "--fault", "rho",
               "--json"])
    out, _ = capsys.readouterr()
    assert rc == 0
    cond = [c for c in json.loads(out)["conditions"] if c["name"] == CONDITIONING_NAME]
    assert len(cond) == 1
    assert cond[0]["holds"] is False and cond[0]["required"] is False
    assert "noise gain" in cond[0]["detail"]


def test_default_drive_does_not_warn(models_dir, capsys):
    rc = main(["design", str(models_dir / "electric_drive.py"), "--observer", "unknown-input",
               "--fault", "rho"])
    out, err = capsys.readouterr()
    assert rc == 0
    assert err == ""
    line = next(l for l in out.splitlines() if CONDITIONING_NAME in l)
    assert line.strip().startswith("[ ok ]")


@pytest.mark.parametrize("opts", [
    dict(observer="unknown-input", faults=["d"]),
    dict(observer="unknown-input", faults=["rho"], symbolic=True),
    dict(observer="unknown-input", faults=["d"], form="jordan"),
    dict(observer="diagnostic"),
    dict(observer="diagnostic", form="canonical", faults=["d"]),
    dict(observer="virtual-sensor", estimate="x1", form="canonical"),
    dict(observer="interval", estimate="x2"),
])
def test_every_design_reports_conditioning_once(drive, opts):
    d = design(drive, **opts)
    conds = _conditions(d)
    assert len(conds) == 1
    assert conds[0].holds and not conds[0].required
    assert sum(c["name"] == CONDITIONING_NAME for c in d.to_json()["conditions"]) == 1


def test_symbolic_design_is_evaluated_at_the_defaults(drive):
    d = design(drive, observer="unknown-input", faults=["rho"], symbolic=True)
    assert "at the parameter defaults" in d.conditioning.detail
    no_defaults = dataclasses.replace(drive, parameters={p: None for p in drive.parameters})
    d2 = design(no_defaults, observer="unknown-input", faults=["rho"], symbolic=True)
    assert d2.conditioning.holds and "not evaluated" in d2.conditioning.detail


def test_numbers_by_hand():
    """z = H_z x* + Q y with Φ = [[1, 0, 2e7]], H = [[1, 0, 0]]: scale 2e7, gain |Q| + |H_z||J*|."""
    m = DesignMatrices(Phi=sp.Matrix([[1, 0, 2 * 10**7]]), F_star=sp.Matrix([[0]]),
                       J_star=sp.Matrix([[3, -4]]), G_star=sp.Matrix([[0]]),
                       Hz=sp.Matrix([[2]]), Q=sp.Matrix([[1, 1]]))
    scale, gain, what = conditioning_numbers("virtual-sensor", m, sp.Matrix([[1, 0, 0]]))
    assert scale == 2e7 > CONDITIONING_LEVEL
    assert gain == 2 + 2 * 7 and what == "z"
