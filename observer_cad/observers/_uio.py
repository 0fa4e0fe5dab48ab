"""Unknown-input estimators of seed 000 (Zhirabok & Zuev 2024, §4-§8) as observers.

Discrete time (the paper's setting); a continuous-time model gets the derivative-free
estimator of :mod:`._uio_continuous` (d filtered by 1/(τ s + 1)) instead. The reduced model of a canonical design
(:func:`~observer_cad.synthesis.design_canonical`, METHOD §2a) or a one-row Jordan
design (:func:`~observer_cad.synthesis.design_jordan` with ``observer="diagnostic"``,
METHOD §2b),

    x*(t+1) = F* x* + J* y + G* u + C* Ψ*(x*, y, u) + D* d,     y* = x*_1 = R* y,

with D* entering one row r only, gets an interval observer: two copies of the reduced
model with the unknown input bounded and a gain g on e = y* − (first component),

    x̲(t+1) = F* x̲ + J* y + G* u + C* Ψ*(x̲ | y*) + min_{d̲≤d≤d̄} D* d + g (y* − x̲_1)
    x̄(t+1) = F* x̄ + J* y + G* u + C* Ψ*(x̄ | y*) + max_{d̲≤d≤d̄} D* d + g (y* − x̄_1)

(min/max by the ⁺/⁻ split D*⁺ d̲ − D*⁻ d̄; ``Ψ*(x | y*)``: the measured y* replaces the
first component inside the nonlinear terms, seed 000 §6). d(t) first reaches the measured
component at step t + m, m = r + 1 (m = 1 matched, m = k mismatched, §7); the estimate of
d(t) is derived by computer algebra from the identity y*(t+m) = α x̄_1(t+m) + (1 − α)
x̲_1(t+m), α(t+m) = (y*(t+m) − x̲_1(t+m)) / (x̄_1(t+m) − x̲_1(t+m)) — the derivation and
which estimate is exact are in :mod:`._uio_derivation` (:func:`derive_estimate`).

The estimate of d(t) needs y(t+m): the observer keeps memory states (``y1_lag1`` =
y1(t−1), ``xl1_lag2`` = x̲_1(t−2), …) and its output ``<name>_hat`` has delay m (the
simulator shifts it so that row t holds d̂(t)).

Default gains (``g``), all with F* − g H* nonnegative (inclusion while d is within its
bounds) and stable:
* matched (D* in row 1): g = (−0.7, 0, …, 0) — −0.7 is the paper's (§9); the zeros are
  explained in :mod:`._uio_derivation` (which estimate is exact);
* D* in a later row (0-based r ≥ 1, e.g. mismatched): g_1 = −0.4, g_2 = −0.1 (the paper's
  gains for the electric drive's ρ; g_2 only if D* is in row 2 or later), 0 in every row
  after D*'s row and from row 3 on;
* Jordan: g = λ − 0.7, so that the copies' error obeys e(t+1) = 0.7 e(t).

Degenerate α: α is computed as ``Piecewise((num/den, abs(den) > eps), (1/2, True))`` with the
denominator itself made nonzero in the unused branch (numpy evaluates every branch of a
select: no division by zero, no NaN), ``eps`` the observer parameter ``alpha_eps``
(default 1e-12). With −g ≥ 0 (k = 1; F* − g H* ≥ 0 in general) and x̲(0) ≤ x̄(0) the
width x̄_1 − x̲_1 is at least |D*_r|(d̄ − d̲) > 0 from step m on, so the guard acts only
when d̲ = d̄ (reported as a failed condition) or for a gain that breaks nonnegativity. It
prevents a crash, not the loss of information: with zero width the identity no longer
involves y*(t+m), and the "estimate" is then the bound terms' value, not d (exactness
needs d̲ < d̄). It also acts at step 0 of the Jordan variant, whose α(t) reads memory
states that start at 0 (that output is discarded by the simulator's shift).

Vector d (seed 000 Remark 7): :func:`vector_unknown_input_observer` designs one estimator
per component (each decoupled from the other components and the disturbances) and
joins them with :func:`combine_observers` into one observer (states and gains prefixed by
the component's name).
"""
from __future__ import annotations

