"""The DREM plant class and its declaration (METHOD §5; seed 003, Dang, Pyrkin, Bobtsov &
Vedyakov 2021): what a model file declares next to its PlantModel, and the recognition of a
model as a member of the class.

Plant class
-----------
::

    x' = A x + Q(y) θ(t) + V(t) u (+ g(y, u)),     y = Cᵀ x = x1,

A the N×N shift matrix (xi' = x(i+1) + …, xN' = …), C = e1, θ(t) ∈ Rᑫ and V(t) ∈ Rᴺ
polynomials in t of declared degrees with unknown coefficients, Q(y) (N×q) known and a
function of y only, u a single known input. g(y, u) is a known term (absent in the
paper; it enters the ζ filter unchanged). Entries of V that are identically zero are
known and dropped from the unknowns.

Model-file form
---------------
An ordinary :class:`~observer_cad.model.PlantModel` plus a declaration ``drem``::

    x1, x2, tau, u = sp.symbols("x1 x2 tau u")
    a0, a1, c0, c1, v1, v2 = sp.symbols("a0 a1 c0 c1 v1 v2")   # unknown coefficients
    theta = [a0 + a1*tau, c0 + c1*tau]                        # θ(τ)
    V = [v1, v2]                                              # V(τ)
    model = PlantModel(
        name="...", time="continuous", states=[x1, x2, tau], inputs=[u], outputs=[x1],
        dynamics=[x2 - theta[0]*x1 + V[0]*u,
                  -theta[1]*(x1 + x1**3) + V[1]*u,
                  1],                                          # the clock: tau' = 1
        parameters={a0: 2, a1: 0.05, ...})                     # TRUE values (simulation only)
    drem = DremSpec(clock=tau, theta=theta, V=V, theta_degree=1, v_degree=0)

* Time enters the plant through a **clock state** (``clock``, dynamics exactly 1,
  initial value 0 by default), so the reference simulator integrates θ(t), V(t) exactly;
  it is not part of x. The observer carries its own copy of the clock, started at the
  plant clock's initial value (it reads time, never the unknown coefficients).
* ``theta`` and ``V`` are the polynomials θ_k(τ), V_j(τ). Each coefficient of a power
  of τ is 0 or a nonzero number times one **unknown** coefficient symbol; every unknown
  appears in exactly one θ_k or V_j. Unknowns are declared as model parameters (their
  values are the truth the simulator uses; the observer never reads them). Parameters
  that are not unknowns are known constants and are substituted by their values.
* ``theta_degree`` / ``v_degree`` (an int, or one per entry) are the declared degrees m,
  n (each polynomial's degree in τ must not exceed its declared degree; a larger
  declared degree adds unknown derivatives that are zero).
* Q(y) and g are **derived** from the dynamics (Q_jk = ∂f_j/∂θ_k) and validated:
  :func:`analyse` raises a one-line :class:`~observer_cad.errors.ModelError` naming the
  equation or symbol when the model is not in the class (A not the shift, y ≠ x1, Q
  depending on anything but y, θ or V not a polynomial of its declared degree, an
  unknown entering non-linearly or outside θ and V, several inputs, noise, …).

:func:`load_drem` reads ``model`` and ``drem`` from a model file.
"""
from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..model import PlantModel, load_model_module, model_from_module
from ._observer import output_symbols

__all__ = ["DremSpec", "DremTerm", "DremClass", "analyse", "load_drem"]


@dataclasses.dataclass(frozen=True)
class DremSpec:
    """What a model file declares next to its PlantModel (see the module docstring).

    clock : Symbol
        The state that is time (dynamics 1).
    theta : list of Expr
        θ_1(τ) … θ_q(τ), polynomials in the clock with unknown coefficients.
    V : list of Expr
        V_1(τ) … V_N(τ) (0 for an entry the input does not enter).
    theta_degree, v_degree : int or list of int
        Declared degrees m, n (one for all entries, or one per entry).
    gamma : number, optional
        The chain gain the model's author found suitable (Δ's scale depends on the
        model and the input; see :func:`suggest_gamma`); :func:`drem_design` uses it
        when no ``gamma`` is passed (else 1).
    """

    clock: sp.Symbol
    theta: tuple
    V: tuple
    theta_degree: object = 0
    v_degree: object = 0
    gamma: object = None

    def __post_init__(self):
        if not isinstance(self.clock, sp.Symbol):
            raise ModelError(f"DremSpec: clock must be a sympy Symbol, got {self.clock!r}")
        for what in ("theta", "V"):
            seq = getattr(self, what)
            if isinstance(seq, (sp.Expr, int, float)):
                seq = (seq,)
            try:
                seq = tuple(sp.sympify(e) for e in seq)
            except (TypeError, sp.SympifyError):
                raise ModelError(f"DremSpec: {what} must be a list of sympy expressions") from None
            object.__setattr__(self, what, seq)
        if not self.theta and not self.V:
            raise ModelError("DremSpec: declare at least one theta or V entry")


