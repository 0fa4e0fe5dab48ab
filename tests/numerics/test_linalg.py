"""Exact linear algebra: ranks with their conditions, null spaces, solving."""
import random

import numpy as np
import sympy as sp

from observer_cad import numerics as linalg

from oracle import frac_rank


def test_rational_rank_matches_fraction_oracle():
    rng = random.Random(5)
    for _ in range(30):
        r, c = rng.randint(1, 7), rng.randint(1, 7)
        M = [[rng.randint(-2, 2) for _ in range(c)] for _ in range(r)]
        res = linalg.exact_rank(sp.Matrix(M))
        assert res.rank == frac_rank(M)
        assert res.conditions == frozenset()


def test_symbolic_rank_reports_its_conditions():
    a, b = sp.symbols("a b")
    M = sp.Matrix([[1, a], [0, b]])
    res = linalg.exact_rank(M)
    assert res.rank == 2
    assert res.conditions == {sp.Ne(b, 0)}
    # and the condition is real: at b = 0 the rank drops
    assert frac_rank(M.subs({a: 3, b: 0}).tolist()) == 1


def test_pivots_prefer_constants():
    a = sp.Symbol("a")
    M = sp.Matrix([[a, 1], [1, 0]])  # full rank for every a: no condition needed
    assert linalg.exact_rank(M).conditions == frozenset()


def test_left_null_space_members_annihilate():
    k1, k4, k5 = sp.symbols("k1 k4 k5")
    M = sp.Matrix([[1, k1, 0], [0, k4, k5], [1, 0, 0], [0, 0, 1]])
    basis, rk = linalg.left_null_space(M)
    assert rk.rank == 3 and len(basis) == 1
    assert (basis[0] * M).applyfunc(sp.cancel) == sp.zeros(1, 3)


def test_solve_left():
    a = sp.Symbol("a")
    A = sp.Matrix([[1, 0, 1], [0, a, 0]])
    X = linalg.solve_left(A, sp.Matrix([[2, 3, 2]]))
    assert (X * A - sp.Matrix([[2, 3, 2]])).applyfunc(sp.cancel) == sp.zeros(1, 3)
    assert linalg.solve_left(A, sp.Matrix([[1, 0, 0]])) is None


def test_nonzero_conditions_factors():
    k1, k2, k4 = sp.symbols("k1 k2 k4")
    assert linalg.nonzero_conditions(-k1 * (k2 + 1) / k4) == {sp.Ne(k1, 0), sp.Ne(k2 + 1, 0)}
    assert linalg.denominator_conditions(-k1 * (k2 + 1) / k4) == {sp.Ne(k4, 0)}
    assert linalg.nonzero_conditions(sp.Rational(3, 2)) == frozenset()


def test_float_rank_evidence():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((6, 3)) @ rng.standard_normal((3, 5))  # rank 3
    fr = linalg.float_rank(A)
    assert fr.rank == 3
    assert fr.gap > 1e8
    assert "σ_3" in fr.evidence() and "σ_4" in fr.evidence()
    N, fr2 = linalg.float_left_null_space(A)
    assert N.shape == (3, 6)
    assert np.linalg.norm(N @ A) < 1e-10
