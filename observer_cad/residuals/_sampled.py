"""Sampled-data guaranteed thresholds: the band of the fault-free residual of the discrete
algorithm that actually runs (METHOD §3, residual evaluation; the L1 norm of an impulse
response as the exact worst case of a bounded input: Dahleh & Diaz-Bobillo 1995).

Deployed, a continuous-time residual generator ξ' = A ξ + G y + G_u u + c0, r = C_r ξ + G_r y
+ G_ru u + c_r is stepped at the sample time h with y(k) and u(k) held over the step
(:func:`observer_cad.codegen.observer_step`): ``ξ(k+1) = F ξ(k) + Q (G y(k) + G_u u(k) + c0)``
with, for RK4, F = Σ_{m ≤ 4} (hA)^m/m!, Q = h Σ_{m ≤ 3} (hA)^m/(m+1)! (exact rationals), and
for the exact zero-order hold F = e^{Ah}, Q = ∫₀ʰ e^{Aτ} dτ. The plant is the true continuous
one, x' = A0 x + B0 u + b0 + Σ_t v_t φ_t (nominal part linear; φ_t the monomials that carry a
parameter uncertainty δ or a disturbance ρ), its input held (ZOH) and its outputs y = H x +
D_y u + h0 + Σ_t w_t φ_t sampled at the same instants. With e(k) = Φ x(t_k) − ξ(k), exactly

    e(k+1) = F e(k) + K_x x(k) + K_u u(k) + K_1 − Q G ν(k) + Φ ∫₀ʰ e^{A0(h−s)} Σ v_t φ_t ds,
    r(k) = −C_r e(k) + G_r ν(k),     ν(k) = Σ_t w_t φ_t(k)  (noise, uncertain sensor terms)

with K_x = Φ e^{A0 h} − F Φ − Q G H, K_u = Φ Γ0 B0 − Q (G D_y + G_u), K_1 = Φ Γ0 b0 −
Q (G h0 + c0), Γ0 = ∫₀ʰ e^{A0 τ} dτ: these are the effect of holding y and u over a step
while the plant moves (zero in the limit h → 0 by the decoupling identities Φ A0 = A Φ +
G H, Φ B0 = G D_y + G_u). The integral is h Φ v_t φ̂_t (φ̂_t the step mean of φ_t, inside
φ_t's range) plus a remainder bounded elementwise by (h²/2 abs(Φ A0 v_t) + h abs(Φ) (e^{abs(A0) h}
− I − abs(A0) h) abs(v_t)) max abs(φ_t). Every term is a bounded scalar input (states and inputs from the
operating envelope, ρ, w, δ from their boxes), and the band is the exact worst-case sum
(:func:`worst_case_sums`) plus the transient of the initial error e(0) = Φ (x(0) − c) from
the initial box (observer started at Φ c, c the box centre), bounded by K q^k with q the
decay per step of an extra observer state z' = −α z, z(0) = 1 stepped by the same algorithm.
Discrete-time plants are the special case without the hold (F = A, the terms sampled).
"""
from __future__ import annotations

import dataclasses
import math

import mpmath
import numpy as np
import sympy as sp

from ..errors import UsageError
from ..model import PlantModel, to_rational
from ..synthesis import Condition
from ..analysis import format_number
from ..observers import Observer, output_symbols
from ._l1 import transient_envelope, worst_case_sums
from ._sampled_algebra import (DPS, Affine, affine_and_rest, box_of, exp_tail, hold_step,
                               identity_condition, split_affine, to_mp, to_np)
from ._sampled_nonlinear import nonlinear_identities, nonlinear_inputs, nonlinear_plant
from ._threshold import ErrorSystem, Threshold, residual_names

__all__ = ["sampled_threshold", "sampled_band_refusal", "SAMPLED_DISCRETISATIONS", "ROUNDOFF_FACTOR"]

SAMPLED_DISCRETISATIONS = ("rk4", "zoh")

