"""Exact sympy matrices built in time linear in their entries.

``sp.ImmutableMatrix(rows, cols, flat)`` compares every entry with 0 through sympy's
``__ne__`` (a sympify per entry), stores them over the EXRAW domain, converts them to
QQ one by one and back to sympy numbers again: 1–2 s for a 240×240 matrix of
rationals. :func:`exact_matrix` builds the same matrix — equal, with the same args,
hash and internal domain (ZZ, QQ or EXRAW, as sympy chooses) — reading each entry
once: the entries are kept as given, only the nonzero rationals are converted to the
domain's own numbers (``ZZ``/``QQ``, whatever sympy's ground types are).
``tests/model/test_structure.py`` checks it against sympy's constructor.
"""
from __future__ import annotations

import sympy as sp
from sympy.core.basic import Basic
from sympy.polys.domains import QQ, ZZ
from sympy.polys.matrices import DomainMatrix

__all__ = ["exact_matrix"]


def exact_matrix(rows: int, cols: int, flat) -> sp.ImmutableMatrix:
    """``sp.ImmutableMatrix(rows, cols, flat)`` for a row-major list of sympy expressions.

    Rational entries (the common case: a model's coefficients) take the linear-time
    path; any other entry (a symbolic parameter, a Python number) hands the whole
    matrix to sympy's own constructor, which gives the same result more slowly.
    """
    flat = list(flat)
    if len(flat) != rows * cols:
        raise ValueError(f"exact_matrix: {len(flat)} entries for a {rows}x{cols} matrix")
    dod: dict = {}
    integer = True
    for k, e in enumerate(flat):
        if not (isinstance(e, Basic) and e.is_Rational):
            return sp.ImmutableMatrix(rows, cols, flat)
        if e:  # a nonzero Rational (0 is falsy)
            i, j = divmod(k, cols)
            row = dod.get(i)
            if row is None:
                row = dod[i] = {}
            row[j] = e
            if integer and not e.is_Integer:
                integer = False
    if integer:
        K, conv = ZZ, (lambda e: ZZ.dtype(e.p))
    else:
        K, conv = QQ, (lambda e: QQ.dtype(e.p, e.q))
    for row in dod.values():
        for j, e in row.items():
            row[j] = conv(e)
    rep = DomainMatrix(dod, (rows, cols), K)
    # what ImmutableDenseMatrix._fromrep does, with the sympy entries already in hand
    # (instead of converting every domain element back to a sympy number)
    obj = Basic.__new__(sp.ImmutableDenseMatrix, sp.Integer(rows), sp.Integer(cols),
                        sp.Tuple(*flat, sympify=False))
    obj._rows = rows
    obj._cols = cols
    obj._rep = rep
    return obj
