"""The full fault signature of a residual: which declared faults move r.

A design with a residual r = R* y − H* x* (diagnostic observers, unknown-input models)
was chosen for its *targets*; every other declared fault may still reach it. With the
error e = Φ x − x* (noise aside),

    e' = F* e + Φ D d  (Φ L = 0),        r = R* H x − H* x* = H* Φ x − H* x* = H* e

(output injection K r does not change what follows). Fault j therefore moves r iff the
transfer H* (sI − F*)⁻¹ Φ D_j is not identically zero, i.e. iff

    O Φ D_j ≠ 0,        O = [H*; H* F*; …; H* F*^{k−1}]

(Φ D_j outside the unobservable subspace of (F*, H*)). A fault that also enters the
outputs (y = … + Dy d) drives e through Φ D_j − J* Dy_j and r directly through R* Dy_j:
it moves r iff R* Dy_j ≠ 0 or O (Φ D_j − J* Dy_j) ≠ 0. Φ D_j = 0 is decoupling in the
strict sense; Φ D_j ≠ 0 with O Φ D_j = 0 means the fault enters rows the residual never
reads. Nonlinear designs (C* ≠ 0): "decoupled" is exact (e is not driven by d_j), and
"sensitive" is judged on the linear part.

With symbolic parameters an entry of O Φ D_j may vanish for special values: the
sensitivity then holds under the relations ``Ne(f, 0)`` of the simplest nonzero entry
(a sufficient condition), recorded in :attr:`FaultSensitivity.conditions`. For the
faults the design detects or estimates these relations join the design's assumptions;
for the others the sensitivity is reported as conditional.

Float designs decide "nonzero" with a relative tolerance (:data:`SIGNATURE_RTOL`).
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ...model import Structure, Task
from ...numerics import nonzero_conditions
from ._gain import steady_state_gain

__all__ = ["FaultSensitivity", "fault_signature", "fault_sensitivity", "residual_response",
           "SIGNATURE_RTOL"]

#: Relative tolerance below which a float entry of O Φ D_j counts as zero.
SIGNATURE_RTOL = 1e-8


@dataclasses.dataclass(frozen=True)
class FaultSensitivity:
    """One column of a residual's signature.

    ``entry`` is Φ D_j (k × 1), ``response`` is O Φ D_j (what r sees), ``sensitive``
    whether r moves with the fault, ``conditions`` the relations (``Ne(k1, 0)``) under
    which that holds for symbolic parameters (empty: unconditionally), and ``role`` what
    the design does with the fault: ``"detected"``, ``"estimated"``, ``"decoupled"`` or
    ``"assumed zero"``.
    """

    name: str
    sensitive: bool
    entry: sp.ImmutableMatrix
    response: sp.ImmutableMatrix
    conditions: tuple = ()
    role: str = "assumed zero"
    enters: bool = False  # Φ D_j ≠ 0 (within the float tolerance for float designs)
    #: R* Dy_j for a fault that also enters the outputs (then ``entry`` is Φ D_j − J* Dy_j)
    direct: sp.ImmutableMatrix | None = None
    #: the residual rows' steady-state gains to the fault (:func:`steady_state_gain`;
    #: None when not computed or without a steady state)
    steady_gain: tuple | None = None

    @property
    def transient_only(self) -> bool:
        """Sensitive, yet with a zero steady-state gain in every residual row."""
        return bool(self.sensitive and self.steady_gain is not None
                    and all(g == 0 for g in self.steady_gain))

    @property
    def conditional(self) -> bool:
        return self.sensitive and bool(self.conditions)

    def describe(self) -> str:
        """``sensitive``, ``sensitive if k1 != 0`` or ``decoupled (…)``."""
        if self.transient_only:
            return "transient only (responds, with a zero steady-state gain)"
        if self.sensitive:
            return "sensitive" + (f" if {' and '.join(map(str, self.conditions))}"
                                  if self.conditions else "")
        pd = "Φ D" if self.direct is None else "Φ D − J* Dy"
        if self.enters:
            return f"decoupled ({pd} ≠ 0 but it enters only rows the residual does not read)"
        return f"decoupled ({pd} = 0)" if self.direct is None else \
            "decoupled (Φ D − J* Dy = 0, R* Dy = 0)"

    def entry_text(self) -> str:
        """``Φ D = [..]``, or ``Φ D − J* Dy = [..]; R* Dy = [..]`` with feedthrough."""
        if self.direct is None:
            return f"Φ D = {list(self.entry)}"
        return f"Φ D − J* Dy = {list(self.entry)}; R* Dy = {list(self.direct)}"

    def to_json(self) -> dict:
        out = {"name": self.name, "sensitive": bool(self.sensitive), "role": self.role,
               "enters": bool(self.enters),
               "entry": [str(e) for e in self.entry],
               "response": [str(e) for e in self.response],
               "conditions": [str(c) for c in self.conditions]}
        if self.direct is not None:
            out["direct"] = [str(e) for e in self.direct]
        return out


def _is_float(M) -> bool:
    return any(isinstance(e, sp.Float) or (isinstance(e, sp.Expr) and e.atoms(sp.Float))
               for e in M)


def residual_response(Phi, F_star, H_star, column) -> sp.Matrix:
    """O Φ D_j with O the observability matrix of (F*, H*): zero iff r ignores D_j."""
    Phi, Fs, Hs = sp.Matrix(Phi), sp.Matrix(F_star), sp.Matrix(H_star)
    b = (Phi * sp.Matrix(column)).applyfunc(sp.cancel)
    blocks, P = [], Hs
    for _ in range(max(Fs.rows, 1)):
        blocks.append(P)
        P = P * Fs
    O = sp.Matrix.vstack(*blocks)
    return (O * b).applyfunc(sp.cancel)


def _size(*matrices) -> float:
    """The largest absolute numeric entry of the matrices (0 when none is numeric)."""
    vals = [abs(float(e)) for M in matrices for e in sp.Matrix(M) if e.is_number]
    return max(vals, default=0.0)


def _nonzero(v, scale: float, floats: bool) -> bool:
    if v == 0:
        return False
    if floats and v.is_number:
        return abs(float(v)) > SIGNATURE_RTOL * max(scale, 1e-300)
    return True


def fault_sensitivity(Phi, F_star, H_star, column, *, name: str = "d",
                      role: str = "assumed zero", feed=None, direct=None,
                      feed_scale: float = 0.0) -> FaultSensitivity:
    """Whether the residual of (Φ, F*, H*) responds to an input entering through
    ``column`` (n × 1): O Φ D_j ≠ 0, with the relations that needs (module docstring).
    An input that also enters the outputs gives ``feed`` = J* Dy_j (subtracted from
    Φ D_j) and ``direct`` = R* Dy_j (the residual's direct term, first in the response);
    ``feed_scale`` = max(‖J*‖, ‖R*‖) ‖Dy_j‖, the size those terms' rounding is relative to
    in a float design."""
    Fs, Hs = F_star, H_star
    entry = (sp.Matrix(Phi) * sp.Matrix(column)).applyfunc(sp.cancel)
    dmat = None if direct is None else sp.ImmutableMatrix(sp.Matrix(direct).applyfunc(sp.cancel))
    if feed is None:
        resp = residual_response(Phi, Fs, Hs, column)
    else:
        entry = (entry - sp.Matrix(feed)).applyfunc(sp.cancel)
        resp = sp.Matrix.vstack(sp.Matrix(direct).applyfunc(sp.cancel),
                                residual_response(sp.eye(entry.rows), Fs, Hs, entry))
    floats = _is_float(Phi) or _is_float(Fs) or _is_float(Hs) or any(
        M is not None and _is_float(sp.Matrix(M)) for M in (feed, direct))
    scale = 1.0

    def norm(M):
        vals = [abs(float(e)) for e in sp.Matrix(M) if e.is_number]
        return max(vals) if vals else 1.0
    if floats:  # ‖O‖ ‖Φ‖ ‖D_j‖: the size r would have for a fully seen unit fault
        # (plus the output part's: a fault in the outputs only has a zero column)
        size = norm(Phi) * norm(column) + feed_scale
        scale = max(norm(Hs) * max(1.0, norm(Fs)) ** max(sp.Matrix(Fs).rows - 1, 0) * size,
                    feed_scale)
    nz = [e for e in resp if _nonzero(e, scale, floats)]
    enters = any(_nonzero(e, size if floats else 1.0, floats) for e in entry)
    if not nz:
        return FaultSensitivity(name, False, sp.ImmutableMatrix(entry),
                                sp.ImmutableMatrix(resp), (), role, enters, dmat)
    if any(not e.free_symbols for e in nz):
        conds = ()
    else:  # the simplest nonzero entry: its factors nonzero suffice
        best = min((nonzero_conditions(e) for e in nz), key=lambda s: (len(s), str(sorted(s, key=str))))
        conds = tuple(sorted(best, key=str))
    return FaultSensitivity(name, True, sp.ImmutableMatrix(entry), sp.ImmutableMatrix(resp),
                            conds, role, enters, dmat)


def _role(task: Task, name: str) -> str:
    if name in task.targets:
        return "detected" if task.observer.value == "diagnostic" else "estimated"
    if name in task.decoupled:
        return "decoupled"
    return "assumed zero"


def fault_signature(matrices, structure: Structure, task: Task) -> tuple:
    """The :class:`FaultSensitivity` of every declared fault (and every detected or
    estimated disturbance), in the model's order, for a design with a residual; ``()``
    for designs without one (no R*, H*: virtual sensors, interval observers).

    ``matrices`` is the design's :class:`DesignMatrices`; Φ D_j is recomputed from the
    structure's columns, not read from D*.
    """
    Hs = getattr(matrices, "H_star", None)
    if getattr(matrices, "R_star", None) is None or Hs is None:
        return ()
    model = structure.model
    names = [f.name for f in model.faults]
    names += [n for n in task.targets if n not in names]
    sig = []
    for n in names:
        feed = direct = None
        feed_scale = 0.0
        Dy = structure.output_columns([n])
        if not Dy.is_zero_matrix:  # the fault enters the outputs too
            feed = sp.Matrix(matrices.J_star) * Dy
            direct = sp.Matrix(matrices.R_star) * Dy
            feed_scale = _size(matrices.J_star, matrices.R_star) * _size(Dy)
        sig.append(fault_sensitivity(matrices.Phi, matrices.F_star, Hs,
                                     structure.unknown_input_columns([n]), name=n,
                                     role=_role(task, n), feed=feed, direct=direct,
                                     feed_scale=feed_scale))
    return tuple(dataclasses.replace(s, steady_gain=steady_state_gain(
        matrices, structure, structure.unknown_input_columns([s.name]),
        _output_column(structure, s.name), rtol=SIGNATURE_RTOL)) if s.sensitive else s
        for s in sig)


def _output_column(structure: Structure, name: str):
    """The fault's (or disturbance's) column of Dy (Ly) in the outputs (None: zero)."""
    m = structure.model
    sym = m.symbol(name)
    Dy, Ly = getattr(structure, "Dy", None), getattr(structure, "Ly", None)
    if sym in m.faults and Dy is not None:
        return Dy[:, m.faults.index(sym)]
    if sym in m.disturbances and Ly is not None:
        return Ly[:, m.disturbances.index(sym)]
    return None
