"""The row spaces behind a diagnosability answer (the module docstring of
:mod:`observer_cad.analysis._diagnosability`): the spaces A_i, B_j grown lazily for one
(F, H, L) (:class:`ReachSpaces`), the smallest detecting order of each fault column
(:func:`detecting_orders`), and one model's questions — a fault with a set of inputs
decoupled — with the nonlinear terms' witness search (:class:`DiagnosisQuestions`).

Every computation goes through one arithmetic strategy
(:func:`~observer_cad.synthesis.core.arithmetic`): rational, exact over QQ(parameters)
with recorded conditions, or float with evidence.
"""
from __future__ import annotations

import dataclasses
import itertools

import sympy as sp

from ..model import PlantModel, Structure
from ..numerics import exact_rank_value, left_null_echelon
from ..synthesis import krylov_blocks, member_to_phi
from ..synthesis import substitute_arguments
from ..synthesis import observer_symbols, output_symbols
from ..synthesis.core import arithmetic
from ._orders import OrderSpaces, Products


def _feedthrough_columns(st: Structure, names) -> sp.ImmutableMatrix:
    """Columns of Dy or Ly for the named faults / disturbances, in that order."""
    m = st.model
    cols = [st.Dy[:, m.faults.index(s)] if s in m.faults else st.Ly[:, m.disturbances.index(s)]
            for s in names]
    return sp.ImmutableMatrix(sp.Matrix.hstack(*cols)) if cols else \
        sp.ImmutableMatrix(sp.zeros(st.l, 0))

__all__ = ["ReachSpaces", "detecting_orders", "DiagnosisQuestions"]


class ReachSpaces:
    """The spaces A_i, B_j of the module docstring for one (F, H, L), grown lazily:
    a question stops growing them as soon as A_i ∩ B_j sees its fault."""

    def __init__(self, ops, F, H, L):
        """``F``, ``H``, ``L`` as the backend ``ops`` holds them."""
        self.ops = ops
        self.F, self.H, self.L = F, H, L
        self.n = F.shape[0]
        self.p = L.shape[1]
        self.conds: set = set()
        self.A: list = []
        self.K: list = [ops.eye(self.n)]  # B_j = {φ : φ K_j = 0}
        self.a_done = self.b_done = False
        self._Y = H
        self._cache: dict = {}

    # -- growth (each space is a function of the previous one: a repeat ends it)
    def _step_a(self):
        ops, F, H, L = self.ops, self.F, self.H, self.L
        Y = self._Y
        X = ops.left_null(ops.mul(Y, L), self.conds) if self.p else ops.eye(Y.shape[0])
        Ai = ops.basis(ops.mul(X, Y), self.conds) if X.shape[0] else ops.zeros(0, self.n)
        if self.A and Ai.shape[0] == self.A[-1].shape[0]:
            self.a_done = True
            return
        self.A.append(Ai)
        self._Y = ops.vstack(ops.mul(Ai, F), H)

    def _step_b(self):
        # B_{j+1} = {φ : φ L = 0, φ F ∈ B_j + rowsp H} is the annihilator of
        # K_{j+1} = Im L + F (K_j ∩ ker H) when B_j is that of K_j (K_0 = Rⁿ, B_0 = {0})
        ops, F, H, L, n = self.ops, self.F, self.H, self.L, self.n
        K = self.K[-1]
        if K.shape[1]:
            Y = ops.left_null(ops.mul(H, K).transpose(), self.conds).transpose()
            X = ops.mul(K, Y) if Y.shape[1] else ops.zeros(n, 0)
        else:
            X = ops.zeros(n, 0)
        M = ops.hstack(L, ops.mul(F, X)) if X.shape[1] else L
        Kn = ops.basis(M.transpose(), self.conds).transpose() if M.shape[1] else M
        if Kn.shape[1] == K.shape[1]:
            self.b_done = True
            return
        self.K.append(Kn)

    def _grow(self) -> bool:
        if self.a_done and self.b_done:
            return False
        if not self.a_done:
            self._step_a()
        if not self.b_done:
            self._step_b()
        return True

    def _cap(self, i, j):
        """A_i ∩ B_j (indices beyond the last space are the stable ones)."""
        while (len(self.A) < i and not self.a_done) or (len(self.K) - 1 < j and not self.b_done):
            self._grow()
        i = min(i, len(self.A))
        j = min(j, len(self.K) - 1)
        ops = self.ops
        if i < 1 or j < 1:
            return ops.zeros(0, self.n)
        key = (i, j)
        if key not in self._cache:
            A, K = self.A[i - 1], self.K[j]
            if A.shape[0] == 0 or K.shape[1] == self.n:
                out = ops.zeros(0, self.n)
            elif K.shape[1] == 0:
                out = A
            else:  # x A with x (A K) = 0: independent rows, as x and A have them
                X = ops.left_null(ops.mul(A, K), self.conds)
                out = ops.mul(X, A) if X.shape[0] else ops.zeros(0, self.n)
            self._cache[key] = out
        return self._cache[key]

    @property
    def horizon(self) -> int:
        """The order from which Σ_k no longer grows (grows the spaces to the end)."""
        while self._grow():
            pass
        return max(1, len(self.A) + len(self.K) - 2)

    def detects(self, d, conds) -> bool:
        """Σ_∞ d ≠ 0 for a fault column d as the backend holds it."""
        if not self.A:
            self._grow()
        while True:
            if self.ops.sees(self._cap(len(self.A), len(self.K) - 1), d, conds):
                return True
            if not self._grow():
                return False

    def min_order(self, d, conds) -> int | None:
        """Smallest k with Σ_k d ≠ 0 (None if none)."""
        if not self.detects(d, set()):
            return None
        k = 0
        while True:
            k += 1
            for i in range(1, k + 1):
                if self.ops.sees(self._cap(i, k + 1 - i), d, conds):
                    return k


