"""Published fault-diagnosis benchmark systems, as structures with output feedthrough.

The matrices are those of Varga's FaultDetectionTools.jl tests (docs/REFERENCES.md:
"FaultDetectionTools.jl", test/test_fdigenspec.jl), which port the examples of the
papers each function names. Control inputs are left out: they do not change what can be
detected (a residual cancels them through G* = Φ G − J* Gy).
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from observer_cad import PlantModel
from observer_cad.model import extract_structure


def q(rows):
    """Exact rationals from decimal literals (by their decimal digits)."""
    return sp.Matrix([[sp.Rational(str(v)) for v in row] for row in rows])


def structure(F, H, D, Dy=None, L=None, Ly=None, *, time="continuous", name="example"):
    """A Structure x' = F x + D d + L ρ, y = H x + Dy d + Ly ρ (faults f1…, disturbances
    rho1…), the model built without the feedthrough and the feedthrough set on the
    structure."""
    F, H, D = sp.Matrix(F), sp.Matrix(H), sp.Matrix(D)
    n, l, m = F.rows, H.rows, D.cols
    L = sp.zeros(n, 0) if L is None else sp.Matrix(L)
    Dy = sp.zeros(l, m) if Dy is None else sp.Matrix(Dy)
    Ly = sp.zeros(l, L.cols) if Ly is None else sp.Matrix(Ly)
    # a model declares only what enters its dynamics: a fault or disturbance only in
    # the outputs gets a stand-in column there, replaced on the structure by its true (zero) one
    def stand_in(X):
        return [X[:, j] if any(X[:, j]) else sp.ones(n, 1) for j in range(X.cols)]
    B = sp.Matrix.hstack(*stand_in(D), *stand_in(L), sp.zeros(n, 1))
    Dm = sp.zeros(l, B.cols)
    model = PlantModel.from_statespace(
        (F, B, H, Dm), faults=list(range(m)), disturbances=list(range(m, m + L.cols)),
        inputs=[m + L.cols], time=time, name=name)
    st = extract_structure(model)
    im = sp.ImmutableMatrix
    return dataclasses.replace(st, D=im(D), L=im(L), Dy=im(Dy), Ly=im(Ly))


def niemann():
    """Niemann & Stoustrup 1998 (as in FaultDetectionTools.jl): n = 5, two actuator
    faults, one disturbance, all states measured."""
    a = q([[-0.0782, 0.2939, 0.0220, 0.0208, -0.0291],
           [0.0077, -0.0278, 0.0015, -0.0015, 0.0026],
           [-1.3251, 5.32608, -0.5263, 0.2214, -0.4777],
           [1.0809, -4.4452, 0.3770, -0.4631, 0.4032],
           [2.1532, -8.6386, 0.7811, -0.5745, 0.7816]]) * 1000
    bd = q([[0.0443], [-0.0042], [0.7910], [-0.6598], [-1.2881]]) * 1000
    bu = q([[-0.007197, 0.003005], [0.003473, 0.000284], [1.218502, -0.032866],
            [1.322502, 0.020147], [-0.082265, 0.024388]])
    return structure(a, sp.eye(5), bu, L=bd, name="niemann")


def xiong_saif_1():
    """Xiong & Saif 2000, Example 1: an actuator fault and a sensor fault (y3)."""
    a = q([[-9.9477, -0.7476, 0.2632, -5.0337], [52.1659, 2.7452, 5.5532, -24.4221],
           [26.0922, 2.6361, -4.1975, -19.2774], [0, 0, 1, 0]])
    bu = q([[0.4422, 0.1761], [3.5446, -7.5922], [-5.52, 4.49], [0, 0]])
    bd = sp.Matrix([[0, 0], [0, 1], [1, 0], [0, 0]])
    bf = sp.Matrix.hstack(bu[:, 0], sp.zeros(4, 1))
    c = sp.Matrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 1, 1, 1]])
    df = sp.Matrix([[0, 0], [0, 0], [0, 1], [0, 0]])
    return structure(a, c, bf, df, L=bd, name="xiong_saif_1")


def xiong_saif_2():
    """Xiong & Saif 2000, Example 2: two actuator faults, two disturbances."""
    a = q([[0, 0, -0.0034, 0, 0], [0, -0.041, 0.0013, 0, 0], [0, 0, -1.1471, 0, 0],
           [0, 0, -0.0036, 0, 0], [0, 0.094, 0.0057, 0, -0.051]])
    bu = q([[-1, 0, 0], [0, 0, 0], [0, 0, 0.948], [0.916, -1, 0], [-0.598, 0, 0]])
    bd = q([[0, 1], [0.062, -0.132], [0, -7.189], [0, 0], [0, 0]])
    c = sp.Matrix([[1, 0, 0, 0, 0], [0, 0, 1, 0, 0], [0, 0, 0, 1, 0]])
    return structure(a, c, bu[:, :2], L=bd, name="xiong_saif_2")


def boeing_747():
    """The linearised Boeing 747 (Varga 2007, as in FaultDetectionTools.jl): five
    actuator faults, the fifth also entering the second output."""
    A = q([[-0.4861, 0.000317, -0.5588, 0, -2.04e-6], [0, -0.0199, 3.0796, -9.8048, 8.98e-5],
           [1.0053, -0.0021, -0.5211, 0, 9.30e-6], [1, 0, 0, 0, 0],
           [0, 0, -92.6, 92.6, 0]])
    Bf = q([[-0.1455, -0.1455, -0.1494, -0.1494, -1.2860],
            [0, 0, 0, 0, -0.3122],
            [-0.0071, -0.0071, -0.0074, -0.0074, -0.0676],
            [0, 0, 0, 0, 0], [0, 0, 0, 0, 0]])
    C = q([[0, 0, 1, 0, 0], [0, -0.0199, 3.0796, -9.8048, 8.98e-5], [0, 0, 0, 1, 0],
           [1, 0, 0, 0, 0], [0, 0, -92.6, 92.6, 0], [0, 0, 0, 0, 1]])
    Df = sp.zeros(6, 5)
    Df[1, 4] = sp.Rational("-0.3122")
    return structure(A, C, Bf, Df, name="boeing_747")


def yuan_1997():
    """Yuan et al. 1997: eight faults, four states, three outputs."""
    A = sp.Matrix([[-1, 1, 0, 0], [1, -2, 1, 0], [0, 1, -2, 1], [0, 0, 1, -2]])
    Bf = sp.Matrix([[1, 0, 0, 0, 1, 0, 0, 0], [0, 1, 0, 0, -1, 1, 0, 0],
                    [0, 0, 1, 0, 0, -1, 1, 0], [0, 0, 0, 1, 0, 0, -1, 1]])
    C = sp.Matrix([[1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    return structure(A, C, Bf, name="yuan_1997")


def triplex_sensor():
    """Varga 2017, Example 5.10 (FaultDetectionTools.jl, Examples/Ex5_10.jl): triplex
    sensor redundancy, three sensors of one signal v = G_u u + G_d d with a fault each,
    y_i = v + f_i. Varga draws G_u and G_d at random (what is asserted does not depend
    on the draw); here G_u = 1/(s + 1), G_d = 1/(s + 2). A plant model: the faults enter
    the outputs only."""
    x1, x2, u, d, f1, f2, f3 = sp.symbols("x1 x2 u d f1 f2 f3")
    v = x1 + x2
    return PlantModel(name="triplex_sensor", time="continuous", states=[x1, x2], inputs=[u],
                      faults=[f1, f2, f3], disturbances=[d], outputs=[v + f1, v + f2, v + f3],
                      dynamics=[-x1 + u, -2 * x2 + d])


def rows(patterns):
    """'00111' strings -> the set of fault tuples (f1…) they mark sensitive."""
    return {tuple(f"f{i + 1}" for i, c in enumerate(p) if c == "1") for p in patterns}
