"""The one entry of the minimality proofs: :func:`prove_minimal` (METHOD §2b, "k is
minimal over λ").

The row search hands over the rows it chose (:class:`ChosenRows`) and what it learnt on
the way (:class:`MinimalityProblem`: the λ searched, the special λ, the chain
polynomials, whether q and q + 1 rows are possible). The proof then runs its stages, each
an exact decision that may also find fewer rows:

1. one row fewer than a basis modulo the outputs (each λ with one row);
2. q + 3 rows, when q + 4 were found (planes of six dimensions);
3. q + 2 rows, when q + 3 (or q + 4) were found (planes of four, five, six dimensions);
4. the lower bound over every F* and, for nonlinear terms, over every Jordan model,
   composed into the condition (:func:`minimality_condition`).

The stages and the cells of their covers check a :class:`ProofClock`; when the budget
(``seconds``, default :data:`~observer_cad.synthesis.core.PROOF_SECONDS`) is spent the
stage is reported as not decided, and the condition gives the range the least order lies
in and says that the budget stopped it. ``seconds=None`` is the exhaustive proof. The
lower bound over every F* always runs (the range needs it; it is a few exact ranks).

References: METHOD §2b; seed 002 §2.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ....numerics import exact_product, solve_left
from .._admissible import LAMBDA, rank_of, rows_for_lambda
from .._rows_check import rows_satisfy_task
from ._bounds import estimation_order_bound, nonlinear_jordan_bound, residual_order_bound
from ._clock import ProofClock, ProofStopped
from ._condition import Verdicts, minimality_condition
from ._row_counts import (basis_minus_one_rows_possible, q_plus_three_rows_possible,
                          q_plus_two_rows_possible)
from ._rows_verdict import RowsVerdict

__all__ = ["MinimalityProblem", "ChosenRows", "prove_minimal", "order_bound"]


@dataclasses.dataclass(frozen=True)
class ChosenRows:
    """Rows of a Jordan design and the attempts that failed before them.

    Parameters
    ----------
    rows : tuple
        ``(λ_i, Φ_i, J*_i)`` per row (exact; Φ_i 1 × n, J*_i 1 × l).
    tried : tuple of str
        Why smaller sets were rejected (at most 12 entries), in order.
    """

    rows: tuple
    tried: tuple = ()

    @property
    def k(self) -> int:
        return len(self.rows)

    @property
    def lambdas(self) -> tuple:
        return tuple(r[0] for r in self.rows)


@dataclasses.dataclass(frozen=True)
class MinimalityProblem:
    """What the proof that a Jordan design has the fewest rows needs (METHOD §2b).

    Parameters
    ----------
    observer : {"diagnostic", "virtual-sensor", "interval"}
    time : {"continuous", "discrete"}
    F, H, D, M, C : sympy.Matrix
        The plant's state, output, fault, estimate (z = M x, None for a residual) and
        nonlinear-term matrices.
    L : sympy.Matrix
        The decoupled inputs (n × 0 when the observer is not decoupled).
    L0 : sympy.Matrix
        Rows of maximal rank with L0 L = 0 (I when not decoupled).
    A_rows : tuple of sympy.Matrix
        The argument rows A_j of the nonlinear terms (empty for a linear model).
    structure : Structure
        The plant structure (argument substitution of candidate rows).
    names : tuple of str
        The faults detected (diagnostic).
    requested : bool
        The λ were requested (then minimality over λ is not claimed).
    lam_list : tuple
        The λ searched.
    admissible : Admissible
    one_row, jumps : SpecialLambdas or None
        The λ of one-row designs and the family jumps (every λ admissible).
    chains : tuple of ChainOrder
        What the chain polynomials of each order said.
    span : QRowsVerdict or None
        Whether q = rank [M; H] − rank H rows are possible.
    more : RowsVerdict or None
        Whether q + 1 rows are possible (decided during the search).
    bounds : tuple
        ``(k, OrderBound)`` pairs the search computed already.
    seconds : float or None
        The proof's time budget; None for the exhaustive proof.
    """

    observer: str
    time: str
    F: sp.Matrix
    H: sp.Matrix
    L: sp.Matrix
    L0: sp.Matrix
    D: sp.Matrix
    M: sp.Matrix | None
    C: sp.Matrix
    A_rows: tuple
    structure: object
    names: tuple
    requested: bool
    lam_list: tuple
    admissible: object
    one_row: object = None
    jumps: object = None
    chains: tuple = ()
    span: object = None
    more: object = None
    bounds: tuple = ()
    seconds: float | None = None

    @property
    def n(self) -> int:
        return self.F.rows

    @property
    def several(self) -> bool:
        """z has several components."""
        return self.M is not None and self.M.rows > 1

    @property
    def nonlinear_terms(self) -> bool:
        """Nonlinear terms bound the rows of every Jordan model of z (λ searched)."""
        return bool(self.A_rows) and self.M is not None and not self.requested


def order_bound(problem: MinimalityProblem, k: int):
    """The lower bound on the order of every model of the task, any F* (:mod:`._bounds`):
    the canonical residual generators below k (diagnostic), else the subspace and chain
    bounds of z = M x."""
    for k_, b in problem.bounds:
        if k_ == k:
            return b
    if problem.observer == "diagnostic":
        return residual_order_bound(problem.F, problem.H, problem.L, problem.D, k - 1)
    return estimation_order_bound(problem.F, problem.H, problem.M,
                                  decoupled=bool(problem.L.cols), linear=not problem.A_rows)


def prove_minimal(problem: MinimalityProblem, chosen: ChosenRows) -> tuple:
    """Prove, within the time budget, that no Jordan model has fewer rows than ``chosen``
    — finding fewer rows on the way when a decision builds them (METHOD §2b).

    Parameters
    ----------
    problem : MinimalityProblem
    chosen : ChosenRows
        The rows the search found.

    Returns
    -------
    chosen : ChosenRows
        The rows of the design: ``chosen``, or fewer rows an exact decision built (with the
        attempts that failed appended).
    condition : Condition
        "k is minimal over λ" (not required): proven, or the range the least order lies
        in, with the stages the budget stopped named.

    Method
    ------
    The stages of the module docstring in order; a :class:`ProofClock` started here is
    checked between stages and between the steps of each (cells of a cover, members
    tried); a stage it stops is reported as not decided. With ``problem.seconds`` None the
    proof runs to its end and gives exactly the exhaustive result.

    References
    ----------
    METHOD §2b; seed 002 §2.
    """
    clock = ProofClock.start(problem.seconds)
    rows, tried, stopped = chosen.rows, list(chosen.tried), []
    verdicts = {}
    for stage in _STAGES:
        name = stage.name
        if not stage.applies(problem, rows, verdicts):
            continue
        try:
            verdict = stage.decide(problem, clock)
        except ProofStopped:
            k_stage = stage.rows_asked(problem, rows)
            verdict = RowsVerdict(False, False, (), "not decided: the proof's time budget"
                                  f" of {clock.describe()} ran out", k_stage)
            stopped.append(f"whether {k_stage} rows are possible")
        verdicts[name] = verdict
        rows = _rows_of(problem, name, verdict, rows, tried)
    bounds = {}

    def bound(k):
        if k not in bounds:
            bounds[k] = order_bound(problem, k)
        return bounds[k]

    def nonlinear(k):  # every Jordan model with the argument substitution (§2c)
        try:
            return nonlinear_jordan_bound(
                problem.F, problem.H, problem.L, problem.M, problem.C, list(problem.A_rows),
                k, LAMBDA, problem.time, list(problem.lam_list), clock=clock)
        except ProofStopped:
            stopped.append("the bound of the nonlinear terms")
            return None

    found = Verdicts(verdicts.get("one row short"), verdicts.get("three more rows"),
                     verdicts.get("two more rows"), clock.describe())
    condition = minimality_condition(problem, len(rows), [r[0] for r in rows], found, bound,
                                     nonlinear if problem.nonlinear_terms else None, stopped)
    return ChosenRows(tuple(rows), tuple(tried)), condition


# ------------------------------------------------------------------ the stages

def _basis(problem, rows) -> bool:
    """One row fewer than a basis modulo the outputs applies: the rows form a basis
    (k = n − rank H) above q + 1, z with several components."""
    span = problem.span
    if not (problem.several and span is not None):
        return False
    return len(rows) == problem.n - rank_of(problem.H) > span.q + 1


def _q_impossible(problem) -> bool:
    span = problem.span
    return problem.several and span is not None and span.analysed and not span.possible


def _solid_applies(problem, rows, verdicts) -> bool:
    """q + 3 rows: q rows impossible and q + 4 found (λ searched)."""
    return _q_impossible(problem) and len(rows) == problem.span.q + 4 and not problem.requested


def _plane_applies(problem, rows, verdicts) -> bool:
    """q + 2 rows: q rows impossible and q + 3 found, or q + 4 with q + 3 decided."""
    solid = verdicts.get("three more rows")
    q = problem.span.q if problem.span is not None else 0
    return (_q_impossible(problem) and not problem.requested
            and (len(rows) == q + 3
                 or (len(rows) == q + 4 and solid is not None and solid.analysed)))


def _decoupled(problem):
    """(F, H, L, M): the arguments of the row-count decisions."""
    return problem.F, problem.H, problem.L, problem.M


@dataclasses.dataclass(frozen=True)
class _Stage:
    """One stage of the proof: its name, when it applies (problem, rows so far, verdicts so
    far), the decision (problem, clock) and the number of rows it asks about."""

    name: str
    applies: object
    decide: object
    rows_asked: object


_STAGES = (
    _Stage("one row short", lambda p, rows, v: _basis(p, rows),
           lambda p, clock: basis_minus_one_rows_possible(*_decoupled(p), LAMBDA, p.time, clock),
           lambda p, rows: len(rows) - 1),
    _Stage("three more rows", _solid_applies,
           lambda p, clock: q_plus_three_rows_possible(*_decoupled(p), LAMBDA, p.time, clock),
           lambda p, rows: p.span.q + 3),
    _Stage("two more rows", _plane_applies,
           lambda p, clock: q_plus_two_rows_possible(*_decoupled(p), LAMBDA, p.time, clock),
           lambda p, rows: p.span.q + 2),
)


def _rows_of(problem, name, verdict, rows, tried) -> tuple:
    """The rows a decision built, when they do the task; else ``rows``."""
    if name == "one row short":
        if verdict.possible and verdict.lambdas:
            alt = _one_row_per_lambda(problem, verdict.lambdas, tried)
            if alt is not None:
                return tuple(alt)
        return rows
    if verdict.possible and verdict.rows:
        alt = _rows_with_given_phi(problem, verdict.lambdas, verdict.rows, tried)
        if alt is not None:
            return tuple(alt)
    return rows


def _check(problem, rows, tried) -> bool:
    return rows_satisfy_task(rows, len(rows), problem.observer, problem.H, problem.D,
                             problem.M, problem.structure, tried, problem.names)


def _one_row_per_lambda(problem, lams, tried):
    """One row of each λ (families of one row each, :func:`basis_minus_one_rows_possible`)
    when they satisfy the task, else None."""
    rows = []
    for lam in lams:
        rows_phi, rows_j, _ = rows_for_lambda(problem.F, problem.H, problem.L0, lam)
        if len(rows_phi) != 1:
            return None
        rows.append((lam, rows_phi[0], rows_j[0]))
    return rows if _check(problem, rows, tried) else None


def _rows_with_given_phi(problem, lams, phis, tried):
    """Rows Φ_i of λ_i given exactly (:func:`q_plus_two_rows_possible`,
    :func:`q_plus_three_rows_possible`), with J*_i from Φ_i (F − λ_i I) = J*_i H, when
    they satisfy the task, else None."""
    F, H = problem.F, problem.H
    rows = []
    for lam, phi in zip(lams, phis):
        J = solve_left(H, exact_product(phi, F - lam * sp.eye(F.rows)))
        if J is None:  # pragma: no cover - the rows of λ satisfy it by construction
            return None
        rows.append((lam, phi, J))
    return rows if _check(problem, rows, tried) else None
