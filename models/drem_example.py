"""DREM example (this project's, METHOD §5; the class of seed 003, Dang, Pyrkin, Bobtsov
& Vedyakov 2021): N = 2, θ(t) affine in t, V constant.

    x1' = x2 − θ1(t) y + V1 u
    x2' = −θ2(t) (y + y³) + V2 u,          y = x1
    θ1(t) = a0 + a1 t,   θ2(t) = c0 + c1 t,   V = (v1, v2)

i.e. x' = A x + Q(y) θ(t) + V u with A the 2×2 shift and Q(y) = diag(−y, −(y + y³)):
a damped hardening oscillator y'' + θ1 y' + (θ1' + θ2) y + θ2 y³ = V1 u' + V2 u whose
damping and stiffness drift linearly in time. The six unknown coefficients and their
values (the truth the simulator uses; the observer never reads them) are this
project's choice: θ1 = 1.5 + 0.025 t, θ2 = 2 − 0.03 t, V = (1, 2) (the scenarios run
to t = 40, where θ2 = 0.8; the oscillator loses its stiffness near t = 67). gamma =
1e22 suits dt = 0.02 and the input of scenarios/drem_example.json (Δ ≈ 1e-11, a
product of six filtered signals; see observer_cad.observers.suggest_gamma).

Time enters through the clock state tau (tau' = 1, tau(0) = 0).
"""
import sympy as sp

from observer_cad import DremSpec, PlantModel

x1, x2, tau = sp.symbols("x1 x2 tau")
u = sp.Symbol("u")
a0, a1, c0, c1, v1, v2 = sp.symbols("a0 a1 c0 c1 v1 v2")

theta = [a0 + a1 * tau, c0 + c1 * tau]
V = [v1, v2]

model = PlantModel(
    name="drem_example",
    time="continuous",
    states=[x1, x2, tau],
    inputs=[u],
    outputs=[x1],
    dynamics=[
        x2 - theta[0] * x1 + V[0] * u,
        -theta[1] * (x1 + x1 ** 3) + V[1] * u,
        1,
    ],
    parameters={a0: 1.5, a1: 0.025, c0: 2, c1: -0.03, v1: 1, v2: 2},
)

drem = DremSpec(clock=tau, theta=theta, V=V, theta_degree=1, v_degree=0, gamma=1e22)
