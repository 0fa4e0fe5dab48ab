"""Import cost: ``import observer_cad`` and the commands that only design
or analyse import neither casadi nor matplotlib nor scipy (nor python-control, pandas);
the top-level names stay importable (PEP 562).  Each check runs in a fresh interpreter
and reads ``sys.modules`` there — no timing here: the wall-clock figures are in
benchmarks/bench_latency.py."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import observer_cad

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("casadi", "matplotlib", "scipy", "control", "pandas")


def _loaded_after(code: str, *argv: str) -> dict:
    """Run ``code`` in a fresh interpreter (the package from this tree) and return the
    JSON object it prints last."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-c", code, *argv], cwd=ROOT,
                          capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


_REPORT = """
    import json, sys
    heavy = {heavy!r}
    print(json.dumps({{"heavy": sorted(m for m in heavy if m in sys.modules),
                       "sympy": "sympy" in sys.modules}}))
"""


def test_import_observer_cad_loads_no_pipeline_stage():
    got = _loaded_after("import observer_cad\n" + textwrap.dedent(_REPORT.format(heavy=HEAVY)))
    assert got["heavy"] == []
    assert not got["sympy"], "import observer_cad alone should not import sympy"


COMMANDS = (
    ("design", "models/electric_drive.py", "--observer", "diagnostic"),
    ("design", "models/electric_drive.py", "--observer", "unknown-input", "--fault", "d"),
    ("design", "models/three_tank.py", "--observer", "virtual-sensor", "--estimate", "x1"),
    ("analyze", "models/three_tank_faults.py"),
    ("show", "models/electric_drive.py"),
)


def test_design_and_analyze_commands_import_no_casadi_matplotlib_scipy():
    """All five commands run one after another in one fresh interpreter; modules only
    accumulate, so reading ``sys.modules`` after each command names the first command
    that pulls in a heavy module."""
    code = """
        import contextlib, io, json, sys
        from observer_cad.cli import main
        heavy = {heavy!r}
        seen = []
        for argv in json.loads(sys.argv[1]):
            with contextlib.redirect_stdout(io.StringIO()) as out:
                rc = main(argv)
            seen.append({{"argv": argv, "rc": rc, "printed": bool(out.getvalue().strip()),
                          "heavy": sorted(m for m in heavy if m in sys.modules),
                          "sympy": "sympy" in sys.modules}})
        print(json.dumps(seen))
    """
    got = _loaded_after(textwrap.dedent(code.format(heavy=HEAVY)), json.dumps(COMMANDS))
    assert [tuple(g["argv"]) for g in got] == list(COMMANDS)
    for g in got:
        cmd = " ".join(g["argv"])
        assert g["rc"] in (0, None), f"{cmd} returned {g['rc']}"
        assert g["printed"], f"{cmd} printed nothing"
        assert g["heavy"] == [], f"{cmd} imported {g['heavy']}"
    assert got[0]["sympy"], "the first command ran without sympy"


def test_simulate_path_imports_no_casadi():
    """The reference simulator needs numpy (and matplotlib for its plots) but not casadi."""
    code = """
        import sys
        from observer_cad import load_model, design, build_observer, simulate, load_scenario
        m = load_model("models/electric_drive.py")
        obs = build_observer(m, design(m, observer="unknown-input", faults=["d"]))
        res = simulate(m, obs, load_scenario("models/scenarios/electric_drive_fig1.json"))
        assert len(res["t"]) > 0
    """
    assert _loaded_after(textwrap.dedent(code) + textwrap.dedent(_REPORT.format(heavy=("casadi",))))["heavy"] == []


def test_top_level_names_resolve_lazily_to_the_stage_objects():
    from observer_cad.codegen import CompiledSimulator
    from observer_cad.model import PlantModel
    from observer_cad.observers import build_observer
    from observer_cad.simulation import simulate
    from observer_cad.synthesis import design
    assert observer_cad.design is design and observer_cad.build_observer is build_observer
    assert observer_cad.PlantModel is PlantModel and observer_cad.simulate is simulate
    assert observer_cad.CompiledSimulator is CompiledSimulator
    for name in observer_cad.__all__:
        assert getattr(observer_cad, name) is not None, name
        assert name in dir(observer_cad), name
    with pytest.raises(AttributeError, match="no_such_name"):
        observer_cad.no_such_name  # noqa: B018


def test_cli_demo_names_resolve_lazily():
    import observer_cad.cli as cli
    assert len(cli.CASES) > 0 and callable(cli.run_demo)
    with pytest.raises(AttributeError, match="nothing_here"):
        cli.nothing_here  # noqa: B018
