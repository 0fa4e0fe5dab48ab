"""Thresholds for residuals: guaranteed adaptive bounds of the fault-free residual (METHOD §3,
"Residual evaluation"), user constants, and the value every kind of threshold shares.

A residual generator is a linear observer ξ' = A ξ + (terms in y, u), r = −C ξ + (terms in y,
u) (ξ(t+1) in discrete time), built so that ξ follows Φ x. With the error e = Φ x − ξ and the
fault-free plant at its *true* parameters θ (nominal θ0 plus an uncertainty δ declared in the
model), its disturbances ρ and its noise w,

    e' = A e + Δ(x, u, ρ, w, δ),          r = −C e + Γ(x, u, w, δ),

where Δ = Φ f(x, u, ρ, 0; θ) − f_obs(Φ x, h(x; θ) + W w, u) and Γ = g_obs(Φ x, h(x; θ) + W w, u)
are computed symbolically from the observer's own equations and the plant model. At θ0 with
w = 0 both vanish identically (the design's certificate, re-checked here from the observer's
equations, not from the design's matrices). Δ and Γ are polynomials in the states and inputs
whose coefficients depend on δ, ρ, w only; those coefficients are bounded exactly over the
declared boxes (rational interval arithmetic), the states they multiply by the measurements
(x_i from an output y_k = c x_i + noise: x_i ∈ (y_k − [W w]_k)/c) or by the model's domain. That
gives [Δ̲, Δ̄] and [Γ̲, Γ̄] as expressions in y and u, evaluated online. The error bounds follow
the comparison (embedding) system

    discrete:    e̲⁺ = A⁺ e̲ − A⁻ ē + Δ̲,          ē⁺ = A⁺ ē − A⁻ e̲ + Δ̄
    continuous:  e̲' = A_d e̲ + A_o⁺ e̲ − A_o⁻ ē + Δ̲   (A_d the diagonal, A_o the rest of A)

and r̲ = N⁺ e̲ − N⁻ ē + Γ̲, r̄ = N⁺ ē − N⁻ e̲ + Γ̄ with N = −C. While the declared bounds hold,
the fault-free residual stays in [r̲, r̄]: no false alarm is possible. The comparison system
must be stable for the band to stay bounded: ρ(abs(A)) < 1 (discrete) or A_d + abs(A_o) Hurwitz
(continuous), certified exactly through the leading principal minors of the M-matrix
I − abs(A) (or −(A_d + abs(A_o))).

Process noise in the dynamics (f = … + Bw w) is not decoupled: it adds Φ Bw w to Δ, bounded
over the noise box together with the measurement noise of the same symbols
(:func:`_process_noise_term`), so the band grows by its contribution.

A fault d adds e_f' = A e_f + B_f d to the error and −C e_f to the residual (B_f = Φ D), so
r = r_0 + r_f with r_0 ∈ [r̲, r̄]: a step fault whose steady response abs(r_f) exceeds the band
width is detected for sure (:meth:`ErrorSystem.dc_gain`, :func:`min_detectable_fault`).
"""
from __future__ import annotations

import dataclasses
import re

import sympy as sp

from ..errors import ExpressionError, UsageError
from ..model import PlantModel, parse_number
from ..numerics import comparison_stability, neg, pos
from ..synthesis import Condition
from ..analysis import argument_range, format_number
from ..observers import Observer, output_symbols

__all__ = ["ErrorSystem", "Threshold", "ThresholdSpec", "guaranteed_threshold",
           "constant_threshold", "residual_names", "min_detectable_fault", "DEFAULT_MARGIN",
           "RELATIVE_ROUNDOFF"]

#: Absolute allowance added to both ends of a guaranteed band for floating-point roundoff of
#: the simulated or compiled residual (the band of a noise-free, exactly decoupled residual is
#: [0, 0], while its computed value is of order 1e-16).
DEFAULT_MARGIN = 1e-9

#: with a positive margin, the band also widens by RELATIVE_ROUNDOFF · eps times the magnitude
#: of the terms the computed residual and the observer's step add up (online, from |ξ|, |y|,
#: |u|), so the allowance scales with the signals (an input of 1e8 leaves a roundoff of
#: order 1e-8 in an exactly decoupled residual)
RELATIVE_ROUNDOFF = 256

_REF = "METHOD §3 (residual evaluation)"


def residual_names(observer: Observer) -> tuple:
    """The residual outputs of an observer: ``r`` or ``r1 … rm`` (in output order)."""
    names = tuple(n for n, _ in observer.outputs if re.fullmatch(r"r\d*", n))
    if not names:
        raise UsageError(f"observer {observer.name} has no residual output (r, r1, …): thresholds"
                         " apply to residual generators (--observer diagnostic, or a bank with"
                         " --isolate)")
    return names


