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

from ._matrices import exact_matrix
from ._plant import PlantModel

__all__ = ["random_matrices", "random_model", "random_structure", "generic_k"]


_RATIONALS: dict = {}  # (numerator, denominator) -> Rational, shared by every draw


def _rationals(ints, den: int) -> list:
    """sympy Rationals ``k/den`` for the integers of an array (one per distinct value)."""
    cache = _RATIONALS
    out = []
    for k in ints.tolist():
        r = cache.get((k, den))
        if r is None:
            r = cache[(k, den)] = sp.Rational(k, den)
        out.append(r)
    return out


def _draw_all(n: int, l: int, p: int, *, seed: int, m: int,  # noqa: E741
              integer: bool, density: float) -> dict:
    """name -> (rows, cols, row-major list of exact entries) for F, H, D, L, G.

    One pass of numpy's generator per matrix, converted to sympy numbers in bulk (each
    distinct value once); the draws and their order are those of the first
    implementation, so a seed gives the same plant as before."""
    if n < 1 or l < 1 or p < 0 or m < 0:
        raise ValueError(f"random_matrices: need n, l >= 1 and p, m >= 0"
                         f" (got n={n}, l={l}, p={p}, m={m})")
    rng = np.random.default_rng(seed)
    shapes = {"F": (n, n), "H": (l, n), "D": (n, 1), "L": (n, p), "G": (n, m)}
    zero = sp.S.Zero

    def draw(name, r, c):
        if integer:
            flat = _rationals(rng.integers(-2, 3, size=(r, c)).ravel(), 1)
        else:
            a = rng.standard_normal((r, c))
            if name == "F":
                a = a / np.sqrt(n)
            # round(v * 1000) per value, as Python's round: half to even, like np.rint
            flat = _rationals(np.rint(a.ravel() * 1000).astype(np.int64), 1000)
        if density < 1.0 and name != "G":
            keep = (rng.random((r, c)) < density).ravel().tolist()
            flat = [e if kp else zero for e, kp in zip(flat, keep)]
        return flat

    def degenerate(name, flat, r, c):
        # a zero output row or a zero fault column makes the problem degenerate
        if name == "H":
            return any(not any(flat[i * c:(i + 1) * c]) for i in range(r))
        return name == "D" and not any(flat)

    out = {}
    for name, (r, c) in shapes.items():  # fixed order: the same seed, the same matrices
        flat = draw(name, r, c)
        while degenerate(name, flat, r, c):  # draw again, deterministically
            flat = draw(name, r, c)
        out[name] = (r, c, flat)
    return out


def random_matrices(n: int, l: int, p: int, *, seed: int, m: int = 1,  # noqa: E741
                    integer: bool = True, density: float = 1.0):
    """The random F (n×n), G (n×m), H (l×n), D (n×1), L (n×p) of :func:`random_model`.

    Returned as a dict of sympy matrices with exact entries. ``density`` < 1 zeroes
    each entry of F, H, D and L independently with probability 1 − density (sparse,
    non-generic structure: structural zeros, rank drops; what the float path must
    agree with the exact one on).
    """
    drawn = _draw_all(n, l, p, seed=seed, m=m, integer=integer, density=density)
    return {name: exact_matrix(r, c, flat).as_mutable() for name, (r, c, flat) in drawn.items()}


@functools.lru_cache(maxsize=65536)
def _canonical_key(e):
    """A sort key equivalent to ``Basic.compare`` (the order ``Add`` keeps its terms in):
    class rank, then the hashable content, element by element. ``tests/model`` checks
    it gives ``Add``'s own order."""
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


def _ranks(items) -> dict:
    """item -> its position in ``Basic.compare`` order among the distinct items."""
    return {e: k for k, e in enumerate(sorted(set(items), key=_canonical_key))}


