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
   over QQ or QQ(parameters)) or by SVD with a stated tolerance.
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
6. Certify independently (:mod:`observer_cad.certificate`); a failure raises.

References: seed 000 (Zhirabok & Zuev 2024) §2-3, §7, §9; seed 001 §2.
"""
from __future__ import annotations

import itertools
from typing import Sequence

import numpy as np
import sympy as sp

from . import linalg
from .certificate import certify_reduced_model
from .design import Condition, Design
from .errors import InfeasibleDesignError, ModelError, UsageError
from .model import PlantModel
from .structure import Structure, extract_structure

__all__ = ["design_canonical", "resolve_task", "krylov_blocks", "member_to_phi",
           "FLOAT_AUTO_N"]

#: Above this state dimension a numeric design uses the float (SVD) path by default.
FLOAT_AUTO_N = 20


# ---------------------------------------------------------------- task
def resolve_task(model: PlantModel, unknown_input: str, decouple: Sequence[str] = ()):
    """Symbols of the unknown input to estimate and of the inputs to decouple from."""
    where = model.where
    declared = ", ".join(s.name for s in model.faults + model.disturbances) or "none"

    def lookup(name, what):
        sym = model.symbol(str(name))
        if sym is None or (sym not in model.faults and sym not in model.disturbances):
            raise ModelError(
                f"{where}: unknown {what} '{name}'; declared faults and disturbances: {declared}")
        return sym

    if unknown_input is None:
        raise UsageError("an unknown-input design needs --fault NAME (the input to estimate)")
    target = lookup(unknown_input, "fault or disturbance")
    dec = [r for r in model.disturbances if r != target]
    for name in decouple or ():
        sym = lookup(name, "disturbance")
        if sym == target:
            raise UsageError(f"'{name}' cannot be both estimated (--fault) and decoupled (--disturbance)")
        if sym not in dec:
            dec.append(sym)
    return target, tuple(dec)


# ---------------------------------------------------------------- blocks
def krylov_blocks(F, H, L, k):
    """W⁽ᵏ⁾ = [H Fᵏ; …; H F; H] and the block Toeplitz L⁽ᵏ⁾ (METHOD §2a), sympy."""
    F, H, L = sp.Matrix(F), sp.Matrix(H), sp.Matrix(L)
    l, p = H.rows, L.cols
    HF = [H]
    for _ in range(k):
        HF.append(HF[-1] * F)
    W = sp.Matrix.vstack(*[HF[k - i] for i in range(k + 1)])
    Lk = sp.zeros(l * (k + 1), k * p)
    if p:
        HFL = [HF[j] * L for j in range(k)]
        for i in range(k):
            for j in range(i, k):
                Lk[i * l:(i + 1) * l, j * p:(j + 1) * p] = HFL[j - i]
    return W, Lk


def member_to_phi(v, F, H, k):
    """From a null-space member v = (R*, −J*_1, …, −J*_k): R*, J* (k×l) and Φ (k×n)."""
    v = sp.Matrix(v)
    l = H.rows
    R = v[:, :l]
    J = sp.Matrix.vstack(*[-v[:, l * (i + 1):l * (i + 2)] for i in range(k)])
    rows = [R * H]
    for i in range(k - 1):
        rows.append(rows[-1] * F - J[i, :] * H)
    Phi = sp.Matrix.vstack(*rows).applyfunc(sp.cancel)
    return R, J, Phi


def _shift(k):
    Fs = sp.zeros(k, k)
    for i in range(k - 1):
        Fs[i, i + 1] = 1
    return Fs


def _nondegeneracy_conditions(Phi, k) -> frozenset:
    """Common factors of all k×k minors of Φ (rank Φ = k fails where one vanishes)."""
    n = Phi.cols
    if not Phi.free_symbols:
        return frozenset()
    combos = list(itertools.combinations(range(n), k))
    if len(combos) > 200:  # too many minors: fall back to the pivots' conditions
        return linalg.exact_rank(Phi).conditions
    minors = [sp.cancel(Phi[:, list(c)].det(method="berkowitz")) for c in combos]
    nums = [sp.fraction(sp.together(m))[0] for m in minors if m != 0]
    if not nums:
        return frozenset()
    g = nums[0]
    for m in nums[1:]:
        g = sp.gcd(g, m)
        if not g.free_symbols:
            break
    return linalg.nonzero_conditions(g)


def _assumption_set(mats: dict, Phi, k, sens_entry) -> frozenset:
    out = set()
    for M in mats.values():
        for e in M:
            out |= linalg.denominator_conditions(e)
    out |= _nondegeneracy_conditions(Phi, k)
    if sens_entry is not None:
        out |= linalg.nonzero_conditions(sens_entry)
    return frozenset(out)


def _primitive(v):
    """v scaled to polynomial entries with no common factor (denominators cleared)."""
    entries = [sp.cancel(sp.together(e)) for e in v]
    dens = [sp.fraction(e)[1] for e in entries]
    lcm = sp.lcm_list(dens) if dens else 1
    w = [sp.cancel(e * lcm) for e in entries]
    nz = [e for e in w if e != 0]
    g = sp.gcd_list(nz) if nz else 1
    w = [sp.cancel(e / g) for e in w]
    first = next((e for e in w if e != 0), None)
    if first is not None and sp.expand(first).could_extract_minus_sign():
        w = [-e for e in w]
    return sp.Matrix([w])


def _fmt_vec(M) -> str:
    M = sp.Matrix(M)
    return "(" + ", ".join(str(sp.factor(e)) for e in M) + ")"


def _pretty(e):
    e = sp.cancel(e)
    if e.free_symbols:
        f = sp.factor(e)
        return f if sp.count_ops(f) <= sp.count_ops(e) else e
    return e


# ---------------------------------------------------------------- main entry
def design_canonical(model: PlantModel, *, unknown_input: str, decouple: Sequence[str] = (),
                     symbolic: bool = True, single_row: bool = True, method: str = "auto",
                     rtol: float | None = None, structure: Structure | None = None) -> Design:
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
        ``FLOAT_AUTO_N`` states.

    Returns
    -------
    Design
        With its certificate, conditions, assumptions, the chosen member and why.

    Raises
    ------
    InfeasibleDesignError
        When no k < n admits a design; the message lists every k tried.
    """
    if method not in ("auto", "exact", "float"):
        raise UsageError(f"method must be 'auto', 'exact' or 'float', got {method!r}")
    target, dec = resolve_task(model, unknown_input, decouple)
    work = model if symbolic else model.substitute_parameters()
    st = structure if structure is not None and symbolic else extract_structure(work)
    has_params = bool(work.parameters)
    if method == "auto":
        method = "float" if (not has_params and st.n > FLOAT_AUTO_N) else "exact"
    if method == "float" and has_params:
        raise UsageError("the float path needs numeric parameters: design without --symbolic")
    D = sp.Matrix(st.unknown_input_columns([target]))
    L = sp.Matrix(st.unknown_input_columns(dec))
    if method == "float":
        return _design_float(work, st, target, dec, D, L, single_row=single_row, rtol=rtol)
    return _design_exact(work, st, target, dec, D, L, symbolic=has_params, single_row=single_row)


