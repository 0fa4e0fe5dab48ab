"""What the demo's figures share: matplotlib (Agg) and the figures' style, the signals'
LaTeX names, units on axes, the text boxes and number format, and the panels several
papers' figures draw (an interval with its bounds, a zoomed inset).
"""
from __future__ import annotations

import numpy as np

__all__ = ["pyplot", "STYLE", "SIGNAL_TEX", "unit_of", "in_brackets", "after_number", "text_box",
           "sci", "aligned", "interval_panel", "zoom_inset"]


def unit_of(res, name: str) -> str:
    """The unit of a column, from the model's ``units=`` (via the result); "" when none."""
    return (getattr(res, "units", None) or {}).get(name, "")


def in_brackets(unit: str) -> str:
    """`` [unit]`` for an axis label, or nothing."""
    return f" [{unit}]" if unit else ""


def after_number(unit: str) -> str:
    """`` unit`` after a number, or nothing."""
    return f" {unit}" if unit else ""


SIGNAL_TEX = {"d": "d", "rho": r"\rho", "x1": "x_1", "x2": "x_2", "x3": "x_3"}


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


#: matplotlib settings of the demo's figures (applied in a context, not globally)
STYLE = {"font.size": 10, "axes.titlesize": 11, "legend.fontsize": 9,
         "axes.grid": True, "grid.alpha": 0.3, "lines.linewidth": 1.4,
         "figure.subplot.hspace": 0.1, "figure.subplot.left": 0.1,
         "figure.subplot.right": 0.97, "figure.subplot.top": 0.94,
         "figure.subplot.bottom": 0.08}


def text_box(ax, text, loc="upper left"):
    x, ha = (0.01, "left") if "left" in loc else (0.99, "right")
    y, va = (0.96, "top") if "upper" in loc else (0.04, "bottom")
    ax.text(x, y, text, transform=ax.transAxes, ha=ha, va=va, fontsize=9,
            bbox=dict(boxstyle="round,pad=0.3", fc="white", ec="0.6", alpha=0.92), zorder=5)


def sci(v: float) -> str:
    if v == 0:
        return "0"
    e = int(np.floor(np.log10(abs(v))))
    m = v / 10 ** e
    return rf"${m:.1f}\times10^{{{e}}}$" if abs(e) >= 3 else f"{v:.3g}"


def aligned(res, name, delay):
    """(t, true, estimate) where the estimate exists (a delayed estimate is shifted back
    by the simulator; its last ``delay`` rows are NaN)."""
    t, true, est = (np.asarray(res[c], dtype=float) for c in ("t", name, f"{name}_hat"))
    ok = np.isfinite(est)
    return t[ok], true[ok], est[ok]


def interval_panel(ax, res, name, *, t_max=None, unit=None, label_true=None, colors=("tab:blue", "tab:orange")):
    t = np.asarray(res["t"])
    sel = slice(None) if t_max is None else (t <= t_max)
    lo, hi, z = (np.asarray(res[c])[sel] for c in (f"{name}_lower", f"{name}_upper", name))
    ts = t[sel]
    sym = SIGNAL_TEX.get(name, name)
    letter, _, sub = sym.partition("_")
    sub = f"_{sub}" if sub else ""
    ax.fill_between(ts, lo, hi, color=colors[0], alpha=0.15, lw=0)
    ax.plot(ts, hi, color=colors[1], lw=1.2, label=rf"upper bound $\overline{{{letter}}}{sub}$")
    ax.plot(ts, lo, color=colors[0], lw=1.2, label=rf"lower bound $\underline{{{letter}}}{sub}$")
    ax.plot(ts, z, color="k", lw=1.4, label=label_true or rf"${sym}$ (true)")
    ax.set_ylabel(rf"${sym}$" + in_brackets(unit_of(res, name) if unit is None else unit))
    full_lo, full_hi, full_z = (np.asarray(res[c]) for c in (f"{name}_lower", f"{name}_upper", name))
    viol = int(np.sum((full_z < full_lo - 1e-9) | (full_z > full_hi + 1e-9)))
    return viol


def zoom_inset(ax, res, name, t0, t1, rect, colors=("tab:blue", "tab:orange")):
    """An inset magnifying [t0, t1], where the bounds are too close to tell apart."""
    t = np.asarray(res["t"])
    sel = (t >= t0) & (t <= t1)
    lo, hi, z = (np.asarray(res[c])[sel] for c in (f"{name}_lower", f"{name}_upper", name))
    ins = ax.inset_axes(rect)
    ins.fill_between(t[sel], lo, hi, color=colors[0], alpha=0.15, lw=0)
    ins.plot(t[sel], hi, color=colors[1], lw=1.1)
    ins.plot(t[sel], lo, color=colors[0], lw=1.1)
    ins.plot(t[sel], z, color="k", lw=1.2)
    pad = 0.15 * (np.max(hi) - np.min(lo))
    ins.set_ylim(np.min(lo) - pad, np.max(hi) + pad)
    ins.set_xlim(t0, t1)
    ins.tick_params(labelsize=7)
    ins.set_title(f"zoom, t ∈ [{t0:g}, {t1:g}] s", fontsize=8, pad=2)
    ins.grid(alpha=0.3)
    ax.indicate_inset_zoom(ins, edgecolor="0.4")
    return ins
