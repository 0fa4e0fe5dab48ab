"""Human-readable and JSON renderings of models, structures and designs."""
from __future__ import annotations

import sympy as sp

from ..synthesis import Design
from ..model import Structure
from ..numerics import readable, with_full_int_text

__all__ = ["format_matrix", "format_structure", "format_design", "structure_to_json",
           "format_observer", "format_observer_conditions", "format_signature", "format_bank"]


def format_matrix(name: str, M, indent: str = "  ") -> str:
    """A matrix as aligned rows: ``name = [ a  b ]`` with later rows under the first.

    Examples
    --------
    >>> import sympy as sp
    >>> from observer_cad.reporting import format_matrix
    >>> k = sp.Symbol("k")
    >>> print(format_matrix("Phi", [[1, 0, 0], [1, k, -k/2]]))
      Phi = [ 1  0     0 ]
            [ 1  k  -k/2 ]
    """
    M = sp.Matrix(M)
    head = f"{indent}{name} = "
    if M.rows == 0 or M.cols == 0:
        return f"{head}(empty, {M.rows}x{M.cols})"
    cells = [[readable(M[i, j]) for j in range(M.cols)] for i in range(M.rows)]
    widths = [max(len(cells[i][j]) for i in range(M.rows)) for j in range(M.cols)]
    lines = []
    for i in range(M.rows):
        body = "  ".join(cells[i][j].rjust(widths[j]) for j in range(M.cols))
        lines.append((head if i == 0 else " " * len(head)) + f"[ {body} ]")
    return "\n".join(lines)


def _mark(holds: bool, required: bool = True) -> str:
    if holds:
        return "[ ok ]"
    return "[FAIL]" if required else "[ -- ]"


def structure_to_json(st: Structure) -> dict:
    m = st.model

    def rows(M):
        M = sp.Matrix(M)
        return [[str(M[i, j]) for j in range(M.cols)] for i in range(M.rows)]
    return {
        "model": m.name, "time": m.time, "source": m.source,
        "states": [s.name for s in m.states], "inputs": [s.name for s in m.inputs],
        "outputs": {f"y{i + 1}": str(h) for i, h in enumerate(m.outputs)},
        "faults": [s.name for s in m.faults], "disturbances": [s.name for s in m.disturbances],
        "noise": [s.name for s in m.noise],
        "parameters": {p.name: (None if v is None else str(v)) for p, v in m.parameters.items()},
        "bounds": {s.name: [str(lo), str(hi)] for s, (lo, hi) in m.bounds.items()},
        "initial": {s.name: [str(lo), str(hi)] for s, (lo, hi) in m.initial.items()},
        "domain": [str(r) for r in m.domain],
        "matrices": {name: rows(getattr(st, name)) for name in _structure_matrices(st, True)},
        "nonlinear": [{"function": str(t.function.xreplace({t.argument: sp.Symbol("s")})),
                       "argument": str((t.row * sp.Matrix(m.states))[0, 0]),
                       "row": [str(e) for e in t.row]} for t in st.terms],
        "certificate": st.certificate.to_json() if st.certificate is not None else None,
    }


def _structure_matrices(st: Structure, with_bw: bool = False) -> tuple:
    """The matrices shown: Bw when the model has process noise (or ``with_bw``: the JSON
    always has it), the output feedthrough Gy, Dy, Ly only for a model that has some
    (inputs, faults or disturbances in the outputs)."""
    names = ("F", "G", "H", "C", "D", "L", "W")
    if with_bw or not st.Bw.is_zero_matrix:
        names += ("Bw",)
    return names + ("Gy", "Dy", "Ly") if st.has_feedthrough else names


