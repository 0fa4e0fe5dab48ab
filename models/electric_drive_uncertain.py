"""The electric drive of models/electric_drive.py (seed 000, Zhirabok & Zuev 2024, §9) with
a 1 % uncertainty on k5 and asymmetric sensor noise: the commissioning example of the
guaranteed thresholds (METHOD §3, residual evaluation).

    x1(t+1) = x1(t) + k1 x2(t)
    x2(t+1) = k2 x2(t) + k3 x3(t) + rho(t)
    x3(t+1) = k4 x2(t) + k5 x3(t) + k6 u(t) + d(t)
    y1 = x1 + w1,  y2 = x3 + w2

Every value is the one of models/electric_drive.py; this project's additions: k5 is known to
1 %, k5 ∈ [0.9504, 0.9696] around its nominal 24/25 = 0.96 (the value the observer is designed
at); the angle sensor reads 0 … +0.02
rad too high (w1 ∈ [0, 0.02]) and the current sensor ±0.01 A. A residual generator designed
at k5 = 0.96 then leaves zero on a plant with k5 = 0.955 even without a fault (the uncertain
term (k5 − 0.96)·x3 is not decoupled); the guaranteed threshold bounds it from the measured
current y2 = x3 + w2. Scenario: models/scenarios/electric_drive_uncertain.json.
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u, d, rho = sp.symbols("u d rho")
w1, w2 = sp.symbols("w1 w2")
k1, k2, k3, k4, k5, k6 = sp.symbols("k1:7")

model = PlantModel(
    name="electric_drive_uncertain",
    time="discrete",
    states=[x1, x2, x3],
    inputs=[u],
    faults=[d],
    disturbances=[rho],
    noise=[w1, w2],
    outputs=[x1 + w1, x3 + w2],
    dynamics=[
        x1 + k1 * x2,
        k2 * x2 + k3 * x3 + rho,
        k4 * x2 + k5 * x3 + k6 * u + d,
    ],
    parameters={
        k1: sp.Rational(1, 500),
        k2: sp.Rational(4, 5),
        k3: sp.Rational(1, 50),
        k4: sp.Rational(-1, 2500),
        k5: sp.Rational(24, 25),
        k6: sp.Rational(1, 25),
    },
    uncertainty={k5: (sp.Rational(9504, 10000), sp.Rational(9696, 10000))},
    bounds={d: (-0.4, 0.4), rho: (-0.05, 0.05), w1: (0, 0.02), w2: (-0.01, 0.01)},
    units={x1: "rad", x2: "rad/s", x3: "A", u: "V", d: "A", rho: "rad/s", w1: "rad", w2: "A"},
)
