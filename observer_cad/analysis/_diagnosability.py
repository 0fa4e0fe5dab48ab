"""Diagnosability analysis: which faults a disturbance-decoupled residual can detect,
which pairs it can tell apart, and the achievable structure matrix (issue 12, item 2).

Problem
-------
Plant (METHOD §1) ``x' = F x + G u + C Ψ + D d + L ρ``, ``y = H x``. A residual
generator of order k is a member ``v = (R*, −J*_1, …, −J*_k)`` of the left null space
of ``(W⁽ᵏ⁾ L⁽ᵏ⁾)`` (METHOD §2a), with rows

    Φ_1 = R* H,   Φ_{i+1} = Φ_i F − J*_i H  (i < k),   Φ_k F = J*_k H,   Φ_i L = 0.

Its residual responds to the fault f iff ``Φ D_f ≠ 0`` (the error system
``e' = (F* − K H*) e + D* f``, ``r = H* e`` is observable). For a set S of inputs to
decouple (the disturbances and possibly other faults) this module answers:

* **detectable**: some member, of some order k, has ``Φ D_f ≠ 0``;
* **minimal order**: the smallest such k;
* **isolable** (f_a from f_b): f_a is detectable with D_b decoupled as well;
* **structure matrix**: for every set of faults decoupled, the faults a single residual
  can stay sensitive to (a row of 0/1).

Method
------
The members of order k never need to be listed. A row φ occurs as row i of some member
of order k iff it can be *reached* from 0 in i steps and *finished* (brought to
``Φ_{k+1} = 0``) in k + 1 − i steps, every row on the way annihilating L; the recursion
is Markov (the next row depends only on the current one and a free J*_i), so reaching
and finishing chains concatenate. With

    A_1 = {R H : R H L = 0},            A_{i+1} = (A_i F + rowsp H) ∩ {φ : φ L = 0},
    B_1 = {φ : φ L = 0, φ F ∈ rowsp H}, B_{j+1} = {φ : φ L = 0, φ F ∈ B_j + rowsp H},

the span of all rows of all members of order k is ``Σ_k = Σ_i A_i ∩ B_{k+1−i}``, so
f has a detecting residual of order k iff ``Σ_k D_f ≠ 0``. The A_i and B_j grow and stop
growing at the first repeat (each is a function of the previous one), after at most n
steps; then ``Σ_k = A_∞ ∩ B_∞`` for every larger k, and f is detectable iff
``(A_∞ ∩ B_∞) D_f ≠ 0``. B_j is kept as the annihilator of the column space
``K_j = Im L + F (K_{j−1} ∩ ker H)`` (K_0 = Rⁿ), the unobservability-subspace
recursion. Every space lives in Rⁿ (n-sized eliminations, not the l(k+1)-row Krylov
matrix), and they are grown only until the question is answered; the tests check ``Σ_k D_f ≠ 0`` against the members of
``(W⁽ᵏ⁾ L⁽ᵏ⁾)`` built with :func:`krylov_blocks` / :func:`member_to_phi`, and
detectability against the normal rank of the system matrix.

A row of the structure matrix with the faults S decoupled: the faults detectable with
S and the disturbances decoupled. A residual sensitive to *all* of them at once exists
because each "Φ D_f ≠ 0" excludes a proper subspace of the members, and a vector space
over an infinite field is not a finite union of proper subspaces.

Exact arithmetic over QQ or QQ(parameters) (:mod:`observer_cad.numerics`): every pivot
divided by and every entry found nonzero is recorded as a condition ``Ne(f, 0)``; under
those conditions the computation specialises unchanged to parameter values, so both the
positive and the negative answers hold there (``assumptions``).

Nonlinear plants (METHOD §2c): a term φ_j(A_j x, u) whose argument is measured
(A_j ∈ rowsp H) is a known signal. Any other term is first decoupled (its column of C
joins L): an answer found that way does not rest on the argument substitution. If that
fails, the term is treated as known (an upper bound on what can be detected) and a
member is searched, order by order, whose Φ passes :func:`substitute_arguments`
(rank [Φ; H] = rank [Φ; H; A_j] for every nonzero column of Φ C); an answer found that
way rests on the substitution and says so. That search tries the reduced-echelon members,
their pairwise sums and one fixed generic combination: a "no" from it is not a proof.

References: METHOD §2a, §2c; seed 000 §3 (canonical form), seed 002 Remark 1 (several
faults); for the geometric reading (Σ_∞ is the annihilator of the smallest
unobservability subspace containing Im L) Massoumnia, Verghese & Willsky, IEEE TAC 34
(1989); for structure matrices Varga, *Solving Fault Diagnosis Problems*, Springer 2017,
§5.2 (achievable specifications).
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from typing import Sequence

import numpy as np
import sympy as sp
from sympy.polys.domains import ZZ
from sympy.polys.matrices import DomainMatrix

from ..errors import ModelError, UsageError
from ..model import PlantModel, Structure, extract_structure, parse_estimate
from ..numerics import (SingleThreadBLAS, exact_rank, exact_rank_value,
                        left_null_echelon, left_null_space, np_exact, nonzero_conditions,
                        rational_left_null, rational_rref)
from ..synthesis import FLOAT_AUTO_N, krylov_blocks, member_to_phi
from ..synthesis import substitute_arguments
from ..synthesis import observer_symbols, output_symbols

__all__ = ["analyze", "Analysis", "FaultAnalysis", "PairAnalysis", "StructureRow",
           "Suggestion", "detecting_orders", "MAX_ENUMERATED_FAULTS"]

#: Up to this many faults every set of decoupled faults is enumerated for the structure
#: matrix; above it only the sets of at most two faults (``structure_complete`` False).
MAX_ENUMERATED_FAULTS = 8


# ---------------------------------------------------------------- values
@dataclasses.dataclass(frozen=True)
class FaultAnalysis:
    """Detectability of one fault with the disturbances decoupled.

    ``min_order`` is the smallest k of a detecting residual generator (None when not
    detectable); ``reason`` one line when not detectable, else ""; ``via_substitution``
    True when the answer rests on the argument substitution of a nonlinear term;
    ``assumptions`` the nonzero conditions this answer needs (symbolic models).
    """

    fault: str
    detectable: bool
    min_order: int | None
    reason: str = ""
    via_substitution: bool = False
    assumptions: tuple = ()

    def to_json(self) -> dict:
        return {"fault": self.fault, "detectable": self.detectable,
                "min_order": self.min_order, "reason": self.reason,
                "via_substitution": self.via_substitution,
                "assumptions": [str(a) for a in self.assumptions]}


@dataclasses.dataclass(frozen=True)
class PairAnalysis:
    """Isolability of two faults a, b.

    ``a_from_b``: a residual sensitive to a and decoupled from b exists (order
    ``a_from_b_order``); ``b_from_a`` the converse. The pair is (strongly) ``isolable``
    when both exist. ``reason``: one line per failing direction.
    """

    faults: tuple
    a_from_b: bool
    b_from_a: bool
    a_from_b_order: int | None = None
    b_from_a_order: int | None = None
    reason: str = ""
    via_substitution: bool = False
    assumptions: tuple = ()

    @property
    def isolable(self) -> bool:
        return self.a_from_b and self.b_from_a

    def to_json(self) -> dict:
        a, b = self.faults
        return {"faults": [a, b], "isolable": self.isolable,
                "first_from_second": self.a_from_b, "second_from_first": self.b_from_a,
                "orders": [self.a_from_b_order, self.b_from_a_order],
                "reason": self.reason, "via_substitution": self.via_substitution}


@dataclasses.dataclass(frozen=True)
class StructureRow:
    """One achievable row of the structure matrix: a residual decoupled from the
    disturbances and from the faults ``decoupled``, sensitive to each of ``sensitive``
    (every other fault is then decoupled as well: it cannot be seen).

    ``requested`` is the set of faults that was asked to be decoupled; ``decoupled``
    adds the faults that turned out undetectable with it.
    """

    requested: tuple
    decoupled: tuple
    sensitive: tuple
    via_substitution: bool = False

    def row(self, faults) -> dict:
        return {f: int(f in self.sensitive) for f in faults}


@dataclasses.dataclass(frozen=True)
class Suggestion:
    """An extra measurement that makes a fault detectable (``other`` None) or isolable
    from ``other``: a state (``x2``) or a candidate output expression."""

    fault: str
    other: str | None
    measurement: str
    min_order: int

    @property
    def goal(self) -> str:
        return f"detect {self.fault}" if self.other is None else \
            f"isolate {self.fault} from {self.other}"

    def to_json(self) -> dict:
        return {"goal": self.goal, "fault": self.fault, "from": self.other,
                "measurement": self.measurement, "min_order": self.min_order}


@dataclasses.dataclass(frozen=True)
class Analysis:
    """The diagnosability of a model's faults with its disturbances decoupled.

    ``fault_results`` (one :class:`FaultAnalysis` per fault, in order), ``pairs``
    (:class:`PairAnalysis` for every pair), ``structure`` (the distinct achievable rows,
    :class:`StructureRow`; complete when ``structure_complete``), ``suggestions``
    (:class:`Suggestion`) and ``unhelped`` (goals no single listed measurement reaches),
    ``assumptions`` (union over every answer), ``notes`` (nonlinear terms, limits).
    """

    model_name: str
    time: str
    faults: tuple
    disturbances: tuple
    symbolic: bool
    fault_results: tuple
    pairs: tuple
    structure: tuple
    structure_complete: bool
    suggestions: tuple
    unhelped: tuple
    assumptions: tuple
    notes: tuple = ()
    candidates: tuple = ()

    def __repr__(self) -> str:
        det = sum(1 for r in self.fault_results if r.detectable)
        iso = sum(1 for p in self.pairs if p.isolable)
        return (f"<Analysis of {self.model_name}: {det} of {len(self.faults)} faults detectable,"
                f" {iso} of {len(self.pairs)} pairs isolable, {len(self.structure)} achievable"
                f" structure rows>")

    def _repr_markdown_(self) -> str:
        """Notebook view: detectability, isolability and the achievable structure matrix."""
        lines = [f"**Diagnosability** of `{self.model_name}` with"
                 f" {', '.join(self.disturbances) or 'nothing'} decoupled", "",
                 "| fault | detectable | minimal order | reason |", "|---|---|---|---|"]
        for r in self.fault_results:
            lines.append(f"| {r.fault} | {'✅' if r.detectable else '❌'} |"
                         f" {r.min_order if r.min_order is not None else '—'} |"
                         f" {r.reason.replace('|', '/')} |")
        if self.pairs:
            lines += ["", "| pair | isolable |", "|---|---|"]
            lines += [f"| {a} / {b} | {'✅' if p.isolable else '❌'} |"
                      for p in self.pairs for a, b in [p.faults]]
        if self.structure:
            lines += ["", "| decoupled | " + " | ".join(self.faults) + " |",
                      "|---|" + "---|" * len(self.faults)]
            for row in self.structure:
                bits = row.row(self.faults)
                lines.append(f"| {', '.join(row.decoupled) or '—'} | "
                             + " | ".join(str(bits[f]) for f in self.faults) + " |")
        return "\n".join(lines)

    def fault(self, name: str) -> FaultAnalysis:
        for r in self.fault_results:
            if r.fault == name:
                return r
        raise KeyError(name)

    def pair(self, a: str, b: str) -> PairAnalysis:
        for p in self.pairs:
            if p.faults == (a, b):
                return p
            if p.faults == (b, a):
                return dataclasses.replace(
                    p, faults=(a, b), a_from_b=p.b_from_a, b_from_a=p.a_from_b,
                    a_from_b_order=p.b_from_a_order, b_from_a_order=p.a_from_b_order)
        raise KeyError((a, b))

    @property
    def detectable(self) -> dict:
        return {r.fault: r.detectable for r in self.fault_results}

    @property
    def min_order(self) -> dict:
        return {r.fault: r.min_order for r in self.fault_results}

    def to_json(self) -> dict:
        """The object ``observer-cad analyze --json`` prints."""
        return {
            "model": self.model_name,
            "time": self.time,
            "faults": list(self.faults),
            "disturbances": list(self.disturbances),
            "symbolic": self.symbolic,
            "detectable": self.detectable,
            "min_order": self.min_order,
            "reasons": {r.fault: r.reason for r in self.fault_results if r.reason},
            "isolable": [p.to_json() for p in self.pairs],
            "structure_matrices": [s.row(self.faults) for s in self.structure],
            "structure_rows": [{"decoupled": list(s.decoupled), "sensitive": list(s.sensitive),
                                "via_substitution": s.via_substitution}
                               for s in self.structure],
            "structure_complete": self.structure_complete,
            "suggestions": [s.to_json() for s in self.suggestions],
            "unhelped": list(self.unhelped),
            "candidates": list(self.candidates),
            "assumptions": [str(a) for a in self.assumptions],
            "notes": list(self.notes),
            "fault_results": [r.to_json() for r in self.fault_results],
        }


# ---------------------------------------------------------------- row spaces
class _Rational:
    """Row-space operations for rational matrices, on integer ``DomainMatrix`` values
    (no conditions to record).

    A row space does not change when a row is scaled, an annihilator when a column is;
    F may be scaled as a whole. So every matrix is kept with integer, primitive rows
    (columns for L and D): fraction-free elimination over ZZ, no rational gcds.
    """

    @staticmethod
    def accepts(*mats) -> bool:
        return all(not sp.Matrix(M).free_symbols and all(e.is_Rational for e in sp.Matrix(M))
                   for M in mats)

    @staticmethod
    def _primitive_rows(M):
        rows = []
        for row in M.to_list():
            g = 0
            for e in row:
                g = math.gcd(g, int(e))
            rows.append([e // g for e in row] if g > 1 else row)
        return DomainMatrix(rows, M.shape, ZZ) if rows else M

    def mat(self, M, scale="rows"):
        """An integer matrix with the same row space (``rows``), column annihilator
        (``cols``) or up to one common factor (``all``)."""
        M = sp.Matrix(M)
        if M.rows == 0 or M.cols == 0:
            return DomainMatrix.zeros(M.shape, ZZ)
        if scale == "cols":
            return self.mat(M.T, "rows").transpose()
        if scale == "all":
            den = sp.ilcm(*[sp.Rational(e).q for e in M])
            return DomainMatrix([[ZZ(int(e * den)) for e in M.row(i)] for i in range(M.rows)],
                                M.shape, ZZ)
        rows = []
        for i in range(M.rows):
            den = sp.ilcm(*[sp.Rational(e).q for e in M.row(i)])
            rows.append([ZZ(int(e * den)) for e in M.row(i)])
        return self._primitive_rows(DomainMatrix(rows, M.shape, ZZ))

    def zeros(self, r, c):
        return DomainMatrix.zeros((r, c), ZZ)

    def eye(self, n):
        return DomainMatrix.eye(n, ZZ)

    @staticmethod
    def vstack(A, B):
        if A.shape[0] == 0:
            return B
        if B.shape[0] == 0:
            return A
        return A.vstack(B)

    @staticmethod
    def hstack(A, B):
        if A.shape[1] == 0:
            return B
        if B.shape[1] == 0:
            return A
        return A.hstack(B)

    def _integer_rows(self, Q):
        """Rows over QQ scaled to primitive integer rows (same row space)."""
        if Q.shape[0] == 0:
            return DomainMatrix.zeros(Q.shape, ZZ)
        return self._primitive_rows(Q.clear_denoms_rowwise(convert=True)[1])

    def basis(self, M, conds):
        if M.shape[0] == 0:
            return M
        R, piv = rational_rref(M)  # FLINT when available
        return self._integer_rows(R[:len(piv), :])

    def left_null(self, M, conds):
        if M.shape[0] == 0:
            return self.zeros(0, 0)
        if M.shape[1] == 0:
            return self.eye(M.shape[0])
        N = rational_left_null(M)
        return self._integer_rows(N) if N.shape[0] else self.zeros(0, M.shape[0])

    def sees(self, Sigma, d, conds) -> bool:
        if Sigma.shape[0] == 0:
            return False
        return any(e for row in (Sigma * d).to_list() for e in row)

    @staticmethod
    def mul(A, B):
        return A * B


class _Symbolic:
    """Row-space operations on sympy matrices over QQ(parameters), through
    :mod:`observer_cad.numerics`, recording every pivot's condition."""

    def mat(self, M, scale="rows"):
        return sp.Matrix(M)

    def zeros(self, r, c):
        return sp.zeros(r, c)

    def eye(self, n):
        return sp.eye(n)

    @staticmethod
    def vstack(A, B):
        return sp.Matrix.vstack(A, B)

    @staticmethod
    def hstack(A, B):
        return sp.Matrix.hstack(A, B)

    def basis(self, M, conds):
        if M.rows == 0:
            return sp.zeros(0, M.cols)
        er = exact_rank(M)
        conds |= er.conditions
        return sp.Matrix(er.reduced[:er.rank, :])

    def left_null(self, M, conds):
        if M.rows == 0:
            return sp.zeros(0, 0)
        if M.cols == 0:
            return sp.eye(M.rows)
        basis, er = left_null_space(M)
        conds |= er.conditions
        return sp.Matrix.vstack(*basis) if basis else sp.zeros(0, M.rows)

    def sees(self, Sigma, d, conds) -> bool:
        """Σ d ≠ 0 (the nonzero entry relied on is recorded as a condition)."""
        if Sigma.rows == 0:
            return False
        nz = [e for e in (sp.cancel(e) for e in (Sigma * d)) if e != 0]
        if not nz:
            return False
        best = min(nz, key=lambda e: (len(nonzero_conditions(e)), sp.count_ops(e)))
        conds |= nonzero_conditions(best)
        return True

    @staticmethod
    def mul(A, B):
        return A * B


