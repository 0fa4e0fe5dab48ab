"""Step 2 of the Jordan design (METHOD §2b): which λ to take rows from.

The admissible λ are computed exactly (:func:`admissible_lambdas`); then one strategy,
chosen by the case, gives the λ the rows are taken from:

- :class:`RequestedLambdas`: the λ the caller gave, each checked (admissible? stable?);
- :class:`EveryLambdaAdmissible`: the default lists (−1, −2, … / 1/2, 1/4, …), the
  special λ fewer rows may need (a one-row design's root, the family jumps) and the roots
  of the chain polynomials of each order (tried as whole sets);
- :class:`AdmissibleRoots`: every stable admissible root, exactly.

For z with several components the λ at which q = rank [M; H] − rank H rows (the least
any model has) become possible are added (:func:`q_rows_possible`).

References: seed 002 §2, eq. (2.5); METHOD §2b.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ...errors import ExpressionError, InfeasibleDesignError, UsageError
from ...model import parse_expression
from ...numerics import rationalize_floats
from ..core import Condition, default_eigenvalues, is_stable
from ._admissible import LAMBDA, Admissible, admissible_lambdas, same_number
from ._lambda_search import family_jump_lambdas, one_row_lambdas, q_rows_possible
from .minimality import chain_order, spread_lambdas

__all__ = ["LambdaChoice", "RequestedLambdas", "EveryLambdaAdmissible", "AdmissibleRoots",
           "choose_lambdas"]


@dataclasses.dataclass(frozen=True)
class LambdaChoice:
    """The λ a Jordan design takes rows from, and what was learnt choosing them.

    Parameters
    ----------
    admissible : Admissible
    values : tuple
        The λ whose rows form the search's pool, in order.
    whole_sets : tuple
        Further λ (roots of the chain polynomials) tried as whole sets, not in combinations.
    requested : bool
        The λ were given by the caller.
    one_row, jumps : SpecialLambdas or None
        The λ of one-row designs and where the family of rows grows (every λ admissible).
    chains : tuple of ChainOrder
        What the chain polynomials of each order say about the λ an m-row model needs.
    span : QRowsVerdict or None
        Whether q = rank [M; H] − rank H rows are possible (z with several components).
    """

    admissible: Admissible
    values: tuple
    whole_sets: tuple = ()
    requested: bool = False
    one_row: object = None
    jumps: object = None
    chains: tuple = ()
    span: object = None

    @property
    def every(self) -> tuple:
        """The pool's λ, then the whole sets' further λ."""
        return self.values + self.whole_sets

    def condition(self) -> Condition:
        """The condition "admissible λ", as reported."""
        adm = self.admissible
        return Condition("admissible λ", adm.generic or bool(adm.values),
                         f"{adm.describe()}; {adm.evidence}"
                         + (f"; complex roots {', '.join(map(str, adm.other_roots))} are not"
                            " usable" if adm.other_roots else ""),
                         "METHOD §2b; seed 002 eq. (2.5)")


@dataclasses.dataclass(frozen=True)
class RequestedLambdas:
    """The caller's λ, each parsed and checked: admissible and stable."""

    given: tuple

    def choose(self, problem, adm: Admissible) -> LambdaChoice:
        """The requested λ, in order.

        Raises
        ------
        UsageError
            A λ that is not a real number (or a declared parameter with --symbolic).
        InfeasibleDesignError
            A λ that is not admissible or not stable.
        """
        work, where = problem.work, problem.where
        lam_list = []
        for v in self.given:
            try:
                lam = parse_expression(v, list(work.parameters), where="--lambda",
                                       allow_complex=True, allow_crootof=True)
            except ExpressionError as exc:
                raise UsageError(f"λ = {v!r} is not a number: {exc.reason}") from None
            if not isinstance(lam, sp.Expr) or lam.free_symbols - set(work.parameters):
                raise UsageError(f"λ = {v} is not a number (or a declared parameter with"
                                 " --symbolic)")
            if lam.is_number:
                if lam.is_real is False:
                    raise UsageError(f"λ = {v} is not real: the Jordan form needs real λ")
                lam = rationalize_floats(lam)  # a float λ by its decimal string; exact stays
            if not adm.contains(lam):
                raise InfeasibleDesignError(
                    f"{where}: λ = {lam} is not admissible: [L0(F − λI); H] has full row rank"
                    f" there (admissible: {adm.describe()})")
            if is_stable(lam, work.time) is False:
                need = "λ < 0" if work.time == "continuous" else "|λ| < 1"
                raise InfeasibleDesignError(
                    f"{where}: λ = {lam} is not stable in {work.time} time (needs {need})")
            lam_list.append(lam)
        return LambdaChoice(adm, tuple(lam_list), requested=True)