def detecting_orders(F, H, L, D, *, max_order=None, method="exact", rtol=None):
    """For each column of D: the smallest k of a member of the left null space of
    (W⁽ᵏ⁾ L⁽ᵏ⁾) with Φ D ≠ 0, or None — by the recursion of the module docstring.

    Plain matrices in, ``(orders, conditions)`` out (a building block and test hook).
    """
    F, H, L, D = (sp.Matrix(M) for M in (F, H, L, D))
    ops = arithmetic(method, F, H, L, D, rtol=rtol)
    r = ReachSpaces(ops, ops.mat(F, "all"), ops.mat(H), ops.mat(L, "cols"))
    conds: set = set(r.conds)
    out = []
    for j in range(D.cols):
        k = r.min_order(ops.mat(D[:, j], "cols"), conds)
        out.append(k if (k is None or max_order is None or k <= max_order) else None)
    return tuple(out), frozenset(conds | r.conds)


# ---------------------------------------------------------------- the analysis
class DiagnosisQuestions:
    """The model's matrices, the faults, and the inputs always decoupled."""

    def __init__(self, work: PlantModel, st: Structure, faults, disturbances, *,
                 method="exact", rtol=None):
        self.work, self.st = work, st
        self.F, self.H = sp.Matrix(st.F), sp.Matrix(st.H)
        self.n = st.n
        self.faults = tuple(faults)
        self.dist = tuple(disturbances)
        self.Dcol = {f.name: sp.Matrix(st.unknown_input_columns([f])) for f in faults}
        self.L0 = sp.Matrix(st.unknown_input_columns(list(disturbances))) if disturbances \
            else sp.zeros(self.n, 0)
        # nonlinear terms whose argument is not measured
        self.hidden = []
        if st.terms:
            rH = exact_rank_value(self.H)
            for j, t in enumerate(st.terms):
                if exact_rank_value(sp.Matrix.vstack(self.H, sp.Matrix(t.row))) > rH:
                    self.hidden.append(j)
        # the matrices as the backend holds them, converted once
        C = sp.Matrix(st.C)
        self.ops = ops = arithmetic(method, self.F, self.H, self.L0, *self.Dcol.values(), C,
                                    rtol=rtol)
        self.b_F, self.b_H, self.b_L0 = ops.mat(self.F, "all"), ops.mat(self.H), \
            ops.mat(self.L0, "cols")
        self.b_D = {f: ops.mat(d, "cols") for f, d in self.Dcol.items()}
        self.b_C = ops.mat(C[:, self.hidden], "cols") if self.hidden else ops.zeros(self.n, 0)
        self._reach: dict = {}
        # output feedthrough (Dy, Ly): answered by the order-by-order spaces of ._orders
        self.feedthrough = st.has_feedthrough
        self.Dycol = {f.name: sp.Matrix(_feedthrough_columns(st, [f])) for f in faults}
        self.Ly0 = sp.Matrix(_feedthrough_columns(st, list(disturbances)))
        self._orders: dict = {}
        self._products = None

    def spaces(self, decoupled: tuple, extra=None) -> OrderSpaces:
        """The residual generators of every order with the disturbances, the faults
        ``decoupled`` and the hidden nonlinear terms decoupled (:mod:`._orders`)."""
        key = (decoupled, None if extra is None else tuple(extra))
        if key not in self._orders:
            # the columns in the order of ``names`` below: disturbances, hidden nonlinear
            # terms, then the decoupled faults (the last one is the parent's addition)
            hid = [sp.Matrix(self.st.C[:, j]) for j in self.hidden]
            L = sp.Matrix.hstack(self.L0, *hid, *[self.Dcol[f] for f in decoupled])
            Ly = sp.Matrix.hstack(self.Ly0, sp.zeros(self.H.rows, len(self.hidden)),
                                  *[self.Dycol[f] for f in decoupled])
            H = self.H
            if extra is not None:
                H = sp.Matrix.vstack(H, sp.Matrix(extra))
                Ly = sp.Matrix.vstack(Ly, sp.zeros(1, Ly.cols))
            if extra is None and self._products is None:
                self._products = Products(self.ops, self.F, self.H)
            names = [r.name for r in self.dist] + [("term", j) for j in self.hidden] + \
                list(decoupled)
            parent = self.spaces(decoupled[:-1], extra) if decoupled else None
            products = parent.P if parent is not None else (
                self._products if extra is None else None)
            self._orders[key] = OrderSpaces(self.ops, self.F, H, L, Ly, products, names,
                                            parent)
        return self._orders[key]

    def dy(self, f: str, extra=None) -> sp.Matrix:
        d = self.Dycol[f]
        return d if extra is None else sp.Matrix.vstack(d, sp.zeros(1, 1))

    def ask_strong(self, f: str, decoupled: tuple, points, *, order: bool):
        """``(strongly detectable, least order or None, conditions)``: a residual with
        ``decoupled`` decoupled whose gain to f is nonzero at every point."""
        conds: set = set()
        sp_ = self.spaces(decoupled)
        if order:
            k = sp_.min_order(self.Dcol[f], self.dy(f), conds, points, name=f)
            return k is not None, k, frozenset(conds | sp_.conds)
        K = sp_.last
        ok = all(sp_.gain_at(K, self.Dcol[f], self.dy(f), p, conds, f) for p in points)
        return ok, None, frozenset(conds | sp_.conds)

    def _ask_feedthrough(self, f: str, decoupled: tuple, order: bool, extra):
        conds: set = set()
        sp_ = self.spaces(decoupled, extra)
        d = self.Dcol[f]
        if not sp_.detects_at(sp_.last, d, self.dy(f, extra), conds, f):
            return False, None, False, frozenset(conds | sp_.conds)
        k = sp_.min_order(d, self.dy(f, extra), conds, name=f) if order else None
        return True, k, False, frozenset(conds | sp_.conds)

    def L(self, decoupled: tuple, nonlinear_decoupled: bool):
        cols = [self.L0] + [self.Dcol[f] for f in decoupled]
        if nonlinear_decoupled and self.hidden:
            cols += [sp.Matrix(self.st.C[:, j]) for j in self.hidden]
        return sp.Matrix.hstack(*cols)

    def reach(self, decoupled: tuple, nonlinear_decoupled: bool = True, extra=None) -> ReachSpaces:
        key = (decoupled, nonlinear_decoupled, None if extra is None else tuple(extra))
        if key not in self._reach:
            ops = self.ops
            H = self.b_H if extra is None else ops.vstack(self.b_H, ops.mat(extra))
            L = self.b_L0
            for f in decoupled:
                L = ops.hstack(L, self.b_D[f])
            if nonlinear_decoupled:
                L = ops.hstack(L, self.b_C)
            self._reach[key] = ReachSpaces(ops, self.b_F, H, L)
        return self._reach[key]

    # -- one question: fault f with the faults `decoupled` decoupled
    def ask(self, f: str, decoupled: tuple, *, order: bool, extra=None):
        """``(detectable, min_order or None, via_substitution, conditions)``."""
        if self.feedthrough:
            return self._ask_feedthrough(f, decoupled, order, extra)
        conds: set = set()
        r = self.reach(decoupled, True, extra)
        d = self.b_D[f]
        if r.detects(d, conds):
            k = r.min_order(d, conds) if order else None
            return True, k, False, frozenset(conds | r.conds)
        if not self.hidden:
            return False, None, False, frozenset(conds | r.conds)
        # the hidden nonlinear terms as known signals: an upper bound, then a witness
        ro = self.reach(decoupled, False, extra)
        if not ro.detects(d, set()):
            return False, None, False, frozenset(conds | r.conds | ro.conds)
        k0 = ro.min_order(d, conds)
        H = self.H if extra is None else sp.Matrix.vstack(self.H, sp.Matrix(extra))
        k = self._witness(f, decoupled, k0, H, conds)
        if k is None:
            return False, None, True, frozenset(conds | ro.conds)
        return True, k, True, frozenset(conds | ro.conds)

    def _witness(self, f, decoupled, k0, H, conds):
        """Smallest k ≥ k0 (< n + 1) with a member sensitive to f whose nonlinear
        arguments are recoverable (METHOD §2c); tried: the reduced-echelon members,
        their pairwise sums and one generic combination."""
        L = self.L(decoupled, False)
        d = self.Dcol[f]
        st = self.st if H is self.H else dataclasses.replace(self.st, H=sp.ImmutableMatrix(H))
        for k in range(k0, self.n + 1):
            W, Lk = krylov_blocks(self.F, H, L, k)
            members, er = left_null_echelon(sp.Matrix.hstack(W, Lk))
            if not members:
                continue
            cands = list(members) + [a + b for a, b in itertools.combinations(members, 2)]
            cands.append(sum((sp.Integer(i + 2) ** 2 * v for i, v in enumerate(members)),
                             sp.zeros(1, members[0].cols)))
            for v in cands:
                _, _, Phi = member_to_phi(v, self.F, H, k)
                if (Phi * d).applyfunc(sp.cancel) == sp.zeros(k, 1):
                    continue
                ok, _, _, _ = substitute_arguments(st, Phi, observer_symbols(k),
                                                   output_symbols(H.rows))
                if ok:
                    conds |= er.conditions
                    return k
        return None

    # -- reasons
    def reason(self, f: str, decoupled: tuple, via_substitution: bool) -> str:
        """One line: which condition fails for f with the faults ``decoupled`` decoupled."""
        names = [r.name for r in self.dist] + list(decoupled)
        dec = ", ".join(names)
        d = self.Dcol[f]
        if decoupled:
            head = f"{f} cannot be isolated from {', '.join(decoupled)}"
            cond = f"with {dec} decoupled"
        else:
            head = f"{f} is undetectable" + (f" with {dec} decoupled" if names else "")
            cond = "with Φ L = 0" if names else ""
        if self.feedthrough:
            return self._reason_feedthrough(f, decoupled, head, dec)
        if all(e == 0 for e in d):
            return f"{head}: it does not enter the dynamics (its column of D is zero)"
        v = sp.Matrix(d)
        for _ in range(self.n):
            if any(sp.cancel(e) != 0 for e in self.H * v):
                break
            v = self.F * v
        else:
            return (f"{head}: it does not reach the outputs (H Fⁱ D({f}) = 0 for every i:"
                    " it acts on the unobservable subspace)")
        L = self.L(decoupled, True)
        if L.cols and exact_rank_value(sp.Matrix.hstack(L, d)) == exact_rank_value(L):
            if len(names) == 1:
                return (f"{head}: D({f}) is a multiple of the column of {dec}: the fault"
                        f" enters exactly as {dec} does")
            return (f"{head}: D({f}) is a combination of the columns of {dec}: the fault"
                    " enters exactly as they do")
        if via_substitution:
            return (f"{head}: every member {cond} and Φ C = 0 has Φ D({f}) = 0, and no"
                    " member sensitive to it that was tried lets the nonlinear arguments be"
                    " recovered (rank [Φ; H; A_j] > rank [Φ; H], METHOD §2c)")
        return (f"{head}: every member {cond} has Φ D({f}) = 0, for every order k (D({f})"
                f" lies in the smallest unobservability subspace containing Im L)"
                ).replace("member  has", "member has")

    def _reason_feedthrough(self, f, decoupled, head, dec) -> str:
        d, dy = self.Dcol[f], self.Dycol[f]
        if all(e == 0 for e in d) and all(e == 0 for e in dy):
            return f"{head}: it enters neither the dynamics nor the outputs (D({f}) = 0," \
                f" Dy({f}) = 0)"
        L = self.L(decoupled, True)
        Ly = sp.Matrix.hstack(self.Ly0, *[self.Dycol[g] for g in decoupled],
                              sp.zeros(self.H.rows, len(self.hidden)))
        col, cols = sp.Matrix.vstack(d, dy), sp.Matrix.vstack(L, Ly)
        if cols.cols and exact_rank_value(sp.Matrix.hstack(cols, col)) == \
                exact_rank_value(cols):
            return (f"{head}: (D({f}); Dy({f})) is a combination of the columns of {dec}:"
                    " the fault enters exactly as they do")
        return (f"{head}: every residual generator with {dec or 'nothing'} decoupled"
                f" (Φ L = J* Ly, R* Ly = 0) has R* Dy({f}) = 0 and Φ D({f}) = J* Dy({f}),"
                " for every order k")

