"""Direct sympy → casadi SX translation, and the step functions built from it.

:func:`to_casadi` walks a sympy expression tree once per *unique* node (a dict cache
keyed by the sympy node), so a subexpression that occurs in several places — e.g.
``sqrt(x1 - x2)`` in two dynamics equations, or an output ``y1 = x2 + w1`` that the
observer reads in four RK4 stages — becomes one casadi node and is computed once in the
generated code.  Sums built here put their state-dependent terms last (CasADi keeps
the written order of a sum; with the loop-carried state last the dependency chain of a
step is shortest — see docs/PERFORMANCE.md).

Step functions (each a named :class:`casadi.Function` whose ``__doc__`` lists the
argument order and meaning; :func:`describe` gives the same text):

* :func:`observer_step` — ``NAME_step(x, y, u, p[, h]) -> (x_next, out)``: the observer
  alone, as it runs embedded: it receives the sampled measurements ``y`` and known
  inputs ``u`` and holds them over the step.  Continuous time is discretised inside
  the graph: fixed-step RK4 by default (step size ``h`` an option, or an input when
  ``h=None``), or, with ``discretisation="zoh"``, the exact zero-order-hold step of an
  observer whose update is affine in its states, ``ξ' = A ξ + g(y, u, p)`` with a
  constant A: ``ξ_next = e^{A h} ξ + Γ g``, ``Γ = ∫₀ʰ e^{A τ} dτ``, both from one
  ``scipy.linalg.expm`` of ``[[A, I], [0, 0]] h`` (double precision; see
  :func:`zoh_matrices`).  ``out`` is the observer's outputs at the *current* state.
* :func:`plant_step` — ``NAME_plant_step(x, v, p[, h]) -> (x_next, y)`` for the plant:
  ``v`` = inputs, faults, disturbances, noise (model order), ``y`` = h(x, w) at the
  current state.
* :func:`joint_step` — ``NAME_sim_step(s, v, h) -> (s_next, y, out)``: plant and
  observer as one system, exactly as the reference simulator
  (:func:`observer_cad.simulation.simulate`) integrates them: ``s = [x; ξ]``, signals
  ``v`` held over the step, the observer reading ``y = h(x, w)`` *inside* the RK4
  stages.  Parameters are substituted by their values.  This is what the compiled
  trajectory loop (:mod:`observer_cad.codegen`) iterates.
"""
from __future__ import annotations

import re
from typing import Iterable, Mapping

import casadi as ca
import numpy as np
import sympy as sp

from ..errors import UsageError
from ..model import PlantModel
from ..numerics import algebraic_to_float
from ..observers import Observer
from ..simulation import parameter_layout

__all__ = ["to_casadi", "Translator", "observer_step", "plant_step", "joint_step",
           "describe", "split_signals", "rk4", "zoh_matrices", "DISCRETISATIONS",
           "observer_step_name", "plant_step_name", "joint_step_name", "observer_identity",
           "plant_identity", "joint_identity", "c_name", "MAX_C_NAME"]

#: continuous-time discretisations of :func:`observer_step`
DISCRETISATIONS = ("rk4", "zoh")


_OPTS = {"cse": True}  # casadi-side common subexpression elimination (RK4 stages)


def _num(e) -> float:
    return float(e)


_UNARY = {
    sp.sin: ca.sin, sp.cos: ca.cos, sp.tan: ca.tan, sp.exp: ca.exp, sp.log: ca.log,
    sp.tanh: ca.tanh, sp.sinh: ca.sinh, sp.cosh: ca.cosh, sp.asin: ca.asin,
    sp.acos: ca.acos, sp.atan: ca.atan, sp.Abs: ca.fabs, sp.sign: ca.sign,
    sp.floor: ca.floor, sp.ceiling: ca.ceil, sp.asinh: ca.asinh, sp.acosh: ca.acosh,
    sp.atanh: ca.atanh, sp.erf: ca.erf,
}


