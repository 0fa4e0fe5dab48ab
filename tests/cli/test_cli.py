"""The command line: ``observer-cad show|design|demo`` and their help.

Output formats (docs/CLI.md): ``show`` prints the extracted matrices (or one
JSON object with ``--json``); ``design`` prints the design with its conditions marked
``[ ok ]`` / ``[FAIL]`` / ``[ -- ]``, or one JSON object with keys ``k``, ``form``,
``matrices``, ``conditions``, ``assumptions``. Error paths are in test_bad_input.py.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

from observer_cad import extract_structure, load_model
from observer_cad.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
DRIVE = str(MODELS / "electric_drive.py")
TANK = str(MODELS / "three_tank.py")
DESIGN_MATRICES = ("Phi", "F_star", "J_star", "R_star", "H_star", "G_star", "D_star", "L_star")
TANK_F = [["-1", "1", "0"], ["1", "-2", "1"], ["0", "1", "-2"]]


def run(capsys, argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return rc, cap.out, cap.err


def design_json(capsys, *extra, fault="d", model=DRIVE):
    rc, out, err = run(capsys, ["design", model, "--observer", "unknown-input",
                                "--fault", fault, "--json", *extra])
    assert rc == 0, err
    assert err == ""
    return json.loads(out)


def sym_matrix(rows):
    """A JSON matrix (list of rows of strings) as a sympy Matrix; every entry must parse."""
    assert isinstance(rows, list) and all(isinstance(r, list) for r in rows), rows
    assert len({len(r) for r in rows}) <= 1, f"ragged rows: {rows}"
    for r in rows:
        for e in r:
            assert isinstance(e, str), (e, rows)
    return sp.Matrix([[sp.sympify(e) for e in r] for r in rows])


# ----------------------------------------------------------------------------- show
def _squash(line: str) -> str:
    return " ".join(line.split())


def test_show_text_three_tank(capsys):
    rc, out, err = run(capsys, ["show", TANK])
    assert rc == 0 and err == ""
    lines = out.splitlines()
    i = next(i for i, ln in enumerate(lines) if _squash(ln).startswith("F = ["))
    assert [_squash(ln) for ln in lines[i:i + 3]] == [
        "F = [ -1 1 0 ]", "[ 1 -2 1 ]", "[ 0 1 -2 ]"]
    assert "three_tank" in lines[0] and "continuous" in lines[0]
    for name in ("G", "H", "C", "D", "L", "W"):
        assert any(_squash(ln).startswith(f"{name} = ") for ln in lines), name
    # the nonlinear terms with their argument rows (seed 002 §8)
    assert "argument x1 - x2" in out and "argument x2 - x3" in out and "argument x3" in out
    assert "sqrt(x1 - x2)" in out


def test_show_json_three_tank(capsys):
    rc, out, err = run(capsys, ["show", TANK, "--json"])
    assert rc == 0 and err == ""
    obj = json.loads(out)
    assert obj["matrices"]["F"] == TANK_F
    assert obj["matrices"]["H"] == [["0", "1", "0"], ["0", "0", "1"]]
    assert obj["matrices"]["L"] == [["0", "0"], ["1", "0"], ["0", "1"]]
    assert obj["states"] == ["x1", "x2", "x3"]
    assert obj["disturbances"] == ["rho1", "rho2"]
    assert [t["row"] for t in obj["nonlinear"]] == [["1", "-1", "0"], ["0", "1", "-1"],
                                                   ["0", "0", "1"]]
    # the JSON agrees with the API
    st = extract_structure(load_model(TANK))
    assert sym_matrix(obj["matrices"]["C"]) == sp.Matrix(st.C)


def test_show_json_subprocess():
    """``python -m observer_cad.cli`` works as a program (exit 0, JSON on stdout)."""
    proc = subprocess.run([sys.executable, "-m", "observer_cad.cli", "show", TANK, "--json"],
                          capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert json.loads(proc.stdout)["matrices"]["F"] == TANK_F


# ----------------------------------------------------------------------------- design
def check_design_json(obj, symbolic, n_decoupled=1):
    for key in ("k", "form", "matrices", "conditions", "assumptions"):
        assert key in obj, key
    k = obj["k"]
    assert isinstance(k, int) and 1 <= k < 3
    assert obj["form"] == "canonical"
    mats = {}
    for name in DESIGN_MATRICES:
        assert name in obj["matrices"], name
        mats[name] = sym_matrix(obj["matrices"][name])
    # shapes: n = 3 states, l = 2 outputs, one input, one unknown input
    shapes = {"Phi": (k, 3), "F_star": (k, k), "J_star": (k, 2), "R_star": (1, 2),
              "H_star": (1, k), "G_star": (k, 1), "D_star": (k, 1), "L_star": (k, n_decoupled)}
    for name, shape in shapes.items():
        assert mats[name].shape == shape, (name, mats[name].shape)
    params = {"k1", "k2", "k3", "k4", "k5", "k6"}
    for name, M in mats.items():
        names = {s.name for s in M.free_symbols}
        assert names <= params, (name, names)
        if not symbolic:
            assert not names, (name, names)
    assert obj["conditions"], "no conditions reported"
    for c in obj["conditions"]:
        assert isinstance(c["name"], str) and c["name"]
        assert isinstance(c["holds"], bool)
        assert isinstance(c["detail"], str)
    assert isinstance(obj["assumptions"], list)
    for a in obj["assumptions"]:
        assert isinstance(a, str)
        rel = sp.sympify(a)
        assert isinstance(rel, sp.core.relational.Relational), a
        assert {s.name for s in rel.free_symbols} <= params, a
    return mats


def check_identities(mats, symbolic, unknown="d"):
    """Re-check the design from its JSON against the model's own structure."""
    model = load_model(DRIVE)
    st = extract_structure(model if symbolic else model.substitute_parameters())
    F, G, H = sp.Matrix(st.F), sp.Matrix(st.G), sp.Matrix(st.H)
    D, L = (sp.Matrix(st.D), sp.Matrix(st.L)) if unknown == "d" else (sp.Matrix(st.L),
                                                                        sp.Matrix(st.D))
    Phi = mats["Phi"]
    zero = lambda M: sp.simplify(M) == sp.zeros(*M.shape)  # noqa: E731
    assert zero(Phi * F - mats["F_star"] * Phi - mats["J_star"] * H)
    assert zero(mats["H_star"] * Phi - mats["R_star"] * H)
    assert zero(Phi * G - mats["G_star"])
    assert zero(Phi * D - mats["D_star"])
    assert not zero(mats["D_star"]), "the design must be sensitive to the unknown input"
    if unknown == "d":  # rho decoupled
        assert zero(Phi * L) and zero(mats["L_star"])


