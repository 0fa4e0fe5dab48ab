"""``observer-cad demo``: every observer the seed papers build for the electric drive and
the three-tank — designed, certified, compiled, simulated on the papers' scenarios,
plotted, and written up in ``out/report.md``.

What runs (see :data:`CASES`):

* electric drive (seed 000 §9, discrete): unknown-input estimators of the fault d
  (k = 1, Fig. 1–2) and of the disturbance ρ (k = 2, mismatched, ρ* = 0.2,
  g = (−0.4, −0.1), Fig. 3–4), the Jordan-form estimator of seed 000 §8, a residual
  generator (seed 002 §2) and an interval observer for the speed x2;
* nonlinear three-tank (seed 002 §8, continuous): the Jordan virtual sensor
  x*' = u1 − √(x* − y1) (Fig. 2) and the interval observer of x1 (Fig. 3, two noise
  levels);
* linear three-tank (seeds 001 §7 and 004 §5): virtual sensors for x1 (canonical form,
  plain and seed 004's variant; Jordan form) and interval observers for x1 (001 methods
  1 and 2, Fig. 2);
* the sliding-mode example (this project's model, seed 002 §5);
* diagnosability (issue 12, :data:`DIAGNOSABILITY`): the analysis of
  ``three_tank_faults.py`` (which faults can be detected with ρ decoupled, which pairs
  isolated, the achievable structure matrix, the reasons and suggestions), and an
  isolating residual bank for ``three_tank_isolation.py`` (every level measured),
  compiled, simulated with a step fault in tank 2 and plotted (:data:`BANK_FIGURE`).

Each design is printed with its conditions (short form; the full text goes to the
report), compiled into one C trajectory function with the plant
(:class:`~observer_cad.codegen.CompiledSimulator`; without a C compiler the reference
simulator runs instead, and the demo says so), simulated, and plotted. Every write is
atomic (figures via :func:`~observer_cad.reporting.save_figure`, text via
:func:`~observer_cad.reporting.atomic_write_text`).

Output, under ``out_dir`` (default ``out``): ``report.md``, ``figures/*.png``,
``designs/<key>.json`` and ``designs/<key>.tex`` (the design exported as JSON and
LaTeX, :mod:`observer_cad.reporting`).
"""
from __future__ import annotations

import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import sympy as sp

from ..files import atomic_write_text
from ..errors import ObserverCadError, UsageError, describe_failure
from ..model import load_model
from ..reporting import format_design, format_observer, format_structure
from ..model import extract_structure
from ..synthesis import design as make_design
from ._evaluation import (BANK_MODEL, DRIVE_MODEL, ENSEMBLE_MODEL, evaluation_section,
                          evaluation_summary, run_evaluation)

__all__ = ["CASES", "EXAMPLES_DIR", "FIGURES", "Case", "Run", "run_demo",
           "DIAGNOSABILITY", "BANK_FIGURE", "DiagnosabilityExample"]

R = sp.Rational

#: The example models (``*.py``) and their scenarios (``scenarios/*.json``), which ship
#: inside the package: in a source checkout ``observer_cad/examples`` is a symbolic link
#: to the repository's ``models/`` (one copy of every file), and an installed package
#: holds the files themselves (pyproject ``package-data``). The demo reads its models
#: here, so it runs from any directory, with or without the repository.
EXAMPLES_DIR = Path(__file__).resolve().parent.parent / "examples"


@dataclasses.dataclass(frozen=True)
class Run:
    """One simulation of a case: a scenario file of ``models/scenarios``."""

    scenario: str
    #: "zero": start the observer at x*(0) = 0 instead of its default Φ x(0), so that
    #: the convergence of the estimate is visible.
    observer_start: str | None = None


@dataclasses.dataclass(frozen=True)
class Case:
    """One design of the demo: what the paper does, and how it is reproduced."""

    key: str
    heading: str
    paper: str
    model: str
    design: dict
    runs: tuple = ()
    options: dict = dataclasses.field(default_factory=dict)  # build_observer(**options)
    bounds: dict = dataclasses.field(default_factory=dict)  # model bounds overridden
    cli: str = ""
    note: str = ""



CASES = (
    Case("drive_d", "Electric drive: estimate the fault d (k = 1)",
         "seed 000 §9, Fig. 1–2", "electric_drive.py",
         dict(observer="unknown-input", faults=["d"], symbolic=True),
         runs=(Run("electric_drive_fig1"), Run("electric_drive_fig2")),
         cli="observer-cad design models/electric_drive.py --observer unknown-input --fault d --symbolic\n"
             "observer-cad simulate models/electric_drive.py --observer unknown-input --fault d"
             " --scenario models/scenarios/electric_drive_fig1.json --out out/fig1",
         note="Designed with k1…k6 kept symbolic (the paper's matrices, up to a common"
              " factor); simulated at the model's values (a forward-Euler DC motor, see"
              " models/electric_drive.py). g = −0.7, d̲ = −0.4, d̄ = 0.4, x̲*(0) = −1,"
              " x̄*(0) = 1 as in the paper."),
    Case("drive_rho", "Electric drive: estimate the disturbance ρ with d = 0 (k = 2, mismatched)",
         "seed 000 §9, Fig. 3–4", "electric_drive.py",
         dict(observer="unknown-input", faults=["rho"], symbolic=True),
         runs=(Run("electric_drive_rho_fig3"), Run("electric_drive_rho_fig4")),
         options=dict(bounds={"rho": (R(-1, 5), R(1, 5))}, g=[R(-2, 5), R(-1, 10)]),
         cli="observer-cad design models/electric_drive.py --observer unknown-input --fault rho --symbolic\n"
             "observer-cad simulate models/electric_drive.py --observer unknown-input --fault rho"
             " --bound rho=-0.2,0.2 --gain -0.4 -0.1"
             " --scenario models/scenarios/electric_drive_rho_fig3.json --out out/fig3",
         note="ρ* = 0.2, g1 = −0.4, g2 = −0.1 as in the paper. ρ enters the second row only"
              " (mismatched case): ρ̂(t) is available at step t + 2."),
    Case("drive_d_jordan", "Electric drive: Jordan-form estimator of d (λ = 1/2)",
         "seed 000 §8", "electric_drive.py",
         dict(observer="unknown-input", faults=["d"], form="jordan"),
         runs=(Run("electric_drive_fig1"),),
         cli="observer-cad design models/electric_drive.py --observer unknown-input --fault d --form jordan",
         note="The one-dimensional λ-model of seed 000 §8 on the scenario of Fig. 1."),
    Case("drive_diag", "Electric drive: residual generator for d, decoupled from ρ",
         "seed 002 §2 (Jordan form) on the drive of seed 000 §9", "electric_drive.py",
         dict(observer="diagnostic", form="jordan"),
         runs=(Run("electric_drive_diagnostic"),),
         cli="observer-cad design models/electric_drive.py --observer diagnostic --form jordan"),
    Case("drive_interval", "Electric drive: interval observer for the motor speed x2 (λ = 4/5)",
         "seed 002 §4 / seed 001 method 2 on the drive of seed 000 §9", "electric_drive.py",
         dict(observer="interval", estimate="x2", lambdas=["4/5"]),
         runs=(Run("electric_drive_interval"),),
         cli="observer-cad design models/electric_drive.py --observer interval --estimate x2 --lambda 4/5",
         note="λ = 4/5 gives Φ = (0, 1, 0): the fault does not reach x*, only the load"
              " torque's bound |ρ| ≤ 0.05 does (width 2·0.05/(1 − 4/5) = 0.5 rad/s)."),
    Case("tank_vs", "Nonlinear three-tank: Jordan virtual sensor for x1",
         "seed 002 §8, Fig. 2", "three_tank.py",
         dict(observer="virtual-sensor", estimate="x1"),
         runs=(Run("three_tank_fig2"),),
         cli="observer-cad design models/three_tank.py --observer virtual-sensor --estimate x1",
         note="λ = −1 gives the one-dimensional sensor x*' = u1 − √(x* − y1), z = x*,"
              " decoupled from ρ1 and ρ2."),
    Case("tank_interval", "Nonlinear three-tank: interval observer for x1 (|w| ≤ 0.01)",
         "seed 002 §8, Fig. 3", "three_tank.py",
         dict(observer="interval", estimate="x1"),
         runs=(Run("three_tank_interval"),),
         cli="observer-cad design models/three_tank.py --observer interval --estimate x1"),
    Case("tank_interval_w05", "Nonlinear three-tank: interval observer for x1 (|w| ≤ 0.05)",
         "seed 002 §8, Fig. 3 (second noise level)", "three_tank.py",
         dict(observer="interval", estimate="x1"),
         runs=(Run("three_tank_interval_w05"),),
         bounds={"w1": (R(-1, 20), R(1, 20)), "w2": (R(-1, 20), R(1, 20))},
         cli="observer-cad design models/three_tank.py --observer interval --estimate x1"
             " --bound w1=-0.05,0.05 --bound w2=-0.05,0.05"),
    Case("lin_vs_plain", "Linear three-tank: canonical-form virtual sensor for x1 (k = 2)",
         "seed 001 §7 / seed 004 §5", "three_tank_linear.py",
         dict(observer="virtual-sensor", estimate="x1", form="canonical", eigenvalues=["-1", "-2"]),
         runs=(Run("three_tank_linear_virtual", "zero"),),
         cli="observer-cad design models/three_tank_linear.py --observer virtual-sensor"
             " --estimate x1 --form canonical --eigenvalues -1 -2"),
    Case("lin_vs_004", "Linear three-tank: seed 004's virtual sensor (virtual output drives the model)",
         "seed 004 §5", "three_tank_linear.py",
         dict(observer="virtual-sensor", estimate="x1", form="canonical", variant="004",
              eigenvalues=["-1", "-2"]),
         runs=(Run("three_tank_linear_virtual", "zero"),),
         cli="observer-cad design models/three_tank_linear.py --observer virtual-sensor"
             " --estimate x1 --form canonical --variant 004 --eigenvalues -1 -2"),
    Case("lin_vs_jordan", "Linear three-tank: Jordan-form virtual sensor for x1 (k = 1)",
         "seed 002 §3 on the tank of seed 001 §7", "three_tank_linear.py",
         dict(observer="virtual-sensor", estimate="x1"),
         runs=(Run("three_tank_linear_virtual", "zero"),),
         cli="observer-cad design models/three_tank_linear.py --observer virtual-sensor --estimate x1"),
    Case("lin_interval_m2", "Linear three-tank: interval observer for x1, method 2 (Jordan, k = 1)",
         "seed 001 §7, observer (7.2), Fig. 2", "three_tank_linear.py",
         dict(observer="interval", estimate="x1"),
         runs=(Run("three_tank_linear_interval"),),
         cli="observer-cad design models/three_tank_linear.py --observer interval --estimate x1"),
    Case("lin_interval_m1", "Linear three-tank: interval observer for x1, method 1 (canonical → diagonal, k = 2)",
         "seed 001 §7, method 1", "three_tank_linear.py",
         dict(observer="interval", estimate="x1", form="canonical", eigenvalues=["-1", "-2"]),
         runs=(Run("three_tank_linear_interval"),),
         cli="observer-cad design models/three_tank_linear.py --observer interval --estimate x1"
             " --form canonical --eigenvalues -1 -2"),
    Case("sliding", "Sliding-mode estimator of the fault d",
         "seed 002 §5 (this project's example model)", "sliding_example.py",
         dict(observer="sliding-mode"),
         runs=(Run("sliding_example"),),
         cli="observer-cad design models/sliding_example.py --observer sliding-mode"),
)


