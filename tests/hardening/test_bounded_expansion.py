"""What parsing may grow to is bounded before anything expands it: terms, degree and
digits, for scenario signals, design files and every CLI expression; a decimal below the
smallest normal double is refused instead of becoming a rational of hundreds of digits."""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import pytest
import sympy as sp
from hypothesis import given, settings, strategies as st

from observer_cad.cli import main
from observer_cad.errors import ExpressionError, UsageError
from observer_cad.model import parse_expression
from observer_cad.model._expressions import (MAX_DEGREE, MAX_DIGITS, MAX_EXPANDED_TERMS,
                                             expansion_size)
from observer_cad.synthesis.core import parse_json_expression

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"


def _parse(text):
    return parse_expression(text, any_name=True, where="w")


@pytest.mark.parametrize("text, needle", [
    ("(k1+k2+k3+k4)**1000", "terms"),
    ("(a+b+c+e)**1000", "terms"),
    ("sin((a+b+c)**200)", "terms"),          # inside a function too
    ("(a+b)*(c+d)*(e+f)*(g+h)*(i+j)*(k+l)*(m+n)*(o+p)*(q+r)*(s+u)*(v+w)*(x+y)*(z+a1)*(b1+c1)",
     "terms"),                               # a product of sums: 2^14 terms
    ("(x**1000)**1000", "degree"),           # each exponent allowed, their product not
    ("(a+b)**1000*(a+b)**1000", "degree"),   # sympy combines them into one power
    ("(1e300*a+b)**1000", "digits"),
])
def test_what_would_expand_too_far_is_refused_in_one_line_at_once(text, needle):
    t0 = time.perf_counter()
    with pytest.raises(ExpressionError) as exc:
        _parse(text)
    assert time.perf_counter() - t0 < 5  # (milliseconds in fact; not a timing test)
    msg = str(exc.value)
    assert needle in msg and "\n" not in msg and msg.startswith("w: cannot read")


@pytest.mark.parametrize("text", ["(a+b)**100", "(2/3*a+5/7*b)**1000", "x*(a+b+c)**50*(d+e)**3",
                                  "sin(t)**1000", "(a+b+c)**99"])
def test_what_stays_within_the_limits_is_read(text):
    e = _parse(text)
    terms, degree, digits = expansion_size(e)
    assert terms <= MAX_EXPANDED_TERMS and degree <= MAX_DEGREE and digits <= MAX_DIGITS


@settings(max_examples=25, deadline=None)
@given(st.lists(st.integers(-5, 5).filter(bool), min_size=1, max_size=4),
       st.integers(0, 6), st.integers(1, 3))
def test_the_estimate_bounds_the_expanded_terms(coeffs, n, m):
    """C(m+n−1, n) and its kin are upper bounds of what sympy.expand makes."""
    xs = sp.symbols(f"x0:{len(coeffs)}")
    base = sum(c * x for c, x in zip(coeffs, xs))
    e = sp.Pow(base, n, evaluate=True) * sp.Symbol("y") ** m
    terms, degree, _digits = expansion_size(e)
    expanded = sp.expand(e)
    assert len(sp.Add.make_args(expanded)) <= terms
    assert sp.Poly(expanded, *xs, sp.Symbol("y")).total_degree() <= degree


def test_subnormal_decimals_are_refused_and_small_normal_ones_are_exact():
    with pytest.raises(ExpressionError, match="below the smallest normal"):
        _parse("5e-324")
    with pytest.raises(ExpressionError, match="below the smallest normal"):
        parse_expression("-1e-310*t", {"t": sp.Symbol("t")}, where="w")
    assert _parse("1e-300") == sp.Rational(1, 10 ** 300)
    assert _parse("0.0") == 0


def test_a_design_file_entry_is_bounded():
    """A 58-byte entry of a design file grew past 8 GB when expanded."""
    with pytest.raises(UsageError, match="terms"):
        parse_json_expression("(a+b+c+e)**1000", {}, "design.json: Phi[0][0]")


def test_cli_lambda_is_bounded(capsys):
    rc = main(["design", str(MODELS / "electric_drive.py"), "--observer", "unknown-input",
               "--fault", "d", "--form", "jordan", "--symbolic", "--lambda",
               "(k1+k2+k3+k4)**1000"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.splitlines()) == 1 and "terms" in err, err


def test_a_scenario_signal_is_bounded(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sc = tmp_path / "sc.json"
    sc.write_text(json.dumps({"steps": 10, "signals": {"u": "(t+1+sin(t)+cos(t))**1000"}}))
    (tmp_path / "out").mkdir()
    rc = main(["simulate", str(MODELS / "electric_drive.py"), "--observer", "unknown-input",
               "--fault", "d", "--scenario", str(sc), "--out", str(tmp_path / "out")])
    cap = capsys.readouterr()
    assert rc == 2 and len(cap.err.splitlines()) == 1 and "terms" in cap.err, cap.err
    assert list((tmp_path / "out").iterdir()) == []


def test_limits_are_sane():
    assert math.comb(1003, 1000) > MAX_EXPANDED_TERMS  # the example is over
    assert MAX_DEGREE >= 1000 and MAX_DIGITS >= 20_000
