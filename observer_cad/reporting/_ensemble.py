"""Ensemble outputs: ``summary.csv``, ``statistics.json`` and figures.

``summary.csv`` has one row per finished run, in run order: ``run`` (the global index),
``case``, ``sample`` (the index k whose random draws the run used: replay it with
``observer-cad simulate … --case CASE --run K`` or ``observer-cad ensemble … --replay
RUN``), ``seed``, then every summary field. A time field whose event never happened (no
violation, no alarm) is an empty cell; a run that diverged has ``inf``/``-inf`` in its
error fields and ``finite`` = 0. ``statistics.json`` holds how the ensemble ran (model,
observer, scenario, seed, sampling, runs, engine, backend, workers, chunk, seconds,
whether it was interrupted) and the statistics overall and per case (quantiles, worst
runs). Both files are written atomically: after a Ctrl-C they hold the runs that
finished.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from ..files import atomic_write_text, atomic_writer
from ._csv import csv_cell
from ._plots import save_figure

__all__ = ["write_summary_csv", "write_statistics_json", "plot_ensemble_histograms",
           "SUMMARY_FILE", "STATISTICS_FILE"]

SUMMARY_FILE = "summary.csv"
STATISTICS_FILE = "statistics.json"


def write_summary_csv(accumulator, out_dir, *, runs: int, seed: int) -> Path:
    """``DIR/summary.csv`` from an :class:`~observer_cad.simulation.EnsembleStatistics`
    (runs per case ``runs`` give each run's sample index); streamed to a temporary file
    in DIR, then renamed (atomic)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / SUMMARY_FILE
    cols = accumulator.columns()
    names = [f.name for f in accumulator.fields]
    with atomic_writer(path, encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["run", "case", "sample", "seed"] + names)
        run = cols["run"]
        values = [cols[n] for n in names]
        for i in range(run.size):
            r = int(run[i])
            w.writerow([r, cols["case"][i], r % runs, seed]
                       + [csv_cell(float(v[i]), nan="") for v in values])
    return path


def write_statistics_json(statistics, out_dir, *, ensemble: dict) -> Path:
    """``DIR/statistics.json``: ``{"ensemble": how it ran, "statistics": …}`` (atomic)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / STATISTICS_FILE
    data = {"ensemble": ensemble, "statistics": statistics.to_json()}
    atomic_write_text(path, json.dumps(data, indent=2, allow_nan=False) + "\n")
    return path


def plot_ensemble_histograms(accumulator, out_dir, *, title: str = "", fields=None) -> list:
    """One histogram per summary field (``DIR/hist_<field>.png``; every case in its own
    colour; the worst run marked), for fields with finite values. Returns the paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cols = accumulator.columns()
    cases = list(dict.fromkeys(cols["case"].tolist()))
    paths = []
    for f in accumulator.fields:
        if fields is not None and f.name not in fields:
            continue
        if f.kind == "code" or f.name == "finite":
            continue
        v = np.asarray(cols[f.name], dtype=float)
        fin = np.isfinite(v)
        if not fin.any():
            continue
        lo, hi = float(v[fin].min()), float(v[fin].max())
        bins = np.linspace(lo, hi if hi > lo else lo + 1, 41)
        fig, ax = plt.subplots(figsize=(7, 3.4))
        for c in cases:
            sel = fin & (cols["case"] == c)
            if sel.any():
                ax.hist(v[sel], bins=bins, alpha=0.55, label=f"{c} ({int(sel.sum())} runs)")
        worst = accumulator.worst(f.name, 1)[0]
        wv = float(v[np.flatnonzero(cols["run"] == worst)[0]])
        if math.isfinite(wv):
            ax.axvline(wv, color="k", lw=1.0, ls="--", label=f"worst: run {worst}")
        unit = f" [{f.unit}]" if f.unit else ""
        ax.set_xlabel(f"{f.name}{unit}")
        ax.set_ylabel("runs")
        nonfin = int((~fin & ~np.isnan(v)).sum())
        extra = f" ({nonfin} runs not finite, not shown)" if nonfin else ""
        ax.set_title((f"{title}: " if title else "") + f"{f.description}{extra}", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in f.name)
        paths.append(save_figure(fig, out / f"hist_{safe}.png"))
    return paths
