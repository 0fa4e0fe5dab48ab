"""GrowingLeftNull: the left null space of a matrix grown by rows on top, without
eliminating the grown matrix, is exactly the one eliminated from scratch.

Every grown state is compared with :func:`rational_left_null` of the grown matrix (the
reduced echelon basis is unique, so the rows must be identical) and its rank with a
Fraction elimination (tests/oracle.py). The state's own invariants are checked too: its
rows are independent, M[B, C] is nonsingular, the kernel annihilates M and is the
identity on ``kernel_columns``. Each test also asserts which path ``grow`` took (a state
with a kernel comes from the incremental path), so that the comparisons cannot pass by
the from-scratch fallback alone.
"""
import random
from fractions import Fraction

import pytest
import sympy as sp
from hypothesis import given, settings, strategies as st
from sympy.polys.matrices import DomainMatrix

from observer_cad.errors import DimensionError
from observer_cad.numerics import GrowingLeftNull, _linalg, rational_left_null

from oracle import frac_rank

QQ = sp.QQ


def dm(rows, ncols=None):
    ncols = len(rows[0]) if rows else ncols
    return DomainMatrix([[QQ(int(v.numerator), int(v.denominator)) for v in r] for r in rows],
                        (len(rows), ncols), QQ).to_dense()


def fractions(M):
    return [[Fraction(int(v.numerator), int(v.denominator)) for v in row] for row in M.to_list()]


def grown(M, top, at, width):
    """The grown matrix written out directly (lists)."""
    rows = [list(r) for r in fractions(top)]
    for r in fractions(M):
        rows.append(r[:at] + [Fraction(0)] * width + r[at:])
    return rows


def check_state(state, rows):
    """state against the from-scratch answers for the matrix ``rows`` (lists of Fractions)."""
    M = dm(rows, state.matrix.shape[1])
    assert state.matrix.to_list() == M.to_list()
    ref = rational_left_null(M)
    assert state.null.shape == ref.shape and state.null.to_list() == ref.to_list()
    rank = frac_rank(rows)
    assert state.rank == rank
    m, c = state.matrix.shape
    assert state.null.shape == (m - rank, m)
    assert frac_rank([rows[i] for i in state.rows]) == rank  # B: independent rows
    if state.kernel is not None:
        C = state.columns
        assert len(C) == rank
        assert frac_rank([[rows[i][j] for j in C] for i in state.rows]) == rank
        K = fractions(state.kernel)
        assert len(K) == c - rank
        for z, q in zip(K, state.kernel_columns):
            assert all(sum(r[j] * z[j] for j in range(c)) == 0 for r in rows)
            assert [z[j] for j in state.kernel_columns] == [int(j == q) for j in state.kernel_columns]


def random_rows(rng, r, c, lo=-3, hi=3, density=1.0):
    return [[Fraction(rng.randint(lo, hi), rng.randint(1, 3)) if rng.random() < density
             else Fraction(0) for _ in range(c)] for _ in range(r)]


def combination(rng, rows, at, width, c):
    """A row of the grown matrix's top that starts a null vector: a combination of the old
    rows (zeros inserted), so that (−1, coefficients) annihilates the grown matrix."""
    a = [Fraction(rng.randint(-2, 2)) for _ in rows]
    row = [sum(ai * r[j] for ai, r in zip(a, rows)) for j in range(c)]
    return row[:at] + [Fraction(0)] * width + row[at:]


# ---------------------------------------------------------------- each path of grow
@pytest.mark.parametrize("backend", ["flint", "sympy-CD"])
def test_incremental_with_an_empty_kernel(backend, monkeypatch):
    """Full column rank with a null space: the new rows reduce against nothing, the new
    null vectors need the solve with M[B, C] (FLINT's, or the reduced form of (A B))."""
    if backend == "flint" and _linalg.RATIONAL_BACKEND != "flint":
        pytest.skip("sympy's ground types are not flint (python-flint not installed)")
    monkeypatch.setattr(_linalg, "RATIONAL_BACKEND", backend)
    rng = random.Random(1)
    rows = random_rows(rng, 7, 4)
    state = GrowingLeftNull.of(dm(rows))
    check_state(state, rows)
    for step in range(4):
        top = random_rows(rng, 3, 4 + step + 1)
        new = grown(state.matrix, dm(top), 2, 1)
        state = state.grow(dm(top), at=2, width=1)
        assert state.kernel is not None and state.kernel.shape[0] == 0
        check_state(state, new)


def test_incremental_with_a_kernel():
    """A zero column (as when H L = 0) keeps a kernel of one vector: the new rows are
    reduced against it."""
    rng = random.Random(2)
    rows = [r + [Fraction(0)] for r in random_rows(rng, 5, 4)]
    state = GrowingLeftNull.of(dm(rows))
    assert state.null.shape[0] == 1
    for step in range(4):
        c = state.matrix.shape[1]
        top = random_rows(rng, 2, c)
        top = [r[:c - 1] + [Fraction(0)] + r[c - 1:] for r in top]  # a zero inserted column
        new = grown(state.matrix, dm(top), c - 1, 1)
        state = state.grow(dm(top), at=c - 1, width=1)
        assert state.kernel is not None and state.kernel.shape[0] == 1
        check_state(state, new)


