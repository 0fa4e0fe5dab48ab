"""The search over k, incremental: the null spaces of (W⁽ᵏ⁾ L⁽ᵏ⁾) that
:func:`krylov_null_spaces` grows from one k to the next are, for every k, exactly the
reduced echelon bases that eliminating (W⁽ᵏ⁾ L⁽ᵏ⁾) from scratch gives
(:func:`left_null_echelon`), and the ranks are those of a Fraction elimination of the
matrix written out independently (tests/oracle.py).

Seeded random rational plants, n = 1 … 12, l = 1 … 4, with and without decoupled inputs,
dense and sparse F, redundant outputs (dependent rows of H) and disturbances that do not
reach y directly (H L = 0), which keep a kernel across k. Seed 004's variant (J* acting on
H0 = [H; M]) grows two matrices; its members are checked against the recurrence they
stand for.
"""
import random
from fractions import Fraction

import pytest
import sympy as sp

from observer_cad.numerics import GrowingLeftNull, left_null_echelon
from observer_cad.synthesis import krylov_blocks, krylov_null_spaces

from oracle import frac_rank, krylov_stack


def _rational(rng, density):
    if rng.random() >= density:
        return Fraction(0)
    return Fraction(rng.randint(-4, 4), rng.randint(1, 3))


def random_plant(rng, n, l, p, kind):
    density = 0.35 if kind == "sparse" else 1.0
    F = [[_rational(rng, density) for _ in range(n)] for _ in range(n)]
    H = [[_rational(rng, 1.0) for _ in range(n)] for _ in range(l)]
    L = [[_rational(rng, 1.0) for _ in range(p)] for _ in range(n)]
    if kind == "redundant" and l >= 2:  # a redundant sensor
        H[-1] = [a - 2 * b for a, b in zip(H[0], H[1])]
    if kind == "HL = 0" and p and n > l:  # the disturbances enter a state H does not see
        for i in range(l):
            H[i][0] = Fraction(0)
        L = [[Fraction(int(i == 0)) for _ in range(p)] for i in range(n)]
    return F, H, L


def _matrix(rows, ncols):
    return sp.Matrix(len(rows), ncols, [sp.Rational(v.numerator, v.denominator)
                                        for r in rows for v in r])


def spy_on_grow(monkeypatch):
    """Count the steps ``grow`` takes incrementally (the result carries a kernel)."""
    counts = {"incremental": 0, "from scratch": 0}
    original = GrowingLeftNull.grow

    def grow(self, top, **kw):
        out = original(self, top, **kw)
        counts["incremental" if out.kernel is not None else "from scratch"] += 1
        return out

    monkeypatch.setattr(GrowingLeftNull, "grow", grow)
    return counts


def case(seed, kind):
    """n = 1 … 12, l = 1 … 4 outputs, p = 0 … l decoupled inputs (p < l for most: with
    p ≥ l the null space may never appear)."""
    rng = random.Random(f"{kind} {seed}")
    n, l = rng.randint(1, 12), rng.randint(1, 4)
    p = rng.randrange(l) if rng.random() < 0.8 else l
    return n, l, p, random_plant(rng, n, l, p, kind)


CASES = [(seed, kind) for kind in ("dense", "sparse", "redundant", "HL = 0") for seed in range(12)]


@pytest.mark.slow
@pytest.mark.parametrize("seed,kind", CASES)
def test_every_k_equals_the_elimination_from_scratch(seed, kind, monkeypatch):
    n, l, p, (F, H, L) = case(seed, kind)
    Fm, Hm, Lm = _matrix(F, n), _matrix(H, n), _matrix(L, p)
    spaces = krylov_null_spaces(Fm, Hm, Lm)
    before = 0
    for k in range(1, n + 1):
        members, rank, conds = next(spaces)
        ref, rk = left_null_echelon(sp.Matrix.hstack(*krylov_blocks(Fm, Hm, Lm, k)))
        assert len(members) == len(ref), (n, l, p, k)
        for a, b in zip(members, ref):
            assert a == b, (n, l, p, k)
        assert rank == rk.rank and conds == frozenset(), (n, l, p, k)
        assert len(members) == l * (k + 1) - rank
        if (members and not before) or k == n:  # the oracle where the null space appears, and last
            assert rank == frac_rank(krylov_stack(F, H, L, k)), (n, l, p, k)
        before = len(members)


@pytest.mark.parametrize("kind", ["dense", "sparse", "redundant", "HL = 0"])
def test_the_cases_grow_incrementally(kind, monkeypatch):
    """The cases above are not passed by the fallback alone: in each kind the null space
    appears at some k and later steps are taken incrementally."""
    counts = spy_on_grow(monkeypatch)
    appeared = 0
    for seed in range(12):
        n, l, p, (F, H, L) = case(seed, kind)
        spaces = krylov_null_spaces(_matrix(F, n), _matrix(H, n), _matrix(L, p))
        sizes = [len(next(spaces)[0]) for _ in range(n)]
        appeared += any(sizes)
    assert appeared >= 8, (kind, appeared)
    assert counts["incremental"] >= 5, (kind, counts)


