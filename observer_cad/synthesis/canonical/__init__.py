"""The identification canonical form (METHOD §2a): unknown-input estimators,
diagnostic observers and virtual sensors.
"""
from ._canonical import (design_canonical, krylov_blocks, krylov_null_spaces, member_to_phi, FLOAT_AUTO_N)
from ._krylov import shift_matrix
from ._diagnostic import (design_diagnostic_canonical, observer_equations)
from ._virtual import (design_virtual_sensor_canonical)
from ._output_faults import (design_output_faults, sees_through_outputs)

__all__ = ["design_canonical", "krylov_blocks", "krylov_null_spaces", "member_to_phi", "FLOAT_AUTO_N", "design_diagnostic_canonical", "observer_equations", "design_virtual_sensor_canonical", "shift_matrix", "design_output_faults", "sees_through_outputs"]