@dataclasses.dataclass(frozen=True)
class DiagnosabilityExample:
    """The worked example of issue 12 in the report: the analysis of one model, and an
    isolating residual bank (:func:`~observer_cad.synthesis.design_bank`, best scheme)
    for another, simulated on ``scenario``."""

    analysis_model: str
    bank_model: str
    scenario: str
    analysis_cli: str = ""
    bank_cli: str = ""
    analysis_note: str = ""
    note: str = ""


DIAGNOSABILITY = DiagnosabilityExample(
    "three_tank_faults.py", "three_tank_isolation.py", "three_tank_isolation",
    analysis_cli="observer-cad analyze models/three_tank_faults.py",
    bank_cli="observer-cad analyze models/three_tank_isolation.py\n"
             "observer-cad design models/three_tank_isolation.py --observer diagnostic --isolate\n"
             "observer-cad simulate models/three_tank_isolation.py --observer diagnostic --isolate"
             " --scenario models/scenarios/three_tank_isolation.json --out out/bank",
    analysis_note="f3 enters tank 3 exactly as ρ does, so no residual decoupled from ρ can see it,"
                  " whatever is measured. f1 and f2 are each detected by an order-2 residual (the"
                  " k = 2 of seed 001 §7), but with two outputs, one disturbance and one more fault"
                  " to decouple there is no room left to tell them apart; measuring x1 as well would"
                  " give an order-1 residual for each direction. The bank below is built on such a"
                  " plant.",
    note="The same three tanks with the third level sensor added (x1 measured too) and the"
         " disturbance ρ entering every tank alike (a common supply line): no fault enters as ρ"
         " does, and each can be decoupled together with ρ.")

#: the figure of the residual bank (r1 … rm under a step fault), under ``figures/``
BANK_FIGURE = "three_tank_isolation_residuals.png"
#: the analysis and the bank as JSON (``analyze --json``, ``design --isolate --json``), under ``designs/``
ANALYSIS_JSON = "three_tank_faults_analysis.json"
BANK_JSON = "three_tank_isolation_bank.json"


# ---------------------------------------------------------------- running the cases
@dataclasses.dataclass
class Outcome:
    case: Case
    model: object = None
    design: object = None
    observer: object = None
    sims: dict = dataclasses.field(default_factory=dict)
    timings: dict = dataclasses.field(default_factory=dict)
    engine: str = ""
    error: str | None = None
    full_text: str = ""
    figures: list = dataclasses.field(default_factory=list)


class _Log:
    def __init__(self, stream):
        self.stream = stream

    def __call__(self, msg: str = "") -> None:
        print(msg, file=self.stream, flush=True)


def _short(text: str, width: int = 96) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= width else text[: width - 1] + "…"


def _mark(c) -> str:
    return "[ ok ]" if c.holds else ("[FAIL]" if c.required else "[ -- ]")


def _model(models_dir: Path, case: Case, cache: dict):
    if case.model not in cache:
        cache[case.model] = load_model(models_dir / case.model)
    m = cache[case.model]
    if case.bounds:
        b = dict(m.bounds)
        for name, lohi in case.bounds.items():
            b[m.symbol(name)] = lohi
        m = dataclasses.replace(m, bounds=b)
    return m


class _Engine:
    """Compiled simulation with a one-time fallback to the reference simulator."""

    def __init__(self, compile: bool, log):
        self.compile = compile
        self.reason = None if compile else "compilation switched off (--no-compile)"
        self.log = log

    def prepare(self, model, observer):
        if self.reason is None:
            from ..codegen import CodegenError, CompiledSimulator
            try:
                return CompiledSimulator(model, observer)
            except CodegenError as exc:
                self.reason = str(exc).splitlines()[0]
                self.log(f"        C compilation unavailable ({self.reason});"
                         " falling back to the reference simulator (numpy) for every design")
        return None

    def prepare_logged(self, model, observer, timings: dict):
        """:meth:`prepare`, timed into ``timings["compile"]`` and logged with the observer's
        build time; returns (simulator or None, the engine's description)."""
        t0 = time.perf_counter()
        sim = self.prepare(model, observer)
        if sim is None:
            self.log(f"        build observer {timings['observer']:.2f} s · not compiled: {self.reason}")
            return None, "reference simulator (numpy)"
        timings["compile"] = time.perf_counter() - t0
        self.log(f"        build observer {timings['observer']:.2f} s · compile {timings['compile']:.2f} s"
                 f" ({'from the cache' if sim.cached else 'C compiled now'})")
        return sim, "compiled C" + (" (cache hit)" if sim.cached else "")

    @staticmethod
    def run(sim, model, observer, scenario):
        if sim is not None:
            return sim.simulate(scenario)
        from ..simulation import simulate
        return simulate(model, observer, scenario)


def _run_case(i: int, n: int, case: Case, models_dir: Path, models: dict, engine: _Engine,
              log) -> Outcome:
    from ..observers import build_observer
    from ..simulation import load_scenario
    out = Outcome(case)
    log(f"[{i:2d}/{n}] {case.heading}  ({case.paper})")
    try:
        first = case.model not in models
        model = out.model = _model(models_dir, case, models)
        if first:
            log("        " + format_structure(extract_structure(model)).splitlines()[0])
        t0 = time.perf_counter()
        d = out.design = make_design(model, **case.design)
        out.timings["design"] = time.perf_counter() - t0
        log(format_design(d).splitlines()[0])
        log(f"        designed in {out.timings['design']:.2f} s;"
            f"{' λ = ' + ', '.join(map(str, d.lambdas)) + ';' if d.lambdas else ''}"
            f" certificate {'PASSED' if d.certificate.passed else 'FAILED'}"
            f" ({'exact' if d.certificate.exact else 'float'})")
        for c in d.conditions:
            log(f"          {_mark(c)} {_short(c.name, 90)}")
        if d.assumptions:
            log(f"          assumptions: {', '.join(str(a) for a in d.assumptions)}")
        t0 = time.perf_counter()
        ob = out.observer = build_observer(model, d, **case.options)
        out.timings["observer"] = time.perf_counter() - t0
        out.full_text = format_design(d) + "\n" + format_observer(ob)
        extra = [c for c in ob.conditions if c not in d.conditions]
        if extra:
            held = sum(1 for c in extra if c.holds)
            log(f"          observer: {held} of {len(extra)} conditions hold"
                + "".join(f"\n          {_mark(c)} {_short(c.name, 90)}" for c in extra if not c.holds))
        sim, out.engine = engine.prepare_logged(model, ob, out.timings)
        t0 = time.perf_counter()
        for run in case.runs:
            sc = load_scenario(models_dir / "scenarios" / f"{run.scenario}.json")
            if run.observer_start == "zero":
                sc = dataclasses.replace(sc, observer_initial={str(s): 0.0 for s in ob.states})
            out.sims[run.scenario] = engine.run(sim, model, ob, sc)
        out.timings["simulate"] = time.perf_counter() - t0
        steps = sum(len(r["t"]) for r in out.sims.values())
        log(f"        simulate {out.timings['simulate'] * 1e3:.0f} ms ({out.engine}):"
            f" {', '.join(r.scenario for r in case.runs)} ({steps} steps)")
    except ObserverCadError as exc:
        out.error = str(exc).splitlines()[0]
        log(f"        FAILED: {out.error}")
    except Exception as exc:  # noqa: BLE001 - one broken case must not stop the demo
        out.error = describe_failure(exc)[1]
        log(f"        FAILED: {out.error}")
    return out