import dataclasses
import re
from typing import Mapping, Sequence

import numpy as np
import sympy as sp

from ..synthesis import Condition, Design
from ..errors import ModelError, UsageError
from ..model import PlantModel, to_rational
from ._observer import Observer, output_symbols
from ._uio_continuous import continuous_unknown_input_observer
from ._uio_feedthrough import known_input_view, reading_y_less_Gy_u
from ._uio_derivation import (Derivation, ReducedModel, bound_symbols, bound_terms, derivation,
                              gain_symbols, is_negligible, lag_symbol, nonlinear_part,
                              reduced_model)

__all__ = ["unknown_input_observer", "vector_unknown_input_observer", "combine_observers",
           "ALPHA_EPS", "default_gains"]

#: Default threshold of the α guard (observer parameter ``alpha_eps``).
ALPHA_EPS = 1e-12


def default_gains(form: str, k: int, row: int, lam=0):
    """The documented default gains (see the module docstring)."""
    if form == "jordan":
        return [sp.sympify(lam) - sp.Rational(7, 10)]
    if row == 0:
        return [sp.Rational(-7, 10)] + [sp.Integer(0)] * (k - 1)
    base = [sp.Rational(-4, 10), sp.Rational(-1, 10)]
    return [base[i] if (i < 2 and i <= row) else sp.Integer(0) for i in range(k)]


# ---------------------------------------------------------------- the observer
def _as_number(v, what):
    try:
        return to_rational(v, what)
    except ModelError as exc:
        raise UsageError(str(exc)) from None


def _lookup_bounds(model, sym, bounds):
    bounds = dict(bounds or {})
    for key, val in bounds.items():
        if str(key) == sym.name:
            lo, hi = val
            lo, hi = _as_number(lo, f"bounds of {sym}"), _as_number(hi, f"bounds of {sym}")
            if lo > hi:
                raise UsageError(f"bounds of {sym}: low {lo} > high {hi}")
            return lo, hi
    if sym not in model.bounds:
        raise ModelError(f"{model.where}: the unknown-input estimator needs bounds on '{sym}'"
                         f" (declare them in the model or pass bounds={{'{sym}': (low, high)}})")
    lo, hi = model.bounds[sym]
    return _as_number(lo, f"bounds of {sym}"), _as_number(hi, f"bounds of {sym}")



def _gain_values(red: ReducedModel, g) -> list:
    """The gains on e = y* − (first component): :func:`default_gains` or the caller's."""
    k = red.k
    lam = red.Fs[0, 0] if red.form == "jordan" else 0
    if g is None:
        return default_gains(red.form, k, red.row, lam)
    gl = list(g) if isinstance(g, (list, tuple, np.ndarray, sp.MatrixBase)) else [g]
    if len(gl) != k:
        raise UsageError(f"g must have {k} entries (one per row of the reduced model)")
    return [_as_number(v, "gain g") for v in gl]


def _parameters(model: PlantModel, red: ReducedModel, gvals, bounds, alpha_eps) -> tuple:
    """The observer's parameters — the model's (symbolic designs), the gains, the bounds
    of the unknown input and of ρ, ``alpha_eps`` — and the unknown input's bounds."""
    gsyms = gain_symbols(red.k)
    dmin, dmax = bound_symbols(red.target)
    lo, hi = _lookup_bounds(model, red.target, bounds)
    params = dict(red.params)
    params.update(dict(zip(gsyms, gvals)))
    params.update({dmin: lo, dmax: hi, sp.Symbol("alpha_eps"): _as_number(alpha_eps, "alpha_eps")})
    for s in red.rho:
        a, b = _lookup_bounds(model, s, bounds)
        smin, smax = bound_symbols(s)
        params.update({smin: a, smax: b})
    return params, lo, hi


