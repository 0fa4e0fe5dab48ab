"""The demo's figures: the table of every paper's figure (:data:`FIGURES`) and drawing
the ones whose designs ran.
"""
from __future__ import annotations

import time
from pathlib import Path

from ._figures_000 import (fig_000_1, fig_000_2, fig_000_3, fig_000_4, fig_000_s8,
                           fig_drive_interval, fig_drive_residual)
from ._figures_001 import fig_001_2, fig_lin_virtual
from ._figures_002 import fig_002_2, fig_002_3, fig_sliding
from ._plotting import STYLE, pyplot

__all__ = ["FIGURES", "render_figures"]


#: (file name, cases it needs, section it belongs to, function)
FIGURES = (
    ("000_fig1.png", ("drive_d",), "drive_d", fig_000_1),
    ("000_fig2.png", ("drive_d",), "drive_d", fig_000_2),
    ("000_fig3.png", ("drive_rho",), "drive_rho", fig_000_3),
    ("000_fig4.png", ("drive_rho",), "drive_rho", fig_000_4),
    ("000_s8_jordan.png", ("drive_d_jordan",), "drive_d_jordan", fig_000_s8),
    ("drive_residual.png", ("drive_diag",), "drive_diag", fig_drive_residual),
    ("drive_interval_x2.png", ("drive_interval",), "drive_interval", fig_drive_interval),
    ("002_fig2.png", ("tank_vs",), "tank_vs", fig_002_2),
    ("002_fig3.png", ("tank_interval", "tank_interval_w05"), "tank_interval", fig_002_3),
    ("linear_tank_virtual_sensors.png", ("lin_vs_plain", "lin_vs_004", "lin_vs_jordan"),
     "lin_vs_plain", fig_lin_virtual),
    ("001_fig2.png", ("lin_interval_m2", "lin_interval_m1"), "lin_interval_m2", fig_001_2),
    ("sliding.png", ("sliding",), "sliding", fig_sliding),
)


def render_figures(figures, by_key: dict, fig_dir: Path, log, failed: list) -> list:
    """Every figure of ``figures`` (a table like :data:`FIGURES`) whose designs ran, under
    ``fig_dir``; (name, caption, section). Figures that raise are named in ``failed``."""
    from ..reporting import save_figure
    plt = pyplot()
    figs = []
    with plt.rc_context(STYLE):
        for name, needs, section, fn in figures:
            if not all(k in by_key for k in needs):
                log(f"[figure] {name}: skipped (a design it needs did not run)")
                continue
            t1 = time.perf_counter()
            try:
                fig, caption = fn(by_key, fig_dir / name)
                save_figure(fig, fig_dir / name)
            except Exception as exc:  # noqa: BLE001 - report it, keep the other figures
                failed.append(name)
                plt.close("all")
                log(f"[figure] {name}: FAILED ({type(exc).__name__}: {exc})")
                continue
            figs.append((name, caption, section))
            log(f"[figure] {fig_dir / name}  ({time.perf_counter() - t1:.2f} s)")
    return figs
