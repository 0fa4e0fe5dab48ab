"""Nonlinear checks (METHOD §4): Lipschitz constant, monotonicity, the sufficient
stability condition 2 N* λ_max(P*) < λ_min(W*).

Every check works on a vector of sympy expressions, the variables it is taken with
respect to, and a *domain*: sympy relations (``x1 >= x2``, ``x3 >= 0``) in some base
variables, with ``definitions`` and ``ranges`` as in the range analysis
(:class:`~observer_cad.analysis.Domain`, :class:`~observer_cad.analysis.RangeAnalyzer`).

How a bound is obtained
-----------------------
The Jacobian is taken symbolically and the range of each entry over the domain found by
the range analysis — ``exact``, a rigorous ``enclosure``, or ``sampled``.

Lipschitz constant (2-norm): J = B0 + Σ_p p(t) E_p with the groups' functions p over
their ranges; the spectral norm is convex in p, so the maximum over the box of p is at
a vertex — a rigorous upper bound, which is the exact supremum when the atoms vary
independently. A lower bound comes from evaluating the true Jacobian at domain points
chosen to approach the maximising vertex and at samples (``tight`` when they agree).
An entry whose exact range is unbounded proves "not Lipschitz" (a Lipschitz function
has every partial derivative bounded by its constant at interior points); the
evidence carries a sequence of domain points where the norm grows.

Monotonicity: the sign of every Jacobian entry on the domain (``+``, ``-``, ``0``,
``±``); a negative exact or sampled value is turned into a concrete witness pair
x ≤ x' with f(x) > f(x').
"""
from __future__ import annotations

import dataclasses
import itertools
from typing import Mapping

import numpy as np
import sympy as sp

from ..synthesis import Condition
from ..errors import UsageError
from ..numerics import rationalize_floats
from ._ranges import (OO, Domain, RangeAnalyzer, affine_parts, as_float, format_number,
                      range_sign)

__all__ = ["LipschitzResult", "MonotoneResult", "StabilityResult", "lipschitz", "is_monotone",
           "is_cooperative", "stability_condition", "model_nonlinearity", "reduced_nonlinearity",
           "nonlinear_conditions"]


# ================================================================== results
@dataclasses.dataclass(frozen=True)
class LipschitzResult:
    """Lipschitz constant (Euclidean norm) of a vector function on a domain.

    ``lipschitz``: True / False, or None when neither could be established.
    ``constant``: a rigorous upper bound N (``kind == "symbolic"``), ``oo`` when not
    Lipschitz, the caller's stated bound (``kind == "sampled"``), or None.
    ``lower``: the largest Jacobian norm seen at domain points (a lower bound on the
    constant). ``tight``: lower and upper agree to 1e-4 relative.
    """

    lipschitz: bool | None
    constant: object
    kind: str
    evidence: str
    lower: float | None = None
    tight: bool = False
    witness: tuple = ()  # ((point, norm), ...) — points where the norm is large

    def condition(self, what: str = "C Ψ") -> Condition:
        name = f"Lipschitz constant of {what} on the domain"
        return Condition(name, bool(self.lipschitz), self.evidence, "METHOD §4; seed 002 §6",
                         required=False)


@dataclasses.dataclass(frozen=True)
class MonotoneResult:
    """Monotonicity of f in the variables on the domain.

    ``monotone``: nondecreasing in every variable (True), not (False, with a witness),
    or undetermined (None). ``direction``: ``"nondecreasing"``, ``"nonincreasing"``,
    ``"constant"`` or None. ``signs[i][k]``: sign of ∂f_i/∂v_k on the domain — ``+``
    (≥ 0), ``-`` (≤ 0), ``0``, ``±`` (both signs occur) or ``?`` (not determined).
    """

    monotone: bool | None
    direction: str | None
    signs: tuple
    kind: str
    evidence: str
    witness: Mapping | None = None

    def condition(self, what: str = "C*Ψ*", required: bool = False) -> Condition:
        return Condition(f"{what} monotone (nondecreasing) in x* on the domain",
                         bool(self.monotone), self.evidence, "METHOD §3; seed 002 §6",
                         required=required)


@dataclasses.dataclass(frozen=True)
class StabilityResult:
    """2 N λ_max(P) < λ_min(W) with Fᵀ P + P F = −W (continuous time)."""

    holds: bool
    lhs: float  # 2 N λ_max(P)
    rhs: float  # λ_min(W)
    N: object
    P: np.ndarray | None
    W: np.ndarray
    evidence: str

    def condition(self) -> Condition:
        return Condition("sufficient stability condition 2 N* λ_max(P*) < λ_min(W*)",
                         self.holds, self.evidence, "METHOD §4; seed 002 §6", required=False)


