"""Sampled-data guaranteed bands for nonlinear plants (METHOD §3, residual evaluation).

The plant x' = f0(x, u) + Σ_t v_t φ_t (f0 nominal and possibly nonlinear; φ_t the
monomials that carry a disturbance, a process noise or a parameter uncertainty δ), its
outputs affine, y = H x + D_y u + h0 + Σ_t w_t ω_t; the residual generator
ξ' = A ξ + G y + G_u u + c0 + n(y, u) (n: the terms in measured signals that are not
affine), r = C_r ξ + G_r y + G_ru u + c_r. Its exact identity Φ f0(x, u) = A Φ x + p(x, u),
p = G y0 + n(y0, u) + G_u u + c0 with y0 the nominal outputs, turns the observer error
e = Φ x − ξ of the algorithm stepped every h with y(k) and u(k) held (ξ(k+1) = F ξ(k) +
Q (…), e^{A h} = E, ∫₀ʰ e^{Aτ} dτ = Γ) into

    e(k+1) = F e(k) + (E − F) Φ x(k) + (Γ − Q) p(x(k), u(k)) + h Φ Σ v_t φ̄_t − Q G Σ w_t ω_t(k)
             + ∫₀ʰ e^{A(h−s)} (p(x(s), u(k)) − p(x(k), u(k))) ds
             + ∫₀ʰ (e^{A(h−s)} − I) Φ Σ v_t φ_t ds − Q (n(y(k), u(k)) − n(y0(k), u(k))),
    r(k) = −C_r e(k) + G_r Σ w_t ω_t(k)

(φ̄_t the step mean of φ_t, inside φ_t's range). The first line's terms are bounded scalar
inputs with their columns; the second line is bounded elementwise: by (h²/2) e^{|A| h} P′
with P′ = Σ_j max|∂p/∂x_j| max|x_j′| (|p(s) − p(k)| ≤ s P′ while x stays in the
envelope), by h (e^{|A| h} − I) |Φ v_t| max|φ_t|, and by |Q| Σ_l max|∂n/∂y_l| max|ν_l|
(ν the noise in the outputs). Every max is an interval enclosure over the operating
envelope and the declared boxes (:func:`interval_range`); a term without a finite one
(a square root whose argument reaches 0, a division by a signal that can vanish) is
refused in one line, and the caller keeps the band of continuous observation.
"""
from __future__ import annotations

import dataclasses

import mpmath
import numpy as np
import sympy as sp

from ..errors import UsageError
from ..model import PlantModel
from ..synthesis import Condition
from ._intervals import abs_bound, interval_range
from ._sampled_algebra import (DPS, Affine, affine_and_rest, box_of, exp_tail, hold_step,
                               identity_condition, split_affine, to_mp, to_np)

__all__ = ["NonlinearPlant", "nonlinear_plant", "nonlinear_identities", "nonlinear_inputs"]

_REF = "METHOD §3 (residual evaluation)"


@dataclasses.dataclass(frozen=True)
class NonlinearPlant:
    """The nominal dynamics f0 (states × 1), the uncertain terms of the dynamics (``rest``),
    the affine outputs, and p(x, u) (observer states × 1) of the module docstring."""

    f0: sp.Matrix
    dyn: list  # the full dynamics (every declared uncertain symbol kept)
    rest: Affine
    out: Affine
    p: sp.Matrix


def nonlinear_plant(model: PlantModel, g: dict, dynx, outx, unc, where: str):
    """The :class:`NonlinearPlant` when the nominal plant or the residual generator is
    not affine, else None (the linear band applies)."""
    xs, us = list(model.states), list(model.inputs)
    zero = {s: 0 for s in unc}
    f0 = [sp.expand(sp.sympify(e).xreplace(zero)) for e in dynx]
    plant_nl = any(affine_and_rest(e, xs + us)[1] != 0 for e in f0)
    if not plant_nl and all(e == 0 for e in g["n"]):
        return None
    if model.time != "continuous":
        raise UsageError(f"{where}: a nonlinear discrete-time plant has no sampled-data band (its"
                         " guaranteed threshold is that of the algorithm that runs)")
    rest = split_affine([sp.expand(d - f) for d, f in zip(dynx, f0)], xs, us, unc,
                        "dynamics equation", where)
    out = split_affine(outx, xs, us, unc, "output", where)
    x = sp.Matrix(xs)
    u = sp.Matrix(us) if us else sp.zeros(0, 1)
    y0 = out.Mx * x + (out.Mu * u if us else sp.zeros(out.Mx.rows, 1)) + out.m0
    sub = {yk: y0[i] for i, yk in enumerate(g["ys"])}
    p = g["G"] * y0 + g["n"].xreplace(sub) + (g["Gu"] * u if us else 0 * g["c0"]) + g["c0"]
    return NonlinearPlant(sp.Matrix(f0), list(dynx), rest, out, p.applyfunc(sp.expand))


def nonlinear_identities(g: dict, nl: NonlinearPlant, states, where: str) -> Condition:
    """Φ f0(x, u) = A Φ x + p(x, u) and the residual's identities, exactly."""
    Phi = g["Phi"]
    return identity_condition(g, nl.out, {
        "Φ f0(x, u) = A Φ x + G y0 + n(y0, u) + G_u u + c0":
            Phi * nl.f0 - g["A"] * Phi * sp.Matrix(states) - nl.p}, where,
        "nominal nonlinear plant")


