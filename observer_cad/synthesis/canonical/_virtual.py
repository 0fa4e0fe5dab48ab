"""Virtual sensors z = M x in the identification canonical form, with a stabilising
feedback computed for the *actual* F* (METHOD §2a, §3; seeds 001 and 004).

Plain form (seed 001 §2, method 1): the reduced model is built from the measured
outputs; the minimal k is the first whose null space has a member with
rank [Φ; H] = rank [Φ; H; M]; then M = H_z Φ + Q H.

Seed-004 variant: the model is driven by y0 = (y; y_v) with y_v = z = M x itself
(H0 = [H; M]); its output y* = H* x* = R* y stays a measured combination, so R* acts on
y and J* on y0. The rank test uses that stacked matrix; a member must still satisfy
the virtual-sensor condition, and substituting y_v = H_z x* + Q y moves F* away from
the shift form: F*_act = F_shift + J*_v H_z, J*_act = J*_y + J*_v Q.

Feedback: x*' = F* x* + J* y + G* u + K r, so the error obeys F* − K H*. K is solved
exactly from det(sI − F* + K H*) = Π (s − μ_i) for the requested μ_i (complex pairs
allowed), and the closed-loop characteristic polynomial is re-checked exactly.
With real distinct μ_i, 001 method 1 then moves F* − K H* to diagonal form by its
eigenvector matrix T (ξ = T⁻¹ x*), which is Metzler.
"""
from __future__ import annotations

from typing import Sequence

import sympy as sp

from ...errors import InfeasibleDesignError, UsageError
from ...model import PlantModel, Task
from ...numerics import readable, solve_left
from ...progress import report
from ..core import (Condition, Design, arithmetic_for, closed_loop_eigenvalues,
                    default_eigenvalues, estimate_outputs, observer_symbols, output_symbols,
                    parse_eigenvalues, pole_placement, prepare, reduced_equations,
                    require_stable, substitute_arguments, task_for)
from ._krylov import krylov_null_spaces, shift_matrix

__all__ = ["design_virtual_sensor_canonical"]


def _member(v, F, H1, H0, k):
    v = sp.Matrix(v)
    l1, l0 = H1.rows, H0.rows
    R = v[:, :l1]
    J = sp.Matrix.vstack(*[-v[:, l1 + i * l0:l1 + (i + 1) * l0] for i in range(k)])
    rows = [R * H1]
    for i in range(k - 1):
        rows.append(rows[-1] * F - J[i, :] * H0)
    return R, J, sp.Matrix.vstack(*rows).applyfunc(sp.cancel)


def design_virtual_sensor_canonical(model: PlantModel, *, estimate, variant: str = "plain",
                                    eigenvalues: Sequence | None = None,
                                    decouple: Sequence[str] = (), symbolic: bool = False,
                                    diagonalize: bool = True, task: Task | None = None) -> Design:
    """Canonical-form virtual sensor for z = M x (plain, or the seed-004 variant).

    Parameters
    ----------
    estimate : expression in the state names (e.g. ``"x1"``), one row.
    variant : {"plain", "004"}
    eigenvalues : requested closed-loop eigenvalues of F* − K H* (default −1, −2, … in
        continuous time, 1/2, 1/4, … in discrete time).
    diagonalize : with real distinct eigenvalues, also report 001 method 1's diagonal
        (Metzler) form: matrices ``T``, ``F_diag``, ``J_diag``, ``Phi_diag``, ``Hz_diag``.
    """
    if variant not in ("plain", "004"):
        raise UsageError(f"variant must be 'plain' or '004', got {variant!r}")
    problem = prepare(model, symbolic=symbolic, method="exact")  # exact arithmetic only
    work, st = problem.work, problem.structure
    ar = arithmetic_for(problem)
    task = task_for(work, task, observer="virtual-sensor", disturbances=decouple,
                    estimate=estimate)
    M = sp.Matrix(task.M)
    if M.rows != 1:
        raise UsageError("a canonical-form virtual sensor estimates one signal z = M x")
    F, H = sp.Matrix(st.F), sp.Matrix(st.H)
    L = sp.Matrix(st.unknown_input_columns(task.decoupled)) if task.decoupled \
        else sp.zeros(st.n, 0)
    H0 = sp.Matrix.vstack(H, M) if variant == "004" else H
    found, attempts, pivots = _search(ar, st, F, H, H0, L, M, variant)
    if found is None:
        raise InfeasibleDesignError(
            f"{model.where}: z = {estimate} is not reachable by a canonical-form virtual sensor"
            f" for any k < n = {st.n}: " + "; ".join(attempts), tuple(attempts))
    k, v, R0, J0, Phi, idents, subs, rank_info = found
    mats, Hz, Q, eigs, placed = _matrices(st, work, Phi, R0, J0, L, M, k, variant, eigenvalues)
    plant = dict(F=F, G=sp.Matrix(st.G), H=H, C=sp.Matrix(st.C), D=sp.zeros(st.n, 0), L=L)
    cert = ar.certify(plant, mats, M=M, substitutions=idents)
    # certified: det(sI − F* + K H*) = Π(s − μ_i) exactly, so the μ_i are the eigenvalues
    cl_list = closed_loop_eigenvalues(placed)
    conds = _conditions(ar, work, mats, k, rank_info, attempts, Hz, Q, eigs, placed, cl_list,
                        variant)
    xs, ys = observer_symbols(k), output_symbols(st.l)
    equations = reduced_equations(mats, work.inputs, xs, ys, nonlinear=subs, q=len(st.terms))
    z = sp.expand(estimate_outputs(mats, xs, ys)[0, 0])
    if diagonalize and all(sp.im(e) == 0 for e in cl_list) and len(set(cl_list)) == k:
        conds.append(_diagonal_form(ar, plant, mats, sp.Matrix(placed.K), M, Q, Hz, Phi,
                                    cl_list, k))
    conds.append(Condition("certificate", cert.passed, cert.summary(), "METHOD §2"))
    chosen_txt = (f"k = {k}: the first member (reduced-echelon order) that is nondegenerate and"
                  f" satisfies the virtual-sensor condition; R* = {list(mats['R_star'])}")
    return Design(
        model_name=work.name, form="canonical", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=tuple(sorted(pivots, key=str)), certificate=cert, task=task, structure=st,
        symbolic=bool(work.parameters), method="exact",
        choice=chosen_txt + (" (seed-004 variant: driven by y and y_v = z)" if variant == "004" else ""),
        attempts=tuple(attempts), time=work.time,
        closed_loop_eigenvalues=cl_list, equations=equations, observer_states=tuple(xs),
        nonlinear=tuple(subs),
        outputs=(("z", z),))