def _prepare(expr_vector, variables, domain_relations, definitions, ranges, seed):
    if isinstance(expr_vector, sp.MatrixBase):
        exprs = list(expr_vector)
    elif isinstance(expr_vector, (list, tuple)):
        exprs = [sp.sympify(e) for e in expr_vector]
    else:
        exprs = [sp.sympify(expr_vector)]
    variables = list(variables) if isinstance(variables, (list, tuple, sp.MatrixBase)) else [variables]
    if not exprs or not variables:
        raise UsageError("need at least one expression and one variable")
    free = set()
    for e in exprs:
        free |= sp.sympify(e).free_symbols
    dom = Domain(domain_relations, definitions, ranges, free | set(variables))
    an = RangeAnalyzer(dom, np.random.default_rng(seed))
    # differentiate with real symbols (d|x|/dx = sign(x), not a complex Derivative)
    real = {s: sp.Dummy(s.name, real=True) for s in free | set(variables)}
    back = {v: k for k, v in real.items()}
    J = sp.Matrix(exprs).xreplace(real).jacobian([real[v] for v in variables]).xreplace(back)
    if J.has(sp.Derivative):
        raise UsageError("the Jacobian has unevaluated derivatives; the checks need"
                         " differentiable sympy expressions")
    return exprs, variables, dom, an, J


def _point_text(dom: Domain, x) -> str:
    return "(" + ", ".join(f"{s} = {v:.6g}" for s, v in zip(dom.base, x)) + ")"


# ================================================================== Lipschitz
def _norm_function(dom: Domain, J):
    """‖J(x)‖₂ at the rows of X (base variables), NaN where an entry is not finite."""
    Jf = dom.lam(list(J))

    def norm_at(X):
        X = np.atleast_2d(X)
        with np.errstate(all="ignore"):
            vals = Jf(*X.T)
        M = np.stack([np.asarray(v, dtype=float) * np.ones(X.shape[0]) for v in vals], axis=1)
        M = M.reshape(X.shape[0], J.rows, J.cols)
        out = np.full(X.shape[0], np.nan)
        fin = np.all(np.isfinite(M), axis=(1, 2))
        if fin.any():
            out[fin] = np.linalg.norm(M[fin], ord=2, axis=(1, 2))
        return out

    return norm_at


def _not_lipschitz(J, variables, entries, an, norm_at, lower, where):
    """Step 1: "not Lipschitz" when an entry's exact range is unbounded, with the domain
    points along which the norm grows as evidence; None when no entry is."""
    for i in range(J.rows):
        for k in range(J.cols):
            en = entries[i][k]
            if en.kind == "exact" and (en.lo == -OO or en.hi == OO) and en.groups:
                g = en.groups[0]
                seq = an.blowup(g)
                wit = []
                for tv, x in seq:
                    nv = norm_at(x)[0]
                    wit.append((tuple(float(v) for v in x), float(nv)))
                atom = g.atoms[0]
                trace = "; ".join(f"{atom} = {tv:.3g}: ‖J‖ = {nv:.4g}"
                                  for (tv, _), (_, nv) in zip(seq, wit))
                ev = (f"not Lipschitz {where}: ∂f{i + 1}/∂{variables[k]} = {J[i, k]} ranges over"
                      f" ({format_number(en.lo)}, {format_number(en.hi)}), unbounded as {atom} approaches the"
                      f" edge of its range [{format_number(an.atoms[atom][1])}, {format_number(an.atoms[atom][2])}]"
                      + (f"; along domain points {trace}" if trace else ""))
                low = max([lower or 0] + [w[1] for w in wit if np.isfinite(w[1])])
                return LipschitzResult(False, OO, "symbolic", ev, low, False, tuple(wit))
    return None


