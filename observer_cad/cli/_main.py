"""Command-line interface: ``observer-cad show|design|simulate|ensemble|codegen|analyze|demo``.

Every user error prints one line ``observer-cad: error: ...`` on stderr and exits with
status 2; a simulation that produced a value that is not finite (NaN, ±inf) exits with
status 4 (one line naming the first: time, signal, likely cause); no traceback is shown.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..errors import NonFiniteError, ObserverCadError, UsageError, describe_failure
from ..progress import report, reporting

__all__ = ["main", "build_parser"]

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
    p = _Parser(prog=PROG, description=(
        "Design reduced-order, disturbance-decoupled observers from a symbolic plant model, "
        "with every synthesis condition checked exactly and every design certified."))
    p.add_argument("--version", action=_VersionAction,
                   help="print the version and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser,
                           required=True)

    s = sub.add_parser("show", help="print the structure extracted from a model file",
                       description="Print the matrices F, G, H, C, D, L, W and the nonlinear "
                                   "terms extracted from MODEL (METHOD §1).")
    s.add_argument("model", metavar="MODEL", help="path to a model file (a Python module defining 'model')")
    s.add_argument("--json", action="store_true", help="print one JSON object instead of text")

    d = sub.add_parser("design", help="synthesise and certify an observer design",
                       description="Synthesise the reduced, disturbance-decoupled model "
                                   "(METHOD §2) for an observer and print it with its "
                                   "conditions, assumptions and certificate. Default form: "
                                   "canonical for unknown-input, jordan for the others.")
    d.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(d)
    d.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    _add_threshold_options(d, quantile=False)

    sim = sub.add_parser("simulate", help="simulate plant and observer on a scenario, write CSV",
                         description="Design the observer, simulate it with the plant on a "
                                     "scenario (JSON; compiled C by default) and write "
                                     "DIR/signals.csv: t, the plant states, y1.., every input, "
                                     "fault and disturbance, and the observer's outputs "
                                     "(<signal>_hat, <signal>_lower/_upper, r).")
    sim.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(sim)
    sim.add_argument("--scenario", metavar="FILE", required=True, help="scenario JSON file")
    sim.add_argument("--out", metavar="DIR", required=True, help="output directory")
    sim.add_argument("--keep-nonfinite", action="store_true",
                     help="when a value becomes NaN or infinite, still write the CSV (with nan/inf"
                          " written literally; an empty cell always means 'not available') and"
                          " exit with status 4 after a one-line warning")
    _add_run_options(sim)
    _add_threshold_options(sim, quantile=True)

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
    en.add_argument("--out", metavar="DIR", required=True, help="output directory")
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

    cg = sub.add_parser("codegen", help="export the observer as standalone C",
                        description="Design the observer and write NAME.c, NAME.h (argument "
                                    "order and work-vector sizes documented) and NAME_example.c, "
                                    "which steps the observer on a recorded input CSV; builds with "
                                    "cc -std=c99 -Wall -Wextra -Werror. Generated by casadi.")
    cg.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(cg)
    cg.add_argument("--out", metavar="DIR", required=True, help="output directory")
    cg.add_argument("--dt", type=_positive_float("--dt"), default=None,
                    help="continuous time: the RK4 step size baked into the step (default 0.01)")
    cg.add_argument("--name", default=None, help="C name prefix (default: the observer's name)")
    _add_threshold_options(cg, quantile=True)
    cg.add_argument("--scenario", metavar="FILE", default=None,
                    help="with --threshold quantile:RATE: the scenario whose fault-free runs"
                         " estimate the threshold")

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
    an.add_argument("--json", action="store_true", help="print one JSON object instead of text")

    dm = sub.add_parser("demo", help="design, compile, simulate and report the seed papers' examples",
                        description="Design every observer the seed papers build for the electric drive and "
                                    "the three-tank (and the sliding-mode example), print each design with its "
                                    "conditions, compile it with the plant (C, cached in $OBSERVER_CAD_CACHE), "
                                    "simulate the papers' scenarios and write DIR/report.md (LaTeX equations, "
                                    "matrices, conditions, assumptions, certificates, timings), PNG figures in "
                                    "DIR/figures and every design as JSON and LaTeX in DIR/designs.")
    dm.add_argument("--out", metavar="DIR", default="out", help="output directory (default: out)")
    dm.add_argument("--no-compile", action="store_true",
                    help="simulate with the reference simulator (numpy) instead of compiled C")
    return p


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


def _simulate_with_engine(args, model, observer, scenario):
    """One run of ``scenario`` (case ``--case``, sample ``--run``) on the engine ``--engine``:
    (result, the engine's description)."""
    from ..simulation import simulate
    case = args.case
    if case is None and scenario.cases:
        case = scenario.case_names[0]
    elif case is not None and case not in scenario.case_names:
        raise UsageError(f"{scenario.source}: no case '{case}' (cases:"
                         f" {', '.join(scenario.case_names)})")
    if scenario.sampling == "lhs" and args.run is not None and args.samples is None:
        raise UsageError(f"{scenario.source}: with \"sampling\": \"lhs\" a run's draws depend on"
                         " the ensemble's size: give --samples N (its --runs)")
    if args.samples is not None and args.run is not None and args.run >= args.samples:
        raise UsageError(f"--run {args.run} is not a sample of an ensemble of --samples"
                         f" {args.samples}")
    import numpy as np
    from ..simulation import signal_program
    for c in scenario.case_names:  # every case read now, as the ensemble does (not only --case)
        signal_program(model, scenario, np.zeros(1), case=c)  # (t = 0 only: no grid built)
    kw = dict(keep_nonfinite=args.keep_nonfinite, first_run=args.run or 0, case=case,
              samples=args.samples)
    if args.engine == "compiled":
        from ..codegen import CodegenError, CompiledSimulator
        try:
            sim = CompiledSimulator(model, observer)
        except CodegenError as exc:
            print(f"{PROG}: warning: not compiled ({str(exc).splitlines()[0]}); using the"
                  " reference simulator", file=sys.stderr)
        else:
            return sim.simulate(scenario, **kw), "compiled C" + (" (cache hit)" if sim.cached else "")
    return simulate(model, observer, scenario, **kw), "reference simulator (numpy)"


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


def _positive_int(option):
    return _whole(option, 1)


def _nonnegative_int(option):
    return _whole(option, 0)


def _threshold_from_args(args, model, observer, scenario=None, *, seed=None):
    """The observer with the bands --threshold asks for (None: unchanged)."""
    if getattr(args, "threshold", None) is None:
        if getattr(args, "initial_error", "0") != "0":
            raise UsageError("--initial-error applies to --threshold guaranteed")
        return observer
    from ..model import parse_number
    from ..residuals import ThresholdSpec
    from ..simulation import apply_threshold
    spec = ThresholdSpec.parse(args.threshold)
    e0 = parse_number(args.initial_error, where="--initial-error")
    if e0 != 0 and spec.kind != "guaranteed":
        raise UsageError("--initial-error applies to --threshold guaranteed")
    if spec.kind == "quantile" and scenario is None:
        raise UsageError("--threshold quantile:RATE is estimated on a scenario: give --scenario FILE")
    report(f"computing the {spec.kind} threshold", stage=True)
    return apply_threshold(model, observer, spec, scenario=scenario, initial_error=e0,
                           runs=getattr(args, "quantile_runs", 200), seed=seed)


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
    p.add_argument("--proof-seconds", metavar="S", default=None,
                   help="Jordan form: time budget of the proof that k is minimal (default 2; "
                        "'exhaustive' runs it to the end; when it runs out the condition gives "
                        "the range the least order lies in)")


def _cmd_show(args) -> int:
    from ..model import load_model
    from ..reporting import format_structure, structure_to_json
    from ..model import extract_structure
    st = extract_structure(load_model(args.model))
    if args.json:
        print(json.dumps(structure_to_json(st), indent=2))
    else:
        print(format_structure(st))
    return 0


def _parse_bounds(model, items):
    import dataclasses
    from ..model import parse_number
    if not items:
        return model
    bounds = dict(model.bounds)
    for item in items:
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(",")
        if not sep or not sep2:
            raise UsageError(f"--bound {item!r}: use NAME=LOW,HIGH, e.g. rho=-0.2,0.2")
        sym = model.symbol(name.strip())
        if sym is None:
            raise UsageError(f"--bound {item!r}: '{name.strip()}' is not a symbol of the model")
        lo_v, hi_v = (parse_number(v.strip(), where=f"--bound {item!r}") for v in (lo, hi))
        if bool(lo_v > hi_v):
            raise UsageError(f"--bound {item!r}: low {lo_v} > high {hi_v}")
        bounds[sym] = (lo_v, hi_v)
    return dataclasses.replace(model, bounds=bounds)


def _observer_options(args, result) -> dict:
    if getattr(args, "gain", None):
        if result.observer != "unknown-input":
            raise UsageError("--gain applies to --observer unknown-input")
        from ..model import parse_number
        g = [parse_number(v, where="--gain") for v in args.gain]
        return {"g": g if len(g) > 1 else g[0]}
    return {}


def _drem_from_args(args):
    from ..observers import drem_design, load_drem
    model, spec = load_drem(args.model)
    poles = None
    if args.poles:
        import math
        try:
            poles = [[float(v) for v in item.split(",")] for item in args.poles]
        except ValueError:
            raise UsageError(f"--poles {' '.join(args.poles)}: use comma-separated numbers per set,"
                             " e.g. -1,-2 -3,-4") from None
        if not all(math.isfinite(v) for ps in poles for v in ps):
            raise UsageError(f"--poles {' '.join(args.poles)}: every pole must be a finite number")
    return model, drem_design(model, spec, gamma=args.gamma, poles=poles,
                              include_epsilon=args.include_epsilon)


def _design_from_args(args):
    from ..model import load_model
    from ..synthesis import design
    if getattr(args, "rtol", None) is not None and not (args.rtol > 0 and args.rtol < 1):
        raise UsageError(f"--rtol {args.rtol}: a relative tolerance must lie in (0, 1)")
    if args.observer == "drem":
        return _drem_from_args(args)
    report(f"reading the model {args.model}", stage=True)
    model = _parse_bounds(load_model(args.model), getattr(args, "bound", None))
    report(f"designing the {args.observer} observer for {model.name}"
           f" ({len(model.states)} states, {len(model.outputs)} outputs)", stage=True)
    if getattr(args, "structure", None) and not getattr(args, "isolate", False):
        raise UsageError("--structure applies to residual banks: add --isolate")
    if getattr(args, "isolate", False):
        return model, _bank_from_args(args, model)
    result = design(model, observer=args.observer, faults=args.fault,
                    disturbances=args.disturbance, estimate=args.estimate, form=args.form,
                    lambdas=args.lambdas, eigenvalues=args.eigenvalues, variant=args.variant,
                    robust=args.robust, symbolic=args.symbolic, method=args.method,
                    rtol=args.rtol, **({} if args.proof_seconds is None
                                       else {"proof_seconds": args.proof_seconds}))
    _warn_conditioning(result)
    report(f"design done (k = {getattr(result, 'k', '?')})", stage=True)
    return model, result


def _bank_from_args(args, model):
    from ..analysis import design_bank
    if args.observer != "diagnostic":
        raise UsageError("--isolate builds a bank of residual generators: use --observer diagnostic")
    for flag, used in (("--form canonical", args.form == "canonical"), ("--robust", args.robust),
                       ("--lambda", bool(args.lambdas)), ("--eigenvalues", bool(args.eigenvalues)),
                       ("--variant", args.variant != "plain"), ("--gain", bool(args.gain))):
        if used:
            raise UsageError(f"{flag} does not apply to --isolate (each residual is a minimal"
                             " Jordan-form design)")
    return design_bank(model, structure=args.structure, faults=args.fault or None,
                       disturbances=args.disturbance, symbolic=args.symbolic,
                       method=args.method, rtol=args.rtol)


def _cmd_bank(args, model, bank) -> int:
    from ..reporting import format_bank
    observer = None
    if not args.symbolic:
        from ..observers import build_observer
        observer = _threshold_from_args(args, model, build_observer(model, bank))
    elif args.threshold is not None:
        raise UsageError("--threshold needs numeric parameters: drop --symbolic")
    if args.json:
        out = bank.to_json()
        if observer is not None:
            out["observer_equations"] = observer.to_json()
            if observer.threshold is not None:
                out["threshold_conditions"] = [c.to_json() for c in observer.threshold.conditions]
        print(json.dumps(out, indent=2))
    else:
        print(format_bank(bank))
        if observer is not None and observer.threshold is not None:
            from ..reporting import format_observer, format_observer_conditions
            print(format_observer(observer))
            print(format_observer_conditions(observer))
    _refuse_failed(observer)
    return 0


def _warn_conditioning(result) -> None:
    """One stderr line when the design is ill-conditioned (README "Conditioning")."""
    cond = getattr(result, "conditioning", None)
    if cond is not None and not cond.holds:
        print(f"{PROG}: warning: ill-conditioned design: {cond.detail}"
              " (see 'Conditioning' in the README)", file=sys.stderr)


def _cmd_design(args) -> int:
    from ..reporting import format_design, format_observer, format_observer_conditions
    model, result = _design_from_args(args)
    if getattr(args, "isolate", False):
        return _cmd_bank(args, model, result)
    if args.observer == "drem":
        if args.json:
            out = result.to_json(equations=False)
            ob = result.observer.to_json()
            out.update({"states": ob["states"], "outputs": ob["outputs"],
                        "equations": ob["equations"]})
            print(json.dumps(out, indent=2))
        else:
            print(result.format())
        return 0
    observer = None
    options = _observer_options(args, result)  # a bad --gain is an error here too
    if not args.symbolic and not result.approximate:
        # build it here exactly as simulate and codegen do: a design whose observer cannot
        # be built, or whose observer fails a required condition, is refused now
        from ..observers import build_observer
        report("building the observer", stage=True)
        observer = build_observer(model, result, **options)
        observer = _threshold_from_args(args, model, observer)
    elif args.threshold is not None:
        raise UsageError("--threshold needs a numeric, exact design: drop --symbolic"
                         if args.symbolic else "--threshold: approximate designs have no observer")
    if args.json:
        out = result.to_json()
        if observer is not None:  # the design's own states/equations/outputs stay (what
            # Design.from_json reads back); the built observer's are beside them
            out["observer_equations"] = observer.to_json()
            out["observer_conditions"] = [c.to_json() for c in observer.own_conditions]
        print(json.dumps(out, indent=2))
    else:
        report("formatting the design", stage=True)
        print(format_design(result))
        if observer is not None and (observer.kind in ("interval", "unknown-input", "sliding-mode")
                                     or observer.threshold is not None):
            print(format_observer(observer))
        if observer is not None and observer.own_conditions:
            print(format_observer_conditions(observer))
    _refuse_failed(observer)
    return 0


def _refuse_failed(observer) -> None:
    """A required observer condition that fails is the user's error (e.g. an unstable
    --gain): one line naming it, exit status 2."""
    if observer is None or not observer.failed_conditions:
        return
    c = observer.failed_conditions[0]
    more = len(observer.failed_conditions) - 1
    raise UsageError(f"the observer fails a required condition: {c.name} ({c.detail})"
                     + (f"; and {more} more" if more else ""))


def _cmd_simulate(args) -> int:
    from ..reporting import write_signals_csv
    from ..observers import build_observer
    from ..simulation import load_scenario
    if args.symbolic:
        raise UsageError("simulate needs numeric parameters: drop --symbolic")
    scenario = load_scenario(args.scenario)  # validated before the design's work
    model, result = _design_from_args(args)
    report("building the observer", stage=True)
    observer = build_observer(model, result, **_observer_options(args, result))
    _refuse_failed(observer)
    observer = _threshold_from_args(args, model, observer, scenario)
    _refuse_failed(observer)
    report("simulating", stage=True)
    res, engine = _simulate_with_engine(args, model, observer, scenario)
    decisions = None
    if observer.threshold is not None:
        from ..residuals import decide, decision_rule
        from ..reporting import with_decisions
        rule = decision_rule(model, result, persistence=args.persistence)
        decisions = decide(rule, res.columns)
        written = with_decisions(res, decisions)
    elif args.persistence != 1:
        raise UsageError("--persistence applies with --threshold")
    from ..files import staged_directory
    from ..reporting import UNITS_FILE, plot_simulation
    out, lines = Path(args.out), []
    with staged_directory(out) as stage:  # an error while writing leaves --out as it was
        path = write_signals_csv(res if decisions is None else written, stage)
        order = res.order if decisions is None else written.order
        lines.append(f"wrote {out / path.name} ({len(res['t'])} rows, columns:"
                     f" {', '.join(order)}; {engine})")
        units = ", ".join(f"{c} [{u}]" for c, u in res.units.items() if c in res.order)
        lines.append(f"wrote {out / UNITS_FILE} ("
                     f"{'units: ' + units if units else 'no units: the model declares none'})")
        if res.nonfinite is not None:  # plot what is finite; the CSV keeps nan/inf
            import dataclasses
            import numpy as np
            res = dataclasses.replace(res, columns={
                k: np.where(np.isfinite(v), v, np.nan) for k, v in res.columns.items()})
        for fig in plot_simulation(res, stage, time=model.time,
                                   title=f"{model.name}, {observer.kind}", decisions=decisions):
            lines.append(f"wrote {out / Path(fig).relative_to(stage)}")
    print("\n".join(lines))
    if decisions is not None:
        _print_evaluation(model, observer, res, decisions)
    if res.nonfinite is not None:
        print(f"{PROG}: warning: {res.nonfinite} (kept in the CSV as nan/inf)", file=sys.stderr)
        return 4
    if observer.kind == "drem":
        from ..observers import excitation_report
        rep = excitation_report(res, observer)
        if not rep.ok:
            print(f"{PROG}: warning: {rep.message}", file=sys.stderr)
            return 3
        print(rep.message)
    return 0


def _print_evaluation(model, observer, res, decisions) -> None:
    """The threshold and what the decisions found on this scenario, a few lines."""
    import numpy as np
    from ..simulation import evaluate_result
    print(f"threshold: {observer.threshold.text()}")
    rule = decisions.rule
    alarm = np.asarray(decisions.alarm)
    t = np.asarray(res["t"])
    if alarm.any():
        k = int(np.flatnonzero(alarm)[0])
        print(f"first alarm at t = {t[k]:g} ({decisions.diagnosis[k]}); alarm in"
              f" {int(alarm.sum())} of {alarm.size} samples (persistence {rule.persistence})")
    else:
        print(f"no alarm in {alarm.size} samples (persistence {rule.persistence})")
    m = evaluate_result(res, decisions)
    o = m.runs_[0]
    unit = " steps" if model.time == "discrete" else " s"
    if o.onset is not None:
        print(f"fault ({o.label}) from t = {o.onset:g}: " + (
            f"detected after {o.delay:g}{unit}" if o.delay is not None else "NOT detected")
            + f"; false alarms before it: {o.false_alarm_samples} samples;"
              f" diagnosis at the end: {o.diagnosis}")
    else:
        print(f"no fault in the scenario: {o.false_alarm_samples} false-alarm samples;"
              f" diagnosis at the end: {o.diagnosis}")
    if observer.threshold.kind == "guaranteed" and observer.threshold.error_system.faults:
        from ..residuals import min_detectable_fault
        end = t.size if o.onset is None else max(1, int(np.searchsorted(t, o.onset)))
        widths = [float(np.nanmax(np.asarray(res[f"{r}_upper"] - res[f"{r}_lower"])[:end]))
                  for r in rule.residuals]
        sizes = min_detectable_fault(observer.threshold, widths)
        print("smallest step fault detected for sure once settled (band width on the fault-free"
              " part of this run / dc gain): " + ", ".join(
                  f"{f} ≥ {v:.3g}" if v is not None else f"{f}: not seen"
                  for f, v in sizes.items()))


def _cmd_ensemble(args) -> int:
    import time as _time
    from ..observers import build_observer
    from ..simulation import load_scenario
    if args.symbolic:
        raise UsageError("ensemble needs numeric parameters: drop --symbolic")
    scenario = load_scenario(args.scenario)
    from ..ensemble import Backend
    kind = args.backend or ("dask" if args.dask else "threads")
    if args.dask and kind != "dask":
        raise UsageError(f"--dask ADDRESS runs on Dask: drop --backend {kind}")
    backend = Backend(kind, address=args.dask) if args.workers is None else \
        Backend(kind, workers=args.workers, address=args.dask)
    model, result = _design_from_args(args)
    report("building the observer", stage=True)
    observer = build_observer(model, result, **_observer_options(args, result))
    _refuse_failed(observer)
    # a quantile threshold is estimated on other samples than the ones it is validated on
    observer = _threshold_from_args(args, model, observer, scenario,
                                    seed=(scenario.seed + CALIBRATION_OFFSET) % 2 ** 64)
    _refuse_failed(observer)
    rule = None
    if observer.threshold is not None:
        from ..residuals import decision_rule
        rule = decision_rule(model, result, persistence=args.persistence)
    elif args.persistence != 1:
        raise UsageError("--persistence applies with --threshold")
    from ..ensemble import replay, replay_worst, run_ensemble
    from ..reporting import (plot_ensemble_histograms, plot_simulation, write_signals_csv,
                             write_statistics_json, write_summary_csv)
    out = Path(args.out)
    _check_writable(out)  # before the runs, not after them
    title = f"{model.name}, {observer.kind}"
    sim = None
    if args.engine == "compiled":
        from ..codegen import CodegenError, CompiledSimulator
        report("compiling", stage=True)
        try:
            sim = CompiledSimulator(model, observer)
        except CodegenError as exc:
            raise UsageError(f"the compiled engine is not available ({str(exc).splitlines()[0]});"
                             " use --engine reference (slow)") from None
    if args.replay is not None:
        res = replay(model, observer, scenario, args.replay, runs=args.runs, engine=args.engine,
                     simulator=sim)
        case, k = divmod(args.replay, args.runs)
        d = out / f"run_{args.replay}"
        print(f"run {args.replay}: case {scenario.case_names[case]}, sample {k}")
        from ..simulation import monitors, summarise
        mon = monitors(model, observer, settle=args.settle, rule=rule)
        summ = summarise(mon, res.columns, res["t"])
        for f in summ.fields:
            print(f"  {f.name} = {float(summ.values[f.name][0]):.6g}"
                  + (f" {f.unit}" if f.unit else ""))
        print(f"wrote {write_signals_csv(res, d)}")
        for fig in plot_simulation(res, d, time=model.time, title=f"{title}, run {args.replay}"):
            print(f"wrote {fig}")
        return 0
    total = args.runs * len(scenario.case_names)
    from ..ensemble import progress_bar
    t0 = _time.perf_counter()
    from ..progress import silenced
    with silenced(), progress_bar(total, desc="runs") as bar:
        res = run_ensemble(model, observer, scenario, runs=args.runs, engine=args.engine,
                           backend=backend, chunk=args.chunk, settle=args.settle, rule=rule,
                           keep=0, worst_by=args.worst_by, progress=bar.update,
                           simulator=sim)
    wall = _time.perf_counter() - t0
    from ..version import package_version
    meta = {"model": model.name, "model_file": str(args.model), "observer": observer.kind,
            "scenario": str(args.scenario), "seed": res.seed, "sampling": res.sampling,
            "runs_per_case": res.runs, "cases": list(res.cases), "runs": res.total,
            "completed": res.completed, "interrupted": res.interrupted,
            "engine": res.engine, "backend": backend.kind, "workers": backend.workers,
            "address": backend.address, "chunk": res.chunk, "settle": args.settle,
            "threshold": observer.threshold.text() if observer.threshold is not None else None,
            "seconds": round(res.seconds, 3),
            "runs_per_second": round(res.completed / res.seconds, 1) if res.seconds > 0 else None,
            "version": package_version()}
    print(f"wrote {write_summary_csv(res.accumulator, out, runs=res.runs, seed=res.seed)}"
          f" ({res.completed} runs)")
    print(f"wrote {write_statistics_json(res.statistics, out, ensemble=meta)}")
    _clear_stale(out)  # figures and worst runs of an earlier ensemble in DIR
    if res.interrupted:
        print(f"{PROG}: interrupted after {res.completed} of {res.total} runs; summary.csv and"
              " statistics.json hold the finished runs", file=sys.stderr)
        return 130
    print(f"{res.completed} runs in {res.seconds:.2f} s ({res.completed / max(res.seconds, 1e-9):,.0f}"
          f" runs/s; {res.engine}, {backend.kind} × {backend.workers}, chunks of {res.chunk}; wall"
          f" clock with the design {wall:.2f} s)")
    print()
    print(res.statistics.to_text().rstrip())
    for fig in plot_ensemble_histograms(res.accumulator, out / "figures", title=title):
        print(f"wrote {fig}")
    # the worst runs, replayed after summary.csv and statistics.json are written (a
    # failing replay or a Ctrl-C here loses nothing of the ensemble)
    kept = replay_worst(res, model, observer, scenario, args.keep, worst_by=args.worst_by,
                        engine=args.engine, simulator=sim, settle=args.settle,
                        rule=rule) if args.keep else ()
    for run, case, k, traj in kept:
        d = out / "worst" / f"run_{run}"
        print(f"worst run {run} (case {case}, sample {k}; replayed, its summary reproduced"
              f" exactly): wrote {write_signals_csv(traj, d)}")
        for fig in plot_simulation(traj, d, time=model.time, title=f"{title}, worst run {run}"):
            print(f"wrote {fig}")
    return 0


#: the seed offset of the fault-free runs a quantile threshold is estimated on in an
#: ensemble: other random numbers than the ensemble's own (validation is out of sample)
CALIBRATION_OFFSET = 2 ** 62


def _check_writable(out: Path) -> None:
    """--out can be created and written (a file is made and removed there): a read-only
    folder or a file in its place is a one-line error before hours of runs, not after.
    A folder made for the probe is removed again (an error before the runs leaves none)."""
    import os
    import tempfile
    try:
        created = not out.exists()
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".probe-", dir=out)
        os.close(fd)
        os.unlink(probe)
        if created:
            out.rmdir()
    except OSError as exc:
        raise UsageError(f"{out}: cannot write the output directory:"
                         f" {exc.strerror or type(exc).__name__}") from None


