"""Robust (approximate) decoupling in the Jordan form (METHOD §2d): the fewest unit rows
Φ_i, each admissible for its λ, reaching z = M x, and among them the set of least
‖Φ L‖_F (see :mod:`observer_cad.synthesis.robust._robust`).
"""
from __future__ import annotations

import heapq
from typing import Sequence

import numpy as np
import sympy as sp

from ...errors import InfeasibleDesignError, ObserverCadError, UsageError
from ...model import PlantModel, parse_expression, resolve_task
from ...numerics import rationalize_floats
from ..core import (Condition, Design, arithmetic_for, default_eigenvalues, estimate_outputs,
                    is_stable, named_outputs, observer_symbols, output_symbols, prepare,
                    reduced_equations, task_parts)
from ._robust import RobustFloat

__all__ = ["design_robust_jordan", "jordan_candidates", "MAX_SUBSETS"]

#: Most k-subsets of Jordan candidate rows examined per k.
MAX_SUBSETS = 20000


def _jordan_setup(model, estimate, lambdas, decouple):
    """The prepared (float) problem, the task and the λ to use: ``(problem, task, M,
    decoupled, L, λ)``."""
    problem = prepare(model, method="float")  # parameters substituted: an SVD design
    work, st = problem.work, problem.structure
    task = resolve_task(work, observer="virtual-sensor", disturbances=decouple, estimate=estimate)
    M, _, dec, _, L = task_parts(work, st, task)
    n = st.n
    if L.cols == 0 or L == sp.zeros(*L.shape):
        raise UsageError(f"{model.where}: nothing to decouple from (no disturbance enters the"
                         " plant): use the exact Jordan design")
    if lambdas:
        lams = []
        for val in lambdas:
            lam = parse_expression(val, where="--lambda", allow_complex=True, allow_crootof=True)
            lam = rationalize_floats(lam)  # a float λ by its decimal string; exact stays
            if lam.free_symbols or not lam.is_real:
                raise UsageError(f"λ = {lam} must be a real number")
            if is_stable(lam, work.time) is False:
                need = "λ < 0" if work.time == "continuous" else "|λ| < 1"
                raise InfeasibleDesignError(
                    f"{model.where}: λ = {lam} is not stable in {work.time} time (needs {need})")
            lams.append(lam)
    else:
        lams = default_eigenvalues(work.time, n)
    return problem, task, M, dec, L, lams


def _candidates(ar, st, L, lams):
    """Candidate rows: for each λ the principal unit rows of the left null space of
    [F − λI; H] (S-part), ordered by ‖Φ_i L‖. List of dicts."""
    F, H, Lf = ar.array(st.F), ar.array(st.H), ar.array(L)
    n = st.n
    pool = []
    for lam in lams:
        lv = float(lam)
        P = np.vstack([F - lv * np.eye(n), H])
        U, fr = ar.left_null_evidence(P)
        B = ar.orth_rows(U[:, :n], ar.rtol)  # orthonormal basis of the admissible rows Φ_i
        if B.shape[0] == 0:
            continue
        Uc, sv = ar.svd_ascending(B @ Lf)
        for j, (c, s) in enumerate(zip(Uc, sv)):
            phi = c @ B
            phi = phi / np.linalg.norm(phi)
            # J*_i from J H = Φ_i (F − λI) (consistent by construction)
            J = np.linalg.lstsq(H.T, (phi @ (F - lv * np.eye(n))), rcond=None)[0]
            pool.append(dict(lam=lam, phi=phi, J=J, res=float(np.linalg.norm(phi @ Lf)),
                             sigma=float(s), basis_dim=B.shape[0], index=j, evidence=fr))
    return pool


def jordan_candidates(model: PlantModel, *, estimate, lambdas=None, decouple: Sequence[str] = (),
                      rtol: float | None = None):
    """The candidate rows of :func:`design_robust_jordan`: a list of (λ, Φ_i, ‖Φ_i L‖),
    Φ_i of unit norm, and the L used (float array)."""
    problem, task, M, dec, L, lams = _jordan_setup(model, estimate, lambdas, decouple)
    ar = arithmetic_for(problem, rtol=rtol, floating=RobustFloat)
    pool = _candidates(ar, problem.structure, L, lams)
    return [(c["lam"], c["phi"], c["res"]) for c in pool], ar.array(L)


def _subsets_by_cost(costs, m):
    """m-subsets of range(len(costs)) (costs ascending) in nondecreasing Σ cost."""
    N = len(costs)
    if m > N:
        return
    start = tuple(range(m))
    heap = [(sum(costs[i] for i in start), start)]
    seen = {start}
    while heap:
        c, idx = heapq.heappop(heap)
        yield idx
        for j in range(m):
            nxt = idx[j] + 1
            lim = idx[j + 1] if j + 1 < m else N
            if nxt < lim:
                t = idx[:j] + (nxt,) + idx[j + 1:]
                if t not in seen:
                    seen.add(t)
                    heapq.heappush(heap, (c - costs[idx[j]] + costs[nxt], t))


