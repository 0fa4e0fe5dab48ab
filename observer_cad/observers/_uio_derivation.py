"""The derivation of an unknown-input estimate of seed 000 (Zhirabok & Zuev 2024, §4-§8)
by computer algebra: the reduced model of the design, the observer copies, the α
identity solved for d(t), and the checks of what the formula is.

The reduced model (:class:`ReducedModel`) and the two observer copies are those of the
unknown-input estimator (:func:`~observer_cad.observers.unknown_input_observer`):

    x*(t+1) = F* x* + J* y + G* u + C* Ψ*(x*, y, u) + D* d,     y* = x*_1 = R* y,

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
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..synthesis import Design
from ..errors import ModelError, UsageError
from ..model import PlantModel
from ._observer import output_symbols

__all__ = ["Derivation", "derive_estimate", "ALPHA", "ALPHA_PREV"]

ALPHA = sp.Symbol("alpha")  # α(t+m) in the derived formula
ALPHA_PREV = sp.Symbol("alpha_prev")  # α(t) (Jordan variant only)
LAMBDA_SYM = sp.Symbol("Lambda")


# ---------------------------------------------------------------- the reduced model
@dataclasses.dataclass(frozen=True)
class ReducedModel:
    """The reduced model of a design as the estimator reads it: F*, J*, G*, C*, D* (its
    one nonzero row ``row``), L* with the inputs ρ behind it, x*_1 = R y, the nonlinear
    terms, the unknown input and the parameter values a symbolic design needs."""

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


def is_negligible(e, scale) -> bool:
    """``e`` is zero: identically for an expression, within 1e-12·``scale`` for a number."""
    e = sp.sympify(e)
    if e == 0:
        return True
    if e.free_symbols:
        return sp.cancel(e) == 0
    return abs(float(e)) <= 1e-12 * scale


def reduced_model(model: PlantModel, design: Design, *, continuous: bool = False) -> ReducedModel:
    """The reduced model of a design for one unknown input (one-line errors when the
    design is not one the estimator takes). ``continuous``: accept a continuous-time
    model (the filtered estimator of :mod:`._uio_continuous`); else discrete time only."""
    if model.time != "discrete" and not continuous:
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
    rows = [i for i in range(k) if not is_negligible(Ds[i, 0], scale)]
    if len(rows) != 1:
        raise UsageError(
            f"unknown_input_observer: D* = {list(Ds)} must enter exactly one row of the reduced"
            " model (design with single_row=True, or use a Jordan design)")
    Ds = sp.Matrix([Ds[i, 0] if i == rows[0] else 0 for i in range(k)])
    Gs = sp.Matrix(mats.G_star) if mats.G_star is not None else sp.zeros(k, len(model.inputs))
    Js = sp.Matrix(mats.J_star)
    st = design.structure
    if st is not None and model.inputs and not st.Gy.is_zero_matrix:
        Gs = Gs + Js * sp.Matrix(st.Gy)  # Φ G: the estimator reads y − Gy u (._uio_feedthrough)
    Cs = sp.Matrix(mats.C_star) if mats.C_star is not None else sp.zeros(k, 0)
    Ls = sp.Matrix(mats.L_star) if mats.L_star is not None else sp.zeros(k, 0)
    rho = ()
    if Ls.cols and any(not is_negligible(e, 1.0) for e in Ls):
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
    return ReducedModel(form, k, Fs, Js, Gs, Cs, Ds, Ls, R, tuple(design.nonlinear), xs,
                        rows[0], target, rho, params, tuple(model.inputs))


def nonlinear_part(red: ReducedModel, X, Y, U):
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


def lag_symbol(base: sp.Symbol, j: int) -> sp.Symbol:
    """The memory symbol of ``base`` j steps back (``y1_lag2``; ``base`` itself for 0)."""
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
            names[lag_symbol(sp.Symbol(f"y{i + 1}"), j)] = f"y{i + 1}({at(j)})"
        for u in inputs:
            names[lag_symbol(u, j)] = f"{u}({at(j)})"
        for i in range(k):
            names[lag_symbol(sp.Symbol(f"xl{i + 1}"), j)] = f"xlow{i + 1}({at(j)})"
            names[lag_symbol(sp.Symbol(f"xu{i + 1}"), j)] = f"xup{i + 1}({at(j)})"
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
    red = reduced_model(model, design)
    return derivation(model, red)


def _split(A):
    """A⁺ = max(0, A), A⁻ = max(0, −A) elementwise (A = A⁺ − A⁻); Max for symbolic entries."""
    def p(e):
        e = sp.sympify(e)
        if e.free_symbols:
            return sp.Max(e, 0)
        return e if e > 0 else sp.Integer(0)
    A = sp.Matrix(A)
    return A.applyfunc(p), (-A).applyfunc(p)


def bound_terms(red):
    """min and max of D* d (+ L* ρ) over the bounds, per row (the ⁺/⁻ split:
    D*⁺ d̲ − D*⁻ d̄ and D*⁺ d̄ − D*⁻ d̲), in the bound parameters ``<d>_min``, ``<d>_max``."""
    mats = [(red.Ds, [bound_symbols(red.target)])]
    if red.Ls.cols:
        mats.append((red.Ls, [bound_symbols(s) for s in red.rho]))
    lo, hi = sp.zeros(red.k, 1), sp.zeros(red.k, 1)
    for A, bs in mats:
        Ap, Am = _split(A)
        vlo, vhi = sp.Matrix([b[0] for b in bs]), sp.Matrix([b[1] for b in bs])
        lo += Ap * vlo - Am * vhi
        hi += Ap * vhi - Am * vlo
    return lo.applyfunc(sp.expand), hi.applyfunc(sp.expand)


def gain_symbols(k):
    """The gain parameters: ``g`` for one row, ``g1 … gk`` otherwise."""
    return [sp.Symbol("g")] if k == 1 else list(sp.symbols(f"g1:{k + 1}"))


def bound_symbols(sym):
    """The bound parameters ``<name>_min``, ``<name>_max`` of an unknown input."""
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



def derivation(model, red: ReducedModel, *, _lambda=None) -> Derivation:
    """The :class:`Derivation` for a reduced model (``_lambda``: F* replaced by that
    symbol or number, for the Jordan term's check)."""
    k, r = red.k, red.row
    m = r + 1
    l = len(model.outputs)
    return _derive_core(model, red, k, r, m, l, red.inputs, _lambda)


def _bound_parameters(red: ReducedModel) -> tuple:
    """The bound terms min/max D* d (+ L* ρ) of each row as symbols b_lo_i / b_hi_i (the
    formula stays readable), with their values: (lows, highs, {symbol: value})."""
    k = red.k
    lo_v, hi_v = bound_terms(red)
    lo_d, hi_d = sp.zeros(k, 1), sp.zeros(k, 1)
    bsub = {}
    for i in range(k):
        if lo_v[i] != 0 or hi_v[i] != 0:
            a, b = sp.Symbol(f"b_lo{i + 1}"), sp.Symbol(f"b_hi{i + 1}")
            lo_d[i], hi_d[i] = a, b
            bsub[a], bsub[b] = lo_v[i], hi_v[i]
    return lo_d, hi_d, bsub


@dataclasses.dataclass(frozen=True)
class _Unrolled:
    """The model and the two observer copies unrolled m steps from time t: the copies'
    current symbols ``xl``, ``xu``; y*(t+j) and the model's, the lower and the upper
    copy's x*(t+j), j = 0 … m; the symbols of d(t+j), ρ(t+j) and of the unmeasured
    x*_i(t); whether α(t) stands for the measured x*(t) (the Jordan variant)."""

    xl: list
    xu: list
    ystar: list
    X: list
    XL: list
    XU: list
    dsyms: list
    rsyms: list
    unknown: list
    jordan: bool


def _unroll(red: ReducedModel, Fs, lo_d, hi_d, m: int, l: int) -> _Unrolled:
    """Step 1: the model (the first component measured, x*_1 = y*, also inside Ψ*) and the
    copies (bound terms and the gain on y* − their first component), m steps."""
    k, inputs = red.k, red.inputs
    gs = sp.Matrix(gain_symbols(k))
    ysym = [sp.Symbol(f"y{i + 1}") for i in range(l)]
    xl = [sp.Symbol(f"xl{i + 1}") for i in range(k)]
    xu = [sp.Symbol(f"xu{i + 1}") for i in range(k)]
    Y = [sp.Matrix([lag_symbol(y, m - j) for y in ysym]) for j in range(m + 1)]
    U = [sp.Matrix([lag_symbol(u, m - j) for u in inputs]) if inputs else sp.zeros(0, 1)
         for j in range(m + 1)]
    ystar = [(red.R * Y[j])[0, 0] for j in range(m + 1)]
    XL = [sp.Matrix([lag_symbol(x, m) for x in xl])]
    XU = [sp.Matrix([lag_symbol(x, m) for x in xu])]
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
        nxt = step_lin(Xj, j) + nonlinear_part(red, with_first(Xj, ystar[j]), Y[j], U[j]) \
            + red.Ds * dsyms[j]
        if red.Ls.cols:
            nxt += red.Ls * sp.Matrix(rsyms[j])
        X.append(nxt.applyfunc(sp.expand))
        for C, b, store in ((XL, lo_d, XL), (XU, hi_d, XU)):
            Cj = C[j]
            e = ystar[j] - Cj[0]
            n2 = step_lin(Cj, j) + nonlinear_part(red, with_first(Cj, ystar[j]), Y[j], U[j]) \
                + b + gs * e
            store.append(n2.applyfunc(sp.expand))
    return _Unrolled(xl, xu, ystar, X, XL, XU, dsyms, rsyms, unknown, jordan)


def _solve_identity(red: ReducedModel, un: _Unrolled, m: int) -> tuple:
    """Step 2: y*(t+m) = α x̄_1(t+m) + (1 − α) x̲_1(t+m) with the model and the copies
    substituted, solved for d(t): (model side E, d(t), the identity, the formula, the
    unmeasured components present, approximate)."""
    E = un.X[m][0]
    d0 = un.dsyms[0]
    for dj in un.dsyms[1:]:
        if E.has(dj):  # pragma: no cover - excluded by D* entering row r only
            raise UsageError(f"d(t+{un.dsyms.index(dj)}) reaches y*(t+{m}): not one row")
    coeff = sp.diff(E, d0)
    if coeff.has(d0) or _zero(coeff):
        raise UsageError(
            f"{red.target}: y*(t+{m}) is not affine in {red.target}(t) with a nonzero coefficient"
            " (nonlinear terms carry the unknown input into later steps); not supported")
    approximate = bool(red.Ls.cols)
    if approximate:  # approximate (robust) design: the residual L* ρ is not known
        E = E.xreplace({s: 0 for row in un.rsyms for s in row})
    present = [s for s in un.unknown if E.has(s)]
    rhs = ALPHA * un.XU[m][0] + (1 - ALPHA) * un.XL[m][0]
    identity = sp.Eq(E, rhs)
    # unmeasured components enter through the copies, α-weighted like the measured one
    lhs = E
    if present:
        lhs = ALPHA * E.xreplace({s: un.XU[0][i + 1] for i, s in enumerate(un.unknown)}) + \
            (1 - ALPHA) * E.xreplace({s: un.XL[0][i + 1] for i, s in enumerate(un.unknown)})
    sols = _solve_affine(lhs, rhs, d0)
    if len(sols) != 1 or d0 not in sols[0]:
        raise UsageError(f"{red.target}: the α identity has no unique solution for"
                         f" {red.target}(t): {sols}")
    formula = sols[0][d0]
    formula = sp.collect(sp.expand(formula), [ALPHA, ALPHA_PREV])
    return E, d0, identity, formula, present, approximate


def _direct_check(formula, bsub, un: _Unrolled, E, d0, m: int, alpha_prev) -> tuple:
    """Step 4 (exact cases): the direct inversion — the model with the measured y*(t)
    solved for d(t) — and the derived formula minus it with α (and α(t)) and the
    unrolled bounds substituted, simplified: (direct, residual)."""
    jordan, ystar, XL, XU = un.jordan, un.ystar, un.XL, un.XU
    Em = E.xreplace({ALPHA_PREV: 0}) if not jordan else \
        E.xreplace({ALPHA_PREV: alpha_prev})
    direct = _solve_affine(Em, ystar[m], d0)[0][d0]
    if jordan:
        direct = sp.cancel(sp.together(direct))
    a_unrolled = (ystar[m] - XL[m][0]) / (XU[m][0] - XL[m][0])
    sub = formula.xreplace({ALPHA: a_unrolled})
    if jordan:
        sub = sub.xreplace({ALPHA_PREV: alpha_prev})
    residual = sp.cancel(sp.together((sub - direct).xreplace(bsub)))
    if residual != 0:
        residual = sp.simplify(residual)
    return direct, residual


def _derive_core(model, red, k, r, m, l, inputs, _lambda):
    """The derivation's steps: unroll, solve the α identity for d(t), guard α in the
    estimate, check against the direct inversion, and (Jordan) verify the λ term by
    deriving again with F* = Λ and F* = 0."""
    Fs = red.Fs if _lambda is None else sp.Matrix([[_lambda]])
    lo_d, hi_d, bsub = _bound_parameters(red)
    un = _unroll(red, Fs, lo_d, hi_d, m, l)
    E, d0, identity, formula, present, approximate = _solve_identity(red, un, m)
    # Step 3: α in the observer's own symbols at the current step t + m, guarded
    xl, xu, ystar, XL, XU, jordan = un.xl, un.xu, un.ystar, un.XL, un.XU, un.jordan
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
        direct, residual = _direct_check(formula, bsub, un, E, d0, m, alpha_prev)
    lam_term, lam_ok = None, False
    if jordan and _lambda is None:
        dl = _derive_core(model, red, k, r, m, l, inputs, LAMBDA_SYM)
        d0f = _derive_core(model, red, k, r, m, l, inputs, sp.Integer(0))
        term = dl.formula - d0f.formula
        expect = LAMBDA_SYM * (XU[0][0] - XL[0][0]) * (ALPHA - ALPHA_PREV) / red.Ds[0, 0]
        lam_ok = _zero(term - expect)
        lam_term = expect.xreplace({LAMBDA_SYM: red.Fs[0, 0]})
    tn = _time_names(m, l, inputs, k, extra={
        **{s: f"x*{i + 2}(t)" for i, s in enumerate(un.unknown)},
        d0: f"{red.target}(t)"})
    return Derivation(
        unknown=red.target.name, form=red.form, delay=m, row=r + 1, identity=identity,
        formula=formula, alpha_definition=alpha_now, alpha_prev_definition=alpha_prev,
        estimate=est, exact=exact, direct=direct, residual=residual,
        unknown_states=tuple(present), lambda_term=lam_term, lambda_term_verified=lam_ok,
        d_symbol=d0, time_names=tn, bound_terms=bsub)


def _guarded(num, den, eps):
    """num/den, or 1/2 where abs(den) ≤ eps (the denominator itself guarded: no 0/0)."""
    ok = sp.Abs(den) > eps
    # den + (0 or 1 − den): an Add, so that sympy does not move the power into the
    # Piecewise (numpy evaluates every branch of a select)
    safe = den + sp.Piecewise((0, ok), (1 - den, True))
    return sp.Piecewise((num / safe, ok), (sp.Rational(1, 2), True))

