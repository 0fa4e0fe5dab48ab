"""Structure extraction: from a model's right-hand side to F, G, H, C, D, L and Ψ.

METHOD §1::

    x' = F x + G u + C Ψ(x, u) + D d + L ρ,     y = H x + W w
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
from ._matrices import exact_matrix
from ._plant import PlantModel

__all__ = ["NonlinearTerm", "Structure", "extract_structure"]


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
        """F x + G u + C Ψ + D d + L ρ rebuilt from the matrices (for checks).

        Built row by row from the nonzero entries (``Add`` of products), which is much
        cheaper than matrix products of long symbolic sums."""
        m = self.model
        psi = list(self.psi()) if self.terms else []
        blocks = [(self.F, m.states), (self.G, m.inputs), (self.C, psi),
                  (self.D, m.faults), (self.L, m.disturbances)]
        rows = []
        for i in range(self.n):
            parts = []
            for M, v in blocks:
                for j, s in enumerate(v):
                    c = M[i, j]
                    if c != 0:
                        parts.append(c * s)
            rows.append(sp.Add(*parts))
        return sp.ImmutableMatrix(rows)


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


def extract_structure(model: PlantModel) -> Structure:
    """Recognise F, G, H, C, D, L, W and the nonlinear terms of a model.

    Raises :class:`ModelError` (one line, naming the equation and symbol) when the
    right-hand side is not affine in u, d or ρ in the required way, when an output
    is not linear in the states, or when a nonlinear term's argument is not a single
    linear form in the states.
    """
    where = model.where
    xs, us = model.states, model.inputs
    ds, rs = model.faults, model.disturbances
    variables = set(xs) | set(us) | set(ds) | set(rs) | set(model.noise)
    n = len(xs)
    zero = sp.Integer(0)
    # filled entry by entry as lists (a sympy Matrix's item assignment costs ~0.1 ms,
    # 10 s for a 300-state model), made matrices after the loop
    F = [[zero] * n for _ in range(n)]
    G = [[zero] * len(us) for _ in range(n)]
    D = [[zero] * len(ds) for _ in range(n)]
    L = [[zero] * len(rs) for _ in range(n)]
    simple = {}  # variable -> (matrix, column) for the fast path of linear equations
    for mat, syms in ((F, xs), (G, us), (D, ds), (L, rs)):
        for k, v in enumerate(syms):
            simple[v] = (mat, k)
    xu_set = set(xs) | set(us)
    x_pos = {x: k for k, x in enumerate(xs)}
    u_pos = {u: k for k, u in enumerate(us)}
    funcs: list = []  # m (x,u-dependent part) per column, in order of appearance
    index: dict = {}  # m -> column j
    coeffs: dict = {}  # (i, j) -> coefficient
    info: list = []  # (function expr in s, s, row) per column

    for i, (x_i, f) in enumerate(zip(xs, model.dynamics)):
        eq = f"dynamics equation {i + 1} (for {x_i})"
        report(f"extracting the structure of {model.name}: equation {i + 1} of {n}")

        lin = _number_times_variable(f, simple)
        if lin is not None:  # fast path: every term is a number times one variable
            _accumulate(lin, i)
            continue
        terms = sp.Add.make_args(sp.expand(f, deep=False))
        fsyms = f.free_symbols

        def part(sym):  # only the terms that contain sym (cheap for long equations)
            return sp.Add(*[t for t in terms if sym in t.free_symbols])
        # Step 1: controls enter affinely (their coefficient may depend on x: φ(A x, u));
        # unknown inputs enter affinely with constant coefficients (D, L constant)
        for sym in us:
            if sym not in fsyms:
                continue
            c = sp.diff(part(sym), sym)
            bad = c.free_symbols & (set(us) | set(ds) | set(rs))
            if bad:
                raise ModelError(
                    f"{where}: {eq} is not affine in input '{sym}' (its coefficient {c}"
                    f" depends on '{sorted(bad, key=str)[0]}')")
        for sym, mat, role in [(s, D, "fault") for s in ds] + [(s, L, "disturbance") for s in rs]:
            if sym not in fsyms:
                continue
            c = sp.diff(part(sym), sym)
            bad = c.free_symbols & variables
            if bad & (set(us) | set(ds) | set(rs)):
                raise ModelError(
                    f"{where}: {eq} is not affine in {role} '{sym}' (its coefficient"
                    f" {c} depends on '{sorted(bad, key=str)[0]}')")
            if bad:
                raise ModelError(
                    f"{where}: {eq}: {role} '{sym}' enters with the coefficient {c}, which"
                    f" depends on state '{sorted(bad, key=str)[0]}'; it must be constant")
            idx = (ds if role == "fault" else rs).index(sym)
            mat[i][idx] = c
        # every term with d or ρ is c·d (checked above): the rest is what remains
        unknown = set(ds) | set(rs)
        rest_terms = [t for t in terms if not (t.free_symbols & unknown)]
        # Step 2: linear terms in x and u, the rest nonlinear
        for t in rest_terms:
            if t == 0:
                continue
            coef, m = _split(t, xu_set)
            if m in x_pos or m in u_pos:
                if not _is_const(coef, variables):  # pragma: no cover - guarded by _split
                    raise ModelError(f"{where}: {eq}: term {t} is not linear")
                if m in x_pos:
                    F[i][x_pos[m]] += coef
                else:
                    G[i][u_pos[m]] += coef
                continue
            if m.free_symbols & (set(ds) | set(rs)):  # pragma: no cover - caught in step 1
                raise ModelError(f"{where}: {eq} is not affine in the unknown inputs: {t}")
            if m not in index:
                # recognise the argument row A_j
                leaves: list = []
                _leaves(m, xs, variables, leaves)
                s = sp.Dummy("s")
                if not leaves:  # depends on u only (or constant): A_j = 0
                    row = [sp.Integer(0)] * n
                    fn = m
                else:
                    row0 = leaves[0][1][0]
                    k0 = next(k for k, c in enumerate(row0) if c != 0)
                    repl = {}
                    for expr, (row_l, off) in leaves:
                        scale = sp.cancel(row_l[k0] / row0[k0])
                        if any(sp.cancel(a - scale * b) != 0 for a, b in zip(row_l, row0)):
                            raise ModelError(
                                f"{where}: {eq}: the nonlinear term {t} is not of the form"
                                f" phi(A x, u): its argument is not one linear form in the"
                                f" states (it depends on {leaves[0][0]} and on {expr} separately)")
                        repl[expr] = scale * s + off
                    fn = m.xreplace(repl)
                    if fn.free_symbols & set(xs):
                        raise ModelError(
                            f"{where}: {eq}: the argument of the nonlinear term {t} is not"
                            " linear in the states")
                    row = row0
                index[m] = len(funcs)
                funcs.append(m)
                info.append([fn, s, list(row)])
            j = index[m]
            coeffs[(i, j)] = coeffs.get((i, j), 0) + coef

    F, G, D, L = (exact_matrix(n, len(v), [e for row in M for e in row])
                  for M, v in ((F, xs), (G, us), (D, ds), (L, rs)))
    q = len(funcs)
    C = sp.zeros(n, q)
    for (i, j), c in coeffs.items():
        C[i, j] = c
    # drop columns that cancelled out entirely
    keep = [j for j in range(q) if any(sp.cancel(C[i, j]) != 0 for i in range(n))]
    C = C[:, keep] if keep else sp.zeros(n, 0)
    info = [info[j] for j in keep]

    # Step 3: the model's own linear/nonlinear split (formal terms β_j A_j x)
    if model.linear_part is not None:
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

    # normalise signs: first nonzero entry of each C column not negative
    for j in range(C.shape[1]):
        first = next((C[i, j] for i in range(n) if C[i, j] != 0), None)
        if first is not None and first.could_extract_minus_sign():
            C[:, j] = -C[:, j]
            info[j][0] = -info[j][0]

    # Outputs: y = H x + W w (term by term: cheap for long outputs)
    H = [[zero] * n for _ in model.outputs]
    W = [[zero] * len(model.noise) for _ in model.outputs]
    xidx = {x: k for k, x in enumerate(xs)}
    widx = {w: k for k, w in enumerate(model.noise)}
    out_simple = {x: (H, k) for x, k in xidx.items()}
    out_simple.update({w: (W, k) for w, k in widx.items()})
    xw_set = set(xs) | set(model.noise)
    for i, h in enumerate(model.outputs):
        name = f"y{i + 1}"
        lin = _number_times_variable(h, out_simple)
        if lin is not None:
            _accumulate(lin, i)
            continue
        for t in sp.Add.make_args(sp.expand(h)):
            if t == 0:
                continue
            coef, m = _split(t, xw_set)
            if m in xidx and _is_const(coef, variables):
                H[i][xidx[m]] += coef
            elif m in widx and _is_const(coef, variables):
                W[i][widx[m]] += coef
            elif m == 1:
                raise ModelError(f"{where}: output {name} = {h} has a constant offset {t}")
            elif m.free_symbols & set(xs):
                raise ModelError(f"{where}: output {name} = {h} is not linear in the states")
            else:
                w = sorted(m.free_symbols & set(model.noise), key=str)[0]
                raise ModelError(f"{where}: output {name} = {h} is not linear in the noise '{w}'")

    H = exact_matrix(len(model.outputs), n, [e for row in H for e in row])
    W = exact_matrix(len(model.outputs), len(model.noise), [e for row in W for e in row])
    terms = tuple(NonlinearTerm(fn, s, sp.ImmutableMatrix([row]))
                  for fn, s, row in info)
    C = exact_matrix(*C.shape, list(C)) if not isinstance(C, sp.ImmutableMatrix) else C
    st = Structure(model, *(sp.ImmutableMatrix(M) for M in (F, G, H, C, D, L, W)), terms)
    # self-check: the matrices rebuild the right-hand side exactly (rows with nonlinear
    # terms, where grouping and the formal-term split happened; linear rows were read
    # off term by term)
    nl_rows = [i for i in range(n) if any(st.C[i, j] != 0 for j in range(st.C.shape[1]))]
    rebuilt = st.rhs() if nl_rows else []
    for i in nl_rows:
        f = model.dynamics[i]
        e = rebuilt[i] - f
        if e != 0 and sp.expand(e) != 0 and sp.simplify(e) != 0:  # pragma: no cover
            raise ModelError(
                f"{where}: internal error: extracted structure does not rebuild dynamics"
                f" equation {i + 1} (residual {e})")
    return st