class _Float:
    """Row-space operations by SVD (numeric models above ``FLOAT_AUTO_N`` states, or
    ``method="float"``): orthonormal bases, a rank cut at ``rtol·max(σ_1, 1)``; ``margin`` keeps
    the smallest distance of a decision from its cut (σ/tol or tol/σ), the evidence."""

    def __init__(self, rtol=None):
        self.rtol = 1e-9 if rtol is None else rtol
        self.margin = float("inf")

    def mat(self, M, scale="rows"):
        A = np_exact(sp.Matrix(M)) if sp.Matrix(M).rows and sp.Matrix(M).cols else \
            np.zeros(sp.Matrix(M).shape)
        if A.size == 0:
            return A
        if scale == "all":
            return A / max(np.abs(A).max(), np.finfo(float).tiny)
        ax = 1 if scale == "rows" else 0
        nrm = np.linalg.norm(A, axis=ax, keepdims=True)
        nrm[nrm == 0] = 1.0
        return A / nrm

    def zeros(self, r, c):
        return np.zeros((r, c))

    def eye(self, n):
        return np.eye(n)

    @staticmethod
    def vstack(A, B):
        return np.vstack([A, B])

    @staticmethod
    def hstack(A, B):
        return np.hstack([A, B])

    @staticmethod
    def mul(A, B):
        return A @ B

    def _svd(self, M):
        U, sv, Vt = np.linalg.svd(M, full_matrices=True)
        # every matrix here is built from unit rows / columns and orthonormal bases: its
        # scale is about 1, so a theoretically zero product (noise only) is cut as such
        tol = self.rtol * max(sv[0] if sv.size else 0.0, 1.0)
        r = int(np.sum(sv > tol))
        if tol > 0:
            if r:
                self.margin = min(self.margin, sv[r - 1] / tol)
            if r < sv.size and sv[r] > 0:
                self.margin = min(self.margin, tol / sv[r])
        return U, r, Vt

    def basis(self, M, conds):
        if M.shape[0] == 0 or M.shape[1] == 0:
            return np.zeros((0, M.shape[1]))
        _, r, Vt = self._svd(M)
        return Vt[:r]

    def left_null(self, M, conds):
        if M.shape[0] == 0:
            return np.zeros((0, 0))
        if M.shape[1] == 0:
            return np.eye(M.shape[0])
        U, r, _ = self._svd(M)
        return U[:, r:].T.copy()

    def sees(self, Sigma, d, conds) -> bool:
        if Sigma.shape[0] == 0:
            return False
        v = float(np.linalg.norm(Sigma @ d))
        tol = self.rtol * max(float(np.linalg.norm(d)), np.finfo(float).tiny)
        self.margin = min(self.margin, v / tol if v > tol else tol / max(v, np.finfo(float).tiny))
        return v > tol


