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

__all__ = ["SignAlternative", "gordan_alternative"]

#: a float LP value above this margin is taken as "A x > 0 is feasible" and then verified
_MARGIN = 1e-9

#: largest denominator tried when rationalising a float solution
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


def _verified_x(A: sp.Matrix, x_float) -> sp.Matrix | None:
    scale = float(np.max(np.abs(x_float))) or 1.0
    for den in _DENOMINATORS:
        x = sp.Matrix([_rational(v / scale, den) for v in x_float])
        if all(e > 0 for e in A * x):
            return x
    return None


def _verified_y(A: sp.Matrix, y_float) -> sp.Matrix | None:
    """y from the float vertex: exact on its support S (Aᵀ_S y_S = 0, Σ y_S = 1), the
    free part (a degenerate vertex) set from the float values; then checked exactly."""
    support = [i for i, v in enumerate(y_float) if v > _MARGIN * max(1.0, max(y_float))]
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


def gordan_alternative(A) -> SignAlternative:
    """Decide, with an exact certificate, whether some x has every entry of A x > 0.

    Two float linear programmes (scipy's HiGHS): maximise t with A x ≥ t, |x| ≤ 1, t ≤ 1;
    if t > 0 the x is rationalised and A x > 0 checked exactly. Otherwise a vertex of
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
    Af = np.array(A.tolist(), dtype=float)
    norms = np.linalg.norm(Af, axis=1)
    Ascaled = Af / np.where(norms > 0, norms, 1.0)[:, None]  # rows scaled: the same signs
    N, K = Af.shape
    res = linprog(np.r_[np.zeros(K), -1.0], A_ub=np.c_[-Ascaled, np.ones(N)],
                  b_ub=np.zeros(N), bounds=[(-1.0, 1.0)] * K + [(None, 1.0)],
                  method="highs")
    if res.status == 0 and -res.fun > _MARGIN:
        x = _verified_x(A, res.x[:K])
        if x is not None:
            return SignAlternative(x, None)
    res = linprog(np.zeros(N), A_eq=np.r_[Ascaled.T, np.ones((1, N))],
                  b_eq=np.r_[np.zeros(K), 1.0], bounds=[(0.0, None)] * N, method="highs")
    if res.status == 0:
        # y for the scaled rows; the same support solves the unscaled system exactly
        y = _verified_y(A, res.x / np.where(norms > 0, norms, 1.0))
        if y is not None:
            return SignAlternative(None, y)
    return SignAlternative(None, None)
