"""Seeded random linear plants, for tests and benchmarks.

:func:`random_model` builds a :class:`~observer_cad.model.PlantModel` with exact
(rational) coefficients::

    x(t+1) or x' = F x + G u + D d + L ρ,     y = H x

states ``x1..xn``, inputs ``u1..um``, one fault ``d``, disturbances ``rho1..rhop``.

* ``integer=True``: every entry is a small integer in −2..2 (exact tests on small n).
* ``integer=False``: F has N(0, 1)/√n entries (spectral radius about 1, so H Fᵏ neither
  blows up nor dies out), H, G, D, L have N(0, 1) entries; every value is rounded to
  a multiple of 1/1000 and stored as an exact ``Rational`` — the model is exact, but
  large enough that a numeric design takes the float path.

The same ``(n, l, p, seed, m, integer)`` always gives the same model (numpy's
``default_rng``). :func:`random_matrices` returns the matrices alone (as sympy
matrices) without building the model, for checks that do not need the expressions.

Generic dimension count (METHOD §2a): the left null space of (W⁽ᵏ⁾ L⁽ᵏ⁾) has generic
dimension ``max(0, l(k+1) − n − kp)``; a design whose D* enters one row only generically
needs that dimension to be at least k (the k − 1 other rows of D* are linear
conditions on the member). :func:`generic_k` returns the smallest such k (None if
none is below n) — the k a design is expected to find for a random plant.
"""
from __future__ import annotations

import functools

import numpy as np
import sympy as sp
from sympy.core.add import Add
from sympy.core.basic import Basic, ordering_of_classes
from sympy.core.mul import Mul

from ._plant import PlantModel

__all__ = ["random_matrices", "random_model", "random_structure", "generic_k"]


def _rational(v: float, den: int = 1000, _cache: dict = {}) -> sp.Rational:  # noqa: B006
    key = (int(round(v * den)), den)
    r = _cache.get(key)
    if r is None:
        r = _cache[key] = sp.Rational(*key)
    return r


def random_matrices(n: int, l: int, p: int, *, seed: int, m: int = 1,  # noqa: E741
                    integer: bool = True, density: float = 1.0):
    """The random F (n×n), G (n×m), H (l×n), D (n×1), L (n×p) of :func:`random_model`.

    Returned as a dict of sympy matrices with exact entries. ``density`` < 1 zeroes
    each entry of F, H, D and L independently with probability 1 − density (sparse,
    non-generic structure: structural zeros, rank drops; what the float path must
    agree with the exact one on).
    """
    if n < 1 or l < 1 or p < 0 or m < 0:
        raise ValueError(f"random_matrices: need n, l >= 1 and p, m >= 0"
                         f" (got n={n}, l={l}, p={p}, m={m})")
    rng = np.random.default_rng(seed)
    shapes = {"F": (n, n), "H": (l, n), "D": (n, 1), "L": (n, p), "G": (n, m)}

    def draw(name, r, c):
        if integer:
            a = rng.integers(-2, 3, size=(r, c))
            M = sp.Matrix(r, c, [sp.Integer(int(v)) for v in a.ravel()])
        else:
            a = rng.standard_normal((r, c))
            if name == "F":
                a = a / np.sqrt(n)
            M = sp.Matrix(r, c, [_rational(float(v)) for v in a.ravel()])
        if density < 1.0 and name != "G":
            keep = rng.random((r, c)) < density
            M = sp.Matrix(r, c, [e if kp else sp.Integer(0) for e, kp in zip(M, keep.ravel())])
        return M

    def degenerate(name, M):
        # a zero output row or a zero fault column makes the problem degenerate
        if name == "H":
            return any(all(e == 0 for e in M.row(i)) for i in range(M.rows))
        return name == "D" and all(e == 0 for e in M)

    out = {}
    for name, (r, c) in shapes.items():  # fixed order: the same seed, the same matrices
        M = draw(name, r, c)
        while degenerate(name, M):  # draw again, deterministically from the same generator
            M = draw(name, r, c)
        out[name] = M
    return out


def _term(c, s):
    """c·s for a number c and a symbol s, built in sympy's canonical form directly."""
    if c is sp.S.One:
        return s
    return Mul._from_args((c, s))


@functools.lru_cache(maxsize=65536)
def _canonical_key(e):
    """A sort key equivalent to ``Basic.compare`` (the order ``Add`` keeps its terms in):
    class rank, then the hashable content, element by element. Computed once per term
    instead of once per comparison (``Add(*terms)`` spends 0.3 s sorting a 300-term row;
    this 0.01 s). ``tests/test_random_systems`` checks it gives ``Add``'s own order."""
    if isinstance(e, Basic):
        name = type(e).__name__
        try:
            rank, tie = ordering_of_classes.index(name), ""
        except ValueError:
            rank, tie = len(ordering_of_classes) + 1, name
        content = e._hashable_content()
        return (rank, tie, len(content), tuple(_canonical_key(a) for a in content))
    if isinstance(e, frozenset):
        return _canonical_key(Basic(*e))
    return e


