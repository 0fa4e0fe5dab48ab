"""Jordan-form synthesis in floating point (METHOD §2b), for large numeric linear models:
the design, step by step (the admissible λ in :mod:`._float_lambdas`, the rows in
:mod:`._float_rows`).

The rows come from the numerical left null space of P(λ) = [L0 (F − λI); H] for each
chosen λ, the task conditions (z = M x reachable; a residual seeing every fault) are
decided by least squares / SVD with stated tolerances, and the design is certified on the
original (exact) plant matrices with :func:`~observer_cad.synthesis.certify_design` in
float mode, with a tolerance scaled to the sizes of the products it compares.

References: seed 002 §2-3; METHOD §2b.
"""
from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np
import sympy as sp

from ...errors import ExpressionError, InfeasibleDesignError, UsageError
from ...model import PlantModel, Structure, Task, extract_structure, parse_expression
from ...numerics import (SingleThreadBLAS, float_left_null_space, float_rank, np_exact,
                         to_sympy_float)
from ..certificates import certify_design
from ..core import (Condition, Design, jordan_equations, observer_symbols, output_symbols,
                    task_for, task_parts)
from ._float_lambdas import (DEFAULT_RTOL, admissible_lambdas_float, relative_sigma,
                             row_singular_values)
from ._float_rows import (Families, SearchBudgetSpent, default_lambdas, fmt, lambda_set_text,
                          lstsq_relative, one_row_lambda, phi_rank, pools_by_size,
                          residual_rows, rows_solving_for_z, stable_float)

__all__ = ["design_jordan_float"]

#: certificate: absolute residual norms ≤ this × the largest norm of the compared products
_CERT_RTOL = 1e-10


def design_jordan_float(model: PlantModel, *, observer: str, estimate=None,
                        faults: Sequence[str] | None = None, decouple: Sequence[str] = (),
                        lambdas: Sequence | None = None, rtol: float | None = None,
                        task: Task | None = None, structure: Structure | None = None) -> Design:
    """Jordan-form design in floating point (numeric linear models).

    Same semantics as :func:`observer_cad.synthesis.design_jordan` for ``"virtual-sensor"``,
    ``"interval"`` and ``"diagnostic"``; parameters are replaced by their defaults;
    nonlinear terms raise :class:`UsageError`. ``rtol``: relative tolerance of the rank
    decisions on P(λ) (default :data:`DEFAULT_RTOL`). ``structure``: the structure of the
    model with its parameters substituted, when the caller has it already (it is not
    extracted again). Returns a :class:`Design` with ``method="float"`` and a float
    certificate (no minimality proof: the float path searches the fewest rows only).
    """
    if observer not in ("diagnostic", "virtual-sensor", "interval"):
        raise UsageError(f"Jordan form supports diagnostic, virtual-sensor and interval, not {observer!r}")
    task = task_for(model, task, observer=observer, faults=faults, disturbances=decouple,
                    estimate=estimate)
    with SingleThreadBLAS():
        return _design(model, observer, task, lambdas, rtol, structure)


@dataclasses.dataclass(frozen=True)
class _FloatPlant:
    """Step 1 of the float path: the task on the plant (floats read off the exact
    matrices), L0, the pencil P(λ) = A − λB and the tolerances."""

    work: PlantModel
    st: Structure
    task: Task
    observer: str
    where: str
    tol: float
    res_tol: float
    M: object
    fault_syms: tuple
    Ds: sp.Matrix
    Ls: sp.Matrix
    F: np.ndarray
    G: np.ndarray
    H: np.ndarray
    D: np.ndarray
    L: np.ndarray
    Mn: np.ndarray | None
    L0: np.ndarray
    l0_ev: str

    @property
    def n(self) -> int:
        return self.st.n

    @property
    def decoupled(self) -> bool:
        return self.observer != "interval"

    @property
    def pencil(self) -> tuple:
        """(A, B) of P(λ) = A − λB = [L0 (F − λI); H]."""
        return (np.vstack([self.L0 @ self.F, self.H]),
                np.vstack([self.L0, np.zeros((self.st.l, self.n))]))


