"""The reference run of an exported monitor on recorded inputs, and comparisons of runs.

    ref = reference_run(obs, columns, dt=0.01, rule=rule)    # per sample: states, outputs,
                                                             # <r>_alarm, alarm, diagnosis_code
    got = fmu_samples(result, fmu)      # FMPy's simulate_fmu result, aligned to the samples
                                        # (fmu: the FmuExport, or the path of the .fmu)
    got = read_csv_columns("out.csv")   # or a CSV: the C example's, a monitor's
    cmp = compare_columns(ref, got)     # signals to 1e-12 (relative to max(1, |ref|)),
    assert cmp.ok, cmp.summary()        # alarms and codes exactly

:func:`reference_run` is the discrete algorithm of the exported C example and of the FMU:
the step function :func:`~observer_cad.codegen.observer_step` (RK4 or exact ZOH of step
``dt`` in continuous time; one sample in discrete time — casadi's interpreter, the same
expression graph the C is generated from) stepped over the rows from the export's
initial state, outputs at the state before each step, then the decision rule
(:func:`~observer_cad.residuals.decide`) over the whole run. :func:`compare_columns`
compares any two such column sets (e.g. the FMU's, the C example's CSV, a monitor's).
"""
from __future__ import annotations

import csv
import dataclasses
from pathlib import Path
from typing import Mapping

import casadi as ca
import numpy as np

from ..errors import UsageError
from ..observers import Observer
from ..residuals import DecisionRule, decide
from ._export import export_sources
from ._translate import observer_step, split_signals

__all__ = ["reference_run", "fmu_samples", "compare_columns", "ColumnComparison",
           "DECISION_COLUMNS", "read_csv_columns"]

#: columns compared exactly besides ``<r>_alarm``
DECISION_COLUMNS = ("alarm", "diagnosis_code")


def _column(columns: Mapping, name: str, n: int | None) -> np.ndarray:
    if name not in columns:
        raise UsageError(f"reference run: no column '{name}' in the inputs"
                         f" ({', '.join(map(str, columns)) or 'none'})")
    a = np.asarray(columns[name], dtype=float).reshape(-1)
    if n is not None and a.size != n:
        raise UsageError(f"reference run: column '{name}' has {a.size} rows, expected {n}")
    return a


#: samples per call of the accumulated step function (its build time grows with it)
_CHUNK = 1024


def _steps(f, x, V, ny: int, pv, nout: int) -> tuple:
    """States before each step and outputs, (n, nx) and (n, nout): ``f`` stepped over the
    rows of ``V`` from ``x`` — casadi's ``mapaccum`` of ``f`` over chunks of rows, the
    same operations as one call per row (bit for bit), without a Python loop per row."""
    n = V.shape[0]
    xs, outs = np.empty((n, x.size)), np.empty((n, nout))
    chains = {}
    k = 0
    while k < n:
        m = min(_CHUNK, n - k)
        F = chains.get(m) or chains.setdefault(m, f.mapaccum(f"{f.name()}_acc", m))
        X, O = F(ca.DM(x), ca.DM(V[k:k + m, :ny].T), ca.DM(V[k:k + m, ny:].T),
                 ca.DM(np.tile(pv.reshape(-1, 1), (1, m))))
        X = np.asarray(X, dtype=float).reshape(x.size, m)
        xs[k] = x
        xs[k + 1:k + m] = X[:, :-1].T
        outs[k:k + m] = np.asarray(O, dtype=float).reshape(nout, m).T
        x = X[:, -1]
        k += m
    return xs, outs