def _copies(model: PlantModel, red: ReducedModel) -> tuple:
    """The two copies at the current step (no lag): (y, u, x̲, x̄, their updates)."""
    k, l = red.k, len(model.outputs)
    ys = sp.Matrix(output_symbols(l))
    us = sp.Matrix(model.inputs) if model.inputs else sp.zeros(0, 1)
    xl = sp.Matrix(sp.symbols(f"xl1:{k + 1}"))
    xu = sp.Matrix(sp.symbols(f"xu1:{k + 1}"))
    ystar = (red.R * ys)[0, 0]
    gs = sp.Matrix(gain_symbols(k))
    lo_d, hi_d = bound_terms(red)
    upd = []
    for C, b in ((xl, lo_d), (xu, hi_d)):
        rhs = red.Fs * C + red.Js * ys + (red.Gs * us if us.rows else sp.zeros(k, 1))
        rhs += nonlinear_part(red, sp.Matrix([ystar] + list(C[1:])), list(ys), list(us))
        rhs += b + gs * (ystar - C[0])
        upd += [sp.expand(e) for e in rhs]
    return ys, us, xl, xu, upd


def _memory(est, bases, m: int) -> tuple:
    """The lagged values the formula reads, as memory states: (states, updates)."""
    lag_states, lag_upd = [], []
    for base in bases:
        need = [j for j in range(1, m + 1) if est.has(lag_symbol(base, j))]
        if not need:
            continue
        for j in range(1, max(need) + 1):
            lag_states.append(lag_symbol(base, j))
            lag_upd.append(lag_symbol(base, j - 1))
    return lag_states, lag_upd


def _description(red: ReducedModel, der: Derivation) -> str:
    """The estimator named by its section of seed 000, with the derived formula."""
    k, m, name = red.k, der.delay, red.target.name
    return (f"unknown-input estimator for {name} (seed 000 "
            + ("§8, Jordan variant" if red.form == "jordan" else
               "§4" if k == 1 else "§5, matched" if red.row == 0 else
               "§7, mismatched" if red.row == k - 1 else "Remark 5")
            + f"): {name}(t) = " + der.readable(der.formula) + f" at step t+{m}, alpha(t+{m}) = "
            + der.readable(der.alpha_definition)
            + ("" if der.alpha_prev_definition is None else
               ", alpha(t) = " + der.readable(der.alpha_prev_definition)))


def unknown_input_observer(model: PlantModel, design: Design, *, g=None, bounds=None,
                           alpha_eps=ALPHA_EPS, tau=None) -> Observer:
    """The unknown-input estimator of seed 000 for a design (module docstring); for a
    continuous-time model :func:`continuous_unknown_input_observer` (d filtered by
    1/(τ s + 1)).

    Parameters
    ----------
    model : PlantModel (discrete time; continuous: see ``tau``)
    design : Design
        ``design_canonical(model, unknown_input=NAME)`` (D* in one row: first = matched,
        last = mismatched), or a one-row Jordan design from
        :func:`design_jordan_unknown_input`.
    g : number or sequence of k numbers, optional
        Gains on e = y* − (first component of each copy). Default:
        :func:`default_gains` (−0.7 for k = 1; (−0.4, −0.1) for the mismatched k = 2;
        λ − 0.7 for the Jordan variant).
    bounds : mapping name -> (low, high), optional
        Bounds of the unknown input (default: the model's declared bounds), e.g.
        ``{"rho": (-0.2, 0.2)}`` for the electric drive's ρ-estimation.
    alpha_eps : float
        Threshold of the α guard.
    tau : positive number, optional
        Continuous time only: the time constant of the estimate's filter (default 1/10).

    Returns
    -------
    Observer
        kind ``"unknown-input"``; states ``xl1…xlk``, ``xu1…xuk`` (the two copies) and the
        memory states ``<signal>_lag<j>``; output ``<name>_hat`` with delay m.
    """
    view, sub = known_input_view(model)
    if sub:  # the known inputs in the outputs: built in y − Gy u (._uio_feedthrough)
        return reading_y_less_Gy_u(unknown_input_observer(
            view, design, g=g, bounds=bounds, alpha_eps=alpha_eps, tau=tau), sub)
    if model.time == "continuous":
        if g is not None:
            raise UsageError("the gains g (--gain) belong to the discrete-time estimator; the"
                             " continuous-time one takes the filter time constant tau (--tau)")
        return continuous_unknown_input_observer(model, design, tau=tau)
    if tau is not None:
        raise UsageError("tau (--tau) applies to continuous-time unknown-input estimation; the"
                         " discrete-time estimator takes the gains g (--gain)")
    red = reduced_model(model, design)
    der = derivation(model, red)
    k, m = red.k, der.delay
    l = len(model.outputs)
    gvals = _gain_values(red, g)
    params, lo, hi = _parameters(model, red, gvals, bounds, alpha_eps)
    ys, us, xl, xu, upd = _copies(model, red)
    est = der.estimate
    lag_states, lag_upd = _memory(est, list(ys) + list(us) + list(xl) + list(xu), m)
    states = tuple(xl) + tuple(xu) + tuple(lag_states)
    Phi = sp.Matrix(design.matrices.Phi)
    xs0 = Phi * sp.Matrix(model.states)
    initial = {}
    for i in range(k):
        initial[xl[i]] = xs0[i] - 1
        initial[xu[i]] = xs0[i] + 1
    for s in lag_states:
        initial[s] = 0
    name = red.target.name
    out = f"{name}_hat"
    conds = list(design.conditions) + _conditions(red, der, gvals, params, lo, hi)
    conds += _process_noise_condition(design, red)
    return Observer(
        name=f"{model.name}_unknown_input_{name}", kind="unknown-input", time="discrete",
        states=states, signals=tuple(output_symbols(l)) + tuple(model.inputs),
        parameters=params, update=tuple(upd) + tuple(lag_upd), outputs=((out, est),),
        delays={out: m}, initial=initial, conditions=tuple(conds),
        assumptions=tuple(design.assumptions), design=design, description=_description(red, der))


