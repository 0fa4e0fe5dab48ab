"""Standalone C export of an observer: ``NAME.c``, ``NAME.h`` and ``NAME_example.c``.

    from observer_cad.codegen import export_observer
    paths = export_observer(obs, "out", dt=0.01)     # [out/NAME.c, out/NAME.h, out/NAME_example.c]

    cc -std=c99 -Wall -Wextra -Werror NAME.c NAME_example.c -lm -o NAME_example
    ./NAME_example inputs.csv > trajectory.csv

* ``NAME.c`` is casadi's generated code for the observer step
  ``NAME(x, y, u, p[, h]) -> (x_next, out)`` (:func:`~observer_cad.codegen.observer_step`:
  ``y``, ``u`` held over the step; continuous time by fixed-step RK4, the step size
  baked in when ``dt`` is given, else a fifth argument ``h``; or, with
  ``discretisation="zoh"`` and ``dt``, the exact zero-order-hold step of an observer
  affine in its states), with double precision,
  plus a plain-pointer wrapper ``NAME_step(...)`` and the default initial state and
  parameters (``NAME_x0``, ``NAME_p_default``) and signal names.
* ``NAME.h`` documents the argument order, meaning and sizes, the equations, the
  output delays and casadi's work-vector sizes ``NAME_SZ_ARG``, ``NAME_SZ_RES``,
  ``NAME_SZ_IW``, ``NAME_SZ_W`` (queried from the casadi Function: ``sz_arg()`` …
  ``sz_w()``, an upper bound of what the generated code asks for through
  ``NAME_work()``), and declares casadi's C API for the function.
* ``NAME_example.c`` reads a recorded input CSV (a header row; the observer's signals
  ``y1, y2, …, u…`` are found by column name, other columns ignored; one row per
  step), steps the observer from its initial state and prints ``step``, the states
  (before the step) and the outputs of every step as CSV with ``%.17g`` (exact
  round trip of doubles).  Options: ``dt=H`` (required when the step size is an
  argument), ``x0=a,b,…`` (initial state), ``p=a,b,…`` (parameters).

Warnings: casadi 3.8.2's generated code does not use every parameter of its
functions (``iw``, ``w``, ``mem`` of the step, ``mem`` of ``NAME_release``), which
``-Wextra`` (``-Wunused-parameter``) turns into errors under ``-Werror``.  The code is
post-processed: every function definition with parameters gets a
``(void)param;`` line per parameter as its first statement (a no-op that marks the
parameter used; portable C, no pragmas, nothing switched off).  Also, ``NAME.c``
includes ``NAME.h``, so the compiler checks the declared prototypes against the
definitions.

All files are written atomically (a temporary file in the directory, then renamed).
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Mapping

import casadi as ca

from ..files import atomic_write_text
from ..errors import UsageError
from ..numerics import algebraic_to_float
from ..observers import Observer
from ..residuals import DecisionRule
from ._decide_c import decision_sources
from ._translate import (DISCRETISATIONS, c_name, describe, observer_step, split_signals,
                         zoh_matrices)

__all__ = ["export_observer", "export_sources", "ExportedSources", "EXAMPLE_FLAGS",
           "silence_unused_parameters"]

#: The flags the exported files are checked with (tests/test_export.py).
EXAMPLE_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror")

_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
#: C's reserved words (C11) and the names the generated files use for their types
_C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum
extern float for goto if inline int long register restrict return short signed sizeof static
struct switch typedef union unsigned void volatile while _Alignas _Alignof _Atomic _Bool
_Complex _Generic _Imaginary _Noreturn _Static_assert _Thread_local casadi_real casadi_int
main""".split())
_ASCII = str.maketrans({"−": "-", "…": "...", "·": "*", "ξ": "xi", "≤": "<=", "≥": ">=",
                        "—": "-", "–": "-", "⁺": "+", "⁻": "-", "§": "S"})

# a top-level function definition as casadi writes it: one line, at column 0, ending in '{'
_DEF = re.compile(r"^(?!\s)(?!#)(?!typedef)(?:[A-Za-z_][\w \t\*]*?[\s\*])"
                  r"([A-Za-z_]\w*)\(([^()]*)\)\s*\{[ \t]*$", re.M)


