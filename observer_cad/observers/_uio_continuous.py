"""Continuous-time unknown-input estimation: d filtered by 1/(τ s + 1), derivative-free.

The estimator of seed 000 is discrete-time (it reads y*(t+m)); in continuous time the
same information is the derivative of the measured component, which is never formed here.
For a design whose reduced model has d in its measured component (the matched,
relative-degree-one case: x*_1 = y* = R* y, and x*_1 depends on no unmeasured component)

    y*' = f_1(y*, y, u) + D*_1 d,        f_1 = F*_11 y* + J*_1 y + G*_1 u + C*_1 Ψ*(y*, y, u),

the filtered input d_f = d / (τ s + 1) (d_f' = (d − d_f)/τ, d_f(0) = 0) is

    d_f = (s y* − f_1) / (D*_1 (τ s + 1)) = (y* − η) / (τ D*_1),
    η' = f_1(y*, y, u) + (y* − η)/τ,      η(0) = y*(0),

one observer state η and no derivative of y. The realisation is checked by computer
algebra: with ε = (y* − η)/τ − D*_1 d_f and the reduced model's y*', ε' + ε/τ ≡ 0, so
ε(0) = 0 gives d̂ ≡ d_f (the condition "d̂ is d filtered by 1/(τ s + 1)"). The filter's
time constant τ (default :data:`DEFAULT_TAU`) is the price: a step in d is seen after
≈ τ (63 %) and a ramp with a steady lag τ ḋ; the bandwidth is 1/τ; measurement noise on
y* reaches d̂ amplified by up to 1/(τ |D*_1|).

Where the estimator does not apply, the refusal names what to use instead:

* :func:`~observer_cad.synthesis.continuous_estimation_check` (cheap, structural, run by
  :func:`~observer_cad.synthesis.design` before any design work):
  d must reach a measured combination of the outputs that the decoupled inputs do not
  reach, rank [H L, H D_d] > rank [H L]; for a linear model, the combination's derivative
  must also be free of unmeasured states, rank [H L, H F N, H D_d] > rank [H L, H F N]
  (N spanning the null space of H). Failing either, no measured row sees d and neither
  this estimator nor the sliding-mode observer (same matching condition, seed 002 §5)
  applies: detect d with a residual (``--observer diagnostic``) or estimate it on a
  discrete-time model (seed 000, with a delay).
* after the design: d in a later row (relative degree > 1) or a measured row that
  depends on unmeasured components: a one-row λ-model (``--form jordan``) or the
  sliding-mode observer (``--observer sliding-mode``).
"""
from __future__ import annotations

import sympy as sp

from ..errors import ModelError, UsageError
from ..model import PlantModel, to_rational
from ..synthesis import Condition, Design, continuous_estimation_check
from ._observer import Observer, output_symbols
from ._uio_derivation import ReducedModel, nonlinear_part, reduced_model
from ._uio_feedthrough import known_input_view, reading_y_less_Gy_u

__all__ = ["continuous_unknown_input_observer", "DEFAULT_TAU"]

#: default time constant τ of the estimate's filter 1/(τ s + 1), in the model's time unit
DEFAULT_TAU = sp.Rational(1, 10)

_REF = "METHOD §3 (continuous-time unknown-input estimation)"


def _tau_value(tau) -> sp.Expr:
    if tau is None:
        return DEFAULT_TAU
    try:
        t = to_rational(tau, "tau")
    except ModelError as exc:
        raise UsageError(str(exc)) from None
    if not (t > 0):
        raise UsageError(f"tau must be a positive time constant, got {tau}")
    return t