def _backend(*mats, method="exact", rtol=None):
    if method == "float":
        return _Float(rtol)
    return _Rational() if _Rational.accepts(*mats) else _Symbolic()


class _Reach:
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
    ops = _backend(F, H, L, D, method=method, rtol=rtol)
    r = _Reach(ops, ops.mat(F, "all"), ops.mat(H), ops.mat(L, "cols"))
    conds: set = set(r.conds)
    out = []
    for j in range(D.cols):
        k = r.min_order(ops.mat(D[:, j], "cols"), conds)
        out.append(k if (k is None or max_order is None or k <= max_order) else None)
    return tuple(out), frozenset(conds | r.conds)


# ---------------------------------------------------------------- the analysis
class _Problem:
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
        self.ops = ops = _backend(self.F, self.H, self.L0, *self.Dcol.values(), C,
                                  method=method, rtol=rtol)
        self.b_F, self.b_H, self.b_L0 = ops.mat(self.F, "all"), ops.mat(self.H), \
            ops.mat(self.L0, "cols")
        self.b_D = {f: ops.mat(d, "cols") for f, d in self.Dcol.items()}
        self.b_C = ops.mat(C[:, self.hidden], "cols") if self.hidden else ops.zeros(self.n, 0)
        self._reach: dict = {}

    def L(self, decoupled: tuple, nonlinear_decoupled: bool):
        cols = [self.L0] + [self.Dcol[f] for f in decoupled]
        if nonlinear_decoupled and self.hidden:
            cols += [sp.Matrix(self.st.C[:, j]) for j in self.hidden]
        return sp.Matrix.hstack(*cols)

    def reach(self, decoupled: tuple, nonlinear_decoupled: bool = True, extra=None) -> _Reach:
        key = (decoupled, nonlinear_decoupled, None if extra is None else tuple(extra))
        if key not in self._reach:
            ops = self.ops
            H = self.b_H if extra is None else ops.vstack(self.b_H, ops.mat(extra))
            L = self.b_L0
            for f in decoupled:
                L = ops.hstack(L, self.b_D[f])
            if nonlinear_decoupled:
                L = ops.hstack(L, self.b_C)
            self._reach[key] = _Reach(ops, self.b_F, H, L)
        return self._reach[key]

    # -- one question: fault f with the faults `decoupled` decoupled
    def ask(self, f: str, decoupled: tuple, *, order: bool, extra=None):
        """``(detectable, min_order or None, via_substitution, conditions)``."""
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