def _ascii(text: str) -> str:
    return str(text).translate(_ASCII).encode("ascii", "replace").decode("ascii")


def _comment(text: str) -> str:
    """Text safe inside a C block comment."""
    return _ascii(text).replace("*/", "* /").replace("/*", "/ *")


def _cstr(s: str) -> str:
    return '"' + _ascii(s).replace("\\", "\\\\").replace('"', '\\"') + '"'


def _cdouble(v: float) -> str:
    v = float(v)
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    r = repr(v)
    return r if any(c in r for c in ".eE") else r + ".0"


def silence_unused_parameters(src: str) -> str:
    """Mark every parameter of every top-level function definition as used.

    casadi's generated code leaves some parameters unused (``iw``, ``w``, ``mem``),
    an error under ``-Wextra -Werror``.  After each definition line
    ``TYPE NAME(T1 a, T2 b) {`` a line ``(void)a; (void)b;`` is inserted; this changes
    no behaviour and works with any C compiler.
    """

    def fix(m):
        params = m.group(2).strip()
        if not params or params == "void":
            return m.group(0)
        names = []
        for p in params.split(","):
            p = p.strip()
            if p == "...":
                continue
            nm = re.search(r"([A-Za-z_]\w*)\s*(\[[^\]]*\])?\s*$", p)
            if nm:
                names.append(nm.group(1))
        if not names:
            return m.group(0)
        return m.group(0) + "\n  " + " ".join(f"(void){n};" for n in names)

    return _DEF.sub(fix, src)


class ExportedSources:
    """The three files' text (``c``, ``h``, ``example``), the casadi Function and sizes."""

    def __init__(self, name, function, c, h, example):
        self.name, self.function, self.c, self.h, self.example = name, function, c, h, example


def _initial_state(observer: Observer, initial: Mapping | None):
    """The default initial state: ``observer.initial`` with the plant-state (or other)
    symbols it mentions replaced by ``initial`` (names or symbols → values), the rest
    by 0; an observer-state name in ``initial`` sets that state directly."""
    given = {str(k): float(v) for k, v in (initial or {}).items()}
    states = [str(s) for s in observer.states]
    par = dict(observer.parameters)
    # a CRootOf coefficient as its Float first: xreplace of a plant state named like the
    # root's polynomial variable (x) would rebuild that polynomial
    init = {s: algebraic_to_float(observer.initial.get(s, 0)).xreplace(par)
            for s in observer.states}
    # every symbol some initial value depends on is a valid key, even when the state
    # that uses it is given directly
    free_used = {str(sym) for e in init.values() for sym in e.free_symbols}
    x0, notes = [], []
    for s in observer.states:
        if str(s) in given:
            x0.append(given[str(s)])
            continue
        e = init[s]
        free = sorted(e.free_symbols, key=str)
        sub = {}
        for sym in free:
            if str(sym) in given:
                sub[sym] = given[str(sym)]
                free_used.add(str(sym))
            else:
                sub[sym] = 0
                notes.append(str(sym))
        free_used.update(str(f) for f in free)
        try:
            x0.append(float(e.xreplace(sub)))
        except TypeError:
            raise UsageError(f"export: the initial value of {s} ({e}) is not a number") from None
    unknown = [k for k in given if k not in states and k not in free_used]
    if unknown:
        raise UsageError(f"export: initial value for '{unknown[0]}', which is neither a state"
                         f" of {observer.name} ({', '.join(states)}) nor a symbol its initial"
                         " state depends on")
    return x0, sorted(set(notes))


def _matrix_text(M) -> str:
    return "[" + "; ".join(", ".join(f"{float(v):.17g}" for v in row) for row in M) + "]"


def _sizes(f: ca.Function) -> dict:
    return {"SZ_ARG": int(f.sz_arg()), "SZ_RES": int(f.sz_res()),
            "SZ_IW": int(f.sz_iw()), "SZ_W": int(f.sz_w())}


def _names_array(cname, names):
    items = ", ".join([_cstr(n) for n in names] + ["0"])
    return f"const char* const {cname}[{len(names) + 1}] = {{{items}}};"


