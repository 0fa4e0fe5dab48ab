"""Which λ can a Jordan model of m rows have? The chain polynomials (METHOD §2b): the
monic p of degree m with M p(F) ∈ rowspace [H; …; H Fᵐ] (and r(s) L = 0 for decoupled
inputs), whose members with m distinct real stable roots are exactly the λ sets of the
m-row models of a linear plant.

References: METHOD §2b; seed 002 §2.
"""
from __future__ import annotations

import itertools

import sympy as sp

from ....numerics import left_null_space, solve_left
from ...core import is_stable
from ._clock import UNLIMITED
from ._families import (ChainOrder, MAX_SUBSETS, family_order, independent_vectors,
                        pinned_member)

__all__ = ["chain_system", "chain_order", "spread_lambdas"]


def chain_system(F, H, M, m: int, L=None):
    """The linear system X A = B of the order-m chain polynomials: X = (a_0, …, a_{m−1},
    b_0, …, b_m), p(λ) = λᵐ − Σ a_i λⁱ, M p(F) = Σ b_i H Fⁱ (n columns) and, for
    decoupled inputs L, the quotient r(s) = Σ_j r_j sʲ of b(s) H − p(s) M = r(s)(sI − F)
    with r_j L = 0 (q columns for each j = 0, …, m − 1):
    Σ_{i>j} (a_i M + b_i H) F^{i−j−1} L = M F^{m−j−1} L (a_m = 0).

    Several rows of M share p (the polynomial whose roots are the model's distinct λ) and
    have their own b: X = (a, b⁽¹⁾, …, b⁽ʳ⁾), one column block per row."""
    parts = [_row_system(F, H, M[j, :], m, L) for j in range(M.rows)]
    if len(parts) == 1:
        Aa, Ab, B = parts[0]
        return sp.Matrix.vstack(Aa, Ab), B
    cols = [P[0].cols for P in parts]
    Aa = sp.Matrix.hstack(*[P[0] for P in parts])
    blocks = []
    for j, P in enumerate(parts):
        blocks.append(sp.Matrix.hstack(*[P[1] if i == j else sp.zeros(P[1].rows, c)
                                         for i, c in enumerate(cols)]))
    return sp.Matrix.vstack(Aa, *blocks), sp.Matrix.hstack(*[P[2] for P in parts])


def _row_system(F, H, M, m, L):
    """For one row M: the rows of X A = B for a (m rows) and for b ((m + 1) l rows), and B."""
    MF, HF = [M], [H]
    for _ in range(m):
        MF.append(MF[-1] * F)
        HF.append(HF[-1] * F)
    Aa, Ab = sp.Matrix.vstack(*MF[:m]), sp.Matrix.vstack(*HF)
    B = MF[m]
    if L is not None and L.cols:
        ML = [X * L for X in MF]
        HL = [X * L for X in HF]
        zero = sp.zeros(1, L.cols)
        ba, bb, rhs = [], [], []
        for j in range(m):
            ba.append(sp.Matrix.vstack(*[ML[i - j - 1] if i > j else zero for i in range(m)]))
            bb.append(sp.Matrix.vstack(*[HL[i - j - 1] if i > j else sp.zeros(H.rows, L.cols)
                                         for i in range(m + 1)]))
            rhs.append(ML[m - j - 1])
        Aa, Ab = sp.Matrix.hstack(Aa, *ba), sp.Matrix.hstack(Ab, *bb)
        B = sp.Matrix.hstack(B, *rhs)
    return Aa, Ab, B


def chain_order(F, H, M, m: int, lam, time: str, tries, L=None, defaults=None,
                clock=UNLIMITED) -> ChainOrder:
    """The affine family of monic p (degree m) with M p(F) ∈ W_m — and, when ``L`` has
    columns (decoupled inputs), with the quotient r(s) of b(s) H − p(s) M = r(s)(sI − F)
    satisfying r(s) L = 0 — and a member with m distinct real stable roots.

    Every Jordan design of m rows with λ_1, …, λ_m (Φ_i L = 0 when decoupled) gives
    p = Π (s − λ_i) here (r(s) = −Σ c_i Φ_i Π_{j≠i} (s − λ_j)); conversely a member with m
    distinct roots gives the rows Φ_i = r(λ_i) (Φ_i (F − λ_i I) = −b(λ_i) H, Φ_i L = 0) and
    M = b_m H − Σ Φ_i / p'(λ_i): a linear model of order m with those λ (METHOD §2b).

    Several rows of M: p has the *distinct* λ of the model as roots (each row of M is a
    combination of its rows, so each satisfies its own chain condition with that p). A
    model of k rows has at most k distinct λ, so "impossible" at order m still rules out
    every model of ≤ m rows; a member gives the λ, with up to one row per row of M each.

    With symbolic parameters in F, H, M, L the ranks are generic (``conditions``) and a
    member is accepted only when it splits into linear factors over QQ(parameters), with
    distinct roots that are stable at the ``defaults`` (symbol -> value): see
    :func:`_symbolic_chain`.

    ``clock`` (:class:`ProofClock`) is passed to :func:`family_order`."""
    F, H, M = (sp.Matrix(X) for X in (F, H, M))
    L = sp.Matrix(L) if L is not None else None
    dec = L is not None and L.cols > 0
    A, B = chain_system(F, H, M, m, L)
    if A.free_symbols | B.free_symbols:
        # (a parameter without a default has no nominal value: it stays a symbol)
        known = {p: v for p, v in (defaults or {}).items() if v is not None}
        return _symbolic_chain(A, B, m, lam, tries, dec, known, time)
    X0 = solve_left(A, B)
    if X0 is None:
        return ChainOrder(m, "empty", -1, None, (), f"m = {m}: M F^{m} ∉ rowspace [M, …,"
                          f" M F^{m - 1}; H, …, H F^{m}]" + (" with r(s) L = 0" if dec else "")
                          + f": no model of order {m}")
    a0 = [X0[0, i] for i in range(m)]
    basis, _ = left_null_space(A)
    dirs = independent_vectors([[v[0, i] for i in range(m)] for v in basis])
    return family_order(m, a0, dirs, lam, time, tries, clock)