# ---------------------------------------------------------------- diagnosability (issue 12)
@dataclasses.dataclass
class DiagOutcome:
    example: DiagnosabilityExample
    analysis: object = None
    analysis_model: object = None
    bank_model: object = None
    bank_analysis: object = None
    bank: object = None
    observer: object = None
    sim: object = None
    engine: str = ""
    analysis_time: float = 0.0
    timings: dict = dataclasses.field(default_factory=dict)  # of the bank
    error: str | None = None
    figure: tuple | None = None  # (name, caption)


def _count(items, word="of") -> str:
    return f"{sum(1 for ok in items if ok)} {word} {len(items)}"


def _run_diagnosability(ex: DiagnosabilityExample, models_dir: Path, engine: _Engine,
                        log) -> DiagOutcome:
    """Analyse ``ex.analysis_model``; design, compile and simulate the residual bank of
    ``ex.bank_model``. Errors are recorded, not raised (one broken step must not stop
    the demo)."""
    from ..observers import build_observer
    from ..simulation import load_scenario
    from ..analysis import analyze, design_bank
    out = DiagOutcome(ex)
    step = "analysis"
    try:
        model = out.analysis_model = load_model(models_dir / ex.analysis_model)
        log(f"[diagnosability 1/2] Analysis of {model.name}: faults"
            f" {', '.join(f.name for f in model.faults)};"
            f" decoupled: {', '.join(d.name for d in model.disturbances) or 'nothing'}"
            "  (issue 12 worked example)")
        t0 = time.perf_counter()
        a = out.analysis = analyze(model)
        out.analysis_time = time.perf_counter() - t0
        det = [f"{r.fault} (k = {r.min_order})" for r in a.fault_results if r.detectable]
        log(f"        analysed in {out.analysis_time:.2f} s: detectable"
            f" {', '.join(det) or 'none'}; isolable pairs {_count([p.isolable for p in a.pairs])};"
            f" {len(a.structure)} achievable structure row(s)")
        for r in a.fault_results:
            if not r.detectable:
                log(f"          {_short(r.reason, 140)}")
        for s_ in a.suggestions:
            log(f"          suggestion: {s_.goal}: measure {s_.measurement} (k = {s_.min_order})")

        step = "residual bank"
        bm = out.bank_model = load_model(models_dir / ex.bank_model)
        log(f"[diagnosability 2/2] Isolating residual bank for {bm.name}: faults"
            f" {', '.join(f.name for f in bm.faults)};"
            f" decoupled: {', '.join(d.name for d in bm.disturbances) or 'nothing'}")
        t0 = time.perf_counter()
        out.bank_analysis = analyze(bm)
        out.timings["analyze"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        bank = out.bank = design_bank(bm)
        out.timings["design"] = time.perf_counter() - t0
        rows = ", ".join("".join(map(str, r)) for r in bank.structure_matrix)
        log(f"        {bank.scheme}: {len(bank.designs)} residuals, structure matrix {rows}"
            f" (columns {', '.join(bank.faults)}); isolated pairs"
            f" {_count([ok for _, ok in bank.isolable])}; designed in {out.timings['design']:.2f} s;"
            f" certificates {'PASSED' if bank.certified else 'FAILED'}")
        t0 = time.perf_counter()
        ob = out.observer = build_observer(bm, bank)
        out.timings["observer"] = time.perf_counter() - t0
        sim, out.engine = engine.prepare_logged(bm, ob, out.timings)
        t0 = time.perf_counter()
        sc = load_scenario(models_dir / "scenarios" / f"{ex.scenario}.json")
        out.sim = engine.run(sim, bm, ob, sc)
        out.timings["simulate"] = time.perf_counter() - t0
        log(f"        simulate {out.timings['simulate'] * 1e3:.0f} ms ({out.engine}):"
            f" {ex.scenario} ({len(out.sim['t'])} steps)")
        if not bank.certified:
            out.error = "a residual of the bank is not certified"
    except ObserverCadError as exc:
        out.error = f"{step}: {str(exc).splitlines()[0]}"
        log(f"        FAILED: {out.error}")
    except Exception as exc:  # noqa: BLE001 - a broken step must not stop the demo
        out.error = f"{step}: {describe_failure(exc)[1]}"
        log(f"        FAILED: {out.error}")
    return out


def _fault_onset(res, faults):
    """(fault, first t where it is nonzero) of the first fault that acts, or (None, None)."""
    for f in faults:
        v = np.asarray(res[f], dtype=float)
        nz = np.flatnonzero(np.abs(v) > 0)
        if nz.size:
            return f, float(np.asarray(res["t"])[nz[0]])
    return None, None


def fig_bank_residuals(diag: DiagOutcome, path):
    """The fault and the disturbance, then one panel per residual r_i: the residuals of
    the faulty column move, the others stay at rounding level."""
    plt = _plt()
    bank, res = diag.bank, diag.sim
    faults = list(bank.faults)
    t = np.asarray(res["t"], dtype=float)
    fault, t_f = _fault_onset(res, faults)
    if fault is None:
        raise ValueError("the scenario applies no fault: nothing to isolate")
    col = [int(r[faults.index(fault)]) for r in bank.structure_matrix]
    m = len(bank.designs)
    fig, axes = plt.subplots(m + 1, 1, sharex=True, figsize=(8, 2.0 + 1.45 * m),
                             height_ratios=[1.6] + [1] * m)
    a = axes[0]
    a.plot(t, res[fault], color="tab:red", lw=1.8, label=f"fault {fault} (tank {faults.index(fault) + 1})")
    for dist in diag.bank_model.disturbances:
        a.plot(t, res[dist.name], color="0.5", lw=1.0,
               label=f"disturbance ${SIGNAL_TEX.get(dist.name, dist.name)}$ (decoupled)")
    a.set_ylabel(f"{fault}, " + ", ".join(f"${SIGNAL_TEX.get(d.name, d.name)}$"
                                          for d in diag.bank_model.disturbances))
    rows = ", ".join("".join(map(str, r)) for r in bank.structure_matrix)
    a.set_title(f"Residual bank for {bank.model_name}: {bank.scheme} (structure {rows})")
    a.legend(loc="upper left", ncols=2, fontsize=8)
    lo, hi = float(np.min(res[fault])), float(np.max(res[fault]))
    a.set_ylim(min(lo, -0.25) - 0.05, hi + 0.35)
    before_mask = t < t_f
    moved, stats = [], []
    scale = max(float(np.max(np.abs(res[f"r{i}"]))) for i in range(1, m + 1))
    for i, ax in enumerate(axes[1:], 1):
        r = np.asarray(res[f"r{i}"], dtype=float)
        sees = col[i - 1]
        before = float(np.max(np.abs(r[before_mask]))) if before_mask.any() else 0.0
        after = float(np.max(np.abs(r[t >= t_f])))
        moved.append(after > 1e-6 * max(scale, 1e-12))
        stats.append((before, after))
        ax.plot(t, r, color="tab:purple" if sees else "tab:green", lw=1.5,
                label=f"r{i}  (row {''.join(map(str, bank.structure_matrix[i - 1]))})")
        ax.axhline(0, color="k", lw=0.6)
        ax.axvline(t_f, color="tab:red", ls=":", lw=1.0)
        ax.set_ylim(-1.15 * scale, 1.15 * scale)
        ax.set_ylabel(f"$r_{{{i}}}$")
        ax.legend(loc="upper left")
        _box(ax, (f"sees {fault} (S = 1): max|r{i}| = {after:.3g} after t = {t_f:g}" if sees else
                  f"decoupled from {fault} (S = 0): max|r{i}| = {_sci(after)}")
             + f"\nbefore the fault: max|r{i}| = {_sci(before)}",
             "upper right" if r[-1] < 0 else "lower right")
    axes[-1].set_xlabel("t [s]" if bank.time == "continuous" else "t [steps]")
    agree = all(bool(mv) == bool(c) for mv, c in zip(moved, col))
    moving = [f"r{i}" for i, mv in enumerate(moved, 1) if mv]
    still = [f"r{i}" for i, mv in enumerate(moved, 1) if not mv]
    caption = (f"Isolating residual bank ({bank.scheme}) for {bank.model_name}: a step fault in"
               f" {fault} at t = {t_f:g} while the disturbance acts. {fault}'s column of the"
               f" structure matrix is ({', '.join(map(str, col))}):"
               f" {', '.join(moving) or 'none'} {'moves' if len(moving) == 1 else 'move'}"
               f" (max |r| = {max(s[1] for s in stats):.3g}),"
               f" {', '.join(still) or 'none'} {'stays' if len(still) == 1 else 'stay'} at rounding"
               f" level ({max([s[1] for s, mv in zip(stats, moved) if not mv] or [0.0]):.1e})"
               f" — {'as the structure matrix predicts' if agree else 'NOT as the structure matrix predicts'};"
               f" before the fault every residual is at most {max(s[0] for s in stats):.1e}.")
    if not agree:
        raise ValueError(caption)
    return fig, caption


def _diag_figure(diag: DiagOutcome, fig_dir: Path, log, failed: list) -> None:
    from ..reporting import save_figure
    if diag.error is not None or diag.sim is None:
        log(f"[figure] {BANK_FIGURE}: skipped (the residual bank did not run)")
        return
    plt = _plt()
    t1 = time.perf_counter()
    with plt.rc_context(STYLE):
        try:
            fig, caption = fig_bank_residuals(diag, fig_dir / BANK_FIGURE)
            save_figure(fig, fig_dir / BANK_FIGURE)
        except Exception as exc:  # noqa: BLE001 - report it, keep the rest
            failed.append(BANK_FIGURE)
            plt.close("all")
            log(f"[figure] {BANK_FIGURE}: FAILED ({type(exc).__name__}: {exc})")
            return
    diag.figure = (BANK_FIGURE, caption)
    log(f"[figure] {fig_dir / BANK_FIGURE}  ({time.perf_counter() - t1:.2f} s)")


# ---------------------------------------------------------------- figures
def _unit(res, name: str) -> str:
    """The unit of a column, from the model's ``units=`` (via the result); "" when none."""
    return (getattr(res, "units", None) or {}).get(name, "")


def _br(unit: str) -> str:
    """`` [unit]`` for an axis label, or nothing."""
    return f" [{unit}]" if unit else ""


def _sp(unit: str) -> str:
    """`` unit`` after a number, or nothing."""
    return f" {unit}" if unit else ""


SIGNAL_TEX = {"d": "d", "rho": r"\rho", "x1": "x_1", "x2": "x_2", "x3": "x_3"}


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


#: matplotlib settings of the demo's figures (applied in a context, not globally)
STYLE = {"font.size": 10, "axes.titlesize": 11, "legend.fontsize": 9,
         "axes.grid": True, "grid.alpha": 0.3, "lines.linewidth": 1.4,
         "figure.subplot.hspace": 0.1, "figure.subplot.left": 0.1,
         "figure.subplot.right": 0.97, "figure.subplot.top": 0.94,
         "figure.subplot.bottom": 0.08}


def _box(ax, text, loc="upper left"):
    x, ha = (0.01, "left") if "left" in loc else (0.99, "right")
    y, va = (0.96, "top") if "upper" in loc else (0.04, "bottom")
    ax.text(x, y, text, transform=ax.transAxes, ha=ha, va=va, fontsize=9,
            bbox=dict(boxstyle="round,pad=0.3", fc="white", ec="0.6", alpha=0.92), zorder=5)


def _sci(v: float) -> str:
    if v == 0:
        return "0"
    e = int(np.floor(np.log10(abs(v))))
    m = v / 10 ** e
    return rf"${m:.1f}\times10^{{{e}}}$" if abs(e) >= 3 else f"{v:.3g}"


def _aligned(res, name, delay):
    """(t, true, estimate) where the estimate exists (a delayed estimate is shifted back
    by the simulator; its last ``delay`` rows are NaN)."""
    t, true, est = (np.asarray(res[c], dtype=float) for c in ("t", name, f"{name}_hat"))
    ok = np.isfinite(est)
    return t[ok], true[ok], est[ok]


def _estimate_figure(out: Outcome, scenario: str, name: str, title: str, *, bounds=None,
                     bounds_label: str = "", note: str = "", xlabel="t [steps]"):
    """Paper layout of seed 000 Fig. 1–3: the signal and its estimate, then the error
    ê = estimate − signal on the signal's own scale (so "practically zero" is seen as
    the paper shows it) with max|ê| written on the panel."""
    plt = _plt()
    res = out.sims[scenario]
    delay = int(out.observer.delays.get(f"{name}_hat", 0))
    t, true, est = _aligned(res, name, delay)
    unit = _unit(res, name)
    sym = SIGNAL_TEX.get(name, name)
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.6), height_ratios=[3, 2])
    a.plot(res["t"], res[name], color="k", lw=2.2, label=rf"${sym}(t)$ (true)")
    a.plot(t, est, color="tab:red", ls="--", lw=1.4, label=rf"$\hat{{{sym}}}(t)$ (estimate)")
    lo = min(np.min(res[name]), bounds[0] if bounds else 0)
    hi = max(np.max(res[name]), bounds[1] if bounds else 0)
    if bounds:
        for v in bounds:
            a.axhline(v, color="0.45", ls=":", lw=1.0)
        a.plot([], [], color="0.45", ls=":", label=bounds_label or f"bounds ±{bounds[1]:g}")
    span = hi - lo
    a.set_ylim(lo - 0.08 * span, hi + 0.42 * span)  # room for the legend above the data
    a.set_ylabel(rf"${sym}$" + _br(unit))
    a.set_title(title)
    a.legend(loc="upper left", ncols=2)
    err = est - true
    span = 1.1 * max(np.max(np.abs(res[name])), 1e-12)
    b.plot(t, err, color="tab:blue", lw=1.4, label=rf"$e_{{{sym}}} = \hat{{{sym}}} - {sym}$")
    b.axhline(0, color="k", lw=0.6)
    emax = float(np.max(np.abs(err)))
    if emax <= span:
        b.set_ylim(-span, span)
    b.set_ylabel(rf"$e_{{{sym}}}$" + _br(unit))
    b.set_xlabel(xlabel)
    b.legend(loc="lower left")
    txt = rf"max $|e_{{{sym}}}|$ = {_sci(emax)}{_sp(unit)}"
    if emax < 1e-9:
        txt += " — zero to floating-point rounding (exact estimator)"
    if note:
        txt += "\n" + note
    _box(b, txt, "upper left")
    return fig, emax


