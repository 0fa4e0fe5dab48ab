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

References: seed 000 (Zhirabok & Zuev 2024) §2-3, §7, §9; seed 001 §2.
"""
from __future__ import annotations

import itertools
from typing import Sequence

import numpy as np
import sympy as sp
from sympy.polys.matrices import DomainMatrix

from ...progress import report
from ...numerics import SingleThreadBLAS, np_exact, to_sympy_float
from ..certificates import certify_design, certify_reduced_model
from ..core import FLOAT_AUTO_N
from ..core import Condition, Design
from ...errors import InfeasibleDesignError, UsageError
from ..core import observer_symbols, output_symbols, reduced_equations, residual_outputs
from ..core import task_for
from ...model import PlantModel, Task
from ..core import substitute_arguments
from ...model import Structure, extract_structure
from ...numerics import (GrowingLeftNull, as_rational, from_rational, exact_product,
                         exact_rank_value, left_null_echelon, default_rtol, denominator_conditions,
                         echelon_rows, exact_rank, float_left_null_space, float_rank,
                         left_null_space, nonzero_conditions)

__all__ = ["design_canonical", "krylov_blocks", "krylov_null_spaces", "member_to_phi",
           "FLOAT_AUTO_N"]



# ---------------------------------------------------------------- blocks
def krylov_blocks(F, H, L, k, *, H0=None):
    """W⁽ᵏ⁾ = [H Fᵏ; H0 Fᵏ⁻¹; …; H0 F; H0] and the block Toeplitz L⁽ᵏ⁾, block (i, j) =
    Hᵢ Fʲ⁻ⁱ L for j ≥ i (H₀ = H, Hᵢ = H0 below), sympy (METHOD §2a).

    (R*, −J*_1, …, −J*_k) (W⁽ᵏ⁾ L⁽ᵏ⁾) = 0 with R* acting on H and J* on ``H0``: H0 = H
    (the default) for the canonical form, H0 = [H; M] for seed 004's virtual sensor.
    """
    F, H, L = (A if isinstance(A, sp.MatrixBase) else sp.Matrix(A) for A in (F, H, L))
    H0 = H if H0 is None else (H0 if isinstance(H0, sp.MatrixBase) else sp.Matrix(H0))
    p = L.cols
    Fq, Hq, Lq, H0q = (as_rational(A) for A in (F, H, L, H0))
    if None not in (Fq, Hq, Lq, H0q):  # rational: products in FLINT
        Wq, Lkq = _krylov_rational(Fq, Hq, Lq, k, H0q=None if H0 is H else H0q)
        return from_rational(Wq), from_rational(Lkq)
    HF, H0F = [H], [H0]
    for _ in range(k):
        HF.append(HF[-1] * F)
        H0F.append(H0F[-1] * F)
    W = sp.Matrix.vstack(HF[k], *[H0F[k - i] for i in range(1, k + 1)])
    Lk = sp.zeros(W.rows, k * p)
    if p:
        HFL = [HF[j] * L for j in range(k)]
        H0FL = HFL if H0 is H else [H0F[j] * L for j in range(k - 1)]
        for i in range(k):
            B, r0 = (HFL, 0) if i == 0 else (H0FL, H.rows + (i - 1) * H0.rows)
            for j in range(i, k):
                Lk[r0:r0 + B[0].rows, j * p:(j + 1) * p] = B[j - i]
    return W, Lk


def _krylov_rational(Fq, Hq, Lq, k, HF=None, H0q=None):
    """:func:`krylov_blocks` on dense DomainMatrices over QQ. ``HF``, if given, is the list
    [H, H F, …] computed so far; it is extended in place (the search over k from scratch
    in ``benchmarks/bench_exact.py`` reuses it). With ``H0q``: the first block row with H,
    below it the matrices of order k − 1 with ``H0q`` (a zero block column first)."""
    p = Lq.shape[1]
    if H0q is not None and k:
        W0, L0 = _krylov_rational(Fq, H0q, Lq, k - 1)
        P = [Hq]
        for _ in range(k):
            P.append(P[-1] * Fq)
        W = P[k].vstack(W0)
        if not p:
            return W, DomainMatrix.zeros((W.shape[0], 0), sp.QQ).to_dense()
        top = (P[0] * Lq).hstack(*[P[j] * Lq for j in range(1, k)])
        return W, top.vstack(DomainMatrix.zeros((L0.shape[0], p), sp.QQ).to_dense().hstack(L0))
    HF = [Hq] if HF is None else HF
    while len(HF) < k + 1:
        HF.append(HF[-1] * Fq)
    l = Hq.shape[0]
    W = HF[k].vstack(*[HF[k - i] for i in range(1, k + 1)])
    Z = DomainMatrix.zeros((l, p), sp.QQ).to_dense()
    if not p or not k:
        return W, DomainMatrix.zeros((l * (k + 1), 0), sp.QQ).to_dense()
    HFL = [HF[j] * Lq for j in range(k)]
    blocks = [[HFL[j - i] if j >= i else Z for j in range(k)] for i in range(k + 1)]
    return W, _block(blocks)


def _block(blocks):
    """A block matrix from a list of rows of DomainMatrix blocks."""
    rows = [b[0].hstack(*b[1:]) for b in blocks]
    return rows[0].vstack(*rows[1:])


def krylov_null_spaces(F, H, L, *, H0=None):
    """For k = 1, 2, …: the left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾) (:func:`krylov_blocks`) as
    ``(members, rank, conditions)``: its reduced echelon basis (1 × rows matrices), the
    rank of (W⁽ᵏ⁾ L⁽ᵏ⁾) and the conditions of a generic rank (empty for rationals).

    Rational F, H, L (and H0): incrementally, with
    :class:`~observer_cad.numerics.GrowingLeftNull`, as

        (W⁽ᵏ⁾ L⁽ᵏ⁾) = [ H Fᵏ   H L   H F L … H Fᵏ⁻¹ L ]
                      [ W̃      0         L̃          ]

    where (W̃ L̃) is the matrix of order k − 1 with H0 in place of H (k = 1: H0 alone):
    (W⁽ᵏ⁾ L⁽ᵏ⁾) is that matrix with a zero column block inserted after W and l rows on
    top. With H0 ≠ H (seed 004) the H0 matrices are grown alongside. With parameters:
    eliminated from scratch at each k (:func:`~observer_cad.numerics.left_null_echelon`).
    """
    Fq, Hq, Lq = (as_rational(A) for A in (F, H, L))
    H0q = Hq if H0 is None else as_rational(H0)
    if None in (Fq, Hq, Lq, H0q):
        for k in itertools.count(1):
            members, rk = left_null_echelon(sp.Matrix.hstack(*krylov_blocks(F, H, L, k, H0=H0)))
            yield members, rk.rank, rk.conditions
    n, p = Fq.shape[0], Lq.shape[1]

    def tops(Hx):  # the rows on top at k = 1, 2, …: (H Fᵏ, H L, …, H Fᵏ⁻¹ L), in FLINT
        P, PL = Hx, []
        while True:
            PL.append(P * Lq)
            P = P * Fq
            yield P.hstack(*PL) if p else P

    below = GrowingLeftNull.of(H0q)  # the H0 matrix of order k − 1
    tops0 = tops(H0q)
    for top in tops(Hq):
        state = below.grow(top, at=n, width=p)
        if H0 is not None:
            below = below.grow(next(tops0), at=n, width=p)
        else:
            below = state
        N = state.null
        yield [from_rational(N[i:i + 1, :]) for i in range(N.shape[0])], state.rank, frozenset()


def member_to_phi(v, F, H, k):
    """From a null-space member v = (R*, −J*_1, …, −J*_k): R*, J* (k×l) and Φ (k×n)."""
    v = v if isinstance(v, sp.MatrixBase) else sp.Matrix(v)
    l = H.rows
    R = v[:, :l]
    J = sp.Matrix.vstack(*[-v[:, l * (i + 1):l * (i + 2)] for i in range(k)])
    Fq, Hq, Rq, Jq = as_rational(F), as_rational(H), as_rational(R), as_rational(J)
    if None not in (Fq, Hq, Rq, Jq):  # rational: products in FLINT
        rows = [Rq * Hq]
        for i in range(k - 1):
            rows.append(rows[-1] * Fq - Jq[i:i + 1, :] * Hq)
        return R, J, from_rational(rows[0].vstack(*rows[1:]))
    rows = [R * H]
    for i in range(k - 1):
        rows.append(rows[-1] * F - J[i, :] * H)
    Phi = sp.Matrix.vstack(*rows).applyfunc(sp.cancel)
    return R, J, Phi


def shift_matrix(k):
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
        return exact_rank(Phi).conditions
    minors = [sp.cancel(Phi[:, list(c)].det(method="berkowitz")) for c in combos]
    nums = [sp.fraction(sp.together(m))[0] for m in minors if m != 0]
    if not nums:
        return frozenset()
    g = nums[0]
    for m in nums[1:]:
        g = sp.gcd(g, m)
        if not g.free_symbols:
            break
    return nonzero_conditions(g)


def _assumption_set(mats: dict, Phi, k, sens_entry) -> frozenset:
    out = set()
    for M in mats.values():
        for e in M:
            out |= denominator_conditions(e)
    out |= _nondegeneracy_conditions(Phi, k)
    if sens_entry is not None:
        out |= nonzero_conditions(sens_entry)
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
    if e.is_Rational:
        return e
    e = sp.cancel(e)
    if e.free_symbols:
        f = sp.factor(e)
        return f if sp.count_ops(f) <= sp.count_ops(e) else e
    return e


# ---------------------------------------------------------------- main entry
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
    task = task_for(model, task, observer="unknown-input",
                    faults=[] if unknown_input is None else [unknown_input], disturbances=decouple)
    work = model if symbolic else model.substitute_parameters()
    st = structure if structure is not None and symbolic else extract_structure(work)
    target = work.symbol(task.targets[0])
    dec = tuple(work.symbol(n) for n in task.decoupled)
    has_params = bool(work.parameters)
    if method == "auto":
        method = "float" if (not has_params and st.n > FLOAT_AUTO_N) else "exact"
    if method == "float" and has_params:
        raise UsageError("the float path needs numeric parameters: design without --symbolic")
    D = sp.Matrix(st.unknown_input_columns([target]))
    L = sp.Matrix(st.unknown_input_columns(dec))
    if method == "float":
        return _design_float(work, st, task, target, dec, D, L, single_row=single_row, rtol=rtol)
    return _design_exact(work, st, task, target, dec, D, L, symbolic=has_params,
                         single_row=single_row)


def _common_conditions(st, D, L, rank_fn):
    """The necessary decoupling condition (2.4) and the matching condition."""
    H = sp.Matrix(st.H)
    conds = []
    rH = rank_fn(H)
    if L.cols:
        if rank_fn is _exact_rank_value:
            L0 = left_null_space(L)[0]
            L0 = sp.Matrix.vstack(*L0) if L0 else sp.zeros(0, st.n)
        else:
            L0, _ = float_left_null_space(np.asarray(L.evalf(), dtype=float))
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
    return exact_rank_value(M)


def _design_exact(model, st, task, target, dec, D, L, *, symbolic, single_row) -> Design:
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
    spaces = krylov_null_spaces(F, H, L)
    for k in range(1, n):
        report(f"designing (exact, canonical form): k = {k} of at most {n - 1}")
        members, rank, rank_conds = next(spaces)
        need = l * (k + 1)
        rank_txt = f"rank (W L) = {rank}" + (
            f" (generic: {', '.join(sorted(map(str, rank_conds)))})" if rank_conds else "")
        if not members:
            attempts.append(f"k={k}: rank condition (3.3) fails: {rank_txt} = l(k+1) = {need}")
            minimality |= rank_conds
            continue
        found, why = _choose_member(members, F, H, D, k, single_row, st)
        if found is None:
            attempts.append(
                f"k={k}: rank condition (3.3) holds ({rank_txt} < {need}), null space of"
                f" dimension {len(members)}, but {why}")
            minimality |= rank_conds
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
            "Phi": Phi, "F_star": shift_matrix(k), "J_star": J, "R_star": R,
            "H_star": sp.Matrix([[1] + [0] * (k - 1)]), "G_star": exact_product(Phi, G),
            "D_star": exact_product(Phi, D), "L_star": exact_product(Phi, L) if L.cols else sp.zeros(k, 0),
        }
        if C.cols:
            mats["C_star"] = exact_product(Phi, C)
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

    xs, ys = observer_symbols(k), output_symbols(l)
    _, _, idents, subs = substitute_arguments(st, mats["Phi"], xs, ys)
    cert = certify_design(dict(F=F, G=G, H=H, C=C, D=D, L=L), mats, substitutions=idents)
    eqs, r_out, _ = _observer_equations(mats, model.inputs, xs, ys, subs, C.cols)

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
        task=task, structure=st, symbolic=symbolic, method="exact", choice=choice, attempts=tuple(attempts),
        null_space=tuple(members), time=model.time, nonlinear=tuple(subs),
        equations=eqs, observer_states=tuple(xs), outputs=(("r", r_out),))


def _observer_equations(mats, inputs, xs, ys, subs, q):
    """The reduced model's right-hand sides (the unknown input omitted) and r = R* y − H* x*."""
    eqs = reduced_equations(mats, inputs, xs, ys, nonlinear=subs, q=q)
    return eqs, sp.expand(residual_outputs(mats, xs, ys)[0, 0]), xs