def test_design_json_numeric(capsys):
    obj = design_json(capsys)
    mats = check_design_json(obj, symbolic=False)
    check_identities(mats, symbolic=False)
    assert all(c["holds"] for c in obj["conditions"] if c.get("required", True))
    assert obj["assumptions"] == []


def test_design_json_symbolic(capsys):
    obj = design_json(capsys, "--symbolic")
    mats = check_design_json(obj, symbolic=True)
    check_identities(mats, symbolic=True)
    assert obj["assumptions"], "a symbolic design holds under assumptions"
    assert any(s.name.startswith("k") for M in mats.values() for s in M.free_symbols)


def test_design_json_symbolic_rho_assumptions(capsys):
    """The README tour's symbolic design: estimating rho symbolically needs k4 != 0 (and k1 != 0)."""
    obj = design_json(capsys, "--symbolic", fault="rho")
    assert obj["decoupled"] == []  # d is a fault, taken as zero; nothing to decouple
    mats = check_design_json(obj, symbolic=True, n_decoupled=0)
    check_identities(mats, symbolic=True, unknown="rho")
    rels = {sp.sympify(a) for a in obj["assumptions"]}
    k1, k4 = sp.symbols("k1 k4")
    assert sp.Ne(k4, 0) in rels and sp.Ne(k1, 0) in rels, obj["assumptions"]


