"""Parity: the fast rational path (FLINT ``fmpq_mat`` / sympy ``DomainMatrix.rref``) gives
the same exact rationals as the hand-written Gauss–Jordan elimination it replaced.

The reference functions below are the previous implementations, verbatim, on top of
``_gauss_jordan`` (still the elimination for matrices with parameters). Matrices are drawn
by hypothesis: rank-deficient ones (repeated and combined rows), zero rows and columns,
large numerators and denominators.
"""
import hashlib

import pytest
import sympy as sp
from hypothesis import given, settings, strategies as st

from observer_cad import numerics
from observer_cad.numerics import _linalg


# ---------------------------------------------------------------- the previous code
def old_exact_rank(M):
    M = sp.Matrix(M)
    if M.rows == 0 or M.cols == 0:
        return 0, (), M
    K, rows, pivots, _ = _linalg._gauss_jordan(_linalg.to_domain_matrix(M), set(), full=True)
    return len(pivots), pivots, sp.Matrix([[K.to_sympy(v) for v in row] for row in rows])


def old_left_null_space(M):
    M = sp.Matrix(M)
    m = M.rows
    if M.cols == 0:
        return [sp.Matrix([[1 if j == i else 0 for j in range(m)]]) for i in range(m)]
    K, rows, pivots, _ = _linalg._gauss_jordan(_linalg.to_domain_matrix(M.T), set(), full=True)
    basis = []
    for f in range(m):
        if f in pivots:
            continue
        v = [K.zero] * m
        v[f] = K.one
        for i, p in enumerate(pivots):
            v[p] = K.neg(rows[i][f])
        basis.append(sp.Matrix([[sp.cancel(K.to_sympy(e)) for e in v]]))
    return basis


def old_echelon_rows(vectors):
    if not vectors:
        return []
    K, rows, pivots, _ = _linalg._gauss_jordan(_linalg.to_domain_matrix(sp.Matrix.vstack(*vectors)))
    return [sp.Matrix([[sp.cancel(K.to_sympy(e)) for e in rows[i]]]) for i in range(len(pivots))]


def old_solve_left(A, B):
    A, B = sp.Matrix(A), sp.Matrix(B)
    K, rows, pivots, _ = _linalg._gauss_jordan(_linalg.to_domain_matrix(sp.Matrix.hstack(A.T, B.T)))
    na = A.rows
    if any(p >= na for p in pivots):
        return None
    X = sp.zeros(B.rows, na)
    for i, p in enumerate(pivots):
        for j in range(B.rows):
            X[j, p] = sp.cancel(K.to_sympy(rows[i][na + j]))
    return X


# ---------------------------------------------------------------- random matrices
_entry = st.one_of(
    st.just(sp.Integer(0)),
    st.builds(sp.Rational, st.integers(-3, 3), st.integers(1, 4)),
    st.builds(sp.Rational, st.integers(-10**30, 10**30), st.integers(1, 10**12)),
)


@st.composite
def rational_matrices(draw, max_rows=7, max_cols=7):
    r = draw(st.integers(0, max_rows))
    c = draw(st.integers(0, max_cols))
    M = sp.Matrix(r, c, draw(st.lists(_entry, min_size=r * c, max_size=r * c)))
    if r >= 2 and c and draw(st.booleans()):  # a dependent row: rank deficiency
        a, b = draw(st.integers(0, r - 1)), draw(st.integers(0, r - 1))
        M[draw(st.integers(0, r - 1)), :] = 3 * M[a, :] - sp.Rational(1, 7) * M[b, :]
    return M


def _same(a, b):
    """Equal as exact rationals, entry by entry, and of the same sympy types."""
    assert a.shape == b.shape
    for x, y in zip(a, b):
        assert x == y and type(x) is type(y), (x, y)


SETTINGS = dict(max_examples=150, deadline=None, derandomize=True)


@settings(**SETTINGS)
@given(rational_matrices())
def test_rank_and_reduced_form_identical(M):
    rank, pivots, R = old_exact_rank(M)
    new = numerics.exact_rank(M)
    assert (new.rank, new.pivots, new.conditions) == (rank, pivots, frozenset())
    _same(new.reduced, R)
    assert numerics.exact_rank_value(M) == rank


