"""Structure extraction: from a model's right-hand side to F, G, H, C, D, L, Bw and Ψ.

METHOD §1::

    x' = F x + G u + C Ψ(x, u) + D d + L ρ + Bw w,     y = H x + Gy u + Dy d + Ly ρ + W w

(process noise Bw w: a noise symbol entering the dynamics linearly with a constant
coefficient; bounded, never decoupled; feedthrough Gy, Dy, Ly: inputs, faults and
disturbances entering the outputs linearly with constant coefficients).
    Ψ(x, u) = (φ_1(A_1 x, u), ..., φ_q(A_q x, u))ᵀ

Every additive term of a right-hand side that is not linear in x and u is a
nonlinear term ``c · m(x, u)``; terms with the same ``m`` share a column of C. The
argument row ``A_j`` is recognised from the maximal subexpressions of ``m`` that are
affine in x with constant coefficients (``√(x1 − x2)`` gives ``A = (1, −1, 0)``);
they must all be multiples of one row, otherwise the term is rejected.

When the model states its own linear part F (``PlantModel(linear_part=...)``), the
difference from the right-hand side's natural linear part is absorbed into the
nonlinear functions as formal terms: ``Ψ_j = φ_j + β_j A_j x`` (seed 002 §8).
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..progress import report
from ..errors import ModelError
from ._identity import EXPAND_HINTS, is_identically_zero
from ._matrices import exact_matrix
from ._plant import PlantModel

__all__ = ["NonlinearTerm", "Structure", "extract_structure", "certify_structure",
           "ModelCertificate", "EquationCheck"]


@dataclasses.dataclass(frozen=True)
class EquationCheck:
    """One equation of the model certificate: which (``dynamics equation 2 (for x2)``,
    ``output y1``), whether exact algebra decided it, and how (see
    :class:`~observer_cad.model.ZeroTest`)."""

    equation: str
    exact: bool
    how: str

    def to_json(self) -> dict:
        return {"equation": self.equation, "exact": self.exact, "how": self.how}


@dataclasses.dataclass(frozen=True)
class ModelCertificate:
    """The extracted matrices rebuild the model's own equations (METHOD §1)::

        F x + G u + C Ψ(A x, u) + D d + L ρ + Bw w − f(x, u, d, ρ, w) ≡ 0,
        H x + Gy u + Dy d + Ly ρ + W w − h(x, u, d, ρ, w) ≡ 0

    one :class:`EquationCheck` per equation and output, every one passed (a failure is a
    :class:`ModelError`, never a certificate)."""

    checks: tuple

    IDENTITY = ("F x + G u + C Psi(A x, u) + D d + L rho + Bw w - f = 0,"
                "  H x + Gy u + Dy d + Ly rho + W w - h = 0")

    @property
    def exact(self) -> bool:
        return all(c.exact for c in self.checks)

    def summary(self) -> str:
        numeric = [c for c in self.checks if not c.exact]
        if not numeric:
            return (f"{self.IDENTITY}: exactly, every one of {len(self.checks)} equations"
                    " and outputs")
        return (f"{self.IDENTITY}: exactly for {len(self.checks) - len(numeric)}, numerically"
                f" for {len(numeric)} ({'; '.join(f'{c.equation}: {c.how}' for c in numeric)})")

    def to_json(self) -> dict:
        return {"identity": self.IDENTITY, "exact": self.exact,
                "equations": [c.to_json() for c in self.checks]}


@dataclasses.dataclass(frozen=True)
class NonlinearTerm:
    """One component ``φ_j(A_j x, u)`` of Ψ.

    ``function`` is an expression in ``argument`` (a dummy scalar standing for
    ``A_j x``) and the inputs; ``row`` is ``A_j`` (1×n).
    """

    function: sp.Expr
    argument: sp.Symbol
    row: sp.ImmutableMatrix

    def of_state(self, states) -> sp.Expr:
        """φ_j(A_j x, u) as an expression in the states and inputs."""
        ax = (self.row * sp.Matrix(states))[0, 0]
        return self.function.xreplace({self.argument: ax})


@dataclasses.dataclass(frozen=True)
class Structure:
    """The matrices of METHOD §1 extracted from a :class:`PlantModel`."""

    model: PlantModel
    F: sp.ImmutableMatrix
    G: sp.ImmutableMatrix
    H: sp.ImmutableMatrix
    C: sp.ImmutableMatrix
    D: sp.ImmutableMatrix
    L: sp.ImmutableMatrix
    W: sp.ImmutableMatrix
    terms: tuple  # of NonlinearTerm
    #: the model certificate (:func:`extract_structure` always sets it; None for a
    #: structure built from known matrices, e.g. :func:`~observer_cad.model.random_structure`)
    certificate: ModelCertificate | None = None
    #: feedthrough to the outputs: y = H x + Gy u + Dy d + Ly rho + W w (zero when absent)
    Gy: sp.ImmutableMatrix | None = None
    Dy: sp.ImmutableMatrix | None = None
    Ly: sp.ImmutableMatrix | None = None
    #: process noise in the dynamics: x' = ... + Bw w (zero when absent)
    Bw: sp.ImmutableMatrix | None = None

    def __post_init__(self) -> None:
        l, n = self.H.shape[0], self.F.shape[0]
        for name, shape in (("Gy", (l, self.G.shape[1])), ("Dy", (l, self.D.shape[1])),
                            ("Ly", (l, self.L.shape[1])), ("Bw", (n, self.W.shape[1]))):
            if getattr(self, name) is None:
                object.__setattr__(self, name, sp.ImmutableMatrix(sp.zeros(*shape)))

    @property
    def has_feedthrough(self) -> bool:
        """True when inputs, faults or disturbances enter the outputs (Gy, Dy, Ly ≠ 0)."""
        return not (self.Gy.is_zero_matrix and self.Dy.is_zero_matrix
                    and self.Ly.is_zero_matrix)

    def output_columns(self, names) -> sp.ImmutableMatrix:
        """Columns of Dy or Ly for the named faults / disturbances, in that order (the
        outputs' counterpart of :meth:`unknown_input_columns`)."""
        cols = []
        for name in names:
            sym = self.model.symbol(name) if isinstance(name, str) else name
            if sym in self.model.faults:
                cols.append(self.Dy[:, self.model.faults.index(sym)])
            elif sym in self.model.disturbances:
                cols.append(self.Ly[:, self.model.disturbances.index(sym)])
            else:
                raise ModelError(f"{self.model.where}: '{name}' is not a fault or disturbance")
        if not cols:
            return sp.ImmutableMatrix(sp.zeros(self.l, 0))
        return sp.ImmutableMatrix(sp.Matrix.hstack(*cols))

    @property
    def n(self) -> int:
        return self.F.shape[0]

    @property
    def l(self) -> int:  # noqa: E743 - the papers' name for the output dimension
        return self.H.shape[0]

    @property
    def is_linear(self) -> bool:
        return not self.terms

    @property
    def A(self) -> sp.ImmutableMatrix:
        """The argument rows A_j stacked (q×n)."""
        n = self.n
        if not self.terms:
            return sp.ImmutableMatrix(sp.zeros(0, n))
        return sp.ImmutableMatrix(sp.Matrix.vstack(*[t.row for t in self.terms]))

    def psi(self) -> sp.ImmutableMatrix:
        """Ψ(x, u) as a column of expressions in the states and inputs."""
        return sp.ImmutableMatrix([t.of_state(self.model.states) for t in self.terms])

    def unknown_input_columns(self, names) -> sp.ImmutableMatrix:
        """Columns of D or L for the named faults / disturbances, in that order."""
        cols = []
        for name in names:
            sym = self.model.symbol(name) if isinstance(name, str) else name
            if sym in self.model.faults:
                cols.append(self.D[:, self.model.faults.index(sym)])
            elif sym in self.model.disturbances:
                cols.append(self.L[:, self.model.disturbances.index(sym)])
            else:
                raise ModelError(f"{self.model.where}: '{name}' is not a fault or disturbance")
        if not cols:
            return sp.ImmutableMatrix(sp.zeros(self.n, 0))
        return sp.ImmutableMatrix(sp.Matrix.hstack(*cols))

    def rhs(self) -> sp.ImmutableMatrix:
        """F x + G u + C Ψ + D d + L ρ + Bw w rebuilt from the matrices (for checks).

        Built row by row from the nonzero entries (``Add`` of products), which is much
        cheaper than matrix products of long symbolic sums."""
        m = self.model
        psi = list(self.psi()) if self.terms else []
        return _rebuilt(self.n, [(self.F, m.states), (self.G, m.inputs), (self.C, psi),
                                 (self.D, m.faults), (self.L, m.disturbances),
                                 (self.Bw, m.noise)])

    def outputs_rebuilt(self) -> sp.ImmutableMatrix:
        """H x + Gy u + Dy d + Ly ρ + W w rebuilt from the matrices (for checks)."""
        m = self.model
        return _rebuilt(self.H.rows, [(self.H, m.states), (self.Gy, m.inputs),
                                      (self.Dy, m.faults), (self.Ly, m.disturbances),
                                      (self.W, m.noise)])


def _rebuilt(rows: int, blocks) -> sp.ImmutableMatrix:
    """Σ_blocks M v, row by row, from each matrix's nonzero entries."""
    parts: list = [[] for _ in range(rows)]
    for M, v in blocks:
        for (i, j), c in sp.ImmutableMatrix(M).todok().items():
            if c != 0:
                parts[i].append(c * v[j])
    return sp.ImmutableMatrix([sp.Add(*p) for p in parts])


def _split(t, varset):
    """(coefficient, variable part) of a product term: ``as_independent`` without its
    cost for the common case of a number or parameter times one factor."""
    if t.is_Symbol:
        return (sp.Integer(1), t) if t in varset else (t, sp.Integer(1))
    if t.is_Mul:
        dep = [a for a in t.args if a.free_symbols & varset]
        if not dep:
            return t, sp.Integer(1)
        rest = [a for a in t.args if not (a.free_symbols & varset)]
        coef = sp.Mul(*rest) if rest else sp.Integer(1)
        return coef, (dep[0] if len(dep) == 1 else sp.Mul(*dep))
    if not (t.free_symbols & varset):
        return t, sp.Integer(1)
    return sp.Integer(1), t


def _number_times_variable(e, where: dict):
    """``[((matrix, column), number), …]`` when every term of e is a number times one
    variable in ``where`` (or the variable alone), else None (then the general path
    decides). Linear equations with numeric coefficients are read off without
    ``expand`` or ``free_symbols`` (a 300-state model: 0.2 s instead of 30 s)."""
    out = []
    for t in sp.Add.make_args(e):
        if t.is_Symbol:
            slot = where.get(t)
            if slot is None:
                return None
            out.append((slot, sp.Integer(1)))
        elif t.is_Mul and len(t.args) == 2 and t.args[0].is_Number and t.args[1].is_Symbol:
            slot = where.get(t.args[1])
            if slot is None:
                return None
            out.append((slot, t.args[0]))
        else:
            return None
    return out


def _accumulate(lin, i: int) -> None:
    """Add the coefficients ``[((matrix, column), c), …]`` into row i (a plain store when
    the entry is still zero: a sympy addition costs more than reading the term)."""
    zero = sp.S.Zero
    for (mat, k), c in lin:
        row = mat[i]
        row[k] = c if row[k] is zero else row[k] + c


def _is_const(e, variables) -> bool:
    return not (e.free_symbols & variables)


def _distributed_terms(e, varset) -> list:
    """The additive terms of e as (coefficient free of the variables, variable part), with
    every variable-free factor distributed over the sums it multiplies, at any depth:
    ``f2 + (u − x/a − f1)/b`` gives (1, f2), (1/b, u), (−1/(a b), x), (−1/b, f1). The
    coefficients stay as written (``(a + b)²`` is not expanded); a variable part that is
    not a sum (``√(x1 − x2)``, ``x u``, ``(x + 1)²``) is one term."""
    out = []
    stack = [(sp.Integer(1), e)]
    while stack:
        c, t = stack.pop()
        if t.is_Add:
            stack.extend((c, a) for a in reversed(t.args))
            continue
        coef, part = _split(t, varset)
        if part.is_Add:  # a constant times a sum: distribute over the sum's terms
            stack.extend((c * coef, a) for a in reversed(part.args))
            continue
        out.append((c * coef, part))
    return out


def _affine_in_x(e, xs, variables):
    """(row, offset) if e is affine in the states with constant coefficients, else None."""
    if _is_const(e, set(xs)):
        return None
    row = [sp.diff(e, x) for x in xs]
    if any(not _is_const(c, variables) for c in row):
        return None
    offset = sp.expand(e - sum(c * x for c, x in zip(row, xs)))
    if not _is_const(offset, variables):
        return None
    return row, offset


def _leaves(e, xs, variables, out):
    """Maximal subexpressions of e that are affine in the states."""
    if _is_const(e, set(xs)):
        return
    if not isinstance(e, sp.Expr):  # Piecewise conditions, relations, tuples: look inside
        for a in e.args:
            _leaves(a, xs, variables, out)
        return
    aff = _affine_in_x(e, xs, variables)
    if aff is not None:
        out.append((e, aff))
        return
    for a in e.args:
        _leaves(a, xs, variables, out)


def _argument(m, xs, variables):
    """``(function of s, s, row A_j)`` for a nonlinear term's variable part m: the maximal
    subexpressions of m affine in the states must all be multiples of one row A_j (plus
    constants), and s stands for A_j x; or a string saying why m is not φ(A x, u)."""
    leaves: list = []
    _leaves(m, xs, variables, leaves)
    s = sp.Dummy("s")
    if not leaves:  # depends on u only (or constant): A_j = 0
        return m, s, [sp.Integer(0)] * len(xs)
    row0 = leaves[0][1][0]
    k0 = next(k for k, c in enumerate(row0) if c != 0)
    repl = {}
    for expr, (row_l, off) in leaves:
        scale = sp.cancel(row_l[k0] / row0[k0])
        if any(sp.cancel(a - scale * b) != 0 for a, b in zip(row_l, row0)):
            return (f"its argument is not one linear form in the states (it depends on"
                    f" {leaves[0][0]} and on {expr} separately)")
        repl[expr] = scale * s + off
    fn = m.xreplace(repl)
    if fn.free_symbols & set(xs):
        return "its argument is not linear in the states"
    return fn, s, list(row0)


def _expanded_terms(coef, part, slots, xs, variables) -> list:
    """The terms ``(coefficient, variable part, argument or None)`` of one distributed term
    ``coef · part``: the variable part expanded (:data:`EXPAND_HINTS`) when that exposes
    terms linear in a variable — ``(x + 1)²`` holds 2x, ``x (u + 1)`` holds x — so that no
    linear term is taken for Ψ. The nonlinear rest stays expanded when each of its terms
    is φ(A x, u) (``x u``); else it stays whole, ``part`` minus its linear terms, with
    the argument recognised on ``part`` (``(x1 − x2 + 1)²`` is φ(s) = (s + 1)² − 2s,
    s = x1 − x2, and 2 x1 − 2 x2 goes to F): the linear terms in the states of a
    φ(A x, u) are a multiple of A x. The argument is None where it is still to be
    recognised."""
    if part.is_Symbol or part == 1:
        return [(coef, part, None)]
    monomials = [_split(t, variables)
                 for t in sp.Add.make_args(sp.expand(part, **EXPAND_HINTS))]
    linear = [(c, v) for c, v in monomials if v in slots]
    if not linear:
        return [(coef, part, None)]
    rest = [v for _, v in monomials if v not in slots]
    found = [_argument(v, xs, variables) for v in rest]
    if not any(isinstance(a, str) for a in found):
        args = dict(zip(rest, found))
        return [(coef * c, v, args.get(v)) for c, v in monomials]
    whole = _argument(part, xs, variables)
    if isinstance(whole, str):  # not φ(A x, u) either way: the term as written is named
        return [(coef, part, None)]
    fn, s, row = whole
    k0 = next((k for k, a in enumerate(row) if a != 0), None)
    lin_x = {v: c for c, v in linear if v in xs}
    beta = sp.Integer(0) if k0 is None else lin_x.get(xs[k0], sp.Integer(0)) / row[k0]
    if any(sp.cancel(lin_x.get(x, 0) - beta * a) != 0 for x, a in zip(xs, row)):
        return [(coef, part, None)]  # (cannot happen for a φ(A x, u); kept whole if it does)
    others = sp.Add(*[c * v for c, v in linear if v not in lin_x])
    remainder = part - sp.Add(*[c * v for c, v in linear])
    return [(coef * c, v, None) for c, v in linear] + [
        (coef, remainder, (fn - beta * s - others, s, row))]


def _linear_in_disguise(m, variables):
    """``{variable: coefficient}, constant`` when the nonlinear-looking m is affine in the
    variables once its fraction is cancelled (``(x² − 1)/(x − 1)`` is x + 1), else None."""
    vs = sorted(m.free_symbols & variables, key=str)
    if not vs or not m.is_rational_function(*vs):
        return None
    num, den = sp.fraction(sp.cancel(sp.together(m)))
    if den.free_symbols & variables:
        return None
    p = sp.Poly(num, *vs)
    if p.total_degree() > 1:
        return None
    coeffs = {v: sp.cancel(p.coeff_monomial(v) / den) for v in vs}
    return {v: c for v, c in coeffs.items() if c != 0}, sp.cancel(p.coeff_monomial(1) / den)


class _Collected:
    """The right-hand side read term by term (not a value: filled equation by equation):
    F, G, D, L as lists of rows (a sympy Matrix's item assignment costs ~0.1 ms, 10 s for
    a 300-state model; made matrices at the end), the slot (matrix, column) of every
    variable that enters linearly, and the nonlinear columns — their variable parts m in
    order of appearance, the column of each, the coefficients C_ij and each column's
    (φ in s, s, row A_j)."""

    def __init__(self, model: PlantModel):
        xs, us = model.states, model.inputs
        ds, rs = model.faults, model.disturbances
        n = len(xs)
        zero = sp.Integer(0)
        self.F = [[zero] * n for _ in range(n)]
        self.G = [[zero] * len(us) for _ in range(n)]
        self.D = [[zero] * len(ds) for _ in range(n)]
        self.L = [[zero] * len(rs) for _ in range(n)]
        self.Bw = [[zero] * len(model.noise) for _ in range(n)]
        self.simple = {}  # variable -> (matrix, column)
        for mat, syms in ((self.F, xs), (self.G, us), (self.D, ds), (self.L, rs),
                          (self.Bw, model.noise)):
            for k, v in enumerate(syms):
                self.simple[v] = (mat, k)
        self.funcs: list = []  # m (x,u-dependent part) per column, in order of appearance
        self.index: dict = {}  # m -> column j
        self.coeffs: dict = {}  # (i, j) -> coefficient
        self.info: list = []  # (function expr in s, s, row) per column


def _check_nonlinear_term(t, m, eq, model: PlantModel, variables, where) -> None:
    """Step 2: in a nonlinear term t = c·m, unknown inputs must enter linearly with
    constant coefficients (D, L constant); controls affinely (φ(A x, u) may hold u)."""
    us, ds = model.inputs, model.faults
    unknown = set(ds) | set(model.disturbances) | set(model.noise)
    for sym in sorted(m.free_symbols & unknown, key=str):
        role = "fault" if sym in ds else "noise" if sym in model.noise else "disturbance"
        k = sp.diff(t, sym)
        bad = k.free_symbols & variables
        if bad & (set(us) | unknown):
            raise ModelError(
                f"{where}: {eq} is not affine in {role} '{sym}' (its coefficient"
                f" {k} depends on '{sorted(bad, key=str)[0]}')")
        raise ModelError(
            f"{where}: {eq}: {role} '{sym}' enters with the coefficient {k}, which"
            f" depends on state '{sorted(bad, key=str)[0]}'; it must be constant")
    for sym in sorted(m.free_symbols & set(us), key=str):
        k = sp.diff(t, sym)
        bad = k.free_symbols & (set(us) | unknown)
        if bad:
            raise ModelError(
                f"{where}: {eq} is not affine in input '{sym}' (its coefficient {k}"
                f" depends on '{sorted(bad, key=str)[0]}')")


def _read_dynamics(model: PlantModel, variables, where) -> _Collected:
    """Steps 1 and 2 for every equation: additive terms with constant factors
    distributed and linear terms exposed; linear ones to F, G, D, L, nonlinear ones
    checked and collected by their variable part (the argument row A_j recognised once)."""
    xs = model.states
    n = len(xs)
    got = _Collected(model)
    simple = got.simple
    for i, (x_i, f) in enumerate(zip(xs, model.dynamics)):
        eq = f"dynamics equation {i + 1} (for {x_i})"
        report(f"extracting the structure of {model.name}: equation {i + 1} of {n}")

        lin = _number_times_variable(f, simple)
        if lin is not None:  # fast path: every term is a number times one variable
            _accumulate(lin, i)
            continue
        # Step 1: additive terms, constant factors distributed, linear terms exposed
        terms = [t for c, p in _distributed_terms(f, variables)
                 for t in _expanded_terms(c, p, simple, xs, variables)]
        for c, m, known in terms:
            if c == 0:
                continue
            if m in simple:  # linear: a constant times one variable
                _accumulate([(simple[m], c)], i)
                continue
            # Step 2: a nonlinear term
            t = c * m
            _check_nonlinear_term(t, m, eq, model, variables, where)
            if m not in got.index:  # recognise the argument row A_j
                found = known if known is not None else _argument(m, xs, variables)
                if isinstance(found, str):
                    raise ModelError(f"{where}: {eq}: the nonlinear term {t} is not of the"
                                     f" form phi(A x, u): {found}")
                got.index[m] = len(got.funcs)
                got.funcs.append(m)
                got.info.append(list(found))
            j = got.index[m]
            got.coeffs[(i, j)] = got.coeffs.get((i, j), 0) + c
    return got


def _linear_after_all(got: _Collected, variables, n: int) -> None:
    """A nonlinear-looking term that is affine once cancelled is linear after all: its
    coefficients move to F, G, D, L (a constant to a constant column)."""
    zero = sp.Integer(0)
    funcs, index, coeffs, info = got.funcs, got.index, got.coeffs, got.info
    for j, m in enumerate(funcs):
        affine = _linear_in_disguise(m, variables)
        if affine is None:
            continue
        lin_part, const = affine
        for (i, jj), c in list(coeffs.items()):
            if jj != j:
                continue
            _accumulate([(got.simple[v], c * a) for v, a in lin_part.items()], i)
            del coeffs[(i, jj)]
            if const != 0:
                if sp.Integer(1) not in index:
                    index[sp.Integer(1)] = len(funcs)
                    funcs.append(sp.Integer(1))
                    info.append([sp.Integer(1), sp.Dummy("s"), [zero] * n])
                k = index[sp.Integer(1)]
                coeffs[(i, k)] = coeffs.get((i, k), 0) + c * const


def _nonlinear_columns(got: _Collected, n: int) -> tuple:
    """C from the collected coefficients, without the columns that cancelled out
    entirely: (C, info of the columns kept)."""
    q = len(got.funcs)
    C = sp.zeros(n, q)
    for (i, j), c in got.coeffs.items():
        C[i, j] = c
    keep = [j for j in range(q) if any(sp.cancel(C[i, j]) != 0 for i in range(n))]
    C = C[:, keep] if keep else sp.zeros(n, 0)
    return C, [got.info[j] for j in keep]


def _own_linear_part(model: PlantModel, F, C, info, n: int, where) -> sp.Matrix:
    """Step 3: the model's own linear/nonlinear split: the difference from the
    right-hand side's linear part absorbed into the nonlinear functions as formal terms
    β_j A_j x (``info`` updated). Returns the F to use."""
    if model.linear_part is None:
        return F
    F_user = sp.Matrix(model.linear_part)
    delta = F - F_user
    if any(sp.cancel(e) != 0 for e in delta):
        betas = sp.symbols(f"beta0:{len(info)}")
        resid = delta - sum(
            (b * C[:, j] * sp.Matrix([info[j][2]]) for j, b in enumerate(betas)), sp.zeros(n, n))
        sol = sp.solve(list(resid), betas, dict=True) if betas else []
        if not sol:
            raise ModelError(
                f"{where}: linear_part cannot be split off: the difference from the"
                " right-hand side's own linear part is not a combination β_j C_j A_j"
                " of the nonlinear terms' columns and arguments")
        sol = sol[0]
        for j, b in enumerate(betas):
            beta = sp.cancel(sol.get(b, 0).xreplace({bb: 0 for bb in betas}))
            info[j][0] = info[j][0] + beta * info[j][1]
        F = F_user
    return F


def _read_outputs(model: PlantModel, where) -> tuple:
    """Outputs: y = H x + Gy u + Dy d + Ly ρ + W w, term by term (cheap for long
    outputs): (H, W, Gy, Dy, Ly) as exact matrices. Every term is a constant times one
    variable; anything else (a product, a constant offset) is refused in one line."""
    xs = model.states
    l = len(model.outputs)  # noqa: E741
    zero = sp.Integer(0)
    groups = (xs, model.noise, model.inputs, model.faults, model.disturbances)
    mats = [[[zero] * len(g) for _ in model.outputs] for g in groups]
    out_simple = {v: (M, k) for M, g in zip(mats, groups) for k, v in enumerate(g)}
    all_set = set(out_simple)
    for i, h in enumerate(model.outputs):
        name = f"y{i + 1}"
        lin = _number_times_variable(h, out_simple)
        if lin is not None:
            _accumulate(lin, i)
            continue
        for coef, part in _distributed_terms(h, all_set):
            for t in sp.Add.make_args(sp.expand(part, **EXPAND_HINTS)):
                c, m = _split(t, all_set)
                c = coef * c
                if c == 0:
                    continue
                if m in out_simple:
                    _accumulate([(out_simple[m], c)], i)
                elif m == 1:
                    raise ModelError(f"{where}: output {name} = {h} has a constant offset {c}")
                elif m.free_symbols & set(xs):
                    raise ModelError(f"{where}: output {name} = {h} is not linear in the states")
                else:
                    v = sorted(m.free_symbols & all_set, key=str)[0]
                    raise ModelError(f"{where}: output {name} = {h} is not linear in the"
                                     f" {model.role_of(v).rstrip('s')} '{v}' (outputs are"
                                     " linear: H x + Gy u + Dy d + Ly rho + W w)")
    return tuple(exact_matrix(l, len(g), [e for row in M for e in row])
                 for M, g in zip(mats, groups))


def extract_structure(model: PlantModel) -> Structure:
    """Recognise F, G, H, C, D, L, W, Bw and the nonlinear terms of a model, and certify them.

    Every right-hand side is split into additive terms with constant factors distributed
    over sums (``(u − x/a − f1)/b`` is u/b − x/(a b) − f1/b) and products and integer
    powers of the variables expanded where that exposes a linear term; what is linear in
    one variable with a constant coefficient goes to F, G, D, L, the rest (grouped by its
    variable part) to C Ψ. The result carries its :class:`ModelCertificate`: the matrices
    rebuild every equation exactly (or, where algebra cannot decide, at random rational
    points, said so).

    Raises :class:`ModelError` (one line, naming the equation and symbol) when the
    right-hand side is not affine in u, d or ρ in the required way, when an output
    is not linear in the states, when a nonlinear term's argument is not a single
    linear form in the states, or when the extracted matrices do not rebuild an equation
    (naming the term they lose).
    """
    where = model.where
    xs, us = model.states, model.inputs
    ds, rs = model.faults, model.disturbances
    variables = set(xs) | set(us) | set(ds) | set(rs) | set(model.noise)
    n = len(xs)
    got = _read_dynamics(model, variables, where)
    _linear_after_all(got, variables, n)
    F, G, D, L, Bw = (exact_matrix(n, len(v), [e for row in M for e in row])
                      for M, v in ((got.F, xs), (got.G, us), (got.D, ds), (got.L, rs),
                                   (got.Bw, model.noise)))
    C, info = _nonlinear_columns(got, n)
    F = _own_linear_part(model, F, C, info, n, where)
    # normalise signs: first nonzero entry of each C column not negative
    for j in range(C.shape[1]):
        first = next((C[i, j] for i in range(n) if C[i, j] != 0), None)
        if first is not None and first.could_extract_minus_sign():
            C[:, j] = -C[:, j]
            info[j][0] = -info[j][0]
    H, W, Gy, Dy, Ly = _read_outputs(model, where)
    terms = tuple(NonlinearTerm(fn, s, sp.ImmutableMatrix([row]))
                  for fn, s, row in info)
    C = exact_matrix(*C.shape, list(C)) if not isinstance(C, sp.ImmutableMatrix) else C
    st = Structure(model, *(sp.ImmutableMatrix(M) for M in (F, G, H, C, D, L, W)), terms,
                   Bw=sp.ImmutableMatrix(Bw), Gy=Gy, Dy=Dy, Ly=Ly)
    return dataclasses.replace(st, certificate=certify_structure(st))


def certify_structure(st: Structure) -> "ModelCertificate":
    """The model certificate of an extracted structure (METHOD §1)::

        F x + G u + C Ψ(A x, u) + D d + L ρ + Bw w − f(x, u, d, ρ, w) ≡ 0,
        H x + Gy u + Dy d + Ly ρ + W w − h(x, u, d, ρ, w) ≡ 0

    each equation and output decided by :func:`is_identically_zero` (exactly, with the
    parameters kept as symbols; else numerically at random rational points, said so).
    Raises :class:`ModelError` naming the first equation the matrices do not rebuild and
    the terms they lose."""
    m = st.model
    rebuilt = st.rhs()
    outs = st.outputs_rebuilt()
    checks = []
    pairs = [(f"dynamics equation {i + 1} (for {x})", r, f)
             for i, (x, r, f) in enumerate(zip(m.states, rebuilt, m.dynamics))]
    pairs += [(f"output y{i + 1}", r, h) for i, (r, h) in enumerate(zip(outs, m.outputs))]
    for name, r, f in pairs:
        test = is_identically_zero(r - f, scale=(f,))
        if not test.holds:
            lost = sp.Add.make_args(sp.expand(f - r, **EXPAND_HINTS))
            shown = ", ".join(str(t) for t in lost[:3]) + (", …" if len(lost) > 3 else "")
            raise ModelError(
                f"{m.where}: {name}: the extracted structure does not rebuild it"
                f" ({test.how}); the terms lost: {shown}")
        checks.append(EquationCheck(name, test.exact, test.how))
    return ModelCertificate(tuple(checks))