def test_the_null_space_appears_after_k_equals_one():
    """n = 12, l = 2, one disturbance: (W L) has full row rank up to k = 10 (2(k+1) ≤ 12 + k),
    then the members appear; every k still equals the elimination from scratch."""
    rng = random.Random(7)
    F, H, L = random_plant(rng, 12, 2, 1, "dense")
    Fm, Hm, Lm = _matrix(F, 12), _matrix(H, 12), _matrix(L, 1)
    sizes = []
    for k, (members, rank, _) in zip(range(1, 13), krylov_null_spaces(Fm, Hm, Lm)):
        ref, _ = left_null_echelon(sp.Matrix.hstack(*krylov_blocks(Fm, Hm, Lm, k)))
        assert members == ref
        sizes.append(len(members))
    assert sizes[:10] == [0] * 10 and sizes[10] > 0 and sizes[11] > sizes[10]


@pytest.mark.parametrize("seed", range(8))
def test_seed_004_variant_grows_two_matrices(seed):
    """J* on H0 = [H; M]: members and ranks as from scratch, and each member (R*, −J*) gives
    Φ₁ = R* H, Φᵢ₊₁ = Φᵢ F − J*ᵢ H0 with Φₖ F = J*ₖ H0 and Φ L = 0 (the recurrence the
    matrix stands for, evaluated here)."""
    rng = random.Random(seed)
    n, l, p = rng.randint(2, 7), rng.randint(1, 3), rng.choice([0, 1, 2])
    F, H, L = random_plant(rng, n, l, p, "dense")
    Mz = [[_rational(rng, 1.0) for _ in range(n)]]
    Fm, Hm, Lm = _matrix(F, n), _matrix(H, n), _matrix(L, p)
    H0 = sp.Matrix.vstack(Hm, _matrix(Mz, n))
    spaces = krylov_null_spaces(Fm, Hm, Lm, H0=H0)
    for k in range(1, n):
        members, rank, _ = next(spaces)
        ref, rk = left_null_echelon(sp.Matrix.hstack(*krylov_blocks(Fm, Hm, Lm, k, H0=H0)))
        assert members == ref and rank == rk.rank, (n, l, p, k)
        for v in members:
            R = v[:, :l]
            J = [-v[:, l + i * (l + 1):l + (i + 1) * (l + 1)] for i in range(k)]
            Phi = [R * Hm]
            for i in range(k - 1):
                Phi.append(Phi[-1] * Fm - J[i] * H0)
            assert Phi[-1] * Fm == J[k - 1] * H0
            assert all((P * Lm).is_zero_matrix for P in Phi)


def test_parameters_are_eliminated_from_scratch():
    """With a parameter the search is the elimination over QQ(a) at each k, with its
    generic-rank conditions."""
    a = sp.Symbol("a")
    F = sp.Matrix([[0, 1, 0], [0, 0, 1], [a, 0, 0]])
    H = sp.Matrix([[1, 0, 0]])
    L = sp.Matrix([[0], [0], [1]])
    spaces = krylov_null_spaces(F, H, L)
    for k in (1, 2, 3):
        members, rank, conds = next(spaces)
        ref, rk = left_null_echelon(sp.Matrix.hstack(*krylov_blocks(F, H, L, k)))
        assert members == ref and rank == rk.rank and conds == rk.conditions


def _blocks_written_out(F, H1, H0, L, k):
    """(W L) with R* on H1 and J* on H0, from powers of F (what _virtual.py built)."""
    p = L.cols
    W = sp.Matrix.vstack(*([H1 * F ** k] + [H0 * F ** (k - i) for i in range(1, k + 1)]))
    rows = []
    for i, Hb in enumerate([H1] + [H0] * k):
        cols = [Hb * F ** (j - i) * L if j >= i else sp.zeros(Hb.rows, p) for j in range(k)]
        rows.append(sp.Matrix.hstack(*cols) if cols and p else sp.zeros(Hb.rows, k * p))
    return W, sp.Matrix.vstack(*rows)


@pytest.mark.parametrize("seed", range(6))
def test_krylov_blocks_with_h0(seed):
    """Rational (FLINT) and symbolic (sympy) paths, k = 0 … 3, H0 = H and H0 = [H; M]."""
    rng = random.Random(seed)
    n, l, p = rng.randint(1, 5), rng.randint(1, 3), rng.randint(0, 2)
    F, H, L, M = (_matrix([[_rational(rng, 1.0) for _ in range(c)] for _ in range(r)], c)
                  for r, c in ((n, n), (l, n), (n, p), (1, n)))
    Fa = F + sp.Matrix(n, n, lambda i, j: sp.Symbol("a") if i == j == 0 else 0)
    for Fx in (F, Fa):
        for H0 in (None, sp.Matrix.vstack(H, M)):
            for k in range(4):
                W, Lk = krylov_blocks(Fx, H, L, k, H0=H0)
                Wo, Lo = _blocks_written_out(Fx, H, H if H0 is None else H0, L, k)
                assert W.shape == Wo.shape and Lk.shape == Lo.shape
                assert (W - Wo).applyfunc(sp.expand).is_zero_matrix
                assert (Lk - Lo).applyfunc(sp.expand).is_zero_matrix
