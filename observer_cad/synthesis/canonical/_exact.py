"""The exact arithmetic of the canonical form (METHOD §2a): rational (FLINT) or over
QQ(parameters), every pivot's condition recorded. The left null spaces grow with k
(:func:`~observer_cad.synthesis.canonical.krylov_null_spaces`); the member is the first of
the reduced-echelon basis (or of the subspace putting D* into one row) that is sensitive,
non-degenerate and lets the nonlinear arguments be recovered; it is presented normalised
or with denominators cleared, whichever needs fewer assumptions.
"""
from __future__ import annotations

import itertools

import sympy as sp

from ...numerics import denominator_conditions, echelon_rows, exact_rank, nonzero_conditions
from ..core import (ExactArithmetic, Condition, observer_symbols, output_symbols,
                    reduced_equations, residual_outputs, substitute_arguments)
from ._krylov import krylov_null_spaces, member_to_phi, shift_matrix
from ._search import Built, Member, NullStep

__all__ = ["CanonicalExact"]


class CanonicalExact(ExactArithmetic):
    """The canonical-form steps in exact arithmetic (see :mod:`._search` for the order)."""

    rank_note = ""

    def bind(self, st, D, L) -> None:
        """The plant this design works on: the structure, D (the unknown input) and L."""
        self.st = st
        self.F, self.G, self.H, self.C = (sp.Matrix(M) for M in (st.F, st.G, st.H, st.C))
        self.D, self.L = D, L

    def common_conditions(self) -> list:
        """The necessary decoupling condition (2.4) and the matching condition."""
        H, D, L = self.H, self.D, self.L
        conds = []
        rH = self.rank(H)
        if L.cols:
            L0 = self.left_null_space(L)
            rL0 = self.rank(L0)
            rHL0 = self.rank(sp.Matrix.vstack(H, L0))
            ok = rHL0 < rH + rL0
            conds.append(Condition(
                "decoupling necessary condition rank [H; L0] < rank H + rank L0", ok,
                f"rank [H; L0] = {rHL0}, rank H + rank L0 = {rH} + {rL0} = {rH + rL0}",
                "seed 000 eq. (2.4)"))
        else:
            conds.append(Condition(
                "decoupling necessary condition rank [H; L0] < rank H + rank L0", True,
                "no disturbances to decouple from (L0 = I)", "seed 000 eq. (2.4)"))
        rHD, rD = self.rank(H * D), self.rank(D)
        conds.append(Condition(
            "matching condition rank(HD) = rank(D)", rHD == rD,
            f"rank HD = {rHD}, rank D = {rD}" + ("" if rHD == rD else
                                                  " (the input does not reach y directly)"),
            "seed 000 Remark 1", required=False))
        return conds

    def null_spaces(self):
        """k = 1, 2, …: the reduced-echelon members of the left null space of (W L)."""
        for members, rank, conds in krylov_null_spaces(self.F, self.H, self.L):
            text = f"rank (W L) = {rank}" + (
                f" (generic: {', '.join(sorted(map(str, conds)))})" if conds else "")
            yield NullStep(len(members), text, frozenset(conds), members)

    def choose(self, step, k, single_row):
        """The first member (in reduced-echelon order) satisfying the task, or a reason.

        Returns ``(Member, None)`` (its data: the index in the basis and the members
        rejected before it) or ``(None, why)``.
        """
        members, F, H, D = step.data, self.F, self.H, self.D
        prefs = [0] if k == 1 else ([0, k - 1] + list(range(1, k - 1)) if single_row else [0])
        dstar = [self.product(member_to_phi(v, F, H, k)[2], D) for v in members]
        reasons = []
        for r in prefs:
            if single_row and k > 1:
                others = [i for i in range(k) if i != r]
                T = sp.Matrix([[ds[i, 0] for i in others] for ds in dstar])
                coeffs = self.left_null_space(T)
                if not coeffs.rows:
                    reasons.append(f"no member puts the input into row {r + 1} only")
                    continue
                sub = echelon_rows([sum((coeffs[i, b] * members[b] for b in range(len(members))),
                                        sp.zeros(1, members[0].cols))
                                    for i in range(coeffs.rows)])
            else:
                sub = list(members)
            found, rejected = self._first_fit(sub, k, r, single_row)
            if found is not None:
                return found, None
            reasons.append(f"row {r + 1}: " + ("; ".join(rejected) if rejected else "no member"))
        if not single_row:
            return None, "no member is sensitive to the input with rank Φ = k"
        return None, ("no member is sensitive with the input in one row only ("
                      + "; ".join(reasons) + ")")

    def _first_fit(self, sub, k, r, single_row):
        """The first of the members ``sub`` (then of their pairwise sums) that is sensitive
        in row r, non-degenerate and lets the nonlinear arguments be recovered (METHOD
        §2c): ``(Member or None, the members rejected and why)``."""
        F, H, D, st = self.F, self.H, self.D, self.st
        rejected = []
        cands = list(enumerate(sub))
        # fallback: sums of two members when no single member works
        cands += [(None, a + b) for a, b in itertools.combinations(sub, 2)]
        for idx, v in cands:
            _, _, Phi = member_to_phi(v, F, H, k)
            ds = self.product(Phi, D)
            if (ds[r, 0] == 0) if single_row else (ds == sp.zeros(*ds.shape)):
                if idx is not None:
                    rejected.append(f"member {idx + 1} is not sensitive (Φ D = 0 in row {r + 1})")
                continue
            rk = self.rank(Phi)
            if rk < k:
                if idx is not None:
                    rejected.append(f"member {idx + 1} is degenerate (rank Φ = {rk} < {k})")
                continue
            if st.terms:  # METHOD §2c: arguments must be recoverable
                ok, why_nl, _, _ = substitute_arguments(st, Phi, observer_symbols(k),
                                                        output_symbols(H.rows))
                if not ok:
                    if idx is not None:
                        rejected.append(f"member {idx + 1}: {why_nl}")
                    continue
            return Member(v, r, len(sub), (idx if idx is not None else len(sub), rejected)), rejected
        return None, rejected

    def _matrices(self, vec, k) -> dict:
        """Φ, F*, J*, R*, H*, G*, D*, L* (and C*) of a member, entries in their
        simplest form."""
        R, J, Phi = member_to_phi(vec, self.F, self.H, k)
        mats = {
            "Phi": Phi, "F_star": shift_matrix(k), "J_star": J, "R_star": R,
            "H_star": sp.Matrix([[1] + [0] * (k - 1)]), "G_star": self.product(Phi, self.G),
            "D_star": self.product(Phi, self.D),
            "L_star": self.product(Phi, self.L) if self.L.cols else sp.zeros(k, 0),
        }
        if self.C.cols:
            mats["C_star"] = self.product(Phi, self.C)
        return {name: M.applyfunc(_pretty) for name, M in mats.items()}

    def _presented(self, v, k, r, minimality, single_row):
        """The member normalised (leading R* entry 1) or primitive, whichever needs fewer
        assumptions: ``(matrices, assumptions, vector)``."""
        best = None
        for vec in [v] + ([_primitive(v)] if self.symbolic else []):
            mats = self._matrices(vec, k)
            if single_row:
                sens = mats["D_star"][r, 0]
            else:  # D* ≠ 0: fails only where every entry vanishes (their common factor)
                nums = [sp.fraction(sp.together(e))[0] for e in mats["D_star"] if e != 0]
                sens = sp.gcd_list(nums) if len(nums) > 1 else (nums[0] if nums else None)
            assume = _assumption_set(mats, mats["Phi"], k, sens) | minimality
            if best is None or len(assume) < len(best[1]):
                best = (mats, assume, vec)
        return best

    def build(self, work, k, step, member, minimality, single_row, tname, rows) -> Built:
        """The chosen member presented, certified, with its observer equations."""
        idx, rejected = member.data
        mats, assume, _ = self._presented(member.vector, k, member.row, minimality, single_row)
        xs, ys = observer_symbols(k), output_symbols(self.H.rows)
        _, _, idents, subs = substitute_arguments(self.st, mats["Phi"], xs, ys)
        plant = dict(F=self.F, G=self.G, H=self.H, C=self.C, D=self.D, L=self.L)
        cert = self.certify(plant, mats, substitutions=idents)
        eqs = reduced_equations(mats, work.inputs, xs, ys, nonlinear=subs, q=self.C.cols)
        r_out = sp.expand(residual_outputs(mats, xs, ys)[0, 0])
        choice = (
            f"k = {k}: the left null space of (W L) has dimension {step.dim}"
            + (f"; {member.count} member(s) put {tname} into {rows}" if single_row and k > 1
               else "")
            + f". Chosen: member {idx + 1} of the reduced-echelon basis, R* ="
            f" {_fmt_vec(mats['R_star'])} (y* = {_ystar(mats['R_star'])}), the first that is"
            f" sensitive to {tname} (D* = {_fmt_vec(mats['D_star'].T)}ᵀ) and gives rank Φ = {k}"
            + (f"; rejected before it: {'; '.join(rejected)}" if rejected else "") + ".")
        return Built(
            mats, cert, sensitivity=f"D* = {_fmt_vec(mats['D_star'].T)}ᵀ", row_note="",
            rank_phi=f"rank Φ = {k}", certificate_detail=cert.summary(), choice=choice,
            extras=dict(assumptions=tuple(sorted(assume, key=str)), symbolic=self.symbolic,
                        null_space=tuple(step.data), nonlinear=tuple(subs), equations=eqs,
                        observer_states=tuple(xs), outputs=(("r", r_out),)))


def _ystar(R) -> str:
    ys = sp.symbols(f"y1:{sp.Matrix(R).cols + 1}")
    return str(sum(c * y for c, y in zip(sp.Matrix(R), ys)))


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

