"""Robust (approximate) decoupling in the identification canonical form (METHOD §2d):
the member of the left null space of W⁽ᵏ⁾ of least ‖Φ L‖_F meeting the task, at the
smallest k (see :mod:`observer_cad.synthesis.robust._robust`).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import sympy as sp

from ...errors import InfeasibleDesignError, UsageError
from ...model import PlantModel, resolve_task
from ...numerics import rank_from_sv
from ...progress import report
from ..canonical import krylov_blocks
from ..core import Condition, Design, arithmetic_for, prepare, task_parts
from ._robust import RobustFloat, sv_text

__all__ = ["design_robust_canonical", "robust_basis"]


def _sci(x) -> str:
    return f"{x:.3e}"


# ---------------------------------------------------------------- the task
def _check_member(v, ar, k, Dk=None):
    """Does the member v (unit) meet the task? Returns (ok, failures, info)."""
    Phi = ar.phis(v, k)[0]
    ref = ar.ref(v, k)
    rho_s = np.where(ref > 0, ref, 1.0)
    fails, info = [], {"Phi": Phi}
    fr = ar.rank_evidence(Phi / rho_s[:, None], atol=ar.tol, rtol=ar.tol)
    info["rank"] = fr
    if fr.rank < k:
        fails.append("degenerate")
    if ar.D.shape[1]:
        dn = float(np.linalg.norm(ar.D))
        sens = np.linalg.norm(Phi @ ar.D, axis=1) / (rho_s * max(dn, np.finfo(float).tiny))
        info["sens"] = float(sens.max())
        if sens.max() <= ar.tol:
            fails.append("insensitive")
    if ar.M is not None:
        ok, dist, Hz, Q = ar.reach(Phi, ar.H, ar.M, ar.tol)
        info.update(dist=dist, Hz=Hz, Q=Q)
        if not ok:
            fails.append("unreachable")
    return not fails, fails, info


_WHY = {"degenerate": "rank Φ < k", "insensitive": "Φ D ≈ 0 (the input does not reach the model)",
        "unreachable": "rank [Φ; H] < rank [Φ; H; M] (z not reachable)"}


def _first_passing(basis, N, A, ar, k, Dk):
    """Best member w N, w in span(basis rows) (coefficients of N's rows), meeting the
    task: the singular directions of basis·A in increasing order, the first that passes."""
    if basis.shape[0] == 0:
        return None
    Uc, _ = ar.svd_ascending(basis @ A)
    for c in Uc:
        w = c @ basis
        w = w / np.linalg.norm(w)
        v = w @ N
        ok, _, info = _check_member(v, ar, k, Dk)
        if ok:
            return float(np.linalg.norm(w @ A)), v, info
    return None


def _reach_subspaces(N, ar, k):
    """Subspaces V(g) of w whose members reach z (see the module docstring), with labels."""
    m = ar.M[0] @ ar.PH
    mn = float(np.linalg.norm(m))
    if mn <= ar.tol * float(np.linalg.norm(ar.M[0])):
        return [(np.eye(N.shape[0]), "z is measured (M in rowspace H): every member reaches it")]
    mh = m / mn
    Pm = np.eye(ar.n) - np.outer(mh, mh)
    Phis = ar.phis(N, k)  # (s, k, n)
    if k < 2:
        return []

    def sub(g):
        C = np.tensordot(g, Phis[:, 1:, :], axes=([0], [1])) @ ar.PH  # (s, n)
        E = C @ Pm
        scale = max(float(np.linalg.norm(C)), np.finfo(float).tiny)
        V, _ = ar.left_null_evidence(E / scale, atol=ar.tol, rtol=ar.tol)
        return V

    if k == 2:
        return [(sub(np.array([1.0])), "k = 2: the members with Φ_2 P_H ∥ M P_H (one subspace)")]
    if k == 3:
        dirs = [np.array([np.cos(t), np.sin(t)]) for t in np.linspace(0, np.pi, 360, endpoint=False)]
        label = "k = 3: H_z direction searched on a 360-point angle grid"
    else:
        rng = np.random.default_rng(0)
        G = rng.standard_normal((400 * (k - 2), k - 1))
        dirs = [r / np.linalg.norm(r) for r in G] + list(np.eye(k - 1))
        label = f"k = {k}: H_z direction searched on {len(dirs)} seeded random directions"
    return [(sub(g), label) for g in dirs]


def _choose(N, A, ar, k, Dk):
    """The member for the task. Returns (dict, None) or (None, why)."""
    Uc, sv = ar.svd_ascending(A)
    w = Uc[0]
    v = w @ N
    ok, fails, info = _check_member(v, ar, k, Dk)
    base = dict(sigma=sv, sigma_min=float(sv[0]))
    if ok:
        return dict(base, v=v, residual=float(np.linalg.norm(w @ A)),
                    info=info, how="the unconstrained optimum (smallest singular value) meets"
                    " the task", fallback=None), None
    why_opt = "; ".join(_WHY[f] for f in fails)
    best = None
    if "insensitive" in fails:
        # column i of N D⁽ᵏ⁾ is Φ_i D over the basis: scaled by the largest reference size
        dn = max(float(np.linalg.norm(ar.D)), np.finfo(float).tiny)
        B = (N @ Dk) / np.repeat(ar.ref_max(k) * dn, ar.D.shape[1])[None, :]
        Ub, sb, _ = np.linalg.svd(B, full_matrices=False)
        r = rank_from_sv(sb, B.shape, ar.tol, ar.tol).rank
        Z = Ub[:, :r].T  # range of N D⁽ᵏ⁾: the sensitive combinations
        if r == 0:
            return None, f"no member is sensitive (N D⁽ᵏ⁾ ≈ 0, σ = {sv_text(sb)})"
        got = _first_passing(Z, N, A, ar, k, Dk)
        if got is not None:
            best = (*got, f"w restricted to the {r}-dimensional range of N D⁽ᵏ⁾ (the orthogonal"
                          f" complement of the insensitive combinations; there |Φ_i D|/(ρ_i |D|) ≥"
                          f" {_sci(sb[r - 1])}·|w| in some row, ρ_i the largest reference size),"
                          f" best member there by SVD")
    elif "unreachable" in fails:
        if ar.M.shape[0] == 1:
            subs = _reach_subspaces(N, ar, k)
            for V, label in subs:
                got = _first_passing(V, N, A, ar, k, Dk)
                if got is not None and (best is None or got[0] < best[0]):
                    best = (*got, label + ", best member of each subspace by SVD")
        else:
            got = _first_passing(Uc, N, A, ar, k, Dk)
            if got is not None:
                best = (*got, "singular directions of N L⁽ᵏ⁾ tried in increasing order")
    else:  # degenerate only
        got = _first_passing(Uc, N, A, ar, k, Dk)
        if got is not None:
            best = (*got, "singular directions of N L⁽ᵏ⁾ tried in increasing order")
    if best is None:
        return None, f"the optimum fails ({why_opt}) and no member meeting the task was found"
    res, v, info, how = best
    return dict(base, v=v, residual=res, info=info,
                how=f"the unconstrained optimum (σ_min = {_sci(sv[0])}) fails the task"
                    f" ({why_opt}); {how}", fallback=why_opt), None


# ---------------------------------------------------------------- the search
def _task(model, unknown_input, estimate, decouple, symbolic):
    """The checks, the prepared (float) problem and the task: ``(problem, task, target,
    decoupled, D, L, M)``."""
    if symbolic and model.parameters:
        raise UsageError("the robust design is numeric (SVD): design without --symbolic")
    if unknown_input is not None and estimate is not None:
        raise UsageError("a robust canonical design serves one task: give unknown_input or"
                         " estimate, not both")
    if unknown_input is None and estimate is None:
        raise UsageError("a robust canonical design needs unknown_input (to estimate) or"
                         " estimate (z = M x)")
    problem = prepare(model, method="float")  # parameters substituted: an SVD design
    work, st = problem.work, problem.structure
    if unknown_input is not None:
        task = resolve_task(work, observer="unknown-input", faults=[unknown_input],
                            disturbances=decouple)
    else:
        task = resolve_task(work, observer="virtual-sensor", disturbances=decouple,
                            estimate=estimate)
    M, targets, dec, D, L = task_parts(work, st, task)
    target = targets[0] if targets else None
    if L.cols == 0 or L == sp.zeros(*L.shape):
        raise UsageError(f"{model.where}: nothing to decouple from (no disturbance enters the"
                         " plant): use the exact design")
    return problem, task, target, tuple(dec), D, L, M


def _search(ar, n):
    """The smallest k < n whose null space of W⁽ᵏ⁾ (no decoupling) has a member meeting
    the task, and the SVD-optimal one: ``(attempts, found or None)``."""
    attempts, found = [], None
    for k in range(1, n):
        report(f"designing (robust, canonical form): k = {k} of at most {n - 1}")
        W, Lk = krylov_blocks(ar.Fs, ar.Hs, ar.Ls, k)
        Wf, Lkf = ar.array(W), ar.array(Lk)
        N, fr = ar.null_rows(Wf, k)
        need = ar.l * (k + 1)
        if N.shape[0] == 0:
            attempts.append(f"k={k}: (R*, −J*) W⁽ᵏ⁾ = 0 has no solution: W {fr.evidence()}"
                            f" = l(k+1) = {need}")
            continue
        Dk = ar.array(krylov_blocks(ar.Fs, ar.Hs, ar.Ds, k)[1]) if ar.D.shape[1] else None
        A = N @ Lkf
        pick, why = _choose(N, A, ar, k, Dk)
        if pick is None:
            attempts.append(f"k={k}: null space of W of dimension {N.shape[0]} ({fr.evidence()}),"
                            f" but {why}")
            continue
        found = dict(pick, k=k, N=N, Lk=Lkf, W=Wf, fr=fr, Dk=Dk)
        break
    return attempts, found


def _exact_check(ar, n):
    """For every k < n: does (W⁽ᵏ⁾ L⁽ᵏ⁾) have a member meeting the task? (evidence per k)"""
    lines, exact_k = [], None
    for k in range(1, n):
        report(f"checking exact decoupling: k = {k} of at most {n - 1}")
        W, Lk = krylov_blocks(ar.Fs, ar.Hs, ar.Ls, k)
        Lkf = ar.array(Lk)
        Mat = np.hstack([ar.array(W), Lkf])
        N, fr = ar.null_rows(Mat, k)
        if N.shape[0] == 0:
            lines.append(f"k={k}: (W L) {fr.evidence()} = l(k+1) = {ar.l * (k + 1)}")
            continue
        Dk = ar.array(krylov_blocks(ar.Fs, ar.Hs, ar.Ds, k)[1]) if ar.D.shape[1] else None
        pick, why = _choose(N, N @ Lkf, ar, k, Dk)
        if pick is None:
            lines.append(f"k={k}: (W L) {fr.evidence()}, but {why}")
            continue
        lines.append(f"k={k}: (W L) {fr.evidence()}: an exactly decoupled member meets the task")
        exact_k = k
        break
    return exact_k, lines


def robust_basis(model: PlantModel, *, unknown_input: str | None = None, estimate=None,
                 decouple: Sequence[str] = (), rtol: float | None = None):
    """(k, N, L⁽ᵏ⁾) used by :func:`design_robust_canonical` (float arrays).

    k is the minimal dimension whose null space of W⁽ᵏ⁾ (no decoupling) has a member
    meeting the task, N an orthonormal basis (rows) of that null space, L⁽ᵏ⁾ the block
    Toeplitz decoupling matrix of :func:`~observer_cad.synthesis.krylov_blocks`; the
    robust member is v = w N with ‖w‖ = 1 minimising ‖w N L⁽ᵏ⁾‖ = ‖Φ L‖_F.
    """
    problem, _, _, _, D, L, M = _task(model, unknown_input, estimate, decouple, False)
    st = problem.structure
    ar = arithmetic_for(problem, rtol=rtol, floating=RobustFloat)
    ar.bind(st, D, L, M)
    attempts, found = _search(ar, st.n)
    if found is None:
        raise InfeasibleDesignError(
            f"{model.where}: no reduced model meeting the task exists for any k < n = {st.n},"
            " even without decoupling: " + "; ".join(attempts), tuple(attempts))
    return found["k"], found["N"], found["Lk"]


def design_robust_canonical(model: PlantModel, *, unknown_input: str | None = None,
                            estimate=None, decouple: Sequence[str] = (), symbolic: bool = False,
                            rtol: float | None = None) -> Design:
    """APPROXIMATE reduced model in identification canonical form, least ‖Φ L‖_F.

    Parameters
    ----------
    model : PlantModel
        Parameters are substituted by their defaults (the design is numeric).
    unknown_input : str, optional
        The fault (or disturbance) the model must be sensitive to (Φ D ≠ 0); the
        model's other disturbances are the ones to decouple from.
    estimate : str or sympy expression, optional
        z = M x to be reachable: rank [Φ; H] = rank [Φ; H; M]; then H_z, Q are reported.
        At most one of ``unknown_input`` and ``estimate``.
    decouple : names, optional
        Further faults/disturbances to decouple from (approximately).
    symbolic : bool, default False
        Must be False for a model with parameters (the design is an SVD).
    rtol : float, optional
        Relative rank tolerance of the null-space SVDs (default ``max(shape)·eps·1e3``).

    Returns
    -------
    Design
        ``approximate=True``, ``residual_norm`` = ‖Φ L‖_F (= σ_min when the optimum meets
        the task), ``method="float"``, ``form="canonical"``; matrices Phi, F_star,
        J_star, R_star, H_star, G_star, D_star (unknown input), L_star = Φ L (the
        residual), C_star (nonlinear models), Hz and Q (estimate).

    Raises
    ------
    InfeasibleDesignError
        When even without decoupling no k < n has a member meeting the task.
    UsageError
        Both tasks given, ``symbolic`` with parameters, or nothing to decouple from.

    Method
    ------
    See the module docstring: SVD of N L⁽ᵏ⁾ at the minimal k (seed 001 §6, Theorem 3).
    """
    # Step 1: the task, the float matrices
    problem, task, target, dec, D, L, M = _task(model, unknown_input, estimate, decouple,
                                                symbolic)
    work, st = problem.work, problem.structure
    n = st.n
    ar = arithmetic_for(problem, rtol=rtol, floating=RobustFloat)
    ar.bind(st, D, L, M)
    # Step 2: minimal k without decoupling, the SVD-optimal member for the task
    attempts, found = _search(ar, n)
    if found is None:
        raise InfeasibleDesignError(
            f"{model.where}: no reduced model meeting the task exists for any k < n = {n},"
            " even without decoupling: " + "; ".join(attempts), tuple(attempts))
    # Step 3: is exact decoupling really impossible? (every k < n, same task)
    exact_k, exact_lines = _exact_check(ar, n)
    # Step 4: the matrices (v has unit norm: ‖Φ L‖_F = ‖v L⁽ᵏ⁾‖)
    k = found["k"]
    mats, mats_np, residual = _matrices(ar, found)
    # Step 5: certificate of the identities that hold exactly (Φ L is the residual)
    cert, tol = ar.certify_approximate(mats, mats_np, M)
    # Step 6: conditions
    conds, exact_zero = _conditions(ar, found, attempts, exact_k, exact_lines, residual,
                                    mats_np["Phi"], target)
    resid = ", ".join(f"{i.name}: {i.residual}" for i in cert.identities)
    conds.append(Condition("certificate (identities that hold exactly; Φ L is the residual)",
                           cert.passed, f"{cert.summary()} ({resid}; absolute tolerance"
                           f" {tol:.1e})", "METHOD §2"))
    task_txt = (f"sensitive to {target.name}" if target is not None else
                f"reaching z = {estimate}" if ar.M is not None else "non-degenerate")
    choice = (f"APPROXIMATE (robust, METHOD §2d): k = {k}, the smallest dimension at which"
              f" (R*, −J*) W⁽ᵏ⁾ = 0 has a member {task_txt}; null space basis N of dimension"
              f" {found['N'].shape[0]}; v = w N with |w| = 1 minimising |w N L⁽ᵏ⁾|: {found['how']}."
              f" Achieved ‖Φ L‖_F = {residual:.6e}"
              + (" — zero up to rounding: an exact design exists, prefer the exact design"
                 if exact_zero else " — NOT an exact decoupling") + "; v kept at unit norm")
    return Design(
        model_name=work.name, form="canonical", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=(), certificate=cert, task=task, structure=st, symbolic=False,
        method="float", choice=choice, attempts=tuple(attempts), time=work.time,
        approximate=True, residual_norm=residual)


def _matrices(ar, found):
    """Φ, F*, J*, R*, H*, G*, D*, L* = Φ L (the residual), C*, H_z, Q of the unit member:
    ``(sympy matrices, float matrices, ‖Φ L‖_F)``."""
    k, v, info = found["k"], found["v"], found["info"]
    l = ar.l  # noqa: E741
    R = v[:l][None, :]
    J = -v[l:].reshape(k, l)
    Phi = ar.phis(v, k)[0]
    Fs = np.eye(k, k, 1)
    Hs = np.eye(1, k)
    Lst = Phi @ ar.L
    residual = float(np.linalg.norm(Lst))
    mats_np = {"Phi": Phi, "F_star": Fs, "J_star": J, "R_star": R, "H_star": Hs,
               "G_star": Phi @ ar.G if ar.G.size else np.zeros((k, ar.G.shape[1]))}
    if ar.D.shape[1]:
        mats_np["D_star"] = Phi @ ar.D
    mats_np["L_star"] = Lst
    if ar.C.shape[1]:
        mats_np["C_star"] = Phi @ ar.C
    if ar.M is not None:
        mats_np["Hz"], mats_np["Q"] = info["Hz"], info["Q"]
    mats = {name: ar.to_sympy(X) for name, X in mats_np.items()}
    mats["F_star"] = sp.Matrix(k, k, lambda i, j: 1 if j == i + 1 else 0)
    mats["H_star"] = sp.Matrix([[1] + [0] * (k - 1)])
    return mats, mats_np, residual


def _conditions(ar, found, attempts, exact_k, exact_lines, residual, Phi, target):
    """Whether exact decoupling is impossible, the solvability and minimality of k, the
    residual achieved, the task (sensitivity or reachability), rank Φ and the argument
    substitutions: ``(conditions, whether the residual is zero up to rounding)``."""
    k, info, n = found["k"], found["info"], ar.n
    pn = float(np.linalg.norm(Phi))
    lnorm = float(np.linalg.norm(ar.L))
    rel = residual / max(pn * lnorm, np.finfo(float).tiny)
    sv = found["sigma"]
    exact_zero = residual <= ar.tol * max(pn * lnorm, np.finfo(float).tiny)
    conds = []
    if exact_k is None:
        conds.append(Condition(
            "approximate: exact decoupling impossible for every k < n", True,
            f"no k < n = {n} has an exactly decoupled member meeting the task (left null space"
            f" of (W⁽ᵏ⁾ L⁽ᵏ⁾), SVD): " + "; ".join(exact_lines), "METHOD §2a, §2d; seed 001 §6"))
    else:
        conds.append(Condition(
            "approximate: exact decoupling impossible for every k < n", False,
            f"an exactly decoupled design exists at k = {exact_k}: use the exact design"
            f" (design_canonical / design_virtual_sensor_canonical); this robust design is"
            f" reported for comparison (" + "; ".join(exact_lines) + ")",
            "METHOD §2a, §2d", required=False))
    conds += [
        Condition(f"(R*, −J*) W⁽ᵏ⁾ = 0 solvable at k = {k} (no decoupling)", True,
                  f"null space of dimension {found['N'].shape[0]}: W {found['fr'].evidence()}",
                  "METHOD §2d; seed 001 §6"),
        Condition("k is minimal (without decoupling)", True,
                  "; ".join(attempts) if attempts else "k = 1 is the smallest dimension",
                  "seed 001 §6"),
        Condition("achieved residual ‖Φ L‖_F (APPROXIMATE decoupling)", True,
                  f"‖Φ L‖_F = ‖v L⁽ᵏ⁾‖ = {residual:.6e} with |v| = 1"
                  f" (relative ‖Φ L‖/(‖Φ‖ ‖L‖) = {rel:.3e}); singular values of N L⁽ᵏ⁾"
                  f" ascending: {sv_text(sv)}; {found['how']}"
                  + ("; the residual is zero up to rounding: an exact design exists"
                     if exact_zero else ""),
                  "seed 001 §6, Theorem 3"),
    ]
    if target is not None:
        conds.append(Condition(f"fault sensitivity Phi D != 0 ({target.name})", True,
                               f"max_i |Φ_i D|/(ρ_i |D|) = {info['sens']:.3e} > tol {ar.tol:.1e} (ρ_i = |H| α^(i−1)"
                               f" Σ_b |v_b| α^(−b), the size of Φ_i without cancellation)",
                               "seed 000 §4"))
    if ar.M is not None:
        conds.append(Condition("z = M x reachable: rank [Φ; H] = rank [Φ; H; M]", True,
                               f"relative distance of M from rowspace [Φ; H] = {info['dist']:.2e}"
                               f" ≤ tol {ar.tol:.1e}; |H_z| = {np.linalg.norm(info['Hz']):.3e}",
                               "seed 002 eq. (3.2)"))
    conds.append(Condition("rank Phi = k (the model is not degenerate)", True,
                           f"rows of Φ divided by ρ_i: {info['rank'].evidence()}", "seed 000 §3"))
    conds += ar.nonlinear_conditions(Phi, ar.tol)
    return conds, exact_zero
