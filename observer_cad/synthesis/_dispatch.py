"""One entry point for every design: picks the method for the observer kind and form.

=================  ==========================================  =========================
observer           --form canonical                            --form jordan
=================  ==========================================  =========================
unknown-input      :func:`~observer_cad.canonical.design_canonical` (default)   —
diagnostic         :func:`~observer_cad.diagnostic.design_diagnostic_canonical`  :func:`~observer_cad.jordan.design_jordan` (default)
virtual-sensor     :func:`~observer_cad.virtual.design_virtual_sensor_canonical`  design_jordan (default)
interval           canonical virtual sensor + 001 method 1 diagonal form       design_jordan (default)
=================  ==========================================  =========================

With ``robust=True`` an infeasible exact design falls back to the approximate one of
METHOD §2d, reported as such.
"""
from __future__ import annotations

from typing import Sequence

from ._design import Design
from ..errors import InfeasibleDesignError, UsageError
from ..model import PlantModel

__all__ = ["design", "OBSERVERS"]

OBSERVERS = ("unknown-input", "diagnostic", "virtual-sensor", "interval", "sliding-mode")


def design(model: PlantModel, *, observer: str, faults: Sequence[str] = (),
           disturbances: Sequence[str] = (), estimate=None, form: str | None = None,
           lambdas=None, eigenvalues=None, variant: str = "plain", robust: bool = False,
           symbolic: bool = False, method: str = "auto", rtol: float | None = None) -> Design:
    """Design an observer of the given kind; see the module table for the methods."""
    if observer not in OBSERVERS:
        raise UsageError(f"unknown observer kind {observer!r}; choose from {', '.join(OBSERVERS)}")
    faults = [faults] if isinstance(faults, str) else list(faults or [])
    if form is None:
        form = "canonical" if observer == "unknown-input" else "jordan"
    if observer == "sliding-mode" and estimate:
        raise UsageError("--estimate does not apply to --observer sliding-mode")
    if form not in ("canonical", "jordan"):
        raise UsageError(f"form must be 'canonical' or 'jordan', got {form!r}")
    if lambdas and form != "jordan":
        raise UsageError("--lambda applies to the Jordan form (use --eigenvalues for the canonical form)")
    if eigenvalues and form != "canonical":
        raise UsageError("--eigenvalues applies to the canonical form (use --lambda for the Jordan form)")
    if variant != "plain" and not (observer == "virtual-sensor" and form == "canonical"):
        raise UsageError("--variant 004 applies to canonical-form virtual sensors")
    if observer in ("virtual-sensor", "interval") and not estimate:
        raise UsageError(f"--observer {observer} needs --estimate EXPR (e.g. x1)")
    if observer in ("unknown-input", "diagnostic") and estimate:
        raise UsageError(f"--estimate does not apply to --observer {observer}")
    try:
        return _exact(model, observer, faults, disturbances, estimate, form, lambdas,
                      eigenvalues, variant, symbolic, method, rtol)
    except InfeasibleDesignError as exc:
        if not robust:
            raise
        from ._robust import design_robust_canonical, design_robust_jordan
        import dataclasses
        if form == "jordan":
            if observer not in ("virtual-sensor", "interval"):
                raise UsageError("a robust Jordan design needs --estimate (virtual-sensor or interval)") from exc
            d = design_robust_jordan(model, estimate=estimate, lambdas=lambdas,
                                     decouple=disturbances)
        else:
            d = design_robust_canonical(model, unknown_input=faults[0] if faults else None,
                                        estimate=estimate, decouple=disturbances,
                                        symbolic=symbolic)
        return dataclasses.replace(d, observer=observer)


def _exact(model, observer, faults, disturbances, estimate, form, lambdas, eigenvalues,
           variant, symbolic, method, rtol):
    if observer == "unknown-input":
        if len(faults) != 1:
            raise UsageError("--observer unknown-input needs exactly one --fault NAME (the input to estimate)")
        if form == "jordan":  # seed 000 §8: a one-dimensional λ-model
            import dataclasses
            from ._jordan import design_jordan_unknown_input
            from ._poles import default_eigenvalues
            lam = lambdas[0] if lambdas else default_eigenvalues(model.time, 1)[0]
            if lambdas and len(lambdas) > 1:
                raise UsageError("the Jordan unknown-input estimator takes one --lambda")
            d = design_jordan_unknown_input(model, faults[0], lam, decouple=disturbances,
                                            symbolic=symbolic)
            return dataclasses.replace(d, observer="unknown-input")
        if len(faults) != 1:
            raise UsageError("--observer unknown-input needs exactly one --fault NAME (the input to estimate)")
        from ._canonical import design_canonical
        return design_canonical(model, unknown_input=faults[0], decouple=disturbances,
                                symbolic=symbolic, method=method, rtol=rtol)
    if observer == "sliding-mode":
        if form != "jordan":
            raise UsageError("the sliding-mode observer uses one Jordan row (--form jordan)")
        if len(faults) > 1 or (lambdas and len(lambdas) > 1):
            raise UsageError("the sliding-mode observer estimates one --fault with one --lambda")
        from ._sliding import design_sliding
        d = design_sliding(model, fault=faults[0] if faults else None,
                              lam=lambdas[0] if lambdas else None, decouple=disturbances)
        return d
    if observer == "diagnostic":
        if form == "canonical":
            if len(faults) > 1:
                raise UsageError("canonical-form diagnostic observers take one --fault; "
                                 "use --form jordan for several (seed 002 Remark 1)")
            if not faults:
                if len(model.faults) != 1:
                    raise UsageError("name the fault to detect with --fault NAME")
                faults = [model.faults[0].name]
            from ._diagnostic import design_diagnostic_canonical
            return design_diagnostic_canonical(model, fault=faults[0], decouple=disturbances,
                                               eigenvalues=eigenvalues, symbolic=symbolic)
        from ._jordan import design_jordan
        return design_jordan(model, observer="diagnostic", faults=faults or None,
                             decouple=disturbances, lambdas=lambdas, symbolic=symbolic,
                             method=method, rtol=rtol)
    # virtual-sensor / interval
    if form == "canonical":
        from ._virtual import design_virtual_sensor_canonical
        d = design_virtual_sensor_canonical(model, estimate=estimate, variant=variant,
                                            eigenvalues=eigenvalues, decouple=disturbances,
                                            symbolic=symbolic)
        if observer == "interval":
            if "F_diag" not in d.matrices:
                raise InfeasibleDesignError(
                    "a canonical-form interval observer needs real distinct eigenvalues so that"
                    " F* − K H* can be made diagonal (Metzler) — seed 001 method 1")
            import dataclasses
            d = dataclasses.replace(d, observer="interval")
        return d
    from ._jordan import design_jordan
    return design_jordan(model, observer=observer, estimate=estimate, decouple=disturbances,
                         lambdas=lambdas, symbolic=symbolic, method=method, rtol=rtol)
