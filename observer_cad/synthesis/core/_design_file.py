"""The design-file checks of :meth:`Design.from_json <observer_cad.synthesis.core.Design.from_json>`:
a design read from JSON is data, never trusted because it was on disk.

Every expression is read by a whitelist parser; the task is re-resolved against the
model; the matrices are re-certified against the model's structure, exactly or in the
floating point of the file's certificate (its tolerance itself bounded: arithmetic
strategy of :mod:`observer_cad.synthesis.core._arithmetic`); a gain's closed-loop
eigenvalues, the fault signature, the decoupling, the seed-001 diagonal form, the
argument substitutions, the λ of a Jordan design and the equations and outputs must all
be what the matrices give.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import sympy as sp
from sympy.polys.matrices import DomainMatrix
from sympy.polys.polyerrors import CoercionFailed

from ...errors import UsageError
from ...model import ObserverKind, PlantModel, Task, structure_digest
from ...numerics import exact_rank_value, np_exact
from ..certificates import fault_signature
from ._arithmetic import ExactArithmetic, arithmetic
from ._expr import parse_json_expression
from ._prepare import prepare
from ._reduced import (EPS, INJECTIONS, K1, TAU, estimate_outputs, output_symbols, reduced_equations,
                       residual_outputs, sliding_equations)
from ._values import (MATRIX_ORDER, Condition, DesignRequest, NonlinearSubstitution,
                      SlidingGainInputs)

__all__ = ["design_from_json", "check_model_hash", "LOADED_TOLERANCE_RTOL"]


def design_from_json(cls, data, model: PlantModel):
    """The design of class ``cls`` that ``data`` (:meth:`Design.to_json`) describes for
    ``model``, every part of it checked (the module docstring); a failure is one
    :class:`~observer_cad.errors.UsageError` (or the certificate's error)."""
    if not isinstance(data, dict) or not isinstance(data.get("matrices"), dict):
        raise UsageError("not a design: a JSON object with 'matrices' is expected")
    if not isinstance(model, PlantModel):
        raise UsageError("Design.from_json needs the PlantModel the design is for")
    for key in ("k", "form", "method", "observer", "time", "states", "equations", "outputs"):
        if key not in data:
            raise UsageError(f"not a design: the key '{key}' is missing")
    symbolic = data.get("symbolic", False)
    if not isinstance(symbolic, bool):
        raise UsageError("a design's 'symbolic' must be true or false")
    # the file's certificate says in which arithmetic it is re-checked (below), not prepare
    problem = prepare(model, symbolic=symbolic, method="exact")
    work = problem.work
    if "model_hash" in data:  # first: a changed model makes every later check fail obscurely
        check_model_hash(data["model_hash"], structure_digest(problem.structure))
    task_data = data.get("task") or {
        "observer": data["observer"],
        "targets": [data["unknown_input"]] if data.get("unknown_input") else [],
        "decoupled": list(data.get("decoupled", [])), "estimate": data.get("estimate")}
    task = Task.from_json(task_data, model)
    if data["time"] != work.time:
        raise UsageError(f"{model.where}: the design is {data['time']}-time, the model"
                         f" {work.time}-time")
    st = problem.structure
    k = data["k"]
    if not isinstance(k, int) or isinstance(k, bool) or k < 0:
        raise UsageError("a design's k must be a non-negative integer (0: a zero-order"
                         " residual)")
    names, xs, params = _names(data, model, work)

    declared = set(names.values())

    def expr(text, where):
        e = parse_json_expression(text, names, where)
        undeclared = sorted(str(s) for s in e.free_symbols if s not in declared)
        if undeclared:
            raise UsageError(f"{where}: '{undeclared[0]}' is not a symbol the model or the"
                             " design declares")
        return e

    mats = _matrices(data, expr)
    if k == 0:  # a zero-order residual: the empty matrices get their shapes back
        mats = _zero_order_shapes(mats, st, task)
    _only_parameters(mats, work)
    nonlinear = _nonlinear(data, expr)
    outputs = data["outputs"]
    if not isinstance(outputs, dict):
        raise UsageError("a design's 'outputs' must be an object")
    approximate = data.get("approximate", False)
    if not isinstance(approximate, bool):
        raise UsageError("a design's 'approximate' must be true or false")
    cert, plant, ar, residual_norm = _recertify(data, st, task, mats, nonlinear, approximate)
    conditions = tuple(Condition.from_json(c) for c in data.get("conditions", []))
    request = None
    if data.get("request") is not None:
        request = DesignRequest.from_json(data["request"], names)
    sliding_inputs = (SlidingGainInputs.from_json(data["sliding_inputs"])
                      if data.get("sliding_inputs") is not None else None)
    recorded = data.get("signature")
    if recorded is not None and (not isinstance(recorded, dict) or not all(
            isinstance(k, str) and isinstance(v, bool) for k, v in recorded.items())):
        raise UsageError("a design's 'signature' must map fault names to true/false")
    made = cls(
        model_name=work.name, task=task, structure=st, form=data["form"], k=k,
        matrices=mats, conditions=conditions,
        assumptions=tuple(expr(a, "assumptions") for a in data.get("assumptions", [])),
        certificate=cert, symbolic=symbolic, method=data["method"],
        choice=str(data.get("choice", "")), attempts=tuple(map(str, data.get("attempts", []))),
        null_space=tuple(sp.Matrix([[expr(e, "null_space") for e in v]])
                         for v in data.get("null_space", [])),
        time=work.time, lambdas=tuple(expr(v, "lambdas") for v in data.get("lambdas", [])),
        closed_loop_eigenvalues=tuple(expr(v, "closed_loop_eigenvalues")
                                      for v in data.get("closed_loop_eigenvalues", [])),
        nonlinear=tuple(nonlinear),
        equations=tuple(expr(e, "equations") for e in data["equations"]),
        observer_states=tuple(xs),
        outputs=tuple((str(n), expr(e, f"outputs.{n}")) for n, e in outputs.items()),
        approximate=approximate,
        residual_norm=residual_norm,
        parameters=params, request=request, sliding_inputs=sliding_inputs)
    sig = _check_made(made, ar, st, task, mats, plant, recorded, approximate, work)
    return dataclasses.replace(made, signature=sig)


def check_model_hash(recorded, digest) -> None:
    """A recorded model hash (``{"sha256": …, "parts": {…}}``) that is not ``digest`` of
    the model given: one line naming the parts that differ."""
    if not isinstance(recorded, dict) or not isinstance(recorded.get("sha256"), str):
        raise UsageError("a design's 'model_hash' must be an object with 'sha256'")
    if recorded["sha256"] == digest.sha256:
        return
    parts = digest.differing(recorded.get("parts"))
    raise UsageError(f"the design was made for a different model (structure hash"
                     f" {recorded['sha256'][:12]}…, this model's {digest.sha256[:12]}…"
                     + (f"; it differs in: {', '.join(parts)}" if parts else "")
                     + "): design again")


def _only_parameters(mats: dict, work) -> None:
    """The matrices hold numbers and the model's parameters only (a symbolic design's);
    any other symbol, even one the file declares elsewhere, is refused."""
    allowed = set(work.parameters)
    for name, M in mats.items():
        extra = sorted(str(s) for s in M.free_symbols if s not in allowed)
        if extra:
            raise UsageError(f"matrices.{name}: '{extra[0]}' is not a parameter of the model")


def _declared(model: PlantModel) -> list:
    return [s for role in ("states", "inputs", "faults", "disturbances", "noise")
            for s in getattr(model, role)] + list(model.parameters)


def _names(data, model, work):
    """The names expressions may use (the model's, the observer's states, y1…, the gains'
    parameters): ``(names, observer states, parameters)``."""
    if not isinstance(data["states"], list):
        raise UsageError("a design's 'states' must list the observer's states")
    names = {s.name: s for s in _declared(model)}
    xs = []
    for s in data["states"]:
        if not isinstance(s, str) or not s.isidentifier():
            raise UsageError(f"a design state name must be an identifier, got {s!r}")
        xs.append(names.setdefault(s, sp.Symbol(s)))
    for j in range(1, len(work.outputs) + 1):
        names.setdefault(f"y{j}", sp.Symbol(f"y{j}"))
    for gain in (K1, EPS, TAU):  # the sliding-mode gains the tool's equations name
        names.setdefault(gain.name, gain)
    params = {}
    for p, v in (data.get("parameters") or {}).items():
        if not isinstance(p, str) or not p.isidentifier():
            raise UsageError(f"a design parameter name must be an identifier, got {p!r}")
        sym = names.setdefault(p, sp.Symbol(p))
        params[sym] = parse_json_expression(v, names, f"parameters.{p}")
    return names, xs, params


def _matrices(data, expr) -> dict:
    """The matrices, each a list of rows of equal length; Φ, F*, J*, G* required."""
    mats = {}
    for name, rows_ in data["matrices"].items():
        if name not in MATRIX_ORDER:
            raise UsageError(f"a design has an unknown matrix {name!r}")
        if not isinstance(rows_, list) or not all(isinstance(r, list) for r in rows_):
            raise UsageError(f"matrix {name} must be a list of rows")
        widths = {len(r) for r in rows_}
        if len(widths) > 1:
            raise UsageError(f"matrix {name}: rows of different lengths")
        mats[name] = sp.Matrix(len(rows_), widths.pop() if widths else 0,
                               [expr(e, f"matrices.{name}") for r in rows_ for e in r])
    for name in ("Phi", "F_star", "J_star", "G_star"):
        if name not in mats:
            raise UsageError(f"not a design: matrix {name} is missing")
    return mats


def _zero_order_shapes(mats: dict, st, task) -> dict:
    """A k = 0 design's empty matrices (JSON ``[]`` has no column count) with the shapes
    the plant gives them: Φ 0×n, F* 0×0, J* 0×l, G* 0×m, D* 0×targets, H* rows(R*)×0."""
    shapes = {"Phi": (0, st.n), "F_star": (0, 0), "J_star": (0, st.l),
              "G_star": (0, st.G.shape[1]), "D_star": (0, len(task.targets)),
              "H_star": (sp.Matrix(mats["R_star"]).rows if "R_star" in mats else 0, 0)}
    out = dict(mats)
    for name, shape in shapes.items():
        if name in out:
            if sp.Matrix(out[name]).rows not in (0, shape[0]) or any(sp.Matrix(out[name])):
                raise UsageError(f"a zero-order design's {name} must be empty")
            out[name] = sp.zeros(*shape)
    return out


def _nonlinear(data, expr) -> list:
    """The argument substitutions (METHOD §2c), as recorded."""
    nonlinear = []
    for item in data.get("nonlinear", []):
        try:
            nonlinear.append(NonlinearSubstitution(
                int(item["index"]), expr(item["function"], "nonlinear.function"),
                expr(item["argument"], "nonlinear.argument"),
                sp.Matrix([[expr(e, "nonlinear.A1") for e in item["A1"]]]),
                sp.Matrix([[expr(e, "nonlinear.A2") for e in item["A2"]]])))
        except (KeyError, TypeError, ValueError):
            raise UsageError("a design's nonlinear substitution is malformed") from None
    return nonlinear


def _recertify(data, st, task, mats, nonlinear, approximate):
    """The loaded matrices certified against the model's structure in the arithmetic of
    the file's certificate (exact, or float within its bounded tolerance; an approximate
    design's Φ L is its residual, recomputed, not an identity): ``(certificate, plant,
    arithmetic, residual norm or None)``."""
    cert_data = data.get("certificate") or {}
    if not isinstance(cert_data, dict):
        raise UsageError("a design's 'certificate' must be an object")
    exact = cert_data.get("exact", True)
    if not isinstance(exact, bool):
        raise UsageError("a design's certificate 'exact' must be true or false")
    exact = exact and not approximate
    plant = dict(F=st.F, G=st.G, H=st.H, C=st.C, D=task.D(st), L=task.L(st))
    if st.has_feedthrough:  # y = H x + Gy u + Dy d + Ly ρ: the identities with them
        plant.update(Gy=st.Gy, Dy=st.output_columns(task.targets),
                     Ly=st.output_columns(task.decoupled))
    M_task = task.M if "Hz" in mats else None
    tol = None if exact else _float_tolerance(cert_data.get("tolerance"), plant, mats, M_task)
    ar = arithmetic("exact" if exact else "float")
    subs = [(ns.index, sp.Matrix(st.A[ns.index - 1, :]), ns.A1, ns.A2) for ns in nonlinear]
    cert = ar.certify(plant, mats, M=M_task, substitutions=subs,
                      decoupled=task.observer != ObserverKind.INTERVAL and not approximate,
                      tolerance=tol if tol is not None else 1e-9)
    residual_norm = (_residual_norm(data.get("residual_norm"), mats, plant["L"])
                     if approximate else None)
    return cert, plant, ar, residual_norm


def _check_made(made, ar, st, task, mats, plant, recorded, approximate, work) -> tuple:
    """What the certificate does not cover: the sliding inputs' kind, a gain's closed
    loop, the recorded signature, k, L* of a decoupled design, the diagonal form, the
    substitutions, the λ and the equations. Returns the fault signature."""
    if made.sliding_inputs is not None and made.observer != ObserverKind.SLIDING_MODE:
        raise UsageError("'sliding_inputs' belong to a sliding-mode design only")
    # a gain K is re-checked too: det(sI − F* + K H*) = Π(s − μ) for the recorded μ
    m = made.matrices
    if m.K is None and made.closed_loop_eigenvalues:
        raise UsageError("the design records closed_loop_eigenvalues but has no gain K: not a"
                         " design this tool writes")
    if m.K is not None:  # (a file that drops the eigenvalues does not skip the check)
        mu = made.closed_loop_eigenvalues
        if len(mu) != sp.Matrix(m.F_star).rows:
            raise UsageError(f"the design has a gain K but records {len(mu)} closed-loop"
                             f" eigenvalues for {sp.Matrix(m.F_star).rows} states: not a"
                             " design this tool writes")
        ar.check_poles(m.F_star, m.H_star, m.K, mu)
    # the signature is recomputed from the matrices, never read: a recorded one must agree
    sig = fault_signature(made.matrices, st, task)
    if recorded:
        _check_signature(sig, recorded)
    k = made.k
    if sp.Matrix(mats["Phi"]).rows != k or sp.Matrix(mats["F_star"]).shape != (k, k):
        raise UsageError(f"the design says k = {k}, but Φ has {sp.Matrix(mats['Phi']).rows}"
                         " rows: not a design this tool writes")
    if "L_star" in mats and task.observer != ObserverKind.INTERVAL and not approximate:
        # decoupled: L* = Φ L, which the certificate proved 0 (observers read L*)
        if not all(_same_expression(e, 0) for e in sp.Matrix(mats["L_star"])):
            raise UsageError("the design decouples its disturbances (Φ L = 0) but records"
                             " L* ≠ 0: not a design this tool writes")
    if "T" in mats:  # the seed-001 diagonal form: what T makes of the certified design
        _check_diagonal_form(made.matrices, plant, task.M)
    _check_substitutions(made, st)  # (after the matrices' own certificates)
    if made.lambdas:  # a Jordan design's λ are F*'s diagonal (reports show them)
        F = sp.Matrix(made.matrices.F_star)
        if not (F.is_diagonal() and len(made.lambdas) == F.rows and all(
                _same_expression(v, F[i, i]) for i, v in enumerate(made.lambdas))):
            raise UsageError("the design's lambdas are not the diagonal of its F*: not a"
                             " design this tool writes")
    _check_equations(made, work)
    return sig


def _check_signature(sig, recorded) -> None:
    """A recorded fault signature names the model's faults and agrees with the matrices."""
    mine = {s.name: bool(s.sensitive) for s in sig}
    for name, val in recorded.items():
        if name not in mine:
            raise UsageError(f"the design's recorded signature names {name!r}, which is"
                             f" not a fault of the model (its faults:"
                             f" {', '.join(mine) or 'none'})")
        if mine[name] != val:
            raise UsageError(f"the design's recorded signature says {name} is "
                             f"{'sensitive' if val else 'decoupled'}, but its matrices"
                             f" make the residual {'sensitive' if mine[name] else 'decoupled'}")



LOADED_TOLERANCE_RTOL = 1e-6


def _float_tolerance(tol, plant: dict, mats: dict, M) -> float:
    """A float design's recorded certificate tolerance, checked: a finite positive number
    at most :data:`LOADED_TOLERANCE_RTOL` times the largest product of norms the identities
    subtract (‖Φ‖‖F‖, ‖F*‖‖Φ‖, ‖J*‖‖H‖, …, computed here from the loaded matrices)."""
    if isinstance(tol, bool) or not isinstance(tol, (int, float)):
        raise UsageError("a float design must record its certificate tolerance (a number)")
    if not (math.isfinite(tol) and tol > 0):
        raise UsageError(f"a design's certificate tolerance must be a finite positive number,"
                         f" got {tol!r}")

    def nrm(X):
        X = sp.Matrix(X)
        return float(np.linalg.norm(np_exact(X))) if X.rows * X.cols else 0.0

    phi = nrm(mats["Phi"])
    sizes = [phi * nrm(plant[k]) for k in ("F", "G", "D", "L", "C")]
    sizes += [nrm(mats["F_star"]) * phi, nrm(mats["J_star"]) * nrm(plant["H"])]
    for a, b in (("H_star", None), ("R_star", "H"), ("Hz", None), ("Q", "H")):
        if a in mats:
            sizes.append(nrm(mats[a]) * (phi if b is None else nrm(plant[b])))
    if M is not None:
        sizes.append(nrm(M))
    cap = LOADED_TOLERANCE_RTOL * max([1.0] + sizes)
    if tol > cap:
        raise UsageError(f"a design's certificate tolerance {tol:.3g} exceeds"
                         f" {LOADED_TOLERANCE_RTOL:g} of the size of its identities' terms"
                         f" ({cap:.3g}): not a design this tool writes")
    return float(tol)


def _residual_norm(recorded, mats: dict, L) -> float:
    """An approximate design's ‖Φ L‖_F, recomputed from the loaded Φ and the model's L; a
    recorded value that differs (beyond rounding) is refused."""
    Ln = np_exact(sp.Matrix(L))
    value = float(np.linalg.norm(np_exact(sp.Matrix(mats["Phi"])) @ Ln)) if Ln.size else 0.0
    if recorded is not None and (isinstance(recorded, bool) or not isinstance(recorded, (int, float))
                                 or abs(recorded - value) > 1e-9 * max(1.0, value)):
        raise UsageError(f"a design's recorded residual_norm {recorded!r} is not ‖Φ L‖_F ="
                         f" {value:.6e} of its matrices")
    return value


def _check_substitutions(d, st) -> None:
    """Each argument substitution of a design file is the model's term φ_j with its
    argument A_j x written as A*_1j x* + A*_2j y (A*_1j, A*_2j certified above), and there
    is one for every nonzero column of C* — a changed function, or one left out, would
    change the observer while the matrices still pass (METHOD §2c)."""
    xs = sp.Matrix(list(d.observer_states))
    ys = sp.Matrix(list(output_symbols(sp.Matrix(st.H).rows)))
    m = d.matrices.as_dict()
    Cs = sp.Matrix(m["C_star"]) if "C_star" in m else None
    need = ({j + 1 for j in range(Cs.cols) if any(e != 0 for e in Cs[:, j])}
            if Cs is not None else set())
    have = [ns.index for ns in d.nonlinear]
    if sorted(have) != sorted(need):
        raise UsageError(f"the design's argument substitutions are for the terms"
                         f" {sorted(have) or 'none'}, but C* has nonzero columns"
                         f" {sorted(need) or 'none'}: not a design this tool writes")
    for ns in d.nonlinear:
        if not 1 <= ns.index <= len(st.terms) or ns.A1.shape != (1, len(xs)) \
                or ns.A2.shape != (1, len(ys)):
            raise UsageError(f"the design's argument substitution {ns.index} does not fit the"
                             " model's terms")
        t = st.terms[ns.index - 1]
        arg = sp.expand((ns.A1 * xs)[0, 0] + (ns.A2 * ys)[0, 0])
        if not (_same_expression(ns.argument, arg)
                and _same_expression(ns.function, t.function.xreplace({t.argument: arg}))):
            raise UsageError(f"the design's argument substitution {ns.index} is not the model's"
                             f" term {t.function} with A*_1 x* + A*_2 y as its argument: not a"
                             " design this tool writes")


def _check_diagonal_form(mats, plant: dict, M) -> None:
    """The diagonal form of seed 001 (method 1) that interval observers are built from:
    with T from the file, F_diag = T⁻¹ (F* − K H*) T diagonal, J_diag = T⁻¹ (J* + K R*),
    Φ_diag = T⁻¹ Φ, G_diag = T⁻¹ G*, H_z,diag = H_z T, recomputed exactly and compared,
    then certified as a design of its own (its identities against the plant)."""
    m = {k: sp.Matrix(v) for k, v in mats.as_dict().items()}
    T = m["T"]
    bad_t = UsageError("the design's T is not an invertible k × k matrix: not a design this"
                       " tool writes")
    if T.rows != T.cols or T.rows != m["F_star"].rows:
        raise bad_t
    K = m.get("K", sp.zeros(m["F_star"].rows, m["J_star"].cols))
    try:  # rational matrices (the usual case): exact arithmetic over QQ, fast for long numbers
        Q = {k: DomainMatrix.from_Matrix(v).convert_to(sp.QQ) for k, v in
             dict(m, K=K).items() if k in ("T", "F_star", "H_star", "J_star", "R_star", "Phi",
                                            "G_star", "Hz", "K", "F_diag", "J_diag",
                                            "Phi_diag", "G_diag", "Hz_diag")}
        if exact_rank_value(T) < T.rows:
            raise bad_t
        # T X = Y instead of X = T⁻¹ Y: products only (inverting a matrix of long rationals
        # cost seconds)
        Tq = Q["T"]

        def left(name):  # T · X_diag, or None when the file lacks it or its shape is wrong
            X = Q.get(name)
            return Tq * X if X is not None and X.shape[0] == Tq.shape[1] else None

        pairs = {"F_diag": (left("F_diag"), (Q["F_star"] - Q["K"] * Q["H_star"]) * Tq),
                 "J_diag": (left("J_diag"), Q["J_star"] + Q["K"] * Q["R_star"]),
                 "Phi_diag": (left("Phi_diag"), Q["Phi"]), "G_diag": (left("G_diag"), Q["G_star"]),
                 "Hz_diag": (Q.get("Hz_diag"), Q["Hz"] * Tq)}
        same = {k: a is not None and a.shape == b.shape and a == b for k, (a, b) in pairs.items()}
    except (CoercionFailed, KeyError):  # parameters or algebraic numbers: sympy, cancelled
        if T.det() == 0:
            raise bad_t from None
        Ti = T.inv()
        want = {"F_diag": Ti * (m["F_star"] - K * m["H_star"]) * T,
                "J_diag": Ti * (m["J_star"] + K * m["R_star"]), "Phi_diag": Ti * m["Phi"],
                "G_diag": Ti * m["G_star"], "Hz_diag": m["Hz"] * T}
        same = {k: k in m and m[k].shape == W.shape and all(
            _same_expression(a, b) for a, b in zip(m[k], W)) for k, W in want.items()}
    for name, ok in same.items():
        if not ok:
            raise UsageError(f"the design's {name} is not what its T makes of the certified"
                             " matrices: not a design this tool writes")
    if not m["F_diag"].is_diagonal():
        raise UsageError("the design's F_diag is not diagonal: not a design this tool writes")
    ExactArithmetic.certify(plant, {"Phi": m["Phi_diag"], "F_star": m["F_diag"],
                                    "J_star": m["J_diag"], "G_star": m["G_diag"],
                                    "Hz": m["Hz_diag"], "Q": m["Q"]}, M=M)


def _same_expression(a, b) -> bool:
    d = sp.expand(a - b)
    return d == 0 or sp.simplify(d) == 0


def _check_equations(d, work) -> None:
    """The equations and outputs a design file carries are what its (certified) matrices
    give — the observer is built from them, so they are checked, not trusted: the
    reduced model F* x* + J* y + G* u + C* Ψ* + K r (when K is there; METHOD §2), its
    estimates z = H_z x* + Q y and residuals r = R* y − H* x*, or the sliding-mode
    injection (seed 002 §5). A design without states, equations and outputs (the robust
    canonical designs: matrices only) has none to check."""
    if not (d.observer_states or d.equations or d.outputs):
        return
    m = d.matrices.as_dict()
    xs = tuple(d.observer_states)
    ys = output_symbols(len(work.outputs))
    measured = ys  # residuals and estimates read y − Gy u (inputs in the outputs)
    Gy = d.structure.Gy if d.structure is not None else None
    if Gy is not None and work.inputs and not Gy.is_zero_matrix:
        measured = tuple(sp.Matrix(ys) - sp.Matrix(Gy) * sp.Matrix(work.inputs))
    if d.observer == ObserverKind.SLIDING_MODE:
        fault = d.task.targets[0] if d.task.targets else ""
        options = [sliding_equations(m, work.inputs, xs[:1], ys, str(fault), inj,
                                     nonlinear=d.nonlinear, measured=measured)
                   for inj in INJECTIONS]
        candidates = [(u, dict(o)) for states, u, o in options
                      if [str(s) for s in states] == [str(s) for s in xs]]
    else:
        outs = {}
        if "Hz" in m:
            z = list(estimate_outputs(m, xs, measured))
            outs.update({("z" if len(z) == 1 else f"z{i + 1}"): e for i, e in enumerate(z)})
        if "R_star" in m and "H_star" in m:
            r = list(residual_outputs(m, xs, measured))
            outs.update({("r" if len(r) == 1 else f"r{i + 1}"): e for i, e in enumerate(r)})
        candidates = [(reduced_equations(m, work.inputs, xs, ys, nonlinear=d.nonlinear,
                                         measured=measured), outs)]
    for update, outs in candidates:
        if len(update) == len(d.equations) and all(
                _same_expression(a, b) for a, b in zip(d.equations, update)):
            break
    else:
        raise UsageError("the design's equations are not the ones its matrices give (the"
                         " observer is built from them): not a design this tool writes")
    for name, e in d.outputs:
        if name not in outs or not _same_expression(e, outs[name]):
            raise UsageError(f"the design's output {name} is not the one its matrices give:"
                             " not a design this tool writes")
    # and none is missing: the observers read them by name
    kind = d.observer
    need = (set(outs) if kind == ObserverKind.SLIDING_MODE else
            {n for n in outs if n[0] == "z"} if kind in (ObserverKind.VIRTUAL_SENSOR,
                                                          ObserverKind.INTERVAL) else
            {n for n in outs if n[0] == "r"} if kind == ObserverKind.DIAGNOSTIC else set())
    missing = sorted(need - {n for n, _ in d.outputs})
    if missing:
        raise UsageError(f"the design's outputs lack {', '.join(missing)}: not a design this"
                         " tool writes")
