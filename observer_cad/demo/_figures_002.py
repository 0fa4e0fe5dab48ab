"""The figures of seed 002 (the nonlinear three-tank, §8, and the sliding-mode estimator,
§5): Fig. 2 (the Jordan virtual sensor for x1), Fig. 3 (the interval observer of x1 at
two noise levels) and the sliding-mode estimate of the fault d.

Each figure function takes the outcomes by case key (and the file it goes to) and
returns (figure, caption).
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from ._plotting import after_number, in_brackets, interval_panel, pyplot, text_box, unit_of, zoom_inset

__all__ = ["fig_002_2", "fig_002_3", "fig_sliding"]


def fig_002_2(outs, path):
    plt = pyplot()
    o = outs["tank_vs"]
    res = o.sims["three_tank_fig2"]
    t, x1, z = res["t"], res["x1"], res["x1_hat"]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.8), height_ratios=[3, 2])
    a.plot(t, x1, color="k", lw=1.8, label=r"$x_1(t)$ (true level, tank 1)")
    a.plot(t, z, color="tab:red", ls="--", lw=1.5, label=r"$z(t) = x^*(t)$ (virtual sensor)")
    for tt, what, ha in ((1, r"$u_1 = 1$", "left"), (5, r"$u_2 = 0.5$", "right"),
                         (6, r"$\rho_1 = -0.3$", "left"), (10, r"$\rho_2 = -0.4$", "left")):
        a.axvline(tt, color="0.55", ls=":", lw=1.0)
        a.text(tt + (0.12 if ha == "left" else -0.12), 0.97, what, fontsize=8, color="0.3", ha=ha,
               va="top", transform=a.get_xaxis_transform())
    a.set_ylim(-0.15, 1.15 * np.max(x1) + 0.1)
    a.set_ylabel(r"level $x_1$" + in_brackets(unit_of(res, "x1")))
    a.set_title("Seed 002, Fig. 2: virtual sensor $\\dot{x}^* = u_1 - \\sqrt{x^* - y_1}$ for $x_1$ (λ = −1, k = 1)")
    a.legend(loc="lower right")
    e = np.abs(z - x1)
    b.semilogy(t, np.maximum(e, 1e-17), color="tab:blue", lw=1.4, label=r"$|z - x_1|$")
    for tt in (1, 5, 6, 10):
        b.axvline(tt, color="0.55", ls=":", lw=1.0)
    b.set_ylabel(r"$|z - x_1|$" + in_brackets(unit_of(res, "x1")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    text_box(b, f"sensor starts at x*(0) = 0.5, x1(0) = 0: the error decays ({e[0]:.2g} → {e[-1]:.1e}{after_number(unit_of(res, 'x1'))} at t = 20)\n"
            "and does not react to the steps of ρ1, ρ2 (decoupled)", "lower left")
    return fig, (f"Seed 002 Fig. 2 — nonlinear three-tank, u1 = 1 (t > 1), u2 = 0.5 (t > 5), ρ1 = −0.3"
                 f" (t > 6), ρ2 = −0.4 (t > 10), no noise: x1 and the virtual sensor z; the error decays"
                 f" from 0.5 to {e[-1]:.1e} m, unaffected by ρ1, ρ2.")


def fig_002_3(outs, path):
    plt = pyplot()
    cases = [("tank_interval", "three_tank_interval", "0.01"),
             ("tank_interval_w05", "three_tank_interval_w05", "0.05")]
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 8.2), height_ratios=[3, 3, 2],
                             gridspec_kw=dict(hspace=0.16))
    total = []
    for ax, (key, sc, w) in zip(axes[:2], cases):
        res = outs[key].sims[sc]
        v = interval_panel(ax, res, "x1")
        total.append(v)
        ax.set_title(f"|w| ≤ {w}" if ax is not axes[0] else
                     f"Seed 002, Fig. 3: interval observer for $x_1$ of the nonlinear three-tank — |w| ≤ {w}",
                     fontsize=11 if ax is axes[0] else 10)
        if ax is not axes[0]:
            ax.set_title(f"same, with noise |w| ≤ {w}")
        ax.legend(loc="upper right", ncols=3)
        ax.set_ylim(0.9, 2.3)
        text_box(ax, f"x1 inside the bounds at all {len(res['t'])} steps ({v} violations)", "lower left")
        zoom_inset(ax, res, "x1", 14, 16, [0.52, 0.47, 0.26, 0.32])
    c = axes[2]
    for (key, sc, w), col in zip(cases, ("tab:blue", "tab:red")):
        res = outs[key].sims[sc]
        width = np.asarray(res["x1_upper"]) - np.asarray(res["x1_lower"])
        c.semilogy(res["t"], width, color=col, lw=1.4, label=f"|w| ≤ {w}: width → {width[-1]:.3g}{after_number(unit_of(res, 'x1'))}")
    c.set_ylabel("width" + in_brackets(unit_of(res, "x1")))
    c.set_xlabel("t [s]")
    c.legend(loc="upper right")
    return fig, (f"Seed 002 Fig. 3 — interval bounds of x1 (u1 = 0.5, u2 = 0.2, ρ1, ρ2 random in ±0.5) for"
                 f" two noise levels, |w| ≤ 0.01 and 0.05: the true x1 stays inside"
                 f" ({sum(total)} violations); more noise, wider bounds (bottom).")


def fig_sliding(outs, path):
    plt = pyplot()
    o = outs["sliding"]
    res = o.sims["sliding_example"]
    t, d, dh = res["t"], res["d"], res["d_hat"]
    k1 = float(o.observer.parameters[sp.Symbol("k_sm")])
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.8), height_ratios=[3, 2])
    a.plot(t, d, color="k", lw=2.2, label="d (true)")
    a.plot(t, dh, color="tab:red", ls="--", lw=1.3, label=r"$\hat{d}$ (sliding-mode estimate)")
    a.set_ylabel("d" + in_brackets(unit_of(res, "d")))
    a.set_ylim(-1.3, k1 + 0.9)
    a.set_title(f"Sliding-mode estimator of the fault d (sliding example, λ = −1, k1 = {k1:.3g})")
    a.legend(loc="upper right")
    err = np.abs(dh - d)
    reach = float(t[np.argmax(err < 0.01)]) if np.any(err < 0.01) else float("nan")
    a.annotate(f"reaching phase: d̂ saturated at k1 = {k1:.3g} until t ≈ {reach:.2f} s", xy=(reach / 2, k1),
               xytext=(1.0, k1 + 0.45), fontsize=8.5, arrowprops=dict(arrowstyle="->", color="0.3"))
    b.semilogy(t, np.maximum(err, 1e-12), color="tab:blue", lw=1.2, label=r"$|\hat{d} - d|$")
    b.set_ylabel(r"$|\hat{d} - d|$" + in_brackets(unit_of(res, "d")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    late = t >= 1
    b.text(0.1, 0.55, f"t ≥ 1 s: max|d̂ − d| = {np.max(err[late]):.2g}{after_number(unit_of(res, 'd'))}\n(boundary layer ε = 0.001:"
           " not an ideal sliding mode)", transform=b.transAxes, fontsize=9, va="center",
           bbox=dict(boxstyle="round,pad=0.3", fc="white", ec="0.6", alpha=0.92))
    return fig, (f"Sliding-mode estimator (this project's example): after a reaching phase of"
                 f" {reach:.2f} s the estimate follows d with max error {np.max(err[late]):.2g}{after_number(unit_of(res, 'd'))}"
                 " while the disturbance ρ = 0.4 sin 3t acts (decoupled).")
