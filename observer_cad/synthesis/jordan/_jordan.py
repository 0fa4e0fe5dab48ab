"""Jordan-form synthesis (METHOD §2b, §2c): diagnostic observers, virtual sensors,
interval observers.

F* = diag(λ_1, …, λ_k), real and stable, so the defining equation splits by rows::

    (S_i, −J*_i) [L0 (F − λ_i I); H] = 0,     Φ_i = S_i L0

(seed 002 eq. (2.5); seed 000 eq. (8.2)). A λ is *admissible* when that stacked
matrix P(λ) loses row rank: for every λ (generic solvability, e.g. when it has more
rows than columns) or on the finite set of roots of the greatest common divisor of its
maximal minors, computed exactly here. Rows are then chosen — fewest first — so that

- diagnostic observer: every fault column is seen by some row (Φ_j D⁽ⁱ⁾ ≠ 0, seed 002
  Remark 1) and (R*, −H*) [H; Φ] = 0 is solvable: rank [Φ; H] < rank Φ + rank H (2.7);
- virtual sensor / interval observer for z = M x: rank [Φ; H] = rank [Φ; H; M] (3.2),
  then M = H_z Φ + Q H;
- nonlinear models: for every nonzero column j of C* = Φ C,
  rank [Φ; H] = rank [Φ; H; A_j], then A_j = A*_1j Φ + A*_2j H and
  Ψ*_j = φ_j(A*_1j x* + A*_2j y, u) (§2c).

Interval observers are not decoupled (L0 = I) and report L* = Φ L.
Stability is by construction (stable λ); no feedback is needed.

References: seed 002 §2-4, §6, §8; seed 001 §5; seed 000 §8.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from typing import Sequence

import numpy as np
import sympy as sp

from ...progress import report
from ..certificates import certify_design
from ..core import Condition, Design
from ...errors import ExpressionError, InfeasibleDesignError, UsageError
from ...model import ObserverKind, PlantModel, Task, parse_expression
from ..core import substitute_arguments
from ..core import default_eigenvalues
from ._lambda_search import family_jump_lambdas, one_row_lambdas, span_rows
from .minimality import (chain_order, estimation_order_bound, nonlinear_jordan_bound, one_more_row,
                         one_row_short, three_more_rows, two_more_rows, residual_order_bound,
                         spread_lambdas)
from ..core import is_stable, jordan_equations, observer_symbols, output_symbols
from ..certificates import residual_response
from ..core import task_for, task_parts
from ._float import design_jordan_float
from ..canonical import FLOAT_AUTO_N
from ...model import Structure, extract_structure
from ...numerics import (denominator_conditions, exact_product, exact_rank, exact_rank_value,
                         left_null_echelon, left_null_space, nonzero_conditions, solve_left)
from ...numerics import float_left_null_space, float_rank, rationalize_floats

__all__ = ["Admissible", "admissible_lambdas", "design_jordan", "design_jordan_unknown_input"]

LAMBDA = sp.Symbol("lambda")



@dataclasses.dataclass(frozen=True)
class Admissible:
    """Which λ make [L0 (F − λI); H] lose row rank."""

    generic: bool
    values: tuple  # real roots (exact) when not generic
    other_roots: tuple  # complex roots, reported, not usable (F* must be real)
    evidence: str

    def contains(self, lam) -> bool:
        if self.generic:
            return True
        lam = sp.sympify(lam)
        return any(_same_number(lam, v) for v in self.values)

    def describe(self) -> str:
        if self.generic:
            return "every λ (generic solvability)"
        vals = ", ".join(str(v) for v in self.values) or "none real"
        return f"λ ∈ {{{vals}}}"


def _pencil(F, H, L0, lam):
    n = F.rows
    return sp.Matrix.vstack(L0 * (F - lam * sp.eye(n)), H)


def _family(F, H, L0, lam) -> tuple:
    """The rows of λ: ``(Φ rows, J rows, pivot conditions)`` with Φ = S L0 and
    S L0 (F − λI) = J H, from the left null space of [L0 (F − λI); H] (nonzero Φ only)."""
    members, rkP = left_null_echelon(_pencil(F, H, L0, lam))
    rows_phi, rows_j = [], []
    for v in members:
        S, J = v[:, :L0.rows], -v[:, L0.rows:]
        Phi_i = (S * L0).applyfunc(sp.cancel)
        if Phi_i != sp.zeros(1, F.rows):
            rows_phi.append(Phi_i)
            rows_j.append(J.applyfunc(sp.cancel))
    return rows_phi, rows_j, rkP.conditions


def _det(M):
    """Determinant over the polynomial ring (fast, exact), as an expression."""
    from sympy.polys.matrices import DomainMatrix
    dm = DomainMatrix.from_Matrix(sp.Matrix(M))
    return dm.domain.to_sympy(dm.det()) if hasattr(dm.domain, "to_sympy") else dm.to_Matrix().det()


def admissible_lambdas(F, H, L0) -> Admissible:
    """Exactly: generic solvability, or the real roots where P(λ) drops row rank."""
    F, H, L0 = sp.Matrix(F), sp.Matrix(H), sp.Matrix(L0)
    n = F.rows
    P = _pencil(F, H, L0, LAMBDA)
    r = P.rows
    if r > n:
        return Admissible(True, (), (), f"[L0(F − λI); H] has {r} rows > {n} columns:"
                                        " a left null vector exists for every λ")
    gr = exact_rank(P)
    if gr.rank < r:
        return Admissible(True, (), (), f"rank [L0(F − λI); H] = {gr.rank} < {r} rows"
                                        " for λ as a free symbol")
    minors = []
    for cols in itertools.combinations(range(n), r):
        m = sp.expand(_det(P[:, list(cols)]))
        if m != 0:
            minors.append(m)
    g = minors[0]
    for m in minors[1:]:
        g = sp.gcd(g, m)
    g = sp.factor(g)
    if not g.has(LAMBDA):
        return Admissible(False, (), (), f"gcd of the maximal minors of [L0(F − λI); H] is"
                                         f" {g}, free of λ: no admissible λ")
    real, other = [], []
    _, factors = sp.factor_list(g, LAMBDA)
    for f, _mult in factors:
        deg = sp.degree(f, LAMBDA)
        if deg == 0:
            continue
        if deg <= 2:  # rational or quadratic roots: exact arithmetic stays cheap
            rts = list(sp.roots(sp.Poly(f, LAMBDA)).keys())
        elif not f.free_symbols - {LAMBDA}:
            rts = list(sp.Poly(f, LAMBDA).all_roots())  # CRootOf: reported, not used
        else:
            rts = []
        for rt in rts:
            real_ = rt.is_real
            if real_ or (real_ is None and rt.free_symbols):
                real.append(rt)
            else:
                other.append(rt)
    real.sort(key=lambda v: (bool(v.free_symbols), sp.re(v) if v.is_number else 0, str(v)))
    return Admissible(False, tuple(real), tuple(other),
                      f"gcd of the maximal minors of [L0(F − λI); H] = {g}")


def _rank(M) -> int:
    M = sp.Matrix(M)
    if M.rows == 0 or M.cols == 0:
        return 0
    return exact_rank_value(M)


def design_jordan(model: PlantModel, *, observer: str, estimate=None,
                  faults: Sequence[str] | None = None, decouple: Sequence[str] = (),
                  lambdas: Sequence | None = None, symbolic: bool = False,
                  structure: Structure | None = None, method: str = "auto",
                  rtol: float | None = None, task: Task | None = None) -> Design:
    """Jordan-form design of a diagnostic observer, virtual sensor or interval observer.

    Parameters
    ----------
    model : PlantModel
    observer : {"diagnostic", "virtual-sensor", "interval"}
    estimate : str or sympy expression or Matrix, for virtual sensors / interval observers
        z = M x, an expression in the state names (e.g. ``"x1"``).
    faults : names, optional (diagnostic)
        Faults the residual must detect (default: all the model's faults).
    decouple : names, optional
        Further inputs to decouple from (besides the model's disturbances). Interval
        observers are not decoupled: L0 = I and L* = Φ L is reported.
    lambdas : values, optional
        Requested eigenvalues; each is checked (admissible? stable?). Default: the
        admissible stable λ, or −1, −2, … (continuous) / 1/2, 1/4, … (discrete) when
        every λ is admissible.
    symbolic : bool
        Keep parameters as symbols (default: substitute their defaults).
    """
    if observer not in ("diagnostic", "virtual-sensor", "interval"):
        raise UsageError(f"Jordan form supports diagnostic, virtual-sensor and interval, not {observer!r}")
    task = task_for(model, task, observer=observer, faults=faults, disturbances=decouple,
                    estimate=estimate)
    if method not in ("auto", "exact", "float"):
        raise UsageError(f"method must be 'auto', 'exact' or 'float', got {method!r}")
    numeric_st = None  # the substituted model's structure, extracted once for both paths
    if method == "auto":  # large numeric linear models: the pencil numerically (with evidence)
        big = len(model.states) > FLOAT_AUTO_N and not (symbolic and model.parameters)
        if big:
            numeric_st = extract_structure(
                model.substitute_parameters() if model.parameters else model)
        method = "float" if big and numeric_st.is_linear else "exact"
    if method == "float":
        if symbolic and model.parameters:
            raise UsageError("the float path needs numeric parameters: design without --symbolic")
        return design_jordan_float(model, observer=observer, estimate=estimate, faults=faults,
                                   decouple=decouple, lambdas=lambdas, rtol=rtol, task=task,
                                   structure=numeric_st)
    work = model if symbolic else model.substitute_parameters()
    if structure is not None and symbolic:
        st = structure
    elif numeric_st is not None and not (symbolic and model.parameters):
        st = numeric_st  # the same substituted model: already extracted above
    else:
        st = extract_structure(work)
    where = model.where
    F, G, H, C = (sp.Matrix(M) for M in (st.F, st.G, st.H, st.C))
    n, l = st.n, st.l

    # Step 1: the task
    M, fault_syms, dec, D, L = task_parts(work, st, task)
    decoupled = observer != "interval"

    if M is not None:  # z already measured: say so rather than build a trivial observer
        X0 = solve_left(H, M)
        if X0 is not None:
            raise UsageError(f"{where}: z = {task.estimate} is measured directly: z = "
                             f"{sp.expand((X0 * sp.Matrix(output_symbols(l)))[0, 0])}; no observer is needed")

    # Step 2: L0 (maximal rank, L0 L = 0) and the admissible λ
    pivots: set = set()  # the pivots of the null spaces the design is built from
    if decoupled and L.cols:
        basis, rkL = left_null_space(L)
        pivots |= rkL.conditions
        L0 = sp.Matrix.vstack(*basis) if basis else sp.zeros(0, n)
    else:
        L0 = sp.eye(n)
    if L0.rows == 0:
        raise InfeasibleDesignError(f"{where}: the decoupled inputs ({', '.join(task.decoupled)})"
                                    " span the whole state space: no row Φ has Φ L = 0, so no"
                                    " decoupled observer exists")
    adm = admissible_lambdas(F, H, L0)
    conds = [Condition("admissible λ", adm.generic or bool(adm.values),
                       f"{adm.describe()}; {adm.evidence}"
                       + (f"; complex roots {', '.join(map(str, adm.other_roots))} are not usable"
                          if adm.other_roots else ""), "METHOD §2b; seed 002 eq. (2.5)")]
    one_row = jumps = None  # the special-λ analysis (every λ admissible, none requested)
    chains: list = []  # what each order m says about the λ a model of m rows needs
    extra: list = []
    if lambdas:
        lam_list = []
        for v in lambdas:
            try:
                lam = parse_expression(v, list(work.parameters), where="--lambda", allow_complex=True,
                                       allow_crootof=True)
            except ExpressionError as exc:
                raise UsageError(f"λ = {v!r} is not a number: {exc.reason}") from None
            if not isinstance(lam, sp.Expr) or lam.free_symbols - set(work.parameters):
                raise UsageError(f"λ = {v} is not a number (or a declared parameter with --symbolic)")
            if lam.is_number:
                if lam.is_real is False:
                    raise UsageError(f"λ = {v} is not real: the Jordan form needs real λ")
                lam = rationalize_floats(lam)  # a float λ by its decimal string; exact stays
            if not adm.contains(lam):
                raise InfeasibleDesignError(
                    f"{where}: λ = {lam} is not admissible: [L0(F − λI); H] has full row rank"
                    f" there (admissible: {adm.describe()})")
            stab = is_stable(lam, work.time)
            if stab is False:
                need = "λ < 0" if work.time == "continuous" else "|λ| < 1"
                raise InfeasibleDesignError(
                    f"{where}: λ = {lam} is not stable in {work.time} time (needs {need})")
            lam_list.append(lam)
    elif adm.generic:  # the defaults, and the special λ that fewer rows may need
        lam_list = default_eigenvalues(work.time, n)
        one_row, jumps = _special_lambdas(observer, F, H, L0, L if decoupled else sp.zeros(n, 0),
                                          M, work.time)
        for v in (one_row.stable if one_row else ()) + jumps.stable:
            if not any(_same_number(v, w) for w in lam_list):
                lam_list.append(v)
        chains = _chain_orders(observer, F, H, M, L if decoupled else None, work.time, n,
                               lam_list, dict(work.parameters))
        extra = []  # the chain polynomials' roots: tried as whole sets, not in combinations
        for c in chains:
            extra += [v for v in c.lambdas if not any(_same_number(v, w)
                                                      for w in lam_list + extra)]
    else:  # every stable admissible root, exactly (CRootOf for irreducible cubics and up)
        lam_list = [v for v in adm.values if is_stable(v, work.time) is not False]
        lam_list.sort(key=lambda v: (not v.is_rational, v.has(sp.CRootOf), str(v)))
        if not lam_list:
            lead = ""
            if observer == "diagnostic":
                lead = (f"{', '.join(task.targets)} cannot be detected"
                        f"{_with_decoupled(task)}: no stable λ gives a row Φ with Φ L = 0"
                        " (a reduced model of order < n); ")
            raise InfeasibleDesignError(
                f"{where}: {lead}no stable admissible λ: {adm.describe()} ({adm.evidence})",
                (adm.evidence,))

    # z with several components: can q = rank [M; H] − rank H rows (the least any model
    # has) do it for some real stable λ? Decided exactly; the λ it needs are tried.
    span = None
    if M is not None and M.rows > 1 and not lambdas and not work.parameters:
        span = span_rows(F, H, L if decoupled else sp.zeros(n, 0), M, LAMBDA, work.time)
        lam_list += [v for v in span.stable if not any(_same_number(v, w) for w in lam_list)]

    # Step 3: for every λ the whole family of rows: Φ = c N_λ L0, J* = c J_λ
    fam = {}
    pool = []
    sums = []  # diagnostic: one generic member per λ family (Σ basis rows), tried last
    lam_pivots = {}
    for i_lam, lam in enumerate(lam_list + extra):
        report(f"designing (Jordan form): null space for λ = {lam} ({i_lam + 1} of"
               f" {len(lam_list) + len(extra)})")
        rows_phi, rows_j, lam_pivots[lam] = _family(F, H, L0, lam)
        if i_lam < len(lam_list):
            pool += [(lam, Phi_i, J_i) for Phi_i, J_i in zip(rows_phi, rows_j)]
        if rows_phi:
            fam[lam] = (sp.Matrix.vstack(*rows_phi), sp.Matrix.vstack(*rows_j))
            if observer == "diagnostic":  # rows inside rowspace(H): a residual with k = 1
                for extra in _rows_in_rowspace(fam[lam], H):
                    pool.append((lam,) + extra)
                if len(rows_phi) > 1:  # a row that sees what each basis row sees
                    sums.append((lam, sum(rows_phi[1:], rows_phi[0]).applyfunc(sp.cancel),
                                 sum(rows_j[1:], rows_j[0]).applyfunc(sp.cancel)))
    if not pool:
        raise InfeasibleDesignError(f"{where}: no nonzero row Φ_i for λ in {lam_list}")

    # Step 4: fewest rows satisfying the task, one row per λ first
    names = tuple(f.name for f in fault_syms)
    if observer == "diagnostic" and _blind(names, pool, D):  # no row sees it: say so now
        raise InfeasibleDesignError(_diagnostic_refusal(where, task, names, pool, D, lam_list,
                                                        [], n))
    CA = [(j, sp.Matrix(t.row)) for j, t in enumerate(st.terms)]
    tried = []
    chosen = None
    if M is not None and M.rows > 1 and (span is None or span.possible):
        chosen = _span_design(fam, lam_list + extra, H, M, observer, D, st, tried, names)
    if M is not None and chosen is None:  # directed: M ∈ rowspace(H) + Σ_λ rowspace(N_λ L0)
        chosen = _directed_rows(fam, lam_list, H, M, n, observer, D, st, tried, names,
                                tuple(c.lambdas for c in chains if c.lambdas))
    bounds: dict = {}  # the lower bound over every F* for k rows (computed once per k)

    def bound(k_):
        if k_ not in bounds:
            bounds[k_] = _order_bound(observer, F, H, L, D, M, st, k_, decoupled)
        return bounds[k_]

    more = None  # q rows impossible: can q + 1 do it? (decided exactly in some cases)
    if (chosen is not None and M is not None and M.rows > 1 and span is not None
            and span.analysed and not span.possible and len(chosen) > span.q + 1):
        L_span = L if decoupled else sp.zeros(n, 0)
        # q + e rows whose images modulo [M; H] lie in e dimensions (e = 1: one line),
        # from the least e the lower bound over every F* allows, e = 1 skipped when
        # decided impossible; then e = c − f, where the rows of one further λ
        # generically meet U at finitely many λ (c = n − rank [M; H], f rows per λ;
        # smaller e need specially placed sets, which the scan rarely hits)
        e_least = max(1, bound(len(chosen)).k - span.q)
        if e_least == 1:  # (the bound does not already rule out q + 1 rows)
            more = one_more_row(F, H, L_span, M, LAMBDA, work.time)
            e_least += more.analysed and not more.possible
        f_rows = sorted(v[0].rows for v in fam.values())[len(fam) // 2] if fam else 0
        generic_e = n - _rank(sp.Matrix.vstack(M, H)) - f_rows
        es = list(range(e_least, _TUPLE_E_MAX + 1))
        es += [generic_e] if max(_TUPLE_E_MAX, e_least - 1) < generic_e <= _TUPLE_E_CAP else []
        for e in es:
            if len(chosen) <= span.q + e:
                break
            alt = _tuple_span_design(F, H, L_span, L0, fam, lam_list, M, observer, D, st,
                                     tried, names, work.time, e, more.lambdas if more else ())
            if alt is not None and len(alt) < len(chosen):
                chosen = alt
                break
    if (chosen is not None and M is not None and M.rows > 1
            and not (span is not None and span.analysed
                     and len(chosen) == span.q + (not span.possible))):
        # z with several components (not already at the least): rows spanning
        # [M; e extra rows] modulo H
        alt = _extended_span_design(fam, lam_list + extra, pool, H, M, observer, D, st, tried,
                                    names, len(chosen))
        chosen = alt or chosen
        if len(chosen) > len({r[0] for r in chosen}):
            # rows still share a λ: more λ with one basis row each may need fewer rows
            # (every combination of the pool, while there are not too many)
            cap = (_COMBINATIONS_MAX_ALGEBRAIC if any(r[0].has(sp.CRootOf) for r in pool)
                   else _COMBINATIONS_MAX)
            for size in range(len({r[0] for r in chosen}), len(chosen)):
                if math.comb(len(pool), size) > cap:
                    break
                alt = _combination_rows(pool, n, observer, H, D, M, st, tried, names, (size,))
                if alt is not None:
                    chosen = alt
                    break
    short = None  # a basis modulo H: can one row fewer do it? (decided exactly, f = 1)
    if (chosen is not None and M is not None and M.rows > 1 and span is not None
            and len(chosen) == n - _rank(H) > span.q + 1):
        short = one_row_short(F, H, L if decoupled else sp.zeros(n, 0), M, LAMBDA, work.time)
        if short.possible and short.lambdas:
            alt = _rows_at(F, H, L0, short.lambdas, observer, D, M, st, tried, names)
            if alt is not None:
                chosen = alt
    solid = None  # q + 4 rows found: can q + 3 do it? (planes of R⁶)
    if (chosen is not None and M is not None and M.rows > 1 and span is not None
            and span.analysed and not span.possible and len(chosen) == span.q + 4
            and not lambdas):
        solid = three_more_rows(F, H, L if decoupled else sp.zeros(n, 0), M, LAMBDA, work.time)
        chosen = _decided_rows(solid, chosen, F, H, observer, D, M, st, tried, names)
    plane = None  # q + 3 rows found: can q + 2 do it? (planes of R⁴, R⁵, R⁶)
    if (chosen is not None and M is not None and M.rows > 1 and span is not None
            and span.analysed and not span.possible and not lambdas
            and (len(chosen) == span.q + 3
                 or (len(chosen) == span.q + 4 and solid is not None and solid.analysed))):
        plane = two_more_rows(F, H, L if decoupled else sp.zeros(n, 0), M, LAMBDA, work.time)
        chosen = _decided_rows(plane, chosen, F, H, observer, D, M, st, tried, names)
    for size in range(1, n) if chosen is None else ():  # fewest rows first, every strategy
        chosen = _combination_rows(pool, n, observer, H, D, M, st, tried, names, (size,))
        if chosen is None and sums:  # the basis rows alone do not do it: generic members too
            chosen = _combination_rows(pool + sums, n, observer, H, D, M, st, tried, names,
                                       (size,))
        if chosen is None and observer == "diagnostic" and size > 1:  # rows of several λ
            chosen = _combined_rows(fam, lam_list, H, D, n, observer, M, st, tried, names, size)
        if chosen is not None:
            break
    if chosen is None and observer == "diagnostic":
        raise InfeasibleDesignError(_diagnostic_refusal(where, task, names, pool, D, lam_list,
                                                        tried, n), tuple(tried))
    if chosen is None:
        raise InfeasibleDesignError(
            f"{where}: no Jordan-form {observer} with fewer than n = {n} rows for λ in"
            f" {{{', '.join(map(str, lam_list))}}}: " + "; ".join(tried), tuple(tried))

    # Step 5: the matrices
    k = len(chosen)
    lams = tuple(r[0] for r in chosen)
    Phi = sp.Matrix.vstack(*[r[1] for r in chosen])
    J = sp.Matrix.vstack(*[r[2] for r in chosen])
    if work.parameters:  # the rank decisions of the task on the chosen Φ (rank Φ = k, …)
        PH = sp.Matrix.vstack(Phi, H)
        for R in (Phi, PH) + ((sp.Matrix.vstack(PH, M),) if M is not None else ()):
            pivots |= exact_rank(R).conditions
    mats = {"Phi": Phi, "F_star": sp.diag(*lams), "J_star": J, "G_star": Phi * G}
    if observer == "diagnostic":
        pair = _residual_pair(Phi, H, pivots)
        if pair is None:  # pragma: no cover - excluded by the rank test
            raise InfeasibleDesignError(f"{where}: (R*, -H*)[H; Phi] = 0 has no solution")
        mats["R_star"], mats["H_star"] = pair
        mats["D_star"] = Phi * D
    if decoupled:
        if L.cols:
            mats["L_star"] = Phi * L
    else:
        mats["L_star"] = Phi * L
    if M is not None:
        X = solve_left(sp.Matrix.vstack(Phi, H), M)
        mats["Hz"], mats["Q"] = X[:, :k], X[:, k:]
    xs, ys = observer_symbols(k), output_symbols(l)
    _, _, subs, nonlinear = substitute_arguments(st, Phi, xs, ys)
    if C.cols:
        mats["C_star"] = Phi * C
    mats = {name: Mx.applyfunc(sp.cancel) for name, Mx in mats.items()}

    # Step 6: certificate, independent of the above
    plant = dict(F=F, G=G, H=H, C=C, D=D, L=L)
    cert = certify_design(plant, mats, M=M, substitutions=subs, decoupled=decoupled)

    # Step 7: equations and reported conditions
    equations, outputs = jordan_equations(mats, work.inputs, xs, ys, observer, M, nonlinear,
                                          C.cols)

    conds += _report_conditions(observer, work.time, lams, mats, Phi, H, D, M, fault_syms, CA,
                                 nonlinear, k, decoupled)
    conds.append(Condition("certificate", cert.passed, cert.summary(), "METHOD §2"))
    minimal = _minimality(observer, k, n, lams, lam_list, adm, bool(lambdas), one_row, jumps,
                          work.time, bound, chains, span,
                          (lambda k_: nonlinear_jordan_bound(
                              F, H, L if decoupled else sp.zeros(n, 0), M, C,
                              [sp.Matrix(t.row) for t in st.terms], k_, LAMBDA, work.time,
                              lam_list)) if st.terms and M is not None and not lambdas
                          else None, several=M is not None and M.rows > 1, more=more,
                          short=short, plane=plane, solid=solid)
    conds.append(minimal)
    choice = (f"k = {k}: rows with λ = ({', '.join(map(str, lams))}) chosen from"
              f" {len(pool)} candidate row(s) for λ in {{{', '.join(map(str, lam_list))}}};"
              f" the fewest rows that satisfy the {observer} conditions; {minimal.detail}"
              + (f" (smaller sets rejected: {'; '.join(tried[:4])})" if tried else ""))
    assumptions = set(pivots)
    for lam in set(lams):
        assumptions |= lam_pivots.get(lam, frozenset())
    for Mx in mats.values():
        for e in Mx:
            assumptions |= denominator_conditions(e)
    if observer == "diagnostic" and work.parameters:  # each fault seen: not all entries 0
        PD = (Phi * D).applyfunc(sp.cancel)
        for c in range(PD.cols):
            nums = [sp.fraction(sp.together(e))[0] for e in PD[:, c] if e != 0]
            if nums:
                g = sp.gcd_list(nums) if len(nums) > 1 else nums[0]
                assumptions |= nonzero_conditions(g)
    return Design(
        model_name=work.name, form="jordan", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=tuple(sorted(assumptions, key=str)), certificate=cert,
        task=task, structure=st, symbolic=bool(work.parameters), method="exact",
        choice=choice, attempts=tuple(tried), time=work.time,
        lambdas=lams, nonlinear=tuple(nonlinear), equations=equations,
        observer_states=tuple(xs), outputs=tuple(outputs))


def _residual_pair(Phi, H, pivots: set | None = None):
    """(R*, H*) with R* H = H* Φ, H* ≠ 0: the first such member (reduced echelon), or None;
    the rank decision's pivot conditions are added to ``pivots`` when given."""
    l, k = H.rows, Phi.rows
    nb, rk = left_null_echelon(sp.Matrix.vstack(H, Phi))
    if pivots is not None:
        pivots |= rk.conditions
    nb = [v for v in nb if v[:, l:] != sp.zeros(1, k)]
    if not nb:
        return None
    return nb[0][:, :l], -nb[0][:, l:]


def _with_decoupled(task) -> str:
    return f" with {', '.join(task.decoupled)} decoupled" if task.decoupled else ""


def _blind(names, pool, D) -> list:
    """The targets no candidate row sees (Φ_i D_j = 0 for every row of every λ family)."""
    return [nm for c, nm in enumerate(names)
            if all((r[1] * D[:, c]).applyfunc(sp.cancel) == sp.zeros(1, 1) for r in pool)]


def _diagnostic_refusal(where, task, names, pool, D, lam_list, tried, n) -> str:
    """Why no residual detects the targets: the faults no row sees, else the faults no
    residual of order < n sees, named (issue 12, item 4)."""
    lams = ", ".join(map(str, lam_list))
    blind = _blind(names, pool, D)
    if blind:
        what = ", ".join(blind)
        cols = ", ".join(f"Φ D_{nm} = 0" for nm in blind)
        return (f"{where}: {what} {'is' if len(blind) == 1 else 'are'} undetectable"
                f"{_with_decoupled(task)}: every row Φ with Φ L = 0 (λ in {{{lams}}}) has"
                f" {cols}")
    steps = "; ".join(tried[:6])
    what = ", ".join(names)
    return (f"{where}: {what} cannot be detected{' together' if len(names) > 1 else ''}"
            f"{_with_decoupled(task)} by a residual of order < n = {n}: no set of rows Φ with"
            f" Φ L = 0 (λ in {{{lams}}}) gives a residual r = R* y − H* x* that responds to"
            f" {what} (tried: {steps})")


def _check_rows(rows, size, observer, H, D, M, st, tried, names=()):
    """True when the rows are independent and satisfy the task; records why not."""
    Phi = sp.Matrix.vstack(*[r[1] for r in rows])
    if _rank(Phi) < size:
        return False
    ok, why = _task_ok(observer, Phi, H, D, M, st, names)
    if ok and observer == "diagnostic":  # the residual itself must respond to every target
        Rs, Hs = _residual_pair(Phi, H)
        Fs = sp.diag(*[r[0] for r in rows])
        for c in range(D.cols):
            if residual_response(Phi, Fs, Hs, D[:, c]) == sp.zeros(Hs.rows * Fs.rows, 1):
                nm = names[c] if c < len(names) else f"column {c + 1}"
                ok, why = False, (f"{nm} enters only rows the residual does not read"
                                  " (H* (sI − F*)⁻¹ Φ D = 0)")
                break
    if not ok and len(tried) < 12:
        tried.append(f"k={size}, λ = ({', '.join(str(r[0]) for r in rows)}): {why}")
    return ok


def _rows_at(F, H, L0, lams, observer, D, M, st, tried, names=()):
    """One row of each λ (families of one row each, :func:`one_row_short`) when they
    satisfy the task, else None."""
    rows = []
    for lam in lams:
        rows_phi, rows_j, _ = _family(F, H, L0, lam)
        if len(rows_phi) != 1:
            return None
        rows.append((lam, rows_phi[0], rows_j[0]))
    return rows if _check_rows(rows, len(rows), observer, H, D, M, st, tried, names) else None


def _decided_rows(decision, chosen, F, H, observer, D, M, st, tried, names):
    """The design from the rows an exact order decision (:func:`two_more_rows`,
    :func:`three_more_rows`) returned with its λ, when it builds; else ``chosen``."""
    if decision.possible and decision.rows:
        alt = _given_rows(F, H, decision.lambdas, decision.rows, observer, D, M, st, tried,
                          names)
        if alt is not None:
            return alt
    return chosen


def _given_rows(F, H, lams, phis, observer, D, M, st, tried, names=()):
    """Rows Φ_i of λ_i given exactly (:func:`two_more_rows`), with J*_i from
    Φ_i (F − λ_i I) = J*_i H, when they satisfy the task, else None."""
    rows = []
    for lam, phi in zip(lams, phis):
        J = solve_left(H, exact_product(phi, F - lam * sp.eye(F.rows)))
        if J is None:  # pragma: no cover - the rows of λ satisfy it by construction
            return None
        rows.append((lam, phi, J))
    return rows if _check_rows(rows, len(rows), observer, H, D, M, st, tried, names) else None


def _rows_in_rowspace(family, H):
    """Rows c N_λ L0 that lie in rowspace(H) (their residual needs only this row)."""
    PhiB, JB = family
    basis, _ = left_null_space(sp.Matrix.vstack(PhiB, H))
    out = []
    vecs = [b[:, :PhiB.rows] for b in basis]
    vecs = [c for c in vecs if c != sp.zeros(1, PhiB.rows)]
    if len(vecs) > 1:
        vecs.append(sum(vecs[1:], vecs[0]))
    for c in vecs:
        Phi_i = exact_product(c, PhiB)
        if Phi_i != sp.zeros(1, PhiB.cols):
            out.append((Phi_i, exact_product(c, JB)))
    return out


def _directed_rows(fam, lam_list, H, M, n, observer, D, st, tried, names=(), sets=()):
    """Sets of distinct λ, smallest first: solve M = Σ c_λ N_λ L0 + Q H for one row per λ.
    ``sets``: whole λ sets (the roots of a chain polynomial) tried first at their size."""
    lams = [lam for lam in lam_list if lam in fam]
    for size in range(1, n):
        report(f"designing (Jordan form): {size} row(s) of at most {n - 1}")
        first = [c for c in sets if len(c) == size and all(lam in fam for lam in c)]
        for combo in itertools.chain(first, itertools.combinations(lams, size)):
            B = sp.Matrix.vstack(*[fam[lam][0] for lam in combo])
            if _irrational(combo) and not _maybe_in_rowspace(sp.Matrix.vstack(B, H), M):
                continue  # numerically far from solvable: skip the algebraic-field solve
            X = solve_left(sp.Matrix.vstack(B, H), M)
            if X is None:
                continue
            rows, off, used = [], 0, 0
            for lam in combo:
                PhiB, JB = fam[lam]
                c = X[:, off:off + PhiB.rows]
                off += PhiB.rows
                # one row per independent combination: z = M x with several components
                # may need several rows of the same λ (rows of c N_λ L0 that add rank)
                block = exact_product(c, PhiB)
                Jblock = exact_product(c, JB)
                mine = []
                for i in range(block.rows):
                    if block[i, :] == sp.zeros(1, n):
                        continue
                    trial = sp.Matrix.vstack(*[r[1] for r in mine], block[i, :])
                    if _rank(trial) == len(mine) + 1:
                        mine.append((lam, block[i, :], Jblock[i, :]))
                used += bool(mine)
                rows += mine
            if used != size:
                continue  # a smaller set does it (found earlier unless the task failed)
            if _check_rows(rows, len(rows), observer, H, D, M, st, tried, names):
                return rows
    return None


def _span_design(fam, lam_list, H, M, observer, D, st, tried, names=(), extra=()):
    """Rows spanning T = [M; extra rows] modulo H with nothing to spare, rank [T; H] − rank H
    of them: with no extra rows the fewest any model of z = M x can have, when the rows
    inside rowspace [M; H] of the λ tried span z modulo H (:func:`span_rows`). At each λ
    the rows c N_λ L0 ∈ rowspace [T; H] (left null space of [N_λ L0; T; H]), taken greedily
    while they add rank to [H; rows so far] (a basis of a sum of subspaces)."""
    T = sp.Matrix.vstack(M, *extra)
    rH = _rank(H)
    rows, have, r_have = [], sp.Matrix(H), rH
    target = _rank(sp.Matrix.vstack(H, T))
    for lam in lam_list:
        if lam not in fam:
            continue
        PhiB, JB = fam[lam]
        stacked = sp.Matrix.vstack(PhiB, T, H)
        if lam.has(sp.CRootOf) and _float_rank_full(stacked):
            continue  # no row of this λ inside rowspace [T; H] (numerically clear)
        basis, _ = left_null_space(stacked)
        for v in basis:
            c = v[:, :PhiB.rows]
            row = exact_product(c, PhiB)
            if row == sp.zeros(1, row.cols):
                continue
            trial = sp.Matrix.vstack(have, row)
            r_trial = _rank(trial)
            if r_trial > r_have:
                rows.append((lam, row, exact_product(c, JB)))
                have, r_have = trial, r_trial
        if r_have == target:
            break
    if r_have != target or len(rows) != target - rH:
        return None
    return rows if _check_rows(rows, len(rows), observer, H, D, M, st, tried, names) else None


def _extended_span_design(fam, lam_list, pool, H, M, observer, D, st, tried, names, k):
    """Fewer than k rows for z with several components: rows spanning [M; e rows of the
    pool at e distinct λ] modulo H (e = 1 … k − q − 1): a model of q + e rows whose rows lie
    in rowspace [M; extra; H] (METHOD §2b). A space of dimension q + e meets a λ's rows
    (f of them, modulo H in n − rank H dimensions) generically only once
    f + q + e > n − rank H, so below that e only a few choices are tried."""
    rH = _rank(H)
    q = _rank(sp.Matrix.vstack(H, M)) - rH
    first = {}
    for r in pool:
        first.setdefault(r[0], r)
    lams = [lam for lam in lam_list if lam in first]
    f = max((fam[lam][0].rows for lam in lams), default=0)
    generic = H.cols - rH - f - q + 1
    for e in range(1, k - q):
        tries = _EXTENDED_TRIES if e >= generic else 3
        for combo in itertools.islice(itertools.combinations(lams, e), tries):
            rows = _span_design(fam, lam_list, H, M, observer, D, st, tried, names,
                                tuple(first[lam][1] for lam in combo))
            if rows is not None and len(rows) < k:
                return rows
    return None


def _tuple_span_design(F, H, L, L0, fam, lam_list, M, observer, D, st, tried, names, time,
                       e=1, hint=()):
    """q + e rows for z with several components when q rows are impossible. Modulo
    rowspace [M; H] (the columns of Q span its right null space) q + e rows spanning z
    modulo H have their images in an e-dimensional subspace U. e + 1 λ with rows
    Σ Φ_i Q = 0 (a linear solve for rational λ_i) give U = span of e of the images; the
    further λ whose rows meet rowspace [M; Φ_1 … Φ_e; H] are the rank drops of E(λ) for
    T = [M; Φ_1; …; Φ_e] (:func:`span_rows`, exact roots: often rational, not in any
    list), and the rows spanning T modulo H are taken as in :func:`_span_design`
    (METHOD §2b). e = 1: pairs of λ and one line w (q + 1 rows, the least when q rows are
    impossible).

    The further λ depend on the chosen λ: a floating-point scan over a grid of rational
    λ (generalised eigenvalues of E(λ)) picks the sets whose further λ look real and
    stable; only those are solved exactly (the solution of the float scan carried over
    by a rationalised least-squares fit when the solutions form more than a line), and
    the exact solve decides. ``hint``: λ known to allow q + 1 rows (:func:`one_more_row`);
    pairs of its rational ones are tried after the scan's (whose λ are less stiff)."""
    Q = sp.Matrix.hstack(*sp.Matrix.vstack(M, H).nullspace())
    if Q.cols == 0:
        return None
    q = _rank(sp.Matrix.vstack(M, H)) - _rank(H)
    grid = [lam for lam in lam_list if lam.is_rational] + [
        v for v in _PAIR_GRID[time] if not any(v == w for w in lam_list)]
    if e > 1:  # the list's first λ, then the grid spread over its range
        head = [lam for lam in lam_list if lam.is_rational][:_TUPLE_GRID // 3]
        top = _TUPLE_STIFF * (abs(head[0]) if head else 1)
        rest = sorted(v for v in grid if not any(v == w for w in head)
                      and (time != "continuous" or abs(v) <= top))
        slots = min(len(rest), _TUPLE_GRID - len(head))
        grid = head + [rest[int(round(i))] for i in np.linspace(0, len(rest) - 1, slots)]
    sets = _promising_sets(F, H, L, L0, M, Q, grid, q, time, e)[:_PAIR_EXACT]
    seen = [lams for lams, _ in sets]
    if e == 1:
        sets += [(pr, None) for pr in itertools.combinations([v for v in hint if v.is_rational], 2)
                 if pr not in seen]
    for i, (lams, phis) in enumerate(sets):
        report(f"designing (Jordan form): q + {e} rows through λ = {', '.join(map(str, lams))}"
               f" (set {i + 1})")
        more = dict(fam)
        for lam in lams:
            if lam not in more:
                rows_phi, js, _ = _family(F, H, L0, lam)
                if not rows_phi:
                    break
                more[lam] = (sp.Matrix.vstack(*rows_phi), sp.Matrix.vstack(*js))
        else:
            Ns = [more[lam][0] for lam in lams]
            basis, _ = left_null_space(sp.Matrix.vstack(*[N * Q for N in Ns]))
            if not basis:
                continue
            y = _fitted(basis, Ns, phis)
            rows, off = [], 0
            for N in Ns:
                rows.append(exact_product(y[:, off:off + N.rows], N))
                off += N.rows
            if any((r * Q).is_zero_matrix for r in rows):
                continue  # a row inside rowspace [M; H]: the q-row case, already decided
            extra, images = [], sp.zeros(0, Q.cols)
            for r in rows:
                if _rank(sp.Matrix.vstack(images, r * Q)) > images.rows:
                    extra.append(r)
                    images = sp.Matrix.vstack(images, r * Q)
            if len(extra) != e:
                continue
            sr = span_rows(F, H, L, sp.Matrix.vstack(M, *extra), LAMBDA, time)
            if not sr.possible:
                continue
            further = []
            # rows inside rowspace [T; H] at every λ but finitely many (e + f > c): the
            # list's λ serve as well as any
            generic = [] if sr.stable else [v for v in lam_list if v not in lams]
            for lam in list(sr.stable) + generic:
                same = next((w for w in more if _same_number(lam, w)), None)
                if same is None:
                    rows_phi, js, _ = _family(F, H, L0, lam)
                    if rows_phi:
                        more[lam] = (sp.Matrix.vstack(*rows_phi), sp.Matrix.vstack(*js))
                        same = lam
                if same is not None and same not in lams and same not in further:
                    further.append(same)
            order = list(lams) + further
            found = _span_design(more, order, H, M, observer, D, st, tried, names, tuple(extra))
            if found is not None:
                return found
    return None


def _fitted(basis, Ns, phis):
    """An exact solution y (Σ y_i N_i Q = 0) close to the float rows ``phis`` of the scan:
    the first basis vector when the solutions form a line (or no float rows are given),
    else the least-squares combination of the basis rows, its weights rationalised."""
    if len(basis) == 1 or phis is None:
        return basis[0]
    def rows_of(v):
        out, off = [], 0
        for N in Ns:
            out.append(np.array((v[:, off:off + N.rows] * N).evalf().tolist(), dtype=float).ravel())
            off += N.rows
        return np.concatenate(out)
    R = np.array([rows_of(b) for b in basis]).T
    target = np.concatenate([np.asarray(p, dtype=float).ravel() for p in phis])
    alpha, *_ = np.linalg.lstsq(R, target, rcond=None)
    if not np.all(np.isfinite(alpha)) or not np.any(alpha):
        return basis[0]
    scale = np.max(np.abs(alpha))
    w = [sp.Rational(float(a / scale)).limit_denominator(10 ** 6) for a in alpha]
    y = sum((wk * b for wk, b in zip(w, basis)), sp.zeros(*basis[0].shape))
    return y if not y.is_zero_matrix else basis[0]


def _promising_sets(F, H, L, L0, M, Q, grid, q, time, e=1) -> list:
    """Sets of e + 1 rational λ of the grid for which, in floating point, rows Φ_i of the
    λ_i with Σ Φ_i Q = 0, all images nonzero and spanning e dimensions, exist, and E(λ) of
    T = [M; e of the rows] drops rank at q − 1 further real stable λ (distinct, not among
    the set); the least stiff first (continuous: the ratio of the largest to the smallest
    |λ|; discrete: the largest |λ|). Items: (the λ, the float rows)."""
    try:
        Fn, Hn, L0n, Mn, Qn = (np.array(X.evalf().tolist(), dtype=float).reshape(X.shape)
                               for X in (F, H, L0, M, Q))
        Ln = np.array(L.evalf().tolist(), dtype=float).reshape(L.shape)
    except (TypeError, ValueError):
        return []
    n = Fn.shape[0]
    fams = {}
    for lam in grid:
        x = float(lam)
        S = float_left_null_space(np.vstack([L0n @ (Fn - x * np.eye(n)), Hn]), rtol=1e-9)[0]
        fams[lam] = S[:, :L0n.shape[0]] @ L0n
    sizes = sorted(len(N) for N in fams.values())
    if not sizes or (e + 1) * sizes[len(sizes) // 2] <= Qn.shape[1]:
        return []  # e + 1 generic families: fewer unknowns than conditions Σ Φ_i Q = 0
    zl = np.zeros((Hn.shape[0], Ln.shape[1]))
    probe = []  # (λ', basis of the rows' images modulo [M; H]) with e + f' = c
    for x in _PROBE_LAMBDAS[time]:
        S = float_left_null_space(np.vstack([L0n @ (Fn - x * np.eye(n)), Hn]), rtol=1e-9)[0]
        W = S[:, :L0n.shape[0]] @ L0n @ Qn
        if len(W) + e == Qn.shape[1] and float_rank(W, rtol=1e-9).rank == len(W):
            probe.append((x, W))

    def score(lams, Ns, y):
        """(stiffness, rows) when the rows of the solution y qualify, else None."""
        rows, off = [], 0
        for N in Ns:
            rows.append(y[off:off + N.shape[0]] @ N)
            off += N.shape[0]
        images = np.array([r @ Qn for r in rows])
        if any(np.linalg.norm(im) < 1e-8 * max(1.0, np.linalg.norm(r))
               for im, r in zip(images, rows)):
            return None
        if np.linalg.matrix_rank(images, tol=1e-8 * np.abs(images).max()) != e:
            return None
        extra, got = [], np.zeros((0, Qn.shape[1]))
        for r, im in zip(rows, images):
            trial = np.vstack([got, im])
            if np.linalg.matrix_rank(trial, tol=1e-8 * np.abs(trial).max()) > got.shape[0]:
                extra.append(r)
                got = trial
        T = np.vstack([Mn] + extra)
        A = np.block([[T @ Fn, T @ Ln], [Hn @ Fn, Hn @ Ln], [-Hn, zl]])
        B = np.vstack([np.hstack([T, np.zeros((T.shape[0], Ln.shape[1]))]),
                       np.zeros((2 * Hn.shape[0], n + Ln.shape[1]))])
        r, ev = _pencil_drops(A, B)
        if ev is None:
            return None
        xs = [float(v) for v in lams]
        real = sorted({round(float(z.real), 9) for z in ev
                       if np.isfinite(z) and abs(z.imag) <= 1e-7 * (1 + abs(z))})
        new = [z for z in real if min(abs(z - x) for x in xs) > 1e-4 * (1 + abs(z))
               and (z < 0 if time == "continuous" else abs(z) < 1)
               and float_rank(A - z * B, rtol=1e-8).rank < r]
        if len(new) < q - 1:
            return None
        mags = [abs(v) for v in xs + new[:q - 1]]
        # continuous: the least stiff (fastest / slowest |λ|); discrete: the fastest
        return ((max(mags) / min(mags)) if time == "continuous" else max(mags)), rows

    scored = []
    for lams in itertools.combinations(grid, e + 1):
        Ns = [fams[v] for v in lams]
        if any(not len(N) for N in Ns):
            continue
        Y = float_left_null_space(np.vstack([N @ Qn for N in Ns]), rtol=1e-9)[0]
        if Y.shape[0] == 0:
            continue
        # the solutions form a space: its first vector, then (when it is more than a
        # line) points of the pencil Y₀ + t Y₁ where U(t) meets the rows' image of a
        # further λ' (:func:`_pencil_points`)
        ys = [Y[0]] + (_pencil_points(Y, Ns, Qn, e, probe) if Y.shape[0] > 1 else [])
        best = None
        for y in ys:
            got = score(lams, Ns, y)
            if got is not None and (best is None or got[0] < best[0]):
                best = got
        if best is not None:
            scored.append((best[0], lams, best[1]))
    scored.sort(key=lambda t: t[0])
    return [(lams, rows) for _, lams, rows in scored]


def _pencil_drops(A, B) -> tuple:
    """``(r, candidates)``: the rank r of A − λB at a shift σ (its generic rank unless σ
    is a drop) and candidates for the λ where it drops below r: the finite eigenvalues of
    a random r × r compression U (A − λB) V (a superset of the drops), by shift and invert
    (μ = 1 / (λ − σ) of (U (A − σB) V)⁻¹ U B V; μ = 0 is λ = ∞). Candidates None when the
    compression is singular at the shift."""
    rng = np.random.default_rng(20261123)
    r = np.linalg.matrix_rank(A - _SHIFT * B)
    if r == 0:
        return r, None
    U, V = rng.standard_normal((r, A.shape[0])), rng.standard_normal((A.shape[1], r))
    try:
        mu = np.linalg.eigvals(np.linalg.solve(U @ (A - _SHIFT * B) @ V, U @ B @ V))
    except np.linalg.LinAlgError:
        return r, None
    big = np.abs(mu) > 1 / _PAIR_MAX  # |λ − σ| < _PAIR_MAX; smaller μ: λ taken as infinite
    return r, _SHIFT + 1 / mu[big]


#: the further λ' at which :func:`_pencil_points` looks for points of the pencil
_PROBE_LAMBDAS = {"continuous": tuple(-np.logspace(-1.5, 3, 91)),
                  "discrete": tuple(np.linspace(-0.975, 0.975, 79))}
#: the most pencil points of one set scored by :func:`_promising_sets`
_PENCIL_POINTS = 3


def _real_roots(coeffs):
    """The real roots of the polynomials whose coefficients (highest first) are the
    columns of ``coeffs``: in closed form for degree ≤ 2 (vectorised), else the
    eigenvalues of batched companion matrices. Leading coefficients below 1e-12 of a
    column's largest are taken as zero (the degree drops; np.roots would instead return a
    root near infinity)."""
    deg = coeffs.shape[0] - 1
    if deg == 1:
        a, b = coeffs
        ok = np.abs(a) > 1e-12 * np.abs(b)
        return -b[ok] / a[ok]
    if deg == 2:
        a, b, c = coeffs
        lin = np.abs(a) <= 1e-12 * (np.abs(b) + np.abs(c))
        disc = b * b - 4 * a * c
        ok = ~lin & (disc >= 0)
        sq = np.sqrt(disc[ok])
        q = -0.5 * (b[ok] + np.copysign(sq, b[ok]))  # no cancellation
        out = [q / a[ok], np.divide(c[ok], q, out=np.full(q.shape, np.nan), where=q != 0)]
        keep = lin & (np.abs(b) > 0)
        out.append(-c[keep] / b[keep])
        r = np.concatenate(out)
        return r[np.isfinite(r)]
    # degree ≥ 3: the eigenvalues of the companion matrices, one batched call per degree
    # (each polynomial trimmed to its degree first)
    out = []
    scale = np.abs(coeffs).max(axis=0)
    lead = np.argmax(np.abs(coeffs) > 1e-12 * scale, axis=0)
    for d in range(1, deg + 1):  # the columns whose leading nonzero coefficient is at deg − d
        cols = coeffs[:, (deg - lead == d) & (scale > 0)]
        if not cols.shape[1]:
            continue
        top = cols[deg - d:]  # (d + 1, P): leading coefficient first
        comp = np.zeros((top.shape[1], d, d))
        comp[:, 0, :] = -(top[1:] / top[0]).T
        comp[:, np.arange(1, d), np.arange(d - 1)] = 1.0
        r = np.linalg.eigvals(comp).ravel()
        out.append(r.real[np.abs(r.imag) <= 1e-9 * (1 + np.abs(r))])
    return np.concatenate(out) if out else np.zeros(0)


def _pencil_points(Y, Ns, Qn, e, probe) -> list:
    """Solutions y = Y₀ + t Y₁ (normalised) of a set whose solutions Σ y_i N_i Q = 0 form
    more than a line, chosen where the images U(t) of its first e rows meet the image
    W(λ') of the rows of a further λ' (e + dim W = c: det [U(t); W(λ')] = 0, a
    polynomial of degree ≤ e in t, interpolated at e + 1 points, its real roots): along
    the pencil U and the further λ move, and a sweep at fixed t would step over the
    narrow stretches where they are stable. At most :data:`_PENCIL_POINTS`, spread over
    the λ' (floats; the caller scores each and the exact solve decides)."""
    if not probe or len(Ns) < e:
        return []
    ts = np.arange(e + 1, dtype=float) - e / 2
    Ws = np.array([W for _, W in probe])  # (P, f', c)
    dets = []
    for t in ts:
        y, off, U = Y[0] + t * Y[1], 0, []
        for N in Ns[:e]:
            U.append(y[off:off + N.shape[0]] @ N @ Qn)
            off += N.shape[0]
        U = np.array(U)
        dets.append(np.linalg.det(np.concatenate(
            [np.broadcast_to(U, (len(probe),) + U.shape), Ws], axis=1)))
    coeffs = np.linalg.solve(np.vander(ts, e + 1), np.array(dets))  # (e + 1, P)
    coeffs = coeffs[:, np.any(np.abs(coeffs) > 1e-12 * np.abs(coeffs).max(initial=0.0),
                              axis=0)]
    roots = np.sort(_real_roots(coeffs))
    if not len(roots):
        return []
    picks = [roots[int(i)] for i in np.linspace(0, len(roots) - 1, min(_PENCIL_POINTS,
                                                                        len(roots)))]
    return [(Y[0] + t * Y[1]) / np.linalg.norm(Y[0] + t * Y[1]) for t in picks]


#: the shift of :func:`_pencil_drops` (a number no λ of interest sits on)
_SHIFT = 0.3717

#: the rational λ the pair search scans besides the list's (continuous / discrete)
_PAIR_GRID = {
    "continuous": [sp.Rational(v) for v in (
        "-1/10", "-1/5", "-1/4", "-1/3", "-1/2", "-2/3", "-3/4", "-1", "-3/2", "-2", "-3", "-4",
        "-5", "-6", "-8", "-10", "-15", "-20", "-30", "-50", "-100", "-200", "-500", "-1000")],
    "discrete": [s_ * sp.Rational(v) for v in (
        "1/16", "1/8", "1/4", "3/8", "1/2", "5/8", "3/4", "7/8", "15/16") for s_ in (1, -1)],
}
#: |λ − shift| at least this large is taken as infinite (B is singular)
_PAIR_MAX = 1e5
#: sets solved exactly after the scan
_PAIR_EXACT = 6
#: every e (q + e rows) up to this is searched through sets of e + 1 λ; beyond it only
#: e = c − f (the rows of a further λ generically meet U at finitely many λ) ...
_TUPLE_E_MAX = 2
#: ... up to this (C(_TUPLE_GRID, e + 1) sets are scanned: 2002 for e = 4)
_TUPLE_E_CAP = 4
#: grid values scanned for sets of three or more λ (the first of the list and the grid)
_TUPLE_GRID = 14
#: continuous time: the grid for sets of three or more λ stops at this many times the
#: list's first |λ| (stiffer sets are rarely needed and make stiff observers)
_TUPLE_STIFF = 100


#: extra-row choices tried per e by :func:`_extended_span_design`
_EXTENDED_TRIES = 24

#: the most pool combinations tried for one size when rows share a λ (fewer when some λ
#: are algebraic: each exact rank is then far slower)
_COMBINATIONS_MAX = 2000
_COMBINATIONS_MAX_ALGEBRAIC = 60


def _combination_rows(pool, n, observer, H, D, M, st, tried, names=(), sizes=None):
    """Fewest rows from the pool; sets with distinct λ before sets that repeat one."""
    for size in sizes or range(1, n):
        report(f"designing (Jordan form): {size} row(s) of at most {n - 1}")
        for distinct in (True, False):
            for combo in itertools.combinations(range(len(pool)), size):
                rows = [pool[i] for i in combo]
                lams = [r[0] for r in rows]
                if (len(set(lams)) == len(lams)) != distinct:
                    continue
                if _check_rows(rows, size, observer, H, D, M, st, tried, names):
                    return rows
    return None


def _same_number(a, b) -> bool:
    """Exact equality of two real numbers (rationals, surds, CRootOf); a float comparison
    first, so that distinct values never reach ``simplify``."""
    if a == b:
        return True
    if a.free_symbols or b.free_symbols:
        return sp.simplify(a - b) == 0
    if abs(float(a) - float(b)) > 1e-9 * (1 + abs(float(a))):
        return False
    return sp.simplify(a - b) == 0


def _irrational(lams) -> bool:
    return any(lam.is_number and not lam.is_rational for lam in lams)


#: float pre-check for sets with irrational λ: relative least-squares residual above which
#: X B = M is certainly not solvable (an exact solution leaves ~1e-15; the exact solve decides)
_PRECHECK_RTOL = 1e-6


def _maybe_in_rowspace(B, M) -> bool:
    """False when X B = M is far from solvable in floating point (exact arithmetic in an
    algebraic field of high degree is slow; only sets that pass are solved exactly)."""
    try:
        Bn = np.array(B.evalf(30).tolist(), dtype=float)
        Mn = np.array(M.evalf(30).tolist(), dtype=float)
    except (TypeError, ValueError):  # symbolic entries: let the exact solve decide
        return True
    X, *_ = np.linalg.lstsq(Bn.T, Mn.T, rcond=None)
    res = np.linalg.norm(X.T @ Bn - Mn)
    return bool(res <= _PRECHECK_RTOL * max(1.0, np.linalg.norm(Mn)) * max(1.0, np.linalg.norm(Bn)))


def _float_rank_full(A) -> bool:
    """True when A has full row rank with a clear margin in floating point."""
    try:
        An = np.array(A.evalf(30).tolist(), dtype=float)
    except (TypeError, ValueError):
        return False
    if An.shape[0] > An.shape[1]:
        return False
    s = np.linalg.svd(An, compute_uv=False)
    return bool(s.size and s[-1] > _PRECHECK_RTOL * s[0])


def _combined_rows(fam, lam_list, H, D, n, observer, M, st, tried, names, size):
    """Diagnostic rows of ``size`` distinct λ whose sum lies in rowspace H (seed 002 (2.7)):
    Σ_λ c_λ N_λ L0 + h H = 0 from the left null space of [N_λ1 L0; …; H], one row
    Φ_i = c_λi N_λi L0 per λ, every λ used (a smaller set is tried before)."""
    lams = [lam for lam in lam_list if lam in fam]
    for combo in itertools.combinations(lams, size):
        Bs = [fam[lam][0] for lam in combo]
        if _irrational(combo) and _float_rank_full(sp.Matrix.vstack(*Bs, H)):
            continue  # no combination in rowspace H (numerically clear): skip the exact solve
        basis, _ = left_null_space(sp.Matrix.vstack(*Bs, H))
        if not basis:
            continue
        cands = list(basis) + ([sum(basis[1:], basis[0])] if len(basis) > 1 else [])
        for v in cands:
            rows, off = [], 0
            for lam, B in zip(combo, Bs):
                c = v[:, off:off + B.rows]
                off += B.rows
                Phi_i = exact_product(c, B)
                if Phi_i == sp.zeros(1, n):
                    break
                rows.append((lam, Phi_i, exact_product(c, fam[lam][1])))
            if len(rows) == size and _check_rows(rows, size, observer, H, D, M, st, tried,
                                                 names):
                return rows
    return None


def _special_lambdas(observer, F, H, L0, L, M, time):
    """Every λ admissible: the exact special λ (METHOD §2b) — those a one-row design needs
    (virtual sensor / interval observer; diagnostic one-row designs do not depend on λ) and
    those where the family of rows grows."""
    one = None
    if M is not None and observer != "diagnostic":
        one = one_row_lambdas(F, H, L, M, LAMBDA, time)
    return one, family_jump_lambdas(F, H, L0, LAMBDA, time)


def _minimality(observer, k, n, lams, lam_list, adm, requested, one_row, jumps, time,
                bound, chains=(), span=None, nonlinear=None, several=False,
                more=None, short=None, plane=None, solid=None) -> Condition:
    """Why fewer rows are impossible, as far as it is proven (METHOD §2b). ``bound(k)``
    gives the :class:`OrderBound` of every reduced model of the task (any F*); ``chains``
    the :class:`ChainOrder` of each order m (z = M x, every λ admissible). A Jordan
    design of at most m rows (decoupled or not, linear or not) has at most m distinct λ,
    the roots of a chain polynomial (shared by every row of M) of that degree; members
    nest (q of degree m − 1 times (λ − c) is a member of degree m), so order k − 1 ruled
    out proves k minimal; for one row z in a linear model such a polynomial is also
    enough."""
    ref = "METHOD §2b; seed 002 §2"
    name = "k is minimal over λ"
    special = [v for v in lams if not any(_same_number(v, w)
                                          for w in default_eigenvalues(time, n))]
    found = (f"λ = {', '.join(map(str, special))} found exactly (not in the default list); "
             if adm.generic and special and not requested else "")
    if k == 1:
        return Condition(name, True, found + "k = 1: one row, the fewest possible", ref,
                         required=False)
    if span is not None and span.analysed and not span.possible and k == span.q + 1:
        return Condition(name, True, found + f"every model of z has at least {span.q} rows"
                         " (rank [M; H] − rank H), and exactly that many is impossible for"
                         f" every real stable λ: {span.evidence}", ref, required=False)
    no_more = (span is not None and span.analysed and not span.possible and more is not None
               and more.analysed and not more.possible)
    if no_more and k == span.q + 2:
        return Condition(name, True, found + f"every model of z has at least {span.q} rows"
                         " (rank [M; H] − rank H); exactly that many is impossible for every"
                         f" real stable λ ({span.evidence}); and {span.q + 1} rows are impossible"
                         f" too: {more.evidence}", ref, required=False)
    if (short is not None and short.analysed and not short.possible and k == short.k + 1
            and not requested):
        return Condition(name, True, found + f"k = {k} rows form a basis modulo the outputs;"
                         f" {short.k} rows are impossible for every real stable λ, and a model"
                         " of fewer rows would extend to that many by rows of further λ:"
                         f" {short.evidence}", ref, required=False)
    if requested:
        why = f"k = {k} for the requested λ only; other λ were not searched"
        proven = False
    elif not adm.generic and (several or nonlinear is not None):
        # z with several components, or nonlinear terms: the search takes particular
        # combinations of each λ's rows, so fewer rows through another combination are
        # not ruled out by the search itself (the bounds below may still prove k)
        why = (f"every stable admissible λ ({', '.join(map(str, lam_list))}; {adm.describe()})"
               " was searched, with particular combinations of each λ's rows")
        proven = False
    elif not adm.generic:
        return Condition(name, True, f"every stable admissible λ ({', '.join(map(str, lam_list))};"
                         f" {adm.describe()}) was searched: no set of fewer than {k} rows"
                         " satisfies the task", ref, required=False)
    else:
        why, proven = _searched(observer, k, lam_list, one_row, jumps)
    if proven:
        return Condition(name, True, found + why, ref, required=False)
    below = [c for c in chains if c.m < k]
    if not requested and below and below[-1].m == k - 1 and below[-1].impossible:
        return Condition(name, True, found + "no Jordan model of fewer rows: a model of m rows"
                         " has its distinct λ (at most m, real, stable) as the roots of a"
                         " monic p with M p(F) ∈ rowspace [H; …; H Fᵐ] (and r(s) L = 0 for"
                         " decoupled inputs, METHOD §2b), and such a p of degree m − 1 times"
                         " (λ − c) is one of"
                         f" degree m, so order {k - 1} ruling it out rules out every lower"
                         " order; " + "; ".join(c.evidence for c in below), ref,
                         required=False)
    b = bound(k)
    where = (f" (for parameters with {', '.join(sorted(str(c.lhs) for c in b.conditions))}"
             " nonzero)" if b.conditions else "")
    anyf = ("no residual generator of any form (any F*) with fewer states responds to every"
            " fault" if observer == "diagnostic" else "every model of any form (any F*) giving z"
            " has at least that many states")
    if b.k == k:  # the bound proves it: say so first, then what the search covered
        return Condition(name, True, found + f"k = {k} is a lower bound: {anyf}{where} —"
                         f" {b.evidence} (the search: {why})", ref, required=False)
    if b.k > k:  # a diagnostic design whose residual misses a fault (unobservable rows)
        return Condition(name, False, found + f"{why}; but {anyf} below {b.k} states{where}"
                         f" ({b.evidence}): this design's residual does not respond to every"
                         " fault (see the observability of (F*, H*))", ref, required=False)
    nb = nonlinear(k) if nonlinear is not None and not requested else None
    if nb is not None and nb.k >= k:
        return Condition(name, True, found + f"{why}; and k = {k} is a lower bound for every"
                         f" Jordan model: {nb.evidence}", ref, required=False)
    least = (f"; an order-{b.k} model exists for some F* (its eigenvalues need not be real,"
             " distinct or stable)" if b.exact else "")
    lo = b.k  # the least Jordan order: at least every bound proven
    if below:
        least += "; chain polynomials: " + "; ".join(c.evidence for c in below)
        lo = max([lo] + [c.m + 1 for c in below if c.impossible])
    if span is not None and span.analysed:
        least += f"; {span.q} rows (rank [M; H] − rank H): {span.evidence}"
        if not span.possible:
            lo = max(lo, span.q + 1)
        if more is not None:
            least += f"; {span.q + 1} rows: {more.evidence}"
            if no_more:
                lo = max(lo, span.q + 2)
    if short is not None:
        least += f"; {short.k} rows: {short.evidence}"
    if (plane is not None and plane.analysed and not plane.possible and lo >= plane.k
            and k == plane.k + 1):
        return Condition(name, True, found + f"{why}; every Jordan model has at least"
                         f" {plane.k} rows (the lower bound over every F* is {b.k}{where}:"
                         f" {b.evidence}{least}), and exactly {plane.k} are impossible for every"
                         f" real stable λ: {plane.evidence}", ref, required=False)
    if plane is not None:
        least += f"; {plane.k} rows: {plane.evidence}"
        if plane.analysed and not plane.possible and lo >= plane.k:
            lo = max(lo, plane.k + 1)
    if solid is not None and solid.analysed and not solid.possible and k == solid.k + 1:
        return Condition(name, True, found + f"{why}; exactly {solid.k} rows are impossible for"
                         " every real stable λ, and a model of fewer rows would extend to that"
                         " many by rows of further λ (their images span all c dimensions and a"
                         f" model exists): {solid.evidence} (fewer: the lower bound over every"
                         f" F* is {b.k}{where}: {b.evidence}{least})", ref, required=False)
    if solid is not None:
        least += f"; {solid.k} rows: {solid.evidence}"
    return Condition(name, False, found + f"{why}; the lower bound over every F* is {b.k}{where}"
                     f" ({b.evidence}){least}, so the least order of a Jordan model lies in"
                     f" [{lo}, {k}]", ref, required=False)


def _searched(observer, k, lam_list, one_row, jumps) -> tuple:
    """(what the search over λ proves, proven?) for k ≥ 2 when every λ is admissible."""
    stable_txt = ", ".join(map(str, one_row.stable)) if one_row else ""
    if observer == "diagnostic":
        k1 = ("k = 1 is impossible for every λ: a one-row residual needs Φ ∈ rowspace H, and"
              " Φ (F − λI) ∈ rowspace H does not depend on λ")
    elif one_row is None or not one_row.analysed:
        k1 = (f"k = 1 was searched over λ in {{{', '.join(map(str, lam_list))}}} only"
              + (f" ({one_row.evidence})" if one_row else ""))
    elif one_row.generic:
        k1 = (f"k = 1 rows exist for all but finitely many λ ({one_row.evidence}) but none"
              f" satisfies the {observer} conditions (nonlinear argument substitution)")
    elif not one_row.stable:
        k1 = (f"k = 1 is impossible for every real λ: {one_row.evidence}; none is stable"
              if one_row.roots else
              f"k = 1 is impossible for every λ: {one_row.evidence}; no real λ admits one row")
    else:
        k1 = (f"k = 1 is impossible for every real λ: {one_row.evidence}; the stable root(s)"
              f" {stable_txt} were tried and fail the task")
    proven = k == 2 and (observer == "diagnostic" or (one_row is not None and one_row.analysed
                                                       and not one_row.generic))
    more = ("" if k == 2 else
            f"; 2 ≤ k < {k} was searched over λ in {{{', '.join(map(str, lam_list))}}} (the"
            " defaults and the stable roots where P(λ) drops rank"
            f" — {jumps.evidence if jumps else 'not analysed'}) only")
    return k1 + more, proven


def _chain_orders(observer, F, H, M, L, time, n, tries, defaults) -> list:
    """:func:`chain_order` for m = 1, 2, … (z = M x, not diagnostic; ``L`` the decoupled
    inputs or None; ``defaults`` the parameter defaults) until every monic p of degree m
    qualifies (the default λ then suffice) or m = n − 1; with symbolic parameters until the
    first member is found."""
    if observer == "diagnostic" or M is None:
        return []
    symbolic = bool(set().union(*(X.free_symbols for X in (F, H, M)
                                  + ((L,) if L is not None else ()))))
    out = []
    tries = list(tries) + [v for v in spread_lambdas(time)
                           if not any(_same_number(v, w) for w in tries)]
    for m in range(1, n):
        c = chain_order(F, H, M, m, LAMBDA, time, tries, L, defaults)
        out.append(c)
        if (c.verdict == "free" and c.dim >= m) or (symbolic and c.lambdas):
            break
    return out


def _order_bound(observer, F, H, L, D, M, st, k, decoupled):
    """The lower bound on the order of every model of the task (:mod:`._order_bound`)."""
    if observer == "diagnostic":
        return residual_order_bound(F, H, L, D, k - 1)
    return estimation_order_bound(F, H, M, decoupled=decoupled and bool(L.cols),
                                  linear=not st.terms)


def _task_ok(observer, Phi, H, D, M, st, names=()):
    PH = sp.Matrix.vstack(Phi, H)
    rPH = _rank(PH)
    if observer == "diagnostic":
        for c in range(D.cols):
            if (Phi * D[:, c]).applyfunc(sp.cancel) == sp.zeros(Phi.rows, 1):
                nm = names[c] if c < len(names) else f"fault column {c + 1}"
                return False, f"{nm} is not seen (Φ D_{nm} = 0)"
        if not rPH < _rank(Phi) + _rank(H):
            return False, f"rank [Φ; H] = {rPH} is not < rank Φ + rank H (no residual)"
    if M is not None:
        r = _rank(sp.Matrix.vstack(PH, M))
        if r != rPH:
            return False, f"rank [Φ; H] = {rPH} < rank [Φ; H; M] = {r} (z not reachable)"
    if st.terms:
        ok, why, _, _ = substitute_arguments(st, Phi, observer_symbols(Phi.rows),
                                             output_symbols(H.rows))
        if not ok:
            return False, why
    return True, ""


def _report_conditions(observer, time, lams, mats, Phi, H, D, M, fault_syms, CA, nonlinear,
                       k, decoupled):
    conds = []
    for i, lam in enumerate(lams):
        stab = is_stable(lam, time)
        need = "λ < 0" if time == "continuous" else "|λ| < 1"
        conds.append(Condition(f"λ_{i + 1} = {lam} stable", bool(stab) if stab is not None else False,
                               f"{need} ({time} time)" + (" — depends on parameters" if stab is None else ""),
                               "METHOD §2b", required=stab is not None))
    PH = sp.Matrix.vstack(Phi, H)
    rPH, rP, rH = _rank(PH), _rank(Phi), _rank(H)
    if observer == "diagnostic":
        conds.append(Condition("residual condition rank [Φ; H] < rank Φ + rank H", rPH < rP + rH,
                               f"rank [Φ; H] = {rPH}, rank Φ + rank H = {rP} + {rH} = {rP + rH}",
                               "seed 002 eq. (2.7)"))
        for c, f in enumerate(fault_syms):
            col = (Phi * D[:, c]).applyfunc(sp.cancel)
            rows = [i + 1 for i in range(k) if col[i] != 0]
            conds.append(Condition(f"fault sensitivity ({f.name})", bool(rows),
                                   f"Φ D = {list(col)}; seen by row(s) {rows}",
                                   "seed 002 §2, Remark 1"))
        Hs, Fs = mats["H_star"], mats["F_star"]
        O = sp.Matrix.vstack(*[Hs * Fs ** i for i in range(k)])
        ro = _rank(O)
        conds.append(Condition("observability of (F*, H*)", ro == k,
                               f"rank of the observability matrix = {ro} (k = {k})", "METHOD §4",
                               required=False))
    if M is not None:
        rPHM = _rank(sp.Matrix.vstack(PH, M))
        conds.append(Condition("z = M x reachable: rank [Φ; H] = rank [Φ; H; M]", rPH == rPHM,
                               f"rank [Φ; H] = {rPH}, rank [Φ; H; M] = {rPHM}", "seed 002 eq. (3.2)"))
        Hz = mats["Hz"]
        nonneg = all((e.is_nonnegative is True) for e in Hz)
        conds.append(Condition("H_z ≥ 0", nonneg, f"H_z = {list(Hz)}"
                               + ("" if nonneg else " (the interval bounds use the split H_z⁺, H_z⁻)"),
                               "METHOD §3", required=False))
    for ns in nonlinear:
        A = CA[ns.index - 1][1]
        r2 = _rank(sp.Matrix.vstack(PH, A))
        conds.append(Condition(f"argument substitution for Ψ_{ns.index}: rank [Φ; H] = rank [Φ; H; A_{ns.index}]",
                               rPH == r2, f"{rPH} = {r2}; Ψ*_{ns.index} = {ns.function}",
                               "METHOD §2c; seed 002 eq. (6.3)"))
    Fs = mats["F_star"]
    if time == "continuous":
        conds.append(Condition("F* Metzler", True, "F* is diagonal", "METHOD §3", required=False))
    else:
        nonneg = all((e.is_nonnegative is True) for e in Fs)
        conds.append(Condition("F* nonnegative", nonneg,
                               f"diag(F*) = {list(Fs.diagonal())}"
                               + ("" if nonneg else " (interval bounds then use the ⁺/⁻ split)"),
                               "METHOD §3", required=False))
    if not decoupled:
        conds.append(Condition("decoupling", True, "not required (interval observer): L* = Φ L"
                               f" = {mats.get('L_star', sp.zeros(0, 0)).tolist()}", "METHOD §2b"))
    return conds


def design_jordan_unknown_input(model: PlantModel, unknown_input: str, lam, *,
                                decouple: Sequence[str] = (), symbolic: bool = False,
                                task: Task | None = None) -> Design:
    """The one-row λ-model x*(t+1) = λ x* + J* y + G* u + D* d, x* = R* y (seed 000 §8).

    Built by :func:`~observer_cad.synthesis.design_jordan` (``observer="diagnostic"``) with
    the single requested λ; the design must have k = 1 (Φ = R* H: x* measured).
    Note: such a row exists iff the canonical k = 1 model does, for every λ — λ R* H
    lies in the row space of H and is absorbed into J* (J*_λ = J*_0 − λ R*).
    """
    d = design_jordan(model, observer="diagnostic", faults=[unknown_input],
                      decouple=decouple, lambdas=[lam], symbolic=symbolic, task=task)
    if d.k != 1:
        raise UsageError(f"no one-row λ-model with x* = R* y for '{unknown_input}'"
                         f" (the Jordan design needs k = {d.k})")
    return d.with_task(observer=ObserverKind.UNKNOWN_INPUT)
