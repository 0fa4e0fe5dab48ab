"""The example program of the standalone C export: ``NAME_example.c``.

It reads a recorded input CSV (a header row; ``t`` and the observer's signals found by
column name — the file ``observer-cad monitor --data`` reads), steps the observer from its
initial state and prints, per row, the columns of ``monitor.csv``: ``t``, the signals, the
observer's outputs, with a decision rule ``alarm`` and ``diagnosis``, then ``in_bounds``
(numbers ``%.17g``). With the argument ``trace`` it prints instead the step number, the
states before the step and the outputs, and with a rule ``<r>_alarm``, ``alarm``,
``diagnosis_code`` and ``diagnosis`` (``t`` is then not needed).
The C is assembled from its parts in source order: the preamble (usage comment,
includes, the signal names), the helpers (line reader, list parser), the start of
``main`` (declarations, options, the work-vector check), reading the input's header,
and the steps.
"""
from __future__ import annotations

import math

from ..simulation import monitor_signal_columns
from ._ctext import c_comment, c_string

__all__ = ["example_source"]


def example_source(name, observer, h_arg, ys, us, xs, outs, dec=None, envelope=None,
                   dt=None) -> str:
    """The text of ``NAME_example.c`` for ``observer`` (``h_arg``: the step size is an
    argument; ``ys``, ``us``: the signals; ``xs``, ``outs``: the states' and outputs'
    names; ``dec``: the :class:`~observer_cad.codegen.DecisionSources` of a rule, or None;
    ``envelope``: signal name → (low, high), the declared ranges ``in_bounds`` checks;
    ``dt``: the baked-in step size of a continuous-time observer, which the data's sample
    time must equal)."""
    N = name
    sig = [str(s) for s in ys] + [str(s) for s in us]
    extra = dec.input_columns if dec is not None else []
    dec_decl, dec_head, dec_step, dec_doc = _decision_parts(N, dec)
    usage = (f"usage: {N}_example INPUT.csv" + (" dt=H" if h_arg else "")
             + " [x0=v1,...] [p=v1,...] [trace]")
    dt_decl, dt_opt, dt_check, h_set = _step_size_parts(h_arg)
    sig_items = ", ".join([c_string(s) for s in sig + extra + ["t"]] + ["0"])
    return (_preamble(N, observer, h_arg, sig, xs, outs, len(extra), sig_items, dec_doc,
                      _monitor_tables(observer, sig, envelope or {}))
            + _HELPERS + _main_start(N, usage, dt_decl, dec_decl, dt_opt, dt_check)
            + _READ_HEADER + _steps(N, h_set, dec_head, dec_step,
                                    _time_check(observer.time == "continuous", h_arg, dt)))


def _time_check(continuous: bool, h_arg: bool, dt) -> str:
    """The monitor format's checks of t per row: increasing, regular (every interval the
    first within 0.1 %) and, in continuous time, the first interval equal to the step
    size (within 0.1 %) — the checks of ``observer-cad monitor``."""
    step = ""
    if continuous:
        h = "h" if h_arg else repr(float(dt))
        step = f"""      if (step == 1 && fabs(h_t - {h}) > 1e-3 * {h}) {{
        fprintf(stderr, "%s: %s line %ld: the sample time %.10g is not the step size %.10g"
                " of this observer (export it with dt = the data's sample time)\\n", argv[0],
                argv[1], lineno, h_t, (double){h});
        status = 2;
        break;
      }}
"""
    return """    if (!trace) {
      if (step == 1) h_t = v[TCOL] - t_prev;
      if (step >= 1 && !(v[TCOL] > t_prev)) {
        fprintf(stderr, "%s: %s line %ld: t does not increase\\n", argv[0], argv[1], lineno);
        status = 2;
        break;
      }
      if (step >= 1 && fabs(v[TCOL] - t_prev - h_t) > 1e-3 * h_t) {
        fprintf(stderr, "%s: %s line %ld: t is not regular (the interval differs from the"
                " first, %.10g, by more than 0.1 %%)\\n", argv[0], argv[1], lineno, h_t);
        status = 2;
        break;
      }
""" + step + """      t_prev = v[TCOL];
    }
"""


def _c_double(v: float) -> str:
    if math.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    return repr(float(v))


