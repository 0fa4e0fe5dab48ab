"""Dynamic residuals that see faults through the outputs (METHOD §2, output feedthrough).

Plant ``x' = F x + G u + D d + L ρ``, ``y = H x + Gy u + Dy d + Ly ρ`` (d the faults to
detect, ρ the inputs to decouple). The designers of :mod:`observer_cad.synthesis.jordan`
and :func:`design_diagnostic_canonical` search Φ with Φ D̃ ≠ 0 on the measured part of
the plant (:mod:`observer_cad.synthesis.core._feedthrough`), and the zero-order residual
needs ``R* [H, Ly] = 0``, ``R* Dy ≠ 0``. A residual of order k ≥ 1 that sees a fault
only through the outputs — ``Φ D = 0`` but ``R* Dy ≠ 0`` or ``D*_i = Φ_i D − J*_i Dy ≠ 0``
— is searched here, in the identification canonical form (METHOD §2a) generalised to
feedthrough: F* the k×k shift, H* = (1 0 … 0), and a member

    v = (R*, −J*_1, …, −J*_k)

of the left null space V_k of ``(W⁽ᵏ⁾ | L_y⁽ᵏ⁾)``, where ``W⁽ᵏ⁾ = [H Fᵏ; …; H F; H]``
(``v W⁽ᵏ⁾ = Φ_{k+1} = 0`` with ``Φ_1 = R* H``, ``Φ_{i+1} = Φ_i F − J*_i H``) and, for
each decoupled column (x of L, xy of Ly), the columns

    c_0 = (xy; 0; …; 0)                              v c_0 = R* xy
    c_i (i = 1 … k): block 0 holds H F^{i−1} x,      v c_i = Φ_i x − J*_i xy
                     block j < i holds H F^{i−1−j} x, block i holds xy.

Every identity of the design then holds by construction: row i of Φ F − F* Φ − J* H is
``Φ_i F − Φ_{i+1} − J*_i H = 0`` (Φ_{k+1} = 0), ``R* H − H* Φ = R* H − Φ_1 = 0``, and
``Φ L − J* Ly = 0``, ``R* Ly = 0`` are the decoupling columns. The same columns built
with a fault's D and Dy give ``v c_0 = R* Dy`` and ``v c_i = D*_i``; the residual's
transfer to the fault is ``(R* Dy sᵏ + Σ_i D*_i s^{k−i}) / p(s)`` (p the characteristic
polynomial of F* − K H*; output injection leaves the numerator unchanged), so it sees
the fault iff ``v C_f ≠ 0``, ``C_f = (c_0 … c_k)``. These are exactly the members and the
sensitivity test of :func:`observer_cad.analysis.feedthrough_orders`, so the least k
found here is analysis' least order for the task (the largest of the targets' own: the
spaces are nested, V_{k−1} padded with J*_k = 0 lies in V_k).

The member: the reduced-echelon basis b_1 … b_d of V_k first, then the combinations
``Σ c^{i−1} b_i`` for c = 1 … C (d − 1) + 1: for each target ``v C_t`` is a
polynomial in c of degree < d, not identically zero when some b_i sees the target, so
it has at most d − 1 roots and some c sees every target; the same holds for the
steady-state numerator ``v C_t p(λ₀)`` (p(λ) = (λᵏ, …, λ, 1)ᵀ, λ₀ = 0 in continuous
time, 1 in discrete time) of each target some member gives a nonzero steady-state gain
(C counts both kinds of condition). Among the candidates that see every target the first
that also keeps every such steady-state gain and has rank Φ = k is taken (else the best
of them by these two, in this order; the rank is reported). The observer is
stabilised by output injection K r with the eigenvalues of F* − K H* placed exactly
(:func:`~observer_cad.synthesis.core.pole_placement`), as the canonical diagnostic
designer does. Linear plants with numeric (rational) matrices; orders below n, as the
other designers. :func:`observer_cad.synthesis.design` takes this design when a fault to
detect enters the outputs and the zero-order residual and the designers give none (or one
that does not respond to it), and, without chosen λ or eigenvalues, when it is of a lower
order than theirs (searched below their k).
"""
from __future__ import annotations

import sympy as sp

from ...errors import InfeasibleDesignError, UsageError
from ...model import ObserverKind
from ...numerics import as_rational, from_rational, rational_left_null
from ...progress import report
from ..certificates import certify_design
from ..core import (Condition, FeedthroughView, closed_loop_eigenvalues, default_eigenvalues,
                    observer_symbols, output_symbols, parse_eigenvalues, pole_placement,
                    reduced_equations, require_stable)
from ._krylov import member_to_phi, shift_matrix

