"""Exact pole placement of F* − K H* (observer-form Ackermann, METHOD §3): reference gains,
properties on random pairs (one and several output rows), algebraic eigenvalues,
symbolic parameters, refusals, and the designers that call it.

Every check of a gain recomputes det(sI − F* + K H*) here with sympy's ``Matrix.charpoly``
on the returned sympy matrices, independently of the Ackermann code under test."""
from __future__ import annotations

import random

import pytest
import sympy as sp

from observer_cad import PlantModel
from observer_cad.errors import CertificateError, DimensionError, InfeasibleDesignError, UsageError
from observer_cad.observers import build_observer
from observer_cad.synthesis import (PLACEMENT_SEED, certify_poles, design, design_diagnostic_canonical,
                                    design_virtual_sensor_canonical, place_poles, pole_placement,
                                    target_polynomial)

s = sp.Symbol("s")


def shift(k):
    return sp.Matrix(k, k, lambda i, j: 1 if j == i + 1 else 0)


def e1(k):
    return sp.Matrix([[1] + [0] * (k - 1)])


def assert_placed(F, H, K, eigs):
    """The oracle: det(sI − F + K H) expanded equals Π(s − μ) expanded."""
    F, H, K = sp.Matrix(F), sp.Matrix(H), sp.Matrix(K)
    assert K.shape == (F.rows, H.rows)
    got = (F - K * H).charpoly(s).as_expr() if F.rows else sp.Integer(1)
    diff = sp.expand(got - sp.prod([s - mu for mu in eigs]))
    assert diff == 0 or sp.simplify(diff) == 0


# ---------------------------------------------------------------- reference gains
@pytest.mark.parametrize("k", [1, 2, 4, 6, 8, 12])
def test_shift_with_first_row_gives_the_polynomial_coefficients(k):
    """F* = shift, H* = e1ᵀ: F* − K e1ᵀ is the observable companion form, so
    det(sI − F* + K H*) = s^k + K1 s^{k−1} + … + Kk (Kailath §2.1): K = the coefficients."""
    eigs = [sp.Rational(1, 2 ** i) for i in range(1, k + 1)]
    K = place_poles(shift(k), e1(k), eigs)
    coeffs = sp.Poly(sp.prod([s - mu for mu in eigs]), s).all_coeffs()[1:]
    assert list(K) == coeffs
    assert_placed(shift(k), e1(k), K, eigs)


def test_two_state_reference_gain():
    """F = [[0, 1], [0, 0]], h = [1, 0]: s² + K1 s + K2 = (s + 1)(s + 2) → K = (3, 2)."""
    assert place_poles(sp.Matrix([[0, 1], [0, 0]]), sp.Matrix([[1, 0]]), [-1, -2]) == \
        sp.Matrix([3, 2])


def test_result_records_the_certificate():
    pp = pole_placement(shift(3), e1(3), [-1, -2, -3])
    assert pp.characteristic_polynomial == (1, 6, 11, 6)
    assert pp.combination is None and pp.preliminary is None
    assert pp.method == "Ackermann (one output row)"


# ---------------------------------------------------------------- random pairs
def _random_pair(rng, k, p, density=0.6):
    F = sp.Matrix(k, k, lambda i, j: sp.Rational(rng.randint(-4, 4), rng.randint(1, 3))
                  if rng.random() < density else 0)
    H = sp.Matrix(p, k, lambda i, j: rng.randint(-2, 2))
    return F, H


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("p", [1, 2, 3])
def test_random_pairs_are_placed_or_refused_as_unobservable(seed, p):
    """Never a raw sympy error: either the certified gain or 'not observable', and the
    refusal agrees with the rank of the observability matrix."""
    rng = random.Random(1000 * p + seed)
    k = rng.randint(2, 6)
    F, H = _random_pair(rng, k, p)
    eigs = [sp.Integer(-i) for i in range(1, k + 1)]
    O = sp.Matrix.vstack(*[H * F ** i for i in range(k)])
    if len(O.rref()[1]) < k:
        with pytest.raises(InfeasibleDesignError, match="not observable"):
            place_poles(F, H, eigs)
    else:
        assert_placed(F, H, place_poles(F, H, eigs), eigs)