def test_new_rows_in_the_row_space_and_independent_ones():
    """Some new rows are combinations of the old (null vectors starting in them), some are
    not (they join B); the kernel shrinks as they are added."""
    rng = random.Random(3)
    rows = random_rows(rng, 4, 6)
    rows.append([a + b for a, b in zip(rows[0], rows[1])])  # a null vector, kernel of 2
    state = GrowingLeftNull.of(dm(rows))
    assert state.null.shape[0] == 1 and state.rank == 4
    c = 6
    top = [combination(rng, fractions(state.matrix), 3, 2, c)] + random_rows(rng, 1, c + 2)
    new = grown(state.matrix, dm(top), 3, 2)
    state = state.grow(dm(top), at=3, width=2)
    assert state.kernel is not None
    check_state(state, new)
    assert state.null.shape[0] == 2 and state.rank == 5


def test_restarts_from_scratch_without_a_null_space_or_with_a_large_kernel():
    rng = random.Random(4)
    rows = random_rows(rng, 3, 8)  # full row rank: nothing to reuse
    state = GrowingLeftNull.of(dm(rows))
    assert state.null.shape[0] == 0
    top = random_rows(rng, 2, 9)
    new = grown(state.matrix, dm(top), 8, 1)
    state = state.grow(dm(top), at=8, width=1)
    assert state.kernel is None
    check_state(state, new)
    rows = random_rows(rng, 3, 8)
    rows.append(rows[0])  # a null space, but a kernel of 5 vectors > width 1
    state = GrowingLeftNull.of(dm(rows))
    top = random_rows(rng, 2, 9)
    new = grown(state.matrix, dm(top), 0, 1)
    state = state.grow(dm(top), at=0, width=1)
    assert state.kernel is None
    check_state(state, new)


def test_degenerate_shapes():
    empty = GrowingLeftNull.of(DomainMatrix.zeros((0, 3), QQ))
    assert empty.null.shape == (0, 0) and empty.rank == 0
    no_cols = GrowingLeftNull.of(DomainMatrix.zeros((2, 0), QQ))
    assert no_cols.null == DomainMatrix.eye(2, QQ).to_dense() and no_cols.rank == 0
    state = no_cols.grow(dm([[Fraction(1)]]), at=0, width=1)
    assert state.kernel is not None
    check_state(state, [[Fraction(1)], [Fraction(0)], [Fraction(0)]])
    zero = GrowingLeftNull.of(DomainMatrix.zeros((2, 2), QQ))
    state = zero.grow(dm([[Fraction(0)] * 3]), at=1, width=1)
    check_state(state, [[Fraction(0)] * 3] * 3)
    with pytest.raises(DimensionError, match="new rows have 2 columns, expected 2 \\+ width 1"):
        zero.grow(dm([[Fraction(1)] * 2]), at=1, width=1)
    with pytest.raises(DimensionError, match="at = 3"):
        zero.grow(dm([[Fraction(1)] * 3]), at=3, width=1)


# ---------------------------------------------------------------- random chains
@st.composite
def chains(draw):
    seed = draw(st.integers(0, 2 ** 32 - 1))
    rng = random.Random(seed)
    m, c = draw(st.integers(1, 6)), draw(st.integers(0, 6))
    kind = draw(st.sampled_from(["random", "dependent", "zero column"]))
    rows = random_rows(rng, m, c, density=draw(st.sampled_from([0.3, 1.0])))
    if kind == "dependent" and m >= 2:
        rows[-1] = [2 * a - b for a, b in zip(rows[0], rows[1])]
    if kind == "zero column" and c:
        for r in rows:
            r[-1] = Fraction(0)
    steps = []
    for _ in range(draw(st.integers(1, 3))):
        l, width = draw(st.integers(1, 3)), draw(st.integers(0, 2))
        at = draw(st.integers(0, c))
        top = random_rows(rng, l, c + width, density=draw(st.sampled_from([0.3, 1.0])))
        steps.append((top, at, width, draw(st.booleans())))
        c += width
    return rows, steps, rng


@settings(max_examples=200, deadline=None, derandomize=True)
@given(chains())
def test_random_chains_equal_the_elimination_from_scratch(chain):
    rows, steps, rng = chain
    state = GrowingLeftNull.of(dm(rows))
    check_state(state, rows)
    for top, at, width, dependent in steps:
        old = fractions(state.matrix)
        if dependent and old:  # a new row that starts a null vector
            top[0] = combination(rng, old, at, width, len(old[0]))
        new = grown(state.matrix, dm(top), at, width)
        state = state.grow(dm(top), at=at, width=width)
        check_state(state, new)
