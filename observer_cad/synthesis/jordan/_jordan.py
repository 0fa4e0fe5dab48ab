"""Jordan-form synthesis (METHOD §2b, §2c): diagnostic observers, virtual sensors,
interval observers — the design as the method's steps.

F* = diag(λ_1, …, λ_k), real and stable, so the defining equation splits by rows::

    (S_i, −J*_i) [L0 (F − λ_i I); H] = 0,     Φ_i = S_i L0

(seed 002 eq. (2.5); seed 000 eq. (8.2)). :func:`design_jordan` takes the steps of
METHOD §2b, each a function of its own module:

1. **the task** (:func:`jordan_problem`): the plant's matrices, z = M x or the faults to
   detect, the decoupled inputs L and L0 with L0 L = 0;
2. **the admissible λ** (:func:`choose_lambdas`): where [L0 (F − λI); H] loses row rank
   (every λ, or the real roots of the gcd of its maximal minors, exactly), and the λ the
   rows are taken from, by a strategy for the case (requested, every λ admissible,
   finitely many);
3. **the rows** (:func:`row_pool`, :func:`find_rows`): every λ's family of rows, and the
   fewest rows that do the task, by a strategy for the case —
   - diagnostic observer: every fault column is seen by some row (Φ_j D⁽ⁱ⁾ ≠ 0, seed 002
     Remark 1) and (R*, −H*) [H; Φ] = 0 is solvable: rank [Φ; H] < rank Φ + rank H (2.7);
   - virtual sensor / interval observer for z = M x: rank [Φ; H] = rank [Φ; H; M] (3.2),
     then M = H_z Φ + Q H;
   - nonlinear models: for every nonzero column j of C* = Φ C,
     rank [Φ; H] = rank [Φ; H; A_j], then A_j = A*_1j Φ + A*_2j H and
     Ψ*_j = φ_j(A*_1j x* + A*_2j y, u) (§2c);
4. **minimality** (:func:`~.minimality.prove_minimal`, within a time budget): why fewer
   rows are impossible — exact decisions that may also build fewer rows, so they run
   before the matrices are formed;
5. **the design and its certificate** (:func:`_design`): the matrices, a certificate
   independent of the above, the equations and the reported conditions.

Interval observers are not decoupled (L0 = I) and report L* = Φ L.
Stability is by construction (stable λ); no feedback is needed.

References: seed 002 §2-4, §6, §8; seed 001 §5; seed 000 §8.
"""
from __future__ import annotations

from typing import Sequence

import sympy as sp

from ...errors import InfeasibleDesignError, UsageError
from ...model import ObserverKind, PlantModel, Structure, Task
from ...numerics import (denominator_conditions, exact_rank, nonzero_conditions, solve_left)
from ..certificates import certify_design
from ..core import (PROOF_SECONDS, Condition, Design, is_stable, jordan_equations,
                    observer_symbols, output_symbols, prepare, substitute_arguments, task_for)
from ._admissible import rank_of
from ._float import design_jordan_float
from ._lambdas import choose_lambdas
from ._problem import jordan_problem
from ._row_search import find_rows, row_pool
from ._rows_check import residual_pair
from .minimality import ChosenRows, MinimalityProblem, proof_seconds_value, prove_minimal

__all__ = ["design_jordan", "design_jordan_unknown_input"]

_KINDS = ("diagnostic", "virtual-sensor", "interval")