def test_several_rows_use_one_row_when_it_is_observable():
    """H* with rows e3ᵀ (unobservable alone through the shift) and (1, 1, 0): the
    combination c = (0, 1) is taken, so K has one nonzero column."""
    F, H = shift(3), sp.Matrix([[0, 0, 1], [1, 1, 0]])
    pp = pole_placement(F, H, [-1, -2, -3])
    assert list(pp.combination) == [0, 1]
    assert pp.K[:, 0] == sp.zeros(3, 1)
    assert_placed(F, H, pp.K, [-1, -2, -3])


def test_non_cyclic_F_needs_a_preliminary_gain():
    """F* = 0 with H* = I (observable, but no single output row sees all of F*: F* is not
    cyclic) — the K₀ route of Heymann's lemma."""
    F, H = sp.zeros(3, 3), sp.eye(3)
    pp = pole_placement(F, H, [-1, -2, -3])
    assert pp.preliminary is not None
    assert_placed(F, H, pp.K, [-1, -2, -3])


def test_several_rows_are_reproducible_for_a_seed():
    """F* = diag(1, 1, 2, 2) is not cyclic; (F*, H*) is observable (PBH)."""
    F, H = sp.diag(1, 1, 2, 2), sp.Matrix([[1, 0, 1, 0], [0, 1, 0, 1]])
    eigs = [-1, -2, -3, -4]
    a = pole_placement(F, H, eigs)
    b = pole_placement(F, H, eigs, seed=PLACEMENT_SEED)
    assert a.K == b.K
    assert_placed(F, H, a.K, eigs)


# ---------------------------------------------------------------- exact number kinds
def test_complex_conjugate_pair_gives_a_real_gain():
    eigs = [-1 + 2 * sp.I, -1 - 2 * sp.I, sp.Rational(-1, 3)]
    K = place_poles(shift(3), e1(3), eigs)
    assert all(x.is_real for x in K)
    assert_placed(shift(3), e1(3), K, eigs)


