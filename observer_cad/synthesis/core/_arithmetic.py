"""Exact or float: the arithmetic a designer or the analysis works in, as one strategy
object chosen once, so that the body that uses it is written once.

Three strategies with the same methods:

* :class:`ExactArithmetic` — sympy matrices over QQ or QQ(parameters), eliminated through
  :mod:`observer_cad.numerics` (FLINT for rationals); every pivot divided by and every
  entry relied on as nonzero can be recorded as a condition ``Ne(f, 0)``;
* :class:`RationalArithmetic` — the same on rational matrices, whose row spaces it keeps
  as integer ``DomainMatrix`` values with primitive rows (fraction-free, no conditions);
* :class:`FloatArithmetic` — SVD with a stated tolerance; the evidence (singular values
  around the cut, the closest decision's distance from it) is kept.

The methods come in two groups.

On sympy matrices, as a designer holds them
    ``rank(M, conds)``, ``left_null_space(M, conds)`` (rows), ``product(A, B)``,
    ``certify(plant, mats, …)`` (the design's certificate, exactly or within a
    tolerance), ``check_poles(F*, H*, K, μ)``, ``to_sympy(A)``, ``threads()`` (the
    context a computation runs in: one BLAS thread on the float path).
On the strategy's own representation (the row-space recursions of the analysis)
    ``mat(M, scale)`` converts once; ``zeros``, ``eye``, ``vstack``, ``hstack``,
    ``mul``, ``basis(M, conds)``, ``left_null(M, conds)`` and ``sees(Σ, d, conds)``
    work on what it returns.

What one path genuinely does differently is a method of its strategy, not a branch in
the body: a designer subclasses :class:`ExactArithmetic` and :class:`FloatArithmetic`
with its own steps (the member choice, the float path's equilibration and evidence) and
takes the one for its prepared problem with :func:`arithmetic_for`. :func:`arithmetic`
chooses by the matrices themselves (rational, else exact over sympy's domains), for
callers that hold matrices rather than a prepared problem.
"""
from __future__ import annotations

import contextlib
import math

import numpy as np
import sympy as sp
from sympy.polys.domains import ZZ
from sympy.polys.matrices import DomainMatrix

from ...errors import UsageError
from ...numerics import (SingleThreadBLAS, exact_product, exact_rank, exact_rank_value,
                         float_left_null_space, float_rank, left_null_space, np_exact,
                         nonzero_conditions, rational_left_null, rational_rref,
                         to_sympy_float)
from ..certificates import certify_design
from ._poles import certify_poles

__all__ = ["Arithmetic", "ExactArithmetic", "RationalArithmetic", "FloatArithmetic",
           "arithmetic", "arithmetic_for"]


class Arithmetic:
    """What every strategy offers (see the module docstring); ``method`` is "exact" or
    "float", ``exact`` the same as a flag, ``symbolic`` whether parameters remain."""

    method = ""
    exact = True
    symbolic = False

    def threads(self):
        """The context the computation runs in (none for exact arithmetic)."""
        return contextlib.nullcontext()


class ExactArithmetic(Arithmetic):
    """Exact arithmetic on sympy matrices over QQ or QQ(parameters) (and algebraic
    numbers), through :mod:`observer_cad.numerics`; conditions are recorded into the set
    ``conds`` a method is given (none is recorded when it is None)."""

    method = "exact"
    exact = True

    def __init__(self, symbolic: bool = False):
        self.symbolic = bool(symbolic)

    # -- on sympy matrices
    def rank(self, M, conds=None) -> int:
        """The (generic) rank; with ``conds``, the pivots' conditions are added to it."""
        if conds is None:
            return exact_rank_value(M)
        er = exact_rank(M)
        conds |= er.conditions
        return er.rank

    def left_null_space(self, M, conds=None) -> sp.Matrix:
        """A basis of {v : v M = 0} as the rows of a matrix (reduced from Mᵀ)."""
        basis, er = left_null_space(M)
        if conds is not None:
            conds |= er.conditions
        return sp.Matrix.vstack(*basis) if basis else sp.zeros(0, sp.Matrix(M).rows)

    @staticmethod
    def product(A, B) -> sp.Matrix:
        """A B, every entry in a canonical exact form (zero exactly when it is)."""
        return exact_product(A, B)

    @staticmethod
    def certify(plant: dict, mats: dict, **kw):
        """The design's identities, each decided exactly (:func:`certify_design`)."""
        return certify_design(plant, mats, exact=True, **kw)

    @staticmethod
    def check_poles(F, H, K, eigenvalues) -> None:
        """det(sI − F* + K H*) = Π(s − μ_i), coefficient by coefficient, exactly."""
        certify_poles(F, H, K, eigenvalues)

    @staticmethod
    def to_sympy(A) -> sp.Matrix:
        return sp.Matrix(A)

    # -- the representation: sympy matrices as they are
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

    @staticmethod
    def mul(A, B):
        return A * B

    def basis(self, M, conds):
        """Independent rows spanning the row space of M (its reduced echelon form)."""
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
        return self.left_null_space(M, conds)

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


