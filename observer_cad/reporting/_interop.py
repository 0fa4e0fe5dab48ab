"""Interoperability: python-control state-space models, LaTeX and JSON exports.

* :func:`to_statespace` — a *linear* observer (virtual sensor, residual generator,
  linear interval observer, …) as a ``control.StateSpace`` with named states, inputs
  (the signals it reads: ``y1, y2, …``, then the known inputs ``u``) and outputs.
  Continuous-time observers give a continuous system, discrete-time ones a system with
  sample time 1 (time in steps). python-control is an optional dependency
  (``pip install control``), imported only here.
* :func:`linear_matrices` — the same A, B, C, D as exact sympy matrices, without
  python-control.
* :func:`design_latex` / :func:`design_latex_document` — every matrix of a design as
  LaTeX (name → string), and a whole LaTeX document (or body snippet) with the
  matrices and the observer equations.
* :func:`write_design_json` / :func:`read_design_json` / :func:`matrices_from_json` —
  ``Design.to_json`` written atomically to a file, read back, and its matrices parsed
  back into exact sympy matrices.
"""
from __future__ import annotations

import json
from pathlib import Path

import sympy as sp

from ..files import atomic_write_text, read_json_file
from ..analysis import BANK_KIND, load_design
from ..synthesis import Design
from ..errors import UsageError
from ..model import parse_expression
from ..numerics import rationalize_floats
from ..observers import Observer
from ._markdown import design_equations_latex, design_matrices_latex

__all__ = ["linear_matrices", "to_statespace", "design_latex", "design_latex_document",
           "write_design_json", "read_design_json", "matrices_from_json", "write_design_latex"]


def _control():
    try:
        import control  # noqa: F401
    except ModuleNotFoundError:
        raise UsageError("python-control is not installed (pip install control);"
                         " it is needed only for the StateSpace export") from None
    return control


def _observer_of(obj, model=None, **options) -> Observer:
    if isinstance(obj, Observer):
        return obj
    if isinstance(obj, Design):
        if model is None:
            raise UsageError("to export a design as a StateSpace, pass the model too"
                             " (to_statespace(design, model))")
        from ..observers import build_observer
        return build_observer(model, obj, **options)
    raise UsageError(f"expected an Observer or a Design, got {type(obj).__name__}")


def linear_matrices(observer: Observer, *, constant_input: bool = False):
    """(A, B, C, D, inputs) of a linear observer: ξ' (or ξ(t+1)) = A ξ + B s,
    o = C ξ + D s, with s the observer's signals (``y…`` then ``u…``) — exact sympy
    matrices with the parameters substituted.

    An affine observer (constant terms, e.g. the ±w* of an interval observer) raises
    unless ``constant_input=True``, which appends a constant input named ``1`` whose
    columns hold the constant terms (drive it with the value 1).
    """
    par = {sp.Symbol(str(k)) if not isinstance(k, sp.Symbol) else k: sp.sympify(v)
           for k, v in observer.parameters.items()}
    xs = list(observer.states)
    ss = list(observer.signals)
    f = [sp.sympify(e).xreplace(par) for e in observer.update]
    g = [sp.sympify(e).xreplace(par) for _, e in observer.outputs]
    v = xs + ss
    zero = {s: 0 for s in v}
    consts = []
    rows = []
    for what, e in [("update of " + str(x), e) for x, e in zip(xs, f)] + \
                    [("output " + n, e) for (n, _), e in zip(observer.outputs, g)]:
        jac = [sp.diff(e, s) for s in v]
        for s, c in zip(v, jac):
            c = sp.simplify(c) if c.free_symbols else c
            if c.free_symbols or c.has(sp.Piecewise, sp.Max, sp.Min, sp.Abs, sp.sign):
                raise UsageError(f"observer {observer.name} is not linear: the {what} depends"
                                 f" nonlinearly on {s} (d/d{s} = {c}); only linear observers"
                                 " export to a StateSpace")
        c0 = sp.simplify(e.xreplace(zero))
        if c0.free_symbols:
            raise UsageError(f"observer {observer.name}: the {what} has symbols without a value:"
                             f" {sorted(map(str, c0.free_symbols))}")
        rows.append([rationalize_floats(c) for c in jac])  # floats only; exact stays exact
        consts.append(c0)
    n, m = len(xs), len(ss)
    J = sp.Matrix(rows) if rows else sp.zeros(0, n + m)
    A, B = J[:n, :n], J[:n, n:]
    C, D = J[n:, :n], J[n:, n:]
    inputs = [str(s) for s in ss]
    if any(c != 0 for c in consts):
        if not constant_input:
            nz = [str(x) for x, c in zip(list(xs) + list(observer.output_names), consts) if c != 0]
            raise UsageError(f"observer {observer.name} is affine (constant terms in {', '.join(nz)});"
                             " use constant_input=True to add a constant input '1'")
        k = sp.Matrix(consts)
        B = B.row_join(k[:n, :])
        D = D.row_join(k[n:, :])
        inputs.append("1")
    return A, B, C, D, inputs


