"""The demo report's "Residual evaluation" section: guaranteed thresholds, alarms and
isolation decisions measured by Monte-Carlo ensembles.

1. The electric drive with an uncertain k5 (``models/electric_drive_uncertain.py``): its
   residual generator with the guaranteed threshold, over fault-free plants sampled from the
   declared uncertainty (false alarms: must be none) and with seed 000's step fault d = 0.2
   (detection delay, measured).
2. The isolating bank of ``models/three_tank_isolation.py`` with guaranteed thresholds: a step
   fault in each tank and the fault-free case over noisy runs, isolated by matching the alarm
   pattern against the structure matrix — the confusion matrix.
3. Sensor against actuator faults (``models/three_tank_sensor_faults.py``: a bias on each
   level sensor, y = x + fs + w): a bank of two residuals over fa1, fa2, fs1 with guaranteed
   thresholds isolates a bias on sensor 1 from the faults of both pumps — the confusion
   matrix over noisy runs.
4. An ensemble: the three-tank's interval observer for x1 over thousands of
   sampled initial states and noise and disturbance realisations
   (``models/scenarios/three_tank_ensemble.json``), summarised per run, the worst run
   replayed (needs the C compiler; skipped with a note without one).

Every figure here is measured when the demo runs; nothing is copied.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from ..errors import ObserverCadError, describe_failure
from ..model import load_model
from ..observers import build_observer
from ..residuals import (FaultCase, decide, decision_rule, guaranteed_threshold,
                         min_detectable_fault)
from ..simulation import evaluate_ensemble, fault_free, load_scenario, simulate
from ..synthesis import design
from ..analysis import design_bank

__all__ = ["EvaluationOutcome", "run_evaluation", "evaluation_section", "evaluation_summary",
           "DRIVE_MODEL", "BANK_MODEL", "SENSOR_MODEL", "ENSEMBLE_MODEL"]

DRIVE_MODEL = "electric_drive_uncertain.py"
DRIVE_SCENARIO = "electric_drive_uncertain"
DRIVE_RUNS = 200
BANK_MODEL = "three_tank_isolation.py"
BANK_SCENARIO = "three_tank_isolation"
BANK_RUNS = 40
SENSOR_MODEL = "three_tank_sensor_faults.py"
SENSOR_SCENARIO = "three_tank_sensor_faults"
SENSOR_FAULTS = ("fa1", "fa2", "fs1")
SENSOR_STRUCTURE = "101,011"
SENSOR_RUNS = 40
SENSOR_FIGURE = "evaluation_sensor_confusion.png"
ENSEMBLE_MODEL = "three_tank.py"
ENSEMBLE_SCENARIO = "three_tank_ensemble"
ENSEMBLE_RUNS = 2000
ENSEMBLE_SETTLE = 5.0
ENSEMBLE_FIGURE = "ensemble_min_slack.png"
ENSEMBLE_WORST_FIGURE = "ensemble_worst_run.png"
DRIVE_FIGURE = "evaluation_drive.png"
BANK_FIGURE = "evaluation_bank_confusion.png"
BANK_RUN_FIGURE = "evaluation_bank_residuals.png"


@dataclasses.dataclass
class EvaluationOutcome:
    drive_metrics: object = None
    drive_conditions: tuple = ()
    drive_min_fault: dict = dataclasses.field(default_factory=dict)
    drive_width: float | None = None
    bank_metrics: object = None
    bank_conditions: tuple = ()
    bank_min_fault: dict = dataclasses.field(default_factory=dict)
    sensor_metrics: object = None
    sensor_conditions: tuple = ()
    ensemble: object = None  # an EnsembleResult
    ensemble_note: str | None = None  # why the ensemble was skipped
    figures: list = dataclasses.field(default_factory=list)  # (name, caption)
    timings: dict = dataclasses.field(default_factory=dict)
    error: str | None = None


def run_evaluation(models_dir: Path, fig_dir: Path, log) -> EvaluationOutcome:
    """Run both ensembles, write the figures; errors are recorded, not raised."""
    from ..reporting import plot_confusion, plot_residuals
    out = EvaluationOutcome()
    step = "electric drive"
    try:
        t0 = time.perf_counter()
        m = load_model(models_dir / DRIVE_MODEL)
        d = design(m, observer="diagnostic")
        ob = guaranteed_threshold(m, build_observer(m, d))
        out.drive_conditions = ob.threshold.conditions
        rule = decision_rule(m, d)
        sc = load_scenario(models_dir / "scenarios" / f"{DRIVE_SCENARIO}.json")
        onset = 100.0
        log(f"[evaluation 1/4] {m.name}: guaranteed threshold, {DRIVE_RUNS} fault-free runs and"
            f" {DRIVE_RUNS} runs with d = 0.2 from t = {onset:g} (k5 sampled per run from its"
            " declared uncertainty)")
        out.drive_metrics = evaluate_ensemble(m, ob, fault_free(m, sc), rule,
                                              cases=[FaultCase("d", 0.2, onset)],
                                              runs=DRIVE_RUNS, seed=sc.seed)
        res = simulate(m, ob, sc)
        dec = decide(rule, res.columns)
        width = np.asarray(res["r_upper"] - res["r_lower"])
        out.drive_width = float(np.max(width[: int(onset)]))
        out.drive_min_fault = min_detectable_fault(ob.threshold, [out.drive_width])
        plot_residuals(res, fig_dir / DRIVE_FIGURE, decisions=dec, time=m.time,
                       title=f"{m.name} (k5 = {res.parameters['k5']:.4g}), d = 0.2 from t = 100")
        out.figures.append((DRIVE_FIGURE,
                            f"{m.name}: the residual, its guaranteed band and the alarm"
                            f" (one run of models/scenarios/{DRIVE_SCENARIO}.json)"))
        out.timings["electric drive"] = time.perf_counter() - t0
        log(f"        {out.drive_metrics.summary()}")

        step = "residual bank"
        t0 = time.perf_counter()
        bm = load_model(models_dir / BANK_MODEL)
        bank = design_bank(bm)
        bo = guaranteed_threshold(bm, build_observer(bm, bank))
        out.bank_conditions = bo.threshold.conditions
        brule = decision_rule(bm, bank)
        bsc = load_scenario(models_dir / "scenarios" / f"{BANK_SCENARIO}.json")
        quiet = fault_free(bm, bsc)
        noisy = dataclasses.replace(quiet, signals={
            **quiet.signals,
            **{w.name: {"uniform": [float(bm.bounds[w][0]), float(bm.bounds[w][1])]}
               for w in bm.noise}})
        log(f"[evaluation 2/4] {bm.name}: bank of {len(bank.designs)} residuals with guaranteed"
            f" thresholds; a step of 0.3 in each fault from t = 10 and the fault-free case,"
            f" {BANK_RUNS} noisy runs each")
        out.bank_metrics = evaluate_ensemble(
            bm, bo, noisy, brule, cases=[FaultCase(f.name, 0.3, 10.0) for f in bm.faults],
            runs=BANK_RUNS, seed=1)
        bres = simulate(bm, bo, dataclasses.replace(noisy, signals={
            **noisy.signals, "f2": "Piecewise((0, t < 10), (0.3, True))"}))
        bdec = decide(brule, bres.columns)
        bw = [float(np.max(np.asarray(bres[f"{r}_upper"] - bres[f"{r}_lower"])))
              for r in brule.residuals]
        out.bank_min_fault = min_detectable_fault(bo.threshold, bw)
        plot_residuals(bres, fig_dir / BANK_RUN_FIGURE, decisions=bdec, time=bm.time,
                       title=f"{bm.name}, f2 = 0.3 from t = 10, noisy")
        out.figures.append((BANK_RUN_FIGURE, f"{bm.name}: the bank's residuals with guaranteed"
                                             " bands, alarms and the diagnosis (fault f2)"))
        plot_confusion(out.bank_metrics, fig_dir / BANK_FIGURE, title=bm.name)
        out.figures.append((BANK_FIGURE, f"{bm.name}: confusion matrix of the isolation"
                                         f" decisions ({out.bank_metrics.runs} runs)"))
        out.timings["residual bank"] = time.perf_counter() - t0
        log(f"        {out.bank_metrics.summary()}")

        step = "sensor faults"
        _run_sensor_faults(out, models_dir, fig_dir, log)

        step = "ensemble"
        _run_ensemble(out, models_dir, fig_dir, log)
    except ObserverCadError as exc:
        out.error = f"{step}: {str(exc).splitlines()[0]}"
        log(f"        FAILED: {out.error}")
    except Exception as exc:  # noqa: BLE001 - a broken step must not stop the demo
        out.error = f"{step}: {describe_failure(exc)[1]}"
        log(f"        FAILED: {out.error}")
    return out


def _run_sensor_faults(out: EvaluationOutcome, models_dir: Path, fig_dir: Path, log) -> None:
    """Part 3: a bias on sensor 1 isolated from the faults of both pumps (guaranteed
    thresholds, noisy runs, the confusion matrix)."""
    from ..reporting import plot_confusion
    t0 = time.perf_counter()
    m = load_model(models_dir / SENSOR_MODEL)
    bank = design_bank(m, faults=SENSOR_FAULTS, structure=SENSOR_STRUCTURE)
    o = guaranteed_threshold(m, build_observer(m, bank))
    out.sensor_conditions = o.threshold.conditions
    quiet = fault_free(m, load_scenario(models_dir / "scenarios" / f"{SENSOR_SCENARIO}.json"))
    noisy = dataclasses.replace(quiet, signals={
        **quiet.signals,
        **{w.name: {"uniform": [float(m.bounds[w][0]), float(m.bounds[w][1])]} for w in m.noise}})
    log(f"[evaluation 3/4] {m.name}: bank of {len(bank.designs)} residuals over"
        f" {', '.join(SENSOR_FAULTS)} with guaranteed thresholds; a step of 0.3 in each from"
        f" t = 10 and the fault-free case, {SENSOR_RUNS} noisy runs each")
    out.sensor_metrics = evaluate_ensemble(
        m, o, noisy, decision_rule(m, bank), cases=[FaultCase(f, 0.3, 10.0) for f in SENSOR_FAULTS],
        runs=SENSOR_RUNS, seed=2)
    plot_confusion(out.sensor_metrics, fig_dir / SENSOR_FIGURE, title=m.name)
    out.figures.append((SENSOR_FIGURE, f"{m.name}: a bias on sensor 1 (fs1) against the pump"
                                       f" faults fa1, fa2 ({out.sensor_metrics.runs} runs)"))
    out.timings["sensor faults"] = time.perf_counter() - t0
    log(f"        {out.sensor_metrics.summary()}")


def _run_ensemble(out: EvaluationOutcome, models_dir: Path, fig_dir: Path, log) -> None:
    """Part 3: the three-tank interval observer over an ensemble (compiled; skipped
    without a C compiler)."""
    from ..codegen import CodegenError, CompiledSimulator
    from ..ensemble import Backend, run_ensemble
    from ..reporting import plot_ensemble_histograms, plot_simulation
    t0 = time.perf_counter()
    m = load_model(models_dir / ENSEMBLE_MODEL)
    o = build_observer(m, design(m, observer="interval", estimate="x1"))
    sc = load_scenario(models_dir / "scenarios" / f"{ENSEMBLE_SCENARIO}.json")
    try:
        sim = CompiledSimulator(m, o)
    except CodegenError as exc:
        out.ensemble_note = f"not run: the ensemble needs the C compiler ({str(exc).splitlines()[0]})"
        log(f"[evaluation 4/4] {out.ensemble_note}")
        return
    log(f"[evaluation 4/4] {m.name}: interval observer for x1, ensemble of {ENSEMBLE_RUNS} runs"
        f" × {len(sc.case_names)} cases (compiled, every core)")
    res = run_ensemble(m, o, sc, runs=ENSEMBLE_RUNS, settle=ENSEMBLE_SETTLE,
                       backend=Backend("threads"), simulator=sim, keep=1)
    out.ensemble = res
    tmp = fig_dir / ".ensemble"
    for path in plot_ensemble_histograms(res.accumulator, tmp, title=m.name,
                                         fields=("x1.min_slack",)):
        path.replace(fig_dir / ENSEMBLE_FIGURE)
    out.figures.append((ENSEMBLE_FIGURE, f"{m.name}: smallest slack of x1 inside its interval"
                                         f" per run ({res.completed} runs, t ≥ {ENSEMBLE_SETTLE:g} s)"))
    run, case, k, traj = res.kept[0]
    for path in plot_simulation(traj, tmp, time=m.time, title=f"{m.name}, worst run {run}"):
        if path.name == "x1_bounds.png":
            path.replace(fig_dir / ENSEMBLE_WORST_FIGURE)
    import shutil
    shutil.rmtree(tmp, ignore_errors=True)
    out.figures.append((ENSEMBLE_WORST_FIGURE, f"{m.name}: the ensemble's worst run {run} (case"
                                               f" {case}, sample {k}), replayed"))
    out.timings["ensemble"] = time.perf_counter() - t0
    viol = res.statistics.overall.fields["x1.violations"]
    log(f"        {res.completed} runs in {res.seconds:.2f} s: {viol.positive} left the interval;"
        f" worst run {run}")


def _fmt(v) -> str:
    return "—" if v is None else f"{v:.3g}"


def evaluation_summary(ev: EvaluationOutcome) -> str:
    """One bullet for the report's introduction."""
    from ..reporting import md_escape
    if ev.drive_metrics is None:
        return f"- [residual evaluation](#evaluation): ❌ {md_escape(ev.error or 'not run')}"
    dm = ev.drive_metrics
    med, mx = dm.delay_stats()
    text = (f"- [residual evaluation](#evaluation) (thresholds and decisions over Monte-Carlo runs):"
            f" electric drive with uncertain k5 —"
            f" {dm.false_alarm_runs} false alarms in {dm.case('no fault').runs} fault-free runs,"
            f" d = 0.2 detected in {dm.faulty_runs - dm.missed_detections} of {dm.faulty_runs} runs"
            f" (delay median {_fmt(med)}, max {_fmt(mx)} steps)")
    if ev.bank_metrics is not None:
        text += f"; three-tank bank isolation accuracy {ev.bank_metrics.isolation_accuracy:.3g}"
    if ev.sensor_metrics is not None:
        text += (f"; sensor against actuator faults isolation accuracy"
                 f" {ev.sensor_metrics.isolation_accuracy:.3g}")
    if ev.ensemble is not None:
        v = ev.ensemble.statistics.overall.fields["x1.violations"]
        text += (f"; [ensemble](#ensemble) (the interval observer over sampled runs):"
                 f" {v.positive} of {ev.ensemble.completed} three-tank runs left the interval")
    if ev.error:
        text += f"; ❌ {md_escape(ev.error)}"
    return text