@dataclasses.dataclass(frozen=True)
class ErrorSystem:
    """The fault-free error system of a linear residual generator (see the module docstring):
    ``e' = A e + Δ``, ``r = −C e + Γ``; a fault adds ``fault_input @ d`` to Δ and
    ``fault_feedthrough @ d`` to Γ."""

    time: str
    A: sp.ImmutableMatrix
    C: sp.ImmutableMatrix
    fault_input: sp.ImmutableMatrix
    fault_feedthrough: sp.ImmutableMatrix
    faults: tuple
    residuals: tuple

    def dc_gain(self) -> sp.ImmutableMatrix:
        """Steady-state residual per unit step of each fault (residuals × faults), exact."""
        k = self.A.shape[0]
        if not self.faults:
            return sp.ImmutableMatrix.zeros(len(self.residuals), 0)
        if self.time == "discrete":
            ss = (sp.eye(k) - self.A).LUsolve(sp.Matrix(self.fault_input))
        else:
            ss = -sp.Matrix(self.A).LUsolve(sp.Matrix(self.fault_input))
        return sp.ImmutableMatrix(-sp.Matrix(self.C) * ss + self.fault_feedthrough)


@dataclasses.dataclass(frozen=True)
class Threshold:
    """How the bands ``r_lower``/``r_upper`` of an observer's residuals were obtained.

    ``kind`` is ``"guaranteed"`` (time-varying, from the declared bounds), ``"constant"`` (a
    user value) or ``"quantile"`` (a Monte-Carlo quantile, :func:`observer_cad.simulation.
    quantile_threshold`); ``values`` the constant half-widths (constant and quantile);
    ``conditions`` what the band rests on; ``error_system`` (guaranteed) the error system used,
    ``margin`` the roundoff allowance added to both ends; ``sample_time`` and
    ``discretisation`` (sampled-data bands, :func:`sampled_threshold`): the step h and how
    the observer must be stepped ("rk4", "zoh", or "discrete" for a discrete-time model)."""

    kind: str
    residuals: tuple
    conditions: tuple = ()
    values: tuple = ()
    error_system: ErrorSystem | None = None
    margin: float = 0.0
    description: str = ""
    sample_time: float | None = None
    discretisation: str = ""

    def text(self) -> str:
        if self.kind == "guaranteed" and self.discretisation:
            how = {"rk4": "RK4", "zoh": "exact ZOH"}.get(self.discretisation, "")
            at = f" at h = {self.sample_time:g} ({how})" if self.sample_time else ""
            return (f"guaranteed threshold of the sampled algorithm{at} (worst-case bounds of"
                    f" the fault-free residual, margin ≤ {self.margin:.3g})")
        if self.kind == "guaranteed":
            return (f"guaranteed adaptive threshold (interval bounds of the fault-free residual,"
                    f" margin {self.margin:g})")
        vals = ", ".join(f"|{r}| ≤ {v:g}" for r, v in zip(self.residuals, self.values))
        return f"{self.kind} threshold: {vals}" + (f" ({self.description})" if self.description else "")


@dataclasses.dataclass(frozen=True)
class ThresholdSpec:
    """Which threshold to put on the residuals: ``kind`` ``"guaranteed"``, ``"quantile"``
    (``rate``: the target false-alarm rate per sample) or ``"constant"`` (``value``)."""

    kind: str
    rate: float | None = None
    value: float | None = None

    @classmethod
    def parse(cls, text: str, where: str = "--threshold") -> "ThresholdSpec":
        """``guaranteed``, ``quantile:RATE`` or a positive number (read by the safe number
        reader, never evaluated)."""
        t = str(text).strip()
        if t == "guaranteed":
            return cls("guaranteed")
        if t.startswith("quantile:"):
            try:
                rate = float(parse_number(t[len("quantile:"):], where=where))
            except ExpressionError:
                raise UsageError(f"{where} {text}: use quantile:RATE with a rate in (0, 1),"
                                 " e.g. quantile:0.001") from None
            if not (0 < rate < 1):
                raise UsageError(f"{where} {text}: the false-alarm rate must lie in (0, 1)")
            return cls("quantile", rate=rate)
        try:
            v = float(parse_number(t, where=where))
        except ExpressionError:
            raise UsageError(f"{where} {text}: use guaranteed, quantile:RATE or a positive"
                             " number") from None
        if not (v > 0) or v == float("inf"):
            raise UsageError(f"{where} {text}: a constant threshold must be a positive finite number")
        return cls("constant", value=v)


# --------------------------------------------------------------------------- exact intervals

def _iv_mul(a, b):
    ps = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]]
    return (min(ps), max(ps))


def _iv_pow(a, n):
    lo, hi = a
    if n % 2 == 1:
        return (lo ** n, hi ** n)
    if lo >= 0:
        return (lo ** n, hi ** n)
    if hi <= 0:
        return (hi ** n, lo ** n)
    return (sp.Integer(0), max(lo ** n, hi ** n))


