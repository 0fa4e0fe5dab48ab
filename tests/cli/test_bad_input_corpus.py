"""A corpus of bad inputs: model files, CLI values, scenarios and
cache faults.

Every case asserts what the README promises a user: the documented exit status (2 for a
user error, 4 for a simulation that produced NaN/inf), exactly one line on stderr, no
traceback, nothing on stdout, nothing executed (payloads try to create a file), and an
existing ``--out`` directory left exactly as it was. Most cases run through
``observer_cad.cli.main`` (fast); a few through ``python3 -m observer_cad.cli``.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from observer_cad.cli import main

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
DRIVE = MODELS / "electric_drive.py"
TANK_LIN = MODELS / "three_tank_linear.py"
TANK = MODELS / "three_tank.py"
PREFIX = "observer-cad: error:"
#: text of a payload that would create the file named PWNED in the working directory
PAYLOAD = "__import__('os').system('touch PWNED')"


# ----------------------------------------------------------------------------- helpers
def snapshot(d: Path) -> dict:
    return {str(p.relative_to(d)): (p.read_bytes() if p.is_file() else None)
            for p in sorted(d.rglob("*"))}


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A working directory with an existing --out holding one file."""
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("user data\n")
    return tmp_path


def check(rc, out, err, status=2, *needles, work=None):
    assert "Traceback" not in err and "Traceback" not in out, err
    assert rc == status, (rc, err)
    lines = err.splitlines()
    assert len(lines) == 1, f"expected one stderr line, got {len(lines)}:\n{err}"
    assert lines[0].startswith(PREFIX), lines[0]
    assert lines[0][len(PREFIX):].strip()
    for n in needles:
        assert n in lines[0], f"{n!r} not in {lines[0]!r}"
    assert out == "", out
    if work is not None:
        assert not (work / "PWNED").exists(), "a payload was executed"
        assert snapshot(work / "out") == {"keep.txt": b"user data\n"}, "--out was changed"