def _process_noise_condition(design: Design, red: ReducedModel) -> list:
    """Process noise reaching the reduced model (Φ Bw ≠ 0) is neither decoupled nor in the
    copies' bound terms: said so (the estimate carries D*_r⁻¹ (Φ Bw w)_r)."""
    st = design.structure
    if st is None or not st.Bw.cols:
        return []
    PBw = sp.Matrix(design.matrices.Phi) * sp.Matrix(st.Bw)
    if all(e == 0 for e in PBw):
        return []
    return [Condition(
        "process noise not decoupled", False,
        f"Φ Bw = {PBw.tolist()}: the estimate of {red.target} carries D*⁻¹ (Φ Bw w) of the row"
        " of D*, and the copies' bound terms do not include it (inclusion may fail)",
        "METHOD §1", required=False)]


def _numeric_matrix(M, params):
    M = sp.Matrix(M).xreplace(params)
    return np.array(M.evalf(), dtype=float) if M.rows and M.cols else np.zeros(M.shape)


def _approx_bound(red, params):
    try:
        r = red.row
        Dn = float(sp.sympify(red.Ds[r, 0]).xreplace(params))
        tot = 0.0
        for j, s in enumerate(red.rho):
            smin, smax = bound_symbols(s)
            lj = float(sp.sympify(red.Ls[r, j]).xreplace(params))
            tot += abs(lj) * max(abs(float(params[smin])), abs(float(params[smax])))
        return f"; |error| <= {tot / abs(Dn):.3g} when only row {r + 1} of L* is nonzero" \
            if all(is_negligible(red.Ls[i, j], 1.0) for i in range(red.k) if i != r
                   for j in range(red.Ls.cols)) else ""
    except (TypeError, ValueError, KeyError, ZeroDivisionError):  # pragma: no cover
        return ""