def _monitor_tables(observer, sig: list, envelope) -> str:
    """The monitor format's tables: the order the signals are printed in (that of
    ``monitor.csv``) and their declared ranges (±INFINITY: none)."""
    order = [sig.index(c) for c in monitor_signal_columns(observer)]
    lo = [_c_double(float(envelope[c][0])) if c in envelope else "-INFINITY" for c in sig]
    hi = [_c_double(float(envelope[c][1])) if c in envelope else "INFINITY" for c in sig]
    pad = lambda xs: ", ".join(xs) if xs else "0"  # noqa: E731 - C needs a non-empty list
    return (f"static const int print_order[ASIZE(NSIG)] = {{{pad([str(i) for i in order])}}};\n"
            f"/* declared ranges of the signals (in_bounds): the model's envelope */\n"
            f"static const double env_lo[ASIZE(NSIG)] = {{{pad(lo)}}};\n"
            f"static const double env_hi[ASIZE(NSIG)] = {{{pad(hi)}}};\n\n")


def _decision_parts(N: str, dec) -> tuple:
    """The example's decision code (declarations, header columns, per step, usage
    comment); empty without a rule."""
    if dec is None:
        return "", "", "", ""
    extra = dec.input_columns
    dec_decl = (f"  double rr[{N}_NRES], lo[{N}_NRES], hi[{N}_NRES];\n"
                f"  int counters[{N}_NRES], alarms[{N}_NRES], code = 0;\n")
    dec_head = (f"  for (i = 0; i < {N}_NRES; ++i) counters[i] = 0;\n"
                "  if (trace) {\n"
                f"    for (i = 0; i < {N}_NRES; ++i) printf(\",%s_alarm\", {N}_residual_names[i]);\n"
                "    printf(\",alarm,diagnosis_code,diagnosis\");\n"
                "  } else {\n"
                "    printf(\",alarm,diagnosis\");\n"
                "  }\n")
    lines = []
    for i, (ri, (lo, hi)) in enumerate(zip(dec.residual_index, dec.thresholds)):
        src = [f"out[{v}]" if k == "out" else f"v[NSIG + {extra.index(v)}]" for k, v in (lo, hi)]
        lines.append(f"    rr[{i}] = out[{ri}]; lo[{i}] = {src[0]}; hi[{i}] = {src[1]};")
    dec_step = ("\n".join(lines) + "\n"
                f"    code = {N}_decide(rr, lo, hi, counters, alarms);\n"
                "    if (trace) {\n"
                f"      for (i = 0; i < {N}_NRES; ++i) printf(\",%d\", alarms[i]);\n"
                f"      printf(\",%d,%d,\\\"%s\\\"\", code != 0, code, {N}_diagnosis_text[code]);\n"
                "    } else {\n"
                f"      printf(\",%d,%s\", code != 0, {N}_diagnosis_text[code]);\n"
                "    }\n")
    dec_doc = (f" * Decisions ({N}_decide): after the outputs, alarm (any) and diagnosis (text);"
               " with trace\n * <r>_alarm per residual, alarm, diagnosis_code and diagnosis"
               " (quoted text); thresholds that are not observer outputs are read"
               " from the input columns\n"
               f" *   {', '.join(extra) or '(none: all are outputs)'} (an empty cell is NaN:"
               " not out).\n")
    return dec_decl, dec_head, dec_step, dec_doc


def _step_size_parts(h_arg: bool) -> tuple:
    """The example's handling of ``dt=H`` (declaration, option, check, argument), when
    the step size is an argument of the step function; else empty."""
    dt_decl = "  double h = 0.0;\n  int have_dt = 0;\n" if h_arg else ""
    dt_opt = ("""    } else if (strncmp(argv[a], "dt=", 3) == 0) {
      char* end;
      h = strtod(argv[a] + 3, &end);
      if (end == argv[a] + 3 || *end != '\\0' || !(h > 0.0)) {
        fprintf(stderr, "%s: dt must be a positive number, got '%s'\\n", argv[0], argv[a] + 3);
        return 2;
      }
      have_dt = 1;
""" if h_arg else "")
    dt_check = ("""  if (!have_dt) {
    fprintf(stderr, "%s: dt=H is required (the RK4 step size is an argument of this export)\\n",
            argv[0]);
    return 2;
  }
""" if h_arg else "")
    h_set = "  arg[4] = &h;\n" if h_arg else ""
    return dt_decl, dt_opt, dt_check, h_set


