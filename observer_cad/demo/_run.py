"""``observer-cad demo``: every observer the seed papers build for the electric drive and
the three-tank — designed, certified, compiled, simulated on the papers' scenarios,
plotted, and written up in ``out/report.md``.

:func:`run_demo` runs the rooms of this package in order: the design cases
(:data:`CASES`, ``_cases``; run by ``_designs``), the diagnosability example
(:data:`DIAGNOSABILITY`, ``_diagnosability``), the residual evaluation
(``_evaluation``), the figures (:data:`FIGURES`, ``_figures``: one module per seed
paper), the exports and the report (``_report``).

Each design is printed with its conditions (short form; the full text goes to the
report), compiled into one C trajectory function with the plant
(:class:`~observer_cad.codegen.CompiledSimulator`; without a C compiler the reference
simulator runs instead, and the demo says so), simulated, and plotted. Every write is
atomic (figures via :func:`~observer_cad.reporting.save_figure`, text via
:func:`~observer_cad.files.atomic_write_text`).

Output, under ``out_dir`` (default ``out``): ``report.md``, ``figures/*.png``,
``designs/<key>.json`` and ``designs/<key>.tex`` (the design exported as JSON and
LaTeX, :mod:`observer_cad.reporting`).
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..errors import UsageError
from ..files import atomic_write_text
from ..model import load_model
from ._cases import ANALYSIS_JSON, BANK_JSON, CASES, DIAGNOSABILITY, EXAMPLES_DIR
from ._designs import Engine, Log, run_case
from ._diagnosability import diagnosability_figure, run_diagnosability
from ._evaluation import BANK_MODEL, DRIVE_MODEL, ENSEMBLE_MODEL, SENSOR_MODEL, run_evaluation
from ._figures import FIGURES, render_figures
from ._report import report_text

__all__ = ["run_demo"]


def run_demo(models_dir: Path = EXAMPLES_DIR, out_dir: Path = Path("out"), *,
             compile: bool = True, stream=None) -> int:
    """Design, compile, simulate, plot and report every case of :data:`CASES` into
    ``out_dir``, reading the models and scenarios from ``models_dir`` (default: the
    examples shipped with the package, :data:`EXAMPLES_DIR`); returns 0 when every
    design was built and certified, else 1."""
    t_start = time.perf_counter()
    log = Log(stream if stream is not None else sys.stdout)
    models_dir, out_dir = Path(models_dir), Path(out_dir)
    fig_dir, des_dir = _output_dirs(models_dir, out_dir)
    n = len(CASES)
    log(f"observer-cad demo: {n} designs from seed papers 000, 001, 002, 004"
        + (", a diagnosability analysis and an isolating residual bank"
           if DIAGNOSABILITY is not None else "") + f" → {out_dir}/report.md")
    engine = Engine(compile, log)
    models: dict = {}
    outcomes = [run_case(i, n, c, models_dir, models, engine, log) for i, c in enumerate(CASES, 1)]
    t_cases = time.perf_counter() - t_start
    t0 = time.perf_counter()
    diag = (run_diagnosability(DIAGNOSABILITY, models_dir, engine, log)
            if DIAGNOSABILITY is not None else None)
    t_diag = time.perf_counter() - t0
    t0 = time.perf_counter()
    evaluation = run_evaluation(models_dir, fig_dir, log)
    t_eval = time.perf_counter() - t0
    by_key = {o.case.key: o for o in outcomes if o.error is None}

    t0 = time.perf_counter()
    fig_failed: list = []
    figs = render_figures(FIGURES, by_key, fig_dir, log, fig_failed)
    if diag is not None:
        diagnosability_figure(diag, fig_dir, log, fig_failed)
    t_figs = time.perf_counter() - t0

    t0 = time.perf_counter()
    _write_exports(outcomes, diag, des_dir)
    used_models = _used_models(outcomes, diag)
    totals = {"designs, compilation and simulation": t_cases}
    if diag is not None:
        totals["diagnosability"] = t_diag
    totals["residual evaluation"] = t_eval
    totals["figures"] = t_figs
    report_path = out_dir / "report.md"
    totals["report"] = time.perf_counter() - t0
    totals["total"] = time.perf_counter() - t_start
    for name in (DRIVE_MODEL, BANK_MODEL, SENSOR_MODEL, ENSEMBLE_MODEL):
        m = load_model(models_dir / name)
        used_models.setdefault(m.name, m)
    text = report_text(outcomes, figs, out_dir, totals, engine, used_models, diag, evaluation)
    atomic_write_text(report_path, text)
    totals["total"] = time.perf_counter() - t_start
    return _finish(log, outcomes, figs, diag, evaluation, engine, totals, t_figs, fig_failed,
                   report_path, des_dir)


def _output_dirs(models_dir: Path, out_dir: Path) -> tuple:
    """(figures, designs) under ``out_dir``, created; a one-line error when the example
    models are missing or a folder cannot be made."""
    if not (models_dir / "scenarios").is_dir():
        raise UsageError(f"{models_dir}: the example models are not there (a broken install "
                         "or checkout: reinstall observer_cad)")
    fig_dir, des_dir = out_dir / "figures", out_dir / "designs"
    for d in (out_dir, fig_dir, des_dir):
        try:
            d.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"{d}: cannot create the output directory: {exc.strerror}") from None
    return fig_dir, des_dir


def _write_exports(outcomes: list, diag, des_dir: Path) -> None:
    """Every design as JSON and LaTeX, the analysis and the bank as JSON, under ``designs/``."""
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


def _used_models(outcomes: list, diag) -> dict:
    """name → model of every model the cases and the diagnosability example ran (a case
    with its own bounds does not count: the report shows the model file's)."""
    used_models = {}
    for o in outcomes:
        if o.model is not None and o.model.name not in used_models and not o.case.bounds:
            used_models[o.model.name] = o.model
    for m in ((diag.analysis_model, diag.bank_model) if diag is not None else ()):
        if m is not None and m.name not in used_models:
            used_models[m.name] = m
    return used_models


def _finish(log, outcomes, figs, diag, evaluation, engine, totals, t_figs, fig_failed,
            report_path, des_dir) -> int:
    """The closing lines (what was written, what was certified, the times) and the exit
    status: 1 when a design, a figure, the diagnosability or the evaluation failed."""
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
