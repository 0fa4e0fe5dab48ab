"""``observer-cad demo``: designs, compiles, simulates, plots and writes
``out/report.md``. One full run into a temporary directory with an empty compile cache;
the checks are on what it wrote (no wall-clock assertions)."""
from __future__ import annotations

import dataclasses
import io
import json
import re

import pytest

import observer_cad.demo._cases as cases
import observer_cad.demo._run as demo  # fault injection: the case list is patched where run_demo reads it
import observer_cad.demo._evaluation as evaluation
from observer_cad.reporting import md_escape, symbol_latex


@pytest.fixture(scope="module")
def demo_run(models_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("demo_out")
    cache = tmp_path_factory.mktemp("cache")
    mp = pytest.MonkeyPatch()
    mp.setenv("OBSERVER_CAD_CACHE", str(cache))
    try:
        buf = io.StringIO()
        rc = demo.run_demo(models_dir, out, stream=buf)
    finally:
        mp.undo()
    return rc, out, buf.getvalue(), cache


@pytest.mark.slow  # the whole demo run, ~10 s
def test_demo_succeeds_and_reports_progress(demo_run):
    rc, out, log, _ = demo_run
    assert rc == 0, log
    n = len(demo.CASES)
    for i in range(1, n + 1):
        assert f"[{i:2d}/{n}]" in log
    assert "certificate PASSED" in log and "FAILED" not in log
    assert re.search(r"^total \d+\.\d s", log, re.M), log[-500:]
    assert log.count("[figure]") == len(demo.FIGURES) + 1  # + the residual bank's
    # the diagnosability steps report their progress like the designs
    assert "[diagnosability 1/2] Analysis of three_tank_faults" in log
    assert "f3 is undetectable with rho decoupled" in log
    assert "[diagnosability 2/2] Isolating residual bank for three_tank_isolation" in log
    assert "generalised observer scheme: 3 residuals, structure matrix 011, 101, 110" in log
    assert re.search(r"simulate \d+ ms \(.*\): three_tank_isolation \(2001 steps\)", log)


@pytest.mark.slow  # the whole demo run, ~10 s
def test_compiled_with_a_cold_cache(demo_run):
    rc, out, log, cache = demo_run
    if "falling back to the reference simulator" in log:
        pytest.skip("no C compiler here: the demo used the reference simulator")
    assert "C compiled now" in log
    assert list(cache.glob("*.so")), "the compiled libraries went to OBSERVER_CAD_CACHE"


@pytest.mark.slow  # the whole demo run, ~10 s
def test_report_references_existing_pngs(demo_run):
    rc, out, log, _ = demo_run
    report = (out / "report.md").read_text(encoding="utf-8")
    refs = re.findall(r"\]\((figures/[^)]+\.png)\)", report)
    assert refs
    for r in refs:
        p = out / r
        assert p.is_file() and p.stat().st_size > 10_000, r
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    written = {p.name for p in (out / "figures").glob("*.png")}
    assert written == {name for name, *_ in demo.FIGURES} | {cases.BANK_FIGURE} | {
        evaluation.DRIVE_FIGURE, evaluation.BANK_FIGURE, evaluation.BANK_RUN_FIGURE,
        evaluation.ENSEMBLE_FIGURE, evaluation.ENSEMBLE_WORST_FIGURE, evaluation.SENSOR_FIGURE}
    assert {r.split("/")[1] for r in refs} == written
    # the papers' figures are all there
    for name in ("000_fig1", "000_fig2", "000_fig3", "000_fig4", "002_fig2", "002_fig3", "001_fig2"):
        assert f"figures/{name}.png" in refs
    # atomic writes leave no temporary files behind
    assert not [p for p in out.rglob(".*") if p.is_file()]


@pytest.mark.slow  # the whole demo run, ~10 s
def test_every_design_certified(demo_run):
    rc, out, log, _ = demo_run
    for case in demo.CASES:
        data = json.loads((out / "designs" / f"{case.key}.json").read_text(encoding="utf-8"))
        assert data["certificate"]["passed"] is True, case.key
        assert all(i["holds"] for i in data["certificate"]["identities"]), case.key
        tex = (out / "designs" / f"{case.key}.tex").read_text(encoding="utf-8")
        assert tex.startswith(r"\documentclass") and r"\Phi &= " in tex
    report = (out / "report.md").read_text(encoding="utf-8")
    assert report.count("Certificate: **PASSED**") == len(demo.CASES)
    assert "FAILED" not in report and "❌" not in report
    summary = report.split("## Figures")[0]
    assert summary.count("| ✅ |") == len(demo.CASES)


@pytest.mark.slow  # the whole demo run, ~10 s
def test_report_has_latex_conditions_and_timings(demo_run):
    rc, out, log, _ = demo_run
    report = (out / "report.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^\$\$\n(.*?)\n\$\$$", report, re.S | re.M)
    assert len(blocks) >= 3 * len(demo.CASES)
    for b in blocks:
        assert b.startswith(r"\begin{aligned}") and b.endswith(r"\end{aligned}")
        assert b.count("{") == b.count("}"), b[:200]
    # seed 000's fault model (symbolic k1..k6) and seed 002's virtual sensor, in LaTeX
    assert r"\Phi &= \left(\begin{matrix}k_{4} & 0 & - k_{1}\end{matrix}\right)" in report
    assert r"\dot{x}^{*}_{1} &= u_{1} - \sqrt{x^{*}_{1} - y_{1}}" in report
    assert report.count("| | condition | evidence | source |") >= len(demo.CASES)
    assert "rank condition (3.3) at k = 1" in report
    assert "**Assumptions**" in report and r"$k_{1} \neq 0$" in report
    assert report.count("**Timings**: design") == len(demo.CASES)
    for case in demo.CASES:
        assert f'<a id="{case.key}"></a>' in report
    # the full text of every design is kept (+ the diagnosability analysis and the bank)
    assert report.count("<summary>Full text output") == len(demo.CASES) + 2


@pytest.mark.slow  # the whole demo run, ~10 s
def test_report_has_the_diagnosability_section(demo_run):
    """The diagnosability section: the analysis of three_tank_faults as tables, and the
    isolating residual bank of three_tank_isolation with its structure matrix, its
    observer, its simulation and figure, and both exported as JSON."""
    rc, out, log, _ = demo_run
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "- [diagnosability](#diagnosability) (which faults can be detected and isolated)" in report
    section = report.split('<a id="diagnosability"></a>\n## Diagnosability')[1]
    analysis, bank = section.split("### Isolating residual bank for `three_tank_isolation`")
    # (a) the analysis: detectability with minimal orders, isolability, structure matrix,
    # reasons and suggestions, as Markdown tables
    assert "### Analysis of `three_tank_faults`" in analysis
    assert "observer-cad analyze models/three_tank_faults.py" in analysis
    assert "| fault | detectable | minimal order k | reason |" in analysis
    assert "| f1 | ✅ yes | 2 | — |" in analysis and "| f2 | ✅ yes | 2 | — |" in analysis
    assert ("| f3 | ➖ no | — | f3 is undetectable with rho decoupled: D(f3) is a multiple of"
            " the column of rho") in analysis
    assert "| f1 / f2 | ➖ no | no | no | f1 cannot be isolated from f2" in analysis
    assert "| f1 / f3 | ➖ no | yes (k = 2) | no |" in analysis
    assert "| residual | f1 | f2 | f3 | decoupled |" in analysis
    assert "| r1 | 1 | 1 | 0 | f3 |" in analysis
    assert "| isolate f1 from f2 | x1 | 1 |" in analysis
    assert "- detect f3: no single extra measurement" in analysis
    # (b) the bank: its structure matrix (generalised observer scheme), certified residuals
    assert "observer-cad design models/three_tank_isolation.py --observer diagnostic --isolate" in bank
    assert "| residual | f1 | f2 | f3 | k | λ | decoupled from | certificate |" in bank
    for i, row in enumerate(("0 | 1 | 1", "1 | 0 | 1", "1 | 1 | 0"), 1):
        assert f"| r{i} | {row} | 1 | $-1$ | rho, f{i} | passed (exact) |" in bank
    assert "3 of 3 pairs isolable" in bank
    assert "f1/f2 yes, f1/f3 yes, f2/f3 yes" in bank
    assert r"r_{1} &= x^{*(1)}_{1} + y_{2} - y_{3}" in bank  # the bank as one observer
    # simulated with a step fault in f2: only the residuals of f2's column (1, 0, 1) move
    assert f"](figures/{cases.BANK_FIGURE})" in bank
    assert "f2's column of the structure matrix is (1, 0, 1): r1, r3 move" in bank
    assert "r2 stays at rounding level" in bank and "as the structure matrix predicts" in bank
    # exports
    data = json.loads((out / "designs" / cases.BANK_JSON).read_text(encoding="utf-8"))
    assert data["structure_matrix"] == [[0, 1, 1], [1, 0, 1], [1, 1, 0]]
    assert data["scheme"] == "generalised observer scheme"
    assert all(d["certificate"]["passed"] for d in data["designs"])
    data = json.loads((out / "designs" / cases.ANALYSIS_JSON).read_text(encoding="utf-8"))
    assert data["detectable"] == {"f1": True, "f2": True, "f3": False}
    assert data["min_order"] == {"f1": 2, "f2": 2, "f3": None}
    # both example models are shown with the others
    assert "### Model `three_tank_faults`" in report and "### Model `three_tank_isolation`" in report


@pytest.mark.slow  # a demo run (~8 s): in the slow step, keeping the default run < 3 min
def test_fallback_without_a_compiler(models_dir, tmp_path, monkeypatch):
    """No C compiler: the demo says so and simulates with the reference simulator."""
    keys = {"lin_vs_jordan", "drive_diag"}
    monkeypatch.setattr(demo, "CASES", tuple(c for c in demo.CASES if c.key in keys))
    monkeypatch.setenv("CC", "no-such-compiler-observer-cad")
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path / "cache"))
    buf = io.StringIO()
    assert demo.run_demo(models_dir, tmp_path / "out", stream=buf) == 0
    log = buf.getvalue()
    assert "falling back to the reference simulator" in log
    assert "no-such-compiler-observer-cad" in log
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "reference simulator (numpy)" in report
    assert "figures/drive_residual.png" in report
    assert "skipped" in log  # figures whose designs were not run are skipped, not failed
    # the residual bank falls back too
    assert f"figures/{cases.BANK_FIGURE}" in report
    assert "Scenario: `models/scenarios/three_tank_isolation.json`. Simulated with:" \
        " reference simulator (numpy)." in report