def _ystar(R) -> str:
    ys = sp.symbols(f"y1:{sp.Matrix(R).cols + 1}")
    return str(sum(c * y for c, y in zip(sp.Matrix(R), ys)))


def _choose_member(members, F, H, D, k, single_row, st=None):
    """The first member (in reduced-echelon order) satisfying the task, or a reason.

    Returns ``((v, row, index, n_subspace, rejected), None)`` or ``(None, why)``.
    """
    prefs = [0] if k == 1 else ([0, k - 1] + list(range(1, k - 1)) if single_row else [0])
    dstar = []
    for v in members:
        _, _, Phi = member_to_phi(v, F, H, k)
        dstar.append(exact_product(Phi, D))
    reasons = []
    for r in prefs:
        if single_row and k > 1:
            others = [i for i in range(k) if i != r]
            T = sp.Matrix([[ds[i, 0] for i in others] for ds in dstar])
            coeffs, _ = left_null_space(T)
            if not coeffs:
                reasons.append(f"no member puts the input into row {r + 1} only")
                continue
            sub = [sum((c[0, b] * members[b] for b in range(len(members))),
                       sp.zeros(1, members[0].cols)) for c in coeffs]
            sub = echelon_rows(sub)
        else:
            sub = list(members)
        rejected = []
        cands = list(enumerate(sub))
        # fallback: sums of two members when no single member works
        cands += [(None, a + b) for a, b in itertools.combinations(sub, 2)]
        for idx, v in cands:
            R, J, Phi = member_to_phi(v, F, H, k)
            ds = exact_product(Phi, D)
            if (ds[r, 0] == 0) if single_row else (ds == sp.zeros(*ds.shape)):
                if idx is not None:
                    rejected.append(f"member {idx + 1} is not sensitive (Φ D = 0 in row {r + 1})")
                continue
            rk = exact_rank_value(Phi)
            if rk < k:
                if idx is not None:
                    rejected.append(f"member {idx + 1} is degenerate (rank Φ = {rk} < {k})")
                continue
            if st is not None and st.terms:  # METHOD §2c: arguments must be recoverable
                ok, why_nl, _, _ = substitute_arguments(st, Phi, observer_symbols(k),
                                                        output_symbols(H.rows))
                if not ok:
                    if idx is not None:
                        rejected.append(f"member {idx + 1}: {why_nl}")
                    continue
            return (v, r, idx if idx is not None else len(sub), len(sub), rejected), None
        reasons.append(f"row {r + 1}: " + ("; ".join(rejected) if rejected else "no member"))
    if not single_row:
        return None, "no member is sensitive to the input with rank Φ = k"
    return None, "no member is sensitive with the input in one row only (" + "; ".join(reasons) + ")"


