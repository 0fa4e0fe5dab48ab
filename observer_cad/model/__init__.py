"""Stage 1 — the plant model: what the engineer writes (:class:`PlantModel`, model files),
the structure extracted from it (F, G, H, C, D, L, W, Ψ) and random test systems.
"""
from ._expressions import (parse_expression, parse_number, FUNCTIONS, MAX_LENGTH, MAX_EXPONENT,
                           MAX_CROOTOF_DEGREE)
from ._plant import (PlantModel, load_model, load_model_module, model_from_module, to_rational)
from ._statespace import statespace_model_arguments
from ._random import (random_matrices, random_model, random_structure, generic_k)
from ._identity import ZeroTest, is_identically_zero
from ._structure import (NonlinearTerm, Structure, extract_structure, certify_structure,
                         ModelCertificate, EquationCheck)
from ._digest import (ModelDigest, structure_digest, model_digest)
from ._task import (ObserverKind, Task, resolve_task, parse_estimate)

__all__ = [
    "parse_expression", "parse_number", "FUNCTIONS", "MAX_LENGTH", "MAX_EXPONENT",
    "MAX_CROOTOF_DEGREE", "PlantModel", "load_model", "load_model_module", "model_from_module",
    "to_rational", "statespace_model_arguments", "random_matrices", "random_model", "random_structure",
    "generic_k", "NonlinearTerm", "Structure", "extract_structure", "certify_structure",
    "ModelCertificate", "EquationCheck", "ZeroTest", "is_identically_zero", "ObserverKind",
    "Task", "resolve_task", "parse_estimate", "ModelDigest", "structure_digest", "model_digest"
]