#: the floating-point margin is ROUNDOFF_FACTOR · eps · (magnitude of the terms the computed
#: residual adds up, from the operating envelope), plus 1e-9 of the band's own size
ROUNDOFF_FACTOR = 4096.0

_REF = "METHOD §3 (residual evaluation)"
_L1REF = "Dahleh & Diaz-Bobillo 1995"


def _nominal(model: PlantModel) -> tuple:
    """Dynamics and outputs with uncertain parameters as θ0 + δ; the δ box."""
    vals, sub, box = model.parameter_values(), {}, {}
    for p, v in vals.items():
        if p in model.uncertainty:
            dl = sp.Symbol(f"delta_{p}", real=True)
            lo, hi = model.uncertainty[p]
            box[dl] = (lo - v, hi - v)
            sub[p] = v + dl
        else:
            sub[p] = v
    nofault = {d: 0 for d in model.faults}
    dyn = [sp.expand(sp.sympify(f).xreplace(sub).xreplace(nofault)) for f in model.dynamics]
    outs = [sp.expand(sp.sympify(h).xreplace(sub).xreplace(nofault)) for h in model.outputs]
    fault_cols = [[sp.diff(sp.sympify(f).xreplace(sub), d).xreplace({b: 0 for b in box})
                   for d in model.faults] for f in model.dynamics]
    out_cols = [[sp.diff(sp.sympify(h).xreplace(sub), d).xreplace({b: 0 for b in box})
                 for d in model.faults] for h in model.outputs]
    if not model.faults:
        return dyn, outs, box, None
    return dyn, outs, box, (sp.Matrix(fault_cols), sp.Matrix(out_cols))


def _generator(model: PlantModel, observer: Observer, residuals, where: str) -> dict:
    """The residual generator's matrices (ξ' = A ξ + G y + G_u u + c0, r = C_r ξ + G_r y +
    G_ru u + c_r) and Φ (from x*(0) = Φ x(0)); refused unless affine with constant
    coefficients."""
    xi = list(observer.states)
    if any(s not in observer.initial for s in xi):
        raise UsageError(f"{where}: an observer state has no map to the plant state (x*(0) ="
                         " Φ x(0)); thresholds need a residual generator built from a design")
    par = dict(observer.parameters)
    ys = list(output_symbols(len(model.outputs)))
    us = list(model.inputs)
    upd = [sp.expand(sp.sympify(e).xreplace(par)) for e in observer.update]
    outmap = {n: sp.expand(sp.sympify(e).xreplace(par)) for n, e in observer.outputs}
    # the update's terms in the measured signals only that are not affine: n(y, u)
    split = [affine_and_rest(e, xi + ys + us) for e in upd]
    nl = sp.Matrix([r for _, r in split]) if split else sp.zeros(0, 1)
    if any(r.free_symbols & set(xi) for r in nl):
        raise UsageError(f"{where}: the observer update is not affine in the observer states;"
                         " sampled guaranteed thresholds need a residual generator linear in"
                         " its own states")
    parts = []
    for what, exprs in (("observer update", [a for a, _ in split]),
                        ("residual", [outmap[r] for r in residuals])):
        try:
            parts.append(split_affine(exprs, xi + ys, us, (), what, where))
        except UsageError:
            raise UsageError(f"{where}: the {what} is not affine in the observer states, outputs"
                             " and inputs with constant coefficients; sampled guaranteed"
                             " thresholds need a linear residual generator") from None
    up, rp = parts
    k = len(xi)
    phi = [sp.expand(sp.sympify(observer.initial[s])) for s in xi]
    if any(e.free_symbols - set(model.states) for e in phi):
        raise UsageError(f"{where}: the observer's map x*(0) = Φ x(0) is not in the plant states")
    Phi = sp.Matrix(phi).jacobian(model.states) if phi else sp.zeros(0, len(model.states))
    return dict(xi=xi, upd=upd, A=up.Mx[:, :k], G=up.Mx[:, k:], Gu=up.Mu, c0=up.m0,
                Cr=rp.Mx[:, :k], Gr=rp.Mx[:, k:], Gru=rp.Mu, cr=rp.m0, Phi=Phi, outmap=outmap,
                n=nl, ys=ys)