def _symbolic_chain(A, B, m, lam, tries, dec, defaults, time) -> ChainOrder:
    """:func:`chain_order` over QQ(parameters): "empty" (generically), or the unique member
    / a member through ``d`` of the ``tries`` whose numerator splits into distinct linear
    factors in λ, each root stable at the defaults; otherwise "symbolic" (undecided)."""
    X0 = solve_left(A, B)
    basis, rk = left_null_space(A)
    conds = frozenset(rk.conditions)
    where = (f" (for parameters with {', '.join(sorted(str(c.lhs) for c in conds))} nonzero)"
             if conds else "")
    if X0 is None:
        return ChainOrder(m, "empty", -1, None, (), f"m = {m}: M F^{m} ∉ rowspace [M, …,"
                          f" M F^{m - 1}; H, …, H F^{m}]" + (" with r(s) L = 0" if dec else "")
                          + f"{where}: no model of order {m}", conds)
    a0 = [sp.cancel(X0[0, i]) for i in range(m)]
    dirs = independent_vectors([[sp.cancel(v[0, i]) for i in range(m)] for v in basis])
    d = len(dirs)

    def poly(a):
        return sp.expand(lam ** m - sum(a[i] * lam ** i for i in range(m)))

    def split(p):
        num, _ = sp.fraction(sp.cancel(sp.together(p)))
        _, facs = sp.factor_list(num, lam)
        rts = []
        for f, mult in facs:
            deg = sp.degree(f, lam)
            if deg == 0:
                continue
            if deg > 1 or mult > 1:
                return ()
            c1, c0 = sp.Poly(f, lam).all_coeffs()
            rts.append(sp.cancel(-c0 / c1))
        if len(rts) != m or any(sp.cancel(r - q) == 0 for r, q in itertools.combinations(rts, 2)):
            return ()
        nominal = [r.subs(defaults) for r in rts]
        if any(v.free_symbols or not v.is_real or not is_stable(v, time) for v in nominal):
            return ()  # no defaults, or not stable at them: not used
        return tuple(rts)

    if d >= m:
        return ChainOrder(m, "free", d, None, (), f"m = {m}: every monic p of degree {m}"
                          f"{where}", conds)
    cands = [poly(a0)] if d == 0 else []
    for subset in itertools.islice(itertools.combinations(tries, d), MAX_SUBSETS) if d else ():
        a = pinned_member(a0, dirs, subset, poly(a0), lam)
        if a is not None:
            cands.append(poly([sp.cancel(v) for v in a]))
    for p in cands:
        rts = split(p)
        if rts:
            return ChainOrder(m, "symbolic", d, p, rts,
                              f"m = {m}: " + ("one p" if d == 0 else f"a {d}-parameter family"
                                              " of p; a member") + f"{where}: p(λ) ="
                              f" {sp.factor(p)}, roots {', '.join(map(str, rts))} (stable at the"
                              " parameter defaults)", conds)
    return ChainOrder(m, "symbolic", d, cands[0] if d == 0 else None, (),
                      f"m = {m}: " + (f"one p(λ) = {sp.factor(cands[0])}" if d == 0 else
                                      f"a {d}-parameter family of p") + f"{where}; no member"
                      " splits into distinct linear factors over the parameters with roots"
                      " stable at their defaults (undecided for symbolic parameters)", conds)


def spread_lambdas(time: str) -> list:
    """Stable λ over several orders of magnitude, tried (after the defaults) to pin a member
    of a family of chain polynomials whose other roots must come out stable."""
    if time == "continuous":
        return [sp.Rational(v) for v in ("-1/10", "-1/3", "-1/2", "-3/2", "-5/2", "-7", "-10",
                                         "-30", "-100")]
    return [sp.Rational(v) for v in ("0", "3/4", "9/10", "-1/2", "-1/4", "-3/4", "1/10",
                                     "-9/10", "99/100")]
