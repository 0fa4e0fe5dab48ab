"""Designs for plants whose outputs carry inputs, faults and disturbances directly::

    y = H x + Gy u + Dy d + Ly ρ + W w

The decoupling conditions with feedthrough (for x* = Φ x and r = R* (y − Gy u) − H* x*)::

    Φ F − F* Φ − J* H = 0,   Φ L − J* Ly = 0,   R* H − H* Φ = 0,   R* Ly = 0,
    G* = Φ G − J* Gy,        D* = Φ D − J* Dy   (R* Dy d enters r directly)

Every designer is reused unchanged on the *measured part* of the plant: the outputs
ỹ = N (y − Gy u), with N a basis of the left null space of Ly (the feedthrough columns
of the inputs the design is decoupled from; N = I when there are none), so that ỹ does
not see the decoupled inputs at all. The outputs that do see them are not thrown away
(diagnostic and virtual-sensor designs, :mod:`._eliminate`): with M rows completing N,
y_a = M (y − Gy u) = M H x + M Dy d + Y₁ ρ₁ + … solves for a set ρ₁ of the decoupled
inputs, which is put into the dynamics; the designers see y_a as a further known input
and are decoupled from the remaining ρ₂ only. A design (Φ, F*, J̃*, G̃*, R̃*, …) of that
plant is one for y with J* = J̃* N + Φ L₁ Y₁⁻¹ M (the gain of y_a, read from G̃*, times
M), R* = R̃* N, Q = Q̃ N (then Φ L − J* Ly = 0, R* Ly = 0), and G* = Φ G − J* Gy,
D* = Φ D − J* Dy; the observer's equations read ỹ = N (y − Gy u) and y_a = M (y − Gy u).
This is exact, not only sufficient: every design of the plant has that form
(J* = J̃ N + S M with S = Φ L₁ Y₁⁻¹ forced by Φ L = J* Ly), so no order is lost: the
designed orders are the least orders of :func:`observer_cad.analysis.feedthrough_orders`
wherever the designers reach them (they search orders below n, for a residual that sees
each fault to detect through Φ D; one that sees a fault only through its output
column, with Φ D = 0, is searched by
:func:`observer_cad.synthesis.canonical.design_output_faults`, which the design takes
when the designers give none or a higher order). It holds for every model
the structure extraction accepts (ρ enters the dynamics linearly with constant
coefficients; the outputs are linear in x).
Other observer kinds see ỹ alone (sufficient, not necessary). The lifted design is
certified again on the plant with its feedthrough (the identities above, and against the
model's own equations).

Faults to detect that all enter the outputs only (sensor faults: no Φ D for the designers
to search on, after the elimination above: a bias on a sensor that a decoupled input also
reaches enters the dynamics through y_a) get a zero-order residual r = R* (y − Gy u) with
R* H = 0, R* Ly = 0 and R* Dy ≠ 0 for each of them (:func:`zero_order_design`; no
observer state) when the outputs alone give one; else the least-order dynamic residual
that sees them through the outputs (R* Dy, Φ D − J* Dy:
:func:`observer_cad.synthesis.canonical.design_output_faults`, linear plants with numeric
matrices), or a one-line refusal. A
diagnostic design whose faults all enter the outputs gets that zero-order residual too
whenever one exists (order 0, the least; :func:`zero_order_first`). Unknown-input,
sliding-mode and interval observers and robust designs with feedthrough:
:mod:`._feedthrough_kinds`.
"""
from __future__ import annotations

import copy
import dataclasses

import sympy as sp

from ...errors import InfeasibleDesignError, UsageError
from ...model import ObserverKind, PlantModel, Structure, Task, extract_structure
from ..certificates import MODEL_PREFIX, Certificate, certify_design
from ._eliminate import Elimination, eliminate_decoupled
from ._reduced import output_symbols
from ._values import Condition

__all__ = ["has_output_feedthrough", "FeedthroughView", "feedthrough_view", "lift_design",
           "feedthrough_outputs_error", "zero_order_design", "zero_order_first"]

