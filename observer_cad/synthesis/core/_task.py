"""The task's symbols and matrices as the designers use them."""
from __future__ import annotations

import sympy as sp

from ...model import PlantModel, Structure, Task, resolve_task

__all__ = ["task_for", "task_parts"]


def task_for(model: PlantModel, task: Task | None, **request) -> Task:
    """``task`` when the caller resolved it already, else :func:`resolve_task` on the
    designer's keywords (``observer``, ``faults``, ``disturbances``, ``estimate``)."""
    return task if task is not None else resolve_task(model, **request)


def task_parts(work: PlantModel, st: Structure, task: Task):
    """(M or None, target symbols, decoupled symbols, D, L) of a task on a model."""
    M = None if task.M is None else sp.Matrix(task.M)
    targets = [work.symbol(n) for n in task.targets]
    dec = [work.symbol(n) for n in task.decoupled]
    return M, targets, dec, task.D(st), task.L(st)
