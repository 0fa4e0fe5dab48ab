"""The one preparation every designer and the analysis start from: which arithmetic,
which model (parameters substituted or kept), which structure.

    problem = prepare(model, symbolic=False, method="auto")
    problem.work, problem.structure, problem.method      # "exact" or "float"

The rule for ``method="auto"`` is the same everywhere: the float path (SVD with stated
tolerances) when no parameter is kept as a symbol, the model has more than
:data:`FLOAT_AUTO_N` states and the caller's float path can take its structure
(``float_takes``: the Jordan float path takes linear structures only); exact arithmetic
otherwise. ``method="float"`` with parameters kept as symbols is refused in one line.
"""
from __future__ import annotations

import dataclasses
from typing import Callable

from ...errors import UsageError
from ...model import PlantModel, Structure, extract_structure

__all__ = ["Prepared", "prepare", "FLOAT_AUTO_N", "METHODS"]

#: numeric models with more states than this take the float path under ``method="auto"``
FLOAT_AUTO_N = 20

#: the arithmetic a designer may be asked for
METHODS = ("auto", "exact", "float")


@dataclasses.dataclass(frozen=True, init=False)
class Prepared:
    """What a design starts from: ``model`` as given, ``work`` (its parameters substituted
    by their defaults unless kept symbolic), the ``structure`` extracted from ``work`` (with
    its model certificate), and the arithmetic ``method`` chosen ("exact" or "float").

    The structure is extracted when it is first asked for (``Prepared(model, work, None,
    method)``), once: :func:`~observer_cad.synthesis.design` prepares a request only to
    resolve its task on ``work`` and leaves the extraction to the designer it calls.
    """

    model: PlantModel
    work: PlantModel
    method: str

    def __init__(self, model: PlantModel, work: PlantModel, structure: Structure | None = None,
                 method: str = "exact"):
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "work", work)
        object.__setattr__(self, "method", method)
        object.__setattr__(self, "_structure", structure)

    @property
    def structure(self) -> Structure:
        """The structure of ``work`` (extracted on first use)."""
        if self._structure is None:
            object.__setattr__(self, "_structure", extract_structure(self.work))
        return self._structure

    @property
    def symbolic(self) -> bool:
        """True when parameters are kept as symbols (the work model still has some)."""
        return bool(self.work.parameters)

    @property
    def exact(self) -> bool:
        return self.method == "exact"


def prepare(model: PlantModel, *, symbolic: bool = False, method: str = "auto",
            structure: Structure | None = None,
            float_takes: Callable[[Structure], bool] | None = None) -> Prepared:
    """Substitute the parameters (unless ``symbolic``), choose the arithmetic, and have the
    structure extracted (unless a ``structure`` of that same work model is given) when it
    is first used.

    Parameters
    ----------
    model : PlantModel
    symbolic : bool, default False
        Keep the parameters as symbols (a model without parameters is the same either way).
    method : {"auto", "exact", "float"}, default "auto"
        See the module docstring for the rule "auto" follows.
    structure : Structure, optional
        The structure of the work model, when the caller has it already (it is used as
        given: it must be the work model's).
    float_takes : callable, optional
        Whether the caller's float path can take a structure (default: any).

    Raises
    ------
    UsageError
        An unknown method, or the float path asked for with parameters kept as symbols.
    """
    if method not in METHODS:
        raise UsageError(f"method must be 'auto', 'exact' or 'float', got {method!r}")
    work = model if symbolic else model.substitute_parameters()
    if method == "float" and work.parameters:
        raise UsageError("the float path needs numeric parameters: design without --symbolic")
    if method == "auto":
        big = not work.parameters and len(work.states) > FLOAT_AUTO_N
        if big and float_takes is not None and structure is None:
            structure = extract_structure(work)  # the caller's float path must see it
        method = "float" if big and (float_takes is None or float_takes(structure)) else "exact"
    return Prepared(model, work, structure, method)
