"""Exact and floating-point linear algebra for synthesis.

Exact path: matrices over the rationals or over rational functions of the model's
parameters, through sympy's ``DomainMatrix`` (never ``Matrix.rank`` on expressions,
which is slow and can be silently wrong). Gauss–Jordan elimination is done here, on
domain elements, so that every pivot divided by is recorded: a rank with symbolic
parameters is *generic* and holds under the conditions ``pivot ≠ 0`` that
:class:`ExactRank` reports. Pivots are chosen to need as few conditions as possible
(nonzero constants first, then entries whose factors are already assumed, then the
simplest).

Rational matrices (no parameters) take a fast path with the same results: the reduced row
echelon form is unique, so it is computed by FLINT's ``fmpq_mat.rref`` (python-flint; sympy
then uses flint as its ground types and a rational ``Matrix`` converts to ``fmpq_mat``
without touching its entries), or, under the gmpy/python ground types, by sympy's
``DomainMatrix.rref(method="CD")`` (denominators cleared, fraction-free over ZZ). Measured
in ``benchmarks/bench_exact.py``; :func:`rational_rref` is the entry point.

The float path (SVD with a stated tolerance) is in :mod:`._float_rank`.
"""
from __future__ import annotations

import dataclasses
import functools

import sympy as sp
from sympy.external.gmpy import GROUND_TYPES
from sympy.polys.matrices import DomainMatrix

from ..errors import DimensionError

__all__ = ["ExactRank", "exact_rank", "left_null_space", "echelon_rows", "solve_left", "nonzero_conditions", "denominator_conditions", "to_domain_matrix", "rational_rref", "rational_left_null", "GrowingLeftNull", "left_null_echelon", "exact_rank_value", "as_rational", "from_rational", "RATIONAL_BACKEND", "exact_product", "number_field"]

#: Which code eliminates rational matrices: "flint" (``fmpq_mat.rref``, when sympy's ground
#: types are flint: python-flint installed) or "sympy-CD" (``DomainMatrix.rref(method="CD")``).
RATIONAL_BACKEND = "flint" if GROUND_TYPES == "flint" else "sympy-CD"


# ---------------------------------------------------------------- conditions
def nonzero_conditions(expr) -> frozenset:
    """See :func:`_nonzero_conditions` (cached: pivot choice asks for the same entries often)."""
    return _nonzero_conditions(sp.sympify(expr))


@functools.lru_cache(maxsize=8192)
def _nonzero_conditions(expr) -> frozenset:
    """The irreducible polynomial factors f of a nonzero expression's numerator,
    returned as relations ``Ne(f, 0)``: the expression is nonzero iff none vanishes.

    Constant factors give nothing. Signs are normalised (``Ne(k4, 0)``, never
    ``Ne(-k4, 0)``).
    """
    expr = sp.sympify(expr)
    if not expr.free_symbols:
        return frozenset()
    num, _ = sp.fraction(sp.cancel(sp.together(expr)))
    _, factors = sp.factor_list(num)
    return frozenset(sp.Ne(g, 0) for g in map(_normalised_factor, (f for f, _m in factors))
                     if g is not None)


def _normalised_factor(f):
    """A factor as the conditions write it: expanded, its sign normalised (``k4``, never
    ``-k4``); None for a constant (it gives no condition)."""
    if not f.free_symbols:
        return None
    return sp.expand(-f if f.could_extract_minus_sign() else f)


def denominator_conditions(expr) -> frozenset:
    """``Ne(f, 0)`` for every irreducible factor f of an expression's denominator."""
    expr = sp.sympify(expr)
    if not expr.free_symbols:
        return frozenset()
    _, den = sp.fraction(sp.cancel(sp.together(expr)))
    return nonzero_conditions(den)


# ---------------------------------------------------------------- exact path
def to_domain_matrix(M) -> DomainMatrix:
    """A sympy Matrix as a DomainMatrix over a field (QQ, or QQ(params), or EX)."""
    M = sp.Matrix(M)
    dm = DomainMatrix.from_Matrix(M)
    if dm.domain.is_EX:  # algebraic numbers (e.g. an irrational λ): an algebraic field
        fast = _algebraic_domain_matrix(M) if not M.free_symbols else None
        if fast is not None:
            return fast
        try:
            dm2 = DomainMatrix.from_Matrix(M, extension=True)
            if not dm2.domain.is_EX:
                dm = dm2
        except Exception:  # pragma: no cover - sympy could not build the extension
            pass
    return dm.to_field()


