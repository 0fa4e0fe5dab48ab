"""What a new user met in the second hardening round: a false alarm labelled with a fault
name; no detection rate or confusion matrix from the CLI ensemble; a "worst run" where no
run differs; condition summaries that counted other things than they showed; symbolic
designs that silently built no observer."""
from __future__ import annotations

import json
import math
import shutil
import types
from pathlib import Path

import numpy as np
import pytest

from observer_cad.cli import main
from observer_cad.ensemble import EnsembleStatistics
from observer_cad.simulation import SummaryField

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
UNCERTAIN = MODELS / "electric_drive_uncertain.py"
SCENARIO = json.loads((MODELS / "scenarios" / "electric_drive_uncertain.json").read_text())
needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler")


def test_no_worst_run_where_every_run_has_the_same_value():
    fields = (SummaryField("zero", "max", "count", None, "always 0"),
              SummaryField("grows", "max", "count", None, "the run index"))
    acc = EnsembleStatistics(fields)
    acc.add(np.arange(4), "a", {"zero": np.zeros(4), "grows": np.arange(4.0)})
    s = acc.result().overall
    assert s["zero"].worst_run is None and math.isnan(s["zero"].worst_value)
    assert s["grows"].worst_run == 3
    text = acc.result().to_text()
    zero_row = next(line for line in text.splitlines() if line.strip().startswith("zero"))
    assert " - " in zero_row or zero_row.rstrip().endswith("-") or "  -  " in zero_row


def test_demo_condition_summary_counts_what_it_shows():
    from observer_cad.demo._designs import _observer_summary
    c = lambda name, holds, required: types.SimpleNamespace(  # noqa: E731
        name=name, holds=holds, required=required)
    extra = [c("a", True, True), c("b", True, False), c("c", True, True),
             c("d", False, False), c("e", False, False), c("f", False, False),
             c("g", False, True)]
    text = _observer_summary(extra, lambda s, n: s)
    lines = text.splitlines()
    assert "3 of 7 conditions hold; the 4 that do not (1 required, 3 optional):" in lines[0]
    assert len(lines) == 1 + 4
    assert sum("[ -- ]" in ln for ln in lines) == 3 and sum("[FAIL]" in ln for ln in lines) == 1
    assert _observer_summary(extra[:3], lambda s, n: s).strip() == \
        "observer: 3 of 3 conditions hold"


def test_symbolic_design_says_why_it_has_no_observer(capsys):
    argv = ["design", str(MODELS / "electric_drive.py"), "--observer", "diagnostic",
            "--symbolic"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "Observer: not built (a symbolic design" in out
    assert main(argv + ["--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["observer_equations"] is None and "symbolic" in data["observer_not_built"]
    assert main(argv[:-1] + ["--json"]) == 0  # numeric: built, no reason given
    data = json.loads(capsys.readouterr().out)
    assert data["observer_equations"] and "observer_not_built" not in data


@needs_cc
def test_an_alarm_without_a_fault_is_a_false_alarm(tmp_path, capsys):
    sc = dict(SCENARIO, signals=dict(SCENARIO["signals"], d="0"))
    f = tmp_path / "sc.json"
    f.write_text(json.dumps(sc))
    rc = main(["simulate", str(UNCERTAIN), "--observer", "diagnostic", "--threshold", "1e-9",
               "--scenario", str(f), "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert rc == 0
    first = next(line for line in out.splitlines() if line.startswith("first alarm"))
    assert "false alarm: no fault is active; pattern 'd'" in first, first
    assert "(d)" not in first


@needs_cc
def test_cli_ensemble_reports_detection_and_the_confusion_matrix(tmp_path, capsys):
    sc = dict(SCENARIO, cases={"healthy": {"d": "0"}, "faulty": {}})
    f = tmp_path / "sc.json"
    f.write_text(json.dumps(sc))
    rc = main(["ensemble", str(UNCERTAIN), "--observer", "diagnostic", "--threshold",
               "guaranteed", "--scenario", str(f), "--runs", "6", "--workers", "1",
               "--keep", "0", "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert rc == 0
    assert "false alarms: 0/12 (0 %) runs" in out
    assert "detected: 6/6 (100 %) faulty runs; isolated (the right fault named): 6/6" in out
    rows = [line.split() for line in out.splitlines()
            if line.strip().startswith(("healthy", "faulty"))
            and len(line.split()) in (5, 6) and "runs" not in line]
    assert ["healthy", "no", "fault", "6", "6", "0"] in rows
    assert ["faulty", "d", "6", "0", "6"] in rows


@needs_cc
def test_fault_free_ensembles_report_no_detection_section(tmp_path, capsys):
    sc = dict(SCENARIO, signals=dict(SCENARIO["signals"], d="0"))
    f = tmp_path / "sc.json"
    f.write_text(json.dumps(sc))
    rc = main(["ensemble", str(UNCERTAIN), "--observer", "diagnostic", "--threshold",
               "guaranteed", "--scenario", str(f), "--runs", "3", "--workers", "1",
               "--keep", "1", "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert rc == 0 and "confusion matrix" not in out
    # r.exceedances is 0 in every run: no run is "the worst"
    assert "no worst run: every run has the same" in out and "worst run 0" not in out