_DB = r"declared bounds $\underline{d} = -0.4$, $\overline{d} = 0.4$ (d may leave them)"


def fig_000_1(outs, path):
    o = outs["drive_d"]
    fig, e = _estimate_figure(o, "electric_drive_fig1", "d",
                              "Seed 000, Fig. 1: fault d of the electric drive and its estimate (k = 1)",
                              bounds=(-0.4, 0.4), bounds_label=_DB, note="d̂(t) is produced at step t + 1")
    u = _unit(o.sims["electric_drive_fig1"], "d")
    return fig, f"Seed 000 Fig. 1 — d(t) = 0.3 sin(t/2) for t ≤ 20, then 1 (outside the declared bounds ±0.4); estimate d̂ and error e_d = d̂ − d, max|e_d| = {e:.1e}{_sp(u)}."


def fig_000_2(outs, path):
    o = outs["drive_d"]
    fig, e = _estimate_figure(o, "electric_drive_fig2", "d",
                              "Seed 000, Fig. 2: fault d (random after t = 20) and its estimate (k = 1)",
                              bounds=(-0.4, 0.4), bounds_label=_DB, note="d̂(t) is produced at step t + 1")
    u = _unit(o.sims["electric_drive_fig2"], "d")
    return fig, f"Seed 000 Fig. 2 — d(t) = 0.3 sin(t/2) for t ≤ 20, then uniform in [−0.5, 0.5]; error max|e_d| = {e:.1e}{_sp(u)}."


def fig_000_3(outs, path):
    o = outs["drive_rho"]
    fig, e = _estimate_figure(o, "electric_drive_rho_fig3", "rho",
                              "Seed 000, Fig. 3: disturbance ρ and its estimate (k = 2, mismatched)",
                              bounds=(-0.2, 0.2),
                              bounds_label="ρ* = ±0.2 of the interval copies (ρ may leave it)",
                              note="ρ̂(t) is produced at step t + 2")
    u = _unit(o.sims["electric_drive_rho_fig3"], "rho")
    return fig, f"Seed 000 Fig. 3 — ρ(t) = 0.3 sin(t/2) for t ≤ 40, then 1; no noise; error max|e_ρ| = {e:.1e}{_sp(u)}."


def fig_000_4(outs, path):
    """Noisy case: ρ, ρ̂ and e_ρ, then |e_ρ| beside the noise-free case on a log axis."""
    plt = _plt()
    o = outs["drive_rho"]
    res4, res3 = o.sims["electric_drive_rho_fig4"], o.sims["electric_drive_rho_fig3"]
    t, true, est = _aligned(res4, "rho", 2)
    _, true3, est3 = _aligned(res3, "rho", 2)
    u = _unit(res4, "rho")
    fig, (a, b, c) = plt.subplots(3, 1, sharex=True, figsize=(8, 7.6), height_ratios=[3, 2, 2])
    a.plot(t, est, color="tab:red", lw=1.0, label=r"$\hat{\rho}(t)$ (estimate, noisy outputs)")
    a.plot(res4["t"], res4["rho"], color="k", lw=1.8, label=r"$\rho(t)$ (true)")
    a.set_ylabel(r"$\rho$" + _br(u))
    a.set_title("Seed 000, Fig. 4: ρ estimated from outputs with noise |w| ≤ 0.01 (k = 2)")
    a.legend(loc="upper left", ncols=2)
    lim = 1.1 * np.max(np.abs(est))
    a.set_ylim(-lim, 1.35 * lim)
    _box(a, "ρ itself (0.3 sin(t/2), then 1) is the\nflat black line at this scale", "upper right")
    err = est - true
    b.plot(t, err, color="tab:blue", lw=1.0, label=r"$e_\rho = \hat{\rho} - \rho$")
    b.axhline(0, color="k", lw=0.6)
    b.set_ylabel(r"$e_\rho$" + _br(u))
    b.legend(loc="upper left")
    m_ = np.max(np.abs(err))
    b.set_ylim(-1.1 * m_, 1.55 * m_)
    _box(b, rf"max $|e_\rho|$ = {np.max(np.abs(err)):.3g}{_sp(u)}, RMS {np.sqrt(np.mean(err ** 2)):.3g}",
         "upper right")
    e3 = np.abs(est3 - true3)
    floor = 1e-17
    c.semilogy(t, np.maximum(np.abs(err), floor), color="tab:blue", lw=1.0,
               label="with noise (Fig. 4)")
    c.semilogy(t, np.maximum(e3, floor), color="tab:green", lw=1.2,
               label="without noise (Fig. 3)")
    c.set_ylabel(r"$|e_\rho|$" + _br(u))
    c.set_xlabel("t [steps]")
    c.legend(loc="upper right", ncols=2)
    c.set_ylim(1e-17, 1e6)
    c.text(0.01, 0.5, "the estimate inverts the outputs exactly: the noise w(t), w(t+1), w(t+2)\n"
           "passes with a gain of ≈ 10⁴ (k1 = 1/500, k4 = −1/2500); without noise: rounding only",
           transform=c.transAxes, va="center", fontsize=9,
           bbox=dict(boxstyle="round,pad=0.3", fc="white", ec="0.6", alpha=0.92))
    return fig, (f"Seed 000 Fig. 4 — as Fig. 3 with measurement noise w1, w2 ~ U[−0.01, 0.01]: the"
                 f" estimate is visibly worse (max|e_ρ| = {np.max(np.abs(err)):.3g}{_sp(u)} against"
                 f" {np.max(e3):.1e} without noise, bottom panel).")