# ---------------------------------------------------------------- float path
def _pow2(x):
    """The powers of two nearest to x > 0 (elementwise): scaling by them is exact."""
    return np.exp2(np.round(np.log2(x)))


def _growth(P, k, hnorm):
    """α with |H Fᵏ| ≈ αᵏ |H|: the mean growth of the Krylov rows (1 if undefined).

    Building (W L) from F/α (exactly a row and column scaling of it, undone for the
    members) keeps H Fʲ, the W and the L⁽ᵏ⁾ parts of each row at comparable sizes,
    whatever the scale of F.
    """
    g = float(np.linalg.norm(P[k]))
    if not (g > 0 and hnorm > 0 and np.isfinite(g)):
        return 1.0
    return float((g / hnorm) ** (1.0 / k))


def _equilibrate(M, sweeps: int = 20):
    """Ruiz equilibration: row and column scale factors (powers of two) such that
    ``M / rs[:, None] / cs[None, :]`` has every nonzero row and column of max-norm
    within a factor of about 2 of 1.

    Each sweep divides rows and columns by the square roots of their max-norms; it
    converges to a scaling that does not depend on any diagonal scaling M had to
    begin with (so F and F/10, whose (W L) differ by exactly such a scaling, give the
    same decisions). Powers of two: no rounding, structural zeros stay zero.
    """
    A = np.abs(M)
    rs = np.ones(M.shape[0])
    cs = np.ones(M.shape[1])
    if A.size == 0:
        return rs, cs
    for _ in range(sweeps):
        r = A.max(axis=1)
        c = A.max(axis=0)
        r[r == 0] = 1.0
        c[c == 0] = 1.0
        if max(np.max(np.abs(np.log2(r))), np.max(np.abs(np.log2(c)))) <= 1.0:
            break
        dr = _pow2(np.sqrt(r))
        dc = _pow2(np.sqrt(c))
        A = A / dr[:, None] / dc[None, :]
        rs *= dr
        cs *= dc
    return rs, cs


