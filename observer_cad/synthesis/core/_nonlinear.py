"""Argument substitution for the nonlinear terms (METHOD §2c; seed 002 §6).

For every nonzero column j of C* = Φ C the argument A_j x must be recoverable from the
reduced state and the outputs: rank [Φ; H] = rank [Φ; H; A_j]; then
A_j = A*_1j Φ + A*_2j H and Ψ*_j = φ_j(A*_1j x* + A*_2j y, u).
"""
from __future__ import annotations

import sympy as sp

from ._values import NonlinearSubstitution
from ...model import Structure
from ...numerics import exact_rank, solve_left

__all__ = ["substitute_arguments"]


def substitute_arguments(st: Structure, Phi, xs, ys):
    """``(ok, why, identities, substitutions)`` for the rows Φ.

    ``identities`` are ``(j, A_j, A*_1j, A*_2j)`` for the certificate; ``substitutions``
    the :class:`NonlinearSubstitution` values, one per nonzero column of C*.
    """
    if not st.terms:
        return True, "", [], []
    Phi = sp.Matrix(Phi)
    H = sp.Matrix(st.H)
    k = Phi.rows
    Cs = (Phi * sp.Matrix(st.C)).applyfunc(sp.cancel)
    PH = sp.Matrix.vstack(Phi, H)
    rPH = exact_rank(PH).rank
    idents, subs = [], []
    for j, t in enumerate(st.terms):
        if Cs[:, j] == sp.zeros(k, 1):
            continue
        A = sp.Matrix(t.row)
        r = exact_rank(sp.Matrix.vstack(PH, A)).rank
        if r != rPH:
            return False, (f"nonlinear term {j + 1}: rank [Φ; H] = {rPH} < rank [Φ; H; A_{j + 1}]"
                           f" = {r} (its argument is not recoverable)"), [], []
        X = solve_left(PH, A)
        A1, A2 = X[:, :k], X[:, k:]
        arg = sp.expand((A1 * sp.Matrix(xs))[0, 0] + (A2 * sp.Matrix(ys))[0, 0])
        idents.append((j + 1, A, A1, A2))
        subs.append(NonlinearSubstitution(j + 1, t.function.xreplace({t.argument: arg}), arg, A1, A2))
    return True, "", idents, subs