def to_statespace(obj, model=None, *, constant_input: bool = False, **options):
    """A ``control.StateSpace`` of a linear observer (or of a design, with its model).

    Continuous time: ``dt = 0``; discrete time: ``dt = 1`` (one step). Outputs that the
    observer declares as delayed (``observer.delays``) are what it computes at step t:
    the estimate for t − delay.
    """
    ct = _control()
    ob = _observer_of(obj, model, **options)
    A, B, C, D, inputs = linear_matrices(ob, constant_input=constant_input)
    import numpy as np

    def num(M, r, c):
        return np.array(M.evalf(), dtype=float).reshape(r, c)
    n, m, p = A.rows, B.cols, C.rows
    dt = 0 if ob.time == "continuous" else 1
    return ct.ss(num(A, n, n), num(B, n, m), num(C, p, n), num(D, p, m), dt,
                 states=[str(s) for s in ob.states], inputs=inputs,
                 outputs=list(ob.output_names), name=ob.name)


# ---------------------------------------------------------------- LaTeX
def design_latex(design: Design) -> dict:
    """Every matrix of the design as LaTeX: name → ``"\\Phi = \\left(\\begin{matrix}…"``."""
    return design_matrices_latex(design)


def design_latex_document(design: Design, *, standalone: bool = True) -> str:
    """The design's matrices and observer equations as LaTeX: a whole document
    (``standalone=True``, compiles with pdflatex and amsmath) or the body snippet."""
    what = f"{design.model_name}: {design.observer}, {design.form} form, k = {design.k}"
    what = what.replace("_", r"\_")
    lines = [v.replace(" = ", " &= ", 1) for v in design_matrices_latex(design).values()]
    body = [rf"\section*{{{what}}}", r"\begin{align*}", " \\\\\n".join(lines), r"\end{align*}"]
    if design.equations:
        eq = design_equations_latex(design)
        body += [r"Observer equations:", r"\begin{align*}", " \\\\\n".join(eq), r"\end{align*}"]
    if design.assumptions:
        body += ["Assumptions: " + ", ".join(f"${sp.latex(a)}$" for a in design.assumptions) + "."]
    body += [rf"Certificate: {'passed' if design.certificate.passed else 'FAILED'}"
             rf" ({'exact' if design.certificate.exact else 'float'})."]
    text = "\n".join(body)
    if not standalone:
        return text + "\n"
    return ("\\documentclass{article}\n\\usepackage{amsmath,amssymb}\n"
            "\\usepackage[margin=2cm]{geometry}\n\\begin{document}\n"
            + text + "\n\\end{document}\n")


def write_design_latex(design: Design, path, *, standalone: bool = True) -> Path:
    path = Path(path)
    atomic_write_text(path, design_latex_document(design, standalone=standalone))
    return path


# ---------------------------------------------------------------- JSON
def write_design_json(design, path) -> Path:
    """``design.to_json()`` written atomically (UTF-8, indented, sorted keys kept in order):
    a :class:`Design` or a residual bank, each read back by :func:`read_design_json`."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{path.parent}: cannot create the directory: {exc.strerror}") from None
    atomic_write_text(path, json.dumps(design.to_json(), indent=2, ensure_ascii=False) + "\n")
    return path


def read_design_json(path, model=None):
    """What :func:`write_design_json` wrote; one-line error for a missing or bad file.

    With ``model`` (the :class:`PlantModel` the design is for) the result is the
    :class:`Design` (or residual bank) itself — parsed by the whitelist reader,
    re-certified, its model hash checked and everything it reports recomputed
    (:func:`observer_cad.analysis.load_design`), ready for ``build_observer(model,
    design)``; without it, the JSON object (a dict)."""
    if model is not None:
        return load_design(path, model)
    data = read_json_file(path, "design")
    if not isinstance(data, dict) or not (isinstance(data.get("matrices"), dict)
                                          or data.get("kind") == BANK_KIND):
        raise UsageError(f"{path}: not a design (no 'matrices') nor a residual bank")
    return data


def matrices_from_json(data: dict) -> dict:
    """The ``matrices`` of a design's JSON as exact sympy matrices (name → Matrix)."""
    out = {}
    for name, rows in data["matrices"].items():
        if not rows:
            out[name] = sp.zeros(0, 0)
            continue
        if not isinstance(rows, list) or not all(isinstance(r, list) for r in rows) \
                or len({len(r) for r in rows}) != 1:
            raise UsageError(f"design JSON: matrix {name} is not a list of equal-length rows")
        out[name] = sp.Matrix([[_parse(e, name) for e in row] for row in rows]) if rows[0] \
            else sp.zeros(len(rows), 0)
    return out


def _parse(text: str, matrix: str = "?"):
    """An expression printed by sympy, read by the safe reader (never evaluated); every
    name that is not a known function or constant is a Symbol (so a parameter called
    ``gamma`` or ``S`` stays a symbol); decimals stay floats; ``CRootOf(poly, index)`` is
    the real algebraic number (an irrational Jordan λ)."""
    return parse_expression(str(text), where=f"design JSON: matrix {matrix}",
                            allow_complex=True, any_name=True, exact_floats=False,
                            allow_crootof=True)
