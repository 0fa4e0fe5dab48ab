"""Robust (approximate) decoupling when no exact decoupled design exists (METHOD §2d).

When Φ L = 0 cannot be met for any k < n, the disturbance's contribution to the
reduced model is made as small as possible instead (seed 001 §6). The result is an
APPROXIMATE design: its ``approximate`` flag is set, ``residual_norm`` is the achieved
‖Φ L‖_F, the decoupling identity is *not* certified (L* = Φ L ≠ 0 is reported as the
residual), and every other defining identity is certified in float arithmetic.

Canonical form (:func:`design_robust_canonical`)
------------------------------------------------
Without decoupling, a member v = (R*, −J*_1, …, −J*_k) of the left null space of
W⁽ᵏ⁾ = [H Fᵏ; …; H] defines Φ row by row (Φ_1 = R* H, Φ_{i+1} = Φ_i F − J*_i H) with
Φ F = F* Φ + J* H exactly (F* the shift). The block Toeplitz L⁽ᵏ⁾ of
:func:`~observer_cad.synthesis.krylov_blocks` satisfies

    v L⁽ᵏ⁾ = (Φ_1 L, Φ_2 L, …, Φ_k L),   so   ‖v L⁽ᵏ⁾‖ = ‖Φ L‖_F.

With N an orthonormal basis (rows) of the null space and v = w N, ‖w‖ = ‖v‖ = 1, the
least ‖Φ L‖_F is the smallest singular value σ_min of N L⁽ᵏ⁾, reached at its left
singular vector w (seed 001 §6, Theorem 3). k is the smallest dimension whose null
space has a member meeting the task. The member is kept at unit norm, so
``residual_norm`` = ‖L*‖_F exactly as presented (= σ_min when the optimum meets the
task).

The task (rank Φ = k always; plus one of):

* ``unknown_input``: the input must reach the model, Φ D ≠ 0 relative to
  ρ_i = abs(H) α^(i−1) Σ_b abs(v_b) α^(−b), the size row Φ_i would have without cancellation
  (α the mean growth of abs(H Fʲ); every block of v counts, so a member whose R* is
  rounding noise is degenerate, not "sensitive");
* ``estimate`` z = M x: rank [Φ; H] = rank [Φ; H; M] (then M = H_z Φ + Q H).

If the unconstrained optimum violates the task the design says so and takes the best
member of a subspace whose members keep the task:

* Φ D ≈ 0: the insensitive combinations Z = {w : w N D⁽ᵏ⁾ = 0} are excluded by
  restricting w to Z⊥ (the range of N D⁽ᵏ⁾, D⁽ᵏ⁾ built like L⁽ᵏ⁾), where
  ‖w N D⁽ᵏ⁾‖ ≥ σ_min⁺(N D⁽ᵏ⁾) > 0 for every unit w; the best w there is again an SVD.
* z not reachable: with P_H = I − H⁺H, the condition reads M P_H = Σ_{i≥2} h_i Φ_i(w) P_H
  (Φ_1 P_H = 0). For a fixed direction g of (h_2, …, h_k) it is linear in w: w must lie
  in V(g), the left null space of C(g)(I − m̂ᵀm̂), C(g) = Σ g_i Φ_i(N) P_H,
  m̂ = M P_H / abs(M P_H); the best w in V(g) is an SVD. k = 2 has one subspace (exact);
  for k = 3 g is an angle searched on a 360-point grid, for k ≥ 4 on 400·(k−2)
  seeded random directions (the best found, not a proven optimum; reported as a search).
* rank Φ < k only: the singular directions of N L⁽ᵏ⁾ are tried in increasing order.

An exact design is not refused: every k < n is also checked for an exactly decoupled
member meeting the same task (left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾)); the condition
"approximate: exact decoupling impossible for every k < n" then either holds, with the
singular values around the cut at every k as evidence, or fails (not required) and
names the k where the exact design (:func:`~observer_cad.synthesis.design_canonical`)
should be used instead. The design is reported as approximate either way. For
nonlinear models C* = Φ C is reported with the argument-substitution condition of
§2c evaluated, not enforced.

Jordan form (:func:`design_robust_jordan`)
------------------------------------------
F* = diag(λ_i), stable λ (given, or −1, −2, … continuous / 1/2, 1/4, … discrete). With
L0 = I the rows for λ are Φ_i = S with (S, −J*_i) [F − λI; H] = 0. For each λ the
S-parts are orthonormalised (basis B_λ); the candidate rows are the unit rows
φ_j = u_jᵀ B_λ, u_j the left singular vectors of B_λ L, with ‖φ_j L‖ = σ_j (the first
is the least ‖Φ_i L‖ over all unit rows of that λ). Rows are normalised ‖Φ_i‖ = 1,
so ‖Φ L‖_F² = Σ ‖Φ_i L‖². The fewest rows meeting the task (rank Φ = k,
rank [Φ; H] = rank [Φ; H; M]) are chosen, and among those the set of least ‖Φ L‖_F:
the k-subsets of the candidates are visited in increasing Σ σ² (best first), the first
meeting the task is taken.

Both designs are float-only: they are prepared with method "float" and work on one
:class:`RobustFloat` strategy bound to the plant (:mod:`._canonical`, :mod:`._jordan`).

References: seed 001 §6 (robust solution, Theorem 3), §5 (Jordan form); METHOD §2a,
§2b, §2d.
"""
from __future__ import annotations

