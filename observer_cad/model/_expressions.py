"""The one reader of expressions that come from data or the command line.

Scenario signals, ``--estimate``, ``--lambda``, ``--eigenvalues``, ``--gain``,
``--bound`` and the matrices of a design's JSON are *text*. Text is never evaluated:
:func:`parse_expression` parses it with Python's :mod:`ast` and builds the sympy
expression node by node from a whitelist grammar::

    expr     := number | name | constant | expr op expr | -expr | +expr | (expr)
              | function(expr, ...) | Piecewise((expr, cond), ...) | root
    op       := + - * / ** (^ is read as ** too, as sympy's parser does)
    number   := 2, 0.25, 1e-3 (exact: 0.25 is 1/4), 1/3 is the rational 1/3
    name     := a declared name (the caller's: t, the states, the parameters, ...)
    constant := pi, E, and I (the imaginary unit) where complex values are allowed
    function := sin cos tan asin acos atan atan2 sinh cosh tanh exp log sqrt
                Abs abs sign floor ceiling Heaviside Min Max
    cond     := expr < expr (also <=, >, >=, ==, !=, chained) | cond and cond
              | cond or cond | not cond | cond & cond | cond | cond | True | False
    root     := CRootOf(poly, index)             (only where the caller allows it)
    poly     := integer | var | poly + poly | poly - poly | poly * poly | -poly | +poly
              | (poly) | poly / c | poly ** e     (c: a nonzero constant poly; e: an
                                                   integer literal ≥ 0; ^ is ** too)
    index    := integer | -integer               (a literal)

Conditions are allowed only where the caller asks for them (piecewise scenario
segments) and inside ``Piecewise``. Anything else — attribute access, subscripts,
calls of other names, keyword arguments, lambdas, strings, comprehensions, ``1j``
literals, numbers outside the floating-point range, nonzero decimals below the smallest
normal double (read exactly they would be rationals of hundreds of digits), exponents above
:data:`MAX_EXPONENT`, text longer than :data:`MAX_LENGTH` characters, an expression that
expanded would exceed :data:`MAX_EXPANDED_TERMS` terms, degree :data:`MAX_DEGREE` or
:data:`MAX_DIGITS` digits (estimated from its tree by :func:`expansion_size`, before
anything is expanded) — raises
:class:`~observer_cad.errors.ExpressionError` (a :class:`UsageError`: one line naming
``where`` and what was rejected). Nothing is executed: no ``eval``, no ``sympify``,
no ``parse_expr`` on the text.

``root`` is read only where the caller passes ``allow_crootof=True`` (a design's JSON,
``--lambda``): the real algebraic number sympy prints as ``CRootOf(x**3 - 3*x + 1, 0)``
(an irrational Jordan λ of degree ≥ 3). ``poly`` has rational coefficients (integers,
``/`` by a nonzero constant; a decimal such as ``0.5`` is refused) and exactly one
variable ``var``: any identifier, sympy's ``lambda`` too (a Python keyword, read here as
a name). ``CRootOf`` binds it: it is not looked up among the caller's names, so
``CRootOf(x**3 - 3*x + 1, 0)`` is the same number whether or not the model has a state
``x`` (the root is built in sympy's own variable ``x``, whatever name was written). The
degree, counted as written, is at most :data:`MAX_CROOTOF_DEGREE`; ``index`` satisfies
−degree ≤ index < degree (sympy's numbering: the real roots first, ascending, with
multiplicity) and must name a *real* root — a complex one is refused even where ``I`` is
allowed (no design needs one, and isolating the complex roots of a polynomial of high
degree can take minutes). Two variables, a variable in a denominator or an exponent,
functions, constants (``pi``, ``I``) and a nested ``CRootOf`` inside ``poly`` are
refused. The number is built node by node like the rest (``sympy.Poly`` of the built
polynomial, then its real roots; the text is never evaluated). Isolating the real roots
is sympy's work, and its time grows with how close the roots lie (``x**16 - 2*(256*x -
1)**2``, two roots 3·10⁻²² apart: over five minutes), so a polynomial with two distinct
roots closer than :data:`MIN_ROOT_SEPARATION` (relative) is refused first, from FLINT's
enclosures of all its complex roots (milliseconds).
"""
from __future__ import annotations

import ast
import io
import math
import tokenize
import re
from decimal import Decimal, InvalidOperation
from typing import Mapping

import sympy as sp

from ..errors import ExpressionError
from ._expansion import MAX_DEGREE, MAX_DIGITS, MAX_EXPANDED_TERMS, expansion_size