def design_robust_jordan(model: PlantModel, *, estimate, lambdas=None,
                         decouple: Sequence[str] = (), rtol: float | None = None) -> Design:
    """APPROXIMATE Jordan-form model for z = M x, rows of least ‖Φ_i L‖ (METHOD §2d).

    Parameters
    ----------
    model : PlantModel
        Parameters are substituted by their defaults (numeric design).
    estimate : str or sympy expression
        z = M x; the rows must satisfy rank [Φ; H] = rank [Φ; H; M].
    lambdas : values, optional
        Stable real eigenvalues to use (default −1, −2, …, −n continuous; 1/2, …, 1/2ⁿ
        discrete).
    decouple : names, optional
        Further faults/disturbances to decouple from (besides the model's disturbances).
    rtol : float, optional
        Relative rank tolerance of the null-space SVDs.

    Returns
    -------
    Design
        ``approximate=True``, ``residual_norm`` = ‖Φ L‖_F with unit rows, matrices Phi,
        F_star = diag(λ), J_star, G_star, L_star = Φ L (the residual), Hz, Q (and C_star).

    Method
    ------
    L0 = I; candidate rows per λ are the principal directions of the rows admissible for
    λ (left singular vectors of B_λ L); the fewest rows meeting the task, and among them
    the set with least Σ ‖Φ_i L‖² (module docstring). Seed 001 §5-6.
    """
    problem, task, M, dec, L, lams = _jordan_setup(model, estimate, lambdas, decouple)
    work, st = problem.work, problem.structure
    n = st.n
    ar = arithmetic_for(problem, rtol=rtol, floating=RobustFloat)
    ar.bind(st, sp.zeros(n, 0), L, M)
    # Step 1: candidate rows
    pool = _candidates(ar, st, L, lams)
    if not pool:
        raise InfeasibleDesignError(f"{model.where}: no row Φ_i for λ in"
                                    f" {{{', '.join(map(str, lams))}}}")
    pool.sort(key=lambda c: c["res"])
    # Step 2: fewest rows, least Σ ‖Φ_i L‖², meeting the task
    chosen, tried, examined = _fewest_rows(ar, pool, n)
    if chosen is None:
        raise InfeasibleDesignError(
            f"{model.where}: no robust Jordan-form model with fewer than n = {n} rows reaches"
            f" z = {estimate} for λ in {{{', '.join(map(str, lams))}}}: " + "; ".join(tried),
            tuple(tried))
    idx, Phi, Hz, Q, dist = chosen
    k = len(idx)
    rows = [pool[i] for i in idx]
    lam_t = tuple(r["lam"] for r in rows)
    mats, mats_np, residual = _jordan_matrices(ar, rows, Phi, Hz, Q, lam_t)
    # Step 3: certificate (Φ L is the residual, not certified as zero)
    cert, ctol = ar.certify_approximate(mats, mats_np, M)
    # Step 4: is an exact decoupled Jordan design possible? (reported, not required)
    conds = [_jordan_exact_condition(work, estimate, dec, n)]
    conds += _jordan_conditions(ar, work, rows, lam_t, residual, Phi, Hz, dist)
    resid = ", ".join(f"{i.name}: {i.residual}" for i in cert.identities)
    conds.append(Condition("certificate (identities that hold exactly; Φ L is the residual)",
                           cert.passed, f"{cert.summary()} ({resid}; absolute tolerance"
                           f" {ctol:.1e})", "METHOD §2"))
    # Step 5: equations
    xs, ys = observer_symbols(k), output_symbols(st.l)
    rhs = reduced_equations(mats, work.inputs, xs, ys)
    outputs = named_outputs("z", estimate_outputs(mats, xs, ys))
    choice = (f"APPROXIMATE (robust, METHOD §2d): k = {k} rows with λ = ({', '.join(map(str, lam_t))})"
              f" from {len(pool)} candidate unit rows (L0 = I; per λ the principal directions"
              f" of the admissible rows, ordered by ‖Φ_i L‖) for λ in"
              f" {{{', '.join(map(str, lams))}}}: the fewest rows reaching z, and among them the"
              f" set of least ‖Φ L‖_F ({examined} subset(s) examined in increasing Σ ‖Φ_i L‖²)."
              f" Achieved ‖Φ L‖_F = {residual:.6e} — NOT an exact decoupling"
              + (f" (smaller sets rejected: {'; '.join(tried[:3])})" if tried else ""))
    return Design(
        model_name=work.name, form="jordan", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=(), certificate=cert, task=task, structure=st, symbolic=False,
        method="float", choice=choice, attempts=tuple(tried), time=work.time,
        lambdas=lam_t, equations=tuple(rhs),
        observer_states=tuple(xs), outputs=tuple(outputs), approximate=True,
        residual_norm=residual)


