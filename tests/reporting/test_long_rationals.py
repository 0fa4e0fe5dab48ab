"""Exact designs of float-based plants can carry rationals of thousands of digits; Python
refuses to print integers of more than 4,300 digits by default. Printing a design, its
JSON and its conditions must not fail on them (before: a bare ValueError from the seed-004
virtual sensor of random_model(12, 4, 2, integer=False))."""
import dataclasses
import json
import sys

import pytest
import sympy as sp

from observer_cad import load_model
from observer_cad.model import random_model
from observer_cad.numerics import full_int_text, readable
from observer_cad.reporting import format_design, format_matrix
from observer_cad.synthesis import design_jordan

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


@pytest.mark.slow  # ~10 s: the seed-004 design of a 12-state float-based plant
def test_seed_004_virtual_sensor_of_a_float_plant():
    from observer_cad.synthesis._virtual import design_virtual_sensor_canonical
    d = design_virtual_sensor_canonical(random_model(12, 4, 2, seed=0, integer=False),
                                        estimate="x1", variant="004")
    assert d.certificate.passed
    metz = next(c for c in d.conditions if c.name.startswith("F* − K H*"))
    assert "F* − K H* = [[" in metz.detail
    assert format_design(d) and json.dumps(d.to_json())