__all__ = ["parse_expression", "parse_number", "FUNCTIONS", "MAX_LENGTH", "MAX_EXPONENT",
           "MAX_CROOTOF_DEGREE", "MAX_EXPANDED_TERMS", "MAX_DEGREE", "MAX_DIGITS",
           "expansion_size"]

#: longest text accepted (characters)
MAX_LENGTH = 2000
#: largest |exponent| of a number in ``a**b``; numbers whose result leaves the
#: floating-point range are refused too
MAX_EXPONENT = 1000
#: highest degree (as written) of the polynomial in ``CRootOf(poly, index)``; above the
#: state dimension of any exact design (the exact path is the default up to
#: ``FLOAT_AUTO_N`` = 20 states), below where sympy's root isolation gets slow for
#: ordinary coefficients
MAX_CROOTOF_DEGREE = 32
#: smallest nonzero |decimal| read exactly: below it (5e-324, a subnormal float) the
#: exact rational would carry hundreds of digits for a value no float arithmetic keeps
MIN_NORMAL = 2.2250738585072014e-308
_MAX_DEPTH = 100
_FLOAT_MAX_LOG10 = math.log10(1.7976931348623157e308)

#: function name → (sympy function, allowed argument counts; None = one or more)
FUNCTIONS: Mapping = {
    "sin": (sp.sin, (1,)), "cos": (sp.cos, (1,)), "tan": (sp.tan, (1,)),
    "asin": (sp.asin, (1,)), "acos": (sp.acos, (1,)), "atan": (sp.atan, (1,)),
    "atan2": (sp.atan2, (2,)),
    "sinh": (sp.sinh, (1,)), "cosh": (sp.cosh, (1,)), "tanh": (sp.tanh, (1,)),
    "exp": (sp.exp, (1,)), "log": (sp.log, (1,)), "sqrt": (sp.sqrt, (1,)),
    "Abs": (sp.Abs, (1,)), "abs": (sp.Abs, (1,)), "sign": (sp.sign, (1,)),
    "floor": (sp.floor, (1,)), "ceiling": (sp.ceiling, (1,)),
    "Heaviside": (sp.Heaviside, (1,)),
    "Min": (sp.Min, None), "Max": (sp.Max, None),
}
_CONSTANTS = {"pi": sp.pi, "E": sp.E}
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_OPNAMES = {ast.FloorDiv: "'//'", ast.Mod: "'%'", ast.MatMult: "'@'", ast.LShift: "'<<'",
            ast.RShift: "'>>'", ast.BitAnd: "'&'", ast.BitOr: "'|'"}
_COMPARE = {ast.Lt: sp.Lt, ast.LtE: sp.Le, ast.Gt: sp.Gt, ast.GtE: sp.Ge, ast.Eq: sp.Eq,
            ast.NotEq: sp.Ne}
_NONFINITE = (sp.nan, sp.zoo, sp.oo, -sp.oo)
#: ``lambda`` (a Python keyword, the name sympy's λ prints as) is parsed under this name
#: where CRootOf is allowed, then read back as the name ``lambda``
_KEYWORD_LAMBDA = "_kw_lambda_"
#: the variable a CRootOf read here is written in (the one sympy's real_roots uses)
_ROOT_VARIABLE = sp.Symbol("x")
_IN_POLY = "in CRootOf's polynomial"
_POLY_GRAMMAR = ("allowed: integers, one variable, + - * /, ** with an integer exponent ≥ 0;"
                 " e.g. CRootOf(x**3 - 3*x + 1, 0)")


#: CRootOf's polynomial is refused when two of its distinct roots are closer than this,
#: relative to max(1, |largest root|): sympy's exact real-root isolation takes 0.5 s at a
#: separation of 7e-7 and 12 s at 5e-9 (degree 12), minutes below; a design's λ are never
#: that close
MIN_ROOT_SEPARATION = 1e-6


def _check_separation(poly) -> None:
    """Refuse a CRootOf polynomial with nearly coincident roots, cheaply (FLINT's ball
    arithmetic finds every complex root in milliseconds) before sympy isolates them."""
    import flint
    _, ints = poly.clear_denoms()
    roots = [complex(r.mid()) for r, _m in
             flint.fmpz_poly([int(c) for c in reversed(ints.all_coeffs())]).complex_roots()]
    scale = max([1.0] + [abs(r) for r in roots])
    for i, a in enumerate(roots):
        for b in roots[i + 1:]:
            if abs(a - b) < MIN_ROOT_SEPARATION * scale:
                raise _Reject(f"CRootOf's polynomial {poly.as_expr()} has two roots closer than"
                              f" {MIN_ROOT_SEPARATION:g} (relative): refused, isolating them"
                              " exactly could take minutes")