def _design(model, observer, task, lambdas, rtol, structure=None):
    p = _float_plant(model, observer, task, rtol, structure)             # 1. the task, L0
    generic, values, adm_ev = admissible_lambdas_float(p.F, p.H, p.L0, rtol=p.tol)
    describe = "every λ (generic solvability)" if generic else (        # 2. admissible λ
        "λ ∈ {" + ", ".join(fmt(v) for v in values) + "}" if values else "λ ∈ {} (none real)")
    adm = Condition("admissible λ", generic or bool(values), f"{describe}; {adm_ev}; {p.l0_ev}",
                    "METHOD §2b; seed 002 eq. (2.5)")
    lam_list = _lambda_list(p, lambdas, generic, values, describe, adm_ev)
    rows, extra, fam, searched, tried = _rows(p, lam_list, generic, lambdas)  # 3. the rows
    mats_np, mats, zres = _matrices(p, rows, extra)                       # 4. the design
    cert, scale = _certificate(p, mats_np, mats)
    k, lams = len(rows), [r[0] for r in rows]
    xs, ys = observer_symbols(k), output_symbols(p.st.l)
    equations, outputs = jordan_equations(mats, p.work.inputs, xs, ys, observer, p.M)
    conds = [adm] + _conditions(p, lams, mats_np, zres, fam)
    resid = ", ".join(f"{i.name}: {i.residual}" for i in cert.identities)
    conds.append(Condition("certificate", cert.passed,
                           f"{cert.summary()} (absolute residual norms {resid}; tolerance"
                           f" {_CERT_RTOL:.0e} × {scale:.2e}, the largest norm of the compared products)",
                           "METHOD §2"))
    choice = (f"k = {k}: rows with λ = ({', '.join(map(fmt, lams))}) from the numerical left"
              f" null spaces of P(λ) for λ in {lambda_set_text(searched)}; the fewest"
              f" rows that satisfy the {observer} conditions (float path, rtol {p.tol:.0e},"
              f" residual tolerance {p.res_tol:.0e})"
              + (f" (smaller sets rejected: {'; '.join(tried[:4])})" if tried else ""))
    work = p.work
    return Design(
        model_name=work.name, form="jordan", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=(), certificate=cert, task=task, structure=p.st, symbolic=False,
        method="float", choice=choice, attempts=tuple(tried), time=work.time,
        lambdas=tuple(sp.Float(v) for v in lams), nonlinear=(), equations=equations,
        observer_states=tuple(xs), outputs=tuple(outputs))


def _float_plant(model, observer, task, rtol, structure) -> _FloatPlant:
    """Step 1: the task on the plant, and L0 (a left null space of L in floats).

    Raises
    ------
    UsageError
        Parameters without defaults, nonlinear terms.
    InfeasibleDesignError
        The disturbances span the whole state space.
    """
    work = model.substitute_parameters()
    where = model.where
    if work.parameters:
        raise UsageError("the float Jordan path needs numeric parameters (defaults for all)")
    st = structure if structure is not None else extract_structure(work)
    if st.terms or st.C.cols:
        raise UsageError(f"{where}: the float Jordan path handles linear models only (the model"
                         " has nonlinear terms); use the exact path")
    n = st.n
    tol = DEFAULT_RTOL if rtol is None else float(rtol)
    M, fault_syms, _, Ds, Ls = task_parts(work, st, task)
    decoupled = observer != "interval"
    # read off the structure's exact matrices directly (a mutable copy of a 300×300
    # rational matrix costs sympy ~1 s)
    F, G, H = (np_exact(sp.ImmutableMatrix(X)) for X in (st.F, st.G, st.H))
    D, L = np_exact(Ds), np_exact(Ls)
    if decoupled and L.shape[1]:
        L0, frL = float_left_null_space(L)
        l0_ev = f"L0: left null space of L, {frL.evidence()}"
    else:
        L0, l0_ev = np.eye(n), "L0 = I" + (" (interval observer: not decoupled)" if not decoupled else "")
    if L0.shape[0] == 0:
        raise InfeasibleDesignError(f"{where}: the disturbances span the whole state space;"
                                    " no decoupled observer exists")
    return _FloatPlant(work, st, task, observer, where, tol, max(1e-7, 100.0 * tol), M,
                       tuple(fault_syms), Ds, Ls, F, G, H, D, L,
                       None if M is None else np_exact(M), L0, l0_ev)