def _scaled_left_null(M, rtol):
    """Left null space of M, computed on its equilibrated version (:func:`_equilibrate`).

    Column scaling leaves the left null space unchanged; a left null vector w of the
    scaled matrix is ``w / rs`` for M. Returns ``(members (rows, for M), w
    (orthonormal rows, scaled space), rs, FloatRank)``.
    """
    rs, cs = _equilibrate(M)
    Nw, fr = float_left_null_space(M / rs[:, None] / cs[None, :], rtol=rtol)
    return Nw / rs[None, :], Nw, rs, fr


def _toeplitz_float(PX, k, l, q):  # noqa: E741 - the papers' name
    """Block upper-triangular Toeplitz X⁽ᵏ⁾ (METHOD §2a) from PX[j] = H Fʲ X (l×q).

    Block (b, j) = H F^{j−b} X for j ≥ b; the last block row is zero. With X = L it
    is L⁽ᵏ⁾; with X = D column i gives D*_{i+1} = v · X⁽ᵏ⁾[:, i] for a member v.
    """
    out = np.zeros((l * (k + 1), k * q))
    if q:
        for b in range(k):
            for j in range(b, k):
                out[b * l:(b + 1) * l, j * q:(j + 1) * q] = PX[j - b]
    return out


def _phi_float(U, F, H, k, l):  # noqa: E741
    """Φ of each member (rows of U = (R*, −J*_1, …, −J*_k)): an (s, k, n) array."""
    U = np.atleast_2d(U)
    rows = [U[:, :l] @ H]
    for i in range(k - 1):
        # Φ_{i+1} = Φ_i F − J*_i H, and −J*_i is block i+1 of the member
        rows.append(rows[-1] @ F + U[:, l * (i + 1):l * (i + 2)] @ H)
    return np.stack(rows, axis=1)