def _conditions(conds) -> list:
    from ..reporting import md_escape
    return [f"- {'✅' if c.holds else '❌'} **{md_escape(c.name)}**: {md_escape(c.detail)}"
            for c in conds]


def _sensor_section(ev: EvaluationOutcome) -> list:
    """The sensor-against-actuator-faults part of the evaluation section."""
    return [
        "### Sensor faults against actuator faults", "",
        f"Model `models/{SENSOR_MODEL}`: the linear three-tank with every level measured and an"
        " additive bias on each sensor, y_i = x_i + fs_i + w_i (the fault enters the output"
        " directly: Dy ≠ 0), besides a fault on each pump (fa1, fa2). Residual r1 is decoupled"
        " from fa2, r2 from fa1 (both from the disturbance ρ); each sees the sensor-1 bias, r1"
        " directly through R* Dy, r2 through the observer's input J* Dy — so the columns of"
        f" the structure matrix over ({', '.join(SENSOR_FAULTS)}) are 10, 01 and 11: the bias is"
        " told apart from either pump fault. Guaranteed thresholds, uniform noise at its"
        f" declared bounds, a step of 0.3 in one fault from t = 10 s, {SENSOR_RUNS} runs per"
        " case.", "",
        "```sh",
        f"observer-cad design models/{SENSOR_MODEL} --observer diagnostic --isolate --fault fa1"
        f" --fault fa2 --fault fs1 --structure {SENSOR_STRUCTURE}",
        f"observer-cad simulate models/{SENSOR_MODEL} --observer diagnostic --isolate --fault fa1"
        f" --fault fa2 --fault fs1 --structure {SENSOR_STRUCTURE} --threshold guaranteed"
        f" --scenario models/scenarios/{SENSOR_SCENARIO}.json --out sensor", "```", "",
        "The threshold rests on:", "", *_conditions(ev.sensor_conditions), "",
        ev.sensor_metrics.to_markdown(), ""]


