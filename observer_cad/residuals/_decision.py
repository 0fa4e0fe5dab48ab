"""Decisions on residuals: alarms with persistence and isolation by
matching the alarm pattern against the structure matrix.

A :class:`DecisionRule` names the residuals ``r_1 … r_m`` (the outputs of a residual
observer: ``r`` for one residual generator, ``r1 … rm`` for a
:class:`~observer_cad.synthesis.ResidualBank`), the faults ``f_1 … f_q`` (the columns of
the structure matrix S, m × q, S_ij = 1 when r_i responds to f_j) and the persistence
N ≥ 1. Each residual is compared with its threshold columns ``<r_i>_lower`` and
``<r_i>_upper`` (the band the fault-free residual stays in; produced by a threshold
step). :func:`decide` is the reference implementation; the C export
(:func:`observer_cad.codegen.export_observer` with ``rule=``) generates the same logic.

Semantics, per run and sample k:

1. residual i is *out* when r_i(k) < lower_i(k) or r_i(k) > upper_i(k) (strict: a value
   on the boundary is in). A NaN residual or bound (a delayed output not available yet)
   compares false: *not out*;
2. a counter c_i(k) = c_i(k−1) + 1 while out, else 0 (c_i(−1) = 0);
3. alarm_i(k) = c_i(k) ≥ N, and ``alarm`` = any alarm_i: residual i alarms from the
   N-th consecutive out sample of a run of outs until the first sample back in;
4. the alarm pattern p = (alarm_1, …, alarm_m) is matched against the COLUMNS of S:
   no alarm → ``"no fault"``; else the faults whose column equals p exactly, in the
   rule's fault order, joined by ``" or "`` (``"f2"``, ``"f1 or f2"`` when columns are
   identical, i.e. the faults are not isolable); no column equals p →
   ``"unknown pattern"``. A residual that sees a fault only as a transient (zero
   steady-state gain) returns into its band while the fault persists: the rule's
   ``steady`` rows (the strong structure matrix, 0 there) give the pattern the fault
   leaves afterwards, and a fault matches when either of its columns equals p;
5. the diagnosis *code* is the pattern as bits, Σ_i alarm_i 2^(i−1) (residual 1 is bit
   0), an integer 0 … 2^m − 1; :meth:`DecisionRule.table` maps every code to its text
   (the C export carries the same table).

References: Gertler, *Fault Detection and Diagnosis in Engineering Systems* (1998), ch. 6
(structured residuals, column matching); Blanke et al., *Diagnosis and Fault-Tolerant
Control* (2016), §6.7 (persistence / N-out-of-N decision logic).
"""
from __future__ import annotations

import dataclasses
import functools
import numbers
from typing import Mapping

import numpy as np

from ..errors import UsageError
from ..synthesis import Design
from ..analysis import ResidualBank

__all__ = ["DecisionRule", "Decisions", "decision_rule", "decide", "NO_FAULT",
           "UNKNOWN_PATTERN", "MAX_RESIDUALS"]

#: diagnosis when no residual alarms
NO_FAULT = "no fault"
#: diagnosis when the alarm pattern equals no column of the structure matrix
UNKNOWN_PATTERN = "unknown pattern"
#: the diagnosis code must fit a C ``int``: at most this many residuals
MAX_RESIDUALS = 30


def _names(what: str, names) -> tuple:
    if isinstance(names, str) or not isinstance(names, (tuple, list)):
        raise UsageError(f"decision rule: {what} must be a sequence of names, got {names!r}")
    out = tuple(names)
    if not out:
        raise UsageError(f"decision rule: {what} is empty")
    for n in out:
        if not isinstance(n, str) or not n:
            raise UsageError(f"decision rule: {what}: a name must be non-empty text, got {n!r}")
    seen = set()
    for n in out:
        if n in seen:
            raise UsageError(f"decision rule: {what}: {n!r} appears twice")
        seen.add(n)
    return out


