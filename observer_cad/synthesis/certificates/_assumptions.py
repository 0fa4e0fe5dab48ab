"""The assumptions of a symbolic design: the relations ``Ne(f, 0)`` on the model's
parameters under which its matrices and equations are what they say.

A symbolic design is a family of designs, one per parameter value; it exists where no
denominator of anything it reports vanishes and where every pivot its rank decisions
divided by is nonzero. Two sources, merged by :func:`complete_assumptions`:

- **denominators** (collected here, for every design, by :class:`Design` itself): every
  entry of every matrix (Φ, F*, J*, R*, H*, G*, D*, L*, C*, H_z, Q, K and the diagonal
  form), every observer equation and output, every observer gain value. Each
  irreducible factor f of a denominator that involves parameters only gives
  ``Ne(f, 0)`` (a factor that involves the observer's own signals, such as a
  nonlinear term's argument, is a condition on the trajectory, not on the parameters,
  and is not an assumption);
- **pivots and nondegeneracy** (recorded by the designer, which alone knows them): the
  pivots of the rank decisions (rank (W L), rank Φ = k, the virtual-sensor condition),
  the pivots that make a smaller k impossible, D* ≠ 0.

Constant factors give nothing: a numeric design has no assumptions.
"""
from __future__ import annotations

from typing import Iterable

import sympy as sp

from ...numerics import denominator_conditions

__all__ = ["denominator_assumptions", "complete_assumptions"]


def denominator_assumptions(exprs: Iterable, parameters) -> frozenset:
    """``Ne(f, 0)`` for every irreducible factor f, in the parameters only, of the
    denominator of each expression (matrix entries, equations, gains)."""
    params = frozenset(parameters)
    if not params:
        return frozenset()
    out = set()
    flat = []
    for e in exprs:
        e = sp.sympify(e)
        flat += list(e) if isinstance(e, sp.MatrixBase) else [e]
    for e in flat:
        if not (e.free_symbols & params):
            continue
        for c in denominator_conditions(e):
            if c.free_symbols <= params:
                out.add(c)
    return frozenset(out)


def _key(a) -> str:
    return str(a)


def complete_assumptions(recorded: Iterable, *, matrices: Iterable = (),
                         expressions: Iterable = (), parameters=()) -> tuple:
    """The recorded assumptions plus the denominators' conditions of every entry of
    ``matrices`` and every expression, without duplicates, sorted by their text.

    ``parameters``: the model's parameter symbols (a numeric design has none and keeps
    its recorded assumptions)."""
    recorded = tuple(recorded)
    params = frozenset(parameters)
    if not params:
        return recorded
    exprs = [e for M in matrices if M is not None for e in M]
    exprs += list(expressions)
    extra = denominator_assumptions(exprs, params)
    seen, out = set(), []
    for a in list(recorded) + sorted(extra, key=_key):
        if a not in seen:
            seen.add(a)
            out.append(a)
    rel = sorted((a for a in out if isinstance(a, sp.Basic)), key=_key)
    other = [a for a in out if not isinstance(a, sp.Basic)]
    return tuple(rel + other)
