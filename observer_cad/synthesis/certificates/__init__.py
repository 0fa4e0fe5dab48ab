"""Certificates, assumptions, conditioning and fault signatures: what every
design is re-checked and reported with.
"""
from ._assumptions import (denominator_assumptions, complete_assumptions)
from ._certificate import (Identity, Certificate, certify_reduced_model, certify_design, certify_against_model, MODEL_PREFIX)
from ._conditioning import (CONDITIONING_LEVEL, CONDITIONING_NAME, CONDITIONING_REFERENCE, conditioning_numbers, conditioning_verdict)
from ._gain import (steady_state_gain, frequency_gains)
from ._signature import (FaultSensitivity, fault_signature, fault_sensitivity, residual_response)

__all__ = [
    "denominator_assumptions", "complete_assumptions", "Identity", "Certificate",
    "certify_reduced_model", "certify_design", "certify_against_model", "MODEL_PREFIX",
    "CONDITIONING_LEVEL", "CONDITIONING_NAME", "CONDITIONING_REFERENCE", "conditioning_numbers",
    "conditioning_verdict", "FaultSensitivity", "fault_signature", "fault_sensitivity",
    "residual_response", "steady_state_gain", "frequency_gains"
]
