"""Running the demo's design cases: each is designed, certified, built, compiled with
the plant (:class:`Engine`: compiled C, or the reference simulator once compilation is
unavailable) and simulated on its scenarios, with its progress logged; a failure is
recorded in its :class:`Outcome`, never raised (one broken case must not stop the demo).
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from ..errors import ObserverCadError, describe_failure
from ..model import extract_structure, load_model
from ..reporting import format_design, format_observer, format_structure
from ..synthesis import design as make_design
from ._cases import Case

__all__ = ["Outcome", "Log", "Engine", "run_case", "short"]


@dataclasses.dataclass
class Outcome:
    """What one case produced, filled in as it runs (mutable for that reason): the model,
    design and observer, the simulations by scenario, the timings, the engine's
    description, the error (None when it ran) and the design's full text."""

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


class Log:
    """The demo's progress lines, printed to ``stream`` and flushed at once."""

    def __init__(self, stream):
        self.stream = stream

    def __call__(self, msg: str = "") -> None:
        print(msg, file=self.stream, flush=True)


def short(text: str, width: int = 96) -> str:
    """``text`` on one line, cut to ``width`` characters with an ellipsis."""
    text = " ".join(str(text).split())
    return text if len(text) <= width else text[: width - 1] + "…"


def _mark(c) -> str:
    return "[ ok ]" if c.holds else ("[FAIL]" if c.required else "[ -- ]")


def _observer_summary(extra, short) -> str:
    """The observer's own conditions: how many hold, then each one that does not, counted
    as shown (required ones first are [FAIL], optional ones [ -- ])."""
    failing = [c for c in extra if not c.holds]
    head = f"          observer: {len(extra) - len(failing)} of {len(extra)} conditions hold"
    if failing:
        req = sum(1 for c in failing if c.required)
        kinds = ", ".join(p for p in (f"{req} required" if req else "",
                                      f"{len(failing) - req} optional" if len(failing) > req
                                      else "") if p)
        head += f"; the {len(failing)} that do not ({kinds}):"
    return head + "".join(f"\n          {_mark(c)} {short(c.name, 90)}" for c in failing)


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


class Engine:
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


def run_case(i: int, n: int, case: Case, models_dir: Path, models: dict, engine: Engine,
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
            log(f"          {_mark(c)} {short(c.name, 90)}")
        if d.assumptions:
            log(f"          assumptions: {', '.join(str(a) for a in d.assumptions)}")
        t0 = time.perf_counter()
        ob = out.observer = build_observer(model, d, **case.options)
        out.timings["observer"] = time.perf_counter() - t0
        out.full_text = format_design(d) + "\n" + format_observer(ob)
        extra = [c for c in ob.conditions if c not in d.conditions]
        if extra:
            log(_observer_summary(extra, short))
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
