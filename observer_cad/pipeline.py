"""From a design to a runnable observer: the dispatch by observer kind.

:func:`build_observer` turns a certified :class:`~observer_cad.design.Design` into the
single :class:`~observer_cad.observer.Observer` representation that simulation and code
generation consume.
"""
from __future__ import annotations

from .design import Design
from .errors import UsageError
from .model import PlantModel
from .observer import Observer, diagnostic_observer, interval_observer, virtual_sensor_observer

__all__ = ["build_observer"]


def build_observer(model: PlantModel, design: Design, **options) -> Observer:
    """The observer for a design; ``options`` go to the kind's builder (gains, bounds)."""
    from .drem import DremDesign
    if isinstance(design, DremDesign):  # DREM designs carry their observer
        return design.observer
    kind = design.observer
    if kind == "virtual-sensor":
        return virtual_sensor_observer(model, design)
    if kind == "diagnostic":
        return diagnostic_observer(model, design)
    if kind == "interval":
        return interval_observer(model, design, **options)
    if kind == "unknown-input":
        try:
            from .uio import unknown_input_observer
        except ModuleNotFoundError:  # pragma: no cover - during development only
            raise UsageError("unknown-input observers are not available") from None
        return unknown_input_observer(model, design, **options)
    if kind == "sliding-mode":
        from .sliding import design_sliding
        lam = design.lambdas[0] if design.lambdas else None
        _, obs = design_sliding(model, fault=design.unknown_input, lam=lam,
                                decouple=[s for s in design.decoupled
                                          if model.symbol(s) not in model.disturbances],
                                **options)
        return obs
    raise UsageError(f"no observer builder for kind {kind!r}")