class Translator:
    """Translate sympy expressions to casadi SX given a symbol → SX mapping.

    One instance keeps its node cache across calls, so expressions translated by the
    same translator share their common subexpressions.  ``state_symbols`` are the
    symbols whose terms go last in a sum.
    """

    def __init__(self, mapping: Mapping, state_symbols: Iterable = ()):
        self.cache: dict = {}
        for s, v in mapping.items():
            self.cache[s] = v
        self.states = frozenset(state_symbols)
        self._dep: dict = {}

    # ------------------------------------------------------------------ helpers
    def _state_dependent(self, e) -> bool:
        """Whether ``e`` contains a state symbol (memoised per node, so a whole
        expression DAG costs one visit per unique node, unlike ``free_symbols``)."""
        r = self._dep.get(e)
        if r is None:
            if e.is_Symbol:
                r = e in self.states
            else:
                r = any(self._state_dependent(a) for a in e.args)
            self._dep[e] = r
        return r

    def _sum(self, terms):
        """Left fold; the caller orders the terms."""
        acc = None
        for t in terms:
            acc = t if acc is None else acc + t
        return acc

    def __call__(self, expr):
        return self.tr(sp.sympify(expr))

    def tr(self, e):
        hit = self.cache.get(e)
        if hit is not None:
            return hit
        out = self._tr(e)
        self.cache[e] = out
        return out

    def _tr(self, e):
        if e.is_Symbol:
            raise UsageError(f"codegen: symbol '{e}' has no value (not a state, signal or parameter)")
        if e.is_Number:
            if e is sp.nan:
                return ca.SX(float("nan"))
            return ca.SX(_num(e))
        if e is sp.pi or e is sp.E or isinstance(e, sp.CRootOf):  # CRootOf: an irrational λ
            return ca.SX(_num(e))
        if e is sp.true:
            return ca.SX(1.0)
        if e is sp.false:
            return ca.SX(0.0)
        if e.is_Add:
            args = list(e.args)
            rest = [a for a in args if not self._state_dependent(a)]
            last = [a for a in args if self._state_dependent(a)]
            return self._sum([self.tr(a) for a in rest + last])
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e.base, e.exp)
        f = e.func
        if f in _UNARY:
            return _UNARY[f](self.tr(e.args[0]))
        if f is sp.atan2:
            return ca.atan2(self.tr(e.args[0]), self.tr(e.args[1]))
        if f is sp.Max or f is sp.Min:
            op = ca.fmax if f is sp.Max else ca.fmin
            vals = [self.tr(a) for a in e.args]
            acc = vals[0]
            for v in vals[1:]:
                acc = op(acc, v)
            return acc
        if f is sp.Heaviside:
            a = self.tr(e.args[0])
            h0 = 0.5 if len(e.args) < 2 else _num(e.args[1])
            return ca.if_else(a > 0, 1.0, ca.if_else(a < 0, 0.0, h0))
        if isinstance(e, sp.Piecewise):
            # fold from the last branch; a branch with condition True ends the chain
            acc = ca.SX(float("nan"))
            for val, cond in reversed(e.args):
                if cond is sp.true:
                    acc = self.tr(val)
                else:
                    acc = ca.if_else(self.tr(cond), self.tr(val), acc, True)
            return acc
        if isinstance(e, sp.core.relational.Relational):
            a, b = self.tr(e.lhs), self.tr(e.rhs)
            op = e.rel_op
            if op == "<":
                return a < b
            if op == "<=":
                return a <= b
            if op == ">":
                return a > b
            if op == ">=":
                return a >= b
            if op == "==":
                return a == b
            if op == "!=":
                return a != b
        if isinstance(e, sp.And):
            vals = [self.tr(a) for a in e.args]
            acc = vals[0]
            for v in vals[1:]:
                acc = ca.logic_and(acc, v)
            return acc
        if isinstance(e, sp.Or):
            vals = [self.tr(a) for a in e.args]
            acc = vals[0]
            for v in vals[1:]:
                acc = ca.logic_or(acc, v)
            return acc
        if isinstance(e, sp.Not):
            return ca.logic_not(self.tr(e.args[0]))
        raise UsageError(f"codegen: cannot translate '{e}' ({type(e).__name__}) to casadi")

    def _mul(self, e):
        num, den = [], []
        coeff = None
        for a in e.args:
            if a.is_Number:
                coeff = a
            elif a.is_Pow and a.exp.is_Number and a.exp.is_negative:
                den.append(a.base if a.exp == -1 else sp.Pow(a.base, -a.exp))
            else:
                num.append(a)
        # as numpy/lambdify prints it: coefficient, then factors, then / denominator
        num.sort(key=self._state_dependent)
        vals = [self.tr(a) for a in num]
        if coeff is not None and coeff != 1:
            if coeff == -1 and vals:
                vals[0] = -vals[0]
            elif isinstance(coeff, sp.Rational) and not coeff.is_Integer and vals:
                # p/q * x: lambdify prints (p/q)*x; (p/q) evaluated as a double
                vals.insert(0, ca.SX(_num(coeff)))
            else:
                vals.insert(0, ca.SX(_num(coeff)))
        acc = vals[0] if vals else ca.SX(_num(coeff) if coeff is not None else 1.0)
        for v in vals[1:]:
            acc = acc * v
        if den:
            d = self.tr(sp.Mul(*den)) if len(den) > 1 else self.tr(den[0])
            acc = acc / d
        return acc

    def _pow(self, base, ex):
        b = self.tr(base)
        if ex == sp.S.Half:
            return ca.sqrt(b)
        if ex == -sp.S.Half:
            return 1.0 / ca.sqrt(b)
        if ex.is_Integer:
            n = int(ex)
            if n == 0:
                return ca.SX(1.0)
            if n < 0:
                return 1.0 / self._pow(base, -ex)
            if n == 1:
                return b
            if n == 2:
                return b * b
            return ca.constpow(b, float(n))
        if ex.is_Number:
            return ca.constpow(b, _num(ex))
        return ca.power(b, self.tr(ex))


