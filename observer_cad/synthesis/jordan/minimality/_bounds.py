"""Lower bounds on the order of *any* reduced model, proven exactly (METHOD §2b).

The Jordan form searches rows Φ_i with Φ_i (F − λ_i I) = J*_i H over real λ_i; when every
λ is admissible the λ can only be searched over finite lists. A lower bound on the
order of every reduced model — whatever its F*: complex, repeated, unstable eigenvalues
included — proves a Jordan design minimal when it reaches the bound.

**Estimation** (virtual sensors, interval observers; z = M x). A model of order k is a
row space V (dim V = k) with V F ⊆ V + rowspace H (the rows of Φ F = F* Φ + J* H) and
M ∈ V + rowspace H (M = H_z Φ + Q H). Write W_j = rowspace [H; H F; …; H Fʲ]. Then

* **subspace bound**: M Fʲ ∈ V + W_j for every j (induction: M Fʲ⁺¹ ∈ V F + W_j F ⊆
  V + W_{j+1}), so k ≥ rank [M; M F; …; M Fʲ; H; …; H Fʲ] − rank [H; …; H Fʲ] for every j;
* **chain bound** (one row M): the chain Φ_1 = M − Q_0 H, Φ_{i+1} = Φ_i F − J_i H stays in
  V, so Φ_1, …, Φ_{k+1} are dependent; at the first dependence Φ_{m+1} = Σ a_i Φ_i with
  m ≤ k, which reads M p(F) ∈ W_m for a monic p of degree m, i.e.
  M Fᵐ ∈ rowspace [M; …; M Fᵐ⁻¹; H; …; H Fᵐ]. So k ≥ the least such m. Conversely that
  chain *is* a model of order m (F* the companion matrix of p), so for a linear model
  without decoupled inputs this bound is the exact least order over all F*.

Decoupling (Φ L = 0), the nonlinear argument substitution and "λ real and stable" only
remove models, so both bounds stay valid lower bounds for them.

**Residual generators** (diagnostic observers). A model of order k with Φ L = 0 whose
residual r = R* y − H* x* responds to every fault (H*(sI − F*)⁻¹ Φ D has no zero column)
has an observable part for (F*, H*) of order k' ≤ k with the same transfer; an observable
single-output pair is similar to the observer canonical form, whose first row x*_1 = R* y
is measured, so its feedback term moves into J* and the model is the identification
canonical form (F* the shift matrix) of :mod:`._canonical` at order k', with Φ D ≠ 0
column by column. Canonical members nest (a member at k' extends to k' + 1 by a zero row),
so the least k' whose null space of (W⁽ᵏ'⁾ L⁽ᵏ'⁾) holds a member seeing every fault bounds
the order of every residual generator that responds to every fault.

With symbolic parameters the ranks are generic: the bound holds where the pivots listed
in ``conditions`` are nonzero.

References: seed 000 §2-3 (the canonical form); seed 002 §2 (the Jordan form); METHOD §2a-b.
"""
from __future__ import annotations

import dataclasses
import itertools

import sympy as sp

from ....numerics import exact_rank, left_null_echelon
from ...canonical import krylov_blocks, member_to_phi
from .._lambda_search import q_rows_possible
from ._chains import chain_order
from ._clock import UNLIMITED

__all__ = ["OrderBound", "estimation_order_bound", "residual_order_bound",
           "nonlinear_jordan_bound", "NONLINEAR_SUBSETS_MAX_TERMS"]


@dataclasses.dataclass(frozen=True)
class OrderBound:
    """Every reduced model of the kind has at least ``k`` states (any F*).

    ``evidence``: the ranks it rests on; ``conditions``: the parameter pivots (``Ne(f, 0)``)
    the generic ranks need (empty for numeric models); ``exact``: the bound is the least
    order over all F* itself (not only a bound)."""

    k: int
    evidence: str
    conditions: frozenset = frozenset()
    exact: bool = False