def test_design_text_pass_marks(capsys):
    rc, out, err = run(capsys, ["design", DRIVE, "--observer", "unknown-input", "--fault", "d"])
    assert rc == 0 and err == ""
    assert out.startswith("Design for electric_drive: estimate d")
    marks = re.findall(r"^  (\[ ok \]|\[FAIL\]|\[ -- \]) (.*)$", out, flags=re.M)
    assert marks, out
    assert ("[ ok ]", ) == tuple({m for m, _ in marks if m != "[ -- ]"})
    assert any(m == "[ ok ]" and t.startswith("certificate") for m, t in marks)
    assert any(m == "[ ok ]" and t.startswith("rank condition (3.3)") for m, t in marks)
    for name in DESIGN_MATRICES:
        assert re.search(rf"^  {name} = \[", out, flags=re.M), name
    assert "Assumptions" in out


def test_design_text_matches_json(capsys):
    """The human and JSON outputs report the same conditions and verdicts."""
    obj = design_json(capsys, "--symbolic", fault="rho")
    rc, out, err = run(capsys, ["design", DRIVE, "--observer", "unknown-input", "--fault",
                                "rho", "--symbolic"])
    assert rc == 0
    assert f"k = {obj['k']}" in out.splitlines()[0]
    for c in obj["conditions"]:
        mark = "[ ok ]" if c["holds"] else ("[FAIL]" if c.get("required", True) else "[ -- ]")
        assert f"{mark} {c['name']}" in out, c["name"]
    for a in obj["assumptions"]:
        assert f"\n  {a}\n" in out or out.endswith(f"\n  {a}"), a


# ----------------------------------------------------------------------------- help
def _help(capsys, argv):
    with pytest.raises(SystemExit) as info:
        main(argv)
    cap = capsys.readouterr()
    assert info.value.code == 0
    assert cap.err == ""
    return cap.out


def _options(parser):
    return {s for a in parser._actions for s in a.option_strings}


def test_help_top_level(capsys):
    out = _help(capsys, ["--help"])
    assert out.startswith("usage: observer-cad")
    for word in ("show", "design", "demo", "--help"):
        assert word in out, word


def test_help_design_mentions_every_option(capsys):
    out = _help(capsys, ["design", "--help"])
    assert out.startswith("usage: observer-cad design")
    expected = {"--observer", "--fault", "--disturbance", "--form", "--symbolic", "--method",
                "--rtol", "--json", "--help", "--estimate", "--lambda", "--eigenvalues",
                "--variant", "--robust", "--bound", "--gain", "--tau", "--gamma", "--poles",
                "--include-epsilon", "--isolate", "--structure", "--threshold", "--initial-error",
                "--proof-seconds", "--design", "--frequency"}
    subparsers = next(a for a in build_parser()._actions if a.choices and "design" in a.choices)
    assert _options(subparsers.choices["design"]) - {"-h"} == expected
    for opt in expected | {"MODEL", "unknown-input", "diagnostic", "virtual-sensor", "interval",
                           "sliding-mode", "drem",
                           "canonical", "jordan", "auto", "exact", "float", "004"}:
        assert opt in out, opt


def test_help_show_mentions_every_option(capsys):
    out = _help(capsys, ["show", "--help"])
    assert out.startswith("usage: observer-cad show")
    for opt in ("MODEL", "--json", "--help"):
        assert opt in out, opt


