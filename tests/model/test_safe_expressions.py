"""The safe expression reader: text from data or the command line is
parsed by a whitelist grammar on Python's ast, never evaluated.

Checked here: what the papers' scenarios and the CLI documentation write still reads
(and means what sympy's own parser made of it — compared independently, on trusted
text only), what must be refused is refused with one line naming the place, and a
payload is never executed.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad.errors import ExpressionError, UsageError
from observer_cad.model import FUNCTIONS, MAX_EXPONENT, MAX_LENGTH, parse_expression, parse_number
from observer_cad.simulation import load_scenario

ROOT = Path(__file__).resolve().parents[2]
t, x1, x2 = sp.symbols("t x1 x2")
T = {"t": t}


def _texts(spec):
    if spec == "declared":  # a keyword (uniform over the model's bounds), not an expression
        return
    if isinstance(spec, str):
        yield spec, False
    elif isinstance(spec, dict) and "piecewise" in spec:
        for value, cond in spec["piecewise"]:
            yield from _texts(value)
            if isinstance(cond, str):
                yield cond, True


SCENARIO_TEXTS = sorted({(text, cond) for f in (ROOT / "models" / "scenarios").glob("*.json")
                         for spec in json.loads(f.read_text()).get("signals", {}).values()
                         for text, cond in _texts(spec)})


def test_every_shipped_scenario_loads():
    files = sorted((ROOT / "models" / "scenarios").glob("*.json"))
    assert len(files) >= 10
    for f in files:
        load_scenario(f)


@pytest.mark.parametrize("text,cond", SCENARIO_TEXTS)
def test_scenario_texts_mean_what_sympy_made_of_them(text, cond):
    """The oracle is sympy's own parser, run here on the project's trusted files only."""
    ours = parse_expression(text, T, where="test", condition=cond)
    theirs = sp.sympify(text, locals=T)
    grid = np.linspace(0, 60, 241)
    a = np.asarray(sp.lambdify(t, ours, "numpy")(grid), dtype=float if not cond else bool)
    b = np.asarray(sp.lambdify(t, theirs, "numpy")(grid), dtype=float if not cond else bool)
    np.testing.assert_allclose(np.broadcast_to(a, grid.shape), np.broadcast_to(b, grid.shape),
                               rtol=1e-15, atol=0)


@pytest.mark.parametrize("text,expected", [
    ("0.2*sin(t/10)", sp.sin(t / 10) / 5),
    ("1e-3", sp.Rational(1, 1000)),
    ("-1/2", sp.Rational(-1, 2)),
    ("2^3", sp.Integer(8)),
    ("1_000", sp.Integer(1000)),
    ("Abs(t) + abs(-t)", 2 * sp.Abs(t)),
    ("Min(t, 1) + Max(t, 2)", sp.Min(t, 1) + sp.Max(t, 2)),
    ("Heaviside(t - 1)", sp.Heaviside(t - 1)),
    ("sqrt(2)*pi*E", sp.sqrt(2) * sp.pi * sp.E),
    ("exp(-t)*log(1 + t)", sp.exp(-t) * sp.log(1 + t)),
    ("atan2(t, 1) + sign(t) + floor(t) + ceiling(t)",
     sp.atan2(t, 1) + sp.sign(t) + sp.floor(t) + sp.ceiling(t)),
    ("Piecewise((0, t < 5), (1, True))", sp.Piecewise((0, t < 5), (1, True))),
    ("Piecewise((0, (t > 1) & (t < 2)), (1, t >= 2), (2, True))",
     sp.Piecewise((0, (t > 1) & (t < 2)), (1, t >= 2), (2, True))),
])
def test_accepted(text, expected):
    assert sp.simplify(parse_expression(text, T, where="test") - expected) == 0


def test_conditions():
    c = parse_expression("0 < t <= 5 and not t == 3 or t > 10", T, where="c", condition=True)
    assert c.subs(t, 1) is sp.true and c.subs(t, 3) is sp.false and c.subs(t, 11) is sp.true


def test_decimals_are_exact_unless_asked():
    assert parse_expression("0.1", where="x") == sp.Rational(1, 10)
    f = parse_expression("0.1", where="x", exact_floats=False)
    assert isinstance(f, sp.Float) and float(f) == 0.1


def test_complex_only_where_allowed():
    assert parse_number("-1+2*I", where="--eigenvalues", allow_complex=True) == -1 + 2 * sp.I
    with pytest.raises(ExpressionError, match="imaginary unit"):
        parse_number("-1+2*I", where="--gain")


@pytest.mark.parametrize("text", ["sqrt(-1)", "log(-1)", "(-8)**(1/3)", "(-1)**(1/2)",
                                  "asin(2)", "2*x1 + sqrt(-3)", "acos(0) + log(-2)"])
def test_complex_values_are_refused_where_i_is(text):
    """Functions and powers that evaluate to a non-real number (sqrt(-1) is I) are refused
    where I is: a plant, a scenario or an estimate cannot use them (an audit found
    sqrt(-1)*x1 certified as an estimate, and a complex scenario signal crashing the
    simulator). Where complex values are allowed they are read."""
    x1 = sp.Symbol("x1")
    with pytest.raises(ExpressionError, match="not a real number"):
        parse_expression(text, {"x1": x1}, where="--estimate")
    value = parse_expression(text, {"x1": x1}, where="--eigenvalues", allow_complex=True)
    assert value.subs(x1, 1).is_extended_real is False
    # real values of the same functions stay exact
    assert parse_expression("sqrt(2) + log(2) + (-8)**2 + acos(1/2) + sqrt(x1)", {"x1": x1},
                            where="w") == sp.sqrt(2) + sp.log(2) + 64 + sp.pi / 3 + sp.sqrt(x1)


def test_any_name_reads_every_identifier_as_a_symbol():
    e = parse_expression("gamma*S + k1/k4", where="json", any_name=True)
    assert {s.name for s in e.free_symbols} == {"gamma", "S", "k1", "k4"}
    with pytest.raises(ExpressionError):
        parse_expression("__class__", where="json", any_name=True)


REJECTED = {
    "attribute": ("t.real", "attribute"),
    "dunder_chain": ("().__class__.__bases__[0].__subclasses__()", "attribute"),
    "import": ("__import__('os').system('touch PWNED')", "attribute"),
    "import_call": ("__import__('os')", "'__import__'"),
    "eval": ("eval('1')", "'eval'"),
    "getattr": ("getattr(t, 'x')", "'getattr'"),
    "subscript": ("t[0]", "subscript"),
    "lambda": ("lambda: 1", "lambda"),
    "string": ("'abc'", "string"),
    "bytes": ("b'abc'", "string"),
    "list_comp": ("[i for i in (1, 2)]", "comprehension"),
    "generator": ("sum(i for i in (1, 2))", "'sum'"),
    "walrus": ("(a := 1)", "assignment"),
    "if_expression": ("1 if t else 2", "if-expression"),
    "fstring": ("f'{t}'", "f-string"),
    "keyword": ("sin(x=t)", "keyword"),
    "starred": ("Max(*t)", "starred"),
    "floordiv": ("t // 2", "'//'"),
    "modulo": ("t % 2", "'%'"),
    "matmul": ("t @ t", "'@'"),
    "unknown_name": ("z", "unknown name 'z'"),
    "nan": ("nan", "unknown name 'nan'"),
    "oo": ("oo", "unknown name 'oo'"),
    "function_without_call": ("sin", "without arguments"),
    "wrong_arity": ("sin(t, t)", "argument"),
    "huge_exponent": ("10**10**10", "exponent"),
    "huge_power_result": ("10**400", "floating-point range"),
    "huge_literal": ("1" + "0" * 400, "floating-point range"),
    "huge_float": ("1e400", "floating-point range"),
    "tiny_float": ("1e-400", "floating-point range"),
    "product_out_of_range": ("1e300*1e300", "floating-point range"),
    "division_by_zero": ("1/0", "division by zero"),
    "zero_negative_power": ("0**-1", "division by zero"),
    "complex_literal": ("2j", "complex literal"),
    "condition_as_value": ("t < 1", "condition"),
    "bool_as_value": ("True", "number"),
    "none": ("None", "number"),
    "ellipsis": ("...", "number"),
    "tuple": ("1, 2", "one expression"),
    "list": ("[1, 2]", "one expression"),
    "dict": ("{1: 2}", "dict"),
    "empty": ("", "empty"),
    "blank": ("   ", "empty"),
    "syntax": ("1 +", "not a valid expression"),
    "statement": ("import os", "not a valid expression"),
    "two_statements": ("1; 2", "not a valid expression"),
    "nul": ("1\x00", "NUL"),
    "too_long": ("t+" * MAX_LENGTH + "t", "longer than"),
    "deep": ("-" * 500 + "t", "too deeply nested"),
    "piecewise_not_pairs": ("Piecewise(1, 2)", "pairs"),
    "piecewise_value_condition": ("Piecewise((1, 2))", "condition"),
    "piecewise_payload": ("Piecewise((1, __import__('os') > 0))", "'__import__'"),
    "call_of_a_name": ("(t)(1)", "call of 't'"),
}


@pytest.mark.parametrize("cid", list(REJECTED))
def test_rejected(cid, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    text, needle = REJECTED[cid]
    with pytest.raises(ExpressionError) as info:
        parse_expression(text, T, where="sc.json: signal 'u'")
    msg = str(info.value)
    assert isinstance(info.value, UsageError)
    assert msg.startswith("sc.json: signal 'u': cannot read ") and "\n" not in msg, msg
    assert needle in msg, (needle, msg)
    assert len(msg) < 400
    assert not (tmp_path / "PWNED").exists()


def test_rejected_conditions():
    for text in ("t", "1", "t + 1", "sin(t)"):
        with pytest.raises(ExpressionError, match="condition"):
            parse_expression(text, T, where="c", condition=True)


def test_parse_number():
    assert parse_number("0.25", where="x") == sp.Rational(1, 4)
    assert parse_number(2, where="x") == 2
    assert parse_number(sp.sqrt(2), where="x") == sp.sqrt(2)
    for bad, needle in (("t", "unknown name"), ("exp(1000)", "not a finite number"),
                        (float("nan"), "not finite"), (True, "not a number"),
                        (sp.I, "not real"), (sp.oo, "not a finite number")):
        with pytest.raises(ExpressionError, match=needle):
            parse_number(bad, where="x")


def test_limits_are_documented_constants():
    assert MAX_LENGTH >= 1000 and MAX_EXPONENT >= 100
    assert {"sin", "cos", "exp", "log", "sqrt", "Abs", "Heaviside", "Min", "Max"} <= set(FUNCTIONS)


def test_no_sympify_or_eval_on_user_text_in_the_package():
    """Every ``sympify(`` left in the package applies to sympy objects, not text: the
    calls that read user text are gone (a grep-level guard against their return)."""
    import re
    pkg = ROOT / "observer_cad"
    bad = []
    for f in pkg.rglob("*.py"):
        src = f.read_text()
        for m in re.finditer(r"(sympify\([^)]*locals=|parse_expr\(|\beval\(|\bexec\()", src):
            bad.append(f"{f.relative_to(pkg)}: {m.group(0)}")
    assert not bad, bad


def test_a_lambda_may_name_a_parameter_of_a_symbolic_design(capsys):
    """--lambda reads the model's parameter names as its symbols (not their values)."""
    from observer_cad.cli import main
    rc = main(["design", str(ROOT / "models" / "electric_drive.py"), "--observer", "diagnostic",
               "--fault", "d", "--symbolic", "--lambda", "k2"])
    out = capsys.readouterr().out
    assert rc == 0 and "λ = (k2)" in out and "F_star = [ k2 ]" in out, out


# ----------------------------------------------------------------------------- CRootOf
# An irrational Jordan λ of degree ≥ 3 is a sympy CRootOf; a design's JSON and --lambda
# read it back (allow_crootof=True), nowhere else. The oracle for the value is numpy's
# companion-matrix eigenvalues, not sympy.
def _real_roots_np(coeffs):
    """The real roots of the polynomial with these coefficients (highest first), ascending,
    from numpy's companion-matrix eigenvalues (an oracle independent of sympy)."""
    r = np.roots(np.asarray(coeffs, dtype=float))
    return np.sort(r[np.abs(r.imag) < 1e-6].real)  # a double root splits by ~1e-8


def _crootof(text, names=None):
    return parse_expression(text, names, where="design.json: lambdas", allow_crootof=True,
                            any_name=True)


@pytest.mark.parametrize("text,coeffs,k", [
    ("CRootOf(x**3 - 3*x + 1, 0)", [1, 0, -3, 1], 0),                # as sympy prints it
    ("CRootOf(x**3 - 3*x + 1, 2)", [1, 0, -3, 1], 2),
    ("CRootOf(x**3 - 3*x + 1, -1)", [1, 0, -3, 1], 2),               # counted from the end
    ("CRootOf(lambda**3 + 6*lambda**2 + 8*lambda + 1, 1)", [1, 6, 8, 1], 1),  # sympy's λ
    ("CRootOf(x**3/2 - 3*x/2 + 1/2, 1)", [1, 0, -3, 1], 1),          # rational coefficients
    ("CRootOf(s**3 - 3*s + 1, 0)", [1, 0, -3, 1], 0),                # any one name
    ("CRootOf((x - 1)**2*(x**3 - 3*x + 1), 3)", [1, -2, -2, 7, -5, 1], 3),  # double root 1
    ("CRootOf(x**5 - x + 1, 0)", [1, 0, 0, 0, -1, 1], 0),            # one real root of five
])
def test_crootof_accepted(text, coeffs, k):
    v = _crootof(text)
    assert v.is_real and not v.free_symbols
    roots = _real_roots_np(coeffs)
    assert abs(float(v) - roots[k]) <= 1e-9 * (1 + abs(roots[k]))


def test_crootof_is_exact_and_the_same_number_as_sympys():
    X = sp.Symbol("x")
    r = sp.CRootOf(X**3 - 3 * X + 1, 1)
    assert _crootof("CRootOf(x**3 - 3*x + 1, 1)") == r
    assert _crootof("CRootOf(x**3 - 3*x + 1, 1)") != sp.CRootOf(X**3 - 3 * X + 1, 2)
    # arithmetic around it is read as usual
    e = _crootof("2*CRootOf(x**3 - 3*x + 1, 1)**2 - 1/3")
    assert e == 2 * r**2 - sp.Rational(1, 3)


def test_crootof_variable_is_bound_not_the_models_name():
    """The polynomial's variable is not looked up: a state called x (here with
    assumptions, so that it is a different Symbol from sympy's x) stays the state outside
    CRootOf, and the root is the same number with or without it."""
    x_state = sp.Symbol("x", real=True)
    e = _crootof("x + CRootOf(x**3 - 3*x + 1, 0)", {"x": x_state})
    assert e.free_symbols == {x_state}
    root = e - x_state
    assert isinstance(root, sp.CRootOf) and root == _crootof("CRootOf(y**3 - 3*y + 1, 0)")
    assert not root.expr.has(x_state)  # the polynomial is not in the state
    # substituting a number for the state leaves the root alone
    assert abs(float(e.subs(x_state, 1)) - (1 + _real_roots_np([1, 0, -3, 1])[0])) < 1e-12


def test_crootof_round_trip_of_sympys_own_roots():
    """str(root) read back is the root, for the real roots sympy gives of seeded random
    integer polynomials of degree 3 to 6 (CRootOf, and rationals where a factor is linear)."""
    import random
    rng = random.Random(20261123)
    X = sp.Symbol("x")
    seen = 0
    for _ in range(12):
        deg = rng.randint(3, 6)
        p = sum(rng.randint(-9, 9) * X**i for i in range(deg)) + X**deg
        for r in sp.Poly(p, X).real_roots():
            assert _crootof(str(r)) == r, str(r)
            seen += isinstance(r, sp.CRootOf)
    assert seen >= 10


CROOTOF_REJECTED = {
    "not_polynomial_function": ("CRootOf(sin(x), 0)", "call of 'sin' in CRootOf's polynomial"),
    "not_polynomial_division": ("CRootOf(1/x + 1, 0)", "division by the variable"),
    "not_polynomial_negative_power": ("CRootOf(x**-1 + 1, 0)", "exponent -1"),
    "not_polynomial_symbolic_power": ("CRootOf(2**x - 3, 0)", "exponent x"),
    "not_polynomial_sqrt": ("CRootOf(sqrt(x) - 2, 0)", "call of 'sqrt'"),
    "two_variables": ("CRootOf(x**3 - 3*x*y + 1, 0)", "two variables"),
    "float_coefficient": ("CRootOf(x**3 - 0.5*x + 1, 0)", "decimal coefficient 0.5"),
    "irrational_coefficient": ("CRootOf(pi*x**3 - 1, 0)", "'pi' in CRootOf's polynomial"),
    "imaginary_coefficient": ("CRootOf(x**3 + I, 0)", "'I' in CRootOf's polynomial"),
    "index_too_high": ("CRootOf(x**3 - 3*x + 1, 3)", "index 3 is out of range for degree 3"),
    "index_too_low": ("CRootOf(x**3 - 3*x + 1, -4)", "index -4 is out of range for degree 3"),
    "index_not_literal": ("CRootOf(x**3 - 3*x + 1, 1 + 1)", "integer literal"),
    "index_float": ("CRootOf(x**3 - 3*x + 1, 1.0)", "integer literal"),
    "index_bool": ("CRootOf(x**3 - 3*x + 1, True)", "integer literal"),
    "complex_root": ("CRootOf(x**5 - x + 1, 1)", "complex root"),
    "no_real_root": ("CRootOf(x**2 + 1, 0)", "it has no real root"),
    "degree_too_high": (f"CRootOf(x**{33} + x + 1, 0)", "degree above 32"),
    "degree_too_high_product": ("CRootOf((x**8 + 1)**4*x + 1, 0)", "degree above 32"),
    "constant": ("CRootOf(3, 0)", "no variable"),
    "degree_zero": ("CRootOf(x - x + 1, 0)", "degree 0"),
    "nested": ("CRootOf(CRootOf(x**3 - 3*x + 1, 0)*x + 1, 0)", "nested CRootOf"),
    "nested_in_index": ("CRootOf(x**3 - 3*x + 1, CRootOf(x - 1, 0))", "integer literal"),
    "one_argument": ("CRootOf(x**3 - 3*x + 1)", "takes (polynomial, index), got 1"),
    "three_arguments": ("CRootOf(x**3 - 3*x + 1, x, 0)", "takes (polynomial, index), got 3"),
    "keyword": ("CRootOf(x**3 - 3*x + 1, index=0)", "keyword arguments"),
    "bare_name": ("CRootOf", "without arguments"),
    "dunder_variable": ("CRootOf(__x**2 - 2, 0)", "names starting with '_'"),
    "payload": ("CRootOf(__import__('os').system('touch PWNED'), 0)", "in CRootOf's polynomial"),
    "attribute": ("CRootOf(x.real, 0)", "attribute access"),
    "division_by_zero": ("CRootOf(x**2/0 - 1, 0)", "division by zero"),
}


@pytest.mark.parametrize("cid", list(CROOTOF_REJECTED))
def test_crootof_rejected(cid, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    text, needle = CROOTOF_REJECTED[cid]
    with pytest.raises(ExpressionError) as info:
        _crootof(text)
    msg = str(info.value)
    assert msg.startswith("design.json: lambdas: cannot read ") and "\n" not in msg, msg
    assert needle in msg, (needle, msg)
    assert not (tmp_path / "PWNED").exists()


@pytest.mark.parametrize("call", [
    lambda: parse_expression("CRootOf(x**3 - 3*x + 1, 0)", T, where="signal 'u'"),
    lambda: parse_expression("CRootOf(x**3 - 3*x + 1, 0)", where="json", any_name=True),
    lambda: parse_number("CRootOf(x**3 - 3*x + 1, 0)", where="--eigenvalues",
                         allow_complex=True),
])
def test_crootof_only_where_allowed(call):
    with pytest.raises(ExpressionError, match="CRootOf .*is not allowed here"):
        call()


def test_crootof_limits():
    from observer_cad.model import MAX_CROOTOF_DEGREE
    from observer_cad.synthesis import FLOAT_AUTO_N
    # every λ of an exact design fits: its degree is at most the state dimension, and the
    # exact path is the default up to FLOAT_AUTO_N states
    assert MAX_CROOTOF_DEGREE >= FLOAT_AUTO_N
    ok = _crootof(f"CRootOf(x**{MAX_CROOTOF_DEGREE} - 2, 0)")
    assert abs(float(ok) + 2 ** (1 / MAX_CROOTOF_DEGREE)) < 1e-12
    with pytest.raises(ExpressionError, match=f"degree above {MAX_CROOTOF_DEGREE}"):
        _crootof(f"CRootOf(x**{MAX_CROOTOF_DEGREE + 1} - 2, 0)")


def test_keyword_lambda_is_a_name_only_where_crootof_is_read():
    """sympy prints λ as `lambda`, a Python keyword: read as a name where CRootOf is
    allowed (then `lambda` outside CRootOf is the symbol lambda), a lambda elsewhere."""
    e = _crootof("lambda*2 + CRootOf(lambda**3 - 3*lambda + 1, 0)")
    assert {s.name for s in e.free_symbols} == {"lambda"}
    for text in ("lambda: 1", "(lambda: 1)()"):
        with pytest.raises(ExpressionError):
            _crootof(text)
    with pytest.raises(ExpressionError, match="not a valid expression"):
        parse_expression("CRootOf(lambda**3 - 3*lambda + 1, 0)", where="x")


@pytest.mark.parametrize("text", ["CRootOf(x**16 - 2*(256*x - 1)**2, 0)",
                                  "CRootOf(x**12 - 2*(16*x - 1)**2, 1)"])
def test_crootof_nearly_coincident_roots_refused_quickly(text):
    """Roots 3e-22 / 5e-9 apart: sympy's exact isolation would take minutes (or 12 s);
    refused from FLINT's root enclosures instead, naming the reason."""
    with pytest.raises(ExpressionError, match="two roots closer than"):
        parse_expression(text, [], where="design.json", allow_crootof=True)


def test_crootof_well_separated_roots_still_read():
    r = parse_expression("CRootOf(x**12 - 2*(4*x - 1)**2, 1)", [], where="t", allow_crootof=True)
    assert isinstance(r, sp.CRootOf)
    assert abs(float(r.evalf(30)) ** 12 - 2 * (4 * float(r.evalf(30)) - 1) ** 2) < 1e-9


@pytest.mark.parametrize("degree,index", [(20, 0), (32, 0), (20, 1), (9, 1)])
def test_crootof_near_a_rational_is_narrowed_on_reading(degree, index):
    """A root very close to a simple rational (x^d − 3x + 1 has one ≈ 1/3 + 3^−(d+1)):
    sympy's continued-fraction refinement needs exponentially many steps for it (degree
    20: the design command never finished, an audit found). Reading narrows sympy's cached
    isolating interval by exact bisection, so evaluating it is immediate. Checked: the
    interval is narrow, still brackets a sign change, and the value agrees with mpmath's
    polyroots at 60 digits."""
    import mpmath

    x = sp.Symbol("x")
    text = f"CRootOf(x**{degree} - 3*x + 1, {index})"
    r = parse_expression(text, [], where="--lambda", allow_crootof=True)
    assert isinstance(r, sp.CRootOf)
    iv = r._get_interval()  # (sympy's cache, shared by every CRootOf of this polynomial)
    a, b = sp.Rational(iv.a), sp.Rational(iv.b)
    f = x**degree - 3 * x + 1
    assert 0 < b - a < sp.Rational(1, 2**250) and f.subs(x, a) * f.subs(x, b) < 0
    with mpmath.workdps(60):
        real = sorted(z.real for z in mpmath.polyroots([1] + [0] * (degree - 2) + [-3, 1],
                                                       maxsteps=400, extraprec=400)
                      if abs(z.imag) < mpmath.mpf(10) ** -40)
        assert abs(mpmath.mpf(str(sp.N(r, 60))) - real[index]) < mpmath.mpf(10) ** -55


_T = sp.Symbol("t")


@pytest.mark.parametrize("text,expected", [("t^2 + 1", _T**2 + 1), ("2*t^2", 2 * _T**2),
                                           ("-t^2", -_T**2), ("(t + 1)^2/2", (_T + 1)**2 / 2),
                                           ("t^2^2", _T**4)])
def test_caret_is_power_with_powers_precedence(text, expected):
    """^ is ** (as sympy's parser reads it) with **'s precedence: Python's own ^ binds
    more loosely than + and *, so t^2 + 1 once read as t³ and 2*t^2 as 4t²."""
    got = parse_expression(text, {"t": _T}, where="scenario")
    assert sp.expand(got - expected) == 0