def _resolve(model: PlantModel, faults, disturbances):
    where = model.where

    def lookup(name, what, pool):
        sym = model.symbol(str(name)) if not isinstance(name, sp.Symbol) else name
        if sym is None or sym not in pool:
            declared = ", ".join(s.name for s in pool) or "none"
            raise ModelError(f"{where}: unknown {what} '{name}'; declared: {declared}")
        return sym

    pool = tuple(model.faults) + tuple(model.disturbances)
    if faults is None:
        fs = list(model.faults)
    else:
        fs = [lookup(n, "fault", pool) for n in ([faults] if isinstance(faults, str) else faults)]
    if not fs:
        raise UsageError(f"{where}: no faults to analyse (the model declares none; name"
                         " one with --fault)")
    if len(set(fs)) != len(fs):
        raise UsageError("a fault is named twice")
    dist = [r for r in model.disturbances if r not in fs]
    for n in ([disturbances] if isinstance(disturbances, str) else (disturbances or ())):
        s = lookup(n, "fault or disturbance to decouple", pool)
        if s in fs:
            raise UsageError(f"'{s.name}' cannot be both analysed (--fault) and decoupled"
                             " (--disturbance)")
        if s not in dist:
            dist.append(s)
    return fs, dist


def _candidate_rows(work: PlantModel, st: Structure, candidates):
    """(label, row) for every state not measured and every candidate expression."""
    H = sp.Matrix(st.H)
    rH = exact_rank_value(H)
    out = []
    for i, x in enumerate(work.states):
        row = sp.Matrix([[1 if j == i else 0 for j in range(st.n)]])
        if exact_rank_value(sp.Matrix.vstack(H, row)) > rH:
            out.append((str(x), row))
    seen = [row for _, row in out]
    for c in candidates or ():
        M = parse_estimate(work, c, what="--candidate")
        for r in range(M.rows):
            if M[r, :] not in seen:  # a candidate that is a state already listed: once
                seen.append(M[r, :])
                out.append((str(c), M[r, :]))
    return out


