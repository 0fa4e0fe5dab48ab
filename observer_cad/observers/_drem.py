"""Adaptive observer for time-varying polynomial parameters by dynamic regressor
extension and mixing (DREM), continuous time (METHOD §5; seed 003, Dang, Pyrkin,
Bobtsov & Vedyakov 2021).

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

Derivation (verified symbolically by :func:`parametrisation_residual` and
:func:`chain_error_residual`, and numerically in tests/test_drem.py)
-------------------------------------------------------------------------------------
Write the unknown part as Σ_r b_r(y, u) φ_r(t): for θ_k the column b = Q(y) e_k, for
V_j the column b = e_j u; φ_r has degree d_r, D_r = d_r + 1. With F = A − K Cᵀ Hurwitz
(det(sI − F) = sᴺ + k1 sᴺ⁻¹ + … + kN, so K is read off the characteristic polynomial of
the chosen poles) and the filters (all started at 0)

    ζ' = F ζ + K y + g(y, u),
    P_{r,1}' = F P_{r,1} − b_r(y, u),     P_{r,i+1}' = F P_{r,i+1} − P_{r,i}

(for V these are the paper's Ω_k e_j, for θ its P_i e_k), the error
ε = ζ − x − Σ_r Σ_{i=1}^{D_r} P_{r,i} φ_r^(i−1) obeys ε' = F ε exactly: K y − A x = −F x
and the sum telescopes because φ_r^(D_r) = 0. **The printed signs (− I u, − Q(y),
− P_i) are right** (with + the residual is 2 Σ b φ ≠ 0). Multiplying by Cᵀ:

    Cᵀζ − y = Σ_r Σ_i (Cᵀ P_{r,i}) φ_r^(i−1) + Cᵀε,    Cᵀε(t) = −Cᵀ e^{F t} x(0).

The last identity holds because the filters start at zero (ε(0) = −x(0)): the decaying
term has the *same* unknown x(0) for every K.

Extension: l = Σ_r D_r distinct K (the paper's (n + m + 2)N for full θ, V ∈ Rᴺ) give
Y = Φ ϑ + E, ϑ = (φ_r^(i−1)). ``include_epsilon=True`` adds x(0) to the unknowns with the
regressor −Cᵀ e^{F t} (w' = Fᵀ w, w(0) = e1; N more states per filter) and therefore
needs l + N filters, not the paper's l + 1 (its stacked ε̄(0) has N entries). Then Y = Φ ϑ
is exact from t = 0 — but those N columns decay like e^{λ t}, so Δ = det Φ → 0
exponentially (at the sum of the N slowest filter poles: measured −2.5/s on
drem_example), ∫Δ² < ∞ and the chain is corrected only in an early window. With γ sized
to that window (:func:`suggest_gamma`) it converges there and then coasts on the
polynomial model, uncorrected (drem_example, γ = 1e45: errors ≈ 1e-6 at t = 5, θ1
drifting to 5e-5 by t = 40 through its slope error); with a γ sized for the default
variant nothing converges. The default drops the term instead (asymptotic convergence
under persistent excitation).

Mixing (Cramer): ρ = adj(Φ) Y = Δ ϑ, Δ = det Φ, with ρ_c = det(Φ with column c replaced
by Y). Determinants are built by Laplace expansion of [Φ | Y] with every minor shared (a
DAG of 2^{l+1} minors), so code generation, which shares common subexpressions, stays
small.

Estimator chain: ξ_{r,i}' = ξ_{r,i+1} + γ Δ (ρ_{r,i} − Δ ξ_{r,i}), ξ_{r,D}' = γ Δ (ρ_{r,D} −
Δ ξ_{r,D}). **ξ_{r,i} estimates φ_r^(i−1)(t)**, the (i−1)-th time derivative at the
current time (not a coefficient): with ξ̃ = φ^(i−1) − ξ the error obeys ξ̃_i' = ξ̃_{i+1} −
γΔ²ξ̃_i, ξ̃_D' = −γΔ²ξ̃_D, since d/dt φ^(i−1) = φ^(i) and φ^(D) = 0. It converges when
∫Δ² = ∞ (the cascade converges from the last element up). The coefficients follow from
the clock: c_i = Σ_{j ≥ i} φ^(j)(τ) (−τ)^{j−i} / (i! (j−i)!).

State: x̂ = ζ_1 − Σ_r Σ_i P_{1,r,i} ξ_{r,i} (filter bank 1; + e^{F_1 t} x̂(0) with the ε
variant) — the printed signs are right.

Excitation. Δ is an output; ``Delta2_integral`` = ∫Δ² is an observer state. The error
of the last chain element contracts by exp(−γ ∫Δ² dt) over a window, so
:func:`excitation_report` calls the excitation insufficient on a window where
γ ∫Δ² < ``min_contraction`` (default 1, one e-fold), and :func:`check_excitation` raises
:class:`ExcitationError` with the message.

API
---
``drem_design(model, spec, *, poles=None, gains=None, gamma=1, include_epsilon=False,
expose_regression=False) -> DremDesign`` (poles, gains, unknowns, conditions, the
observer); ``drem_observer(...) -> Observer`` (kind ``"drem"``, continuous; outputs
``x1_hat … xN_hat``, ``theta1_hat``, ``theta1_d1_hat`` (θ1'), ``V1_hat``, …, ``<coef>_hat``
for every unknown coefficient, ``Delta``, ``Delta2_integral``; with
``expose_regression`` also ``Y<a>`` and ``Phi<a>_<c>``), so
:func:`observer_cad.simulation.simulate` runs it unchanged.

References: seed 003 (Утверждения 1–3, eqs. (4)–(8)); METHOD §5; Aranovskiy et al.,
IEEE TAC 62(7) 2017 (DREM).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping, Sequence

import numpy as np
import sympy as sp

from ..synthesis import Condition, parse_json_expression
from ..errors import ModelError, ObserverCadError, UsageError
from ..model import PlantModel, load_model_module, model_from_module, to_rational
from ..numerics import rational_approximation
from ._observer import Observer, output_symbols

__all__ = ["shift_matrix", "DremSpec", "DremTerm", "DremClass", "DremDesign", "ExcitationReport",
           "ExcitationError", "analyse", "load_drem", "gains_from_poles", "default_poles",
           "parametrisation_residual", "chain_error_residual", "drem_design",
           "drem_observer", "excitation_report", "check_excitation", "suggest_gamma", "true_unknowns",
           "determinants"]

REFERENCE = "seed 003 (Statements 1–3); METHOD §5"


class ExcitationError(ObserverCadError):
    """Δ(t) was too small over a window: the DREM estimates are not converging."""


# =============================================================== the declaration
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


def analyse(model: PlantModel, spec: DremSpec) -> DremClass:
    """Recognise ``model`` as a member of the DREM class declared by ``spec``.

    Raises :class:`ModelError` (one line, naming the equation or symbol) when it is not.
    """
    where = model.where
    if not isinstance(spec, DremSpec):
        raise ModelError(f"{where}: 'drem' is a {type(spec).__name__}, not a DremSpec")
    # Step 1: time domain, roles, the clock
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
    N = len(xs)
    if N < 1:
        raise ModelError(f"{where}: the model has no state besides the clock")
    # Step 2: unknown coefficients vs known parameters
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
    # Step 3: each polynomial, its degree and coefficient structure
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
    # Step 4: the dynamics: A x, Q(y) θ, V u, g
    ysym = output_symbols(1)[0]
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
        info[f"g{j}"] = g.xreplace({xs[0]: ysym})
    # Step 5: the terms in the paper's order (V first, then θ)
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
    return DremClass(model=model, spec=spec, clock=clock, states=xs, input=u, y=ysym,
                     Q=Q.xreplace({xs[0]: ysym}),
                     known=tuple(info[f"g{j}"] for j in range(N)), terms=tuple(terms),
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


# =============================================================== gains
def shift_matrix(N: int) -> sp.Matrix:
    return sp.Matrix(N, N, lambda i, j: 1 if j == i + 1 else 0)


def gains_from_poles(poles) -> sp.Matrix:
    """K with det(sI − (A − K e1ᵀ)) = Π (s − λ): K = the coefficients k1 … kN.

    Poles are real and negative (exact rationals); checked against the characteristic
    polynomial of A − K Cᵀ.
    """
    lam = [to_rational(v, "pole") for v in poles]
    for v in lam:
        if not (v.is_real and v < 0):
            raise UsageError(f"pole {v} is not real and negative (F = A − K Cᵀ must be Hurwitz)")
    s = sp.Symbol("s")
    N = len(lam)
    c = sp.Poly(sp.prod([s - v for v in lam]), s).all_coeffs()
    K = sp.Matrix(c[1:])
    F = shift_matrix(N) - K * sp.eye(N)[0, :]
    if sp.expand(F.charpoly(s).as_expr() - sp.prod([s - v for v in lam])) != 0:
        raise AssertionError("pole placement check failed")  # pragma: no cover
    return K


def default_poles(N: int, l: int) -> list:
    """l distinct real pole sets: filter a has −(1 + (a−1)/2) − (0, 1, …, N−1)."""
    return [tuple(-(1 + sp.Rational(a, 2)) - i for i in range(N)) for a in range(l)]


# =============================================================== symbolic checks
def parametrisation_residual(N: int, degrees: Sequence[int], *, input_sign: int = -1,
                             known_term: bool = True) -> sp.Matrix:
    """ε' − F ε for generic K, b_r(t), φ_r (degrees d_r), g(t): zero iff
    ζ = x + Σ P_{r,i} φ_r^(i−1) + ε with ε' = F ε holds for the filters
    ζ' = Fζ + K y + g, P_{r,1}' = F P_{r,1} + input_sign·b_r, P_{r,i+1}' = F P_{r,i+1} +
    input_sign·P_{r,i}. (The paper's signs are input_sign = −1.)"""
    t = sp.Symbol("t")
    A = shift_matrix(N)
    K = sp.Matrix(sp.symbols(f"k1:{N + 1}"))
    C = sp.eye(N)[:, 0]
    F = A - K * C.T
    x = sp.Matrix([sp.Function(f"x{i + 1}")(t) for i in range(N)])
    zeta = sp.Matrix([sp.Function(f"zeta{i + 1}")(t) for i in range(N)])
    g = sp.Matrix([sp.Function(f"g{i + 1}")(t) for i in range(N)]) if known_term else sp.zeros(N, 1)
    phis, bs, Ps = [], [], []
    for r, d in enumerate(degrees):
        cs = sp.symbols(f"c{r}_0:{d + 1}")
        phis.append(sum(c * t ** i for i, c in enumerate(cs)))
        bs.append(sp.Matrix([sp.Function(f"b{r}_{i + 1}")(t) for i in range(N)]))
        Ps.append([sp.Matrix([sp.Function(f"P{r}_{k}_{i + 1}")(t) for i in range(N)])
                   for k in range(1, d + 2)])
    eps = zeta - x - sum((Ps[r][k] * sp.diff(phis[r], t, k) for r in range(len(degrees))
                          for k in range(degrees[r] + 1)), sp.zeros(N, 1))
    y = x[0]
    rules = {}
    xdot = A * x + sum((bs[r] * phis[r] for r in range(len(degrees))), sp.zeros(N, 1)) + g
    for i in range(N):
        rules[sp.Derivative(x[i], t)] = xdot[i]
    zdot = F * zeta + K * y + g
    for i in range(N):
        rules[sp.Derivative(zeta[i], t)] = zdot[i]
    for r in range(len(degrees)):
        for k, P in enumerate(Ps[r]):
            prev = bs[r] if k == 0 else Ps[r][k - 1]
            pdot = F * P + input_sign * prev
            for i in range(N):
                rules[sp.Derivative(P[i], t)] = pdot[i]
    deps = sp.diff(eps, t).xreplace(rules)
    return (deps - F * eps).applyfunc(sp.expand)


def chain_error_residual(D: int) -> sp.Matrix:
    """ξ̃_i' − (ξ̃_{i+1} − γΔ²ξ̃_i) for ξ̃_i = φ^(i−1) − ξ_i, ρ_i = Δ φ^(i−1), φ of degree
    D − 1 and the chain ξ_i' = ξ_{i+1} + γΔ(ρ_i − Δξ_i) (ξ_{D+1} := 0): zero iff ξ_i
    estimates the (i−1)-th derivative of φ at the current time."""
    t, gam = sp.symbols("t gamma")
    Delta = sp.Function("Delta")(t)
    cs = sp.symbols(f"c0:{D}")
    phi = sum(c * t ** i for i, c in enumerate(cs))
    xi = [sp.Function(f"xi{i + 1}")(t) for i in range(D)]
    rules = {}
    for i in range(D):
        nxt = xi[i + 1] if i + 1 < D else 0
        rho = Delta * sp.diff(phi, t, i)
        rules[sp.Derivative(xi[i], t)] = nxt + gam * Delta * (rho - Delta * xi[i])
    err = [sp.diff(phi, t, i) - xi[i] for i in range(D)]
    res = []
    for i in range(D):
        lhs = sp.diff(err[i], t).xreplace(rules)
        rhs = (err[i + 1] if i + 1 < D else 0) - gam * Delta ** 2 * err[i]
        res.append(sp.expand(lhs - rhs))
    return sp.Matrix(res)


# =============================================================== determinants
def determinants(M: sp.Matrix):
    """For a p×(p+1) matrix [Φ | Y]: (Δ, [ρ_1 … ρ_p]) with Δ = det Φ and ρ_c = det(Φ with
    column c replaced by Y) = (adj(Φ) Y)_c. Laplace expansion along the rows with every
    minor built once (the expressions share them)."""
    p = M.rows
    if M.cols != p + 1:
        raise ValueError("determinants needs a p×(p+1) matrix")
    rows = [[M[i, j] for j in range(p + 1)] for i in range(p)]
    cache: dict = {}

    def minor(cols: tuple):
        k = len(cols)
        if k == 0:
            return sp.Integer(1)
        hit = cache.get(cols)
        if hit is not None:
            return hit
        row = rows[k - 1]
        terms = []
        for idx, j in enumerate(cols):
            e = row[j]
            if e == 0:
                continue
            sub = minor(cols[:idx] + cols[idx + 1:])
            if sub == 0:
                continue
            term = sp.Mul(e, sub)
            terms.append(term if (k - 1 + idx) % 2 == 0 else -term)
        r = sp.Add(*terms)
        cache[cols] = r
        return r

    Delta = minor(tuple(range(p)))
    rhos = []
    for c in range(p):
        cols = tuple(j for j in range(p) if j != c) + (p,)
        sign = 1 if (p - 1 - c) % 2 == 0 else -1  # move Y from position c to the end
        m = minor(cols)
        rhos.append(m if sign > 0 else -m)
    return Delta, rhos


# =============================================================== the design
@dataclasses.dataclass(frozen=True)
class DremDesign:
    """The DREM observer and the decisions behind it (poles, gains, unknowns)."""

    cls: DremClass
    poles: tuple  # per filter, the N poles of F_a
    gains: tuple  # per filter, K_a (sympy column)
    gamma: object
    include_epsilon: bool
    labels: tuple  # of the unknowns ϑ in the order of Φ's columns
    observer: Observer
    conditions: tuple

    @property
    def l(self) -> int:
        return len(self.gains)

    @property
    def slowest_pole(self) -> float:
        return float(max(max(ps) for ps in self.poles))

    def to_json(self, *, equations: bool = True) -> dict:
        """The design as JSON; ``equations=False`` leaves out the observer's equations
        (Δ and ρ print as l!-term expressions: ≈ 0.5 MB and seconds for l = 6)."""
        out = {
            "observer": "drem", "model": self.cls.model.name,
            "N": self.cls.N, "unknowns": list(self.labels),
            "coefficients": [str(s) for s in self.cls.unknowns],
            "terms": [{"name": t.name, "degree": t.degree, "polynomial": str(t.poly),
                       "column": [str(c) for c in t.column]} for t in self.cls.terms],
            "Q": [[str(e) for e in self.cls.Q.row(i)] for i in range(self.cls.Q.rows)],
            "known_term": [str(e) for e in self.cls.known],
            "filters": [{"poles": [str(v) for v in ps], "K": [str(k) for k in K]}
                        for ps, K in zip(self.poles, self.gains)],
            "gamma": str(self.gamma), "include_epsilon": self.include_epsilon,
            "conditions": [c.to_json() for c in self.conditions],
            "outputs": list(self.observer.output_names),
        }
        if equations:
            out["observer_equations"] = self.observer.to_json()
        return out

    @classmethod
    def from_json(cls, data, model: PlantModel, spec: "DremSpec") -> "DremDesign":
        """Rebuild a DREM design from its JSON (:meth:`to_json`): the recorded choice (pole
        sets, γ, ε variant) is parsed by the whitelist reader and passed back to
        :func:`drem_design`; the rebuilt filters and unknowns must match the recorded ones."""
        if not isinstance(data, dict) or data.get("observer") != "drem":
            raise UsageError("not a DREM design: a JSON object with observer = 'drem' is expected")
        filters = data.get("filters")
        if not isinstance(filters, list) or not filters:
            raise UsageError("a DREM design's 'filters' must be a non-empty list")
        for i, f in enumerate(filters, 1):
            if not isinstance(f, dict) or not isinstance(f.get("poles"), list) or not f["poles"]:
                raise UsageError(f"a DREM design's filter {i} needs 'poles' as a non-empty list"
                                 " of numbers (e.g. [\"-1\", \"-2\"])")
        try:
            poles = [[float(parse_json_expression(v, {}, "filters.poles")) for v in f["poles"]]
                     for f in filters]
            gamma = float(parse_json_expression(data["gamma"], {}, "gamma"))
        except (KeyError, TypeError):
            raise UsageError("a DREM design's filters need 'poles' and the design 'gamma'") from None
        include = data.get("include_epsilon", False)
        if not isinstance(include, bool):
            raise UsageError("a DREM design's include_epsilon must be true or false")
        rebuilt = drem_design(model, spec, poles=poles, gamma=gamma, include_epsilon=include)
        again = rebuilt.to_json(equations=False)
        for key in ("unknowns", "filters", "gamma", "N"):
            if again[key] != data.get(key):
                raise UsageError(f"{model.where}: the recorded DREM design does not match the"
                                 f" model: its '{key}' differs when rebuilt")
        return rebuilt

    def format(self) -> str:
        c = self.cls
        out = [f"DREM adaptive observer for {c.model.name} (N = {c.N}, {self.l} filters,"
               f" {len(self.labels)} unknowns)"]
        out.append("  Q(y) = " + str(c.Q.tolist()))
        for t in c.terms:
            out.append(f"  {t.name}(t) = {t.poly}  (degree {t.degree}, column {list(t.column)})")
        out.append("  unknowns ϑ: " + ", ".join(self.labels))
        for a, (ps, K) in enumerate(zip(self.poles, self.gains), 1):
            out.append(f"  filter {a}: poles {', '.join(map(str, ps))};  K = {list(K)}")
        out.append(f"  gamma = {self.gamma}")
        for cond in self.conditions:
            out.append(f"  [{'ok' if cond.holds else 'FAIL'}] {cond.name}: {cond.detail}")
        return "\n".join(out)


def drem_design(model: PlantModel, spec: DremSpec, *, poles=None, gains=None, gamma=None,
                include_epsilon: bool = False, expose_regression: bool = False,
                name: str | None = None) -> DremDesign:
    """Build the DREM adaptive observer (see the module docstring).

    Parameters
    ----------
    model, spec : the plant and its declaration (:func:`load_drem`).
    poles : list of l pole sets (each N real negative numbers), optional
        Default :func:`default_poles`. l = number of unknowns (+ N with ε).
    gains : list of l vectors K, optional (instead of poles; must give Hurwitz F).
    gamma : positive number, optional
        Gain of the gradient chain (an observer parameter ``gamma``); default
        ``spec.gamma``, else 1.
    include_epsilon : bool
        Include x(0) as unknowns (exact regression, l + N filters); default drop ε.
    expose_regression : bool
        Also output Y<a> = Cᵀζ_a − y and Phi<a>_<c> (for checks of the identity).
    """
    cls = analyse(model, spec)
    N = cls.N
    terms = list(cls.terms)
    if include_epsilon:
        for i, x in enumerate(cls.states):
            terms.append(DremTerm(f"{x}_0", "x0", tuple(sp.Integer(0) for _ in range(N)), 0, x, ()))
    labels = [t.name if i == 0 else f"{t.name}_d{i}" for t in terms for i in range(t.length)]
    l = len(labels)
    if gamma is None:
        gamma = spec.gamma if spec.gamma is not None else 1
    gam = to_rational(gamma, "gamma")
    if not gam > 0:
        raise UsageError(f"gamma must be positive, got {gamma}")
    # Step 1: l distinct gain vectors, F_a Hurwitz, poles reported
    if gains is not None and poles is not None:
        raise UsageError("give poles or gains, not both")
    if gains is not None:
        Ks = [sp.Matrix([to_rational(v, "gain") for v in K]) for K in gains]
        for K in Ks:
            if K.shape != (N, 1):
                raise UsageError(f"each gain vector needs {N} entries")
        pole_sets = []
        for K in Ks:
            F = shift_matrix(N) - K * sp.eye(N)[0, :]
            ev = [complex(v) for v in sp.Poly(F.charpoly(sp.Symbol("s")).as_expr(),
                                              sp.Symbol("s")).nroots()]
            if max(v.real for v in ev) >= 0:
                raise UsageError(f"gain K = {list(K)}: A − K Cᵀ is not Hurwitz (poles {ev})")
            pole_sets.append(tuple(rational_approximation(v.real, 1e-12) if abs(v.imag) < 1e-12
                                   else v for v in ev))  # nroots' floats, within 1e-12
    else:
        pole_sets = [tuple(ps) for ps in (poles if poles is not None else default_poles(N, l))]
        for ps in pole_sets:
            if len(ps) != N:
                raise UsageError(f"each pole set needs N = {N} poles, got {len(ps)}")
        Ks = [gains_from_poles(ps) for ps in pole_sets]
        pole_sets = [tuple(to_rational(v, "pole") for v in ps) for ps in pole_sets]
    if len(Ks) != l:
        raise UsageError(f"{l} filters are needed (one per unknown: {', '.join(labels)}),"
                         f" {len(Ks)} given")
    if len({tuple(K) for K in Ks}) != l:
        raise UsageError("the gain vectors K must be distinct")
    A = shift_matrix(N)
    e1 = sp.eye(N)[0, :]
    Fs = [A - K * e1 for K in Ks]
    conds = []
    conds.append(Condition("model in the DREM class (A shift, C = e1, Q = Q(y))", True,
                           f"N = {N}, Q(y) = {cls.Q.tolist()}, unknowns "
                           f"{', '.join(map(str, cls.unknowns))}", REFERENCE))
    for a, (ps, K) in enumerate(zip(pole_sets, Ks), 1):
        conds.append(Condition(f"filter {a}: F = A − K Cᵀ Hurwitz", True,
                               f"poles {', '.join(map(str, ps))}; K = {list(K)}", "METHOD §5"))
    # Step 2: symbolic verification of the parametrisation and of the chain
    res = parametrisation_residual(N, [t.degree for t in cls.terms])
    ok_par = all(e == 0 for e in res)
    conds.append(Condition("ζ = x + Σ Ω_k V^(k−1) + Σ P_i θ^(i−1) + ε with ε' = F ε", ok_par,
                           "verified symbolically for generic K (filters with − b, − P_i)",
                           "seed 003 Statement 2"))
    ok_chain = all(all(e == 0 for e in chain_error_residual(D))
                   for D in sorted({t.length for t in terms}))
    conds.append(Condition("gradient chain: ξ_i estimates φ^(i−1)(t)", ok_chain,
                           "ξ̃_i' = ξ̃_{i+1} − γΔ²ξ̃_i verified symbolically",
                           "seed 003 Statement 3, eq. (8)"))
    if not (ok_par and ok_chain):  # pragma: no cover - the derivation is fixed
        raise AssertionError("DREM derivation check failed")
    # Step 3: observer states
    taken = {str(s) for s in model.states + model.inputs} | {str(p) for p in model.parameters}
    taken |= {"y1"}
    u, y = cls.input, cls.y

    def sym(nm):
        if nm in taken:
            raise UsageError(f"observer state name '{nm}' clashes with a model symbol; rename it")
        return sp.Symbol(nm)

    states, update, initial = [], [], {}
    zeta, P, chi, E1 = [], [], [], None
    g = sp.Matrix(cls.known)
    for a in range(l):
        F, K = Fs[a], Ks[a]
        z = sp.Matrix([sym(f"zeta{a + 1}_{i + 1}") for i in range(N)])
        zeta.append(z)
        states += list(z)
        update += list(F * z + K * y + g)
        Pa = {}
        for t in cls.terms:
            prev = sp.Matrix(t.column)
            for k in range(1, t.length + 1):
                Pk = sp.Matrix([sym(f"P{a + 1}_{t.name}_{k}_{i + 1}") for i in range(N)])
                states += list(Pk)
                update += list(F * Pk - prev)
                Pa[(t.name, k)] = Pk
                prev = Pk
        P.append(Pa)
        if include_epsilon:
            if a == 0:
                E = sp.Matrix(N, N, lambda i, j: sym(f"E1_{i + 1}_{j + 1}"))
                E1 = E
                states += list(E)
                update += list(F * E)
                for i in range(N):
                    for j in range(N):
                        initial[E[i, j]] = 1 if i == j else 0
                chi.append(E.row(0))
            else:
                w = sp.Matrix([sym(f"chi{a + 1}_{i + 1}") for i in range(N)])
                states += list(w)
                update += list(F.T * w)
                initial[w[0]] = 1
                chi.append(w.T)
    # Step 4: the regression rows, the mixing
    Yv = sp.Matrix([zeta[a][0] - y for a in range(l)])
    Phi = sp.zeros(l, l)
    col = 0
    for t in terms:
        for k in range(1, t.length + 1):
            for a in range(l):
                if t.kind == "x0":
                    Phi[a, col] = -chi[a][terms.index(t) - len(cls.terms)]
                else:
                    Phi[a, col] = P[a][(t.name, k)][0]
            col += 1
    Delta, rhos = determinants(Phi.row_join(Yv))
    gsym = sp.Symbol("gamma")
    xi = {}
    col = 0
    for t in terms:
        for k in range(1, t.length + 1):
            xi[(t.name, k)] = sym(f"xi_{t.name}_{k}")
    for t in terms:
        for k in range(1, t.length + 1):
            s = xi[(t.name, k)]
            nxt = xi[(t.name, k + 1)] if k < t.length else 0
            states.append(s)
            update.append(nxt + gsym * Delta * (rhos[col] - Delta * s))
            col += 1
    clk = sym(f"{cls.clock}_obs")
    states.append(clk)
    update.append(sp.Integer(1))
    initial[clk] = cls.clock  # the plant clock's initial value
    J = sym("J_Delta2")
    states.append(J)
    update.append(Delta ** 2)
    # Step 5: outputs: x̂, the polynomials and their derivatives, the coefficients
    xhat = zeta[0]
    for t in cls.terms:
        for k in range(1, t.length + 1):
            xhat = xhat - P[0][(t.name, k)] * xi[(t.name, k)]
    if include_epsilon:
        x0hat = sp.Matrix([xi[(f"{x}_0", 1)] for x in cls.states])
        xhat = xhat + E1 * x0hat
    outputs = [(f"{x}_hat", xhat[i]) for i, x in enumerate(cls.states)]
    for t in cls.terms:
        outputs.append((f"{t.name}_hat", xi[(t.name, 1)]))
        for k in range(2, t.length + 1):
            outputs.append((f"{t.name}_d{k - 1}_hat", xi[(t.name, k)]))
    for t in cls.terms:
        d = t.degree
        for i, s, f in t.coefficients:
            ci = sum(xi[(t.name, j + 1)] * (-clk) ** (j - i) / (math.factorial(i) * math.factorial(j - i))
                     for j in range(i, d + 1))
            outputs.append((f"{s}_hat", sp.expand(ci / f)))
    if include_epsilon:
        outputs += [(f"{x}_0_hat", xi[(f"{x}_0", 1)]) for x in cls.states]
    outputs.append(("Delta", Delta))
    outputs.append(("Delta2_integral", J))
    if expose_regression:
        outputs += [(f"Y{a + 1}", Yv[a]) for a in range(l)]
        outputs += [(f"Phi{a + 1}_{c + 1}", Phi[a, c]) for a in range(l) for c in range(l)]
    for s in states:
        initial.setdefault(s, 0)
    ob = Observer(
        name=name or f"{model.name}_drem", kind="drem", time="continuous",
        states=tuple(states), signals=(y, u), parameters={gsym: gam},
        update=tuple(update), outputs=tuple(outputs), initial=initial,
        conditions=tuple(conds),
        assumptions=("Δ(t) not square-integrable (excitation; checked after simulation by"
                     " excitation_report)",),
        description=(f"DREM adaptive observer: {l} filter banks, unknowns "
                     f"{', '.join(labels)}; gamma = {gam}"))
    return DremDesign(cls=cls, poles=tuple(pole_sets), gains=tuple(Ks), gamma=gam,
                      include_epsilon=include_epsilon, labels=tuple(labels), observer=ob,
                      conditions=tuple(conds))


def drem_observer(model: PlantModel, spec: DremSpec, **options) -> Observer:
    """The DREM observer (kind ``"drem"``); options as :func:`drem_design`."""
    return drem_design(model, spec, **options).observer


# =============================================================== truth, excitation
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
