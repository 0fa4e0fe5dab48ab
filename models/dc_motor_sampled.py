"""A DC motor driving a load through an elastic coupling, continuous time, sampled: the worked
example of sampled-data guaranteed thresholds (this project's own example; METHOD §3,
residual evaluation).

    i'  = 2 u − 4 i − ω + d                   armature current (d: actuator / current fault)
    ω'  = 5 i − b ω − 3 (ω − ωl)              motor speed, friction b uncertain
    ωl' = 3 (ω − ωl) − ωl − ρ                 load speed, ρ an unknown load torque
    y1 = i + w1,  y2 = ω + w2,  y3 = ωl + w3  three sensors with bounded noise

The friction b is known to ±5 % (b ∈ [1.9, 2.1], nominal 2); the load torque ρ is decoupled
by the residual generator, the friction is not (it is bounded instead). The operating
envelope (bounds on the states and the input) and the box of the unknown initial state are
what the sampled-data band rests on besides the noise and disturbance bounds. Recorded data
of this plant: examples/dc_motor_sampled.csv (solve_ivp of the continuous plant, ZOH input).
"""
import sympy as sp

from observer_cad import PlantModel

i, w, wl = sp.symbols("i w wl")
u, d, rho = sp.symbols("u d rho")
w1, w2, w3 = sp.symbols("w1 w2 w3")
b = sp.Symbol("b")

model = PlantModel(
    name="dc_motor_sampled",
    time="continuous",
    states=[i, w, wl],
    inputs=[u],
    faults=[d],
    disturbances=[rho],
    noise=[w1, w2, w3],
    outputs=[i + w1, w + w2, wl + w3],
    dynamics=[
        2 * u - 4 * i - w + d,
        5 * i - b * w - 3 * (w - wl),
        3 * (w - wl) - wl - rho,
    ],
    parameters={b: 2},
    uncertainty={b: (sp.Rational(19, 10), sp.Rational(21, 10))},
    bounds={u: (-5, 5), i: (-4, 4), w: (-5, 5), wl: (-5, 5),
            d: (-2, 2), rho: (-sp.Rational(1, 2), sp.Rational(1, 2)),
            w1: (-sp.Rational(1, 100), sp.Rational(1, 100)),
            w2: (-sp.Rational(1, 100), sp.Rational(1, 100)),
            w3: (-sp.Rational(1, 100), sp.Rational(1, 100))},
    initial={i: (-sp.Rational(1, 2), sp.Rational(1, 2)), w: (-1, 1), wl: (-1, 1)},
    units={i: "A", w: "rad/s", wl: "rad/s", u: "V", d: "A/s", rho: "rad/s^2",
           w1: "A", w2: "rad/s", w3: "rad/s"},
)