def _algebraic_domain_matrix(M) -> DomainMatrix | None:
    """A matrix of algebraic numbers over QQ(θ), θ a primitive element of the numbers it
    is built from; None when an entry is not such a number.

    What ``DomainMatrix.from_Matrix(M, extension=True)`` does, with two differences that
    make it cheap when it is asked again and again (the Jordan search ranks many matrices
    built from the same irrational λ): an integer power ``a**j`` (negative too) is
    arithmetic on ``a``, not a generator of its own (sympy takes λ, λ², 1/λ, … as
    separate generators and searches a primitive element of all of them: 0.5–3 s for one
    matrix), and the field of a set of generators is built once (:func:`_algebraic_field`).
    """
    leaves: set = set()

    def tree(a):
        if a.is_Rational:
            return ("Q", sp.QQ.from_sympy(a))
        if a.is_Add or a.is_Mul:
            return ("+" if a.is_Add else "*", [tree(b) for b in a.args])
        if a.is_Pow and a.exp.is_Integer and not a.base.is_Rational:
            return ("^", tree(a.base), int(a.exp))
        if not a.is_number or a.is_algebraic is not True:
            raise ValueError(a)
        leaves.add(a)
        return ("e", a)

    try:
        trees = [tree(sp.sympify(e)) for e in M]
        if not leaves:
            return None
        K, emap = _algebraic_field(tuple(sp.ordered(leaves)))

        def value(t):
            op = t[0]
            if op == "Q":
                return K.convert(t[1], sp.QQ)
            if op == "+":
                return sum((value(b) for b in t[1]), K.zero)
            if op == "*":
                out = K.one
                for b in t[1]:
                    out = out * value(b)
                return out
            if op == "^":
                base = value(t[1])
                return base ** t[2] if t[2] >= 0 else K.one / base ** (-t[2])
            return emap[t[1]]

        flat = [value(t) for t in trees]
    except Exception:  # noqa: BLE001 - what this cannot read, sympy's own conversion reads
        return None
    r, c = M.shape
    return DomainMatrix([flat[i * c:(i + 1) * c] for i in range(r)], (r, c), K)


def exact_product(A, B) -> sp.Matrix:
    """A B with every entry in a canonical exact form: ``(A * B).applyfunc(sp.cancel)``,
    computed in QQ(θ) when the entries are algebraic numbers (:func:`to_domain_matrix`;
    sympy's ``cancel`` of sums of products of ``CRootOf`` took seconds a row), and zero
    exactly when the value is."""
    A, B = _matrix(A), _matrix(B)
    if A.cols != B.rows:
        raise ValueError(f"exact_product: shapes {A.shape} and {B.shape} do not match")
    if 0 in A.shape or 0 in B.shape or A.free_symbols or B.free_symbols:
        return (A * B).applyfunc(sp.cancel)
    ra, rb = as_rational(A), as_rational(B)
    if ra is not None and rb is not None:
        return from_rational(ra * rb)
    dm = _algebraic_domain_matrix(sp.diag(A, B))
    if dm is None:
        return (A * B).applyfunc(sp.cancel)
    a = dm.extract(list(range(A.rows)), list(range(A.cols)))
    b = dm.extract(list(range(A.rows, A.rows + B.rows)), list(range(A.cols, A.cols + B.cols)))
    return (a * b).to_Matrix()


def number_field(gens):
    """QQ(θ) containing the algebraic numbers ``gens`` (built once per set of numbers)."""
    return _algebraic_field(tuple(sp.ordered(set(gens))))[0]


@functools.lru_cache(maxsize=64)
def _algebraic_field(exts: tuple):
    """QQ(θ) for the algebraic numbers ``exts`` (θ a primitive element) and each of them
    as an element of it — as sympy's ``construct_domain(..., extension=True)`` builds
    them, kept for the next matrix made of the same numbers."""
    from sympy.polys.numberfields import primitive_element

    g, span, H = primitive_element(list(exts), ex=True, polys=True)
    root = sum(s * e for s, e in zip(span, exts))
    K = sp.QQ.algebraic_field((g, root))
    gl = g.rep.to_list()
    return K, {e: K.dtype.from_list(h, gl, sp.QQ) for e, h in zip(exts, H)}


def _constant(K, e) -> bool:
    """Is the nonzero entry e a constant (assuming e ≠ 0 costs nothing)?"""
    try:
        if K.is_QQ or K.is_ZZ:
            return True
        if hasattr(e, "numer") and hasattr(e, "denom") and hasattr(e.numer, "is_ground"):
            return bool(e.numer.is_ground)
        return not K.to_sympy(e).free_symbols
    except Exception:  # pragma: no cover - exotic domains
        return False