def _common_conditions(st, D, L, rank_fn):
    """The necessary decoupling condition (2.4) and the matching condition."""
    H = sp.Matrix(st.H)
    conds = []
    rH = rank_fn(H)
    if L.cols:
        if rank_fn is _exact_rank_value:
            L0 = linalg.left_null_space(L)[0]
            L0 = sp.Matrix.vstack(*L0) if L0 else sp.zeros(0, st.n)
        else:
            L0, _ = linalg.float_left_null_space(np.asarray(L.evalf(), dtype=float))
            L0 = sp.Matrix(L0)
        rL0 = rank_fn(L0)
        rHL0 = rank_fn(sp.Matrix.vstack(H, L0))
        ok = rHL0 < rH + rL0
        conds.append(Condition(
            "decoupling necessary condition rank [H; L0] < rank H + rank L0", ok,
            f"rank [H; L0] = {rHL0}, rank H + rank L0 = {rH} + {rL0} = {rH + rL0}",
            "seed 000 eq. (2.4)"))
    else:
        conds.append(Condition(
            "decoupling necessary condition rank [H; L0] < rank H + rank L0", True,
            "no disturbances to decouple from (L0 = I)", "seed 000 eq. (2.4)"))
    rHD, rD = rank_fn(H * D), rank_fn(D)
    conds.append(Condition(
        "matching condition rank(HD) = rank(D)", rHD == rD,
        f"rank HD = {rHD}, rank D = {rD}" + ("" if rHD == rD else
                                              " (the input does not reach y directly)"),
        "seed 000 Remark 1", required=False))
    return conds