def run(capsys, argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


# ----------------------------------------------------------------------------- scenarios
#: raw JSON text of a scenario for the discrete electric drive → needles of the message
SCENARIOS = {
    "steps_zero": ('{"steps": 0}', ("'steps'", "at least 1")),
    "steps_negative": ('{"steps": -5}', ("'steps'",)),
    "steps_fraction": ('{"steps": 10.7}', ("'steps'", "whole number", "10.7")),
    "steps_true": ('{"steps": true}', ("'steps'", "whole number", "true")),
    "steps_string": ('{"steps": "100"}', ("'steps'", "whole number")),
    "steps_nan": ('{"steps": NaN}', ("'steps'",)),
    "steps_infinity": ('{"steps": Infinity}', ("'steps'",)),
    "steps_null": ('{"steps": null}', ("steps",)),
    "steps_huge": ('{"steps": 1e9}', ("GiB", "OBSERVER_CAD_MEMORY_LIMIT")),
    "steps_astronomic": ('{"steps": 1e300}', ("OBSERVER_CAD_MEMORY_LIMIT",)),
    "no_steps": ('{"t_end": 5, "dt": 0.1}', ("needs 'steps'",)),
    "dt_zero": ('{"steps": 5, "t_end": 1, "dt": 0}', ("'dt'", "> 0")),
    "dt_negative": ('{"steps": 5, "t_end": 1, "dt": -0.1}', ("'dt'", "> 0")),
    "dt_nan": ('{"steps": 5, "t_end": 1, "dt": NaN}', ("'dt'", "finite")),
    "t_end_nan": ('{"steps": 5, "t_end": NaN, "dt": 0.1}', ("'t_end'", "finite")),
    "t_end_string": ('{"steps": 5, "t_end": "ten", "dt": 0.1}', ("'t_end'", "number")),
    "dt_above_t_end": ('{"steps": 5, "t_end": 1, "dt": 2}', ("'dt'", "larger than 't_end'")),
    "seed_negative": ('{"steps": 5, "seed": -1}', ("'seed'", "in [0, 2^64)")),
    "seed_beyond_64_bits": ('{"steps": 5, "seed": 18446744073709551616}', ("'seed'", "in [0, 2^64)")),
    "seed_string": ('{"steps": 5, "seed": "one"}', ("'seed'",)),
    "seed_fraction": ('{"steps": 5, "seed": 1.5}', ("'seed'",)),
    "seed_bool": ('{"steps": 5, "seed": false}', ("'seed'",)),
    "signals_list": ('{"steps": 5, "signals": ["u"]}', ("'signals'", "object")),
    "signals_string": ('{"steps": 5, "signals": "u=1"}', ("'signals'", "object")),
    "initial_list": ('{"steps": 5, "initial": [0, 0, 0]}', ("'initial'", "object")),
    "initial_string_value": ('{"steps": 5, "initial": {"x1": "0.5"}}', ("initial 'x1'", "number")),
    "initial_nan": ('{"steps": 5, "initial": {"x1": NaN}}', ("initial 'x1'", "finite")),
    "initial_infinity": ('{"steps": 5, "initial": {"x1": -Infinity}}', ("initial 'x1'",)),
    "initial_bool": ('{"steps": 5, "initial": {"x1": true}}', ("initial 'x1'",)),
    "initial_unknown_state": ('{"steps": 5, "initial": {"x9": 1}}', ("x9",)),
    "observer_initial_list": ('{"steps": 5, "observer_initial": [1]}', ("'observer_initial'",)),
    "observer_initial_nan": ('{"steps": 5, "observer_initial": {"xl1": NaN}}', ("'xl1'",)),
    "uniform_range_overflows": ('{"steps": 5, "signals": {"u": {"uniform": [-1e308, 1e308]}}}',
                                ("signal 'u'", "wider than a double can hold")),
    "uniform_reversed": ('{"steps": 5, "signals": {"u": {"uniform": [1, 0]}}}',
                         ("signal 'u'", "low 1 > high 0")),
    "uniform_nan": ('{"steps": 5, "signals": {"u": {"uniform": [NaN, 1]}}}', ("signal 'u'",)),
    "uniform_string": ('{"steps": 5, "signals": {"u": {"uniform": ["a", 1]}}}', ("signal 'u'",)),
    "uniform_three": ('{"steps": 5, "signals": {"u": {"uniform": [0, 1, 2]}}}', ("uniform",)),
    "uniform_not_list": ('{"steps": 5, "signals": {"u": {"uniform": 1}}}', ("uniform",)),
    "gauss": ('{"steps": 5, "signals": {"u": {"gauss": [0, 1]}}}', ("uniform",)),
    "signal_nan_number": ('{"steps": 5, "signals": {"u": NaN}}', ("signal 'u'", "finite")),
    "signal_bool": ('{"steps": 5, "signals": {"u": true}}', ("signal 'u'",)),
    "signal_null": ('{"steps": 5, "signals": {"u": null}}', ("signal 'u'",)),
    "signal_list": ('{"steps": 5, "signals": {"u": [1, 2]}}', ("signal 'u'",)),
    "signal_unknown": ('{"steps": 5, "signals": {"nope": "1"}}', ("'nope'",)),
    "signal_text_nan": ('{"steps": 5, "signals": {"u": "nan"}}', ("signal 'u'", "'nan'")),
    "signal_text_inf": ('{"steps": 5, "signals": {"u": "inf"}}', ("signal 'u'", "'inf'")),
    "signal_other_symbol": ('{"steps": 5, "signals": {"u": "t + z"}}', ("'z'",)),
    "signal_syntax": ('{"steps": 5, "signals": {"u": "sin(t"}}', ("signal 'u'", "not a valid")),
    "signal_import": (json.dumps({"steps": 5, "signals": {"u": PAYLOAD + " * 0"}}),
                      ("signal 'u'", "cannot read")),
    "signal_import_only": (json.dumps({"steps": 5, "signals": {"u": PAYLOAD}}), ("signal 'u'",)),
    "signal_builtins": (json.dumps({"steps": 5, "signals": {
        "u": "t.__class__.__base__.__subclasses__()"}}), ("attribute access",)),
    "piecewise_without_default": ('{"steps": 5, "signals": {"u": {"piecewise": [["1", "t < 3"]]}}}',
                                  ("signal 'u'", "no piecewise condition holds at t = 3",
                                   "[value, true]")),
    "signal_lambda": ('{"steps": 5, "signals": {"u": "(lambda: 1)()"}}', ("signal 'u'",)),
    "signal_subscript": ('{"steps": 5, "signals": {"u": "t[0]"}}', ("subscript",)),
    "signal_string": ('{"steps": 5, "signals": {"u": "\'abc\'"}}', ("a string",)),
    "signal_comprehension": ('{"steps": 5, "signals": {"u": "[t for t in (1, 2)]"}}',
                             ("comprehension",)),
    "signal_unknown_function": ('{"steps": 5, "signals": {"u": "eval(t)"}}', ("'eval'",)),
    "signal_sympify_function": ('{"steps": 5, "signals": {"u": "sympify(t)"}}', ("'sympify'",)),
    "signal_keyword": ('{"steps": 5, "signals": {"u": "sin(x=t)"}}', ("keyword",)),
    "signal_huge_power": ('{"steps": 5, "signals": {"u": "10**10**10"}}', ("exponent",)),
    "signal_huge_number": (json.dumps({"steps": 5, "signals": {"u": "9" * 500}}),
                           ("floating-point range",)),
    "signal_too_long": (json.dumps({"steps": 5, "signals": {"u": "+".join(["t"] * 1500)}}),
                        ("longer than",)),
    "signal_deep": (json.dumps({"steps": 5, "signals": {"u": "(" * 300 + "t" + ")" * 300}}),
                    ("signal 'u'",)),
    "signal_division_by_zero": ('{"steps": 5, "signals": {"u": "1/0"}}', ("division by zero",)),
    "signal_complex": ('{"steps": 5, "signals": {"u": "1j*t"}}', ("complex",)),
    "signal_imaginary_unit": ('{"steps": 5, "signals": {"u": "I*t"}}', ("imaginary",)),
    "signal_condition_as_value": ('{"steps": 5, "signals": {"u": "t < 3"}}', ("condition",)),
    "piecewise_bad_condition": ('{"steps": 5, "signals": {"u": {"piecewise": [["1", "t +"]]}}}',
                                ("condition",)),
    "piecewise_value_condition": ('{"steps": 5, "signals": {"u": {"piecewise": [["1", "t"]]}}}',
                                  ("condition",)),
    "piecewise_payload": (json.dumps({"steps": 5, "signals": {"u": {"piecewise": [
        ["1", PAYLOAD + " or True"]]}}}), ("condition",)),
    "piecewise_empty": ('{"steps": 5, "signals": {"u": {"piecewise": []}}}', ("piecewise",)),
    "piecewise_not_pairs": ('{"steps": 5, "signals": {"u": {"piecewise": [["1"]]}}}',
                            ("pairs",)),
    "sympy_piecewise_payload": (json.dumps({"steps": 5, "signals": {
        "u": f"Piecewise((1, {PAYLOAD} > 0), (0, True))"}}), ("signal 'u'",)),
    "unknown_key": ('{"steps": 5, "colour": "red"}', ("colour",)),
    "description_not_text": ('{"steps": 5, "description": 5}', ("description",)),
    "not_an_object": ('[1, 2, 3]', ("JSON object",)),
    "not_json": ('{"steps": 5,', ("not valid JSON",)),
    "empty_file": ('', ("not valid JSON",)),
    "deeply_nested_json": ('[' * 100000 + ']' * 100000, ("JSON",)),
    "not_utf8": (b"\xff\xfe{\x00", ("scenario",)),
}


def _write_scenario(work, text):
    p = work / "scenario.json"
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return p


@pytest.mark.parametrize("cid", list(SCENARIOS))
def test_scenario(work, capsys, cid):
    text, needles = SCENARIOS[cid]
    sc = _write_scenario(work, text)
    rc, out, err = run(capsys, ["simulate", DRIVE, "--observer", "unknown-input", "--fault", "d",
                                "--scenario", sc, "--out", work / "out"])
    check(rc, out, err, 2, "scenario.json", *needles, work=work)


NONFINITE = {
    # (model, observer options, scenario) → needles of the one line (exit 4)
    "pole_of_a_signal": (DRIVE, ["--observer", "unknown-input", "--fault", "d"],
                         {"steps": 20, "signals": {"u": "1/(t-5)"}},
                         ("signal 'u' is inf at t = 5", "division by zero")),
    "overflowing_signal": (DRIVE, ["--observer", "unknown-input", "--fault", "d"],
                           {"steps": 20, "signals": {"u": "exp(100*t)"}},
                           ("signal 'u' is inf at t = 8",)),
    "log_of_negative_signal": (DRIVE, ["--observer", "unknown-input", "--fault", "d"],
                               {"steps": 20, "signals": {"d": "log(5 - t)"}},
                               ("signal 'd'", "at t = 5")),
    "piecewise_overflow": (DRIVE, ["--observer", "unknown-input", "--fault", "d"],
                           {"steps": 20, "signals": {"d": {"piecewise": [
                               ["0", "t < 3"], ["exp(1000*t)", True]]}}},
                           ("signal 'd' is inf at t = 3",)),
    "plant_leaves_its_domain": (TANK, ["--observer", "virtual-sensor", "--estimate", "x1"],
                                {"t_end": 1, "dt": 0.01, "initial": {"x1": 0, "x2": 1, "x3": 2}},
                                ("x1 became nan at t = 0.01", "left its domain")),
    "plant_overflows": (TANK_LIN, ["--observer", "virtual-sensor", "--estimate", "x1"],
                        {"t_end": 5, "dt": 0.01, "signals": {"u1": "1e308"}},
                        ("became inf",)),
}


@pytest.mark.parametrize("cid", list(NONFINITE))
def test_nonfinite_simulation_stops_with_status_4(work, capsys, cid):
    model, opts, scenario, needles = NONFINITE[cid]
    sc = _write_scenario(work, json.dumps(scenario))
    rc, out, err = run(capsys, ["simulate", model, *opts, "--scenario", sc, "--out", work / "out"])
    check(rc, out, err, 4, "scenario.json", *needles, work=work)


def test_keep_nonfinite_writes_nan_literally_and_empty_only_for_unavailable(work, capsys):
    """--keep-nonfinite: the CSV keeps nan/inf as text; an empty cell is 'not available'
    (the last rows of a delayed estimate); exit 4 after one warning line."""
    sc = _write_scenario(work, json.dumps({"steps": 8, "signals": {"u": "1/(t-5)"}}))
    out = work / "sim"
    rc = main(["simulate", str(DRIVE), "--observer", "unknown-input", "--fault", "rho",
               "--scenario", str(sc), "--out", str(out), "--keep-nonfinite"])
    err = capsys.readouterr().err
    assert rc == 4 and len(err.splitlines()) == 1 and err.startswith("observer-cad: warning:")
    assert "signal 'u' is inf at t = 5" in err
    rows = [ln.split(",") for ln in (out / "signals.csv").read_text().splitlines()]
    head, body = rows[0], rows[1:]
    u, est = head.index("u"), head.index("rho_hat")
    assert body[5][u] == "inf"
    assert "" not in [r[i] for r in body for i in range(len(head)) if i != est]
    assert [r[est] for r in body[-2:]] == ["", ""]  # k = 2: the last two are not available
    assert all(r[est] != "" for r in body[:-2])
    assert [r[head.index("x3")] for r in body[6:]] == ["inf", "inf"]


# ----------------------------------------------------------------------------- CLI values
def uio(*extra):
    return ["design", DRIVE, "--observer", "unknown-input", "--fault", "d", *extra]


def vs(*extra):
    return ["design", TANK_LIN, "--observer", "virtual-sensor", "--estimate", "x1", *extra]


CLI_VALUES = {
    "gain_incomplete": (uio("--gain", "1+"), ("--gain", "not a valid expression")),
    "gain_division_by_zero": (uio("--gain", "1/0"), ("--gain", "division by zero")),
    "gain_nan": (uio("--gain", "nan"), ("--gain", "'nan'")),
    "gain_complex": (uio("--gain", "0.5+I"), ("--gain", "imaginary")),
    "gain_payload": (uio("--gain", PAYLOAD), ("--gain", "attribute access")),
    "gain_attribute": (uio("--gain", "(1).__class__"), ("--gain", "attribute")),
    "gain_huge": (uio("--gain", "1e999"), ("--gain", "floating-point range")),
    "gain_too_many": (uio("--gain", "-0.7", "-0.4", "-0.1", "-0.2"), ("g must have",)),
    "gain_symbol": (uio("--gain", "k1"), ("--gain", "'k1'")),
    "gain_symbolic_design": (uio("--symbolic", "--gain", "1+"), ("--gain", "not a valid")),
    "gain_wrong_observer": (vs("--gain", "1"), ("--gain applies",)),
    "eigenvalue_incomplete": (vs("--form", "canonical", "--eigenvalues", "-1+"),
                              ("--eigenvalues", "not a valid expression")),
    "eigenvalue_payload": (vs("--form", "canonical", "--eigenvalues", PAYLOAD),
                           ("--eigenvalues",)),
    "eigenvalue_name": (vs("--form", "canonical", "--eigenvalues", "abc"), ("'abc'",)),
    "eigenvalue_infinite": (vs("--form", "canonical", "--eigenvalues", "exp(1000)"),
                            ("not a finite number",)),
    "eigenvalue_division_by_zero": (vs("--form", "canonical", "--eigenvalues", "1/0"),
                                    ("division by zero",)),
    "eigenvalue_without_conjugate": (vs("--form", "canonical", "--eigenvalues", "-1+2*I"),
                                     ("conjugate",)),
    "eigenvalue_python_complex": (vs("--form", "canonical", "--eigenvalues", "-1+2j"),
                                  ("complex literal",)),
    "lambda_name": (vs("--lambda", "abc"), ("not a number",)),
    "lambda_payload": (vs("--lambda", PAYLOAD), ("not a number",)),
    "lambda_complex": (vs("--lambda", "0.5+0.1*I"), ("not real",)),
    "lambda_syntax": (vs("--lambda", "1+*2"), ("not a number",)),
    "lambda_power": (vs("--lambda", "2**100000"), ("exponent",)),
    "lambda_crootof_complex": (vs("--lambda", "CRootOf(x**5 - x + 1, 1)"), ("complex root",)),
    "lambda_crootof_index": (vs("--lambda", "CRootOf(x**3 - 3*x + 1, 3)"), ("out of range",)),
    "lambda_crootof_two_variables": (vs("--lambda", "CRootOf(x**3 - y, 0)"), ("two variables",)),
    "eigenvalue_crootof": (vs("--form", "canonical", "--eigenvalues", "CRootOf(x**3 - 3*x + 1, 0)"),
                           ("not allowed here",)),
    "estimate_payload": (["design", TANK_LIN, "--observer", "virtual-sensor", "--estimate", PAYLOAD],
                         ("--estimate",)),
    "estimate_tuple": (["design", TANK_LIN, "--observer", "virtual-sensor", "--estimate", "x1,x3"],
                       ("one expression",)),
    "estimate_unknown": (["design", TANK_LIN, "--observer", "virtual-sensor", "--estimate", "x9"],
                         ("'x9'",)),
    "estimate_nonlinear": (["design", TANK_LIN, "--observer", "virtual-sensor", "--estimate",
                            "x1*x2"], ("not linear",)),
    "estimate_attribute": (["design", TANK_LIN, "--observer", "virtual-sensor", "--estimate",
                            "x1.func"], ("attribute",)),
    "bound_payload": (["design", TANK_LIN, "--observer", "interval", "--estimate", "x1",
                       "--bound", f"rho=-1,{PAYLOAD}"], ("--bound",)),
    "bound_reversed": (["design", TANK_LIN, "--observer", "interval", "--estimate", "x1",
                        "--bound", "rho=1,-1"], ("--bound", "low 1 > high -1")),
    "bound_infinite": (["design", TANK_LIN, "--observer", "interval", "--estimate", "x1",
                        "--bound", "rho=-oo,oo"], ("--bound", "'oo'")),
    "bound_nan": (["design", TANK_LIN, "--observer", "interval", "--estimate", "x1",
                   "--bound", "rho=nan,1"], ("--bound",)),
    "bound_unknown_symbol": (["design", TANK_LIN, "--observer", "interval", "--estimate", "x1",
                              "--bound", "zz=0,1"], ("'zz'",)),
    "bound_format": (["design", TANK_LIN, "--observer", "interval", "--estimate", "x1",
                      "--bound", "rho:0..1"], ("NAME=LOW,HIGH",)),
    "bound_complex": (["design", TANK_LIN, "--observer", "interval", "--estimate", "x1",
                       "--bound", "rho=-1,I"], ("--bound",)),
    "rtol_nan": (uio("--rtol", "nan"), ("--rtol",)),
    "rtol_negative": (uio("--rtol", "-1"), ("--rtol",)),
    "codegen_dt_zero": (["codegen", TANK_LIN, "--observer", "virtual-sensor", "--estimate", "x1",
                         "--out", "out", "--dt", "0"], ("--dt",)),
    "codegen_dt_nan": (["codegen", TANK_LIN, "--observer", "virtual-sensor", "--estimate", "x1",
                        "--out", "out", "--dt", "nan"], ("--dt",)),
    "codegen_dt_inf": (["codegen", TANK_LIN, "--observer", "virtual-sensor", "--estimate", "x1",
                        "--out", "out", "--dt", "inf"], ("--dt",)),
    "gamma_nan": (["design", MODELS / "drem_example.py", "--observer", "drem", "--gamma", "nan"],
                  ("--gamma",)),
    "poles_nan": (["design", MODELS / "drem_example.py", "--observer", "drem",
                   "--poles", "nan,-1"], ("--poles", "finite")),
    "poles_text": (["design", MODELS / "drem_example.py", "--observer", "drem",
                    "--poles", "a,b"], ("--poles",)),
    "gamma_negative": (["design", MODELS / "drem_example.py", "--observer", "drem",
                        "--gamma", "-1"], ("--gamma",)),
}


@pytest.mark.parametrize("cid", list(CLI_VALUES))
def test_cli_value(work, capsys, cid):
    argv, needles = CLI_VALUES[cid]
    rc, out, err = run(capsys, argv)
    check(rc, out, err, 2, *needles, work=work)


@pytest.mark.parametrize("cid", ["gain_payload", "eigenvalue_payload", "estimate_payload"])
def test_cli_value_in_simulate_leaves_out_alone(work, capsys, cid):
    argv, needles = CLI_VALUES[cid]
    sc = _write_scenario(work, '{"steps": 5, "t_end": 1, "dt": 0.1}')
    argv = ["simulate"] + list(argv[1:]) + ["--scenario", sc, "--out", work / "out"]
    rc, out, err = run(capsys, argv)
    check(rc, out, err, 2, *needles, work=work)


@pytest.mark.parametrize("option", ["--run", "--persistence"])
def test_whole_numbers_beyond_a_c_int_are_refused(work, capsys, option):
    """--run 2⁶⁴ − 1 was an OverflowError (internal error) and --persistence 10²⁰ exported
    C that does not compile: whole-number options stop at a C int."""
    sc = _write_scenario(work, '{"steps": 5}')
    extra = ["--threshold", "guaranteed"] if option == "--persistence" else []
    rc, out, err = run(capsys, ["simulate", DRIVE, "--observer", "diagnostic", *extra,
                                "--scenario", sc, "--out", work / "out",
                                option, "18446744073709551615"])
    check(rc, out, err, 2, f"{option} 18446744073709551615: must be at most 2147483647",
          work=work)


def test_simulate_reads_every_case_not_only_the_one_it_runs(work, capsys):
    """A case simulate does not run is still read: an unknown signal in it is one line
    (the ensemble already refused it; simulate ran the first case and exited 0)."""
    sc = _write_scenario(work, json.dumps({"steps": 5, "cases": {"ok": {}, "bad": {"nope": 1}}}))
    rc, out, err = run(capsys, ["simulate", DRIVE, "--observer", "unknown-input", "--fault", "d",
                                "--scenario", sc, "--case", "ok", "--out", work / "out"])
    check(rc, out, err, 2, "signal 'nope'", work=work)


def test_out_is_a_file(work, capsys):
    sc = _write_scenario(work, '{"steps": 5}')
    (work / "afile").write_text("x")
    rc, out, err = run(capsys, ["simulate", DRIVE, "--observer", "unknown-input", "--fault", "d",
                                "--scenario", sc, "--out", work / "afile"])
    check(rc, out, err, 2, "afile", "cannot create the output directory", work=work)
    assert (work / "afile").read_text() == "x"


# ----------------------------------------------------------------------------- model files
HEADER = '''\
import sympy as sp
from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u, d, rho, w1 = sp.symbols("u d rho w1")
k1 = sp.Symbol("k1")
BASE = dict(
    name="corpus", time="discrete", states=[x1, x2, x3], inputs=[u], faults=[d],
    disturbances=[rho], noise=[w1], outputs=[x1 + w1, x3],
    dynamics=[x2, k1 * x3 + rho, u + d], parameters={k1: 2},
    bounds={d: (-1, 1), rho: (-0.1, 0.1), w1: (-0.01, 0.01)},
)
'''

MODEL_CASES = {
    "parameter_sympy_nan": ("parameters={k1: sp.nan}", ("parameter 'k1'", "not a finite number")),
    "parameter_sympy_oo": ("parameters={k1: sp.oo}", ("parameter 'k1'", "not a finite number")),
    "parameter_sympy_minus_oo": ("parameters={k1: -sp.oo}", ("parameter 'k1'", "not a finite")),
    "parameter_sympy_zoo": ("parameters={k1: sp.zoo}", ("parameter 'k1'", "not a finite number")),
    "parameter_float_inf": ("parameters={k1: float('inf')}", ("parameter 'k1'", "not a finite")),
    "parameter_imaginary": ("parameters={k1: sp.I}", ("parameter 'k1'", "not real")),
    "parameter_complex_sympy": ("parameters={k1: 1 + 2 * sp.I}", ("parameter 'k1'", "not real")),
    "parameter_python_complex": ("parameters={k1: 1 + 2j}", ("parameter 'k1'", "not real")),
    "parameter_sqrt_negative": ("parameters={k1: sp.sqrt(-2)}", ("parameter 'k1'", "not real")),
    "parameter_text_payload": (f"parameters={{k1: {PAYLOAD!r}}}", ("parameter 'k1'",)),
    "parameter_text_division_by_zero": ("parameters={k1: '1/0'}", ("parameter 'k1'",)),
    "parameter_bool": ("parameters={k1: True}", ("parameter 'k1'", "not a number")),
    "parameter_list": ("parameters={k1: [1]}", ("parameter 'k1'", "not a number")),
    "bound_both_infinite": ("bounds={d: (-sp.oo, sp.oo)}", ("bound of 'd'", "not a finite")),
    "bound_one_sided": ("bounds={d: (0, sp.oo)}", ("upper bound of 'd'", "not a finite")),
    "bound_nan": ("bounds={d: (sp.nan, 1)}", ("lower bound of 'd'", "not a finite")),
    "bound_float_nan": ("bounds={d: (0, float('nan'))}", ("upper bound of 'd'", "not a finite")),
    "bound_reversed": ("bounds={d: (1, -1)}", ("bounds of 'd'", "low 1 > high -1")),
    "bound_complex": ("bounds={d: (-1, sp.I)}", ("upper bound of 'd'", "not real")),
    "bound_text_payload": (f"bounds={{d: (-1, {PAYLOAD!r})}}", ("upper bound of 'd'",)),
    "bound_not_a_pair": ("bounds={d: 1}", ("bounds of 'd'", "pair")),
    "bound_of_a_state_reversed": ("bounds={x1: (1, 0)}", ("bounds of 'x1'", "low 1 > high 0")),
    "initial_box_outside_the_bounds": ("bounds={x1: (0, 1)}, initial={x1: (2, 3)}",
                                       ("initial box of 'x1'",)),
    "unused_fault": ("faults=[d, sp.Symbol('f9')]", ("fault 'f9'", "appears in no dynamics")),
    "unused_disturbance": ("disturbances=[rho, sp.Symbol('r9')]",
                           ("disturbance 'r9'", "appears in no dynamics")),
    "unused_noise": ("noise=[w1, sp.Symbol('w9')]", ("noise 'w9'", "appears in no output")),
    # (an audit found these reported as "internal error" or a TypeError)
    "dynamics_imaginary": ("dynamics=[x2 + sp.I * x1, k1 * x3 + rho, u + d]",
                           ("dynamics[1]", "not real")),
    "dynamics_nonreal_power": ("dynamics=[x2 + (-1) ** sp.Rational(1, 3) * x1, k1 * x3 + rho,"
                               " u + d]", ("dynamics[1]", "not real")),
    "dynamics_nan": ("dynamics=[x2, k1 * x3 + rho + sp.nan, u + d]", ("dynamics[2]", "not finite")),
    "dynamics_zoo": ("dynamics=[x2, k1 * x3 + rho, u + d + sp.zoo * x1]",
                     ("dynamics[3]", "not finite")),
    "output_huge_coefficient": ("outputs=[x1 + w1, 10**400 * x3]",
                                ("outputs[2]", "beyond the floating-point range")),
    "input_named_t": ("inputs=[sp.Symbol('t')], dynamics=[x2, k1 * x3 + rho, sp.Symbol('t') + d]",
                      ("input name 't' is reserved",)),
    "input_named_like_an_output": ("inputs=[sp.Symbol('y1')], dynamics=[x2, k1 * x3 + rho,"
                                   " sp.Symbol('y1') + d]", ("input name 'y1' is reserved",)),
    "parameter_named_like_an_observer_state": (
        "parameters={sp.Symbol('xs2'): 2}, dynamics=[x2, sp.Symbol('xs2') * x3 + rho, u + d]",
        ("parameter name 'xs2' is reserved",)),
    "dynamics_matrix_entry": ("dynamics=[sp.Matrix([x2]), k1 * x3 + rho, u + d]",
                              ("dynamics[1]", "not a scalar expression")),
}


@pytest.mark.parametrize("cid", list(MODEL_CASES))
def test_model_file(work, capsys, cid):
    override, needles = MODEL_CASES[cid]
    path = work / f"{cid}.py"
    path.write_text(HEADER + f"model = PlantModel(**{{**BASE, **dict({override})}})\n")
    for argv in (["show", path], uio()[:1] + [path] + uio()[2:]):
        rc, out, err = run(capsys, argv)
        check(rc, out, err, 2, str(path), *needles, work=work)


def test_symbol_named_like_an_observer_column_is_refused_before_writing(work, capsys):
    """A state named d_hat would share its CSV column with the estimate of fault d (the
    audit found the state's column showing the estimate): refused, one line, --out
    untouched."""
    path = work / "dhat.py"
    path.write_text(HEADER.replace('x1, x2, x3 = sp.symbols("x1 x2 x3")',
                                   'x1, x2, x3 = sp.symbols("x1 x2 d_hat")')
                    + "model = PlantModel(**BASE)\n")
    sc = _write_scenario(work, '{"steps": 5}')
    rc, out, err = run(capsys, ["simulate", path, "--observer", "unknown-input", "--fault", "d",
                                "--scenario", sc, "--out", work / "out"])
    check(rc, out, err, 2, "column name 'd_hat'", "rename the model's symbol", work=work)
    assert snapshot(work / "out") == {"keep.txt": b"user data\n"}


def test_write_failure_leaves_out_as_it_was(work, capsys, monkeypatch):
    """A full disk while the figures are written (after the CSV): one line naming the file
    system's complaint, exit 2 — not "internal error" — and the existing --out exactly as
    it was (the CSV went to a staging folder that is removed); a new --out is removed."""
    import errno
    import observer_cad.reporting as reporting

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", "figure.png")

    monkeypatch.setattr(reporting, "plot_simulation", full)
    sc = _write_scenario(work, '{"steps": 5}')
    for out in (work / "out", work / "new"):
        rc, stdout, err = run(capsys, ["simulate", DRIVE, "--observer", "unknown-input",
                                       "--fault", "d", "--scenario", sc, "--out", out])
        check(rc, stdout, err, 2, "figure.png", "No space left on device", work=work)
    assert snapshot(work / "out") == {"keep.txt": b"user data\n"}
    assert not (work / "new").exists()


def test_a_directory_in_the_way_changes_nothing(work, capsys):
    """A directory where simulate's CSV (or codegen's header) goes: one line naming it,
    and nothing in --out replaced (the audit saw the figures replaced before the CSV
    failed, and a hidden staging path in the message)."""
    out = work / "sim"
    (out / "signals.csv").mkdir(parents=True)
    (out / "d_error.png").write_bytes(b"old figure")
    before = snapshot(out)
    sc = _write_scenario(work, '{"steps": 5}')
    rc, stdout, err = run(capsys, ["simulate", DRIVE, "--observer", "unknown-input", "--fault",
                                   "d", "--scenario", sc, "--out", out])
    check(rc, stdout, err, 2, str(out / "signals.csv"), "a directory is in the way", work=work)
    assert ".staging" not in err and snapshot(out) == before
    cg = work / "cg"
    (cg / "obs.h").mkdir(parents=True)
    (cg / "obs.c").write_text("old\n")
    before = snapshot(cg)
    rc, stdout, err = run(capsys, ["codegen", DRIVE, "--observer", "unknown-input", "--fault",
                                   "d", "--name", "obs", "--out", cg])
    check(rc, stdout, err, 2, str(cg / "obs.h"), work=work)
    assert snapshot(cg) == before


def test_a_failing_simulate_keeps_what_another_wrote_into_its_new_out(work, capsys, monkeypatch):
    """A new --out that a failing run created is removed only if still empty: another
    process's results written there meanwhile stay (the audit lost them)."""
    import errno
    import observer_cad.reporting as reporting

    def other_process_then_full(res, stage, **kwargs):
        (work / "new" / "theirs.csv").write_text("their results\n")
        raise OSError(errno.ENOSPC, "No space left on device", "figure.png")

    monkeypatch.setattr(reporting, "plot_simulation", other_process_then_full)
    sc = _write_scenario(work, '{"steps": 5}')
    rc, stdout, err = run(capsys, ["simulate", DRIVE, "--observer", "unknown-input", "--fault",
                                   "d", "--scenario", sc, "--out", work / "new"])
    check(rc, stdout, err, 2, "No space left on device", work=work)
    assert snapshot(work / "new") == {"theirs.csv": b"their results\n"}


def test_base_model_of_the_corpus_is_valid(work, capsys):
    path = work / "base.py"
    path.write_text(HEADER + "model = PlantModel(**BASE)\n")
    assert main(["show", str(path)]) == 0
    assert main(["design", str(path), "--observer", "unknown-input", "--fault", "d"]) == 0


# ----------------------------------------------------------------------------- design JSON
def test_design_json_is_read_without_evaluation(tmp_path):
    from observer_cad.errors import UsageError
    from observer_cad.reporting import matrices_from_json
    data = {"matrices": {"Phi": [[PAYLOAD, "1"]]}}
    with pytest.raises(UsageError, match="design JSON: matrix Phi"):
        matrices_from_json(data)
    assert not Path("PWNED").exists()


DESIGN_FILES = {
    "payload": (json.dumps({"matrices": {"Phi": [[PAYLOAD]]}}).encode(), "matrix Phi"),
    "dunder": (json.dumps({"matrices": {"Phi": [["k1.__class__"]]}}).encode(), "attribute"),
    "not_utf8": (b"\xff\xfe\x00{", "cannot read"),
    "not_json": (b"{", "not valid JSON"),
    "no_matrices": (b"{}", "not a design"),
    "matrices_not_object": (b'{"matrices": [1]}', "not a design"),
    "ragged_rows": (b'{"matrices": {"Phi": [["1"], ["1", "2"]]}}', "equal-length rows"),
    "row_not_list": (b'{"matrices": {"Phi": ["1"]}}', "equal-length rows"),
    "deep": (b"[" * 100000 + b"]" * 100000, "design"),
}


@pytest.mark.parametrize("cid", list(DESIGN_FILES))
def test_design_json_file(work, cid):
    from observer_cad.errors import UsageError
    from observer_cad.reporting import matrices_from_json, read_design_json
    raw, needle = DESIGN_FILES[cid]
    p = work / "design.json"
    p.write_bytes(raw)
    with pytest.raises(UsageError) as info:
        matrices_from_json(read_design_json(p))
    assert needle in str(info.value) and "\n" not in str(info.value)
    assert not (work / "PWNED").exists()


# ----------------------------------------------------------------------------- cache faults
casadi = pytest.importorskip("casadi") if shutil.which(os.environ.get("CC") or "cc") else None

CACHE_FAULTS = ["truncated", "garbage", "foreign_library", "missing_checksum",
                "wrong_checksum", "group_writable", "world_writable_dir", "uncreatable_dir",
                "dir_is_a_file", "entry_is_a_directory", "entry_is_a_symlink", "ref_garbage",
                "ref_points_outside"]


def _tiny(k=2.0, name="ocad_corpus"):
    x = casadi.SX.sym("x", 2)
    return casadi.Function(name, [x], [k * x + 1], ["x"], ["y"])


@pytest.mark.skipif(casadi is None, reason="no C compiler or casadi")
@pytest.mark.parametrize("fault", CACHE_FAULTS)
def test_cache_fault(tmp_path, capsys, fault):
    """Nothing on disk crashes the process or is loaded unverified: the result is
    right, at most one warning line, never an error."""
    from observer_cad.codegen import compile_function, verify_library
    ident = ("corpus", fault)
    build = lambda: _tiny()  # noqa: E731
    good = compile_function(build, name="ocad_corpus", identity=ident, cache=tmp_path / "good")
    cache = tmp_path / "cache"
    shutil.copytree(tmp_path / "good", cache)
    lib = cache / good.path.name
    ref = next(cache.glob("*.ref"))
    if fault == "truncated":
        lib.write_bytes(lib.read_bytes()[:1000])
    elif fault == "garbage":
        lib.write_bytes(b"\x7fELF\x02\x01\x01" + b"\xff" * 5000)
    elif fault == "foreign_library":
        other = compile_function(_tiny(7.0), cache=tmp_path / "other")
        lib.write_bytes(other.path.read_bytes())
    elif fault == "missing_checksum":
        lib.with_name(lib.name + ".sha256").unlink()
    elif fault == "wrong_checksum":
        lib.with_name(lib.name + ".sha256").write_text("0" * 64 + "  " + lib.name + "\n")
    elif fault == "group_writable":
        os.chmod(lib, 0o664)
    elif fault == "world_writable_dir":
        os.chmod(cache, 0o777)
    elif fault == "uncreatable_dir":
        cache = tmp_path / "good" / good.path.name / "sub"  # below a file
    elif fault == "dir_is_a_file":
        shutil.rmtree(cache)
        cache.write_text("not a directory")
    elif fault == "entry_is_a_directory":
        lib.unlink()
        lib.mkdir()
    elif fault == "entry_is_a_symlink":
        lib.unlink()
        lib.symlink_to(good.path)
    elif fault == "ref_garbage":
        ref.write_bytes(b"\x00\xff{{{")
    elif fault == "ref_points_outside":
        ref.write_text(json.dumps({**json.loads(ref.read_text()), "library": "../x.so"}))
    capsys.readouterr()
    c = compile_function(build, name="ocad_corpus", identity=ident, cache=cache)
    assert [float(v) for v in c.function(casadi.DM([1, 2])).full().ravel()] == [3.0, 5.0]
    assert verify_library(c.path) is None
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) <= 1, err
    assert all(ln.startswith("observer-cad: warning:") for ln in err.splitlines())