#: bits of relative width to which a CRootOf's isolating interval is narrowed on reading
_NARROW_BITS = 320


def _narrow_isolating_interval(root) -> None:
    """Narrow sympy's cached isolating interval of a real ``CRootOf`` to 2⁻³²⁰ of the
    root's size by bisection with exact integer signs (milliseconds; once per root: the
    cache is sympy's, shared by every CRootOf of the polynomial). sympy refines it by
    continued fractions, which for a root very close to a simple rational takes
    exponentially many steps: ``CRootOf(x**14 - 3*x + 1, 0)`` (≈ 1/3 + 3⁻¹⁵) took 5 s to
    evaluate, degree 16 over a minute, degree 20 never finished. sympy reuses the cached
    interval for every later evaluation of the root (``evalf``, ``float``) to about 90
    digits. Best effort: if sympy's internals differ, the interval is left as it was."""
    from fractions import Fraction

    try:
        from sympy.polys.rootisolation import RealInterval

        interval = root._get_interval()
        poly = root.poly
        dom = poly.domain
        if not dom.is_ZZ:
            return
        a, b = sp.Rational(interval.a), sp.Rational(interval.b)
        lo, hi = Fraction(int(a.p), int(a.q)), Fraction(int(b.p), int(b.q))
        coeffs = [int(c) for c in poly.all_coeffs()]  # highest power first

        def value_sign(r):  # sign of the polynomial at a rational: Horner in integers
            num, den = r.numerator, r.denominator
            v, dpow = 0, 1
            for c in coeffs:
                v = v * num + c * dpow
                dpow *= den
            return (v > 0) - (v < 0)  # v = den^deg · p(num/den), den > 0

        def narrow_enough():
            return hi - lo <= max(abs(lo), abs(hi)) / 2 ** _NARROW_BITS

        s_lo, s_hi = value_sign(lo), value_sign(hi)
        if lo >= hi or s_lo == 0 or s_hi == 0 or s_lo == s_hi or (lo < 0 < hi) \
                or narrow_enough():
            return
        while not narrow_enough():
            mid = (lo + hi) / 2
            s_mid = value_sign(mid)
            if s_mid == 0:
                return  # a rational root: sympy would not have made it a CRootOf
            if s_mid == s_lo:
                lo = mid
            else:
                hi = mid
        field = dom.get_field()
        root._set_interval(RealInterval((field(lo.numerator, lo.denominator),
                                         field(hi.numerator, hi.denominator)),
                                        poly.rep.to_list(), dom))
    except Exception:  # pragma: no cover - other sympy internals: sympy's own refinement
        return


def _check_expansion(expr) -> None:
    """Refuse what would be too large to expand (terms, degree, digits) in one line."""
    if not isinstance(expr, sp.Basic) or expr.is_Atom:
        return
    try:
        expansion_size(expr)
    except ValueError as exc:
        raise _Reject(str(exc)) from None


class _Reject(Exception):
    """Internal: what was rejected (becomes the ExpressionError's reason)."""


def _symbol_table(names) -> dict:
    if names is None:
        return {}
    if isinstance(names, Mapping):
        return {str(k): v for k, v in names.items()}
    return {str(s): s for s in names}


def _describe(node: ast.AST) -> str:
    kinds = {ast.Attribute: "attribute access", ast.Subscript: "subscript",
             ast.Lambda: "lambda", ast.ListComp: "comprehension",
             ast.SetComp: "comprehension", ast.DictComp: "comprehension",
             ast.GeneratorExp: "comprehension", ast.List: "a list (one expression expected)", ast.Dict: "dict",
             ast.Set: "set", ast.Tuple: "a tuple (one expression expected)", ast.Starred: "starred argument",
             ast.NamedExpr: "assignment", ast.IfExp: "if-expression",
             ast.JoinedStr: "f-string", ast.Await: "await", ast.Yield: "yield",
             ast.YieldFrom: "yield"}
    for k, v in kinds.items():
        if isinstance(node, k):
            return v
    return type(node).__name__


