"""The float path of the canonical form (METHOD §2a): SVD with stated tolerances and
the evidence of every decision, certified on the original matrices.

* Scale: (W⁽ᵏ⁾ L⁽ᵏ⁾) is built from F/α, α = (abs(H Fᵏ) / abs(H))^{1/k} the mean growth of
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
* Sensitivity and rank Φ are judged relative to ρ_i = Σ_b abs(v_b) abs(H F^(i−1−b)), the
  size row Φ_i would have without cancellation (:func:`_phi_ref`): abs(Φ_i D)/(ρ_i abs(D))
  and Φ with rows divided by ρ_i. Scaling a row to unit norm instead would turn a
  row that is zero up to rounding (R* H = 0 when H has dependent rows) into a
  "sensitive, full-rank" one.
* Φ, J* come from the recurrence with the original F and H, and the certificate
  is evaluated on the ORIGINAL matrices (relative residuals, tolerance 1e-8, or
  100·rtol when a larger rtol is given).
"""
from __future__ import annotations

import itertools

import numpy as np
import sympy as sp

from ...numerics import (default_rtol, float_left_null_space, float_rank, np_exact,
                         to_sympy_float)
from ..certificates import certify_reduced_model
from ..core import Condition, FloatArithmetic
from ._krylov import shift_matrix
from ._search import Built, Member, NullStep

__all__ = ["CanonicalFloat"]


