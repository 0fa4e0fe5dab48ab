"""Linearised three-tank system (seed 001, Zhirabok, Zuev & Kim 2022, §7; seed 004 §5).

    x1' = -x1 + x2 + u1
    x2' =  x1 - 2 x2 + x3 + u2
    x3' =  x2 - 2 x3 + rho
    y1 = x2 + w1,  y2 = x3 + w2

x1, x2, x3 are the liquid levels in the three tanks; u1, u2 the inflows into tanks 1
and 2; rho a disturbance acting on tank 3 (to decouple from); w1, w2 measurement
noise. The papers set every geometric coefficient to 1, which gives
F = [[-1,1,0],[1,-2,1],[0,1,-2]], G = [[1,0],[0,1],[0,0]], H = [[0,1,0],[0,0,1]].
The bounds on rho and w are this project's choice for its simulations (the papers
give none numerically): |rho| <= 0.2, |w| <= 0.02.
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u1, u2 = sp.symbols("u1 u2")
rho = sp.Symbol("rho")
w1, w2 = sp.symbols("w1 w2")

model = PlantModel(
    name="three_tank_linear",
    time="continuous",
    states=[x1, x2, x3],
    inputs=[u1, u2],
    disturbances=[rho],
    noise=[w1, w2],
    outputs=[x2 + w1, x3 + w2],
    dynamics=[
        -x1 + x2 + u1,
        x1 - 2 * x2 + x3 + u2,
        x2 - 2 * x3 + rho,
    ],
    bounds={rho: (-0.2, 0.2), w1: (-0.02, 0.02), w2: (-0.02, 0.02)},
)
