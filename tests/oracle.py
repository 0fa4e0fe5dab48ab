"""Independent oracles for the tests: plain Fraction arithmetic, no sympy DomainMatrix."""
from fractions import Fraction


def frac_rank(rows) -> int:
    """Rank of a rational matrix by Gaussian elimination over fractions.Fraction."""
    M = [[Fraction(str(v)) if not isinstance(v, Fraction) else v for v in row] for row in rows]
    if not M:
        return 0
    r = 0
    ncol = len(M[0])
    for c in range(ncol):
        piv = next((i for i in range(r, len(M)) if M[i][c] != 0), None)
        if piv is None:
            continue
        M[r], M[piv] = M[piv], M[r]
        for i in range(len(M)):
            if i != r and M[i][c] != 0:
                f = M[i][c] / M[r][c]
                M[i] = [a - f * b for a, b in zip(M[i], M[r])]
        r += 1
        if r == len(M):
            break
    return r


def matmul(A, B):
    return [[sum(A[i][t] * B[t][j] for t in range(len(B))) for j in range(len(B[0]))]
            for i in range(len(A))]


def krylov_stack(F, H, L, k):
    """(W^(k) L^(k)) built from lists of Fractions, written independently of the package."""
    l = len(H)
    n = len(F)
    p = len(L[0]) if L and L[0] else 0
    HF = [H]
    for _ in range(k):
        HF.append(matmul(HF[-1], F))
    rows = []
    for i in range(k + 1):  # block row i pairs with H F^(k-i)
        blk = HF[k - i]
        for r in range(l):
            row = list(blk[r])
            for j in range(k):  # block column j: H F^(j-i) L if j >= i
                if p == 0:
                    continue
                if j >= i:
                    hfl = matmul(HF[j - i], L)
                    row += hfl[r]
                else:
                    row += [Fraction(0)] * p
            rows.append(row)
    return rows


def frac_left_null_space(rows):
    """Basis of {v : v M = 0} over the rationals (Fractions), independent of sympy."""
    m = len(rows)
    if m == 0:
        return []
    ncol = len(rows[0])
    # eliminate M^T (ncol x m)
    T = [[Fraction(rows[i][j]) for i in range(m)] for j in range(ncol)]
    pivots = []
    r = 0
    for c in range(m):
        piv = next((i for i in range(r, len(T)) if T[i][c] != 0), None)
        if piv is None:
            continue
        T[r], T[piv] = T[piv], T[r]
        inv = T[r][c]
        T[r] = [a / inv for a in T[r]]
        for i in range(len(T)):
            if i != r and T[i][c] != 0:
                f = T[i][c]
                T[i] = [a - f * b for a, b in zip(T[i], T[r])]
        pivots.append(c)
        r += 1
        if r == len(T):
            break
    basis = []
    for f in range(m):
        if f in pivots:
            continue
        v = [Fraction(0)] * m
        v[f] = Fraction(1)
        for i, p in enumerate(pivots):
            v[p] = -T[i][f]
        basis.append(v)
    return basis