def _identities(g: dict, dyn: Affine, out: Affine, where: str) -> Condition:
    """The exact decoupling identities the band rests on."""
    Phi, A, G = g["Phi"], g["A"], g["G"]
    return identity_condition(g, out, {
        "Φ A0 = A Φ + G H": Phi * dyn.Mx - A * Phi - G * out.Mx,
        "Φ B0 = G D_y + G_u": Phi * dyn.Mu - G * out.Mu - g["Gu"],
        "Φ b0 = G h0 + c0": Phi * dyn.m0 - G * out.m0 - g["c0"]}, where, "nominal plant")


def _envelope(model: PlantModel, box: dict, where: str) -> dict:
    """The full box: states and inputs (operating envelope), ρ, w (declared bounds), δ."""
    missing = [s for s in tuple(model.states) + tuple(model.inputs) if s not in model.bounds]
    if missing:
        role = "state" if missing[0] in model.states else "input"
        raise UsageError(f"{where}: the sampled guaranteed threshold needs the operating envelope:"
                         f" declare bounds={{{missing[0]}: (low, high)}} for the {role}"
                         f" {missing[0]} (and every other state and input)")
    full = dict(box)
    full.update(model.bounds)
    return full


def _inputs(g: dict, dyn: Affine, out: Affine, hold: dict, full: dict, where: str) -> dict:
    """The error system the band sums over, with its bounded scalar inputs (the module
    docstring's terms). With a stable plant step (ρ(e^{A0 h}) < 1) the state is z = [x; e]
    (the plant moves the held terms K_x x: exact); otherwise z = e and x(k) is an input
    bounded by the envelope. Returns dict(F, N, B, Cd, lo, hi, labels, joint, n)."""
    Phi, G, Gr = g["Phi"], g["G"], g["Gr"]
    F, Q, E0, G0, h = hold["F"], hold["Q"], hold["E0"], hold["G0"], hold["h"]
    sampled = hold["sampled"]
    Phim, Gm, Hm = to_mp(Phi), to_mp(G), to_mp(out.Mx)
    k, m, n = Phi.rows, Gr.rows, Phi.cols
    E0n = to_np(E0)
    joint = bool(n) and float(max(np.abs(np.linalg.eigvals(E0n)))) < 1 - 1e-9
    cols, labels = [], []
    Phin = to_np(Phi)

    def add(bx, be, c, lo, hi, label):
        bx = [float(v) for v in bx] if joint else []
        be, c = [float(v) for v in be], [float(v) for v in c]
        if any(bx) or any(be) or any(c):
            cols.append((bx + be, c, float(lo), float(hi)))
            labels.append(label)
    with mpmath.workdps(DPS):
        Kx = Phim * E0 - F * Phim - Q * Gm * Hm
        Ku = Phim * G0 * to_mp(dyn.Mu) - Q * (Gm * to_mp(out.Mu) + to_mp(g["Gu"]))
        K1 = Phim * G0 * to_mp(dyn.m0) - Q * (Gm * to_mp(out.m0) + to_mp(g["c0"]))
        Bx, b0 = G0 * to_mp(dyn.Mu), G0 * to_mp(dyn.m0)
        if not joint:
            for j, x in enumerate(full["__states"]):
                add([], Kx[:, j], [0] * m, *full[x], f"{x} (hold)")
        for j, u in enumerate(full["__inputs"]):
            add(Bx[:, j], Ku[:, j], [0] * m, *full[u], f"{u} (hold)")
        add(b0[:, 0], K1[:, 0], [0] * m, 1, 1, "constant (hold)")
        for phi, w in out.rest:  # sampled output terms: noise, uncertain sensors
            b = -(Q * Gm * to_mp(w))
            add([0] * n, b[:, 0], list(Gr * w), *box_of(phi, full, where), f"{phi} (sampled output)")
    Rx, Re = np.zeros(n), np.zeros(k)
    hf = 1.0 if sampled else float(h)
    tail = exp_tail(np.abs(to_np(dyn.Mx)) * hf) * (1 + 1e-9)
    for phi, v in dyn.rest:  # dynamics terms: disturbances, uncertain parameters
        lo, hi = box_of(phi, full, where)
        vv = v * (1 if sampled else h)
        add(list(vv), list(Phi * vv), [0] * m, lo, hi, f"{phi} (dynamics)")
        if not sampled:
            big = float(max(abs(lo), abs(hi)))
            va = np.abs(to_np(v)[:, 0])
            Rx += (np.abs(to_np(dyn.Mx * v)[:, 0]) * hf * hf / 2 + hf * (tail @ va)) * big
            Re += (np.abs(to_np(Phi * dyn.Mx * v)[:, 0]) * hf * hf / 2
                   + hf * (np.abs(Phin) @ (tail @ va))) * big
    if joint:
        for i in range(n):
            if Rx[i] > 0:
                add([Rx[i] if j == i else 0 for j in range(n)], Phin[:, i] * Rx[i], [0] * m,
                    -1, 1, f"intersample remainder {i + 1}")
    else:
        for i in range(k):
            if Re[i] > 0:
                add([], [Re[i] if j == i else 0 for j in range(k)], [0] * m, -1, 1,
                    f"intersample remainder {i + 1}")
    N = -to_np(g["Cr"])
    Fe = to_np(F)
    if joint:
        Fz = np.block([[E0n, np.zeros((n, k))], [to_np(Kx), Fe]])
        Nz = np.hstack([np.zeros((m, n)), N])
    else:
        Fz, Nz = Fe, N
    d = Fz.shape[0]
    T = len(cols)
    B = np.array([c[0] for c in cols]).T.reshape(d, T) if T else np.zeros((d, 0))
    Cd = np.array([c[1] for c in cols]).T.reshape(m, T) if T else np.zeros((m, 0))
    return dict(F=Fz, N=Nz, B=B, Cd=Cd, lo=np.array([c[2] for c in cols]),
                hi=np.array([c[3] for c in cols]), labels=labels, joint=joint, n=n, k=k)


