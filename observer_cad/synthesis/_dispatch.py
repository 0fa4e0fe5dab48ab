"""One entry point for every design: resolves the task once, picks the method for the
observer kind and form, and records the request that reproduces the design.

=================  ==========================================  =========================
observer           --form canonical                            --form jordan
=================  ==========================================  =========================
unknown-input      :func:`design_canonical` (default)          one-row λ-model (seed 000 §8)
diagnostic         :func:`design_diagnostic_canonical`         :func:`design_jordan` (default)
virtual-sensor     :func:`design_virtual_sensor_canonical`     :func:`design_jordan` (default)
interval           canonical virtual sensor + 001 method 1     :func:`design_jordan` (default)
sliding-mode       —                                           :func:`design_sliding` (default)
=================  ==========================================  =========================

With ``robust=True`` an infeasible exact design falls back to the approximate one of
METHOD §2d, reported as such.
"""
from __future__ import annotations

import dataclasses
from typing import Sequence

from ..errors import InfeasibleDesignError, UsageError
from ..model import ObserverKind, PlantModel, Task, resolve_task
from .canonical import design_canonical
from .core import PROOF_SECONDS, Design, DesignRequest, prepare
from .core import feedthrough_view, has_output_feedthrough, lift_kind_design, zero_order_design
from .core import check_kind_feedthrough, check_robust_feedthrough, lift_robust_design
from .core import zero_order_first
from .canonical import design_diagnostic_canonical, design_output_faults, sees_through_outputs
from .jordan import design_jordan, design_jordan_unknown_input, proof_seconds_value
from .core import default_eigenvalues
from .robust import design_robust_canonical, design_robust_jordan
from .sliding import design_sliding
from ._continuous_estimation import continuous_estimation_check
from .canonical import design_virtual_sensor_canonical

__all__ = ["design", "OBSERVERS"]

#: The kinds :func:`design` makes (DREM designs come from ``observers.drem_design``).
OBSERVERS = ("unknown-input", "diagnostic", "virtual-sensor", "interval", "sliding-mode")