def _sum(terms: list):
    """Add(*terms) for distinct terms c·s, without re-flattening: the terms sorted as
    ``Add`` sorts them, so the result is the canonical expression (equal to
    ``Add(*terms)``, the same args in the same order) at a small fraction of the cost."""
    if not terms:
        return sp.Integer(0)
    if len(terms) == 1:
        return terms[0]
    return Add._from_args(sorted(terms, key=_canonical_key))


def _linear_forms(M: sp.Matrix, syms) -> list:
    """The rows of M applied to the symbols, built as flat sums (no expansion needed)."""
    entries = M.tolist()
    zero = sp.S.Zero
    return [_sum([_term(c, s) for c, s in zip(row, syms) if c is not zero]) for row in entries]


def random_model(n: int, l: int, p: int, *, seed: int, m: int = 1,  # noqa: E741
                 integer: bool = True, time: str = "discrete",
                 density: float = 1.0) -> PlantModel:
    """A seeded random linear plant (see the module docstring).

    Parameters
    ----------
    n, l, p : int
        States, outputs and disturbances ``rho1..rhop`` (p may be 0).
    seed : int
        Seed of numpy's ``default_rng``.
    m : int, default 1
        Inputs ``u1..um``.
    integer : bool, default True
        Integer entries in −2..2, else N(0, 1)-based rationals (F scaled by 1/√n).
    time : {"discrete", "continuous"}
    density : float, default 1.0
        Probability that an entry of F, H, D, L is drawn at all (else 0).
    """
    mats = random_matrices(n, l, p, seed=seed, m=m, integer=integer, density=density)
    xs = sp.symbols(f"x1:{n + 1}")
    us = sp.symbols(f"u1:{m + 1}") if m else ()
    rhos = sp.symbols(f"rho1:{p + 1}") if p else ()
    d = sp.Symbol("d")
    F, G, H, D, L = (mats[k] for k in ("F", "G", "H", "D", "L"))
    Fx = _linear_forms(F, xs)
    Gu = _linear_forms(G, us) if m else [sp.Integer(0)] * n
    Lr = _linear_forms(L, rhos) if p else [sp.Integer(0)] * n
    dynamics = [_sum([t for part in (Fx[i], Gu[i], D[i, 0] * d, Lr[i])
                      for t in sp.Add.make_args(part) if t != 0]) for i in range(n)]
    outputs = _linear_forms(H, xs)
    kind = ("int" if integer else "gauss") + (f"_d{density:g}" if density < 1.0 else "")
    return PlantModel(
        name=f"random_n{n}_l{l}_p{p}_m{m}_{kind}_seed{seed}",
        time=time,
        states=list(xs),
        inputs=list(us),
        faults=[d],
        disturbances=list(rhos),
        outputs=outputs,
        dynamics=dynamics,
    )


def generic_k(n: int, l: int, p: int, *, single_row: bool = True):  # noqa: E741
    """The smallest k < n a generic plant of these dimensions admits (None if none).

    A member exists when ``l(k+1) − n − kp > 0``; with ``single_row`` the null space
    must also have dimension at least k (k = 1 needs only one member).
    """
    for k in range(1, n):
        dim = l * (k + 1) - n - k * p
        if dim >= (k if single_row and k > 1 else 1):
            return k
    return None


def random_structure(n: int, l: int, p: int, *, seed: int, m: int = 1,  # noqa: E741
                     integer: bool = True, time: str = "discrete", density: float = 1.0):
    """``(model, structure)``: :func:`random_model` and its ``Structure``, built directly
    from the drawn matrices without ``extract_structure``.

    Extraction re-derives the matrices from the sympy expressions (seconds at n = 60);
    for tests and benchmarks of the synthesis alone, pass this structure to
    ``design_canonical(model, ..., symbolic=True, structure=structure)`` (the model has
    no parameters, so "symbolic" changes nothing but lets the structure be reused).
    The matrices are the very ones ``extract_structure(model)`` returns.
    """
    from ._structure import Structure

    mats = random_matrices(n, l, p, seed=seed, m=m, integer=integer, density=density)
    model = random_model(n, l, p, seed=seed, m=m, integer=integer, time=time, density=density)
    im = sp.ImmutableMatrix
    st = Structure(model, im(mats["F"]), im(mats["G"]), im(mats["H"]), im(sp.zeros(n, 0)),
                   im(mats["D"]), im(mats["L"]), im(sp.zeros(l, 0)), ())
    return model, st