def _phi_ref(U, pn, k, l):  # noqa: E741
    """Size of each Φ_i without cancellation: Σ_b |v_b| |H F^{i−b}| (an (s, k) array).

    Φ_{i+1} = Σ_{b≤i} v_b H F^{i−b} for a member v = (v_0, …, v_k) (METHOD §2a); a row
    far below this reference is zero up to rounding (e.g. R* H = 0 when H has
    dependent rows), however it looks after scaling it to unit norm.
    """
    U = np.atleast_2d(U)
    vb = np.stack([np.linalg.norm(U[:, l * b:l * (b + 1)], axis=1) for b in range(k)], axis=1)
    ref = np.zeros((U.shape[0], k))
    for i in range(k):
        ref[:, i] = sum(vb[:, b] * pn[i - b] for b in range(i + 1))
    return ref


def _float_common_conditions(H, D, L, rtol):
    """The necessary decoupling condition and the matching condition by SVD, with evidence.

    Rows of H and columns of D and L are scaled to unit norm first (ranks are invariant
    under it; the decisions become scale-free).
    """
    def unit_rows(A):
        s = np.linalg.norm(A, axis=1)
        s[s == 0] = 1.0
        return A / s[:, None]

    Hu = unit_rows(H)
    Du = unit_rows(D.T).T
    fH = float_rank(Hu, rtol=rtol)
    conds = []
    name = "decoupling necessary condition rank [H; L0] < rank H + rank L0"
    if L.shape[1]:
        L0, fL = float_left_null_space(unit_rows(L.T).T, rtol=rtol)
        rL0 = L0.shape[0]
        fHL0 = float_rank(np.vstack([Hu, L0]), rtol=rtol)
        ok = fHL0.rank < fH.rank + rL0
        conds.append(Condition(
            name, ok,
            f"rank [H; L0] = {fHL0.rank}, rank H + rank L0 = {fH.rank} + {rL0} = {fH.rank + rL0}"
            f" (SVD, rows of H and columns of L scaled to unit norm, L0 the orthonormal left"
            f" null space of L: [H; L0] {fHL0.evidence()}; H {fH.evidence()};"
            f" L {fL.evidence()})",
            "seed 000 eq. (2.4)"))
    else:
        conds.append(Condition(name, True, "no disturbances to decouple from (L0 = I)",
                               "seed 000 eq. (2.4)"))
    # the entries of Hu Du are cosines H_i·D / (|H_i| |D|): an absolute cut is scale-free
    cut = rtol if rtol is not None else default_rtol(H.shape)
    fHD = float_rank(Hu @ Du, atol=cut, rtol=cut)
    rHD, rD = fHD.rank, float_rank(Du, atol=cut, rtol=cut).rank
    conds.append(Condition(
        "matching condition rank(HD) = rank(D)", rHD == rD,
        f"rank HD = {rHD}, rank D = {rD}" + ("" if rHD == rD else
                                              " (the input does not reach y directly)")
        + f" (SVD of the cosines H_i·D/(|H_i| |D|): {fHD.evidence()})",
        "seed 000 Remark 1", required=False))
    return conds


def _design_float(model, st, task, target, dec, D, L, *, single_row, rtol) -> Design:
    """The canonical-form design by SVD (METHOD §2a); see :func:`_design_float_core`."""
    with SingleThreadBLAS():
        return _design_float_core(model, st, task, target, dec, D, L, single_row=single_row,
                                  rtol=rtol)


