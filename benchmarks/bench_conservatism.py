"""How conservative is the guaranteed band? For each linear example, the width of its
sampled-data guaranteed band (observer_cad.residuals.sampled_threshold) against the largest
fault-free residual a falsification search finds on the plant itself.

    python3 benchmarks/bench_conservatism.py            # print the table
    python3 benchmarks/bench_conservatism.py --write    # ... and update benchmarks/README.md

The search runs the discrete algorithm that runs deployed (observer_step at the band's sample
time and discretisation) on the plant discretised exactly (continuous plants: zero-order hold
of the input and of a disturbance held over each sample interval, which a bang-bang
disturbance is). It measures the response of r to a unit impulse of every noise, disturbance
and input channel by simulation, then drives every channel bang-bang with the sign of its
response so that r(k*) is as large (or as small) as it can be at the last sample k*, at every
corner of the parameter box, from the worst corner of the initial box. Ratio = band edge /
residual found at k* (1.00: the band is attained).
"""
from __future__ import annotations

import argparse
import dataclasses
import itertools
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg
import sympy as sp

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from common import load, machine, publish  # noqa: E402

from observer_cad import build_observer, design, load_model  # noqa: E402
from observer_cad.analysis import design_bank  # noqa: E402
from observer_cad.codegen import observer_step, split_signals  # noqa: E402
from observer_cad.residuals import (guaranteed_threshold, residual_names,  # noqa: E402
                                    sampled_threshold)

ROOT = HERE.parent
README = HERE / "README.md"
BEGIN = "<!-- BEGIN CONSERVATISM RESULTS (bench_conservatism.py --write) -->"
END = "<!-- END CONSERVATISM RESULTS -->"


def _envelope(m, states, inputs):
    b = dict(m.bounds)
    b.update(dict(zip(m.states, states)))
    b.update(dict(zip(m.inputs, inputs)))
    return dataclasses.replace(m, bounds=b)


def examples():
    """(name, model with envelope, observer, h, discretisation, steps); discretisation
    "adaptive": the online interval band (guaranteed_threshold) of a discrete-time model."""
    out = []
    m = load_model(ROOT / "models" / "dc_motor_sampled.py")
    out.append(("dc_motor_sampled (h = 0.01, RK4)", m,
                build_observer(m, design(m, observer="diagnostic", lambdas=[-4])),
                sp.Rational(1, 100), "rk4", 600))
    m = _envelope(load_model(ROOT / "models" / "three_tank_faults.py"),
                  [(-2, 7)] * 3, [(0, 1)] * 2)
    ob = build_observer(m, design_bank(m))
    for h, steps in ((sp.Rational(1, 100), 2000), (sp.Rational(1, 1000), 16000)):
        out.append((f"three_tank_faults bank (h = {h}, ZOH)", m, ob, h, "zoh", steps))
    for name in ("electric_drive", "electric_drive_uncertain"):
        m = _envelope(load_model(ROOT / "models" / f"{name}.py"),
                      [(-10, 10), (-1, 1), (-3, 3)], [(-2, 2)])
        ob = build_observer(m, design(m, observer="diagnostic"))
        out.append((f"{name} (discrete)", m, ob, None, "rk4", 200))
        if m.uncertainty:
            out.append((f"{name} (discrete, adaptive band)", m, ob, None, "adaptive", 200))
    return out


def _plant(m, theta, h):
    """x⁺ = E x + Gu u + Gr ρ, y = Cy x + Wy w at the parameter values theta."""
    vals = dict(m.parameter_values())
    vals.update(theta)
    f = sp.Matrix([sp.sympify(e).xreplace(vals).xreplace({d: 0 for d in m.faults})
                   for e in m.dynamics])
    y = sp.Matrix([sp.sympify(e).xreplace(vals) for e in m.outputs])
    jac = lambda M, v: np.array(M.jacobian(list(v)).tolist(), dtype=float).reshape(M.rows, len(v))  # noqa: E731
    A, B, L = jac(f, m.states), jac(f, m.inputs), jac(f, m.disturbances)
    Cy, Wy = jac(y, m.states), jac(y, m.noise)
    n = A.shape[0]
    if h is None:
        return A, B, L, Cy, Wy
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n], M[:n, n:] = A * float(h), np.eye(n) * float(h)
    E = scipy.linalg.expm(M)
    return E[:n, :n], E[:n, n:] @ B, E[:n, n:] @ L, Cy, Wy


class Runner:
    """The deployed algorithm on the exactly discretised plant."""

    def __init__(self, m, ot, h, how):
        self.m, self.ot = m, ot
        self.f = observer_step(ot, h=None if h is None else float(h),
                               discretisation=how if h is not None else "rk4")
        self.ys, self.us = split_signals(ot)
        self.names = [n for n, _ in ot.outputs]
        self.res = residual_names(ot)
        self.acc = {}

    def __call__(self, plant, x0, u, rho, w):
        E, Gu, Gr, Cy, Wy = plant
        N = u.shape[0]
        x = np.array(x0, dtype=float)
        xi = np.array([float(self.ot.initial[s].xreplace(dict(zip(self.m.states, x0))))
                       if hasattr(self.ot.initial[s], "xreplace") else float(self.ot.initial[s])
                       for s in self.ot.states])
        yidx = [int(str(s)[1:]) - 1 for s in self.ys]
        uidx = [list(self.m.inputs).index(s) for s in self.us]
        X, Y = np.zeros((N, len(x))), np.zeros((N, Cy.shape[0]))
        for k in range(N):  # the plant does not depend on the observer: simulate it first
            X[k] = x
            Y[k] = Cy @ x + Wy @ w[k]
            x = E @ x + Gu @ u[k] + Gr @ rho[k]
        if N not in self.acc:
            self.acc[N] = self.f.mapaccum(N)
        _, out = self.acc[N](xi, Y[:, yidx].T, u[:, uidx].T, np.zeros((0, N)))
        out = np.array(out)  # outputs × N, at the state before each step
        R = np.stack([out[self.names.index(r)] for r in self.res], axis=1)
        band = np.stack([np.stack([out[self.names.index(f"{r}_lower")],
                                   out[self.names.index(f"{r}_upper")]], axis=1)
                         for r in self.res], axis=1)
        return R, X, band


