"""The condition "k is minimal over λ" (METHOD §2b): why fewer rows are impossible, as far
as it is proven, else the range the least order of a Jordan model lies in.

A Jordan design of at most m rows (decoupled or not, linear or not) has at most m
distinct λ, the roots of a chain polynomial (shared by every row of M) of that degree;
members nest (q of degree m − 1 times (λ − c) is a member of degree m), so order k − 1
ruled out proves k minimal; for one row z in a linear model such a polynomial is also
enough. Each verdict below is tried in turn; the first that proves k (or, for a
residual that misses a fault, disproves the design) gives the condition.

References: METHOD §2b; seed 002 §2.
"""
from __future__ import annotations

import dataclasses

from .._admissible import same_number
from ...core import Condition, default_eigenvalues

__all__ = ["Verdicts", "minimality_condition", "CONDITION_NAME"]

#: the name of the condition in a design's list
CONDITION_NAME = "k is minimal over λ"
_REF = "METHOD §2b; seed 002 §2"


@dataclasses.dataclass(frozen=True)
class Verdicts:
    """What the decisions of :func:`~.prove_minimal` said (each None when it did not run).

    ``short``: n − rank H − 1 rows; ``solid``: q + 3 rows; ``plane``: q + 2 rows
    (:class:`RowsVerdict`); ``budget``: the proof's time budget in words (e.g. "2 s")."""

    short: object = None
    solid: object = None
    plane: object = None
    budget: str = ""


def _holds(detail: str) -> Condition:
    return Condition(CONDITION_NAME, True, detail, _REF, required=False)


def minimality_condition(problem, k: int, lams, verdicts: Verdicts, bound, nonlinear,
                         stopped=()) -> Condition:
    """Why fewer than ``k`` rows are impossible (the design's λ ``lams``), as far as it is
    proven (METHOD §2b).

    Parameters
    ----------
    problem : MinimalityProblem
    k : int
        The design's rows.
    lams : sequence
        The design's λ.
    verdicts : Verdicts
    bound : callable
        k ↦ the :class:`OrderBound` of every reduced model of the task (any F*).
    nonlinear : callable or None
        k ↦ the :class:`OrderBound` of every Jordan model with nonlinear terms, or None
        when not proven (or stopped by the budget); None when it does not apply.
    stopped : sequence of str
        What the time budget stopped, in words (read when the range is reported: the
        nonlinear bound, run while the condition is composed, may add to it).

    Returns
    -------
    Condition
        Not required; holds when k is proven minimal.
    """
    special = [v for v in lams if not any(same_number(v, w) for w in
                                          default_eigenvalues(problem.time, problem.n))]
    found = (f"λ = {', '.join(map(str, special))} found exactly (not in the default list); "
             if problem.admissible.generic and special and not problem.requested else "")
    early = _early(problem, k, found, verdicts)
    if early is not None:
        return early
    cond, why, proven = _searched_verdict(problem, k)
    if cond is not None:
        return cond
    if proven:
        return _holds(found + why)
    below = [c for c in problem.chains if c.m < k]
    if not problem.requested and below and below[-1].m == k - 1 and below[-1].impossible:
        return _holds(found + "no Jordan model of fewer rows: a model of m rows"
                      " has its distinct λ (at most m, real, stable) as the roots of a"
                      " monic p with M p(F) ∈ rowspace [H; …; H Fᵐ] (and r(s) L = 0 for"
                      " decoupled inputs, METHOD §2b), and such a p of degree m − 1 times"
                      " (λ − c) is one of"
                      f" degree m, so order {k - 1} ruling it out rules out every lower"
                      " order; " + "; ".join(c.evidence for c in below))
    b = bound(k)
    by_bound = _bound_verdict(problem, k, found, why, b, nonlinear)
    if by_bound is not None:
        return by_bound
    return _range_verdict(problem, k, found, why, b, below, verdicts, tuple(stopped))


def _early(problem, k, found, verdicts) -> Condition | None:
    """k = 1, and the row counts decided exactly before any search argument: q rows
    impossible (k = q + 1), q + 1 too (k = q + 2), one row fewer than a basis (k − 1)."""
    span, more, short = problem.span, problem.more, verdicts.short
    if k == 1:
        return _holds(found + "k = 1: one row, the fewest possible")
    if span is not None and span.analysed and not span.possible and k == span.q + 1:
        return _holds(found + f"every model of z has at least {span.q} rows"
                      " (rank [M; H] − rank H), and exactly that many is impossible for"
                      f" every real stable λ: {span.evidence}")
    if _no_more(problem) and k == span.q + 2:
        return _holds(found + f"every model of z has at least {span.q} rows"
                      " (rank [M; H] − rank H); exactly that many is impossible for every"
                      f" real stable λ ({span.evidence}); and {span.q + 1} rows are impossible"
                      f" too: {more.evidence}")
    if (short is not None and short.analysed and not short.possible and k == short.k + 1
            and not problem.requested):
        return _holds(found + f"k = {k} rows form a basis modulo the outputs;"
                      f" {short.k} rows are impossible for every real stable λ, and a model"
                      " of fewer rows would extend to that many by rows of further λ:"
                      f" {short.evidence}")
    return None