def to_casadi(exprs, mapping: Mapping, state_symbols: Iterable = (), *, cse: bool = False):
    """Translate sympy expressions (a list) to a list of casadi SX scalars.

    ``mapping`` sends every free symbol to an SX scalar.  Unique sympy nodes are
    translated once (shared subexpressions).  With ``cse=True`` sympy's ``cse`` runs
    first (rarely needed: the cache already shares structurally equal nodes).
    """
    exprs = [sp.sympify(e) for e in exprs]
    tr = Translator(mapping, state_symbols)
    if cse:
        reps, reduced = sp.cse(exprs, optimizations=None)
        for s, sub in reps:
            tr.cache[s] = tr.tr(sub)
        exprs = reduced
    return [tr.tr(e) for e in exprs]


# --------------------------------------------------------------------- RK4 and steps
def rk4(f, x, h):
    """One classical RK4 step of dx/dt = f(x) (f: SX column → SX column), in the
    reference simulator's operation order (state term written last in each sum)."""
    k1 = f(x)
    k2 = f(h / 2 * k1 + x)
    k3 = f(h / 2 * k2 + x)
    k4 = f(h * k3 + x)
    return h / 6 * (k1 + 2 * k2 + 2 * k3 + k4) + x


def _vec(xs):
    return ca.densify(ca.vertcat(*xs)) if xs else ca.SX(0, 1)


def _sym(name, n):
    return ca.SX.sym(name, n) if n else ca.SX(0, 1)


def _scalars(v, n):
    return [v[i] for i in range(n)]


#: longest C name made from a model's or observer's name (longer ones are cut and given a
#: hash of the whole name: file names in the compile cache stay below the file system's limit)
MAX_C_NAME = 64


def c_name(name: str) -> str:
    """A name casadi and C accept, made from any text: ASCII letters, digits and single
    underscores, starting with a letter (casadi refuses ``d__x``, ``_d`` and non-ASCII
    letters, which a model's names may hold), at most :data:`MAX_C_NAME` characters."""
    c = re.sub(r"_+", "_", re.sub(r"[^0-9A-Za-z_]", "_", name)).strip("_")
    if not c or not c[0].isalpha():
        c = "f_" + c if c else "f"
    if len(c) > MAX_C_NAME:
        import hashlib
        c = c[:MAX_C_NAME - 9].rstrip("_") + "_" + hashlib.sha256(name.encode()).hexdigest()[:8]
    return c


def split_signals(observer: Observer):
    """The observer's signals split into measurements ``y1, y2, …`` and the rest (known
    inputs), in the observer's order."""
    ys = [s for s in observer.signals if re.fullmatch(r"y\d+", str(s))]
    us = [s for s in observer.signals if s not in ys]
    return ys, us


def _attach_doc(f: ca.Function, lines: list) -> ca.Function:
    text = "\n".join(lines)
    f.__doc__ = text
    return f


def describe(f: ca.Function) -> str:
    """The argument-order docstring of a step function built here."""
    return getattr(f, "__doc__", "") or ""


def _fmt(names):
    return ", ".join(str(s) for s in names) if names else "(empty)"