def fig_000_s8(outs, path):
    o = outs["drive_d_jordan"]
    fig, e = _estimate_figure(o, "electric_drive_fig1", "d",
                              "Seed 000 §8: Jordan-form estimator of d (λ = 1/2), Fig. 1 scenario",
                              bounds=(-0.4, 0.4), bounds_label=_DB, note="d̂(t) is produced at step t + 1")
    u = _unit(o.sims["electric_drive_fig1"], "d")
    return fig, f"Seed 000 §8 — the Jordan-form (λ-model) estimator on Fig. 1's scenario; max|e_d| = {e:.1e}{_sp(u)}."


def fig_drive_residual(outs, path):
    plt = _plt()
    o = outs["drive_diag"]
    res = o.sims["electric_drive_diagnostic"]
    t = res["t"]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.2))
    ud, ur = _br(_unit(res, "d")), _br(_unit(res, "rho"))
    a.plot(t, res["d"], color="tab:red", lw=1.6, label=f"fault d{ud}")
    a.plot(t, res["rho"], color="0.5", lw=1.0, label=f"load disturbance ρ{ur} (decoupled)")
    a.set_ylabel(f"d{ud}, ρ{ur}")
    a.set_title("Residual generator for the electric drive (Jordan form, λ = 1/2)")
    a.legend(loc="upper left")
    r = res["r"]
    b.plot(t, r, color="tab:purple", lw=1.5, label=f"residual r = {_rstar_text(o)} − x*")
    b.axhline(0, color="k", lw=0.6)
    b.axvline(50, color="tab:red", ls=":", lw=1.0)
    b.set_ylabel(r"residual $r = R^* y - x^*$" + _br(_unit(res, "r")))
    b.set_xlabel("t [steps]")
    b.legend(loc="upper left")
    before = float(np.max(np.abs(r[t < 50])))
    after = float(np.min(np.abs(r[t >= 52])))
    _box(b, f"no fault (t < 50): max|r| = {_sci(before)} despite ρ\nfault (t ≥ 52): |r| ≥ {after:.3g}",
         "lower right")
    R_ = o.design.matrices.R_star
    return fig, (f"Residual r = R* y − x* (R* = {list(R_)}) of the electric drive: zero to rounding"
                 f" ({before:.1e}) while only the disturbance ρ acts, nonzero once the fault d = 0.2"
                 f" appears at t = 50.")


def _rstar_text(o) -> str:
    R_ = list(o.design.matrices.R_star)
    terms = []
    for i, c in enumerate(R_, 1):
        if c == 0:
            continue
        c = sp.sympify(c)
        coef = "" if c == 1 else ("−" if c == -1 else f"{c}·")
        terms.append(f"{coef}y{i}")
    return " + ".join(terms).replace("+ −", "− ")


def _interval_panel(ax, res, name, *, t_max=None, unit=None, label_true=None, colors=("tab:blue", "tab:orange")):
    t = np.asarray(res["t"])
    sel = slice(None) if t_max is None else (t <= t_max)
    lo, hi, z = (np.asarray(res[c])[sel] for c in (f"{name}_lower", f"{name}_upper", name))
    ts = t[sel]
    sym = SIGNAL_TEX.get(name, name)
    letter, _, sub = sym.partition("_")
    sub = f"_{sub}" if sub else ""
    ax.fill_between(ts, lo, hi, color=colors[0], alpha=0.15, lw=0)
    ax.plot(ts, hi, color=colors[1], lw=1.2, label=rf"upper bound $\overline{{{letter}}}{sub}$")
    ax.plot(ts, lo, color=colors[0], lw=1.2, label=rf"lower bound $\underline{{{letter}}}{sub}$")
    ax.plot(ts, z, color="k", lw=1.4, label=label_true or rf"${sym}$ (true)")
    ax.set_ylabel(rf"${sym}$" + _br(_unit(res, name) if unit is None else unit))
    full_lo, full_hi, full_z = (np.asarray(res[c]) for c in (f"{name}_lower", f"{name}_upper", name))
    viol = int(np.sum((full_z < full_lo - 1e-9) | (full_z > full_hi + 1e-9)))
    return viol


def _zoom(ax, res, name, t0, t1, rect, colors=("tab:blue", "tab:orange")):
    """An inset magnifying [t0, t1], where the bounds are too close to tell apart."""
    t = np.asarray(res["t"])
    sel = (t >= t0) & (t <= t1)
    lo, hi, z = (np.asarray(res[c])[sel] for c in (f"{name}_lower", f"{name}_upper", name))
    ins = ax.inset_axes(rect)
    ins.fill_between(t[sel], lo, hi, color=colors[0], alpha=0.15, lw=0)
    ins.plot(t[sel], hi, color=colors[1], lw=1.1)
    ins.plot(t[sel], lo, color=colors[0], lw=1.1)
    ins.plot(t[sel], z, color="k", lw=1.2)
    pad = 0.15 * (np.max(hi) - np.min(lo))
    ins.set_ylim(np.min(lo) - pad, np.max(hi) + pad)
    ins.set_xlim(t0, t1)
    ins.tick_params(labelsize=7)
    ins.set_title(f"zoom, t ∈ [{t0:g}, {t1:g}] s", fontsize=8, pad=2)
    ins.grid(alpha=0.3)
    ax.indicate_inset_zoom(ins, edgecolor="0.4")
    return ins


def fig_drive_interval(outs, path):
    plt = _plt()
    o = outs["drive_interval"]
    res = o.sims["electric_drive_interval"]
    fig, ax = plt.subplots(figsize=(8, 4.2))
    viol = _interval_panel(ax, res, "x2", t_max=300)
    ax.set_xlabel("t [steps]")
    ax.set_title("Electric drive: interval observer for the motor speed x2 (λ = 4/5)")
    ax.legend(loc="upper right", ncols=3)
    ax.set_ylim(-1.1, 1.3)
    n = len(res["t"])
    w = np.asarray(res["x2_upper"]) - np.asarray(res["x2_lower"])
    _box(ax, f"first 300 of {n} steps shown; x2 inside the bounds at all {n} steps"
             f" ({viol} violations)\nwidth → {w[-1]:.3g}{_sp(_unit(res, 'x2'))} = 2·0.05/(1 − 4/5): set by |ρ| ≤ 0.05;"
             " the fault d does not enter (Φ = (0, 1, 0))", "lower right")
    return fig, (f"Interval observer of the electric drive's speed x2 with ρ, d and noise random within"
                 f" their bounds: the bounds enclose x2 at every step ({viol} violations in {n}).")


