"""Structure extraction on the bundled models and on hand-made ones (METHOD §1)."""
import random

import sympy as sp

from observer_cad import PlantModel, extract_structure, load_model


def test_electric_drive_matrices(models_dir):
    # seed 000 §9: F, G, H, L, D of eq. (9.1)
    st = extract_structure(load_model(models_dir / "electric_drive.py"))
    k1, k2, k3, k4, k5, k6 = sp.symbols("k1:7")
    assert st.F == sp.Matrix([[1, k1, 0], [0, k2, k3], [0, k4, k5]])
    assert st.G == sp.Matrix([0, 0, k6])
    assert st.H == sp.Matrix([[1, 0, 0], [0, 0, 1]])
    assert st.L == sp.Matrix([0, 1, 0])
    assert st.D == sp.Matrix([0, 0, 1])
    assert st.W == sp.eye(2)
    assert st.is_linear


def test_three_tank_linear_matrices(models_dir):
    st = extract_structure(load_model(models_dir / "three_tank_linear.py"))
    assert st.F == sp.Matrix([[-1, 1, 0], [1, -2, 1], [0, 1, -2]])
    assert st.G == sp.Matrix([[1, 0], [0, 1], [0, 0]])
    assert st.H == sp.Matrix([[0, 1, 0], [0, 0, 1]])
    assert st.L == sp.Matrix([0, 0, 1])


def test_three_tank_nonlinear_split_gives_paper_F(models_dir):
    # seed 002 §8: the formal terms give F = [[-1,1,0],[1,-2,1],[0,1,-2]],
    # C = [[1,0,0],[-1,1,0],[0,-1,1]], Psi_j = -sqrt(A_j x) + A_j x
    m = load_model(models_dir / "three_tank.py")
    st = extract_structure(m)
    x1, x2, x3 = m.states
    assert st.F == sp.Matrix([[-1, 1, 0], [1, -2, 1], [0, 1, -2]])
    assert st.C == sp.Matrix([[1, 0, 0], [-1, 1, 0], [0, -1, 1]])
    assert st.A == sp.Matrix([[1, -1, 0], [0, 1, -1], [0, 0, 1]])
    expected = [-sp.sqrt(x1 - x2) + x1 - x2, -sp.sqrt(x2 - x3) + x2 - x3, -sp.sqrt(x3) + x3]
    for got, want in zip(st.psi(), expected):
        assert sp.simplify(got - want) == 0
    assert st.L == sp.Matrix([[0, 0], [1, 0], [0, 1]])


def test_nonlinear_without_split_has_natural_F(models_dir):
    m = load_model(models_dir / "three_tank.py")
    import dataclasses
    st = extract_structure(dataclasses.replace(m, linear_part=None))
    assert st.F == sp.zeros(3, 3)
    assert st.A == sp.Matrix([[1, -1, 0], [0, 1, -1], [0, 0, 1]])


def test_structure_rebuilds_dynamics_at_random_points(models_dir):
    """Independent check: F x + G u + C Psi + D d + L rho equals the model's right-hand
    side at random points of the domain (evaluated numerically, not simplified)."""
    rng = random.Random(7)
    for name in ("electric_drive.py", "three_tank_linear.py", "three_tank.py"):
        m = load_model(models_dir / name)
        st = extract_structure(m)
        rebuilt = st.rhs()
        syms = list(m.states) + list(m.inputs) + list(m.faults) + list(m.disturbances) + list(m.parameters)
        for _ in range(5):
            # decreasing positive levels keep the three-tank square roots real
            vals = sorted((rng.uniform(0.1, 3) for _ in m.states), reverse=True)
            point = dict(zip(m.states, vals))
            point.update({s: rng.uniform(-1, 1) for s in syms if s not in point})
            for got, want in zip(rebuilt, m.dynamics):
                assert abs(complex(got.evalf(subs=point)) - complex(want.evalf(subs=point))) < 1e-12


def test_argument_rows_and_inputs_in_nonlinear_terms():
    x1, x2, u = sp.symbols("x1 x2 u")
    m = PlantModel(name="t", time="continuous", states=[x1, x2], inputs=[u], outputs=[x1],
                   dynamics=[-x1 + 3 * sp.sin(2 * x1 - 2 * x2) + x1 * u, sp.exp(x1 - x2) * sp.cos(x1 - x2) + u])
    st = extract_structure(m)
    rows = {tuple(t.row) for t in st.terms}
    assert (2, -2) in rows or (1, -1) in rows
    assert (1, 0) in rows  # x1*u is phi(A x, u) with A = (1, 0)
    assert st.F == sp.Matrix([[-1, 0], [0, 0]])
    assert st.G == sp.Matrix([0, 1])
    # the structure rebuilds the right-hand side exactly
    for got, want in zip(st.rhs(), m.dynamics):
        assert sp.simplify(got - want) == 0


def test_same_function_in_two_equations_shares_a_column():
    x1, x2 = sp.symbols("x1 x2")
    m = PlantModel(name="t", time="continuous", states=[x1, x2], outputs=[x2],
                   dynamics=[-sp.sqrt(x1 - x2), 2 * sp.sqrt(x1 - x2) - x2])
    st = extract_structure(m)
    assert st.C.shape == (2, 1)
    assert sp.simplify(st.C[1, 0] / st.C[0, 0]) == -2