def _rows(what: str, table, res, faults) -> tuple:
    """Validated 0/1 rows, one per residual, one entry per fault."""
    if isinstance(table, str) or not isinstance(table, (tuple, list)):
        raise UsageError(f"decision rule: {what} must be rows of 0/1, one per residual")
    if len(table) != len(res):
        raise UsageError(f"decision rule: {what} has {len(table)} rows but there"
                         f" are {len(res)} residuals ({', '.join(res)})")
    rows = []
    for name, row in zip(res, table):
        if isinstance(row, str) or not isinstance(row, (tuple, list)) or len(row) != len(faults):
            raise UsageError(f"decision rule: the row of {name} must have {len(faults)} entries"
                             f" 0/1 (one per fault: {', '.join(faults)}), got {row!r}")
        cells = []
        for c in row:
            if isinstance(c, (bool, np.bool_)) or c not in (0, 1):
                raise UsageError(f"decision rule: the row of {name} has {c!r}; entries are 0 or 1")
            cells.append(int(c))
        rows.append(tuple(cells))
    return tuple(rows)


@dataclasses.dataclass(frozen=True)
class DecisionRule:
    """Residual names, fault names, structure matrix (rows = residuals, columns = faults,
    entries 0/1) and persistence N ≥ 1; see the module docstring for the semantics.
    Invalid values raise a one-line :class:`~observer_cad.errors.UsageError`."""

    residuals: tuple
    faults: tuple
    structure: tuple
    persistence: int = 1
    #: the columns a constant fault leaves once its transient has passed (0 where the
    #: residual sees the fault only as a transient: zero steady-state gain); () = structure
    steady: tuple = ()

    def __post_init__(self):
        res = _names("residuals", self.residuals)
        faults = _names("faults", self.faults)
        if len(res) > MAX_RESIDUALS:
            raise UsageError(f"decision rule: {len(res)} residuals; at most {MAX_RESIDUALS}"
                             " (the diagnosis code is an int of one bit per residual)")
        rows = _rows("structure", self.structure, res, faults)
        steady = _rows("steady", self.steady, res, faults) if len(self.steady) else ()
        p = self.persistence
        if isinstance(p, (bool, np.bool_)) or not isinstance(p, numbers.Integral) or p < 1:
            raise UsageError(f"decision rule: persistence must be a whole number ≥ 1, got {p!r}")
        object.__setattr__(self, "residuals", res)
        object.__setattr__(self, "faults", faults)
        object.__setattr__(self, "structure", rows)
        object.__setattr__(self, "steady", () if steady == rows else steady)
        object.__setattr__(self, "persistence", int(p))

    @property
    def lower_names(self) -> tuple:
        """The lower threshold columns, ``<r_i>_lower``."""
        return tuple(f"{r}_lower" for r in self.residuals)

    @property
    def upper_names(self) -> tuple:
        """The upper threshold columns, ``<r_i>_upper``."""
        return tuple(f"{r}_upper" for r in self.residuals)

    @property
    def codes(self) -> int:
        """The number of diagnosis codes, 2^m."""
        return 1 << len(self.residuals)

    def column(self, fault: str) -> tuple:
        """The alarm pattern fault ``fault`` produces (its column of the structure)."""
        if fault not in self.faults:
            raise UsageError(f"decision rule: {fault!r} is not one of its faults"
                             f" ({', '.join(self.faults)})")
        j = self.faults.index(fault)
        return tuple(row[j] for row in self.structure)

    def steady_column(self, fault: str) -> tuple:
        """The alarm pattern fault ``fault`` leaves after its transient (its column of
        ``steady``; its structure column when the rule has no steady rows)."""
        if not self.steady:
            return self.column(fault)
        j = self.faults.index(fault)
        return tuple(row[j] for row in self.steady)

    def diagnosis(self, code: int) -> str:
        """The text of a diagnosis code (see the module docstring, step 4)."""
        code = int(code)
        if not 0 <= code < self.codes:
            raise UsageError(f"decision rule: diagnosis code {code} outside 0 … {self.codes - 1}")
        if code == 0:
            return NO_FAULT
        pattern = tuple((code >> i) & 1 for i in range(len(self.residuals)))
        match = [f for f in self.faults
                 if self.column(f) == pattern or self.steady_column(f) == pattern]
        return " or ".join(match) if match else UNKNOWN_PATTERN

    def table(self) -> tuple:
        """The diagnosis text of every code 0 … 2^m − 1 (2^m entries: for the C export,
        which takes at most 16 residuals)."""
        return tuple(self.diagnosis(c) for c in range(self.codes))

    def diagnoses(self) -> tuple:
        """Every diagnosis text the rule can give, each once: ``"no fault"``, the fault
        texts in the order of the faults, ``"unknown pattern"`` (when some code gives it)."""
        out = [NO_FAULT]
        patterns = set()
        for f in self.faults:
            for col in dict.fromkeys((self.column(f), self.steady_column(f))):
                if any(col):
                    code = sum(b << i for i, b in enumerate(col))
                    patterns.add(code)
                    text = self.diagnosis(code)
                    if text not in out:
                        out.append(text)
        if len(patterns) < self.codes - 1:   # some nonzero pattern is no fault's column
            out.append(UNKNOWN_PATTERN)
        return tuple(out)

    def describe(self) -> str:
        rows = ", ".join("".join(map(str, r)) for r in self.structure)
        steady = (" (after a fault's transient: " + ", ".join("".join(map(str, r))
                                                            for r in self.steady) + ")"
                  if self.steady else "")
        return (f"alarm when a residual of ({', '.join(self.residuals)}) leaves its threshold"
                f" for {self.persistence} consecutive sample(s); isolation by the columns of"
                f" {rows}{steady} over ({', '.join(self.faults)})")