def _lambda_list(p, lambdas, generic, values, describe, adm_ev) -> list:
    """Step 2: the λ the rows are taken from — the requested ones (checked), the defaults
    and the one-row λ (every λ admissible), or the stable admissible values.

    Raises
    ------
    UsageError, InfeasibleDesignError
        A requested λ that is not a real number, not admissible or not stable; no stable
        admissible λ.
    """
    work, where, tol, n, observer = p.work, p.where, p.tol, p.n, p.observer
    F, H, L, Mn, decoupled = p.F, p.H, p.L, p.Mn, p.decoupled
    A, B = p.pencil
    need = "λ < 0" if work.time == "continuous" else "|λ| < 1"
    if lambdas:
        lam_list = []
        for v in lambdas:
            try:
                lam_s = parse_expression(v, where="--lambda", allow_complex=True,
                                         allow_crootof=True)
                lam = complex(lam_s)
            except ExpressionError as exc:
                raise UsageError(f"λ = {v!r} is not a number: {exc.reason}") from None
            except (TypeError, ValueError):
                raise UsageError(f"λ = {v!r} is not a number") from None
            if abs(lam.imag) > 0:
                raise UsageError(f"λ = {v} is not real: the Jordan form needs real λ")
            lam = lam.real
            if not generic:
                s = row_singular_values(A, B, lam)[0]
                near = [w for w in values if abs(w - lam) <= 1e-6 * (1.0 + abs(w))]
                if relative_sigma(s) > tol:
                    if not near:
                        raise InfeasibleDesignError(
                            f"{where}: λ = {fmt(lam)} is not admissible: [L0(F − λI); H] has"
                            f" full row rank there (σ_min/σ_1 = {relative_sigma(s):.2e} > tol"
                            f" {tol:.0e}; admissible: {describe})")
                    lam = near[0]  # the computed root, of which λ is a rounding
            if not stable_float(lam, work.time):
                raise InfeasibleDesignError(
                    f"{where}: λ = {fmt(lam)} is not stable in {work.time} time (needs {need})")
            lam_list.append(lam)
    elif generic:
        lam_list = default_lambdas(work.time, n)
        if Mn is not None and observer != "diagnostic":  # the λ a one-row design needs
            lam1 = one_row_lambda(F, H, L if decoupled else np.zeros((n, 0)), Mn, tol)
            if lam1 is not None and stable_float(lam1, work.time) and \
                    all(abs(lam1 - v) > 1e-9 * (1 + abs(v)) for v in lam_list):
                lam_list.insert(0, lam1)  # first: the narrow generic search stops early
    else:
        lam_list = [v for v in values if stable_float(v, work.time)]
        if not lam_list:
            raise InfeasibleDesignError(
                f"{where}: no stable admissible λ: {describe} ({adm_ev})", (adm_ev,))
    return lam_list