#: the observer kinds designed with feedthrough (the others are refused)
FEEDTHROUGH_KINDS = (ObserverKind.DIAGNOSTIC, ObserverKind.VIRTUAL_SENSOR,
                     ObserverKind.INTERVAL, ObserverKind.UNKNOWN_INPUT,
                     ObserverKind.SLIDING_MODE)
#: the kinds whose designs see the decoupled inputs' measured part as a known input
#: (the others are designed on ỹ = N (y − Gy u) alone)
ELIMINATING_KINDS = (ObserverKind.DIAGNOSTIC, ObserverKind.VIRTUAL_SENSOR)


def has_output_feedthrough(model: PlantModel) -> bool:
    """True when an input, fault or disturbance appears in some output."""
    known = set(model.inputs) | set(model.faults) | set(model.disturbances)
    return any(h.free_symbols & known for h in model.outputs)


@dataclasses.dataclass(frozen=True)
class FeedthroughView:
    """The measured part of a plant with feedthrough: ``model`` has the outputs
    N h(x, 0, 0, 0, w) (what the designers see), ``N`` (l′×l) selects them from y,
    ``structure`` is the plant's own (with Gy, Dy, Ly), ``task`` the task as asked."""

    model: PlantModel
    N: sp.ImmutableMatrix
    structure: Structure
    task: Task
    #: the task the designers are given: the faults to detect that enter the outputs only
    #: (no Φ D to search on) are left to the signature, which checks the residual sees them
    inner: Task
    #: the decoupled inputs' measured part y_a = M (y − Gy u), eliminated from the
    #: dynamics (:mod:`._eliminate`); None when no decoupled input enters the outputs
    elimination: Elimination | None = None


def feedthrough_view(work: PlantModel, task: Task) -> FeedthroughView:
    """The view the designers work on for ``task`` (see the module docstring); refuses
    the observer kinds that do not take feedthrough yet, in one line."""
    where = work.where
    if task.observer not in FEEDTHROUGH_KINDS:
        raise UsageError(
            f"{where}: inputs, faults or disturbances enter the outputs; {task.observer.value}"
            " observers do not take output feedthrough yet (diagnostic and virtual-sensor"
            " observers do)")
    st = extract_structure(work)
    Ly = sp.Matrix(st.output_columns(task.decoupled))
    if Ly.free_symbols:
        raise UsageError(f"{where}: the outputs' feedthrough of the decoupled inputs has"
                         " symbolic parameters; give them values (design without --symbolic)")
    if Ly.is_zero_matrix:
        N = sp.eye(st.l)
    else:
        basis = Ly.T.nullspace()
        if not basis:
            raise InfeasibleDesignError(
                f"{where}: every output carries some of the decoupled inputs"
                f" ({', '.join(task.decoupled)}) directly; no output combination is free of them")
        N = sp.Matrix.vstack(*[v.T for v in basis])
    elim = (eliminate_decoupled(work, st, task, N) if task.observer in ELIMINATING_KINDS
            else None)
    # the targets' columns in the dynamics the designers see (D − L₁ Y₁⁻¹ M Dy)
    D = task.D(st) if elim is None else elim.D
    outputs_only = [n for j, n in enumerate(task.targets) if sp.Matrix(D[:, j]).is_zero_matrix
                    and not st.output_columns([n]).is_zero_matrix]
    inner = dataclasses.replace(task, targets=tuple(n for n in task.targets
                                                    if n not in outputs_only),
                                assumed_zero=tuple(task.assumed_zero) + tuple(outputs_only))
    zero = {s: sp.S.Zero for s in list(work.inputs) + list(work.faults) + list(work.disturbances)}
    outs = [h.xreplace(zero) for h in work.outputs]
    if N != sp.eye(st.l):
        outs = [sp.expand(e) for e in N * sp.Matrix(outs)]
    measured = copy.copy(work)  # the same model, its outputs the measured part (no re-check:
    object.__setattr__(measured, "outputs", tuple(outs))  # a sensor fault may vanish from it)
    if elim is not None:  # y_a a known input, ρ₁ solved from it in the dynamics
        object.__setattr__(measured, "inputs", tuple(work.inputs) + elim.measured)
        object.__setattr__(measured, "dynamics", elim.dynamics)
        object.__setattr__(measured, "linear_part", elim.linear_part)
    return FeedthroughView(measured, sp.ImmutableMatrix(N), st, task, inner, elim)


