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
                                   "conditions, assumptions and certificate.")
    d.add_argument("model", metavar="MODEL", help="path to a model file")
    d.add_argument("--observer", required=True, choices=["unknown-input"],
                   help="observer kind (unknown-input: estimate the input named by --fault)")
    d.add_argument("--fault", metavar="NAME",
                   help="the unknown input to estimate: a fault, or a disturbance (then it is "
                        "not decoupled); faults not named are taken as zero")
    d.add_argument("--disturbance", metavar="NAME", action="append", default=[],
                   help="a further fault or disturbance to decouple from (repeatable); the "
                        "model's own disturbances are always decoupled")
    d.add_argument("--form", choices=["canonical"], default="canonical",
                   help="form of the reduced model (default: canonical, METHOD §2a)")
    d.add_argument("--symbolic", action="store_true",
                   help="keep parameters as symbols (default: substitute their values as exact rationals)")
    d.add_argument("--method", choices=["auto", "exact", "float"], default="auto",
                   help="exact algebra, or SVD with a tolerance (default auto: float above "
                        "20 states for numeric models)")
    d.add_argument("--rtol", type=float, default=None,
                   help="relative rank tolerance of the float path (default 1e3·eps·size)")
    d.add_argument("--json", action="store_true", help="print one JSON object instead of text")

    sub.add_parser("demo", help="design the seed papers' examples and print them",
                   description="Load the bundled models (electric drive, three-tank) and print "
                               "their structure and certified designs.")
    return p


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


def _cmd_design(args) -> int:
    from .canonical import design_canonical
    from .model import load_model
    from .report import format_design
    if args.fault is None:
        raise UsageError("--observer unknown-input needs --fault NAME (the input to estimate)")
    model = load_model(args.model)
    design = design_canonical(model, unknown_input=args.fault, decouple=args.disturbance,
                              symbolic=args.symbolic, method=args.method, rtol=args.rtol)
    if args.json:
        print(json.dumps(design.to_json(), indent=2))
    else:
        print(format_design(design))
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
        return {"show": _cmd_show, "design": _cmd_design, "demo": _cmd_demo}[args.command](args)
    except ObserverCadError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