def analyze(model: PlantModel, *, faults: Sequence[str] | None = None,
            disturbances: Sequence[str] | None = None,
            candidates: Sequence | None = None, symbolic: bool = False,
            method: str = "auto", rtol: float | None = None,
            structure: Structure | None = None,
            max_enumerated: int = MAX_ENUMERATED_FAULTS) -> Analysis:
    """Detectability, minimal orders, isolability and the achievable structure matrix.

    Problem: for ``x' = F x + G u + C Ψ + D d + L ρ``, ``y = H x`` and the residual
    generators of METHOD §2a decoupled from ρ, which faults can be detected (Φ D_f ≠ 0),
    with which minimal order k, which pairs isolated, which sets of faults decoupled by
    one residual that stays sensitive to the rest (see the module docstring).

    Parameters
    ----------
    model : PlantModel
    faults : sequence of str, optional
        The faults to analyse (default: every declared fault). A declared disturbance
        may be named: it is then analysed, not decoupled.
    disturbances : sequence of str, optional
        Further faults or disturbances to decouple, besides the model's disturbances
        (default: none). Declared faults not named anywhere are taken as zero.
    candidates : sequence of str or sympy expressions, optional
        Candidate extra outputs (linear in the states) for the suggestions; every
        unmeasured state is always tried.
    symbolic : bool, default False
        Keep parameters as symbols (answers generic, with ``assumptions``); otherwise
        substitute their defaults as exact rationals.
    method : {"auto", "exact", "float"}, default "auto"
        Exact arithmetic, or SVD rank decisions with relative tolerance ``rtol``
        (default 1e-9; the smallest distance of a decision from its cut is reported in
        ``notes``). "auto" takes the float path for numeric models with more than
        ``FLOAT_AUTO_N`` states, as ``design`` does.
    rtol : float, optional
    structure : Structure, optional
        The extracted structure of ``model`` (symbolic only; saves re-extraction).
    max_enumerated : int, default 8
        Up to this many faults every set of decoupled faults is enumerated for the
        structure matrix; above it, only sets of at most two.

    Returns
    -------
    Analysis

    Raises
    ------
    ModelError, UsageError
        An unknown fault or disturbance name, or nothing to analyse.
    """
    if method not in ("auto", "exact", "float"):
        raise UsageError(f"method must be 'auto', 'exact' or 'float', got {method!r}")
    if rtol is not None and not 0 < rtol < 1:
        raise UsageError(f"rtol {rtol}: a relative tolerance must lie in (0, 1)")
    work = model if symbolic else model.substitute_parameters()
    st = structure if (structure is not None and symbolic) else extract_structure(work)
    fs, dist = _resolve(work, faults, disturbances)
    for c in candidates or ():  # read (and refused) now, whether or not they are needed
        parse_estimate(work, c, what="--candidate")
    if method == "auto":
        method = "float" if (not work.parameters and st.n > FLOAT_AUTO_N) else "exact"
    if method == "float" and work.parameters:
        raise UsageError("the float path needs numeric parameters: analyse without --symbolic")
    with SingleThreadBLAS():
        return _analyze(work, st, fs, dist, candidates, symbolic, method, rtol, max_enumerated)