def _exact_rank_value(M) -> int:
    return linalg.exact_rank(M).rank


def _design_exact(model, st, target, dec, D, L, *, symbolic, single_row) -> Design:
    F, G, H, C = (sp.Matrix(M) for M in (st.F, st.G, st.H, st.C))
    n, l = st.n, st.l
    tname = target.name
    conds = _common_conditions(st, D, L, _exact_rank_value)
    if not conds[0].holds:
        raise InfeasibleDesignError(
            f"{model.where}: no model decoupled from {', '.join(s.name for s in dec)} exists:"
            f" the necessary condition fails ({conds[0].detail})", (conds[0].detail,))
    attempts: list = []
    minimality: set = set()
    chosen = None
    for k in range(1, n):
        W, Lk = krylov_blocks(F, H, L, k)
        M = sp.Matrix.hstack(W, Lk)
        basis, rk = linalg.left_null_space(M)
        need = l * (k + 1)
        rank_txt = f"rank (W L) = {rk.rank}" + (
            f" (generic: {', '.join(sorted(map(str, rk.conditions)))})" if rk.conditions else "")
        if not basis:
            attempts.append(f"k={k}: rank condition (3.3) fails: {rank_txt} = l(k+1) = {need}")
            minimality |= rk.conditions
            continue
        members = linalg.echelon_rows(basis)
        found, why = _choose_member(members, F, H, D, k, single_row)
        if found is None:
            attempts.append(
                f"k={k}: rank condition (3.3) holds ({rank_txt} < {need}), null space of"
                f" dimension {len(members)}, but {why}")
            minimality |= rk.conditions
            continue
        chosen = (k, members, found, rank_txt, need)
        break
    if chosen is None:
        raise InfeasibleDesignError(
            f"{model.where}: no disturbance-decoupled model sensitive to '{tname}' exists for"
            f" any k < n = {n}: " + "; ".join(attempts), tuple(attempts))

    k, members, (v, r, idx, nsub, rejected), rank_txt, need = chosen

    def build(vec):
        R, J, Phi = member_to_phi(vec, F, H, k)
        mats = {
            "Phi": Phi, "F_star": _shift(k), "J_star": J, "R_star": R,
            "H_star": sp.Matrix([[1] + [0] * (k - 1)]), "G_star": Phi * G,
            "D_star": Phi * D, "L_star": Phi * L if L.cols else sp.zeros(k, 0),
        }
        if C.cols:
            mats["C_star"] = Phi * C
        mats = {name: M.applyfunc(_pretty) for name, M in mats.items()}
        return mats

    # presentation: normalised (leading R* entry 1) or primitive, fewer assumptions wins
    variants = [v]
    if symbolic:
        variants.append(_primitive(v))
    best = None
    for vec in variants:
        mats = build(vec)
        if single_row:
            sens = mats["D_star"][r, 0]
        else:  # D* ≠ 0: fails only where every entry vanishes (their common factor)
            nums = [sp.fraction(sp.together(e))[0] for e in mats["D_star"] if e != 0]
            sens = sp.gcd_list(nums) if len(nums) > 1 else (nums[0] if nums else None)
        assume = _assumption_set(mats, mats["Phi"], k, sens) | minimality
        if best is None or len(assume) < len(best[1]):
            best = (mats, assume, vec)
    mats, assume, v = best

    cert = certify_reduced_model(
        F=F, G=G, H=H, C=C, D=D, L=L, Phi=mats["Phi"], F_star=mats["F_star"],
        J_star=mats["J_star"], R_star=mats["R_star"], H_star=mats["H_star"],
        G_star=mats["G_star"], D_star=mats["D_star"],
        C_star=mats.get("C_star"), exact=True)

    row_txt = ("the first row (matched case)" if r == 0 else
               f"the last row only (mismatched case: the estimate is delayed by {k - 1} step(s))"
               if r == k - 1 else f"row {r + 1} only")
    if k == 1:
        row_txt = "the only row"
    choice = (
        f"k = {k}: the left null space of (W L) has dimension {len(members)}"
        + (f"; {nsub} member(s) put {tname} into {row_txt}" if single_row and k > 1 else "")
        + f". Chosen: member {idx + 1} of the reduced-echelon basis, R* = {_fmt_vec(mats['R_star'])}"
        f" (y* = {_ystar(mats['R_star'])}), the first that is sensitive to {tname}"
        f" (D* = {_fmt_vec(mats['D_star'].T)}ᵀ) and gives rank Φ = {k}"
        + (f"; rejected before it: {'; '.join(rejected)}" if rejected else "") + ".")
    conds += [
        Condition(f"rank condition (3.3) at k = {k}", True, f"{rank_txt} < l(k+1) = {need}",
                  "seed 000 eq. (3.3)"),
        Condition("k is minimal", True,
                  "; ".join(attempts) if attempts else "k = 1 is the smallest dimension",
                  "seed 000 §3"),
        Condition(f"fault sensitivity Phi D != 0 ({tname})", True,
                  f"D* = {_fmt_vec(mats['D_star'].T)}ᵀ", "seed 000 §4"),
    ]
    if single_row:
        conds.append(Condition("D* enters one row only", True, f"{tname} enters {row_txt}",
                               "seed 000 §5, §7"))
    conds.append(Condition("rank Phi = k (the model is not degenerate)", True,
                           f"rank Φ = {k}", "seed 000 §3"))
    conds.append(Condition("certificate", cert.passed, cert.summary(), "METHOD §2"))
    assumptions = tuple(sorted(assume, key=str))
    return Design(
        model_name=model.name, form="canonical", k=k, matrices=mats,
        conditions=tuple(conds), assumptions=assumptions, certificate=cert,
        unknown_input=tname, decoupled=tuple(s.name for s in dec), symbolic=symbolic,
        method="exact", choice=choice, attempts=tuple(attempts),
        null_space=tuple(members))