def _cost(K, e, assumed: set) -> tuple:
    """How expensive is it to assume e ≠ 0 (lower is better): (1, conditions not yet
    assumed, conditions, operations), constants (0, 0, 0, 0)."""
    if _constant(K, e):
        return (0, 0, 0, 0)
    expr = K.to_sympy(e)
    factors = _factors_in_domain(K, e)
    if factors is None or any(len(getattr(g, "assumptions0", {})) > 1
                              for g in getattr(K, "symbols", ())):
        # (symbols with assumptions, e.g. positive: nonzero_conditions may evaluate a
        # relation to true, which the factors compared below would not)
        conds = nonzero_conditions(expr)
        return (1, len(conds - assumed), len(conds), sp.count_ops(expr))
    # the factors as nonzero_conditions normalises them, compared with the assumed
    # relations' left sides (no relation built: evaluating Ne on a long polynomial is slow)
    have = {a.lhs for a in assumed if isinstance(a, sp.Ne)}
    return (1, sum(f not in have for f in factors), len(factors), sp.count_ops(expr))


def _factors_in_domain(K, e):
    """The nonconstant irreducible factors of the numerator of e, factored in the domain
    (a polynomial ring or rational function field), each as ``nonzero_conditions`` writes
    it (expanded, sign normalised); None for other domains, and for a ground field other
    than the rationals (over QQ(√2), say, k² − 2 would split into factors that
    ``nonzero_conditions``, factoring over the rationals, keeps whole)."""
    try:
        if not (K.domain.is_QQ or K.domain.is_ZZ):
            return None
        if K.is_FractionField:
            num = e.numer
        elif K.is_PolynomialRing:
            num = e
        else:
            return None
        _, facs = num.factor_list()
    except Exception:  # pragma: no cover - a domain without factorisation
        return None
    out = {_normalised_factor(f.as_expr()) for f, _m in facs}
    out.discard(None)
    return out


@dataclasses.dataclass(frozen=True)
class ExactRank:
    """Result of exact Gauss–Jordan elimination.

    ``rank``; ``pivots`` (pivot column of each row, full pivoting); ``conditions``: relations ``Ne(f, 0)`` under
    which the rank holds (empty for rational matrices: then the rank is exact).
    """

    rank: int
    pivots: tuple
    conditions: frozenset
    reduced: sp.Matrix  # the eliminated matrix (rows beyond the rank are zero)

    @property
    def generic(self) -> bool:
        return bool(self.conditions)


def _gauss_jordan(dm: DomainMatrix, assumed: set | None = None, *, full: bool = False):
    """Gauss–Jordan elimination over a field, recording the pivots' conditions.

    With ``full=False`` the pivot columns are the leftmost possible (reduced row
    echelon form). With ``full=True`` any remaining column may give the pivot, so that
    nonzero constants are preferred and a symbolic rank needs the fewest conditions;
    rows then have a 1 in their pivot column and zeros in the other pivot columns.
    Returns ``(K, rows, pivot_columns, new_conditions)``; rows beyond the rank are zero.
    """
    K = dm.domain
    rows = [list(r) for r in dm.to_dense().rep.to_ddm()]
    nr, nc = dm.shape
    pivots: list = []
    conds: set = set(assumed or ())
    new_conds: set = set()
    r = 0
    cols = list(range(nc))
    while r < nr and cols:
        if full:
            cands = [(i, c) for c in cols for i in range(r, nr) if not K.is_zero(rows[i][c])]
        else:
            cands = []
            for c in list(cols):
                cands = [(i, c) for i in range(r, nr) if not K.is_zero(rows[i][c])]
                if cands:
                    break
                cols.remove(c)
        if not cands:
            break
        # a constant pivot costs nothing: the first one (leftmost column, then topmost
        # row) is what the cost order picks, without factoring every other candidate
        free = [ic for ic in cands if _constant(K, rows[ic[0]][ic[1]])]
        if free:
            bi, bc = min(free, key=lambda ic: (ic[1], ic[0]))
        else:
            bi, bc = min(cands, key=lambda ic: (_cost(K, rows[ic[0]][ic[1]], conds), ic[1],
                                                ic[0]))
        rows[r], rows[bi] = rows[bi], rows[r]
        p = rows[r][bc]
        pc = nonzero_conditions(K.to_sympy(p)) if not (K.is_QQ or K.is_ZZ) else frozenset()
        new_conds |= pc
        conds |= pc
        inv = K.quo(K.one, p)
        rows[r] = [K.mul(v, inv) for v in rows[r]]
        for i in range(nr):
            if i != r and not K.is_zero(rows[i][bc]):
                fac = rows[i][bc]
                rows[i] = [K.sub(a, K.mul(fac, b)) for a, b in zip(rows[i], rows[r])]
        pivots.append(bc)
        cols.remove(bc)
        r += 1
    return K, rows, tuple(pivots), frozenset(new_conds)


