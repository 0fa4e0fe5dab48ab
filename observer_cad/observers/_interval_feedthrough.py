"""The outputs an interval observer reads when inputs, faults and disturbances enter them
directly (y = H x + Gy u + Dy d + Ly ρ + W w; METHOD §3 with output feedthrough).

The reduced model is written in ỹ = H x, the outputs without what enters them directly:

    ỹ = (y − Gy u) − E e − W w,    E e = Dy d + Ly ρ over the faults and disturbances e

so the observer reads y − Gy u (the known inputs' feedthrough removed exactly) and the
faults and disturbances that reach the outputs it reads are bounded like the measurement
noise: [W E] over the box of (w, e) (their declared bounds), worst case per output by the
signs of ∂f/∂ỹ. With x*' = Φ (F x + G u + …) = F* x* + J* H x + Φ G u + …, the input
matrix of the reduced model is Φ G = G* + J* Gy (G* of a design with feedthrough is
Φ G − J* Gy, for y itself). An interval observer decouples nothing, so an input
decoupled by the design that reaches a read output is refused in one line.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ..errors import UsageError
from ._observer import output_symbols

__all__ = ["OutputFeedthrough", "output_feedthrough"]


@dataclasses.dataclass(frozen=True)
class OutputFeedthrough:
    """What the interval observer reads: ``measured`` (y_k − (Gy u)_k per output), the
    columns ``E`` of the faults and disturbances ``names`` that reach a read output (they
    join the noise box), and ``Gs`` = Φ G, the reduced model's input matrix."""

    measured: list
    E: sp.Matrix
    names: list
    Gs: sp.Matrix


def _read_outputs(d, l: int) -> set:
    """The outputs some part of the observer reads: a nonzero column of J*, Q or A2."""
    m = d.matrices
    mats = [sp.Matrix(m.J_star)] + ([sp.Matrix(m.Q)] if m.Q is not None else [])
    mats += [sp.Matrix(ns.A2) for ns in d.nonlinear]
    return {k for k in range(l) for M in mats if M.cols == l and any(e != 0 for e in M[:, k])}


def output_feedthrough(work, d) -> OutputFeedthrough:
    """The outputs read by the interval observer of design ``d`` on model ``work`` (see
    the module docstring); without feedthrough: y itself, no E, Gs = G*."""
    st, m = d.structure, d.matrices
    l = len(work.outputs)
    ys = list(output_symbols(l))
    Gs = sp.Matrix(m.G_star)
    if st is None or not st.has_feedthrough:
        return OutputFeedthrough(ys, sp.zeros(l, 0), [], Gs)
    us = sp.Matrix(work.inputs) if work.inputs else sp.zeros(0, 1)
    Gy = sp.Matrix(st.Gy)
    if us.rows and not Gy.is_zero_matrix:
        Gu = Gy * us
        ys = [y - Gu[k] for k, y in enumerate(ys)]
        Gs = Gs + sp.Matrix(m.J_star) * Gy
    read = _read_outputs(d, l)
    decoupled = list(d.task.decoupled) if d.task is not None else []
    for name in decoupled:
        col = st.output_columns([name])
        if any(col[k, 0] != 0 for k in read):
            raise UsageError(
                f"{work.where}: the decoupled input {name} enters an output this observer"
                " reads; an interval observer bounds the inputs of the outputs instead of"
                " decoupling them (declare bounds on it and design the interval observer)")
    cols, names = [], []
    for sym in list(work.faults) + list(work.disturbances):
        if sym.name in decoupled:
            continue
        col = sp.Matrix(st.output_columns([sym]))
        if any(col[k, 0] != 0 for k in read):
            cols.append(col)
            names.append(sym)
    E = sp.Matrix.hstack(*cols) if cols else sp.zeros(l, 0)
    return OutputFeedthrough(ys, E, names, Gs)
