"""Markdown reports with LaTeX: designs, observers, conditions, timings and figures.

Used by ``observer-cad demo`` (``out/report.md``) and by :mod:`observer_cad.reporting`
(LaTeX export of a design's matrices). Equations and matrices are rendered by
:func:`sympy.latex` into ``$$ … $$`` blocks; the observer's symbols get their usual
typography (``xs1`` → x*₁, ``xl1``/``xu1`` → lower/upper copies, ``d_hat`` → d̂,
``x1_lower`` → x̲₁ …). Markdown text taken from designs (condition names and details)
is escaped so that ``J*`` or ``|`` cannot turn into emphasis or table cells.
"""
from __future__ import annotations

import re
from typing import Iterable, Sequence

import sympy as sp

__all__ = ["symbol_latex", "matrix_name_latex", "matrix_latex", "expr_latex",
           "design_matrices_latex", "design_equations_latex", "observer_equations_latex",
           "latex_block", "md_escape", "conditions_table", "certificate_table",
           "design_section", "render_report", "lag_states", "analysis_markdown",
           "bank_markdown"]


# ---------------------------------------------------------------- symbols and names
def _accent(accent: str, inner: str) -> str:
    """``\\hat{x}_{1}`` rather than ``\\hat{x_{1}}``: the accent on the letter only."""
    m = re.fullmatch(r"(\\?[A-Za-z]+)(_\{.*\})?(\^\{.*\})?", inner)
    if m and m.group(2) and not m.group(3):
        return rf"{accent}{{{m.group(1)}}}{m.group(2)}"
    if m and m.group(2) and m.group(3):
        return rf"{accent}{{{m.group(1)}}}{m.group(3)}{m.group(2)}"
    return rf"{accent}{{{inner}}}"


_SPECIAL = {
    "k_sm": r"k_{\mathrm{sm}}",
    "eps_sm": r"\varepsilon_{\mathrm{sm}}",
    "alpha_eps": r"\varepsilon_{\alpha}",
    "alpha": r"\alpha",
    "t": "t",
}


def symbol_latex(name) -> str:
    """LaTeX for one symbol name of a model, design or observer."""
    name = str(name)
    if name in _SPECIAL:
        return _SPECIAL[name]
    m = re.fullmatch(r"xs(\d+)", name)
    if m:
        return rf"x^{{*}}_{{{m.group(1)}}}"
    m = re.fullmatch(r"r(\d+)_xs(\d+)", name)
    if m:  # state j of residual generator i of a bank (observers.bank_observer)
        return rf"x^{{*({m.group(1)})}}_{{{m.group(2)}}}"
    m = re.fullmatch(r"x([lu])(\d+)", name)
    if m:
        acc = r"\underline" if m.group(1) == "l" else r"\overline"
        return rf"{acc}{{x}}^{{*}}_{{{m.group(2)}}}"
    m = re.fullmatch(r"(.+)_lag(\d+)", name)
    if m:  # the value one (or k) steps earlier, kept as an observer state
        return rf"{{{symbol_latex(m.group(1))}}}^{{[-{m.group(2)}]}}"
    for suffix, acc in (("_hat", r"\hat"), ("_lower", r"\underline"), ("_upper", r"\overline"),
                        ("_min", r"\underline"), ("_max", r"\overline")):
        if name.endswith(suffix) and len(name) > len(suffix):
            return _accent(acc, symbol_latex(name[: -len(suffix)]))
    m = re.fullmatch(r"([A-Za-z]+)_(\w+)", name)
    if m and m.group(1) not in ("x",):
        base = sp.latex(sp.Symbol(m.group(1)))
        sub = m.group(2)
        sub = sp.latex(sp.Symbol(sub)) if len(sub) > 1 and sp.latex(sp.Symbol(sub)).startswith("\\") \
            else (sub if sub.isdigit() or len(sub) == 1 else rf"\mathrm{{{sub}}}")
        return f"{base}_{{{sub}}}"
    return sp.latex(sp.Symbol(name))


def matrix_name_latex(name: str) -> str:
    """``Phi`` → Φ, ``F_star`` → F*, ``Hz`` → H_z, ``F_diag`` → F_diag, …"""
    parts = name.split("_")
    base = parts[0]
    tex = {"Phi": r"\Phi", "Hz": "H_{z}", "Psi": r"\Psi"}.get(base, base)
    sup, sub = "", []
    for p in parts[1:]:
        if p == "star":
            sup = "^{*}"
        else:
            sub.append(rf"\mathrm{{{p}}}")
    if sub:
        if tex == "H_{z}":
            tex = "H_{z," + ",".join(sub) + "}"
        else:
            tex = f"{tex}_{{{','.join(sub)}}}"
    return tex + sup