def _rows(p, lam_list, generic, lambdas) -> tuple:
    """Step 3: each λ's rows (computed as the search reaches it) and the fewest rows that
    do the task: (rows, extra matrices, families, λ searched, attempts).

    Raises
    ------
    InfeasibleDesignError
        No nonzero row; a fault no row sees; no set of rows does the task.
    """
    where, observer, n, tol, res_tol = p.where, p.observer, p.n, p.tol, p.res_tol
    H, D, Mn, fault_syms, task = p.H, p.D, p.Mn, p.fault_syms, p.task
    A, B = p.pencil
    fam = Families(A, B, p.L0, p.L0.shape[0], tol)
    pools = pools_by_size(fam, lam_list, narrow=generic and not lambdas)
    if not pools(1):
        raise InfeasibleDesignError(
            f"{where}: no nonzero row Φ_i for λ in {lambda_set_text(lam_list)}")
    tried = []
    budget = [0]
    try:
        if observer == "diagnostic":
            chosen = residual_rows(fam, pools, H, D, n, tol, res_tol, tried, budget)
        else:
            chosen = rows_solving_for_z(fam, pools, H, Mn, n, tol, res_tol, tried, budget)
    except SearchBudgetSpent:
        chosen = None
    searched = fam.reached(lam_list)
    if chosen is None and observer == "diagnostic":  # name the faults no row sees
        blind = []
        for c, f in enumerate(fault_syms):
            col = D[:, c]
            if all(np.linalg.norm(fam[lam][0] @ col) <= res_tol * np.linalg.norm(fam[lam][0])
                   * max(np.linalg.norm(col), 1e-300) for lam in fam):
                blind.append(f.name)
        if blind:
            dec_txt = f" with {', '.join(task.decoupled)} decoupled" if task.decoupled else ""
            raise InfeasibleDesignError(
                f"{where}: {', '.join(blind)} {'is' if len(blind) == 1 else 'are'} undetectable"
                f"{dec_txt}: every row Φ with Φ L = 0 (λ in {{{', '.join(map(fmt, searched))}}})"
                f" has " + ", ".join(f"Φ D_{b} ≈ 0" for b in blind) + " (float path)",
                tuple(tried))
    if chosen is None:
        bound = (f"with fewer than n = {n} rows for λ in {lambda_set_text(searched)}"
                 if not pools.narrow or len(lam_list) >= n - 1 else
                 f"from the default λ {lambda_set_text(lam_list)} (at most {len(lam_list)} distinct"
                 " λ; give more with lambdas= / --lambda)")
        raise InfeasibleDesignError(
            f"{where}: no Jordan-form {observer} {bound} (float path): " + "; ".join(tried),
            tuple(tried))
    rows, extra = chosen
    return rows, extra, fam, searched, tried


def _matrices(p, rows, extra) -> tuple:
    """The matrices in floats and as sympy Floats, and the relative residual of
    M ≈ H_z Φ + Q H (None without z)."""
    observer, G, D, L, H, Mn, decoupled = p.observer, p.G, p.D, p.L, p.H, p.Mn, p.decoupled
    zres = None
    k = len(rows)
    lams = [r[0] for r in rows]
    Phi = np.vstack([r[1] for r in rows])
    J = np.vstack([r[2] for r in rows])
    mats_np = {"Phi": Phi, "F_star": np.diag(lams), "J_star": J, "G_star": Phi @ G}
    if observer == "diagnostic":
        mats_np["R_star"], mats_np["H_star"] = extra["R_star"], extra["H_star"]
        mats_np["D_star"] = Phi @ D
    if L.shape[1]:
        mats_np["L_star"] = np.zeros((k, L.shape[1])) if decoupled else Phi @ L
    if Mn is not None:
        X, zres = lstsq_relative(np.vstack([Phi, H]), Mn)
        mats_np["Hz"], mats_np["Q"] = X[:, :k], X[:, k:]
    mats = {name: to_sympy_float(X) for name, X in mats_np.items()}
    mats["F_star"] = sp.diag(*[sp.Float(v) for v in lams])
    return mats_np, mats, zres


def _certificate(p, mats_np, mats) -> tuple:
    """The certificate on the exact plant matrices, its tolerance scaled to the sizes of
    the products it compares: (certificate, scale)."""
    st, n, observer, Mn, M, decoupled = p.st, p.n, p.observer, p.Mn, p.M, p.decoupled
    F, G, H, D, L, Ds, Ls = p.F, p.G, p.H, p.D, p.L, p.Ds, p.Ls
    Phi, J, lams = mats_np["Phi"], mats_np["J_star"], list(np.diag(mats_np["F_star"]))
    nrm = np.linalg.norm
    sizes = [nrm(Phi) * nrm(F), nrm(np.diag(lams)) * nrm(Phi), nrm(J) * nrm(H),
             nrm(Phi) * nrm(G), nrm(Phi) * nrm(D), nrm(Phi) * nrm(L)]
    if observer == "diagnostic":
        sizes += [nrm(mats_np["H_star"]) * nrm(Phi), nrm(mats_np["R_star"]) * nrm(H)]
    if Mn is not None:
        sizes += [nrm(Mn), nrm(mats_np["Hz"]) * nrm(Phi), nrm(mats_np["Q"]) * nrm(H)]
    scale = max([1.0] + [float(s) for s in sizes])
    cert_tol = _CERT_RTOL * scale
    plant = dict(F=st.F, G=st.G, H=st.H, C=sp.zeros(n, 0), D=Ds, L=Ls)
    cert = certify_design(plant, mats, M=M, decoupled=decoupled, exact=False, tolerance=cert_tol)
    return cert, scale


