"""The model, design, observer and threshold the command-line options ask for (shared by
``design``, ``simulate``, ``ensemble`` and ``codegen``).
"""
from __future__ import annotations

import dataclasses

import sys

from ..errors import UsageError
from ..progress import report
from ._parser import PROG

__all__ = ["design_or_load", "design_from_args", "observer_options", "threshold_from_args", "refuse_failed",
           "unsampled_band_note", "monitor_engine"]


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


def design_or_load(args, *, numeric: bool = False):
    """``(model, design)`` for a command: designed from the options (:func:`design_from_args`),
    or, with ``--design FILE``, the frozen design (or residual bank, or DREM design) in
    FILE, loaded for the model, recomputed and compared, never believed
    (:func:`observer_cad.analysis.load_design`). Design options given beside ``--design``
    must agree with the file (one line naming the first that does not); options not given
    are the file's. ``numeric``: a symbolic design file is refused (simulate, ensemble,
    codegen). The one entry every command that runs an observer uses."""
    path = getattr(args, "design", None)
    if path is None:
        return design_from_args(args)
    from ..model import load_model
    if getattr(args, "rtol", None) is not None and not (args.rtol > 0 and args.rtol < 1):
        raise UsageError(f"--rtol {args.rtol}: a relative tolerance must lie in (0, 1)")
    if args.observer == "drem":
        return _drem_from_file(args, path)
    report(f"reading the model {args.model}", stage=True)
    model = _parse_bounds(load_model(args.model), getattr(args, "bound", None))
    report(f"loading the design {path} (recomputed and compared)", stage=True)
    from ..analysis import ResidualBank, load_design
    result = load_design(path, model)
    bank = isinstance(result, ResidualBank)
    _agree(args, path, result, bank)
    if numeric and (result.designs[0].symbolic if bank else result.symbolic):
        raise UsageError(f"design file {path}: a symbolic design has no numeric observer:"
                         f" design without --symbolic")
    args.isolate = bank  # what the file is decides (the commands read these two)
    args.symbolic = result.designs[0].symbolic if bank else result.symbolic
    if not bank:
        _warn_conditioning(result)
        _check_observer_conditions(args, path, model, result)
    report("design loaded", stage=True)
    return model, result


def _check_observer_conditions(args, path, model, result) -> None:
    """A file written by ``design --json`` records its observer's conditions: they are
    recomputed by building the observer (with this command's --gain) and compared, the
    required ones by name and verdict, the others by name."""
    from ..files import read_json_file
    recorded = read_json_file(path, "design").get("observer_conditions")
    if recorded is None or result.symbolic or result.approximate:
        return
    from ..observers import build_observer
    observer = build_observer(model, result, **observer_options(args, result))
    mine = {c.name: c for c in observer.own_conditions}
    if not isinstance(recorded, list) or not all(isinstance(c, dict) for c in recorded):
        raise UsageError(f"design file {path}: the recorded observer_conditions are not a list"
                         " of objects")
    names = [c.get("name") for c in recorded]
    for c in recorded:
        own = mine.get(c.get("name"))
        if own is None:
            raise UsageError(f"design file {path}: the recorded observer condition"
                             f" {str(c.get('name'))[:80]!r} is not one building the observer"
                             " gives (refused, never believed)")
        if own.required and c.get("holds") is not bool(own.holds):
            raise UsageError(f"design file {path}: the recorded observer condition"
                             f" {own.name!r} says holds = {c.get('holds')!r}, recomputed"
                             f" {bool(own.holds)} (refused, never believed)")
    missing = [n for n in mine if n not in names]
    if missing:
        raise UsageError(f"design file {path}: the recorded observer_conditions lack"
                         f" {missing[0]!r} (refused, never believed)")


def _given(args, name, default) -> bool:
    return getattr(args, name, default) not in (default, None, [], ())


def _agree(args, path, result, bank: bool) -> None:
    """Each design option given beside --design agrees with the file's design."""
    def refuse(option, mine, theirs):
        raise UsageError(f"--design {path}: {option} {mine} does not agree with the file"
                         f" ({theirs}); drop {option} or design again")
    kind = "diagnostic" if bank else result.observer.value
    if args.observer != kind:
        refuse("--observer", args.observer, kind)
    if bank:
        faults, dist = list(result.faults), list(result.disturbances)
        req = result.designs[0].request
        if _given(args, "structure", None):
            from ..analysis import parse_structure
            rows = parse_structure(args.structure, result.faults)
            if rows != result.structure_matrix:
                refuse("--structure", args.structure, ",".join(
                    "".join(map(str, r)) for r in result.structure_matrix))
    else:
        req = result.request
        faults, dist = list(req.faults), list(req.disturbances)
        if getattr(args, "isolate", False) or _given(args, "structure", None):
            refuse("--isolate" if getattr(args, "isolate", False) else "--structure",
                   "(a bank)", "a single design")
    if _given(args, "fault", []) and sorted(args.fault) != sorted(faults):
        refuse("--fault", ",".join(args.fault), ",".join(faults) or "none")
    if _given(args, "disturbance", []) and sorted(args.disturbance) != sorted(dist):
        refuse("--disturbance", ",".join(args.disturbance), ",".join(dist) or "none")
    for option, name, default, theirs in (
            ("--form", "form", None, req.form), ("--variant", "variant", "plain", req.variant),
            ("--method", "method", "auto", req.method), ("--robust", "robust", False, req.robust),
            ("--symbolic", "symbolic", False, req.symbolic), ("--rtol", "rtol", None, req.rtol)):
        if _given(args, name, default) and getattr(args, name) != theirs:
            refuse(option, getattr(args, name), theirs)
    if _given(args, "estimate", None) and "".join(args.estimate.split()) != "".join(
            str(req.estimate or "").split()):
        refuse("--estimate", args.estimate, req.estimate)
    for option, name, theirs in (("--lambda", "lambdas", req.lambdas),
                                 ("--eigenvalues", "eigenvalues", req.eigenvalues)):
        if _given(args, name, None) and not _same_values(getattr(args, name), theirs, option):
            refuse(option, " ".join(getattr(args, name)), " ".join(map(str, theirs or ())))
    if _given(args, "proof_seconds", None):
        from ..synthesis.jordan import proof_seconds_value
        if proof_seconds_value(args.proof_seconds) != req.proof_seconds:
            refuse("--proof-seconds", args.proof_seconds, req.proof_seconds)