def _interval(e, box, where):
    """Exact enclosure [lo, hi] of ``e`` (polynomial in the symbols of ``box``) over the box."""
    e = sp.sympify(e)
    if not e.free_symbols:
        if not e.is_real:
            raise UsageError(f"{where}: coefficient {e} is not real")
        return (e, e)
    if e.is_Symbol:
        if e not in box:
            raise UsageError(f"{where}: '{e}' has no declared bounds (declare bounds={{{e}: (low,"
                             " high)}} in the model)")
        return box[e]
    if e.is_Add:
        lo = hi = sp.Integer(0)
        for a in e.args:
            al, ah = _interval(a, box, where)
            lo, hi = lo + al, hi + ah
        return (lo, hi)
    if e.is_Mul:
        acc = (sp.Integer(1), sp.Integer(1))
        for a in e.args:
            acc = _iv_mul(acc, _interval(a, box, where))
        return acc
    if e.is_Pow and e.exp.is_Integer and e.exp > 0:
        return _iv_pow(_interval(e.base, box, where), int(e.exp))
    raise UsageError(f"{where}: the term {e} is not polynomial in the uncertain quantities;"
                     " guaranteed thresholds need polynomial dependence on parameters,"
                     " disturbances and noise")


# --------------------------------------------------------------------------- symbolic helpers

def _sym_mul(c, m):
    """[c_lo, c_hi] × [m_lo, m_hi] with constant c and online m (sympy Min/Max)."""
    (cl, ch), (ml, mh) = c, m
    if cl == ch:
        if cl == 0:
            return (sp.Integer(0), sp.Integer(0))
        if ml == mh:
            return (cl * ml, cl * ml)
        return (cl * ml, cl * mh) if cl > 0 else (cl * mh, cl * ml)
    if ml == mh:  # a known value (an input, or 1)
        if not ml.free_symbols:
            return (cl * ml, ch * ml) if ml >= 0 else (ch * ml, cl * ml)
        return (sp.Min(cl * ml, ch * ml), sp.Max(cl * ml, ch * ml))
    if cl >= 0:
        return (sp.Min(cl * ml, ch * ml), sp.Max(cl * mh, ch * mh))
    if ch <= 0:
        return (sp.Min(cl * mh, ch * mh), sp.Max(cl * ml, ch * ml))
    ps = [cl * ml, cl * mh, ch * ml, ch * mh]
    return (sp.Min(*ps), sp.Max(*ps))


def _sym_iv_mul(a, b):
    if a[0] == a[1]:
        if not a[0].free_symbols:
            return _sym_mul(a, b)
    if b[0] == b[1] and not b[0].free_symbols:
        return _sym_mul(b, a)
    ps = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]]
    return (sp.Min(*ps), sp.Max(*ps))


def _sym_iv_pow(a, n):
    lo, hi = a
    if lo == hi:
        return (lo ** n, lo ** n)
    if n % 2 == 1:
        return (lo ** n, hi ** n)
    return (sp.Max(0, lo, -hi) ** n, sp.Max(lo ** n, hi ** n))


# --------------------------------------------------------------------------- the threshold

def _nominal_model(model: PlantModel):
    """Dynamics and outputs with every parameter at its default except the uncertain ones,
    which become θ0 + δ (δ a fresh symbol named ``delta_<p>``); the δ box."""
    vals = model.parameter_values()
    unc = dict(model.uncertainty)
    deltas, box = {}, {}
    sub = {}
    for p, v in vals.items():
        if p in unc:
            dl = sp.Symbol(f"delta_{p}", real=True)
            deltas[p] = dl
            box[dl] = (unc[p][0] - v, unc[p][1] - v)
            sub[p] = v + dl
        else:
            sub[p] = v
    dyn = [sp.sympify(f).xreplace(sub) for f in model.dynamics]
    outs = [sp.sympify(h).xreplace(sub) for h in model.outputs]
    return dyn, outs, deltas, box


def _state_boxes(model: PlantModel, outs_nominal, states_needed, box, deltas, where):
    """Online interval of each needed state: from a measurement y_k = c x_i + noise, else from
    the model's domain. Returns ({x: (lo_expr, hi_expr)}, [source text])."""
    ys = output_symbols(len(model.outputs))
    result, texts = {}, []
    noise = set(model.noise)
    dset = set(deltas.values())
    for x in states_needed:
        found = None
        for k, h in enumerate(outs_nominal):
            h = sp.expand(h)
            if h.free_symbols & dset:
                continue
            if not (h.free_symbols - noise) == {x}:
                continue
            c = h.coeff(x)
            rest = sp.expand(h - c * x)
            if c == 0 or c.free_symbols or (rest.free_symbols - noise) or \
                    sp.Poly(h, x).degree() != 1:
                continue
            wl, wh = _interval(rest, box, f"{where}: noise of y{k + 1}")
            lo, hi = (ys[k] - wh) / c, (ys[k] - wl) / c
            if c < 0:
                lo, hi = hi, lo
            found = ((sp.expand(lo), sp.expand(hi)), f"{x} from y{k + 1}")
            break
        if found is None:
            lo, hi = argument_range(model, x)
            if lo.is_finite and hi.is_finite:
                found = ((sp.Rational(lo), sp.Rational(hi)) if lo.is_Rational and hi.is_Rational
                         else (lo, hi), f"{x} ∈ [{format_number(lo)}, {format_number(hi)}] (model domain)")
        if found is None:
            raise UsageError(
                f"{where}: the guaranteed threshold needs bounds on {x} (the parameter uncertainty"
                f" multiplies it), which is neither measured alone by an output nor bounded by the"
                f" model's domain; measure it, or declare its range in the model's domain"
                f" ({x} >= low, {x} <= high)")
        result[x] = found[0]
        texts.append(found[1])
    return result, texts