def _domain_matrix(M) -> DomainMatrix:
    """:func:`to_domain_matrix`, without the conversion for a matrix of rational numbers:
    sympy already keeps such a ``Matrix`` as a DomainMatrix over ZZ or QQ."""
    rep = getattr(M, "_rep", None)
    if isinstance(rep, DomainMatrix) and (rep.domain.is_ZZ or rep.domain.is_QQ):
        return rep.convert_to(sp.QQ)
    return to_domain_matrix(M)


def _to_matrix(dm: DomainMatrix) -> sp.Matrix:
    """A DomainMatrix over QQ as a sympy Matrix, entries untouched (no sympification)."""
    return sp.Matrix._fromrep(dm.to_sparse())


def as_rational(M) -> DomainMatrix | None:
    """A matrix of rational numbers as a dense DomainMatrix over QQ (FLINT's ``fmpq_mat``
    under flint ground types: products and eliminations in C), else ``None``.

    For hot loops over rational matrices (Krylov blocks, Φ from a null-space member,
    certificates): ``as_rational(A) * as_rational(B)`` then :func:`from_rational`.
    """
    if isinstance(M, DomainMatrix):
        dm = M
    else:
        rep = getattr(M, "_rep", None)
        if not isinstance(rep, DomainMatrix):
            rep = getattr(sp.Matrix(M), "_rep", None)
        dm = rep
    if not isinstance(dm, DomainMatrix) or not (dm.domain.is_ZZ or dm.domain.is_QQ):
        return None
    return dm.convert_to(sp.QQ).to_dense()


def from_rational(dm: DomainMatrix) -> sp.Matrix:
    """The sympy Matrix of a DomainMatrix over QQ (see :func:`as_rational`)."""
    return _to_matrix(dm)


def rational_rref(M) -> tuple:
    """Reduced row echelon form of a rational matrix: ``(R, pivots)``.

    ``M`` a sympy Matrix of rational numbers or a DomainMatrix over ZZ or QQ; ``R`` a
    DomainMatrix over QQ of the same shape (rows beyond the rank zero), ``pivots`` the pivot
    column of each nonzero row. The form is unique, so every backend gives the same
    ``R``: FLINT's ``fmpq_mat.rref`` when sympy's ground types are flint, else sympy's
    ``DomainMatrix.rref(method="CD")`` (see :data:`RATIONAL_BACKEND`).
    """
    dm = M if isinstance(M, DomainMatrix) else _domain_matrix(M)
    if not dm.domain.is_QQ:
        dm = dm.convert_to(sp.QQ)
    nr, nc = dm.shape
    if nr == 0 or nc == 0:
        return dm, ()
    if RATIONAL_BACKEND == "flint":
        from sympy.polys.matrices._dfm import DFM

        R, rank = dm.to_dense().rep.rep.rref()  # DomainMatrix → DFM → flint.fmpq_mat
        pivots, c = [], 0
        for i in range(rank):
            while R[i, c] == 0:
                c += 1
            pivots.append(c)
            c += 1
        return DomainMatrix.from_rep(DFM(R, (nr, nc), sp.QQ)), tuple(pivots)
    R, pivots = dm.rref(method="CD")
    return R, tuple(pivots)


def _null_rows(R: DomainMatrix, pivots, m: int) -> DomainMatrix:
    """The null space {x : R x = 0} of a reduced row echelon R (m columns), one row per
    non-pivot column f: 1 at f, −R[i, f] at pivot column i, zero elsewhere."""
    K = R.domain
    rows = R.to_list()[:len(pivots)]
    free = [f for f in range(m) if f not in set(pivots)]
    out = []
    for f in free:
        v = [K.zero] * m
        v[f] = K.one
        for i, p in enumerate(pivots):
            v[p] = -rows[i][f]
        out.append(v)
    return DomainMatrix(out, (len(out), m), K)


def _matrix(M) -> sp.MatrixBase:
    """M as a sympy matrix, without copying one (copying converts every entry)."""
    return M if isinstance(M, sp.MatrixBase) else sp.Matrix(M)


