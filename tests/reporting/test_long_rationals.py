"""Exact designs of float-based plants can carry rationals of thousands of digits; Python
refuses to print integers of more than 4,300 digits by default. Printing a design, its
JSON and its conditions must not fail on them (before: a bare ValueError from the seed-004
virtual sensor of random_model(12, 4, 2, integer=False))."""
import dataclasses
import json
import sys
import threading
import time

import pytest
import sympy as sp

from observer_cad import CertificateError, UsageError, load_model
from observer_cad.model import random_model
from observer_cad.numerics import full_int_text, readable
from observer_cad.reporting import format_design, format_matrix
from observer_cad.synthesis import Design, design_jordan
from observer_cad.synthesis.core._expr import parse_json_expression

HUGE = sp.Rational(3 * 10 ** 5000 + 7, 10 ** 5000 + 3)  # ≈ 3, 5,000 digits


def test_python_refuses_them_by_default():
    with pytest.raises(ValueError):
        str(HUGE)
    with full_int_text():
        assert len(str(HUGE)) > 9000
    with pytest.raises(ValueError):  # the limit is restored after the block
        str(HUGE)
    assert sys.get_int_max_str_digits() > 0


def test_readable_rounds_only_the_long_ones():
    text = readable(sp.Matrix([[HUGE, sp.Rational(1, 3)], [2, -HUGE]]))
    assert text.count("≈") == 2 and "1/3" in text
    assert text.startswith("[[≈3.000") and "≈-3.000" in text
    assert readable(sp.Rational(5, 7)) == "5/7"  # short rationals stay exact


def test_design_with_a_long_rational_prints_and_serialises(models_dir):
    d = design_jordan(load_model(str(models_dir / "three_tank_linear.py")),
                      observer="virtual-sensor", estimate="x1")
    mats = dict(d.matrices.items())
    mats["F_star"] = mats["F_star"] + sp.Matrix([[HUGE]])
    big = dataclasses.replace(d, matrices=mats)
    text = format_design(big)
    assert "≈" in text  # the matrix entry rounded for reading
    data = json.loads(json.dumps(big.to_json()))
    with full_int_text():  # the JSON keeps the exact value
        assert sp.Rational(data["matrices"]["F_star"][0][0]) == mats["F_star"][0, 0]
    assert "≈" in format_matrix("F*", mats["F_star"])


def test_long_or_irrational_lambdas_are_also_shown_approximately(models_dir):
    """The exact λ line stays; a second line gives every λ to 6 digits when one is long
    (a rational of over 24 characters, a surd, a CRootOf) — not for short rationals, and
    not when a λ is a symbol."""
    d = design_jordan(load_model(str(models_dir / "three_tank_linear.py")),
                      observer="virtual-sensor", estimate="x1")
    assert "λ ≈" not in format_design(d)
    x = sp.Symbol("x")
    lams = (sp.Rational(-10 ** 30 - 7, 10 ** 29), -2 - sp.sqrt(2),
            sp.CRootOf(x ** 3 + 6 * x ** 2 + 8 * x + 1, 0), sp.Rational(-1, 3))
    text = format_design(dataclasses.replace(d, lambdas=lams))
    exact = next(line for line in text.splitlines() if line.startswith("  λ = ("))
    assert str(lams[0]) in exact  # exact, in full
    approx = next(line for line in text.splitlines() if line.startswith("  λ ≈ ("))
    got = [float(v) for v in approx[len("  λ ≈ ("):-1].split(", ")]
    assert got == pytest.approx([float(v) for v in lams], rel=1e-5)
    a = sp.Symbol("a")
    assert "λ ≈" not in format_design(dataclasses.replace(d, lambdas=(-a, HUGE)))
    # floating-point designs: their λ read as they are
    assert "λ ≈" not in format_design(dataclasses.replace(d, lambdas=(sp.Float(-1),
                                                                     sp.Float(-2.5))))


@pytest.mark.slow  # ~10 s: the seed-004 design of a 12-state float-based plant
def test_seed_004_virtual_sensor_of_a_float_plant():
    from observer_cad.synthesis.canonical._virtual import design_virtual_sensor_canonical
    model = random_model(12, 4, 2, seed=0, integer=False)
    d = design_virtual_sensor_canonical(model, estimate="x1", variant="004")
    assert d.certificate.passed
    metz = next(c for c in d.conditions if c.name.startswith("F* − K H*"))
    assert "F* − K H* = [[" in metz.detail
    assert format_design(d)
    data = json.loads(json.dumps(d.to_json()))
    assert max(len(e) for rows in data["matrices"].values() for r in rows for e in r) > 4300
    again = Design.from_json(data, model)  # read back exactly and re-certified
    assert again.certificate.passed and again.matrices.Phi == d.matrices.Phi


def test_two_threads_keep_the_limit_lifted_inside_and_restored_after():
    errors = []

    def hold(delay, work):
        time.sleep(delay)
        with full_int_text():
            time.sleep(work)
            try:
                str(HUGE)
            except ValueError as exc:  # the other thread restored the limit too early
                errors.append(exc)

    threads = [threading.Thread(target=hold, args=a) for a in ((0, 0.1), (0.05, 0.3))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and sys.get_int_max_str_digits() == 4300


def test_long_rational_literals_are_read_from_json():
    with full_int_text():
        text = f"-{HUGE.p}/{HUGE.q}"
    assert parse_json_expression(text, {}, "matrices.Phi") == -HUGE
    with pytest.raises(UsageError, match="division by zero"):
        parse_json_expression("1/0", {}, "matrices.Phi")
    with full_int_text():  # an expression with long coefficients: the whitelist reader
        e = parse_json_expression(f"x*{HUGE.p}/{HUGE.q} + 1", {"x": sp.Symbol("x")},
                                  "equations")
    assert e == sp.Symbol("x") * HUGE + 1
    with pytest.raises(UsageError, match="longer than"):  # beyond the design cap
        parse_json_expression("x + " + "1" * 1_000_001, {"x": sp.Symbol("x")}, "equations")


def test_a_tampered_long_rational_is_a_certificate_error(models_dir):
    model = load_model(str(models_dir / "three_tank_linear.py"))
    d = design_jordan(model, observer="virtual-sensor", estimate="x1")
    data = json.loads(json.dumps(d.to_json()))
    with full_int_text():
        data["matrices"]["F_star"][0][0] = str(HUGE)
    with pytest.raises(CertificateError, match="≈"):  # one line, the residual rounded
        Design.from_json(data, model)