def _bound_terms(expr, gens, coeff_box, xbox, where):
    """[lo, hi] (sympy expressions in y, u) of a polynomial in gens (states and inputs) with
    coefficients in the box symbols."""
    expr = sp.expand(expr)
    if expr == 0:
        return (sp.Integer(0), sp.Integer(0))
    try:
        poly = sp.Poly(expr, *gens)
    except sp.PolynomialError:
        raise UsageError(f"{where}: the fault-free error is not polynomial in the states and"
                         " inputs; guaranteed thresholds need a linear residual generator and"
                         " a model polynomial in the states") from None
    lo = hi = sp.Integer(0)
    for monom, coeff in poly.terms():
        if any(s in gens for s in coeff.free_symbols):
            raise UsageError(f"{where}: could not separate the term {coeff} (internal structure)")
        c = _interval(coeff, coeff_box, where)
        m = (sp.Integer(1), sp.Integer(1))
        for g, a in zip(gens, monom):
            if a == 0:
                continue
            gi = xbox.get(g, (g, g))
            m = _sym_iv_mul(m, _sym_iv_pow(gi, a))
        tl, th = _sym_mul(c, m)
        lo, hi = lo + tl, hi + th
    return (lo, hi)


def _checked_options(model: PlantModel, observer: Observer, initial_error, margin) -> tuple:
    """The residuals, abs(e(0)) and the margin, with one-line errors for what cannot have a
    guaranteed threshold."""
    where = model.where
    residuals = residual_names(observer)
    if observer.time != model.time:
        raise UsageError(f"{where}: the observer is {observer.time}-time, the model {model.time}-time")
    if observer.delays and any(observer.delays.get(r, 0) for r in residuals):
        raise UsageError(f"{where}: delayed residuals have no guaranteed threshold")
    try:
        E0 = sp.Rational(str(initial_error)) if not isinstance(initial_error, sp.Basic) else initial_error
        margin = float(margin)
    except (TypeError, ValueError):
        raise UsageError(f"{where}: initial_error and margin must be numbers") from None
    if E0 < 0 or not (margin >= 0):
        raise UsageError(f"{where}: initial_error and margin must be nonnegative")
    return residuals, E0, margin


def _linear_generator(observer: Observer, residuals, where: str) -> tuple:
    """The observer's own equations with its parameters substituted, and the matrices of
    ξ' = A ξ + …, r = −C ξ + … (refused unless linear in ξ): (ξ, updates, residual
    expressions, A, C)."""
    xi = list(observer.states)
    missing = [s for s in xi if s not in observer.initial]
    if missing:
        raise UsageError(f"{where}: observer state {missing[0]} has no map to the plant state"
                         " (x*(0) = Φ x(0)); thresholds need a residual generator built from a design")
    par = dict(observer.parameters)
    upd = [sp.sympify(e).xreplace(par) for e in observer.update]
    outmap = {n: sp.sympify(e).xreplace(par) for n, e in observer.outputs}
    g = [outmap[r] for r in residuals]
    A = sp.Matrix(upd).jacobian(xi) if xi else sp.zeros(0, 0)
    C = sp.Matrix(g).jacobian(xi) if xi else sp.zeros(len(g), 0)  # r = −C e + Γ
    if A.free_symbols or C.free_symbols:
        raise UsageError(f"{where}: guaranteed thresholds need a residual generator linear in its"
                         " own states (this one is nonlinear in them)")
    return xi, upd, g, A, C


def _error_terms(model: PlantModel, observer: Observer, xi, upd, g, where: str) -> tuple:
    """Δ = Φ f(x, u, ρ, 0; θ0 + δ) − f_obs(Φ x, h(x) + W w, u) and Γ = g_obs(…), from the
    observer's equations and the plant: (Δ, Γ, Φ, dynamics, outputs, δ symbols, δ box)."""
    dyn, outs, deltas, dbox = _nominal_model(model)
    phi = [sp.expand(sp.sympify(observer.initial[s])) for s in xi]
    if any(e.free_symbols - set(model.states) for e in phi):
        raise UsageError(f"{where}: the observer's map x*(0) = Φ x(0) is not in the plant states")
    Phi = sp.Matrix(phi).jacobian(model.states) if phi else sp.zeros(0, len(model.states))
    ys = list(output_symbols(len(model.outputs)))
    nofault = {d: 0 for d in model.faults}
    ysub = dict(zip(ys, [sp.sympify(h).xreplace(nofault) for h in outs]))  # (faults in y too)
    xsub = dict(zip(xi, phi))
    nofault.update({w: 0 for w in model.noise})  # process noise: _process_noise_term
    Fx = sp.Matrix([f.xreplace(nofault) for f in dyn])
    Delta = (Phi * Fx - sp.Matrix([e.xreplace(xsub).xreplace(ysub) for e in upd])).applyfunc(sp.expand)
    Gamma = sp.Matrix([e.xreplace(xsub).xreplace(ysub) for e in g]).applyfunc(sp.expand)
    return Delta, Gamma, Phi, dyn, outs, deltas, dbox


