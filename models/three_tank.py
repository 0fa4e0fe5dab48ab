"""Nonlinear three-tank system (seed 002, Zhirabok et al. 2022, §8, eq. (8.1)).

    x1' = u1 - sqrt(x1 - x2)
    x2' = u2 + sqrt(x1 - x2) - sqrt(x2 - x3) + rho1
    x3' = sqrt(x2 - x3) - sqrt(x3) + rho2
    y1 = x2 + w1,  y2 = x3 + w2

with the paper's simplification a1 = ... = a6 = 1 and outlet height theta7 = 0.
x1, x2, x3 are the levels in the tanks, u1, u2 the inflows, rho1, rho2 disturbances in
tanks 2 and 3, w1, w2 measurement noise. The state domain x1 >= x2 >= x3 >= 0 is the
paper's assumption on the initial conditions and the control.

The right-hand side has no linear part of its own (F = 0). As in the paper, formal
terms -(A_j x) + (A_j x) are added: the model states its linear part F, and the tool
absorbs the difference into the nonlinear terms, giving
Psi_j = -sqrt(A_j x) + A_j x with A1 = (1,-1,0), A2 = (0,1,-1), A3 = (0,0,1).
Bounds (|rho| <= 0.5, |w| <= 0.01) are this project's choice for its simulations.
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u1, u2 = sp.symbols("u1 u2")
rho1, rho2 = sp.symbols("rho1 rho2")
w1, w2 = sp.symbols("w1 w2")

model = PlantModel(
    name="three_tank",
    time="continuous",
    states=[x1, x2, x3],
    inputs=[u1, u2],
    disturbances=[rho1, rho2],
    noise=[w1, w2],
    outputs=[x2 + w1, x3 + w2],
    dynamics=[
        u1 - sp.sqrt(x1 - x2),
        u2 + sp.sqrt(x1 - x2) - sp.sqrt(x2 - x3) + rho1,
        sp.sqrt(x2 - x3) - sp.sqrt(x3) + rho2,
    ],
    linear_part=[[-1, 1, 0], [1, -2, 1], [0, 1, -2]],
    domain=[x1 >= x2, x2 >= x3, x3 >= 0],
    bounds={rho1: (-0.5, 0.5), rho2: (-0.5, 0.5), w1: (-0.01, 0.01), w2: (-0.01, 0.01)},
)
