"""observer_cad: design toolchain for reduced-order, disturbance-decoupled observers.

The package reads as the pipeline, each stage importing only from earlier ones::

    model → numerics → synthesis → observers → simulation → codegen → reporting → cli

The everyday API is re-exported here::

    from observer_cad import load_model, design, build_observer, simulate
    model = load_model("models/electric_drive.py")
    d = design(model, observer="unknown-input", faults=["d"])
    obs = build_observer(model, d)
"""
from .version import package_version as _package_version
from .errors import (CertificateError, DimensionError, InfeasibleDesignError, ModelError,
                     ObserverCadError, UsageError)
from .model import (NonlinearTerm, ObserverKind, PlantModel, Structure, Task, extract_structure,
                    load_model, resolve_task)
from .synthesis import (Certificate, Condition, Design, DesignMatrices, DesignRequest,
                        certify_reduced_model, design, design_canonical)
from .synthesis import Analysis, analyze
from .synthesis import FaultSensitivity, ResidualBank, design_bank
from .observers import DremSpec, Observer, build_observer
from .simulation import Scenario, SimulationResult, load_scenario, simulate

__version__ = _package_version()

__all__ = [
    "__version__",
    "PlantModel", "load_model", "Structure", "NonlinearTerm", "extract_structure",
    "Task", "ObserverKind", "resolve_task",
    "design", "design_canonical", "analyze", "Analysis", "Design", "DesignMatrices", "DesignRequest",
    "Condition", "Certificate", "certify_reduced_model",
    "design_bank", "ResidualBank", "FaultSensitivity",
    "Observer", "build_observer", "DremSpec", "Scenario", "SimulationResult", "load_scenario", "simulate",
    "CompiledSimulator",
    "ObserverCadError", "ModelError", "DimensionError", "InfeasibleDesignError",
    "CertificateError", "UsageError",
]


def __getattr__(name):  # PEP 562: casadi is imported only when compiled code is asked for
    if name == "CompiledSimulator":
        from .codegen import CompiledSimulator
        return CompiledSimulator
    raise AttributeError(f"module 'observer_cad' has no attribute {name!r}")