def _names(exprs) -> dict:
    syms = set()
    for e in exprs:
        syms |= sp.sympify(e).free_symbols
    return {s: symbol_latex(s.name) for s in syms}


def expr_latex(e, names: dict | None = None) -> str:
    """One expression, with the observer's symbol typography."""
    e = sp.sympify(e)
    return sp.latex(e, symbol_names=names if names is not None else _names([e]))


def matrix_latex(M) -> str:
    """A matrix in round brackets (``pmatrix``-like); empty matrices are named as such.

    Examples
    --------
    >>> import sympy as sp
    >>> from observer_cad.reporting import matrix_latex
    >>> print(matrix_latex(sp.Matrix([[1, sp.Rational(1, 2)]])))
    \\left(\\begin{matrix}1 & \\frac{1}{2}\\end{matrix}\\right)
    >>> print(matrix_latex(sp.zeros(2, 0)))
    \\emptyset_{2\\times 0}
    """
    M = sp.Matrix(M)
    if M.rows == 0 or M.cols == 0:
        return rf"\emptyset_{{{M.rows}\times {M.cols}}}"
    return sp.latex(M, mat_delim="(", symbol_names=_names(list(M)))


def latex_block(lines: Sequence[str]) -> str:
    """A display-math block ``$$ \\begin{aligned} … \\end{aligned} $$``."""
    lines = [ln for ln in lines if ln]
    if not lines:
        return ""
    body = " \\\\\n".join(lines)
    return "$$\n\\begin{aligned}\n" + body + "\n\\end{aligned}\n$$"


def design_matrices_latex(design) -> dict:
    """Every matrix of a design: name → ``"\\Phi = \\left(\\begin{matrix}…"`` (LaTeX)."""
    return {n: f"{matrix_name_latex(n)} = {matrix_latex(M)}" for n, M in design.ordered_matrices}


def _dot(sym) -> str:
    s = symbol_latex(sym)
    m = re.fullmatch(r"(\\underline\{x\}|\\overline\{x\}|x)\^\{\*(\(\d+\))?\}_\{(\d+)\}", s)
    if m:  # \dot{x}^{*}_{1}, \dot{\underline{x}}^{*}_{1}, \dot{x}^{*(2)}_{1}
        return rf"\dot{{{m.group(1)}}}^{{*{m.group(2) or ''}}}_{{{m.group(3)}}}"
    return rf"\dot{{{s}}}"


def _is_lag(x, e) -> bool:
    """A delay line ``v_lagk(t+1) = v_lag(k-1)`` (or ``= v``): shown in one sentence."""
    m = re.fullmatch(r"(.+)_lag(\d+)", str(x))
    if not m:
        return False
    k = int(m.group(2))
    prev = m.group(1) if k == 1 else f"{m.group(1)}_lag{k - 1}"
    return str(e) == prev


def _equation_lines(states, rhs, outputs, time: str, collapse_lags: bool = False) -> list:
    exprs = list(rhs) + [e for _, e in outputs]
    names = _names(exprs + list(states))
    lines = []
    for x, e in zip(states, rhs):
        if collapse_lags and time == "discrete" and _is_lag(x, e):
            continue
        lhs = _dot(x) if time == "continuous" else rf"{symbol_latex(x)}(t+1)"
        lines.append(f"{lhs} &= {expr_latex(e, names)}")
    for name, e in outputs:
        lines.append(f"{symbol_latex(name)} &= {expr_latex(e, names)}")
    return lines


def design_equations_latex(design) -> list:
    """The design's observer equations (x*' or x*(t+1), then its outputs) as aligned lines."""
    return _equation_lines(design.observer_states, design.equations, design.outputs, design.time)


def observer_equations_latex(observer, collapse_lags: bool = False) -> list:
    """The runnable observer's equations (gains and bounds as named parameters);
    ``collapse_lags`` leaves out the delay lines ``v^{[-k]}(t+1) = v^{[-k+1]}``."""
    return _equation_lines(observer.states, observer.update, observer.outputs, observer.time,
                           collapse_lags)


def lag_states(observer) -> list:
    """The observer's delay-line states (``y1_lag1`` …), in order."""
    if observer.time != "discrete":
        return []
    return [x for x, e in zip(observer.states, observer.update) if _is_lag(x, e)]