def _box(m, syms):
    return np.array([[float(m.bounds[s][0]), float(m.bounds[s][1])] for s in syms]).reshape(len(syms), 2)


def falsify(m, ot, h, how, steps):
    """Largest r(k*) and smallest found, per residual; the band at k*; envelope respected;
    whether the residual stayed inside its band at every sample of every run. At each
    corner of the parameter box the plant is LTI: its own impulse responses (not the
    nominal plant's) give the bang-bang signals that reach the largest r(k*) there, and
    its response to x(0) the worst corner of the initial box."""
    run = Runner(m, ot, h, how)
    ub, rb, wb = _box(m, m.inputs), _box(m, m.disturbances), _box(m, m.noise)
    x0c = np.array([float(sum(m.initial[x]) / 2) if m.initial else 0.0 for x in m.states])
    base = [np.tile(b.mean(axis=1), (steps, 1)) for b in (ub, rb, wb)]
    corners = list(itertools.product(*[(lo, hi) for lo, hi in m.uncertainty.values()]))
    found = np.zeros((len(run.res), 2))
    band, inside, included = None, True, True
    env = _box(m, m.states)
    k = steps - 1
    for corner in corners or [()]:
        plant = _plant(m, dict(zip(m.uncertainty, corner)), h)
        R0, _, _ = run(plant, x0c, *base)
        chans = []  # (signal index, channel) → impulse response of r (steps × residuals)
        for si, box in enumerate((ub, rb, wb)):
            for j in range(box.shape[0]):
                sig = [b.copy() for b in base]
                sig[si][0, j] += 1.0
                R, _, _ = run(plant, x0c, *sig)
                chans.append((si, j, R - R0))
        x0resp = []  # the response of r to a unit step of x(0) in each boxed direction
        for j, x in enumerate(m.states):
            if x in m.initial:
                R, _, _ = run(plant, x0c + np.eye(len(m.states))[j], *base)
                x0resp.append((j, R - R0))
        for i in range(len(run.res)):
            for side, s in enumerate((-1.0, 1.0)):
                x0 = x0c.copy()  # the worst corner of the initial box for r(k*)
                for j, g in x0resp:
                    lo, hi = (float(v) for v in m.initial[m.states[j]])
                    x0[j] = hi if s * g[k, i] >= 0 else lo
                sig = [b.copy() for b in base]
                for si, j, g in chans:
                    box = (ub, rb, wb)[si][j]
                    resp = g[k::-1, i]  # response at k* of a unit at time 0 … k*
                    sig[si][: k + 1, j] = np.where(s * resp >= 0, box[1], box[0])
                R, X, B = run(plant, x0, *sig)
                inside &= bool(np.all((X >= env[:, 0] - 1e-9) & (X <= env[:, 1] + 1e-9)))
                included &= bool(np.all((R >= B[:, :, 0]) & (R <= B[:, :, 1])))
                found[i, side] = max(found[i, side], s * R[k, i])
                band = B[k]
    return found, band, inside, included


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="update benchmarks/README.md")
    args = ap.parse_args(argv)
    started = time.strftime("%Y-%m-%d")
    rows = ["| example | residual | band [lower, upper] | falsified [min, max] | ratio | in envelope | r inside its band | seconds |",
            "|---|---|---|---|---|---|---|---|"]
    worst = 0.0
    for name, m, ob, h, how, steps in examples():
        t0 = time.perf_counter()
        if how == "adaptive":
            ot, how = guaranteed_threshold(m, ob), "rk4"
        elif h is not None:
            ot = sampled_threshold(m, ob, h, discretisation=how)
        else:
            ot = sampled_threshold(m, ob)
        found, band, inside, included = falsify(m, ot, h, how, steps)
        secs = time.perf_counter() - t0
        for i, r in enumerate(residual_names(ot)):
            lo, up = band[i]
            ratio = max(up / found[i, 1] if found[i, 1] > 0 else np.inf,
                        -lo / found[i, 0] if found[i, 0] > 0 else np.inf)
            worst = max(worst, ratio)
            rows.append(f"| {name} | {r} | [{lo:.4g}, {up:.4g}] | [{-found[i, 0]:.4g}, {found[i, 1]:.4g}]"
                        f" | {ratio:.2f} | {'yes' if inside else 'no'} | {'yes' if included else '**NO**'}"
                        f" | {secs:.1f} |")
        print(rows[-1], flush=True)
    mc = machine()
    table = "\n".join([f"Measured {started} by `python3 benchmarks/bench_conservatism.py --write`"
                       f" on {mc['nproc']} CPUs ({mc['cpu']}), load {load()}:", ""] + rows
                      + ["", f"Largest ratio: {worst:.2f} (goal ≤ 1.2). The sampled band bounds an"
                         " uncertain parameter's term δ·x with the envelope of x at every sample;"
                         " where x is measured, the adaptive band (from y online) follows the"
                         " measured signal (its row: the band at k* of the worst run)."])
    publish(table, README, BEGIN, END, write=args.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