def _double_array(cname, vals):
    items = ", ".join(_cdouble(v) for v in vals) if vals else "0.0"
    return f"const casadi_real {cname}[{max(len(vals), 1)}] = {{{items}}};"


def export_sources(observer: Observer, *, name: str | None = None, dt: float | None = None,
                   initial: Mapping | None = None,
                   discretisation: str = "rk4",
                   rule: DecisionRule | None = None) -> ExportedSources:
    """The text of the three files (nothing written); see :func:`export_observer`."""
    if not isinstance(observer, Observer):
        raise UsageError("export_observer needs an Observer (observer_cad.observers.build_observer)")
    if name is None:
        name = c_name(observer.name)
    if (not _IDENT.match(name) or name.startswith(("casadi_", "_")) or "__" in name
            or name in _C_KEYWORDS):
        raise UsageError(f"export: name {name!r} is not a name casadi and C accept (letters,"
                         " digits and single underscores, starting with a letter; not starting"
                         " with 'casadi_'; not a C keyword)")
    if observer.time == "discrete":
        if dt is not None:
            raise UsageError(f"export: dt applies to continuous-time observers; {observer.name}"
                             " is discrete (one call = one sample)")
    elif dt is not None:
        try:
            dt = float(dt)
        except (TypeError, ValueError):
            raise UsageError(f"export: dt must be a number, got {dt!r}") from None
        if not (math.isfinite(dt) and dt > 0):
            raise UsageError(f"export: dt must be a positive finite step size, got {dt!r}")
    if discretisation not in DISCRETISATIONS:
        raise UsageError(f"export: discretisation must be one of {', '.join(DISCRETISATIONS)},"
                         f" got {discretisation!r}")
    zoh = discretisation == "zoh"
    if zoh and observer.time != "continuous":
        raise UsageError(f"export: discretisation='zoh' applies to continuous-time observers;"
                         f" {observer.name} is discrete")
    if zoh and dt is None:
        raise UsageError("export: discretisation='zoh' needs dt (e^(A dt) is computed when the"
                         " code is generated)")
    h_arg = observer.time == "continuous" and dt is None

    f = observer_step(observer, h=dt, name=name, discretisation=discretisation)
    zoh_text = []
    if zoh:
        A, Ad, Gam, _ = zoh_matrices(observer, dt)
        zoh_text = [f" *   A     = {_matrix_text(A)}",
                    f" *   Ad    = e^(A dt) = {_matrix_text(Ad)}",
                    f" *   Gamma = int_0^dt e^(A s) ds = {_matrix_text(Gam)}"]
    ys, us = split_signals(observer)
    xs = [str(s) for s in observer.states]
    ps = list(observer.parameters)
    pvals = [float(v) for v in observer.parameters.values()]
    outs = list(observer.output_names)
    nx, ny, nu, npar, no = len(xs), len(ys), len(us), len(ps), len(outs)
    sz = _sizes(f)
    x0, zeroed = _initial_state(observer, initial)
    dec = decision_sources(name, observer, rule) if rule is not None else None

    # ------------------------------------------------------------------ NAME.c
    cg = ca.CodeGenerator(f"{name}.c", {"casadi_real": "double", "with_header": False})
    cg.add(f)
    body = silence_unused_parameters(cg.dump())
    step_params = ("const casadi_real* x, const casadi_real* y, const casadi_real* u,"
                   " const casadi_real* p, " + ("casadi_real h, " if h_arg else "")
                   + "casadi_real* x_next, casadi_real* out")
    csrc = [f"/* {name}.c: observer '{_comment(observer.name)}' ({observer.kind},"
            f" {observer.time} time), exported by observer_cad with CasADi {ca.__version__}.",
            f" * See {name}.h for the arguments; built with: cc -std=c99 -Wall -Wextra -Werror"
            f" {name}.c YOUR_MAIN.c -lm",
            " * Post-processed: '(void)param;' statements mark parameters the generated code"
            " does not use",
            " * (-Wunused-parameter under -Wextra). */",
            f'#include "{name}.h"', "", body.rstrip(), "",
            "/* ---- added by observer_cad.codegen ---- */",
            _names_array(f"{name}_x_names", xs),
            _names_array(f"{name}_y_names", [str(s) for s in ys]),
            _names_array(f"{name}_u_names", [str(s) for s in us]),
            _names_array(f"{name}_p_names", [str(s) for s in ps]),
            _names_array(f"{name}_out_names", outs),
            _double_array(f"{name}_x0", x0),
            _double_array(f"{name}_p_default", pvals),
            "",
            f"CASADI_SYMBOL_EXPORT int {name}_step({step_params}) {{",
            f"  const casadi_real* arg[{name}_SZ_ARG > 0 ? {name}_SZ_ARG : 1];",
            f"  casadi_real* res[{name}_SZ_RES > 0 ? {name}_SZ_RES : 1];",
            f"  casadi_int iw[{name}_SZ_IW > 0 ? {name}_SZ_IW : 1];",
            f"  casadi_real w[{name}_SZ_W > 0 ? {name}_SZ_W : 1];",
            "  int i, mem, flag;",
            f"  for (i = 0; i < {name}_SZ_ARG; ++i) arg[i] = 0;",
            f"  for (i = 0; i < {name}_SZ_RES; ++i) res[i] = 0;",
            "  arg[0] = x; arg[1] = y; arg[2] = u; arg[3] = p;"]
    if h_arg:
        csrc.append("  arg[4] = &h;")
    csrc += ["  res[0] = x_next; res[1] = out;",
             f"  mem = {name}_checkout();",
             f"  flag = {name}(arg, res, iw, w, mem);",
             f"  {name}_release(mem);",
             "  return flag;",
             "}", ""]
    if dec is not None:
        csrc.append(dec.c)
    c_text = "\n".join(csrc)

    # ------------------------------------------------------------------ NAME.h
    G = name.upper()
    doc = describe(f).splitlines()
    delays = {k: int(v) for k, v in observer.delays.items() if int(v)}
    hl = [f"/* {name}.h: observer '{_comment(observer.name)}' ({observer.kind}, {observer.time}"
          f" time), exported by observer_cad",
          f" * with CasADi {ca.__version__} (double precision).",
          " *"]
    if observer.description:
        hl.append(f" * {_comment(observer.description)}")
        hl.append(" *")
    hl += [" * Equations" + (" (x' = dx/dt)" if observer.time == "continuous" else "") + ":"]
    hl += [f" *   {_comment(e)}" for e in observer.equations_text()]
    hl += [" *", " * The step function (casadi's generated code, arguments in this order):", " *"]
    hl += [f" *   {_comment(line)}" for line in doc]
    hl += [" *"]
    if observer.time == "continuous":
        if h_arg:
            hl.append(" * Continuous time: one call is one classical RK4 step of size h (an"
                      " argument), with y and u held over the step.")
        elif zoh:
            hl.append(f" * Continuous time, exact zero-order hold: one call advances the"
                      f" affine update x' = A x + g(y, u, p) by {name}_DT = {dt!r} with y and u"
                      " held,")
            hl.append(" * x_next = Ad x + Gamma g(y, u, p) (scipy.linalg.expm, double"
                      " precision):")
            hl += zoh_text
        else:
            hl.append(f" * Continuous time: one call is one classical RK4 step of size"
                      f" {name}_DT = {dt!r}, with y and u held over the step.")
    else:
        hl.append(" * Discrete time: one call is one sample, x(t+1) = f(x(t), y(t), u(t), p).")
    hl += [" * out is evaluated at the current state x (before the step). x_next must not"
           " alias x: the",
           " * generated code may write x_next[0] before it has read x[1].",
           " *"]
    for o_name, k in delays.items():
        hl.append(f" * Delay: out '{_comment(o_name)}' (index {outs.index(o_name)}) at step t is"
                  f" the estimate for step t - {k}.")
    if delays:
        hl.append(" *")
    hl += [f" * Initial state {name}_x0 = {[float(v) for v in x0]}"
           + (f" (from the observer's initial state with {', '.join(zeroed)} = 0;"
              " pass the plant's values to export_observer(initial=...) or override at run"
              " time)" if zeroed else "") + ".",
           f" * Default parameters {name}_p_default: "
           + (", ".join(f"{p} = {v!r}" for p, v in zip(ps, pvals)) if ps else "none") + ".",
           " *",
           " * Work vectors (queried from the casadi Function; upper bounds of what"
           f" {name}_work() reports):",
           f" *   {name}_SZ_ARG = {sz['SZ_ARG']}  pointers in arg[] (const casadi_real*)",
           f" *   {name}_SZ_RES = {sz['SZ_RES']}  pointers in res[] (casadi_real*)",
           f" *   {name}_SZ_IW  = {sz['SZ_IW']}  casadi_int in iw[]",
           f" *   {name}_SZ_W   = {sz['SZ_W']}  casadi_real in w[]",
           f" * Unused arg[]/res[] slots beyond the function's {f.n_in()} inputs / {f.n_out()}"
           " outputs should be 0.",
           " *",
           " * Calling the casadi API directly (thread-safe with checkout/release):",
           f" *   const casadi_real* arg[{name}_SZ_ARG]; casadi_real* res[{name}_SZ_RES];",
           f" *   casadi_int iw[{name}_SZ_IW]; casadi_real w[{name}_SZ_W];"
           "   (at least 1 element each)",
           " *   arg[0] = x; arg[1] = y; arg[2] = u; arg[3] = p;"
           + (" arg[4] = &h;" if h_arg else ""),
           " *   res[0] = x_next; res[1] = out;",
           f" *   int mem = {name}_checkout(); int flag = {name}(arg, res, iw, w, mem);"
           f" {name}_release(mem);",
           f" * or simply {name}_step(x, y, u, p, " + ("h, " if h_arg else "")
           + "x_next, out) (work vectors on the stack).",
           " * Both return 0 on success.",
           *(dec.h_doc if dec is not None else ()),
           " *",
           f" * Example: {name}_example.c (cc -std=c99 -Wall -Wextra -Werror {name}.c"
           f" {name}_example.c -lm).",
           " */",
           f"#ifndef {G}_H",
           f"#define {G}_H",
           "",
           "#ifdef __cplusplus",
           'extern "C" {',
           "#endif",
           "",
           "#ifndef casadi_real",
           "#define casadi_real double",
           "#endif",
           "#ifndef casadi_int",
           "#define casadi_int long long int",
           "#endif",
           "",
           f"#define {name}_NX {nx}   /* observer states x */",
           f"#define {name}_NY {ny}   /* measured outputs y */",
           f"#define {name}_NU {nu}   /* known inputs u */",
           f"#define {name}_NP {npar}   /* parameters p */",
           f"#define {name}_NOUT {no}   /* outputs out */",
           f"#define {name}_H_ARG {1 if h_arg else 0}   /* 1: the step size h is an argument */"]
    if observer.time == "continuous" and not h_arg:
        hl.append(f"#define {name}_DT {_cdouble(dt)}   /* the step size baked in"
                  f" ({'exact ZOH' if zoh else 'RK4'}) */")
    hl += [f"#define {name}_SZ_ARG {sz['SZ_ARG']}",
           f"#define {name}_SZ_RES {sz['SZ_RES']}",
           f"#define {name}_SZ_IW {sz['SZ_IW']}",
           f"#define {name}_SZ_W {sz['SZ_W']}",
           "",
           "/* names (0-terminated) and defaults; arrays of length 0 hold one unused element */",
           f"extern const char* const {name}_x_names[];   /* {', '.join(xs) or '-'} */",
           f"extern const char* const {name}_y_names[];   /* {', '.join(map(str, ys)) or '-'} */",
           f"extern const char* const {name}_u_names[];   /* {', '.join(map(str, us)) or '-'} */",
           f"extern const char* const {name}_p_names[];   /* {', '.join(map(str, ps)) or '-'} */",
           f"extern const char* const {name}_out_names[]; /* {_comment(', '.join(outs)) or '-'} */",
           f"extern const casadi_real {name}_x0[];          /* default initial state [NX] */",
           f"extern const casadi_real {name}_p_default[];   /* default parameters [NP] */",
           "",
           f"/* One step: x[NX], y[NY], u[NU], p[NP]{', h' if h_arg else ''} -> x_next[NX],"
           " out[NOUT]; 0 on success. */",
           f"int {name}_step({step_params});",
           "",
           "/* casadi's C API of the generated function */",
           f"int {name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w,"
           " int mem);",
           f"int {name}_checkout(void);",
           f"void {name}_release(int mem);",
           f"void {name}_incref(void);",
           f"void {name}_decref(void);",
           f"casadi_int {name}_n_in(void);",
           f"casadi_int {name}_n_out(void);",
           f"casadi_real {name}_default_in(casadi_int i);",
           f"const char* {name}_name_in(casadi_int i);",
           f"const char* {name}_name_out(casadi_int i);",
           f"const casadi_int* {name}_sparsity_in(casadi_int i);",
           f"const casadi_int* {name}_sparsity_out(casadi_int i);",
           f"int {name}_work(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw,"
           " casadi_int* sz_w);",
           f"int {name}_work_bytes(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw,"
           " casadi_int* sz_w);",
           f"void {name}_casadi_version(int* major, int* minor, int* patch);",
           f"int {name}_casadi_int_size(void);",
           f"int {name}_casadi_real_size(void);",
           *(dec.h_decl if dec is not None else ()),
           "",
           "#ifdef __cplusplus",
           '} /* extern "C" */',
           "#endif",
           "",
           f"#endif /* {G}_H */",
           ""]
    h_text = "\n".join(hl)
    ex_text = _example_source(name, observer, h_arg, ys, us, xs, outs, dec)
    return ExportedSources(name, f, c_text, h_text, ex_text)


