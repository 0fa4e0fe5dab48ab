"""Canonical-form synthesis of the reduced, disturbance-decoupled model (METHOD §2a).

Find Φ (k×n, k as small as possible) with x* = Φ x obeying

    x*(t+1) or x*' = F* x* + J* y + G* u + D* d,     y* = H* x* = R* y

in the identification canonical form (F* the shift matrix, H* = (1 0 … 0)), and Φ L = 0
for the disturbances to decouple. Row by row Φ_1 = R* H, Φ_{i+1} = Φ_i F − J*_i H,
Φ_k F = J*_k H; eliminating Φ gives

    (R*, −J*_1, …, −J*_k) (W⁽ᵏ⁾  L⁽ᵏ⁾) = 0,

solvable iff rank (W⁽ᵏ⁾ L⁽ᵏ⁾) < l(k+1) (seed 000, eqs. (3.2)-(3.3); seed 001 §2).

Method
------
1. Resolve the task: the unknown input to estimate (a fault, or a disturbance as in
   000's estimation of ρ), the inputs to decouple from (the model's other
   disturbances plus any named), faults not named set to zero.
2. Check the necessary condition rank [H; L0] < rank H + rank L0 (000 eq. (2.4)) and
   report the matching condition rank(HD) = rank(D) (000 Remark 1).
3. For k = 1, 2, … < n: the left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾), exactly (DomainMatrix
   over QQ, grown from that of k − 1: :func:`krylov_null_spaces`; or over
   QQ(parameters)) or by SVD with a stated tolerance.
4. Choose a member for the task: D* = Φ D nonzero and (by default) entering one row
   only — the first (matched case) preferred, then the last (mismatched case, 000 §7).
   "One row only" is a linear condition on the null-space coefficients, so the members
   satisfying it form a subspace; its reduced-echelon basis is searched in order (the
   first member has R* selecting the lowest-numbered output it can) for one that is
   sensitive and gives rank Φ = k. If none exists at this k, the next k is tried.
5. Build Φ, F*, H*, J*, R*, G*, D*, L* (and C* = Φ C), present the member either
   normalised (leading entry of R* = 1) or with denominators cleared — whichever needs
   fewer assumptions — and collect the assumptions: denominators, the nonzero factors
   of D*, the common factors of Φ's maximal minors, and the pivots that make smaller k
   impossible.
6. Certify independently (:mod:`observer_cad.synthesis`); a failure raises.

Steps 2-6 are written once (:mod:`._search`) on the arithmetic chosen for the prepared
problem: exact (:class:`._exact.CanonicalExact`) or by SVD with evidence
(:class:`._float.CanonicalFloat`, whose numerics its module describes).

References: seed 000 (Zhirabok & Zuev 2024) §2-3, §7, §9; seed 001 §2.
"""
from __future__ import annotations

from typing import Sequence

import sympy as sp

from ...model import PlantModel, Structure, Task
from ..core import (FLOAT_AUTO_N, Design, arithmetic_for, prepare, task_for)
from ._exact import CanonicalExact
from ._float import CanonicalFloat
from ._krylov import krylov_blocks, krylov_null_spaces, member_to_phi
from ._search import design_with

__all__ = ["design_canonical", "krylov_blocks", "krylov_null_spaces", "member_to_phi",
           "FLOAT_AUTO_N"]


def design_canonical(model: PlantModel, *, unknown_input: str, decouple: Sequence[str] = (),
                     symbolic: bool = True, single_row: bool = True, method: str = "auto",
                     rtol: float | None = None, structure: Structure | None = None,
                     task: Task | None = None) -> Design:
    """Reduced, disturbance-decoupled model in identification canonical form.

    Parameters
    ----------
    model : PlantModel
    unknown_input : str
        The fault (or disturbance) to estimate; it must reach the model (Φ D ≠ 0).
    decouple : sequence of str, optional
        Further faults/disturbances to decouple from, besides the model's
        disturbances (default: none). Faults not named anywhere are taken as zero.
    symbolic : bool, default True
        Keep parameters as symbols; otherwise substitute their defaults as exact
        rationals (a parameter without a default is an error).
    single_row : bool, default True
        Require D* to enter one row of the model only (needed by the unknown-input
        estimators of seed 000: first row, or last row in the mismatched case).
    method : {"auto", "exact", "float"}, default "auto"
        Exact rational/rational-function algebra, or SVD with tolerance ``rtol``.
        "auto" takes the float path for numeric models with more than
        ``FLOAT_AUTO_N`` states (:func:`~observer_cad.synthesis.core.prepare`).
    rtol : float, optional
        The float path's relative rank tolerance (default ``max(shape)·eps·1e3``).
    structure : Structure, optional
        The model's structure, used when ``symbolic`` (the model is then the one the
        design works on); otherwise extracted from the model with its parameters
        substituted.
    task : Task, optional
        The task resolved already (by :func:`~observer_cad.synthesis.design`).

    Returns
    -------
    Design
        With its certificate, conditions, assumptions, the chosen member and why.

    Raises
    ------
    InfeasibleDesignError
        When no k < n admits a design; the message lists every k tried.
    """
    task = task_for(model, task, observer="unknown-input",
                    faults=[] if unknown_input is None else [unknown_input], disturbances=decouple)
    # a given structure is the model's: the work model's only when parameters are kept
    problem = prepare(model, symbolic=symbolic, method=method,
                      structure=structure if symbolic else None)
    work, st = problem.work, problem.structure
    target = work.symbol(task.targets[0])
    dec = tuple(work.symbol(n) for n in task.decoupled)
    D = sp.Matrix(st.unknown_input_columns([target]))
    L = sp.Matrix(st.unknown_input_columns(dec))
    ar = arithmetic_for(problem, rtol=rtol, exact=CanonicalExact, floating=CanonicalFloat)
    with ar.threads():
        return design_with(ar, work, st, task, target, dec, D, L, single_row=single_row)
