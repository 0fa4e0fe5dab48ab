"""Exterior algebra for the row decisions (METHOD §2b): signs of permutations, the
2 × 2 minors of two polynomial rows (a Plücker vector) and the wedge form on Λ²R⁴.
"""
from __future__ import annotations

import itertools

import sympy as sp
from sympy.polys.matrices import DomainMatrix

__all__ = ["perm_sign", "pair_minors", "plucker"]


def plucker(G, lam):
    """(π, Ω): the primitive Plücker vector π(λ) (2 × 2 minors, over the pairs of
    {0, 1, 2, 3}) of the plane spanned by the two rows of ``G`` (polynomials in λ), or None
    when they are dependent for λ generic; and Ω with p ∧ p' = pᵀ Ω p'
    (Σ_S ε_S p_{S^c} p'_S, ε_S the sign of the permutation S S^c)."""
    pairs = list(itertools.combinations(range(4), 2))
    comp = {S: tuple(sorted(set(range(4)) - set(S))) for S in pairs}
    Om = sp.zeros(6, 6)
    for i, S in enumerate(pairs):
        Om[pairs.index(comp[S]), i] = perm_sign(S + comp[S])
    return pair_minors(G, lam), Om


def pair_minors(G, lam):
    """The primitive vector of the 2 × 2 minors of the two rows of ``G`` (polynomials in
    λ), over the pairs of columns in lexicographic order, or None when the rows are
    dependent for λ generic."""
    minors = []
    for S in itertools.combinations(range(G.cols), 2):
        dm = DomainMatrix.from_Matrix(G[:, list(S)]).convert_to(sp.QQ[lam])
        minors.append(sp.QQ[lam].to_sympy(dm.det()))
    g = sp.gcd_list(minors)
    return None if g == 0 else [sp.cancel(e / g) for e in minors]


def perm_sign(seq) -> int:
    """The sign of the permutation ``seq`` of distinct integers."""
    return (-1) ** sum(1 for i in range(len(seq)) for j in range(i + 1, len(seq))
                       if seq[i] > seq[j])
