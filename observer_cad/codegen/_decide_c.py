"""C text of the decision logic (:func:`observer_cad.observers.decide`) for the standalone
export: ``NAME_decide``, the diagnosis table and the rule's constants.

    int NAME_decide(const double* r, const double* lower, const double* upper,
                    int* counters, int* alarms);

takes the m residuals and their thresholds of one sample, updates the m counters (zero
them before the first sample) and the m alarms, and returns the diagnosis code
Σ alarm_i 2^(i−1); ``NAME_diagnosis_text[code]`` is its text. The counters saturate
at ``NAME_PERSISTENCE`` (no overflow however long a residual stays out; the alarms are
those of the unsaturated counter). Comparisons are the IEEE ones: a NaN residual or
bound is *not out* — do not compile with ``-ffast-math``, which lets the compiler
assume there is no NaN.
"""
from __future__ import annotations

from ..errors import UsageError
from ..residuals import DecisionRule
from ..observers import Observer

__all__ = ["MAX_C_RESIDUALS", "DecisionSources", "decision_sources"]

#: the exported table has 2^m entries: at most this many residuals
MAX_C_RESIDUALS = 16


def _cstr(s: str) -> str:
    text = str(s).encode("ascii", "replace").decode("ascii")
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


class DecisionSources:
    """Fragments of the exported files for a rule: ``c`` (definitions, appended to
    NAME.c), ``h_doc`` (comment lines for NAME.h), ``h_decl`` (declarations),
    ``thresholds``: per residual, where the example finds its lower and upper threshold
    — ``("out", index)`` an output of the observer, ``("input", name)`` a column of the
    input CSV — and ``residual_index`` the residuals' indices in the outputs."""

    def __init__(self, c, h_doc, h_decl, residual_index, thresholds):
        self.c, self.h_doc, self.h_decl = c, h_doc, h_decl
        self.residual_index, self.thresholds = residual_index, thresholds

    @property
    def input_columns(self) -> list:
        """The threshold columns the example reads from its input CSV."""
        return [src for pair in self.thresholds for kind, src in pair if kind == "input"]


def decision_sources(name: str, observer: Observer, rule: DecisionRule) -> DecisionSources:
    """The C fragments of ``rule`` for the export ``name`` of ``observer``."""
    if not isinstance(rule, DecisionRule):
        raise UsageError(f"export: rule must be a DecisionRule (observer_cad.observers."
                         f"decision_rule), not {type(rule).__name__}")
    m = len(rule.residuals)
    if m > MAX_C_RESIDUALS:
        raise UsageError(f"export: the decision table of {m} residuals would have 2^{m} entries;"
                         f" at most {MAX_C_RESIDUALS} residuals")
    outs = list(observer.output_names)
    missing = [r for r in rule.residuals if r not in outs]
    if missing:
        raise UsageError(f"export: the rule's residual '{missing[0]}' is not an output of"
                         f" {observer.name} (outputs: {', '.join(outs) or 'none'})")
    res_idx = [outs.index(r) for r in rule.residuals]
    thresholds = []
    for lo, hi in zip(rule.lower_names, rule.upper_names):
        thresholds.append(tuple(("out", outs.index(c)) if c in outs else ("input", c)
                                for c in (lo, hi)))
    table = rule.table()
    N = name
    c = ["", "/* ---- decision logic (observer_cad.observers.decide), see "
         f"{N}.h ---- */",
         f"const char* const {N}_residual_names[{m + 1}] = {{"
         + ", ".join([_cstr(r) for r in rule.residuals] + ["0"]) + "};",
         f"const char* const {N}_fault_names[{len(rule.faults) + 1}] = {{"
         + ", ".join([_cstr(f) for f in rule.faults] + ["0"]) + "};",
         f"const int {N}_structure[{m}][{len(rule.faults)}] = {{"
         + ", ".join("{" + ", ".join(map(str, row)) + "}" for row in rule.structure) + "};",
         f"const char* const {N}_diagnosis_text[{N}_NCODES] = {{",
         *[f"  {_cstr(text)},   /* code {k} */" for k, text in enumerate(table)],
         "};",
         "",
         f"int {N}_decide(const double* r, const double* lower, const double* upper,"
         " int* counters, int* alarms) {",
         "  int i, code = 0;",
         f"  for (i = 0; i < {N}_NRES; ++i) {{",
         "    /* out: strictly outside [lower, upper]; NaN compares false (not out) */",
         "    if (r[i] < lower[i] || r[i] > upper[i]) {",
         f"      if (counters[i] < {N}_PERSISTENCE) ++counters[i];",
         "    } else {",
         "      counters[i] = 0;",
         "    }",
         f"    alarms[i] = counters[i] >= {N}_PERSISTENCE;",
         "    if (alarms[i]) code |= 1 << i;",
         "  }",
         "  return code;",
         "}", ""]
    rows = ", ".join("".join(map(str, r)) for r in rule.structure)
    where = []
    for r, (lo, hi) in zip(rule.residuals, thresholds):
        desc = [f"out[{v}]" if k == "out" else f"input column {v}" for k, v in (lo, hi)]
        where.append(f" *   {r} = out[{outs.index(r)}]: lower {desc[0]}, upper {desc[1]}"
                     " (in the example)")
    h_doc = [" *",
             " * Decision logic (observer_cad.observers.decide, bit-exact):",
             f" *   {N}_decide(r, lower, upper, counters, alarms) takes the {m} residual(s)"
             f" ({', '.join(rule.residuals)})",
             " *   of one sample and their thresholds; residual i is out when r[i] < lower[i]"
             " or r[i] > upper[i]",
             " *   (strict; NaN is not out); counters[i] counts consecutive outs (saturating at"
             f" {N}_PERSISTENCE;",
             " *   set them to 0 before the first sample); alarms[i] = counters[i] >="
             f" {N}_PERSISTENCE. Returns the",
             " *   diagnosis code sum alarms[i] << i; its text is"
             f" {N}_diagnosis_text[code]: the faults whose",
             f" *   column of the structure matrix ({rows}; columns {', '.join(rule.faults)})"
             " equals the",
             " *   alarm pattern (\"f1 or f2\" when several do), \"no fault\" without alarm,"
             " \"unknown pattern\" otherwise.",
             " *   Do not compile with -ffast-math (it assumes no NaN).",
             *where]
    h_decl = ["",
              "/* decision logic */",
              f"#define {N}_NRES {m}   /* residuals */",
              f"#define {N}_NFAULTS {len(rule.faults)}   /* faults (columns of the structure) */",
              f"#define {N}_PERSISTENCE {rule.persistence}   /* consecutive out samples before"
              " an alarm */",
              f"#define {N}_NCODES {1 << m}   /* diagnosis codes 0 .. 2^NRES - 1 */",
              f"extern const char* const {N}_residual_names[];   /* {', '.join(rule.residuals)} */",
              f"extern const char* const {N}_fault_names[];      /* {', '.join(rule.faults)} */",
              f"extern const int {N}_structure[{m}][{len(rule.faults)}];   /* {rows} */",
              f"extern const char* const {N}_diagnosis_text[];   /* by code */",
              f"int {N}_decide(const double* r, const double* lower, const double* upper,"
              " int* counters, int* alarms);"]
    return DecisionSources("\n".join(c), h_doc, h_decl, res_idx, thresholds)