def _noise_amplitudes(out: Affine, full: dict, where: str) -> np.ndarray:
    """max |ν_l| per output l: the sampled output terms' reach (noise, uncertain sensors)."""
    nu = np.zeros(out.Mx.rows)
    for phi, w in out.rest:
        lo, hi = box_of(phi, full, where)
        nu += np.abs(to_np(to_mp(w))[:, 0]) * float(max(abs(lo), abs(hi)))
    return nu


def _remainders(g: dict, nl: NonlinearPlant, model: PlantModel, full: dict, h, Qn, where):
    """The second line of the module docstring, elementwise (observer states), and
    max |n| over the envelope (for the roundoff margin)."""
    k, xs = g["Phi"].rows, list(model.states)
    hf = float(h)
    absA = np.abs(to_np(to_mp(g["A"])))
    eA1 = absA * hf + exp_tail(absA * hf) * (1 + 1e-9)  # e^{|A| h} − I (nonnegative)
    eA = np.eye(k) + eA1
    box = dict(full)
    xdot = np.array([abs_bound(e, box, where=where, what=f"the derivative of {x}")
                     for x, e in zip(xs, nl.dyn)])
    dp = np.zeros(k)
    for i in range(k):
        for j, x in enumerate(xs):
            d = sp.diff(nl.p[i], x)
            if d != 0:
                dp[i] += abs_bound(d, box, where=where,
                                   what=f"the slope ∂p{i + 1}/∂{x} of the observer's drive") * xdot[j]
    R = hf * hf / 2 * (eA @ dp)
    Phin = np.abs(to_np(to_mp(g["Phi"])))
    for phi, v in nl.rest.rest:
        lo, hi = box_of(phi, full, where)
        R += hf * (eA1 @ (Phin @ np.abs(to_np(to_mp(v))[:, 0]))) * float(max(abs(lo), abs(hi)))
    nu = _noise_amplitudes(nl.out, full, where)
    n_mag = np.zeros(k)
    if any(e != 0 for e in g["n"]):
        ybox = dict(box)
        us = list(model.inputs)
        y0 = nl.out.Mx * sp.Matrix(xs) + nl.out.m0
        if us:
            y0 += nl.out.Mu * sp.Matrix(us)
        for l, yk in enumerate(g["ys"]):
            lo, hi = interval_range(y0[l], box, where=where, what=f"the output y{l + 1}")
            ybox[yk] = (sp.Rational(lo) - sp.Rational(nu[l]), sp.Rational(hi) + sp.Rational(nu[l]))
        dn = np.zeros(k)
        for i, e in enumerate(g["n"]):
            if e == 0:
                continue
            n_mag[i] = abs_bound(e, ybox, where=where, what=f"the observer's term {e}")
            for l, yk in enumerate(g["ys"]):
                d = sp.diff(e, yk)
                if d != 0 and nu[l] > 0:
                    dn[i] += abs_bound(d, ybox, where=where, what=f"the slope of {e} in y{l + 1}") * nu[l]
        R += np.abs(Qn) @ dn
    return R * (1 + 1e-9), n_mag


def nonlinear_inputs(g: dict, nl: NonlinearPlant, model: PlantModel, hold: dict, full: dict,
                     where: str) -> dict:
    """The error system z = e with its bounded scalar inputs (the module docstring):
    dict(F, N, B, Cd, lo, hi, labels, joint=False, n, k, n_mag)."""
    Phi, G, Gr = g["Phi"], g["G"], g["Gr"]
    F, Q, h = hold["F"], hold["Q"], hold["h"]
    k, m, n = Phi.rows, Gr.rows, Phi.cols
    cols, labels = [], []

    def add(be, c, lo, hi, label):
        be, c = [float(v) for v in be], [float(v) for v in c]
        if any(be) or any(c):
            cols.append((be, c, float(lo), float(hi)))
            labels.append(label)
    with mpmath.workdps(DPS):
        E, Gam = hold_step(g["A"], h, "exact")
        Phim, Gm = to_mp(Phi), to_mp(G)
        Kx, Kp = (E - F) * Phim, Gam - Q
        for j, x in enumerate(model.states):
            add(Kx[:, j], [0] * m, *full[x], f"{x} (hold)")
        for i in range(k):
            lo, hi = interval_range(nl.p[i], full, where=where,
                                    what=f"the observer's drive p{i + 1}(x, u)")
            add(Kp[:, i], [0] * m, lo, hi, f"p{i + 1}(x, u) (hold)")
        hm = mpmath.mpf(sp.Rational(h).p) / sp.Rational(h).q
        for phi, v in nl.rest.rest:
            add(Phim * to_mp(v) * hm, [0] * m, *box_of(phi, full, where), f"{phi} (dynamics)")
        for phi, w in nl.out.rest:
            b = -(Q * Gm * to_mp(w))
            add(b[:, 0], list(Gr * w), *box_of(phi, full, where), f"{phi} (sampled output)")
        Qn = to_np(Q)
    R, n_mag = _remainders(g, nl, model, full, h, Qn, where)
    for i in range(k):
        if R[i] > 0:
            add([R[i] if j == i else 0 for j in range(k)], [0] * m, -1, 1,
                f"intersample remainder {i + 1} (nonlinear)")
    T = len(cols)
    B = np.array([c[0] for c in cols]).T.reshape(k, T) if T else np.zeros((k, 0))
    Cd = np.array([c[1] for c in cols]).T.reshape(m, T) if T else np.zeros((m, 0))
    return dict(F=to_np(F), N=-to_np(to_mp(g["Cr"])), B=B, Cd=Cd,
                lo=np.array([c[2] for c in cols]), hi=np.array([c[3] for c in cols]),
                labels=labels, joint=False, n=n, k=k, n_mag=n_mag, Gamma=Gam)