def _conditions(red, der, gvals, params, lo, hi):
    k, r = red.k, red.row
    conds = []
    conds.append(Condition(
        f"{red.target} enters one row of the reduced model", True,
        f"row {r + 1} of {k}: estimate of {red.target}(t) available at step t+{der.delay}"
        f" (delay {der.delay})", "seed 000 §4, §5, §7"))
    Hs = sp.Matrix([[1] + [0] * (k - 1)])
    A = red.Fs - sp.Matrix(gvals) * Hs
    An = _numeric_matrix(A, params)
    ev = np.linalg.eigvals(An) if k else np.zeros(0)
    rho_ = float(max(abs(ev))) if ev.size else 0.0
    conds.append(Condition(
        "observer stable: spectral radius of F* − g H* < 1", rho_ < 1,
        f"eigenvalues {', '.join(f'{complex(e):.4g}' for e in ev)}", "seed 000 §4, §5"))
    nonneg = bool(np.all(An >= -1e-15))
    conds.append(Condition(
        "inclusion x̲ ≤ x* ≤ x̄ while the input is within its bounds: F* − g H* ≥ 0", nonneg,
        "F* − g H* = " + str(A.tolist()) + ("" if nonneg else
                                            " has negative entries: α may leave [0, 1]"
                                            " (the estimate does not need inclusion)"),
        "METHOD §3", required=False))
    later = [i for i in range(r + 1, k)]
    if later:
        zero_g = all(sp.sympify(gvals[i]) == 0 for i in later)
        conds.append(Condition(
            "gains after the row of D* are zero (the copies' unmeasured rows are nilpotent)",
            zero_g,
            ("the copies equal the model in rows " f"{r + 2}..{k} after {k - r - 1} step(s) (linear"
             " case): the estimate is exact from then on") if zero_g else
            ("g in rows after D* couples the bound distance y* − x̲_1 (never zero) into the"
             " unmeasured rows: a persistent error remains"), "seed 000 §5 (derived here)",
            required=False))
    if der.exact:
        conds.append(Condition(
            "derived estimate equals the direct inversion (computer algebra)",
            der.residual == 0, f"formula(α) − D*⁻¹(y*(t+{der.delay}) − known terms) simplifies"
            f" to {der.residual}", "METHOD §3"))
    elif der.unknown_states:
        conds.append(Condition(
            "estimate asymptotic", True,
            "unmeasured " + ", ".join(der.readable(s) for s in der.unknown_states)
            + " enter through the observer copies", "seed 000 §5"))
    if red.form == "jordan":
        conds.append(Condition(
            "Jordan term D*⁻¹ λ (x̄ − x̲)(α(t+1) − α(t)) (computer algebra)",
            der.lambda_term_verified, der.readable(der.lambda_term), "seed 000 §8"))
    conds.append(Condition(
        f"bounds {red.target}_min < {red.target}_max (nonzero α denominator)", lo < hi,
        f"[{lo}, {hi}]" + ("" if lo < hi else ": the two copies coincide, α carries no"
                            " information and the estimate is not d"), "seed 000 §4"))
    conds.append(Condition(
        "α denominator guarded", True,
        f"α = 1/2 where |x̄_1 − x̲_1| ≤ alpha_eps; with F* − g H* ≥ 0 the width is at least"
        f" |D*|({hi} − ({lo})) > 0 from step {der.delay} on", "METHOD §3"))
    if red.Ls.cols:
        conds.append(Condition(
            "approximate design: L* ρ is not decoupled", False,
            "the estimate carries the error D*_r⁻¹ L*_r ρ(t) (ρ set to 0 in the model side of the"
            " identity; its bounds enter the copies)" + _approx_bound(red, params),
            "METHOD §2d", required=False))
    return conds


# ---------------------------------------------------------------- Jordan and vector d
def _rename(obs: Observer, prefix: str, shared: set) -> tuple:
    rep = {s: sp.Symbol(f"{prefix}_{s.name}") for s in obs.states}
    rep.update({p: sp.Symbol(f"{prefix}_{p.name}") for p in obs.parameters if p not in shared})
    return rep