# ----------------------------------------------------------------------------- demo
@pytest.mark.slow  # the whole demo, ~10 s
def test_demo(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    rc, out, err = run(capsys, ["demo"])
    assert rc == 0, err
    assert err == ""
    m = re.search(r"^(\d+) designs, all certified\.$", out, flags=re.M)
    assert m, out[-500:]
    n = int(m.group(1))
    assert n >= 2
    assert len(re.findall(r"^Design for ", out, flags=re.M)) == n
    assert out.count("[ ok ] certificate") == n
    assert "[FAIL]" not in out
    for name in ("electric_drive", "three_tank"):
        assert f"Model {name}" in out, name


def test_unstable_user_gain_is_a_failed_condition_and_exit_2(capsys, models_dir):
    """An estimator gain that makes F* − g H* unstable is the user's error: the design is
    printed with [FAIL] on the observer condition, and one line on stderr, exit 2."""
    argv = ["design", str(models_dir / "electric_drive.py"), "--observer", "unknown-input",
            "--fault", "d", "--gain", "3"]
    rc = main(argv)
    cap = capsys.readouterr()
    assert rc == 2
    assert "[FAIL] observer stable: spectral radius of F* − g H* < 1" in cap.out
    err = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(err) == 1 and "observer stable" in err[0] and "Traceback" not in cap.err
    rc = main(argv[:-1] + ["-0.5", "--json"])
    cap = capsys.readouterr()
    assert rc == 0
    data = json.loads(cap.out)
    stable = [c for c in data["observer_conditions"] if c["name"].startswith("observer stable")]
    assert stable and stable[0]["holds"] is True and stable[0]["required"] is True


def test_simulate_refuses_the_unstable_gain_too(capsys, models_dir, tmp_path):
    rc = main(["simulate", str(models_dir / "electric_drive.py"), "--observer", "unknown-input",
               "--fault", "d", "--gain", "5", "--scenario",
               str(models_dir / "scenarios" / "electric_drive_fig1.json"), "--out", str(tmp_path / "o")])
    cap = capsys.readouterr()
    assert rc == 2 and "observer stable" in cap.err
    assert not (tmp_path / "o" / "signals.csv").exists()


def test_interval_design_fails_where_simulate_refuses(capsys, tmp_path):
    """A model without bounds on its disturbance: the interval observer cannot be built,
    so design refuses it at design time with the same message simulate gives."""
    src = ("import sympy as sp\nfrom observer_cad import PlantModel\n"
           "x1, x2, rho = sp.symbols('x1 x2 rho')\n"
           "model = PlantModel(name='nb', time='continuous', states=[x1, x2],"
           " disturbances=[rho], outputs=[x2], dynamics=[-x1 + rho, x1 - 2*x2])\n")
    path = tmp_path / "nb.py"
    path.write_text(src)
    scen = tmp_path / "s.json"
    scen.write_text(json.dumps({"t_end": 1, "dt": 0.1, "signals": {"rho": "0"}}))
    rc_d = main(["design", str(path), "--observer", "interval", "--estimate", "x1"])
    err_d = capsys.readouterr().err
    rc_s = main(["simulate", str(path), "--observer", "interval", "--estimate", "x1",
                 "--scenario", str(scen), "--out", str(tmp_path / "o")])
    err_s = capsys.readouterr().err
    assert rc_d == rc_s == 2
    assert err_d == err_s and len(err_d.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- CRootOf λ
CLASH_MODEL = '''"""A state called x: the name sympy writes a CRootOf's polynomial in."""
import sympy as sp
from observer_cad import PlantModel
x, x2, x3, u = sp.symbols("x x2 x3 u")
model = PlantModel(name="clash", time="continuous", states=[x, x2, x3], inputs=[u],
                   outputs=[x2, x3], dynamics=[-x + x2 + u, x - 2*x2 + x3 + u, x2 - 2*x3])
'''
CUBIC_ROOT = "CRootOf(x**3 + 6*x**2 + 8*x + 1, 0)"  # irreducible cubic, three stable roots


def test_crootof_lambda_design_written_by_the_cli_loads_and_runs(capsys, tmp_path):
    """``design --lambda 'CRootOf(...)' --json > F.json`` (the CLI's design file: there is
    no ``--out``/``--design`` option) read back with ``read_design_json``: re-certified,
    the same λ and matrices as the design made in Python. The design's own file
    (``write_design_json``) builds and simulates: the virtual sensor reproduces z = x (it
    starts at Φ x(0) = 0)."""
    from observer_cad import design
    from observer_cad.observers import build_observer
    from observer_cad.reporting import read_design_json, write_design_json
    from observer_cad.simulation import load_scenario, simulate
    path = tmp_path / "clash.py"
    path.write_text(CLASH_MODEL)
    common = [path, "--observer", "virtual-sensor", "--estimate", "x", "--lambda", CUBIC_ROOT]
    rc, out, err = run(capsys, ["design", *common, "--json"])
    assert rc == 0, err
    design_file = tmp_path / "F.json"
    design_file.write_text(out)
    model = load_model(path)
    d = read_design_json(design_file, model)
    (lam,) = d.lambdas
    assert isinstance(lam, sp.CRootOf) and str(lam) == CUBIC_ROOT
    assert d.certificate.passed and d.certificate.exact
    ref = design(model, observer="virtual-sensor", estimate="x", form="jordan",
                 lambdas=[CUBIC_ROOT])
    assert d.lambdas == ref.lambdas
    for name, M in ref.ordered_matrices:
        assert sp.Matrix(getattr(d.matrices, name)) == sp.Matrix(M), name
    again = read_design_json(write_design_json(ref, tmp_path / "G.json"), model)
    scen = tmp_path / "s.json"
    scen.write_text(json.dumps({"t_end": 2, "dt": 0.01, "signals": {"u": "sin(3*t)"}}))
    res = simulate(model, build_observer(model, again), load_scenario(scen))
    x, x_hat = res["x"], res["x_hat"]
    assert abs(x).max() > 0.1  # the plant moved
    assert abs(x_hat - x).max() < 1e-9 * (1 + abs(x).max())


def test_crootof_lambda_simulate_and_codegen(capsys, tmp_path):
    """simulate and codegen of a design with a CRootOf λ, for a model with a state called x
    (lambdify has no CRootOf; substituting x(0) into the initial state would rebuild the
    root's polynomial in x): both used to stop with an internal error."""
    path = tmp_path / "clash.py"
    path.write_text(CLASH_MODEL)
    common = [path, "--observer", "virtual-sensor", "--estimate", "x", "--lambda", CUBIC_ROOT]
    scen = tmp_path / "s.json"
    scen.write_text(json.dumps({"t_end": 2, "dt": 0.01, "signals": {"u": "sin(3*t)"}}))
    rc, out, err = run(capsys, ["simulate", *common, "--scenario", scen, "--out", tmp_path / "o",
                                "--engine", "reference"])
    assert rc == 0, err
    cols = (tmp_path / "o" / "signals.csv").read_text().splitlines()
    head, last = cols[0].split(","), [float(v) for v in cols[-1].split(",")]
    x, x_hat = last[head.index("x")], last[head.index("x_hat")]
    assert abs(x) > 0.01 and abs(x_hat - x) < 1e-9
    rc, out, err = run(capsys, ["codegen", *common, "--out", tmp_path / "c"])
    assert rc == 0, err
    assert list((tmp_path / "c").glob("*.c"))


def test_missing_package_is_named_not_an_internal_error(capsys, monkeypatch):
    """A dependency that is not installed (matplotlib here) is the environment's problem:
    one line naming the package and the install command, exit 2 — not "internal error"
    with a request to report it. Any other unexpected exception stays an internal error."""
    import observer_cad.cli._main as cli_main

    def broken(args):
        raise ModuleNotFoundError("No module named 'matplotlib.pyplot'", name="matplotlib.pyplot")

    monkeypatch.setattr(cli_main, "cmd_show", broken)
    rc, _, err = run(capsys, ["show", TANK])
    assert rc == 2
    assert err.strip() == ("observer-cad: error: the Python package 'matplotlib' is not installed"
                           " (observer-cad needs it here): python3 -m pip install matplotlib")

    def flint_missing(args):  # the import name is not the distribution's name
        raise ModuleNotFoundError("No module named 'flint'", name="flint")

    monkeypatch.setattr(cli_main, "cmd_show", flint_missing)
    rc, _, err = run(capsys, ["show", TANK])
    assert rc == 2 and err.strip().endswith("python3 -m pip install python-flint")

    def dask_missing(args):  # Dask: the package's own extra, as the ensemble says it
        raise ModuleNotFoundError("No module named 'distributed'", name="distributed")

    from observer_cad.ensemble import DASK_MISSING

    monkeypatch.setattr(cli_main, "cmd_show", dask_missing)
    rc, _, err = run(capsys, ["show", TANK])
    hint = "pip install 'observer_cad[cluster]'"
    assert rc == 2 and err.strip().endswith(hint) and DASK_MISSING.endswith(hint)

    def own_module_missing(args):  # a module of observer_cad itself: a packaging bug
        raise ModuleNotFoundError("No module named 'observer_cad.x'", name="observer_cad.x")

    monkeypatch.setattr(cli_main, "cmd_show", own_module_missing)
    rc, _, err = run(capsys, ["show", TANK])
    assert rc == 1 and "internal error: ModuleNotFoundError" in err

    def bug(args):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(cli_main, "cmd_show", bug)
    rc, _, err = run(capsys, ["show", TANK])
    assert rc == 1 and "internal error: ZeroDivisionError: division by zero" in err
    assert "please report" in err