def reference_run(observer: Observer, columns: Mapping, *, dt: float | None = None,
                  initial: Mapping | None = None, discretisation: str = "rk4",
                  rule: DecisionRule | None = None, parameters: Mapping | None = None,
                  x0=None) -> dict:
    """The monitor stepped over the rows of ``columns`` (name → array: the observer's
    signals ``y…``, ``u…`` and, with a rule whose thresholds are not outputs, the
    threshold columns). Returns name → array per sample: the observer states (before
    the step), its outputs and, with ``rule``, ``<r>_alarm``, ``alarm`` (bool) and
    ``diagnosis_code`` (int). ``dt``, ``initial``, ``discretisation`` as for
    :func:`~observer_cad.codegen.export_observer`; ``parameters``: values overriding the
    observer's parameters (name → value); ``x0``: the initial state (default: the
    export's ``NAME_x0``)."""
    if observer.time == "discrete":
        dt = None
    elif dt is None:
        raise UsageError("reference run: a continuous-time observer needs dt")
    if x0 is None:
        x0 = export_sources(observer, dt=dt, initial=initial,
                            discretisation=discretisation).x0
    f = observer_step(observer, h=dt, discretisation=discretisation)
    ys, us = split_signals(observer)
    sig = [str(s) for s in ys + us]
    n = _column(columns, sig[0], None).size if sig else len(next(iter(columns.values())))
    V = np.stack([_column(columns, s, n) for s in sig], axis=1) if sig else np.zeros((n, 0))
    p = {str(k): float(v) for k, v in observer.parameters.items()}
    for k, v in (parameters or {}).items():
        if str(k) not in p:
            raise UsageError(f"reference run: '{k}' is not a parameter of {observer.name}")
        p[str(k)] = float(v)
    pv = np.array(list(p.values()), dtype=float)
    xs, outs = _steps(f, np.array(x0, dtype=float).reshape(-1), V, len(ys), pv,
                      len(observer.output_names))
    res = {str(s): xs[:, i] for i, s in enumerate(observer.states)}
    res.update({o: outs[:, i] for i, o in enumerate(observer.output_names)})
    if rule is not None:
        cols = dict(res)
        for c in rule.lower_names + rule.upper_names:
            if c not in cols:
                cols[c] = _column(columns, c, n)
        d = decide(rule, cols)
        for r, a in zip(rule.residuals, d.alarms):
            res[f"{r}_alarm"] = np.asarray(a, dtype=bool)
        res["alarm"] = np.asarray(d.alarm, dtype=bool)
        res["diagnosis_code"] = np.asarray(d.code, dtype=np.int64)
        res["diagnosis"] = np.asarray(d.diagnosis, dtype=str)
    return res


def _fmu_outputs(fmu) -> list:
    """``(FMI name, observer name, type)`` of the FMU's outputs: from an
    :class:`FmuExport`, or read from the ``modelDescription.xml`` of an ``.fmu`` file
    (FMI 2.0 or 3.0; then the observer name is the FMI name)."""
    if hasattr(fmu, "outputs"):
        return [(v.name, v.source, v.type) for v in fmu.outputs]
    import xml.etree.ElementTree as ET
    import zipfile
    try:
        with zipfile.ZipFile(fmu) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
    except (OSError, KeyError, zipfile.BadZipFile, ET.ParseError) as exc:
        raise UsageError(f"{fmu}: not an FMU with a readable modelDescription.xml"
                         f" ({type(exc).__name__})") from None
    kinds = {"Real": "Real", "Float64": "Real", "Float32": "Real", "Integer": "Integer",
             "Int32": "Integer", "Boolean": "Boolean"}
    out = []
    variables = root.find("ModelVariables")
    for v in (variables if variables is not None else []):
        if v.get("causality") != "output":
            continue
        tag = v.tag if v.tag != "ScalarVariable" else (v[0].tag if len(v) else "Real")
        out.append((v.get("name"), v.get("name"), kinds.get(tag, "Real")))
    return out


def fmu_samples(result, fmu, n: int | None = None) -> dict:
    """The outputs of an FMU run per sample, keyed by the observer's names: ``result``
    a structured array with a ``time`` field (FMPy's ``simulate_fmu``), recorded at the
    communication points ``t_start + k·Ts`` with one step per sample; ``fmu`` the
    :class:`FmuExport` or the path of the ``.fmu`` file. The outputs at
    ``t_start + (k+1)·Ts`` are those of sample ``k`` (one sample of latency), so row
    ``k + 1`` becomes sample ``k``; ``n`` samples (default all recorded)."""
    names = result.dtype.names
    out = {}
    rows = len(result) - 1
    n = rows if n is None else n
    if n > rows:
        raise UsageError(f"fmu_samples: {n} samples asked, the run recorded {rows}")
    for name, source, typ in _fmu_outputs(fmu):
        if name not in names:
            continue
        col = np.asarray(result[name][1:n + 1])
        if typ == "Boolean":
            col = col.astype(bool)
        elif typ == "Integer":
            col = col.astype(np.int64)
        else:
            col = col.astype(float)
        out[source] = col
    return out