def _failing_at_defaults(conditions, parameters) -> list:
    """The conditions (``Ne(f, 0)``) a symbolic answer needs that are false at the
    parameters' defaults (none when a parameter has no default: there is nothing to
    evaluate at)."""
    values = dict(parameters)
    if not values or any(v is None for v in values.values()):
        return []
    return sorted((c for c in conditions if sp.sympify(c).xreplace(values) == sp.false),
                  key=str)


def _analyze(work, st, fs, dist, candidates, symbolic, method, rtol, max_enumerated):
    P = _Problem(work, st, fs, dist, method=method, rtol=rtol)
    names = tuple(f.name for f in fs)
    all_conds: set = set()

    # Step 1: detectability and minimal order, disturbances decoupled
    fault_results = []
    for f in names:
        ok, k, sub, conds = P.ask(f, (), order=True)
        all_conds |= conds
        fault_results.append(FaultAnalysis(
            f, ok, k, "" if ok else P.reason(f, (), sub), sub and ok,
            tuple(sorted(conds, key=str))))

    # Step 2: isolability of each pair (a from b: a detectable with b decoupled too)
    pairs = []
    for a, b in itertools.combinations(names, 2):
        ab = P.ask(a, (b,), order=True)
        ba = P.ask(b, (a,), order=True)
        all_conds |= ab[3] | ba[3]
        why = []
        if not ab[0]:
            why.append(P.reason(a, (b,), ab[2]))
        if not ba[0]:
            why.append(P.reason(b, (a,), ba[2]))
        pairs.append(PairAnalysis((a, b), ab[0], ba[0], ab[1], ba[1], "; ".join(why),
                                  (ab[2] and ab[0]) or (ba[2] and ba[0]),
                                  tuple(sorted(ab[3] | ba[3], key=str))))

    # Step 3: achievable structure matrix rows. Larger sets first: f detectable with S
    # decoupled stays detectable with any subset of S decoupled (more members), so a
    # positive answer for S ∪ {g} settles f for S without computing.
    m = len(names)
    complete = m <= max_enumerated
    sizes = range(m - 1, -1, -1) if complete else range(min(m - 1, 2), -1, -1)
    known: dict = {}  # (S, f) -> (detectable, via_substitution)
    rows: dict = {}
    for size in sizes:
        for S in itertools.combinations(names, size):
            sens, via = [], False
            for f in names:
                if f in S:
                    continue
                ans = next((known[(T, f)] for g in names if g != f and g not in S
                            for T in [tuple(x for x in names if x in S or x == g)]
                            if known.get((T, f), (False, True)) == (True, False)), None)
                if ans is None:
                    ok, _, sub, conds = P.ask(f, S, order=False)
                    all_conds |= conds
                    ans = (ok, sub)
                known[(S, f)] = ans
                if ans[0]:
                    sens.append(f)
                    via = via or ans[1]
            if not sens:
                continue
            key = tuple(sens)
            if key not in rows or len(S) < len(rows[key].requested):
                rows[key] = StructureRow(S, tuple(f for f in names if f not in sens), key, via)
    structure_rows = tuple(sorted(rows.values(), key=lambda r: (len(r.decoupled), r.decoupled)))

    # Step 4: suggestions: one extra measurement for each failing question
    goals = [(r.fault, None) for r in fault_results if not r.detectable]
    for p in pairs:
        a, b = p.faults
        if not p.a_from_b and P.ask(a, (), order=False)[0]:
            goals.append((a, b))
        if not p.b_from_a and P.ask(b, (), order=False)[0]:
            goals.append((b, a))
    cands = _candidate_rows(work, st, candidates) if goals else []
    suggestions, unhelped = [], []
    for f, other in goals:
        dec = () if other is None else (other,)
        found = False
        for label, row in cands:
            ok, k, _, conds = P.ask(f, dec, order=True, extra=row)
            if ok:
                all_conds |= conds
                suggestions.append(Suggestion(f, other, label, k))
                found = True
        if not found:
            goal = f"detect {f}" if other is None else f"isolate {f} from {other}"
            unhelped.append(goal + (": no single extra measurement among the unmeasured"
                                    " states" + (" and the candidates" if candidates else "")
                                    + " helps" if cands else ": every state is measured"))

    notes = []
    if P.hidden:
        args = ", ".join(str((sp.Matrix(st.terms[j].row) * sp.Matrix(work.states))[0, 0])
                         for j in P.hidden)
        notes.append(f"nonlinear terms with unmeasured arguments ({args}): answers are first"
                     " sought with those terms decoupled (Φ C = 0); an answer marked 'via"
                     " argument substitution' rests on rank [Φ; H] = rank [Φ; H; A_j]"
                     " (METHOD §2c) for the member found")
    if not complete:
        notes.append(f"{m} faults > {max_enumerated}: structure-matrix rows enumerated for"
                     " at most two decoupled faults only")
    notes.append("a residual of order k = n is a full-order one; the reduced-order designs"
                 " (design --form canonical) search k < n")
    failing = _failing_at_defaults(all_conds, work.parameters) if symbolic else []
    if failing:
        notes.append(f"at the parameter defaults {', '.join(str(c) for c in failing)}"
                     f" fail{'s' if len(failing) == 1 else ''}: the defaults are a special"
                     " case this generic answer does not cover (analyse without --symbolic"
                     " for the answer there)")
    if method == "float":
        notes.append(f"float path: rank decisions by SVD, cut at {P.ops.rtol:.0e}·max(σ_1, 1); the"
                     f" closest decision was {P.ops.margin:.1e} times away from its cut"
                     " (exact: method='exact')")
    return Analysis(
        model_name=work.name, time=work.time, faults=names,
        disturbances=tuple(s.name for s in dist), symbolic=bool(symbolic and work.parameters),
        fault_results=tuple(fault_results), pairs=tuple(pairs), structure=structure_rows,
        structure_complete=complete, suggestions=tuple(suggestions),
        unhelped=tuple(unhelped), assumptions=tuple(sorted(all_conds, key=str)),
        notes=tuple(notes), candidates=tuple(str(c) for c in (candidates or ())))