def exact_rank(M, assumed=()) -> ExactRank:
    """Rank of a matrix over QQ or QQ(parameters), with the conditions it needs.

    Examples
    --------
    A rational matrix has an exact rank; with a parameter the rank is generic, and the
    result names the relations it rests on:

    >>> import sympy as sp
    >>> from observer_cad.numerics import exact_rank
    >>> exact_rank(sp.Matrix([[1, 2], [2, 4]])).rank
    1
    >>> k = sp.Symbol("k")
    >>> r = exact_rank(sp.Matrix([[1, k], [k, 1]]))
    >>> r.rank, sorted(map(str, r.conditions))
    (2, ['Ne(k + 1, 0)', 'Ne(k - 1, 0)'])
    """
    M = _matrix(M)
    if M.rows == 0 or M.cols == 0:
        return ExactRank(0, (), frozenset(), M)
    dm = _domain_matrix(M)
    if dm.domain.is_QQ:
        R, pivots = rational_rref(dm)
        return ExactRank(len(pivots), pivots, frozenset(), _to_matrix(R))
    K, rows, pivots, conds = _gauss_jordan(dm, set(assumed), full=True)
    R = sp.Matrix([[K.to_sympy(v) for v in row] for row in rows])
    return ExactRank(len(pivots), pivots, conds, R)


def left_null_space(M, assumed=()):
    """Basis of {v : v M = 0} (list of 1×rows matrices) and the rank's conditions.

    Returns ``(basis, ExactRank of M)``. The basis comes from the eliminated Mᵀ: one
    vector per non-pivot column, with a 1 there. ``M`` may also be a DomainMatrix over QQ
    (see :func:`as_rational`).

    Examples
    --------
    >>> import sympy as sp
    >>> from observer_cad.numerics import left_null_space
    >>> basis, rank = left_null_space(sp.Matrix([[1, 2], [2, 4], [0, 1]]))
    >>> basis, rank.rank
    ([Matrix([[-2, 1, 0]])], 2)
    """
    if isinstance(M, DomainMatrix):
        m, nc = M.shape
        dm = M.convert_to(sp.QQ).transpose()
    else:
        M = _matrix(M)
        m, nc = M.shape
        dm = None
    if nc == 0:
        return [sp.Matrix([[1 if j == i else 0 for j in range(m)]]) for i in range(m)], \
            ExactRank(0, (), frozenset(), sp.zeros(0, m))
    if dm is None:
        dm = _domain_matrix(M.T)
    if dm.domain.is_QQ:
        R, pivots = rational_rref(dm)
        N = _null_rows(R, pivots, m)
        basis = [_to_matrix(N[i:i + 1, :]) for i in range(N.shape[0])]
        return basis, ExactRank(len(pivots), pivots, frozenset(), _to_matrix(R))
    K, rows, pivots, conds = _gauss_jordan(dm, set(assumed), full=True)
    basis = []
    for f in range(m):
        if f in pivots:
            continue
        v = [K.zero] * m
        v[f] = K.one
        for i, p in enumerate(pivots):
            v[p] = K.neg(rows[i][f])
        basis.append(sp.Matrix([[sp.cancel(K.to_sympy(e)) for e in v]]))
    R = sp.Matrix([[K.to_sympy(v) for v in row] for row in rows])
    return basis, ExactRank(len(pivots), pivots, conds, R)


def left_null_echelon(M, assumed=()):
    """The left null space {v : v M = 0} as its reduced row echelon basis (what
    :func:`echelon_rows` of :func:`left_null_space` gives), and the rank of M.

    Returns ``(members, ExactRank of M)``. For a rational M this is one elimination, not
    two: eliminating Mᵀ with its columns in reverse order, the null vector of each free
    column f has its 1 at f, zeros at the other free columns and entries only at pivot
    columns right of f, which is the reduced echelon form of the null space (unique).
    The ExactRank's pivots are then the pivot columns of that reversed elimination, as
    indices of M's rows.
    """
    if isinstance(M, DomainMatrix):
        dm = M.convert_to(sp.QQ)
    else:
        M = _matrix(M)
        dm = _domain_matrix(M) if M.rows and M.cols else None
    if dm is None or not dm.domain.is_QQ:
        basis, rk = left_null_space(M, assumed)
        return echelon_rows(basis), rk
    m, nc = dm.shape
    if nc == 0:
        return [sp.Matrix([[1 if j == i else 0 for j in range(m)]]) for i in range(m)], \
            ExactRank(0, (), frozenset(), sp.zeros(0, m))
    N, R, pivots = _left_null_echelon(dm)
    members = [_to_matrix(N[i:i + 1, :]) for i in range(N.shape[0])]
    return members, ExactRank(len(pivots), tuple(m - 1 - p for p in pivots), frozenset(),
                              _to_matrix(R))


