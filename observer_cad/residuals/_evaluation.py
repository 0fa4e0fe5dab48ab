"""Evaluation of a decision rule's output: detection delay, false alarms, missed
detections and isolation (confusion matrix), computed from the columns of a result — one
scenario run or R runs — and the :class:`~observer_cad.residuals.Decisions` taken on it.
Pure functions of the columns: nothing here simulates (the Monte-Carlo ensemble over
fault cases is :func:`observer_cad.simulation.evaluate_ensemble`).

Definitions, per run of a result (columns of shape (N,) or (R, N)):

* **fault onset**: the first sample where any fault column (the rule's faults) is
  nonzero; none in a fault-free run;
* **true label**: the faults that are nonzero somewhere in the run, in the rule's order
  (``"f2"``; two at once ``"f1 and f2"``), ``"no fault"`` when none;
* **detection delay**: t(first alarm at or after the onset) − t(onset); ``None`` when
  no alarm follows the onset (a *missed detection*);
* **false alarms**: alarm samples before the onset, or anywhere in a fault-free run.
  The *false-alarm rate per sample* is their number over the number of such
  (fault-free) samples; the *false-alarm rate per run* the fraction of runs with at
  least one;
* **missed-detection rate**: faulty runs never alarmed after the onset, over faulty runs;
* **isolation**: the diagnosis at the end of the run (the last sample where every
  residual is available, i.e. not NaN) against the true label; the *confusion matrix*
  counts runs by (true label, diagnosis) — rows the labels including ``"no fault"``,
  columns the diagnoses including ``"unknown pattern"`` — and the *isolation accuracy*
  is the fraction of runs whose diagnosis equals the true label exactly (``"f1 or
  f2"`` for a fault f1 is a detection, not an isolation).

A :class:`FaultCase` (one fault, a constant size from an onset time, the other faults
zero) names a case of an ensemble.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from typing import Sequence

import numpy as np

from ..errors import UsageError
from ._decision import NO_FAULT, UNKNOWN_PATTERN, DecisionRule

__all__ = ["RunOutcome", "Metrics", "FaultCase", "evaluate_result", "fault_onsets",
           "true_labels"]


@dataclasses.dataclass(frozen=True)
class RunOutcome:
    """One run: its case, true label, onset time (None: fault-free), detection delay (None:
    not detected or fault-free), false-alarm samples, the fault-free samples they were
    counted over, and the diagnosis at the end of the run."""

    case: str
    label: str
    onset: float | None
    delay: float | None
    false_alarm_samples: int
    fault_free_samples: int
    diagnosis: str

    @property
    def faulty(self) -> bool:
        return self.onset is not None


def _fmt(v, unit="") -> str:
    if v is None:
        return "—"
    if isinstance(v, float) and math.isnan(v):
        return "—"
    return f"{v:.4g}{unit}"


@dataclasses.dataclass(frozen=True)
class Metrics:
    """Detection and isolation metrics of a set of runs (see the module docstring).

    ``runs_`` holds one :class:`RunOutcome` per run; everything else is computed from
    them, so two Metrics combine with ``a + b``. ``labels`` / ``diagnoses`` order the
    confusion matrix (the rule's; labels and diagnoses met but not listed are appended);
    ``time_unit`` labels delays (``"s"`` or ``"steps"``).
    """

    runs_: tuple
    labels: tuple
    diagnoses: tuple
    time_unit: str = ""

    def __add__(self, other: "Metrics") -> "Metrics":
        labels = self.labels + tuple(l for l in other.labels if l not in self.labels)
        diags = self.diagnoses + tuple(d for d in other.diagnoses if d not in self.diagnoses)
        return Metrics(self.runs_ + other.runs_, labels, diags, self.time_unit or other.time_unit)

    # ---- counts and rates
    @property
    def runs(self) -> int:
        return len(self.runs_)

    @property
    def faulty_runs(self) -> int:
        return sum(o.faulty for o in self.runs_)

    @property
    def delays(self) -> tuple:
        """Detection delays of the faulty runs that were detected."""
        return tuple(o.delay for o in self.runs_ if o.faulty and o.delay is not None)

    @property
    def false_alarm_samples(self) -> int:
        return sum(o.false_alarm_samples for o in self.runs_)

    @property
    def false_alarm_rate(self) -> float:
        """False-alarm samples over fault-free samples (NaN when there are none)."""
        n = sum(o.fault_free_samples for o in self.runs_)
        return self.false_alarm_samples / n if n else float("nan")

    @property
    def false_alarm_runs(self) -> int:
        return sum(o.false_alarm_samples > 0 for o in self.runs_)

    @property
    def false_alarm_run_rate(self) -> float:
        return self.false_alarm_runs / self.runs if self.runs else float("nan")

    @property
    def missed_detections(self) -> int:
        return sum(o.faulty and o.delay is None for o in self.runs_)

    @property
    def missed_detection_rate(self) -> float:
        """Faulty runs never alarmed after the onset, over faulty runs (NaN: none faulty)."""
        f = self.faulty_runs
        return self.missed_detections / f if f else float("nan")

    @property
    def isolation_accuracy(self) -> float:
        """Runs whose end-of-run diagnosis equals the true label exactly, over all runs."""
        if not self.runs:
            return float("nan")
        return sum(o.diagnosis == o.label for o in self.runs_) / self.runs

    def delay_stats(self) -> tuple:
        """(median, max) detection delay of the detected runs, (None, None) when none."""
        d = self.delays
        return (float(np.median(d)), float(max(d))) if d else (None, None)

    @property
    def confusion(self) -> tuple:
        """Counts[i][j]: runs with true label ``labels[i]`` diagnosed ``diagnoses[j]``."""
        li = {l: i for i, l in enumerate(self.labels)}
        dj = {d: j for j, d in enumerate(self.diagnoses)}
        counts = [[0] * len(self.diagnoses) for _ in self.labels]
        for o in self.runs_:
            counts[li[o.label]][dj[o.diagnosis]] += 1
        return tuple(tuple(r) for r in counts)

    def cases(self) -> tuple:
        """The case names in order of appearance."""
        seen = []
        for o in self.runs_:
            if o.case not in seen:
                seen.append(o.case)
        return tuple(seen)

    def case(self, name: str) -> "Metrics":
        """The metrics of one case's runs."""
        sel = tuple(o for o in self.runs_ if o.case == name)
        if not sel:
            raise UsageError(f"metrics: no case {name!r} (cases: {', '.join(self.cases())})")
        return Metrics(sel, self.labels, self.diagnoses, self.time_unit)

    # ---- tables
    def _summary_rows(self):
        rows = []
        for name in self.cases():
            m = self.case(name)
            med, mx = m.delay_stats()
            u = f" {self.time_unit}" if self.time_unit else ""
            rows.append((name, str(m.runs),
                         _fmt(1 - m.missed_detection_rate) if m.faulty_runs else "—",
                         _fmt(med, u), _fmt(mx, u),
                         f"{m.false_alarm_rate:.3g}", f"{m.false_alarm_runs}/{m.runs}",
                         _fmt(m.missed_detection_rate) if m.faulty_runs else "—",
                         f"{m.isolation_accuracy:.3g}"))
        return rows

    _HEAD = ("case", "runs", "detected", "median delay", "max delay", "false alarms / sample",
             "runs with false alarm", "missed", "isolation accuracy")

    def summary(self) -> str:
        """One line: runs, false alarms, missed detections, delays, isolation accuracy."""
        med, mx = self.delay_stats()
        u = f" {self.time_unit}" if self.time_unit else ""
        miss = f"{self.missed_detections}/{self.faulty_runs}" if self.faulty_runs else "—"
        return (f"{self.runs} runs: false alarms {self.false_alarm_samples} samples"
                f" (rate {self.false_alarm_rate:.3g}/sample, {self.false_alarm_runs} runs),"
                f" missed {miss}, delay median {_fmt(med, u)} max {_fmt(mx, u)},"
                f" isolation accuracy {self.isolation_accuracy:.3g}")

    def to_markdown(self) -> str:
        """A per-case table and the confusion matrix, as Markdown."""
        lines = ["| " + " | ".join(self._HEAD) + " |", "|" + "---|" * len(self._HEAD)]
        lines += ["| " + " | ".join(r) + " |" for r in self._summary_rows()]
        lines += ["", "Confusion matrix (rows: true label, columns: diagnosis at the end of"
                  " the run; runs):", ""]
        lines.append("| true \\ diagnosis | " + " | ".join(self.diagnoses) + " |")
        lines.append("|" + "---|" * (len(self.diagnoses) + 1))
        for l, row in zip(self.labels, self.confusion):
            if any(row):
                lines.append(f"| {l} | " + " | ".join(str(c) for c in row) + " |")
        return "\n".join(lines)

    def to_text(self) -> str:
        """The same tables as aligned plain text."""
        def table(head, rows):
            w = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
            fmt = lambda r: "  ".join(str(x).ljust(n) for x, n in zip(r, w)).rstrip()
            return [fmt(head), fmt(["-" * n for n in w])] + [fmt(r) for r in rows]
        out = table(self._HEAD, self._summary_rows())
        out += ["", "confusion matrix (rows: true label, columns: diagnosis at the end):"]
        rows = [(l,) + tuple(map(str, r)) for l, r in zip(self.labels, self.confusion) if any(r)]
        out += table(("true \\ diagnosis",) + self.diagnoses, rows)
        return "\n".join(out)

    def __str__(self) -> str:
        return self.to_text()


def _as_2d(v) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a[None, :] if a.ndim == 1 else a


def _fault_names(result, faults) -> tuple:
    out = tuple(faults)
    for f in out:
        try:
            result[f]
        except (KeyError, IndexError):
            raise UsageError(f"evaluate: the result has no fault column '{f}'") from None
    return out


def fault_onsets(result, faults: Sequence[str]) -> np.ndarray:
    """Per run, the index of the first sample where any of ``faults`` is nonzero, −1 when
    none is (shape (R,); R = 1 for a single run)."""
    faults = _fault_names(result, faults)
    t = _as_2d(result["t"])
    active = np.zeros(t.shape, dtype=bool)
    for f in faults:
        active |= _as_2d(result[f]) != 0
    first = np.argmax(active, axis=1)
    return np.where(active.any(axis=1), first, -1)


def true_labels(result, faults: Sequence[str]) -> tuple:
    """Per run, the faults nonzero somewhere in it joined by ``" and "``, or ``"no fault"``."""
    faults = _fault_names(result, faults)
    t = _as_2d(result["t"])
    on = [(_as_2d(result[f]) != 0).any(axis=1) for f in faults]
    labels = []
    for k in range(t.shape[0]):
        names = [f for f, a in zip(faults, on) if a[k]]
        labels.append(" and ".join(names) if names else NO_FAULT)
    return tuple(labels)


def evaluate_result(result, decisions, *, faults: Sequence[str] | None = None,
                    case: str | None = None) -> Metrics:
    """The :class:`Metrics` of one scenario result (one run or R runs) and the
    :class:`~observer_cad.residuals.Decisions` taken on it (:func:`decide`). ``faults``:
    the fault columns that define onset and label (default: the rule's faults);
    ``case``: the name the runs are listed under (default: the true label)."""
    rule: DecisionRule = decisions.rule
    faults = rule.faults if faults is None else tuple(faults)
    t = _as_2d(result["t"])
    R, N = t.shape
    alarm = np.asarray(decisions.alarm).reshape(R, N)
    diag = np.asarray(decisions.diagnosis, dtype=object).reshape(R, N)
    avail = np.ones((R, N), dtype=bool)
    for r in rule.residuals:
        avail &= np.isfinite(_as_2d(result[r]))
    onsets = fault_onsets(result, faults)
    labels = true_labels(result, faults)
    outcomes = []
    for k in range(R):
        on = int(onsets[k])
        if on < 0:
            fa, free, onset, delay = int(alarm[k].sum()), N, None, None
        else:
            fa, free = int(alarm[k, :on].sum()), on
            onset = float(t[k, on])
            hit = np.flatnonzero(alarm[k, on:])
            delay = float(t[k, on + hit[0]] - t[k, on]) if hit.size else None
        last = np.flatnonzero(avail[k])
        end = int(last[-1]) if last.size else N - 1
        outcomes.append(RunOutcome(case=case or labels[k], label=labels[k], onset=onset,
                                   delay=delay, false_alarm_samples=fa, fault_free_samples=free,
                                   diagnosis=str(diag[k, end])))
    time = getattr(result, "time", None)
    unit = "s" if time == "continuous" else ("steps" if time == "discrete" else "")
    label_order = (NO_FAULT,) + tuple(faults)
    label_order += tuple(sorted({o.label for o in outcomes} - set(label_order)))
    diag_order = rule.diagnoses()
    if UNKNOWN_PATTERN not in diag_order:
        diag_order += (UNKNOWN_PATTERN,)
    diag_order += tuple(sorted({o.diagnosis for o in outcomes} - set(diag_order)))
    return Metrics(tuple(outcomes), label_order, diag_order, unit)


@dataclasses.dataclass(frozen=True)
class FaultCase:
    """One fault of the ensemble: ``fault`` steps from 0 to the constant ``size`` at time
    ``onset`` (in the model's time: seconds, or steps for a discrete model); the other
    faults are zero."""

    fault: str
    size: float
    onset: float

    def __post_init__(self):
        if not isinstance(self.fault, str):
            raise UsageError(f"fault case: the fault must be a name, got {self.fault!r}")
        for key in ("size", "onset"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v):
                raise UsageError(f"fault case {self.fault}: {key} must be a finite number, got {v!r}")
        if self.size == 0:
            raise UsageError(f"fault case {self.fault}: size 0 is the fault-free case")
        object.__setattr__(self, "size", float(self.size))
        object.__setattr__(self, "onset", float(self.onset))

    @property
    def name(self) -> str:
        return f"{self.fault} = {self.size:g} from t = {self.onset:g}"