def _preamble(N: str, observer, h_arg: bool, sig: list, xs: list, outs: list, nextra: int,
              sig_items: str, dec_doc: str, tables: str) -> str:
    """The usage comment, the includes, the sizes and the signal names."""
    dt_doc = "; dt= gives the RK4 step size" if h_arg else ""
    oname = c_comment(observer.name)
    return f"""/* {N}_example.c: step the observer '{oname}' on a recorded input file.
 *
 * Build:  cc -std=c99 -Wall -Wextra -Werror {N}.c {N}_example.c -lm -o {N}_example
 * Run:    ./{N}_example INPUT.csv{' dt=H' if h_arg else ''} [x0=v1,...] [p=v1,...] > OUTPUT.csv
 *
 * INPUT.csv: a header row, then one row per step (the file observer-cad monitor --data
 * reads).  The time t and the observer's signals
 *   {', '.join(sig) or '(none)'}
 * are found by column name (any order; other columns, e.g. a simulator's states, are
 * ignored).  Output on stdout, CSV, the columns of observer-cad monitor's monitor.csv:
 * t, the signals, the outputs ({c_comment(', '.join(outs))}), with decisions alarm and
 * diagnosis, then in_bounds (1 while every signal lies in its declared range); every number
 * printed with %.17g (doubles round-trip exactly).  With trace (t then optional): step,
 * the observer states before the step ({', '.join(xs)}) and the outputs at that state.
 * x0= overrides the initial state {N}_x0, p= the parameters {N}_p_default{dt_doc}.
 * Exit status: 0 ok, 1 the step function failed or out of memory, 2 bad input or usage.
{dec_doc} */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "{N}.h"

#define NSIG ({N}_NY + {N}_NU)
#define NREAD (NSIG + {nextra})   /* signals, then threshold columns read from the input */
#define TCOL NREAD                /* then the time t */
#define ASIZE(n) ((n) > 0 ? (n) : 1)

static const char* const sig_names[NREAD + 2] = {{{sig_items}}};
{tables}"""


#: line reader, blank-line test and list parser of the example (fixed text)
_HELPERS = """/* One line without its line end, malloc'd; NULL at the end of the file or when out of
   memory (*oom set). */
static char* read_line(FILE* fp, int* oom) {
  size_t cap = 256, len = 0;
  char* buf = (char*)malloc(cap);
  int c = 0;
  if (buf == NULL) {
    *oom = 1;
    return NULL;
  }
  while ((c = fgetc(fp)) != EOF && c != '\\n') {
    if (len + 1 >= cap) {
      char* nb = (char*)realloc(buf, cap * 2);
      if (nb == NULL) {
        free(buf);
        *oom = 1;
        return NULL;
      }
      buf = nb;
      cap *= 2;
    }
    buf[len++] = (char)c;
  }
  if (c == EOF && len == 0) {
    free(buf);
    return NULL;
  }
  if (len > 0 && buf[len - 1] == '\\r') --len;
  buf[len] = '\\0';
  return buf;
}

static int blank(const char* s) {
  for (; *s; ++s)
    if (*s != ' ' && *s != '\\t') return 0;
  return 1;
}

/* Parse a comma-separated list of exactly n numbers into v. */
static int parse_list(const char* s, double* v, int n) {
  int k = 0;
  char* end;
  if (n == 0) return *s == '\\0' ? 0 : -1;
  for (;;) {
    if (k == n) return -1;
    v[k++] = strtod(s, &end);
    if (end == s) return -1;
    while (*end == ' ') ++end;
    if (*end == '\\0') break;
    if (*end != ',') return -1;
    s = end + 1;
  }
  return k == n ? 0 : -1;
}

"""