def combine_observers(observers: Mapping[str, Observer], *, name: str | None = None) -> Observer:
    """Join observers that read the same signals into one (vector d, Remark 7).

    Every state and every gain is prefixed with the component's key (``d1_xl1``,
    ``d1_g``); other parameters with the same name and value in every observer (model
    parameters, ``alpha_eps``, bounds — already named by their input) are shared, and
    the same name with different values gets the prefix too.
    """
    obs = list(observers.items())
    if not obs:
        raise UsageError("combine_observers: nothing to combine")
    time = obs[0][1].time
    signals: list = []
    params: dict = {}
    states, upd, outs, delays, init, conds, assume = [], [], [], {}, {}, [], []
    # parameters present in several observers with equal values are shared
    seen: dict = {}
    for _, o in obs:
        for p, v in o.parameters.items():
            seen.setdefault(p, []).append(v)
    # gains (g, g1, g2, …) belong to one estimator each and are always prefixed
    shared = {p for p, vs in seen.items()
              if all(sp.sympify(v) == sp.sympify(vs[0]) for v in vs)
              and not re.fullmatch(r"g\d*", p.name)}
    for key, o in obs:
        if o.time != time:
            raise UsageError("combine_observers: observers of different time domains")
        rep = _rename(o, key, shared)
        for s in o.signals:
            if s not in signals:
                signals.append(s)
        for p, v in o.parameters.items():
            q = rep.get(p, p)
            if q in params and sp.sympify(params[q]) != sp.sympify(v):
                raise UsageError(f"combine_observers: parameter {q} has two values")
            params[q] = v
        states += [rep[s] for s in o.states]
        upd += [sp.sympify(e).xreplace(rep) for e in o.update]
        for on, e in o.outputs:
            if on in delays or any(on == x for x, _ in outs):
                raise UsageError(f"combine_observers: output {on} appears twice")
            outs.append((on, sp.sympify(e).xreplace(rep)))
            if on in o.delays:
                delays[on] = o.delays[on]
        init.update({rep[s]: v for s, v in o.initial.items()})
        conds += [dataclasses.replace(c, name=f"[{key}] {c.name}") for c in o.conditions]
        assume += [a for a in o.assumptions if a not in assume]
    return Observer(
        name=name or "+".join(o.name for _, o in obs), kind=obs[0][1].kind, time=time,
        states=tuple(states), signals=tuple(signals), parameters=params, update=tuple(upd),
        outputs=tuple(outs), delays=delays, initial=init, conditions=tuple(conds),
        assumptions=tuple(assume),
        description="; ".join(f"[{k}] {o.description}" for k, o in obs))


def vector_unknown_input_observer(model: PlantModel, names: Sequence[str] | None = None, *,
                                  form: str = "canonical", lambdas: Mapping | None = None,
                                  g: Mapping | None = None, bounds: Mapping | None = None,
                                  symbolic: bool = True, designs: Mapping | None = None
                                  ) -> Observer:
    """One estimator per component of a vector unknown input (seed 000 Remark 7).

    Each component is designed decoupled from the other components (and from the model's
    disturbances), with :func:`~observer_cad.synthesis.design_canonical` (``form=
    "canonical"``) or the one-row λ-model (``form="jordan"``, λ from ``lambdas[name]``,
    default 1/2); ``designs`` may supply them instead. ``g`` maps a component to its gains.
    Outputs ``<name>_hat`` for every component, each with its own delay.
    """
    from ..synthesis import design, design_canonical, design_jordan_unknown_input
    names = list(names) if names else [f.name for f in model.faults]
    known = set(model.inputs) | set(model.faults) | set(model.disturbances)
    lifted = any(sp.sympify(h).free_symbols & known for h in model.outputs)
    if not names:
        raise ModelError(f"{model.where}: no unknown inputs to estimate")
    built = {}
    for nm in names:
        others = [o for o in names if o != nm]
        if designs and nm in designs:
            des = designs[nm]
        elif lifted and form in ("canonical", "jordan"):  # output feedthrough: lifted (y − Gy u)
            lam = [(lambdas or {}).get(nm, sp.Rational(1, 2))] if form == "jordan" else None
            des = design(model, observer="unknown-input", faults=[nm], disturbances=others,
                         form=form, lambdas=lam, symbolic=symbolic)
        elif form == "canonical":
            des = design_canonical(model, unknown_input=nm, decouple=others, symbolic=symbolic)
        elif form == "jordan":
            lam = (lambdas or {}).get(nm, sp.Rational(1, 2))
            des = design_jordan_unknown_input(model, nm, lam, decouple=others, symbolic=symbolic)
        else:
            raise UsageError(f"form must be 'canonical' or 'jordan', not {form!r}")
        built[nm] = unknown_input_observer(model, des, g=(g or {}).get(nm), bounds=bounds)
    return combine_observers(built, name=f"{model.name}_unknown_input_vector")
