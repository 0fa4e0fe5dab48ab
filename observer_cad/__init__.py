"""observer_cad: design toolchain for reduced-order, disturbance-decoupled observers."""
from .errors import (CertificateError, DimensionError, InfeasibleDesignError, ModelError,
                     ObserverCadError, UsageError)
from .model import PlantModel, load_model
from .structure import NonlinearTerm, Structure, extract_structure

__all__ = [
    "PlantModel", "load_model", "Structure", "NonlinearTerm", "extract_structure",
    "ObserverCadError", "ModelError", "DimensionError", "InfeasibleDesignError",
    "CertificateError", "UsageError",
]
from .canonical import design_canonical
from .certificate import Certificate, certify_reduced_model
from .design import Condition, Design

__all__ += ["design_canonical", "Design", "Condition", "Certificate", "certify_reduced_model"]