def _left_null_echelon(dm: DomainMatrix):
    """(N, R, pivots): N the echelon left null basis of dm (over QQ, at least one column),
    R and pivots the reversed elimination of dmᵀ."""
    m, nc = dm.shape
    rev = list(range(m - 1, -1, -1))
    R, pivots = rational_rref(dm.extract(rev, list(range(nc))).transpose())
    N = _null_rows(R, pivots, m)  # columns in reverse order
    return N.extract(list(range(N.shape[0] - 1, -1, -1)), rev), R, pivots


def rational_left_null(M: DomainMatrix) -> DomainMatrix:
    """The reduced echelon basis (rows, over QQ) of {v : v M = 0} for a DomainMatrix over
    ZZ or QQ; see :func:`left_null_echelon`."""
    dm = M.convert_to(sp.QQ)
    m, nc = dm.shape
    if nc == 0:
        return DomainMatrix.eye(m, sp.QQ)
    if m == 0:
        return DomainMatrix.zeros((0, 0), sp.QQ)
    return _left_null_echelon(dm)[0]


def _solve_square(A: DomainMatrix, B: DomainMatrix) -> DomainMatrix:
    """X with A X = B for a nonsingular square A over QQ (FLINT's ``fmpq_mat.solve`` under
    flint ground types, else the reduced form of (A B))."""
    n = A.shape[0]
    if n == 0 or B.shape[1] == 0:
        return DomainMatrix.zeros((n, B.shape[1]), sp.QQ).to_dense()
    if RATIONAL_BACKEND == "flint":
        return A.to_dense().lu_solve(B.to_dense())
    R, pivots = rational_rref(A.hstack(B))
    if len(pivots) < n or pivots[-1] >= n:  # pragma: no cover - A is nonsingular by construction
        raise ArithmeticError("singular system in _solve_square")
    return R.extract(list(range(n)), list(range(n, n + B.shape[1])))


def _scatter(X: DomainMatrix, cols, width: int) -> DomainMatrix:
    """The matrix with X's columns at positions ``cols`` of ``width`` columns, zero elsewhere."""
    K = sp.QQ
    rows = X.to_list()
    out = [[K.zero] * width for _ in rows]
    for i, row in enumerate(rows):
        for j, c in enumerate(cols):
            out[i][c] = row[j]
    return DomainMatrix(out, (len(rows), width), K).to_dense()


