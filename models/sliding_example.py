"""Matching-condition example for the sliding-mode observer (this project's example,
not from the seed papers; METHOD §3, seed 002 §5).

    x1' = -2 x1 + x2 + x3 + u1
    x2' =  x1 - 2 x2 + x3 + u2 + rho + d
    x3' =  x1 + x2 - 3 x3 + rho
    y1 = x2 + w1,  y2 = x3 + w2

Three coupled tanks: u1, u2 inflows into tanks 1 and 2; d a fault (a leak or an
actuator offset) in tank 2, which is measured; rho a disturbance acting equally on
tanks 2 and 3 (to decouple from); w1, w2 measurement noise. The plant is stable
(eigenvalues of F: -3, -2 +- sqrt(3)).

It is built so that the matching condition rank(HD) = rank(D) holds (the fault enters
a measured state) and one Jordan row Phi_1 = R* H exists with Phi_1 L = 0: the level
difference x* = x2 - x3 is blind to the unmeasured x1 (it enters tanks 2 and 3
equally) and to rho, and sees d with D* = 1:

    x*' = lambda x* + (-3 - lambda) y1 + (4 + lambda) y2 + u2 + d      (any lambda)

Bounds (this project's choice for its simulations): |d| <= 1, |rho| <= 0.5,
|w| <= 0.01.
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u1, u2 = sp.symbols("u1 u2")
d = sp.Symbol("d")
rho = sp.Symbol("rho")
w1, w2 = sp.symbols("w1 w2")

model = PlantModel(
    name="sliding_example",
    time="continuous",
    states=[x1, x2, x3],
    inputs=[u1, u2],
    faults=[d],
    disturbances=[rho],
    noise=[w1, w2],
    outputs=[x2 + w1, x3 + w2],
    dynamics=[
        -2 * x1 + x2 + x3 + u1,
        x1 - 2 * x2 + x3 + u2 + rho + d,
        x1 + x2 - 3 * x3 + rho,
    ],
    bounds={d: (-1, 1), rho: (-0.5, 0.5), w1: (-0.01, 0.01), w2: (-0.01, 0.01)},
)