def _main_start(N: str, usage: str, dt_decl: str, dec_decl: str, dt_opt: str,
                dt_check: str) -> str:
    """``main``'s declarations, its options (x0=, p=, dt=) and the work-vector check."""
    return f"""int main(int argc, char** argv) {{
  FILE* fp;
  char* line;
  int oom = 0, status = 0, ncol = 0, i, j, a, mem = -1;
  int col_of[NREAD + 1];
  int* sig_of_col = NULL;
  long lineno = 1, step = 0;
  int trace = 0, need = NREAD, ok = 1;
  double t_prev = 0.0, h_t = 0.0;
  double v[NREAD + 1];
  double x[ASIZE({N}_NX)], xn[ASIZE({N}_NX)], out[ASIZE({N}_NOUT)], p[ASIZE({N}_NP)];
{dt_decl}{dec_decl}  const casadi_real* arg[ASIZE({N}_SZ_ARG)];
  casadi_real* res[ASIZE({N}_SZ_RES)];
  casadi_int iw[ASIZE({N}_SZ_IW)];
  casadi_real w[ASIZE({N}_SZ_W)];
  casadi_int sz_arg, sz_res, sz_iw, sz_w;

  if (argc < 2 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0) {{
    fprintf(stderr, "{usage}\\n");
    return argc < 2 ? 2 : 0;
  }}
  for (i = 0; i < {N}_NX; ++i) x[i] = {N}_x0[i];
  for (i = 0; i < {N}_NP; ++i) p[i] = {N}_p_default[i];
  for (a = 2; a < argc; ++a) {{
    if (strncmp(argv[a], "x0=", 3) == 0) {{
      if (parse_list(argv[a] + 3, x, {N}_NX) != 0) {{
        fprintf(stderr, "%s: x0= needs %d comma-separated numbers\\n", argv[0], {N}_NX);
        return 2;
      }}
    }} else if (strncmp(argv[a], "p=", 2) == 0) {{
      if (parse_list(argv[a] + 2, p, {N}_NP) != 0) {{
        fprintf(stderr, "%s: p= needs %d comma-separated numbers\\n", argv[0], {N}_NP);
        return 2;
      }}
{dt_opt}    }} else if (strcmp(argv[a], "trace") == 0) {{
      trace = 1;
    }} else {{
      fprintf(stderr, "%s: unknown argument '%s'\\n{usage}\\n", argv[0], argv[a]);
      return 2;
    }}
  }}
{dt_check}
  /* the generated code must not need more work space than the header promises */
  {N}_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
  if (sz_arg > {N}_SZ_ARG || sz_res > {N}_SZ_RES || sz_iw > {N}_SZ_IW || sz_w > {N}_SZ_W) {{
    fprintf(stderr, "%s: work vectors larger than {N}.h declares\\n", argv[0]);
    return 1;
  }}

"""


#: open the input and find the signals' columns in its header (fixed text)
_READ_HEADER = """  fp = fopen(argv[1], "r");
  if (fp == NULL) {
    fprintf(stderr, "%s: cannot open %s\\n", argv[0], argv[1]);
    return 2;
  }
  /* header: find the signals' columns */
  line = read_line(fp, &oom);
  if (line == NULL) {
    fprintf(stderr, oom ? "%s: out of memory\\n" : "%s: %s is empty\\n", argv[0], argv[1]);
    fclose(fp);
    return oom ? 1 : 2;
  }
  for (j = 0; j <= NREAD; ++j) col_of[j] = -1;
  {
    char* s = line;
    for (ncol = 0;; ++ncol) {
      char* e = strchr(s, ',');
      char* b = s;
      char* t;
      if (e != NULL) *e = '\\0';
      t = s + strlen(s);
      while (*b == ' ' || *b == '\\t' || *b == '"') ++b;
      while (t > b && (t[-1] == ' ' || t[-1] == '\\t' || t[-1] == '"')) *--t = '\\0';
      for (j = 0; j <= NREAD; ++j)
        if (col_of[j] < 0 && strcmp(b, sig_names[j]) == 0) col_of[j] = ncol;
      if (e == NULL) break;
      s = e + 1;
    }
    ++ncol;
  }
  free(line);
  for (j = 0; j <= NREAD; ++j) {
    if (col_of[j] < 0 && (j < NREAD || !trace)) {
      fprintf(stderr, "%s: %s has no column '%s'\\n", argv[0], argv[1], sig_names[j]);
      fclose(fp);
      return 2;
    }
  }
  if (col_of[TCOL] >= 0) need = NREAD + 1;
  sig_of_col = (int*)malloc(sizeof(int) * (size_t)ncol);
  if (sig_of_col == NULL) {
    fprintf(stderr, "%s: out of memory\\n", argv[0]);
    fclose(fp);
    return 1;
  }
  for (i = 0; i < ncol; ++i) sig_of_col[i] = -1;
  for (j = 0; j <= NREAD; ++j)
    if (col_of[j] >= 0) sig_of_col[col_of[j]] = j;

"""