def _process_noise_term(model: PlantModel, Phi, dyn) -> tuple:
    """Process noise in the error equation: Φ Bw w with Bw = ∂f/∂w (constant, the model's
    extraction guarantees it; uncertain parameters kept as θ0 + δ), and the condition naming
    it (None without process noise). Added to Δ, it is bounded over the noise box like every
    other term, jointly with the measurement noise −J* W w of the same symbols."""
    k = Phi.rows
    noise = [w for w in model.noise if any(f.has(w) for f in dyn)]
    if not noise:
        return sp.zeros(k, 1), None
    Bw = sp.Matrix([[sp.diff(f, w) for w in noise] for f in dyn])
    term = (Phi * Bw * sp.Matrix(noise)).applyfunc(sp.expand)
    seen = [str(w) for j, w in enumerate(noise) if any(e != 0 for e in (Phi * Bw)[:, j])]
    detail = (f"Φ Bw w over {', '.join(map(str, noise))}: Φ Bw = {(Phi * Bw).tolist()}; "
              + (f"{', '.join(seen)} widen the band (bounded over their declared boxes)" if seen
                 else "Φ Bw = 0: the process noise does not reach this residual"))
    return term, Condition("process noise bounded", True, detail, _REF)


def _identity_condition(model: PlantModel, Delta, Gamma, deltas, where: str) -> Condition:
    """The fault-free identity: Δ and Γ vanish at nominal parameters without noise (the
    disturbances kept: an approximate decoupling leaves terms in ρ only)."""
    zero = {**{dl: 0 for dl in deltas.values()}, **{w: 0 for w in model.noise}}
    left_d = Delta.applyfunc(lambda e: sp.expand(e.xreplace(zero)))
    left_g = Gamma.applyfunc(lambda e: sp.expand(e.xreplace(zero)))
    rho_only = all(not (e.free_symbols - set(model.disturbances)) for e in list(left_d) + list(left_g))
    ident = all(e == 0 for e in list(left_d) + list(left_g))
    if not rho_only:
        raise UsageError(f"{where}: the observer does not reproduce the plant (Φ f − f_obs(Φx, Hx, u)"
                         f" = {[e for e in left_d if e != 0][:1] or [e for e in left_g if e != 0][:1]});"
                         " the residual is not zero without faults, noise and uncertainty")
    return Condition(
        "fault-free residual identity", True,
        "Φ f(x, u, ρ, 0) − f_obs(Φ x, H x, u) and g_obs(Φ x, H x, u) recomputed from the observer's"
        " equations: " + ("exactly zero" if ident else "zero up to the disturbance terms"
                          " (approximate decoupling: ρ is bounded instead)"),
        _REF)


def _uncertainty_bounds(model: PlantModel, Delta, Gamma, outs, deltas, dbox, xi, residuals,
                        where: str) -> tuple:
    """[Δ̲, Δ̄] and [Γ̲, Γ̄] as expressions in y and u: the coefficients over the declared
    boxes (δ, ρ, w), the states they multiply by the measurements or the domain. Returns
    (Δ̲, Δ̄, Γ̲, Γ̄, the conditions "declared bounds" and "state bounds")."""
    cbox = dict(dbox)
    for s in tuple(model.disturbances) + tuple(model.noise):
        if s in model.bounds:
            cbox[s] = model.bounds[s]
    used = set()
    for e in list(Delta) + list(Gamma):
        used |= e.free_symbols
    for s in tuple(model.disturbances) + tuple(model.noise):
        if s in used and s not in cbox:
            raise UsageError(f"{where}: '{s}' reaches the residual but has no declared bounds;"
                             f" declare bounds={{{s}: (low, high)}} in the model")
    gens = list(model.states) + list(model.inputs)
    needed = []
    for e in list(Delta) + list(Gamma):
        try:
            p = sp.Poly(e, *gens)
        except sp.PolynomialError:
            continue
        for monom, _ in p.terms():
            for gsym, a in zip(gens, monom):
                if a and gsym in model.states and gsym not in needed:
                    needed.append(gsym)
    needed = [x for x in model.states if x in needed]
    fault_free_outs = [sp.sympify(h).xreplace({d: 0 for d in model.faults}) for h in outs]
    xbox, xtexts = _state_boxes(model, fault_free_outs, needed, cbox, deltas, where)
    Dl, Dh, Gl, Gh = [], [], [], []
    for i, e in enumerate(Delta):
        lo, hi = _bound_terms(e, gens, cbox, xbox, f"{where}: error equation of {xi[i]}")
        Dl.append(lo)
        Dh.append(hi)
    for i, e in enumerate(Gamma):
        lo, hi = _bound_terms(e, gens, cbox, xbox, f"{where}: residual {residuals[i]}")
        Gl.append(lo)
        Gh.append(hi)
    bnames = [f"{s} ∈ [{format_number(cbox[s][0])}, {format_number(cbox[s][1])}]"
              for s in tuple(model.disturbances) + tuple(model.noise) if s in used]
    bnames += [f"{p} ∈ [{format_number(model.uncertainty[p][0])}, {format_number(model.uncertainty[p][1])}]"
               f" (nominal {format_number(model.parameters[p])})" for p in deltas if deltas[p] in used]
    conds = [Condition(
        "declared bounds", True,
        ("no false alarm while " + ", ".join(bnames) + " and the faults are zero") if bnames else
        "no uncertainty reaches the residual: the fault-free residual is zero", _REF)]
    if xtexts:
        conds.append(Condition("state bounds", True,
                               "the uncertain terms multiply states bounded online: " + "; ".join(xtexts),
                               _REF))
    return Dl, Dh, Gl, Gh, conds