def _not_proven(entries, sampled, lower, stated_upper, where):
    """When some entry is not bounded rigorously: the caller's stated bound checked
    against the sampled lower bound, or "undetermined"; None when every entry is."""
    rigorous = all(en.kind in ("exact", "enclosure") for row in entries for en in row)
    bounded = all(en.lo != -OO and en.hi != OO for row in entries for en in row)
    if rigorous and bounded:
        return None
    why = ("an entry's enclosure is unbounded (not proven: the enclosure may be loose)"
           if rigorous else "sympy could not bound every Jacobian entry")
    grow = ""
    if sampled.size and np.isfinite(sampled).any():
        grow = f"; largest sampled ‖J‖ = {lower:.6g}"
    if stated_upper is not None:
        ok = lower is None or float(stated_upper) >= lower
        return LipschitzResult(True if ok else False, sp.sympify(stated_upper), "sampled",
                               f"{why}{grow}; stated upper bound {stated_upper}"
                               + ("" if ok else " is below the sampled lower bound"),
                               lower, False)
    return LipschitzResult(None, None, "sampled", f"undetermined {where}: {why}{grow}",
                           lower, False)


def _derivative_box(J, entries):
    """Step 2a: J = B0 + Σ_p p E_p — the constant part B0 and, per distinct group function
    p (groups in the same atoms proportional to it share it), [atoms, p, lo, hi, E_p,
    group]."""
    B0 = np.zeros((J.rows, J.cols))
    ps = []  # [atoms, func, lo, hi, E, group]
    for i in range(J.rows):
        for k in range(J.cols):
            en = entries[i][k]
            B0[i, k] = float(en.const)
            for g in en.groups:
                for p in ps:
                    if p[0] == g.atoms:
                        ratio = sp.cancel(g.func / p[1])
                        if ratio.is_number and ratio != 0:
                            p[4][i, k] += float(ratio)
                            break
                else:
                    E = np.zeros((J.rows, J.cols))
                    E[i, k] = 1.0
                    ps.append([g.atoms, g.func, as_float(g.lo), as_float(g.hi), E, g])
    return B0, ps


def _vertex_maximum(B0, ps, entries):
    """Step 2b: the largest ‖B0 + Σ p E_p‖₂ over the vertices of the box of the p (the
    norm is convex in p): (bound, maximising vertex or None, how it was found)."""
    if len(ps) > 14:  # pragma: no cover - large systems
        Mabs = np.array([[max(abs(as_float(en.lo)), abs(as_float(en.hi))) for en in row]
                         for row in entries])
        return float(np.linalg.norm(Mabs, 2)), None, "‖(sup |J_ik|)‖₂"
    best, best_v = -1.0, None
    for vert in itertools.product((0, 1), repeat=len(ps)):
        M = B0 + sum((p[3] if v else p[2]) * p[4] for p, v in zip(ps, vert))
        nv = float(np.linalg.norm(M, 2)) if M.size else 0.0
        if nv > best:
            best, best_v = nv, vert
    return best, best_v, f"max over the {2 ** len(ps)} vertices of the derivative box"


def _vertex_witnesses(ps, best_v, an, dom, norm_at, lower):
    """Step 2c: domain points where the groups approach the maximising vertex; their
    norms raise the lower bound. Returns (witnesses ((point, norm), …), lower)."""
    wit = []
    if best_v is None or not ps:
        return wit, lower
    targets = []
    for p, v in zip(ps, best_v):
        pts = an.group_point(p[5], "hi" if v else "lo")
        if pts and len(p[0]) == 1:
            targets.append((p[0][0], pts[0][0]))
    cand = []
    if targets:
        x = dom.point_with(targets)
        if x is not None:
            cand.append(x)
    for p, v in zip(ps, best_v):
        for _, x in an.group_point(p[5], "hi" if v else "lo"):
            cand.append(x)
    if cand:
        nv = norm_at(np.vstack(cand))
        for x, val in zip(cand, nv):
            if np.isfinite(val):
                wit.append((tuple(float(c) for c in x), float(val)))
                lower = val if lower is None else max(lower, float(val))
    return wit, lower


def _exact_vector_norm(J, entries, ps, best_v, best):
    """Step 2d: for a vector Jacobian (one row or one column) whose groups are all in
    one atom, the norm √(Σ squares) at the maximising vertex in exact arithmetic; None
    otherwise or when it does not reproduce the numeric bound."""
    if not (J.rows == 1 or J.cols == 1):
        return None
    if best_v is None or not all(len(p[0]) == 1 for p in ps):
        return None
    vals = sp.Matrix(J.rows, J.cols, lambda i, k: entries[i][k].const)
    for p, v in zip(ps, best_v):
        g = p[5]
        val = g.hi if v else g.lo
        for i in range(J.rows):
            for k in range(J.cols):
                if p[4][i, k]:
                    vals[i, k] += rationalize_floats(p[4][i, k]) * val
    exact_const = sp.sqrt(sum(v ** 2 for v in vals))
    exact_const = sp.radsimp(exact_const) if exact_const.is_number else exact_const
    if abs(float(exact_const) - best) > 1e-9 * (1 + best):
        return None
    return exact_const