def fig_002_2(outs, path):
    plt = _plt()
    o = outs["tank_vs"]
    res = o.sims["three_tank_fig2"]
    t, x1, z = res["t"], res["x1"], res["x1_hat"]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.8), height_ratios=[3, 2])
    a.plot(t, x1, color="k", lw=1.8, label=r"$x_1(t)$ (true level, tank 1)")
    a.plot(t, z, color="tab:red", ls="--", lw=1.5, label=r"$z(t) = x^*(t)$ (virtual sensor)")
    for tt, what, ha in ((1, r"$u_1 = 1$", "left"), (5, r"$u_2 = 0.5$", "right"),
                         (6, r"$\rho_1 = -0.3$", "left"), (10, r"$\rho_2 = -0.4$", "left")):
        a.axvline(tt, color="0.55", ls=":", lw=1.0)
        a.text(tt + (0.12 if ha == "left" else -0.12), 0.97, what, fontsize=8, color="0.3", ha=ha,
               va="top", transform=a.get_xaxis_transform())
    a.set_ylim(-0.15, 1.15 * np.max(x1) + 0.1)
    a.set_ylabel(r"level $x_1$" + _br(_unit(res, "x1")))
    a.set_title("Seed 002, Fig. 2: virtual sensor $\\dot{x}^* = u_1 - \\sqrt{x^* - y_1}$ for $x_1$ (λ = −1, k = 1)")
    a.legend(loc="lower right")
    e = np.abs(z - x1)
    b.semilogy(t, np.maximum(e, 1e-17), color="tab:blue", lw=1.4, label=r"$|z - x_1|$")
    for tt in (1, 5, 6, 10):
        b.axvline(tt, color="0.55", ls=":", lw=1.0)
    b.set_ylabel(r"$|z - x_1|$" + _br(_unit(res, "x1")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    _box(b, f"sensor starts at x*(0) = 0.5, x1(0) = 0: the error decays ({e[0]:.2g} → {e[-1]:.1e}{_sp(_unit(res, 'x1'))} at t = 20)\n"
            "and does not react to the steps of ρ1, ρ2 (decoupled)", "lower left")
    return fig, (f"Seed 002 Fig. 2 — nonlinear three-tank, u1 = 1 (t > 1), u2 = 0.5 (t > 5), ρ1 = −0.3"
                 f" (t > 6), ρ2 = −0.4 (t > 10), no noise: x1 and the virtual sensor z; the error decays"
                 f" from 0.5 to {e[-1]:.1e} m, unaffected by ρ1, ρ2.")


def fig_002_3(outs, path):
    plt = _plt()
    cases = [("tank_interval", "three_tank_interval", "0.01"),
             ("tank_interval_w05", "three_tank_interval_w05", "0.05")]
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 8.2), height_ratios=[3, 3, 2],
                             gridspec_kw=dict(hspace=0.16))
    total = []
    for ax, (key, sc, w) in zip(axes[:2], cases):
        res = outs[key].sims[sc]
        v = _interval_panel(ax, res, "x1")
        total.append(v)
        ax.set_title(f"|w| ≤ {w}" if ax is not axes[0] else
                     f"Seed 002, Fig. 3: interval observer for $x_1$ of the nonlinear three-tank — |w| ≤ {w}",
                     fontsize=11 if ax is axes[0] else 10)
        if ax is not axes[0]:
            ax.set_title(f"same, with noise |w| ≤ {w}")
        ax.legend(loc="upper right", ncols=3)
        ax.set_ylim(0.9, 2.3)
        _box(ax, f"x1 inside the bounds at all {len(res['t'])} steps ({v} violations)", "lower left")
        _zoom(ax, res, "x1", 14, 16, [0.52, 0.47, 0.26, 0.32])
    c = axes[2]
    for (key, sc, w), col in zip(cases, ("tab:blue", "tab:red")):
        res = outs[key].sims[sc]
        width = np.asarray(res["x1_upper"]) - np.asarray(res["x1_lower"])
        c.semilogy(res["t"], width, color=col, lw=1.4, label=f"|w| ≤ {w}: width → {width[-1]:.3g}{_sp(_unit(res, 'x1'))}")
    c.set_ylabel("width" + _br(_unit(res, "x1")))
    c.set_xlabel("t [s]")
    c.legend(loc="upper right")
    return fig, (f"Seed 002 Fig. 3 — interval bounds of x1 (u1 = 0.5, u2 = 0.2, ρ1, ρ2 random in ±0.5) for"
                 f" two noise levels, |w| ≤ 0.01 and 0.05: the true x1 stays inside"
                 f" ({sum(total)} violations); more noise, wider bounds (bottom).")


def fig_001_2(outs, path):
    plt = _plt()
    res2 = outs["lin_interval_m2"].sims["three_tank_linear_interval"]
    res1 = outs["lin_interval_m1"].sims["three_tank_linear_interval"]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.0), height_ratios=[3, 2])
    v2 = _interval_panel(a, res2, "x1")
    v1 = int(np.sum((res1["x1"] < res1["x1_lower"] - 1e-9) | (res1["x1"] > res1["x1_upper"] + 1e-9)))
    a.set_title("Seed 001, Fig. 2: interval observer (7.2) for $x_1$ of the linear three-tank (method 2, k = 1)")
    a.legend(loc="lower right")
    _box(a, f"x1 inside at all {len(res2['t'])} steps ({v2} violations)", "upper left")
    _zoom(a, res2, "x1", 14, 16, [0.33, 0.08, 0.3, 0.36])
    for res, lab, col in ((res2, "method 2 (Jordan, k = 1)", "tab:blue"),
                          (res1, "method 1 (canonical → diagonal, k = 2)", "tab:green")):
        w = np.asarray(res["x1_upper"]) - np.asarray(res["x1_lower"])
        b.semilogy(res["t"], w, color=col, lw=1.4, label=f"{lab}: width → {w[-1]:.3g}{_sp(_unit(res, 'x1'))}")
    b.set_ylabel(r"width $\overline{x}_1 - \underline{x}_1$" + _br(_unit(res2, "x1")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    return fig, (f"Seed 001 Fig. 2 — linear three-tank, u1 = 1 (t ≥ 1), u2 = 0.5 (t ≥ 5), ρ and noise random"
                 f" in ±0.2, ±0.02: x1 and its bounds (method 2, {v2} violations); method 1 ({v1}"
                 f" violations) converges to the same width 2w* = 0.04{_sp(_unit(res2, 'x1'))} (bottom).")


def fig_lin_virtual(outs, path):
    plt = _plt()
    # drawn wide-to-narrow so that coinciding curves stay visible
    keys = (("lin_vs_plain", "canonical (k = 2, eigenvalues −1, −2)", "tab:red", "-", 5.0, 0.35),
            ("lin_vs_004", "seed 004 variant (k = 2, eigenvalues −1, −2)", "tab:green", "--", 2.4, 0.9),
            ("lin_vs_jordan", "Jordan (k = 1, λ = −1)", "tab:purple", ":", 1.6, 1.0))
    sc = "three_tank_linear_virtual"
    base = outs[keys[0][0]].sims[sc]
    t = base["t"]
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.0), height_ratios=[3, 2])
    a.plot(t, base["x1"], color="k", lw=1.6, label=r"$x_1$ (true)", zorder=5)
    errs = []
    for key, lab, col, ls, lw, al in keys:
        r = outs[key].sims[sc]
        a.plot(t, r["x1_hat"], color=col, ls=ls, lw=lw, alpha=al, label=rf"$\hat{{x}}_1$ {lab}")
        e = np.abs(r["x1_hat"] - r["x1"])
        errs.append(e)
        b.semilogy(t, np.maximum(e, 1e-17), color=col, ls=ls, lw=lw, alpha=al, label=lab)
    for ax in (a, b):
        ax.axvline(10, color="0.55", ls=":", lw=1.0)
    a.text(10.12, 0.97, "ρ = −0.2 from t = 10", fontsize=8, color="0.3", va="top",
           transform=a.get_xaxis_transform())
    a.set_ylabel(r"level $x_1$" + _br(_unit(base, "x1")))
    a.set_title("Linear three-tank: virtual sensors for $x_1$ (seeds 001, 004), started at $x^*(0) = 0$")
    a.legend(loc="lower right")
    b.set_ylabel(r"$|\hat{x}_1 - x_1|$" + _br(_unit(base, "x1")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    spread = max(float(np.max(np.abs(errs[i] - errs[0]))) for i in range(len(errs)))
    _box(b, f"the three errors coincide (max difference {_sci(spread)}{_sp(_unit(base, 'x1'))}): each is −x1(0)·e^(−t);\n"
            "no reaction to the disturbance step at t = 10 (decoupled)", "lower left")
    return fig, ("Linear three-tank, no noise, inputs as in seed 002 Fig. 2 and a disturbance step ρ = −0.2"
                 " at t = 10: three virtual sensors for x1 (started at 0) converge exponentially — their"
                 " errors coincide, −x1(0)·e^(−t) — and are blind to ρ.")


def fig_sliding(outs, path):
    plt = _plt()
    o = outs["sliding"]
    res = o.sims["sliding_example"]
    t, d, dh = res["t"], res["d"], res["d_hat"]
    k1 = float(o.observer.parameters[sp.Symbol("k_sm")])
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.8), height_ratios=[3, 2])
    a.plot(t, d, color="k", lw=2.2, label="d (true)")
    a.plot(t, dh, color="tab:red", ls="--", lw=1.3, label=r"$\hat{d}$ (sliding-mode estimate)")
    a.set_ylabel("d" + _br(_unit(res, "d")))
    a.set_ylim(-1.3, k1 + 0.9)
    a.set_title(f"Sliding-mode estimator of the fault d (sliding example, λ = −1, k1 = {k1:.3g})")
    a.legend(loc="upper right")
    err = np.abs(dh - d)
    reach = float(t[np.argmax(err < 0.01)]) if np.any(err < 0.01) else float("nan")
    a.annotate(f"reaching phase: d̂ saturated at k1 = {k1:.3g} until t ≈ {reach:.2f} s", xy=(reach / 2, k1),
               xytext=(1.0, k1 + 0.45), fontsize=8.5, arrowprops=dict(arrowstyle="->", color="0.3"))
    b.semilogy(t, np.maximum(err, 1e-12), color="tab:blue", lw=1.2, label=r"$|\hat{d} - d|$")
    b.set_ylabel(r"$|\hat{d} - d|$" + _br(_unit(res, "d")))
    b.set_xlabel("t [s]")
    b.legend(loc="upper right")
    late = t >= 1
    b.text(0.1, 0.55, f"t ≥ 1 s: max|d̂ − d| = {np.max(err[late]):.2g}{_sp(_unit(res, 'd'))}\n(boundary layer ε = 0.001:"
           " not an ideal sliding mode)", transform=b.transAxes, fontsize=9, va="center",
           bbox=dict(boxstyle="round,pad=0.3", fc="white", ec="0.6", alpha=0.92))
    return fig, (f"Sliding-mode estimator (this project's example): after a reaching phase of"
                 f" {reach:.2f} s the estimate follows d with max error {np.max(err[late]):.2g}{_sp(_unit(res, 'd'))}"
                 " while the disturbance ρ = 0.4 sin 3t acts (decoupled).")


