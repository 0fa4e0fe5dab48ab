"""The demo's diagnosability example: the analysis of one model (which faults can be
detected with the disturbances decoupled, which pairs isolated, the achievable structure
matrix) and an isolating residual bank for another — designed, compiled, simulated and
plotted — with its lines in the report's introduction and its section.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from ..errors import ObserverCadError, describe_failure
from ..model import load_model
from ._cases import ANALYSIS_JSON, BANK_FIGURE, BANK_JSON, DiagnosabilityExample
from ._designs import Engine, short
from ._plotting import SIGNAL_TEX, STYLE, pyplot, sci, text_box

__all__ = ["DiagOutcome", "run_diagnosability", "fig_bank_residuals", "diagnosability_figure",
           "diagnosability_summary", "diagnosability_section"]


@dataclasses.dataclass
class DiagOutcome:
    """What the diagnosability example produced, filled in as it runs: the analysis, the
    bank (its analysis, observer and simulation), the timings, the error (None when it
    ran) and the bank's figure."""

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


def run_diagnosability(ex: DiagnosabilityExample, models_dir: Path, engine: Engine,
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
            "  (worked example: which faults can be detected and isolated)")
        t0 = time.perf_counter()
        a = out.analysis = analyze(model)
        out.analysis_time = time.perf_counter() - t0
        det = [f"{r.fault} (k = {r.min_order})" for r in a.fault_results if r.detectable]
        log(f"        analysed in {out.analysis_time:.2f} s: detectable"
            f" {', '.join(det) or 'none'}; isolable pairs {_count([p.isolable for p in a.pairs])};"
            f" {len(a.structure)} achievable structure row(s)")
        for r in a.fault_results:
            if not r.detectable:
                log(f"          {short(r.reason, 140)}")
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
    plt = pyplot()
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
        text_box(ax, (f"sees {fault} (S = 1): max|r{i}| = {after:.3g} after t = {t_f:g}" if sees else
                  f"decoupled from {fault} (S = 0): max|r{i}| = {sci(after)}")
             + f"\nbefore the fault: max|r{i}| = {sci(before)}",
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


def diagnosability_figure(diag: DiagOutcome, fig_dir: Path, log, failed: list) -> None:
    from ..reporting import save_figure
    if diag.error is not None or diag.sim is None:
        log(f"[figure] {BANK_FIGURE}: skipped (the residual bank did not run)")
        return
    plt = pyplot()
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


def diagnosability_summary(diag: DiagOutcome) -> str:
    """One bullet for the report's introduction."""
    from ..reporting import md_escape
    if diag.error is not None and diag.analysis is None:
        return f"- [diagnosability](#diagnosability): ❌ {md_escape(diag.error)}"
    a = diag.analysis
    text = (f"- [diagnosability](#diagnosability) (which faults can be detected and isolated): analysis of `{a.model_name}` —"
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


def diagnosability_section(diag: DiagOutcome) -> str:
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