__all__ = ["sees_through_outputs", "design_output_faults"]

REFERENCE = "METHOD §2 (output feedthrough), §2a"


def sees_through_outputs(view: FeedthroughView) -> bool:
    """Whether :func:`design_output_faults` applies to ``view``: a diagnostic design of a
    linear plant with numeric matrices, some fault to detect entering the outputs."""
    task, st = view.task, view.structure
    if task.observer != ObserverKind.DIAGNOSTIC or not task.targets or st.C.cols:
        return False
    if sp.Matrix(st.output_columns(task.targets)).is_zero_matrix:
        return False
    mats = (st.F, st.H, st.G, st.Gy, task.D(st), task.L(st), st.output_columns(task.targets),
            st.output_columns(task.decoupled))
    return all(as_rational(sp.Matrix(M)) is not None for M in mats)


def _block_columns(HF: list, x, xy, k: int) -> list:
    """c_0 … c_k (module docstring) for one input column (x of the dynamics, xy of the
    outputs), each l (k + 1) × 1."""
    l = xy.rows  # noqa: E741
    cols = []
    for i in range(k + 1):
        parts = [HF[i - 1 - j] * x for j in range(i)] + [xy]
        rest = l * (k + 1 - len(parts))
        cols.append(sp.Matrix.vstack(*parts, *([sp.zeros(rest, 1)] if rest else [])))
    return cols


def _space(F, H, L, Ly, k: int) -> tuple:
    """The reduced-echelon basis of V_k (rows, sympy), exactly over QQ, and the products
    H, H F, …, H Fᵏ."""
    HF = [sp.Matrix(H)]
    for _ in range(k):
        HF.append(HF[-1] * F)
    W = sp.Matrix.vstack(*[HF[k - i] for i in range(k + 1)])
    cols = [W] + [c for j in range(L.cols) for c in _block_columns(HF, L[:, j], Ly[:, j], k)]
    N = from_rational(rational_left_null(as_rational(sp.Matrix.hstack(*cols))))
    return [N[i, :] for i in range(N.rows)], HF


def _fault_blocks(HF, D, Dy, k: int) -> list:
    """C_t = (c_0 … c_k) for each target column t, as l (k + 1) × (k + 1) matrices."""
    return [sp.Matrix.hstack(*_block_columns(HF, D[:, t], Dy[:, t], k)) for t in range(D.cols)]


def _candidates(basis: list, conditions: int):
    """The basis rows, then Σ c^(i−1) b_i for c = 1 … C (d − 1) + 1 for C polynomial
    conditions on c (module docstring)."""
    yield from basis
    d = len(basis)
    for c in range(1, conditions * (d - 1) + 2):
        yield sum((sp.Integer(c) ** i * b for i, b in enumerate(basis)), sp.zeros(1, basis[0].cols))


def _dc_column(k: int, time: str) -> sp.Matrix:
    """p(λ₀) = (λ₀ᵏ, …, λ₀, 1)ᵀ at λ₀ = 0 (continuous time) or 1 (discrete time): v C_t
    p(λ₀) is the numerator of the residual's transfer to fault t at steady state."""
    lam = 0 if time == "continuous" else 1
    return sp.Matrix([lam ** (k - i) for i in range(k + 1)])


def _member(basis, blocks, F, H, k, time):
    """(v, Φ, rank Φ) of the first candidate seeing every target, v scaled to a leading 1,
    preferring (in this order) a nonzero steady-state gain to every target some member
    gives one to, and rank Φ = k; None when no candidate sees every target."""
    p = _dc_column(k, time)
    strong = [C * p for C in blocks if any(not (b * C * p).is_zero_matrix for b in basis)]
    best, rank_best = None, (-1, -1)
    for v in _candidates(basis, len(blocks) + len(strong)):
        if any((v * C).is_zero_matrix for C in blocks):
            continue
        v = v / next(e for e in v if e != 0)
        _, _, Phi = member_to_phi(v, F, H, k)
        rank = Phi.rank()
        score = (all(not (v * c).is_zero_matrix for c in strong), rank == k)
        if score > rank_best:
            best, rank_best = (v, Phi, rank), score
        if all(score):
            break
    return best