class _Builder:
    def __init__(self, text, table, allow_complex, any_name, exact_floats=True,
                 allow_crootof=False, keyword_lambda=False, big_integers=False):
        self.exact_floats = exact_floats
        self.big_integers = big_integers
        self.text = text
        self.table = table
        self.allow_complex = allow_complex
        self.any_name = any_name
        self.allow_crootof = allow_crootof
        self.keyword_lambda = keyword_lambda  # `lambda` was renamed to _KEYWORD_LAMBDA
        self.depth = 0

    def identifier(self, ident: str) -> str:
        return "lambda" if self.keyword_lambda and ident == _KEYWORD_LAMBDA else ident

    # ------------------------------------------------------------------ expressions
    def expr(self, node):
        self.depth += 1
        if self.depth > _MAX_DEPTH:
            raise _Reject("too deeply nested")
        try:
            return self._expr(node)
        finally:
            self.depth -= 1

    def _expr(self, node):
        if isinstance(node, ast.Constant):
            return self.number(node)
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            v = self.expr(node.operand)
            return -v if isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.BinOp) and (type(node.op) in _BINOPS or isinstance(node.op, ast.BitXor)):
            a, b = self.expr(node.left), self.expr(node.right)
            op = type(node.op)
            if op is ast.Add:
                return a + b
            if op is ast.Sub:
                return a - b
            if op is ast.Mult:
                return a * b
            if op is ast.Div:
                if b == 0:
                    raise _Reject("division by zero")
                return a / b
            return self.power(a, b)  # ** (and ^, which sympy's parser also reads as a power)
        if isinstance(node, ast.BinOp):
            raise _Reject(f"operator {_OPNAMES.get(type(node.op), type(node.op).__name__)}"
                          " (allowed: + - * / **)")
        if isinstance(node, ast.Call):
            return self.call(node)
        if isinstance(node, (ast.Compare, ast.BoolOp)) or \
                (isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not)):
            raise _Reject("a condition where a value is expected")
        raise _Reject(_describe(node))

    def number(self, node):
        v = node.value
        if isinstance(v, bool) or v is None or v is Ellipsis:
            raise _Reject(f"'{v}' where a number is expected")
        if isinstance(v, int):
            if v.bit_length() > 1024 and not self.big_integers:
                raise _Reject("a number outside the floating-point range")
            return sp.Integer(v)
        if isinstance(v, float):
            seg = ast.get_source_segment(self.text, node) or repr(v)
            try:
                dec = Decimal(seg.replace("_", ""))
            except InvalidOperation:
                raise _Reject(f"number {seg!r}") from None
            if not dec.is_finite() or not math.isfinite(v) or \
                    (dec != 0 and abs(dec.adjusted()) > 330):
                raise _Reject(f"number {seg} outside the floating-point range")
            if not self.exact_floats:
                return sp.Float(seg.replace("_", ""))
            if dec != 0 and abs(dec) < Decimal(repr(MIN_NORMAL)):
                raise _Reject(f"number {seg} is below the smallest normal floating-point"
                              f" number {MIN_NORMAL:.3g} in magnitude (write 0 or a larger"
                              " value)")
            p, q = dec.as_integer_ratio()
            return sp.Rational(p, q)
        if isinstance(v, complex):
            raise _Reject(f"complex literal {ast.get_source_segment(self.text, node)!s}"
                          + (" (write the imaginary unit as I, e.g. 1+2*I)" if self.allow_complex
                             else ""))
        if isinstance(v, (str, bytes)):
            raise _Reject("a string")
        raise _Reject(type(v).__name__)

    def name(self, ident):
        ident = self.identifier(ident)
        if ident in self.table:
            return self.table[ident]
        if ident in _CONSTANTS:
            return _CONSTANTS[ident]
        if ident == "I":
            if self.allow_complex:
                return sp.I
            raise _Reject("the imaginary unit I (complex values are not allowed here)")
        if ident in FUNCTIONS or ident in ("Piecewise", "CRootOf"):
            raise _Reject(f"function '{ident}' used without arguments")
        if self.any_name and not ident.startswith("_"):
            return sp.Symbol(ident)
        names = sorted(self.table)
        known = ", ".join(names[:12]) + (f", … ({len(names)} names)" if len(names) > 12 else "") \
            if names else "none"
        raise _Reject(f"unknown name '{ident}' (allowed names: {known})")

    def power(self, a, b):
        if b.is_number:
            try:
                bv = abs(complex(b))
            except (TypeError, ValueError):
                bv = math.inf
            if not bv <= MAX_EXPONENT:
                raise _Reject(f"exponent {b} (|exponent| ≤ {MAX_EXPONENT})")
            if a.is_number:
                if a == 0 and b.is_extended_negative:
                    raise _Reject("division by zero")
                try:
                    av = abs(complex(a))
                except (TypeError, ValueError):
                    av = math.inf
                if av > 0 and bv * abs(math.log10(av)) > _FLOAT_MAX_LOG10:
                    raise _Reject(f"power {a}**{b} outside the floating-point range")
        return self.real(sp.Pow(a, b), f"({a})**({b})")

    def real(self, value, what):
        """``value`` when complex values are allowed or it is not a non-real number:
        sqrt(-1), log(-2), (-8)**(1/3), asin(2) evaluate to complex numbers, which a
        plant, a scenario or a gain cannot use (I itself is refused by name)."""
        if not self.allow_complex and value.is_number and (
                value.has(sp.I) or value.is_extended_real is False):
            raise _Reject(f"{what} is not a real number (complex values are not allowed here)")
        return value

    def call(self, node):
        f = node.func
        if not isinstance(f, ast.Name):
            raise _Reject(f"call of {_describe(f)}" if not isinstance(f, ast.Attribute)
                          else f"attribute access '.{f.attr}'")
        if node.keywords:
            raise _Reject(f"keyword arguments in {f.id}(...)")
        if any(isinstance(a, ast.Starred) for a in node.args):
            raise _Reject(f"starred arguments in {f.id}(...)")
        if f.id == "Piecewise":
            return self.piecewise(node)
        if f.id == "CRootOf":
            return self.crootof(node)
        if f.id not in FUNCTIONS:
            raise _Reject(f"call of '{f.id}' (allowed functions: {', '.join(FUNCTIONS)},"
                          " Piecewise" + (", CRootOf)" if self.allow_crootof else ")"))
        fn, nargs = FUNCTIONS[f.id]
        if (nargs is None and not node.args) or (nargs is not None and len(node.args) not in nargs):
            want = "one or more" if nargs is None else " or ".join(map(str, nargs))
            raise _Reject(f"{f.id}() takes {want} argument(s), got {len(node.args)}")
        args = [self.expr(a) for a in node.args]
        return self.real(fn(*args), f"{f.id}({', '.join(map(str, args))})")

    def piecewise(self, node):
        if not node.args:
            raise _Reject("Piecewise() needs (value, condition) pairs")
        pieces = []
        for a in node.args:
            if not isinstance(a, ast.Tuple) or len(a.elts) != 2:
                raise _Reject("Piecewise takes (value, condition) pairs")
            pieces.append((self.expr(a.elts[0]), self.cond(a.elts[1])))
        return sp.Piecewise(*pieces)

    # ------------------------------------------------------------------ algebraic numbers
    def crootof(self, node):
        """``CRootOf(poly, index)``: a real root of a rational polynomial (module docstring)."""
        if not self.allow_crootof:
            raise _Reject("CRootOf (an algebraic number) is not allowed here")
        if len(node.args) != 2:
            raise _Reject(f"CRootOf takes (polynomial, index), got {len(node.args)} argument(s)")
        var = []  # the one variable's name, once seen
        expr, _bound = self.poly(node.args[0], var)
        index = self.root_index(node.args[1])
        if not var:
            raise _Reject("CRootOf's polynomial has no variable")
        # in sympy's own variable (real_roots writes x): the roots of one polynomial then
        # carry the same expression whatever name each text used
        poly = sp.Poly(expr, sp.Symbol(var[0])).replace(sp.Symbol(var[0]), _ROOT_VARIABLE)
        deg = poly.degree()
        if deg < 1:
            raise _Reject(f"CRootOf's polynomial {expr} has degree {max(deg, 0)} (at least 1"
                          " is needed)")
        if not -deg <= index < deg:
            raise _Reject(f"CRootOf index {index} is out of range for degree {deg}"
                          f" (−{deg} ≤ index < {deg})")
        _check_separation(poly)
        reals = poly.real_roots(radicals=False)  # ascending, with multiplicity: sympy's order
        i = index % deg
        if i >= len(reals):
            have = (f"its real roots are indices 0…{len(reals) - 1}" if reals
                    else "it has no real root")
            raise _Reject(f"CRootOf index {index} names a complex root of {poly.as_expr()}"
                          f" ({have}); only real roots are read")
        if isinstance(reals[i], sp.CRootOf):
            _narrow_isolating_interval(reals[i])
        return reals[i]

    def root_index(self, node) -> int:
        sign = 1
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            sign = -1 if isinstance(node.op, ast.USub) else 1
            node = node.operand
        if not (isinstance(node, ast.Constant) and isinstance(node.value, int)
                and not isinstance(node.value, bool)):
            seg = ast.get_source_segment(self.text, node) or _describe(node)
            raise _Reject(f"CRootOf's index must be an integer literal, got {seg!r}")
        return sign * node.value

    def poly(self, node, var: list):
        """(sympy polynomial, degree bound as written) of CRootOf's first argument."""
        self.depth += 1
        if self.depth > _MAX_DEPTH:
            raise _Reject("too deeply nested")
        try:
            expr, deg = self._poly(node, var)
        finally:
            self.depth -= 1
        if deg > MAX_CROOTOF_DEGREE:
            raise _Reject(f"CRootOf's polynomial has degree above {MAX_CROOTOF_DEGREE}"
                          " (the most that is read)")
        return expr, deg

    def _poly(self, node, var):
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, float):
                seg = ast.get_source_segment(self.text, node) or repr(v)
                raise _Reject(f"decimal coefficient {seg} {_IN_POLY} (coefficients are exact:"
                              " write 1/4, not 0.25)")
            return self.number(node), 0  # an integer, or the number's own refusal
        if isinstance(node, ast.Name):
            ident = self.identifier(node.id)
            if ident in _CONSTANTS or ident == "I":
                raise _Reject(f"'{ident}' {_IN_POLY} (coefficients must be rational numbers)")
            if ident in FUNCTIONS or ident in ("Piecewise", "CRootOf"):
                raise _Reject(f"function '{ident}' used without arguments {_IN_POLY}")
            if ident.startswith("_"):
                raise _Reject(f"name '{ident}' {_IN_POLY} (names starting with '_' are not read)")
            if not var:
                var.append(ident)
            elif var[0] != ident:
                raise _Reject(f"two variables {_IN_POLY} ('{var[0]}' and '{ident}'): it must be"
                              " a polynomial in one variable")
            return sp.Symbol(ident), 1
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            v, d = self.poly(node.operand, var)
            return (-v if isinstance(node.op, ast.USub) else v), d
        if isinstance(node, ast.BinOp) and type(node.op) in (ast.Add, ast.Sub, ast.Mult, ast.Div):
            (a, da), (b, db) = self.poly(node.left, var), self.poly(node.right, var)
            if isinstance(node.op, ast.Add):
                return a + b, max(da, db)
            if isinstance(node.op, ast.Sub):
                return a - b, max(da, db)
            if isinstance(node.op, ast.Mult):
                return a * b, da + db
            if db:
                raise _Reject(f"division by the variable {_IN_POLY} (not a polynomial)")
            if b == 0:
                raise _Reject("division by zero")
            return a / b, da
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Pow, ast.BitXor)):
            e = node.right
            if not (isinstance(e, ast.Constant) and isinstance(e.value, int)
                    and not isinstance(e.value, bool)):
                seg = ast.get_source_segment(self.text, e) or _describe(e)
                raise _Reject(f"exponent {seg} {_IN_POLY} (an integer literal ≥ 0 is needed)")
            a, da = self.poly(node.left, var)
            if da * e.value > MAX_CROOTOF_DEGREE:
                raise _Reject(f"CRootOf's polynomial has degree above {MAX_CROOTOF_DEGREE}"
                              " (the most that is read)")
            return (self.power(a, sp.Integer(e.value)) if da == 0 else a ** e.value), da * e.value
        if isinstance(node, ast.BinOp):
            raise _Reject(f"operator {_OPNAMES.get(type(node.op), type(node.op).__name__)}"
                          f" {_IN_POLY} ({_POLY_GRAMMAR})")
        if isinstance(node, ast.Call):
            f = node.func.id if isinstance(node.func, ast.Name) else None
            if f == "CRootOf":
                raise _Reject(f"CRootOf {_IN_POLY} (nested CRootOf is not read)")
            raise _Reject(f"call of '{f or _describe(node.func)}' {_IN_POLY} ({_POLY_GRAMMAR})")
        raise _Reject(f"{_describe(node)} {_IN_POLY} ({_POLY_GRAMMAR})")

    # ------------------------------------------------------------------ conditions
    def cond(self, node):
        self.depth += 1
        if self.depth > _MAX_DEPTH:
            raise _Reject("too deeply nested")
        try:
            return self._cond(node)
        finally:
            self.depth -= 1

    def _cond(self, node):
        if isinstance(node, ast.Constant) and isinstance(node.value, bool):
            return sp.true if node.value else sp.false
        if isinstance(node, ast.Compare):
            parts = []
            left = self.expr(node.left)
            for op, right in zip(node.ops, node.comparators):
                if type(op) not in _COMPARE:
                    raise _Reject(f"comparison '{type(op).__name__}' (allowed: < <= > >= == !=)")
                r = self.expr(right)
                parts.append(_COMPARE[type(op)](left, r))
                left = r
            return sp.And(*parts)
        if isinstance(node, ast.BoolOp):
            vals = [self.cond(v) for v in node.values]
            return sp.And(*vals) if isinstance(node.op, ast.And) else sp.Or(*vals)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.Not, ast.Invert)):
            return sp.Not(self.cond(node.operand))
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.BitAnd, ast.BitOr)):
            a, b = self.cond(node.left), self.cond(node.right)
            return sp.And(a, b) if isinstance(node.op, ast.BitAnd) else sp.Or(a, b)
        raise _Reject("a value where a condition (e.g. t <= 20) is expected")