def _rank(blocks) -> tuple:
    rows = [B for B in blocks if B.rows]
    if not rows:
        return 0, frozenset()
    r = exact_rank(sp.Matrix.vstack(*rows))
    return r.rank, r.conditions


def estimation_order_bound(F, H, M, *, decoupled: bool = False, linear: bool = True) -> OrderBound:
    """The lower bound for a model of z = M x (M not in rowspace H): the larger of the
    subspace bound (any number of rows of M) and the chain bound (one row; never below the
    subspace one). ``exact`` when M is one row of a linear model without decoupled inputs."""
    F, H, M = (sp.Matrix(X) for X in (F, H, M))
    n = F.rows
    conds: set = set()
    HF, MF = [H], [M]
    best, best_j, prev = 0, 0, None
    for j in range(n + 1):  # W_j grows at most n times
        if j:
            HF.append(HF[-1] * F)
            MF.append(MF[-1] * F)
        rw, cw = _rank(HF)
        rmw, cmw = _rank(MF + HF)
        conds |= cw | cmw
        if rmw - rw > best:
            best, best_j = rmw - rw, j
        if (rw, rmw) == prev:  # both spaces stopped growing: so do all later ones
            break
        prev = (rw, rmw)
    ev = (f"subspace bound: rank [M, …, M F^{best_j}; H, …, H F^{best_j}] − rank [H, …,"
          f" H F^{best_j}] = {best}")
    exact = False
    if M.rows == 1:
        m = _chain_order(F, H, M, conds)
        ev += (f"; chain bound: M F^{m} ∈ rowspace [M, …, M F^{m - 1}; H, …, H F^{m}] first"
               f" at m = {m} (M p(F) ∈ W_m for a monic p of degree {m})")
        best, exact = max(best, m), not decoupled and linear
    return OrderBound(best, ev, frozenset(conds), exact)


#: nonlinear terms beyond which :func:`nonlinear_jordan_bound` is not tried (2^t subsets)
NONLINEAR_SUBSETS_MAX_TERMS = 4


def nonlinear_jordan_bound(F, H, L, M, C, A_rows, k: int, lam, time: str, tries,
                           defaults=None, clock=UNLIMITED) -> OrderBound | None:
    """A lower bound on the rows of a Jordan model of z = M x in a model with nonlinear
    terms φ_j(A_j x) entering through the columns C_j (numeric F, H, L, M, C, A).

    Argument substitution: a term the rows see (Φ C_j ≠ 0) needs A_j ∈ rowspace [Φ; H].
    So a model whose rows see the terms S and no other is a linear Jordan model of
    z_S = [M; A_j (j ∈ S)] decoupled from L_S = [L, C_j (j ∉ S)] (seeing the terms of S is
    relaxed away, which only adds models). For each S the bound is the larger of
    rank [M_S; H] − rank H (+ 1 when that many rows are impossible for every real stable λ,
    :func:`q_rows_possible`) and 1 + the largest order m < k whose joint chain polynomials with
    r(s) L_S = 0 have no member with m distinct real stable roots (members nest, so the
    orders ruled out are 1 … m). The bound is the least over all S; None when some S
    gives less than k (nothing proven), when there are more than
    :data:`NONLINEAR_SUBSETS_MAX_TERMS` terms, or when parameters are symbolic. ``clock``
    (:class:`ProofClock`) is checked before each subset and passed to the chain orders.
    """
    t = len(A_rows)
    if not t or t > NONLINEAR_SUBSETS_MAX_TERMS:
        return None
    if set().union(*(X.free_symbols for X in (F, H, L, M, C) + tuple(A_rows))):
        return None
    rH = exact_rank(H).rank if H.rows else 0
    least, parts = None, []
    for size in range(t + 1):
        for S in itertools.combinations(range(t), size):
            clock.check()
            MS = sp.Matrix.vstack(M, *[A_rows[j] for j in S])
            LS = sp.Matrix.hstack(L, *[C[:, j] for j in range(t) if j not in S])
            q = exact_rank(sp.Matrix.vstack(MS, H)).rank - rH
            bound, why = q, f"q = {q}"
            if q < k:
                sr = q_rows_possible(F, H, LS, MS, lam, time)
                if sr.analysed and not sr.possible:
                    bound, why = q + 1, f"{q} rows impossible for every λ"
            if bound < k:
                for m in range(1, k):
                    c = chain_order(F, H, MS, m, lam, time, tries, LS if LS.cols else None,
                                    defaults, clock)
                    if not c.impossible:
                        break
                    if m + 1 > bound:
                        bound, why = m + 1, f"chain orders ≤ {m} ruled out"
            name = "{" + ", ".join(str(j + 1) for j in S) + "}"
            parts.append(f"S = {name}: ≥ {bound} ({why})")
            if bound < k:  # no proof at k (the least over every S is below k)
                return None
            least = bound if least is None else min(least, bound)
    return OrderBound(least, _nonlinear_evidence(parts))