def _clear_stale(out: Path) -> None:
    """Remove the histograms and worst runs an earlier ensemble wrote in ``out``."""
    import shutil
    for f in (out / "figures").glob("hist_*.png"):
        f.unlink(missing_ok=True)
    for d in (out / "worst").glob("run_*"):
        if d.is_dir():
            shutil.rmtree(d, ignore_errors=True)


def _cmd_codegen(args) -> int:
    from ..observers import build_observer
    if args.symbolic:
        raise UsageError("codegen needs numeric parameters: drop --symbolic")
    model, result = _design_from_args(args)
    report("building the observer", stage=True)
    observer = build_observer(model, result, **_observer_options(args, result))
    _refuse_failed(observer)
    scenario = None
    if args.scenario is not None:
        from ..simulation import load_scenario
        scenario = load_scenario(args.scenario)
    observer = _threshold_from_args(args, model, observer, scenario)
    _refuse_failed(observer)
    try:
        from ..codegen import export_observer
    except ModuleNotFoundError:  # pragma: no cover - during development only
        raise UsageError("standalone C export is not available") from None
    dt = args.dt if args.dt is not None else (0.01 if observer.time == "continuous" else None)
    rule = None
    if observer.threshold is not None:
        from ..residuals import decision_rule
        rule = decision_rule(model, result, persistence=args.persistence)
    elif args.persistence != 1:
        raise UsageError("--persistence applies with --threshold")
    from ..files import staged_directory
    out = Path(args.out)
    with staged_directory(out) as stage:  # the three files together, or none changed
        paths = export_observer(observer, stage, name=args.name, dt=dt, rule=rule)
    for p in paths:
        print(f"wrote {out / Path(p).relative_to(stage)}")
    return 0