@dataclasses.dataclass(frozen=True, eq=False)
class Decisions:
    """What :func:`decide` finds, arrays of shape (N,) or (R, N) like the residuals.

    ``out``: per residual, the samples outside the threshold; ``alarms``: per residual,
    alarm_i (bool); ``alarm``: any alarm; ``code``: the diagnosis code (int64);
    ``diagnosis``: its text (object array of str); ``rule``: the rule applied.
    """

    rule: DecisionRule
    out: tuple
    alarms: tuple
    alarm: np.ndarray
    code: np.ndarray

    @functools.cached_property
    def diagnosis(self) -> np.ndarray:
        """The text of every code (object array of str; built on first use)."""
        codes, inverse = np.unique(self.code, return_inverse=True)
        texts = np.array([self.rule.diagnosis(c) for c in codes.tolist()], dtype=object)
        return texts[inverse.reshape(self.code.shape)]

    def alarm_of(self, residual: str) -> np.ndarray:
        """alarm_i of the residual named ``residual``."""
        if residual not in self.rule.residuals:
            raise UsageError(f"decisions: no residual {residual!r} (residuals:"
                             f" {', '.join(self.rule.residuals)})")
        return self.alarms[self.rule.residuals.index(residual)]

    def columns(self) -> dict:
        """``r_i_alarm`` (0/1 per residual), ``alarm`` (0/1), ``diagnosis_code`` and
        ``diagnosis`` (text) as arrays by name."""
        cols = {f"{r}_alarm": a.astype(np.int64) for r, a in zip(self.rule.residuals, self.alarms)}
        cols["alarm"] = self.alarm.astype(np.int64)
        cols["diagnosis_code"] = self.code
        cols["diagnosis"] = self.diagnosis
        return cols


def _column(columns, name: str, rule: DecisionRule) -> np.ndarray:
    try:
        v = columns[name]
    except (KeyError, IndexError, TypeError):
        v = None
    if v is None:
        hint = (" (add a threshold: its columns are <r>_lower and <r>_upper)"
                if name.endswith(("_lower", "_upper")) else "")
        raise UsageError(f"decide: no column '{name}' for the rule over"
                         f" ({', '.join(rule.residuals)}){hint}")
    a = np.asarray(v, dtype=float)
    if a.ndim not in (1, 2):
        raise UsageError(f"decide: column '{name}' must have shape (N,) or (R, N), got {a.shape}")
    return a


