"""Step 3 of the Jordan design (METHOD §2b): the fewest rows that do the task.

One strategy per case, each with one entry (``search``):

- :class:`ResidualRows` (diagnostic): sets of pool rows, fewest first (distinct λ before
  repeated ones), then generic members of each λ's family, then rows of several λ whose
  sum lies in rowspace H;
- :class:`EstimateRows` (z = M x, one component): M = Σ c_λ N_λ L0 + Q H solved over
  sets of distinct λ, fewest first (the chain polynomials' roots as whole sets first);
- :class:`SeveralComponentRows` (z with several components): rows spanning z modulo the
  outputs (q of them when possible), the solve above, q + e rows through sets of λ when q
  rows are impossible, rows spanning z and e extra rows, and combinations when rows
  share a λ.

Every strategy ends with the pool combinations when nothing else was found.

References: seed 002 §2-3, eqs. (2.7), (3.2); METHOD §2b.
"""
from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import sympy as sp

from ...errors import InfeasibleDesignError
from ...numerics import exact_product, left_null_space, solve_left
from ...progress import report
from ._admissible import LAMBDA, rank_of, rows_for_lambda
from ._lambda_sets import (PRECHECK_RTOL, TUPLE_E_CAP, TUPLE_E_MAX, float_rank_full, rows_spanning_z,
                           rows_through_lambda_sets)
from ._rows_check import rows_satisfy_task
from .minimality import ChosenRows, estimation_order_bound, q_plus_one_rows_possible


def _measured_rows(family, H):
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


def _rows_solving_for_z(fam, lam_list, H, M, n, observer, D, st, tried, names=(), sets=()):
    """Sets of distinct λ, smallest first: solve M = Σ c_λ N_λ L0 + Q H for one row per λ.
    ``sets``: whole λ sets (the roots of a chain polynomial) tried first at their size."""
    lams = [lam for lam in lam_list if lam in fam]
    for size in range(1, n):
        report(f"designing (Jordan form): {size} row(s) of at most {n - 1}")
        first = [c for c in sets if len(c) == size and all(lam in fam for lam in c)]
        for combo in itertools.chain(first, itertools.combinations(lams, size)):
            B = sp.Matrix.vstack(*[fam[lam][0] for lam in combo])
            if irrational(combo) and not maybe_in_rowspace(sp.Matrix.vstack(B, H), M):
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
                    if rank_of(trial) == len(mine) + 1:
                        mine.append((lam, block[i, :], Jblock[i, :]))
                used += bool(mine)
                rows += mine
            if used != size:
                continue  # a smaller set does it (found earlier unless the task failed)
            if rows_satisfy_task(rows, len(rows), observer, H, D, M, st, tried, names):
                return rows
    return None


def _rows_spanning_z_and_extra(fam, lam_list, pool, H, M, observer, D, st, tried, names, k):
    """Fewer than k rows for z with several components: rows spanning [M; e rows of the
    pool at e distinct λ] modulo H (e = 1 … k − q − 1): a model of q + e rows whose rows lie
    in rowspace [M; extra; H] (METHOD §2b). A space of dimension q + e meets a λ's rows
    (f of them, modulo H in n − rank H dimensions) generically only once
    f + q + e > n − rank H, so below that e only a few choices are tried."""
    rH = rank_of(H)
    q = rank_of(sp.Matrix.vstack(H, M)) - rH
    first = {}
    for r in pool:
        first.setdefault(r[0], r)
    lams = [lam for lam in lam_list if lam in first]
    f = max((fam[lam][0].rows for lam in lams), default=0)
    generic = H.cols - rH - f - q + 1
    for e in range(1, k - q):
        tries = _EXTENDED_TRIES if e >= generic else 3
        for combo in itertools.islice(itertools.combinations(lams, e), tries):
            rows = rows_spanning_z(fam, lam_list, H, M, observer, D, st, tried, names,
                                tuple(first[lam][1] for lam in combo))
            if rows is not None and len(rows) < k:
                return rows
    return None


#: extra-row choices tried per e by :func:`_rows_spanning_z_and_extra`
_EXTENDED_TRIES = 24


#: the most pool combinations tried for one size when rows share a λ (fewer when some λ
#: are algebraic: each exact rank is then far slower)
_COMBINATIONS_MAX = 2000


_COMBINATIONS_MAX_ALGEBRAIC = 60


def _fewest_rows_from_pool(pool, n, observer, H, D, M, st, tried, names=(), sizes=None):
    """Fewest rows from the pool; sets with distinct λ before sets that repeat one."""
    for size in sizes or range(1, n):
        report(f"designing (Jordan form): {size} row(s) of at most {n - 1}")
        for distinct in (True, False):
            for combo in itertools.combinations(range(len(pool)), size):
                rows = [pool[i] for i in combo]
                lams = [r[0] for r in rows]
                if (len(set(lams)) == len(lams)) != distinct:
                    continue
                if rows_satisfy_task(rows, size, observer, H, D, M, st, tried, names):
                    return rows
    return None


