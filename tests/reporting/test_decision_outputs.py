"""Outputs of decisions: the residual figure with threshold band, alarms and diagnoses
(plot_residuals, and plot_simulation using it when threshold columns exist), the
confusion-matrix figure, and the CSV columns alarm / diagnosis (with_decisions; a
result without decisions is written byte-identically)."""
from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from observer_cad.errors import UsageError
from observer_cad.residuals import NO_FAULT, DecisionRule, decide, evaluate_result
from observer_cad.reporting import (plot_confusion, plot_residuals, plot_simulation,
                                    residual_names, with_decisions, write_signals_csv)
from observer_cad.simulation import SimulationResult

GOS = DecisionRule(residuals=("r1", "r2", "r3"), faults=("f1", "f2", "f3"),
                   structure=((0, 1, 1), (1, 0, 1), (1, 1, 0)), persistence=2)


def bank_result(with_thresholds=True):
    N = 60
    t = np.arange(N) * 0.1
    f2 = np.where(t >= 3, 0.3, 0.0)
    cols = {"t": t, "y1": np.sin(t), "f1": np.zeros(N), "f2": f2, "f3": np.zeros(N)}
    for i, sens in enumerate((1, 0, 1), 1):     # f2's column (1, 0, 1)
        r = 0.01 * np.cos(7 * t * i) + sens * f2
        cols[f"r{i}"] = r
        if with_thresholds:
            cols[f"r{i}_lower"] = np.full(N, -0.05)
            cols[f"r{i}_upper"] = np.full(N, 0.05)
    return SimulationResult(cols, tuple(cols), units={"y1": "m", "r1": "m"}, time="continuous")


def _is_png(path):
    return path.exists() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 5000


def test_residual_figure_with_band_alarms_and_diagnoses(tmp_path):
    res = bank_result()
    d = decide(GOS, res)
    assert d.diagnosis[-1] == "f2"
    p = plot_residuals(res, tmp_path / "res.png", decisions=d, time="continuous", title="bank")
    assert _is_png(p)
    assert residual_names(res) == ("r1", "r2", "r3")
    with pytest.raises(UsageError, match="no residual with threshold"):
        plot_residuals(bank_result(False), tmp_path / "x.png")
    with pytest.raises(UsageError, match="no threshold columns r1_lower"):
        plot_residuals(bank_result(False), tmp_path / "x.png", decisions=d)


@pytest.mark.slow
def test_plot_simulation_uses_the_band_when_thresholds_exist(tmp_path):
    res = bank_result()
    d = decide(GOS, res)
    paths = plot_simulation(res, tmp_path / "a", time="continuous", decisions=d)
    names = sorted(p.name for p in paths)
    assert names == ["residual_r1.png", "residual_r2.png", "residual_r3.png", "residuals.png"]
    assert all(_is_png(p) for p in paths)
    # without thresholds: the plain residual figures, no band figure
    paths = plot_simulation(bank_result(False), tmp_path / "b", time="continuous")
    assert sorted(p.name for p in paths) == ["residual_r1.png", "residual_r2.png",
                                             "residual_r3.png"]
    # thresholds but no decisions: band and samples out, no alarms
    paths = plot_simulation(res, tmp_path / "c", time="continuous")
    assert "residuals.png" in {p.name for p in paths}


def test_confusion_figure(tmp_path):
    res = bank_result()
    m = evaluate_result(res, decide(GOS, res))
    assert _is_png(plot_confusion(m, tmp_path / "confusion.png", title="bank"))


def _read(path):
    return list(csv.reader(io.StringIO(path.read_text())))


def test_csv_gains_alarm_and_diagnosis(tmp_path):
    res = bank_result()
    rule = DecisionRule(residuals=("r1", "r2", "r3"), faults=("f1", "f2", "f3"),
                        structure=((1, 0, 1), (0, 0, 0), (1, 0, 1)))  # f1, f3 identical columns
    d = decide(rule, res)
    out = with_decisions(res, d, per_residual=True)
    write_signals_csv(out, tmp_path)
    rows = _read(tmp_path / "signals.csv")
    head = rows[0]
    assert head[-5:] == ["r1_alarm", "r2_alarm", "r3_alarm", "alarm", "diagnosis"]
    alarm = [r[head.index("alarm")] for r in rows[1:]]
    diag = [r[head.index("diagnosis")] for r in rows[1:]]
    assert alarm == [str(int(a)) for a in d.alarm]
    assert diag == list(d.diagnosis)
    assert diag[0] == NO_FAULT and diag[-1] == "f1 or f3"
    # numeric cells unchanged: repr of the float
    assert rows[1][head.index("r1")] == repr(float(res["r1"][0]))


def test_csv_quotes_text_that_needs_it(tmp_path):
    res = bank_result()
    rule = DecisionRule(residuals=("r1",), faults=('a,"b"',), structure=((1,),))
    cols = {"r1": np.r_[np.zeros(30), np.ones(30)], "r1_lower": np.zeros(60),
            "r1_upper": np.full(60, 0.5)}
    out = with_decisions(res, decide(rule, cols))
    write_signals_csv(out, tmp_path)
    text = (tmp_path / "signals.csv").read_text()
    assert '"a,""b"""' in text
    assert _read(tmp_path / "signals.csv")[-1][-1] == 'a,"b"'


def test_csv_without_decisions_is_unchanged(tmp_path):
    res = bank_result()
    write_signals_csv(res, tmp_path / "a")
    before = (tmp_path / "a" / "signals.csv").read_bytes()
    # the writer as it was: repr of every float cell, nan/inf literal
    expected = ",".join(res.order) + "\n" + "".join(
        ",".join(repr(float(res[c][i])) for c in res.order) + "\n" for i in range(60))
    assert before == expected.encode()


def test_with_decisions_checks_shapes_and_names():
    res = bank_result()
    d = decide(GOS, {k: v[:10] for k, v in res.columns.items()})
    with pytest.raises(UsageError, match="shape"):
        with_decisions(res, d)
    once = with_decisions(res, decide(GOS, res))
    with pytest.raises(UsageError, match="already has a column 'alarm'"):
        with_decisions(once, decide(GOS, res))
