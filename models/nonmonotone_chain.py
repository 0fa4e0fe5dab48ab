"""A three-state chain with Lipschitz but non-monotone nonlinear terms:
an interval observer through the γ-shift (mixed-monotone) decomposition, METHOD §3.

    x1' = -2 x1 + a sin(x2) + b exp(-|x1 - x2|) + u + rho
    x2' = x1 - 3 x2
    x3' = x2 - x3
    y   = x3 + w

A constructed example, not from the seed papers. The interval observer for x1 needs
k = 2 rows (the argument x2 of sin must be a combination of the rows and of y), and in
the reduced model ∂f_i/∂x*_j changes sign (cos of a state, sign(x1 - x2) e^(-|x1 - x2|)):
no sign-definite embedding exists, so the tool shifts each such term by γ = the bound
of its derivative, (φ + γ v) − γ v, and checks that the comparison system of the
interval width is stable (spectral abscissa < 0). With a = b = 1/4 it is (α(M) ≈
−0.66); with a = b = 1/2 it is not (α(M) = 0) and the tool refuses.
Bounds |rho| <= 0.1, |w| <= 0.01 are this example's choice.
"""
import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u, rho, w = sp.symbols("u rho w")
a, b = sp.symbols("a b")

model = PlantModel(
    name="nonmonotone_chain",
    time="continuous",
    states=[x1, x2, x3],
    inputs=[u],
    disturbances=[rho],
    noise=[w],
    outputs=[x3 + w],
    dynamics=[
        -2 * x1 + a * sp.sin(x2) + b * sp.exp(-sp.Abs(x1 - x2)) + u + rho,
        x1 - 3 * x2,
        x2 - x3,
    ],
    parameters={a: sp.Rational(1, 4), b: sp.Rational(1, 4)},
    bounds={rho: (-0.1, 0.1), w: (-0.01, 0.01)},
)