@dataclasses.dataclass(frozen=True, eq=False)
class GrowingLeftNull:
    """The left null space of a rational matrix, kept while the matrix grows by rows on
    top (:meth:`grow`): the search over k of the canonical form (METHOD §2a), where
    (W⁽ᵏ⁺¹⁾ L⁽ᵏ⁺¹⁾) is (W⁽ᵏ⁾ L⁽ᵏ⁾) with a zero column block inserted and l rows on top.

    For M (m × c) over QQ: ``null``, the reduced echelon basis of {v : v M = 0} (rows;
    exactly what :func:`rational_left_null` gives, the form being unique), and ``rows``
    B, rank M independent rows of M (the rows that are not leading positions of
    ``null``). ``columns``, ``kernel`` and ``kernel_columns`` are what :meth:`grow`
    reuses, ``None`` until it needs them (:meth:`with_kernel`): C, as many columns as B
    with M[B, C] nonsingular, and the basis (rows) of {z : M z = 0} that is the identity
    on the other columns: row i has its 1 at column ``kernel_columns[i]``, zeros at the
    others.
    """

    matrix: DomainMatrix
    null: DomainMatrix
    rows: tuple
    columns: tuple | None = None
    kernel: DomainMatrix | None = None
    kernel_columns: tuple | None = None

    @property
    def rank(self) -> int:
        return len(self.rows)

    @property
    def null_pivots(self) -> tuple:
        """The leading column of each row of ``null``: the rows of M not in ``rows``."""
        B = set(self.rows)
        return tuple(i for i in range(self.matrix.shape[0]) if i not in B)

    @classmethod
    def of(cls, M: DomainMatrix) -> "GrowingLeftNull":
        """The state of M (a DomainMatrix over ZZ or QQ), from scratch: the full-rank
        certificate of :func:`exact_rank_value` when M has no more rows than columns, else
        one elimination (:func:`rational_left_null`)."""
        dm = M.convert_to(sp.QQ).to_dense()
        m, c = dm.shape
        if m == 0 or c == 0:
            return cls(dm, DomainMatrix.eye(m, sp.QQ).to_dense(), ())
        if m <= c and _full_rank_certified(dm):
            return cls(dm, DomainMatrix.zeros((0, m), sp.QQ).to_dense(), tuple(range(m)))
        null, _, piv = _left_null_echelon(dm)
        return cls(dm, null, tuple(sorted(m - 1 - p for p in piv)))

    def with_kernel(self) -> "GrowingLeftNull":
        """This state with ``columns`` and ``kernel`` (one elimination of M unless it has
        full column rank)."""
        if self.kernel is not None:
            return self
        m, c = self.matrix.shape
        if self.rank == c:
            C, kernel = tuple(range(c)), DomainMatrix.zeros((0, c), sp.QQ).to_dense()
        else:
            R, C = rational_rref(self.matrix)
            kernel = _null_rows(R, C, c).to_dense()
        Cset = set(C)
        return dataclasses.replace(self, columns=tuple(C), kernel=kernel,
                                   kernel_columns=tuple(j for j in range(c) if j not in Cset))

    def grow(self, top: DomainMatrix, *, at: int, width: int) -> "GrowingLeftNull":
        """The state of

            M' = [ top                                                ]
                 [ M with ``width`` zero columns inserted at column ``at`` ]

        (``top``: l rows, c + ``width`` columns, over ZZ or QQ).

        Method. v = (s, x) is in the left null space of M' iff s T = 0 (T the inserted
        columns of ``top``) and s A + x M = 0 (A the rest of ``top``). The second is
        solvable iff s A is in the row space of M, i.e. s A Kᵀ = 0 for the kernel K, so the
        s form the left null space S of G = (T, A Kᵀ), an l-row matrix. The reduced echelon
        basis of the new null space is (sᵢ, xᵢ) for the reduced echelon basis sᵢ of S,
        xᵢ = −sᵢ Y with Y M[B, :] = A on the columns C (one square solve; xᵢ M = −sᵢ A
        because sᵢ A is in the row space), reduced against the old basis, followed by
        (0, old basis). The rows of ``top`` at the non-leading positions of S join B; the
        pivot columns of G's reduced form join C (the Schur complement of M[B, C] in
        M'[B', C'] is those columns of G); G's right kernel gives the new kernel.

        This reuses M's null space when it has one and M's kernel has at most ``width``
        vectors (in the search over k: once the null space has appeared, when the kernel
        comes only from the inserted columns, e.g. H L = 0). Otherwise M' is eliminated
        from scratch (:meth:`of`): there is no basis to reuse, or the kernel of a wide
        matrix costs more than the elimination it spares (measured in
        ``benchmarks/bench_exact.py``).
        """
        K = sp.QQ
        m, c = self.matrix.shape
        l = top.shape[0]
        if top.shape[1] != c + width or not 0 <= at <= c:
            raise DimensionError(f"GrowingLeftNull.grow: the new rows have {top.shape[1]}"
                                 f" columns, expected {c} + width {width}, inserted at"
                                 f" 0 <= at = {at} <= {c}")
        top = top.convert_to(K).to_dense()
        zeros = DomainMatrix.zeros
        every, old_rows = list(range(l)), list(range(m))
        grown = top.vstack(zeros((m, 0), K).to_dense().hstack(
            self.matrix.extract(old_rows, list(range(at))), zeros((m, width), K).to_dense(),
            self.matrix.extract(old_rows, list(range(at, c)))))
        if not self.null.shape[0] or c - self.rank > width:
            return GrowingLeftNull.of(grown)
        base = self.with_kernel()
        old = [j if j < at else j + width for j in range(c)]  # column j of M → column of M'
        ins = list(range(at, at + width))
        A = top.extract(every, old)
        G = top.extract(every, ins)
        if base.kernel.shape[0]:
            G = G.hstack(A * base.kernel.transpose())
        g = G.shape[1]
        # S: the starts s of null vectors; T: rows of top independent modulo M's row space
        if g:
            S, _, piv = _left_null_echelon(G)
            T = tuple(sorted(l - 1 - p for p in piv))
            RG, PG = rational_rref(G)
        else:
            S, T, RG, PG = DomainMatrix.eye(l, K).to_dense(), (), G, ()
        d = S.shape[0]
        null = zeros((self.null.shape[0], l), K).to_dense().hstack(self.null)
        if d:
            C = list(base.columns)
            Y = _solve_square(self.matrix.extract(list(self.rows), C).transpose(),
                              A.extract(every, C).transpose()).transpose()
            x = _scatter(-(S * Y), self.rows, m)
            x = x - x.extract(list(range(d)), list(self.null_pivots)) * self.null
            null = S.hstack(x).vstack(null)
        # the next step's B, C and kernel
        gcol = ins + [old[q] for q in base.kernel_columns]  # G's column → column of M'
        PGset = set(PG)
        free = [j for j in range(g) if j not in PGset]
        if free:
            Y = _null_rows(RG, PG, g).to_dense()
            kept = list(range(len(free)))
            Yk = Y.extract(kept, list(range(width, g))) * base.kernel if base.kernel.shape[0] \
                else zeros((len(free), c), K).to_dense()
            kernel = Yk.extract(kept, list(range(at))).hstack(
                Y.extract(kept, list(range(width))), Yk.extract(kept, list(range(at, c))))
        else:
            kernel = zeros((0, c + width), K).to_dense()
        return GrowingLeftNull(
            grown, null, T + tuple(i + l for i in self.rows),
            tuple(old[j] for j in base.columns) + tuple(gcol[j] for j in PG),
            kernel, tuple(gcol[j] for j in free))