def irrational(lams) -> bool:
    return any(lam.is_number and not lam.is_rational for lam in lams)


def maybe_in_rowspace(B, M) -> bool:
    """False when X B = M is far from solvable in floating point (exact arithmetic in an
    algebraic field of high degree is slow; only sets that pass are solved exactly)."""
    try:
        Bn = np.array(B.evalf(30).tolist(), dtype=float)
        Mn = np.array(M.evalf(30).tolist(), dtype=float)
    except (TypeError, ValueError):  # symbolic entries: let the exact solve decide
        return True
    X, *_ = np.linalg.lstsq(Bn.T, Mn.T, rcond=None)
    res = np.linalg.norm(X.T @ Bn - Mn)
    return bool(res <= PRECHECK_RTOL * max(1.0, np.linalg.norm(Mn)) * max(1.0, np.linalg.norm(Bn)))


def _residual_rows_across_lambdas(fam, lam_list, H, D, n, observer, M, st, tried, names, size):
    """Diagnostic rows of ``size`` distinct λ whose sum lies in rowspace H (seed 002 (2.7)):
    Σ_λ c_λ N_λ L0 + h H = 0 from the left null space of [N_λ1 L0; …; H], one row
    Φ_i = c_λi N_λi L0 per λ, every λ used (a smaller set is tried before)."""
    lams = [lam for lam in lam_list if lam in fam]
    for combo in itertools.combinations(lams, size):
        Bs = [fam[lam][0] for lam in combo]
        if irrational(combo) and float_rank_full(sp.Matrix.vstack(*Bs, H)):
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
            if len(rows) == size and rows_satisfy_task(rows, size, observer, H, D, M, st, tried,
                                                 names):
                return rows
    return None


def _with_decoupled(task) -> str:
    return f" with {', '.join(task.decoupled)} decoupled" if task.decoupled else ""


def _blind(names, pool, D) -> list:
    """The targets no candidate row sees (Φ_i D_j = 0 for every row of every λ family)."""
    return [nm for c, nm in enumerate(names)
            if all((r[1] * D[:, c]).applyfunc(sp.cancel) == sp.zeros(1, 1) for r in pool)]


def _diagnostic_refusal(where, task, names, pool, D, lam_list, tried, n) -> str:
    """Why no residual detects the targets: the faults no row sees, else the faults no
    residual of order < n sees, named."""
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


# ------------------------------------------------------------------ the pool of rows

@dataclasses.dataclass(frozen=True)
class RowPool:
    """The rows of every λ of a :class:`LambdaChoice` (step 3 of METHOD §2b).

    Parameters
    ----------
    families : dict
        λ ↦ (basis rows N_λ L0 stacked, their J*), for the λ with a nonzero row.
    rows : tuple
        ``(λ, Φ_i, J*_i)``: the basis rows of the pool's λ and, for a residual, the rows
        inside rowspace H.
    sums : tuple
        Diagnostic: one generic member per λ family (Σ of its basis rows), tried last.
    pivots : dict
        λ ↦ the parameter pivots of its null space.
    """

    families: dict
    rows: tuple
    sums: tuple
    pivots: dict


def row_pool(problem, choice) -> RowPool:
    """Step 3 of METHOD §2b: for every λ the whole family of rows, Φ = c N_λ L0,
    J* = c J_λ.

    Raises
    ------
    InfeasibleDesignError
        No λ gives a nonzero row.
    """
    F, H, L0 = problem.F, problem.H, problem.L0
    fam, pool, sums, pivots = {}, [], [], {}
    every = choice.every
    for i_lam, lam in enumerate(every):
        report(f"designing (Jordan form): null space for λ = {lam} ({i_lam + 1} of"
               f" {len(every)})")
        rows_phi, rows_j, pivots[lam] = rows_for_lambda(F, H, L0, lam)
        if i_lam < len(choice.values):
            pool += [(lam, Phi_i, J_i) for Phi_i, J_i in zip(rows_phi, rows_j)]
        if rows_phi:
            fam[lam] = (sp.Matrix.vstack(*rows_phi), sp.Matrix.vstack(*rows_j))
            if problem.observer == "diagnostic":  # rows inside rowspace(H): k = 1 residuals
                for measured in _measured_rows(fam[lam], H):
                    pool.append((lam,) + measured)
                if len(rows_phi) > 1:  # a row that sees what each basis row sees
                    sums.append((lam, sum(rows_phi[1:], rows_phi[0]).applyfunc(sp.cancel),
                                 sum(rows_j[1:], rows_j[0]).applyfunc(sp.cancel)))
    if not pool:
        raise InfeasibleDesignError(f"{problem.where}: no nonzero row Φ_i for λ in"
                                    f" {list(choice.values)}")
    return RowPool(fam, tuple(pool), tuple(sums), pivots)


