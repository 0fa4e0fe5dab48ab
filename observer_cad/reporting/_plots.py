"""PNG figures of simulations: signal and estimate, error, interval bounds, residual.

Matplotlib with the non-interactive Agg backend; every figure is written atomically
(temporary file, then ``os.replace``).
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import new_file_mode

__all__ = ["plot_simulation", "save_figure", "plot_residuals", "plot_confusion",
           "residual_names"]

#: at most this many diagnosis changes are written on a residual figure
MAX_ANNOTATIONS = 12


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
        os.chmod(tmp, new_file_mode())  # (mkstemp's 0o600 otherwise)
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
        _plt().close(fig)
    return path


def _time_label(time: str) -> str:
    return "t [s]" if time == "continuous" else "t [steps]"


def _is_residual(name: str) -> bool:
    return name == "r" or (name.startswith("r") and name[1:].isdigit())


def residual_names(result) -> tuple:
    """The residual columns (``r``, ``r1`` …) of a result that have threshold columns
    ``<r>_lower`` and ``<r>_upper``, in column order."""
    names = list(result.order)
    return tuple(n for n in names if _is_residual(n) and f"{n}_lower" in names
                 and f"{n}_upper" in names)


def _run0(v) -> np.ndarray:
    a = np.asarray(v)
    return a[0] if a.ndim == 2 else a


def _spans(mask: np.ndarray):
    """(start, stop) index pairs of the runs of True in a 1-D mask (stop exclusive)."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[::2], d[1::2]))


def _residual_axes(ax, t, result, name, *, alarm=None, ylabel="", xl=""):
    """One residual with its threshold band, the samples out of it (x) and, when
    ``alarm`` is given, the alarm spans (shaded)."""
    r = _run0(result[name]).astype(float)
    lo = _run0(result[f"{name}_lower"]).astype(float)
    hi = _run0(result[f"{name}_upper"]).astype(float)
    ax.fill_between(t, lo, hi, color="tab:green", alpha=0.18, step="mid",
                    label="threshold band (fault-free)")
    ax.plot(t, r, color="tab:purple", lw=1.1, label=name)
    with np.errstate(invalid="ignore"):
        out = (r < lo) | (r > hi)
    if out.any():
        ax.plot(t, np.where(out, r, np.nan), color="tab:red", lw=1.6, marker=".", ms=2.5,
                label="outside the band")
    if alarm is not None:
        dt = float(t[1] - t[0]) if t.size > 1 else 1.0
        for k, (a, b) in enumerate(_spans(alarm)):
            ax.axvspan(t[a] - dt / 2, t[b - 1] + dt / 2, color="tab:red", alpha=0.12, lw=0,
                       label="alarm" if k == 0 else None)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_ylabel(ylabel or name)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=7)


def plot_residuals(result, path, *, decisions=None, time: str = "discrete", title: str = "",
                   units: dict | None = None) -> Path:
    """One figure, a panel per residual (``decisions.rule.residuals``, else every residual
    with threshold columns): the residual, its threshold band ``<r>_lower … <r>_upper``
    (filled), the samples outside it (red), and with ``decisions``
    (:func:`observer_cad.observers.decide`) the alarm spans of each residual (shaded) and
    the diagnosis changes (dotted lines labelled with the new diagnosis; at most
    :data:`MAX_ANNOTATIONS`). A Monte-Carlo result shows its first run. Returns ``path``.
    """
    plt = _plt()
    banded = residual_names(result)
    names = tuple(decisions.rule.residuals) if decisions is not None else banded
    if not names:
        raise UsageError("plot_residuals: no residual with threshold columns <r>_lower,"
                         " <r>_upper in the result")
    for n in names:
        if n not in banded:
            raise UsageError(f"plot_residuals: the result has no threshold columns {n}_lower,"
                             f" {n}_upper for residual {n}")
    units = dict(getattr(result, "units", None) or {}) if units is None else dict(units)
    t = _run0(result["t"]).astype(float)
    fig, axes = plt.subplots(len(names), 1, figsize=(7.5, 2.3 * len(names) + 0.8),
                             sharex=True, squeeze=False)
    axes = axes[:, 0]
    for i, (ax, name) in enumerate(zip(axes, names)):
        alarm = _run0(decisions.alarms[i]) if decisions is not None else None
        u = units.get(name)
        _residual_axes(ax, t, result, name, alarm=alarm, ylabel=f"{name} [{u}]" if u else name)
    if decisions is not None:
        diag = _run0(decisions.diagnosis)
        change = [k for k in range(diag.size) if k == 0 or diag[k] != diag[k - 1]]
        shown = change[:MAX_ANNOTATIONS]
        for k in shown:
            for ax in axes:
                ax.axvline(t[k], color="0.3", ls=":", lw=0.8)
            axes[0].annotate(str(diag[k]), xy=(t[k], 1.0), xycoords=("data", "axes fraction"),
                             xytext=(2, 2), textcoords="offset points", fontsize=7,
                             rotation=30, ha="left", va="bottom")
        more = len(change) - len(shown)
        if more > 0:
            axes[-1].text(1.0, -0.35, f"+{more} more diagnosis changes", fontsize=7,
                          transform=axes[-1].transAxes, ha="right")
        rule = decisions.rule
        sub = (f"alarm after {rule.persistence} sample(s) out; diagnosis at the end:"
               f" {diag[-1]}")
    else:
        sub = "threshold band and samples out of it"
    axes[-1].set_xlabel(_time_label(time))
    head = f"{title}: residuals" if title else "residuals"
    fig.suptitle(f"{head} — {sub}", fontsize=9)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, path)


