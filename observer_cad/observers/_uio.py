"""Unknown-input estimators of seed 000 (Zhirabok & Zuev 2024, §4-§8) as observers.

Discrete time only (the paper's setting). The reduced model of a canonical design
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
component at step t + m, m = r + 1 (m = 1 matched, m = k mismatched, §7). With

    α(t+m) = (y*(t+m) − x̲_1(t+m)) / (x̄_1(t+m) − x̲_1(t+m))

the identity y*(t+m) = α x̄_1(t+m) + (1 − α) x̲_1(t+m) holds by definition.
:func:`derive_estimate` substitutes the model (unrolled m steps from time t, with d(t)
symbolic) for y*(t+m) and the observer equations (unrolled from x̲(t), x̄(t)) for the two
bounds, and solves for d(t) with ``sympy.solve``. Unmeasured components x*_{r+2..k}(t)
of the model (the matched case k > 1, §5) enter through the observer copies: the model
side is taken as the same α-combination, α E(d, x̄) + (1 − α) E(d, x̲), which is the
paper's (5.2) with the vanishing term dropped. Nothing of the formula is typed in.

Which estimate is exact
-----------------------
* k = 1 (§4, §6) and the mismatched case (§7, D* in the last row): no unmeasured
  component is left after unrolling; the derived formula equals the direct inversion
  D*⁻¹(y*(t+m) − known terms) identically once α is substituted (checked by the
  computer algebra: :attr:`Derivation.residual` is 0). Exact at every step, with
  disturbances (decoupled) and whatever d does — also outside [d̲, d̄].
* D* in row r < k − 1 (matched k > 1, §5): the estimate error is
  D*_r⁻¹ [α ẽ(x̄) + (1 − α) ẽ(x̲)] with ẽ the copies' error in the unmeasured rows.
  Rows after r have no bound terms, so their error obeys e(t+1) = F** e − g** e_1(t),
  and e_1 (the distance of the first component to its bound) never vanishes. With
  g** = 0 (the default here) the rows after r are nilpotent: the copies equal the model
  after k − r − 1 steps and the estimate is exact from then on (linear case; nonlinear
  terms make it asymptotic). With g** ≠ 0, as printed in the paper's (5.1), a persistent
  error proportional to g** and to the variation of α remains — the paper's claim that
  d̂ → d relies on the copies converging, which they do not do while e_1 ≠ 0.
* Jordan (§8, k = 1, F* = λ): y*(t) = x*(t) is measured, but as in the paper it is
  written as α(t) x̄(t) + (1 − α(t)) x̲(t); the derived formula then carries the term
  D*⁻¹ λ (x̄(t) − x̲(t)) (α(t+1) − α(t)) (:attr:`Derivation.lambda_term`, verified by
  the computer algebra). Exact; equal to the direct inversion
  D*⁻¹(y*(t+1) − λ y*(t) − J* y(t) − G* u(t) − C*Ψ*).

The estimate of d(t) needs y(t+m): the observer keeps memory states (``y1_lag1`` =
y1(t−1), ``xl1_lag2`` = x̲_1(t−2), …) and its output ``<name>_hat`` has delay m (the
simulator shifts it so that row t holds d̂(t)).

Default gains (``g``), all with F* − g H* nonnegative (inclusion while d is within its
bounds) and stable:
* matched (D* in row 1): g = (−0.7, 0, …, 0) — −0.7 is the paper's (§9); the zeros are
  explained above;
* D* in a later row (0-based r ≥ 1, e.g. mismatched): g_1 = −0.4, g_2 = −0.1 (the paper's
  gains for the electric drive's ρ; g_2 only if D* is in row 2 or later), 0 in every row
  after D*'s row and from row 3 on;
* Jordan: g = λ − 0.7, so that the copies' error obeys e(t+1) = 0.7 e(t).

Degenerate α: α is computed as ``Piecewise((num/den, |den| > eps), (1/2, True))`` with the
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

__all__ = ["Derivation", "derive_estimate", "unknown_input_observer",
           "vector_unknown_input_observer",
           "combine_observers", "ALPHA", "ALPHA_PREV", "ALPHA_EPS", "default_gains"]

#: Default threshold of the α guard (observer parameter ``alpha_eps``).
ALPHA_EPS = 1e-12

ALPHA = sp.Symbol("alpha")  # α(t+m) in the derived formula
ALPHA_PREV = sp.Symbol("alpha_prev")  # α(t) (Jordan variant only)
LAMBDA_SYM = sp.Symbol("Lambda")


# ---------------------------------------------------------------- the reduced model
@dataclasses.dataclass(frozen=True)
class _Reduced:
    form: str  # "canonical" or "jordan"
    k: int
    Fs: sp.Matrix
    Js: sp.Matrix
    Gs: sp.Matrix
    Cs: sp.Matrix
    Ds: sp.Matrix  # k×1
    Ls: sp.Matrix  # k×p (nonzero only for approximate designs)
    R: sp.Matrix  # 1×l with x*_1 = R y
    subs: tuple
    xs: tuple
    row: int  # 0-based row of D*
    target: sp.Symbol
    rho: tuple  # symbols of the inputs behind L*
    params: dict  # model parameters used by a symbolic design, with their defaults
    inputs: tuple  # the model's known inputs u


def _is_zero(e, scale) -> bool:
    e = sp.sympify(e)
    if e == 0:
        return True
    if e.free_symbols:
        return sp.cancel(e) == 0
    return abs(float(e)) <= 1e-12 * scale


def _reduced(model: PlantModel, design: Design) -> _Reduced:
    if model.time != "discrete":
        raise UsageError("unknown-input estimators (seed 000) are discrete-time; the model"
                         f" {model.name} is {model.time}-time")
    if len(design.task.targets) != 1:
        raise UsageError("unknown_input_observer needs a design for one unknown input; for a"
                         " vector d use vector_unknown_input_observer")
    target = model.symbol(design.task.targets[0])  # the task was checked against the model
    mats = design.matrices
    if mats.D_star is None:
        raise UsageError("unknown_input_observer needs a design with D* (a canonical"
                         " unknown-input design, or a Jordan diagnostic design)")
    k = design.k
    Fs = sp.Matrix(mats.F_star)
    Ds = sp.Matrix(mats.D_star)
    if Ds.cols != 1:
        raise UsageError("unknown_input_observer: D* must have one column")
    if design.form == "canonical":
        Hs = sp.Matrix(mats.H_star)
        if Hs != sp.Matrix([[1] + [0] * (k - 1)]):
            raise UsageError("unknown_input_observer: canonical design without H* = (1 0 … 0)")
        R = sp.Matrix(mats.R_star)
        form = "canonical"
    elif design.form == "jordan":
        if k != 1:
            raise UsageError(f"the Jordan variant (seed 000 §8) needs a one-row λ-model; the design"
                             f" has k = {k} (use design_jordan_unknown_input)")
        if mats.R_star is None or mats.H_star is None:
            raise UsageError("the Jordan variant needs y* = R* y = H* x* (a diagnostic design)")
        h = sp.Matrix(mats.H_star)[0, 0]
        R = (sp.Matrix(mats.R_star) / h).applyfunc(sp.cancel)
        form = "jordan"
    else:
        raise UsageError(f"unknown_input_observer: unsupported design form {design.form!r}")
    scale = max([abs(float(e)) for e in Ds if not sp.sympify(e).free_symbols] + [1e-300])
    rows = [i for i in range(k) if not _is_zero(Ds[i, 0], scale)]
    if len(rows) != 1:
        raise UsageError(
            f"unknown_input_observer: D* = {list(Ds)} must enter exactly one row of the reduced"
            " model (design with single_row=True, or use a Jordan design)")
    Ds = sp.Matrix([Ds[i, 0] if i == rows[0] else 0 for i in range(k)])
    Gs = sp.Matrix(mats.G_star) if mats.G_star is not None else sp.zeros(k, len(model.inputs))
    Js = sp.Matrix(mats.J_star)
    Cs = sp.Matrix(mats.C_star) if mats.C_star is not None else sp.zeros(k, 0)
    Ls = sp.Matrix(mats.L_star) if mats.L_star is not None else sp.zeros(k, 0)
    rho = ()
    if Ls.cols and any(not _is_zero(e, 1.0) for e in Ls):
        rho = tuple(model.symbol(n) for n in design.decoupled)
        if len(rho) != Ls.cols or any(s is None for s in rho):
            raise UsageError("unknown_input_observer: cannot match the columns of L* to the"
                             f" design's decoupled inputs {design.decoupled}")
    else:
        Ls = sp.zeros(k, 0)
    xs = tuple(design.observer_states) or tuple(sp.symbols(f"xs1:{k + 1}"))
    used = set()
    for M in (Fs, Js, Gs, Cs, Ds, Ls, R):
        used |= M.free_symbols
    for ns in design.nonlinear:
        used |= sp.sympify(ns.function).free_symbols
    params = {}
    for p in model.parameters:
        if p in used:
            v = model.parameters[p]
            if v is None:
                raise ModelError(f"{model.where}: the design is symbolic and parameter '{p}' has"
                                 " no default value; the observer needs numbers (design with"
                                 " symbolic=False or give the parameter a value)")
            params[p] = v
    return _Reduced(form, k, Fs, Js, Gs, Cs, Ds, Ls, R, tuple(design.nonlinear), xs, rows[0],
                    target, rho, params, tuple(model.inputs))


def _psi(red: _Reduced, X, Y, U):
    """C* Ψ*(X, Y, U) (zero vector for a linear design)."""
    k = red.k
    if not red.subs or red.Cs.cols == 0:
        return sp.zeros(k, 1)
    ys = output_symbols(len(Y))
    rep = dict(zip(red.xs, X))
    rep.update(dict(zip(ys, Y)))
    rep.update(dict(zip(red.inputs, U)))
    psi = sp.zeros(red.Cs.cols, 1)
    for ns in red.subs:
        psi[ns.index - 1, 0] = sp.sympify(ns.function).xreplace(rep)
    return red.Cs * psi


def default_gains(form: str, k: int, row: int, lam=0):
    """The documented default gains (see the module docstring)."""
    if form == "jordan":
        return [sp.sympify(lam) - sp.Rational(7, 10)]
    if row == 0:
        return [sp.Rational(-7, 10)] + [sp.Integer(0)] * (k - 1)
    base = [sp.Rational(-4, 10), sp.Rational(-1, 10)]
    return [base[i] if (i < 2 and i <= row) else sp.Integer(0) for i in range(k)]


def _lag(base: sp.Symbol, j: int) -> sp.Symbol:
    return base if j == 0 else sp.Symbol(f"{base.name}_lag{j}")


# ---------------------------------------------------------------- the derivation
@dataclasses.dataclass(frozen=True)
class Derivation:
    """What the computer algebra produced for one unknown input.

    Symbols: the current step is t + m (``delay`` = m); ``y1``, ``xl1`` … are values at
    t + m, ``y1_lag{j}``, ``xl1_lag{j}`` at t + m − j; ``alpha`` is α(t+m),
    ``alpha_prev`` α(t) (Jordan); gains ``g``/``g1…``, bounds ``<d>_min``, ``<d>_max``.
    """

    unknown: str
    form: str
    delay: int
    row: int  # 1-based row of the reduced model that D* enters
    identity: sp.Eq  # model and observer substituted into y*(t+m) = α x̄_1 + (1−α) x̲_1
    formula: sp.Expr  # sp.solve's d(t), in α (and α(t) for Jordan) and b_lo_i, b_hi_i
    alpha_definition: sp.Expr  # α(t+m) in the observer's current symbols (unguarded)
    alpha_prev_definition: sp.Expr | None
    estimate: sp.Expr  # the observer's output: formula with the bounds and the guarded α
    exact: bool
    direct: sp.Expr | None  # the direct inversion (exact cases)
    residual: sp.Expr | None  # formula(α = definition) − direct, simplified: 0
    unknown_states: tuple  # unmeasured x*_i(t) that entered through the copies
    lambda_term: sp.Expr | None  # Jordan: D*⁻¹ λ (x̄ − x̲)(α(t+1) − α(t)), verified
    lambda_term_verified: bool
    d_symbol: sp.Symbol
    time_names: dict  # symbol -> readable name with its time index
    bound_terms: dict  # b_lo_i / b_hi_i -> min / max of D* d (+ L* ρ) in row i

    def readable(self, expr) -> str:
        """``expr`` with every symbol written with its time index (y1(t+1), …)."""
        rep = {s: sp.Symbol(n) for s, n in self.time_names.items()}
        return str(sp.sympify(expr).xreplace(rep))


def _time_names(m, l, inputs, k, extra=()):
    def at(j):  # lag j -> time label
        off = m - j
        return "t" if off == 0 else f"t+{off}"
    names = {}
    for j in range(m + 1):
        for i in range(l):
            names[_lag(sp.Symbol(f"y{i + 1}"), j)] = f"y{i + 1}({at(j)})"
        for u in inputs:
            names[_lag(u, j)] = f"{u}({at(j)})"
        for i in range(k):
            names[_lag(sp.Symbol(f"xl{i + 1}"), j)] = f"xlow{i + 1}({at(j)})"
            names[_lag(sp.Symbol(f"xu{i + 1}"), j)] = f"xup{i + 1}({at(j)})"
    names[ALPHA] = f"alpha({at(0)})"
    names[ALPHA_PREV] = "alpha(t)"
    names.update(dict(extra))
    return names


def _zero(expr) -> bool:
    expr = sp.sympify(expr)
    if expr == 0:
        return True
    e = sp.cancel(sp.together(sp.expand(expr)))
    if e == 0:
        return True
    return sp.simplify(expr) == 0


def derive_estimate(model: PlantModel, design: Design) -> Derivation:
    """Derive d̂(t) from the α identity with the computer algebra (module docstring).

    The formula is symbolic in the gains (``g`` or ``g1…gk``), the bounds
    (``<d>_min``, ``<d>_max``) and, for symbolic designs, the model's parameters.
    """
    red = _reduced(model, design)
    return _derive(model, red)


def _split(A):
    """A⁺ = max(0, A), A⁻ = max(0, −A) elementwise (A = A⁺ − A⁻); Max for symbolic entries."""
    def p(e):
        e = sp.sympify(e)
        if e.free_symbols:
            return sp.Max(e, 0)
        return e if e > 0 else sp.Integer(0)
    A = sp.Matrix(A)
    return A.applyfunc(p), (-A).applyfunc(p)


def _bound_terms(red):
    """min and max of D* d (+ L* ρ) over the bounds, per row (the ⁺/⁻ split:
    D*⁺ d̲ − D*⁻ d̄ and D*⁺ d̄ − D*⁻ d̲), in the bound parameters ``<d>_min``, ``<d>_max``."""
    mats = [(red.Ds, [_bound_symbols(red.target)])]
    if red.Ls.cols:
        mats.append((red.Ls, [_bound_symbols(s) for s in red.rho]))
    lo, hi = sp.zeros(red.k, 1), sp.zeros(red.k, 1)
    for A, bs in mats:
        Ap, Am = _split(A)
        vlo, vhi = sp.Matrix([b[0] for b in bs]), sp.Matrix([b[1] for b in bs])
        lo += Ap * vlo - Am * vhi
        hi += Ap * vhi - Am * vlo
    return lo.applyfunc(sp.expand), hi.applyfunc(sp.expand)


def _gain_symbols(k):
    return [sp.Symbol("g")] if k == 1 else list(sp.symbols(f"g1:{k + 1}"))


def _bound_symbols(sym):
    return sp.Symbol(f"{sym.name}_min"), sp.Symbol(f"{sym.name}_max")


def _solve_affine(lhs, rhs, v) -> list:
    """``[{v: solution}]`` of lhs = rhs when it is affine in v with a coefficient free
    of v (the case here: D* d enters linearly): −b/a directly, exact numbers kept exact.
    Anything else goes to ``sympy.solve`` (which for large float models spends seconds
    converting every float to a rational and back)."""
    expr = sp.expand(lhs - rhs)
    a = expr.coeff(v)
    b = expr.xreplace({v: 0})
    if a != 0 and not a.has(v) and sp.expand(a * v + b - expr) == 0:
        return [{v: -b / a}]
    return sp.solve(sp.Eq(lhs, rhs), v, dict=True, simplify=False, check=False)


def _derive(model, red: _Reduced, *, _lambda=None) -> Derivation:
    k, r = red.k, red.row
    m = r + 1
    l = len(model.outputs)
    return _derive_core(model, red, k, r, m, l, red.inputs, _lambda)


def _derive_core(model, red, k, r, m, l, inputs, _lambda):
    Fs = red.Fs if _lambda is None else sp.Matrix([[_lambda]])
    gs = sp.Matrix(_gain_symbols(k))
    # the bound terms min/max D* d (+ L* ρ) of each row, as symbols b_lo_i / b_hi_i in the
    # derivation (the formula stays readable), replaced by their values afterwards
    lo_v, hi_v = _bound_terms(red)
    lo_d, hi_d = sp.zeros(k, 1), sp.zeros(k, 1)
    bsub = {}
    for i in range(k):
        if lo_v[i] != 0 or hi_v[i] != 0:
            a, b = sp.Symbol(f"b_lo{i + 1}"), sp.Symbol(f"b_hi{i + 1}")
            lo_d[i], hi_d[i] = a, b
            bsub[a], bsub[b] = lo_v[i], hi_v[i]
    ysym = [sp.Symbol(f"y{i + 1}") for i in range(l)]
    xl = [sp.Symbol(f"xl{i + 1}") for i in range(k)]
    xu = [sp.Symbol(f"xu{i + 1}") for i in range(k)]
    Y = [sp.Matrix([_lag(y, m - j) for y in ysym]) for j in range(m + 1)]
    U = [sp.Matrix([_lag(u, m - j) for u in inputs]) if inputs else sp.zeros(0, 1)
         for j in range(m + 1)]
    ystar = [(red.R * Y[j])[0, 0] for j in range(m + 1)]
    XL = [sp.Matrix([_lag(x, m) for x in xl])]
    XU = [sp.Matrix([_lag(x, m) for x in xu])]
    dsyms = [sp.Symbol(f"{red.target.name}_at_{j}") for j in range(m)]
    rsyms = [[sp.Symbol(f"{s.name}_at_{j}") for s in red.rho] for j in range(m)]
    unknown = [sp.Symbol(f"xstar{i + 1}_t") for i in range(1, k)]
    # α(t) for the Jordan variant: x*(t) written as α(t) x̄(t) + (1 − α(t)) x̲(t)
    jordan = red.form == "jordan"
    first0 = (ALPHA_PREV * XU[0][0] + (1 - ALPHA_PREV) * XL[0][0]) if jordan else ystar[0]
    X = [sp.Matrix([first0] + unknown)]

    def step_lin(Xj, j):
        out = Fs * Xj + red.Js * Y[j]
        if inputs:
            out += red.Gs * U[j]
        return out

    def with_first(Xj, v):
        return sp.Matrix([v] + list(Xj[1:]))

    for j in range(m):
        # the model: the first component is measured (x*_1 = y*), also inside Ψ*
        Xj = X[j] if j == 0 else with_first(X[j], ystar[j])
        nxt = step_lin(Xj, j) + _psi(red, with_first(Xj, ystar[j]), Y[j], U[j]) \
            + red.Ds * dsyms[j]
        if red.Ls.cols:
            nxt += red.Ls * sp.Matrix(rsyms[j])
        X.append(nxt.applyfunc(sp.expand))
        for C, b, store in ((XL, lo_d, XL), (XU, hi_d, XU)):
            Cj = C[j]
            e = ystar[j] - Cj[0]
            n2 = step_lin(Cj, j) + _psi(red, with_first(Cj, ystar[j]), Y[j], U[j]) + b + gs * e
            store.append(n2.applyfunc(sp.expand))
    E = X[m][0]
    d0 = dsyms[0]
    for dj in dsyms[1:]:
        if E.has(dj):  # pragma: no cover - excluded by D* entering row r only
            raise UsageError(f"d(t+{dsyms.index(dj)}) reaches y*(t+{m}): not one row")
    coeff = sp.diff(E, d0)
    if coeff.has(d0) or _zero(coeff):
        raise UsageError(
            f"{red.target}: y*(t+{m}) is not affine in {red.target}(t) with a nonzero coefficient"
            " (nonlinear terms carry the unknown input into later steps); not supported")
    approximate = bool(red.Ls.cols)
    if approximate:  # approximate (robust) design: the residual L* ρ is not known
        E = E.xreplace({s: 0 for row in rsyms for s in row})
    present = [s for s in unknown if E.has(s)]
    # the identity y*(t+m) = α x̄_1(t+m) + (1 − α) x̲_1(t+m), model and observer substituted
    rhs = ALPHA * XU[m][0] + (1 - ALPHA) * XL[m][0]
    identity = sp.Eq(E, rhs)
    # unmeasured components enter through the copies, α-weighted like the measured one
    lhs = E
    if present:
        lhs = ALPHA * E.xreplace({s: XU[0][i + 1] for i, s in enumerate(unknown)}) + \
            (1 - ALPHA) * E.xreplace({s: XL[0][i + 1] for i, s in enumerate(unknown)})
    sols = _solve_affine(lhs, rhs, d0)
    if len(sols) != 1 or d0 not in sols[0]:
        raise UsageError(f"{red.target}: the α identity has no unique solution for"
                         f" {red.target}(t): {sols}")
    formula = sols[0][d0]
    formula = sp.collect(sp.expand(formula), [ALPHA, ALPHA_PREV])
    # α in the observer's own symbols at the current step t + m
    alpha_now = (ystar[m] - xl[0]) / (xu[0] - xl[0])
    alpha_prev = (ystar[0] - XL[0][0]) / (XU[0][0] - XL[0][0]) if jordan else None
    e_sym = sp.Symbol("alpha_eps")
    est = formula.xreplace(bsub).xreplace(
        {ALPHA: _guarded(ystar[m] - xl[0], xu[0] - xl[0], e_sym)})
    if jordan:
        est = est.xreplace({ALPHA_PREV: _guarded(ystar[0] - XL[0][0], XU[0][0] - XL[0][0],
                                                 e_sym)})
    exact = not present and not approximate
    direct = residual = None
    if exact:
        # the direct inversion: the model with the measured y*(t), solved for d(t)
        Em = E.xreplace({ALPHA_PREV: 0}) if not jordan else \
            E.xreplace({ALPHA_PREV: alpha_prev})
        direct = _solve_affine(Em, ystar[m], d0)[0][d0]
        if jordan:
            direct = sp.cancel(sp.together(direct))
        # the derived formula with α (and α(t)) and the unrolled bounds substituted
        a_unrolled = (ystar[m] - XL[m][0]) / (XU[m][0] - XL[m][0])
        sub = formula.xreplace({ALPHA: a_unrolled})
        if jordan:
            sub = sub.xreplace({ALPHA_PREV: alpha_prev})
        residual = sp.cancel(sp.together((sub - direct).xreplace(bsub)))
        if residual != 0:
            residual = sp.simplify(residual)
    lam_term, lam_ok = None, False
    if jordan and _lambda is None:
        dl = _derive_core(model, red, k, r, m, l, inputs, LAMBDA_SYM)
        d0f = _derive_core(model, red, k, r, m, l, inputs, sp.Integer(0))
        term = dl.formula - d0f.formula
        expect = LAMBDA_SYM * (XU[0][0] - XL[0][0]) * (ALPHA - ALPHA_PREV) / red.Ds[0, 0]
        lam_ok = _zero(term - expect)
        lam_term = expect.xreplace({LAMBDA_SYM: red.Fs[0, 0]})
    tn = _time_names(m, l, inputs, k, extra={
        **{s: f"x*{i + 2}(t)" for i, s in enumerate(unknown)},
        d0: f"{red.target}(t)"})
    return Derivation(
        unknown=red.target.name, form=red.form, delay=m, row=r + 1, identity=identity,
        formula=formula, alpha_definition=alpha_now, alpha_prev_definition=alpha_prev,
        estimate=est, exact=exact, direct=direct, residual=residual,
        unknown_states=tuple(present), lambda_term=lam_term, lambda_term_verified=lam_ok,
        d_symbol=d0, time_names=tn, bound_terms=bsub)


def _guarded(num, den, eps):
    """num/den, or 1/2 where |den| ≤ eps (the denominator itself guarded: no 0/0)."""
    ok = sp.Abs(den) > eps
    # den + (0 or 1 − den): an Add, so that sympy does not move the power into the
    # Piecewise (numpy evaluates every branch of a select)
    safe = den + sp.Piecewise((0, ok), (1 - den, True))
    return sp.Piecewise((num / safe, ok), (sp.Rational(1, 2), True))


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


def unknown_input_observer(model: PlantModel, design: Design, *, g=None, bounds=None,
                           alpha_eps=ALPHA_EPS) -> Observer:
    """The unknown-input estimator of seed 000 for a design (module docstring).

    Parameters
    ----------
    model : PlantModel (discrete time)
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

    Returns
    -------
    Observer
        kind ``"unknown-input"``; states ``xl1…xlk``, ``xu1…xuk`` (the two copies) and the
        memory states ``<signal>_lag<j>``; output ``<name>_hat`` with delay m.
    """
    red = _reduced(model, design)
    der = _derive(model, red)
    k, m = red.k, der.delay
    l = len(model.outputs)
    lam = red.Fs[0, 0] if red.form == "jordan" else 0
    if g is None:
        gvals = default_gains(red.form, k, red.row, lam)
    else:
        gl = list(g) if isinstance(g, (list, tuple, np.ndarray, sp.MatrixBase)) else [g]
        if len(gl) != k:
            raise UsageError(f"g must have {k} entries (one per row of the reduced model)")
        gvals = [_as_number(v, "gain g") for v in gl]
    gsyms = _gain_symbols(k)
    dmin, dmax = _bound_symbols(red.target)
    lo, hi = _lookup_bounds(model, red.target, bounds)
    params = dict(red.params)
    params.update(dict(zip(gsyms, gvals)))
    params.update({dmin: lo, dmax: hi, sp.Symbol("alpha_eps"): _as_number(alpha_eps, "alpha_eps")})
    for s in red.rho:
        a, b = _lookup_bounds(model, s, bounds)
        smin, smax = _bound_symbols(s)
        params.update({smin: a, smax: b})

    # the two copies, at the current step (no lag)
    ys = sp.Matrix(output_symbols(l))
    us = sp.Matrix(model.inputs) if model.inputs else sp.zeros(0, 1)
    xl = sp.Matrix(sp.symbols(f"xl1:{k + 1}"))
    xu = sp.Matrix(sp.symbols(f"xu1:{k + 1}"))
    ystar = (red.R * ys)[0, 0]
    gs = sp.Matrix(gsyms)
    lo_d, hi_d = _bound_terms(red)
    upd = []
    for C, b in ((xl, lo_d), (xu, hi_d)):
        rhs = red.Fs * C + red.Js * ys + (red.Gs * us if us.rows else sp.zeros(k, 1))
        rhs += _psi(red, sp.Matrix([ystar] + list(C[1:])), list(ys), list(us))
        rhs += b + gs * (ystar - C[0])
        upd += [sp.expand(e) for e in rhs]

    # memory: the lagged values the formula reads
    est = der.estimate
    bases = list(ys) + list(us) + list(xl) + list(xu)
    lag_states, lag_upd = [], []
    for base in bases:
        need = [j for j in range(1, m + 1) if est.has(_lag(base, j))]
        if not need:
            continue
        for j in range(1, max(need) + 1):
            lag_states.append(_lag(base, j))
            lag_upd.append(_lag(base, j - 1))
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
    desc = (f"unknown-input estimator for {name} (seed 000 "
            + ("§8, Jordan variant" if red.form == "jordan" else
               "§4" if k == 1 else "§5, matched" if red.row == 0 else
               "§7, mismatched" if red.row == k - 1 else "Remark 5")
            + f"): {name}(t) = " + der.readable(der.formula) + f" at step t+{m}, alpha(t+{m}) = "
            + der.readable(der.alpha_definition)
            + ("" if der.alpha_prev_definition is None else
               ", alpha(t) = " + der.readable(der.alpha_prev_definition)))
    return Observer(
        name=f"{model.name}_unknown_input_{name}", kind="unknown-input", time="discrete",
        states=states, signals=tuple(output_symbols(l)) + tuple(model.inputs),
        parameters=params, update=tuple(upd) + tuple(lag_upd), outputs=((out, est),),
        delays={out: m}, initial=initial, conditions=tuple(conds),
        assumptions=tuple(design.assumptions), design=design, description=desc)


def _numeric_matrix(M, params):
    M = sp.Matrix(M).xreplace(params)
    return np.array(M.evalf(), dtype=float) if M.rows and M.cols else np.zeros(M.shape)


def _approx_bound(red, params):
    try:
        r = red.row
        Dn = float(sp.sympify(red.Ds[r, 0]).xreplace(params))
        tot = 0.0
        for j, s in enumerate(red.rho):
            smin, smax = _bound_symbols(s)
            lj = float(sp.sympify(red.Ls[r, j]).xreplace(params))
            tot += abs(lj) * max(abs(float(params[smin])), abs(float(params[smax])))
        return f"; |error| <= {tot / abs(Dn):.3g} when only row {r + 1} of L* is nonzero" \
            if all(_is_zero(red.Ls[i, j], 1.0) for i in range(red.k) if i != r
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
    from ..synthesis import design_canonical, design_jordan_unknown_input
    names = list(names) if names else [f.name for f in model.faults]
    if not names:
        raise ModelError(f"{model.where}: no unknown inputs to estimate")
    built = {}
    for nm in names:
        others = [o for o in names if o != nm]
        if designs and nm in designs:
            des = designs[nm]
        elif form == "canonical":
            des = design_canonical(model, unknown_input=nm, decouple=others, symbolic=symbolic)
        elif form == "jordan":
            lam = (lambdas or {}).get(nm, sp.Rational(1, 2))
            des = design_jordan_unknown_input(model, nm, lam, decouple=others, symbolic=symbolic)
        else:
            raise UsageError(f"form must be 'canonical' or 'jordan', not {form!r}")
        built[nm] = unknown_input_observer(model, des, g=(g or {}).get(nm), bounds=bounds)
    return combine_observers(built, name=f"{model.name}_unknown_input_vector")