@dataclasses.dataclass(frozen=True)
class DremTerm:
    """One unknown polynomial φ_r(t) and its regressor column b_r(y, u) (in y1, u)."""

    name: str  # theta1 … / V1 …
    kind: str  # "theta" | "V" | "x0"
    column: tuple  # N expressions in y1 and the input
    degree: int  # declared degree d_r (D_r = d_r + 1 chain elements)
    poly: sp.Expr  # φ_r(τ) with the unknown coefficient symbols (x0: the state symbol)
    coefficients: tuple  # ((power i, unknown symbol, factor), …): coeff of τ^i = factor·symbol

    @property
    def length(self) -> int:
        return self.degree + 1


@dataclasses.dataclass(frozen=True)
class DremClass:
    """A model recognised as x' = A x + Q(y) θ(t) + V(t) u + g(y, u), y = x1."""

    model: PlantModel
    spec: DremSpec
    clock: sp.Symbol
    states: tuple  # x1 … xN (without the clock)
    input: sp.Symbol
    y: sp.Symbol  # the signal symbol y1
    Q: sp.Matrix  # N×q in y1
    known: tuple  # g(y1, u), N entries
    terms: tuple  # of DremTerm: V terms first, then theta (the paper's order)
    unknowns: tuple  # unknown coefficient symbols
    truth: Mapping  # unknown symbol -> value (from the model's parameters), may be empty

    @property
    def N(self) -> int:
        return len(self.states)

    @property
    def p(self) -> int:
        """Number of unknowns ϑ of the regression (without the ε variant)."""
        return sum(t.length for t in self.terms)

    def unknown_labels(self) -> list:
        """Labels of ϑ in order: ``theta1``, ``theta1_d1``, …"""
        return [t.name if i == 0 else f"{t.name}_d{i}" for t in self.terms for i in range(t.length)]


def _as_degrees(value, n: int, what: str, where: str) -> tuple:
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        vals = (int(value),) * n
    else:
        try:
            vals = tuple(int(v) for v in value)
        except (TypeError, ValueError):
            raise ModelError(f"{where}: drem.{what} must be an int or a list of ints") from None
        if len(vals) != n:
            raise ModelError(f"{where}: drem.{what} has {len(vals)} entries for {n} polynomials")
    for v in vals:
        if v < 0:
            raise ModelError(f"{where}: drem.{what} = {v} is negative")
    return vals


def _roles(model: PlantModel, spec: DremSpec, where: str) -> tuple:
    """Step 1: the time domain, the roles, the clock: (u, the states without the clock)."""
    if model.time != "continuous":
        raise ModelError(f"{where}: the DREM observer is continuous-time; the model is {model.time}")
    for role in ("faults", "disturbances", "noise"):
        if getattr(model, role):
            raise ModelError(f"{where}: the DREM class has no {role}; declared:"
                             f" {', '.join(map(str, getattr(model, role)))}")
    if len(model.inputs) != 1:
        raise ModelError(f"{where}: the DREM class has one known input u; the model has"
                         f" {len(model.inputs)}")
    u = model.inputs[0]
    clock = spec.clock
    if clock not in model.states:
        raise ModelError(f"{where}: drem.clock '{clock}' is not a state of the model")
    ci = model.states.index(clock)
    if sp.simplify(model.dynamics[ci] - 1) != 0:
        raise ModelError(f"{where}: dynamics equation {ci + 1} (for the clock {clock}) must be 1,"
                         f" got {model.dynamics[ci]}")
    xs = tuple(s for s in model.states if s != clock)
    if len(xs) < 1:
        raise ModelError(f"{where}: the model has no state besides the clock")
    return u, xs


