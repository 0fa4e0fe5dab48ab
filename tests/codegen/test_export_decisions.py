"""C export of the decision logic (export_observer(..., rule=...)): NAME_decide, the
diagnosis table and NAME_PERSISTENCE, compiled with ``cc -std=c99 -Wall -Wextra -Werror``;
parity with the Python reference observer_cad.observers.decide, bit-exact (codes and
alarms), on simulated residual trajectories with thresholds that some samples leave,
NaN samples and values exactly on the boundary.

* a small driver feeds r, lower, upper of every sample (printed with %.17g / repr:
  exact doubles) to NAME_decide and prints the code and the alarms;
* the exported example prints <r>_alarm, alarm, diagnosis_code and diagnosis after the
  outputs: with the thresholds as observer outputs (the drive) and read from the input
  CSV (the isolation bank, where one threshold cell is empty: NaN).
"""
from __future__ import annotations

import csv
import dataclasses
import io
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from observer_cad.codegen import EXAMPLE_FLAGS, export_observer, export_sources
from observer_cad.errors import UsageError
from observer_cad.model import load_model
from observer_cad.residuals import DecisionRule, decide, decision_rule
from observer_cad.observers import build_observer
from observer_cad.simulation import scenario_from_dict, simulate
from observer_cad.synthesis import design
from observer_cad.analysis import design_bank

ROOT = Path(__file__).resolve().parents[2]
CC = shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler 'cc' on PATH")

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "NAME.h"

