"""Excitation of a DREM observer after a simulation (METHOD §5; seed 003): the
unknowns' true values from the model's parameters, the windowed excitation report and
the pilot-run gain.

Excitation. Δ is an output; ``Delta2_integral`` = ∫Δ² is an observer state. The error
of the last chain element contracts by exp(−γ ∫Δ² dt) over a window, so
:func:`excitation_report` calls the excitation insufficient on a window where
γ ∫Δ² < ``min_contraction`` (default 1, one e-fold), and :func:`check_excitation` raises
:class:`ExcitationError` with the message.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import sympy as sp

from ..errors import ObserverCadError, UsageError
from ._drem_class import DremClass
from ._observer import Observer

__all__ = ["ExcitationReport", "ExcitationError", "excitation_report", "check_excitation",
           "suggest_gamma", "true_unknowns"]


class ExcitationError(ObserverCadError):
    """Δ(t) was too small over a window: the DREM estimates are not converging."""



def true_unknowns(cls: DremClass, t: np.ndarray, *, x0=None) -> np.ndarray:
    """ϑ(t) from the model's parameter values: rows in the order of the unknowns,
    (derivatives of) each polynomial at the plant clock t (clock initial value 0)."""
    t = np.asarray(t, dtype=float)
    tau = sp.Symbol("_tau")
    rows = []
    for term in cls.terms:
        e = term.poly.xreplace(dict(cls.truth)).xreplace({cls.clock: tau})
        for k in range(term.length):
            f = sp.lambdify(tau, sp.diff(e, tau, k), "numpy")
            rows.append(np.broadcast_to(np.asarray(f(t), dtype=float), t.shape))
    if x0 is not None:
        rows += [np.full(t.shape, float(v)) for v in x0]
    return np.array(rows)


@dataclasses.dataclass(frozen=True)
class ExcitationReport:
    """Windowed excitation of Δ: the contraction exponent γ ∫Δ² dt per window."""

    ok: bool
    message: str
    window: float
    windows: tuple  # of (t0, t1, γ∫Δ² on the window, max|Δ| on the window)
    cumulative: float  # γ ∫Δ² over the whole run
    min_contraction: float
    stiffness: float  # max γΔ² · dt (explicit RK4 needs < 2.78)

    def to_json(self) -> dict:
        return {"ok": self.ok, "message": self.message, "window": self.window,
                "cumulative": self.cumulative, "min_contraction": self.min_contraction,
                "stiffness": self.stiffness, "windows": [list(w) for w in self.windows]}


def excitation_report(result, observer: Observer, *, window: float = 5.0,
                      min_contraction: float = 1.0, t_from: float | None = None) -> ExcitationReport:
    """Check Δ after a simulation (``result`` from :func:`observer_cad.simulation.simulate`).

    The last chain error obeys ξ̃' = −γΔ²ξ̃: over a window it shrinks by
    exp(−γ ∫Δ² dt). Windows of length ``window`` are laid from ``t_from`` (default: one
    window after the start, past the filters' charging). Excitation is **insufficient**
    when the last window's exponent is below ``min_contraction`` (default 1: less than
    one e-fold per window), i.e. Δ has stayed near zero; the message then names the
    window, max|Δ| on it and the cumulative exponent γ∫Δ² of the whole run (large: the
    estimates converged earlier and now coast on the polynomial model uncorrected;
    small: they never converged). ``stiffness`` = max γΔ²·dt (explicit RK4 with step dt
    is unstable on the chain above ≈ 2.78; a warning is appended).
    """
    if observer.kind != "drem":
        raise UsageError(f"excitation_report needs a DREM observer, got kind {observer.kind!r}")
    t = np.asarray(result["t"], dtype=float)
    D = np.asarray(result["Delta"], dtype=float)
    if t.ndim != 1:
        raise UsageError("excitation_report takes a single run")
    gam = float(observer.parameters[sp.Symbol("gamma")])
    t0 = t[0] + window if t_from is None else float(t_from)
    wins = []
    a = t0
    while a + window <= t[-1] + 1e-9:
        m = (t >= a - 1e-12) & (t <= a + window + 1e-12)
        if m.sum() >= 2:
            integ = gam * float(np.trapezoid(D[m] ** 2, t[m]))
            wins.append((float(a), float(a + window), integ, float(np.max(np.abs(D[m])))))
        a += window
    if not wins:
        raise UsageError(f"the simulation ({t[-1] - t[0]:g} s) is shorter than one window"
                         f" ({window:g} s) after t = {t0:g}")
    cumulative = gam * float(np.trapezoid(D ** 2, t))
    dt = float(np.min(np.diff(t)))
    stiff = gam * float(np.max(D ** 2)) * dt
    good = sum(1 for w in wins if w[2] >= min_contraction)
    last = wins[-1]
    ok = last[2] >= min_contraction
    if ok:
        msg = (f"excitation sufficient: γ∫Δ² = {last[2]:.3g} ≥ {min_contraction:g} on"
               f" [{last[0]:g}, {last[1]:g}] s ({good}/{len(wins)} windows; whole run"
               f" {cumulative:.3g})")
    else:
        msg = (f"insufficient excitation: γ∫Δ² = {last[2]:.3g} < {min_contraction:g} on"
               f" [{last[0]:g}, {last[1]:g}] s (max |Δ| = {last[3]:.3g}): Δ(t) is near zero and"
               f" the DREM estimates are not being corrected (whole run γ∫Δ² = {cumulative:.3g}"
               + ("; they never converged" if cumulative < 10 * min_contraction else
                  "; they may have converged earlier") +
               ") — use a richer input (several frequencies) or a larger gamma")
    if stiff > 2.78:
        msg += f"; warning: γΔ²·dt reaches {stiff:.3g} > 2.78 (RK4 unstable: smaller dt or gamma)"
    return ExcitationReport(ok=ok, message=msg, window=float(window), windows=tuple(wins),
                            cumulative=cumulative, min_contraction=float(min_contraction),
                            stiffness=stiff)


def suggest_gamma(result, *, safety: float = 0.5, t_from: float = 0.0) -> float:
    """γ = safety · 2.78 / (dt · max Δ²) from a pilot run (Δ does not depend on γ: the
    filters do not read the estimates), so that explicit RK4 with the run's step stays
    stable on the chain (γΔ²·dt < 2.78) while converging as fast as it allows."""
    t = np.asarray(result["t"], dtype=float)
    D = np.asarray(result["Delta"], dtype=float)
    m = t >= t_from
    peak = float(np.max(D[m] ** 2)) if m.any() else 0.0
    if not peak > 0:
        raise ExcitationError("Δ is identically zero on the pilot run: no excitation, no gain helps")
    dt = float(np.min(np.diff(t)))
    return safety * 2.78 / (dt * peak)


def check_excitation(result, observer: Observer, **options) -> ExcitationReport:
    """:func:`excitation_report`, raising :class:`ExcitationError` when insufficient."""
    rep = excitation_report(result, observer, **options)
    if not rep.ok:
        raise ExcitationError(rep.message)
    return rep