def _design_float_core(model, st, task, target, dec, D, L, *, single_row, rtol) -> Design:
    """The canonical-form design by SVD (METHOD §2a), certified on the original matrices.

    Numerics.

    * Scale: (W⁽ᵏ⁾ L⁽ᵏ⁾) is built from F/α, α = (|H Fᵏ| / |H|)^{1/k} the mean growth of
      the Krylov rows. That is exactly a row and column scaling of the original
      matrix (a member v of the scaled one gives the member v_b α^b, block b, of the
      original); without it a contractive F (F/10 of a random F) buries the W part of
      each row under the L⁽ᵏ⁾ part and the rank decisions go wrong (k = 8 or 5 instead
      of 9 at n = 60 in testing).
    * Every rank decision is then an SVD of the Ruiz-equilibrated matrix (powers of
      two: no rounding, structural zeros stay zero) with the cut
      ``max(shape)·eps·1e3·σ_1`` (or ``rtol·σ_1``), reported with the singular values
      on both sides of it and their distance to the cut.
    * "D* enters row r only" is linear in the member: D*_{i+1} = v · D⁽ᵏ⁾[:, i], D⁽ᵏ⁾
      the block Toeplitz of D built like L⁽ᵏ⁾, so the members doing so are the left
      null space of (W L⁽ᵏ⁾ D⁽ᵏ⁾_others), computed in one SVD like the rank condition
      (not by a second null space of a computed, already rounded basis).
    * Sensitivity and rank Φ are judged relative to ρ_i = Σ_b |v_b| |H F^(i−1−b)|, the
      size row Φ_i would have without cancellation (:func:`_phi_ref`): |Φ_i D|/(ρ_i |D|)
      and Φ with rows divided by ρ_i. Scaling a row to unit norm instead would turn a
      row that is zero up to rounding (R* H = 0 when H has dependent rows) into a
      "sensitive, full-rank" one.
    * Φ, J* come from the recurrence with the original F and H, and the certificate
      is evaluated on the ORIGINAL matrices (relative residuals, tolerance 1e-8, or
      100·rtol when a larger rtol is given).
    """
    F, G, H, Cm = (np_exact(M) for M in (st.F, st.G, st.H, st.C))
    Dn, Ln = np_exact(D), np_exact(L)
    n, l = st.n, st.l  # noqa: E741
    p = Ln.shape[1]
    tname = target.name

    conds = _float_common_conditions(H, Dn, Ln, rtol)
    if not conds[0].holds:
        raise InfeasibleDesignError(
            f"{model.where}: no model decoupled from {', '.join(s.name for s in dec)} exists:"
            f" the necessary condition fails ({conds[0].detail})", (conds[0].detail,))

    dnorm = float(np.linalg.norm(Dn))
    P, PL, PD = [H], [H @ Ln], [H @ Dn]  # H Fʲ, H Fʲ L, H Fʲ D, extended as k grows
    hnorm = float(np.linalg.norm(H))
    attempts = []
    chosen = None
    for k in range(1, n):
        report(f"designing (float, canonical form): k = {k} of at most {n - 1}")
        while len(P) <= k:
            P.append(P[-1] @ F)
            PL.append(P[-1] @ Ln)
            PD.append(P[-1] @ Dn)
        alpha = _growth(P, k, hnorm)
        sc = alpha ** -np.arange(k + 1.0)  # H (F/α)ʲ = H Fʲ α^-j
        M = np.hstack([np.vstack([P[k - b] * sc[k - b] for b in range(k + 1)]),
                       _toeplitz_float([X * c for X, c in zip(PL, sc)], k, l, p)])
        back = np.repeat(alpha ** np.arange(k + 1.0), l)  # member of M̃ -> member of M
        U, _, _, fr = _scaled_left_null(M, rtol)
        need = l * (k + 1)
        if U.shape[0] == 0:
            attempts.append(f"k={k}: rank condition (3.3) fails: {fr.evidence()} = l(k+1) = {need}")
            continue
        Dk = _toeplitz_float([X * c for X, c in zip(PD, sc)], k, l, Dn.shape[1])
        pn = [float(np.linalg.norm(X)) for X in P[:k + 1]]
        pick, why = _pick_float(M, U, Dk, back, F, H, Dn, pn, k, l, single_row, rtol)
        if pick is None:
            attempts.append(
                f"k={k}: rank condition (3.3) holds ({fr.evidence()} < {need}), null space of"
                f" dimension {U.shape[0]}, but {why}")
            continue
        chosen = (k, pick, fr, need, U.shape[0], pn)
        break
    if chosen is None:
        raise InfeasibleDesignError(
            f"{model.where}: no disturbance-decoupled model sensitive to '{tname}' exists for"
            f" any k < n = {n}: " + "; ".join(attempts), tuple(attempts))

    k, (v, r, sub_ev, fr_phi, nsub, tol2), fr, need, dim, pn = chosen
    R = v[:l]
    v = v / R[np.argmax(np.abs(R))] if np.any(R != 0) else v / np.max(np.abs(v))
    R = v[:l]
    J = -v[l:].reshape(k, l)
    Phi = _phi_float(v, F, H, k, l)[0]
    Dst = Phi @ Dn
    ref = _phi_ref(v, pn, k, l)[0]
    cos = np.abs(Dst[:, 0]) / np.maximum(ref * dnorm, np.finfo(float).tiny)
    others = [i for i in range(k) if i != r]
    tol = 1e-8 if rtol is None else max(1e-8, 100.0 * rtol)
    zeroed = False
    if single_row and others:
        leak = float(cos[others].max())
        # Zero the other rows when that is far inside the certificate's tolerance (the
        # certificate's Φ D − D* then checks it); when Φ's rows differ by many orders of
        # magnitude (large ‖F‖, large k) their rounding alone can exceed it: keep them.
        if np.linalg.norm(Dst[others, 0]) <= 1e-2 * tol * abs(Dst[r, 0]):
            Dst[others, :] = 0.0
            zeroed = True
    Fs = np.eye(k, k, 1)
    Hs = np.eye(1, k)
    mats_np = {"Phi": Phi, "F_star": Fs, "J_star": J, "R_star": R[None, :], "H_star": Hs,
               "G_star": Phi @ G if G.size else np.zeros((k, G.shape[1])), "D_star": Dst,
               "L_star": np.zeros((k, p))}
    if Cm.size:
        mats_np["C_star"] = Phi @ Cm
    cert = certify_reduced_model(
        F=F, G=G if G.size else np.zeros((n, 0)), H=H, C=Cm if Cm.size else np.zeros((n, 0)),
        D=Dn, L=Ln if p else np.zeros((n, 0)), Phi=Phi, F_star=Fs, J_star=J,
        R_star=R[None, :], H_star=Hs, G_star=mats_np["G_star"], D_star=Dst,
        C_star=mats_np.get("C_star"), exact=False, tolerance=tol)
    mats = {name: to_sympy_float(M) for name, M in mats_np.items()}
    mats["F_star"], mats["H_star"] = shift_matrix(k), sp.Matrix([[1] + [0] * (k - 1)])
    row_txt = ("the only row" if k == 1 else "the first row (matched case)" if r == 0 else
               f"the last row only (mismatched case: the estimate is delayed by {k - 1} step(s))"
               if r == k - 1 else f"row {r + 1} only")
    conds += [
        Condition(f"rank condition (3.3) at k = {k}", True,
                  f"{fr.evidence()} < l(k+1) = {need}; SVD of (W L) with rows and columns"
                  f" equilibrated", "seed 000 eq. (3.3)"),
        Condition("k is minimal", True,
                  "; ".join(attempts) if attempts else "k = 1 is the smallest dimension",
                  "seed 000 §3"),
        Condition(f"fault sensitivity Phi D != 0 ({tname})", True,
                  f"|D*_{r + 1}| = {abs(Dst[r, 0]):.3e}; relative to its size without"
                  f" cancellation, |Φ_{r + 1} D|/(ρ_{r + 1} |D|) = {cos[r]:.3e} > tol {tol2:.1e}"
                  f" (ρ_i = Σ_b |v_b| |H F^(i−1−b)|, v = (R*, −J*_1, …))", "seed 000 §4"),
    ]
    if single_row:
        detail = f"{tname} enters {row_txt}"
        if others:
            detail += (f"; members doing so: {sub_ev}; the other rows'"
                       f" |Φ_i D|/(ρ_i |D|) are at most {leak:.1e}"
                       + (", set to 0 in D* (Φ D − D* is certified)" if zeroed else
                          ", kept in D* as computed (zeroing them would exceed the"
                          " certificate's tolerance: Φ's rows differ widely in size)"))
        conds.append(Condition("D* enters one row only", True, detail, "seed 000 §5, §7"))
    conds.append(Condition("rank Phi = k (the model is not degenerate)", True,
                           f"rows of Φ divided by ρ_i: {fr_phi.evidence()}", "seed 000 §3"))
    resid = ", ".join(f"{i.name}: {i.residual}" for i in cert.identities)
    conds.append(Condition("certificate", cert.passed, f"{cert.summary()} ({resid})",
                           "METHOD §2"))
    choice = (f"k = {k}: numerical left null space of dimension {dim} ({fr.evidence()});"
              + (f" {nsub} independent member(s) put {tname} into {row_txt};"
                 if single_row and k > 1 else "")
              + " chosen: the unit combination (in the equilibrated coordinates) maximising"
              + (f" |D*_{r + 1}|" if single_row or k == 1 else " |D*| (rows scaled by ρ_i |D|)")
              + f" (|Φ_{r + 1} D|/(ρ_{r + 1} |D|) = {cos[r]:.3e}), or the first non-degenerate"
              " combination near it, scaled so that the largest entry of R* is 1")
    return Design(
        model_name=model.name, form="canonical", k=k, matrices=mats, conditions=tuple(conds),
        assumptions=(), certificate=cert, task=task, structure=st, symbolic=False,
        method="float", time=model.time,
        choice=choice, attempts=tuple(attempts), null_space=())