def exact_rank_value(M) -> int:
    """The exact rank alone (no conditions: for a matrix over QQ(parameters) it is the
    generic rank, see :func:`exact_rank`).

    A rational matrix whose integer numerator has full rank modulo the prime 2⁶¹ − 1 has
    full rank over QQ (a minor nonzero mod p is nonzero): that certificate costs
    milliseconds with FLINT's ``nmod_mat``; any other case is eliminated exactly.
    """
    dm = M.convert_to(sp.QQ) if isinstance(M, DomainMatrix) else None
    if dm is None:
        M = _matrix(M)
        if M.rows == 0 or M.cols == 0:
            return 0
        dm = _domain_matrix(M)
        if dm.domain.is_AlgebraicField:  # numbers: the pivot order does not matter
            return dm.rank()
        if not dm.domain.is_QQ:  # what exact_rank(M).rank is, without converting M again
            return len(_gauss_jordan(dm, set(), full=True)[2])
    if 0 in dm.shape:
        return 0
    if _full_rank_certified(dm):
        return min(dm.shape)
    return len(rational_rref(dm)[1])


def _full_rank_certified(dm: DomainMatrix) -> bool:
    """True if the integer numerator of dm (over QQ, no zero dimension) has full rank
    modulo :data:`_PRIME` (then dm has full rank over QQ); False if not or without FLINT."""
    if RATIONAL_BACKEND != "flint":
        return False
    import flint

    num, _den = dm.to_dense().rep.rep.numer_denom()
    return flint.nmod_mat(num, _PRIME).rank() == min(dm.shape)


#: The prime of :func:`exact_rank_value`'s full-rank certificate (the Mersenne prime 2⁶¹ − 1).
_PRIME = 2 ** 61 - 1


def echelon_rows(vectors) -> list:
    """Reduced row echelon basis of the span of the given row vectors.

    Its first member has the leftmost possible leading entry, normalised to 1, and zeros
    in the other members' leading positions: the sparsest, most readable members.
    """
    if not vectors:
        return []
    M = sp.Matrix.vstack(*vectors)
    dm = _domain_matrix(M)
    if dm.domain.is_QQ:
        R, pivots = rational_rref(dm)
        return [_to_matrix(R[i:i + 1, :]) for i in range(len(pivots))]
    K, rows, pivots, _ = _gauss_jordan(dm)
    return [sp.Matrix([[sp.cancel(K.to_sympy(e)) for e in rows[i]]]) for i in range(len(pivots))]


def solve_left(A, B, assumed=()):
    """Solve X A = B exactly; return X (one particular solution) or None.

    Free variables are set to zero.
    """
    A = _matrix(A)
    B = _matrix(B)
    # X A = B  <=>  Aᵀ Xᵀ = Bᵀ ; reduce [Aᵀ | Bᵀ]
    aug = sp.Matrix.hstack(A.T, B.T)
    dm = _domain_matrix(aug)
    na = A.rows
    if dm.domain.is_QQ:
        R, pivots = rational_rref(dm)
        if any(p >= na for p in pivots):
            return None
        rows = R.to_list()
        K = R.domain
        X = [[K.zero] * na for _ in range(B.rows)]
        for i, p in enumerate(pivots):
            for j in range(B.rows):
                X[j][p] = rows[i][na + j]
        return _to_matrix(DomainMatrix(X, (B.rows, na), K))
    K, rows, pivots, _ = _gauss_jordan(dm, set(assumed))
    if any(p >= na for p in pivots):
        return None
    X = sp.zeros(B.rows, na)
    for i, p in enumerate(pivots):
        for j in range(B.rows):
            X[j, p] = sp.cancel(K.to_sympy(rows[i][na + j]))
    return X
