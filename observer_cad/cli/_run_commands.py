"""The commands that run an observer with the plant: ``simulate`` (one scenario, CSV and
figures) and ``ensemble`` (many sampled runs: summaries, statistics, the worst runs).
"""
from __future__ import annotations

import sys
from pathlib import Path

from ..errors import UsageError
from ..progress import report
from ._from_args import (design_or_load, monitor_engine, observer_options, refuse_failed,
                         threshold_from_args, unsampled_band_note)
from ._parser import PROG

__all__ = ["cmd_simulate", "cmd_ensemble", "CALIBRATION_OFFSET"]


def cmd_simulate(args) -> int:
    from ..reporting import write_signals_csv
    from ..observers import build_observer
    from ..simulation import load_scenario
    if args.symbolic:
        raise UsageError("simulate needs numeric parameters: drop --symbolic")
    scenario = load_scenario(args.scenario)  # validated before the design's work
    model, result = design_or_load(args, numeric=True)
    report("building the observer", stage=True)
    observer = build_observer(model, result, **observer_options(args, result))
    refuse_failed(observer)
    scenario = _sampled_scenario(args, scenario)
    h = scenario.sample_time
    if h is not None:
        from ..simulation import sample_steps
        sample_steps(model, observer, scenario, h)  # its one-line errors before the band's work
    observer = threshold_from_args(args, model, observer, scenario, sample_time=h)
    refuse_failed(observer)
    report("simulating", stage=True)
    res, engine = _simulate_with_engine(args, model, observer, scenario)
    decisions = None
    if observer.threshold is not None:
        from ..residuals import decide, decision_rule
        from ..reporting import with_decisions
        rule = decision_rule(model, result, persistence=args.persistence)
        decisions = decide(rule, res.columns)
        written, out_of_bounds = _with_bounds(model, with_decisions(res, decisions))
    elif args.persistence != 1:
        raise UsageError("--persistence applies with --threshold")
    from ..files import staged_directory
    from ..reporting import UNITS_FILE, plot_simulation
    out, lines = Path(args.out), []
    with staged_directory(out, command="simulate") as stage:  # an error: --out as it was
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
        note = unsampled_band_note(observer)
        if note:
            print(note)
        _warn_bounds(written, out_of_bounds)
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


def _sampled_scenario(args, scenario):
    """The scenario with --sample-time as its "sample_time" (a quantile threshold is then
    estimated on the sampled runs too)."""
    if getattr(args, "sample_time", None) is None:
        return scenario
    import dataclasses
    return dataclasses.replace(scenario, sample_time=float(args.sample_time))


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
    if scenario.sample_time is not None:
        return _simulate_sampled(args, model, observer, scenario, kw)
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


def _simulate_sampled(args, model, observer, scenario, kw):
    """--sample-time H (or the scenario's "sample_time"): the plant (numpy, on the
    scenario's grid, inputs held) sampled every H and the observer stepped by the
    monitor's engine (compiled C by default, as ``monitor``): (result, the engines'
    description)."""
    from ..simulation import simulate
    h = float(scenario.sample_time)
    engine, how = (None, "reference engine (Python)") if observer is None \
        else monitor_engine(args, observer)
    res = simulate(model, observer, scenario, engine=engine, **kw)
    return res, (f"sampled at h = {h:g}: the plant by the reference simulator (numpy, inputs"
                 f" held), the observer by the monitor's step ({how})")


def _with_bounds(model, res):
    """(the result with ``in_bounds`` appended — 1 while every disturbance, noise and
    bounded input the scenario drew lies in its declared range, in a sampled run over each
    sample's hold —, the first violation ``(index, name, value, low, high)`` or None)."""
    import dataclasses
    import numpy as np
    from ..simulation import bounds_check, declared_signal_bounds
    n = int(np.asarray(res["t"]).size)
    ranges = declared_signal_bounds(model)
    ok, first = bounds_check(ranges, res.columns, n)
    for name, (lo_k, hi_k) in res.holds.items():  # sampled: between the samples too
        if name in ranges:
            k_ok, k_first = bounds_check({name: ranges[name]}, {name: lo_k}, n)
            h_ok, h_first = bounds_check({name: ranges[name]}, {name: hi_k}, n)
            ok &= k_ok & h_ok
            for f in (k_first, h_first):
                if f is not None and (first is None or f[0] < first[0]):
                    first = f
    cols = dict(res.columns)
    cols["in_bounds"] = ok.astype(np.int64)
    return dataclasses.replace(res, columns=cols, order=tuple(res.order) + ("in_bounds",)), first