@pytest.mark.slow  # a demo run (~8 s): in the slow step, keeping the default run < 3 min
def test_a_failing_diagnosability_step_is_reported(models_dir, tmp_path, monkeypatch):
    """A broken diagnosability example fails the demo (exit 1) with one line naming the
    step, and the rest of the report is still written."""
    monkeypatch.setattr(demo, "CASES", tuple(c for c in demo.CASES if c.key == "drive_diag"))
    monkeypatch.setattr(demo, "DIAGNOSABILITY", dataclasses.replace(
        demo.DIAGNOSABILITY, bank_model="no_such_model.py"))
    buf = io.StringIO()
    assert demo.run_demo(models_dir, tmp_path, compile=False, stream=buf) == 1
    log = buf.getvalue()
    assert "[diagnosability 1/2]" in log
    assert re.search(r"FAILED: residual bank: .*no_such_model", log), log[-800:]
    assert f"[figure] {cases.BANK_FIGURE}: skipped" in log
    assert "FAILED: diagnosability" in log
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "### Analysis of `three_tank_faults`" in report and "**FAILED** (residual bank:" in report


@pytest.mark.slow  # a demo run (~8 s): in the slow step, keeping the default run < 3 min
def test_no_compile_option(models_dir, tmp_path, monkeypatch):
    monkeypatch.setattr(demo, "CASES", tuple(c for c in demo.CASES if c.key == "drive_diag"))
    buf = io.StringIO()
    assert demo.run_demo(models_dir, tmp_path, compile=False, stream=buf) == 0
    assert "compilation switched off" in buf.getvalue()
    assert not list(tmp_path.glob("*.so"))