def plot_confusion(metrics, path, *, title: str = "") -> Path:
    """The confusion matrix of :class:`observer_cad.residuals.Metrics` as an image with the
    counts written in the cells (rows: true label; columns: diagnosis at the end of the
    run; labels with no run are left out). Returns ``path``."""
    plt = _plt()
    rows = [(l, r) for l, r in zip(metrics.labels, metrics.confusion) if any(r)]
    labels = [l for l, _ in rows]
    C = np.array([r for _, r in rows], dtype=float).reshape(len(rows), len(metrics.diagnoses))
    fig, ax = plt.subplots(figsize=(1.3 * len(metrics.diagnoses) + 2.5, 0.7 * len(labels) + 1.8))
    share = C / np.maximum(C.sum(axis=1, keepdims=True), 1)
    ax.imshow(share, cmap="Blues", vmin=0, vmax=1, aspect="auto")
    for i in range(C.shape[0]):
        for j in range(C.shape[1]):
            ax.text(j, i, f"{int(C[i, j])}", ha="center", va="center", fontsize=9,
                    color="white" if share[i, j] > 0.6 else "black")
    ax.set_xticks(range(len(metrics.diagnoses)), metrics.diagnoses, rotation=30, ha="right")
    ax.set_yticks(range(len(labels)), labels)
    ax.set_xlabel("diagnosis at the end of the run")
    ax.set_ylabel("true fault")
    acc = metrics.isolation_accuracy
    ax.set_title((f"{title}: " if title else "") + f"confusion matrix ({metrics.runs} runs,"
                 f" isolation accuracy {acc:.3g})", fontsize=9)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, path)


def plot_simulation(result, out_dir, *, time: str, title: str = "", units: dict | None = None,
                    decisions=None) -> list:
    """Figures for every observer output found in ``result`` (a SimulationResult).

    - ``<s>_hat``: ``<s>_estimate.png`` (signal and estimate) and ``<s>_error.png``;
    - ``<s>_lower`` / ``<s>_upper``: ``<s>_bounds.png`` (the bounds and, when the
      signal is a column, the signal itself);
    - ``r`` (``r1`` …): ``residual.png`` (``residual_r1.png`` …); when the result has
      threshold columns ``<r>_lower``/``<r>_upper`` the figure shows the band and the
      samples out of it (no separate ``r_bounds.png``), and ``residuals.png``
      (:func:`plot_residuals`) shows every residual with its band, and with
      ``decisions`` (:func:`observer_cad.observers.decide`) the alarms and diagnoses.

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

    banded = set(residual_names(result))
    for name in names:
        if name.endswith(("_lower", "_upper")) and name[:-6] in banded:
            continue
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
        elif name in banded:
            fig, ax = plt.subplots(figsize=(7, 3.2))
            alarm = None
            if decisions is not None and name in decisions.rule.residuals:
                alarm = _run0(decisions.alarm_of(name))
            _residual_axes(ax, _run0(t), result, name, alarm=alarm,
                           ylabel=f"residual {ylabel(name)}")
            ax.set_xlabel(xl)
            ax.set_title(f"{title}: residual {name} and its threshold" if title
                         else f"residual {name} and its threshold")
            paths.append(save_figure(fig, out / f"residual_{name}.png" if name != "r" else out / "residual.png"))
        elif _is_residual(name):
            fig, ax = plt.subplots(figsize=(7, 3.0))
            ax.plot(t, result[name], color="tab:purple", lw=1.2, label=name)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_xlabel(xl)
            ax.set_ylabel(f"residual {ylabel(name)}")
            ax.set_title(f"{title}: residual {name}" if title else f"residual {name}")
            ax.grid(alpha=0.3)
            ax.legend(loc="best")
            paths.append(save_figure(fig, out / f"residual_{name}.png" if name != "r" else out / "residual.png"))
    if banded:
        paths.append(plot_residuals(result, out / "residuals.png", decisions=decisions,
                                    time=time, title=title, units=units))
    return paths


def plot_monitor(result, path, *, outputs, decisions=None, time: str = "discrete",
                 title: str = "") -> Path:
    """The figure of a monitor's run (``monitor.png``): with residual bands, that of
    :func:`plot_residuals` (bands, samples out, alarm spans, diagnosis changes); else a
    panel per observer output in ``outputs`` (its estimate over time). Samples where the
    recorded data leave the declared envelope (``in_bounds`` 0) are shaded grey."""
    if residual_names(result):
        path = plot_residuals(result, path, decisions=decisions, time=time, title=title)
        return path
    plt = _plt()
    names = list(outputs)
    if not names:
        raise UsageError("plot_monitor: the observer has no outputs to plot")
    t = _run0(result["t"]).astype(float)
    fig, axes = plt.subplots(len(names), 1, figsize=(7.5, 2.0 * len(names) + 0.8),
                             sharex=True, squeeze=False)
    for ax, n in zip(axes[:, 0], names):
        ax.plot(t, _run0(result[n]).astype(float), lw=1.1, label=n)
        if "in_bounds" in result.order:
            dt = float(t[1] - t[0]) if t.size > 1 else 1.0
            for a, b in _spans(_run0(result["in_bounds"]) == 0):
                ax.axvspan(t[a] - dt / 2, t[b - 1] + dt / 2, color="0.5", alpha=0.2, lw=0)
        ax.set_ylabel(n)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel(_time_label(time))
    fig.suptitle(f"{title}: observer outputs" if title else "observer outputs", fontsize=9)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, path)
