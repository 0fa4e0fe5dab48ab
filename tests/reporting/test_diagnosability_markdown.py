"""Markdown of a diagnosability analysis and of a residual bank (the demo report's
Diagnosability section): every table present, text from the analysis escaped, a "no"
about the plant not shown as a failure."""
from __future__ import annotations

import pytest

from observer_cad import analyze, build_observer, design_bank, load_model
from observer_cad.reporting import analysis_markdown, bank_markdown, symbol_latex


@pytest.fixture(scope="module")
def faults_md(models_dir):
    return analysis_markdown(analyze(load_model(models_dir / "three_tank_faults.py")))


def test_analysis_tables(faults_md):
    md = faults_md
    assert "| fault | detectable | minimal order k | reason |" in md
    assert "| f1 | ✅ yes | 2 | — |" in md
    assert "| f3 | ➖ no | — | f3 is undetectable with rho decoupled" in md
    assert "| pair a / b | isolable | a from b (k) | b from a (k) | reason |" in md
    assert "| f2 / f3 | ➖ no | yes (k = 2) | no | f3 cannot be isolated from f2" in md
    assert "| residual | f1 | f2 | f3 | decoupled |\n|---|---|---|---|---|\n| r1 | 1 | 1 | 0 | f3 |" in md
    assert "| isolate f2 from f1 | x1 | 1 |" in md
    assert "❌" not in md  # an undetectable fault is an answer, not a failure


def test_analysis_table_rows_have_the_header_width(faults_md):
    for block in faults_md.split("\n\n"):
        lines = [ln for ln in block.splitlines() if ln.startswith("|")]
        if not lines:
            continue
        width = lines[0].count(" | ")
        for ln in lines[2:]:  # text from the analysis cannot add cells (| is escaped)
            assert ln.replace("\\|", "").count(" | ") == width, ln


def test_bank_markdown(models_dir):
    m = load_model(models_dir / "three_tank_isolation.py")
    bank = design_bank(m)
    md = bank_markdown(bank, build_observer(m, bank))
    assert "| residual | f1 | f2 | f3 | k | λ | decoupled from | certificate |" in md
    assert "| r2 | 1 | 0 | 1 | 1 | $-1$ | rho, f2 | passed (exact) |" in md
    assert "f1/f2 yes, f1/f3 yes, f2/f3 yes" in md
    assert r"\dot{x}^{*(3)}_{1} &= " in md and r"r_{3} &= x^{*(3)}_{1} + y_{1} - y_{2}" in md


def test_bank_state_names_in_latex():
    assert symbol_latex("r2_xs1") == "x^{*(2)}_{1}"
    assert symbol_latex("xs1") == "x^{*}_{1}"