def design(model: PlantModel, *, observer: str, faults: Sequence[str] = (),
           disturbances: Sequence[str] = (), estimate=None, form: str | None = None,
           lambdas=None, eigenvalues=None, variant: str = "plain", robust: bool = False,
           symbolic: bool = False, method: str = "auto", rtol: float | None = None,
           proof_seconds: float | None = PROOF_SECONDS) -> Design:
    """Design an observer of the given kind; see the module table for the methods.

    Parameters
    ----------
    observer : {"unknown-input", "diagnostic", "virtual-sensor", "interval", "sliding-mode"}
    faults : names of the inputs to estimate (unknown-input, sliding-mode: one) or detect
        (diagnostic; default all faults).
    disturbances : further inputs to decouple from, besides the model's disturbances.
    estimate : z = M x for virtual sensors and interval observers (e.g. ``"x1"``).
    form : ``"canonical"`` or ``"jordan"`` (default: canonical for unknown-input, else jordan).
    lambdas, eigenvalues : requested Jordan λ / closed-loop eigenvalues of F* − K H*.
    variant : ``"plain"`` or ``"004"`` (canonical virtual sensors, seed 004).
    robust : fall back to the approximate design (METHOD §2d) when exact decoupling fails.
    symbolic : keep the model's parameters as symbols.
    method, rtol : ``"auto"``, ``"exact"`` or ``"float"``; the float path's rank tolerance.
    proof_seconds : the time budget of the Jordan proof that k is minimal (default 2 s;
        None or ``"exhaustive"``: no limit); see :func:`design_jordan`.

    Returns
    -------
    Design
        Certified; ``design.request`` reproduces it: ``design(model, **d.request.options())``.
    """
    kind = ObserverKind.parse(observer)
    proof_seconds = proof_seconds_value(proof_seconds)
    if kind.value not in OBSERVERS:
        raise UsageError(f"unknown observer kind {observer!r}; choose from {', '.join(OBSERVERS)}")
    faults = [faults] if isinstance(faults, str) else list(faults or [])
    disturbances = [disturbances] if isinstance(disturbances, str) else list(disturbances or [])
    form = _checked_form(kind, form, faults, lambdas, eigenvalues, variant)
    # the arithmetic asked for is checked here for the designers that take it; the others
    # design in exact arithmetic whatever it says (the structure is left to the designer)
    takes_method = (form == "canonical" and kind == ObserverKind.UNKNOWN_INPUT) or (
        form == "jordan" and kind in (ObserverKind.DIAGNOSTIC, ObserverKind.VIRTUAL_SENSOR,
                                      ObserverKind.INTERVAL))
    problem = prepare(model, symbolic=symbolic, method=method if takes_method else "exact")
    task = resolve_task(problem.work, observer=kind, faults=faults, disturbances=disturbances,
                        estimate=estimate)
    if kind == ObserverKind.DIAGNOSTIC and form == "canonical" and len(task.targets) > 1:
        raise UsageError("name the fault to detect with --fault NAME")
    view = None
    if has_output_feedthrough(problem.work):  # y = H x + Gy u + Dy d + Ly ρ + W w
        check_kind_feedthrough(problem.work, task)  # an estimated input in y: refused
        view = feedthrough_view(problem.work, task)
    if kind == ObserverKind.UNKNOWN_INPUT and not robust:  # continuous time: rank tests first
        continuous_estimation_check(model, task.targets[0], task.decoupled)
    try:
        try:
            d = _first_design(model, view, task, faults, disturbances, estimate, form, lambdas,
                              eigenvalues, variant, symbolic, method, rtol, proof_seconds)
            if view is not None and d.k > 1 and not (lambdas or eigenvalues) \
                    and sees_through_outputs(view):
                # a lower order may see the faults of the outputs through R* Dy or J* Dy
                d = _as_strong(d, design_output_faults(view, Design, form=form, below=d.k))
        except InfeasibleDesignError:
            if view is None or not sees_through_outputs(view):
                raise
            # faults seen through the outputs: the least-order dynamic residual
            d = design_output_faults(view, Design, form=form, eigenvalues=eigenvalues,
                                     lambdas=lambdas)
    except InfeasibleDesignError as exc:
        if not robust:
            raise
        if view is not None:  # known inputs in the outputs only (else one line)
            check_robust_feedthrough(view, exc)
        measured = model if view is None else view.model  # (y − Gy u: lifted below)
        if form == "jordan":
            if kind not in (ObserverKind.VIRTUAL_SENSOR, ObserverKind.INTERVAL):
                raise UsageError("a robust Jordan design needs --estimate (virtual-sensor or"
                                 " interval)") from exc
            d = design_robust_jordan(measured, estimate=estimate, lambdas=lambdas,
                                     decouple=disturbances)
        else:
            d = design_robust_canonical(measured, unknown_input=faults[0] if faults else None,
                                        estimate=estimate, decouple=disturbances,
                                        symbolic=symbolic)
        d = d.with_task(observer=kind)
        if view is not None:
            d = lift_robust_design(d, view)
    request = DesignRequest(
        observer=kind.value, faults=tuple(faults), disturbances=tuple(disturbances),
        estimate=None if estimate is None else str(estimate), form=form,
        lambdas=tuple(d.lambdas) if form == "jordan" and d.lambdas else None,
        eigenvalues=(tuple(d.closed_loop_eigenvalues)
                     if form == "canonical" and d.matrices.K is not None else None),
        variant=variant, robust=robust, symbolic=symbolic,
        method=method if d.approximate else d.method.value, rtol=rtol,
        proof_seconds=proof_seconds)
    # the full fault signature: every declared fault against the residual
    d = dataclasses.replace(d, request=request).with_signature()
    _require_seen(d, model)  # a residual generator must respond to what it is meant to detect
    return d


def _require_seen(d: Design, model: PlantModel) -> None:
    """One line when ``d`` (with its signature) does not respond to a fault it detects."""
    blind = [s for s in d.signature if s.role == "detected" and not s.sensitive]
    if blind:
        s = blind[0]
        raise InfeasibleDesignError(
            f"{model.where}: the residual found does not respond to {s.name}: Φ D_{s.name} ="
            f" {list(s.entry)} enters only rows r does not read (H* (sI − F*)⁻¹ Φ D = 0)")


def _as_strong(d: Design, lower: Design | None) -> Design:
    """``lower`` (a design of lower order) unless it is None or sees a fault to detect as a
    transient only (a zero steady-state gain) that ``d`` sees with a nonzero one."""
    if lower is None:
        return d
    was = {s.name: s.transient_only for s in d.with_signature().signature}
    lost = [s.name for s in lower.with_signature().signature
            if s.role == "detected" and s.transient_only and not was.get(s.name, False)]
    return d if lost else lower