def _same_values(texts, values, option) -> bool:
    from ..model import parse_number
    if values is None or len(texts) != len(values):
        return False
    return all(parse_number(t, where=option) == v for t, v in zip(texts, values))


def _drem_from_file(args, path):
    """A frozen DREM design: its recorded choice designed again and compared
    (:meth:`DremDesign.from_json`); --gamma, --poles, --include-epsilon must agree."""
    from ..files import read_json_file
    from ..observers import DremDesign, load_drem
    model, spec = load_drem(args.model)
    data = read_json_file(path, "design")
    if not isinstance(data, dict) or "model_hash" not in data:
        raise UsageError(f"design file {path}: not a DREM design with a 'model_hash' (the"
                         " structure of the model it was made for): design again")
    try:
        result = DremDesign.from_json(data, model, spec)
    except UsageError as exc:
        raise UsageError(f"design file {path}: {exc}") from None
    _, fresh = _drem_from_args(args) if (args.gamma is not None or args.poles
                                         or args.include_epsilon) else (None, None)
    if fresh is not None and fresh.to_json(equations=False) != result.to_json(equations=False):
        raise UsageError(f"--design {path}: --gamma, --poles or --include-epsilon do not agree"
                         " with the file; drop them or design again")
    return model, result


def _parse_bounds(model, items):
    import dataclasses
    from ..model import bound_problem, parse_number
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
        problem = bound_problem(lo_v, hi_v)
        if problem:
            raise UsageError(f"--bound {item!r}: the bounds {problem}")
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
    why = ""
    if spec.kind == "guaranteed" and sample_time is not None and model.time == "continuous":
        why = _sampled_band_obstacle(model, observer, e0)
        if not why:
            import sympy as sp
            from ..residuals import sampled_threshold
            return sampled_threshold(model, observer, sp.Rational(repr(float(sample_time))))
    try:
        out = apply_threshold(model, observer, spec, scenario=scenario, initial_error=e0,
                              runs=getattr(args, "quantile_runs", 200), seed=seed)
    except UsageError as exc:
        if why.startswith("no sampled-data band"):  # neither band: say both reasons
            raise UsageError(f"{exc}; and {why}") from None
        raise
    if not why:
        return out
    # the band of continuous observation on a sampled observer: the gap is a listed condition
    from ..synthesis import Condition
    c = Condition("sampling", False, f"the sampling at h = {float(sample_time):.10g} s (y and u"
                  f" held over each step) is not covered; {why}", "METHOD §3", required=False)
    th = dataclasses.replace(out.threshold, conditions=tuple(out.threshold.conditions) + (c,))
    return dataclasses.replace(out, threshold=th, conditions=tuple(out.conditions) + (c,))


def _sampled_band_obstacle(model, observer, e0) -> str:
    """Why the sampled-data band does not apply ("" when it does)."""
    if e0 != 0:
        return "--initial-error gives the band of continuous observation"
    missing = [str(s) for s in model.states + model.inputs if s not in model.bounds]
    if missing:
        return (f"declare bounds for every state and input (the operating envelope; {missing[0]}"
                " has none) for the sampled-data band")
    from ..residuals import sampled_band_refusal
    why = sampled_band_refusal(model, observer)
    prefix = f"{model.where}: "
    return f"no sampled-data band: {why[len(prefix):] if why.startswith(prefix) else why}" if why else ""


def unsampled_band_note(observer) -> str:
    """The note line for a guaranteed band of continuous observation on a continuous-time
    observer that runs sampled (its "sampling" condition), "" otherwise."""
    th = observer.threshold
    c = next((c for c in th.conditions if c.name == "sampling"), None) if th is not None else None
    return f"note: this band is that of continuous observation: {c.detail}" if c else ""


def monitor_engine(args, observer):
    """(the monitor's engine for ``observer``, its description): the compiled loop unless
    --engine reference or no C compiler (then a warning), else the reference engine."""
    if args.engine == "compiled":
        from ..codegen import CodegenError, CompiledMonitorEngine
        report("compiling", stage=True)
        try:
            eng = CompiledMonitorEngine(observer)
        except CodegenError as exc:
            print(f"{PROG}: warning: not compiled ({str(exc).splitlines()[0]}); using the"
                  " monitor's reference engine", file=sys.stderr)
        else:
            return eng, "compiled C" + (" (cache hit)" if eng.cached else "")
    from ..simulation import ReferenceMonitorEngine
    return ReferenceMonitorEngine(observer), "reference engine (Python)"


def refuse_failed(observer) -> None:
    """A required observer condition that fails is the user's error (e.g. an unstable
    --gain): one line naming it, exit status 2."""
    if observer is None or not observer.failed_conditions:
        return
    c = observer.failed_conditions[0]
    more = len(observer.failed_conditions) - 1
    raise UsageError(f"the observer fails a required condition: {c.name} ({c.detail})"
                     + (f"; and {more} more" if more else ""))