# ---------------------------------------------------------------- markdown
def md_escape(text) -> str:
    """Plain text safe inside markdown paragraphs and table cells.

    Examples
    --------
    >>> from observer_cad.reporting import md_escape
    >>> print(md_escape("x_hat | r*"))
    x\\_hat \\| r\\*
    """
    text = str(text).replace("\\", "\\\\")
    for ch in "*_`|<>[]#":
        text = text.replace(ch, "\\" + ch)
    return text.replace("\n", " ")


def _mark(c) -> str:
    if c.holds:
        return "✅ ok"
    return "❌ FAIL" if c.required else "➖ no (informational)"


def conditions_table(conditions: Iterable) -> str:
    rows = ["| | condition | evidence | source |", "|---|---|---|---|"]
    for c in conditions:
        rows.append(f"| {_mark(c)} | {md_escape(c.name)} | {md_escape(c.detail)} |"
                    f" {md_escape(c.reference)} |")
    return "\n".join(rows)


def certificate_table(cert) -> str:
    kind = "exact (simplified to 0)" if cert.exact else f"float, tolerance {cert.tolerance:.1e}"
    rows = [f"Certificate: **{'PASSED' if cert.passed else 'FAILED'}**, {kind}.", "",
            "| identity | holds | residual |", "|---|---|---|"]
    for i in cert.identities:
        rows.append(f"| {md_escape(i.name)} | {'✅' if i.holds else '❌'} | {md_escape(i.residual)} |")
    return "\n".join(rows)


def _fmt_s(v) -> str:
    if v is None:
        return "—"
    return f"{v * 1e3:.0f} ms" if v < 1 else f"{v:.2f} s"


def design_section(*, anchor: str, heading: str, paper: str, command: str, model_name: str,
                   design, observer=None, timings: dict | None = None,
                   figures: Sequence = (), notes: Sequence[str] = (),
                   full_text: str = "", level: int = 2) -> str:
    """One design in the report: what, how to reproduce, equations, matrices, conditions,
    assumptions, certificate, timings, figures, and the full text output."""
    h = "#" * level
    out = [f'<a id="{anchor}"></a>', f"{h} {md_escape(heading)}", "",
           f"*{md_escape(paper)}* — model `{model_name}`, {design.observer}, {design.form} form,"
           f" k = {design.k}, {'symbolic' if design.symbolic else 'numeric'}"
           f" ({design.method} arithmetic){', APPROXIMATE' if design.approximate else ''}.", ""]
    if command:
        out += ["Reproduce:", "", "```sh", command, "```", ""]
    for n in notes:
        out += [n, ""]
    if design.lambdas:
        out += ["Jordan eigenvalues: $" + ", ".join(rf"\lambda_{{{i + 1}}} = {sp.latex(sp.sympify(v))}"
                                                      for i, v in enumerate(design.lambdas)) + "$", ""]
    if design.closed_loop_eigenvalues:
        out += ["Closed-loop eigenvalues of $F^{*} - K H^{*}$: $"
                + ", ".join(sp.latex(sp.sympify(v)) for v in design.closed_loop_eigenvalues) + "$", ""]
    if design.equations:
        out += ["**Reduced model (observer) equations** (the design):", "",
                latex_block(design_equations_latex(design)), ""]
    if observer is not None and (observer.kind != design.observer or
                                 list(observer.update) != list(design.equations)):
        desc = str(observer.description)
        out += [f"**Runnable observer** ({md_escape(observer.kind)}, {observer.time} time) —"
                " compiled and simulated" + (f": {md_escape(desc)}." if len(desc) <= 100 else ":"), ""]
        if len(desc) > 100:
            out += ["```text", desc, "```", ""]
        out += [latex_block(observer_equations_latex(observer, collapse_lags=True)), ""]
        lags = lag_states(observer)
        if lags:
            out += ["plus the delay lines " + ", ".join(f"${symbol_latex(x)}$" for x in lags)
                    + r" ($v^{[-k]}$ holds the value of $v$ k steps earlier).", ""]
        if observer.parameters:
            out += ["with " + ", ".join(
                f"${symbol_latex(p)} = {sp.latex(sp.sympify(v))}$" for p, v in observer.parameters.items())
                + ".", ""]
        if observer.delays:
            out += ["Delayed outputs: " + ", ".join(
                f"${symbol_latex(k)}$ at step t is the estimate for t − {v}" for k, v in observer.delays.items())
                + " (the figures align it with the true signal).", ""]
    if design.nonlinear:
        out += ["Nonlinear terms after argument substitution (METHOD §2c):", "",
                latex_block([rf"\Psi^{{*}}_{{{ns.index}}} &= {expr_latex(ns.function)}"
                             rf" \quad (\text{{argument }} {expr_latex(ns.argument)})"
                             for ns in design.nonlinear]), ""]
    out += ["**Matrices**", "", latex_block([v.replace(" = ", " &= ", 1)
                                             for v in design_matrices_latex(design).values()]), ""]
    out += ["**Conditions**", "", conditions_table(design.conditions), ""]
    if getattr(design, "signature", ()):
        out += ["**Fault signature** (every declared fault against the residual; 1 = r moves):",
                "", "| fault | r | role | Φ D |", "|---|---|---|---|"]
        out += [f"| {md_escape(s.name)} | {int(bool(s.sensitive))} | {md_escape(s.role)}"
                f"{' (if ' + md_escape(' and '.join(map(str, s.conditions))) + ')' if s.conditions else ''}"
                f" | ${sp.latex(sp.Matrix(s.entry).T)}$ |" for s in design.signature]
        out += [""]
    if observer is not None:
        extra = [c for c in observer.conditions if c not in design.conditions]
        if extra:
            out += ["Observer conditions (gains, bounds, stability of the runnable observer):", "",
                    conditions_table(extra), ""]
    out += ["**Assumptions**", ""]
    if design.assumptions:
        out += ["".join(f"- ${sp.latex(a, symbol_names=_names([a]))}$\n" for a in design.assumptions)]
    else:
        out += ["none (the design holds for all parameter values)", ""]
    if observer is not None:
        extra = [a for a in observer.assumptions if a not in design.assumptions]
        if extra:
            out += ["Observer assumptions:", "", "".join(f"- {md_escape(a)}\n" for a in extra)]
    out += ["**Choice**: " + md_escape(design.choice), ""]
    out += [certificate_table(design.certificate), ""]
    if timings:
        out += ["**Timings**: " + ", ".join(f"{k} {_fmt_s(v)}" for k, v in timings.items()), ""]
    for path, caption in figures:
        out += [f"![{md_escape(caption)}]({path})", "", f"*{md_escape(caption)}*", ""]
    if full_text:
        out += ["<details><summary>Full text output (as <code>observer-cad design</code> prints it)"
                "</summary>", "", "```text", full_text.rstrip(), "```", "", "</details>", ""]
    return "\n".join(out)

