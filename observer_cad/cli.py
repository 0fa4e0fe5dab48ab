"""Command-line interface: ``observer-cad show|design|demo``.

Every user error prints one line ``observer-cad: error: ...`` on stderr and exits with
status 2; no traceback is shown.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .errors import ObserverCadError, UsageError

__all__ = ["main", "build_parser"]

PROG = "observer-cad"
MODELS_DIR = Path(__file__).resolve().parent.parent / "models"


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors and exit status 2."""

    def error(self, message):  # noqa: D401 - argparse API
        raise UsageError(f"{message} (see '{self.prog} --help')")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description=(
        "Design reduced-order, disturbance-decoupled observers from a symbolic plant model, "
        "with every synthesis condition checked exactly and every design certified."))
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

    sim = sub.add_parser("simulate", help="simulate plant and observer on a scenario, write CSV",
                         description="Design the observer, run the reference simulator on a "
                                     "scenario (JSON) and write DIR/signals.csv: t, the plant "
                                     "states, y1.., every input, fault and disturbance, and the "
                                     "observer's outputs (<signal>_hat, <signal>_lower/_upper, r).")
    sim.add_argument("model", metavar="MODEL", help="path to a model file")
    _add_design_options(sim)
    sim.add_argument("--scenario", metavar="FILE", required=True, help="scenario JSON file")
    sim.add_argument("--out", metavar="DIR", required=True, help="output directory")

    sub.add_parser("demo", help="design the seed papers' examples and print them",
                   description="Load the bundled models (electric drive, three-tank) and print "
                               "their structure and certified designs.")
    return p


def _add_design_options(p) -> None:
    """Options shared by ``design``, ``simulate`` (and later ``codegen``)."""
    p.add_argument("--observer", required=True,
                   choices=["unknown-input", "diagnostic", "virtual-sensor", "interval"],
                   help="unknown-input: estimate the input named by --fault; diagnostic: a "
                        "residual that detects the faults; virtual-sensor / interval: estimate "
                        "(bounds on) z = M x given by --estimate")
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
    p.add_argument("--symbolic", action="store_true",
                   help="keep parameters as symbols (default: substitute their values as exact rationals)")
    p.add_argument("--method", choices=["auto", "exact", "float"], default="auto",
                   help="unknown-input: exact algebra, or SVD with a tolerance (default auto: "
                        "float above 20 states for numeric models)")
    p.add_argument("--rtol", type=float, default=None,
                   help="relative rank tolerance of the float path (default 1e3·eps·size)")


def _cmd_show(args) -> int:
    from .model import load_model
    from .report import format_structure, structure_to_json
    from .structure import extract_structure
    st = extract_structure(load_model(args.model))
    if args.json:
        print(json.dumps(structure_to_json(st), indent=2))
    else:
        print(format_structure(st))
    return 0


def _design_from_args(args):
    from .model import load_model
    from .synthesis import design
    model = load_model(args.model)
    result = design(model, observer=args.observer, faults=args.fault,
                    disturbances=args.disturbance, estimate=args.estimate, form=args.form,
                    lambdas=args.lambdas, eigenvalues=args.eigenvalues, variant=args.variant,
                    robust=args.robust, symbolic=args.symbolic, method=args.method,
                    rtol=args.rtol)
    return model, result


def _cmd_design(args) -> int:
    from .report import format_design, format_observer
    model, result = _design_from_args(args)
    observer = None
    if not args.symbolic and not result.approximate:
        from .pipeline import build_observer
        try:
            observer = build_observer(model, result)
        except ObserverCadError:
            observer = None  # the design stands; the observer kind is not buildable yet
    if args.json:
        out = result.to_json()
        if observer is not None:
            oj = observer.to_json()
            out["observer_equations"] = oj
            out["states"] = oj["states"]
            out["equations"] = oj["equations"]
            out["outputs"] = oj["outputs"]
        print(json.dumps(out, indent=2))
    else:
        print(format_design(result))
        if observer is not None and observer.kind in ("interval", "unknown-input", "sliding-mode"):
            print(format_observer(observer))
    return 0


def _cmd_simulate(args) -> int:
    from .csvout import write_signals_csv
    from .pipeline import build_observer
    from .simulate import load_scenario, simulate
    if args.symbolic:
        raise UsageError("simulate needs numeric parameters: drop --symbolic")
    model, result = _design_from_args(args)
    scenario = load_scenario(args.scenario)
    observer = build_observer(model, result)
    res = simulate(model, observer, scenario)
    path = write_signals_csv(res, args.out)
    print(f"wrote {path} ({len(res['t'])} rows, columns: {', '.join(res.order)})")
    return 0


def _cmd_demo(args) -> int:
    from .demo import run_demo
    return run_demo(MODELS_DIR)


def main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 2
        return {"show": _cmd_show, "design": _cmd_design, "simulate": _cmd_simulate,
                "demo": _cmd_demo}[args.command](args)
    except ObserverCadError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as exc:  # noqa: BLE001 - never a bare traceback for the user
        print(f"{PROG}: internal error: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
              " (please report this with the command that caused it)", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