def test_markdown_and_latex_helpers():
    assert md_escape("Phi F - F* Phi | x_1") == r"Phi F - F\* Phi \| x\_1"
    assert symbol_latex("xs2") == "x^{*}_{2}"
    assert symbol_latex("xl1") == r"\underline{x}^{*}_{1}"
    assert symbol_latex("rho_hat") == r"\hat{\rho}"
    assert symbol_latex("x1_upper") == r"\overline{x}_{1}"
    assert symbol_latex("y2_lag1") == "{y_{2}}^{[-1]}"


@pytest.mark.slow  # the whole demo run
def test_report_has_the_residual_evaluation(demo_run):
    """The residual evaluation section, measured by this run: no false alarm with the
    guaranteed threshold over the fault-free runs, the step fault detected in every run with
    its delay, and the three-tank bank's confusion matrix (every run isolated)."""
    rc, out, log, _ = demo_run
    report = (out / "report.md").read_text(encoding="utf-8")
    sec = report[report.index('<a id="evaluation"></a>'):]
    assert "| no fault | 200 | — | — | — | 0 | 0/200 |" in sec
    assert re.search(r"\| d = 0\.2 from t = 100 \| 200 \| 1 \| 1 steps \| 1 steps \| 0 \| 0/200 \| 0 \| 1 \|", sec)
    for f in ("f1", "f2", "f3"):
        row = {"f1": "0 | 40 | 0 | 0", "f2": "0 | 0 | 40 | 0", "f3": "0 | 0 | 0 | 40"}[f]
        assert f"| {f} | {row} | 0 |" in sec
    assert "comparison system stable" in sec and "594/625" in sec
    assert "0 false alarms in 200 fault-free runs" in report
    # a bias on sensor 1 against the pump faults: every run isolated, no false alarm
    sensor = sec[sec.index("### Sensor faults against actuator faults"):]
    for f in ("fa1", "fa2", "fs1"):
        row = {"fa1": "0 | 40 | 0 | 0", "fa2": "0 | 0 | 40 | 0", "fs1": "0 | 0 | 0 | 40"}[f]
        assert f"| {f} | {row} | 0 |" in sensor
    assert "sensor against actuator faults isolation accuracy 1" in report


@pytest.mark.slow  # the whole demo run
def test_report_has_the_ensemble(demo_run):
    """The ensemble section: the three-tank interval observer over many runs, its
    statistics and the worst run replayed (a compiler is there: the demo compiles)."""
    rc, out, log, _ = demo_run
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "### Validation over an ensemble" in report
    assert f"{2 * evaluation.ENSEMBLE_RUNS} runs in" in report
    assert re.search(r"x1\.violations +\d+/\d+ +0 ", report)  # no run left the interval
    assert "0 of 4000 three-tank runs left the interval" in report
