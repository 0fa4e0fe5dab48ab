"""Gordan's alternative over the rationals: either some x has A x > 0 (every entry), or
some y ≥ 0, y ≠ 0 has yᵀ A = 0 — never both (yᵀ A x would be 0 and > 0 at once).

The search is a floating-point linear programme; whichever side it finds is rebuilt in
exact rationals and verified exactly, so the answer is a certificate, not a float
verdict. When neither side can be verified (a degenerate programme) the answer is
undecided and says so."""
from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np
import sympy as sp

__all__ = ["SignAlternative", "gordan_alternative", "positive_combination"]

#: a float LP value above this margin is taken as "A x > 0 is feasible" and then verified
_MARGIN = 1e-12

#: a float y_i above this (relative to the largest) is in the certificate's support
_SUPPORT = 1e-9

#: scales (largest denominators) tried when rounding a float solution to exact numbers
_DENOMINATORS = (10 ** 3, 10 ** 6, 10 ** 9, 10 ** 12)


@dataclasses.dataclass(frozen=True)
class SignAlternative:
    """The two sides of Gordan's alternative for a rational matrix A (N × K).

    ``x``: a rational column with every entry of A x > 0 (verified), or None;
    ``y``: a rational column, y ≥ 0, y ≠ 0, with yᵀ A = 0 (verified), or None — the proof
    that no x has A x > 0; at most one of them is set, neither when undecided."""

    x: sp.Matrix | None
    y: sp.Matrix | None

    @property
    def feasible(self) -> bool:
        """Some x has A x > 0 (verified exactly)."""
        return self.x is not None

    @property
    def infeasible(self) -> bool:
        """No x has A x > 0 (the certificate y verified exactly)."""
        return self.y is not None


def _rational(v: float, den: int) -> sp.Rational:
    f = Fraction(float(v)).limit_denominator(den)
    return sp.Rational(f.numerator, f.denominator)


def _verified_y(A: sp.Matrix, y_float) -> sp.Matrix | None:
    """y from the float vertex: exact on its support S (Aᵀ_S y_S = 0, Σ y_S = 1), the
    free part (a degenerate vertex) set from the float values; then checked exactly."""
    support = [i for i, v in enumerate(y_float) if v > _SUPPORT * max(1.0, max(y_float))]
    if not support:
        return None
    N = len(support)
    system = sp.Matrix.vstack(A[support, :].T, sp.ones(1, N))
    rhs = sp.Matrix([0] * A.cols + [1])
    try:
        sol, params = system.gauss_jordan_solve(rhs)
    except ValueError:  # no exact solution on this support
        return None
    for den in _DENOMINATORS:
        values = {p: _rational(0.0, den) for p in params}
        if params:  # fit the free parameters to the float vertex by least squares
            base = np.array([float(e) for e in sol.subs({p: 0 for p in params})])
            cols = np.array([[float(sp.diff(e, p)) for p in params] for e in sol])
            coef, *_ = np.linalg.lstsq(cols, np.asarray(y_float)[support] - base, rcond=None)
            values = {p: _rational(c, den) for p, c in zip(params, coef)}
        y_s = sol.subs(values)
        if all(e >= 0 for e in y_s):
            y = sp.zeros(A.rows, 1)
            for i, e in zip(support, y_s):
                y[i] = e
            if (y.T * A).is_zero_matrix and not y.is_zero_matrix:
                return y
        if not params:
            break
    return None


def _exact(v):
    """An int stays an int (fast exact sums); other rationals become Fractions."""
    if isinstance(v, (int, sp.Integer)):
        return int(v)
    return Fraction(int(v.p), int(v.q)) if isinstance(v, sp.Rational) else Fraction(v)