def _checked_step(model: PlantModel, h, discretisation: str) -> tuple:
    where = model.where
    if model.time == "discrete":
        if h is not None:
            raise UsageError(f"{where}: a discrete-time model has its own sample time; give no h")
        return None, "discrete"
    if discretisation not in SAMPLED_DISCRETISATIONS:
        raise UsageError(f"discretisation must be one of {', '.join(SAMPLED_DISCRETISATIONS)},"
                         f" got {discretisation!r}")
    if h is None:
        raise UsageError(f"{where}: the sampled guaranteed threshold of a continuous-time plant"
                         " needs the sample time h")
    hr = to_rational(h, "the sample time h")
    if not bool(hr > 0):
        raise UsageError(f"the sample time h must be positive, got {h}")
    return hr, discretisation


def _hold_matrices(g: dict, dyn: Affine, h, how: str) -> dict:
    """The observer's discrete step (F, Q) and the plant's (e^{A0 h}, Γ0) in 40 digits."""
    with mpmath.workdps(DPS):
        if how == "discrete":
            k, n = g["A"].rows, dyn.Mx.rows
            return dict(F=to_mp(g["A"]), Q=mpmath.eye(k) if k else mpmath.zeros(0, 0),
                        E0=to_mp(dyn.Mx), G0=mpmath.eye(n), h=1, sampled=True)
        F, Q = hold_step(g["A"], h, "rk4" if how == "rk4" else "exact")
        E0, G0 = hold_step(dyn.Mx, h, "exact")
        return dict(F=F, Q=Q, E0=E0, G0=G0, h=h, sampled=False)