def _warn_bounds(res, first) -> None:
    """One stderr line when the scenario left the declared bounds: the first time, the
    signal, its range, how many samples."""
    import numpy as np
    if first is None:
        return
    k, name, v, lo, hi = first
    bad = int(np.sum(np.asarray(res["in_bounds"]) == 0))
    t = float(np.asarray(res["t"])[k])
    print(f"{PROG}: warning: the scenario leaves the declared bounds at t = {t:g} ({name} ="
          f" {v:g} outside [{lo:g}, {hi:g}]); {bad} of {np.asarray(res['t']).size} samples out"
          " (in_bounds = 0): the threshold's guarantee does not hold there", file=sys.stderr)


def _print_evaluation(model, observer, res, decisions) -> None:
    """The threshold and what the decisions found on this scenario, a few lines."""
    import numpy as np
    from ..residuals import evaluate_result
    print(f"threshold: {observer.threshold.text()}")
    rule = decisions.rule
    alarm = np.asarray(decisions.alarm)
    t = np.asarray(res["t"])
    m = evaluate_result(res, decisions)
    o = m.runs_[0]
    if alarm.any():
        k = int(np.flatnonzero(alarm)[0])
        print(f"first alarm at t = {t[k]:g} ({_alarm_label(decisions.diagnosis[k], t[k], o)});"
              f" alarm in {int(alarm.sum())} of {alarm.size} samples (persistence"
              f" {rule.persistence})")
    else:
        print(f"no alarm in {alarm.size} samples (persistence {rule.persistence})")
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


def _alarm_label(diagnosis: str, when: float, outcome) -> str:
    """What an alarm at ``when`` is: its diagnosis while a fault is active, else a false
    alarm (no fault yet, or none in the scenario), with the pattern it matched."""
    if outcome.onset is not None and when >= outcome.onset:
        return diagnosis
    return f"false alarm: no fault is active; pattern {diagnosis!r}"


def cmd_ensemble(args) -> int:
    from ..simulation import load_scenario
    if args.symbolic:
        raise UsageError("ensemble needs numeric parameters: drop --symbolic")
    scenario = _sampled_scenario(args, load_scenario(args.scenario))
    backend = _backend(args)
    model, observer, rule = _ensemble_observer(args, scenario)
    out = Path(args.out)
    _check_writable(out)  # before the runs, not after them
    from ..files import check_output_targets
    if args.replay is not None:
        check_output_targets(out, folders=[f"run_{args.replay}"])
    else:
        check_output_targets(out, files=["summary.csv", "statistics.json"],
                             folders=["figures", "worst"])
    title = f"{model.name}, {observer.kind}"
    sim = None
    if args.engine == "compiled" and scenario.sample_time is None:
        from ..codegen import CodegenError, CompiledSimulator
        report("compiling", stage=True)
        try:
            sim = CompiledSimulator(model, observer)
        except CodegenError as exc:
            raise UsageError(f"the compiled engine is not available ({str(exc).splitlines()[0]});"
                             " use --engine reference (slow)") from None
    if args.replay is not None:
        return _replay_one(args, model, observer, scenario, rule, sim, out, title)
    return _run_and_write(args, model, observer, scenario, rule, sim, backend, out, title)


def _backend(args):
    """The :class:`~observer_cad.ensemble.Backend` of --backend, --dask and --workers."""
    from ..ensemble import Backend
    kind = args.backend or ("dask" if args.dask else "threads")
    if args.dask and kind != "dask":
        raise UsageError(f"--dask ADDRESS runs on Dask: drop --backend {kind}")
    if args.dask is not None:
        from ..ensemble import dask_address_problem
        problem = dask_address_problem(args.dask)
        if problem is not None:
            raise UsageError(f"--dask {args.dask!r} is not an address such as"
                             f" tcp://host:8786: {problem}")
    return Backend(kind, address=args.dask) if args.workers is None else \
        Backend(kind, workers=args.workers, address=args.dask)