def _cmd_analyze(args) -> int:
    from ..model import load_model
    from ..reporting import analysis_to_json, format_analysis
    from ..analysis import analyze
    result = analyze(load_model(args.model), faults=args.fault or None,
                     disturbances=args.disturbance, candidates=args.candidate,
                     symbolic=args.symbolic, method=args.method, rtol=args.rtol)
    if args.json:
        print(json.dumps(analysis_to_json(result), indent=2))
    else:
        print(format_analysis(result))
    return 0


class _ShownAs:
    """A text stream that prints ``final`` where the text says ``staging`` (the demo logs
    the paths it writes; they are moved from the staging folder into place at the end)."""

    def __init__(self, stream, staging: Path, final: Path):
        self.stream, self.staging, self.final = stream, str(staging), str(final)

    def write(self, text: str) -> int:
        return self.stream.write(text.replace(self.staging, self.final))

    def flush(self) -> None:
        self.stream.flush()


def _cmd_demo(args) -> int:
    from ..files import staged_directory
    from ..demo import EXAMPLES_DIR, run_demo
    out = Path(args.out)
    with staged_directory(out) as stage:  # an error leaves an existing --out as it was
        return run_demo(EXAMPLES_DIR, stage, compile=not args.no_compile,
                        stream=_ShownAs(sys.stdout, stage, out))


