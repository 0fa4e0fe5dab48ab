"""Streaming statistics of an ensemble's per-run summaries.

The per-run summaries come from :mod:`observer_cad.simulation` (:func:`~observer_cad.simulation.monitors`
decides the :class:`~observer_cad.simulation.SummaryField` s, :func:`~observer_cad.simulation.summarise`
reduces a chunk of runs to :class:`~observer_cad.simulation.RunSummaries`);
:class:`EnsembleStatistics` collects them chunk by chunk, in any order, and gives per-run
rows (``summary.csv``, :class:`SummaryRow`), the worst runs (for replay) and the
:class:`Statistics` of the ensemble (per case and overall: :class:`GroupStatistics` of
:class:`FieldStatistics`).

Determinism: the stored values are ordered by run index before anything is computed, so
the results do not depend on the order of ``add``.

Quantiles are empirical (``numpy.quantile(..., method="inverted_cdf")``: the smallest
observed value v with F(v) ≥ q — an observed value, no interpolation, so ±inf is kept).
"""
from __future__ import annotations

import dataclasses
import json
import math
import numbers
from typing import Iterator, Mapping, NamedTuple

import numpy as np

from ..errors import UsageError
from ..simulation import Monitors, RunSummaries, SummaryField

__all__ = ["EnsembleStatistics", "FieldStatistics", "GroupStatistics", "Statistics",
           "SummaryRow", "DEFAULT_QUANTILES"]

#: the quantiles :class:`EnsembleStatistics` reports unless told otherwise
DEFAULT_QUANTILES = (0.01, 0.05, 0.5, 0.95, 0.99, 0.999)


class SummaryRow(NamedTuple):
    """One run's record for ``summary.csv``: its global index, case and values (in field
    order)."""

    run: int
    case: str
    values: tuple


@dataclasses.dataclass(frozen=True)
class FieldStatistics:
    """Statistics of one field over a group of runs.

    ``count``: runs; ``finite``: runs whose value is finite; ``undefined``: runs whose
    value is NaN (a time field whose event never happened); ``min``, ``max`` and
    ``quantiles`` ((q, value) pairs, empirical, ``inverted_cdf``) over the values that are
    not NaN (±inf included: a diverged run shows); ``mean`` and ``std`` (sample standard
    deviation, ddof = 1) over the finite values; ``worst_run``/``worst_value``: the
    worst run (:meth:`EnsembleStatistics.worst`; None/NaN when every run is finite and
    its value NaN — no run had the event — or when every run is finite with the same
    value: no run differs); ``positive``/``positive_fraction``: for
    ``count`` fields, the runs with a value > 0 and their fraction of ``count`` (else
    None); ``histogram``: for ``code`` fields, (value, runs) pairs (else None). NaN where
    a statistic has no value.
    """

    field: SummaryField
    count: int
    finite: int
    undefined: int
    min: float
    max: float
    mean: float
    std: float
    quantiles: tuple
    worst_run: int | None
    worst_value: float
    positive: int | None = None
    positive_fraction: float | None = None
    histogram: tuple | None = None

    def quantile(self, q: float) -> float:
        for qq, v in self.quantiles:
            if qq == q:
                return v
        raise UsageError(f"statistics of {self.field.name}: quantile {q} was not computed"
                         f" (quantiles: {', '.join(str(qq) for qq, _ in self.quantiles)})")

    def to_json(self) -> dict:
        out = {"count": self.count, "finite": self.finite, "undefined": self.undefined,
               "min": _js(self.min), "max": _js(self.max), "mean": _js(self.mean),
               "std": _js(self.std),
               "quantiles": {repr(q): _js(v) for q, v in self.quantiles},
               "worst_run": self.worst_run, "worst_value": _js(self.worst_value)}
        if self.positive is not None:
            out["positive"] = self.positive
            out["positive_fraction"] = _js(self.positive_fraction)
        if self.histogram is not None:
            out["histogram"] = {str(int(v)) if math.isfinite(v) else "null": n
                                for v, n in self.histogram}
        return out


@dataclasses.dataclass(frozen=True)
class GroupStatistics:
    """The statistics of a group of runs (one case, or all): ``runs``, ``nonfinite``
    (runs that are not finite, when a ``finite`` field exists, else 0) and ``fields``
    (name → :class:`FieldStatistics`)."""

    runs: int
    nonfinite: int
    fields: Mapping

    def __getitem__(self, name: str) -> FieldStatistics:
        return self.fields[name]

    def to_json(self) -> dict:
        return {"runs": self.runs, "nonfinite": self.nonfinite,
                "fields": {k: v.to_json() for k, v in self.fields.items()}}


