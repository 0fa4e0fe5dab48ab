"""C text of the standalone export: ASCII, block comments, string and double literals.

The exported files are plain ASCII C99: the observer's names and equations (which may
hold −, …, ·, ξ, ≤ …) are transliterated, made safe inside ``/* … */``, and numbers are
written so that a double round-trips exactly.
"""
from __future__ import annotations

import math

__all__ = ["ascii_text", "c_comment", "c_string", "c_double"]

_ASCII = str.maketrans({"−": "-", "…": "...", "·": "*", "ξ": "xi", "≤": "<=", "≥": ">=",
                        "—": "-", "–": "-", "⁺": "+", "⁻": "-", "§": "S"})


def ascii_text(text: str) -> str:
    """``text`` in ASCII (known symbols transliterated, others replaced by '?')."""
    return str(text).translate(_ASCII).encode("ascii", "replace").decode("ascii")


def c_comment(text: str) -> str:
    """Text safe inside a C block comment."""
    return ascii_text(text).replace("*/", "* /").replace("/*", "/ *")


def c_string(s: str) -> str:
    """A C string literal of ``s`` (ASCII, quotes and backslashes escaped)."""
    return '"' + ascii_text(s).replace("\\", "\\\\").replace('"', '\\"') + '"'


def c_double(v: float) -> str:
    """A C double literal of ``v`` (``repr``: exact round trip; NAN, ±INFINITY)."""
    v = float(v)
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    r = repr(v)
    return r if any(c in r for c in ".eE") else r + ".0"
