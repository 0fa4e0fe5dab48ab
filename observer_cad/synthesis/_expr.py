"""Reading the expressions stored in a design's JSON with the model stage's whitelist
reader (:func:`observer_cad.model.parse_expression`): nothing in a design file is
evaluated. Identifiers the design introduced (``xs1``, ``y1``, gains) become symbols;
decimals stay floats (float designs); ``CRootOf(poly, index)`` (an irrational Jordan λ of
degree ≥ 3, as sympy prints it) is read as that real algebraic number; the assumptions
``Ne(a, b)`` / ``Eq(a, b)`` and comparisons are read as relations."""
from __future__ import annotations

import re
from typing import Mapping

import sympy as sp

from ..errors import UsageError
from ..model import parse_expression

__all__ = ["parse_json_expression"]

_RELATION = re.compile(r"^\s*(Ne|Eq)\((.*)\)\s*$", re.S)


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
    kw = dict(where=where, any_name=True, allow_complex=True, exact_floats=False,
              allow_crootof=True)
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