def design_jordan(model: PlantModel, *, observer: str, estimate=None,
                  faults: Sequence[str] | None = None, decouple: Sequence[str] = (),
                  lambdas: Sequence | None = None, symbolic: bool = False,
                  structure: Structure | None = None, method: str = "auto",
                  rtol: float | None = None, task: Task | None = None,
                  proof_seconds: float | None = PROOF_SECONDS) -> Design:
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
    structure : Structure, optional
        The structure of the model with its parameters kept (used with ``symbolic``).
    method : {"auto", "exact", "float"}
        The arithmetic (:func:`~observer_cad.synthesis.core.prepare`: "auto" takes the float
        path for numeric linear models of more than 20 states).
    rtol : float, optional
        The float path's rank tolerance.
    task : Task, optional
        The resolved task (default: from the arguments above).
    proof_seconds : float or None, default :data:`~observer_cad.synthesis.core.PROOF_SECONDS`
        The time budget of the proof that k is minimal (informational: the condition is
        not required). When it runs out the condition reports the range the least order
        lies in and says so; the decisions it stopped may also have found fewer rows.
        None (or ``"exhaustive"``) runs the proof to the end.

    Returns
    -------
    Design
        Certified; ``method="exact"`` (or the float path's design).

    Raises
    ------
    UsageError
        An unknown kind or method, a bad λ or budget, z measured directly.
    InfeasibleDesignError
        No Jordan-form design of fewer than n rows does the task.

    Method
    ------
    The steps of the module docstring (METHOD §2b).

    References
    ----------
    seed 002 §2-4; METHOD §2b, §2c.
    """
    if observer not in _KINDS:
        raise UsageError(f"Jordan form supports diagnostic, virtual-sensor and interval, not {observer!r}")
    proof_seconds = proof_seconds_value(proof_seconds)
    task = task_for(model, task, observer=observer, faults=faults, disturbances=decouple,
                    estimate=estimate)
    prepared = prepare(model, symbolic=symbolic, method=method,
                       structure=structure if symbolic else None,
                       float_takes=lambda st: st.is_linear)
    if prepared.method == "float":  # large numeric linear models: the pencil numerically
        return design_jordan_float(model, observer=observer, estimate=estimate, faults=faults,
                                   decouple=decouple, lambdas=lambdas, rtol=rtol, task=task,
                                   structure=prepared.structure)
    problem = jordan_problem(prepared, observer, task)                   # 1. the task
    choice = choose_lambdas(problem, lambdas)                            # 2. admissible λ
    pool = row_pool(problem, choice)                                     # 3. the rows
    found = find_rows(problem, choice, pool)
    chosen, minimal = prove_minimal(_minimality_problem(problem, choice, found, proof_seconds),
                                    found.chosen())                      # 4. minimality
    return _design(problem, choice, pool, chosen, minimal)               # 5. the design


def _minimality_problem(problem, choice, found, seconds) -> MinimalityProblem:
    """What the proof needs from the steps before it."""
    st = problem.structure
    return MinimalityProblem(
        observer=problem.observer, time=problem.time, F=problem.F, H=problem.H,
        L=problem.L_decoupled, L0=problem.L0, D=problem.D, M=problem.M, C=problem.C,
        A_rows=tuple(sp.Matrix(t.row) for t in st.terms), structure=st, names=problem.names,
        requested=choice.requested, lam_list=choice.values, admissible=choice.admissible,
        one_row=choice.one_row, jumps=choice.jumps, chains=choice.chains, span=choice.span,
        more=found.more, bounds=found.bounds, seconds=seconds)


def _design(problem, choice, pool, chosen: ChosenRows, minimal: Condition) -> Design:
    """Step 5 of METHOD §2b: the matrices from the chosen rows, the certificate (independent
    of the steps before), the equations and the reported conditions."""
    work, st, observer = problem.work, problem.structure, problem.observer
    k, lams = chosen.k, chosen.lambdas
    mats, pivots = _matrices(problem, chosen)
    xs, ys = observer_symbols(k), output_symbols(st.l)
    Phi, H, M = mats["Phi"], problem.H, problem.M
    _, _, subs, nonlinear = substitute_arguments(st, Phi, xs, ys)
    if problem.C.cols:
        mats["C_star"] = Phi * problem.C
    mats = {name: Mx.applyfunc(sp.cancel) for name, Mx in mats.items()}
    plant = dict(F=problem.F, G=problem.G, H=H, C=problem.C, D=problem.D, L=problem.L)
    cert = certify_design(plant, mats, M=M, substitutions=subs, decoupled=problem.decoupled)
    equations, outputs = jordan_equations(mats, work.inputs, xs, ys, observer, M, nonlinear,
                                          problem.C.cols)
    CA = [(j, sp.Matrix(t.row)) for j, t in enumerate(st.terms)]
    conds = [choice.condition()]
    conds += _report_conditions(observer, work.time, lams, mats, Phi, H, problem.D, M,
                                problem.fault_syms, CA, nonlinear, k, problem.decoupled)
    conds.append(Condition("certificate", cert.passed, cert.summary(), "METHOD §2"))
    conds.append(minimal)
    tried = list(chosen.tried)
    choice_txt = (f"k = {k}: rows with λ = ({', '.join(map(str, lams))}) chosen from"
                  f" {len(pool.rows)} candidate row(s) for λ in"
                  f" {{{', '.join(map(str, choice.values))}}}; the fewest rows that satisfy the"
                  f" {observer} conditions; {minimal.detail}"
                  + (f" (smaller sets rejected: {'; '.join(tried[:4])})" if tried else ""))
    return Design(
        model_name=work.name, form="jordan", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=_assumptions(problem, pool, chosen, mats, pivots), certificate=cert,
        task=problem.task, structure=st, symbolic=bool(work.parameters), method="exact",
        choice=choice_txt, attempts=tuple(tried), time=work.time,
        lambdas=lams, nonlinear=tuple(nonlinear), equations=equations,
        observer_states=tuple(xs), outputs=tuple(outputs))


def _matrices(problem, chosen) -> tuple:
    """(Φ, F*, J*, G* and the kind's matrices, the rank pivots they rest on)."""
    k, rows, H, M, L = chosen.k, chosen.rows, problem.H, problem.M, problem.L
    pivots = set(problem.pivots)
    Phi = sp.Matrix.vstack(*[r[1] for r in rows])
    J = sp.Matrix.vstack(*[r[2] for r in rows])
    if problem.work.parameters:  # the rank decisions of the task on the chosen Φ (rank Φ = k, …)
        PH = sp.Matrix.vstack(Phi, H)
        for R in (Phi, PH) + ((sp.Matrix.vstack(PH, M),) if M is not None else ()):
            pivots |= exact_rank(R).conditions
    mats = {"Phi": Phi, "F_star": sp.diag(*chosen.lambdas), "J_star": J, "G_star": Phi * problem.G}
    if problem.observer == "diagnostic":
        pair = residual_pair(Phi, H, pivots)
        if pair is None:  # pragma: no cover - excluded by the rank test
            raise InfeasibleDesignError(f"{problem.where}: (R*, -H*)[H; Phi] = 0 has no solution")
        mats["R_star"], mats["H_star"] = pair
        mats["D_star"] = Phi * problem.D
    if problem.decoupled:
        if L.cols:
            mats["L_star"] = Phi * L
    else:
        mats["L_star"] = Phi * L
    if M is not None:
        X = solve_left(sp.Matrix.vstack(Phi, H), M)
        mats["Hz"], mats["Q"] = X[:, :k], X[:, k:]
    return mats, pivots


def _assumptions(problem, pool, chosen, mats, pivots) -> tuple:
    """The parameter conditions the design rests on: rank pivots, the pivots of the λ
    used, denominators, and (diagnostic) each fault seen."""
    assumptions = set(pivots)
    for lam in set(chosen.lambdas):
        assumptions |= pool.pivots.get(lam, frozenset())
    for Mx in mats.values():
        for e in Mx:
            assumptions |= denominator_conditions(e)
    if problem.observer == "diagnostic" and problem.work.parameters:  # each fault seen
        PD = (mats["Phi"] * problem.D).applyfunc(sp.cancel)
        for c in range(PD.cols):
            nums = [sp.fraction(sp.together(e))[0] for e in PD[:, c] if e != 0]
            if nums:
                g = sp.gcd_list(nums) if len(nums) > 1 else nums[0]
                assumptions |= nonzero_conditions(g)
    return tuple(sorted(assumptions, key=str))


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
    rPH, rP, rH = rank_of(PH), rank_of(Phi), rank_of(H)
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
        ro = rank_of(O)
        conds.append(Condition("observability of (F*, H*)", ro == k,
                               f"rank of the observability matrix = {ro} (k = {k})", "METHOD §4",
                               required=False))
    if M is not None:
        rPHM = rank_of(sp.Matrix.vstack(PH, M))
        conds.append(Condition("z = M x reachable: rank [Φ; H] = rank [Φ; H; M]", rPH == rPHM,
                               f"rank [Φ; H] = {rPH}, rank [Φ; H; M] = {rPHM}", "seed 002 eq. (3.2)"))
        Hz = mats["Hz"]
        nonneg = all((e.is_nonnegative is True) for e in Hz)
        conds.append(Condition("H_z ≥ 0", nonneg, f"H_z = {list(Hz)}"
                               + ("" if nonneg else " (the interval bounds use the split H_z⁺, H_z⁻)"),
                               "METHOD §3", required=False))
    for ns in nonlinear:
        A = CA[ns.index - 1][1]
        r2 = rank_of(sp.Matrix.vstack(PH, A))
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