def _comparison_system(A, time: str) -> tuple:
    """The embedding of the error bounds (A_d the diagonal; A⁺, A⁻ of A, or of A − A_d in
    continuous time) and its exact stability certificate: (A_d, A⁺, A⁻, condition)."""
    k = A.shape[0]
    Ad = sp.diag(*[A[i, i] for i in range(k)]) if k else sp.zeros(0, 0)
    if time == "discrete":
        Ap, An = pos(A), neg(A)
        what = "ρ(|A|) < 1 (I − |A| a nonsingular M-matrix)"
    else:
        Ap, An = pos(A - Ad), neg(A - Ad)
        what = "A_d + |A_o| Hurwitz (−(A_d + |A_o|) a nonsingular M-matrix)"
    # the comparison matrix: |A| (discrete) or A_d + |A_o| (continuous)
    stable, _, minors = comparison_stability((Ad if time == "continuous" else sp.zeros(k, k))
                                             + Ap + An, time)
    cond = Condition(
        "comparison system stable", bool(stable),
        f"{what}: leading principal minors " + ", ".join(format_number(mn) for mn in minors),
        _REF)
    return Ad, Ap, An, cond


def _initial_box(model: PlantModel, observer: Observer, xi, Phi):
    """(x*(0) = Φ c, the bounds |Φ| ρ of e(0) = Φ (x(0) − c)) for the model's initial box
    (c its centre, ρ its half-widths); None without a box (or with Φ not numeric)."""
    if not model.initial or not all(x in model.initial for x in model.states):
        return None
    P = sp.Matrix(Phi).xreplace(dict(observer.parameters))
    if P.free_symbols:
        return None
    c = {x: (sp.Rational(lo) + sp.Rational(hi)) / 2 for x, (lo, hi) in model.initial.items()}
    rad = sp.Matrix([(sp.Rational(model.initial[x][1]) - sp.Rational(model.initial[x][0])) / 2
                     for x in model.states])
    par = dict(observer.parameters)
    start = [sp.sympify(observer.initial[s]).xreplace(par).xreplace(c) for s in xi]
    return start, list(P.applyfunc(abs) * rad), model.initial


def _run_conditions(time: str, E0, margin: float, box=None) -> list:
    """What the band assumes of the run: the initial error, the roundoff margin, the
    integration (continuous time)."""
    if box is not None:
        text = ("x(0) in the initial box " + ", ".join(
            f"{x} ∈ [{format_number(lo)}, {format_number(hi)}]" for x, (lo, hi) in box[2].items())
            + "; observer started at x*(0) = Φ c (c the box centre): |e(0)| ≤ |Φ| (half-widths) = "
            + ", ".join(format_number(r) for r in box[1]))
    else:
        text = ("x(0) known: observer started at x*(0) = Φ x(0) (e(0) = 0); no initial box"
                " declared" if E0 == 0 else
                f"|e_i(0)| ≤ {format_number(E0)} for every observer state")
    conds = [Condition("initial error", True, text, _REF)]
    if margin:
        conds.append(Condition("roundoff margin", True,
                               f"{margin:g} plus {RELATIVE_ROUNDOFF}·eps × (the magnitude of the"
                               " terms the residual and the observer's step add up, online from"
                               " |ξ|, |y|, |u|) added to both ends of the band (floating-point"
                               " roundoff of the computed residual)", _REF, required=False))
    if time == "continuous":
        conds.append(Condition(
            "continuous-time integration", True,
            "the bounds hold for the exact solution; a simulation integrates plant, observer and"
            " bounds with the same fixed step (error O(dt⁴), covered by the margin only for"
            " small dt)", _REF, required=False))
    return conds