def _decay(F: np.ndarray, h, how: str) -> tuple:
    """The extra state z's update (z' = −α z, or z⁺ = q z) and its guaranteed decay per
    step q (slightly below what the algorithm computes): (update coefficient, q)."""
    rho = float(max(np.abs(np.linalg.eigvals(F)))) if F.size else 0.0
    target = min(max(math.sqrt(rho), 0.1), 1 - 1e-6) if rho < 1 else None
    if target is None:
        raise UsageError("the discrete error system is not stable: no bounded band")
    if how == "discrete":
        c = sp.Rational(str(round(target, 12)))
        return c, float(c) * (1 - 1e-12)
    hf = float(h)
    a = -math.log(target)
    if how == "rk4":
        a = min(a, 2.0)
        q = 1 - a + a * a / 2 - a ** 3 / 6 + a ** 4 / 24
    else:
        q = math.exp(-a)
    alpha = sp.Rational(str(round(a / hf, 12)))
    a = float(alpha) * hf
    q = (1 - a + a * a / 2 - a ** 3 / 6 + a ** 4 / 24) if how == "rk4" else math.exp(-a)
    if not (rho < q < 1):
        raise UsageError(f"internal: no transient decay rate between {rho:g} and 1")
    return -alpha, q * (1 - 1e-12)


def _magnitudes(g: dict, out: Affine, hold: dict, full: dict, model: PlantModel, where) -> tuple:
    """Per residual: the magnitude of the terms the computed residual adds up (from the
    envelope), and the per-step magnitude of the terms the observer's step adds up."""
    X = np.array([float(max(abs(a), abs(b))) for a, b in (full[x] for x in model.states)])
    U = np.array([float(max(abs(a), abs(b))) for a, b in (full[u] for u in model.inputs)])
    ab = lambda M: np.abs(to_np(M))  # noqa: E731
    ny = out.Mx.rows
    Y = ab(out.Mx) @ X + (ab(out.Mu) @ U if U.size else 0) + ab(out.m0)[:, 0]
    for phi, w in out.rest:
        lo, hi = box_of(phi, full, where)
        Y = Y + np.abs(to_np(w)[:, 0]) * float(max(abs(lo), abs(hi)))
    Xi = ab(g["Phi"]) @ X
    res = ab(g["Cr"]) @ Xi + ab(g["Gr"]) @ Y + (ab(g["Gru"]) @ U if U.size else 0) \
        + ab(g["cr"])[:, 0]
    F, Q = np.abs(to_np(hold["F"])), np.abs(to_np(hold["Q"]))
    step = F @ Xi + Q @ (ab(g["G"]) @ Y.reshape(ny) + (ab(g["Gu"]) @ U if U.size else 0)
                         + ab(g["c0"])[:, 0])
    return res, step


def _conditions(model, hr, how, full, box, labels, wc, rho_F, x0_text, margin_text,
                joint) -> list:
    where_h = (f"observer stepped every h = {format_number(hr)} by "
               + ("RK4" if how == "rk4" else "the exact zero-order hold")
               + " with y(k) and u(k) held over the step (observer_step(..., h, discretisation="
               f"'{how}')); the plant's inputs held (ZOH) and its outputs sampled at the same"
               " instants") if how != "discrete" else "one observer step per plant sample"
    env = ", ".join(f"{s} ∈ [{format_number(full[s][0])}, {format_number(full[s][1])}]"
                    for s in tuple(model.states) + tuple(model.inputs))
    decl = [s for s in tuple(model.disturbances) + tuple(model.noise)
            if any(str(s) in lab for lab in labels)]
    decl_text = ", ".join(f"{s} ∈ [{format_number(full[s][0])}, {format_number(full[s][1])}]"
                          for s in decl)
    decl_text += "".join(f", {p} ∈ [{format_number(lo)}, {format_number(hi)}]"
                         for p, (lo, hi) in model.uncertainty.items())
    return [
        Condition("sample time", True, where_h, _REF),
        Condition("operating envelope", True,
                  f"no false alarm while {env} at every instant (between samples too)", _REF),
        Condition("declared bounds", True,
                  ("no false alarm while " + decl_text.lstrip(", ") + " and the faults are zero")
                  if decl_text else "faults zero; no disturbance, noise or uncertainty declared",
                  _REF),
        Condition("initial state", True, x0_text, _REF),
        Condition("discrete error system stable", bool(rho_F < 1),
                  ("z = [x; e] (plant and observer error, the plant's step stable: the held"
                   " terms move with the plant)" if joint else
                   "z = e (the held terms bounded by the envelope at every sample)")
                  + f": spectral radius of the step matrix {rho_F:.6g}", _REF),
        Condition("worst-case sum", True,
                  f"L1 norm of each input's impulse response to r over {len(labels)} bounded"
                  f" inputs, {wc.steps} terms summed, geometric tail bound {wc.tail:.3g} added",
                  _L1REF, required=False),
        Condition("roundoff margin", True, margin_text, _REF, required=False),
    ]


