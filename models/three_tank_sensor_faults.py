"""Linear three-tank system with a bias fault on each level sensor and a fault on each
inflow (the plant of ``three_tank_linear.py``, every tank measured).

    x1' = -x1 + x2 + u1 + fa1
    x2' =  x1 - 2 x2 + x3 + u2 + fa2
    x3' =  x2 - 2 x3 + rho
    y1 = x1 + fs1 + w1,  y2 = x2 + fs2 + w2,  y3 = x3 + fs3 + w3

fa1, fa2 are actuator faults (an inflow off its command); fs1, fs2, fs3 additive bias
faults of the level sensors, which enter the outputs directly (y = H x + Dy d + W w);
rho a disturbance in tank 3 to decouple from; w1, w2, w3 measurement noise. The
coefficients are those of ``three_tank_linear.py``; the bounds are this project's
choice for its simulations: |rho| <= 0.2, |w| <= 0.02.
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u1, u2 = sp.symbols("u1 u2")
fa1, fa2 = sp.symbols("fa1 fa2")
fs1, fs2, fs3 = sp.symbols("fs1 fs2 fs3")
rho = sp.Symbol("rho")
w1, w2, w3 = sp.symbols("w1 w2 w3")

model = PlantModel(
    name="three_tank_sensor_faults",
    time="continuous",
    states=[x1, x2, x3],
    inputs=[u1, u2],
    faults=[fa1, fa2, fs1, fs2, fs3],
    disturbances=[rho],
    noise=[w1, w2, w3],
    outputs=[x1 + fs1 + w1, x2 + fs2 + w2, x3 + fs3 + w3],
    dynamics=[
        -x1 + x2 + u1 + fa1,
        x1 - 2 * x2 + x3 + u2 + fa2,
        x2 - 2 * x3 + rho,
    ],
    bounds={rho: (-0.2, 0.2), w1: (-0.02, 0.02), w2: (-0.02, 0.02), w3: (-0.02, 0.02)},
)
