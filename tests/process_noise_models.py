"""Models with process noise in the dynamics (x' = … + Bw w), shared by the tests.

``drive_with_process_noise``: the electric drive of seed 000 §9 (models/electric_drive.py)
with a bounded torque ripple w3 on the speed equation and w4 on the current equation,
|w3| ≤ 0.002, |w4| ≤ 0.001, besides the measurement noise w1, w2 of the outputs.
``drive_with_process_noise(0)`` keeps the symbols with the process noise's bounds at zero.
"""
from __future__ import annotations

import sympy as sp

from observer_cad import PlantModel

x1, x2, x3 = sp.symbols("x1 x2 x3")
u, d, rho = sp.symbols("u d rho")
w1, w2, w3, w4 = sp.symbols("w1 w2 w3 w4")
k1, k2, k3, k4, k5, k6 = sp.symbols("k1:7")

PROCESS_NOISE = {w3: sp.Rational(1, 500), w4: sp.Rational(1, 1000)}


def drive_with_process_noise(process_bound=1, measurement_bound=1) -> PlantModel:
    """The drive with process noise w3, w4 (bounds scaled by ``process_bound``; those of the
    measurement noise w1, w2 by ``measurement_bound``)."""
    s = sp.Rational(process_bound)
    wm = sp.Rational(measurement_bound) / 100
    return PlantModel(
        name="electric_drive_process_noise",
        time="discrete",
        states=[x1, x2, x3],
        inputs=[u],
        faults=[d],
        disturbances=[rho],
        noise=[w1, w2, w3, w4],
        outputs=[x1 + w1, x3 + w2],
        dynamics=[
            x1 + k1 * x2,
            k2 * x2 + k3 * x3 + rho + w3,
            k4 * x2 + k5 * x3 + k6 * u + d + 2 * w4,
        ],
        parameters={k1: sp.Rational(1, 500), k2: sp.Rational(4, 5), k3: sp.Rational(1, 50),
                    k4: sp.Rational(-1, 2500), k5: sp.Rational(24, 25), k6: sp.Rational(1, 25)},
        bounds={d: (-0.4, 0.4), rho: (-0.05, 0.05), w1: (-wm, wm), w2: (-wm, wm),
                w3: (-s * PROCESS_NOISE[w3], s * PROCESS_NOISE[w3]),
                w4: (-s * PROCESS_NOISE[w4], s * PROCESS_NOISE[w4])},
    )
