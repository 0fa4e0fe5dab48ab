"""Rigorous enclosures of expressions over boxes by interval arithmetic (mpmath's ``iv``,
outward rounded): the ranges the sampled-data band of a nonlinear plant rests on (the
terms a held step leaves, bounded from the operating envelope; METHOD §3, residual
evaluation).

The enclosure of an expression is that of its expression tree, evaluated bottom-up:
numbers exactly (a rational as the interval of p/q), symbols as their boxes, sums,
products, integer powers, square roots, exp, log, sin, cos, tan and Abs. It contains the
range and may exceed it (every occurrence of a symbol is taken independently). What the
tree does not support, and a range that is not finite (a root of an interval reaching
below 0, a quotient by an interval containing 0), is refused in one line.
"""
from __future__ import annotations

import math

import sympy as sp
from mpmath import iv

from ..errors import UsageError

__all__ = ["interval_range", "abs_bound"]

_FUNCTIONS = {sp.exp: iv.exp, sp.log: iv.log, sp.sin: iv.sin, sp.cos: iv.cos, sp.tan: iv.tan}


class _NotBounded(Exception):
    pass


def _number(q) -> "iv.mpf":
    q = sp.Rational(q)
    return iv.mpf(int(q.p)) / iv.mpf(int(q.q))


def _enclose(e, box: dict):
    if e.is_Number:
        return _number(e)
    if e.is_Symbol:
        if e not in box:
            raise _NotBounded(f"'{e}' has no declared bounds")
        lo, hi = box[e]
        return iv.mpf([_number(lo).a, _number(hi).b])
    if e.is_Add:
        out = _number(0)
        for a in e.args:
            out = out + _enclose(a, box)
        return out
    if e.is_Mul:
        out = _number(1)
        for a in e.args:
            out = out * _enclose(a, box)
        return out
    if e.is_Pow:
        base, ex = e.args
        b = _enclose(base, box)
        if ex.is_Integer:
            if int(ex) < 0 and b.a <= 0 <= b.b:
                raise _NotBounded(f"{base} can be 0 in {e}")
            return b ** int(ex)
        if ex == sp.Rational(1, 2) or ex == sp.Rational(-1, 2):
            if b.a < 0 or (ex < 0 and b.a <= 0):
                raise _NotBounded(f"{base} can be {'negative' if b.a < 0 else '0'} in {e}")
            r = iv.sqrt(b)
            return r if ex > 0 else 1 / r
        raise _NotBounded(f"the power {e} is not supported")
    if isinstance(e, sp.Abs):
        return abs(_enclose(e.args[0], box))
    fn = _FUNCTIONS.get(e.func)
    if fn is not None and len(e.args) == 1:
        a = _enclose(e.args[0], box)
        if e.func is sp.log and a.a <= 0:
            raise _NotBounded(f"{e.args[0]} can be ≤ 0 in {e}")
        return fn(a)
    raise _NotBounded(f"{e.func.__name__} is not supported by the interval bound")


def interval_range(expr, box: dict, *, where: str, what: str) -> tuple:
    """(lo, hi) as floats with lo ≤ expr ≤ hi whenever every symbol lies in its box
    (``box``: symbol → (low, high)); a one-line :class:`UsageError` naming ``what`` when
    the enclosure is not finite or the expression is not supported."""
    e = sp.sympify(expr)
    try:
        r = _enclose(e, box)
        lo, hi = float(r.a), float(r.b)
    except (_NotBounded, ValueError, ZeroDivisionError) as exc:
        raise UsageError(f"{where}: {what} has no finite bound over the operating envelope"
                         f" ({exc}); the sampled-data band needs it") from None
    except Exception as exc:  # mpmath's ComplexResult for a root of a negative interval
        raise UsageError(f"{where}: {what} has no finite bound over the operating envelope"
                         f" ({type(exc).__name__}: {exc}); the sampled-data band needs it") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise UsageError(f"{where}: {what} is unbounded over the operating envelope ({e});"
                         " the sampled-data band needs it bounded")
    # float() rounds to nearest: step outward by one ulp to keep the enclosure
    return math.nextafter(lo, -math.inf), math.nextafter(hi, math.inf)


def abs_bound(expr, box: dict, *, where: str, what: str) -> float:
    """max |expr| over the box (an upper bound, from :func:`interval_range`)."""
    lo, hi = interval_range(expr, box, where=where, what=what)
    return max(abs(lo), abs(hi))