def _keyword_lambda_as_name(source: str):
    """(renamed text, tree) when ``source`` parses once ``lambda`` — sympy's printed λ,
    a Python keyword — is read as a name (``CRootOf(lambda**3 - 3*lambda + 1, 0)``);
    None when it still does not parse."""
    if not re.search(r"\blambda\b", source):
        return None
    renamed = re.sub(r"\blambda\b", _KEYWORD_LAMBDA, source)
    try:
        return renamed, ast.parse(renamed, mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError, OverflowError):
        return None


def _xor_as_power(source: str) -> str:
    """``^`` read as ``**`` at the token level, as sympy's parser does (``convert_xor``):
    Python's ``^`` binds more loosely than ``+`` and ``*``, so the tree of ``t^2 + 1`` is
    t ^ (2 + 1) and of ``2*t^2`` is (2·t) ^ 2 — replacing the operator in the tree would
    read them as t³ and 4t². The text is only split into tokens, never run."""
    if "^" not in source:
        return source
    try:
        toks = [(tok.type, "**" if tok.type == tokenize.OP and tok.string == "^" else tok.string)
                for tok in tokenize.generate_tokens(io.StringIO(source).readline)]
        return tokenize.untokenize(toks).strip()
    except (tokenize.TokenError, IndentationError, SyntaxError, ValueError):
        return source  # not tokenizable: ast.parse reports it


