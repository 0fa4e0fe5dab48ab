"""Exact numbers stay exact (issue 11 item 7): nsimplify never sees an exact number;
floats become the rational their decimal string denotes."""
from __future__ import annotations

import ast
import pathlib

import sympy as sp

import observer_cad
from observer_cad import design, load_model
from observer_cad.numerics import rational_approximation, rationalize_floats
from observer_cad.observers import interval_observer_nonlinear
from observer_cad.synthesis import place_poles

#: A rational that sympy.nsimplify turns into a product of irrational powers:
#: 2**(20/101)*3**(37/707)*5**(354/707)*7**(611/707)/21.
MANGLED = sp.Rational(313319610133, 450092401851)


def test_the_example_is_one_nsimplify_mangles():
    assert sp.nsimplify(MANGLED) != MANGLED  # the hazard this test file guards against
    assert not sp.nsimplify(MANGLED).is_Rational


def test_rationalize_floats_keeps_exact_numbers():
    assert rationalize_floats(MANGLED) == MANGLED
    assert rationalize_floats(sp.sqrt(2) * MANGLED) == sp.sqrt(2) * MANGLED
    assert rationalize_floats(sp.Matrix([[MANGLED, sp.pi]])) == sp.Matrix([[MANGLED, sp.pi]])


def test_rationalize_floats_reads_the_decimal_string():
    assert rationalize_floats(0.1) == sp.Rational(1, 10)
    assert rationalize_floats(sp.Float("2.5e-3")) == sp.Rational(1, 400)
    assert rationalize_floats(sp.Float(0.5) * sp.sqrt(3)) == sp.sqrt(3) / 2


def test_rational_approximation_states_its_tolerance():
    assert rational_approximation(-0.9999999999999998, 1e-12) == -1
    assert rational_approximation(MANGLED, 1e-3) == MANGLED  # exact: unchanged
    v = rational_approximation(0.123456789, 1e-6)
    assert abs(float(v) - 0.123456789) <= 1e-6


def test_interval_margin_keeps_a_mangled_rational(models_dir):
    """The user's margin k* w* enters the bounds exactly: x̲' gets − margin, x̄' + margin."""
    model = load_model(models_dir / "three_tank.py")
    d = design(model, observer="interval", estimate="x1")
    with_m = interval_observer_nonlinear(model, d, margin=MANGLED)
    without = interval_observer_nonlinear(model, d, margin=0)
    diff = [sp.expand(a - b) for a, b in zip(with_m.update, without.update)]
    assert diff == [-MANGLED, MANGLED]


def test_pole_placement_keeps_a_mangled_eigenvalue():
    Fs = sp.Matrix([[0, 1], [0, 0]])
    Hs = sp.Matrix([[1, 0]])
    K = place_poles(Fs, Hs, [MANGLED, 0])
    # det(sI − F* + K H*) = s² + K1 s + K2 = (s − a)(s − b)
    assert K == sp.Matrix([[-MANGLED], [0]])


def test_no_bare_nsimplify_in_the_package():
    """Every nsimplify call in the package passes rational=True (which converts floats
    only); guessing closed forms (the default) is never applied to the tool's numbers."""
    root = pathlib.Path(observer_cad.__file__).parent
    bad = []
    for f in root.rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "nsimplify":
                kws = {k.arg: k.value for k in node.keywords}
                if not (isinstance(kws.get("rational"), ast.Constant) and kws["rational"].value):
                    bad.append(f"{f.relative_to(root)}:{node.lineno}")
    assert not bad, bad
