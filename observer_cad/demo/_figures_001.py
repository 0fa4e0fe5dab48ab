"""The figures of seeds 001 and 004 (the linear three-tank): seed 001 Fig. 2 (the interval
observers of x1, methods 1 and 2) and the virtual sensors for x1 (canonical, seed 004's
variant, Jordan).

Each figure function takes the outcomes by case key (and the file it goes to) and
returns (figure, caption).
"""
from __future__ import annotations

import numpy as np

from ._plotting import (after_number, in_brackets, interval_panel, pyplot, sci, text_box, unit_of,
                        zoom_inset)

__all__ = ["fig_001_2", "fig_lin_virtual"]


def fig_001_2(outs, path):
    plt = pyplot()
    res2 = outs["lin_interval_m2"].sims["three_tank_linear_interval"]
    res1 = outs["lin_interval_m1"].sims["three_tank_linear_interval"]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.0), height_ratios=[3, 2])
    v2 = interval_panel(a, res2, "x1")
    v1 = int(np.sum((res1["x1"] < res1["x1_lower"] - 1e-9) | (res1["x1"] > res1["x1_upper"] + 1e-9)))
    a.set_title("Seed 001, Fig. 2: interval observer (7.2) for $x_1$ of the linear three-tank (method 2, k = 1)")
    a.legend(loc="lower right")
    text_box(a, f"x1 inside at all {len(res2['t'])} steps ({v2} violations)", "upper left")
    zoom_inset(a, res2, "x1", 14, 16, [0.33, 0.08, 0.3, 0.36])
    for res, lab, col in ((res2, "method 2 (Jordan, k = 1)", "tab:blue"),
                          (res1, "method 1 (canonical → diagonal, k = 2)", "tab:green")):
        w = np.asarray(res["x1_upper"]) - np.asarray(res["x1_lower"])
        b.semilogy(res["t"], w, color=col, lw=1.4, label=f"{lab}: width → {w[-1]:.3g}{after_number(unit_of(res, 'x1'))}")
    b.set_ylabel(r"width $\overline{x}_1 - \underline{x}_1$" + in_brackets(unit_of(res2, "x1")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    return fig, (f"Seed 001 Fig. 2 — linear three-tank, u1 = 1 (t ≥ 1), u2 = 0.5 (t ≥ 5), ρ and noise random"
                 f" in ±0.2, ±0.02: x1 and its bounds (method 2, {v2} violations); method 1 ({v1}"
                 f" violations) converges to the same width 2w* = 0.04{after_number(unit_of(res2, 'x1'))} (bottom).")


def fig_lin_virtual(outs, path):
    plt = pyplot()
    # drawn wide-to-narrow so that coinciding curves stay visible
    keys = (("lin_vs_plain", "canonical (k = 2, eigenvalues −1, −2)", "tab:red", "-", 5.0, 0.35),
            ("lin_vs_004", "seed 004 variant (k = 2, eigenvalues −1, −2)", "tab:green", "--", 2.4, 0.9),
            ("lin_vs_jordan", "Jordan (k = 1, λ = −1)", "tab:purple", ":", 1.6, 1.0))
    sc = "three_tank_linear_virtual"
    base = outs[keys[0][0]].sims[sc]
    t = base["t"]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.0), height_ratios=[3, 2])
    a.plot(t, base["x1"], color="k", lw=1.6, label=r"$x_1$ (true)", zorder=5)
    errs = []
    for key, lab, col, ls, lw, al in keys:
        r = outs[key].sims[sc]
        a.plot(t, r["x1_hat"], color=col, ls=ls, lw=lw, alpha=al, label=rf"$\hat{{x}}_1$ {lab}")
        e = np.abs(r["x1_hat"] - r["x1"])
        errs.append(e)
        b.semilogy(t, np.maximum(e, 1e-17), color=col, ls=ls, lw=lw, alpha=al, label=lab)
    for ax in (a, b):
        ax.axvline(10, color="0.55", ls=":", lw=1.0)
    a.text(10.12, 0.97, "ρ = −0.2 from t = 10", fontsize=8, color="0.3", va="top",
           transform=a.get_xaxis_transform())
    a.set_ylabel(r"level $x_1$" + in_brackets(unit_of(base, "x1")))
    a.set_title("Linear three-tank: virtual sensors for $x_1$ (seeds 001, 004), started at $x^*(0) = 0$")
    a.legend(loc="lower right")
    b.set_ylabel(r"$|\hat{x}_1 - x_1|$" + in_brackets(unit_of(base, "x1")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    spread = max(float(np.max(np.abs(errs[i] - errs[0]))) for i in range(len(errs)))
    text_box(b, f"the three errors coincide (max difference {sci(spread)}{after_number(unit_of(base, 'x1'))}): each is −x1(0)·e^(−t);\n"
            "no reaction to the disturbance step at t = 10 (decoupled)", "lower left")
    return fig, ("Linear three-tank, no noise, inputs as in seed 002 Fig. 2 and a disturbance step ρ = −0.2"
                 " at t = 10: three virtual sensors for x1 (started at 0) converge exponentially — their"
                 " errors coincide, −x1(0)·e^(−t) — and are blind to ρ.")
