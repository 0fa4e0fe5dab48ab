"""Deciding that an expression is identically zero, exactly where algebra can, else by
evaluation at random rational points — and saying which.

Used by the model certificate (the extracted matrices rebuild the model's own equations)
and by the design certificates that re-check a design against the model's right-hand
side. The decision is a :class:`ZeroTest`: ``holds``, ``exact`` (decided by algebra) and
``how`` (the evidence, one line).

Exact steps, cheapest first: the expression is already 0; it expands to 0 (products
and integer powers distributed, inside functions too); its ``cancel`` (one fraction of
polynomials over the rationals and the algebraic numbers it holds) is 0. When none
decides — a function identity such as ``sin²θ + cos²θ − 1``, or an expression too large
to cancel — the expression is evaluated at :data:`POINTS` random rational points (every
free symbol drawn from [1/8, 3] with denominators 7, 11, 13, 16 or 17, seeded, so the same
expression always gets the same points) with :data:`DIGITS` significant digits, and
it holds when every value is below :data:`NUMERIC_RTOL` relative to the size of the
terms it is the difference of. A point where the expression is not defined (a division
by zero) is skipped; fewer than :data:`MIN_POINTS` defined points decide nothing (the
test fails, saying so).
"""
from __future__ import annotations

import dataclasses
import random

import sympy as sp

__all__ = ["ZeroTest", "is_identically_zero", "EXPAND_HINTS", "POINTS", "MIN_POINTS", "DIGITS",
           "NUMERIC_RTOL"]

#: sympy ``expand`` hints of the extraction and of the zero test: products and integer
#: powers distributed (inside function arguments too), but ``exp(a + b)`` and
#: ``(a b)^c`` left whole, so that a nonlinear term keeps its one argument
EXPAND_HINTS = dict(deep=True, mul=True, multinomial=True, power_exp=False, power_base=False,
                    log=False, basic=True)

#: random rational points of the numeric fallback, how many must be defined, the digits
#: each is evaluated with, and the relative size below which a value counts as zero
POINTS = 12
MIN_POINTS = 6
DIGITS = 50
NUMERIC_RTOL = 1e-35

#: the largest expression (in sympy's count of operations) that ``cancel`` is tried on
CANCEL_LIMIT = 4000


@dataclasses.dataclass(frozen=True)
class ZeroTest:
    """Whether an expression is identically zero, whether algebra decided it (``exact``)
    and the evidence (``how``): "identical", "expanded", "cancelled" or the numeric
    check's points and largest relative value."""

    holds: bool
    exact: bool
    how: str


def _size(e) -> int:
    try:
        return int(sp.count_ops(e, visual=False))
    except Exception:  # pragma: no cover - count_ops of an odd object
        return CANCEL_LIMIT + 1


def is_identically_zero(expr, *, scale=(), seed: int = 0, rtol: float | None = None) -> ZeroTest:
    """Decide ``expr ≡ 0`` (see the module docstring).

    ``scale``: the expressions ``expr`` is the difference of (their size makes the
    numeric check relative). ``seed`` varies the random points. ``rtol``: the relative
    size that counts as zero in the numeric check (default :data:`NUMERIC_RTOL`; a float
    design passes its own tolerance).
    """
    e = sp.sympify(expr)
    if e == 0:
        return ZeroTest(True, True, "identical")
    ex = sp.expand(e, **EXPAND_HINTS)
    if ex == 0:
        return ZeroTest(True, True, "expanded")
    if _size(ex) <= CANCEL_LIMIT:
        try:
            c = sp.cancel(sp.together(ex))
        except (sp.PolynomialError, NotImplementedError, TypeError):  # pragma: no cover
            c = None
        if c == 0:
            return ZeroTest(True, True, "cancelled")
    return _numeric(ex, scale, seed, NUMERIC_RTOL if rtol is None else rtol)


def _numeric(e, scale, seed: int, rtol: float) -> ZeroTest:
    """The numeric fallback: abs(e) relative to the size of ``scale`` at random rational points."""
    syms = sorted(e.free_symbols | set().union(*[sp.sympify(s).free_symbols for s in scale]),
                  key=str)
    rng = random.Random(f"{seed}:{len(syms)}")
    worst = 0.0
    used = 0
    for _ in range(4 * POINTS):
        if used == POINTS:
            break
        point = {}
        for s in syms:
            q = rng.choice((7, 11, 13, 16, 17))
            point[s] = sp.Rational(rng.randint(-(-q // 8), 3 * q), q)
        try:
            val = complex(e.xreplace(point).evalf(DIGITS))
            size = 1.0 + sum(abs(complex(sp.sympify(s).xreplace(point).evalf(DIGITS)))
                             for s in scale)
        except (TypeError, ValueError, ZeroDivisionError, OverflowError):
            continue
        if val != val or size != size or size == float("inf"):  # NaN or oo: not defined here
            continue
        used += 1
        worst = max(worst, abs(val) / size)
    where = f"{used} random rational points, {DIGITS} digits"
    if used < MIN_POINTS:
        return ZeroTest(False, False, f"undecided: defined at only {used} of {4 * POINTS}"
                                      " random rational points")
    return ZeroTest(worst <= rtol, False,
                    f"numeric: {where}, largest relative value {worst:.1e}")