def _pick_float(M, U, Dk, back, F, H, D, pn, k, l, single_row, rtol):  # noqa: E741
    """The member for the task (float path), or the reason none exists.

    ``M`` is the scaled (W L), ``U`` its left null space (rows), ``Dk`` the scaled
    D⁽ᵏ⁾ (column i: D*_{i+1} = v · D⁽ᵏ⁾[:, i]), ``back`` maps a member of the scaled
    matrix to one of the original (elementwise product). Rows are tried in the exact
    path's order (first, last, then the others). For row r the members with D* in row
    r only are the left null space of (M, D⁽ᵏ⁾_others); among them the unit combination
    maximising |D*_r| is taken if it clears the tolerance relative to ρ_r |D| (ρ the
    size of Φ_r without cancellation, :func:`_phi_ref`; ``pn[j] = |H Fʲ|``) and if Φ,
    its rows divided by ρ, has rank k. Without ``single_row`` (as the exact path): any
    member with D* ≠ 0, the unit combination maximising |D*| (rows scaled by ρ_i |D|).
    If the optimum is degenerate, perturbations of it are tried (rank Φ = k is generic
    in the null space when it holds anywhere).
    Returns ``((v, r, evidence, FloatRank of Φ, subspace dimension, tolerance), None)``
    or ``(None, why)``; v is a member of the original (W L).
    """
    prefs = [0] if k == 1 else ([0, k - 1] + list(range(1, k - 1)) if single_row else [0])
    dnorm = float(np.linalg.norm(D))
    reasons = []
    for r in prefs:
        others = [i for i in range(k) if i != r]
        if single_row and others:
            Ur, _, _, fsub = _scaled_left_null(np.hstack([M, Dk[:, others]]), rtol)
            ev = f"{Ur.shape[0]} (SVD of (W L D⁽ᵏ⁾ without column {r + 1}): {fsub.evidence()})"
            if Ur.shape[0] == 0:
                reasons.append(f"row {r + 1}: no member keeps the input out of the other rows"
                               f" ({fsub.evidence()})")
                continue
        else:
            Ur = U
            ev = f"all {U.shape[0]}"
        Uo = Ur * back[None, :]  # members of the original (W L)
        Phis = _phi_float(Uo, F, H, k, l)  # (s, k, n)
        T = Phis @ D[:, 0] if D.shape[1] else np.zeros(Phis.shape[:2])  # D* of each member
        # scale row i of D* by the largest ρ_i |D| over the basis members
        scale = _phi_ref(Uo, pn, k, l).max(axis=0) * dnorm
        scale[scale == 0] = 1.0
        Ts = T / scale[None, :]
        tol = rtol if rtol is not None else default_rtol(
            (M.shape[0], M.shape[1] + len(others)))
        if single_row or k == 1:
            ts = Ts[:, r]
            nt = float(np.linalg.norm(ts))
            c0 = ts / nt if nt > 0 else ts
        else:  # D* ≠ 0 in any row: the unit combination maximising |D*| (scaled)
            u, sv, _ = np.linalg.svd(Ts, full_matrices=False)
            nt, c0 = float(sv[0]), u[:, 0]
        if nt <= tol:
            where_ = f"Φ_{r + 1} D" if single_row or k == 1 else "Φ D"
            reasons.append(f"row {r + 1}: the {Ur.shape[0]} member(s) with the input in that"
                           f" row only are not sensitive (|{where_}|/(ρ |D|) at most"
                           f" {nt:.1e} ≤ tol {tol:.1e})" if single_row and others else
                           f"the {Ur.shape[0]} member(s) are not sensitive (|{where_}|/(ρ |D|)"
                           f" at most {nt:.1e} ≤ tol {tol:.1e})")
            continue
        # the optimum, then perturbations of it, then generic combinations near it (the
        # members with rank Φ = k are generic in the null space if there are any)
        rng = np.random.default_rng(k)
        cands = [c0] + [c0 + e for e in np.eye(len(c0))]
        cands += [c0 + 0.5 * g / np.linalg.norm(g) for g in rng.standard_normal((4, len(c0)))]
        fphi = None
        for c in cands:
            ds = c @ Ts
            size = abs(ds[r]) if single_row or k == 1 else np.linalg.norm(ds)
            if size <= tol * np.linalg.norm(c):
                continue
            Phi = np.tensordot(c, Phis, axes=1)
            nr = _phi_ref(c @ Uo, pn, k, l)[0]
            nr[nr == 0] = 1.0
            fphi = float_rank(Phi / nr[:, None], atol=tol, rtol=tol)
            if fphi.rank == k:
                rr = r if single_row or k == 1 else int(np.argmax(np.abs(ds)))
                return (c @ Uo, rr, ev, fphi, Ur.shape[0], tol), None
        reasons.append(f"row {r + 1}: the sensitive members are degenerate (rank Φ < {k}"
                       + (f": {fphi.evidence()})" if fphi is not None else ")"))
    what = "sensitive with the input in one row only" if single_row and k > 1 else \
        "sensitive to the input with rank Φ = k"
    return None, f"no member is {what} (" + "; ".join(reasons) + ")"
