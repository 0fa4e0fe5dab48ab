"""Matrices of algebraic numbers in QQ(θ) (``_algebraic_domain_matrix``, ``exact_product``):
the same numbers as sympy's own conversion, the same ranks, powers and inverses as
arithmetic rather than new generators, and products that are exactly zero when the value is.

The oracle is independent of the code under test: every entry is compared with the sympy
expression it came from at 40 digits, ranks with sympy's ``from_Matrix(extension=True)``
(which builds its own primitive element), products with ``cancel`` of the sympy product.
"""
import random

import pytest

import sympy as sp
from sympy import CRootOf, sqrt
from sympy.polys.matrices import DomainMatrix

from observer_cad.numerics import exact_product, exact_rank_value
from observer_cad.numerics import _linalg

x = sp.Symbol("x")
A = CRootOf(x**3 - 3 * x - 1, 0)
B = CRootOf(x**3 - 3 * x - 1, 2)
ATOMS = [A, B, sqrt(2), A**2, 1 / A, A * B, sqrt(3), 1 / (1 + sqrt(2)), A**-2]


def _random_matrix(rng, r, c):
    M = sp.Matrix(r, c, lambda i, j: sp.Rational(rng.randint(-3, 3), rng.randint(1, 3))
                  * rng.choice(ATOMS) + rng.randint(-2, 2))
    if r > 1 and rng.random() < 0.5:  # a dependent row: the rank drops
        M[r - 1, :] = M[0, :] * rng.choice(ATOMS)
    return M


@pytest.mark.slow
def test_same_numbers_and_ranks_as_sympy():
    rng = random.Random(1)
    drops = 0
    for _ in range(12):
        M = _random_matrix(rng, rng.randint(2, 4), rng.randint(1, 4))
        dm = _linalg._algebraic_domain_matrix(M)
        assert dm is not None
        for got, want in zip(dm.to_Matrix(), M):
            assert abs(complex(sp.N(got - want, 40))) < 1e-30
        ref = DomainMatrix.from_Matrix(M, extension=True).to_field().rank()
        assert dm.rank() == ref == exact_rank_value(M)
        drops += ref < min(M.shape)
    assert drops >= 3  # the dependent rows were exercised


def test_powers_and_inverses_are_arithmetic_not_generators():
    M = sp.Matrix([[A, A**2, 1 / A], [A**-2, A**3, 1]])
    K = _linalg._algebraic_domain_matrix(M).domain
    assert K.orig_ext == (A,) and K.mod.degree() == 3  # QQ(A): one generator, degree 3
    # the field of a set of numbers is built once
    _linalg._algebraic_field.cache_clear()
    _linalg._algebraic_domain_matrix(M)
    _linalg._algebraic_domain_matrix(M.T)
    assert _linalg._algebraic_field.cache_info().hits == 1


@pytest.mark.slow
def test_exact_product_matches_cancel_and_is_zero_exactly():
    rng = random.Random(2)
    for _ in range(4):
        P = _random_matrix(rng, 2, 3)
        Q = _random_matrix(rng, 3, 2)
        got = exact_product(P, Q)
        want = (P * Q).applyfunc(sp.cancel)
        for g, w in zip(got, want):
            assert abs(complex(sp.N(g - w, 40))) < 1e-30
    # a left null vector of an algebraic matrix gives an exact zero row, not a tiny sum
    N = sp.Matrix([[A, B], [A**2, A * B]])  # row 2 = A · row 1
    c = sp.Matrix([[A, -1]])
    assert exact_product(c, N) == sp.zeros(1, 2)
    # rational and symbolic matrices keep their paths
    assert exact_product(sp.Matrix([[sp.Rational(1, 2), 1]]), sp.Matrix([[2], [3]])) == \
        sp.Matrix([[4]])
    a = sp.Symbol("a")
    assert exact_product(sp.Matrix([[a, 1]]), sp.Matrix([[1 / a], [-1]])) == sp.Matrix([[0]])


def test_pivot_cost_factors_are_the_conditions_recorded():
    """The pivot cost compares an entry's factors, computed in its domain, with the
    conditions already assumed; they must be the factors ``nonzero_conditions`` records.
    Over the rationals they are (random products of polynomials in two parameters); over
    an algebraic ground field, where k² − 2 would split, the cost falls back to
    ``nonzero_conditions`` itself (None)."""
    from observer_cad.numerics import nonzero_conditions

    k, m = sp.symbols("k m")
    rng = random.Random(5)
    pieces = [k**2 - 2, k + 1, -k + 3 * m, k * m - 1, m**2 + k, 2 * k]
    for _ in range(12):
        num = sp.Mul(*rng.sample(pieces, 3)) * rng.choice([1, -3, sp.Rational(2, 5)])
        den = rng.choice([1, k + 7, m**2 + 1])
        want = {c.lhs for c in nonzero_conditions(num / den)}
        ring = sp.QQ[k, m]
        field = sp.QQ.frac_field(k, m)
        if den == 1:
            assert _linalg._factors_in_domain(ring, ring.from_sympy(sp.expand(num))) == want
        assert _linalg._factors_in_domain(field, field.from_sympy(num / den)) == want
    K = sp.QQ.algebraic_field(sqrt(2))[k]
    assert _linalg._factors_in_domain(K, K.from_sympy(k**2 - 2)) is None
    assert nonzero_conditions(k**2 - 2) == {sp.Ne(k**2 - 2, 0)}
