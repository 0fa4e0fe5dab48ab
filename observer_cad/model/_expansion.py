"""How large an expression could grow when expanded, estimated from its tree before
anything is expanded (:func:`expansion_size`), and the limits that
:func:`~observer_cad.model.parse_expression` holds every expression read from data or the
command line to: a few bytes such as ``(a+b+c+e)**1000`` would otherwise expand to 10⁸
terms and exhaust memory.
"""
from __future__ import annotations

import math

import sympy as sp

__all__ = ["MAX_EXPANDED_TERMS", "MAX_DEGREE", "MAX_DIGITS", "expansion_size"]

#: most terms an expression may have once expanded (estimated before anything is
#: expanded: a power of a sum of m terms to the n has C(m+n−1, n) terms):
#: ``(k1+k2+k3+k4)**1000`` would have 1.7·10⁸ and is refused in milliseconds
MAX_EXPANDED_TERMS = 10_000
#: highest total degree an expression may reach in its names (``(x**1000)**1000`` is
#: x¹⁰⁰⁰⁰⁰⁰ to sympy: each exponent is bounded, their product is not)
MAX_DEGREE = 1000
#: most decimal digits a coefficient may reach once expanded (a power multiplies the
#: digits of its base's coefficients by its exponent)
MAX_DIGITS = 100_000


def _digits(n: int) -> int:
    """Decimal digits of an integer, from its bit length (never str(): Python refuses to
    print integers of more than 4300 digits by default)."""
    return int(abs(n).bit_length() * math.log10(2)) + 1


def _number_digits(v) -> int:
    """Decimal digits of a sympy number's numerator and denominator (0 for others)."""
    if v.is_Rational:
        return _digits(int(v.p)) + (_digits(int(v.q)) if v.q != 1 else 0)
    if v.is_Float:
        return 20
    return 0


_TERMS_CEILING = 10 * MAX_EXPANDED_TERMS  # estimates stop growing here


def _power_terms(t: int, n: int) -> int:
    """C(t+n−1, n) (terms of a t-term sum to the n), or ``_TERMS_CEILING`` if larger."""
    if t <= 1 or n == 0:
        return 1
    terms = 1
    for i in range(1, n + 1):
        terms = terms * (t + i - 1) // i
        if terms >= _TERMS_CEILING:
            return _TERMS_CEILING
    return terms


def expansion_size(expr) -> tuple[int, int, int]:
    """(terms, total degree, largest coefficient's decimal digits) that ``expr`` could
    reach when expanded (``sympy.expand``, deep), estimated from its tree without
    expanding anything: an upper bound for polynomial parts (a sum adds terms, a product
    multiplies them, a power of a sum of m terms to the n gives C(m+n−1, n)), every other
    function or non-integer power one term of its own. The estimate of every
    subexpression is checked against the limits (:data:`MAX_EXPANDED_TERMS`,
    :data:`MAX_DEGREE`, :data:`MAX_DIGITS`) as it is made; the first exceeded raises
    ``ValueError`` naming it (:func:`parse_expression` turns it into its one line)."""
    memo: dict = {}

    def size(e):
        if e in memo:
            return memo[e]
        if e.is_Number:
            out = (1, 0, _number_digits(e))
        elif e.is_Symbol:
            out = (1, 1, 0)
        elif e.is_Add:
            parts = [size(a) for a in e.args]
            out = (min(sum(p[0] for p in parts), _TERMS_CEILING), max(p[1] for p in parts),
                   max(p[2] for p in parts) + len(str(len(parts))))
        elif e.is_Mul:
            parts = [size(a) for a in e.args]
            terms = 1
            for p in parts:
                terms = min(terms * p[0], _TERMS_CEILING)
            out = (terms, sum(p[1] for p in parts), sum(p[2] for p in parts))
        elif e.is_Pow and e.exp.is_Integer:
            t, d, g = size(e.base)
            n = abs(int(e.exp))
            out = (_power_terms(t, n), d * n, g * n + math.ceil(n * math.log10(max(t, 1))))
        else:  # a function, a non-integer power, a Piecewise, CRootOf: one term
            parts = [size(a) for a in e.args if isinstance(a, sp.Basic)] or [(1, 0, 0)]
            out = (1, 1 if e.free_symbols else 0, max(p[2] for p in parts))
        _check_size(*out)
        memo[e] = out
        return out

    return size(sp.sympify(expr))


def _check_size(terms: int, degree: int, digits: int) -> None:
    if terms > MAX_EXPANDED_TERMS:
        how = "more than" if terms >= _TERMS_CEILING else "about"
        raise ValueError(f"expanded it would have {how}"
                         f" {terms:,} terms (at most {MAX_EXPANDED_TERMS:,} are read)")
    if degree > MAX_DEGREE:
        raise ValueError(f"its degree would be {degree:,} (at most {MAX_DEGREE:,} is read)")
    if digits > MAX_DIGITS:
        raise ValueError(f"expanded its coefficients would have about {digits:,} digits (at"
                         f" most {MAX_DIGITS:,} are read)")