# ----------------------------------------------------------------------------- subprocesses
@pytest.mark.slow
@pytest.mark.parametrize("argv_kind", ["scenario_payload", pytest.param("gain_payload", marks=pytest.mark.slow),
                                       pytest.param("model_nan", marks=pytest.mark.slow), "nonfinite"])
def test_through_a_real_process(work, argv_kind):
    if argv_kind == "scenario_payload":
        sc = _write_scenario(work, json.dumps({"steps": 5, "signals": {"u": PAYLOAD + " * 0"}}))
        argv, status = ["simulate", DRIVE, "--observer", "unknown-input", "--fault", "d",
                        "--scenario", sc, "--out", work / "out"], 2
    elif argv_kind == "gain_payload":
        argv, status = uio("--gain", PAYLOAD), 2
    elif argv_kind == "model_nan":
        path = work / "m.py"
        path.write_text(HEADER + "model = PlantModel(**{**BASE, 'parameters': {k1: sp.nan}})\n")
        argv, status = ["show", path], 2
    else:
        sc = _write_scenario(work, json.dumps({"steps": 9, "signals": {"u": "1/(t-5)"}}))
        argv, status = ["simulate", DRIVE, "--observer", "unknown-input", "--fault", "d",
                        "--scenario", sc, "--out", work / "out"], 4
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "observer_cad.cli", *map(str, argv)],
                       capture_output=True, text=True, cwd=work, env=env, timeout=120)
    check(r.returncode, r.stdout, r.stderr, status, work=work)


