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

Where the parts live: the options are checked and the step function built here
(:func:`export_sources`), ``NAME.c`` and ``NAME.h`` written here from their parts (the
header's comment, its timing note, its declarations); ``NAME_example.c`` in ``_example``;
the C literals and comments in ``_ctext``; the decision logic in ``_decide_c``.
"""
from __future__ import annotations

import dataclasses
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
from ._ctext import c_comment, c_double, c_string
from ._decide_c import decision_sources
from ._example import example_source
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

# a top-level function definition as casadi writes it: one line, at column 0, ending in '{'
_DEF = re.compile(r"^(?!\s)(?!#)(?!typedef)(?:[A-Za-z_][\w \t\*]*?[\s\*])"
                  r"([A-Za-z_]\w*)\(([^()]*)\)\s*\{[ \t]*$", re.M)


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
    """The three files' text (``c``, ``h``, ``example``), the casadi Function and sizes;
    ``x0``: the default initial state (``NAME_x0``), ``decisions``: the
    :class:`~observer_cad.codegen.DecisionSources` of the rule (None without)."""

    def __init__(self, name, function, c, h, example, x0=(), decisions=None):
        self.name, self.function, self.c, self.h, self.example = name, function, c, h, example
        self.x0, self.decisions = tuple(x0), decisions


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
    items = ", ".join([c_string(n) for n in names] + ["0"])
    return f"const char* const {cname}[{len(names) + 1}] = {{{items}}};"


def _double_array(cname, vals):
    items = ", ".join(c_double(v) for v in vals) if vals else "0.0"
    return f"const casadi_real {cname}[{max(len(vals), 1)}] = {{{items}}};"


def export_sources(observer: Observer, *, name: str | None = None, dt: float | None = None,
                   initial: Mapping | None = None,
                   discretisation: str = "rk4",
                   rule: DecisionRule | None = None,
                   envelope: Mapping | None = None) -> ExportedSources:
    """The text of the three files (nothing written); see :func:`export_observer`."""
    name, dt = _checked_options(observer, name, dt, discretisation)
    parts = _parts(observer, name, dt, discretisation, initial, rule)
    c_text, h_text = _c_source(parts), _header_source(parts)
    ex_text = example_source(name, observer, parts.h_arg, parts.ys, parts.us, parts.xs,
                             parts.outs, parts.dec, envelope=envelope, dt=parts.dt)
    return ExportedSources(name, parts.f, c_text, h_text, ex_text, parts.x0, parts.dec)


def _checked_options(observer: Observer, name: str | None, dt, discretisation: str) -> tuple:
    """(C name, step size) after checking the options (one-line UsageError otherwise)."""
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
    return name, dt


@dataclasses.dataclass(frozen=True)
class _Parts:
    """What the three files are written from: the observer, its casadi step ``f`` and
    sizes, the signal, state, parameter and output names, the default initial state
    (``zeroed``: the symbols it took as 0), the decision sources of a rule (or None)."""

    name: str
    observer: Observer
    f: ca.Function
    h_arg: bool        # continuous time without dt: the step size is an argument
    zoh: bool
    dt: float | None
    zoh_text: list     # the ZOH matrices, for the header
    ys: list
    us: list
    xs: list
    ps: list
    pvals: list
    outs: list
    sz: dict
    x0: list
    zeroed: list
    dec: object


def _parts(observer: Observer, name: str, dt, discretisation: str, initial, rule) -> _Parts:
    """The casadi step function and everything the files say about it."""
    zoh = discretisation == "zoh"
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
    x0, zeroed = _initial_state(observer, initial)
    dec = decision_sources(name, observer, rule) if rule is not None else None
    return _Parts(name, observer, f, h_arg, zoh, dt, zoh_text, ys, us, xs, ps, pvals, outs,
                  _sizes(f), x0, zeroed, dec)


def _step_params(h_arg: bool) -> str:
    """The parameters of ``NAME_step``."""
    return ("const casadi_real* x, const casadi_real* y, const casadi_real* u,"
            " const casadi_real* p, " + ("casadi_real h, " if h_arg else "")
            + "casadi_real* x_next, casadi_real* out")


def _c_source(parts: _Parts) -> str:
    """``NAME.c``: casadi's code (parameters marked used), the names and defaults, and
    ``NAME_step``; the decision logic with a rule."""
    name, observer, f, h_arg, dec = parts.name, parts.observer, parts.f, parts.h_arg, parts.dec
    xs, ys, us, ps, pvals, outs, x0 = parts.xs, parts.ys, parts.us, parts.ps, parts.pvals, parts.outs, parts.x0
    cg = ca.CodeGenerator(f"{name}.c", {"casadi_real": "double", "with_header": False})
    cg.add(f)
    body = silence_unused_parameters(cg.dump())
    step_params = _step_params(h_arg)
    csrc = [f"/* {name}.c: observer '{c_comment(observer.name)}' ({observer.kind},"
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
    return "\n".join(csrc)


def _header_source(parts: _Parts) -> str:
    """``NAME.h``: the documentation comment, then the declarations."""
    return "\n".join(_header_doc(parts) + _header_declarations(parts))


def _header_doc(parts: _Parts) -> list:
    """The header's comment: equations, the step function, how one call steps, delays,
    defaults, work vectors, how to call it (and the decision logic)."""
    name, observer, f, h_arg, dec = parts.name, parts.observer, parts.f, parts.h_arg, parts.dec
    outs, ps, pvals, sz, x0, zeroed = parts.outs, parts.ps, parts.pvals, parts.sz, parts.x0, parts.zeroed
    doc = describe(f).splitlines()
    delays = {k: int(v) for k, v in observer.delays.items() if int(v)}
    hl = [f"/* {name}.h: observer '{c_comment(observer.name)}' ({observer.kind}, {observer.time}"
          f" time), exported by observer_cad",
          f" * with CasADi {ca.__version__} (double precision).",
          " *"]
    if observer.description:
        hl.append(f" * {c_comment(observer.description)}")
        hl.append(" *")
    hl += [" * Equations" + (" (x' = dx/dt)" if observer.time == "continuous" else "") + ":"]
    hl += [f" *   {c_comment(e)}" for e in observer.equations_text()]
    hl += [" *", " * The step function (casadi's generated code, arguments in this order):", " *"]
    hl += [f" *   {c_comment(line)}" for line in doc]
    hl += [" *"]
    hl += _header_timing(parts)
    hl += [" * out is evaluated at the current state x (before the step). x_next must not"
           " alias x: the",
           " * generated code may write x_next[0] before it has read x[1].",
           " *"]
    for o_name, k in delays.items():
        hl.append(f" * Delay: out '{c_comment(o_name)}' (index {outs.index(o_name)}) at step t is"
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
           " */"]
    return hl


def _header_timing(parts: _Parts) -> list:
    """What one call of the step function does: a sample, an RK4 step (of size h or
    NAME_DT) or an exact zero-order-hold step."""
    name, observer, h_arg, zoh, dt = parts.name, parts.observer, parts.h_arg, parts.zoh, parts.dt
    out = []
    if observer.time == "continuous":
        if h_arg:
            out.append(" * Continuous time: one call is one classical RK4 step of size h (an"
                      " argument), with y and u held over the step.")
        elif zoh:
            out.append(f" * Continuous time, exact zero-order hold: one call advances the"
                      f" affine update x' = A x + g(y, u, p) by {name}_DT = {dt!r} with y and u"
                      " held,")
            out.append(" * x_next = Ad x + Gamma g(y, u, p) (scipy.linalg.expm, double"
                      " precision):")
            out += parts.zoh_text
        else:
            out.append(f" * Continuous time: one call is one classical RK4 step of size"
                      f" {name}_DT = {dt!r}, with y and u held over the step.")
    else:
        out.append(" * Discrete time: one call is one sample, x(t+1) = f(x(t), y(t), u(t), p).")
    return out


def _header_declarations(parts: _Parts) -> list:
    """The header's guard, sizes, names, defaults and prototypes."""
    name, observer, h_arg, zoh, dt, dec = parts.name, parts.observer, parts.h_arg, parts.zoh, parts.dt, parts.dec
    xs, ys, us, ps, outs, sz = parts.xs, parts.ys, parts.us, parts.ps, parts.outs, parts.sz
    nx, ny, nu, npar, no = len(xs), len(ys), len(us), len(ps), len(outs)
    G = name.upper()
    step_params = _step_params(h_arg)
    hl = [f"#ifndef {G}_H",
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
        hl.append(f"#define {name}_DT {c_double(dt)}   /* the step size baked in"
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
           f"extern const char* const {name}_out_names[]; /* {c_comment(', '.join(outs)) or '-'} */",
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
    return hl


def export_observer(observer: Observer, out_dir, *, name: str | None = None,
                    dt: float | None = None, initial: Mapping | None = None,
                    discretisation: str = "rk4", rule: DecisionRule | None = None,
                    envelope: Mapping | None = None) -> list:
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
    ``envelope``: signal name → (low, high), the declared ranges the example's
    ``in_bounds`` column checks (:func:`~observer_cad.simulation.declared_envelope`).
    """
    src = export_sources(observer, name=name, dt=dt, initial=initial,
                         discretisation=discretisation, rule=rule, envelope=envelope)
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
