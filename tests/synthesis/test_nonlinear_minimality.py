"""Jordan minimality with nonlinear terms (METHOD §2b-c): a term the rows
see needs its argument in rowspace [Φ; H], so the rows seeing the terms S form a linear
model of [M; A_j, j ∈ S] decoupled from the other terms' columns; the least bound over
every S proves k. Checked against sampled two-row designs, which the bound's code does
not compute."""
import numpy as np
import pytest
import sympy as sp

from observer_cad import PlantModel
from observer_cad.model import extract_structure
from observer_cad.synthesis import design_jordan
from observer_cad.synthesis.jordan.minimality import nonlinear_jordan_bound

LAM = sp.Symbol("lambda")
x1, x2, x3, x4, u = sp.symbols("x1:5 u")


def _plant():
    """z = x1 is one row at λ = −1 for the linear part, but x1' carries sin(x2) + cos(x3):
    its rows see both terms, so x2 and x3 must be recoverable too."""
    return PlantModel(name="two_arguments", time="continuous", states=[x1, x2, x3, x4],
                      inputs=[u], outputs=[x4],
                      dynamics=[-x1 + x4 + sp.sin(x2) + sp.cos(x3), -2 * x2 + x4,
                                -3 * x3 + x4, -x4 + x1 + u])


@pytest.mark.parametrize("observer", ["virtual-sensor", "interval"])
def test_argument_substitution_needs_three_rows_proven(observer):
    d = design_jordan(_plant(), observer=observer, estimate="x1", proof_seconds=None)
    assert d.k == 3 and d.certificate.passed
    c = next(c for c in d.conditions if c.name == "k is minimal over λ")
    assert c.holds and "nonlinear terms" in c.detail and "S = {1, 2}: ≥ 3" in c.detail


def test_the_bound_against_sampled_two_row_designs():
    """Every two-row Jordan model (one row per λ: one output, no decoupling) either misses
    x1 or sees a term whose argument it cannot recover — over 400 random λ pairs."""
    st = extract_structure(_plant())
    F, H, C = (np.array(sp.Matrix(X).tolist(), dtype=float) for X in (st.F, st.H, st.C))
    A = [np.array(sp.Matrix(t.row).tolist(), dtype=float) for t in st.terms]
    M = np.array([[1.0, 0, 0, 0]])
    rng = np.random.default_rng(5)

    def rank(X):
        s = np.linalg.svd(X, compute_uv=False)
        return int(np.sum(s > 1e-9 * s[0]))

    for _ in range(400):
        lams = -10 ** rng.uniform(-2, 1.5, 2)
        Phi = np.vstack([H @ np.linalg.inv(F - v * np.eye(4)) for v in lams])
        PH = np.vstack([Phi, H])
        reaches = rank(np.vstack([PH, M])) == rank(PH)
        seen = [j for j in range(len(A)) if np.linalg.norm(Phi @ C[:, j]) > 1e-9]
        recovered = all(rank(np.vstack([PH, A[j]])) == rank(PH) for j in seen)
        assert not (reaches and recovered)


def test_no_claim_above_the_least_subset():
    st = extract_structure(_plant())
    F, H, C = (sp.Matrix(X) for X in (st.F, st.H, st.C))
    M = sp.Matrix([[1, 0, 0, 0]])
    rows = [sp.Matrix(t.row) for t in st.terms]
    b = nonlinear_jordan_bound(F, H, sp.zeros(4, 0), M, C, rows, 3, LAM, "continuous", [-1, -2])
    assert b is not None and b.k == 3
    # at k = 4 the subset seeing both terms allows three rows (the design found):
    # nothing is claimed
    assert nonlinear_jordan_bound(F, H, sp.zeros(4, 0), M, C, rows, 4, LAM, "continuous",
                                  [-1, -2]) is None