def _applicable(red: ReducedModel, name: str) -> None:
    """The matched, relative-degree-one case only: d in the measured row 1, which depends
    on no unmeasured component (else a one-line refusal naming what to use instead)."""
    if red.row != 0:
        raise UsageError(
            f"continuous-time estimation of '{name}': the design puts it in row {red.row + 1} of"
            f" {red.k} (relative degree {red.row + 1} > 1), which the filtered estimator cannot"
            " invert without derivatives; use a one-row λ-model (--form jordan) or the"
            " sliding-mode observer (--observer sliding-mode)")
    unmeasured = set(red.xs[1:])
    hidden = [red.xs[j] for j in range(1, red.k) if sp.sympify(red.Fs[0, j]) != 0]
    if not hidden and red.subs and red.Cs.cols:
        for ns in red.subs:
            if red.Cs[0, ns.index - 1] != 0 and sp.sympify(ns.function).free_symbols & unmeasured:
                hidden.append(sorted(sp.sympify(ns.function).free_symbols & unmeasured, key=str)[0])
    if hidden:
        raise UsageError(
            f"continuous-time estimation of '{name}': the measured row of the design depends on"
            f" the unmeasured {sorted(hidden, key=str)[0]}; use a one-row λ-model (--form"
            " jordan) or the sliding-mode observer (--observer sliding-mode)")


def _measured_row(model: PlantModel, red: ReducedModel) -> tuple:
    """(y*, f_1(y*, y, u)) in the observer's signals."""
    l = len(model.outputs)
    ys = sp.Matrix(output_symbols(l))
    us = sp.Matrix(model.inputs) if model.inputs else sp.zeros(0, 1)
    ystar = sp.expand((red.R * ys)[0, 0])
    f1 = red.Fs[0, 0] * ystar + (red.Js[0, :] * ys)[0, 0]
    if us.rows:
        f1 += (red.Gs[0, :] * us)[0, 0]
    X = sp.Matrix([ystar] + [sp.Integer(0)] * (red.k - 1))  # row 1 reads no other component
    f1 += nonlinear_part(red, X, list(ys), list(us))[0, 0]
    return ystar, sp.expand(f1)


def _filter_identity(model: PlantModel, red: ReducedModel, ystar, f1) -> sp.Expr:
    """ε' + ε/τ times τ, with ε = (y* − η)/τ − D*_1 d_f, η' = f_1 + (y* − η)/τ (the
    observer) and d_f' = (d − d_f)/τ: it equals y*' − f_1 − D*_1 d, where y*' is taken
    from the plant's own equations (y = h(x) without noise, y*' = ∂y*/∂x · f(x, u, d, ρ),
    the other faults, the process noise and — for an approximate design — the
    non-decoupled ρ at zero) and f_1 from the observer: zero identically when d̂ =
    (y* − η)/(τ D*_1) is d filtered by 1/(τ s + 1)."""
    vals = model.parameter_values()
    zero = {w: 0 for w in model.noise}
    zero.update({f: 0 for f in model.faults if f != red.target})
    zero.update({r: 0 for r in red.rho})
    ys = output_symbols(len(model.outputs))
    h = {y: sp.sympify(e).xreplace(zero).xreplace(vals) for y, e in zip(ys, model.outputs)}
    f = [sp.sympify(e).xreplace(zero).xreplace(vals) for e in model.dynamics]
    y_plant = ystar.xreplace(vals).xreplace(h)
    dy = sum((sp.diff(y_plant, x) * fx for x, fx in zip(model.states, f)), sp.Integer(0))
    D1 = sp.sympify(red.Ds[0, 0]).xreplace(vals)
    left = dy - sp.sympify(f1).xreplace(vals).xreplace(h) - D1 * red.target
    left = sp.expand(left)
    return left if left == 0 else sp.simplify(left)