def positive_combination(rows, *, linprog=None) -> tuple | None:
    """Integer weights c with Σ_j c_j a_ij > 0 for every row a_i of ``rows`` (sequences of
    ints, Fractions or sympy Rationals, all of one length K ≥ 1), or None when none is
    found. The search is a float linear programme on the rows scaled to unit length
    (maximise t with a_i·x ≥ t, ``|x|`` ≤ 1, t ≤ 1); an x with t > 0 is rounded to integers
    and every a_i·c > 0 is checked exactly. None is no proof that no c exists
    (:func:`gordan_alternative` gives one). ``linprog``: scipy's, when the caller has it.

    Examples
    --------
    >>> from observer_cad.numerics import positive_combination
    >>> c = positive_combination([[1, 1], [-1, 2]])
    >>> all(sum(ci * ai for ci, ai in zip(c, row)) > 0 for row in ([1, 1], [-1, 2]))
    True
    >>> positive_combination([[1], [-1]]) is None
    True
    """
    exact = [[_exact(v) for v in row] for row in rows]
    if not exact:
        return None
    if len(exact[0]) == 1:  # one weight: the signs decide
        signs = {(row[0] > 0) - (row[0] < 0) for row in exact}
        return (signs.pop(),) if len(signs) == 1 and 0 not in signs else None
    if linprog is None:
        from scipy.optimize import linprog  # lazy: scipy costs ~0.3 s to import
    Af = np.array([[float(v) for v in row] for row in exact])
    norms = np.linalg.norm(Af, axis=1)
    if np.any(norms == 0):
        return None
    N, K = Af.shape
    res = linprog(np.r_[np.zeros(K), -1.0], A_ub=np.c_[-Af / norms[:, None], np.ones(N)],
                  b_ub=np.zeros(N), bounds=[(-1.0, 1.0)] * K + [(None, 1.0)],
                  method="highs")
    if res.status != 0 or -res.fun <= _MARGIN:
        return None
    for scale in _DENOMINATORS:
        c = tuple(int(round(x * scale)) for x in res.x[:K])
        if all(sum(ci * v for ci, v in zip(c, row)) > 0 for row in exact):
            return c
    return None


def gordan_alternative(A) -> SignAlternative:
    """Decide, with an exact certificate, whether some x has every entry of A x > 0.

    Two float linear programmes (scipy's HiGHS): :func:`positive_combination` (an integer x
    with A x > 0, checked exactly); when it finds none, a vertex of
    {y ≥ 0, Σ y = 1, Aᵀ y = 0} is found, solved exactly on its support and checked
    exactly. ``A`` must be rational; an empty A (no rows) is trivially feasible."""
    from scipy.optimize import linprog  # lazy: scipy costs ~0.3 s to import

    A = sp.Matrix(A)
    if A.rows == 0:
        return SignAlternative(sp.zeros(A.cols, 1), None)
    if A.cols == 0:  # A x = () has no entry > 0 … but A has rows: every y ≥ 0 works
        return SignAlternative(None, sp.Matrix([1] + [0] * (A.rows - 1)))
    if not all(e.is_Rational for e in A):
        raise ValueError("gordan_alternative needs a rational matrix")
    c = positive_combination(A.tolist(), linprog=linprog)
    if c is not None:
        return SignAlternative(sp.Matrix(c), None)
    Af = np.array(A.tolist(), dtype=float)
    norms = np.linalg.norm(Af, axis=1)
    Ascaled = Af / np.where(norms > 0, norms, 1.0)[:, None]  # rows scaled: the same signs
    N, K = Af.shape
    res = linprog(np.zeros(N), A_eq=np.r_[Ascaled.T, np.ones((1, N))],
                  b_eq=np.r_[np.zeros(K), 1.0], bounds=[(0.0, None)] * N, method="highs")
    if res.status == 0:
        # y for the scaled rows; the same support solves the unscaled system exactly
        y = _verified_y(A, res.x / np.where(norms > 0, norms, 1.0))
        if y is not None:
            return SignAlternative(None, y)
    return SignAlternative(None, None)