def _bound_equations(time: str, xi, C, Ad, Ap, An, bounds, where: str) -> tuple:
    """The error-bound states and their updates, and the bands r̲ = N⁺ e̲ − N⁻ ē + Γ̲,
    r̄ = N⁺ ē − N⁻ e̲ + Γ̄ (N = −C): (e̲ states, ē states, updates e̲, updates ē, r̲, r̄)."""
    Dl, Dh, Gl, Gh = bounds
    elo = [sp.Symbol(f"{s}_elo") for s in xi]
    ehi = [sp.Symbol(f"{s}_ehi") for s in xi]
    clash = {str(s) for s in elo + ehi} & {str(s) for s in xi}
    if clash:
        raise UsageError(f"{where}: observer state names clash with the bound states ({sorted(clash)[0]})")
    L, U = sp.Matrix(elo), sp.Matrix(ehi)
    if time == "discrete":
        nl = Ap * L - An * U + sp.Matrix(Dl)
        nh = Ap * U - An * L + sp.Matrix(Dh)
    else:
        nl = Ad * L + Ap * L - An * U + sp.Matrix(Dl)
        nh = Ad * U + Ap * U - An * L + sp.Matrix(Dh)
    Np, Nn = pos(-C), neg(-C)
    rl = Np * L - Nn * U + sp.Matrix(Gl)
    rh = Np * U - Nn * L + sp.Matrix(Gh)
    return elo, ehi, nl, nh, rl, rh


def _abs_terms(e) -> sp.Expr:
    """Σ |term| of an expression (the magnitude its floating-point evaluation adds up)."""
    e = sp.expand(e)
    return sp.Add(*[sp.Abs(t) for t in sp.Add.make_args(e)]) if e != 0 else sp.Integer(0)


def _roundoff(time: str, xi, upd, g, A, C) -> tuple:
    """Online roundoff allowances: per observer state, RELATIVE_ROUNDOFF·eps·Σ|terms| of its
    update (discrete: added to the error bounds each step), and per residual the same of
    its expression plus, in continuous time, |C| times each state's step terms over its
    decay rate |A_jj| (the accumulated roundoff of ξ)."""
    eps = sp.Float(RELATIVE_ROUNDOFF * 2.0 ** -52)
    step = [eps * _abs_terms(e) for e in upd]
    res = []
    for i, e in enumerate(g):
        m = eps * _abs_terms(e)
        if time == "continuous":
            for j in range(len(xi)):
                rate = abs(A[j, j]) if A[j, j] != 0 else 1
                if C[i, j] != 0:
                    m += abs(C[i, j]) * step[j] / rate
        res.append(m)
    return step, res


def guaranteed_threshold(model: PlantModel, observer: Observer, *, initial_error=0,
                         margin: float = DEFAULT_MARGIN) -> Observer:
    """The residual generator with guaranteed adaptive thresholds (module docstring).

    Returns a new :class:`Observer` whose outputs add ``r_lower``/``r_upper`` (or
    ``rI_lower``/``rI_upper`` for each residual of a bank), computed online from y and u by
    extra states (the error bounds ``<ξ>_elo``, ``<ξ>_ehi``); its conditions list what the
    band rests on, and ``observer.threshold`` is the :class:`Threshold`.

    ``initial_error`` bounds abs(e_i(0)) (0: the observer starts at x*(0) = Φ x(0), as the
    simulator does unless a scenario sets ``observer_initial``); ``margin`` is added to both
    ends for floating-point roundoff.
    """
    where = model.where
    residuals, E0, margin = _checked_options(model, observer, initial_error, margin)
    xi, upd, g, A, C = _linear_generator(observer, residuals, where)
    Delta, Gamma, Phi, dyn, outs, deltas, dbox = _error_terms(model, observer, xi, upd, g, where)
    conds = [_identity_condition(model, Delta, Gamma, deltas, where)]
    process, process_cond = _process_noise_term(model, Phi, dyn)
    Delta = Delta + process
    conds += [process_cond] if process_cond is not None else []
    Dl, Dh, Gl, Gh, bound_conds = _uncertainty_bounds(model, Delta, Gamma, outs, deltas, dbox,
                                                      xi, residuals, where)
    conds += bound_conds
    Ad, Ap, An, stability = _comparison_system(A, model.time)
    conds.append(stability)
    box = _initial_box(model, observer, xi, Phi) if E0 == 0 else None
    conds += _run_conditions(model.time, E0, margin, box)
    # the augmented observer
    step_mag, res_mag = _roundoff(model.time, xi, upd, g, A, C) if margin else ([], [])
    if margin and model.time == "discrete":  # the step's roundoff enters the error bounds
        Dl = [lo - m for lo, m in zip(Dl, step_mag)]
        Dh = [hi + m for hi, m in zip(Dh, step_mag)]
    elo, ehi, nl, nh, rl, rh = _bound_equations(model.time, xi, C, Ad, Ap, An,
                                                (Dl, Dh, Gl, Gh), where)
    outputs = list(observer.outputs)
    for i, r in enumerate(residuals):
        mg = sp.Float(margin) + res_mag[i] if margin else 0
        outputs.append((f"{r}_lower", rl[i] - mg))
        outputs.append((f"{r}_upper", rh[i] + mg))
    initial = dict(observer.initial)
    if box is not None:  # started at Φ c: e(0) = Φ (x(0) − c) within ±|Φ| (half-widths)
        initial.update(dict(zip(xi, box[0])))
        initial.update({s: -r for s, r in zip(elo, box[1])})
        initial.update({s: r for s, r in zip(ehi, box[1])})
    else:
        initial.update({s: -E0 for s in elo})
        initial.update({s: E0 for s in ehi})
    Bf, Gf = _fault_inputs(model, Phi, dyn, outs, upd, g, deltas)
    es = ErrorSystem(model.time, sp.ImmutableMatrix(A), sp.ImmutableMatrix(C),
                     sp.ImmutableMatrix(Bf), sp.ImmutableMatrix(Gf),
                     tuple(str(d) for d in model.faults), residuals)
    th = Threshold("guaranteed", residuals, tuple(conds), (), es, margin,
                   "interval bounds of the fault-free residual")
    return dataclasses.replace(
        observer, states=tuple(xi) + tuple(elo) + tuple(ehi),
        update=tuple(upd) + tuple(sp.expand(e) for e in nl) + tuple(sp.expand(e) for e in nh),
        parameters={}, outputs=tuple(outputs), initial=initial,
        conditions=tuple(observer.conditions) + tuple(conds),
        description=observer.description + "; with guaranteed thresholds", threshold=th)


