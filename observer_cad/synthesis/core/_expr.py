"""Reading the expressions stored in a design's JSON with the model stage's whitelist
reader (:func:`observer_cad.model.parse_expression`): nothing in a design file is
evaluated. Identifiers the design introduced (``xs1``, ``y1``, gains) become symbols;
decimals stay floats (float designs); ``CRootOf(poly, index)`` (an irrational Jordan λ of
degree ≥ 3, as sympy prints it) is read as that real algebraic number; the assumptions
``Ne(a, b)`` / ``Eq(a, b)`` and comparisons are read as relations. A plain rational
literal ``-p/q`` is read by a regular expression and ``int`` (up to
:data:`MAX_RATIONAL_CHARS` characters), anything else by the whitelist reader with a
length cap of :data:`MAX_DESIGN_CHARS` (exact designs of float-based plants carry
rationals of thousands of digits)."""
from __future__ import annotations

import re
from typing import Mapping

import sympy as sp

from ...errors import UsageError
from ...model import parse_expression
from ...numerics import full_int_text

__all__ = ["parse_json_expression"]

_RELATION = re.compile(r"^\s*(Ne|Eq)\((.*)\)\s*$", re.S)
_RATIONAL = re.compile(r"-?[0-9]+(/[0-9]+)?")

#: the longest plain rational literal read (int() of 100,000 digits takes ~50 ms)
MAX_RATIONAL_CHARS = 100_000

#: the longest expression read from a design's JSON (the equations of a 12-state
#: float-based design run to ~10⁵ characters; ast.parse of 10⁶ takes well under a second)
MAX_DESIGN_CHARS = 1_000_000


def _split_top_level(text: str) -> list:
    depth, parts, cur = 0, [], []
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    return parts


def parse_json_expression(text, names: Mapping, where: str) -> sp.Basic:
    """The sympy expression (or relation) written as ``text`` in a design's JSON."""
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise UsageError(f"{where}: expected an expression string, got {type(text).__name__}")
    text = str(text)
    if len(text) <= MAX_RATIONAL_CHARS and _RATIONAL.fullmatch(text):
        num, _, den = text.partition("/")
        with full_int_text():
            p, q = int(num), int(den or "1")
        if q == 0:
            raise UsageError(f"{where}: division by zero in {text[:40]!r}")
        return sp.Rational(p, q)
    kw = dict(where=where, any_name=True, allow_complex=True, exact_floats=False,
              allow_crootof=True, max_length=MAX_DESIGN_CHARS, big_integers=True)
    m = _RELATION.match(text)
    if m:
        args = _split_top_level(m.group(2))
        if len(args) != 2:
            raise UsageError(f"{where}: {m.group(1)}(a, b) takes two arguments")
        a, b = (parse_expression(x.strip(), names, **kw) for x in args)
        return sp.Ne(a, b) if m.group(1) == "Ne" else sp.Eq(a, b)
    if re.search(r"[<>]", text):
        return parse_expression(text, names, condition=True, **kw)
    return parse_expression(text, names, **kw)
