"""Decoupled inputs that enter the outputs, eliminated through their measured part.

Plant (METHOD §1)::

    x' = F x + G u + C Ψ(x, u) + D d + L ρ + Bw w,     y = H x + Gy u + Dy d + Ly ρ + W w

with ρ the inputs a design is decoupled from. Let N (l′×l) be a basis of the left null
space of Ly, r = rank Ly = l − l′, and M (r×l) rows of the identity with [N; M]
invertible. Then M Ly has rank r; its pivot columns (the inputs ρ₁, the others ρ₂)
give Y₁ = M Ly₁, square and invertible, and with K = Y₁⁻¹ M Ly₂ the measured part

    y_a := M (y − Gy u) = M H x + M Dy d + Y₁ (ρ₁ + K ρ₂) + M W w

solves for ρ₁ = Y₁⁻¹ (y_a − M H x − M Dy d − M W w) − K ρ₂. Put into the dynamics::

    x' = (F − L₁ Y₁⁻¹ M H) x + G u + L₁ Y₁⁻¹ y_a + (D − L₁ Y₁⁻¹ M Dy) d
         + (L₂ − L₁ K) ρ₂ + C Ψ + (Bw − L₁ Y₁⁻¹ M W) w

a plant with y_a as a further *known* input, outputs ỹ = N (y − Gy u) = N H x + N Dy d
+ N W w (free of ρ) and the disturbances ρ₂ only (in the coordinates ρ = T (ρ₁′; ρ₂)
with T = [[I, −K], [0, I]], ρ₁′ = ρ₁ + K ρ₂, so that M Ly T = [Y₁, 0]). A design
(Φ, F*, J̃*, G̃* = [Φ G, Φ L₁ Y₁⁻¹], …) of that plant lifts with
``J* = J̃* N + Φ L₁ Y₁⁻¹ M`` (the y_a column block of G̃* times M); then
Φ F − F* Φ − J* H = Φ F̃ − F* Φ − J̃* N H = 0 and Φ L T = [Φ L₁, Φ L₂ − Φ L₁ K]
= [Φ L₁, 0] = J* Ly T, i.e. Φ L − J* Ly = 0.

It loses nothing: every design of the plant has J* = J̃ N + S M ([N; M] invertible), and
Φ L T = J* Ly T reads Φ L₁ = S Y₁ and Φ (L₂ − L₁ K) = 0, so S = Φ L₁ Y₁⁻¹ and
(Φ, F*, J̃) is a design of the eliminated plant of the same order (R* Ly = 0 and
Q Ly = 0 still force R* = R̃ N, Q = Q̃ N). The least orders are therefore the same.
The substitution is exact for every model :func:`~observer_cad.model.extract_structure`
accepts: ρ enters the dynamics linearly with constant coefficients and the outputs are
linear in x.
"""
from __future__ import annotations

import dataclasses

import sympy as sp

from ...model import PlantModel, Structure, Task

__all__ = ["Elimination", "eliminate_decoupled", "completing_rows"]


@dataclasses.dataclass(frozen=True)
class Elimination:
    """What :func:`eliminate_decoupled` found: ``M`` (r×l), the known inputs ``measured``
    (y_a = M (y − Gy u), one symbol per row), the decoupled inputs solved for
    (``solved``, ρ₁), ``gain`` = L₁ Y₁⁻¹ (n×r), the eliminated dynamics and linear part,
    and ``D`` = D − L₁ Y₁⁻¹ M Dy, the targets' columns in the eliminated dynamics."""

    M: sp.ImmutableMatrix
    measured: tuple
    solved: tuple
    gain: sp.ImmutableMatrix
    dynamics: tuple
    linear_part: object
    D: sp.ImmutableMatrix


def completing_rows(N: sp.Matrix, l: int) -> sp.Matrix:  # noqa: E741
    """Rows of the l×l identity, first ones first, that make [N; M] invertible."""
    rows, stack = [], sp.Matrix(N)
    for i in range(l):
        e = sp.zeros(1, l)
        e[0, i] = 1
        trial = sp.Matrix.vstack(stack, e) if stack.rows else e
        if trial.rank() > stack.rank():
            rows.append(e)
            stack = trial
        if stack.rows == l:
            break
    return sp.Matrix.vstack(*rows) if rows else sp.zeros(0, l)


def _fresh_symbols(model: PlantModel, count: int) -> tuple:
    """``count`` symbols ya1, ya2, … that no model symbol or parameter uses."""
    taken = {s.name for s in (*model.states, *model.inputs, *model.faults,
                              *model.disturbances, *model.noise, *model.parameters)}
    base = "ya"
    while any(name.startswith(base) for name in taken):
        base = "_" + base
    return tuple(sp.Symbol(f"{base}{i + 1}") for i in range(count))


def eliminate_decoupled(work: PlantModel, st: Structure, task: Task,
                        N: sp.Matrix) -> Elimination | None:
    """The dynamics of ``work`` with the decoupled inputs' measured part eliminated (see
    the module docstring); None when no decoupled input enters the outputs."""
    Ly = sp.Matrix(st.output_columns(task.decoupled))
    if Ly.is_zero_matrix:
        return None
    l = st.l  # noqa: E741
    M = completing_rows(N, l)
    MLy = M * Ly
    _, pivots = MLy.rref()
    Y1 = MLy[:, list(pivots)]
    Y1inv = Y1.inv()
    dec = [work.symbol(n) if isinstance(n, str) else n for n in task.decoupled]
    rho1 = sp.Matrix([dec[j] for j in pivots])
    ya = _fresh_symbols(work, M.rows)
    # M (y − Gy u) without its ρ₁ part: M H x + M Dy d + M Ly₂ ρ₂ + M W w
    no_inputs = {u: 0 for u in work.inputs}
    e = M * sp.Matrix([sp.expand(h.xreplace(no_inputs)) for h in work.outputs])
    rest = (e - Y1 * rho1).applyfunc(sp.expand)  # free of ρ₁: the outputs are linear
    solution = Y1inv * (sp.Matrix(ya) - rest)
    sub = {s: solution[i] for i, s in enumerate(rho1)}
    dynamics = tuple(sp.sympify(f).xreplace(sub) for f in work.dynamics)
    L1 = sp.Matrix.hstack(*[sp.Matrix(st.unknown_input_columns([dec[j]])) for j in pivots])
    gain = L1 * Y1inv
    linear_part = work.linear_part
    if linear_part is not None:
        linear_part = sp.ImmutableMatrix(sp.Matrix(linear_part) - gain * M * sp.Matrix(st.H))
    D = sp.Matrix(task.D(st)) - gain * M * sp.Matrix(st.output_columns(task.targets))
    return Elimination(sp.ImmutableMatrix(M), ya, tuple(rho1), sp.ImmutableMatrix(gain),
                       dynamics, linear_part, sp.ImmutableMatrix(D))