def _conditions(p, lams, mats_np, zres, fam) -> list:
    """The reported conditions (stability of each λ, the residual or z reachable, the
    interval observer's)."""
    work, observer, tol, res_tol, fault_syms = p.work, p.observer, p.tol, p.res_tol, p.fault_syms
    H, D, Mn, decoupled = p.H, p.D, p.Mn, p.decoupled
    Phi, k, nrm = mats_np["Phi"], len(lams), np.linalg.norm
    need = "λ < 0" if work.time == "continuous" else "|λ| < 1"
    conds = []
    for i, lam in enumerate(lams):
        conds.append(Condition(f"λ_{i + 1} = {fmt(lam)} stable", stable_float(lam, work.time),
                               f"{need} ({work.time} time); null space of P(λ): {fam.evidence[lam]}",
                               "METHOD §2b"))
    PH = np.vstack([Phi, H])
    fPH, fP, fH = float_rank(PH), phi_rank(Phi, tol), float_rank(H)
    if observer == "diagnostic":
        conds.append(Condition(
            "residual condition rank [Φ; H] < rank Φ + rank H", fPH.rank < fP.rank + fH.rank,
            f"rank [Φ; H] = {fPH.rank} ({fPH.evidence()}), rank Φ + rank H = {fP.rank} +"
            f" {fH.rank}", "seed 002 eq. (2.7)"))
        for c, f in enumerate(fault_syms):
            col = Phi @ D[:, c]
            rel = np.abs(col) / np.maximum(nrm(Phi, axis=1) * nrm(D[:, c]), np.finfo(float).tiny)
            seen = [i + 1 for i in range(k) if rel[i] > res_tol]
            conds.append(Condition(f"fault sensitivity ({f.name})", bool(seen),
                                   f"Φ D = [{', '.join(f'{v:.3e}' for v in col)}];"
                                   f" |Φ_i D|/(|Φ_i| |D|) = [{', '.join(f'{v:.1e}' for v in rel)}]"
                                   f" > {res_tol:.0e} for row(s) {seen}", "seed 002 §2, Remark 1"))
        Hs, Fs = mats_np["H_star"], mats_np["F_star"]
        O = np.vstack([Hs @ np.linalg.matrix_power(Fs, i) for i in range(k)])
        fo = float_rank(O)
        conds.append(Condition("observability of (F*, H*)", fo.rank == k,
                               f"observability matrix: {fo.evidence()} (k = {k})", "METHOD §4",
                               required=False))
    if Mn is not None:
        fPHM = float_rank(np.vstack([PH, Mn]))
        conds.append(Condition("z = M x reachable: rank [Φ; H] = rank [Φ; H; M]",
                               zres <= res_tol,
                               f"least squares M ≈ H_z Φ + Q H: relative residual {zres:.2e} ≤"
                               f" {res_tol:.0e}; [Φ; H]: {fPH.evidence()}; [Φ; H; M]:"
                               f" {fPHM.evidence()}", "seed 002 eq. (3.2)"))
        Hz = mats_np["Hz"]
        ztol = res_tol * max(1.0, float(np.max(np.abs(Hz))))
        nonneg = bool(np.all(Hz >= -ztol))
        conds.append(Condition("H_z ≥ 0", nonneg, f"H_z = [{', '.join(f'{v:.6g}' for v in Hz.ravel())}]"
                               + ("" if nonneg else " (the interval bounds use the split H_z⁺, H_z⁻)"),
                               "METHOD §3", required=False))
    if work.time == "continuous":
        conds.append(Condition("F* Metzler", True, "F* is diagonal", "METHOD §3", required=False))
    else:
        nonneg = all(v >= 0 for v in lams)
        conds.append(Condition("F* nonnegative", nonneg,
                               f"diag(F*) = [{', '.join(map(fmt, lams))}]"
                               + ("" if nonneg else " (interval bounds then use the ⁺/⁻ split)"),
                               "METHOD §3", required=False))
    if not decoupled:
        conds.append(Condition("decoupling", True, "not required (interval observer): L* = Φ L",
                               "METHOD §2b"))
    return conds