def lipschitz(expr_vector, variables, domain_relations=(), *, definitions=None, ranges=None,
              stated_upper=None, seed=0) -> LipschitzResult:
    """Lipschitz constant (Euclidean norms) of ``expr_vector`` with respect to
    ``variables`` on the domain.

    A rigorous upper bound when the Jacobian's entries can be bounded symbolically
    (``kind="symbolic"``); "not Lipschitz" when an entry is provably unbounded (e.g.
    d√x3/dx3 = 1/(2√x3) with x3 ≥ 0 in the domain); otherwise ``kind="sampled"``:
    the largest Jacobian norm seen at sample points (``lower``) and the caller's
    ``stated_upper`` (if any) as the constant.
    """
    exprs, variables, dom, an, J = _prepare(expr_vector, variables, domain_relations,
                                            definitions, ranges, seed)
    entries = [[an.entry(J[i, k]) for k in range(J.cols)] for i in range(J.rows)]
    norm_at = _norm_function(dom, J)
    X = an.X()
    sampled = norm_at(X) if X.size else np.array([])
    lower = float(np.nanmax(sampled)) if sampled.size and np.isfinite(sampled).any() else None
    where = f"on the domain {dom.describe}"
    # 1. a provably unbounded entry; or entries not all bounded rigorously
    found = _not_lipschitz(J, variables, entries, an, norm_at, lower, where)
    if found is None:
        found = _not_proven(entries, sampled, lower, stated_upper, where)
    if found is not None:
        return found
    # 2. rigorous bound: J = B0 + Σ p E_p, max over the vertices of the p-box
    B0, ps = _derivative_box(J, entries)
    best, best_v, how = _vertex_maximum(B0, ps, entries)
    upper = best * (1 + 1e-12) + 1e-300
    wit, lower = _vertex_witnesses(ps, best_v, an, dom, norm_at, lower)
    exact_const = _exact_vector_norm(J, entries, ps, best_v, best)
    tight = lower is not None and lower >= upper * (1 - 1e-4)
    const = exact_const if exact_const is not None else upper
    ev = (f"Lipschitz {where} with N = {format_number(const)} (rigorous upper bound: {how};"
          f" Jacobian entries bounded symbolically)"
          + (f"; largest ‖J‖ at domain points {lower:.6g}" if lower is not None else "")
          + ("; the bound is attained or approached (tight)" if tight else ""))
    return LipschitzResult(True, const, "symbolic", ev, lower, tight, tuple(wit[:5]))


# ================================================================== monotonicity
def _signs(exprs, variables, dom, an, J, skip_diagonal=False):
    signs, kinds, bad = [], set(), []
    for i in range(J.rows):
        row = []
        for k in range(J.cols):
            if skip_diagonal and i == k:
                row.append("·")
                continue
            en = an.entry(J[i, k])
            s = range_sign(en.lo, en.hi)
            if s == "±" and en.kind != "exact":
                s = "?"
            kinds.add(en.kind)
            row.append(s)
            if s in ("±", "?", "-"):
                bad.append((i, k, en))
        signs.append(tuple(row))
    return tuple(signs), kinds, bad


def _negative_witness(exprs, variables, dom, an, J, i, k, en):
    """A pair x ≤ x' (differing in variable k) with f_i(x) > f_i(x'), or None."""
    cands = []
    if en.kind == "exact" and en.groups:
        cands += [x for _, x in an.group_point(en.groups[0], "lo")]
    X = an.X()
    if X.size:
        cands += list(X)
    if not cands:
        return None
    Xc = np.vstack(cands)
    f = dom.lam([J[i, k]])
    with np.errstate(all="ignore"):
        d = np.asarray(f(*Xc.T)[0], dtype=float) * np.ones(Xc.shape[0])
    neg = np.where(np.isfinite(d) & (d < 0))[0]
    if not neg.size:
        return None
    # move variable k alone: a base step that changes v_k by 1 and the others by 0
    rows = []
    for v in variables:
        aff = affine_parts(sp.expand(dom.to_base(v)))
        if aff is None:
            return None
        rows.append([float(aff[0].get(s, 0)) for s in dom.base])
    A = np.array(rows)
    rhs = np.zeros(A.shape[0])
    rhs[k] = 1.0
    step, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    if np.linalg.norm(A @ step - rhs) > 1e-9:
        return None
    fi = dom.lam([exprs[i]])
    order = neg[np.argsort(d[neg])][:60]
    for h in (1e-2, 1e-3, 1e-5, 1e-7):
        for j in order:
            x = Xc[j]
            x2 = x + h * step
            if not dom.feasible(x2[None, :])[0]:
                continue
            with np.errstate(all="ignore"):
                f1, f2 = float(fi(*x)[0]), float(fi(*x2)[0])
            if f1 > f2:
                return {"x": _point_text(dom, x), "x_prime": _point_text(dom, x2),
                        "variable": str(variables[k]), "f": (f1, f2), "derivative": float(d[j])}
    return None