def _search(ar, st, F, H, H0, L, M, variant):
    """The smallest k < n with a member that is nondegenerate, satisfies the virtual-sensor
    condition rank [Φ; H] = rank [Φ; H; M] and lets the nonlinear arguments be recovered:
    ``(found or None, attempts, pivots)`` — the rank decisions' pivots: smaller k
    impossible, then the chosen k."""
    attempts = []
    pivots: set = set()
    # (R*, −J*_1, …, −J*_k) (W L) = 0 with R* acting on H and J* on H0 (krylov_blocks)
    spaces = krylov_null_spaces(F, H, L, H0=H0 if variant == "004" else None)
    for k in range(1, st.n):
        report(f"designing (virtual sensor, canonical form): k = {k} of at most {st.n - 1}")
        members, rank, rank_conds = next(spaces)
        need = H.rows + k * H0.rows
        if not members:
            attempts.append(f"k={k}: rank condition (3.3) fails: rank (W L) = {rank} = {need} rows")
            pivots |= rank_conds
            continue
        cands = list(members) + [a + b for i, a in enumerate(members) for b in members[i + 1:]]
        why = "no member"
        for v in cands:
            R0, J0, Phi = _member(v, F, H, H0, k)
            conds: set = set()
            if ar.rank(Phi, conds) < k:
                why = "every member is degenerate (rank Φ < k)"
                continue
            PH = sp.Matrix.vstack(Phi, H)
            if ar.rank(PH, conds) != ar.rank(sp.Matrix.vstack(PH, M), conds):
                why = "no member satisfies the virtual-sensor condition rank [Φ; H] = rank [Φ; H; M]"
                continue
            ok, why_nl, idents, subs = substitute_arguments(st, Phi, observer_symbols(k),
                                                            output_symbols(st.l))
            if not ok:
                why = why_nl
                continue
            pivots |= rank_conds | conds
            return (k, v, R0, J0, Phi, idents, subs, (rank, need, len(members))), attempts, pivots
        pivots |= rank_conds
        attempts.append(f"k={k}: rank condition (3.3) holds (rank (W L) = {rank} < {need} rows),"
                        f" but {why}")
    return None, attempts, pivots


def _matrices(st, work, Phi, R0, J0, L, M, k, variant, eigenvalues):
    """The reduced model's matrices with M = H_z Φ + Q H (the seed-004 variant: F* and J*
    with y_v = H_z x* + Q y substituted) and the gain K placing F* − K H*:
    ``(matrices, H_z, Q, eigenvalues requested, placement)``."""
    G, H = sp.Matrix(st.G), sp.Matrix(st.H)
    X = solve_left(sp.Matrix.vstack(Phi, H), M)
    Hz, Q = X[:, :k], X[:, k:]
    Fs = shift_matrix(k)
    Hs = sp.Matrix([[1] + [0] * (k - 1)])
    if variant == "004":
        Jy, Jv = J0[:, :st.l], J0[:, st.l:]
        Fs = Fs + Jv * Hz
        J = Jy + Jv * Q
        R = R0
    else:
        J, R = J0, R0
    mats = {"Phi": Phi, "F_star": Fs, "J_star": J, "R_star": R, "H_star": Hs, "G_star": Phi * G,
            "Hz": Hz, "Q": Q}
    if L.cols:
        mats["L_star"] = Phi * L
    if st.terms:
        mats["C_star"] = Phi * sp.Matrix(st.C)
    eigs = parse_eigenvalues(eigenvalues) if eigenvalues else default_eigenvalues(work.time, k)
    placed = pole_placement(Fs, Hs, eigs)
    mats["K"] = sp.Matrix(placed.K)
    mats = {name: Mx.applyfunc(sp.cancel) for name, Mx in mats.items()}
    return mats, Hz, Q, eigs, placed