# ---------------------------------------------------------------- diagnosability
def _yes_no(ok: bool) -> str:
    """✅ yes / ➖ no: a "no" here is an answer about the plant, not a failure."""
    return "✅ yes" if ok else "➖ no"


def _order(k) -> str:
    return "—" if k is None else str(k)


def analysis_markdown(analysis) -> str:
    """A diagnosability analysis (:class:`~observer_cad.synthesis.Analysis`) as Markdown
    tables: detectability with the minimal orders and the reasons, isolability of every
    pair in both directions, the achievable structure matrix, the suggested extra
    measurements, then assumptions and notes (what ``observer-cad analyze`` prints)."""
    a = analysis
    dec = ", ".join(a.disturbances) or "nothing"
    out = [f"**Detectability** (a residual decoupled from {md_escape(dec)} that responds to the"
           " fault; k = the minimal order of one):", "",
           "| fault | detectable | minimal order k | reason |", "|---|---|---|---|"]
    for r in a.fault_results:
        via = " (via argument substitution)" if r.via_substitution else ""
        out.append(f"| {md_escape(r.fault)} | {_yes_no(r.detectable)}{via} |"
                   f" {_order(r.min_order)} | {md_escape(r.reason) or '—'} |")
    out.append("")
    if a.pairs:
        out += ["**Isolability** (a from b: a residual sensitive to a and decoupled from b;"
                " the pair is isolable when both directions exist):", "",
                "| pair a / b | isolable | a from b (k) | b from a (k) | reason |",
                "|---|---|---|---|---|"]
        for p in a.pairs:
            x, y = p.faults
            ways = [(f"yes (k = {k})" if ok else "no")
                    for ok, k in ((p.a_from_b, p.a_from_b_order), (p.b_from_a, p.b_from_a_order))]
            out.append(f"| {md_escape(x)} / {md_escape(y)} | {_yes_no(p.isolable)} |"
                       f" {ways[0]} | {ways[1]} |"
                       f" {'<br>'.join(md_escape(t) for t in p.reason.split('; ')) or '—'} |")
        out.append("")
    out += ["**Achievable structure matrix** (one residual per row; 1 = sensitive,"
            " 0 = decoupled):", ""]
    if a.structure:
        out += ["| residual | " + " | ".join(md_escape(f) for f in a.faults) + " | decoupled |",
                "|---|" + "---|" * len(a.faults) + "---|"]
        for i, row in enumerate(a.structure, 1):
            bits = row.row(a.faults)
            via = " (via argument substitution)" if row.via_substitution else ""
            out.append(f"| r{i} | " + " | ".join(str(bits[f]) for f in a.faults)
                       + f" | {md_escape(', '.join(row.decoupled)) or '—'}{via} |")
    else:
        out.append("none: no fault can be detected.")
    if not a.structure_complete:
        out += ["", "(partial: see the notes)"]
    out.append("")
    if a.suggestions or a.unhelped:
        out += ["**Suggestions** (one extra measurement):", ""]
        if a.suggestions:
            out += ["| goal | measure | minimal order k |", "|---|---|---|"]
            out += [f"| {md_escape(s.goal)} | {md_escape(s.measurement)} | {s.min_order} |"
                    for s in a.suggestions]
            out.append("")
        out += [f"- {md_escape(u)}" for u in a.unhelped]
        if a.unhelped:
            out.append("")
    if a.assumptions:
        out += ["**Assumptions**: " + ", ".join(
            f"${sp.latex(c, symbol_names=_names([c]))}$" for c in a.assumptions), ""]
    if a.notes:
        out += ["Notes:", ""] + [f"- {md_escape(n)}" for n in a.notes] + [""]
    return "\n".join(out)