def _steps(N: str, h_set: str, dec_head: str, dec_step: str, t_check: str) -> str:
    """The step function's arguments, the output header, one step per input row, and
    the clean-up."""
    return f"""  for (i = 0; i < ASIZE({N}_SZ_ARG); ++i) arg[i] = 0;
  for (i = 0; i < ASIZE({N}_SZ_RES); ++i) res[i] = 0;
  arg[0] = x;
  arg[1] = v;               /* y: the first NY signals */
  arg[2] = v + {N}_NY;      /* u: the next NU */
  arg[3] = p;
{h_set}  res[0] = xn;
  res[1] = out;
  mem = {N}_checkout();

  if (trace) {{
    printf("step");
    for (i = 0; i < {N}_NX; ++i) printf(",%s", {N}_x_names[i]);
  }} else {{
    printf("t");
    for (i = 0; i < NSIG; ++i) printf(",%s", sig_names[print_order[i]]);
  }}
  for (i = 0; i < {N}_NOUT; ++i) printf(",%s", {N}_out_names[i]);
{dec_head}  if (!trace) printf(",in_bounds");
  printf("\\n");

  while ((line = read_line(fp, &oom)) != NULL) {{
    char* s = line;
    int col, seen = 0;
    ++lineno;
    if (blank(line)) {{
      free(line);
      continue;
    }}
    for (col = 0; col < ncol; ++col) {{
      char* e = strchr(s, ',');
      if (e != NULL) *e = '\\0';
      if (sig_of_col[col] >= 0) {{
        char* end;
        double val = strtod(s, &end);
        while (*end == ' ' || *end == '\\t') ++end;
        int empty = sig_of_col[col] >= NSIG && sig_of_col[col] < NREAD && blank(s);
        if (empty) val = NAN;   /* an empty threshold cell: not available (NaN) */
        if (!empty && (end == s || *end != '\\0')) {{
          fprintf(stderr, "%s: %s line %ld: column '%s' is not a number\\n", argv[0], argv[1],
                  lineno, sig_names[sig_of_col[col]]);
          status = 2;
          break;
        }}
        v[sig_of_col[col]] = val;
        ++seen;
      }}
      if (e == NULL) break;
      s = e + 1;
    }}
    free(line);
    if (status) break;
    if (seen != need) {{
      fprintf(stderr, "%s: %s line %ld: too few columns\\n", argv[0], argv[1], lineno);
      status = 2;
      break;
    }}
{t_check}    if ({N}(arg, res, iw, w, mem) != 0) {{
      fprintf(stderr, "%s: the step function failed at step %ld\\n", argv[0], step);
      status = 1;
      break;
    }}
    if (trace) {{
      printf("%ld", step);
      for (i = 0; i < {N}_NX; ++i) printf(",%.17g", x[i]);
    }} else {{
      printf("%.17g", v[TCOL]);
      for (i = 0; i < NSIG; ++i) printf(",%.17g", v[print_order[i]]);
    }}
    for (i = 0; i < {N}_NOUT; ++i) printf(",%.17g", out[i]);
{dec_step}    if (!trace) {{
      ok = 1;
      for (i = 0; i < NSIG; ++i)
        if (!(v[i] >= env_lo[i] && v[i] <= env_hi[i])) ok = 0;
      printf(",%d", ok);
    }}
    printf("\\n");
    for (i = 0; i < {N}_NX; ++i) x[i] = xn[i];
    ++step;
  }}
  if (oom) {{
    fprintf(stderr, "%s: out of memory\\n", argv[0]);
    status = 1;
  }}
  {N}_release(mem);
  free(sig_of_col);
  fclose(fp);
  return status;
}}
"""
