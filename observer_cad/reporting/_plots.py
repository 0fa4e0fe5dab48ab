"""PNG figures of simulations: signal and estimate, error, interval bounds, residual.

Matplotlib with the non-interactive Agg backend; every figure is written atomically
(temporary file, then ``os.replace``).
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["plot_simulation", "save_figure"]


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, path) -> Path:
    """Save a figure atomically as PNG and close it."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".png", dir=path.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
        _plt().close(fig)
    return path


def _time_label(time: str) -> str:
    return "t [s]" if time == "continuous" else "t [steps]"


def plot_simulation(result, out_dir, *, time: str, title: str = "", units: dict | None = None) -> list:
    """Figures for every observer output found in ``result`` (a SimulationResult).

    - ``<s>_hat``: ``<s>_estimate.png`` (signal and estimate) and ``<s>_error.png``;
    - ``<s>_lower`` / ``<s>_upper``: ``<s>_bounds.png`` (the bounds and, when the
      signal is a column, the signal itself);
    - ``r``: ``residual.png``.

    Axis labels carry units (``x1 [rad]``): ``units`` (column -> unit) if given, else the
    result's own ``units`` (from the model's ``units=``, see
    :func:`observer_cad.simulation.column_units`). Returns the paths written.
    """
    plt = _plt()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    units = dict(getattr(result, "units", None) or {}) if units is None else dict(units)
    t = np.asarray(result["t"], dtype=float)
    names = list(result.order)
    paths = []
    xl = _time_label(time)

    def ylabel(s):
        u = units.get(s)
        return f"{s} [{u}]" if u else s

    for name in names:
        if name.endswith("_hat"):
            s = name[:-4]
            est = np.asarray(result[name], dtype=float)
            fig, ax = plt.subplots(figsize=(7, 3.6))
            if s in result.columns:
                ax.plot(t, result[s], label=f"{s} (true)", color="k", lw=1.6)
            ax.plot(t, est, label=f"{s} estimate", color="tab:red", lw=1.2, ls="--")
            ax.set_xlabel(xl)
            ax.set_ylabel(ylabel(s))
            ax.set_title(f"{title}: {s} and its estimate" if title else f"{s} and its estimate")
            ax.grid(alpha=0.3)
            ax.legend(loc="best")
            paths.append(save_figure(fig, out / f"{s}_estimate.png"))
            if s in result.columns:
                err = est - np.asarray(result[s], dtype=float)
                fig, ax = plt.subplots(figsize=(7, 3.0))
                ax.plot(t, err, color="tab:blue", lw=1.2, label=f"{s} estimate − {s}")
                ax.set_xlabel(xl)
                ax.set_ylabel(f"error{' [' + units[s] + ']' if s in units else ''}")
                ax.set_title(f"{title}: estimation error of {s}" if title else f"estimation error of {s}")
                ax.grid(alpha=0.3)
                ax.legend(loc="best")
                paths.append(save_figure(fig, out / f"{s}_error.png"))
        elif name.endswith("_lower") and name[:-6] + "_upper" in names:
            s = name[:-6]
            lo = np.asarray(result[name], dtype=float)
            hi = np.asarray(result[s + "_upper"], dtype=float)
            fig, ax = plt.subplots(figsize=(7, 3.6))
            ax.fill_between(t, lo, hi, color="tab:blue", alpha=0.18, label="interval")
            ax.plot(t, lo, color="tab:blue", lw=1.0, label=f"{s} lower bound")
            ax.plot(t, hi, color="tab:orange", lw=1.0, label=f"{s} upper bound")
            if s in result.columns:
                ax.plot(t, result[s], color="k", lw=1.4, label=f"{s} (true)")
            ax.set_xlabel(xl)
            ax.set_ylabel(ylabel(s))
            ax.set_title(f"{title}: interval bounds of {s}" if title else f"interval bounds of {s}")
            ax.grid(alpha=0.3)
            ax.legend(loc="best")
            paths.append(save_figure(fig, out / f"{s}_bounds.png"))
        elif name == "r" or (name.startswith("r") and name[1:].isdigit()):
            fig, ax = plt.subplots(figsize=(7, 3.0))
            ax.plot(t, result[name], color="tab:purple", lw=1.2, label=name)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_xlabel(xl)
            ax.set_ylabel(f"residual {ylabel(name)}")
            ax.set_title(f"{title}: residual {name}" if title else f"residual {name}")
            ax.grid(alpha=0.3)
            ax.legend(loc="best")
            paths.append(save_figure(fig, out / f"residual_{name}.png" if name != "r" else out / "residual.png"))
    return paths
