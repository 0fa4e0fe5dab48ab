"""Isolating residual banks (structure matrices): a bank of certified Jordan residual
generators realising a structure matrix; its rows checked against an independent oracle
(fault columns read off the right-hand side, H*(sI − F*)⁻¹ Φ D_j in s), by simulation (a
step in f2 moves exactly the residuals of f2's column), as one observer in standalone C,
and from the command line."""
from __future__ import annotations

import csv
import json
import shutil
import subprocess

import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel, build_observer, simulate
from observer_cad.cli import main
from observer_cad.errors import InfeasibleDesignError, UsageError
from observer_cad.reporting import format_bank
from observer_cad.simulation import scenario_from_dict
from observer_cad.analysis import ResidualBank, design_bank, parse_structure

from signature_oracle import oracle_signature, three_tanks

CC = shutil.which("cc")
GOS = ((0, 1, 1), (1, 0, 1), (1, 1, 0))
STEP_F2 = {"t_end": 10, "dt": 0.01,
           "signals": {"u1": "0.5*sin(t)", "u2": "0.3", "rho": "0.4*sin(3*t)",
                       "f2": "Piecewise((0, t < 5), (1, True))"}}


def tanks_all_measured(time="continuous"):
    """Three tanks, every level measured, a fault in each tank and a common inflow
    disturbance ρ into all three (so that each fault can be decoupled with ρ)."""
    x1, x2, x3 = sp.symbols("x1:4")
    u1, u2 = sp.symbols("u1 u2")
    f1, f2, f3, rho = sp.symbols("f1 f2 f3 rho")
    rhs = [-x1 + x2 + u1 + f1 + rho, x1 - 2 * x2 + x3 + u2 + f2 + rho, x2 - 2 * x3 + f3 + rho]
    if time == "discrete":  # Euler step h = 1/10
        h = sp.Rational(1, 10)
        rhs = [x + h * e for x, e in zip((x1, x2, x3), rhs)]
    return PlantModel(name="tanks3" + ("d" if time == "discrete" else ""), time=time,
                      states=[x1, x2, x3], inputs=[u1, u2], faults=[f1, f2, f3],
                      disturbances=[rho], outputs=[x1, x2, x3], dynamics=rhs)


@pytest.fixture(scope="module")
def tanks():
    m = tanks_all_measured()
    return m, design_bank(m)


def _oracle_rows(m, bank):
    return tuple(tuple(int(oracle_signature(m, d)[f]) for f in bank.faults)
                 for d in bank.designs)


def test_bank_realises_strong_isolation(tanks):
    m, bank = tanks
    assert bank.scheme == "generalised observer scheme"
    assert bank.structure_matrix == GOS
    assert _oracle_rows(m, bank) == GOS  # independent of the bank's own check
    assert all(ok for _, ok in bank.isolable)
    assert bank.detectable == {"f1": True, "f2": True, "f3": True}
    assert bank.certified
    for d in bank.designs:  # each residual decoupled from ρ and certified
        assert d.certificate.passed and "rho" in d.task.decoupled
    text = format_bank(bank)
    assert "Structure matrix" in text and "generalised observer scheme" in text


def test_requested_structure_is_realised_and_checked(tanks):
    m, _ = tanks
    bank = design_bank(m, structure="111,011")
    assert bank.structure_matrix == ((1, 1, 1), (0, 1, 1))
    assert _oracle_rows(m, bank) == bank.structure_matrix
    pairs = dict(bank.isolable)
    assert pairs[("f1", "f2")] and pairs[("f1", "f3")] and not pairs[("f2", "f3")]


def test_unachievable_row_is_refused_with_row_and_reason(tanks):
    m, _ = tanks
    with pytest.raises(InfeasibleDesignError) as exc:
        design_bank(m, structure="011,100")
    msg = str(exc.value)
    assert "--structure row 2 (100: sensitive to f1; decoupled from f2, f3)" in msg
    assert "not achievable" in msg and "rho, f2, f3" in msg


def test_best_achievable_when_no_scheme_works():
    """The issue's plant (y = x2, x3; ρ beside tank 3): f3 is undetectable, so neither
    scheme exists; the bank keeps the achievable row and says why the others fail."""
    m = three_tanks()
    bank = design_bank(m)
    assert bank.scheme == "best achievable"
    assert bank.structure_matrix == ((1, 1, 0),)
    assert _oracle_rows(m, bank) == bank.structure_matrix
    assert bank.detectable == {"f1": True, "f2": True, "f3": False}
    refused = dict(bank.refused)
    assert "f3 is undetectable" in refused["111"]