def _transient(model: PlantModel, g: dict, sysm: dict, full: dict, hr, how: str) -> tuple:
    """K (per residual) with abs(transient of r) ≤ K q^k, the decay state's coefficient, q, the
    condition text, and the observer's start Φ c (None: keep x*(0) = Φ x(0))."""
    F, N, n = sysm["F"], sysm["N"], sysm["n"]
    Phin = to_np(g["Phi"])
    start, cols = None, []
    if model.initial:
        box = [model.initial[x] for x in model.states]
        c = sp.Matrix([(lo + hi) / 2 for lo, hi in box])
        rad = np.array([float((hi - lo) / 2) for lo, hi in box])
        start = g["Phi"] * c
        if sysm["joint"]:  # z(0) = [c; 0] + [I; Φ] (x(0) − c)
            cols = [np.concatenate([np.eye(n)[:, j], Phin[:, j]]) * rad[j] for j in range(n)]
            cols.append(np.concatenate([to_np(c)[:, 0], np.zeros(Phin.shape[0])]))
        else:
            cols = [Phin[:, j] * rad[j] for j in range(n)]
        x0_text = ("x(0) in the initial box " + ", ".join(
            f"{x} ∈ [{format_number(lo)}, {format_number(hi)}]" for x, (lo, hi)
            in zip(model.states, box)) + "; observer started at x*(0) = Φ c (c the box centre)")
    else:
        x0_text = ("x(0) known: observer started at x*(0) = Φ x(0) (e(0) = 0); no initial box"
                   " declared")
        if sysm["joint"]:  # x(0) anywhere in the envelope, e(0) = 0
            env = [full[x] for x in model.states]
            cols = [np.concatenate([np.eye(n)[:, j], np.zeros(Phin.shape[0])])
                    * float((hi - lo) / 2) for j, (lo, hi) in enumerate(env)]
            cols.append(np.concatenate([[float((lo + hi) / 2) for lo, hi in env],
                                        np.zeros(Phin.shape[0])]))
    if not cols:
        return np.zeros(N.shape[0]), None, None, x0_text, start
    coef, q = _decay(F, hr, how)
    K = transient_envelope(F, N, np.array(cols).T, q) * (1 + 1e-9)
    return K, coef, q, x0_text + f"; transient ≤ K·{q:.6g}^k", start


def _error_system(model: PlantModel, g: dict, hold: dict, sysm: dict, Bf, residuals):
    """The sampled error system (discrete: z(k+1) = F z(k) + fault_input d, r = −C z) for the
    fault's steady response; z = [x; e] when the plant's step is stable."""
    k = g["Phi"].rows
    rat = lambda M: sp.Matrix(M).applyfunc(sp.Rational)  # noqa: E731
    Df = sp.zeros(g["Gr"].cols, 0)
    if Bf is None:
        Bx = sp.zeros(g["Phi"].cols, 0)
    else:
        Bf, Df = Bf
        Bx = Bf if hold["sampled"] else (None if hold["G0"] is None else
                                         rat(to_np(hold["G0"] * to_mp(Bf))))
    # a fault in the outputs enters the observer's step (−Q G D_f) and r (G_r D_f) directly;
    # a nonlinear plant's fault through the observer's side, Γ Φ D_f over a step
    PhiBx = g["Phi"] * Bx if Bx is not None else rat(to_np(hold["Gamma"] * to_mp(g["Phi"] * Bf)))
    Be = PhiBx - rat(to_np(hold["Q"] * to_mp(g["G"]) * to_mp(Df))) if Df.cols else PhiBx
    if sysm["joint"]:
        fin, C = Bx.col_join(Be), sp.zeros(len(residuals), sysm["n"]).row_join(g["Cr"])
    else:
        fin, C = Be, g["Cr"]
    return ErrorSystem("discrete", sp.ImmutableMatrix(rat(sysm["F"])), sp.ImmutableMatrix(C),
                       sp.ImmutableMatrix(fin),
                       sp.ImmutableMatrix(g["Gr"] * Df if Df.cols else
                                          sp.zeros(len(residuals), len(model.faults))),
                       tuple(str(d) for d in model.faults), residuals) if k >= 0 else None