def _linear_sums(rows: list, symbols: list) -> list:
    """``Add(*[c·s for the nonzero c])`` for each row of ``[(c, s), ...]`` pairs (numbers
    c, distinct symbols s per row), built in sympy's canonical form directly.

    ``Add`` sorts its terms with ``Basic.compare``: a term ``c·s`` is ``Mul(c, s)``
    (class Mul, content (c, s): ordered by c, then s) and ``1·s`` is ``s`` (class
    Symbol, before or after every Mul by class rank). The symbols must be commutative
    (``sp.symbols``' default): the sums are built with ``is_commutative=True``. Ranking the distinct
    coefficients and symbols once turns that order into an integer key per term, so
    a row costs a sort of small tuples instead of ``Add``'s comparisons (0.3 s for a
    300-term row) or a recursive key per term. The result equals ``Add(*terms)``,
    the same args in the same order (``tests/synthesis/test_large_model``)."""
    one, zero = sp.S.One, sp.S.Zero
    # ranks by object identity (the drawn numbers are shared objects): no sympy hash per
    # term; the distinct objects are ranked by value once
    objs = {id(c): c for row in rows for c, _ in row}
    by_value = _ranks(c for c in objs.values() if c is not zero and c is not one)
    coefs = {i: by_value[c] for i, c in objs.items() if c is not zero and c is not one}
    syms = _ranks(symbols)
    # class rank (and name): decides Symbol against Mul before any content
    mul_rank = _canonical_key(Mul._from_args((sp.Integer(2), symbols[0])))[:2] if symbols else ()
    sym_rank = _canonical_key(symbols[0])[:2] if symbols else ()
    from_args = Mul._from_args
    out = []
    for row in rows:
        keyed = []
        for c, s in row:
            if c is zero:
                continue
            if c is one:  # Rational(1) is the singleton S.One
                keyed.append(((sym_rank, 0, syms[s]), s))
            else:
                keyed.append(((mul_rank, coefs[id(c)], syms[s]),
                              from_args((c, s), is_commutative=True)))
        if not keyed:
            out.append(zero)
        elif len(keyed) == 1:
            out.append(keyed[0][1])
        else:
            keyed.sort(key=lambda kt: kt[0])
            out.append(Add._from_args([t for _, t in keyed], is_commutative=True))
    return out


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

    Examples
    --------
    >>> from observer_cad.model import random_model
    >>> random_model(3, 1, 1, seed=0)
    <PlantModel 'random_n3_l1_p1_m1_int_seed0': discrete time, 3 states, 1 output, 1 input, 1 fault, 1 disturbance>
    """
    drawn = _draw_all(n, l, p, seed=seed, m=m, integer=integer, density=density)
    return _model_from(drawn, n, l, p, seed=seed, m=m, integer=integer, time=time,
                       density=density)


def _model_from(drawn: dict, n, l, p, *, seed, m, integer, time, density):  # noqa: E741
    """The PlantModel of :func:`random_model` from already drawn matrices."""
    xs = sp.symbols(f"x1:{n + 1}")
    us = sp.symbols(f"u1:{m + 1}") if m else ()
    rhos = sp.symbols(f"rho1:{p + 1}") if p else ()
    d = sp.Symbol("d")
    F, G, D, L, H = (drawn[k][2] for k in ("F", "G", "D", "L", "H"))
    rows = []
    for i in range(n):
        row = list(zip(F[i * n:(i + 1) * n], xs))
        row += zip(G[i * m:(i + 1) * m], us)
        row.append((D[i], d))
        row += zip(L[i * p:(i + 1) * p], rhos)
        rows.append(row)
    dynamics = _linear_sums(rows, [*xs, *us, d, *rhos])
    outputs = _linear_sums([list(zip(H[i * n:(i + 1) * n], xs)) for i in range(l)], list(xs))
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

    Extraction re-derives the matrices from the sympy expressions (~0.1 s at n = 240);
    for tests and benchmarks of the synthesis alone, pass this structure to
    ``design_canonical(model, ..., symbolic=True, structure=structure)`` (the model has
    no parameters, so "symbolic" changes nothing but lets the structure be reused).
    The matrices are the very ones ``extract_structure(model)`` returns.
    """
    from ._structure import Structure

    drawn = _draw_all(n, l, p, seed=seed, m=m, integer=integer, density=density)
    model = _model_from(drawn, n, l, p, seed=seed, m=m, integer=integer, time=time,
                        density=density)
    F, G, H, D, L = (exact_matrix(*drawn[k]) for k in ("F", "G", "H", "D", "L"))
    im = sp.ImmutableMatrix
    st = Structure(model, F, G, H, im(sp.zeros(n, 0)), D, L, im(sp.zeros(l, 0)), ())
    return model, st