@settings(**SETTINGS)
@given(rational_matrices())
def test_left_null_space_identical(M):
    old = old_left_null_space(M)
    new, _ = numerics.left_null_space(M)
    assert len(new) == len(old)
    for a, b in zip(new, old):
        _same(a, b)
    # one elimination gives the echelon basis of two
    ech, rk = numerics.left_null_echelon(M)
    ref = old_echelon_rows(old)
    assert len(ech) == len(ref)
    for a, b in zip(ech, ref):
        _same(a, b)
    assert rk.rank == old_exact_rank(M)[0]
    if M.rows:
        N = numerics.rational_left_null(numerics.as_rational(M))
        assert [numerics.from_rational(N[i:i + 1, :]) for i in range(N.shape[0])] == ref


@settings(**SETTINGS)
@given(rational_matrices(max_rows=5), rational_matrices(max_rows=3))
def test_echelon_rows_and_solve_left_identical(A, B):
    rows = [A[i, :] for i in range(A.rows)]
    if A.cols:
        for a, b in zip(numerics.echelon_rows(rows), old_echelon_rows(rows)):
            _same(a, b)
        assert len(numerics.echelon_rows(rows)) == len(old_echelon_rows(rows))
    if A.rows and A.cols and B.rows and B.cols == A.cols:
        X, Y = numerics.solve_left(A, B), old_solve_left(A, B)
        assert (X is None) == (Y is None)
        if X is not None:
            _same(X, Y)
            assert X * A == B


def test_full_rank_modulo_the_prime_is_not_trusted_when_it_fails():
    """A matrix singular modulo 2⁶¹ − 1 but regular over QQ: the rank is still exact."""
    p = 2 ** 61 - 1
    M = sp.Matrix([[p, 0], [0, 1]])
    assert numerics.exact_rank_value(M) == 2
    assert numerics.exact_rank_value(sp.Matrix([[1, 2], [2, 4]])) == 1
    assert numerics.exact_rank_value(sp.Matrix([[sp.Rational(1, p), 1], [1, p]])) == 1


@pytest.mark.parametrize("backend", ["flint", "sympy-CD"])
def test_both_backends_give_the_same_reduced_form(backend, monkeypatch):
    if backend == "flint" and numerics.RATIONAL_BACKEND != "flint":
        pytest.skip("sympy's ground types are not flint (python-flint not installed)")
    monkeypatch.setattr(_linalg, "RATIONAL_BACKEND", backend)
    M = sp.Matrix(6, 9, [sp.Rational((7 * i * i - 5 * i + 3) % 23 - 11, 1 + i % 5) for i in range(54)])
    M[5, :] = M[0, :] - 2 * M[3, :]
    R, pivots = numerics.rational_rref(M)
    rank, old_pivots, old_R = old_exact_rank(M)
    assert pivots == old_pivots and len(pivots) == 5
    _same(numerics.from_rational(R), old_R)


def _digest(design) -> str:
    return hashlib.sha1(repr(sorted((k, str(v)) for k, v in design.matrices.items()
                                    if v is not None)).encode()).hexdigest()


@pytest.mark.parametrize("n,k,digest", [
    (20, 2, "ac8f3452b37d5ca9c017b85b7a14e59b57c414dc"),
    (40, 6, "15b85ee964f15493def3a65338556cd99c3155dd"),
    pytest.param(60, 9, "13c3967385fa24adef713d3a7292661f81485962", marks=pytest.mark.slow),
])
def test_random_exact_design_matrices_unchanged(n, k, digest):
    """The exact canonical design of a dense-rational random plant: the same matrices as
    the hand-written elimination gave (digest recorded with it, main at 6cfb86b)."""
    from observer_cad import design_canonical
    from observer_cad.model import random_model

    model = random_model(n, 8, 1, seed=0, integer=False)
    d = design_canonical(model, unknown_input="d", symbolic=True, method="exact")
    assert d.k == k
    assert _digest(d) == digest