def test_corpus_has_at_least_100_cases():
    n = (len(SCENARIOS) + len(NONFINITE) + len(CLI_VALUES) + len(MODEL_CASES)
         + len(DESIGN_FILES) + len(CACHE_FAULTS) + 4)
    assert n >= 100, n


@pytest.mark.skipif(casadi is None, reason="no C compiler or casadi")
def test_compiled_simulator_reports_the_same_first_nonfinite_value(tmp_path, monkeypatch):
    from observer_cad import build_observer, design, load_model
    from observer_cad.codegen import CompiledSimulator
    from observer_cad.errors import NonFiniteError
    from observer_cad.simulation import scenario_from_dict, simulate
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    m = load_model(TANK)
    ob = build_observer(m, design(m, observer="virtual-sensor", estimate="x1"))
    sc = scenario_from_dict({"t_end": 1, "dt": 0.01, "initial": {"x1": 0, "x2": 1, "x3": 2}},
                            source="sc.json")
    with pytest.raises(NonFiniteError) as ref:
        simulate(m, ob, sc)
    with pytest.raises(NonFiniteError) as comp:
        CompiledSimulator(m, ob).simulate(sc)
    assert str(ref.value) == str(comp.value)
    assert str(ref.value).startswith("sc.json: x1 became nan at t = 0.01")
    kept = CompiledSimulator(m, ob).simulate(sc, keep_nonfinite=True)
    assert kept.nonfinite == str(ref.value)