def constant_threshold(observer: Observer, value, *, kind: str = "constant",
                       description: str = "") -> Observer:
    """The observer with constant bands ``rI_lower = −τ_I``, ``rI_upper = τ_I`` (``value`` a
    number, or one per residual)."""
    residuals = residual_names(observer)
    vals = list(value) if isinstance(value, (list, tuple)) else [value] * len(residuals)
    if len(vals) != len(residuals):
        raise UsageError(f"{len(vals)} threshold values for {len(residuals)} residuals"
                         f" ({', '.join(residuals)})")
    out = []
    for v in vals:
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise UsageError(f"threshold value {v!r} is not a number") from None
        if not (v > 0) or v == float("inf"):
            raise UsageError(f"a threshold must be a positive finite number, got {v:g}")
        out.append(v)
    outputs = list(observer.outputs)
    for r, v in zip(residuals, out):
        outputs.append((f"{r}_lower", sp.Float(-v)))
        outputs.append((f"{r}_upper", sp.Float(v)))
    th = Threshold(kind, residuals, (), tuple(out), None, 0.0, description)
    return dataclasses.replace(observer, outputs=tuple(outputs), threshold=th)


def _fault_inputs(model: PlantModel, Phi, dyn, outs, upd, g, deltas) -> tuple:
    """How a fault enters the error system: Δ gains Φ ∂f/∂d − ∂f_obs/∂y ∂h/∂d and Γ gains
    ∂g_obs/∂y ∂h/∂d (a fault in the outputs, y = … + Dy d, reaches both: through the
    observer's input and the residual directly)."""
    k, q = Phi.rows, len(model.faults)
    if not q:
        return sp.zeros(k, 0), sp.zeros(len(g), 0)
    nominal = {dl: 0 for dl in deltas.values()}
    Bf = Phi * sp.Matrix([[sp.diff(f, d).xreplace(nominal) for d in model.faults] for f in dyn])
    Gf = sp.zeros(len(g), q)
    Hd = sp.Matrix([[sp.diff(h, d).xreplace(nominal) for d in model.faults] for h in outs])
    if not Hd.is_zero_matrix:
        ys = list(output_symbols(len(model.outputs)))
        Bf = Bf - sp.Matrix(upd).jacobian(ys) * Hd
        Gf = sp.Matrix(g).jacobian(ys) * Hd
    return Bf.applyfunc(sp.expand), Gf.applyfunc(sp.expand)


def min_detectable_fault(threshold: Threshold, width) -> dict:
    """Smallest step fault (per fault name) guaranteed to be detected once its response has
    settled: min over residuals of width_I / abs(dc gain_I,j) (``width``: the band width per
    residual, e.g. its largest value over a run). None where no residual sees the fault."""
    es = threshold.error_system
    if es is None:
        raise UsageError("the smallest detectable fault needs a guaranteed threshold")
    G = es.dc_gain()
    out = {}
    for j, f in enumerate(es.faults):
        best = None
        for i in range(len(es.residuals)):
            gij = abs(float(G[i, j]))
            if gij > 0:
                v = float(width[i]) / gij
                best = v if best is None else min(best, v)
        out[f] = best
    return out
