"""Step 1 of the Jordan design (METHOD §2b): the task on the plant — F, G, H, C, what to
detect (D) or estimate (z = M x), what to decouple (L) and L0 with L0 L = 0.

References: seed 002 §2; METHOD §2b.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ...errors import InfeasibleDesignError, UsageError
from ...model import Task
from ...numerics import left_null_space, solve_left
from ..core import Prepared, output_symbols, task_parts

__all__ = ["JordanProblem", "jordan_problem"]


@dataclasses.dataclass(frozen=True)
class JordanProblem:
    """What a Jordan design is asked for, on the prepared plant (step 1 of METHOD §2b).

    Parameters
    ----------
    prepared : Prepared
        The model, the work model (parameters substituted unless symbolic), its structure.
    observer : {"diagnostic", "virtual-sensor", "interval"}
    task : Task
    F, G, H, C : sympy.Matrix
        The plant's matrices (exact).
    M : sympy.Matrix or None
        z = M x (None for a residual).
    fault_syms : tuple
        The faults the residual must detect (diagnostic).
    D, L : sympy.Matrix
        Their columns, and the decoupled inputs' columns.
    L0 : sympy.Matrix
        Rows of maximal rank with L0 L = 0 (I for interval observers: not decoupled).
    pivots : frozenset
        Parameter pivots (``Ne(f, 0)``) of the null space L0 came from.
    """

    prepared: Prepared
    observer: str
    task: Task
    F: sp.Matrix
    G: sp.Matrix
    H: sp.Matrix
    C: sp.Matrix
    M: sp.Matrix | None
    fault_syms: tuple
    D: sp.Matrix
    L: sp.Matrix
    L0: sp.Matrix
    pivots: frozenset

    @property
    def work(self):
        return self.prepared.work

    @property
    def structure(self):
        return self.prepared.structure

    @property
    def where(self) -> str:
        return self.prepared.model.where

    @property
    def time(self) -> str:
        return self.prepared.work.time

    @property
    def n(self) -> int:
        return self.F.rows

    @property
    def decoupled(self) -> bool:
        """Decoupled from L (every kind but the interval observer, which reports L* = Φ L)."""
        return self.observer != "interval"

    @property
    def L_decoupled(self) -> sp.Matrix:
        """L when the observer is decoupled, else n × 0."""
        return self.L if self.decoupled else sp.zeros(self.n, 0)

    @property
    def names(self) -> tuple:
        return tuple(f.name for f in self.fault_syms)

    @property
    def several(self) -> bool:
        """z = M x has several components."""
        return self.M is not None and self.M.rows > 1


def jordan_problem(prepared: Prepared, observer: str, task: Task) -> JordanProblem:
    """The task on the prepared plant, and L0 (step 1 of METHOD §2b).

    Raises
    ------
    UsageError
        z is measured directly (no observer is needed).
    InfeasibleDesignError
        The decoupled inputs span the whole state space (no row Φ has Φ L = 0).
    """
    st, work = prepared.structure, prepared.work
    F, G, H, C = (sp.Matrix(X) for X in (st.F, st.G, st.H, st.C))
    M, fault_syms, _, D, L = task_parts(work, st, task)
    where = prepared.model.where
    if M is not None:  # z already measured: say so rather than build a trivial observer
        X0 = solve_left(H, M)
        if X0 is not None:
            raise UsageError(f"{where}: z = {task.estimate} is measured directly: z = "
                             f"{sp.expand((X0 * sp.Matrix(output_symbols(st.l)))[0, 0])};"
                             " no observer is needed")
    pivots: set = set()
    if observer != "interval" and L.cols:
        basis, rkL = left_null_space(L)
        pivots |= rkL.conditions
        L0 = sp.Matrix.vstack(*basis) if basis else sp.zeros(0, st.n)
    else:
        L0 = sp.eye(st.n)
    if L0.rows == 0:
        raise InfeasibleDesignError(f"{where}: the decoupled inputs ({', '.join(task.decoupled)})"
                                    " span the whole state space: no row Φ has Φ L = 0, so no"
                                    " decoupled observer exists")
    return JordanProblem(prepared, observer, task, F, G, H, C, M, tuple(fault_syms), D, L, L0,
                         frozenset(pivots))