def _fewest_rows(ar, pool, n):
    """The fewest candidate rows (sorted by ‖Φ_i L‖) of full rank reaching z, the sets
    of each size visited in increasing Σ ‖Φ_i L‖²: ``((indices, Φ, H_z, Q, distance) or
    None, the sets rejected, how many were examined)``."""
    costs = [c["res"] ** 2 for c in pool]
    tol = ar.tol
    chosen, tried, examined = None, [], 0
    for m in range(1, n):
        cnt = 0
        for idx in _subsets_by_cost(costs, m):
            cnt += 1
            if cnt > MAX_SUBSETS:
                tried.append(f"k={m}: stopped after {MAX_SUBSETS} subsets")
                break
            Phi = np.vstack([pool[i]["phi"] for i in idx])
            if ar.rank_evidence(Phi, atol=tol, rtol=tol).rank < m:
                continue
            ok, dist, Hz, Q = ar.reach(Phi, ar.H, ar.M, tol)
            if ok:
                chosen = (idx, Phi, Hz, Q, dist)
                break
            if len(tried) < 6:
                tried.append(f"k={m}, λ = ({', '.join(str(pool[i]['lam']) for i in idx)}):"
                             f" z not reachable (distance {dist:.1e})")
        examined += min(cnt, MAX_SUBSETS)
        if chosen:
            break
    return chosen, tried, examined


def _jordan_matrices(ar, rows, Phi, Hz, Q, lam_t):
    """Φ, F* = diag(λ), J*, G*, L* = Φ L (the residual), H_z, Q (and C*): ``(sympy
    matrices, float matrices, ‖Φ L‖_F)``."""
    k = len(rows)
    G, C = ar.G, ar.C
    J = np.vstack([r["J"] for r in rows])
    Lst = Phi @ ar.L
    residual = float(np.linalg.norm(Lst))
    mats_np = {"Phi": Phi, "F_star": np.diag([float(x) for x in lam_t]), "J_star": J,
               "G_star": Phi @ G if G.size else np.zeros((k, G.shape[1])), "L_star": Lst,
               "Hz": Hz, "Q": Q}
    if C.shape[1]:
        mats_np["C_star"] = Phi @ C
    mats = {name: ar.to_sympy(X) for name, X in mats_np.items()}
    mats["F_star"] = sp.diag(*lam_t)
    return mats, mats_np, residual


def _jordan_conditions(ar, work, rows, lam_t, residual, Phi, Hz, dist) -> list:
    """Each λ stable, the residual achieved row by row, z reachable, H_z ≥ 0, rank Φ = k
    and the argument substitutions (reported)."""
    tol = ar.tol
    conds = []
    for i, lam in enumerate(lam_t):
        need = "λ < 0" if work.time == "continuous" else "|λ| < 1"
        conds.append(Condition(f"λ_{i + 1} = {lam} stable", bool(is_stable(lam, work.time)),
                               f"{need} ({work.time} time)", "METHOD §2b"))
    per = "; ".join(f"row {i + 1} (λ = {r['lam']}): ‖Φ_i L‖ = {r['res']:.3e}"
                    f" (direction {r['index'] + 1} of {r['basis_dim']})"
                    for i, r in enumerate(rows))
    conds += [
        Condition("achieved residual ‖Φ L‖_F (APPROXIMATE decoupling)", True,
                  f"‖Φ L‖_F = {residual:.6e} with unit rows ‖Φ_i‖ = 1: {per}",
                  "METHOD §2d; seed 001 §6"),
        Condition("z = M x reachable: rank [Φ; H] = rank [Φ; H; M]", True,
                  f"relative distance of M from rowspace [Φ; H] = {dist:.2e} ≤ tol {tol:.1e};"
                  f" |H_z| = {np.linalg.norm(Hz):.3e}", "seed 002 eq. (3.2)"),
        Condition("H_z ≥ 0", bool(np.all(Hz >= 0)), f"H_z = {np.round(Hz, 6).tolist()}"
                  + ("" if np.all(Hz >= 0) else " (interval bounds use the split H_z⁺, H_z⁻)"),
                  "METHOD §3", required=False),
        Condition("rank Phi = k", True, ar.rank_evidence(Phi, atol=tol, rtol=tol).evidence(),
                  "METHOD §2b"),
    ]
    return conds + ar.nonlinear_conditions(Phi, tol)


def _jordan_exact_condition(work, estimate, dec, n) -> Condition:
    """Whether the exact decoupled Jordan design exists (design_jordan), reported."""
    name = "approximate: no exact decoupled Jordan-form design"
    if n > 12:
        return Condition(name, True, f"not checked (n = {n} > 12: exact synthesis skipped)",
                         "METHOD §2b", required=False)
    try:
        from ..jordan import design_jordan
        d = design_jordan(work, observer="virtual-sensor", estimate=estimate,
                          decouple=[s.name for s in dec])
    except InfeasibleDesignError as exc:
        msg = str(exc)
        return Condition(name, True, "design_jordan (exact, L0 from L) fails: "
                         + (msg if len(msg) < 400 else msg[:400] + " …"), "METHOD §2b, §2d")
    except ObserverCadError as exc:  # pragma: no cover - reported, not fatal
        return Condition(name, True, f"not checked: {exc}", "METHOD §2b", required=False)
    return Condition(name, False, f"an exact decoupled design exists (design_jordan: k = {d.k},"
                     f" λ = {tuple(map(str, d.lambdas))}): prefer it; this robust design is"
                     " reported for comparison", "METHOD §2b, §2d", required=False)