def test_structure_parsing():
    faults = ("f1", "f2", "f3")
    assert parse_structure("110, 101;011", faults) == ((1, 1, 0), (1, 0, 1), (0, 1, 1))
    for bad, what in (("11", "3 digits"), ("000", "all zeros"), ("1a0", "3 digits"), ("", "at least")):
        with pytest.raises(UsageError, match=what):
            parse_structure(bad, faults)


def test_bank_json_round_trip_rechecks_rows(tanks):
    m, bank = tanks
    data = json.loads(json.dumps(bank.to_json()))
    assert data["structure_matrix"] == [list(r) for r in GOS]
    again = ResidualBank.from_json(data, m)
    assert again.structure_matrix == bank.structure_matrix
    data["structure_matrix"][0] = [1, 1, 1]  # tampered: residual 1 does not see f1
    with pytest.raises(UsageError, match="r1"):
        ResidualBank.from_json(data, m)
    # a bank file's own rows are named as such (the messages spoke of --structure)
    for rows, needle in (([], "the bank's 'structure_matrix' needs at least one row"),
                         ([[0, 0, 0]], "the bank's 'structure_matrix' row 1 .* all zeros")):
        with pytest.raises(UsageError, match=needle):
            ResidualBank.from_json({**data, "structure_matrix": rows}, m)


def test_simulated_step_in_f2_moves_its_column_only(tanks):
    m, bank = tanks
    ob = build_observer(m, bank)
    assert ob.output_names == ("r1", "r2", "r3")
    res = simulate(m, ob, scenario_from_dict(STEP_F2))
    t = res["t"]
    col = [row[1] for row in bank.structure_matrix]  # f2's column
    for i, c in enumerate(col, 1):
        r = np.asarray(res[f"r{i}"])
        assert np.max(np.abs(r[t < 5])) < 1e-9, f"r{i} moves before the fault (ρ decoupled)"
        late = np.max(np.abs(r[t > 6]))
        if c:
            assert late > 0.1, f"r{i} should respond to f2"
        else:
            assert late < 1e-9, f"r{i} should ignore f2"


@pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")
def test_bank_exports_to_c_and_reproduces_the_simulator(tmp_path, monkeypatch):
    """Discrete time: the exported step on the recorded y, u is exactly what the
    simulator runs, so the C residuals must match the simulated r1..r3."""
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    from observer_cad.codegen import EXAMPLE_FLAGS, export_observer, split_signals
    m = tanks_all_measured("discrete")
    bank = design_bank(m)
    assert bank.structure_matrix == GOS
    ob = build_observer(m, bank)
    sc = scenario_from_dict({"steps": 80, "signals": {
        "u1": "0.5*sin(t/5)", "u2": "0.3", "rho": {"uniform": [-0.2, 0.2]},
        "f2": "Piecewise((0, t < 40), (1, True))"}})
    res = simulate(m, ob, sc)
    paths = export_observer(ob, tmp_path)
    c, _, ex = paths
    r = subprocess.run(["cc", *EXAMPLE_FLAGS, c.name, ex.name, "-lm"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    ys, us = split_signals(ob)
    names = [str(s) for s in ys + us]
    with open(tmp_path / "in.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", *names])  # the monitor's CSV: t counts a discrete model's steps
        for i in range(len(res["t"])):
            w.writerow([str(i)] + [repr(float(res[n][i])) for n in names])
    run = subprocess.run([str(tmp_path / "a.out"), "in.csv"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    rows = list(csv.reader(run.stdout.splitlines()))
    head, body = rows[0], np.array([[float(v) for v in row] for row in rows[1:]])
    for name in ("r1", "r2", "r3"):
        got = body[:, head.index(name)]
        want = np.asarray(res[name])[:len(got)]
        assert np.max(np.abs(got - want)) <= 1e-9 * max(1.0, np.max(np.abs(want))), name
    assert np.max(np.abs(body[:, head.index("r2")])) < 1e-9  # f2's column: r2 stays 0


def _write_model(tmp_path):
    src = '''"""Three tanks, every level measured, a fault in each tank, a common disturbance."""
import sympy as sp
from observer_cad import PlantModel
x1, x2, x3 = sp.symbols("x1:4")
u1, u2 = sp.symbols("u1 u2")
f1, f2, f3, rho = sp.symbols("f1 f2 f3 rho")
model = PlantModel(name="tanks3", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
    faults=[f1, f2, f3], disturbances=[rho], outputs=[x1, x2, x3],
    dynamics=[-x1 + x2 + u1 + f1 + rho, x1 - 2*x2 + x3 + u2 + f2 + rho, x2 - 2*x3 + f3 + rho])
'''
    p = tmp_path / "tanks3.py"
    p.write_text(src)
    return p


def test_cli_design_simulate_codegen_isolate(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    model = str(_write_model(tmp_path))
    assert main(["design", model, "--observer", "diagnostic", "--isolate"]) == 0
    out = capsys.readouterr().out
    assert "Structure matrix" in out and "Fault signature" in out
    assert main(["design", model, "--observer", "diagnostic", "--isolate", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["structure_matrix"] == [list(r) for r in GOS]
    assert data["designs"][0]["signature"] == {"f1": False, "f2": True, "f3": True}
    assert main(["design", model, "--observer", "diagnostic", "--isolate",
                 "--structure", "011,100"]) == 2
    err = capsys.readouterr().err
    assert "--structure row 2 (100" in err
    assert main(["design", model, "--observer", "diagnostic", "--structure", "011"]) == 2
    assert "add --isolate" in capsys.readouterr().err
    scen = tmp_path / "step.json"
    scen.write_text(json.dumps(STEP_F2))
    assert main(["simulate", model, "--observer", "diagnostic", "--isolate", "--scenario",
                 str(scen), "--out", str(tmp_path / "sim")]) == 0
    header = (tmp_path / "sim" / "signals.csv").read_text().splitlines()[0].split(",")
    assert header[-3:] == ["r1", "r2", "r3"]
    assert main(["codegen", model, "--observer", "diagnostic", "--isolate", "--out",
                 str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "tanks3_bank.c").is_file()


def test_cli_refuses_undetectable_fault_by_name(tmp_path, capsys):
    src = tmp_path / "tt3.py"
    src.write_text('''import sympy as sp
from observer_cad import PlantModel
x1, x2, x3 = sp.symbols("x1:4")
u1, u2 = sp.symbols("u1 u2")
f1, f2, f3, rho = sp.symbols("f1 f2 f3 rho")
model = PlantModel(name="tt3", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
    faults=[f1, f2, f3], disturbances=[rho], outputs=[x2, x3],
    dynamics=[-x1 + x2 + u1 + f1, x1 - 2*x2 + x3 + u2 + f2, x2 - 2*x3 + f3 + rho])
''')
    rc = main(["design", str(src), "--observer", "diagnostic", "--fault", "f1", "--fault", "f2",
               "--fault", "f3"])
    assert rc == 2
    err = capsys.readouterr().err
    assert "f3 is undetectable with rho decoupled" in err and "Φ D_f3 = 0" in err


def test_symbolic_bank_assumes_the_fault_gain_nonzero():
    """f2 enters through a: the residuals that must see f2 hold for a ≠ 0 (an assumption
    of the bank). (The one decoupled from f2 may carry a ≠ 0 too: every pivot of its rank
    decisions contributes its nonzero condition, a sufficient condition.)"""
    x1, x2, x3 = sp.symbols("x1:4")
    u1, u2 = sp.symbols("u1 u2")
    f1, f2, f3, rho, a = sp.symbols("f1 f2 f3 rho a")
    m = PlantModel(name="tanks3a", time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
                   faults=[f1, f2, f3], disturbances=[rho], outputs=[x1, x2, x3],
                   dynamics=[-x1 + x2 + u1 + f1 + rho, x1 - 2 * x2 + x3 + u2 + a * f2 + rho,
                             x2 - 2 * x3 + f3 + rho], parameters={a: 2})
    bank = design_bank(m, symbolic=True)
    assert bank.structure_matrix == GOS
    assert bank.assumptions == (sp.Ne(a, 0),)
    for row, d in zip(bank.structure_matrix, bank.designs):
        if row[1]:
            assert sp.Ne(a, 0) in d.assumptions


def four_tanks():
    """Four tanks in a row, levels 1, 3, 4 measured, faults in tanks 1-3, a disturbance
    into tanks 3 and 4: the strongly isolating residuals need k = 2 for two of the rows."""
    x1, x2, x3, x4 = sp.symbols("x1:5")
    u1, u2 = sp.symbols("u1 u2")
    f1, f2, f3, rho = sp.symbols("f1 f2 f3 rho")
    return PlantModel(name="tanks4", time="continuous", states=[x1, x2, x3, x4],
                      inputs=[u1, u2], faults=[f1, f2, f3], disturbances=[rho],
                      outputs=[x1, x3, x4],
                      dynamics=[-x1 + x2 + u1 + f1, x1 - 2 * x2 + x3 + u2 + f2,
                                x2 - 2 * x3 + x4 + f3 + rho, x3 - 2 * x4 + rho])


def test_bank_with_higher_order_residuals_simulates_its_structure():
    m = four_tanks()
    bank = design_bank(m)
    assert bank.scheme == "generalised observer scheme"
    assert bank.structure_matrix == GOS
    assert _oracle_rows(m, bank) == GOS
    assert max(d.k for d in bank.designs) > 1
    ob = build_observer(m, bank)
    assert len(ob.states) == sum(d.k for d in bank.designs)
    for j, f in enumerate(bank.faults):  # a step in each fault moves its column only
        sc = scenario_from_dict({"t_end": 8, "dt": 0.01, "signals": {
            "u1": "0.5*sin(t)", "u2": "0.3", "rho": "0.4*sin(2*t)",
            f: "Piecewise((0, t < 4), (1, True))"}})
        res = simulate(m, ob, sc)
        t = res["t"]
        for i, row in enumerate(bank.structure_matrix, 1):
            r = np.asarray(res[f"r{i}"])
            assert np.max(np.abs(r[t < 4])) < 1e-9
            late = np.max(np.abs(r[t > 5]))
            assert (late > 1e-3) == bool(row[j]), (f, i, late)


def test_bank_columns_from_named_faults_and_cli_usage_errors(tanks, tmp_path, capsys):
    m, _ = tanks
    bank = design_bank(m, faults=["f1", "f2"])
    assert bank.faults == ("f1", "f2")
    assert bank.structure_matrix == ((0, 1), (1, 0))
    with pytest.raises(UsageError, match="both a bank column"):
        design_bank(m, faults=["f1", "f2"], disturbances=["f2"])
    model = str(_write_model(tmp_path))
    assert main(["design", model, "--observer", "virtual-sensor", "--estimate", "x1",
                 "--isolate"]) == 2
    assert "use --observer diagnostic" in capsys.readouterr().err
    assert main(["design", model, "--observer", "diagnostic", "--isolate", "--form",
                 "canonical"]) == 2
    assert "--form canonical does not apply to --isolate" in capsys.readouterr().err


@pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")
def test_compiled_simulator_runs_the_bank_like_the_reference(tanks, tmp_path, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    from observer_cad import CompiledSimulator
    m, bank = tanks
    ob = build_observer(m, bank)
    sc = scenario_from_dict(STEP_F2)
    ref, fast = simulate(m, ob, sc), CompiledSimulator(m, ob).simulate(sc)
    for name in ("r1", "r2", "r3"):
        assert np.max(np.abs(np.asarray(ref[name]) - np.asarray(fast[name]))) < 1e-10, name


# ---------------------------------------------------------------- the example model
def test_example_model_three_tank_isolation(models_dir):
    """models/three_tank_isolation.py (the demo's bank): every fault detectable, every pair
    isolable by analysis; the bank is the generalised observer scheme, its rows confirmed by
    the oracle; on the example scenario (step in f2 at t = 10, ρ acting) only f2's column
    moves."""
    from observer_cad import analyze, load_model
    from observer_cad.simulation import load_scenario
    m = load_model(models_dir / "three_tank_isolation.py")
    a = analyze(m)
    assert a.detectable == {"f1": True, "f2": True, "f3": True}
    assert all(p.isolable for p in a.pairs)
    bank = design_bank(m)
    assert bank.scheme == "generalised observer scheme"
    assert bank.structure_matrix == GOS
    assert _oracle_rows(m, bank) == GOS
    res = simulate(m, build_observer(m, bank),
                   load_scenario(models_dir / "scenarios" / "three_tank_isolation.json"))
    t = np.asarray(res["t"])
    assert np.max(np.abs(np.asarray(res["rho"]))) > 0.1  # the disturbance acts throughout
    for i, c in enumerate((row[1] for row in bank.structure_matrix), 1):
        r = np.asarray(res[f"r{i}"])
        assert np.max(np.abs(r[t < 10])) < 1e-9, f"r{i} moves before the fault"
        late = np.max(np.abs(r[t > 12]))
        assert (late > 0.1) if c else (late < 1e-9), (i, c, late)


def test_repeated_structure_row_is_refused():
    from observer_cad.analysis import parse_structure
    with pytest.raises(UsageError, match="repeats row 1"):
        parse_structure("011,011", ["f1", "f2", "f3"])
