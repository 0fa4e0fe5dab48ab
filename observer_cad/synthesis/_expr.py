"""A whitelist reader for the expressions stored in a design's JSON.

The text is parsed with :mod:`ast` and rebuilt node by node into sympy: numbers, names
(looked up in the given namespace; other identifiers become plain symbols), ``+ - * / **``,
comparisons, and a fixed list of functions. Nothing is evaluated by Python; anything
else (attributes, subscripts, strings, lambdas, keyword arguments, other calls) is
refused with a one-line :class:`~observer_cad.errors.UsageError`.
"""
from __future__ import annotations

import ast
from typing import Mapping

import sympy as sp

from ..errors import UsageError

__all__ = ["parse_json_expression"]

_FUNCTIONS = {
    "sqrt": sp.sqrt, "Abs": sp.Abs, "sign": sp.sign, "exp": sp.exp, "log": sp.log,
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "atan": sp.atan, "tanh": sp.tanh,
    "Max": sp.Max, "Min": sp.Min, "Heaviside": sp.Heaviside, "re": sp.re, "im": sp.im,
    "Ne": sp.Ne, "Eq": sp.Eq, "conjugate": sp.conjugate,
}
_CONSTANTS = {"I": sp.I, "pi": sp.pi, "E": sp.E}
_MAX_LEN = 100_000
_MAX_EXPONENT = 1000


def _build(node, names, where):
    rec = lambda n: _build(n, names, where)  # noqa: E731
    if isinstance(node, ast.Expression):
        return rec(node.body)
    if isinstance(node, ast.Constant):
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise UsageError(f"{where}: {v!r} is not a number")
        if isinstance(v, int):
            return sp.Integer(v)
        if v != v or v in (float("inf"), float("-inf")):
            raise UsageError(f"{where}: {v!r} is not a finite number")
        return sp.Float(repr(v), 17)
    if isinstance(node, ast.Name):
        if node.id in _CONSTANTS:
            return _CONSTANTS[node.id]
        if node.id in names:
            return names[node.id]
        if node.id.startswith("_") or node.id in _FUNCTIONS or node.id in ("nan", "oo", "zoo"):
            raise UsageError(f"{where}: name {node.id!r} is not allowed here")
        return sp.Symbol(node.id)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = rec(node.operand)
        return -v if isinstance(node.op, ast.USub) else v
    if isinstance(node, ast.BinOp):
        a, b = rec(node.left), rec(node.right)
        if isinstance(node.op, ast.Add):
            return a + b
        if isinstance(node.op, ast.Sub):
            return a - b
        if isinstance(node.op, ast.Mult):
            return a * b
        if isinstance(node.op, ast.Div):
            if b == 0:
                raise UsageError(f"{where}: division by zero")
            return a / b
        if isinstance(node.op, ast.Pow):
            if b.is_number and abs(b) > _MAX_EXPONENT:
                raise UsageError(f"{where}: exponent {b} is too large")
            return a ** b
    if isinstance(node, ast.Compare) and len(node.ops) == 1:
        a, b = rec(node.left), rec(node.comparators[0])
        ops = {ast.Lt: sp.Lt, ast.LtE: sp.Le, ast.Gt: sp.Gt, ast.GtE: sp.Ge}
        for k, f in ops.items():
            if isinstance(node.ops[0], k):
                return f(a, b)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
            and node.func.id in _FUNCTIONS and not node.keywords:
        return _FUNCTIONS[node.func.id](*[rec(a) for a in node.args])
    raise UsageError(f"{where}: {type(node).__name__} is not allowed in an expression")


def parse_json_expression(text, names: Mapping, where: str) -> sp.Expr:
    """The sympy expression written as ``text`` (see the module docstring)."""
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise UsageError(f"{where}: expected an expression string, got {type(text).__name__}")
    text = str(text)
    if len(text) > _MAX_LEN:
        raise UsageError(f"{where}: expression longer than {_MAX_LEN} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise UsageError(f"{where}: cannot parse {text[:60]!r}") from None
    return _build(tree, names, where)