def _search(view: FeedthroughView, below: int):
    """The least k < ``below`` with a member seeing every target: ``((k, dim V_k, (v, Φ,
    rank Φ)) or None, the lower orders tried)``."""
    st, task = view.structure, view.task
    F, H = sp.Matrix(st.F), sp.Matrix(st.H)
    L, Ly = task.L(st), sp.Matrix(st.output_columns(task.decoupled))
    D, Dy = task.D(st), sp.Matrix(st.output_columns(task.targets))
    attempts = []
    for k in range(1, below):
        report(f"designing (exact, canonical form, faults seen through the outputs): k = {k}"
               f" of at most {below - 1}")
        basis, HF = _space(F, H, L, Ly, k)
        if not basis:
            attempts.append(f"k={k}: the left null space of (W⁽ᵏ⁾ | L_y⁽ᵏ⁾) is zero")
            continue
        found = _member(basis, _fault_blocks(HF, D, Dy, k), F, H, k, st.model.time)
        if found is None:
            attempts.append(f"k={k}: the left null space of (W⁽ᵏ⁾ | L_y⁽ᵏ⁾) has dimension"
                            f" {len(basis)}, but no member sees every target (V_k C_f = 0"
                            " for " + ", ".join(_blind(basis, HF, D, Dy, k, task.targets)) + ")")
            continue
        return (k, len(basis), found), attempts
    return None, attempts


def _blind(basis, HF, D, Dy, k, names) -> list:
    blocks = _fault_blocks(HF, D, Dy, k)
    return [n for n, C in zip(names, blocks) if all((b * C).is_zero_matrix for b in basis)]


def _matrices(view: FeedthroughView, v, Phi, k: int) -> dict:
    """Φ, F*, J*, R*, H*, G* = Φ G − J* Gy, D* = Φ D − J* Dy of the member v."""
    st, task = view.structure, view.task
    R, J, _ = member_to_phi(v, sp.Matrix(st.F), sp.Matrix(st.H), k)
    Dy = sp.Matrix(st.output_columns(task.targets))
    return {"Phi": Phi, "F_star": shift_matrix(k), "J_star": J, "R_star": R,
            "H_star": sp.Matrix([[1] + [0] * (k - 1)]),
            "G_star": Phi * sp.Matrix(st.G) - J * sp.Matrix(st.Gy),
            "D_star": Phi * task.D(st) - J * Dy}


def _steady_numerators(mats, Dy, k: int, time: str) -> list:
    """Per fault to detect: the residual's transfer numerator R* Dy λᵏ + Σ D*_i λ^{k−i} at
    λ₀ (:func:`_dc_column`); zero means a zero steady-state gain."""
    p = _dc_column(k, time)
    C = sp.Matrix.vstack(sp.Matrix(mats["R_star"]) * Dy, sp.Matrix(mats["D_star"]))
    return [sum((C[i, t] * p[i] for i in range(k + 1)), sp.Integer(0)) for t in range(C.cols)]


def _refusal(view: FeedthroughView, attempts) -> InfeasibleDesignError:
    st, task = view.structure, view.task
    which = ", ".join(task.targets)
    dec = f" with {', '.join(task.decoupled)} decoupled" if task.decoupled else ""
    tried = "; ".join(attempts) if attempts else f"n = {st.n}: no order between 1 and n − 1"
    return InfeasibleDesignError(
        f"{st.model.where}: no residual of order < n = {st.n} sees {which}{dec}: no"
        " zero-order residual (R* [H, Ly] = 0, R* Dy ≠ 0) and, through the outputs or the"
        f" dynamics, no dynamic one ({tried})", tuple(attempts))


