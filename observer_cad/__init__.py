"""observer_cad: design toolchain for reduced-order, disturbance-decoupled observers.

The package reads as the pipeline, each stage importing only from earlier ones::

    model → numerics → synthesis → analysis → observers → residuals → simulation
    → codegen → ensemble → reporting → demo → cli

The everyday API is re-exported here::

    from observer_cad import load_model, design, build_observer, simulate
    model = load_model("models/electric_drive.py")
    d = design(model, observer="unknown-input", faults=["d"])
    obs = build_observer(model, d)
"""
from .errors import (CertificateError, DimensionError, InfeasibleDesignError, ModelError,
                     ObserverCadError, UsageError)

# Everything else is imported on first use (PEP 562 ``__getattr__`` below), so that
# ``import observer_cad`` — and a command that needs only the model and the synthesis —
# does not pay for the stages it does not use (scipy, casadi, matplotlib).
# ``from observer_cad import design`` works as before.
_LAZY = {
    "model": ("NonlinearTerm", "ObserverKind", "PlantModel", "Structure", "Task",
              "extract_structure", "load_model", "resolve_task"),
    "synthesis": ("Certificate", "Condition", "Design", "DesignMatrices", "DesignRequest",
                  "certify_reduced_model", "design", "design_canonical", "FaultSensitivity"),
    "analysis": ("Analysis", "analyze", "ResidualBank", "design_bank"),
    "observers": ("DremSpec", "Observer", "build_observer"),
    "simulation": ("Scenario", "SimulationResult", "load_scenario", "simulate", "Monitor"),
    "codegen": ("CompiledSimulator",),
}
_WHERE = {name: sub for sub, names in _LAZY.items() for name in names}

__all__ = [
    "__version__",
    "PlantModel", "load_model", "Structure", "NonlinearTerm", "extract_structure",
    "Task", "ObserverKind", "resolve_task",
    "design", "design_canonical", "analyze", "Analysis", "Design", "DesignMatrices", "DesignRequest",
    "Condition", "Certificate", "certify_reduced_model",
    "design_bank", "ResidualBank", "FaultSensitivity",
    "Observer", "build_observer", "DremSpec", "Scenario", "SimulationResult", "load_scenario", "simulate", "Monitor",
    "CompiledSimulator",
    "ObserverCadError", "ModelError", "DimensionError", "InfeasibleDesignError",
    "CertificateError", "UsageError",
]


def __getattr__(name):  # PEP 562: a stage is imported when one of its names is asked for
    sub = _WHERE.get(name)
    if sub is not None:
        import importlib
        value = getattr(importlib.import_module(f"{__name__}.{sub}"), name)
    elif name == "__version__":
        from .version import package_version
        value = package_version()
    else:
        raise AttributeError(f"module 'observer_cad' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