def test_irrational_eigenvalues_stay_exact():
    eigs = [-sp.sqrt(2), -sp.sqrt(3), -1 + sp.sqrt(2) * sp.I, -1 - sp.sqrt(2) * sp.I]
    F = sp.Matrix([[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [1, 2, 0, 1]])
    K = place_poles(F, e1(4), eigs)
    assert not any(x.has(sp.Float) for x in K)
    assert_placed(F, e1(4), K, eigs)


def test_symbolic_parameters():
    a, b = sp.symbols("a b")
    F = sp.Matrix([[a, 1], [0, b]])
    K = place_poles(F, sp.Matrix([[1, 0]]), [-1, -2])
    assert K == sp.Matrix([a + b + 3, b ** 2 + 3 * b + 2])
    assert_placed(F, sp.Matrix([[1, 0]]), K, [-1, -2])


def test_symbolic_parameters_with_algebraic_eigenvalues():
    a = sp.Symbol("a")
    F = sp.Matrix([[0, a], [1, 0]])
    eigs = [-sp.sqrt(2), -1]
    assert_placed(F, e1(2), place_poles(F, e1(2), eigs), eigs)


def test_floats_are_read_as_their_decimal_rationals():
    K = place_poles(sp.Matrix([[0.5, 1], [0, 0]]), sp.Matrix([[1, 0]]), [-1, -2])
    assert_placed(sp.Matrix([[sp.Rational(1, 2), 1], [0, 0]]), sp.Matrix([[1, 0]]), K, [-1, -2])


# ---------------------------------------------------------------- refusals
def test_unobservable_single_row_names_the_rank():
    with pytest.raises(InfeasibleDesignError, match=r"not observable \(rank of the observability"
                                                    r" matrix 1 < k = 2\)"):
        place_poles(sp.zeros(2, 2), sp.Matrix([[1, 0]]), [-1, -2])


def test_unobservable_several_rows_is_not_a_shape_error():
    with pytest.raises(InfeasibleDesignError, match="not observable"):
        place_poles(sp.zeros(3, 3), sp.Matrix([[1, 0, 0], [0, 1, 0]]), [-1, -2, -3])


def test_dimension_and_count_errors_are_one_line():
    with pytest.raises(DimensionError, match="H\\* must have k = 2 columns"):
        place_poles(sp.zeros(2, 2), sp.Matrix([[1, 0, 0]]), [-1, -2])
    with pytest.raises(DimensionError, match="F\\* must be square"):
        place_poles(sp.zeros(2, 3), sp.Matrix([[1, 0, 0]]), [-1, -2])
    with pytest.raises(UsageError, match="2 eigenvalues needed"):
        place_poles(shift(2), e1(2), [-1])


def test_certificate_rejects_a_wrong_gain():
    with pytest.raises(CertificateError, match="exact check"):
        certify_poles(shift(2), e1(2), sp.Matrix([3, 3]), [-1, -2])
    assert certify_poles(shift(2), e1(2), sp.Matrix([3, 2]), [-1, -2]) == (1, 3, 2)


def test_target_polynomial_of_a_conjugate_pair_is_rational():
    assert target_polynomial([-1 + 2 * sp.I, -1 - 2 * sp.I]) == (1, 2, 5)


# ---------------------------------------------------------------- the designers that call it
def chain(n, time="continuous"):
    """x_i' = x_{i+1}, x_n' = −x1 − x2 + u + d (|d| ≤ 1/10); y = (x1, x2): canonical order
    k = n − 1."""
    xs = sp.symbols(f"x1:{n + 1}")
    u, d = sp.symbols("u d")
    dyn = [xs[i + 1] for i in range(n - 1)] + [-xs[0] - xs[1] + u + d]
    return PlantModel(name=f"chain{n}", time=time, states=list(xs), inputs=[u], faults=[d],
                      outputs=[xs[0], xs[1]], dynamics=dyn,
                      bounds={d: (sp.Rational(-1, 10), sp.Rational(1, 10))})


def _check_design(d, eigs):
    m = d.matrices
    assert_placed(m.F_star, m.H_star, m.K, eigs)
    key = lambda z: (float(sp.re(z)), float(sp.im(z)))  # noqa: E731
    assert list(d.closed_loop_eigenvalues) == sorted(eigs, key=key)
    cond = next(c for c in d.conditions if c.name == "closed-loop eigenvalues of F* − K H*")
    assert cond.holds and "recomputed" in cond.detail


def test_virtual_sensor_canonical_at_k8():
    d = design_virtual_sensor_canonical(chain(9), estimate="x9")
    assert d.k == 8
    _check_design(d, [-i for i in range(1, 9)])


def test_virtual_sensor_canonical_complex_pair():
    eigs = ["-1+2*I", "-1-2*I", "-3", "-4"]
    d = design_virtual_sensor_canonical(chain(5), estimate="x5", eigenvalues=eigs)
    _check_design(d, [-1 + 2 * sp.I, -1 - 2 * sp.I, -3, -4])


def test_diagnostic_canonical_at_k6_discrete():
    d = design_diagnostic_canonical(chain(7, time="discrete"), fault="d")
    assert d.k == 6
    _check_design(d, [sp.Rational(1, 2 ** i) for i in range(1, 7)])


def test_interval_canonical_diagonal_form_builds():
    eigs = [-1, -2, -3, -4]
    d = design(chain(5), observer="interval", estimate="x5", form="canonical", eigenvalues=eigs)
    _check_design(d, eigs)
    assert sorted(sp.Matrix(d.matrices.F_diag).diagonal()) == [-4, -3, -2, -1]
    obs = build_observer(chain(5), d)
    assert len(obs.update) == 2 * 4  # lower and upper bound of each of the k = 4 states


def test_float_eigenvalues_are_read_as_their_decimal_rationals():
    pp = pole_placement(shift(2), e1(2), [-0.5, -0.25])
    assert pp.eigenvalues == (sp.Rational(-1, 2), sp.Rational(-1, 4))
    assert list(pp.K) == [sp.Rational(3, 4), sp.Rational(1, 8)]


def test_certificate_rejects_a_wrong_algebraic_gain():
    eigs = [-1 + sp.sqrt(2) * sp.I, -1 - sp.sqrt(2) * sp.I, -sp.sqrt(3)]
    K = place_poles(shift(3), e1(3), eigs)
    certify_poles(shift(3), e1(3), K, eigs)
    bad = K + sp.Matrix([0, 0, sp.sqrt(2) * 10 ** -6])
    with pytest.raises(CertificateError):
        certify_poles(shift(3), e1(3), bad, eigs)