def parse_expression(text, names=None, *, where: str, allow_complex: bool = False,
                     condition: bool = False, any_name: bool = False,
                     exact_floats: bool = True, allow_crootof: bool = False,
                     max_length: int = MAX_LENGTH, big_integers: bool = False) -> sp.Basic:
    """The sympy expression (or, with ``condition=True``, the sympy boolean) that
    ``text`` denotes, built from a whitelist grammar (see the module docstring).

    Parameters
    ----------
    text : str
        The expression as written by the user. (A Python int or float, or a sympy
        expression, is returned as it is after a finiteness check: it is not text.)
    names : mapping str -> Symbol, or iterable of Symbols, optional
        The names the text may use (e.g. ``{"t": t}``, the model's states).
    where : str
        Where the text came from, for messages (``"scenario.json: signal 'u'"``,
        ``"--gain"``).
    allow_complex : bool
        Whether ``I`` (the imaginary unit) is allowed.
    condition : bool
        Parse a condition (``t <= 20``, ``and``/``or``/``not``) instead of a value.
    any_name : bool
        Every identifier not otherwise known becomes a Symbol (design JSON files).
    exact_floats : bool
        Decimals become exact rationals (``0.2`` → 1/5, the default) or sympy Floats.
    allow_crootof : bool
        Whether ``CRootOf(poly, index)`` (a real algebraic number, as sympy prints it)
        is read (design JSON, ``--lambda``); off by default. See the module docstring.
    max_length : int
        The longest text read (default :data:`MAX_LENGTH`; a design's JSON allows more:
        exact designs of float-based plants carry rationals of thousands of digits).
    big_integers : bool
        Integer literals beyond the floating-point range are read exactly (a design's
        JSON: exact coefficients); off by default (model and scenario values must be
        numbers a simulation can use).

    Raises
    ------
    ExpressionError
        One line: ``where``, the text (abridged) and what was rejected.

    Examples
    --------
    Decimals are read exactly; nothing is evaluated, and what is not in the grammar is
    refused in one line:

    >>> import sympy as sp
    >>> from observer_cad.model import parse_expression
    >>> t = sp.Symbol("t")
    >>> parse_expression("0.2*sin(t/10)", {"t": t}, where="scenario.json: signal 'u'")
    sin(t/10)/5
    >>> parse_expression("__import__('os')", {"t": t}, where="scenario.json: signal 'u'")
    Traceback (most recent call last):
    ...
    observer_cad.errors.ExpressionError: scenario.json: signal 'u': cannot read "__import__('os')": call of '__import__' (allowed functions: ...)
    """
    shown = text if not isinstance(text, str) or len(text) <= 60 else text[:57] + "..."

    def fail(reason):
        return ExpressionError(f"{where}: cannot read {shown!r}: {reason}", reason=reason)

    if isinstance(text, (int, float, sp.Basic)) and not isinstance(text, bool) and not condition:
        # a value built in Python (not text): checked, never parsed
        if isinstance(text, float) and not math.isfinite(text):
            raise fail("not finite")
        out = sp.Integer(text) if isinstance(text, int) else (
            sp.Float(text) if isinstance(text, float) else text)
        if isinstance(out, sp.Basic) and out.has(*_NONFINITE):
            raise fail("not finite")
        return out
    if not isinstance(text, str):
        raise fail(f"a {type(text).__name__}, not text")
    if len(text) > max_length:
        raise fail(f"longer than {max_length} characters")
    if not text.strip():
        raise fail("empty")
    if "\x00" in text:
        raise fail("a NUL character")
    source, keyword_lambda = _xor_as_power(text.strip()), False
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError as exc:
        renamed = _keyword_lambda_as_name(source) if allow_crootof else None
        if renamed is None:
            raise fail(f"not a valid expression ({exc.msg})") from None
        (source, tree), keyword_lambda = renamed, True
    except (ValueError, RecursionError, MemoryError, OverflowError) as exc:
        raise fail(f"not a valid expression ({type(exc).__name__})") from None
    b = _Builder(source, _symbol_table(names), allow_complex, any_name, exact_floats,
                 allow_crootof, keyword_lambda, big_integers)
    try:
        out = b.cond(tree.body) if condition else b.expr(tree.body)
    except _Reject as exc:
        raise fail(str(exc)) from None
    except RecursionError:
        raise fail("too deeply nested") from None
    except (TypeError, ValueError, ArithmeticError) as exc:  # sympy refusing an operand
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise fail(f"not a valid expression ({detail})") from None
    try:
        _check_expansion(out)  # before anyone expands it
    except _Reject as exc:
        raise fail(str(exc)) from None
    if not condition:
        if out.has(*_NONFINITE):
            raise fail("not finite (division by zero or an infinite value)")
        for atom in out.atoms(sp.Number):
            if not math.isfinite(float(abs(atom))):
                raise fail("a number outside the floating-point range")
    return out