def _nonlinear_evidence(parts) -> str:
    return ("nonlinear terms: rows seeing the terms S are a linear model of [M; A_j, j ∈ S]"
            " decoupled from C_j, j ∉ S; " + "; ".join(parts))


def _chain_order(F, H, M, conds: set) -> int:
    """The least m ≥ 1 with M Fᵐ ∈ rowspace [M, …, M Fᵐ⁻¹; H, …, H Fᵐ] (m ≤ n by
    Cayley–Hamilton)."""
    MF, HF = [M], [H]
    m = 0
    while True:
        m += 1
        MF.append(MF[-1] * F)
        HF.append(HF[-1] * F)
        r0, c0 = _rank(MF[:m] + HF)
        r1, c1 = _rank(MF + HF)
        conds |= c0 | c1
        if r1 == r0:
            return m


def residual_order_bound(F, H, L, D, k_max: int) -> OrderBound:
    """The least k' ≤ ``k_max`` at which a residual generator decoupled from L and
    responding to every column of D exists (canonical form, any F*); ``k_max + 1`` when
    none exists up to ``k_max`` (every such generator has more states)."""
    F, H, L, D = (sp.Matrix(X) for X in (F, H, L, D))
    conds: set = set()
    tried = []
    for k in range(1, k_max + 1):
        W, Lk = krylov_blocks(F, H, L, k)
        members, rk = left_null_echelon(sp.Matrix.hstack(W, Lk) if Lk.cols else W)
        conds |= rk.conditions
        blind = _blind_columns(members, F, H, D, k)
        if members and not blind:
            return OrderBound(k, f"canonical form: the null space of (W⁽{k}⁾ L⁽{k}⁾) has a member"
                              " seeing every fault" + _tried(tried), frozenset(conds))
        tried.append(f"k = {k}: " + (f"rank (W L) = {rk.rank} = l(k+1), no member" if not members
                                     else f"{len(members)} member(s), none sees fault column(s)"
                                     f" {', '.join(str(c + 1) for c in blind)}"))
    return OrderBound(k_max + 1, "canonical form: " + "; ".join(tried), frozenset(conds))


def _tried(tried) -> str:
    return f" (below it: {'; '.join(tried)})" if tried else ""


def _blind_columns(members, F, H, D, k) -> list:
    """The fault columns c with Φ(v) D_c = 0 for every member v (a generic combination of
    the members sees every other column: a finite union of proper subspaces is not the
    whole space)."""
    if not members:
        return list(range(D.cols))
    seen = set()
    for v in members:
        _, _, Phi = member_to_phi(v, F, H, k)
        PD = (Phi * D).applyfunc(sp.cancel)
        seen |= {c for c in range(D.cols) if any(e != 0 for e in PD[:, c])}
        if len(seen) == D.cols:
            break
    return [c for c in range(D.cols) if c not in seen]