def decide(rule: DecisionRule, columns: Mapping) -> Decisions:
    """Apply ``rule`` to residual and threshold columns.

    ``columns`` maps names to arrays of shape (N,) or (R, N) — a
    :class:`~observer_cad.simulation.SimulationResult` works — and must hold every
    residual ``r_i`` and its ``r_i_lower``, ``r_i_upper``. Vectorised over runs and time
    (no Python loop over samples). Semantics: see the module docstring.
    """
    if not isinstance(rule, DecisionRule):
        raise UsageError(f"decide needs a DecisionRule, not a {type(rule).__name__}")
    r = [_column(columns, n, rule) for n in rule.residuals]
    lo = [_column(columns, n, rule) for n in rule.lower_names]
    hi = [_column(columns, n, rule) for n in rule.upper_names]
    shape = r[0].shape
    for name, a in zip(rule.residuals + rule.lower_names + rule.upper_names, r + lo + hi):
        if a.shape != shape:
            raise UsageError(f"decide: column '{name}' has shape {a.shape}, but"
                             f" '{rule.residuals[0]}' has {shape}")
    n = shape[-1]
    idx = np.arange(n, dtype=np.int32 if n < 2 ** 31 - 1 else np.int64)
    outs, alarms = [], []
    code = np.zeros(shape, dtype=np.int64)
    for i, (ri, li, hi_) in enumerate(zip(r, lo, hi)):
        with np.errstate(invalid="ignore"):   # NaN compares false: not out
            out = (ri < li) | (ri > hi_)
        if rule.persistence == 1:
            alarm = out
        else:
            # run length of consecutive outs ending at each sample: k − (last k' ≤ k not out)
            last_in = np.where(out, -1, idx)
            np.maximum.accumulate(last_in, axis=-1, out=last_in)
            alarm = (idx - last_in) >= rule.persistence
        outs.append(out)
        alarms.append(alarm)
        code |= np.left_shift(alarm, i, dtype=np.int64)
    return Decisions(rule=rule, out=tuple(outs), alarms=tuple(alarms),
                     alarm=code != 0, code=code)


def decision_rule(model, design_or_bank, *, persistence: int = 1) -> DecisionRule:
    """The rule of a residual observer: for a
    :class:`~observer_cad.synthesis.ResidualBank`, residuals ``r1 … rm``, its ``faults``
    and ``structure_matrix``; for a single residual generator
    (:class:`~observer_cad.synthesis.Design` with a residual), residual ``r`` and the one
    row of its fault signature over ``model.faults`` (1 = the residual responds)."""
    if isinstance(design_or_bank, ResidualBank):
        b = design_or_bank
        return DecisionRule(residuals=tuple(f"r{i}" for i in range(1, len(b.structure_matrix) + 1)),
                            faults=tuple(b.faults), structure=tuple(b.structure_matrix),
                            persistence=persistence, steady=tuple(b.strong_structure))
    if isinstance(design_or_bank, Design):
        d = design_or_bank
        if "r" not in dict(d.outputs or ()):
            raise UsageError(f"decision_rule: the {d.observer} design has no residual r; use a"
                             " diagnostic design or a residual bank")
        sig = d.signature_map
        sig = sig() if callable(sig) else sig
        faults = tuple(s.name for s in model.faults)
        if not faults:
            raise UsageError(f"decision_rule: {model.name} declares no faults to diagnose")
        missing = [f for f in faults if f not in sig]
        if missing:
            raise UsageError(f"decision_rule: the design's fault signature lacks {missing[0]}")
        full = d.signature or d.with_signature().signature
        transient = {s.name for s in (full or ()) if getattr(s, "transient_only", False)}
        return DecisionRule(residuals=("r",), faults=faults,
                            structure=(tuple(int(bool(sig[f])) for f in faults),),
                            persistence=persistence,
                            steady=(tuple(int(bool(sig[f]) and f not in transient)
                                          for f in faults),))
    raise UsageError(f"decision_rule takes a Design with a residual or a ResidualBank, not a"
                     f" {type(design_or_bank).__name__}")
