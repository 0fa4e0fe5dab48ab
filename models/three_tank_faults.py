"""Linear three-tank with a fault in each tank and a disturbance beside the third
(this project's own example, built for the diagnosability analysis).

The plant is the linearised three-tank of seed 001 (Zhirabok, Zuev & Kim 2022, §7) and
seed 004 §5 (every geometric coefficient 1, levels x2, x3 measured); the faults are this
project's addition:

    x1' = -x1 + x2 + u1 + f1          f1: actuator fault of pump 1 (tank 1)
    x2' =  x1 - 2 x2 + x3 + u2 + f2   f2: actuator fault of pump 2 (tank 2)
    x3' =  x2 - 2 x3 + f3 + rho       f3: leak in tank 3;  rho: disturbance on tank 3
    y1 = x2 + w1,  y2 = x3 + w2

f3 enters tank 3 exactly as the disturbance rho does, so no residual decoupled from rho
can see it, whatever is measured: `observer-cad analyze` says so and names the reason.
Bounds are this project's choice (as in models/three_tank_linear.py).
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u1, u2 = sp.symbols("u1 u2")
f1, f2, f3 = sp.symbols("f1 f2 f3")
rho = sp.Symbol("rho")
w1, w2 = sp.symbols("w1 w2")

model = PlantModel(
    name="three_tank_faults",
    time="continuous",
    states=[x1, x2, x3],
    inputs=[u1, u2],
    faults=[f1, f2, f3],
    disturbances=[rho],
    noise=[w1, w2],
    outputs=[x2 + w1, x3 + w2],
    dynamics=[
        -x1 + x2 + u1 + f1,
        x1 - 2 * x2 + x3 + u2 + f2,
        x2 - 2 * x3 + f3 + rho,
    ],
    bounds={f1: (-0.5, 0.5), f2: (-0.5, 0.5), f3: (-0.5, 0.5), rho: (-0.2, 0.2),
            w1: (-0.02, 0.02), w2: (-0.02, 0.02)},
)