def _conditions(red, ystar, tau, residual, params, process) -> list:
    name, D1 = red.target.name, red.Ds[0, 0]
    conds = [Condition(
        f"{name} enters the measured component (relative degree one)", True,
        f"y* = {ystar} = x*_1 with x*_1' = f_1(y*, y, u) + ({D1}) {name}: the matched case",
        _REF)]
    conds.append(Condition(
        "d̂ is d filtered by 1/(τ s + 1) (computer algebra)", residual == 0,
        f"ε = (y* − η)/τ − D*_1 {name}_f: τ (ε' + ε/τ) = y*' − f_1 − D*_1 {name} with y*' from"
        f" the plant's equations simplifies to {residual}; η(0) = y*(0)"
        f" gives ε ≡ 0, i.e. {name}_hat = {name} filtered by 1/({tau} s + 1)", _REF))
    gain = sp.nsimplify(abs(1 / (tau * sp.sympify(D1).xreplace(params))), rational=True)
    conds.append(Condition(
        "filter time constant τ > 0", bool(tau > 0),
        f"τ = {tau}: delay ≈ τ (a step reaches 63 % after τ, a ramp lags by τ ḋ), bandwidth"
        f" 1/τ = {sp.nsimplify(1 / tau, rational=True)} rad per time unit; noise on y*"
        f" reaches {name}_hat"
        f" amplified by up to 1/(τ |D*_1|) = {gain}",
        _REF))
    if process is not None:
        conds.append(Condition(
            "process noise", True, f"Φ_1 Bw = {process} in the measured row: the process noise"
            f" reaches {name}_hat as (Φ_1 Bw w)/D*_1 filtered by 1/(τ s + 1) (not decoupled)",
            _REF, required=False))
    if red.Ls.cols:
        conds.append(Condition(
            "approximate design: L* ρ is not decoupled", False,
            "the estimate carries D*_1⁻¹ L*_1 ρ filtered by 1/(τ s + 1)", "METHOD §2d",
            required=False))
    return conds


def continuous_unknown_input_observer(model: PlantModel, design: Design, *, tau=None
                                      ) -> Observer:
    """The continuous-time unknown-input estimator (module docstring): ``<d>_hat`` is d
    filtered by 1/(τ s + 1).

    Parameters
    ----------
    model : PlantModel (continuous time)
    design : Design
        An unknown-input design (``design(model, observer="unknown-input", faults=[NAME])``,
        canonical or ``form="jordan"``) whose reduced model has the input in its measured
        first component, and that component's equation free of the others.
    tau : positive number, optional
        The filter's time constant (default :data:`DEFAULT_TAU`); an observer parameter.

    Returns
    -------
    Observer
        kind ``"unknown-input"``; one state ``eta``; output ``<name>_hat`` without delay.
    """
    if model.time != "continuous":
        raise UsageError("continuous_unknown_input_observer takes a continuous-time model")
    view, sub = known_input_view(model)
    if sub:  # the known inputs in the outputs: built in y − Gy u (._uio_feedthrough)
        return reading_y_less_Gy_u(continuous_unknown_input_observer(view, design, tau=tau), sub)
    red = reduced_model(model, design, continuous=True)
    name = red.target.name
    if not design.approximate:  # the structural refusal first: it names the right alternative
        continuous_estimation_check(model, name, [n for n in design.decoupled if n != name])
    _applicable(red, name)
    tv = _tau_value(tau)
    ystar, f1 = _measured_row(model, red)
    tsym, eta = sp.Symbol("tau"), sp.Symbol("eta")
    D1 = red.Ds[0, 0]
    residual = _filter_identity(model, red, ystar, f1)
    params = dict(red.params)
    params[tsym] = tv
    x0 = (sp.Matrix(design.matrices.Phi) * sp.Matrix(model.states))[0, 0]
    out = f"{name}_hat"
    st = design.structure
    row = sp.Matrix(design.matrices.Phi)[0, :]
    process = (row * sp.Matrix(st.Bw)).tolist()[0] if st is not None and st.Bw.cols and \
        any(e != 0 for e in row * sp.Matrix(st.Bw)) else None
    conds = list(design.conditions) + _conditions(red, ystar, tv, residual, params, process)
    return Observer(
        name=f"{model.name}_unknown_input_{name}", kind="unknown-input", time="continuous",
        states=(eta,), signals=tuple(output_symbols(len(model.outputs))) + tuple(model.inputs),
        parameters=params, update=(sp.expand(f1 + (ystar - eta) / tsym),),
        outputs=((out, (ystar - eta) / (tsym * D1)),), initial={eta: sp.expand(x0)},
        conditions=tuple(conds), assumptions=tuple(design.assumptions), design=design,
        description=(f"continuous-time unknown-input estimator for {name}: {out} is {name}"
                     f" filtered by 1/(tau s + 1), tau = {tv} (derivative-free: eta' = f_1 +"
                     f" (y* - eta)/tau, {out} = (y* - eta)/(tau D*_1), y* = {ystar},"
                     f" D*_1 = {D1})"))