_JSON_NOTE = ("null stands for a value that is NaN (undefined: e.g. a time of a first event"
              " that never happened, a statistic of no value) or ±inf (a run that is not"
              " finite makes its error fields +inf and min_slack −inf)")


def _js(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def _fmt(v) -> str:
    if v is None:
        return "-"
    v = float(v)
    if math.isnan(v):
        return "nan"
    return f"{v:.4g}"


@dataclasses.dataclass(frozen=True)
class Statistics:
    """The statistics of an ensemble: ``fields``, ``quantiles``, ``overall`` (all runs)
    and ``cases`` (case name → :class:`GroupStatistics`, in the order of each case's
    smallest run index). Independent of the order in which chunks were added."""

    fields: tuple
    quantiles: tuple
    overall: GroupStatistics
    cases: Mapping

    def to_json(self) -> dict:
        """JSON-safe (NaN and ±inf are null: see ``note``)."""
        return {"note": _JSON_NOTE, "quantiles": list(self.quantiles),
                "fields": {f.name: f.to_json() for f in self.fields},
                "overall": self.overall.to_json(),
                "cases": {c: g.to_json() for c, g in self.cases.items()}}

    def to_text(self) -> str:
        """A short table per group (all runs, then each case when there are several)."""
        qs = [q for q in self.quantiles if q in (0.5, 0.99, 0.999)] or list(self.quantiles)[-1:]
        head = ["field", "unit", "finite/runs", "mean", "min"] + [f"q{q:g}" for q in qs] + \
            ["max", "worst run", "> 0"]
        groups = [("all runs", self.overall)]
        if len(self.cases) > 1:
            groups += [(f"case {c}", g) for c, g in self.cases.items()]
        out = []
        for title, g in groups:
            out.append(f"{title}: {g.runs} runs" + (f", {g.nonfinite} not finite"
                                                     if g.nonfinite else ""))
            rows = [head]
            for f in self.fields:
                s = g.fields[f.name]
                qv = dict(s.quantiles)
                pos = ("-" if s.positive is None else
                       f"{s.positive} ({100 * s.positive_fraction:.3g} %)")
                rows.append([f.name, f.unit or "", f"{s.finite}/{s.count}", _fmt(s.mean),
                             _fmt(s.min)] + [_fmt(qv[q]) for q in qs] +
                            [_fmt(s.max), "-" if s.worst_run is None else str(s.worst_run), pos])
            widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
            for r in rows:
                out.append("  " + "  ".join(c.ljust(w) if i < 2 else c.rjust(w)
                                            for i, (c, w) in enumerate(zip(r, widths))).rstrip())
            out.append("")
        return "\n".join(out).rstrip() + "\n"

    def dumps(self) -> str:
        return json.dumps(self.to_json(), indent=2, allow_nan=False)


def _rank_order(values: np.ndarray, worse: str, runs: np.ndarray, broken: np.ndarray) -> np.ndarray:
    """Indices from worst to best: runs that are not finite first, then by value in the
    field's worse direction, NaN (undefined) last; ties → lower run index."""
    v = np.where(np.isnan(values), 0.0, -values if worse == "max" else values)
    group = np.where(broken, 0, np.where(np.isnan(values), 2, 1))
    return np.lexsort((runs, v, group))


class EnsembleStatistics:
    """Streaming accumulator of per-run summaries (memory O(runs × fields)).

    ``EnsembleStatistics(fields, quantiles=...)`` with the :class:`SummaryField` s (or a
    :class:`Monitors`); :meth:`add` each chunk's :class:`RunSummaries` with its global run
    indices and case name, in any order; then :meth:`rows`, :meth:`worst` and
    :meth:`result`, which do not depend on the order of the ``add`` calls (values are
    ordered by run index first). A run index may be added once.
    """

    def __init__(self, fields, *, quantiles=DEFAULT_QUANTILES):
        if isinstance(fields, Monitors):
            fields = fields.fields
        fields = tuple(fields)
        for f in fields:
            if not isinstance(f, SummaryField):
                raise UsageError(f"EnsembleStatistics: fields must be SummaryField values,"
                                 f" got {type(f).__name__}")
        names = [f.name for f in fields]
        if len(set(names)) != len(names):
            raise UsageError("EnsembleStatistics: a field name appears twice")
        qs = []
        for q in quantiles:
            if isinstance(q, (bool, np.bool_)) or not isinstance(q, numbers.Real) \
                    or not 0 <= float(q) <= 1:
                raise UsageError(f"EnsembleStatistics: a quantile must be in [0, 1], got {q!r}")
            qs.append(float(q))
        self.fields = fields
        self.quantiles = tuple(qs)
        self._names = tuple(names)
        self._runs: list = []
        self._cases: list = []       # case index per chunk
        self._values: list = []
        self._case_names: list = []
        self._seen = np.zeros(0, dtype=bool)   # which run indices were added
        self._count = 0
        self._cache = None

    def add(self, runs, case: str, summaries) -> None:
        """Add the summaries of runs ``runs`` ((R,) global indices) of case ``case``;
        ``summaries``: a :class:`RunSummaries` (or a mapping field → (R,) values)."""
        if not isinstance(case, str) or not case:
            raise UsageError(f"EnsembleStatistics.add: case must be a non-empty name, got {case!r}")
        vals = summaries.values if isinstance(summaries, RunSummaries) else summaries
        if not isinstance(vals, Mapping):
            raise UsageError("EnsembleStatistics.add: summaries must be RunSummaries")
        r = np.asarray(runs)
        if r.ndim != 1 or (r.size and not np.issubdtype(r.dtype, np.integer)):
            raise UsageError(f"EnsembleStatistics.add: runs must be (R,) integers, got"
                             f" {r.dtype} of shape {r.shape}")
        r = r.astype(np.int64)
        if r.size and r.min() < 0:
            raise UsageError(f"EnsembleStatistics.add: run index {int(r.min())} is negative")
        missing = [n for n in self._names if n not in vals]
        if missing:
            raise UsageError(f"EnsembleStatistics.add: the summaries lack '{missing[0]}'")
        M = np.empty((r.size, len(self._names)), dtype=np.float64)
        for j, n in enumerate(self._names):
            v = np.asarray(vals[n], dtype=np.float64)
            if v.shape != r.shape:
                raise UsageError(f"EnsembleStatistics.add: '{n}' has shape {v.shape} for"
                                 f" {r.size} runs")
            M[:, j] = v
        if np.unique(r).size != r.size:
            raise UsageError("EnsembleStatistics.add: a run index appears twice in one chunk")
        if r.size:
            top = int(r.max()) + 1
            if top > self._seen.size:      # one byte per run index, grown geometrically
                grown = np.zeros(max(top, 2 * self._seen.size), dtype=bool)
                grown[:self._seen.size] = self._seen
                self._seen = grown
            again = r[self._seen[r]]
            if again.size:
                raise UsageError(f"EnsembleStatistics.add: run {int(again.min())} was added before")
            self._seen[r] = True
        self._count += int(r.size)
        if case not in self._case_names:
            self._case_names.append(case)
        self._runs.append(r)
        self._cases.append(np.full(r.size, self._case_names.index(case), dtype=np.int32))
        self._values.append(M)
        self._cache = None

    def __len__(self) -> int:
        return self._count

    @property
    def nbytes(self) -> int:
        """The bytes stored: per-run values, run indices, case indices, and one byte per
        run index up to the largest added (to refuse a run added twice)."""
        return self._seen.nbytes + sum(a.nbytes for part in (self._runs, self._cases,
                                                              self._values) for a in part)

    def _table(self):
        """(runs, case names, case index per run, values (n, F)), sorted by run; case
        names in the order of their smallest run index (independent of add order)."""
        if self._cache is None:
            if self._runs:
                runs = np.concatenate(self._runs)
                cidx = np.concatenate(self._cases)
                vals = np.concatenate(self._values)
            else:
                runs = np.zeros(0, np.int64)
                cidx = np.zeros(0, np.int32)
                vals = np.zeros((0, len(self._names)))
            order = np.argsort(runs, kind="stable")
            runs, cidx, vals = runs[order], cidx[order], vals[order]
            first = {}
            for k, c in enumerate(cidx.tolist()):
                first.setdefault(c, k)
            names_in_order = sorted(first, key=first.get)
            remap = np.zeros(len(self._case_names), dtype=np.int32)
            for new, old in enumerate(names_in_order):
                remap[old] = new
            cases = tuple(self._case_names[i] for i in names_in_order)
            self._cache = (runs, cases, remap[cidx] if cidx.size else cidx, vals)
        return self._cache

    def columns(self) -> dict:
        """``run`` (int64), ``case`` (object array of names) and every field (float64), all
        (n,) sorted by run index: the ``summary.csv`` table as arrays."""
        runs, cases, cidx, vals = self._table()
        out = {"run": runs, "case": np.array(cases, dtype=object)[cidx] if runs.size
               else np.zeros(0, dtype=object)}
        for j, n in enumerate(self._names):
            out[n] = vals[:, j]
        return out

    def rows(self) -> Iterator[SummaryRow]:
        """Per-run records (run, case, values in field order), sorted by run index."""
        runs, cases, cidx, vals = self._table()
        for k in range(runs.size):
            yield SummaryRow(int(runs[k]), cases[cidx[k]], tuple(vals[k].tolist()))

    def _field_index(self, field: str) -> int:
        if field not in self._names:
            raise UsageError(f"no summary field '{field}' (fields: {', '.join(self._names)})")
        return self._names.index(field)

    def _broken(self, vals: np.ndarray) -> np.ndarray:
        if "finite" in self._names:
            return ~(vals[:, self._names.index("finite")] == 1.0)
        return np.zeros(vals.shape[0], dtype=bool)

    def worst(self, field: str, k: int = 1, case: str | None = None) -> tuple:
        """The ``k`` worst run indices by ``field``: runs that are not finite first, then
        by value in the field's ``worse`` direction, NaN (an event that never happened)
        last; ties → lower run index. ``case``: only that case's runs."""
        j = self._field_index(field)
        if isinstance(k, (bool, np.bool_)) or not isinstance(k, numbers.Integral) or k < 1:
            raise UsageError(f"worst: k must be a whole number ≥ 1, got {k!r}")
        runs, cases, cidx, vals = self._table()
        if case is not None:
            if case not in cases:
                raise UsageError(f"worst: no case '{case}' (cases: {', '.join(cases)})")
            sel = cidx == cases.index(case)
            runs, vals = runs[sel], vals[sel]
        order = _rank_order(vals[:, j], self.fields[j].worse, runs, self._broken(vals))
        return tuple(int(i) for i in runs[order[:int(k)]])

    def _group(self, runs: np.ndarray, vals: np.ndarray) -> GroupStatistics:
        broken = self._broken(vals)
        out = {}
        for j, f in enumerate(self.fields):
            v = vals[:, j]
            n = v.size
            defined = v[~np.isnan(v)]
            fin = v[np.isfinite(v)]
            if defined.size:
                lo, hi = float(defined.min()), float(defined.max())
                qv = np.quantile(defined, self.quantiles, method="inverted_cdf") \
                    if self.quantiles else ()
                quant = tuple((q, float(x)) for q, x in zip(self.quantiles, qv))
            else:
                lo = hi = math.nan
                quant = tuple((q, math.nan) for q in self.quantiles)
            mean = float(np.mean(fin)) if fin.size else math.nan
            std = float(np.std(fin, ddof=1)) if fin.size > 1 else math.nan
            wr, wv = None, math.nan
            same = not broken.any() and defined.size == n and lo == hi
            if n and not same:  # no worst run where every run has the same value
                w = int(_rank_order(v, f.worse, runs, broken)[0])
                if broken[w] or not math.isnan(v[w]):   # else: no run had the event
                    wr, wv = int(runs[w]), float(v[w])
            pos = frac = hist = None
            if f.kind == "count":
                pos = int(np.count_nonzero(v > 0))
                frac = pos / n if n else math.nan
            if f.kind == "code":
                u, c = np.unique(v, return_counts=True)   # NaN last
                hist = tuple((float(a), int(b)) for a, b in zip(u, c))
            out[f.name] = FieldStatistics(
                field=f, count=n, finite=int(fin.size), undefined=int(n - defined.size),
                min=lo, max=hi, mean=mean, std=std, quantiles=quant, worst_run=wr,
                worst_value=wv, positive=pos, positive_fraction=frac, histogram=hist)
        return GroupStatistics(runs=int(runs.size), nonfinite=int(np.count_nonzero(broken)),
                               fields=out)

    def result(self) -> Statistics:
        """The :class:`Statistics` of the runs added so far (overall and per case)."""
        runs, cases, cidx, vals = self._table()
        by_case = {c: self._group(runs[cidx == i], vals[cidx == i]) for i, c in enumerate(cases)}
        return Statistics(fields=self.fields, quantiles=self.quantiles,
                          overall=self._group(runs, vals), cases=by_case)