def format_structure(st: Structure) -> str:
    m = st.model
    names = lambda seq: ", ".join(s.name for s in seq) or "-"  # noqa: E731
    out = [f"Model {m.name} ({m.time} time{', from ' + m.source if m.source else ''})",
           f"  states       x = ({names(m.states)})",
           f"  inputs       u = ({names(m.inputs)})",
           "  outputs      " + ", ".join(f"y{i + 1} = {h}" for i, h in enumerate(m.outputs)),
           f"  faults       d = ({names(m.faults)})",
           f"  disturbances rho = ({names(m.disturbances)})",
           f"  noise        w = ({names(m.noise)})"]
    if m.parameters:
        out.append("  parameters   " + ", ".join(
            f"{p} = {'(no value)' if v is None else v}" for p, v in m.parameters.items()))
    if m.bounds:
        out.append("  bounds       " + ", ".join(f"{s} in [{lo}, {hi}]" for s, (lo, hi) in m.bounds.items()))
    if m.initial:
        out.append("  initial      " + ", ".join(f"{s}(0) in [{lo}, {hi}]" for s, (lo, hi) in m.initial.items()))
    if m.domain:
        out.append("  domain       " + ", ".join(str(r) for r in m.domain))
    lhs = "x(t+1)" if m.time == "discrete" else "dx/dt"
    process = not st.Bw.is_zero_matrix  # process noise: shown only when the model has it
    y = "H x + Gy u + Dy d + Ly rho + W w" if st.has_feedthrough else "H x + W w"
    out.append(f"\n  {lhs} = F x + G u + C Psi(x, u) + D d + L rho{' + Bw w' if process else ''},"
               f"   y = {y}\n")
    for name in _structure_matrices(st):
        out.append(format_matrix(name, getattr(st, name)))
    if st.terms:
        out.append("\n  nonlinear terms Psi_j = phi_j(A_j x, u):")
        for j, t in enumerate(st.terms, 1):
            ax = (t.row * sp.Matrix(m.states))[0, 0]
            out.append(f"    Psi_{j} = {t.of_state(m.states)}    (A_{j} = {list(t.row)}, argument {ax})")
    if st.certificate is not None:
        cert = st.certificate
        out.append("\n  model certificate: the matrices rebuild the model's equations")
        out.append(f"    {cert.IDENTITY}")
        for c in cert.checks:
            mark = "exact  " if c.exact else "numeric"
            out.append(f"    [{mark}] {c.equation}: {c.how}")
    return "\n".join(out)


def _title(d: Design) -> str:
    what = {
        "unknown-input": f"estimate {d.unknown_input}",
        "diagnostic": f"diagnostic observer (residual) for fault(s) {', '.join(d.task.targets)}",
        "virtual-sensor": f"virtual sensor for z = {d.estimate}",
        "interval": f"interval observer for z = {d.estimate}",
    }.get(d.observer, d.observer)
    dec = f", decoupled from {', '.join(d.decoupled)}" if d.decoupled else ""
    kind = "APPROXIMATE (robust) " if d.approximate else ""
    return (f"Design for {d.model_name}: {what}{dec} — {kind}{d.form} form, k = {d.k},"
            f" {'symbolic' if d.symbolic else 'numeric'} ({d.method} arithmetic)")


def _approximate(values) -> str:
    """The values to 6 significant digits when some numeric one is long to read (a rational
    of over 24 characters, a surd, a CRootOf); "" when each reads as it is or one is
    symbolic."""
    if any(isinstance(v, str) for v in values):  # text is never parsed here
        return ""
    vals = [sp.sympify(v) for v in values]  # sympy numbers, or Python ints and floats
    if not all(v.is_number and v.is_real for v in vals):
        return ""
    if not any(not (v.is_Rational or v.is_Float) or len(str(v)) > 24 for v in vals):
        return ""  # rationals and floats read as they are
    return ", ".join(f"{float(sp.N(v, 20)):.6g}" for v in vals)


@with_full_int_text  # equations may carry rationals of any length
def format_design(d: Design) -> str:
    """A design as a control engineer reads it: matrices, equations, conditions."""
    out = [_title(d), ""]
    if d.lambdas:
        out.append(f"  λ = ({', '.join(str(v) for v in d.lambdas)})")
        approx = _approximate(d.lambdas)
        if approx:
            out.append(f"  λ ≈ ({approx})")
    if d.closed_loop_eigenvalues:
        out.append(f"  closed-loop eigenvalues: {', '.join(str(v) for v in d.closed_loop_eigenvalues)}")
    for name, M in d.ordered_matrices:
        out.append(format_matrix(name, M))
    if d.nonlinear:
        out.append("\n  nonlinear terms after argument substitution (METHOD §2c):")
        for ns in d.nonlinear:
            out.append(f"    Psi*_{ns.index} = {ns.function}    (argument {ns.argument})")
    if d.equations:
        dot = "(t+1)" if d.time == "discrete" else "'"
        out.append("\n  observer equations:")
        for x, e in zip(d.observer_states, d.equations):
            out.append(f"    {x}{dot} = {e}")
        for name, e in d.outputs:
            out.append(f"    {name} = {e}")
    if d.approximate:
        out.append(f"\n  APPROXIMATE: the decoupling is not exact; achieved residual norm {d.residual_norm:.6g}")
    out.append("\nConditions")
    for c in d.conditions:
        out.append(f"  {_mark(c.holds, c.required)} {c.name}: {c.detail}"
                   + (f"  [{c.reference}]" if c.reference else ""))
    if d.signature:
        out.append("\n" + format_signature(d.signature))
    none = (": none (numeric design; the decoupling is APPROXIMATE, see the residual norm)"
            if d.approximate else ": none (exact for all parameter values)")
    out.append("\nAssumptions" + ("" if d.assumptions else none))
    for a in d.assumptions:
        out.append(f"  {a}")
    out.append(f"\nChoice\n  {d.choice}")
    return "\n".join(out)