def _first_design(model, view, task, faults, disturbances, estimate, form, lambdas,
                  eigenvalues, variant, symbolic, method, rtol, proof_seconds) -> Design:
    """The design of the zero-order residual or of the designers (on the measured part of
    a plant with feedthrough, lifted); a diagnostic design for faults that enter the outputs
    is checked here to respond to them (its lifted D* = Φ D − J* Dy and R* Dy)."""
    if view is not None and zero_order_first(view):
        # the outputs alone give the residual (every fault to detect enters them)
        return zero_order_design(view, Design, form=form)
    d = _exact(model if view is None else view.model, task if view is None else view.inner,
               faults, disturbances, estimate, form, lambdas, eigenvalues, variant, symbolic,
               method, rtol, proof_seconds)
    if view is None:
        return d
    d = lift_kind_design(d, view)
    if sees_through_outputs(view):  # (Φ D − J* Dy and R* Dy may cancel, or be absent)
        _require_seen(d.with_signature(), model)
    return d


def _checked_form(kind, form, faults, lambdas, eigenvalues, variant) -> str:
    """The form (default: canonical for unknown-input, else Jordan), with one-line errors for
    options that do not go with it."""
    if form is None:
        form = "canonical" if kind == ObserverKind.UNKNOWN_INPUT else "jordan"
    if form not in ("canonical", "jordan"):
        raise UsageError(f"form must be 'canonical' or 'jordan', got {form!r}")
    if lambdas and form != "jordan":
        raise UsageError("--lambda applies to the Jordan form (use --eigenvalues for the canonical form)")
    if eigenvalues and form != "canonical":
        raise UsageError("--eigenvalues applies to the canonical form (use --lambda for the Jordan form)")
    if variant != "plain" and not (kind == ObserverKind.VIRTUAL_SENSOR and form == "canonical"):
        raise UsageError("--variant 004 applies to canonical-form virtual sensors")
    if kind == ObserverKind.SLIDING_MODE and form != "jordan":
        raise UsageError("the sliding-mode observer uses one Jordan row (--form jordan)")
    if kind == ObserverKind.DIAGNOSTIC and form == "canonical" and len(faults) > 1:
        raise UsageError("canonical-form diagnostic observers take one --fault; "
                         "use --form jordan for several (seed 002 Remark 1)")
    return form


def _exact(model: PlantModel, task: Task, faults, disturbances, estimate, form, lambdas,
           eigenvalues, variant, symbolic, method, rtol, proof_seconds) -> Design:
    kind = task.observer
    if kind == ObserverKind.UNKNOWN_INPUT:
        if form == "jordan":  # seed 000 §8: a one-dimensional λ-model
            if lambdas and len(lambdas) > 1:
                raise UsageError("the Jordan unknown-input estimator takes one --lambda")
            lam = lambdas[0] if lambdas else default_eigenvalues(model.time, 1)[0]
            return design_jordan_unknown_input(model, task.targets[0], lam,
                                               decouple=disturbances, symbolic=symbolic,
                                               task=task)
        return design_canonical(model, unknown_input=task.targets[0], symbolic=symbolic,
                                method=method, rtol=rtol, task=task)
    if kind == ObserverKind.SLIDING_MODE:
        if lambdas and len(lambdas) > 1:
            raise UsageError("the sliding-mode observer estimates one --fault with one --lambda")
        return design_sliding(model, lam=lambdas[0] if lambdas else None, task=task)
    if kind == ObserverKind.DIAGNOSTIC:
        if form == "canonical":
            return design_diagnostic_canonical(model, fault=task.targets[0],
                                               eigenvalues=eigenvalues, symbolic=symbolic,
                                               task=task)
        return design_jordan(model, observer="diagnostic", lambdas=lambdas, symbolic=symbolic,
                             method=method, rtol=rtol, task=task, proof_seconds=proof_seconds)
    # virtual-sensor / interval
    if form == "canonical":
        # an interval observer's canonical model is the decoupled virtual sensor's
        d = design_virtual_sensor_canonical(
            model, estimate=estimate, variant=variant, eigenvalues=eigenvalues,
            decouple=disturbances, symbolic=symbolic,
            task=task if kind == ObserverKind.VIRTUAL_SENSOR else None)
        if kind == ObserverKind.INTERVAL:
            if not d.matrices.diagonal:
                raise InfeasibleDesignError(
                    "a canonical-form interval observer needs real distinct eigenvalues so that"
                    " F* − K H* can be made diagonal (Metzler) — seed 001 method 1")
            d = d.with_task(observer=ObserverKind.INTERVAL)
        return d
    return design_jordan(model, observer=kind.value, lambdas=lambdas, symbolic=symbolic,
                         method=method, rtol=rtol, task=task, proof_seconds=proof_seconds)