def is_monotone(expr_vector, variables, domain_relations=(), *, definitions=None, ranges=None,
                seed=0) -> MonotoneResult:
    """Is f nondecreasing in every variable on the domain (x ≤ x' ⇒ f(x) ≤ f(x'))?

    By the sign of every Jacobian entry (symbolic ranges as in :func:`lipschitz`).
    ``False`` comes with a witness pair; ``None`` when no sign could be proven and no
    witness was found.
    """
    exprs, variables, dom, an, J = _prepare(expr_vector, variables, domain_relations,
                                            definitions, ranges, seed)
    return _monotone_result(exprs, variables, dom, an, J, skip_diagonal=False)


def is_cooperative(rhs, variables, domain_relations=(), *, definitions=None, ranges=None,
                   seed=0) -> MonotoneResult:
    """Is the system v' = rhs(v) cooperative (∂rhs_i/∂v_k ≥ 0 for i ≠ k, a Metzler
    Jacobian) on the domain? ``monotone`` then means "cooperative"."""
    exprs, variables, dom, an, J = _prepare(rhs, variables, domain_relations, definitions,
                                            ranges, seed)
    if J.rows != J.cols:
        raise UsageError("is_cooperative needs as many right-hand sides as variables")
    return _monotone_result(exprs, variables, dom, an, J, skip_diagonal=True)


def _monotone_result(exprs, variables, dom, an, J, skip_diagonal):
    signs, kinds, bad = _signs(exprs, variables, dom, an, J, skip_diagonal)
    rigorous = kinds <= {"exact", "enclosure"}
    flat = [s for row in signs for s in row if s != "·"]
    what = "off-diagonal Jacobian entry" if skip_diagonal else "Jacobian entry"
    table = "; ".join(f"∂f{i + 1}/∂{variables[k]}: {signs[i][k]}"
                      for i in range(J.rows) for k in range(J.cols) if signs[i][k] != "·")
    where = f"on the domain {dom.describe}"
    if all(s in ("+", "0") for s in flat):
        direction = "constant" if all(s == "0" for s in flat) else "nondecreasing"
        ok = True if rigorous else None
        return MonotoneResult(ok, direction, signs, "symbolic" if rigorous else "sampled",
                              f"every {what} ≥ 0 {where} ({table})"
                              + ("" if rigorous else " — from samples only, not proven"))
    # look for a concrete witness of a decrease
    for i, k, en in bad:
        if en.lo == -OO or bool(en.lo < 0):
            w = _negative_witness(exprs, variables, dom, an, J, i, k, en)
            if w is not None:
                direction = "nonincreasing" if all(s in ("-", "0") for s in flat) else None
                ev = (f"not nondecreasing {where}: ∂f{i + 1}/∂{variables[k]} = {J[i, k]} < 0 at"
                      f" {w['x']} (= {w['derivative']:.4g}); f{i + 1} drops from {w['f'][0]:.6g}"
                      f" to {w['f'][1]:.6g} when {w['variable']} increases to {w['x_prime']}"
                      f" ({table})")
                return MonotoneResult(False, direction, signs, "symbolic" if en.kind == "exact"
                                      else "sampled", ev, w)
    direction = "nonincreasing" if all(s in ("-", "0") for s in flat) else None
    if direction:
        return MonotoneResult(False, direction, signs, "symbolic" if rigorous else "sampled",
                              f"nonincreasing {where} ({table})")
    return MonotoneResult(None, None, signs, "sampled",
                          f"undetermined {where}: some signs could not be proven and no"
                          f" decrease was found at samples ({table})")