class RationalArithmetic(ExactArithmetic):
    """Exact arithmetic on rational matrices, row spaces kept as integer ``DomainMatrix``
    values (no conditions to record).

    A row space does not change when a row is scaled, an annihilator when a column is;
    F may be scaled as a whole. So every matrix is kept with integer, primitive rows
    (columns for L and D): fraction-free elimination over ZZ, no rational gcds.
    """

    def __init__(self, symbolic: bool = False):
        super().__init__(False)

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
            den = sp.ilcm(1, *[sp.Rational(e).q for e in M])
            return DomainMatrix([[ZZ(int(e * den)) for e in M.row(i)] for i in range(M.rows)],
                                M.shape, ZZ)
        rows = []
        for i in range(M.rows):
            den = sp.ilcm(1, *[sp.Rational(e).q for e in M.row(i)])
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


class FloatArithmetic(Arithmetic):
    """Floating-point arithmetic: ranks and null spaces by SVD, with evidence.

    ``rtol`` is the relative tolerance asked for (None: each decision's default,
    ``max(shape)·eps·1e3`` in :func:`~observer_cad.numerics.float_rank`); ``tolerance``
    the certificate's. The row-space methods (the analysis) cut at
    ``cut·max(σ_1, 1)`` with ``cut`` = ``rtol`` or 1e-9, every matrix there being built
    from unit rows, unit columns and orthonormal bases; ``margin`` keeps the smallest
    distance of one of their decisions from its cut (σ/tol or tol/σ), the evidence.
    """

    method = "float"
    exact = False
    symbolic = False

    def __init__(self, rtol: float | None = None, *, tolerance: float = 1e-9):
        self.rtol = rtol
        self.cut = 1e-9 if rtol is None else rtol
        self.tolerance = tolerance
        self.margin = float("inf")

    def threads(self):
        """One BLAS thread (:class:`~observer_cad.numerics.SingleThreadBLAS`)."""
        return SingleThreadBLAS()

    # -- on sympy matrices (or arrays)
    @staticmethod
    def array(M) -> np.ndarray:
        """A numeric matrix as floats, every rational entry correctly rounded."""
        if isinstance(M, np.ndarray):
            return M
        return np_exact(M if isinstance(M, sp.MatrixBase) else sp.Matrix(M))

    def rank_evidence(self, M, *, atol=None, rtol=None):
        """The :class:`~observer_cad.numerics.FloatRank` of M (its SVD and cut)."""
        return float_rank(self.array(M), atol=atol, rtol=self.rtol if rtol is None else rtol)

    def rank(self, M, conds=None) -> int:
        return self.rank_evidence(M).rank

    def left_null_evidence(self, M, *, atol=None, rtol=None):
        """An orthonormal basis (rows) of the numerical left null space, and its
        :class:`~observer_cad.numerics.FloatRank`."""
        return float_left_null_space(self.array(M), atol=atol,
                                     rtol=self.rtol if rtol is None else rtol)

    def left_null_space(self, M, conds=None) -> np.ndarray:
        return self.left_null_evidence(M)[0]

    def product(self, A, B) -> np.ndarray:
        return self.array(A) @ self.array(B)

    def certify(self, plant: dict, mats: dict, **kw):
        """The design's identities, each residual's norm below ``tolerance``."""
        kw.setdefault("tolerance", self.tolerance)
        return certify_design(plant, mats, exact=False, **kw)

    @staticmethod
    def check_poles(F, H, K, eigenvalues) -> None:
        """The eigenvalues of F* − K H* are the recorded ones (each within 1e-6 relative of
        its nearest, in floating point)."""
        A = np_exact(sp.Matrix(F) - sp.Matrix(K) * sp.Matrix(H))
        got = np.sort_complex(np.linalg.eigvals(A))
        want = np.sort_complex(np.array([complex(sp.N(v)) for v in eigenvalues]))
        if not np.allclose(got, want, rtol=1e-6, atol=1e-9):
            raise UsageError("the design's closed-loop eigenvalues are not those of F* − K H*:"
                             " not a design this tool writes")

    @staticmethod
    def to_sympy(A) -> sp.Matrix:
        """A float array as a sympy matrix (exact zeros stay Integer 0)."""
        return to_sympy_float(A)

    # -- the representation: float arrays, unit rows (columns) where the scale is free
    def mat(self, M, scale="rows"):
        M = sp.Matrix(M)
        A = np_exact(M) if M.rows and M.cols else np.zeros(M.shape)
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
        tol = self.cut * max(sv[0] if sv.size else 0.0, 1.0)
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
        tol = self.cut * max(float(np.linalg.norm(d)), np.finfo(float).tiny)
        self.margin = min(self.margin, v / tol if v > tol else tol / max(v, np.finfo(float).tiny))
        return v > tol


def arithmetic(method: str, *mats, rtol: float | None = None) -> Arithmetic:
    """The strategy for ``method`` ("exact" or "float") and the matrices it will see:
    :class:`FloatArithmetic` for "float", else :class:`RationalArithmetic` when every
    matrix is rational, else :class:`ExactArithmetic` (parameters or algebraic numbers)."""
    if method == "float":
        return FloatArithmetic(rtol)
    if RationalArithmetic.accepts(*mats):
        return RationalArithmetic()
    return ExactArithmetic(any(sp.Matrix(M).free_symbols for M in mats))


def arithmetic_for(problem, *, rtol: float | None = None, exact=ExactArithmetic,
                   floating=FloatArithmetic) -> Arithmetic:
    """The strategy for a prepared problem (:func:`~observer_cad.synthesis.core.prepare`):
    ``floating(rtol)`` when its method is "float", else ``exact(symbolic)``, symbolic when
    parameters remain. A designer passes its own subclasses."""
    if problem.method == "float":
        return floating(rtol)
    return exact(problem.symbolic)