# ------------------------------------------------------------------ the strategies

@dataclasses.dataclass(frozen=True)
class RowSearch:
    """What a row search found: the rows (None when nothing does the task), the attempts
    that failed, and what it decided on the way (q + 1 rows; lower bounds computed)."""

    rows: tuple | None
    tried: tuple
    more: object = None
    bounds: tuple = ()

    def chosen(self) -> ChosenRows:
        return ChosenRows(tuple(self.rows), self.tried)


def _args(problem):
    """The arguments every row check takes: (observer, H, D, M, structure)."""
    return problem.observer, problem.H, problem.D, problem.M, problem.structure


def _fewest_of_all(problem, choice, pool, tried):
    """Fewest rows first, every strategy: pool combinations, then generic members, then
    (diagnostic) rows of several λ whose sum lies in rowspace H."""
    observer, H, D, M, st = _args(problem)
    n, names = problem.n, problem.names
    for size in range(1, n):
        chosen = _fewest_rows_from_pool(list(pool.rows), n, observer, H, D, M, st, tried, names,
                                        (size,))
        if chosen is None and pool.sums:  # the basis rows alone do not do it
            chosen = _fewest_rows_from_pool(list(pool.rows + pool.sums), n, observer, H, D, M,
                                            st, tried, names, (size,))
        if chosen is None and observer == "diagnostic" and size > 1:  # rows of several λ
            chosen = _residual_rows_across_lambdas(pool.families, list(choice.values), H, D, n,
                                                   observer, M, st, tried, names, size)
        if chosen is not None:
            return chosen
    return None


@dataclasses.dataclass(frozen=True)
class ResidualRows:
    """A residual generator (diagnostic): the fewest pool rows that see every fault and
    give a residual (seed 002 eq. (2.7), Remark 1)."""

    def search(self, problem, choice, pool) -> RowSearch:
        """
        Raises
        ------
        InfeasibleDesignError
            Some fault is seen by no row of any λ (said before searching).
        """
        names = problem.names
        if _blind(names, pool.rows, problem.D):  # no row sees it: say so now
            raise InfeasibleDesignError(_diagnostic_refusal(
                problem.where, problem.task, names, pool.rows, problem.D, list(choice.values),
                [], problem.n))
        tried = []
        return RowSearch(_fewest_of_all(problem, choice, pool, tried), tuple(tried))


@dataclasses.dataclass(frozen=True)
class EstimateRows:
    """z = M x with one component: M = Σ c_λ N_λ L0 + Q H over sets of distinct λ
    (seed 002 eq. (3.2)), the chain polynomials' roots first at their size."""

    def search(self, problem, choice, pool) -> RowSearch:
        observer, H, D, M, st = _args(problem)
        tried = []
        chosen = _rows_solving_for_z(pool.families, list(choice.values), H, M, problem.n,
                                     observer, D, st, tried, problem.names,
                                     tuple(c.lambdas for c in choice.chains if c.lambdas))
        if chosen is None:
            chosen = _fewest_of_all(problem, choice, pool, tried)
        return RowSearch(chosen, tuple(tried))


@dataclasses.dataclass(frozen=True)
class SeveralComponentRows:
    """z = M x with several components (METHOD §2b, "Fewest rows for several
    components"): q rows spanning z modulo the outputs, else the solve, then q + e rows
    through sets of λ when q rows are impossible, rows spanning z and e extra rows, and
    combinations when rows share a λ."""

    def search(self, problem, choice, pool) -> RowSearch:
        observer, H, D, M, st = _args(problem)
        fam, span, names, tried = pool.families, choice.span, problem.names, []
        chosen = None
        if span is None or span.possible:
            chosen = rows_spanning_z(fam, list(choice.every), H, M, observer, D, st, tried,
                                     names)
        if chosen is None:  # directed: M ∈ rowspace(H) + Σ_λ rowspace(N_λ L0)
            chosen = _rows_solving_for_z(fam, list(choice.values), H, M, problem.n, observer,
                                         D, st, tried, names,
                                         tuple(c.lambdas for c in choice.chains if c.lambdas))
        more, bounds = None, ()
        if (chosen is not None and span is not None and span.analysed and not span.possible
                and len(chosen) > span.q + 1):
            chosen, more, bounds = _q_plus_e_rows(problem, choice, pool, chosen, tried)
        if chosen is not None and not (span is not None and span.analysed
                                       and len(chosen) == span.q + (not span.possible)):
            chosen = _fewer_through_extra_rows(problem, choice, pool, chosen, tried)
        if chosen is None:
            chosen = _fewest_of_all(problem, choice, pool, tried)
        return RowSearch(chosen, tuple(tried), more, bounds)


