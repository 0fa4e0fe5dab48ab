"""DREM example with an input gain affine in time (this project's, METHOD §5; the class
of seed 003, Dang, Pyrkin, Bobtsov & Vedyakov 2021): N = 2, θ constant, V(t) affine.

    x1' = x2 − θ1 y + V1(t) u
    x2' = −θ2 (y + y³) + V2(t) u,          y = x1
    V1(t) = v10 + v11 t,   V2(t) = v20 + v21 t,   θ = (a0, c0)

i.e. x' = A x + Q(y) θ + V(t) u with A the 2×2 shift and Q(y) = diag(−y, −(y + y³)):
y'' + θ1 y' + θ2 (y + y³) = V1 u' + V1' u + V2 u, an oscillator whose actuator gains
drift. Values (this project's choice; the observer never reads them): θ = (1.5, 2),
V1 = 1 + 0.02 t, V2 = 2 − 0.025 t (scenarios run to t = 40, where V2 = 1). gamma = 1e21
suits dt = 0.02 and the input of scenarios/drem_example_v_affine.json.

Time enters through the clock state tau (tau' = 1, tau(0) = 0).
"""
import sympy as sp

from observer_cad import DremSpec, PlantModel

x1, x2, tau = sp.symbols("x1 x2 tau")
u = sp.Symbol("u")
a0, c0, v10, v11, v20, v21 = sp.symbols("a0 c0 v10 v11 v20 v21")

theta = [a0, c0]
V = [v10 + v11 * tau, v20 + v21 * tau]

model = PlantModel(
    name="drem_example_v_affine",
    time="continuous",
    states=[x1, x2, tau],
    inputs=[u],
    outputs=[x1],
    dynamics=[
        x2 - theta[0] * x1 + V[0] * u,
        -theta[1] * (x1 + x1 ** 3) + V[1] * u,
        1,
    ],
    parameters={a0: 1.5, c0: 2, v10: 1, v11: 0.02, v20: 2, v21: -0.025},
)

drem = DremSpec(clock=tau, theta=theta, V=V, theta_degree=0, v_degree=1, gamma=1e21)
