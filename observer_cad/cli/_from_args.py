"""The model, design, observer and threshold the command-line options ask for (shared by
``design``, ``simulate``, ``ensemble`` and ``codegen``).
"""
from __future__ import annotations

import sys

from ..errors import UsageError
from ..progress import report
from ._parser import PROG

__all__ = ["design_from_args", "observer_options", "threshold_from_args", "refuse_failed"]


def design_from_args(args):
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


def _warn_conditioning(result) -> None:
    """One stderr line when the design is ill-conditioned (README "Conditioning")."""
    cond = getattr(result, "conditioning", None)
    if cond is not None and not cond.holds:
        print(f"{PROG}: warning: ill-conditioned design: {cond.detail}"
              " (see 'Conditioning' in the README)", file=sys.stderr)


def observer_options(args, result) -> dict:
    if getattr(args, "tau", None) is not None:
        if result.observer != "unknown-input" or getattr(args, "gain", None):
            raise UsageError("--tau applies to --observer unknown-input on a continuous-time"
                             " model (without --gain)")
        from ..model import parse_number
        return {"tau": parse_number(args.tau, where="--tau")}
    if getattr(args, "gain", None):
        if result.observer != "unknown-input":
            raise UsageError("--gain applies to --observer unknown-input")
        from ..model import parse_number
        g = [parse_number(v, where="--gain") for v in args.gain]
        return {"g": g if len(g) > 1 else g[0]}
    return {}


def threshold_from_args(args, model, observer, scenario=None, *, seed=None, sample_time=None):
    """The observer with the bands --threshold asks for (None: unchanged). With the data's
    ``sample_time`` on a continuous-time model that declares its operating envelope, the
    guaranteed band is the sampled-data one of the algorithm that runs (RK4 at that step)."""
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
    if spec.kind == "guaranteed" and sample_time is not None and model.time == "continuous" \
            and e0 == 0 and all(s in model.bounds for s in model.states + model.inputs):
        import sympy as sp
        from ..residuals import sampled_threshold
        return sampled_threshold(model, observer, sp.Rational(repr(float(sample_time))))
    return apply_threshold(model, observer, spec, scenario=scenario, initial_error=e0,
                           runs=getattr(args, "quantile_runs", 200), seed=seed)


def refuse_failed(observer) -> None:
    """A required observer condition that fails is the user's error (e.g. an unstable
    --gain): one line naming it, exit status 2."""
    if observer is None or not observer.failed_conditions:
        return
    c = observer.failed_conditions[0]
    more = len(observer.failed_conditions) - 1
    raise UsageError(f"the observer fails a required condition: {c.name} ({c.detail})"
                     + (f"; and {more} more" if more else ""))