def _terminate(signum, frame):  # pragma: no cover - exercised by a subprocess test
    """SIGTERM as an exception (exit 143): clean-up code runs (staging folders, temporary
    files), as for Ctrl-C; Python's default would end the process on the spot."""
    raise SystemExit(128 + signum)


def main(argv=None) -> int:
    """The ``observer-cad`` command (SIGTERM handled as an exit while it runs)."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        return _main(argv)
    old = signal.signal(signal.SIGTERM, _terminate)
    try:
        return _main(argv)
    finally:
        signal.signal(signal.SIGTERM, old)


def _main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 2
        run = {"show": _cmd_show, "design": _cmd_design, "simulate": _cmd_simulate,
               "codegen": _cmd_codegen, "analyze": _cmd_analyze, "ensemble": _cmd_ensemble,
               "demo": _cmd_demo}[args.command]
        if args.command == "demo":  # the demo prints its own progress
            return run(args)
        with reporting():  # stage lines on stderr after 2 s, on a terminal (progress.py)
            return run(args)
    except ObserverCadError as exc:
        msg = " / ".join(part.strip() for part in str(exc).splitlines() if part.strip())
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 4 if isinstance(exc, NonFiniteError) else 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as exc:  # noqa: BLE001 - never a bare traceback for the user
        internal, line = describe_failure(exc)
        if not internal:  # the environment's (a package not installed), not a bug
            print(f"{PROG}: error: {line}", file=sys.stderr)
            return 2
        print(f"{PROG}: {line} (please report this with the command that caused it)",
              file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