def _lifted_matrices(d, view: FeedthroughView) -> dict:
    """J* = J̃* N + G̃*_a M (G̃*_a: the gain of the known inputs y_a = M (y − Gy u), when
    decoupled inputs were eliminated), R* = R̃* N, Q = Q̃ N, G* = Φ G − J* Gy,
    D* = Φ D − J* Dy."""
    st, N = view.structure, sp.Matrix(view.N)
    m = d.matrices.as_dict()
    m_in = len(st.model.inputs)
    for key in ("R_star", "Q"):
        if m.get(key) is not None:
            m[key] = sp.Matrix(m[key]) * N
    Gy = sp.Matrix(st.Gy)
    for J, G in (("J_star", "G_star"), ("J_diag", "G_diag")):
        if m.get(J) is None:
            continue
        m[J] = sp.Matrix(m[J]) * N
        if view.elimination is not None and m.get(G) is not None:
            Gt = sp.Matrix(m[G])
            m[J] = m[J] + Gt[:, m_in:] * sp.Matrix(view.elimination.M)
            m[G] = Gt[:, :m_in]
        if m.get(G) is not None and Gy.cols:
            m[G] = sp.Matrix(m[G]) - sp.Matrix(m[J]) * Gy
    task = view.task
    if m.get("D_star") is not None and task.targets:
        m["D_star"] = sp.Matrix(m["Phi"]) * task.D(st) - sp.Matrix(m["J_star"]) * sp.Matrix(
            st.output_columns(task.targets))
    return {k: (v.applyfunc(sp.cancel) if isinstance(v, sp.MatrixBase) else v)
            for k, v in m.items()}


def lift_design(d, view: FeedthroughView):
    """The design ``d`` made on ``view.model`` as a design for the plant with feedthrough:
    matrices lifted, ỹ = N (y − Gy u) in its equations, outputs and nonlinear
    substitutions, the feedthrough identities certified (and, when the design is built,
    those against the model's own equations)."""
    st, N = view.structure, sp.Matrix(view.N)
    ys_tilde = output_symbols(N.rows)
    ys = sp.Matrix(output_symbols(st.l))
    u = sp.Matrix(st.model.inputs) if st.model.inputs else sp.zeros(0, 1)
    measured = ys - sp.Matrix(st.Gy) * u if u.rows else ys
    corrected = N * measured
    # simultaneous: y1 of the view may stand for y2 − y1 of the plant
    sub = {yt: corrected[i] for i, yt in enumerate(ys_tilde)}
    if view.elimination is not None:  # the known inputs y_a = M (y − Gy u)
        ya = sp.Matrix(view.elimination.M) * measured
        sub.update({s: ya[i] for i, s in enumerate(view.elimination.measured)})

    def tr(e):
        return sp.expand(sp.sympify(e).xreplace(sub))
    mats = _lifted_matrices(d, view)
    nonlinear = tuple(dataclasses.replace(ns, function=tr(ns.function), argument=tr(ns.argument),
                                          A2=sp.Matrix(ns.A2) * N) for ns in d.nonlinear)
    task = view.task
    plant = {"F": st.F, "G": st.G, "H": st.H, "C": st.C, "D": task.D(st), "L": task.L(st),
             "Gy": st.Gy, "Dy": st.output_columns(task.targets),
             "Ly": st.output_columns(task.decoupled)}
    old = d.certificate
    cert = certify_design(plant, mats, M=task.M, exact=old.exact,
                          tolerance=old.tolerance if old.tolerance is not None else 1e-9)
    kept = tuple(i for i in old.identities
                 if not i.name.startswith(MODEL_PREFIX) and i.name.startswith("A_"))
    cert = Certificate(tuple(cert.identities) + kept, cert.exact, cert.tolerance)
    conds = tuple(dataclasses.replace(c, holds=cert.passed, detail=cert.summary())
                  if c.name == "certificate" else c for c in d.conditions)
    if view.elimination is not None:
        conds += (_elimination_condition(view),)
    return dataclasses.replace(
        d, structure=st, task=task, matrices=mats, certificate=cert, nonlinear=nonlinear,
        conditions=conds,
        equations=tuple(tr(e) for e in d.equations),
        outputs=tuple((name, tr(e)) for name, e in d.outputs))