def _ensemble_observer(args, scenario) -> tuple:
    """(model, observer with its threshold, decision rule or None) of the ensemble."""
    from ..observers import build_observer
    model, result = design_or_load(args, numeric=True)
    report("building the observer", stage=True)
    observer = build_observer(model, result, **observer_options(args, result))
    refuse_failed(observer)
    # a quantile threshold is estimated on other samples than the ones it is validated on
    if scenario.sample_time is not None:
        from ..simulation import sample_steps
        sample_steps(model, observer, scenario, scenario.sample_time)
    observer = threshold_from_args(args, model, observer, scenario,
                                   seed=(scenario.seed + CALIBRATION_OFFSET) % 2 ** 64,
                                   sample_time=scenario.sample_time)
    refuse_failed(observer)
    rule = None
    if observer.threshold is not None:
        from ..residuals import decision_rule
        rule = decision_rule(model, result, persistence=args.persistence)
    elif args.persistence != 1:
        raise UsageError("--persistence applies with --threshold")
    return model, observer, rule


def _replay_one(args, model, observer, scenario, rule, sim, out: Path, title: str) -> int:
    """--replay RUN: that run alone, its summary printed, its signals and figures written."""
    from ..ensemble import replay
    from ..reporting import plot_simulation, write_signals_csv
    res = replay(model, observer, scenario, args.replay, runs=args.runs, engine=args.engine,
                 simulator=sim)
    case, k = divmod(args.replay, args.runs)
    print(f"run {args.replay}: case {scenario.case_names[case]}, sample {k}")
    from ..simulation import monitors, summarise
    mon = monitors(model, observer, settle=args.settle, rule=rule)
    summ = summarise(mon, res.columns, res["t"])
    for f in summ.fields:
        print(f"  {f.name} = {float(summ.values[f.name][0]):.6g}"
              + (f" {f.unit}" if f.unit else ""))
    from ..files import staged_directory
    lines = []
    with staged_directory(out, command=f"ensemble --replay {args.replay}") as stage:
        d = stage / f"run_{args.replay}"
        lines.append(f"wrote {_shown(write_signals_csv(res, d), stage, out)}")
        for fig in plot_simulation(res, d, time=model.time, title=f"{title}, run {args.replay}"):
            lines.append(f"wrote {_shown(fig, stage, out)}")
    print("\n".join(lines))
    return 0


def _shown(path, stage: Path, out: Path) -> Path:
    """Where ``path``, written in the staging folder, is once moved into ``out``."""
    return out / Path(path).relative_to(stage)


def _run_and_write(args, model, observer, scenario, rule, sim, backend, out: Path,
                   title: str) -> int:
    """The ensemble's runs, then summary.csv, statistics.json, the statistics, the
    histograms and the worst runs replayed; 130 when interrupted."""
    import time as _time
    from ..ensemble import progress_bar, run_ensemble
    from ..progress import silenced
    from ..reporting import (plot_ensemble_histograms, write_statistics_json,
                             write_summary_csv)
    total = args.runs * len(scenario.case_names)
    t0 = _time.perf_counter()
    with silenced(), progress_bar(total, desc="runs") as bar:
        res = run_ensemble(model, observer, scenario, runs=args.runs, engine=args.engine,
                           backend=backend, chunk=args.chunk, settle=args.settle, rule=rule,
                           keep=0, worst_by=args.worst_by, progress=bar.update,
                           simulator=sim)
    wall = _time.perf_counter() - t0
    meta = _metadata(args, model, observer, res, backend)
    from ..files import staged_directory
    lines, stopped = [], None
    # everything staged and moved into place together: summary.csv and statistics.json,
    # the histograms, the worst runs (an interruption while the worst runs are replayed
    # keeps what is finished)
    with staged_directory(out, command="ensemble") as stage:
        summary = write_summary_csv(res.accumulator, stage, runs=res.runs, seed=res.seed)
        lines.append(f"wrote {_shown(summary, stage, out)} ({res.completed} runs)")
        statistics = write_statistics_json(res.statistics, stage, ensemble=meta)
        lines.append(f"wrote {_shown(statistics, stage, out)}")
        if not res.interrupted:
            lines += _statistics_lines(res, backend, wall, model, scenario, rule)
            for fig in plot_ensemble_histograms(res.accumulator, stage / "figures", title=title):
                lines.append(f"wrote {_shown(fig, stage, out)}")
            try:
                _replay_worst_runs(args, res, model, observer, scenario, rule, sim, stage, out,
                                   title, lines)
            except (KeyboardInterrupt, SystemExit) as exc:
                stopped = exc
    print("\n".join(lines))
    if res.interrupted:
        print(f"{PROG}: interrupted after {res.completed} of {res.total} runs; summary.csv and"
              " statistics.json hold the finished runs", file=sys.stderr)
        return 130
    if isinstance(stopped, SystemExit):
        raise stopped
    if stopped is not None:
        print(f"{PROG}: interrupted while replaying the worst runs; the ensemble's files are"
              " written", file=sys.stderr)
        return 130
    return 0


