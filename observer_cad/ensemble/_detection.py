"""Detection and false-alarm rates of an ensemble run with a decision rule, and its
confusion matrix, from the per-run summaries the ensemble already keeps
(``alarm.first``, ``diagnosis.code``) and the scenario's cases.

A case's *true label* is read from its signal program: the faults whose signal is not
identically zero on the grid (for any run: base value, uniform or normal part), ``"no
fault"`` when none is; its *onset* is the first grid time at which one of them may be
nonzero. Per run:

* a *false alarm*: a run of a fault-free case with an alarm, or a run of a faulty case
  whose first alarm comes before the onset;
* *detected*: a run of a faulty case whose diagnosis at its last sample is not ``"no
  fault"``; *isolated*: that diagnosis is the case's label.

These are counts over the ensemble's runs, not the sample-wise rates of
:func:`observer_cad.simulation.evaluate_ensemble` (whose fault cases are steps it builds).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..residuals import NO_FAULT, DecisionRule
from ..simulation import signal_program

__all__ = ["CaseDetection", "DetectionReport", "detection_report"]


@dataclasses.dataclass(frozen=True)
class CaseDetection:
    """One case: its true ``label``, fault ``onset`` (None when fault-free), ``runs``,
    runs with an alarm (``alarm_runs``), runs alarming before the onset
    (``early_alarm_runs``), and ``diagnoses``: (diagnosis at the last sample, runs) pairs."""

    case: str
    label: str
    onset: float | None
    runs: int
    alarm_runs: int
    early_alarm_runs: int
    diagnoses: tuple

    @property
    def faulty(self) -> bool:
        return self.label != NO_FAULT

    def count(self, diagnosis: str) -> int:
        return sum(n for d, n in self.diagnoses if d == diagnosis)


def _rate(k: int, n: int) -> str:
    return f"{k}/{n} ({100 * k / n:.3g} %)" if n else "—"


@dataclasses.dataclass(frozen=True)
class DetectionReport:
    """Per-case detection counts (:class:`CaseDetection`) of an ensemble."""

    cases: tuple

    @property
    def diagnoses(self) -> tuple:
        seen = []
        for c in self.cases:
            for d, _n in c.diagnoses:
                if d not in seen:
                    seen.append(d)
        return tuple(seen)

    @property
    def fault_free_runs(self) -> int:
        return sum(c.runs for c in self.cases if not c.faulty)

    @property
    def faulty_runs(self) -> int:
        return sum(c.runs for c in self.cases if c.faulty)

    @property
    def false_alarm_runs(self) -> int:
        return sum(c.alarm_runs if not c.faulty else c.early_alarm_runs for c in self.cases)

    @property
    def detected_runs(self) -> int:
        return sum(c.runs - c.count(NO_FAULT) for c in self.cases if c.faulty)

    @property
    def isolated_runs(self) -> int:
        return sum(c.count(c.label) for c in self.cases if c.faulty)

    def to_text(self) -> str:
        """The rates and the confusion matrix, as plain text."""
        n_all = self.fault_free_runs + self.faulty_runs
        out = ["detection (diagnosis at the last sample of each run):",
               f"  false alarms: {_rate(self.false_alarm_runs, n_all)} runs (an alarm in a"
               " fault-free run, or before the fault's onset)"]
        if self.faulty_runs:
            out.append(f"  detected: {_rate(self.detected_runs, self.faulty_runs)} faulty runs;"
                       f" isolated (the right fault named): "
                       f"{_rate(self.isolated_runs, self.faulty_runs)}")
        diags = self.diagnoses
        head = ["case", "true label", "runs", *diags]
        rows = [head] + [[c.case, c.label, str(c.runs), *(str(c.count(d)) for d in diags)]
                         for c in self.cases]
        widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
        out.append("  confusion matrix (rows: case and its true label, columns: diagnosis at"
                   " the end; runs):")
        for r in rows:
            out.append("    " + "  ".join(x.ljust(w) if i < 2 else x.rjust(w)
                                          for i, (x, w) in enumerate(zip(r, widths))).rstrip())
        return "\n".join(out)


def _case_truth(model, scenario, t, case: str) -> tuple:
    """(label, onset or None) of a case from its signal program."""
    prog = signal_program(model, scenario, t, case=case)
    faults = [str(f) for f in model.faults]
    present, first = [], None
    for j, name in enumerate(prog.names):
        if str(name) not in faults:
            continue
        nz = (prog.base[:, j] != 0) | (prog.su[:, j] != 0) | (prog.sn[:, j] != 0)
        if nz.any():
            present.append(str(name))
            k = int(np.flatnonzero(nz)[0])
            first = k if first is None else min(first, k)
    if not present:
        return NO_FAULT, None
    return " + ".join(present), float(t[first])


def detection_report(result, model, scenario, rule: DecisionRule) -> DetectionReport | None:
    """The :class:`DetectionReport` of an ensemble ``result`` run with ``rule``, or None
    when no case has a fault (then there is nothing to detect)."""
    t = scenario.grid(model.time)
    truth = {c: _case_truth(model, scenario, t, c) for c in result.cases}
    if all(label == NO_FAULT for label, _ in truth.values()):
        return None
    cols = result.accumulator.columns()
    case_of = np.asarray(cols["case"], dtype=object)
    first = np.asarray(cols["alarm.first"], dtype=float)
    code = np.asarray(cols["diagnosis.code"], dtype=float)
    out = []
    for c in result.cases:
        sel = case_of == c
        if not sel.any():
            continue
        label, onset = truth[c]
        f, k = first[sel], code[sel]
        texts = [rule.diagnosis(int(v)) if math.isfinite(v) else "not finite" for v in k]
        counts = {d: texts.count(d) for d in dict.fromkeys(texts)}
        alarm = ~np.isnan(f)
        early = int(np.count_nonzero(alarm & (f < onset))) if onset is not None else 0
        out.append(CaseDetection(c, label, onset, int(sel.sum()), int(alarm.sum()), early,
                                 tuple(counts.items())))
    return DetectionReport(tuple(out))