def _unknowns(model: PlantModel, spec: DremSpec, N: int, where: str) -> tuple:
    """Step 2: the unknown coefficients (each in one polynomial) against the known
    parameters: (polynomials (name, kind, expr), unknowns, owner of each unknown,
    known parameter values, the unknowns' true values)."""
    clock = spec.clock
    if len(spec.V) != N:
        raise ModelError(f"{where}: drem.V has {len(spec.V)} entries for N = {N} states")
    polys = [(f"theta{k + 1}", "theta", e) for k, e in enumerate(spec.theta)] + \
            [(f"V{j + 1}", "V", e) for j, e in enumerate(spec.V)]
    unknowns, owner = [], {}
    for name, _, e in polys:
        for s in sorted(e.free_symbols - {clock}, key=str):
            if s not in model.parameters:
                role = model.role_of(s)
                raise ModelError(f"{where}: drem {name} = {e} uses '{s}', which is "
                                 + (f"a {role[:-1]}; coefficients must be unknown parameters"
                                    if role else "not declared in the model"))
            if s in owner:
                raise ModelError(f"{where}: unknown '{s}' appears in both {owner[s]} and {name};"
                                 " each unknown coefficient belongs to one polynomial")
            owner[s] = name
            unknowns.append(s)
    known_vals = {}
    for p, v in model.parameters.items():
        if p in owner:
            continue
        if v is None:
            raise ModelError(f"{where}: known parameter '{p}' has no value")
        known_vals[p] = v
    truth = {p: model.parameters[p] for p in unknowns if model.parameters[p] is not None}
    return polys, unknowns, owner, known_vals, truth


def _polynomials(spec: DremSpec, polys, unknowns, owner, known_vals, N: int, where: str) -> dict:
    """Step 3: each polynomial, its degree and coefficient structure: name → (declared
    degree, polynomial, ((power, unknown, factor), …)), or None for a known V_j."""
    clock = spec.clock
    th_deg = _as_degrees(spec.theta_degree, len(spec.theta), "theta_degree", where)
    v_deg = _as_degrees(spec.v_degree, N, "v_degree", where)
    degrees = list(th_deg) + list(v_deg)
    info = {}
    for (name, kind, e), dd in zip(polys, degrees):
        e = sp.expand(e.xreplace(known_vals))
        own = [s for s in unknowns if owner[s] == name]
        if not own:
            if kind == "theta":
                raise ModelError(f"{where}: drem {name} = {e} has no unknown coefficient")
            info[name] = None  # known V_j (e.g. 0): part of g
            continue
        poly = sp.Poly(e, clock)
        if poly.degree() > dd:
            raise ModelError(f"{where}: drem {name} = {e} has degree {poly.degree()} in {clock}"
                             f" but the declared degree is {dd}")
        coeffs = []
        for (i,), c in poly.terms():
            ok = False
            if c.free_symbols and len(c.free_symbols) == 1:
                s = next(iter(c.free_symbols))
                f = sp.simplify(c / s)
                ok = s in own and f.is_number and f != 0
            if not ok:
                raise ModelError(f"{where}: drem {name}: the coefficient of {clock}**{i} is {c};"
                                 " it must be a number times one unknown coefficient")
            coeffs.append((i, s, f))
        info[name] = (dd, e, tuple(sorted(coeffs, key=lambda t: t[0])))
    return info


def _known_term(f, j, eq, xs, u, clock, unknowns, Q, theta_exprs, V_exprs, where):
    """g_j = f_j − x_{j+1} − Σ_k Q_jk θ_k − V_j u, checked to hold no unknown, no clock
    and no state but y (A the shift matrix)."""
    N, q = len(xs), len(theta_exprs)
    shift = xs[j + 1] if j + 1 < N else sp.Integer(0)
    g = sp.expand(f - shift - sum(Q[j, k] * theta_exprs[k] for k in range(q)) - V_exprs[j] * u)
    bad = g.free_symbols & set(unknowns)
    if bad:
        raise ModelError(f"{where}: {eq}: the unknown '{sorted(bad, key=str)[0]}' enters"
                         " outside Q(y) θ(t) + V(t) u (check the declared polynomials)")
    if clock in g.free_symbols:
        raise ModelError(f"{where}: {eq}: the known term {g} depends on the clock {clock};"
                         " time may enter through θ(t) and V(t) only")
    others = g.free_symbols & set(xs[1:])
    if others:
        s = sorted(others, key=str)[0]
        want = 1 if s == shift else 0
        raise ModelError(f"{where}: {eq}: A must be the shift matrix ({xs[j]}' = {shift}"
                         f" + Q(y) θ + V u): the coefficient of '{s}' is {sp.diff(f, s)},"
                         f" not {want}")
    return g