def observer_step_name(observer: Observer, name: str | None = None) -> str:
    """The C name :func:`observer_step` gives its Function."""
    return c_name(name or f"{observer.name}_step")


def _check_discretisation(observer: Observer, h, discretisation: str) -> str:
    if discretisation not in DISCRETISATIONS:
        raise UsageError(f"discretisation must be one of {', '.join(DISCRETISATIONS)},"
                         f" got {discretisation!r}")
    if discretisation == "zoh":
        if observer.time != "continuous":
            raise UsageError(f"discretisation='zoh' applies to continuous-time observers;"
                             f" {observer.name} is discrete (one call = one sample)")
        if h is None:
            raise UsageError("discretisation='zoh' needs a fixed step size h (e^{A h} is"
                             " computed when the function is built)")
    return discretisation


def zoh_matrices(observer: Observer, h: float):
    """``(A, Ad, Gamma, g)`` of the exact zero-order-hold step of size ``h``.

    The update must be affine in the observer's states with a constant state matrix,
    ``ξ' = A ξ + g(y, u, p)`` (A numeric: it may not depend on states, signals or
    parameters); otherwise :class:`~observer_cad.errors.UsageError` names the first
    offending equation.  With the signals held over the step the exact solution is
    ``ξ(t + h) = Ad ξ(t) + Gamma g``, ``Ad = e^{A h}``, ``Gamma = ∫₀ʰ e^{A τ} dτ``
    (= A⁻¹(e^{A h} − I) when A is invertible), read off one matrix exponential
    ``expm([[A, I], [0, 0]] h) = [[Ad, Gamma], [0, I]]`` (scipy.linalg.expm, double
    precision).  ``g`` is the list of sympy expressions ``g_i = ξ'_i`` at ``ξ = 0``.
    """
    import scipy.linalg
    xs = list(observer.states)
    upd = [sp.sympify(e) for e in observer.update]
    n = len(xs)
    try:
        h = float(h)
    except (TypeError, ValueError):
        raise UsageError(f"discretisation='zoh': h must be a number, got {h!r}") from None
    if not (np.isfinite(h) and h > 0):
        raise UsageError(f"discretisation='zoh': h must be a positive finite step, got {h!r}")
    xset = set(xs)
    A = np.zeros((n, n))
    for i, e in enumerate(upd):
        for j, x in enumerate(xs):
            a = sp.diff(e, x)
            if a.free_symbols or a.has(sp.Derivative) or not a.is_number:
                if a.free_symbols & xset or a.has(sp.Derivative):
                    raise UsageError(
                        f"discretisation='zoh' needs an observer update affine in its states"
                        f" (x' = A x + g(y, u, p)); {observer.name} is not: the equation for"
                        f" {xs[i]} is nonlinear in {x}; use discretisation='rk4'")
                raise UsageError(
                    f"discretisation='zoh' needs a constant state matrix A (e^(A h) is"
                    f" precomputed); in {observer.name} d({xs[i]}')/d{x} = {a} depends on"
                    f" {', '.join(sorted(map(str, a.free_symbols)))}; use discretisation='rk4'")
            A[i, j] = float(a)
    g = [e.xreplace({x: 0 for x in xs}) for e in upd]
    for i, e in enumerate(g):
        if e.free_symbols & xset:  # defensive: an affine update has no state left
            raise UsageError(f"discretisation='zoh': the equation for {xs[i]} is not affine"
                             " in the states; use discretisation='rk4'")
    if n == 0:
        return A, np.zeros((0, 0)), np.zeros((0, 0)), g
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = A * h
    M[:n, n:] = np.eye(n) * h
    E = scipy.linalg.expm(M)
    return A, E[:n, :n].copy(), E[:n, n:].copy(), g


def _zoh_step(observer: Observer, h, X, base):
    """SX x_next of the exact ZOH step; state terms written last in every sum."""
    xs = list(observer.states)
    _, Ad, Gam, g = zoh_matrices(observer, h)
    n = len(xs)
    t = Translator(base, xs)
    gv = [t.tr(e) for e in g]
    rows = []
    for i in range(n):
        terms = [float(Gam[i, j]) * gv[j] for j in range(n) if Gam[i, j] != 0.0]
        terms += [float(Ad[i, j]) * X[j] for j in range(n) if Ad[i, j] != 0.0]
        acc = None
        for term in terms:
            acc = term if acc is None else acc + term
        rows.append(acc if acc is not None else ca.SX(0.0))
    return _vec(rows)