#: (file name, cases it needs, section it belongs to, function)
FIGURES = (
    ("000_fig1.png", ("drive_d",), "drive_d", fig_000_1),
    ("000_fig2.png", ("drive_d",), "drive_d", fig_000_2),
    ("000_fig3.png", ("drive_rho",), "drive_rho", fig_000_3),
    ("000_fig4.png", ("drive_rho",), "drive_rho", fig_000_4),
    ("000_s8_jordan.png", ("drive_d_jordan",), "drive_d_jordan", fig_000_s8),
    ("drive_residual.png", ("drive_diag",), "drive_diag", fig_drive_residual),
    ("drive_interval_x2.png", ("drive_interval",), "drive_interval", fig_drive_interval),
    ("002_fig2.png", ("tank_vs",), "tank_vs", fig_002_2),
    ("002_fig3.png", ("tank_interval", "tank_interval_w05"), "tank_interval", fig_002_3),
    ("linear_tank_virtual_sensors.png", ("lin_vs_plain", "lin_vs_004", "lin_vs_jordan"),
     "lin_vs_plain", fig_lin_virtual),
    ("001_fig2.png", ("lin_interval_m2", "lin_interval_m1"), "lin_interval_m2", fig_001_2),
    ("sliding.png", ("sliding",), "sliding", fig_sliding),
)


# ---------------------------------------------------------------- report
def _model_section(model) -> str:
    from ..reporting import expr_latex, latex_block, symbol_latex
    lines = []
    for x, f in zip(model.states, model.dynamics):
        lhs = rf"{symbol_latex(x.name)}(t+1)" if model.time == "discrete" else rf"\dot{{{symbol_latex(x.name)}}}"
        lines.append(f"{lhs} &= {expr_latex(f)}")
    for i, h in enumerate(model.outputs, 1):
        lines.append(f"y_{{{i}}} &= {expr_latex(h)}")
    out = [f"### Model `{model.name}` ({model.time} time)", ""]
    if model.source:
        out += [f"From `{Path(model.source).name}`.", ""]
    out += [latex_block(lines), ""]
    if model.parameters:
        out += ["Parameters: " + ", ".join(
            f"${symbol_latex(p.name)} = {sp.latex(v)}$" for p, v in model.parameters.items()
            if v is not None) + ".", ""]
    if model.bounds:
        out += ["Declared bounds: " + ", ".join(
            rf"${symbol_latex(s.name)} \in [{sp.latex(sp.sympify(lo))}, {sp.latex(sp.sympify(hi))}]$"
            for s, (lo, hi) in model.bounds.items()) + ".", ""]
    if model.domain:
        out += ["Domain: " + ", ".join(f"${sp.latex(r)}$" for r in model.domain) + ".", ""]
    out += ["<details><summary>Structure (as <code>observer-cad show</code> prints it)</summary>", "",
            "```text", format_structure(extract_structure(model)), "```", "", "</details>", ""]
    return "\n".join(out)


def _units_text(models: dict) -> str:
    """Units as the model files declare them (``units=``); models without any are named."""
    from ..reporting import md_escape
    with_units, without = [], []
    for name, m in models.items():
        if m.units:
            with_units.append(md_escape(f"{name}: " + ", ".join(f"{s} {u}" for s, u in m.units.items())))
        else:
            without.append(md_escape(name))
    text = "Units, as the model files declare them (`units=`): " + ("; ".join(with_units) or "none") + "."
    if without:
        text += (" No units for " + ", ".join(without) + ": their model files declare none (the"
                 " three-tank papers set every coefficient to 1 and give no units), so their axes"
                 " carry none.")
    return text



def _diag_summary(diag: DiagOutcome) -> str:
    """One bullet for the report's introduction."""
    from ..reporting import md_escape
    if diag.error is not None and diag.analysis is None:
        return f"- [diagnosability](#diagnosability): ❌ {md_escape(diag.error)}"
    a = diag.analysis
    text = (f"- [diagnosability](#diagnosability) (issue 12): analysis of `{a.model_name}` —"
            f" {_count([r.detectable for r in a.fault_results])} faults detectable,"
            f" {_count([p.isolable for p in a.pairs])} pairs isolable")
    if diag.bank is not None:
        b = diag.bank
        text += (f"; residual bank for `{b.model_name}` — {len(b.designs)} residuals"
                 f" ({md_escape(b.scheme)}), {_count([ok for _, ok in b.isolable])} pairs isolated,"
                 f" {'all certified' if b.certified else 'NOT all certified'}")
    if diag.error is not None:
        text += f"; ❌ {md_escape(diag.error)}"
    return text


def _diag_section(diag: DiagOutcome) -> str:
    """The report's "Diagnosability" section: the analysis as tables, then the bank, its
    structure matrix, the observer, the figure and the full text outputs."""
    from ..reporting import (analysis_markdown, bank_markdown, format_analysis, format_bank,
                             md_escape)
    ex = diag.example
    fmt = lambda v: f"{v * 1e3:.0f} ms" if v < 1 else f"{v:.2f} s"  # noqa: E731
    out = ['<a id="diagnosability"></a>', "## Diagnosability", "",
           "Before designing residual generators one by one: which faults can the sensors"
           " detect once the disturbances are decoupled, which pairs of faults can be told"
           " apart, and what bank of residual generators does it? (`observer-cad analyze`,"
           " described in `docs/analyze.md` of the repository, and `observer-cad design"
           " --observer diagnostic --isolate`.)", ""]
    if diag.analysis is not None:
        a = diag.analysis
        out += [f"### Analysis of `{a.model_name}`", "",
                f"*This project's example on the three-tank of seed 001 §7* — model"
                f" `{ex.analysis_model}`: a fault in each tank, the levels x2 and x3 measured,"
                f" the disturbance ρ beside the third tank (equations under"
                f" [Models](#models)). Exact arithmetic; analysed in {fmt(diag.analysis_time)}.", "",
                "Reproduce:", "", "```sh", ex.analysis_cli, "```", "",
                analysis_markdown(a),
                ("**Reading.** " + md_escape(ex.analysis_note)) if ex.analysis_note else "", "",
                f"Exported: [JSON](designs/{ANALYSIS_JSON}) (what `analyze --json` prints).", "",
                "<details><summary>Full text output (as <code>observer-cad analyze</code> prints it)"
                "</summary>", "", "```text", format_analysis(a), "```", "", "</details>", ""]
    if diag.bank is not None:
        b, ba = diag.bank, diag.bank_analysis
        out += [f"### Isolating residual bank for `{b.model_name}`", "",
                f"*This project's example on the three-tank of seed 001 §7* — model"
                f" `{ex.bank_model}`. {md_escape(ex.note)}", "",
                "Reproduce:", "", "```sh", ex.bank_cli, "```", ""]
        if ba is not None:
            out += [f"`analyze` on this model: {_count(ba.detectable.values())} faults detectable"
                    f" (minimal orders {', '.join(f'{f} k = {k}' for f, k in ba.min_order.items())}),"
                    f" {_count([p.isolable for p in ba.pairs])} pairs isolable,"
                    f" {len(ba.structure)} achievable structure rows.", ""]
        out += [bank_markdown(b, diag.observer)]
        if diag.sim is not None:
            out += [f"Scenario: `models/scenarios/{ex.scenario}.json`. Simulated with:"
                    f" {md_escape(diag.engine)}.", ""]
        out += ["**Timings**: " + ", ".join(f"{k} {fmt(v)}" for k, v in diag.timings.items()), ""]
        if diag.figure is not None:
            name, cap = diag.figure
            out += [f"![{md_escape(cap)}](figures/{name})", "", f"*{md_escape(cap)}*", ""]
        out += [f"Exported: [JSON](designs/{BANK_JSON}) (what `design --isolate --json` prints).", "",
                "<details><summary>Full text output (as <code>observer-cad design --isolate</code>"
                " prints it)</summary>", "", "```text", format_bank(b), "```", "", "</details>", ""]
    if diag.error is not None:
        out += [f"**FAILED** ({md_escape(diag.error)})", ""]
    return "\n".join(out)