def _elimination_condition(view: FeedthroughView) -> Condition:
    """What the design read of the decoupled inputs that enter the outputs (for the
    record: the certificate checks Φ L − J* Ly = 0 and R* Ly = 0 on the plant)."""
    el = view.elimination
    M = sp.Matrix(el.M)
    used = ", ".join(f"y{j + 1}" for i in range(M.rows) for j in range(M.cols) if M[i, j])
    solved = ", ".join(map(str, el.solved))
    return Condition(
        "decoupled inputs in the outputs", True,
        f"{solved} solved from the measured part M (y − Gy u) of {used} and put into the"
        " dynamics (a known input there): J* = J̃* N + Φ L₁ Y₁⁻¹ M, R* = R̃* N; no order"
        " is lost to the outputs that carry decoupled inputs",
        "METHOD §2 (output feedthrough)", required=False)


def feedthrough_outputs_error(d) -> str:
    """Why a design's residual r or estimate z does not read y − Gy u when inputs enter the
    outputs ("" when it does, or when there is nothing to check): a designer that ignores
    Gy would leave R* Gy u in r, which no identity on the matrices sees."""
    st = d.structure
    if st is None or not st.model.inputs or st.Gy.is_zero_matrix or not d.outputs:
        return ""
    m = d.matrices
    ys = sp.Matrix(output_symbols(st.l))
    measured = ys - sp.Matrix(st.Gy) * sp.Matrix(st.model.inputs)
    xs = sp.Matrix(d.observer_states) if d.observer_states else sp.zeros(0, 1)
    want = {}
    if m.R_star is not None and m.H_star is not None and xs.rows == m.H_star.cols:
        r = sp.Matrix(m.R_star) * measured - sp.Matrix(m.H_star) * xs
        want.update({("r" if r.rows == 1 else f"r{i + 1}"): e for i, e in enumerate(r)})
    if m.Hz is not None and m.Q is not None and xs.rows == m.Hz.cols:
        z = sp.Matrix(m.Hz) * xs + sp.Matrix(m.Q) * measured
        want.update({("z" if z.rows == 1 else f"z{i + 1}"): e for i, e in enumerate(z)})
    for name, e in d.outputs:
        if name in want and sp.expand(sp.sympify(e) - want[name]) != 0:
            return (f"its output {name} does not read the measurements less the inputs'"
                    " feedthrough, y − Gy u (observer_cad.synthesis.design takes it into"
                    " account)")
    return ""


def _zero_order_row(st: Structure, task: Task):
    """A row R* with R* [H, Ly] = 0 (Ly: the decoupled inputs' output columns) and
    R* Dy_t ≠ 0 for every target t, exactly; None when the outputs alone give none."""
    Ly, Dy = sp.Matrix(st.output_columns(task.decoupled)), sp.Matrix(st.output_columns(task.targets))
    M = sp.Matrix.hstack(sp.Matrix(st.H), Ly)
    if M.free_symbols or Dy.free_symbols:
        raise InfeasibleDesignError(
            f"{st.model.where}: a zero-order residual for {', '.join(task.targets)} is searched"
            " with numeric H, Dy and Ly: give the parameters values (drop --symbolic)")
    basis = [v.T for v in M.T.nullspace()]
    if not basis:
        return None
    # Σ_i c^i b_i over c = 1 … T (d − 1) + 1: for each target the entry R* Dy_t is a
    # polynomial in c of degree < d that is not identically zero when some b_i sees the
    # target, so it has at most d − 1 roots; T (d − 1) + 1 values of c leave one that
    # misses every target's roots (the basis rows themselves are tried first)
    T, dim = Dy.cols, len(basis)
    candidates = basis + [sum((c ** i * b for i, b in enumerate(basis)), sp.zeros(1, st.l))
                          for c in range(1, T * (dim - 1) + 2)]
    for row in candidates:
        if all(e != 0 for e in row * Dy):
            den = next(e for e in row if e != 0)
            return (row / den).applyfunc(sp.nsimplify)
    return None


