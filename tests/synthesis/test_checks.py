"""Nonlinear checks (METHOD §4): Lipschitz constant, monotonicity, the sufficient
stability condition. Every constant is compared with an independent derivation (an
analytic formula or a finite-difference Jacobian at domain points), never with the
checker's own arithmetic."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from observer_cad import UsageError, load_model
from observer_cad.analysis import (argument_range, is_cooperative, is_monotone, lipschitz,
                                   model_nonlinearity, nonlinear_conditions, reduced_nonlinearity,
                                   stability_condition)
from observer_cad.synthesis import design_jordan

x1, x2, x3, xs1, y1 = sp.symbols("x1 x2 x3 xs1 y1")


@pytest.fixture(scope="module")
def tank(models_dir):
    return load_model(models_dir / "three_tank.py")


def away(a):
    """The three-tank domain bounded away from 0 by a in every argument."""
    return [x3 >= a, x2 - x3 >= a, x1 - x2 >= a]


_FD = {}


def fd_norm(exprs, variables, point, h=1e-7):
    """Spectral norm of a central finite-difference Jacobian at a point."""
    key = (tuple(exprs), tuple(variables))
    if key not in _FD:
        _FD[key] = sp.lambdify(variables, exprs, "numpy")
    f = _FD[key]
    p = np.array(point, dtype=float)
    J = np.zeros((len(exprs), len(variables)))
    for k in range(len(variables)):
        e = np.zeros_like(p)
        e[k] = h
        J[:, k] = (np.array(f(*(p + e)), dtype=float) - np.array(f(*(p - e)), dtype=float)) / (2 * h)
    return np.linalg.norm(J, 2)


# ---------------------------------------------------------------- Lipschitz
def test_sqrt_not_lipschitz_on_tank_domain(tank):
    res = lipschitz([sp.sqrt(x3)], [x3], tank.domain)
    assert res.lipschitz is False and res.constant == sp.oo and res.kind == "symbolic"
    assert "not Lipschitz" in res.evidence
    norms = [n for _, n in res.witness]
    assert len(norms) >= 3 and all(b > 5 * a for a, b in zip(norms, norms[1:]))  # grows without bound
    # the witness points are in the domain and the norm there is d√x3/dx3 = 1/(2√x3)
    for point, n in res.witness:
        p = dict(zip(("x1", "x2", "x3"), point))
        assert p["x1"] >= p["x2"] >= p["x3"] > 0
        assert n == pytest.approx(1 / (2 * np.sqrt(p["x3"])), rel=1e-9)


@pytest.mark.parametrize("a", [sp.Rational(1, 4), sp.Rational(1, 16), sp.Integer(1), sp.Rational(9, 4)])
def test_sqrt_lipschitz_away_from_zero(a):
    res = lipschitz([sp.sqrt(x3)], [x3], away(a))
    assert res.lipschitz is True and res.kind == "symbolic" and res.tight
    assert sp.simplify(sp.sympify(res.constant) - 1 / (2 * sp.sqrt(a))) == 0  # analytic 1/(2√a)


def test_sqrt_vector_lipschitz_constant():
    """(√(x1−x2), √(x2−x3), √x3) on arguments ≥ 1/4: J = diag(1/(2√a_j)) A, largest when
    every a_j = 1/4, so N = ‖A‖₂ · 1/(2√(1/4)) = ‖A‖₂ (= 2 cos(π/7))."""
    A = np.array([[1, -1, 0], [0, 1, -1], [0, 0, 1]], dtype=float)
    res = lipschitz([sp.sqrt(x1 - x2), sp.sqrt(x2 - x3), sp.sqrt(x3)], [x1, x2, x3],
                    away(sp.Rational(1, 4)))
    assert res.lipschitz and res.tight
    assert float(res.constant) == pytest.approx(np.linalg.norm(A, 2), rel=1e-9)
    assert float(res.constant) == pytest.approx(2 * np.cos(np.pi / 7), rel=1e-9)
    exprs = [sp.sqrt(x1 - x2), sp.sqrt(x2 - x3), sp.sqrt(x3)]
    assert fd_norm(exprs, [x1, x2, x3], [0.75, 0.5, 0.25]) == pytest.approx(float(res.constant), rel=1e-5)


def test_tank_C_psi_not_lipschitz_and_bounded_away(tank):
    """C Ψ of the model (Ψ_j = −√(A_j x) + A_j x, seed 002 §8) on its own domain: not
    Lipschitz; on arguments ≥ 1/4: the bound holds at every sampled domain point and is
    approached far out (all arguments large: φ' → 1, J → C A)."""
    cpsi, xs, st = model_nonlinearity(tank)
    res = lipschitz(list(cpsi), xs, tank.domain)
    assert res.lipschitz is False
    res = lipschitz(list(cpsi), xs, away(sp.Rational(1, 4)))
    assert res.lipschitz is True and res.kind == "symbolic"
    N = float(res.constant)
    rng = np.random.default_rng(0)
    seen = 0.0
    args = [0.25 + 10 ** rng.uniform(-6, 6, size=3) for _ in range(300)]  # x3, x2 − x3, x1 − x2
    args += [np.full(3, 10.0 ** e) for e in range(1, 9)]  # all arguments large together
    for a in args:
        p = [a[0] + a[1] + a[2], a[0] + a[1], a[0]]
        nv = fd_norm(list(cpsi), xs, p, h=1e-4 * min(a))
        assert nv <= N * (1 + 1e-6)
        seen = max(seen, nv)
    CA = np.array((sp.Matrix(st.C) * sp.Matrix(st.A)).tolist(), dtype=float)
    assert N == pytest.approx(np.linalg.norm(CA, 2), rel=1e-6)
    assert seen == pytest.approx(N, rel=1e-3)


def test_reduced_C_psi_lipschitz(tank):
    """C*Ψ* = a − √a, a = x* − y1 = x1 − x2: |1 − 1/(2√a)| on a ≥ 1/100 is at most
    max(|1 − 5|, 1) = 4 (at a = 1/100); on a ≥ 0 it is unbounded."""
    d = design_jordan(tank, observer="interval", estimate="x1")
    expr, xs, ys, defs = reduced_nonlinearity(tank, d)
    assert sp.simplify(expr[0] - (xs1 - y1 - sp.sqrt(xs1 - y1))) == 0
    assert defs[xs1] == x1 and defs[y1] == x2
    assert lipschitz(list(expr), xs, tank.domain, definitions=defs).lipschitz is False
    dom = [x1 - x2 >= sp.Rational(1, 100), x2 >= x3, x3 >= 0]
    res = lipschitz(list(expr), xs, dom, definitions=defs)
    assert res.lipschitz and res.constant == 4 and res.tight


def test_abs_of_affine_argument_is_bounded_exactly():
    """|x3 − 1| has derivative sign(x3 − 1): the range analysis splits at x3 = 1 and
    bounds each smooth piece exactly (not from samples), N = 1 rigorously."""
    res = lipschitz([sp.Abs(x3 - 1)], [x3], [x3 >= 0])
    assert res.kind == "symbolic" and res.lipschitz is True and res.constant == 1


def test_sampled_fallback_and_stated_bound():
    """max(0, x3 − 1) has derivative Heaviside(x3 − 1), which sympy's range analysis
    does not handle: the result is a sampled lower bound, and a stated upper bound is used."""
    f = sp.Max(0, x3 - 1)
    res = lipschitz([f], [x3], [x3 >= 0])
    assert res.kind == "sampled" and res.lipschitz is None and res.lower == pytest.approx(1)
    res = lipschitz([f], [x3], [x3 >= 0], stated_upper=1)
    assert res.kind == "sampled" and res.lipschitz is True and res.constant == 1
    res = lipschitz([f], [x3], [x3 >= 0], stated_upper=sp.Rational(1, 2))
    assert res.lipschitz is False  # the statement contradicts the samples


def test_polynomial_lipschitz_on_box():
    """x1² on 0 ≤ x1 ≤ 3: N = 6 (independently: max |2 x1|)."""
    res = lipschitz([x1 ** 2], [x1], [x1 >= 0, x1 <= 3])
    assert res.lipschitz and res.constant == 6
    res = lipschitz([x1 ** 2], [x1], [x1 >= 0])
    assert res.lipschitz is False


def test_empty_domain():
    with pytest.raises(UsageError, match="empty"):
        lipschitz([sp.sqrt(x3)], [x3], [x3 >= 1, x3 <= 0])


def test_argument_ranges(tank):
    assert argument_range(tank, [1, -1, 0]) == (0, sp.oo)
    assert argument_range(tank, [0, 0, 1]) == (0, sp.oo)
    assert argument_range(tank, [-1, 0, 1]) == (-sp.oo, 0)  # x3 − x1 ≤ 0


# ---------------------------------------------------------------- monotonicity
def test_sqrt_monotone(tank):
    res = is_monotone([sp.sqrt(x3)], [x3], tank.domain)
    assert res.monotone is True and res.direction == "nondecreasing" and res.kind == "symbolic"
    # √(x* − y1) of the reduced model (seed 002 §8) in x*
    res = is_monotone([sp.sqrt(xs1 - y1)], [xs1], tank.domain, definitions={xs1: x1, y1: x2})
    assert res.monotone is True and res.signs == (("+",),)


def _check_witness(f, var, res):
    """The witness pair really has x ≤ x' and f(x) > f(x')."""
    w = res.witness
    assert w is not None and w["variable"] == str(var)
    assert w["f"][0] > w["f"][1]


def test_non_monotone_examples(tank):
    res = is_monotone([sp.sin(x1)], [x1], [x1 >= 0, x1 <= 4])
    assert res.monotone is False and res.signs == (("±",),)
    _check_witness(sp.sin(x1), x1, res)
    res = is_monotone([-sp.sqrt(x3)], [x3], tank.domain)
    assert res.monotone is False and res.direction == "nonincreasing"
    # the formal split of seed 002 §8: C*Ψ* = a − √a is not monotone near a = 0 ...
    d = design_jordan(tank, observer="interval", estimate="x1")
    expr, xs, ys, defs = reduced_nonlinearity(tank, d)
    res = is_monotone(list(expr), xs, tank.domain, definitions=defs)
    assert res.monotone is False and res.direction is None
    _check_witness(expr[0], xs1, res)
    # ... and is on a ≥ 1/4 (1 − 1/(2√a) ≥ 0 there)
    dom = [x1 - x2 >= sp.Rational(1, 4), x2 >= x3, x3 >= 0]
    assert is_monotone(list(expr), xs, dom, definitions=defs).monotone is True


def test_vector_monotonicity_signs():
    res = is_monotone([sp.sqrt(x1 - x2), sp.sqrt(x3)], [x1, x2, x3], away(sp.Rational(1, 4)))
    assert res.signs == (("+", "-", "0"), ("0", "0", "+"))
    assert res.monotone is False


def test_three_tank_is_cooperative(tank):
    """The three-tank's right-hand side has a Metzler Jacobian on its domain
    (∂f_i/∂x_j = 1/(2√·) ≥ 0 for i ≠ j): a cooperative system."""
    rhs = [e.subs({s: 0 for s in tank.inputs + tank.disturbances}) for e in tank.dynamics]
    res = is_cooperative(rhs, list(tank.states), tank.domain)
    assert res.monotone is True
    res = is_cooperative([-x1 - x2, -x2], [x1, x2])
    assert res.monotone is False and res.signs[0][1] == "-"


# ---------------------------------------------------------------- stability condition
def test_stability_scalar_by_hand():
    """F* = −1, W = 1: P = 1/2; 2 N · 1/2 < 1 ⇔ N < 1."""
    r = stability_condition(sp.Matrix([[-1]]), sp.Rational(1, 2))
    assert r.holds and r.P[0, 0] == pytest.approx(0.5) and r.lhs == pytest.approx(0.5) and r.rhs == 1
    r = stability_condition(sp.Matrix([[-1]]), 1)
    assert not r.holds and r.lhs == pytest.approx(1.0)


def test_stability_nondiagonal_by_hand():
    """F = [[−1, 5], [0, −2]], W = I: solving FᵀP + PF = −I by hand gives
    P = [[1/2, 5/6], [5/6, 7/3]], λ_max(P) = (17/6 + √((17/6)² − 4·17/36))/2."""
    F = sp.Matrix([[-1, 5], [0, -2]])
    P = np.array([[1 / 2, 5 / 6], [5 / 6, 7 / 3]])
    lmax = (17 / 6 + np.sqrt((17 / 6) ** 2 - 4 * 17 / 36)) / 2
    r = stability_condition(F, 0.1)
    assert np.allclose(r.P, P)
    assert r.lhs == pytest.approx(2 * 0.1 * lmax) and r.holds
    assert not stability_condition(F, 0.2).holds  # 2 · 0.2 · 2.6555 > 1
    # scaling W scales P: the condition is unchanged
    r2 = stability_condition(F, 0.1, W=2 * sp.eye(2))
    assert np.allclose(r2.P, 2 * P) and r2.holds and r2.lhs / r2.rhs == pytest.approx(r.lhs / r.rhs)


def test_stability_not_hurwitz_and_not_lipschitz(tank):
    assert not stability_condition(sp.Matrix([[1]]), 0).holds
    lip = lipschitz([sp.sqrt(x3)], [x3], tank.domain)
    r = stability_condition(sp.Matrix([[-1]]), lip)
    assert not r.holds and "not Lipschitz" in r.evidence


def test_nonlinear_conditions_three_tank(tank):
    d = design_jordan(tank, observer="interval", estimate="x1")
    conds = {c.name: c for c in nonlinear_conditions(tank, d)}
    assert not conds["Lipschitz constant of C*Ψ* (in x*) on the domain"].holds
    assert "not Lipschitz" in conds["Lipschitz constant of C*Ψ* (in x*) on the domain"].detail
    assert not conds["C*Ψ* monotone (nondecreasing) in x* on the domain"].holds
    assert not conds["sufficient stability condition 2 N* λ_max(P*) < λ_min(W*)"].holds
    assert all(not c.required for c in conds.values())  # reported, the design does not rest on them
    # bounded away from 0 (a ≥ 1/100): N* = 4 and 2·4·(1/2) = 4 ≥ 1 — still fails, as the
    # paper says the condition is conservative
    dom = [x1 - x2 >= sp.Rational(1, 100), x2 - x3 >= 0, x3 >= 0]
    conds = {c.name: c for c in nonlinear_conditions(tank, d, dom)}
    assert conds["Lipschitz constant of C*Ψ* (in x*) on the domain"].holds
    assert "N = 4" in conds["Lipschitz constant of C*Ψ* (in x*) on the domain"].detail
    assert not conds["sufficient stability condition 2 N* λ_max(P*) < λ_min(W*)"].holds