def design_output_faults(view: FeedthroughView, design_cls, *, form: str, eigenvalues=None,
                         lambdas=None, below: int | None = None):
    """The least-order canonical-form residual generator for ``view``'s faults, seen
    through the outputs or the dynamics (module docstring): a certified design
    (``design_cls``) or one :class:`InfeasibleDesignError` naming every k tried. With
    ``below`` (the order of a design the other designers made): one of a lower order, or
    None when there is none."""
    st, task = view.structure, view.task
    if lambdas and form == "jordan":
        raise UsageError(
            f"{st.model.where}: the least-order residual for {', '.join(task.targets)} is"
            " found in the identification canonical form (the faults are seen through the"
            " outputs): give its closed-loop eigenvalues with --form canonical --eigenvalues")
    found, attempts = _search(view, st.n if below is None else below)
    if found is None:
        if below is not None:
            return None
        raise _refusal(view, attempts)
    k, dim, (v, Phi, rank) = found
    mats = _matrices(view, v, Phi, k)
    eigs = parse_eigenvalues(eigenvalues) if eigenvalues else default_eigenvalues(st.model.time, k)
    placed = pole_placement(mats["F_star"], mats["H_star"], eigs)
    mats["K"] = sp.Matrix(placed.K)
    cl = closed_loop_eigenvalues(placed)
    require_stable(cl, st.model.time, eigs)
    plant = {"F": st.F, "G": st.G, "H": st.H, "C": st.C, "D": task.D(st), "L": task.L(st),
             "Gy": st.Gy, "Dy": st.output_columns(task.targets),
             "Ly": st.output_columns(task.decoupled)}
    cert = certify_design(plant, mats)
    conds = _conditions(view, mats, k, dim, rank, attempts, cert, eigs, cl, placed, below)
    xs, ys = observer_symbols(k), sp.Matrix(output_symbols(st.l))
    u = sp.Matrix(st.model.inputs) if st.model.inputs else sp.zeros(0, 1)
    measured = ys - sp.Matrix(st.Gy) * u if u.rows else ys
    eqs = reduced_equations(mats, list(st.model.inputs), xs, list(ys), deep=True,
                            measured=measured)
    r = sp.expand((mats["R_star"] * measured)[0] - xs[0])
    steady = _steady_numerators(mats, sp.Matrix(st.output_columns(task.targets)), k,
                                st.model.time)
    weak = [n for n, g in zip(task.targets, steady) if g == 0]
    choice = (f"k = {k}: the least order found for {', '.join(task.targets)} among residuals"
              " that see the faults through the outputs as well as the dynamics (R* Dy, "
              f"D* = Φ D − J* Dy); the left null space of (W⁽ᵏ⁾ | L_y⁽ᵏ⁾) has dimension {dim}."
              f" Chosen: v = (R*, −J*_1, …) with R* = {list(mats['R_star'])}, the first"
              " member (basis rows first, then generic combinations) that sees every fault"
              " to detect, "
              + ("with a nonzero steady-state gain to each" if not weak else
                 f"with a nonzero steady-state gain wherever a member of this order has one"
                 f" ({', '.join(weak)}: a transient only)")
              + (f", and rank Φ = {k}" if rank == k else f" (rank Φ = {rank})") + ".")
    return design_cls(
        model_name=st.model.name, task=task, structure=st, form="canonical", k=k,
        matrices=mats, conditions=conds, assumptions=(), certificate=cert, symbolic=False,
        method="exact", choice=choice, attempts=("k=0: no zero-order residual",)
        + tuple(attempts), time=st.model.time, closed_loop_eigenvalues=cl, equations=eqs,
        observer_states=tuple(xs), outputs=(("r", r),))


def _conditions(view, mats, k, dim, rank, attempts, cert, eigs, cl, placed, below) -> tuple:
    st, task = view.structure, view.task
    R, Dy = mats["R_star"], sp.Matrix(st.output_columns(task.targets))
    seen = "; ".join(f"{n}: R* Dy = {(R * Dy[:, j])[0]}, D* = {list(mats['D_star'][:, j])}"
                     for j, n in enumerate(task.targets))
    lower = "; ".join(["k=0: no zero-order residual"] + list(attempts))
    into = [n for j, n in enumerate(task.targets) if not Dy[:, j].is_zero_matrix]
    them = "it" if len(into) == 1 else "them"
    why = (f"the designs that see {them} through Φ D̃ on the measured part have order"
           f" {below}" if below is not None else
           f"no design of the measured part sees {them} through Φ D̃")
    return (
        Condition("faults seen through the outputs", True,
                  f"{', '.join(into)} {'enters' if len(into) == 1 else 'enter'} the outputs"
                  f" (Dy ≠ 0); {why}, so the members"
                  " v = (R*, −J*_1, …, −J*_k) of the left null space of (W⁽ᵏ⁾ | L_y⁽ᵏ⁾)"
                  " (decoupling columns with L and Ly) were searched for one with"
                  f" v C_f ≠ 0 (fault columns with D and Dy): dimension {dim} at k = {k}",
                  REFERENCE),
        Condition("k is minimal", True,
                  f"the least order found this way: {lower} (analysis' least order with"
                  " feedthrough, the same spaces)", REFERENCE),
        Condition("fault sensitivity (R* Dy, D* = Φ D − J* Dy)", True, seen, REFERENCE),
        Condition("rank Phi = k (the model is not degenerate)", rank == k,
                  f"rank Φ = {rank}" + ("" if rank == k else f" < k = {k}: the residual is"
                                        " valid (certified) but its realisation not minimal"),
                  "seed 000 §3", required=False),
        Condition("closed-loop eigenvalues of F* − K H*", True,
                  f"requested {[str(e) for e in eigs]}, obtained exactly"
                  f" {[str(e) for e in cl]} ({placed.method}; det(sI − F* + K H*)"
                  " recomputed and equal to Π(s − μ_i))", "METHOD §3"),
        Condition("certificate", cert.passed, cert.summary(), "METHOD §2"),
    )
