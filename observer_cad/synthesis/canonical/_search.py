"""The canonical-form design written once (METHOD §2a, steps 2-6 of
:mod:`observer_cad.synthesis.canonical._canonical`), on an arithmetic strategy that knows
how to take the left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾), choose a member and build the matrices —
exactly (:class:`~observer_cad.synthesis.canonical._exact.CanonicalExact`) or by SVD
(:class:`~observer_cad.synthesis.canonical._float.CanonicalFloat`).

A strategy offers ``bind(st, D, L)``, ``common_conditions()``, ``null_spaces()`` (one
:class:`NullStep` per k = 1, 2, …), ``choose(step, k, single_row)`` (a :class:`Member` or
the reason none fits) and ``build(…)`` (a :class:`Built`); this module runs the search
for the smallest k and writes the conditions and the design.
"""
from __future__ import annotations

import dataclasses

from ...errors import InfeasibleDesignError
from ...progress import report
from ..core import Condition, Design

__all__ = ["NullStep", "Member", "Built", "row_text", "design_with"]


@dataclasses.dataclass(frozen=True)
class NullStep:
    """The left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾) at one k: its dimension (0: the rank condition
    (3.3) fails), the rank decision as text, the pivots' conditions (symbolic models), and
    what the strategy's member choice reads (the members, or the scaled matrices)."""

    dim: int
    rank: str
    conditions: frozenset = frozenset()
    data: object = None


@dataclasses.dataclass(frozen=True)
class Member:
    """The member chosen at k: the vector (R*, −J*_1, …, −J*_k), the row D* enters, the
    dimension of the subspace it was chosen from, and the strategy's evidence."""

    vector: object
    row: int
    count: int
    data: tuple = ()


@dataclasses.dataclass(frozen=True)
class Built:
    """The chosen member made into the design's matrices and certificate, with the
    evidence the conditions print and what the design records besides (``extras``:
    assumptions, symbolic, null space, equations, …)."""

    matrices: dict
    certificate: object
    sensitivity: str
    row_note: str
    rank_phi: str
    certificate_detail: str
    choice: str
    extras: dict


def row_text(r: int, k: int) -> str:
    """Where D* enters: the only row, the first (matched case), the last (mismatched
    case, 000 §7) or another one."""
    if k == 1:
        return "the only row"
    if r == 0:
        return "the first row (matched case)"
    if r == k - 1:
        return f"the last row only (mismatched case: the estimate is delayed by {k - 1} step(s))"
    return f"row {r + 1} only"


def _search(ar, st, tname: str, single_row: bool, where: str):
    """The smallest k < n with a member for the task: ``(k, step, member, attempts,
    minimality)``; every k tried is one line of ``attempts``."""
    n, l = st.n, st.l  # noqa: E741
    attempts: list = []
    minimality: set = set()
    spaces = ar.null_spaces()
    for k in range(1, n):
        report(f"designing ({ar.method}, canonical form): k = {k} of at most {n - 1}")
        step = next(spaces)
        need = l * (k + 1)
        if not step.dim:
            attempts.append(f"k={k}: rank condition (3.3) fails: {step.rank} = l(k+1) = {need}")
            minimality |= step.conditions
            continue
        member, why = ar.choose(step, k, single_row)
        if member is None:
            attempts.append(
                f"k={k}: rank condition (3.3) holds ({step.rank} < {need}), null space of"
                f" dimension {step.dim}, but {why}")
            minimality |= step.conditions
            continue
        return k, step, member, attempts, minimality
    raise InfeasibleDesignError(
        f"{where}: no disturbance-decoupled model sensitive to '{tname}' exists for"
        f" any k < n = {n}: " + "; ".join(attempts), tuple(attempts))


def design_with(ar, work, st, task, target, dec, D, L, *, single_row: bool) -> Design:
    """The design on the strategy ``ar``: necessary conditions, the smallest k, the
    member, its matrices and certificate, the conditions and the design."""
    tname = target.name
    ar.bind(st, D, L)
    conds = ar.common_conditions()
    if not conds[0].holds:
        raise InfeasibleDesignError(
            f"{work.where}: no model decoupled from {', '.join(s.name for s in dec)} exists:"
            f" the necessary condition fails ({conds[0].detail})", (conds[0].detail,))
    k, step, member, attempts, minimality = _search(ar, st, tname, single_row, work.where)
    rows = row_text(member.row, k)
    built = ar.build(work, k, step, member, frozenset(minimality), single_row, tname, rows)
    need = st.l * (k + 1)
    conds += [
        Condition(f"rank condition (3.3) at k = {k}", True,
                  f"{step.rank} < l(k+1) = {need}{ar.rank_note}", "seed 000 eq. (3.3)"),
        Condition("k is minimal", True,
                  "; ".join(attempts) if attempts else "k = 1 is the smallest dimension",
                  "seed 000 §3"),
        Condition(f"fault sensitivity Phi D != 0 ({tname})", True, built.sensitivity,
                  "seed 000 §4"),
    ]
    if single_row:
        conds.append(Condition("D* enters one row only", True,
                               f"{tname} enters {rows}{built.row_note}", "seed 000 §5, §7"))
    conds.append(Condition("rank Phi = k (the model is not degenerate)", True, built.rank_phi,
                           "seed 000 §3"))
    conds.append(Condition("certificate", built.certificate.passed, built.certificate_detail,
                           "METHOD §2"))
    return Design(
        model_name=work.name, form="canonical", k=k, matrices=built.matrices,
        conditions=tuple(conds), certificate=built.certificate, task=task, structure=st,
        method=ar.method, choice=built.choice, attempts=tuple(attempts), time=work.time,
        **built.extras)