def _gain_text(gains) -> str:
    """Steady-state gains as printed: exact values as they are, floats to 4 digits."""
    parts = [f"{float(g):.4g}" if isinstance(g, sp.Float) else str(g) for g in gains]
    return parts[0] if len(parts) == 1 else "[" + ", ".join(parts) + "]"


def format_signature(signature, indent: str = "  ") -> str:
    """The "Fault signature" section: every declared fault, sensitive or decoupled, with
    Φ D_j, what the design does with it and the relations a sensitivity needs."""
    out = ["Fault signature (every declared fault against the observer's reduced model:"
           " 1 = Φ D_j reaches what the observer outputs)"]
    width = max(len(s.name) for s in signature)
    for s in signature:
        note = ""
        if s.sensitive and s.role in ("assumed zero", "decoupled"):
            note = f"  — not a target ({s.role}), yet a nonzero {s.name} moves r"
        elif not s.sensitive and s.role in ("detected", "estimated"):
            note = "  — a target the residual does NOT see"
        gain = getattr(s, "steady_gain", None)
        gain = "" if gain is None else f"; steady-state gain = {_gain_text(gain)}"
        out.append(f"{indent}{s.name.ljust(width)}  {int(bool(s.sensitive))}  {s.describe()}"
                   f"  [{s.role}; {s.entry_text()}{gain}]{note}")
    return "\n".join(out)


def format_bank(bank) -> str:
    """A residual bank: its structure matrix, which pairs it isolates, then each residual
    generator's design (with its fault signature)."""
    faults = list(bank.faults)
    w = max(len(f) for f in faults)
    out = [f"Residual bank for {bank.model_name}: {len(bank.designs)} residual generator(s) over"
           f" faults ({', '.join(faults)}) — {bank.scheme}"
           + (f"; every residual also decoupled from {', '.join(bank.disturbances)}"
              if bank.disturbances else ""), "",
           "Structure matrix (row = residual, column = fault; 1 = the residual responds,"
           " recomputed from O Φ D_j)"]
    head = "        " + "  ".join(f.rjust(w) for f in faults)
    out.append(head)
    for i, (row, d) in enumerate(zip(bank.structure_matrix, bank.designs), 1):
        out.append(f"  r{i}".ljust(8) + "  ".join(str(c).rjust(w) for c in row)
                   + f"    (k = {d.k}, λ = ({', '.join(map(str, d.lambdas))}))")
    out.append("\nDetectable: " + ", ".join(f"{f} {'yes' if ok else 'NO'}"
                                              for f, ok in bank.detectable.items()))
    if len(faults) > 1:
        out.append("Isolable pairs (both detected, columns differ): " + ", ".join(
            f"{a}/{b} {'yes' if ok else 'NO'}" for (a, b), ok in bank.isolable))
    if tuple(bank.strong_structure) != tuple(bank.structure_matrix):
        out.append("Strong structure matrix (1 = a nonzero steady-state gain): " + ", ".join(
            f"r{i} {''.join(map(str, r))}" for i, r in enumerate(bank.strong_structure, 1)))
    if bank.transient_note:
        out.append(bank.transient_note)
    out.append(f"\nChoice\n  {bank.choice}")
    if bank.refused:
        out.append("\nRows tried and not achievable")
        for row, why in bank.refused:
            out.append(f"  {row}: {why}")
    out.append("\nAssumptions" + ("" if bank.assumptions else ": none"))
    for a in bank.assumptions:
        out.append(f"  {a}")
    for i, d in enumerate(bank.designs, 1):
        out += ["", f"== residual r{i} (row {''.join(map(str, bank.structure_matrix[i - 1]))}) ==",
                format_design(d)]
    return "\n".join(out)


def format_observer_conditions(ob) -> str:
    """The conditions building the observer checked, in the design's format."""
    conds = ob.own_conditions
    if not conds:
        return ""
    out = ["\nObserver conditions"]
    for c in conds:
        out.append(f"  {_mark(c.holds, c.required)} {c.name}: {c.detail}"
                   + (f"  [{c.reference}]" if c.reference else ""))
    return "\n".join(out)


def format_observer(ob) -> str:
    """The observer's equations, parameters and outputs."""
    out = [f"\nObserver ({ob.kind}, {ob.time} time): {ob.description}"]
    if ob.parameters:
        out.append("  parameters: " + ", ".join(f"{p} = {v}" for p, v in ob.parameters.items()))
    for line in ob.equations_text():
        out.append(f"    {line}")
    if ob.delays:
        out.append("  delayed outputs: " + ", ".join(f"{k} (estimate of t − {v})" for k, v in ob.delays.items()))
    return "\n".join(out)