def _conditions(ar, work, mats, k, rank_info, attempts, Hz, Q, eigs, placed, cl_list,
                variant) -> list:
    """The rank condition, minimality, the virtual-sensor condition, the closed loop
    (placed exactly, stable), observability of (F*, H*), H_z ≥ 0 and the Metzler (or
    nonnegative) F* − K H* of interval observers."""
    rank, need, dim = rank_info
    Fcl = (mats["F_star"] - sp.Matrix(placed.K) * mats["H_star"]).applyfunc(sp.cancel)
    conds = [
        Condition(f"rank condition (3.3) at k = {k}" + (" (outputs y and y_v = z)" if variant == "004" else ""),
                  True, f"rank (W L) = {rank} < {need} rows; left null space"
                  f" of dimension {dim}", "seed 001 §2; seed 004"),
        Condition("k is minimal", True, "; ".join(attempts) if attempts else "k = 1", "seed 001 §2"),
        Condition("virtual-sensor condition rank [Φ; H] = rank [Φ; H; M]", True,
                  f"M = H_z Φ + Q H with H_z = {list(Hz)}, Q = {list(Q)}", "seed 002 eq. (3.2)"),
        Condition("closed-loop eigenvalues of F* − K H*", True,
                  f"requested {[str(e) for e in eigs]}, obtained exactly {[str(e) for e in cl_list]}"
                  f" ({placed.method}; det(sI − F* + K H*) recomputed and equal to Π(s − μ_i))",
                  "METHOD §3"),
    ]
    require_stable(cl_list, work.time, eigs)
    stable = all((sp.re(e) < 0) if work.time == "continuous" else (sp.Abs(e) < 1) for e in cl_list)
    conds.append(Condition("observer stable", bool(stable),
                           "all closed-loop eigenvalues " + ("have Re < 0" if work.time == "continuous"
                                                             else "inside the unit circle"),
                           "METHOD §3"))
    O = sp.Matrix.vstack(*[mats["H_star"] * mats["F_star"] ** i for i in range(k)])
    ro = ar.rank(O, set())
    conds.append(Condition("observability of (F*, H*)", ro == k,
                           f"rank of the observability matrix = {ro} (k = {k})", "METHOD §4"))
    hz_ok = all(e.is_nonnegative is True for e in Hz)
    conds.append(Condition("H_z ≥ 0", hz_ok, f"H_z = {list(Hz)}" + (
        "" if hz_ok else " (interval bounds need the split H_z⁺, H_z⁻)"), "METHOD §3",
        required=False))
    if work.time == "continuous":
        metz = all(Fcl[i, j].is_nonnegative is True for i in range(k) for j in range(k) if i != j)
        conds.append(Condition("F* − K H* Metzler", metz, f"F* − K H* = {readable(Fcl)}",
                               "METHOD §3", required=False))
    else:
        nonneg = all(e.is_nonnegative is True for e in Fcl)
        conds.append(Condition("F* − K H* nonnegative", nonneg, f"F* − K H* = {readable(Fcl)}",
                               "METHOD §3", required=False))
    return conds


def _diagonal_form(ar, plant, mats, K, M, Q, Hz, Phi, cl_list, k) -> Condition:
    """Seed 001 method 1: T from the eigenvectors of F* − K H* (real distinct
    eigenvalues), ξ = T⁻¹ x*; the matrices T, F_diag, J_diag, Phi_diag, G_diag, Hz_diag
    join ``mats``, certified as a design of their own (K as placed)."""
    Fcl = (mats["F_star"] - K * mats["H_star"]).applyfunc(sp.cancel)
    T_cols = []
    for lam in cl_list:
        ns = (Fcl - lam * sp.eye(k)).nullspace()
        T_cols.append(ns[0])
    T = sp.Matrix.hstack(*T_cols)
    Ti = T.inv()
    Lam = (Ti * Fcl * T).applyfunc(sp.cancel)
    Jd = (Ti * (mats["J_star"] + K * mats["R_star"])).applyfunc(sp.cancel)
    Phid = (Ti * Phi).applyfunc(sp.cancel)
    mats.update({"T": T, "F_diag": Lam, "J_diag": Jd, "Phi_diag": Phid,
                 "G_diag": (Ti * mats["G_star"]).applyfunc(sp.cancel),
                 "Hz_diag": (Hz * T).applyfunc(sp.cancel)})
    dcert = ar.certify(plant, {"Phi": Phid, "F_star": Lam, "J_star": Jd,
                               "G_star": mats["G_diag"], "Hz": mats["Hz_diag"], "Q": Q}, M=M)
    metz = all(Lam[i, j] == 0 for i in range(k) for j in range(k) if i != j)
    return Condition("diagonal form (001 method 1) Metzler", metz and dcert.passed,
                     f"T⁻¹(F* − K H*)T = diag{tuple(Lam.diagonal())}; its identities: "
                     + dcert.summary(), "seed 001 §3", required=False)