# ================================================================== stability
def stability_condition(F_star, N, W=None) -> StabilityResult:
    """The sufficient condition 2 N λ_max(P) < λ_min(W), F*ᵀ P + P F* = −W
    (continuous time; seed 002 §6 after Misawa & Hedrick). ``N`` is a number or a
    :class:`LipschitzResult`; W defaults to the identity."""
    if isinstance(N, LipschitzResult):
        Nv = N.constant if N.lipschitz else OO
    else:
        Nv = N
    F = np.array(sp.Matrix(F_star).evalf().tolist(), dtype=float) if not isinstance(F_star, np.ndarray) \
        else np.asarray(F_star, dtype=float)
    F = np.atleast_2d(F)
    k = F.shape[0]
    Wm = np.eye(k) if W is None else np.atleast_2d(np.asarray(
        sp.Matrix(W).evalf().tolist() if not isinstance(W, np.ndarray) else W, dtype=float))
    wmin = float(np.min(np.linalg.eigvalsh((Wm + Wm.T) / 2)))
    if wmin <= 0:
        raise UsageError("W must be symmetric positive definite")
    eig = np.linalg.eigvals(F)
    if np.max(eig.real) >= 0:
        return StabilityResult(False, np.inf, wmin, Nv, None, Wm,
                               f"F* is not Hurwitz (eigenvalues {np.round(eig, 6).tolist()}):"
                               " no positive definite P*")
    from scipy.linalg import solve_continuous_lyapunov
    P = solve_continuous_lyapunov(F.T, -Wm)
    P = (P + P.T) / 2
    pmax = float(np.max(np.linalg.eigvalsh(P)))
    Nf = as_float(Nv) if Nv is not None else np.inf
    lhs = 2 * Nf * pmax
    holds = bool(lhs < wmin)
    ev = (f"F*ᵀP* + P*F* = −W*: λ_max(P*) = {pmax:.6g}, λ_min(W*) = {wmin:.6g};"
          f" 2 N* λ_max(P*) = 2·{format_number(Nv) if Nv is not None else '∞'}·{pmax:.6g} = {lhs:.6g}"
          f" {'<' if holds else '≥'} {wmin:.6g}")
    if Nf == np.inf:
        ev += " (N* = ∞: not Lipschitz, the condition cannot hold)"
    return StabilityResult(holds, lhs, wmin, Nv, P, Wm, ev)


# ================================================================== model / design level
def model_nonlinearity(model):
    """(C Ψ(x, u) as a column, the states, the structure) of a model."""
    from ..model import extract_structure
    m = model.substitute_parameters() if model.parameters else model
    st = extract_structure(m)
    if not st.terms:
        return sp.zeros(len(m.states), 1), list(m.states), st
    return sp.Matrix(st.C) * sp.Matrix(st.psi()), list(m.states), st


def reduced_nonlinearity(model, design):
    """(C*Ψ*(x*, y, u), x* symbols, y symbols, definitions {x*_i: Φ_i x, y_j: H_j x})."""
    m = model.substitute_parameters() if model.parameters else model
    st = design.structure
    k = design.k
    xs = list(design.observer_states) or list(sp.symbols(f"xs1:{k + 1}"))
    ys = list(sp.symbols(f"y1:{len(m.outputs) + 1}"))
    Phi = sp.Matrix(design.matrices.Phi)
    H = sp.Matrix(st.H)
    xv = sp.Matrix(m.states)
    defs = {x: (Phi[i, :] * xv)[0, 0] for i, x in enumerate(xs)}
    defs.update({y: (H[j, :] * xv)[0, 0] for j, y in enumerate(ys)})
    if not design.nonlinear:
        return sp.zeros(k, 1), xs, ys, defs
    Cs = sp.Matrix(design.matrices.C_star)
    psi = sp.zeros(Cs.cols, 1)
    for ns in design.nonlinear:
        psi[ns.index - 1, 0] = ns.function
    return Cs * psi, xs, ys, defs


def nonlinear_conditions(model, design, domain=None) -> tuple:
    """The METHOD §4 nonlinear conditions of a design, as reported Conditions:
    Lipschitz constant of C*Ψ* in x* on the domain, the stability condition with it
    (continuous time), monotonicity of C*Ψ* in x*."""
    if not design.nonlinear:
        return ()
    m = model.substitute_parameters() if model.parameters else model
    dom = m.domain if domain is None else domain
    expr, xs, ys, defs = reduced_nonlinearity(model, design)
    lip = lipschitz(list(expr), xs, dom, definitions=defs)
    mono = is_monotone(list(expr), xs, dom, definitions=defs)
    out = [lip.condition("C*Ψ* (in x*)"), mono.condition("C*Ψ*")]
    if design.time == "continuous":
        out.append(stability_condition(design.matrices.F_star, lip).condition())
    return tuple(out)
