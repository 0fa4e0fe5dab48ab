"""Exact numbers stay exact: nsimplify never sees an exact number;
floats become the rational their decimal string denotes."""
from __future__ import annotations

import ast
import pathlib

import sympy as sp

import observer_cad
from observer_cad import design, load_model
from observer_cad.numerics import (ALGEBRAIC_DIGITS, algebraic_to_float, rational_approximation,
                                   rationalize_floats)
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


def test_algebraic_to_float_lets_numeric_code_substitute_a_state_named_x():
    """sympy writes a CRootOf's polynomial in x; a model may have a state x. Substituting a
    number for the state rebuilds the root's polynomial (the hazard); on the Float the
    numeric stages use instead, it is an ordinary substitution."""
    import numpy as np
    x, x2 = sp.symbols("x x2")
    root = sp.CRootOf(x**3 + 6 * x**2 + 8 * x + 1, 0)
    e = x + x2 * (root + 1)
    try:  # the hazard, when sympy's root is in the same x as the model (else nothing to guard)
        bad = e.xreplace({x: 2, x2: 3})
    except Exception:
        bad = None
    assert bad is None or root.poly.gen != x
    f = algebraic_to_float(e)
    assert not f.atoms(sp.CRootOf) and f.free_symbols == {x, x2}
    oracle = min(np.roots([1, 6, 8, 1]).real)  # numpy, not sympy
    assert abs(float(f.xreplace({x: 2, x2: 3})) - (2 + 3 * (oracle + 1))) < 1e-12
    flt = algebraic_to_float(root)
    assert isinstance(flt, sp.Float)
    assert abs(flt - root.evalf(ALGEBRAIC_DIGITS + 5)) < sp.Float(10) ** (2 - ALGEBRAIC_DIGITS)
    assert algebraic_to_float(x + sp.sqrt(2)) == x + sp.sqrt(2)  # nothing else is touched
    assert algebraic_to_float(sp.Matrix([[root]]))[0, 0] == flt


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
