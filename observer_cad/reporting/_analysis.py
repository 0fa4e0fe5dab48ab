"""Text and JSON renderings of a diagnosability analysis (``observer-cad analyze``)."""
from __future__ import annotations

from ..analysis import Analysis

__all__ = ["format_analysis", "analysis_to_json"]


def analysis_to_json(analysis: Analysis) -> dict:
    """The object ``observer-cad analyze --json`` prints (see :meth:`Analysis.to_json`)."""
    return analysis.to_json()


def _mark(ok: bool) -> str:
    return "[ ok ]" if ok else "[ no ]"


def format_analysis(a: Analysis) -> str:
    """The analysis as text: detectability, isolability, structure matrix, suggestions,
    assumptions and notes."""
    dec = ", ".join(a.disturbances) or "nothing"
    arith = "symbolic (exact arithmetic)" if a.symbolic else \
        ("float (SVD)" if any(n.startswith("float path") for n in a.notes)
         else "numeric (exact arithmetic)")
    out = [f"Diagnosability of {a.model_name}: faults {', '.join(a.faults)};"
           f" decoupled: {dec} — {arith}", ""]

    out.append(f"Detectability (a residual decoupled from {dec} that responds to the fault)")
    w = max(len(f) for f in a.faults)
    for r in a.fault_results:
        if r.detectable:
            via = ", via argument substitution" if r.via_substitution else ""
            out.append(f"  {_mark(True)} {r.fault.ljust(w)}  detectable, minimal order"
                       f" k = {r.min_order}{via}")
        else:
            out.append(f"  {_mark(False)} {r.fault.ljust(w)}  {r.reason}")
    out.append("")

    if a.pairs:
        out.append("Isolability (a from b: a residual sensitive to a and decoupled from b;"
                   " isolable: both ways)")
        for p in a.pairs:
            x, y = p.faults
            ways = []
            for ok, k, s, t in ((p.a_from_b, p.a_from_b_order, x, y),
                                (p.b_from_a, p.b_from_a_order, y, x)):
                ways.append(f"{s} from {t}: " + (f"yes (k = {k})" if ok else "no"))
            out.append(f"  {_mark(p.isolable)} {x} / {y}   " + "; ".join(ways))
            if p.reason:
                for line in p.reason.split("; "):
                    out.append(f"         {line}")
        out.append("")

    out.append("Achievable structure matrix (one residual per row; 1 sensitive, 0 decoupled)")
    if a.structure:
        cw = max(3, w + 1)
        out.append("       " + "".join(f.rjust(cw) for f in a.faults))
        for i, row in enumerate(a.structure):
            vals = row.row(a.faults)
            mark = "  (via argument substitution)" if row.via_substitution else ""
            out.append(f"  r{i + 1:<4}" + "".join(str(vals[f]).rjust(cw) for f in a.faults)
                       + mark)
    else:
        out.append("  (none: no fault can be detected)")
    if not a.structure_complete:
        out.append("  (partial: see the notes)")
    out.append("")

    out += _strong_lines(a, w)

    if a.suggestions or a.unhelped:
        out.append("Suggestions (one extra measurement)")
        for s in a.suggestions:
            out.append(f"  {s.goal}: measure {s.measurement} (minimal order k = {s.min_order})")
        for u in a.unhelped:
            out.append(f"  {u}")
        out.append("")

    if a.assumptions:
        out.append("Assumptions")
        out += [f"  {c}" for c in a.assumptions]
        out.append("")
    if a.notes:
        out.append("Notes")
        out += [f"  {n}" for n in a.notes]
    return "\n".join(out).rstrip()


def _strong_lines(a: Analysis, w: int) -> list:
    """Strong detectability and the strong structure matrix (nothing when skipped)."""
    if not a.strong:
        return []
    var = "s = jω" if a.time == "continuous" else "z = e^{jω}"
    where = ", ".join(str(x) for x in a.frequencies)
    out = [f"Strong detectability (a residual whose gain to the fault is nonzero at {var},"
           f" ω = {where})"]
    for s in a.strong:
        if s.strongly_detectable:
            out.append(f"  {_mark(True)} {s.fault.ljust(w)}  strongly detectable, minimal"
                       f" order k = {s.min_order}")
        elif a.fault(s.fault).detectable:
            out.append(f"  {_mark(False)} {s.fault.ljust(w)}  detectable only as a transient"
                       f" (every detecting residual has a zero gain at some ω = {where})")
        else:
            out.append(f"  {_mark(False)} {s.fault.ljust(w)}  not detectable")
    out += ["", "Strong structure matrix (one residual per row; nonzero gain at every ω)"]
    if a.strong_structure:
        cw = max(3, w + 1)
        out.append("       " + "".join(f.rjust(cw) for f in a.faults) + "   order")
        for i, row in enumerate(a.strong_structure):
            vals = row.row(a.faults)
            out.append(f"  s{i + 1:<4}" + "".join(str(vals[f]).rjust(cw) for f in a.faults)
                       + f"   k = {row.order}")
    else:
        out.append("  (none: no fault is strongly detectable)")
    return out + [""]