def _ystar(R) -> str:
    ys = sp.symbols(f"y1:{sp.Matrix(R).cols + 1}")
    return str(sum(c * y for c, y in zip(sp.Matrix(R), ys)))


def _choose_member(members, F, H, D, k, single_row):
    """The first member (in reduced-echelon order) satisfying the task, or a reason.

    Returns ``((v, row, index, n_subspace, rejected), None)`` or ``(None, why)``.
    """
    prefs = [0] if k == 1 else ([0, k - 1] + list(range(1, k - 1)) if single_row else [0])
    dstar = []
    for v in members:
        _, _, Phi = member_to_phi(v, F, H, k)
        dstar.append((Phi * D).applyfunc(sp.cancel))
    reasons = []
    for r in prefs:
        if single_row and k > 1:
            others = [i for i in range(k) if i != r]
            T = sp.Matrix([[ds[i, 0] for i in others] for ds in dstar])
            coeffs, _ = linalg.left_null_space(T)
            if not coeffs:
                reasons.append(f"no member puts the input into row {r + 1} only")
                continue
            sub = [sum((c[0, b] * members[b] for b in range(len(members))),
                       sp.zeros(1, members[0].cols)) for c in coeffs]
            sub = linalg.echelon_rows(sub)
        else:
            sub = list(members)
        rejected = []
        cands = list(enumerate(sub))
        # fallback: sums of two members when no single member works
        cands += [(None, a + b) for a, b in itertools.combinations(sub, 2)]
        for idx, v in cands:
            R, J, Phi = member_to_phi(v, F, H, k)
            ds = (Phi * D).applyfunc(sp.cancel)
            if (ds[r, 0] == 0) if single_row else (ds == sp.zeros(*ds.shape)):
                if idx is not None:
                    rejected.append(f"member {idx + 1} is not sensitive (Φ D = 0 in row {r + 1})")
                continue
            rk = linalg.exact_rank(Phi).rank
            if rk < k:
                if idx is not None:
                    rejected.append(f"member {idx + 1} is degenerate (rank Φ = {rk} < {k})")
                continue
            return (v, r, idx if idx is not None else len(sub), len(sub), rejected), None
        reasons.append(f"row {r + 1}: " + ("; ".join(rejected) if rejected else "no member"))
    if not single_row:
        return None, "no member is sensitive to the input with rank Φ = k"
    return None, "no member is sensitive with the input in one row only (" + "; ".join(reasons) + ")"


