"""Discretised electric drive (seed 000, Zhirabok & Zuev 2024, §9, eq. (9.1)).

    x1(t+1) = x1(t) + k1 x2(t)
    x2(t+1) = k2 x2(t) + k3 x3(t) + rho(t)
    x3(t+1) = k4 x2(t) + k5 x3(t) + k6 u(t) + d(t)
    y1 = x1 + w1,  y2 = x3 + w2

x1 is the angle of the gearbox output shaft [rad], x2 the motor shaft speed [rad/s],
x3 the armature current [A], u the armature voltage [V]. rho is the load torque
reduced to the motor shaft (a disturbance to decouple from), d the fault caused by a
change of armature resistance, d(t) = x3(t)·Δk5(t). w1, w2 are measurement noise
(zero in the paper's Fig. 1-3, U[-0.01, 0.01] in Fig. 4).

The paper keeps k1..k6 symbolic and does not give values. The defaults here come from
a forward-Euler discretisation, with sample time T = 0.02 s and gear ratio N = 10, of
the textbook DC motor J ω' = K i − b ω, La i' = −R i − K ω + u (the University of
Michigan "Control Tutorials" DC motor: J = 0.01 kg·m², b = 0.1 N·m·s, K = 0.01 N·m/A,
R = 1 Ω, La = 0.5 H):

    k1 = T/N = 1/500,          k2 = 1 − T b/J = 4/5,     k3 = T K/J = 1/50,
    k4 = −T K/La = −1/2500,    k5 = 1 − T R/La = 24/25,  k6 = T/La = 1/25.

Bounds are the paper's: d in [-0.4, 0.4] (d_ and d¯), |rho| <= 0.05 for the
fault-estimation scenario (rho* = 0.2 when rho itself is estimated), |w| <= 0.01.
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u, d, rho = sp.symbols("u d rho")
w1, w2 = sp.symbols("w1 w2")
k1, k2, k3, k4, k5, k6 = sp.symbols("k1:7")

model = PlantModel(
    name="electric_drive",
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
    bounds={d: (-0.4, 0.4), rho: (-0.05, 0.05), w1: (-0.01, 0.01), w2: (-0.01, 0.01)},
    # as the docstring says; d and rho in the units of the equations they enter,
    # w1, w2 in those of the outputs they disturb
    units={x1: "rad", x2: "rad/s", x3: "A", u: "V", d: "A", rho: "rad/s", w1: "rad", w2: "A"},
)