def sampled_band_refusal(model: PlantModel, observer: Observer) -> str:
    """Why :func:`sampled_threshold` cannot bound this plant and residual generator (not
    affine with constant coefficients where it must be, or, for a nonlinear plant, a term
    without a finite bound over the operating envelope), "" when it can (the step is
    checked by :func:`sampled_threshold` itself)."""
    where = model.where
    try:
        g = _generator(model, observer, residual_names(observer), where)
        dynx, outx, box, _ = _nominal(model)
        unc = tuple(box) + tuple(model.disturbances) + tuple(model.noise)
        nl = nonlinear_plant(model, g, dynx, outx, unc, where)
        if nl is None:
            split_affine(dynx, model.states, model.inputs, unc, "dynamics equation", where)
            split_affine(outx, model.states, model.inputs, unc, "output", where)
        else:  # the identities and every interval bound (at a step of 1/100: they do not
            nonlinear_identities(g, nl, model.states, where)  # depend on it being finite)
            h = sp.Rational(1, 100)
            with mpmath.workdps(DPS):
                F, Q = hold_step(g["A"], h, "rk4")
            nonlinear_inputs(g, nl, model, dict(F=F, Q=Q, h=h), _envelope(model, box, where),
                             where)
    except UsageError as exc:
        return str(exc)
    return ""


