"""The Krylov matrices of the identification canonical form (METHOD §2a) and their left
null spaces: W⁽ᵏ⁾ = [H Fᵏ; …; H] and the block Toeplitz L⁽ᵏ⁾ (:func:`krylov_blocks`),
the members of the left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾) for k = 1, 2, … grown incrementally
(:func:`krylov_null_spaces`), and the rows Φ of a member (:func:`member_to_phi`).

A member v = (R*, −J*_1, …, −J*_k) gives Φ_1 = R* H, Φ_{i+1} = Φ_i F − J*_i H and
Φ_k F = J*_k H; v L⁽ᵏ⁾ = (Φ_1 L, …, Φ_k L), so v annihilates (W⁽ᵏ⁾ L⁽ᵏ⁾) exactly when
Φ L = 0 (seed 000, eqs. (3.2)-(3.3); seed 001 §2).
"""
from __future__ import annotations

import itertools

import sympy as sp
from sympy.polys.matrices import DomainMatrix

from ...numerics import GrowingLeftNull, as_rational, from_rational, left_null_echelon

__all__ = ["krylov_blocks", "krylov_null_spaces", "member_to_phi", "shift_matrix"]


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
    """The k×k shift matrix: ones on the superdiagonal (the F* of the canonical form)."""
    Fs = sp.zeros(k, k)
    for i in range(k - 1):
        Fs[i, i + 1] = 1
    return Fs