def _report(outcomes, figs, out_dir: Path, totals: dict, engine: _Engine, models: dict,
            diag: DiagOutcome | None = None, evaluation=None) -> str:
    from ..reporting import design_section, md_escape, render_report
    ok = [o for o in outcomes if o.error is None]
    intro = [
        "Generated by `observer-cad demo`: every observer the seed papers build for the electric"
        " drive (seed 000) and the three-tank (seeds 001, 002, 004), plus the sliding-mode example —"
        " designed with every condition checked exactly, certified, compiled together with the"
        " plant into one C trajectory function, simulated on the papers' scenarios, and plotted.",
        "",
        f"- designs: {len(ok)} of {len(outcomes)} built, "
        f"{sum(1 for o in ok if o.design.certificate.passed)} certified",
        f"- simulation engine: {'compiled C (observer_cad.codegen.CompiledSimulator)' if engine.reason is None else 'reference simulator (numpy) — ' + md_escape(engine.reason)}",
        f"- compile cache: `{_cache_dir()}`",
        f"- Python {platform.python_version()}, {platform.machine()}, {os.cpu_count()} CPU(s)",
        "- time: " + ", ".join(f"{k} {v:.2f} s" for k, v in totals.items()),
        *([_diag_summary(diag)] if diag is not None else []),
        *([evaluation_summary(evaluation)] if evaluation is not None else []),
        "",
        "Conventions: discrete-time plots use t in steps; continuous-time plots t in s. " + _units_text(models),
        "",
        "## Summary",
        "",
        "| # | design | paper | k | certified | design | observer | compile | simulate | engine |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    fmt = lambda v: "—" if v is None else (f"{v * 1e3:.0f} ms" if v < 1 else f"{v:.2f} s")  # noqa: E731
    for i, o in enumerate(outcomes, 1):
        c = o.case
        if o.error:
            intro.append(f"| {i} | [{md_escape(c.heading)}](#{c.key}) | {md_escape(c.paper)} | — |"
                         f" ❌ {md_escape(o.error)} | | | | | |")
            continue
        tm = o.timings
        intro.append(f"| {i} | [{md_escape(c.heading)}](#{c.key}) | {md_escape(c.paper)} | {o.design.k} |"
                     f" {'✅' if o.design.certificate.passed else '❌'} | {fmt(tm.get('design'))} |"
                     f" {fmt(tm.get('observer'))} | {fmt(tm.get('compile'))} | {fmt(tm.get('simulate'))} |"
                     f" {md_escape(o.engine)} |")
    intro += ["", "## Figures", ""]
    for name, caption, key in figs:
        intro.append(f"- [`figures/{name}`](figures/{name}) — {md_escape(caption)}")
    if diag is not None and diag.figure is not None:
        name, caption = diag.figure
        intro.append(f"- [`figures/{name}`](figures/{name}) — {md_escape(caption)}")
    for name, caption in (evaluation.figures if evaluation is not None else ()):
        intro.append(f"- [`figures/{name}`](figures/{name}) — {md_escape(caption)}")
    intro += ["", '<a id="models"></a>', "## Models", ""]
    for m in models.values():
        intro.append(_model_section(m))
    sections = ["## Designs", ""]
    for o in outcomes:
        c = o.case
        if o.error:
            sections.append(f'<a id="{c.key}"></a>\n### {md_escape(c.heading)}\n\n**FAILED**: {md_escape(o.error)}\n')
            continue
        scen = ", ".join(f"`models/scenarios/{r.scenario}.json`" +
                         (" (observer started at x*(0) = 0)" if r.observer_start == "zero" else "")
                         for r in c.runs)
        notes = [md_escape(c.note)] if c.note else []
        notes.append(f"Scenarios: {scen}. Simulated with: {md_escape(o.engine)}.")
        notes.append(f"Exports: [JSON](designs/{c.key}.json), [LaTeX](designs/{c.key}.tex)"
                     " (`observer_cad.reporting`).")
        sections.append(design_section(
            anchor=c.key, heading=c.heading, paper=c.paper, command=c.cli, model_name=o.model.name,
            design=o.design, observer=o.observer, timings=o.timings,
            figures=[(f"figures/{n}", cap) for n, cap, k in figs if k == c.key],
            notes=notes, full_text=o.full_text, level=3))
    if diag is not None:
        sections.append(_diag_section(diag))
    if evaluation is not None:
        sections.append(evaluation_section(evaluation))
    return render_report("observer-cad demo: the seed papers' observers", intro, sections)


def _cache_dir() -> str:
    try:
        from ..codegen import cache_dir
        return str(cache_dir())
    except Exception:  # noqa: BLE001 - casadi missing: the cache is irrelevant
        return "(none)"


def _figures(by_key: dict, fig_dir: Path, log, failed: list) -> list:
    """Every figure of :data:`FIGURES` whose designs ran; (name, caption, section).
    Figures that raise are named in ``failed``."""
    from ..reporting import save_figure
    plt = _plt()
    figs = []
    with plt.rc_context(STYLE):
        for name, needs, section, fn in FIGURES:
            if not all(k in by_key for k in needs):
                log(f"[figure] {name}: skipped (a design it needs did not run)")
                continue
            t1 = time.perf_counter()
            try:
                fig, caption = fn(by_key, fig_dir / name)
                save_figure(fig, fig_dir / name)
            except Exception as exc:  # noqa: BLE001 - report it, keep the other figures
                failed.append(name)
                plt.close("all")
                log(f"[figure] {name}: FAILED ({type(exc).__name__}: {exc})")
                continue
            figs.append((name, caption, section))
            log(f"[figure] {fig_dir / name}  ({time.perf_counter() - t1:.2f} s)")
    return figs


# ---------------------------------------------------------------- entry point
def run_demo(models_dir: Path = EXAMPLES_DIR, out_dir: Path = Path("out"), *,
             compile: bool = True, stream=None) -> int:
    """Design, compile, simulate, plot and report every case of :data:`CASES` into
    ``out_dir``, reading the models and scenarios from ``models_dir`` (default: the
    examples shipped with the package, :data:`EXAMPLES_DIR`); returns 0 when every
    design was built and certified, else 1."""
    t_start = time.perf_counter()
    log = _Log(stream if stream is not None else sys.stdout)
    models_dir, out_dir = Path(models_dir), Path(out_dir)
    if not (models_dir / "scenarios").is_dir():
        raise UsageError(f"{models_dir}: the example models are not there (a broken install "
                         "or checkout: reinstall observer_cad)")
    fig_dir, des_dir = out_dir / "figures", out_dir / "designs"
    for d in (out_dir, fig_dir, des_dir):
        try:
            d.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"{d}: cannot create the output directory: {exc.strerror}") from None
    n = len(CASES)
    log(f"observer-cad demo: {n} designs from seed papers 000, 001, 002, 004"
        + (", a diagnosability analysis and an isolating residual bank (issue 12)"
           if DIAGNOSABILITY is not None else "") + f" → {out_dir}/report.md")
    engine = _Engine(compile, log)
    models: dict = {}
    outcomes = [_run_case(i, n, c, models_dir, models, engine, log) for i, c in enumerate(CASES, 1)]
    t_cases = time.perf_counter() - t_start
    t0 = time.perf_counter()
    diag = (_run_diagnosability(DIAGNOSABILITY, models_dir, engine, log)
            if DIAGNOSABILITY is not None else None)
    t_diag = time.perf_counter() - t0
    t0 = time.perf_counter()
    evaluation = run_evaluation(models_dir, fig_dir, log)
    t_eval = time.perf_counter() - t0
    by_key = {o.case.key: o for o in outcomes if o.error is None}

    t0 = time.perf_counter()
    fig_failed: list = []
    figs = _figures(by_key, fig_dir, log, fig_failed)
    if diag is not None:
        _diag_figure(diag, fig_dir, log, fig_failed)
    t_figs = time.perf_counter() - t0

    t0 = time.perf_counter()
    from ..reporting import write_design_json, write_design_latex
    for o in outcomes:
        if o.error is None:
            write_design_json(o.design, des_dir / f"{o.case.key}.json")
            write_design_latex(o.design, des_dir / f"{o.case.key}.tex")
    if diag is not None and diag.analysis is not None:
        atomic_write_text(des_dir / ANALYSIS_JSON, json.dumps(
            diag.analysis.to_json(), indent=2, ensure_ascii=False) + "\n")
    if diag is not None and diag.bank is not None:
        atomic_write_text(des_dir / BANK_JSON, json.dumps(
            diag.bank.to_json(), indent=2, ensure_ascii=False) + "\n")
    used_models = {}
    for o in outcomes:
        if o.model is not None and o.model.name not in used_models and not o.case.bounds:
            used_models[o.model.name] = o.model
    for m in ((diag.analysis_model, diag.bank_model) if diag is not None else ()):
        if m is not None and m.name not in used_models:
            used_models[m.name] = m
    totals = {"designs, compilation and simulation": t_cases}
    if diag is not None:
        totals["diagnosability"] = t_diag
    totals["residual evaluation"] = t_eval
    totals["figures"] = t_figs
    report_path = out_dir / "report.md"
    totals["report"] = time.perf_counter() - t0
    totals["total"] = time.perf_counter() - t_start
    for name in (DRIVE_MODEL, BANK_MODEL, ENSEMBLE_MODEL):
        m = load_model(models_dir / name)
        used_models.setdefault(m.name, m)
    text = _report(outcomes, figs, out_dir, totals, engine, used_models, diag, evaluation)
    atomic_write_text(report_path, text)
    totals["total"] = time.perf_counter() - t_start
    failed = [o for o in outcomes if o.error is not None or not o.design.certificate.passed]
    n_figs = len(figs) + (1 if diag is not None and diag.figure is not None else 0) \
        + len(evaluation.figures)
    log(f"[report] {report_path} ({n_figs} figures, designs as JSON and LaTeX in {des_dir})")
    log(f"{len(outcomes)} designs, all certified." if not failed else
        f"{len(outcomes) - len(failed)} of {len(outcomes)} designs certified.")
    if diag is not None and diag.error is None:
        log(f"diagnosability: {diag.analysis.model_name} analysed; residual bank for"
            f" {diag.bank.model_name} with {len(diag.bank.designs)} residuals, all certified.")
    timed = [o.timings for o in outcomes] + ([diag.timings] if diag is not None else [])
    sim_t = sum(tm.get("simulate", 0) for tm in timed)
    comp_t = sum(tm.get("compile", 0) for tm in timed)
    des_t = sum(tm.get("design", 0) + tm.get("observer", 0) + tm.get("analyze", 0) for tm in timed) \
        + (diag.analysis_time if diag is not None else 0.0)
    log(f"total {totals['total']:.1f} s (design {des_t:.1f} s, compile {comp_t:.1f} s,"
        f" simulate {sim_t:.1f} s, figures {t_figs:.1f} s)"
        + ("" if engine.reason is None else f"; not compiled: {engine.reason}"))
    diag_failed = ["diagnosability"] if diag is not None and diag.error is not None else []
    if evaluation.error is not None:
        diag_failed.append("residual evaluation")
    if failed or fig_failed or diag_failed:
        log(f"FAILED: {', '.join([o.case.key for o in failed] + diag_failed + fig_failed)}")
        return 1
    return 0
