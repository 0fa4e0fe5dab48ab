"""The commands that design an observer and print or export it: ``design`` (text or
JSON; a residual bank with ``--isolate``) and ``codegen`` (standalone C).
"""
from __future__ import annotations

import json
from pathlib import Path

from ..errors import FailedConditionError, UsageError
from ..progress import report
from ._from_args import (design_or_load, observer_options, refuse_failed, threshold_from_args,
                         unsampled_band_note)

__all__ = ["cmd_design", "cmd_codegen"]


def cmd_design(args) -> int:
    from ..reporting import format_design, format_observer, format_observer_conditions
    model, result = design_or_load(args)
    if getattr(args, "isolate", False):
        return _cmd_bank(args, model, result)
    gains = _gains(args, model, [result])  # a bad --frequency is refused before any output
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
    options = observer_options(args, result)  # a bad --gain is an error here too
    if not args.symbolic and not result.approximate:
        # build it here exactly as simulate and codegen do: a design whose observer cannot
        # be built, or whose observer fails a required condition, is refused now
        from ..observers import build_observer
        report("building the observer", stage=True)
        try:
            observer = build_observer(model, result, **options)
        except FailedConditionError as exc:  # shown with its [FAIL], then refused
            observer = exc.observer
        if not observer.failed_conditions:
            observer = threshold_from_args(args, model, observer)
    elif args.threshold is not None:
        raise UsageError("--threshold needs a numeric, exact design: drop --symbolic"
                         if args.symbolic else "--threshold: approximate designs have no observer")
    why_not = None if observer is not None else _no_observer_reason(args, result)
    if args.json:
        out = result.to_json()
        if observer is not None:  # the design's own states/equations/outputs stay (what
            # Design.from_json reads back); the built observer's are beside them
            out["observer_equations"] = observer.to_json()
            out["observer_conditions"] = [c.to_json() for c in observer.own_conditions]
        else:
            out["observer_equations"] = None
            out["observer_not_built"] = why_not
        if args.frequency:
            out["frequency_gains"] = _gains_json(gains)
        print(json.dumps(out, indent=2))
    else:
        report("formatting the design", stage=True)
        print(format_design(result))
        if why_not is not None:
            print(f"\nObserver: not built ({why_not})")
        if observer is not None and (observer.kind in ("interval", "unknown-input", "sliding-mode")
                                     or observer.threshold is not None):
            print(format_observer(observer))
        if observer is not None and observer.own_conditions:
            print(format_observer_conditions(observer))
        if args.frequency:
            print(_gains_text(gains))
    refuse_failed(observer)
    return 0


def _gains(args, model, designs) -> list:
    """--frequency: each design's (each bank row's) gains to the faults at every ω."""
    if not args.frequency:
        return []
    from ..analysis import parse_frequencies
    from ..synthesis.certificates import frequency_gains
    omegas = parse_frequencies(args.frequency, model.time)
    return [frequency_gains(d, omegas) for d in designs]


def _gains_json(gains) -> list:
    """One entry per residual (bank row): fault → [{"omega": ω, "gain": [|g| per output
    row] or null}]."""
    return [{f: [{"omega": str(w), "gain": None if g is None else list(g)} for w, g in rows]
             for f, rows in per.items()} for per in gains]


def _gains_text(gains) -> str:
    var = "|G(jω)|"
    lines = [f"\nGains {var} of the residual to each fault (the residual's rows; 0: not seen"
             " at that frequency)"]
    for i, per in enumerate(gains, 1):
        head = f"  r{i} " if len(gains) > 1 else "  "
        for f, rows in per.items():
            txt = "; ".join(f"ω = {w}: " + ("no steady state" if g is None else
                                            ", ".join(f"{v:.6g}" for v in g)) for w, g in rows)
            lines.append(f"{head}{f}  {txt}")
    return "\n".join(lines)