def _dynamics(model: PlantModel, spec: DremSpec, xs, u, unknowns, info, known_vals,
              ysym, where) -> tuple:
    """Step 4: the dynamics as A x + Q(y) θ + V u + g: (Q in x1, [g_j in y1])."""
    clock = spec.clock
    N = len(xs)
    outs = [sp.expand(h.xreplace(known_vals)) for h in model.outputs]
    if len(outs) != 1 or sp.expand(outs[0] - xs[0]) != 0:
        raise ModelError(f"{where}: the DREM class measures y = {xs[0]} only (C = e1);"
                         f" outputs are {', '.join(map(str, model.outputs))}")
    dyn = [sp.expand(model.dynamics[model.states.index(x)].xreplace(known_vals)) for x in xs]
    q = len(spec.theta)
    Q = sp.zeros(N, q)
    theta_exprs = [info[f"theta{k + 1}"][1] for k in range(q)]
    V_exprs = [info[f"V{j + 1}"][1] if info[f"V{j + 1}"] else
               sp.expand(spec.V[j].xreplace(known_vals)) for j in range(N)]
    known = []
    for j, f in enumerate(dyn):
        eq = f"dynamics equation {model.states.index(xs[j]) + 1} (for {xs[j]})"
        for s in unknowns:
            if sp.diff(f, s).free_symbols & set(unknowns):
                raise ModelError(f"{where}: {eq} is not linear in the unknown '{s}'")
        for k in range(q):
            i0, s0, f0 = info[f"theta{k + 1}"][2][0]
            qjk = sp.cancel(sp.diff(f, s0) / (f0 * clock ** i0))
            bad = qjk.free_symbols - {xs[0]}
            if bad:
                s = sorted(bad, key=str)[0]
                raise ModelError(f"{where}: {eq}: Q[{j + 1},{k + 1}] (multiplying theta{k + 1})"
                                 f" = {qjk} depends on '{s}'; Q may depend on y = {xs[0]} only")
            Q[j, k] = qjk
        for jj in range(N):
            if info[f"V{jj + 1}"] is None:
                continue
            i0, s0, f0 = info[f"V{jj + 1}"][2][0]
            col = sp.cancel(sp.diff(f, s0) / (f0 * clock ** i0))
            want = u if jj == j else 0
            if sp.expand(col - want) != 0:
                raise ModelError(f"{where}: {eq}: the unknown '{s0}' of V{jj + 1} multiplies {col};"
                                 f" V(t) u must enter equation {jj + 1} as V{jj + 1}(t)*{u} only")
        g = _known_term(f, j, eq, xs, u, clock, unknowns, Q, theta_exprs, V_exprs, where)
        known.append(g.xreplace({xs[0]: ysym}))
    return Q, known


def _terms(info, Q, xs, u, ysym, q: int, where: str) -> tuple:
    """Step 5: the terms in the paper's order (V first, then θ)."""
    N = len(xs)
    terms = []
    for j in range(N):
        it = info[f"V{j + 1}"]
        if it is None:
            continue
        col = tuple(u if i == j else sp.Integer(0) for i in range(N))
        terms.append(DremTerm(f"V{j + 1}", "V", col, it[0], it[1], it[2]))
    for k in range(q):
        it = info[f"theta{k + 1}"]
        col = tuple(sp.expand(Q[i, k].xreplace({xs[0]: ysym})) for i in range(N))
        if all(c == 0 for c in col):
            raise ModelError(f"{where}: theta{k + 1} enters no dynamics equation (Q column {k + 1} is 0)")
        terms.append(DremTerm(f"theta{k + 1}", "theta", col, it[0], it[1], it[2]))
    return tuple(terms)


def analyse(model: PlantModel, spec: DremSpec) -> DremClass:
    """Recognise ``model`` as a member of the DREM class declared by ``spec``.

    Raises :class:`ModelError` (one line, naming the equation or symbol) when it is not.
    """
    where = model.where
    if not isinstance(spec, DremSpec):
        raise ModelError(f"{where}: 'drem' is a {type(spec).__name__}, not a DremSpec")
    u, xs = _roles(model, spec, where)
    polys, unknowns, owner, known_vals, truth = _unknowns(model, spec, len(xs), where)
    info = _polynomials(spec, polys, unknowns, owner, known_vals, len(xs), where)
    ysym = output_symbols(1)[0]
    Q, known = _dynamics(model, spec, xs, u, unknowns, info, known_vals, ysym, where)
    terms = _terms(info, Q, xs, u, ysym, len(spec.theta), where)
    return DremClass(model=model, spec=spec, clock=spec.clock, states=xs, input=u, y=ysym,
                     Q=Q.xreplace({xs[0]: ysym}), known=tuple(known), terms=terms,
                     unknowns=tuple(unknowns), truth=truth)


def load_drem(path) -> tuple:
    """``(model, spec)`` from a model file defining ``model`` and ``drem``."""
    module = load_model_module(path)  # the file runs once, for both
    model = model_from_module(module, path)
    spec = getattr(module, "drem", None)
    if spec is None:
        raise ModelError(f"{path}: the model file declares no 'drem' (a DremSpec) for the DREM observer")
    if not isinstance(spec, DremSpec):
        raise ModelError(f"{path}: 'drem' is a {type(spec).__name__}, not a DremSpec")
    return model, spec