def observer_step(observer: Observer, *, h: float | None = None, name: str | None = None,
                  cse: bool = False, discretisation: str = "rk4") -> ca.Function:
    """``NAME(x, y, u, p[, h]) -> (x_next, out)`` for the observer alone.

    ``x`` observer states, ``y`` measurements (y1…), ``u`` the other signals it reads
    (known inputs), ``p`` its parameters (defaults: ``observer.parameters``).  For
    continuous time the step is RK4 with ``y``, ``u`` held; the step size is ``h`` or,
    when ``h`` is None, a fifth input.  ``discretisation="zoh"`` (continuous time, ``h``
    given) makes the step the exact zero-order hold of an update affine in the states
    (:func:`zoh_matrices`; a nonlinear observer is rejected with a UsageError).  ``out``
    = outputs at the current state.
    """
    _check_discretisation(observer, h, discretisation)
    ys, us = split_signals(observer)
    ps = list(observer.parameters)
    xs = list(observer.states)
    n = len(xs)
    X, Y, U, P = _sym("x", n), _sym("y", len(ys)), _sym("u", len(us)), _sym("p", len(ps))
    H = ca.SX.sym("h") if (h is None and observer.time == "continuous") else None
    base = {**dict(zip(ys, _scalars(Y, len(ys)))), **dict(zip(us, _scalars(U, len(us)))),
            **dict(zip(ps, _scalars(P, len(ps))))}
    upd = [sp.sympify(e) for e in observer.update]
    outs = [sp.sympify(e) for _, e in observer.outputs]
    tr_out = Translator({**base, **dict(zip(xs, _scalars(X, n)))}, xs)
    out = _vec([tr_out.tr(e) for e in outs])
    if observer.time == "discrete":
        xn = _vec([tr_out.tr(e) for e in upd])
    elif discretisation == "zoh":
        xn = _zoh_step(observer, h, X, base)
    else:
        base_tr = Translator(base, xs)  # x-free subexpressions shared over the stages

        def f(xv):
            t = Translator(dict(zip(xs, _scalars(xv, n))), xs)
            t.cache.update(base_tr.cache)
            res = [t.tr(e) for e in upd]
            return _vec(res)
        # pre-translate the x-free parts (with a signal or parameter) once
        seen: set = set()

        def pre(e):
            if e in seen or e.is_Symbol or not e.args:
                return
            seen.add(e)
            if not base_tr._state_dependent(e):
                if e.free_symbols:
                    base_tr.tr(e)
                return
            for a in e.args:
                pre(a)
        for e in upd:
            pre(e)
        step = H if H is not None else ca.SX(float(h))
        xn = rk4(f, X, step)
    fname = observer_step_name(observer, name)
    ins, in_names = [X, Y, U, P], ["x", "y", "u", "p"]
    if H is not None:
        ins.append(H)
        in_names.append("h")
    F = ca.Function(fname, ins, [xn, out], in_names, ["x_next", "out"], _OPTS)
    if observer.time == "continuous" and discretisation == "zoh":
        how = (f", exact zero-order-hold step h = {h!r} (x_next = e^(A h) x + Gamma g(y, u, p),"
               " y and u held)")
    elif observer.time == "continuous" and h is not None:
        how = f", RK4 step h = {h!r}"
    else:
        how = ""
    doc = [f"{fname}({', '.join(in_names)}) -> (x_next, out): {observer.kind} observer"
           f" '{observer.name}', {observer.time} time" + how + ".",
           f"  x      [{n}]  observer states: {_fmt(xs)}",
           f"  y      [{len(ys)}]  measured outputs (held over the step): {_fmt(ys)}",
           f"  u      [{len(us)}]  known inputs (held over the step): {_fmt(us)}",
           f"  p      [{len(ps)}]  parameters: {_fmt(ps)}"
           + (f" (defaults {[float(v) for v in observer.parameters.values()]})" if ps else "")]
    if H is not None:
        doc.append("  h      [1]  RK4 step size (time units of the model)")
    doc += [f"  x_next [{n}]  states one step later",
            f"  out    [{len(outs)}]  outputs at the current state: {_fmt(observer.output_names)}"]
    return _attach_doc(F, doc)


def _observer_parts(observer: Observer | None):
    if observer is None:
        return (None,)
    return (observer.name, observer.kind, observer.time, tuple(observer.states),
            tuple(observer.signals), dict(observer.parameters), tuple(observer.update),
            tuple(observer.outputs))