def _no_observer_reason(args, result) -> str:
    """Why ``design`` built no observer for ``result`` (one line)."""
    if args.symbolic:
        return ("a symbolic design: its parameters have no values, and the observer's"
                " equations, conditions and simulation need numbers; drop --symbolic to"
                " build it")
    return ("an approximate design (--robust: the disturbance is not decoupled exactly):"
            " observers are built from exact designs")


def _cmd_bank(args, model, bank) -> int:
    from ..reporting import format_bank
    gains = _gains(args, model, bank.designs)
    observer = None
    if not args.symbolic:
        from ..observers import build_observer
        observer = threshold_from_args(args, model, build_observer(model, bank))
    elif args.threshold is not None:
        raise UsageError("--threshold needs numeric parameters: drop --symbolic")
    if args.json:
        out = bank.to_json()
        if observer is not None:
            out["observer_equations"] = observer.to_json()
            if observer.threshold is not None:
                out["threshold_conditions"] = [c.to_json() for c in observer.threshold.conditions]
        if args.frequency:
            out["frequency_gains"] = _gains_json(gains)
        print(json.dumps(out, indent=2))
    else:
        print(format_bank(bank))
        if args.frequency:
            print(_gains_text(gains))
        if observer is not None and observer.threshold is not None:
            from ..reporting import format_observer, format_observer_conditions
            print(format_observer(observer))
            print(format_observer_conditions(observer))
    refuse_failed(observer)
    return 0


def cmd_codegen(args) -> int:
    from ..observers import build_observer
    if args.symbolic:
        raise UsageError("codegen needs numeric parameters: drop --symbolic")
    if getattr(args, "fmi_version", None) is not None and not getattr(args, "fmu", False):
        raise UsageError("--fmi-version applies with --fmu")
    model, result = design_or_load(args, numeric=True)
    report("building the observer", stage=True)
    observer = build_observer(model, result, **observer_options(args, result))
    refuse_failed(observer)
    scenario = None
    if args.scenario is not None:
        from ..simulation import load_scenario
        scenario = load_scenario(args.scenario)
    # the band of the algorithm the export runs: a continuous-time observer steps RK4 at --dt
    band_step = (args.dt if args.dt is not None else 0.01) if observer.time == "continuous" \
        else None
    observer = threshold_from_args(args, model, observer, scenario, sample_time=band_step)
    refuse_failed(observer)
    try:
        from ..codegen import export_observer
    except ModuleNotFoundError:  # pragma: no cover - during development only
        raise UsageError("standalone C export is not available") from None
    dt = args.dt if args.dt is not None else (0.01 if observer.time == "continuous" else None)
    sample_time = None
    if getattr(args, "fmu", False) and observer.time == "discrete":
        sample_time, dt = dt, None   # --dt: the FMU's sample period
    rule = None
    if observer.threshold is not None:
        from ..residuals import decision_rule
        rule = decision_rule(model, result, persistence=args.persistence)
    elif args.persistence != 1:
        raise UsageError("--persistence applies with --threshold")
    from ..files import staged_directory
    out = Path(args.out)
    fmu = None
    # several observers (--name) may share a folder: each name's files are its own
    with staged_directory(out, command=f"codegen --name {args.name or observer.name}") as stage:
        from ..simulation import declared_envelope
        paths = export_observer(observer, stage, name=args.name, dt=dt, rule=rule,
                                envelope=declared_envelope(model))
        if getattr(args, "fmu", False):
            from ..codegen import export_fmu
            fmu = export_fmu(observer, stage, name=args.name, dt=dt, sample_time=sample_time,
                             rule=rule, fmi_version=args.fmi_version or "2.0")
            paths.append(fmu.path)
    for p in paths:
        print(f"wrote {out / Path(p).relative_to(stage)}")
    note = unsampled_band_note(observer)
    if note:
        print(note)
    if fmu is not None:
        for src, fmi in fmu.renamed:
            print(f"fmu: '{src}' is named {fmi} (FMI names are identifiers; listed in"
                  " documentation/index.html)")
    return 0
