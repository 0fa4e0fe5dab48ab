"""The exact / float strategies (``synthesis.core.arithmetic``): chosen once, with the same
methods, and agreeing on small random systems — the same ranks and null-space
dimensions, the same row spaces for the analysis, the same order k for a design."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from observer_cad.analysis import detecting_orders
from observer_cad.errors import UsageError
from observer_cad.model import random_model
from observer_cad.synthesis import design_canonical
from observer_cad.synthesis.core import (Arithmetic, ExactArithmetic, FloatArithmetic,
                                         RationalArithmetic, arithmetic, arithmetic_for,
                                         prepare)

METHODS = ("rank", "left_null_space", "product", "certify", "check_poles", "to_sympy",
           "threads", "mat", "zeros", "eye", "vstack", "hstack", "mul", "basis", "left_null",
           "sees")


def _deficient(seed: int, rows: int, cols: int, rank: int) -> sp.Matrix:
    """A random integer matrix of the given rank (a product of two full-rank factors)."""
    rng = np.random.default_rng(seed)
    A = sp.Matrix(rng.integers(-3, 4, size=(rows, rank)))
    B = sp.Matrix(rng.integers(-3, 4, size=(rank, cols)))
    return A * B


def _strategies():
    return [RationalArithmetic(), ExactArithmetic(), FloatArithmetic()]


def test_the_strategies_have_the_same_methods():
    for ar in _strategies():
        assert isinstance(ar, Arithmetic)
        assert all(callable(getattr(ar, m)) for m in METHODS), type(ar).__name__
        assert ar.method in ("exact", "float") and ar.exact == (ar.method == "exact")


def test_chosen_once_from_the_method_and_the_matrices():
    x = sp.Symbol("x")
    assert type(arithmetic("float", sp.eye(2))) is FloatArithmetic
    assert type(arithmetic("exact", sp.Matrix([[1, sp.Rational(1, 3)]]))) is RationalArithmetic
    sym = arithmetic("exact", sp.Matrix([[1, x]]))
    assert type(sym) is ExactArithmetic and sym.symbolic
    assert type(arithmetic("exact", sp.Matrix([[sp.sqrt(2)]]))) is ExactArithmetic


def test_chosen_once_for_a_prepared_problem():
    small = random_model(4, 2, 1, seed=0, time="discrete")
    assert type(arithmetic_for(prepare(small))) is ExactArithmetic
    assert type(arithmetic_for(prepare(small, method="float"), rtol=1e-7)) is FloatArithmetic
    assert arithmetic_for(prepare(small, method="float"), rtol=1e-7).rtol == 1e-7

    class Mine(ExactArithmetic):
        pass
    assert type(arithmetic_for(prepare(small), exact=Mine)) is Mine


@pytest.mark.parametrize("seed", range(6))
def test_exact_and_float_agree_on_ranks_and_null_spaces(seed):
    rng = np.random.default_rng(100 + seed)
    rows, cols = (int(v) for v in rng.integers(3, 7, size=2))
    r = int(rng.integers(1, min(rows, cols) + 1))
    M = _deficient(seed, rows, cols, r)
    for ar in _strategies():
        assert ar.rank(M) == r, type(ar).__name__
        N = ar.left_null_space(M)
        assert N.shape == (rows - r, rows), type(ar).__name__
        assert np.allclose(np.asarray(ar.product(N, M), dtype=float), 0.0, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_exact_and_float_agree_on_row_spaces(seed):
    """The analysis's representation: bases, annihilators, what a space sees."""
    M = _deficient(seed, 5, 4, 2)
    d_in = _deficient(seed + 50, 4, 1, 1)
    outcomes = []
    for ar in _strategies():
        conds: set = set()
        A = ar.mat(M)
        basis = ar.basis(A, conds)
        null = ar.left_null(A, conds)
        outcomes.append((basis.shape[0], null.shape[0], ar.sees(basis, ar.mat(d_in, "cols"), conds)))
    assert outcomes[0] == outcomes[1] == outcomes[2]
    assert outcomes[0][:2] == (2, 3)


def test_exact_records_the_conditions_a_symbolic_rank_needs():
    a = sp.Symbol("a")
    conds: set = set()
    assert ExactArithmetic(symbolic=True).rank(sp.Matrix([[a, 1], [1, 1]]), conds) == 2
    assert conds  # the pivot a − 1 ≠ 0 (or a ≠ 0) is recorded
    assert ExactArithmetic(symbolic=True).rank(sp.Matrix([[a, 1], [1, 1]])) == 2


@pytest.mark.parametrize("seed", range(3))
def test_detecting_orders_agree_exact_and_float(seed):
    model = random_model(5, 2, 1, seed=seed, time="discrete")
    st = prepare(model).structure
    exact, _ = detecting_orders(st.F, st.H, st.L, st.D, method="exact")
    floating, _ = detecting_orders(st.F, st.H, st.L, st.D, method="float")
    assert exact == floating


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_design_has_the_same_k_exact_and_float(seed):
    model = random_model(6, 3, 1, seed=seed, time="discrete")
    exact = design_canonical(model, unknown_input=model.faults[0].name, symbolic=False,
                             method="exact")
    floating = design_canonical(model, unknown_input=model.faults[0].name, symbolic=False,
                                method="float")
    assert (exact.method.value, floating.method.value) == ("exact", "float")
    assert exact.k == floating.k


def test_the_closed_loop_check_in_both_arithmetics():
    F, H = sp.Matrix([[0, 1], [0, 0]]), sp.Matrix([[1, 0]])
    K = sp.Matrix([3, 2])  # det(sI − F + K H) = s² + 3 s + 2 = (s + 1)(s + 2)
    ExactArithmetic.check_poles(F, H, K, [-1, -2])
    FloatArithmetic.check_poles(F, H, K, [-1, -2])
    with pytest.raises(UsageError, match="closed-loop eigenvalues"):
        FloatArithmetic.check_poles(F, H, K, [-1, -3])