def evaluation_section(ev: EvaluationOutcome) -> str:
    from ..reporting import md_escape
    out = ['<a id="evaluation"></a>', "## Residual evaluation", "",
           "A residual becomes a diagnosis with a threshold and a decision rule. The guaranteed"
           " threshold is the band the fault-free residual cannot leave while the declared bounds"
           " of noise, disturbances and parameter uncertainty hold (METHOD §3, residual"
           " evaluation, in `docs/METHOD.md`); an alarm is a residual outside its band, and the"
           " alarm pattern is matched against the structure matrix. Every number below was"
           " measured by this run of the demo (seeded, so it is reproduced exactly).", ""]
    if ev.drive_metrics is not None:
        dm = ev.drive_metrics
        out += ["### Electric drive with an uncertain k5", "",
                f"Model `models/{DRIVE_MODEL}`: the drive of seed 000 §9 with k5 known to 1 % and"
                " asymmetric sensor noise (this project's example). The residual generator is"
                " designed at the nominal k5; the true k5 of each run is drawn from the declared"
                f" range. {DRIVE_RUNS} fault-free runs and {DRIVE_RUNS} runs with a step d = 0.2"
                " from t = 100 (seed 000's fault size), 200 steps each.", "",
                "Reproduce one run:", "", "```sh",
                f"observer-cad simulate models/{DRIVE_MODEL} --observer diagnostic --threshold"
                f" guaranteed --scenario models/scenarios/{DRIVE_SCENARIO}.json --out sim", "```", "",
                "The threshold rests on:", "", *_conditions(ev.drive_conditions), "",
                dm.to_markdown(), ""]
        if ev.drive_min_fault:
            out += [f"Smallest step fault detected for sure once settled (band width"
                    f" {ev.drive_width:.3g} over the fault-free part of the run ÷ the dc gain of"
                    f" the fault to the residual): "
                    + ", ".join(f"{f} ≥ {_fmt(v)}" for f, v in ev.drive_min_fault.items()), ""]
    if ev.bank_metrics is not None:
        out += ["### Isolation with the three-tank bank", "",
                f"Model `models/{BANK_MODEL}` and its bank (generalised observer scheme, see"
                " [Diagnosability](#diagnosability)) with guaranteed thresholds; uniform noise at"
                " its declared bounds, the scenario's inputs and disturbance, a step of 0.3 in one"
                f" fault from t = 10 s, {BANK_RUNS} runs per case. The diagnosis is the one at the"
                " end of the run.", "",
                "The threshold rests on:", "", *_conditions(ev.bank_conditions), "",
                ev.bank_metrics.to_markdown(), ""]
        if ev.bank_min_fault:
            out += ["Smallest step faults detected for sure once settled: "
                    + ", ".join(f"{f} ≥ {_fmt(v)}" for f, v in ev.bank_min_fault.items()), ""]
    if ev.sensor_metrics is not None:
        out += _sensor_section(ev)
    if ev.ensemble is not None or ev.ensemble_note:
        out += ['<a id="ensemble"></a>', "### Validation over an ensemble", ""]
    if ev.ensemble_note:
        out += [md_escape(ev.ensemble_note), ""]
    if ev.ensemble is not None:
        r = ev.ensemble
        slack = r.statistics.overall.fields["x1.min_slack"]
        run, case, k, _ = r.kept[0]
        out += [f"Model `models/{ENSEMBLE_MODEL}`, interval observer for x1, scenario"
                f" `models/scenarios/{ENSEMBLE_SCENARIO}.json`: initial levels drawn per run,"
                " noise (and, in case *gusty*, the disturbances) uniform over the model's declared"
                f" bounds, a new sample every step; {r.runs} samples × {len(r.cases)} cases, each run"
                " reduced to its summaries as it finished (nothing else kept). A run depends only on"
                " (seed, its index): the worst one is replayed exactly.", "",
                "```sh",
                f"observer-cad ensemble models/{ENSEMBLE_MODEL} --observer interval --estimate x1"
                f" --scenario models/scenarios/{ENSEMBLE_SCENARIO}.json --runs {r.runs}"
                f" --settle {ENSEMBLE_SETTLE:g} --out ens", "```", "",
                f"{r.completed} runs in {r.seconds:.2f} s ({r.completed / max(r.seconds, 1e-9):,.0f}"
                f" runs/s, {md_escape(r.engine)}, {r.backend.kind} × {r.backend.workers}). Samples"
                f" with t ≥ {ENSEMBLE_SETTLE:g} s count:", "",
                "```text", r.statistics.to_text().rstrip(), "```", "",
                f"Worst run by the smallest slack: run {run} (case {case}, sample {k}), slack"
                f" {slack.min:.4g}; replay it with `observer-cad simulate models/{ENSEMBLE_MODEL}"
                f" --observer interval --estimate x1 --scenario"
                f" models/scenarios/{ENSEMBLE_SCENARIO}.json --case {case} --run {k} --out sim`.", ""]
    for name, cap in ev.figures:
        out += [f"![{md_escape(cap)}](figures/{name})", "", f"*{md_escape(cap)}*", ""]
    if ev.timings:
        out += ["**Timings**: " + ", ".join(f"{k} {v:.2f} s" for k, v in ev.timings.items()), ""]
    if ev.error:
        out += [f"**FAILED** ({md_escape(ev.error)})", ""]
    return "\n".join(out)