class CanonicalFloat(FloatArithmetic):
    """The canonical-form steps by SVD (see :mod:`._search` for the order): Krylov rows
    scaled by their mean growth, Ruiz equilibration before every rank decision, members
    judged relative to the size of Φ's rows without cancellation."""

    rank_note = "; SVD of (W L) with rows and columns equilibrated"

    def bind(self, st, D, L) -> None:
        """The plant this design works on, as floats (every rational correctly rounded)."""
        self.st = st
        self.F, self.G, self.H, self.Cm = (np_exact(M) for M in (st.F, st.G, st.H, st.C))
        self.Dn, self.Ln = np_exact(D), np_exact(L)

    def common_conditions(self):
        """The necessary decoupling condition and the matching condition by SVD, with evidence.

        Rows of H and columns of D and L are scaled to unit norm first (ranks are invariant
        under it; the decisions become scale-free).
        """
        H, D, L, rtol = self.H, self.Dn, self.Ln, self.rtol

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

    @staticmethod
    def equilibrate(M, sweeps: int = 20):
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

    def scaled_left_null(self, M):
        """Left null space of M, computed on its equilibrated version (:meth:`equilibrate`).

        Column scaling leaves the left null space unchanged; a left null vector w of the
        scaled matrix is ``w / rs`` for M. Returns ``(members (rows, for M), w
        (orthonormal rows, scaled space), rs, FloatRank)``.
        """
        rs, cs = self.equilibrate(M)
        Nw, fr = self.left_null_evidence(M / rs[:, None] / cs[None, :])
        return Nw / rs[None, :], Nw, rs, fr

    def null_spaces(self):
        """k = 1, 2, …: the left null space of (W L) built from F/α, α the mean growth of
        the Krylov rows, by SVD of its equilibrated version (members mapped back)."""
        F, H, Ln, Dn = self.F, self.H, self.Ln, self.Dn
        l, p = self.st.l, Ln.shape[1]  # noqa: E741
        P, PL, PD = [H], [H @ Ln], [H @ Dn]  # H Fʲ, H Fʲ L, H Fʲ D, extended as k grows
        hnorm = float(np.linalg.norm(H))
        for k in itertools.count(1):
            while len(P) <= k:
                P.append(P[-1] @ F)
                PL.append(P[-1] @ Ln)
                PD.append(P[-1] @ Dn)
            alpha = _growth(P, k, hnorm)
            sc = alpha ** -np.arange(k + 1.0)  # H (F/α)ʲ = H Fʲ α^-j
            M = np.hstack([np.vstack([P[k - b] * sc[k - b] for b in range(k + 1)]),
                           _toeplitz_float([X * c for X, c in zip(PL, sc)], k, l, p)])
            back = np.repeat(alpha ** np.arange(k + 1.0), l)  # member of M̃ -> member of M
            U, _, _, fr = self.scaled_left_null(M)
            if U.shape[0] == 0:
                yield NullStep(0, fr.evidence())
                continue
            Dk = _toeplitz_float([X * c for X, c in zip(PD, sc)], k, l, Dn.shape[1])
            pn = [float(np.linalg.norm(X)) for X in P[:k + 1]]
            yield NullStep(U.shape[0], fr.evidence(), frozenset(), (M, U, Dk, back, pn, fr))

    def choose(self, step, k, single_row):
        """The member for the task (:meth:`_pick`) as a :class:`Member` (its data: the
        evidence of the subspace, the FloatRank of Φ, the tolerance), or the reason."""
        M, U, Dk, back, pn, _ = step.data
        pick, why = self._pick(M, U, Dk, back, pn, k, single_row)
        if pick is None:
            return None, why
        v, r, ev, fphi, nsub, tol = pick
        return Member(v, r, nsub, (ev, fphi, tol)), None

    def _pick(self, M, U, Dk, back, pn, k, single_row):
        """The member for the task (float path), or the reason none exists.

        ``M`` is the scaled (W L), ``U`` its left null space (rows), ``Dk`` the scaled
        D⁽ᵏ⁾ (column i: D*_{i+1} = v · D⁽ᵏ⁾[:, i]), ``back`` maps a member of the scaled
        matrix to one of the original (elementwise product). Rows are tried in the exact
        path's order (first, last, then the others). For row r the members with D* in row
        r only are the left null space of (M, D⁽ᵏ⁾_others); among them the unit combination
        maximising abs(D*_r) is taken if it clears the tolerance relative to ρ_r abs(D) (ρ the
        size of Φ_r without cancellation, :func:`_phi_ref`; ``pn[j] = |H Fʲ|``) and if Φ,
        its rows divided by ρ, has rank k. Without ``single_row`` (as the exact path): any
        member with D* ≠ 0, the unit combination maximising abs(D*) (rows scaled by ρ_i abs(D)).
        If the optimum is degenerate, perturbations of it are tried (rank Φ = k is generic
        in the null space when it holds anywhere).
        Returns ``((v, r, evidence, FloatRank of Φ, subspace dimension, tolerance), None)``
        or ``(None, why)``; v is a member of the original (W L).
        """
        F, H, D, l, rtol = self.F, self.H, self.Dn, self.st.l, self.rtol  # noqa: E741
        prefs = [0] if k == 1 else ([0, k - 1] + list(range(1, k - 1)) if single_row else [0])
        dnorm = float(np.linalg.norm(D))
        reasons = []
        for r in prefs:
            others = [i for i in range(k) if i != r]
            if single_row and others:
                Ur, _, _, fsub = self.scaled_left_null(np.hstack([M, Dk[:, others]]))
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

    def certify(self, plant: dict, mats: dict, *, tolerance: float):
        """Every identity's residual relative to the terms it compares, below
        ``tolerance`` (:func:`~observer_cad.synthesis.certify_reduced_model`)."""
        return certify_reduced_model(**plant, **mats, exact=False, tolerance=tolerance)

    def build(self, work, k, step, member, minimality, single_row, tname, rows) -> Built:
        """The member normalised (largest entry of R* = 1), its matrices, the certificate
        on the original matrices, and the evidence of each decision."""
        pn, fr = step.data[4], step.data[5]
        sub_ev, fr_phi, tol2 = member.data
        r, l = member.row, self.st.l  # noqa: E741
        v = member.vector
        R = v[:l]
        v = v / R[np.argmax(np.abs(R))] if np.any(R != 0) else v / np.max(np.abs(v))
        mats_np, cos, tol, zeroed, leak = self._matrices(v, k, r, pn, single_row)
        cert = self.certify(self._plant(), {
            n: mats_np.get(n) for n in ("Phi", "F_star", "J_star", "R_star", "H_star", "G_star",
                                         "D_star", "C_star")}, tolerance=tol)
        mats = {name: to_sympy_float(M) for name, M in mats_np.items()}
        mats["F_star"], mats["H_star"] = shift_matrix(k), sp.Matrix([[1] + [0] * (k - 1)])
        Dst = mats_np["D_star"]
        others = [i for i in range(k) if i != r]
        row_note = ""
        if single_row and others:
            row_note = (f"; members doing so: {sub_ev}; the other rows'"
                        f" |Φ_i D|/(ρ_i |D|) are at most {leak:.1e}"
                        + (", set to 0 in D* (Φ D − D* is certified)" if zeroed else
                           ", kept in D* as computed (zeroing them would exceed the"
                           " certificate's tolerance: Φ's rows differ widely in size)"))
        resid = ", ".join(f"{i.name}: {i.residual}" for i in cert.identities)
        choice = (f"k = {k}: numerical left null space of dimension {step.dim} ({fr.evidence()});"
                  + (f" {member.count} independent member(s) put {tname} into {rows};"
                     if single_row and k > 1 else "")
                  + " chosen: the unit combination (in the equilibrated coordinates) maximising"
                  + (f" |D*_{r + 1}|" if single_row or k == 1 else " |D*| (rows scaled by ρ_i |D|)")
                  + f" (|Φ_{r + 1} D|/(ρ_{r + 1} |D|) = {cos[r]:.3e}), or the first non-degenerate"
                  " combination near it, scaled so that the largest entry of R* is 1")
        return Built(
            mats, cert,
            sensitivity=(f"|D*_{r + 1}| = {abs(Dst[r, 0]):.3e}; relative to its size without"
                         f" cancellation, |Φ_{r + 1} D|/(ρ_{r + 1} |D|) = {cos[r]:.3e} > tol"
                         f" {tol2:.1e} (ρ_i = Σ_b |v_b| |H F^(i−1−b)|, v = (R*, −J*_1, …))"),
            row_note=row_note, rank_phi=f"rows of Φ divided by ρ_i: {fr_phi.evidence()}",
            certificate_detail=f"{cert.summary()} ({resid})", choice=choice,
            extras=dict(assumptions=(), symbolic=False, null_space=()))

    def _plant(self) -> dict:
        n = self.st.n
        G, Cm, Ln = self.G, self.Cm, self.Ln
        return dict(F=self.F, G=G if G.size else np.zeros((n, 0)), H=self.H,
                    C=Cm if Cm.size else np.zeros((n, 0)), D=self.Dn,
                    L=Ln if Ln.shape[1] else np.zeros((n, 0)))

    def _matrices(self, v, k, r, pn, single_row):
        """Φ, F*, J*, R*, H*, G*, D*, L* (and C*) of the normalised member as floats, D*'s
        other rows zeroed when that is far inside the certificate's tolerance; with the
        relative sensitivities, that tolerance, whether rows were zeroed and the leak."""
        F, G, H, Cm, Dn = self.F, self.G, self.H, self.Cm, self.Dn
        l, p = self.st.l, self.Ln.shape[1]  # noqa: E741
        J = -v[l:].reshape(k, l)
        Phi = _phi_float(v, F, H, k, l)[0]
        Dst = Phi @ Dn
        ref = _phi_ref(v, pn, k, l)[0]
        cos = np.abs(Dst[:, 0]) / np.maximum(ref * float(np.linalg.norm(Dn)),
                                             np.finfo(float).tiny)
        others = [i for i in range(k) if i != r]
        tol = 1e-8 if self.rtol is None else max(1e-8, 100.0 * self.rtol)
        zeroed, leak = False, None
        if single_row and others:
            leak = float(cos[others].max())
            # Zero the other rows when that is far inside the certificate's tolerance (the
            # certificate's Φ D − D* then checks it); when Φ's rows differ by many orders of
            # magnitude (large ‖F‖, large k) their rounding alone can exceed it: keep them.
            if np.linalg.norm(Dst[others, 0]) <= 1e-2 * tol * abs(Dst[r, 0]):
                Dst[others, :] = 0.0
                zeroed = True
        mats = {"Phi": Phi, "F_star": np.eye(k, k, 1), "J_star": J, "R_star": v[:l][None, :],
                "H_star": np.eye(1, k),
                "G_star": Phi @ G if G.size else np.zeros((k, G.shape[1])), "D_star": Dst,
                "L_star": np.zeros((k, p))}
        if Cm.size:
            mats["C_star"] = Phi @ Cm
        return mats, cos, tol, zeroed, leak


# ---------------------------------------------------------------- helpers
def _pow2(x):
    """The powers of two nearest to x > 0 (elementwise): scaling by them is exact."""
    return np.exp2(np.round(np.log2(x)))


def _growth(P, k, hnorm):
    """α with abs(H Fᵏ) ≈ αᵏ abs(H): the mean growth of the Krylov rows (1 if undefined).

    Building (W L) from F/α (exactly a row and column scaling of it, undone for the
    members) keeps H Fʲ, the W and the L⁽ᵏ⁾ parts of each row at comparable sizes,
    whatever the scale of F.
    """
    g = float(np.linalg.norm(P[k]))
    if not (g > 0 and hnorm > 0 and np.isfinite(g)):
        return 1.0
    return float((g / hnorm) ** (1.0 / k))



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
    """Size of each Φ_i without cancellation: Σ_b abs(v_b) abs(H F^{i−b}) (an (s, k) array).

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