def _model_parts(m: PlantModel):
    return (m.name, m.time, tuple(m.states), tuple(m.inputs), tuple(m.faults),
            tuple(m.disturbances), tuple(m.noise), tuple(m.dynamics), tuple(m.outputs),
            dict(m.parameters))


def observer_identity(observer: Observer, *, h=None, name=None, cse=False,
                      discretisation="rk4") -> tuple:
    """What determines :func:`observer_step`'s Function before translation (for the
    compile cache's fingerprint): the equations, signals, parameters and options."""
    return ("observer_step", observer_step_name(observer, name),
            None if h is None else float(h), bool(cse), discretisation,
            _observer_parts(observer))

def _plant_parts(model: PlantModel, substitute: bool):
    m = model.substitute_parameters() if (substitute and model.parameters) else model
    xs = list(m.states)
    vs = list(m.inputs) + list(m.faults) + list(m.disturbances) + list(m.noise)
    ps = [] if substitute else list(m.parameters)
    return m, xs, vs, ps


def plant_step_name(model: PlantModel, name: str | None = None) -> str:
    return c_name(name or f"{model.name}_plant_step")


def plant_identity(model: PlantModel, *, h=None, name=None,
                   substitute_parameters: bool = False) -> tuple:
    """What determines :func:`plant_step`'s Function before translation."""
    return ("plant_step", plant_step_name(model, name), None if h is None else float(h),
            bool(substitute_parameters), _model_parts(model))


def plant_step(model: PlantModel, *, h: float | None = None, name: str | None = None,
               substitute_parameters: bool = False) -> ca.Function:
    """``NAME(x, v, p[, h]) -> (x_next, y)`` for the plant.

    ``v`` = inputs, faults, disturbances, noise (the model's order), ``p`` the model
    parameters (empty with ``substitute_parameters=True``), ``y = h(x, w)`` at the
    current state.  Continuous time: RK4 with ``v`` held, step ``h`` (an input when None).
    """
    m, xs, vs, ps = _plant_parts(model, substitute_parameters)
    n = len(xs)
    X, V, P = _sym("x", n), _sym("v", len(vs)), _sym("p", len(ps))
    H = ca.SX.sym("h") if (h is None and m.time == "continuous") else None
    base = {**dict(zip(vs, _scalars(V, len(vs)))), **dict(zip(ps, _scalars(P, len(ps))))}
    tr = Translator({**base, **dict(zip(xs, _scalars(X, n)))}, xs)
    y = _vec([tr.tr(e) for e in m.outputs])
    if m.time == "discrete":
        xn = _vec([tr.tr(e) for e in m.dynamics])
    else:
        def f(xv):
            t = Translator({**base, **dict(zip(xs, _scalars(xv, n)))}, xs)
            return _vec([t.tr(e) for e in m.dynamics])
        xn = rk4(f, X, H if H is not None else ca.SX(float(h)))
    fname = plant_step_name(model, name)
    ins, in_names = [X, V, P], ["x", "v", "p"]
    if H is not None:
        ins.append(H)
        in_names.append("h")
    F = ca.Function(fname, ins, [xn, y], in_names, ["x_next", "y"], _OPTS)
    doc = [f"{fname}({', '.join(in_names)}) -> (x_next, y): plant '{m.name}', {m.time} time.",
           f"  x      [{n}]  plant states: {_fmt(xs)}",
           f"  v      [{len(vs)}]  inputs, faults, disturbances, noise (held): {_fmt(vs)}",
           f"  p      [{len(ps)}]  parameters: {_fmt(ps)}"]
    if H is not None:
        doc.append("  h      [1]  RK4 step size")
    doc += [f"  x_next [{n}]  states one step later",
            f"  y      [{len(m.outputs)}]  outputs y1… = h(x, w) at the current state"]
    return _attach_doc(F, doc)


def joint_step_name(model: PlantModel, observer: Observer | None,
                    name: str | None = None) -> str:
    return c_name(name or f"{(observer.name if observer else model.name)}_sim_step")


