"""The argument parser of ``observer-cad``: one sub-parser per command, the option
groups several commands share (the design options, the threshold options, the run
options) and the argparse types that check numbers.

Every option is long (``--name``); a usage error is one line and exit status 2
(:class:`_Parser`).
"""
from __future__ import annotations

import argparse

from ..errors import UsageError

__all__ = ["build_parser", "PROG", "MAX_WHOLE"]

PROG = "observer-cad"


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors and exit status 2.

    Every option here is long (``--name``), so a token with a single leading dash
    (``-1+2*I``, ``-sqrt(2)``, ``-1/2``) is a value, not an option (argparse alone takes
    only plain negative numbers as values).
    """

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        import re
        self._negative_number_matcher = re.compile(r"^-(?!-)(?!h$).+")

    def error(self, message):  # noqa: D401 - argparse API
        raise UsageError(f"{message} (see '{self.prog} --help')")


class _VersionAction(argparse.Action):
    """``--version``: the version is looked up only when asked for (importlib.metadata
    costs 20–60 ms of imports every command would pay otherwise)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help=None):  # noqa: A002 - argparse API
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0,
                         help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from ..version import package_version
        print(f"{parser.prog} {package_version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``observer-cad`` and its commands (in the order ``--help`` lists them)."""
    p = _Parser(prog=PROG, description=(
        "Design reduced-order, disturbance-decoupled observers from a symbolic plant model, "
        "with every synthesis condition checked exactly and every design certified."))
    p.add_argument("--version", action=_VersionAction,
                   help="print the version and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser,
                           required=True)
    for add in (_add_show, _add_design, _add_simulate, _add_ensemble, _add_monitor, _add_codegen,
                _add_analyze, _add_demo):
        add(sub)
    return p


def _add_show(sub) -> None:
    """``show``: the structure extracted from a model file."""
    s = sub.add_parser("show", help="print the structure extracted from a model file",
                       description="Print the matrices F, G, H, C, D, L, W and the nonlinear "
                                   "terms extracted from MODEL (METHOD §1).")
    s.add_argument("model", metavar="MODEL", help="path to a model file (a Python module defining 'model')")
    s.add_argument("--json", action="store_true", help="print one JSON object instead of text")


def _add_design(sub) -> None:
    """``design``: synthesise, certify and print a design."""
    d = sub.add_parser("design", help="synthesise and certify an observer design",
                       description="Synthesise the reduced, disturbance-decoupled model "
                                   "(METHOD §2) for an observer and print it with its "
                                   "conditions, assumptions and certificate. Default form: "
                                   "canonical for unknown-input, jordan for the others.")
    d.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(d)
    d.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    d.add_argument("--frequency", metavar="W", action="append", default=None,
                   help="also report the residual's gain to each fault at ω = W (repeatable;"
                        " rad per time unit, per sample in discrete time; 0: the steady-state"
                        " gain); for a bank, each row's")
    _add_threshold_options(d, quantile=False)


def _add_simulate(sub) -> None:
    """``simulate``: one scenario, CSV and figures."""
    sim = sub.add_parser("simulate", help="simulate plant and observer on a scenario, write CSV",
                         description="Design the observer, simulate it with the plant on a "
                                     "scenario (JSON; compiled C by default) and write "
                                     "DIR/signals.csv: t, the plant states, y1.., every input, "
                                     "fault and disturbance, and the observer's outputs "
                                     "(<signal>_hat, <signal>_lower/_upper, r).")
    sim.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(sim)
    sim.add_argument("--scenario", metavar="FILE", required=True, help="scenario JSON file")
    sim.add_argument("--out", metavar="DIR", type=_out_dir, required=True, help="output directory")
    sim.add_argument("--keep-nonfinite", action="store_true",
                     help="when a value becomes NaN or infinite, still write the CSV (with nan/inf"
                          " written literally; an empty cell always means 'not available') and"
                          " exit with status 4 after a one-line warning")
    _add_run_options(sim)
    sim.add_argument("--sample-time", metavar="H", type=_positive_float("--sample-time"),
                     default=None,
                     help="continuous time: the observer as deployed, stepped every H by the"
                          " monitor's step (RK4, y and u held) on the plant's outputs sampled"
                          " at t = 0, H, 2H, ..., its inputs held over each H; the CSV's rows are"
                          " the samples; H a whole multiple of the scenario's dt (with"
                          " --threshold guaranteed and a declared envelope, the band of the"
                          " sampled algorithm at H)")
    _add_threshold_options(sim, quantile=True)


def _add_ensemble(sub) -> None:
    """``ensemble``: many sampled runs, their statistics and worst cases."""
    en = sub.add_parser("ensemble", help="validate an observer over many sampled runs (statistics, worst cases)",
                        description="Design the observer and run it with the plant over RUNS samples of "
                                    "every fault case of the scenario: parameters (\"declared\" = the "
                                    "model's uncertainty box), initial states and signals drawn from "
                                    "the scenario's distributions, seeded per run (a run depends only on "
                                    "(seed, run index), never on chunks or workers). Each run is reduced "
                                    "to summaries (errors, inclusion slack and violations, residual and "
                                    "alarm statistics) as it finishes. Writes DIR/summary.csv (one row "
                                    "per run), DIR/statistics.json (quantiles, worst runs), histograms "
                                    "and the worst runs' trajectories; a progress bar on stderr. Ctrl-C "
                                    "stops and writes what finished.")
    en.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(en)
    en.add_argument("--scenario", metavar="FILE", required=True, help="scenario JSON file")
    en.add_argument("--runs", metavar="N", type=_positive_int("--runs"), required=True,
                    help="samples per fault case (run i is sample i mod N of case i div N)")
    en.add_argument("--out", metavar="DIR", type=_out_dir, required=True, help="output directory")
    en.add_argument("--sample-time", metavar="H", type=_positive_float("--sample-time"),
                    default=None,
                    help="continuous time: every run with the observer as deployed (as simulate"
                         " --sample-time H: stepped every H by the monitor's step on sampled"
                         " outputs, inputs held); the plant runs in numpy, on threads")
    en.add_argument("--workers", metavar="W", type=_positive_int("--workers"), default=None,
                    help="threads or processes (default: every core)")
    en.add_argument("--backend", choices=["threads", "processes", "dask", "serial"], default=None,
                    help="threads (default; the compiled loop releases the GIL), processes (a loky"
                         " pool), dask (a local cluster, or --dask ADDRESS), serial")
    en.add_argument("--dask", metavar="ADDRESS", default=None,
                    help="run on the Dask scheduler at ADDRESS (e.g. tcp://host:8786); workers load"
                         " the compiled library from their own cache (compiling it once if missing)")
    en.add_argument("--chunk", metavar="R", type=_positive_int("--chunk"), default=None,
                    help="runs per chunk (default: trajectory buffers of about 32 MiB per worker)")
    en.add_argument("--engine", choices=["compiled", "reference"], default="compiled",
                    help="compiled (default) or the numpy reference simulator (validation; slow)")
    en.add_argument("--settle", metavar="T", type=_nonnegative_float("--settle"), default=0.0,
                    help="summaries ignore samples before time T (the transient; default 0)")
    en.add_argument("--keep", metavar="K", type=_nonnegative_int("--keep"), default=1,
                    help="replay the K worst runs (by --worst-by) and write their trajectories"
                         " to DIR/worst/run_<i>/ (default 1; 0: none)")
    en.add_argument("--worst-by", metavar="FIELD", default=None,
                    help="the summary field that ranks runs (default: an interval's smallest"
                         " slack, else an estimate's largest error, else a residual's samples"
                         " out of its band, else the first field)")
    en.add_argument("--replay", metavar="RUN", type=_nonnegative_int("--replay"), default=None,
                    help="only replay run RUN of this ensemble: write DIR/run_<RUN>/signals.csv"
                         " and figures, and print its summary")
    _add_threshold_options(en, quantile=True)


def _add_monitor(sub) -> None:
    """``monitor``: the observer over recorded data (a file, or rows on stdin)."""
    mo = sub.add_parser("monitor", help="run the observer (and its threshold) over recorded data",
                        description="Design the observer and run it over recorded data: a CSV "
                                    "(or Parquet, with pyarrow) with a time column t and one "
                                    "column per input and output the observer reads (u, y1, ...). "
                                    "Writes DIR/monitor.csv (t, the signals, the observer's "
                                    "outputs, alarm and diagnosis with a threshold, in_bounds) and "
                                    "DIR/monitor.png. Continuous time: the discrete algorithm of "
                                    "the exported C at the data's sample time, inputs held (ZOH).")
    mo.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(mo)
    mo.add_argument("--data", metavar="FILE", required=True,
                    help="the recorded data (CSV, or .parquet with pyarrow); '-' reads CSV rows"
                         " from stdin as they arrive and prints each change of alarm or"
                         " diagnosis at once")
    mo.add_argument("--out", metavar="DIR", required=True, help="output directory")
    mo.add_argument("--column", metavar="SIGNAL=NAME", action="append", default=[],
                    help="the column NAME holds the signal SIGNAL (e.g. y1=angle; repeatable;"
                         " t=time for the time column)")
    mo.add_argument("--sample-time", metavar="H", type=_positive_float("--sample-time"),
                    default=None,
                    help="discrete-time models: the interval of t between two steps (default 1:"
                         " t counts the steps)")
    mo.add_argument("--initial", metavar="NAME=VALUE", action="append", default=[],
                    help="a plant state the observer's initial state depends on (default 0, as"
                         " the exported C), or an observer state (repeatable)")
    mo.add_argument("--engine", choices=["compiled", "reference"], default="compiled",
                    help="compiled: the exported C step in a compiled loop (cached; without a"
                         " C compiler the reference is used, with a warning); reference: Python"
                         " (default compiled)")
    _add_threshold_options(mo, quantile=False)
    mo.add_argument("--persistence", metavar="N", type=_positive_int("--persistence"), default=1,
                    help="alarm when a residual is outside its band for N consecutive samples"
                         " (default 1)")


def _add_codegen(sub) -> None:
    """``codegen``: the observer as standalone C."""
    cg = sub.add_parser("codegen", help="export the observer as standalone C",
                        description="Design the observer and write NAME.c, NAME.h (argument "
                                    "order and work-vector sizes documented) and NAME_example.c, "
                                    "which steps the observer on a recorded input CSV; builds with "
                                    "cc -std=c99 -Wall -Wextra -Werror. Generated by casadi.")
    cg.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(cg)
    cg.add_argument("--out", metavar="DIR", type=_out_dir, required=True, help="output directory")
    cg.add_argument("--dt", type=_positive_float("--dt"), default=None,
                    help="continuous time: the RK4 step size baked into the step (default 0.01);"
                         " with --fmu and a discrete observer: the sample period (default 1)")
    cg.add_argument("--name", default=None, help="C name prefix (default: the observer's name)")
    cg.add_argument("--fmu", action="store_true",
                    help="also write NAME.fmu: an FMI co-simulation FMU of the monitor (the C"
                         " sources and this platform's binary, built with $CC or cc; inputs y, u;"
                         " outputs, bands, alarms, diagnosis code; sample time = --dt, for a"
                         " discrete observer its sample period, default 1)")
    cg.add_argument("--fmi-version", choices=["2.0", "3.0"], default=None,
                    help="with --fmu: the FMI version of NAME.fmu (default 2.0)")
    _add_threshold_options(cg, quantile=True)
    cg.add_argument("--scenario", metavar="FILE", default=None,
                    help="with --threshold quantile:RATE: the scenario whose fault-free runs"
                         " estimate the threshold")


def _add_analyze(sub) -> None:
    """``analyze``: diagnosability (detection, isolation, structure matrix)."""
    an = sub.add_parser("analyze", help="which faults can be detected and isolated (diagnosability)",
                        description="For the declared faults, with the declared disturbances "
                                    "decoupled: detectability and the minimal order of a "
                                    "detecting residual generator, isolability of each pair, "
                                    "the achievable structure matrix, the reason for each "
                                    "failure and which extra measurement would help (METHOD §2a).")
    an.add_argument("model", metavar="MODEL", help="path to a model file")
    an.add_argument("--fault", metavar="NAME", action="append", default=[],
                    help="a fault to analyse (repeatable; default every declared fault)")
    an.add_argument("--disturbance", metavar="NAME", action="append", default=[],
                    help="a further fault or disturbance to decouple (repeatable); the model's "
                         "own disturbances are always decoupled")
    an.add_argument("--candidate", metavar="EXPR", action="append", default=[],
                    help="a candidate extra output, linear in the states (repeatable), tried for "
                         "the suggestions besides every unmeasured state")
    an.add_argument("--symbolic", action="store_true",
                    help="keep parameters as symbols (answers generic, with assumptions)")
    an.add_argument("--method", choices=["auto", "exact", "float"], default="auto",
                    help="exact algebra or SVD rank decisions (default auto: float above 20 "
                         "states for numeric models)")
    an.add_argument("--rtol", type=float, default=None,
                    help="relative rank tolerance of the float path (default 1e-9)")
    an.add_argument("--frequency", metavar="W", action="append", default=None,
                    help="a frequency ω for strong detectability (repeatable; rad per time "
                         "unit, per sample in discrete time; default 0: the steady-state "
                         "gain): a residual's gain to the fault must be nonzero at every ω")
    an.add_argument("--json", action="store_true", help="print one JSON object instead of text")


def _add_demo(sub) -> None:
    """``demo``: the seed papers' examples, designed, simulated and reported."""
    dm = sub.add_parser("demo", help="design, compile, simulate and report the seed papers' examples",
                        description="Design every observer the seed papers build for the electric drive and "
                                    "the three-tank (and the sliding-mode example), print each design with its "
                                    "conditions, compile it with the plant (C, cached in $OBSERVER_CAD_CACHE), "
                                    "simulate the papers' scenarios and write DIR/report.md (LaTeX equations, "
                                    "matrices, conditions, assumptions, certificates, timings), PNG figures in "
                                    "DIR/figures and every design as JSON and LaTeX in DIR/designs.")
    dm.add_argument("--out", metavar="DIR", type=_out_dir, default="out",
                    help="output directory (default: out)")
    dm.add_argument("--no-compile", action="store_true",
                    help="simulate with the reference simulator (numpy) instead of compiled C")


def _add_design_options(p) -> None:
    """Options shared by ``design``, ``simulate`` and ``codegen``."""
    p.add_argument("--observer", required=True,
                   choices=["unknown-input", "diagnostic", "virtual-sensor", "interval",
                            "sliding-mode", "drem"],
                   help="unknown-input: estimate the input named by --fault; diagnostic: a "
                        "residual that detects the faults; virtual-sensor / interval: estimate "
                        "(bounds on) z = M x given by --estimate; sliding-mode: estimate the "
                        "fault with a sliding-mode observer (continuous time, matching condition); "
                        "drem: adaptive observer for time-varying polynomial parameters (seed 003; "
                        "the model file declares drem = DremSpec(...))")
    p.add_argument("--fault", metavar="NAME", action="append", default=[],
                   help="unknown-input: the input to estimate (a fault, or a disturbance, which "
                        "is then not decoupled); diagnostic: a fault to detect (repeatable; "
                        "default all). Faults not named are taken as zero")
    p.add_argument("--disturbance", metavar="NAME", action="append", default=[],
                   help="a further fault or disturbance to decouple from (repeatable); the "
                        "model's own disturbances are always decoupled")
    p.add_argument("--estimate", metavar="EXPR",
                   help="virtual-sensor / interval: z = M x as an expression in the state "
                        "names, e.g. x1 or 'x1 - x2'")
    p.add_argument("--form", choices=["canonical", "jordan"], default=None,
                   help="identification canonical form (METHOD §2a) or Jordan form (§2b)")
    p.add_argument("--lambda", dest="lambdas", metavar="VALUE", nargs="+",
                   help="Jordan form: the eigenvalues λ to use (each checked: admissible? "
                        "stable?); default: computed")
    p.add_argument("--eigenvalues", metavar="VALUE", nargs="+",
                   help="canonical form: closed-loop eigenvalues of F* − K H* (complex pairs "
                        "as '-1+2*I' '-1-2*I'); default -1, -2, ... (continuous) or 1/2, 1/4, ... "
                        "(discrete)")
    p.add_argument("--variant", choices=["plain", "004"], default="plain",
                   help="canonical virtual sensor: plain, or seed 004's model driven by the "
                        "virtual output (default plain)")
    p.add_argument("--robust", action="store_true",
                   help="when exact decoupling is impossible, give the best approximate design "
                        "(METHOD §2d), reported as APPROXIMATE with its residual norm")
    p.add_argument("--isolate", action="store_true",
                   help="diagnostic: a bank of residual generators that isolates the faults "
                        "(--fault names the columns, default every fault): the structure given "
                        "by --structure, else the generalised observer scheme, else the "
                        "dedicated scheme, else the best achievable rows; residuals r1 … rm")
    p.add_argument("--structure", metavar="ROWS",
                   help="with --isolate: the structure matrix to realise, one row per residual "
                        "and one digit per fault (1 = sensitive), e.g. 110,101,011")
    p.add_argument("--bound", metavar="NAME=LOW,HIGH", action="append", default=[],
                   help="override a declared bound, e.g. rho=-0.2,0.2 (repeatable): used by "
                        "interval observers and unknown-input estimators")
    p.add_argument("--gain", metavar="VALUE", nargs="+",
                   help="unknown-input estimator: the gains g (one, or one per row of the "
                        "model); default as in seed 000 (-0.7; -0.4, -0.1 mismatched)")
    p.add_argument("--tau", metavar="T", default=None,
                   help="unknown-input estimator, continuous time: the time constant of the "
                        "estimate's filter 1/(T s + 1) (default 1/10): the estimate is the "
                        "input filtered by it")
    p.add_argument("--gamma", type=_positive_float("--gamma"), default=None,
                   help="drem: the gradient gain γ (default: the model's suggestion)")
    p.add_argument("--poles", metavar="SET", nargs="+",
                   help="drem: one comma-separated pole set per filter, e.g. -1,-2 -3,-4")
    p.add_argument("--include-epsilon", action="store_true",
                   help="drem: estimate the decaying term as extra unknowns (more filters)")
    p.add_argument("--symbolic", action="store_true",
                   help="keep parameters as symbols (default: substitute their values as exact rationals)")
    p.add_argument("--method", choices=["auto", "exact", "float"], default="auto",
                   help="exact algebra, or SVD / generalised eigenvalues with a tolerance "
                        "(canonical unknown-input and linear Jordan designs; default auto: float "
                        "above 20 states for numeric models)")
    p.add_argument("--rtol", type=float, default=None,
                   help="relative rank tolerance of the float path (default 1e3·eps·size)")
    p.add_argument("--design", metavar="FILE", default=None,
                   help="use the frozen design in FILE (written by 'design --json' or"
                        " write_design_json; a single design, a residual bank or a DREM design)"
                        " instead of designing: it is loaded for MODEL, whose structure must"
                        " be the one it was made for, and everything it reports is recomputed"
                        " and compared; design options given beside it must agree with it")
    p.add_argument("--proof-seconds", metavar="S", default=None,
                   help="Jordan form: time budget of the proof that k is minimal (default 2; "
                        "'exhaustive' runs it to the end; when it runs out the condition gives "
                        "the range the least order lies in)")


def _add_threshold_options(p, *, quantile: bool) -> None:
    """--threshold and its companions (residual generators: --observer diagnostic, or a bank)."""
    kinds = "guaranteed, quantile:RATE or a positive number" if quantile else \
        "guaranteed or a positive number"
    p.add_argument("--threshold", metavar="SPEC", default=None,
                   help=f"residual evaluation ({kinds}): guaranteed = the adaptive band of the"
                        " fault-free residual from the declared bounds of noise, disturbances"
                        " and parameter uncertainty (no false alarm while they hold);"
                        + (" quantile:RATE = the constant band |r| <= the (1 - RATE) quantile"
                           " of |r| over Monte-Carlo fault-free runs of the scenario;" if quantile else "")
                        + " a number = the constant band |r| <= VALUE")
    p.add_argument("--initial-error", metavar="E", default="0",
                   help="--threshold guaranteed: bound on |x*_i(0) - (Phi x(0))_i| (default 0: the"
                        " observer starts at Phi x(0))")
    if quantile:
        p.add_argument("--persistence", metavar="N", type=_positive_int("--persistence"), default=1,
                       help="alarm when a residual is outside its band for N consecutive samples"
                            " (default 1)")
        p.add_argument("--quantile-runs", metavar="R", type=_positive_int("--quantile-runs"),
                       default=200, help="--threshold quantile: fault-free runs (default 200)")


def _add_run_options(p) -> None:
    """--engine, --case, --run (simulate)."""
    p.add_argument("--engine", choices=["compiled", "reference"], default="compiled",
                   help="compiled: plant and observer as one C trajectory function (cached;"
                        " without a C compiler the reference simulator is used, with a"
                        " warning); reference: the numpy simulator (default compiled)")
    p.add_argument("--case", metavar="NAME", default=None,
                   help="the scenario's fault case to simulate (its \"cases\"; default the first)")
    p.add_argument("--run", metavar="K", type=_nonnegative_int("--run"), default=None,
                   help="the sample to simulate: its random signals, parameters and initial"
                        " states are those of sample K of an ensemble with the same scenario"
                        " (replays a run of 'observer-cad ensemble'; default 0)")
    p.add_argument("--samples", metavar="N", type=_positive_int("--samples"), default=None,
                   help="with --run and \"sampling\": \"lhs\": the ensemble's --runs (a Latin"
                        " hypercube's draws depend on its size)")


#: the largest whole number an option takes: a C int (counts, sample indices and the
#: persistence of the generated C; 2⁶⁴ − 1 was an OverflowError, a persistence of 10²⁰ C
#: that does not compile)
MAX_WHOLE = 2**31 - 1


def _whole(option, low: int):
    """argparse type: a whole number in [``low``, :data:`MAX_WHOLE`]."""
    def convert(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} {text}: not a whole number") from None
        if v < low:
            raise argparse.ArgumentTypeError(f"{option} {text}: must be "
                                             + ("at least 1" if low == 1 else f"≥ {low}"))
        if v > MAX_WHOLE:
            raise argparse.ArgumentTypeError(f"{option} {text}: must be at most {MAX_WHOLE}")
        return v
    return convert


def _out_dir(text):
    """argparse type of ``--out``: a folder name that is not empty, not only white space
    (an unset ``$OUT`` would write into the working directory) and has no control
    character."""
    if not text.strip():
        raise argparse.ArgumentTypeError("--out is empty: name the output directory")
    if any(ord(c) < 32 or ord(c) == 127 for c in text):
        raise argparse.ArgumentTypeError(f"--out {text!r}: a control character in the name")
    return text


_out_dir.__name__ = "--out"


def _positive_int(option):
    return _whole(option, 1)


def _nonnegative_int(option):
    return _whole(option, 0)


def _positive_float(option):
    """argparse type: a finite number > 0 (``nan``, ``inf``, ``0`` and ``-1`` refused)."""
    return _real(option, zero=False)


def _nonnegative_float(option):
    """argparse type: a finite number ≥ 0."""
    return _real(option, zero=True)


def _real(option, *, zero: bool):
    """argparse type: a finite number > 0 (≥ 0 with ``zero``)."""
    bound = "≥ 0" if zero else "> 0"

    def convert(text):
        import math
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} {text}: not a number") from None
        if not (math.isfinite(v) and (v >= 0 if zero else v > 0)):
            raise argparse.ArgumentTypeError(f"{option} {text}: must be a finite number {bound}")
        return v
    convert.__name__ = option
    return convert