def bank_markdown(bank, observer=None) -> str:
    """An isolating residual bank (:class:`~observer_cad.synthesis.ResidualBank`) as
    Markdown: its structure matrix with each residual's order, eigenvalue, decoupled
    inputs and certificate, the pairs it isolates, the choice, and (given the bank's
    ``observer``) the equations of the one observer with outputs r1 … rm."""
    faults = list(bank.faults)
    out = ["**Structure matrix** (row = residual, column = fault; 1 = the residual responds;"
           " every row recomputed from O Φ D_j and checked):", "",
           "| residual | " + " | ".join(md_escape(f) for f in faults)
           + " | k | λ | decoupled from | certificate |",
           "|---|" + "---|" * len(faults) + "---|---|---|---|"]
    for i, (row, d) in enumerate(zip(bank.structure_matrix, bank.designs), 1):
        lam = ", ".join(f"${sp.latex(sp.sympify(v))}$" for v in d.lambdas) or "—"
        cert = ("passed" if d.certificate.passed else "**failed**") + \
            (" (exact)" if d.certificate.exact else " (float)")
        out.append(f"| r{i} | " + " | ".join(str(int(c)) for c in row)
                   + f" | {d.k} | {lam} | {md_escape(', '.join(d.task.decoupled)) or '—'} | {cert} |")
    out.append("")
    out.append("Detected: " + ", ".join(f"{md_escape(f)} {'yes' if ok else 'no'}"
                                        for f, ok in bank.detectable.items()) + ".")
    if len(faults) > 1:
        out.append("")
        out.append("Isolated pairs (both detected, columns differ): " + ", ".join(
            f"{md_escape(a)}/{md_escape(b)} {'yes' if ok else 'no'}" for (a, b), ok in bank.isolable)
            + ".")
    if tuple(bank.strong_structure) != tuple(bank.structure_matrix):
        out += ["", "Strong structure matrix (1 = a nonzero steady-state gain): " + ", ".join(
            f"r{i} {''.join(map(str, r))}" for i, r in enumerate(bank.strong_structure, 1)) + "."]
    if bank.transient_note:
        out += ["", md_escape(bank.transient_note)]
    out += ["", f"**Choice**: {md_escape(bank.choice)}.", ""]
    if bank.refused:
        out += ["Rows tried and not achievable:", ""]
        out += [f"- {md_escape(r)}: {md_escape(why)}" for r, why in bank.refused]
        out.append("")
    if observer is not None:
        out += [f"**The bank as one observer** ({md_escape(observer.kind)}, {observer.time} time;"
                " the state $x^{*(i)}$ belongs to residual generator i):", "",
                latex_block(observer_equations_latex(observer)), ""]
    return "\n".join(out)


def render_report(title: str, intro: Sequence[str], sections: Sequence[str]) -> str:
    return "\n".join([f"# {title}", "", *intro, "", *sections]).rstrip() + "\n"