def joint_identity(model: PlantModel, observer: Observer | None, *, name=None,
                   parameters: bool = False) -> tuple:
    """What determines :func:`joint_step`'s Function before translation (the model's
    equations with its parameter values — or only their names with ``parameters=True`` —
    the observer's, the name)."""
    mp, op = _model_parts(model), _observer_parts(observer)
    if parameters:
        mp = mp[:-1] + (tuple(model.parameters),)
        if observer is not None:
            op = op[:5] + (tuple(observer.parameters),) + op[6:]
    return ("joint_step", joint_step_name(model, observer, name), bool(parameters), mp, op)


def joint_step(model: PlantModel, observer: Observer | None, *, name: str | None = None,
               parameters: bool = False) -> ca.Function:
    """``NAME(s, v, h) -> (s_next, y, out)``: plant + observer as the reference simulator
    integrates them (see the module docstring).  ``s = [x; ξ]``; ``h`` is ignored in
    discrete time.  Parameters (model and observer) are substituted by their values; with
    ``parameters=True`` they are a run-time input instead, ``NAME(s, v, p, h)`` with ``p``
    the model's parameters then the observer's (each in its own order): one compiled
    function serves every parameter sample."""
    m, xs, vs, _ = _plant_parts(model, not parameters)
    if observer is not None and observer.time != m.time:
        raise UsageError(f"observer is {observer.time}-time but the model is {m.time}-time")
    par = {} if (parameters or observer is None) else dict(observer.parameters)
    ps = []
    if parameters:  # the plant's then the observer's (renamed where they clash)
        layout = parameter_layout(m, observer)
        par = dict(layout.rename)
        ps = list(layout.plant) + list(layout.observer)
    obs_states = list(observer.states) if observer else []
    obs_upd = [algebraic_to_float(e).xreplace(par) for e in (observer.update if observer else ())]
    obs_out = [algebraic_to_float(e).xreplace(par)
               for _, e in (observer.outputs if observer else ())]
    ysyms = [sp.Symbol(f"y{i + 1}") for i in range(len(m.outputs))]
    allx = xs + obs_states
    n, nv = len(allx), len(vs)
    S, V, H = _sym("s", n), _sym("v", nv), ca.SX.sym("h")
    P = _sym("p", len(ps))
    vmap = {**dict(zip(vs, _scalars(V, nv))), **dict(zip(ps, _scalars(P, len(ps))))}

    def rhs_and_y(sv):
        t = Translator({**vmap, **dict(zip(allx, _scalars(sv, n)))}, allx)
        yv = [t.tr(e) for e in m.outputs]
        for ys_, yv_ in zip(ysyms, yv):
            t.cache[ys_] = yv_
        t.states = frozenset(allx) | frozenset(ysyms)
        return t, yv, [t.tr(e) for e in list(m.dynamics) + obs_upd]

    t0, y0, r0 = rhs_and_y(S)
    out = _vec([t0.tr(e) for e in obs_out])
    y = _vec(y0)
    if m.time == "discrete":
        sn = _vec(r0)
    else:
        first = [True]

        def f(sv):
            if first[0]:
                first[0] = False
                return _vec(r0)
            return _vec(rhs_and_y(sv)[2])
        sn = rk4(f, S, H)
    fname = joint_step_name(m, observer, name)
    ins, in_names = ([S, V, P, H], ["s", "v", "p", "h"]) if parameters else ([S, V, H], ["s", "v", "h"])
    F = ca.Function(fname, ins, [sn, y, out], in_names, ["s_next", "y", "out"], _OPTS)
    doc = [f"{fname}({', '.join(in_names)}) -> (s_next, y, out): plant '{m.name}'"
           + (f" + {observer.kind} observer '{observer.name}'" if observer else "")
           + f", {m.time} time" + (" (RK4, signals held over the step)" if m.time == "continuous" else "")
           + ".",
           f"  s      [{n}]  plant states then observer states: {_fmt(allx)}",
           f"  v      [{nv}]  inputs, faults, disturbances, noise (held): {_fmt(vs)}"]
    if parameters:
        doc.append(f"  p      [{len(ps)}]  parameters (the model's, then the observer's): {_fmt(ps)}")
    doc += ["  h      [1]  step size" + (" (unused in discrete time)" if m.time == "discrete" else ""),
           f"  s_next [{n}]  joint state one step later",
           f"  y      [{len(ysyms)}]  plant outputs at the current state: {_fmt(ysyms)}",
           f"  out    [{len(obs_out)}]  observer outputs at the current state:"
           f" {_fmt(observer.output_names if observer else ())}"]
    return _attach_doc(F, doc)
