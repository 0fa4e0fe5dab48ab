"""``observer-cad analyze``: text, JSON, messages naming the fault."""
from __future__ import annotations

import json

import pytest

from observer_cad.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_analyze_text(capsys, models_dir):
    code, out, err = run(capsys, "analyze", str(models_dir / "three_tank_faults.py"))
    assert code == 0, err
    assert "f1  detectable, minimal order k = 2" in out
    assert "f3 is undetectable with rho decoupled" in out
    assert "isolate f1 from f2: measure x1" in out
    assert "Achievable structure matrix" in out


def test_analyze_json(capsys, models_dir):
    code, out, err = run(capsys, "analyze", str(models_dir / "three_tank_faults.py"), "--json",
                         "--candidate", "x1 - x2")
    assert code == 0, err
    js = json.loads(out)
    assert js["detectable"] == {"f1": True, "f2": True, "f3": False}
    assert js["min_order"] == {"f1": 2, "f2": 2, "f3": None}
    assert {"faults": ["f1", "f2"], "isolable": False}.items() <= js["isolable"][0].items()
    assert js["structure_matrices"] == [{"f1": 1, "f2": 1, "f3": 0}]
    assert {s["measurement"] for s in js["suggestions"]} == {"x1", "x1 - x2"}
    assert js["assumptions"] == []


def test_analyze_symbolic_json_reports_assumptions(capsys, models_dir):
    code, out, err = run(capsys, "analyze", str(models_dir / "electric_drive.py"), "--symbolic",
                         "--json")
    assert code == 0, err
    js = json.loads(out)
    assert js["detectable"] == {"d": True} and js["min_order"] == {"d": 1}
    assert "Ne(k1, 0)" in js["assumptions"]


@pytest.mark.parametrize("argv,needle", [
    (["--fault", "f9"], "unknown fault 'f9'"),
    (["--fault", "f1", "--disturbance", "f1"], "'f1' cannot be both"),
    (["--candidate", "x1**2"], "not linear in the states"),
])
def test_analyze_errors_name_the_symbol(capsys, models_dir, argv, needle):
    code, out, err = run(capsys, "analyze", str(models_dir / "three_tank_faults.py"), *argv)
    if argv[0] == "--candidate":  # candidates are parsed only when a goal needs them
        assert code == 2 and needle in err
    else:
        assert code == 2 and needle in err and err.count("\n") == 1


def test_candidate_errors_name_the_option_and_a_state_candidate_is_listed_once(capsys, models_dir):
    from observer_cad.cli import main
    path = str(models_dir / "three_tank_faults.py")
    assert main(["analyze", path, "--candidate", "x1*x2"]) == 2
    assert "--candidate x1*x2 is not linear" in capsys.readouterr().err
    # read even where no fault needs a candidate (the electric drive's are all detectable:
    # an audit found a payload accepted there, unread)
    drive = str(models_dir / "electric_drive.py")
    assert main(["analyze", drive, "--candidate", "__import__('os')"]) == 2
    assert "--candidate" in capsys.readouterr().err
    assert main(["analyze", path, "--candidate", "x1"]) == 0
    out = capsys.readouterr().out
    assert out.count("isolate f1 from f2: measure x1") == 1