def _statistics_lines(res, backend, wall, model, scenario, rule) -> list:
    """The timing line, the statistics' text and, with a decision rule and fault cases,
    the detection and false-alarm rates and the confusion matrix."""
    rate = res.completed / max(res.seconds, 1e-9)
    lines = [f"{res.completed} runs in {res.seconds:.2f} s ({rate:,.0f} runs/s; {res.engine},"
             f" {backend.kind} × {backend.workers}, chunks of {res.chunk}; wall clock with the"
             f" design {wall:.2f} s)", "", res.statistics.to_text().rstrip()]
    if rule is not None:
        from ..ensemble import detection_report
        det = detection_report(res, model, scenario, rule)
        if det is not None:  # fault cases: rates and the confusion matrix
            lines += ["", det.to_text()]
    return lines


def _replay_worst_runs(args, res, model, observer, scenario, rule, sim, stage, out, title,
                       lines) -> None:
    """The worst runs replayed into ``stage``/worst (their lines appended to ``lines``)."""
    from ..ensemble import default_worst_field, replay_worst
    from ..reporting import plot_simulation, write_signals_csv
    from ..simulation import monitors
    if not args.keep:
        return
    field = args.worst_by or default_worst_field(monitors(model, observer, settle=args.settle,
                                                          rule=rule))
    if res.statistics.overall.fields[field].worst_run is None:
        lines.append(f"no worst run: every run has the same {field} (none replayed)")
        return
    kept = replay_worst(res, model, observer, scenario, args.keep, worst_by=field,
                        engine=args.engine, simulator=sim, settle=args.settle, rule=rule)
    for run, case, k, traj in kept:
        d = stage / "worst" / f"run_{run}"
        csv_path = _shown(write_signals_csv(traj, d), stage, out)
        lines.append(f"worst run {run} (case {case}, sample {k}; replayed, its summary"
                     f" reproduced exactly): wrote {csv_path}")
        for fig in plot_simulation(traj, d, time=model.time, title=f"{title}, worst run {run}"):
            lines.append(f"wrote {_shown(fig, stage, out)}")


def _metadata(args, model, observer, res, backend) -> dict:
    """What statistics.json records about the ensemble (``"ensemble"``)."""
    from ..version import package_version
    return {"model": model.name, "model_file": str(args.model), "observer": observer.kind,
            "scenario": str(args.scenario), "seed": res.seed, "sampling": res.sampling,
            "runs_per_case": res.runs, "cases": list(res.cases), "runs": res.total,
            "completed": res.completed, "interrupted": res.interrupted,
            "engine": res.engine, "backend": backend.kind, "workers": backend.workers,
            "address": backend.address, "chunk": res.chunk, "settle": args.settle,
            "threshold": observer.threshold.text() if observer.threshold is not None else None,
            "seconds": round(res.seconds, 3),
            "runs_per_second": round(res.completed / res.seconds, 1) if res.seconds > 0 else None,
            "version": package_version()}


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