def zero_order_first(view: FeedthroughView) -> bool:
    """Whether the design for ``view`` is the zero-order residual r = R* (y − Gy u): when
    every fault to detect enters the outputs only, and, for a diagnostic design, when
    every one is in the outputs and some R* with R* H = 0, R* Ly = 0 sees them all
    (order 0, the least there is: Varga 2017, ``efdsyn``'s zero-order residuals)."""
    task, st = view.task, view.structure
    if not task.targets:
        return False
    if not view.inner.targets:
        return True
    if task.observer != ObserverKind.DIAGNOSTIC:
        return False
    Dy = sp.Matrix(st.output_columns(task.targets))
    if any(Dy[:, j].is_zero_matrix for j in range(Dy.cols)) or Dy.free_symbols \
            or sp.Matrix(st.H).free_symbols:
        return False
    return _zero_order_row(st, task) is not None


def zero_order_design(view: FeedthroughView, design_cls, *, form: str):
    """The zero-order residual r = R* (y − Gy u) for faults that enter the outputs only
    (see the module docstring): a certified design with k = 0 (Φ, F*, J* empty), or an
    :class:`InfeasibleDesignError` naming why none exists."""
    st, task = view.structure, view.task
    where = st.model.where
    R = _zero_order_row(st, task)
    which = (f"{task.targets[0]} enters" if len(task.targets) == 1
             else f"{', '.join(task.targets)} enter")
    if R is None:
        dec = f" and the decoupled inputs' output columns ({', '.join(task.decoupled)})" \
            if task.decoupled else ""
        raise InfeasibleDesignError(
            f"{where}: {which} the outputs only, and no combination R* y of the outputs is"
            f" free of the states (R* H = 0){dec} while seeing it: no zero-order residual;"
            " dynamic residuals that see such faults through the outputs are designed for"
            " linear plants with numeric parameters (not nonlinear ones, nor with --symbolic)")
    n, l, m_in = st.n, st.l, len(st.model.inputs)
    mats = {"Phi": sp.zeros(0, n), "F_star": sp.zeros(0, 0), "J_star": sp.zeros(0, l),
            "G_star": sp.zeros(0, m_in), "R_star": R, "H_star": sp.zeros(1, 0),
            "D_star": sp.zeros(0, len(task.targets))}
    plant = {"F": st.F, "G": st.G, "H": st.H, "C": st.C, "D": task.D(st), "L": task.L(st),
             "Gy": st.Gy, "Dy": st.output_columns(task.targets),
             "Ly": st.output_columns(task.decoupled)}
    cert = certify_design(plant, mats)
    ys = sp.Matrix(output_symbols(l))
    u = sp.Matrix(st.model.inputs) if m_in else sp.zeros(0, 1)
    r = sp.expand((R * (ys - sp.Matrix(st.Gy) * u))[0] if m_in else (R * ys)[0])
    seen = [str(e) for e in R * sp.Matrix(st.output_columns(task.targets))]
    conds = (
        Condition("zero-order residual", True,
                  f"R* = {R.tolist()[0]}: R* H = 0 and R* Ly = 0 (the decoupled inputs' output"
                  f" columns), R* Dy = {seen} for {', '.join(task.targets)}; r = R* (y − Gy u)"
                  " needs no observer state", "METHOD §2 (output feedthrough)"),
        Condition("certificate", cert.passed, cert.summary(), "METHOD §2"))
    return design_cls(
        model_name=st.model.name, task=task, structure=st, form=form, k=0, matrices=mats,
        conditions=conds, assumptions=(), certificate=cert, symbolic=False, method="exact",
        choice="k = 0: the outputs alone give a residual (R* in the left null space of"
               " [H, Ly]); no observer state", attempts=("k=0: a zero-order residual",),
        time=st.model.time, equations=(), observer_states=(), outputs=(("r", r),))
