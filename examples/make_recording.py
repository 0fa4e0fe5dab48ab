"""Make examples/three_tank_recording.csv: a recording of the three-tank plant of
models/three_tank_isolation.py as a data logger would take it, for ``observer-cad monitor``.

The true continuous plant is integrated by scipy's ``solve_ivp`` (RK45, rtol 1e-10,
atol 1e-12) from one sample to the next; the inputs are held over each interval (a
zero-order hold, as a controller's output), the disturbance varies smoothly inside it,
and the outputs are sampled at the sample times with bounded measurement noise (seeded).

    u1 = 1 + 0.5 sin(0.3 t_k) held,  u2 = 0.5 from t = 5 held
    rho(t) = 0.1 sin(0.7 t)          (declared bound 0.2)
    w ~ U[-0.005, 0.005] per sample  (declared bound 0.02)
    f2 = 0.3 from t = 20             (a step fault of pump 2)
    x(0) = 0, h = 0.05 s, t = 0 … 30 s (601 rows)

    python3 examples/make_recording.py [OUT.csv] [--fault-free] [--seed N]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

HERE = Path(__file__).resolve().parent
MODEL = HERE.parent / "models" / "three_tank_isolation.py"
H, T_END, FAULT_AT, FAULT = 0.05, 30.0, 20.0, 0.3


def inputs(t: float) -> dict:
    """The held inputs at the sample time t."""
    return {"u1": 1 + 0.5 * math.sin(0.3 * t), "u2": 0.5 if t >= 5 else 0.0}


def recording(*, fault: bool = True, seed: int = 0, h: float = H, t_end: float = T_END,
              noise: float = 0.005) -> dict:
    """The columns t, u1, u2, y1, y2, y3 of the recording (numpy arrays)."""
    from observer_cad import load_model
    m = load_model(MODEL)
    xs, us = list(m.states), list(m.inputs)
    sym = {s.name: s for s in list(m.faults) + list(m.disturbances) + list(m.noise)}
    rhs = sp.lambdify([sp.Symbol("t"), xs, us, [sym["f1"], sym["f2"], sym["f3"], sym["rho"]]],
                      list(m.dynamics), modules="math")
    out = sp.lambdify([xs, [sym["w1"], sym["w2"], sym["w3"]]], list(m.outputs), modules="math")
    rng = np.random.default_rng(seed)
    n = int(round(t_end / h)) + 1
    t = np.arange(n) * h
    x = np.zeros(len(xs))
    cols = {k: np.empty(n) for k in ("t", "u1", "u2", "y1", "y2", "y3")}
    for k in range(n):
        u = inputs(t[k])
        f2 = FAULT if fault and t[k] >= FAULT_AT else 0.0
        w = rng.uniform(-noise, noise, 3)
        cols["t"][k] = t[k]
        cols["u1"][k], cols["u2"][k] = u["u1"], u["u2"]
        cols["y1"][k], cols["y2"][k], cols["y3"][k] = out(list(x), list(w))
        if k + 1 < n:
            sol = solve_ivp(lambda tt, xx: rhs(tt, list(xx), [u["u1"], u["u2"]],
                                               [0.0, f2, 0.0, 0.1 * math.sin(0.7 * tt)]),
                            (t[k], t[k + 1]), x, method="RK45", rtol=1e-10, atol=1e-12)
            x = sol.y[:, -1]
    return cols


def write_csv(cols: dict, path) -> None:
    names = list(cols)
    lines = [",".join(names)]
    for k in range(len(cols["t"])):
        lines.append(",".join(f"{cols[c][k]:.10g}" for c in names))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default=str(HERE / "three_tank_recording.csv"))
    ap.add_argument("--fault-free", action="store_true", help="no fault")
    ap.add_argument("--seed", type=int, default=0, help="the noise's seed (default 0)")
    a = ap.parse_args()
    write_csv(recording(fault=not a.fault_free, seed=a.seed), a.out)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