def parse_number(text, *, where: str, allow_complex: bool = False) -> sp.Expr:
    """A finite number (exact where the text is: ``0.2`` is 1/5, ``sqrt(2)`` stays
    ``sqrt(2)``) read by :func:`parse_expression` without names; real unless
    ``allow_complex``. Sympy numbers pass through after the same checks.

    Examples
    --------
    >>> from observer_cad.model import parse_number
    >>> parse_number("0.25", where="--gain"), parse_number("1/3", where="--gain")
    (1/4, 1/3)
    """
    if isinstance(text, sp.Basic):
        e = text
        shown = str(text)
    elif isinstance(text, bool):
        raise ExpressionError(f"{where}: {text!r} is not a number", reason="not a number")
    elif isinstance(text, (int, float)):
        if isinstance(text, float) and not math.isfinite(text):
            raise ExpressionError(f"{where}: {text!r} is not finite", reason="not finite")
        e = parse_expression(repr(text), where=where, allow_complex=allow_complex)
        shown = repr(text)
    else:
        e = parse_expression(text, where=where, allow_complex=allow_complex)
        shown = text if len(str(text)) <= 60 else str(text)[:57] + "..."

    def fail(reason):
        return ExpressionError(f"{where}: {shown!r} is {reason}", reason=reason)

    if not isinstance(e, sp.Expr) or not e.is_number:
        raise fail("not a number")
    try:
        v = complex(sp.N(e, 30))
    except (TypeError, ValueError, OverflowError):
        raise fail("not a finite number") from None
    if not (math.isfinite(v.real) and math.isfinite(v.imag)):
        raise fail("not a finite number")
    if not allow_complex and (v.imag != 0 or e.is_real is False):
        raise fail("not real")
    return e