@dataclasses.dataclass(frozen=True)
class ColumnComparison:
    """The comparison of two runs: ``columns`` compared, ``worst`` (name → largest
    scaled deviation, 0/1 for exact columns), ``mismatches`` (one line each, first
    sample that fails), ``missing`` (columns of the reference the candidate lacks)."""

    columns: tuple
    worst: Mapping
    mismatches: tuple
    missing: tuple
    tol: float

    @property
    def ok(self) -> bool:
        return not self.mismatches and not self.missing and bool(self.columns)

    def summary(self) -> str:
        if self.ok:
            return f"{len(self.columns)} columns equal (signals to {self.tol:g})"
        parts = list(self.mismatches)
        if self.missing:
            parts.append(f"missing: {', '.join(self.missing)}")
        if not self.columns:
            parts.append("no column in common")
        return "; ".join(parts)


def _show(v) -> str:
    return repr(v.item() if hasattr(v, "item") else v)


def _is_exact(name: str, a: np.ndarray, b: np.ndarray) -> bool:
    return name in DECISION_COLUMNS or name.endswith("_alarm") or a.dtype.kind in "biu"


def compare_columns(reference: Mapping, candidate: Mapping, *, columns=None,
                    tol: float = 1e-12, require_all: bool = False) -> ColumnComparison:
    """Compare ``candidate`` with ``reference`` (name → per-sample arrays, equal length
    per column): decision columns (``<r>_alarm``, ``alarm``, ``diagnosis_code``, integer
    or boolean arrays) exactly, the others to ``|a − b| <= tol·max(1, |a|)`` with NaN
    equal to NaN. ``columns``: the names to compare (default: those in both);
    ``require_all``: a reference column the candidate lacks is a mismatch."""
    names = list(columns) if columns is not None else [c for c in reference if c in candidate]
    missing = tuple(c for c in (columns if columns is not None else reference)
                    if c not in candidate) if (require_all or columns is not None) else ()
    worst, bad = {}, []
    for c in names:
        if c not in candidate or c not in reference:
            continue
        a, b = np.asarray(reference[c]), np.asarray(candidate[c])
        if a.shape != b.shape:
            bad.append(f"{c}: {b.shape[0] if b.ndim else 0} samples, reference"
                       f" {a.shape[0] if a.ndim else 0}")
            continue
        if a.dtype.kind in "USO" or b.dtype.kind in "USO":   # text, e.g. the diagnosis
            diff = a.astype(str) != b.astype(str)
            worst[c] = float(diff.any())
            if diff.any():
                k = int(np.argmax(diff))
                bad.append(f"{c}: sample {k}: {_show(b[k])}, reference {_show(a[k])}")
            continue
        if _is_exact(c, a, b):
            diff = a.astype(np.int64) != b.astype(np.int64)
            worst[c] = float(diff.any())
            if diff.any():
                k = int(np.argmax(diff))
                bad.append(f"{c}: sample {k}: {_show(b[k])}, reference {_show(a[k])}")
            continue
        a, b = a.astype(float), b.astype(float)
        both_nan = np.isnan(a) & np.isnan(b)
        with np.errstate(invalid="ignore"):
            dev = np.where(both_nan, 0.0, np.abs(a - b) / np.maximum(1.0, np.abs(a)))
        dev = np.where(np.isnan(dev), np.inf, dev)
        worst[c] = float(dev.max()) if dev.size else 0.0
        if worst[c] > tol:
            k = int(np.argmax(dev > tol))
            bad.append(f"{c}: sample {k}: {_show(b[k])}, reference {_show(a[k])}")
    return ColumnComparison(tuple(c for c in names if c in worst), worst, tuple(bad),
                            missing, tol)


def _cell(text: str):
    t = text.strip()
    if t == "":
        return np.nan
    if t in ("True", "False", "true", "false"):
        return 1.0 if t[0] in "Tt" else 0.0
    return float(t)


def read_csv_columns(path) -> dict:
    """The columns of a CSV file with a header row (name → array, one entry per row):
    numbers as float (an empty cell NaN; True/False 1/0, as FMPy writes Booleans),
    a column with any other text as strings — e.g. the C example's output, FMPy's
    ``write_csv``, a monitor's CSV — for :func:`compare_columns`."""
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    if not rows:
        raise UsageError(f"{path}: empty CSV (no header row)")
    head, body = [h.strip() for h in rows[0]], [r for r in rows[1:] if any(c.strip() for c in r)]
    out = {}
    for i, name in enumerate(head):
        cells = [r[i] if i < len(r) else "" for r in body]
        try:
            out[name] = np.array([_cell(c) for c in cells], dtype=float)
        except ValueError:
            out[name] = np.array(cells, dtype=str)
    return out