# ---------------------------------------------------------------- float path
def _to_np(M):
    M = sp.Matrix(M)
    if M.rows == 0 or M.cols == 0:
        return np.zeros(M.shape)
    return np.array(M.evalf(), dtype=float)


def _design_float(model, st, target, dec, D, L, *, single_row, rtol) -> Design:
    F, G, H, Cm = (_to_np(M) for M in (st.F, st.G, st.H, st.C))
    Dn, Ln = _to_np(D), _to_np(L)
    n, l = st.n, st.l
    p = Ln.shape[1]
    tname = target.name

    def frank(M):
        return linalg.float_rank(M, rtol=rtol).rank
    conds = [c for c in _common_conditions(st, D, L, lambda M: frank(_to_np(M)))]
    if not conds[0].holds:
        raise InfeasibleDesignError(
            f"{model.where}: no model decoupled from {', '.join(s.name for s in dec)} exists:"
            f" the necessary condition fails ({conds[0].detail})", (conds[0].detail,))
    attempts = []
    HF = [H]
    for _ in range(n):
        HF.append(HF[-1] @ F)
    HFL = [h @ Ln for h in HF] if p else []
    chosen = None
    for k in range(1, n):
        W = np.vstack([HF[k - i] for i in range(k + 1)])
        Lk = np.zeros((l * (k + 1), k * p))
        for i in range(k):
            for j in range(i, k):
                Lk[i * l:(i + 1) * l, j * p:(j + 1) * p] = HFL[j - i]
        M = np.hstack([W, Lk])
        # row scaling for conditioning: v (S M) = 0  <=>  (v S) M = 0
        s = np.linalg.norm(M, axis=1)
        s[s == 0] = 1.0
        N, fr = linalg.float_left_null_space(M / s[:, None], rtol=rtol)
        need = l * (k + 1)
        if N.shape[0] == 0:
            attempts.append(f"k={k}: rank condition (3.3) fails: {fr.evidence()} = l(k+1) = {need}")
            continue
        members = N / s[None, :]

        def phi(v):
            R = v[:l]
            J = np.vstack([-v[l * (i + 1):l * (i + 2)] for i in range(k)])
            rows = [R @ H]
            for i in range(k - 1):
                rows.append(rows[-1] @ F - J[i] @ H)
            return R, J, np.vstack(rows)
        prefs = [0] if k == 1 else ([0, k - 1] + list(range(1, k - 1)) if single_row else [0])
        pick = None
        for r in prefs:
            dst = np.array([(phi(v)[2] @ Dn)[:, 0] for v in members])  # (s, k)
            if single_row and k > 1:
                others = [i for i in range(k) if i != r]
                cs, _ = linalg.float_left_null_space(dst[:, others], rtol=rtol)
                if cs.shape[0] == 0:
                    continue
                sub = cs @ members
            else:
                sub = members
            t = np.array([(phi(v)[2] @ Dn)[r, 0] for v in sub])
            scale = max(np.linalg.norm(phi(v)[2]) for v in sub) * max(np.linalg.norm(Dn), 1e-300)
            if np.linalg.norm(t) <= 1e-9 * scale:
                continue
            v = (t / np.linalg.norm(t)) @ sub
            _, _, Phi = phi(v)
            fr_phi = linalg.float_rank(Phi, rtol=rtol)
            if fr_phi.rank < k:
                continue
            pick = (v, r, fr_phi)
            break
        if pick is None:
            attempts.append(f"k={k}: rank condition (3.3) holds ({fr.evidence()} < {need}),"
                            f" null space of dimension {members.shape[0]}, but no member is"
                            f" sensitive to {tname}" + (" in one row only" if single_row else ""))
            continue
        chosen = (k, pick, fr, need, members.shape[0])
        break
    if chosen is None:
        raise InfeasibleDesignError(
            f"{model.where}: no disturbance-decoupled model sensitive to '{tname}' exists for"
            f" any k < n = {n}: " + "; ".join(attempts), tuple(attempts))
    k, (v, r, fr_phi), fr, need, dim = chosen
    l_ = l
    R = v[:l_]
    v = v / R[np.argmax(np.abs(R))] if np.any(np.abs(R) > 0) else v
    R = v[:l_]
    J = np.vstack([-v[l_ * (i + 1):l_ * (i + 2)] for i in range(k)])
    rows = [R @ H]
    for i in range(k - 1):
        rows.append(rows[-1] @ F - J[i] @ H)
    Phi = np.vstack(rows)
    Fs = np.eye(k, k, 1)
    Hs = np.eye(1, k)
    mats_np = {"Phi": Phi, "F_star": Fs, "J_star": J, "R_star": R[None, :], "H_star": Hs,
               "G_star": Phi @ G if G.size else np.zeros((k, 0)), "D_star": Phi @ Dn,
               "L_star": Phi @ Ln if p else np.zeros((k, 0))}
    if Cm.size:
        mats_np["C_star"] = Phi @ Cm
    tol = 1e-8
    cert = certify_reduced_model(
        F=F, G=G if G.size else np.zeros((n, 0)), H=H, C=Cm if Cm.size else np.zeros((n, 0)),
        D=Dn, L=Ln if p else np.zeros((n, 0)), Phi=Phi, F_star=Fs, J_star=J,
        R_star=R[None, :], H_star=Hs, G_star=mats_np["G_star"], D_star=mats_np["D_star"],
        C_star=mats_np.get("C_star"), exact=False, tolerance=tol)
    mats = {name: sp.Matrix(np.atleast_2d(M)) if M.size else sp.zeros(*M.shape)
            for name, M in mats_np.items()}
    conds += [
        Condition(f"rank condition (3.3) at k = {k}", True, f"{fr.evidence()} < l(k+1) = {need}",
                  "seed 000 eq. (3.3)"),
        Condition("k is minimal", True,
                  "; ".join(attempts) if attempts else "k = 1 is the smallest dimension",
                  "seed 000 §3"),
        Condition(f"fault sensitivity Phi D != 0 ({tname})", True,
                  f"|D*| = {np.linalg.norm(mats_np['D_star']):.3e}", "seed 000 §4"),
    ]
    if single_row:
        conds.append(Condition("D* enters one row only", True,
                               f"{tname} enters row {r + 1} (other rows below tolerance)",
                               "seed 000 §5, §7"))
    conds.append(Condition("rank Phi = k (the model is not degenerate)", True,
                           fr_phi.evidence(), "seed 000 §3"))
    conds.append(Condition("certificate", cert.passed, cert.summary(), "METHOD §2"))
    choice = (f"k = {k}: numerical left null space of dimension {dim} ({fr.evidence()});"
              f" chosen: the combination maximising |D*_{r + 1}| with {tname} in row {r + 1}"
              f" only, scaled so that the largest entry of R* is 1")
    return Design(
        model_name=model.name, form="canonical", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=(), certificate=cert, unknown_input=tname,
        decoupled=tuple(s.name for s in dec), symbolic=False, method="float",
        choice=choice, attempts=tuple(attempts), null_space=())