def sampled_threshold(model: PlantModel, observer: Observer, h=None, *,
                      discretisation: str = "rk4") -> Observer:
    """The residual generator with guaranteed bands that hold for the discrete algorithm
    that runs deployed (module docstring): stepped every ``h`` by ``discretisation`` (RK4 or
    the exact ZOH, as :func:`observer_cad.codegen.observer_step`), on the true continuous
    plant with held inputs and sampled outputs. A discrete-time model takes no ``h``.

    Needs the operating envelope (bounds on every state and input) and bounds on every
    disturbance and noise that reaches the residual; with an initial box (``model.initial``)
    the returned observer starts at Φ c (c the box centre) and the band includes the
    transient from the box, else it rests on a known x(0) (a listed condition). Returns a new
    :class:`Observer` with outputs ``r_lower``/``r_upper`` (``rI_…`` for a bank), one extra
    state ``<ξ>_decay`` when there is a transient, and ``threshold.sample_time``/
    ``threshold.discretisation`` saying how it must be stepped.
    """
    where = model.where
    residuals = residual_names(observer)
    if observer.time != model.time:
        raise UsageError(f"{where}: the observer is {observer.time}-time, the model {model.time}-time")
    if observer.delays and any(observer.delays.get(r, 0) for r in residuals):
        raise UsageError(f"{where}: delayed residuals have no guaranteed threshold")
    hr, how = _checked_step(model, h, discretisation)
    g = _generator(model, observer, residuals, where)
    dynx, outx, box, Bf = _nominal(model)
    unc = tuple(box) + tuple(model.disturbances) + tuple(model.noise)
    nl = nonlinear_plant(model, g, dynx, outx, unc, where)
    full = _envelope(model, box, where)
    if nl is None:
        dyn = split_affine(dynx, model.states, model.inputs, unc, "dynamics equation", where)
        out = split_affine(outx, model.states, model.inputs, unc, "output", where)
        conds = [_identities(g, dyn, out, where)]
        full["__states"], full["__inputs"] = tuple(model.states), tuple(model.inputs)
        hold = _hold_matrices(g, dyn, hr, how)
        sysm = _inputs(g, dyn, out, hold, full, where)
    else:
        out = nl.out
        conds = [nonlinear_identities(g, nl, model.states, where)]
        with mpmath.workdps(DPS):
            F, Q = hold_step(g["A"], hr, "rk4" if how == "rk4" else "exact")
        hold = dict(F=F, Q=Q, E0=None, G0=None, h=hr, sampled=False)
        sysm = nonlinear_inputs(g, nl, model, hold, full, where)
        hold["Gamma"] = sysm["Gamma"]
    F, N, labels = sysm["F"], sysm["N"], sysm["labels"]
    rho_F = float(max(np.abs(np.linalg.eigvals(F)))) if F.size else 0.0
    if not rho_F < 1:
        raise UsageError(f"{where}: the observer's discrete step is not stable (spectral radius"
                         f" {rho_F:.6g}); no bounded band at this sample time")
    wc = worst_case_sums(F, N, sysm["B"], sysm["Cd"], sysm["lo"], sysm["hi"])
    Fe, Ne = to_np(hold["F"]), -to_np(g["Cr"])
    res_mag, step_mag = _magnitudes(g, out, hold, full, model, where)
    if nl is not None:  # the observer's nonlinear terms add up in its step too
        step_mag = step_mag + np.abs(to_np(hold["Q"])) @ sysm["n_mag"]
    acc = worst_case_sums(Fe, Ne, np.diag(step_mag), np.zeros((Ne.shape[0], len(step_mag))),
                          -np.ones(len(step_mag)), np.ones(len(step_mag))).upper
    eps = float(np.finfo(float).eps)
    margin = ROUNDOFF_FACTOR * eps * (res_mag + acc) + 1e-9 * (np.abs(wc.upper) + np.abs(wc.lower))
    margin_text = (f"{ROUNDOFF_FACTOR:g}·eps·(magnitude of the residual's terms and of the"
                   " accumulated step terms over the envelope) + 1e-9·|band|: "
                   + ", ".join(f"{v:.3g}" for v in margin))
    xi, upd = list(g["xi"]), list(g["upd"])
    initial = dict(observer.initial)
    K, coef, q, x0_text, start = _transient(model, g, sysm, full, hr, how)
    if start is not None:
        initial.update({s_: start[i] for i, s_ in enumerate(xi)})
    conds += _conditions(model, hr, how, full, box, labels, wc, rho_F, x0_text, margin_text,
                         sysm["joint"])
    z = sp.Symbol(f"{xi[0] if xi else 'xs'}_decay")
    states, updates = tuple(xi), tuple(upd)
    if np.any(K > 0):
        states, updates = states + (z,), updates + (coef * z,)
        initial[z] = sp.Integer(1)
    outputs = list(observer.outputs)
    for i, r in enumerate(residuals):
        tr = sp.Float(float(K[i]), 17) * z if K[i] > 0 else 0
        outputs.append((f"{r}_lower", sp.Float(float(wc.lower[i] - margin[i]), 17) - tr))
        outputs.append((f"{r}_upper", sp.Float(float(wc.upper[i] + margin[i]), 17) + tr))
    es = _error_system(model, g, hold, sysm, Bf, residuals)
    th = Threshold("guaranteed", residuals, tuple(conds), (), es, float(max(margin, default=0)),
                   "worst-case (L1) bounds of the fault-free residual of the sampled algorithm",
                   sample_time=float(hr) if hr is not None else None, discretisation=how)
    return dataclasses.replace(
        observer, states=states, update=updates, parameters={}, outputs=tuple(outputs),
        initial=initial, conditions=tuple(observer.conditions) + tuple(conds),
        description=observer.description + "; with sampled-data guaranteed thresholds",
        threshold=th)