@pytest.mark.slow  # a subprocess simulating 400,000 steps until it is stopped: ~5 s
@pytest.mark.skipif(sys.platform == "win32", reason="SIGTERM")
def test_sigterm_while_writing_leaves_out_as_it_was(work):
    """SIGTERM (a scheduler stopping a job) while simulate writes: exit 143, the staging
    folder removed, --out as it was (Python's default would end the process on the spot
    and leave the hidden staging folder behind; an audit found it)."""
    import signal
    import time

    sc = _write_scenario(work, '{"steps": 400000}')
    out = work / "out"
    before = snapshot(out)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-m", "observer_cad.cli", "simulate", str(DRIVE),
                          "--observer", "unknown-input", "--fault", "d", "--engine", "reference",
                          "--scenario", str(sc), "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=work)
    for _ in range(1200):  # until the staging folder exists (the results are being written)
        if any(q.name.startswith(".staging-") for q in out.iterdir()) or p.poll() is not None:
            break
        time.sleep(0.05)
    assert p.poll() is None, p.communicate()
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=120)
    assert p.returncode == 143
    assert snapshot(out) == before


@pytest.mark.slow  # the whole demo runs before the obstacle is met: ~15 s
def test_demo_with_an_obstacle_in_out_changes_nothing(work, capsys):
    """demo writes into a staging folder and moves its files into --out at the end: a
    directory where report.md goes is one line, exit 2, and --out exactly as it was (a
    third audit found 51 files written before the error, and a figure's obstacle gave
    exit 1 with the report replaced)."""
    out = work / "out"
    (out / "report.md").mkdir()
    before = snapshot(out)
    rc, stdout, err = run(capsys, ["demo", "--no-compile", "--out", out])
    assert rc == 2 and len(err.splitlines()) == 1, err
    assert str(out / "report.md") in err and "a directory is in the way" in err
    assert snapshot(out) == before and ".staging" not in stdout