def export_observer(observer: Observer, out_dir, *, name: str | None = None,
                    dt: float | None = None, initial: Mapping | None = None,
                    discretisation: str = "rk4", rule: DecisionRule | None = None) -> list:
    """Write ``NAME.c``, ``NAME.h`` and ``NAME_example.c`` into ``out_dir`` (created if
    missing); returns their paths in that order.

    ``name``: the C name (default: the observer's name).  ``dt``: for a continuous-time
    observer, the RK4 step size baked into the code; when None the step function takes
    ``h`` as its last input and the example needs ``dt=H`` on its command line (an
    error for discrete observers).  ``initial``: values of the plant states the
    observer's initial state depends on (e.g. ``{"x1": 0.1}``), or of observer states;
    others are 0 (stated in the header).  ``discretisation``: ``"rk4"`` (default) or
    ``"zoh"``, the exact zero-order-hold step of an observer affine in its states
    (continuous time, ``dt`` required; see
    :func:`~observer_cad.codegen.zoh_matrices`).  ``rule``: a
    :class:`~observer_cad.observers.DecisionRule` over the observer's residual outputs;
    the sources then gain ``NAME_decide`` (the logic of
    :func:`~observer_cad.observers.decide`, bit-exact), the diagnosis table
    ``NAME_diagnosis_text`` and ``NAME_PERSISTENCE``, and the example prints
    ``<r>_alarm`` per residual, ``alarm``, ``diagnosis_code`` and ``diagnosis`` after the
    outputs (thresholds ``<r>_lower``/``<r>_upper``: observer outputs when it has them,
    else columns of the input CSV; an empty cell there is NaN, i.e. not out).
    """
    src = export_sources(observer, name=name, dt=dt, initial=initial,
                         discretisation=discretisation, rule=rule)
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{out_dir}: cannot create the output directory: {exc.strerror}") from None
    paths = [out / f"{src.name}.c", out / f"{src.name}.h", out / f"{src.name}_example.c"]
    for p, text in zip(paths, (src.c, src.h, src.example)):
        try:
            atomic_write_text(p, text)
        except OSError as exc:
            raise UsageError(f"{p}: cannot write: {exc.strerror}") from None
    return paths