from __future__ import annotations

import numpy as np
import sympy as sp

from ...numerics import rank_from_sv
from ..core import Condition, FloatArithmetic

__all__ = ["RobustFloat", "TASK_RTOL", "sv_text"]

#: Relative tolerance of the task decisions (sensitivity, rank Φ, reachability of z).
TASK_RTOL = 1e-8


def sv_text(sv, limit=6) -> str:
    """The first ``limit`` singular values, ``1.234e-05, …``."""
    sv = list(sv)
    txt = ", ".join(f"{s:.3e}" for s in sv[:limit])
    return txt + (", …" if len(sv) > limit else "")


class RobustFloat(FloatArithmetic):
    """The float arithmetic of the robust designs, bound to the plant and the task
    (:meth:`bind`): the Krylov rows and their growth, Φ of a member and the size of its
    rows without cancellation, reachability of z, and the certificate of every identity
    but the decoupling (absolute tolerance)."""

    @staticmethod
    def array(M) -> np.ndarray:
        """A numeric sympy matrix as floats, through 20-digit decimals (as these designs
        have always read the plant: :func:`~observer_cad.numerics.np_exact` rounds once,
        and a design must not move by an ulp)."""
        if isinstance(M, np.ndarray):
            return M
        M = sp.Matrix(M)
        if M.rows == 0 or M.cols == 0:
            return np.zeros(M.shape)
        return np.array(M.evalf(20), dtype=float)

    @staticmethod
    def svd_ascending(A):
        """Left singular vectors of A (s × q) as rows, with their singular values, ascending.

        When s > q the missing singular values are 0 (structural left null vectors).
        """
        s = A.shape[0]
        if s == 0:
            return np.zeros((0, 0)), np.zeros(0)
        if A.shape[1] == 0:
            return np.eye(s), np.zeros(s)
        U, sv, _ = np.linalg.svd(A, full_matrices=True)
        full = np.zeros(s)
        full[:sv.size] = sv
        order = np.argsort(full, kind="stable")
        return U[:, order].T, full[order]

    @staticmethod
    def orth_rows(V, rtol=None):
        """Orthonormal basis (rows) of the row space of V."""
        if V.shape[0] == 0:
            return V
        _, sv, Vt = np.linalg.svd(V, full_matrices=False)
        r = rank_from_sv(sv, V.shape, None, rtol).rank
        return Vt[:r].copy()

    def bind(self, st, D, L, M) -> None:
        """Float matrices of the plant and the task (parameters substituted)."""
        self.st = st
        self.F, self.G, self.H, self.C = (self.array(X) for X in (st.F, st.G, st.H, st.C))
        self.Fs, self.Hs = sp.Matrix(st.F), sp.Matrix(st.H)
        self.D, self.L = self.array(D), self.array(L)
        self.Ds, self.Ls = sp.Matrix(D), sp.Matrix(L)
        self.M = None if M is None else self.array(M)
        self.n, self.l = st.n, st.l
        self.tol = TASK_RTOL if self.rtol is None else max(TASK_RTOL, self.rtol)
        self.HF = [self.H]
        self.PH = np.eye(self.n) - np.linalg.pinv(self.H) @ self.H

    def hf(self, j):
        while len(self.HF) <= j:
            self.HF.append(self.HF[-1] @ self.F)
        return self.HF[j]

    def phis(self, V, k):
        """Φ of each member (rows of V = (R*, −J*_1, …)): an (s, k, n) array."""
        V = np.atleast_2d(V)
        l = self.l  # noqa: E741
        rows = [V[:, :l] @ self.H]
        for i in range(k - 1):
            rows.append(rows[-1] @ self.F + V[:, l * (i + 1):l * (i + 2)] @ self.H)
        return np.stack(rows, axis=1)

    def alpha(self, k):
        """α with abs(H Fᵏ) ≈ αᵏ abs(H): the mean growth of the Krylov rows (1 if undefined)."""
        g = float(np.linalg.norm(self.hf(k)))
        h = float(np.linalg.norm(self.H))
        return (g / h) ** (1.0 / k) if g > 0 and h > 0 and np.isfinite(g) else 1.0

    def ref(self, v, k):
        """Reference size of each row Φ_i of the member v: abs(H) α^(i−1) Σ_b abs(v_b) α^(−b).

        Φ_i = Σ_(b<i) v_b H F^(i−1−b) and abs(H Fʲ) ≈ abs(H) αʲ, so this is the size Φ_i
        would have without cancellation — counting every block of v, so that a member
        whose R* is rounding noise (a shifted smaller-k member, Φ_1 ≈ 0) is degenerate.
        """
        l = self.l  # noqa: E741
        a = self.alpha(k)
        mu = sum(float(np.linalg.norm(v[l * b:l * (b + 1)])) * a ** -b for b in range(k + 1))
        h = float(np.linalg.norm(self.H))
        return np.array([h * a ** i * mu for i in range(k)])

    def ref_max(self, k):
        """Largest ``ref`` over unit members (Cauchy–Schwarz), per row."""
        a = self.alpha(k)
        mu = float(np.sqrt(sum(a ** (-2 * b) for b in range(k + 1))))
        h = float(np.linalg.norm(self.H))
        return np.array([h * a ** i * mu for i in range(k)])

    def null_rows(self, Mat, k):
        """Orthonormal basis (rows) of the left null space of a Krylov-stacked matrix.

        Block b of rows (H F^(k−b)) is scaled by α^-(k−b), α the mean growth of H Fʲ, and
        columns are normalised, before the SVD decision (both leave the null space
        unchanged after mapping back); the members are then orthonormalised.
        """
        rs = np.repeat(self.alpha(k) ** -(k - np.arange(k + 1.0)), self.l)
        S = Mat * rs[:, None]
        cn = np.abs(S).max(axis=0)
        cn[cn == 0] = 1.0
        U, fr = self.left_null_evidence(S / cn[None, :])
        if U.shape[0] == 0:
            return U, fr
        return self.orth_rows(U * rs[None, :]), fr

    @staticmethod
    def reach(Phi, H, M, tol):
        """(ok, relative distance of M from rowspace [Φ; H], H_z, Q) with rows normalised."""
        B = np.vstack([Phi, H])
        sc = np.linalg.norm(B, axis=1)
        sc[sc == 0] = 1.0
        Bn = B / sc[:, None]
        X = M @ np.linalg.pinv(Bn, rcond=tol)
        dist = float(np.linalg.norm(M - X @ Bn) / max(np.linalg.norm(M), np.finfo(float).tiny))
        X = X / sc[None, :]
        k = Phi.shape[0]
        return dist <= tol, dist, X[:, :k], X[:, k:]

    def nonlinear_conditions(self, Phi, tol) -> list:
        """Argument substitution (METHOD §2c) for every column of C* = Φ C that is not ≈ 0.

        Reported, not enforced by the robust choice: a failure means the reduced model's
        nonlinear term cannot be written in x* and y.
        """
        out = []
        C, H = self.C, self.H
        if not C.shape[1]:
            return out
        A = self.array(self.st.A)
        for j in range(C.shape[1]):
            cs = Phi @ C[:, j]
            if np.linalg.norm(cs) <= tol * max(np.linalg.norm(Phi) * np.linalg.norm(C[:, j]), 1e-300):
                continue
            ok, dist, _, _ = self.reach(Phi, H, A[j:j + 1], tol)
            out.append(Condition(
                f"argument substitution for Ψ_{j + 1}: rank [Φ; H] = rank [Φ; H; A_{j + 1}]", ok,
                f"relative distance of A_{j + 1} from rowspace [Φ; H] = {dist:.2e} (tol {tol:.1e});"
                " not enforced by the robust choice", "METHOD §2c"))
        return out

    def certify_approximate(self, mats, mats_np, M):
        """Float certificate of every identity except the decoupling (absolute tolerance
        1e-9 times the largest product of norms the identities subtract): ``(certificate,
        tolerance)``."""
        scale = 1.0
        Phi = mats_np["Phi"]
        for X in (self.F, self.G, self.D, self.C):
            if X.size:
                scale = max(scale, float(np.linalg.norm(Phi) * np.linalg.norm(X)))
        scale = max(scale, float(np.linalg.norm(mats_np["J_star"]) * np.linalg.norm(self.H)))
        if "R_star" in mats_np:
            scale = max(scale, float(np.linalg.norm(mats_np["R_star"]) * np.linalg.norm(self.H)))
        if M is not None:
            scale = max(scale, float(np.linalg.norm(self.M)))
        tol = 1e-9 * scale
        n, sym = self.n, self.to_sympy
        plant = dict(F=sym(self.F), G=sym(self.G) if self.G.size else sp.zeros(n, self.G.shape[1]),
                     H=sym(self.H), C=sym(self.C) if self.C.size else sp.zeros(n, self.C.shape[1]),
                     D=sym(self.D) if self.D.size else sp.zeros(n, self.D.shape[1]),
                     L=sym(self.L))
        cert = self.certify(plant, mats, M=None if M is None else sym(self.M), decoupled=False,
                            tolerance=tol)
        return cert, tol