def _q_plus_e_rows(problem, choice, pool, chosen, tried) -> tuple:
    """q rows impossible: q + e rows whose images modulo [M; H] lie in e dimensions
    (e = 1: one line), from the least e the lower bound over every F* allows, e = 1 skipped
    when decided impossible (:func:`q_plus_one_rows_possible`); then e = c − f, where the
    rows of one further λ generically meet U at finitely many λ (c = n − rank [M; H], f rows
    per λ; smaller e need specially placed sets, which the scan rarely hits).
    Returns (rows, the q + 1 verdict or None, ((k, bound),))."""
    F, H, M, n, span, fam = problem.F, problem.H, problem.M, problem.n, choice.span, pool.families
    L_span = problem.L_decoupled
    b = estimation_order_bound(F, H, M, decoupled=problem.decoupled and bool(problem.L.cols),
                               linear=not problem.structure.terms)
    e_least = max(1, b.k - span.q)
    more = None
    if e_least == 1:  # (the bound does not already rule out q + 1 rows)
        more = q_plus_one_rows_possible(F, H, L_span, M, LAMBDA, problem.time)
        e_least += more.analysed and not more.possible
    f_rows = sorted(v[0].rows for v in fam.values())[len(fam) // 2] if fam else 0
    generic_e = n - rank_of(sp.Matrix.vstack(M, H)) - f_rows
    es = list(range(e_least, TUPLE_E_MAX + 1))
    es += [generic_e] if max(TUPLE_E_MAX, e_least - 1) < generic_e <= TUPLE_E_CAP else []
    for e in es:
        if len(chosen) <= span.q + e:
            break
        alt = rows_through_lambda_sets(F, H, L_span, problem.L0, fam, list(choice.values), M,
                                       problem.observer, problem.D, problem.structure, tried,
                                       problem.names, problem.time, e,
                                       more.lambdas if more else ())
        if alt is not None and len(alt) < len(chosen):
            return alt, more, ((len(chosen), b),)
    return chosen, more, ((len(chosen), b),)


def _fewer_through_extra_rows(problem, choice, pool, chosen, tried):
    """z with several components, not already at the least: rows spanning [M; e extra
    rows] modulo H; then, when rows still share a λ, more λ with one basis row each
    (every combination of the pool, while there are not too many)."""
    observer, H, D, M, st = _args(problem)
    alt = _rows_spanning_z_and_extra(pool.families, list(choice.every), list(pool.rows), H, M,
                                     observer, D, st, tried, problem.names, len(chosen))
    chosen = alt or chosen
    if len(chosen) > len({r[0] for r in chosen}):
        cap = (_COMBINATIONS_MAX_ALGEBRAIC if any(r[0].has(sp.CRootOf) for r in pool.rows)
               else _COMBINATIONS_MAX)
        for size in range(len({r[0] for r in chosen}), len(chosen)):
            if math.comb(len(pool.rows), size) > cap:
                break
            alt = _fewest_rows_from_pool(list(pool.rows), problem.n, observer, H, D, M, st,
                                         tried, problem.names, (size,))
            if alt is not None:
                return alt
    return chosen


def row_strategy(problem):
    """The row search for the case: a residual, one estimate, several components."""
    if problem.observer == "diagnostic" or problem.M is None:
        return ResidualRows()
    return SeveralComponentRows() if problem.several else EstimateRows()


def find_rows(problem, choice, pool) -> RowSearch:
    """Step 3 of METHOD §2b: the fewest rows that do the task, by the strategy for the case.

    Raises
    ------
    InfeasibleDesignError
        No set of fewer than n rows does it (for a residual: the faults no row sees, or no
        residual of order < n responds to).
    """
    found = row_strategy(problem).search(problem, choice, pool)
    if found.rows is not None:
        return found
    tried = list(found.tried)
    if problem.observer == "diagnostic":
        raise InfeasibleDesignError(_diagnostic_refusal(
            problem.where, problem.task, problem.names, pool.rows, problem.D,
            list(choice.values), tried, problem.n), tuple(tried))
    raise InfeasibleDesignError(
        f"{problem.where}: no Jordan-form {problem.observer} with fewer than n = {problem.n}"
        f" rows for λ in {{{', '.join(map(str, choice.values))}}}: " + "; ".join(tried),
        tuple(tried))