# ---------------------------------------------------------------------- the example
def _example_source(name, observer, h_arg, ys, us, xs, outs, dec=None) -> str:
    N = name
    sig = [str(s) for s in ys] + [str(s) for s in us]
    extra = dec.input_columns if dec is not None else []
    nextra = len(extra)
    if dec is None:
        dec_decl = dec_head = dec_step = ""
        dec_doc = ""
    else:
        dec_decl = (f"  double rr[{N}_NRES], lo[{N}_NRES], hi[{N}_NRES];\n"
                    f"  int counters[{N}_NRES], alarms[{N}_NRES], code = 0;\n")
        dec_head = (f"  for (i = 0; i < {N}_NRES; ++i) counters[i] = 0;\n"
                    f"  for (i = 0; i < {N}_NRES; ++i) printf(\",%s_alarm\", {N}_residual_names[i]);\n"
                    "  printf(\",alarm,diagnosis_code,diagnosis\");\n")
        lines = []
        for i, (ri, (lo, hi)) in enumerate(zip(dec.residual_index, dec.thresholds)):
            src = [f"out[{v}]" if k == "out" else f"v[NSIG + {extra.index(v)}]" for k, v in (lo, hi)]
            lines.append(f"    rr[{i}] = out[{ri}]; lo[{i}] = {src[0]}; hi[{i}] = {src[1]};")
        dec_step = ("\n".join(lines) + "\n"
                    f"    code = {N}_decide(rr, lo, hi, counters, alarms);\n"
                    f"    for (i = 0; i < {N}_NRES; ++i) printf(\",%d\", alarms[i]);\n"
                    f"    printf(\",%d,%d,\\\"%s\\\"\", code != 0, code, {N}_diagnosis_text[code]);\n")
        dec_doc = (f" * Decisions ({N}_decide): after the outputs, <r>_alarm per residual, alarm"
                   " (any), diagnosis_code and\n"
                   " * diagnosis (quoted text); thresholds that are not observer outputs are read"
                   " from the input columns\n"
                   f" *   {', '.join(extra) or '(none: all are outputs)'} (an empty cell is NaN:"
                   " not out).\n")
    usage = (f"usage: {N}_example INPUT.csv" + (" dt=H" if h_arg else "")
             + " [x0=v1,...] [p=v1,...]")
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
    sig_items = ", ".join([_cstr(s) for s in sig + extra] + ["0"])
    dt_doc = "; dt= gives the RK4 step size" if h_arg else ""
    oname = _comment(observer.name)
    return f"""/* {N}_example.c: step the observer '{oname}' on a recorded input file.
 *
 * Build:  cc -std=c99 -Wall -Wextra -Werror {N}.c {N}_example.c -lm -o {N}_example
 * Run:    ./{N}_example INPUT.csv{' dt=H' if h_arg else ''} [x0=v1,...] [p=v1,...] > OUTPUT.csv
 *
 * INPUT.csv: a header row, then one row per step.  The observer's signals
 *   {', '.join(sig) or '(none)'}
 * are found by column name (any order; other columns, e.g. a simulator's t or states, are
 * ignored).  Output on stdout, CSV: step, the observer states before the step
 * ({', '.join(xs)}), and the outputs at that state ({_comment(', '.join(outs))}),
 * every number printed with %.17g (doubles round-trip exactly).
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
#define ASIZE(n) ((n) > 0 ? (n) : 1)

static const char* const sig_names[NREAD + 1] = {{{sig_items}}};

/* One line without its line end, malloc'd; NULL at the end of the file or when out of
   memory (*oom set). */
static char* read_line(FILE* fp, int* oom) {{
  size_t cap = 256, len = 0;
  char* buf = (char*)malloc(cap);
  int c = 0;
  if (buf == NULL) {{
    *oom = 1;
    return NULL;
  }}
  while ((c = fgetc(fp)) != EOF && c != '\\n') {{
    if (len + 1 >= cap) {{
      char* nb = (char*)realloc(buf, cap * 2);
      if (nb == NULL) {{
        free(buf);
        *oom = 1;
        return NULL;
      }}
      buf = nb;
      cap *= 2;
    }}
    buf[len++] = (char)c;
  }}
  if (c == EOF && len == 0) {{
    free(buf);
    return NULL;
  }}
  if (len > 0 && buf[len - 1] == '\\r') --len;
  buf[len] = '\\0';
  return buf;
}}

static int blank(const char* s) {{
  for (; *s; ++s)
    if (*s != ' ' && *s != '\\t') return 0;
  return 1;
}}

/* Parse a comma-separated list of exactly n numbers into v. */
static int parse_list(const char* s, double* v, int n) {{
  int k = 0;
  char* end;
  if (n == 0) return *s == '\\0' ? 0 : -1;
  for (;;) {{
    if (k == n) return -1;
    v[k++] = strtod(s, &end);
    if (end == s) return -1;
    while (*end == ' ') ++end;
    if (*end == '\\0') break;
    if (*end != ',') return -1;
    s = end + 1;
  }}
  return k == n ? 0 : -1;
}}

int main(int argc, char** argv) {{
  FILE* fp;
  char* line;
  int oom = 0, status = 0, ncol = 0, i, j, a, mem = -1;
  int col_of[ASIZE(NREAD)];
  int* sig_of_col = NULL;
  long lineno = 1, step = 0;
  double v[ASIZE(NREAD)];
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
{dt_opt}    }} else {{
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

  fp = fopen(argv[1], "r");
  if (fp == NULL) {{
    fprintf(stderr, "%s: cannot open %s\\n", argv[0], argv[1]);
    return 2;
  }}
  /* header: find the signals' columns */
  line = read_line(fp, &oom);
  if (line == NULL) {{
    fprintf(stderr, oom ? "%s: out of memory\\n" : "%s: %s is empty\\n", argv[0], argv[1]);
    fclose(fp);
    return oom ? 1 : 2;
  }}
  for (j = 0; j < NREAD; ++j) col_of[j] = -1;
  {{
    char* s = line;
    for (ncol = 0;; ++ncol) {{
      char* e = strchr(s, ',');
      char* b = s;
      char* t;
      if (e != NULL) *e = '\\0';
      t = s + strlen(s);
      while (*b == ' ' || *b == '\\t' || *b == '"') ++b;
      while (t > b && (t[-1] == ' ' || t[-1] == '\\t' || t[-1] == '"')) *--t = '\\0';
      for (j = 0; j < NREAD; ++j)
        if (col_of[j] < 0 && strcmp(b, sig_names[j]) == 0) col_of[j] = ncol;
      if (e == NULL) break;
      s = e + 1;
    }}
    ++ncol;
  }}
  free(line);
  for (j = 0; j < NREAD; ++j) {{
    if (col_of[j] < 0) {{
      fprintf(stderr, "%s: %s has no column '%s'\\n", argv[0], argv[1], sig_names[j]);
      fclose(fp);
      return 2;
    }}
  }}
  sig_of_col = (int*)malloc(sizeof(int) * (size_t)ncol);
  if (sig_of_col == NULL) {{
    fprintf(stderr, "%s: out of memory\\n", argv[0]);
    fclose(fp);
    return 1;
  }}
  for (i = 0; i < ncol; ++i) sig_of_col[i] = -1;
  for (j = 0; j < NREAD; ++j) sig_of_col[col_of[j]] = j;

  for (i = 0; i < ASIZE({N}_SZ_ARG); ++i) arg[i] = 0;
  for (i = 0; i < ASIZE({N}_SZ_RES); ++i) res[i] = 0;
  arg[0] = x;
  arg[1] = v;               /* y: the first NY signals */
  arg[2] = v + {N}_NY;      /* u: the next NU */
  arg[3] = p;
{h_set}  res[0] = xn;
  res[1] = out;
  mem = {N}_checkout();

  printf("step");
  for (i = 0; i < {N}_NX; ++i) printf(",%s", {N}_x_names[i]);
  for (i = 0; i < {N}_NOUT; ++i) printf(",%s", {N}_out_names[i]);
{dec_head}  printf("\\n");

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
        int empty = sig_of_col[col] >= NSIG && blank(s);
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
    if (seen != NREAD) {{
      fprintf(stderr, "%s: %s line %ld: too few columns\\n", argv[0], argv[1], lineno);
      status = 2;
      break;
    }}
    if ({N}(arg, res, iw, w, mem) != 0) {{
      fprintf(stderr, "%s: the step function failed at step %ld\\n", argv[0], step);
      status = 1;
      break;
    }}
    printf("%ld", step);
    for (i = 0; i < {N}_NX; ++i) printf(",%.17g", x[i]);
    for (i = 0; i < {N}_NOUT; ++i) printf(",%.17g", out[i]);
{dec_step}    printf("\\n");
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