/* stdin: per sample, NRES triples r lower upper; stdout: code then the alarms */
int main(void) {
  double r[NAME_NRES], lo[NAME_NRES], hi[NAME_NRES];
  int counters[NAME_NRES], alarms[NAME_NRES], i, code;
  char buf[64];
  for (i = 0; i < NAME_NRES; ++i) counters[i] = 0;
  for (;;) {
    for (i = 0; i < NAME_NRES; ++i) {
      if (scanf("%63s", buf) != 1) return 0;
      r[i] = strtod(buf, NULL);
      if (scanf("%63s", buf) != 1) return 1;
      lo[i] = strtod(buf, NULL);
      if (scanf("%63s", buf) != 1) return 1;
      hi[i] = strtod(buf, NULL);
    }
    code = NAME_decide(r, lo, hi, counters, alarms);
    printf("%d", code);
    for (i = 0; i < NAME_NRES; ++i) printf(" %d", alarms[i]);
    printf(" %s\n", NAME_diagnosis_text[code] == NAME_diagnosis_text[code] ? "ok" : "");
  }
}
"""


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_CACHE", str(tmp_path_factory.getbasetemp() / "occache"))


@pytest.fixture(scope="module")
def drive():
    m = load_model(ROOT / "models" / "electric_drive.py")
    d = design(m, observer="diagnostic")
    o = build_observer(m, d)
    sc = scenario_from_dict({"steps": 300, "seed": 4, "initial": {"x1": 0.1},
                             "signals": {"u": "sin(t/10)", "d": "Piecewise((0, t < 150), (0.02, True))",
                                         "rho": {"uniform": [-0.05, 0.05]},
                                         "w1": {"uniform": [-0.01, 0.01]},
                                         "w2": {"uniform": [-0.01, 0.01]}}})
    return m, d, o, simulate(m, o, sc)


@pytest.fixture(scope="module")
def bank():
    m = load_model(ROOT / "models" / "three_tank_isolation.py")
    b = design_bank(m, structure="011,101,110")
    o = build_observer(m, b)
    sc = scenario_from_dict({"t_end": 3, "dt": 0.01, "seed": 1,
                             "initial": {"x1": 0.5, "x2": 0.2, "x3": 0.1},
                             "signals": {"u1": 1, "u2": 0.5, "rho": {"uniform": [-0.2, 0.2]},
                                         "w1": {"uniform": [-0.02, 0.02]},
                                         "w2": {"uniform": [-0.02, 0.02]},
                                         "w3": {"uniform": [-0.02, 0.02]},
                                         "f3": "Piecewise((0, t < 1.5), (0.6, True))"}})
    return m, b, o, simulate(m, o, sc)


def _thresholds(res, residuals, width, seed):
    """Bands around 0 that the residual leaves now and then, with ties and NaN."""
    rng = np.random.default_rng(seed)
    cols = {}
    for r in residuals:
        v = np.array(res[r], dtype=float)
        n = v.size
        lo = np.full(n, -width)
        hi = np.full(n, width) * rng.uniform(0.8, 1.2, n)
        ties = rng.choice(n, 12, replace=False)
        hi[ties[:6]] = v[ties[:6]]          # exactly on the upper boundary: in
        lo[ties[6:]] = v[ties[6:]]          # exactly on the lower boundary: in
        v[rng.choice(n, 3, replace=False)] = np.nan
        lo[rng.choice(n, 2, replace=False)] = np.nan
        cols[r], cols[f"{r}_lower"], cols[f"{r}_upper"] = v, lo, hi
    return cols


def _compile(paths, cwd, extra_source=None, name=None):
    c = paths[0]
    srcs = [c.name]
    if extra_source is not None:
        (cwd / "driver.c").write_text(extra_source.replace("NAME", name))
        srcs.append("driver.c")
    else:
        srcs.append(paths[2].name)
    r = subprocess.run(["cc", *EXAMPLE_FLAGS, *srcs, "-lm", "-o", "prog"], cwd=cwd,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", r.stderr
    return cwd / "prog"


def _driver_run(exe, rule, cols):
    lines = []
    n = np.asarray(cols[rule.residuals[0]]).size
    for k in range(n):
        lines.append(" ".join(f"{repr(float(cols[r][k]))} {repr(float(cols[r + '_lower'][k]))}"
                              f" {repr(float(cols[r + '_upper'][k]))}" for r in rule.residuals))
    p = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    rows = [line.split() for line in p.stdout.splitlines()]
    assert len(rows) == n
    code = np.array([int(r[0]) for r in rows])
    alarms = np.array([[int(x) for x in r[1:1 + len(rule.residuals)]] for r in rows]).T
    return code, alarms


@needs_cc
@pytest.mark.parametrize("which, persistence", [("drive", 1), ("drive", 3), ("bank", 2)])
def test_decide_in_c_is_bit_exact(which, persistence, drive, bank, tmp_path):
    m, d, o, res = drive if which == "drive" else bank
    rule = decision_rule(m, d, persistence=persistence)
    width = 0.02 if which == "drive" else 0.05
    cols = _thresholds(res, rule.residuals, width, seed=persistence)
    ref = decide(rule, cols)
    assert 0 < ref.alarm.sum() < ref.alarm.size      # some alarms, not all
    paths = export_observer(o, tmp_path, dt=None, rule=rule)
    exe = _compile(paths, tmp_path, DRIVER, paths[0].stem)
    code, alarms = _driver_run(exe, rule, cols)
    assert np.array_equal(code, ref.code)
    assert np.array_equal(alarms.astype(bool), np.stack(ref.alarms))
    h = paths[1].read_text()
    assert f"#define {paths[0].stem}_PERSISTENCE {persistence} " in h
    table = paths[0].read_text()
    for k, text in enumerate(rule.table()):
        assert f'"{text}",   /* code {k} */' in table


def _example_rows(stdout):
    rows = list(csv.reader(io.StringIO(stdout)))
    head = rows[0]
    return {h: [r[i] for r in rows[1:]] for i, h in enumerate(head)}


@needs_cc
def test_example_prints_decisions_with_thresholds_as_outputs(drive, tmp_path):
    m, d, o, res = drive
    # thresholds as observer outputs (constants), as a threshold step adds them
    o2 = dataclasses.replace(o, outputs=o.outputs + (("r_lower", sp.Float(-0.012)),
                                                     ("r_upper", sp.Float(0.012))))
    rule = decision_rule(m, d, persistence=2)
    paths = export_observer(o2, tmp_path, rule=rule)
    exe = _compile(paths, tmp_path)
    inp = tmp_path / "in.csv"
    inp.write_text("y1,y2,u\n" + "".join(",".join(repr(float(res[c][k])) for c in ("y1", "y2", "u")) + "\n"
                                         for k in range(res["t"].size)))
    p = subprocess.run([str(exe), inp.name, "trace"], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    got = _example_rows(p.stdout)
    cols = {c: np.array(got[c], dtype=float) for c in ("r", "r_lower", "r_upper")}
    ref = decide(rule, cols)
    assert 0 < ref.alarm.sum() < ref.alarm.size
    assert np.array_equal(np.array(got["alarm"], dtype=int), ref.alarm.astype(int))
    assert np.array_equal(np.array(got["r_alarm"], dtype=int), ref.alarms[0].astype(int))
    assert np.array_equal(np.array(got["diagnosis_code"], dtype=int), ref.code)
    assert got["diagnosis"] == list(ref.diagnosis)


@needs_cc
def test_example_reads_thresholds_from_the_input(bank, tmp_path):
    m, b, o, res = bank
    rule = decision_rule(m, b, persistence=3)
    paths = export_observer(o, tmp_path, dt=0.01, rule=rule)
    exe = _compile(paths, tmp_path)
    n = res["t"].size
    th = {}
    for r in rule.residuals:
        th[f"{r}_lower"] = np.full(n, -0.03)
        th[f"{r}_upper"] = np.full(n, 0.03)
    names = ["t", "y1", "y2", "y3", "u1", "u2"] + list(th)
    lines = [",".join(names)]
    for k in range(n):
        cells = [repr(float(res[c][k])) for c in names[:6]] + [repr(float(th[c][k])) for c in th]
        if k == 5:
            cells[names.index("r2_upper")] = ""       # not available: NaN, not out
        lines.append(",".join(cells))
    (tmp_path / "in.csv").write_text("\n".join(lines) + "\n")
    p = subprocess.run([str(exe), "in.csv", "trace"], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    got = _example_rows(p.stdout)
    cols = {r: np.array(got[r], dtype=float) for r in rule.residuals}
    cols.update(th)
    cols["r2_upper"] = cols["r2_upper"].copy()
    cols["r2_upper"][5] = np.nan
    ref = decide(rule, cols)
    assert "f3" in set(ref.diagnosis)                   # the fault in tank 3 is isolated
    assert np.array_equal(np.array(got["diagnosis_code"], dtype=int), ref.code)
    for r, a in zip(rule.residuals, ref.alarms):
        assert np.array_equal(np.array(got[f"{r}_alarm"], dtype=int), a.astype(int))
    assert got["diagnosis"] == list(ref.diagnosis)


def test_rule_must_match_the_observer(drive):
    m, d, o, res = drive
    bad = DecisionRule(("r9",), ("d",), ((1,),))
    with pytest.raises(UsageError, match="residual 'r9' is not an output"):
        export_sources(o, rule=bad)
    with pytest.raises(UsageError, match="must be a DecisionRule"):
        export_sources(o, rule={"r": 1})
    # without a rule the sources have no decision logic (unchanged export)
    assert "_decide" not in export_sources(o).c
