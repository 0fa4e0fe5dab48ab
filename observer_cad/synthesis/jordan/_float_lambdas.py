"""The admissible λ of the float Jordan path (METHOD §2b), for large numeric linear models.

The admissible λ are those where the pencil

    P(λ) = A − λ B,    A = [L0 F; H],  B = [L0; 0]    (r × n)

loses row rank. They are computed, not guessed:

* r > n: every λ (a left null vector exists structurally): generic solvability;
* σ_r(P(λ)) negligible at several random λ: the pencil is singular (rank-deficient for
  every λ): generic solvability;
* r = n: the finite generalised eigenvalues of (A, B) (QZ, ``scipy.linalg.eig``);
* r < n: P(λ) loses row rank iff P(λ)ᵀ loses column rank; every such λ is an eigenvalue
  of the square pencil (A − λB) Z for any n × r matrix Z, so the eigenvalues common to two
  random orthonormal Z are the candidates.

Every candidate (real up to a tolerance, finite: abs(β) of the normalised homogeneous pair
not negligible) is refined by the two-sided Rayleigh step λ ← λ + σ/(uᵀ B v) (u, v the
singular vectors of σ_min(P(λ))) and kept only when σ_min(P(λ)) / σ_1(P(λ)) is below the
tolerance; the evidence gives that ratio and the gap to the next singular value.

References: seed 002 eq. (2.5); METHOD §2b.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from ...numerics import SingleThreadBLAS, np_exact

__all__ = ["admissible_lambdas_float", "DEFAULT_RTOL", "float_pencil", "row_singular_values",
           "relative_sigma"]


#: default relative tolerance on σ_min(P(λ)) / σ_1(P(λ)) for "P(λ) loses row rank"
DEFAULT_RTOL = 1e-9


#: candidates with |β| below this (normalised homogeneous eigenvalue (α, β)) are infinite
_INF_BETA = 1e-8


# ---------------------------------------------------------------- admissible λ
def float_pencil(A, B, lam):
    return A - lam * B


def row_singular_values(A, B, lam):
    """Singular values of P(λ) (descending, min(r, n) of them) and the singular vectors
    (u, v) belonging to σ_min (the smallest of the min(r, n) values)."""
    P = float_pencil(A, B, lam)
    U, s, Vt = np.linalg.svd(P, full_matrices=False)
    return s, U[:, -1], Vt[-1, :]


def relative_sigma(s):
    return float(s[-1] / s[0]) if s.size and s[0] > 0 else 0.0


def _refine(A, B, lam, steps: int = 4):
    """Two-sided Rayleigh steps λ ← λ + σ/(uᵀ B v); keeps the best λ seen."""
    s, u, v = row_singular_values(A, B, lam)
    best = (relative_sigma(s), lam, s)
    for _ in range(steps):
        d = float(u @ B @ v)
        if d == 0.0 or not np.isfinite(d):
            break
        # uᵀ (A − λ B) = σ vᵀ  ⇒  uᵀ(A − (λ + σ/d) B) v = 0 to first order
        lam2 = lam + float(s[-1]) / d
        s2, u2, v2 = row_singular_values(A, B, lam2)
        if relative_sigma(s2) < best[0]:
            best = (relative_sigma(s2), lam2, s2)
            lam, s, u, v = lam2, s2, u2, v2
        else:
            # the sign of σ is arbitrary: try the other direction once
            lam3 = lam - float(s[-1]) / d
            s3, u3, v3 = row_singular_values(A, B, lam3)
            if relative_sigma(s3) < best[0]:
                best = (relative_sigma(s3), lam3, s3)
                lam, s, u, v = lam3, s3, u3, v3
            else:
                break
    return best[1], best[2]


def _finite_real_eigs(a, b, imag_tol):
    """Finite, (nearly) real generalised eigenvalues of the square pencil (a, b).

    Returns (real values, number of complex ones, number of infinite ones)."""
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    a = a / na if na else a
    b = b / nb if nb else b
    import scipy.linalg  # here, not at module level: 0.3-0.5 s of imports the package need not pay
    w = scipy.linalg.eig(a, b, right=False, homogeneous_eigvals=True)
    alpha, beta = w[0], w[1]
    scale = np.sqrt(np.abs(alpha) ** 2 + np.abs(beta) ** 2)
    scale[scale == 0] = 1.0
    alpha, beta = alpha / scale, beta / scale
    real, ncomplex, ninf = [], 0, 0
    for al, be in zip(alpha, beta):
        if abs(be) <= _INF_BETA:
            ninf += 1
            continue
        lam = complex(al / be) * (na / nb if na and nb else 1.0)  # undo the normalisation
        if abs(lam.imag) <= imag_tol * (1.0 + abs(lam.real)):
            real.append(lam.real)
        else:
            ncomplex += 1
    return real, ncomplex, ninf


def _cluster(vals, tol):
    vals = sorted(vals)
    out = []
    for v in vals:
        if out and abs(v - out[-1][-1]) <= tol * (1.0 + abs(v)):
            out[-1].append(v)
        else:
            out.append([v])
    return [float(np.mean(c)) for c in out]


def admissible_lambdas_float(F, H, L0, *, rtol: float | None = None):
    """``(generic, values, evidence)``: the real λ where [L0(F − λI); H] loses row rank.

    Parameters
    ----------
    F, H, L0 : array-like (or numeric sympy matrices)
        n × n, l × n and m0 × n.
    rtol : float, optional
        P(λ) loses row rank when σ_min(P(λ)) ≤ rtol · σ_1(P(λ)) (default
        :data:`DEFAULT_RTOL`).

    Returns
    -------
    generic : bool
        Every λ is admissible (r > n, or the pencil is singular).
    values : list of float
        The admissible real λ, ascending (empty when generic).
    evidence : str
        How it was decided: dimensions, counts of complex / infinite / rejected
        candidates, and for every value σ_min/σ_1 and the gap σ_(min−1)/σ_min.
    """
    F, H, L0 = (np.atleast_2d(np.asarray(np_exact(sp.Matrix(M)) if isinstance(M, sp.MatrixBase)
                                         else M, dtype=float)) for M in (F, H, L0))
    n = F.shape[0]
    H = H.reshape(-1, n) if H.size else np.zeros((0, n))
    L0 = L0.reshape(-1, n) if L0.size else np.zeros((0, n))
    A = np.vstack([L0 @ F, H])
    B = np.vstack([L0, np.zeros((H.shape[0], n))])
    r = A.shape[0]
    tol = DEFAULT_RTOL if rtol is None else float(rtol)
    if r > n:
        return True, [], (f"[L0(F − λI); H] has {r} rows > {n} columns: a left null vector"
                          " exists for every λ (generic solvability)")
    if r == 0:
        return False, [], "[L0(F − λI); H] has no rows: no admissible λ"
    with SingleThreadBLAS():
        # singular pencil: rank deficient at every λ (checked at random λ)
        na, nb = np.linalg.norm(A, 2), np.linalg.norm(B, 2)
        scale = na / nb if nb > 0 else 1.0
        rng = np.random.default_rng(20240611)
        probes = list(scale * rng.standard_normal(3))
        rels = [relative_sigma(row_singular_values(A, B, lam)[0]) for lam in probes]
        if max(rels) <= tol:
            return True, [], (f"σ_min/σ_1 of [L0(F − λI); H] ({r}×{n}) is at most"
                              f" {max(rels):.1e} ≤ tol {tol:.0e} at {len(probes)} random λ:"
                              " singular pencil, every λ is admissible (generic solvability)")
        imag_tol = 1e-6
        if r == n:
            cands, ncx, ninf = _finite_real_eigs(A, B, imag_tol)
            how = f"finite real generalised eigenvalues of the square pencil ({r}×{n}, QZ)"
            nraw = len(cands)
        else:
            sets = []
            ncx = ninf = 0
            for seed in (1, 2):
                g = np.random.default_rng(seed).standard_normal((n, r))
                Z, _ = np.linalg.qr(g)
                c, nc, ni = _finite_real_eigs(A @ Z, B @ Z, imag_tol)
                sets.append(c)
                ncx, ninf = max(ncx, nc), max(ninf, ni)
            match = 1e-4
            cands = [v for v in sets[0]
                     if any(abs(v - w) <= match * (1.0 + abs(v)) for w in sets[1])]
            nraw = len(cands)
            how = (f"wide pencil ({r}×{n}): real eigenvalues common to (A − λB) Z for two random"
                   f" orthonormal Z ({n}×{r}) ({len(sets[0])} and {len(sets[1])} real"
                   f" candidates, {nraw} common)")
        cands = _cluster(cands, 1e-6)
        values, ev, rejected = [], [], []
        for c in cands:
            lam, s = _refine(A, B, c)
            rel = relative_sigma(s)
            gap = float(s[-2] / s[-1]) if s.size > 1 and s[-1] > 0 else float("inf")
            txt = (f"λ = {lam:.12g}: σ_min/σ_1 = {rel:.2e}, gap σ_{s.size - 1}/σ_{s.size} ="
                   f" {'inf' if gap == float('inf') else f'{gap:.2e}'}")
            if rel <= tol:
                values.append(lam)
                ev.append(txt)
            else:
                rejected.append(txt)
        order = np.argsort(values)
        values = [float(values[i]) for i in order]
        ev = [ev[i] for i in order]
        values2, ev2 = [], []
        for v, e in zip(values, ev):  # refinement may merge neighbours
            if values2 and abs(v - values2[-1]) <= 1e-9 * (1.0 + abs(v)):
                continue
            values2.append(v)
            ev2.append(e)
        evidence = (f"{how}; {ncx} complex and {ninf} infinite eigenvalue(s) not usable;"
                    f" tol σ_min/σ_1 ≤ {tol:.0e}; probes at random λ: σ_min/σ_1 ≥"
                    f" {min(rels):.1e} (regular pencil); admissible: "
                    + ("; ".join(ev2) if ev2 else "none real")
                    + (f"; rejected candidates: {'; '.join(rejected[:6])}" if rejected else ""))
    return False, values2, evidence
