"""Frozen design files, recomputed and never believed.

:meth:`Design.from_json` parses a design file with the whitelist reader, checks the
model's structure hash and re-certifies the matrices against the model. This module
goes further: everything a design reports besides its matrices — the conditions, the
assumptions, the closed-loop eigenvalues, the λ, the fault signature, the observer's
gain parameters, the sliding-mode inputs — is recomputed by designing again with the
file's recorded request (``design(model, **request.options())``, which reproduces the
design), and the recorded values serve only as a comparison: the matrices must be the
ones designing again gives (exactly; float designs within their certificate's
tolerance), and every recorded field must equal its recomputed value. A mismatch is
one :class:`~observer_cad.errors.UsageError` naming the field. What the loaded design
then reports is the recomputed value, never the file's.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import sympy as sp

from ..errors import ObserverCadError, UsageError
from ..model import PlantModel, is_identically_zero
from ..numerics import np_exact
from .core import Design
from ._dispatch import design

__all__ = ["load_design_data", "recomputed_design"]

#: the largest comparison this module makes by algebra (sympy's operation count of the
#: difference, and the largest integer exponent in it): a recorded value beyond it is not
#: one this tool writes, and is refused without expanding it
COMPARE_OPS = 400
COMPARE_EXPONENT = 64

#: the relative tolerance within which a float design's matrices must equal the ones
#: designing again gives (a float design is reproduced up to rounding)
FLOAT_MATRIX_RTOL = 1e-8


def load_design_data(data, model: PlantModel) -> Design:
    """The design ``data`` (a design file's JSON) describes for ``model``, parsed and
    certified (:meth:`Design.from_json`), then recomputed and compared (the module
    docstring). A file without a model hash or a request is refused: it cannot be
    checked."""
    if not isinstance(data, dict) or not isinstance(data.get("matrices"), dict):
        raise UsageError("not a design (no 'matrices')")
    if "model_hash" not in data:
        raise UsageError("the design records no 'model_hash' (the structure of the model it"
                         " was made for): design again")
    loaded = Design.from_json(data, model)
    if loaded.request is None:
        raise UsageError("the design records no 'request', so its conditions cannot be"
                         " recomputed: design again")
    try:
        fresh = design(model, **loaded.request.options())
    except ObserverCadError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UsageError(f"designing again with the recorded request fails ({first}): the"
                         " file does not describe a design of this model") from None
    return recomputed_design(data, loaded, fresh)


def recomputed_design(data: dict, loaded: Design, fresh: Design) -> Design:
    """``loaded`` (:meth:`Design.from_json` of ``data``) compared field by field with
    ``fresh`` (the same request designed again), with everything but its matrices and
    equations taken from ``fresh``; a mismatch is one UsageError naming the field."""
    fresh = fresh.with_signature() if data.get("signature_detail") else fresh
    _compare(data, loaded, fresh)
    return dataclasses.replace(
        loaded, conditions=fresh.conditions, assumptions=fresh.assumptions,
        closed_loop_eigenvalues=fresh.closed_loop_eigenvalues, lambdas=fresh.lambdas,
        signature=fresh.signature, choice=fresh.choice, attempts=fresh.attempts,
        null_space=fresh.null_space, parameters=fresh.parameters, nonlinear=loaded.nonlinear)


def _refuse(field: str, why: str):
    raise UsageError(f"the recorded {field} {why}: the file is not what designing again"
                     " gives (refused, never believed)")


def _compare(data: dict, loaded: Design, fresh: Design) -> None:
    """Every recorded field against its recomputed value (the module docstring)."""
    for key, want in (("k", fresh.k), ("form", fresh.form.value),
                      ("method", fresh.method.value), ("observer", fresh.observer.value),
                      ("time", fresh.time), ("approximate", bool(fresh.approximate)),
                      ("symbolic", bool(fresh.symbolic))):
        if key in data and data[key] != want:
            _refuse(key, f"{data[key]!r} is not {want!r}")
    _compare_matrices(loaded, fresh)
    _compare_conditions(data.get("conditions", []), fresh.conditions)
    _compare_texts("assumptions", data.get("assumptions", []),
                   [str(a) for a in fresh.assumptions], ordered=False)
    for key, mine, theirs in (("closed_loop_eigenvalues", loaded.closed_loop_eigenvalues,
                               fresh.closed_loop_eigenvalues),
                              ("lambdas", loaded.lambdas, fresh.lambdas)):
        _compare_values(key, mine, theirs)
    _compare_texts("states", data.get("states", []),
                   [str(s) for s in fresh.observer_states], ordered=True)
    rec_params = data.get("parameters") or {}
    if sorted(rec_params) != sorted(str(p) for p in fresh.parameters):
        _refuse("parameters", f"{sorted(rec_params)} are not"
                f" {sorted(str(p) for p in fresh.parameters)}")
    _compare_values("parameters", [loaded.parameters[p] for p in sorted(loaded.parameters, key=str)],
                    [fresh.parameters[p] for p in sorted(fresh.parameters, key=str)])
    if "signature" in data and data["signature"] != fresh.signature_map:
        _refuse("signature", f"{data['signature']} is not {fresh.signature_map}")
    if data.get("signature_detail") and data["signature_detail"] != [
            s.to_json() for s in fresh.signature]:
        _refuse("signature_detail", "differs from the recomputed fault signature")
    if fresh.request is not None and data.get("request") != fresh.request.to_json():
        _refuse("request", "differs from the request designing again records")
    if "task" in data and data["task"] != fresh.task.to_json():
        _refuse("task", "differs from the task designing again resolves")
    want_sliding = fresh.sliding_inputs.to_json() if fresh.sliding_inputs is not None else None
    if data.get("sliding_inputs") != want_sliding:
        _refuse("sliding_inputs", "differ from the recomputed ones")
    if [n.to_json() for n in loaded.nonlinear] != [n.to_json() for n in fresh.nonlinear]:
        _refuse("nonlinear", "argument substitutions differ from the recomputed ones")
    cert = data.get("certificate")
    if isinstance(cert, dict) and cert.get("passed") is not True:
        _refuse("certificate", "does not say it passed")


def _compare_matrices(loaded: Design, fresh: Design) -> None:
    mine, theirs = loaded.matrices.as_dict(), fresh.matrices.as_dict()
    if sorted(mine) != sorted(theirs):
        _refuse("matrices", f"are {', '.join(sorted(mine))}, not {', '.join(sorted(theirs))}")
    exact = loaded.certificate.exact and fresh.certificate.exact
    for name in theirs:
        A, B = sp.Matrix(mine[name]), sp.Matrix(theirs[name])
        if A.shape != B.shape:
            _refuse(f"matrix {name}", f"is {A.rows}×{A.cols}, not {B.rows}×{B.cols}")
        if A == B or A.rows * A.cols == 0:
            continue
        if exact or A.free_symbols or B.free_symbols:
            same = all(_same_value(a, b) for a, b in zip(A, B))
        else:
            a, b = np_exact(A), np_exact(B)
            same = bool(np.all(np.isfinite(a))) and np.allclose(
                a, b, rtol=FLOAT_MATRIX_RTOL, atol=FLOAT_MATRIX_RTOL * max(1.0, np.abs(b).max()))
        if not same:
            _refuse(f"matrix {name}", "differs from the one designing again gives")


def _compare_conditions(recorded, fresh) -> None:
    """Required conditions by name, verdict and kind; informative ones (a minimality proof
    within a time budget may settle differently on another machine) by name only. The
    evidence text is the recomputed one."""
    if not isinstance(recorded, list):
        _refuse("conditions", "are not a list")
    names = [c.get("name") if isinstance(c, dict) else None for c in recorded]
    want = [c.name for c in fresh]
    for n in names:
        if n not in want:
            _refuse("conditions", f"include {str(n)[:80]!r}, which designing again does not"
                    " report")
    for c in fresh:
        if c.name not in names:
            _refuse("conditions", f"lack {c.name!r}")
        rec = recorded[names.index(c.name)]
        if c.required and (rec.get("holds") is not bool(c.holds)
                           or rec.get("required", True) is not True):
            _refuse(f"condition {c.name!r}", f"says holds = {rec.get('holds')!r}, recomputed"
                    f" {bool(c.holds)}")
    if len(names) != len(want):
        _refuse("conditions", f"are {len(names)}, designing again reports {len(want)}")


def _compare_texts(field: str, recorded, want, *, ordered: bool) -> None:
    if not isinstance(recorded, list) or not all(isinstance(x, str) for x in recorded):
        _refuse(field, "are not a list of strings")
    a, b = (list(recorded), list(want)) if ordered else (sorted(recorded), sorted(want))
    if a != b:
        missing = [x for x in want if x not in recorded]
        extra = [x for x in recorded if x not in want]
        what = (f"lack {missing[0]}" if missing else f"include {extra[0][:80]}" if extra
                else f"are {a}, not {b}")
        _refuse(field, what)


def _compare_values(field: str, mine, theirs) -> None:
    """Parsed values (eigenvalues, λ, gains) against the recomputed ones, in order."""
    if len(mine) != len(theirs):
        _refuse(field, f"list {len(mine)} value(s), designing again gives {len(theirs)}")
    for a, b in zip(mine, theirs):
        if not _same_value(a, b):
            _refuse(field, f"hold {a}, designing again gives {b}")


def _same_value(a, b) -> bool:
    """Whether two parsed values are equal: identical, or (within :data:`COMPARE_OPS` and
    :data:`COMPARE_EXPONENT`, so that nothing recorded is expanded without bound) their
    difference is identically zero."""
    if a == b:
        return True
    d = a - b
    if sp.count_ops(d) > COMPARE_OPS or any(
            p.exp.is_Integer and abs(int(p.exp)) > COMPARE_EXPONENT for p in d.atoms(sp.Pow)):
        return False
    return is_identically_zero(d).holds