def _no_more(problem) -> bool:
    """q rows and q + 1 rows both decided impossible."""
    span, more = problem.span, problem.more
    return (span is not None and span.analysed and not span.possible and more is not None
            and more.analysed and not more.possible)


def _searched_verdict(problem, k) -> tuple:
    """(condition or None, what the search over λ proves, proven?)."""
    adm, lam_list = problem.admissible, problem.lam_list
    if problem.requested:
        return None, f"k = {k} for the requested λ only; other λ were not searched", False
    if not adm.generic and (problem.several or problem.nonlinear_terms):
        # z with several components, or nonlinear terms: the search takes particular
        # combinations of each λ's rows, so fewer rows through another combination are
        # not ruled out by the search itself (the bounds below may still prove k)
        return None, (f"every stable admissible λ ({', '.join(map(str, lam_list))};"
                      f" {adm.describe()}) was searched, with particular combinations of each"
                      " λ's rows"), False
    if not adm.generic:
        return _holds(f"every stable admissible λ ({', '.join(map(str, lam_list))};"
                      f" {adm.describe()}) was searched: no set of fewer than {k} rows"
                      " satisfies the task"), "", False
    why, proven = _searched(problem.observer, k, lam_list, problem.one_row, problem.jumps)
    return None, why, proven


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


def _where(b) -> str:
    return (f" (for parameters with {', '.join(sorted(str(c.lhs) for c in b.conditions))}"
            " nonzero)" if b.conditions else "")


def _any_form(observer) -> str:
    return ("no residual generator of any form (any F*) with fewer states responds to every"
            " fault" if observer == "diagnostic" else "every model of any form (any F*) giving z"
            " has at least that many states")


def _bound_verdict(problem, k, found, why, b, nonlinear) -> Condition | None:
    """The lower bound over every F* (and, for nonlinear terms, over every Jordan model)
    at k: proven, or the design's residual misses a fault."""
    where, anyf = _where(b), _any_form(problem.observer)
    if b.k == k:  # the bound proves it: say so first, then what the search covered
        return _holds(found + f"k = {k} is a lower bound: {anyf}{where} —"
                      f" {b.evidence} (the search: {why})")
    if b.k > k:  # a diagnostic design whose residual misses a fault (unobservable rows)
        return Condition(CONDITION_NAME, False, found + f"{why}; but {anyf} below {b.k}"
                         f" states{where} ({b.evidence}): this design's residual does not"
                         " respond to every fault (see the observability of (F*, H*))", _REF,
                         required=False)
    nb = nonlinear(k) if nonlinear is not None and not problem.requested else None
    if nb is not None and nb.k >= k:
        return _holds(found + f"{why}; and k = {k} is a lower bound for every"
                      f" Jordan model: {nb.evidence}")
    return None


def _range_verdict(problem, k, found, why, b, below, verdicts, stopped) -> Condition:
    """The planes of q + 2 and q + 3 rows when they close the gap; else the range
    [lo, k] the least order of a Jordan model lies in (and, when the time budget stopped
    a decision, which)."""
    span, more, short = problem.span, problem.more, verdicts.short
    plane, solid = verdicts.plane, verdicts.solid
    where = _where(b)
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
            if _no_more(problem):
                lo = max(lo, span.q + 2)
    if short is not None:
        least += f"; {short.k} rows: {short.evidence}"
    if (plane is not None and plane.analysed and not plane.possible and lo >= plane.k
            and k == plane.k + 1):
        return _holds(found + f"{why}; every Jordan model has at least"
                      f" {plane.k} rows (the lower bound over every F* is {b.k}{where}:"
                      f" {b.evidence}{least}), and exactly {plane.k} are impossible for every"
                      f" real stable λ: {plane.evidence}")
    if plane is not None:
        least += f"; {plane.k} rows: {plane.evidence}"
        if plane.analysed and not plane.possible and lo >= plane.k:
            lo = max(lo, plane.k + 1)
    if solid is not None and solid.analysed and not solid.possible and k == solid.k + 1:
        return _holds(found + f"{why}; exactly {solid.k} rows are impossible for"
                      " every real stable λ, and a model of fewer rows would extend to that"
                      " many by rows of further λ (their images span all c dimensions and a"
                      f" model exists): {solid.evidence} (fewer: the lower bound over every"
                      f" F* is {b.k}{where}: {b.evidence}{least})")
    if solid is not None:
        least += f"; {solid.k} rows: {solid.evidence}"
    budget = (f" (the proof stopped at its time budget of {verdicts.budget} before deciding"
              f" {' and '.join(stopped)}; proof_seconds=None, or --proof-seconds exhaustive,"
              " runs it to the end)" if stopped else "")
    return Condition(CONDITION_NAME, False, found + f"{why}; the lower bound over every F* is"
                     f" {b.k}{where} ({b.evidence}){least}, so the least order of a Jordan"
                     f" model lies in [{lo}, {k}]{budget}", _REF, required=False)
