"""Independent oracle for fault signatures: the fault columns read off
the model's right-hand side by differentiation, and the residual's transfer function
H* (sI − F*)⁻¹ Φ D_j computed symbolically in s — not the extracted structure's D nor the
observability matrix the implementation uses. Also the issue's three-tank plant."""
from __future__ import annotations

import sympy as sp

from observer_cad import Design, PlantModel

S = sp.Symbol("s")


def three_tanks(outputs=("x2", "x3"), L=(0, 0, 1), name="tt3"):
    """Linear three tanks (METHOD §6 F, G), a fault in each tank, one disturbance."""
    x1, x2, x3 = sp.symbols("x1:4")
    u1, u2 = sp.symbols("u1 u2")
    f1, f2, f3, rho = sp.symbols("f1 f2 f3 rho")
    st = {"x1": x1, "x2": x2, "x3": x3}
    dyn = [-x1 + x2 + u1 + f1, x1 - 2 * x2 + x3 + u2 + f2, x2 - 2 * x3 + f3]
    dyn = [e + c * rho for e, c in zip(dyn, L)]
    return PlantModel(name=name, time="continuous", states=[x1, x2, x3], inputs=[u1, u2],
                      faults=[f1, f2, f3], disturbances=[rho],
                      outputs=[st[o] for o in outputs], dynamics=dyn)


def oracle_signature(model: PlantModel, d: Design) -> dict:
    """fault → residual responds, from dynamics/∂f and H*(sI − F*)⁻¹ Φ D_f in s."""
    work = d.structure.model
    rhs = sp.Matrix(work.dynamics)
    Phi, Fs, Hs = (sp.Matrix(M) for M in (d.matrices.Phi, d.matrices.F_star, d.matrices.H_star))
    k = Fs.rows
    out = {}
    for f in list(work.faults) + [r for r in work.disturbances if r.name in d.task.targets]:
        col = rhs.diff(f)
        assert not col.free_symbols & set(work.states), "faults enter additively"
        tf = (Hs * (S * sp.eye(k) - Fs).adjugate() * Phi * col).applyfunc(sp.cancel)
        out[f.name] = any(sp.simplify(e) != 0 for e in tf)
    return out
