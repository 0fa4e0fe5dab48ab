"""Linear three-tank with a fault in each tank, every level measured and a common
disturbance (this project's own example, built for the isolating residual banks of
the companion of models/three_tank_faults.py, where isolation fails).

The plant is the linearised three-tank of seed 001 (Zhirabok, Zuev & Kim 2022, §7) and
seed 004 §5 (every geometric coefficient 1), as in models/three_tank_faults.py; the
faults, the third level sensor and the disturbance are this project's additions:

    x1' = -x1 + x2 + u1 + f1 + rho      f1: actuator fault of pump 1 (tank 1)
    x2' =  x1 - 2 x2 + x3 + u2 + f2 + rho   f2: actuator fault of pump 2 (tank 2)
    x3' =  x2 - 2 x3 + f3 + rho         f3: leak in tank 3
    y1 = x1 + w1,  y2 = x2 + w2,  y3 = x3 + w3

rho is an inflow disturbance common to the three tanks (say a shared supply line whose
pressure varies): it enters every tank alike, so no fault enters the way rho does, and
with every level measured each fault can be decoupled together with rho. Every pair of
faults is then strongly isolable: `observer-cad analyze` finds every fault detectable
and every pair isolable, and `observer-cad design --observer diagnostic --isolate`
builds the generalised observer scheme (residual i decoupled from f_i and rho,
sensitive to the two other faults; structure matrix 011, 101, 110). A fault in tank j
moves exactly the residuals of column j. Scenario: models/scenarios/three_tank_isolation.json
(a step fault in tank 2). Bounds are this project's choice (as in
models/three_tank_linear.py).
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u1, u2 = sp.symbols("u1 u2")
f1, f2, f3 = sp.symbols("f1 f2 f3")
rho = sp.Symbol("rho")
w1, w2, w3 = sp.symbols("w1 w2 w3")

model = PlantModel(
    name="three_tank_isolation",
    time="continuous",
    states=[x1, x2, x3],
    inputs=[u1, u2],
    faults=[f1, f2, f3],
    disturbances=[rho],
    noise=[w1, w2, w3],
    outputs=[x1 + w1, x2 + w2, x3 + w3],
    dynamics=[
        -x1 + x2 + u1 + f1 + rho,
        x1 - 2 * x2 + x3 + u2 + f2 + rho,
        x2 - 2 * x3 + f3 + rho,
    ],
    bounds={f1: (-0.5, 0.5), f2: (-0.5, 0.5), f3: (-0.5, 0.5), rho: (-0.2, 0.2),
            w1: (-0.02, 0.02), w2: (-0.02, 0.02), w3: (-0.02, 0.02)},
)
