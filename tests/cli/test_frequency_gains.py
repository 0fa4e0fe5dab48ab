"""``design --frequency W``: the residual's gain to each fault at ω (Varga 2017, Ch. 3, strong
fault detectability at a frequency), checked independently of the formula: the amplitude
of the steady sinusoidal residual the tool's own simulation gives for a fault sin(ω t)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from observer_cad import build_observer, design, load_model, simulate
from observer_cad.cli import main
from observer_cad.simulation import scenario_from_dict
from observer_cad.synthesis.certificates import frequency_gains

ROOT = Path(__file__).resolve().parents[2]


def test_gains_at_frequencies_equal_the_simulated_amplitude():
    """three_tank_faults, the residual for f1 (f3 decoupled with rho): at ω = 0 the gain is
    the signature's steady-state gain; at ω = 1 and 3 it equals the amplitude of r once a
    fault sin(ω t) has settled; f3, decoupled, has gain 0 everywhere."""
    m = load_model(ROOT / "models" / "three_tank_faults.py")
    d = design(m, observer="diagnostic", faults=["f1"])
    g = frequency_gains(d, [0, 1, 3])
    sig = {s.name: s for s in (d.signature or d.with_signature().signature)}
    assert g["f1"][0][1][0] == pytest.approx(float(sig["f1"].steady_gain[0]), rel=1e-12)
    assert all(v == (0.0,) for _, v in g["f3"])
    ob = build_observer(m, d)
    for k, w in ((1, 1.0), (2, 3.0)):
        sc = scenario_from_dict({"t_end": 40, "dt": 0.005,
                                 "signals": {"f1": f"sin({w}*t)"}})
        r = np.asarray(simulate(m, ob, sc)["r"])
        tail = r[-int(2 * np.pi / w / 0.005) * 2:]
        assert float(np.max(np.abs(tail))) == pytest.approx(g["f1"][k][1][0], rel=2e-3)


def test_the_cli_reports_gains_for_a_design_and_a_bank(capsys):
    """The text and the JSON of design and of a bank (one entry per row); a bad ω is one line."""
    tanks = str(ROOT / "models" / "three_tank_isolation.py")
    assert main(["design", tanks, "--observer", "diagnostic", "--isolate", "--frequency", "0",
                 "--frequency", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)["frequency_gains"]
    assert len(out) == 3 and out[0]["f1"][0] == {"omega": "0", "gain": [0.0]}
    assert out[0]["f2"][1]["gain"][0] == pytest.approx(1 / np.sqrt(5), rel=1e-12)
    assert main(["design", str(ROOT / "models" / "three_tank_faults.py"), "--observer",
                 "diagnostic", "--fault", "f1", "--frequency", "1"]) == 0
    text = capsys.readouterr().out
    assert "Gains |G(jω)| of the residual to each fault" in text and "f1  ω = 1: 0.316228" in text
    assert main(["design", str(ROOT / "models" / "three_tank_faults.py"), "--observer",
                 "diagnostic", "--fault", "f1", "--frequency", "abc"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err.count("\n") == 1 and "frequency 'abc'" in cap.err