@dataclasses.dataclass(frozen=True)
class EveryLambdaAdmissible:
    """Every λ admissible, none requested: the defaults, the special λ fewer rows may need,
    and the roots of the chain polynomials (METHOD §2b)."""

    def choose(self, problem, adm: Admissible) -> LambdaChoice:
        work, n = problem.work, problem.n
        lam_list = default_eigenvalues(work.time, n)
        one_row, jumps = _special_lambdas(problem)
        for v in (one_row.stable if one_row else ()) + jumps.stable:
            if not any(same_number(v, w) for w in lam_list):
                lam_list.append(v)
        chains = _chain_orders(problem, lam_list)
        whole = []  # the chain polynomials' roots: tried as whole sets, not in combinations
        for c in chains:
            whole += [v for v in c.lambdas if not any(same_number(v, w)
                                                      for w in lam_list + whole)]
        return LambdaChoice(adm, tuple(lam_list), tuple(whole), False, one_row, jumps,
                            tuple(chains))


@dataclasses.dataclass(frozen=True)
class AdmissibleRoots:
    """Finitely many admissible λ: every stable one, exactly (CRootOf for irreducible
    cubics and up), rationals first."""

    def choose(self, problem, adm: Admissible) -> LambdaChoice:
        """The stable admissible roots.

        Raises
        ------
        InfeasibleDesignError
            No admissible root is stable.
        """
        time = problem.time
        lam_list = [v for v in adm.values if is_stable(v, time) is not False]
        lam_list.sort(key=lambda v: (not v.is_rational, v.has(sp.CRootOf), str(v)))
        if not lam_list:
            lead = ""
            if problem.observer == "diagnostic":
                task = problem.task
                dec = f" with {', '.join(task.decoupled)} decoupled" if task.decoupled else ""
                lead = (f"{', '.join(task.targets)} cannot be detected{dec}: no stable λ gives"
                        " a row Φ with Φ L = 0 (a reduced model of order < n); ")
            raise InfeasibleDesignError(
                f"{problem.where}: {lead}no stable admissible λ: {adm.describe()}"
                f" ({adm.evidence})", (adm.evidence,))
        return LambdaChoice(adm, tuple(lam_list))


def lambda_strategy(requested, adm: Admissible):
    """The strategy for the case: the caller's λ, every λ admissible, or finitely many."""
    if requested:
        return RequestedLambdas(tuple(requested))
    return EveryLambdaAdmissible() if adm.generic else AdmissibleRoots()


def choose_lambdas(problem, requested=None) -> LambdaChoice:
    """Step 2 of METHOD §2b: the admissible λ, the λ the rows are taken from (by the
    strategy for the case) and, for z with several components, the λ that q rows need.

    Parameters
    ----------
    problem : JordanProblem
    requested : sequence, optional
        The caller's λ.

    Returns
    -------
    LambdaChoice
    """
    adm = admissible_lambdas(problem.F, problem.H, problem.L0)
    choice = lambda_strategy(requested, adm).choose(problem, adm)
    # z with several components: can q = rank [M; H] − rank H rows (the least any model
    # has) do it for some real stable λ? Decided exactly; the λ it needs are tried.
    if problem.several and not requested and not problem.work.parameters:
        span = q_rows_possible(problem.F, problem.H, problem.L_decoupled, problem.M, LAMBDA,
                               problem.time)
        extra = tuple(v for v in span.stable if not any(same_number(v, w)
                                                        for w in choice.values))
        choice = dataclasses.replace(choice, values=choice.values + extra, span=span)
    return choice


def _special_lambdas(problem):
    """Every λ admissible: the exact special λ (METHOD §2b) — those a one-row design needs
    (virtual sensor / interval observer; diagnostic one-row designs do not depend on λ) and
    those where the family of rows grows."""
    one = None
    if problem.M is not None and problem.observer != "diagnostic":
        one = one_row_lambdas(problem.F, problem.H, problem.L_decoupled, problem.M, LAMBDA,
                              problem.time)
    return one, family_jump_lambdas(problem.F, problem.H, problem.L0, LAMBDA, problem.time)


def _chain_orders(problem, tries) -> list:
    """:func:`chain_order` for m = 1, 2, … (z = M x, not diagnostic) until every monic p of
    degree m qualifies (the default λ then suffice) or m = n − 1; with symbolic parameters
    until the first member is found."""
    M = problem.M
    if problem.observer == "diagnostic" or M is None:
        return []
    F, H, time, n = problem.F, problem.H, problem.time, problem.n
    L = problem.L if problem.decoupled else None
    defaults = dict(problem.work.parameters)
    symbolic = bool(set().union(*(X.free_symbols for X in (F, H, M)
                                  + ((L,) if L is not None else ()))))
    out = []
    tries = list(tries) + [v for v in spread_lambdas(time)
                           if not any(same_number(v, w) for w in tries)]
    for m in range(1, n):
        c = chain_order(F, H, M, m, LAMBDA, time, tries, L, defaults)
        out.append(c)
        if (c.verdict == "free" and c.dim >= m) or (symbolic and c.lambdas):
            break
    return out
