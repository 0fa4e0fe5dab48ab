"""Isolating residual banks: several certified minimal-order residual generators whose
fault signatures, stacked, form a structure matrix S — one row per residual, one column
per fault, S_ij = 1 when residual i responds to fault j.

Each row is one Jordan-form diagnostic design (METHOD §2b; :func:`design` with
``form="jordan"``): the faults marked 1 are its targets (every one seen by the residual),
the faults marked 0 are decoupled exactly (Φ D_j = 0, as the model's disturbances are).
After synthesis every residual's realised row is recomputed from the structure,
O Φ D_j for every column (:func:`fault_sensitivity`), and must equal the requested row.

Without a requested structure the bank prefers rows that isolate *strongly*: a row is
*strongly realised* when its residual sees every fault it responds to with a nonzero
steady-state gain (:func:`~observer_cad.synthesis.certificates.steady_state_gain`, at
s = 0 or z = 1; a fault with a zero gain is seen only as a transient, Varga 2017, Ch. 3).
The bank takes the first of

1. the *generalised observer scheme* (GOS) with every row strongly realised: residual i
   decoupled from fault i only and sensitive to all the others — every pair of faults
   isolable (for each pair a residual sees one and not the other), single faults isolated;
2. the *dedicated observer scheme* (DOS) with every row strongly realised: residual i
   sensitive to fault i only;
3. the *best achievable* strongly realised rows: every nonzero row is tried (for more than
   :data:`FULL_SEARCH_FAULTS` faults, only rows with one zero, rows with one one, the
   all-ones row and the rows of the strong structure matrix of :func:`analyze` at
   ω = 0), and rows are added greedily, each time the one that tells apart the
   most further pairs of faults (then detects the most further faults; ties: fewer
   residual states), until no row improves the bank;
4. only when no achievable row is strongly realised: the same three steps with rows seen
   partly as transients (the choice says so), the best-achievable search (without the
   analysis's rows) scoring the strongly isolated pairs first, then the pairs isolated
   at all.

A pair of faults is *isolable* by the bank when both are detected (their columns are
nonzero) and their columns differ (some residual responds to one and not the other); it
is *strongly isolable* when the same holds for the columns of the *strong structure
matrix* (:attr:`ResidualBank.strong_structure`: 1 only where the residual responds with
a nonzero steady-state gain).

References: the structure matrices of Gertler's residual structuring and of Varga's
FaultDetectionTools.jl (``efdisyn``); seed 002 Remark 1 (one residual per fault set).
"""
from __future__ import annotations

import dataclasses
import itertools
from typing import Sequence

from ..errors import InfeasibleDesignError, ModelError, ObserverCadError, UsageError
from ..model import PlantModel
from ..synthesis import Design
from ._diagnosability import analyze
from ..synthesis import design
from ..synthesis import fault_sensitivity

__all__ = ["ResidualBank", "design_bank", "parse_structure", "realised_row", "strong_row",
           "strongly_realised", "FULL_SEARCH_FAULTS"]

#: Up to this many faults the best-achievable search tries every nonzero row (2^m − 1).
FULL_SEARCH_FAULTS = 4

GOS = "generalised observer scheme"
DOS = "dedicated observer scheme"
REQUESTED = "requested structure"
BEST = "best achievable"


def parse_structure(text, faults: Sequence[str], what: str = "--structure") -> tuple:
    """Rows like ``"110,101,011"`` (or a list of such strings / of 0-1 sequences) →
    a tuple of 0/1 tuples, one entry per fault. ``what`` names the source in messages."""
    m = len(faults)
    if isinstance(text, str):
        items = [t.strip() for t in text.replace(";", ",").split(",") if t.strip()]
    else:
        items = list(text)
    if not items:
        raise UsageError(f"{what} needs at least one row, e.g. 110,101,011")
    rows = []
    for i, item in enumerate(items, 1):
        cells = list(item) if isinstance(item, str) else list(item)
        try:
            row = tuple(int(c) for c in cells)
        except (TypeError, ValueError):
            row = ()
        if len(row) != m or any(c not in (0, 1) for c in row):
            raise UsageError(f"{what} row {i} {item!r}: give {m} digits 0/1, one per fault"
                             f" ({', '.join(faults)})")
        if not any(row):
            raise UsageError(f"{what} row {i} {item!r} is all zeros: a residual that sees"
                             " no fault detects nothing")
        if row in rows:
            raise UsageError(f"{what} row {i} {item!r} repeats row {rows.index(row) + 1}:"
                             " a second residual with the same signature adds nothing")
        rows.append(row)
    return tuple(rows)


def _row_text(row) -> str:
    return "".join(str(int(c)) for c in row)


def _describe_row(row, faults) -> str:
    on = [f for f, c in zip(faults, row) if c]
    off = [f for f, c in zip(faults, row) if not c]
    return (f"sensitive to {', '.join(on)}"
            + (f"; decoupled from {', '.join(off)}" if off else ""))


def realised_row(d: Design, faults: Sequence[str]) -> tuple:
    """The row a residual realises, recomputed from its structure: 1 where O Φ D_j ≠ 0
    (with faults in the outputs, the design's signature: R* Dy_j ≠ 0 or
    O (Φ D_j − J* Dy_j) ≠ 0)."""
    m = d.matrices
    sig = d.signature_map
    if d.structure.has_feedthrough and all(f in sig for f in faults):
        return tuple(int(sig[f]) for f in faults)
    return tuple(int(fault_sensitivity(m.Phi, m.F_star, m.H_star,
                                       d.structure.unknown_input_columns([f]), name=f).sensitive)
                 for f in faults)


def strongly_realised(d: Design, faults: Sequence[str]) -> bool:
    """Whether the residual's every sensitive fault among ``faults`` has a nonzero
    steady-state gain (none is seen only as a transient, see
    :func:`~observer_cad.synthesis.certificates.steady_state_gain`)."""
    sig = d.signature or d.with_signature().signature
    return not any(s.transient_only for s in sig if s.name in faults)


def strong_row(d: Design, faults: Sequence[str]) -> tuple:
    """The residual's row of the strong structure matrix: its realised row
    (:func:`realised_row`) with a 0 where it responds to the fault with a zero
    steady-state gain (seen only as a transient)."""
    sig = d.signature or d.with_signature().signature
    transient = {s.name for s in sig if s.transient_only}
    return tuple(0 if f in transient else c for f, c in zip(faults, realised_row(d, faults)))


def transient_faults(rows, strong_rows, faults) -> tuple:
    """(faults, pairs): the faults detected or isolated by ``rows`` but not by
    ``strong_rows`` — seen only as a transient — and the pairs isolated only so."""
    weak_det = [any(r[j] for r in rows) for j in range(len(faults))]
    strong_det = [any(r[j] for r in strong_rows) for j in range(len(faults))]
    pairs = tuple(p for (p, w), (_, s) in zip(_pairs(rows, faults), _pairs(strong_rows, faults))
                  if w and not s)
    seen = {f for f, w, s in zip(faults, weak_det, strong_det) if w and not s}
    seen |= {f for p in pairs for f in p}
    return tuple(f for f in faults if f in seen), pairs


def transient_sentence(rows, strong_rows, faults) -> str:
    """One sentence naming the faults detected or isolated only transiently ("" if none)."""
    only, pairs = transient_faults(rows, strong_rows, faults)
    if not only:
        return ""
    lost = [f for j, f in enumerate(faults) if any(r[j] for r in rows)
            and not any(r[j] for r in strong_rows)]
    shown = ", ".join(f"{a}/{b}" for a, b in pairs[:6]) + (", …" if len(pairs) > 6 else "")
    return (f"Isolated only transiently (a residual that responds has a zero steady-state"
            f" gain, so a constant fault's pattern fades): {', '.join(only)}"
            + (f" (pairs {shown})" if pairs else "")
            + (f"; {', '.join(lost)} detected only transiently" if lost else "") + ".")


def _pairs(rows, faults):
    """((a, b), isolable) for every pair: both detected, columns different."""
    out = []
    for i, j in itertools.combinations(range(len(faults)), 2):
        ci = tuple(r[i] for r in rows)
        cj = tuple(r[j] for r in rows)
        out.append(((faults[i], faults[j]), any(ci) and any(cj) and ci != cj))
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class ResidualBank:
    """A bank of certified residual generators realising a structure matrix.

    ``faults`` names the columns, ``structure_matrix`` the rows (0/1 tuples, realised and
    checked), ``designs`` one certified Jordan :class:`Design` per row (its residual is
    ``r<i>`` of the bank's observer), ``scheme`` which rule chose the rows, ``choice`` what
    was tried, ``refused`` the rows tried and not achievable with the reason.
    """

    model_name: str
    faults: tuple
    structure_matrix: tuple
    designs: tuple
    scheme: str
    choice: str = ""
    refused: tuple = ()  # of (row text, reason)
    disturbances: tuple = ()  # further inputs every residual is decoupled from
    time: str = "continuous"

    @property
    def isolable(self) -> tuple:
        """((fault a, fault b), bool) for every pair of columns."""
        return _pairs(self.structure_matrix, self.faults)

    @property
    def detectable(self) -> dict:
        """Fault → True when some residual responds to it."""
        return {f: any(r[j] for r in self.structure_matrix) for j, f in enumerate(self.faults)}

    @property
    def strong_structure(self) -> tuple:
        """The strong structure matrix: the rows with a 0 where the residual responds to
        the fault with a zero steady-state gain (s = 0, or z = 1 in discrete time)."""
        return tuple(strong_row(d, self.faults) for d in self.designs)

    @property
    def strongly_isolable(self) -> tuple:
        """((fault a, fault b), bool): isolable by the columns of the strong structure
        matrix (both strongly detected, columns different)."""
        return _pairs(self.strong_structure, self.faults)

    @property
    def transient_only(self) -> tuple:
        """The faults the bank detects or isolates only transiently (in order)."""
        return transient_faults(self.structure_matrix, self.strong_structure, self.faults)[0]

    @property
    def transient_note(self) -> str:
        """One sentence naming the faults isolated only transiently ("" when none is)."""
        return transient_sentence(self.structure_matrix, self.strong_structure, self.faults)

    @property
    def assumptions(self) -> tuple:
        out = []
        for d in self.designs:
            out += [a for a in d.assumptions if a not in out]
        return tuple(out)

    @property
    def certified(self) -> bool:
        return all(d.certificate.passed for d in self.designs)

    def __repr__(self) -> str:
        rows = ",".join(_row_text(r) for r in self.structure_matrix)
        return (f"<ResidualBank for {self.model_name}: {len(self.designs)} residuals over"
                f" ({', '.join(self.faults)}), structure {rows}, {self.scheme}>")

    def _repr_markdown_(self) -> str:
        """Notebook view: the structure matrix as a table, the isolable pairs."""
        lines = [f"**Residual bank** for `{self.model_name}` — {self.scheme}", "",
                 "| | " + " | ".join(self.faults) + " | k |",
                 "|---" * (len(self.faults) + 2) + "|"]
        for i, (row, d) in enumerate(zip(self.structure_matrix, self.designs), 1):
            lines.append(f"| r{i} | " + " | ".join(map(str, row)) + f" | {d.k} |")
        if len(self.faults) > 1:
            lines += ["", "Isolable: " + ", ".join(f"{a}/{b} {'yes' if ok else 'no'}"
                                                  for (a, b), ok in self.isolable)]
        if self.transient_note:
            lines += ["", self.transient_note]
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {
            "model": self.model_name, "kind": "residual-bank", "time": self.time,
            "faults": list(self.faults),
            "structure_matrix": [[int(c) for c in r] for r in self.structure_matrix],
            "strong_structure": [[int(c) for c in r] for r in self.strong_structure],
            "transient_only": list(self.transient_only),
            "scheme": self.scheme, "choice": self.choice,
            "detectable": self.detectable,
            "isolable": [{"faults": list(p), "isolable": bool(ok)} for p, ok in self.isolable],
            "refused": [{"row": r, "reason": why} for r, why in self.refused],
            "disturbances": list(self.disturbances),
            "assumptions": [str(a) for a in self.assumptions],
            "residuals": [f"r{i + 1}" for i in range(len(self.designs))],
            "designs": [d.to_json() for d in self.designs],
        }

    @classmethod
    def from_json(cls, data, model: PlantModel) -> "ResidualBank":
        """The bank of :meth:`to_json`: every design re-read and re-certified by
        :meth:`Design.from_json`, every row recomputed from the structure and compared.
        (:func:`~observer_cad.analysis.load_design` also designs the bank again and
        compares everything else it records.)"""
        if not isinstance(data, dict) or not isinstance(data.get("designs"), list) \
                or not isinstance(data.get("structure_matrix"), list):
            raise UsageError("not a residual bank: a JSON object with 'designs' and"
                             " 'structure_matrix' is expected")
        faults = data.get("faults")
        if not isinstance(faults, list) or not all(isinstance(f, str) for f in faults):
            raise UsageError("a residual bank's 'faults' must list fault names")
        declared = {s.name for s in model.faults + model.disturbances}
        for f in faults:
            if f not in declared:
                raise ModelError(f"{model.where}: the bank's column '{f}' is not a fault or"
                                 " disturbance of the model")
        rows = parse_structure([[c for c in r] if isinstance(r, list) else r
                                for r in data["structure_matrix"]], faults,
                               "the bank's 'structure_matrix'")
        if len(rows) != len(data["designs"]):
            raise UsageError("a residual bank needs one design per structure row")
        designs = tuple(Design.from_json(dj, model) for dj in data["designs"])
        for i, (row, d) in enumerate(zip(rows, designs), 1):
            got = realised_row(d, faults)
            if got != row:
                raise UsageError(f"residual r{i} of the bank realises {_row_text(got)}, not the"
                                 f" recorded row {_row_text(row)}")
        refused = tuple((str(r.get("row", "")), str(r.get("reason", "")))
                        for r in data.get("refused", []) if isinstance(r, dict))
        strong = tuple(strong_row(d, faults) for d in designs)
        if "strong_structure" in data and data["strong_structure"] != [list(r) for r in strong]:
            raise UsageError("the bank's recorded strong_structure differs from the one"
                             " recomputed from its residuals' steady-state gains "
                             + ",".join(map(_row_text, strong)))
        return cls(model_name=designs[0].model_name if designs else model.name,
                   faults=tuple(faults), structure_matrix=rows, designs=designs,
                   scheme=str(data.get("scheme", REQUESTED)), choice=str(data.get("choice", "")),
                   refused=refused, disturbances=tuple(map(str, data.get("disturbances", []))),
                   time=designs[0].time if designs else model.time)


def _columns(model: PlantModel, faults, disturbances) -> tuple:
    """The bank's columns (default: every declared fault) and the further inputs every
    residual is decoupled from, with one-line errors for a clash."""
    names = [f.name for f in model.faults] if not faults else [str(f) for f in faults]
    if not names:
        raise ModelError(f"{model.where}: the model declares no faults to isolate")
    if len(set(names)) != len(names):
        raise UsageError("--fault names a fault twice")
    extra = [str(x) for x in (disturbances or ())]
    clash = set(extra) & set(names)
    if clash:
        raise UsageError(f"'{sorted(clash)[0]}' cannot be both a bank column (--fault) and"
                         " decoupled (--disturbance)")
    return names, extra


class _Rows:
    """The rows tried so far (not a value: it remembers every attempt): for a row, the
    certified design and its realised row, or the reason it fails."""

    def __init__(self, model: PlantModel, names, extra, options: dict):
        self.model, self.names, self.extra, self.options = model, names, extra, options
        self.attempts: dict = {}

    def __call__(self, row) -> tuple:
        """(design, "") for an achievable row, (None, reason) otherwise."""
        attempts, names, model = self.attempts, self.names, self.model
        if row in attempts:
            return attempts[row]
        on = [f for f, c in zip(names, row) if c]
        off = [f for f, c in zip(names, row) if not c]
        try:
            d = design(model, observer="diagnostic", faults=on, disturbances=off + self.extra,
                       form="jordan", **self.options)
        except InfeasibleDesignError as exc:
            reason = str(exc).split(": ", 1)[-1] if str(exc).startswith(model.where) else str(exc)
            attempts[row] = (None, reason)
            return attempts[row]
        got = realised_row(d, names)
        if got != tuple(row):
            wrong = [f for f, a, b in zip(names, got, row) if a != b]
            attempts[row] = (None, f"the residual realises {_row_text(got)}: it "
                                   + ", ".join(f"{'responds to' if got[names.index(f)] else 'does not respond to'} {f}"
                                               for f in wrong))
            return attempts[row]
        attempts[row] = (d, "")
        return attempts[row]

    def bank(self, rows, designs, scheme, choice) -> ResidualBank:
        """The bank of these rows; every failed attempt is listed as refused."""
        return _bank(self.model, self.names, rows, designs, scheme, choice, self.attempts,
                     self.extra)


def _requested_bank(attempt: _Rows, structure) -> ResidualBank:
    """The requested rows, each realised or refused with the reason (the diagnosability
    analysis's when no residual of any order can realise it)."""
    model, names, extra = attempt.model, attempt.names, attempt.extra
    rows = parse_structure(structure, names)
    designs = []
    for i, row in enumerate(rows, 1):
        d, why = attempt(row)
        if d is None:
            impossible = _impossible_row(model, row, names, extra, **attempt.options)
            if impossible:
                raise InfeasibleDesignError(
                    f"{model.where}: --structure row {i} ({_row_text(row)}:"
                    f" {_describe_row(row, names)}) is not achievable for any order:"
                    f" {impossible}")
            raise InfeasibleDesignError(
                f"{model.where}: --structure row {i} ({_row_text(row)}:"
                f" {_describe_row(row, names)}) is not achievable: {why}")
        designs.append(d)
    return attempt.bank(rows, designs, REQUESTED,
                        f"the requested rows {','.join(map(_row_text, rows))}")


def _transient_text(row, d: Design, faults) -> str:
    """``11110111 (f6 transient only)``: a row whose residual sees faults as transients."""
    sig = d.signature or d.with_signature().signature
    seen = [s.name for s in sig if s.transient_only and s.name in faults]
    return f"{_row_text(row)} ({', '.join(seen)} transient only)"


def _scheme_bank(attempt: _Rows, tried_txt: list, strong: bool = True):
    """1. the generalised observer scheme, 2. the dedicated scheme (the same for m ≤ 2):
    the bank of the first whose every row is achievable and, when ``strong``, strongly
    realised, else None (what failed is appended to ``tried_txt`` on the strong pass)."""
    names = attempt.names
    m = len(names)
    if m == 1:
        schemes = [("detection", [(1,)])]
    else:
        gos = [tuple(0 if j == i else 1 for j in range(m)) for i in range(m)]
        dos = [tuple(1 if j == i else 0 for j in range(m)) for i in range(m)]
        schemes = [(GOS, gos)] + ([(DOS, dos)] if m > 2 else [])
    for scheme, rows in schemes:
        results = [attempt(r) for r in rows]
        if all(d is not None for d, _ in results):
            designs = [d for d, _ in results]
            weak = [(r, d) for r, d in zip(rows, designs) if not strongly_realised(d, names)]
            if strong and weak:
                tried_txt.append(f"{scheme} achievable only with faults seen as transients:"
                                 " row(s) " + ", ".join(_transient_text(r, d, names)
                                                        for r, d in weak))
                continue
            return attempt.bank(rows, designs, scheme,
                                f"{scheme}: every row achievable"
                                + (", some seeing faults only as transients" if weak else "")
                                + (f" ({'; '.join(tried_txt)})" if tried_txt else ""))
        if strong:
            bad = [f"{_row_text(r)}" for r, (d, _) in zip(rows, results) if d is None]
            tried_txt.append(f"{scheme} not achievable: row(s) {', '.join(bad)} fail")
    return None


def _candidates(attempt: _Rows, strong: bool) -> tuple:
    """The achievable rows the best-achievable search tries, with their designs, and
    (when ``strong``) the further rows of :func:`_analysis_rows`."""
    model, names = attempt.model, attempt.names
    m = len(names)
    if m <= FULL_SEARCH_FAULTS:
        cands = [r for r in itertools.product((0, 1), repeat=m) if any(r)]
    else:
        cands = sorted({tuple(0 if j == i else 1 for j in range(m)) for i in range(m)}
                       | {tuple(1 if j == i else 0 for j in range(m)) for i in range(m)}
                       | {(1,) * m})
    ok = [(r, attempt(r)[0]) for r in cands]
    ok = [(r, d) for r, d in ok if d is not None]
    more = _analysis_rows(attempt) if strong else []
    if not ok and not more:
        reasons = "; ".join(f"{_row_text(r)}: {attempt.attempts[r][1]}" for r in cands[:6])
        raise InfeasibleDesignError(f"{model.where}: no residual detects any of"
                                    f" {', '.join(names)}: {reasons}")
    return ok, more


def _analysis_rows(attempt: _Rows) -> list:
    """For more than :data:`FULL_SEARCH_FAULTS` faults, the further rows the strong
    structure matrix of the diagnosability analysis holds (at ω = 0: a nonzero
    steady-state gain), achievable by the Jordan search, with their designs."""
    names = attempt.names
    if len(names) <= FULL_SEARCH_FAULTS:
        return []
    try:
        a = analyze(attempt.model, faults=names, disturbances=list(attempt.extra),
                    frequencies=[0], **attempt.options)
    except ObserverCadError:
        return []
    rows = sorted({tuple(int(s.row(a.faults)[f]) for f in names) for s in a.strong_structure})
    out = [(r, attempt(r)[0]) for r in rows if r not in attempt.attempts]
    return [(r, d) for r, d in out if d is not None]


def _greedy(ok: list, names, strong_first: bool = True) -> list:
    """Rows added greedily, each the one that isolates the most further pairs strongly
    (then detects the most further faults strongly, then isolates and detects the most
    at all; ties: strongly realised, fewer states), until no row improves the bank.
    ``strong_first`` False: isolating and detecting at all only (the weak choice)."""
    strong = {r: strong_row(d, names) for r, d in ok}
    m = len(names)

    def count(rows):
        pairs = sum(1 for _, good in _pairs(rows, names) if good) if rows else 0
        return pairs, sum(1 for j in range(m) if any(r[j] for r in rows))

    def score(rows):
        return (count([strong[r] for r in rows]) if strong_first else ()) + count(rows)

    chosen: list = []
    while True:
        base = score([r for r, _ in chosen])
        best = None
        for r, d in ok:
            if any(r == c for c, _ in chosen):
                continue
            s = score([c for c, _ in chosen] + [r])
            if s <= base:
                continue
            key = (s, strongly_realised(d, names), -d.k)
            if best is None or key > best[0]:
                best = (key, r, d)
        if best is None:
            return chosen
        chosen.append((best[1], best[2]))


def _best_bank(attempt: _Rows, tried_txt: list, strong: bool = True):
    """3. the best achievable rows (:func:`_greedy`); when ``strong``, among the strongly
    realised rows only (None when there is none)."""
    names = attempt.names
    every, more = _candidates(attempt, strong)
    ok, left = every + more, []
    if strong:
        left = [(r, d) for r, d in ok if not strongly_realised(d, names)]
        ok = [(r, d) for r, d in ok if strongly_realised(d, names)]
        if not ok:
            return None
    chosen = _greedy(ok, names)
    rows = [r for r, _ in chosen]
    txt = ("; ".join(tried_txt) + "; achievable rows"
           + (" (with the strong rows of the diagnosability analysis)" if more else "")
           + f": {', '.join(_row_text(r) for r, _ in ok)};"
           " added greedily, each the row that isolates the most further pairs"
           + (" (then detects the most further faults, then has the fewest states)" if strong
              else " strongly (then detects the most further faults strongly, then isolates"
              " and detects the most at all, then has the fewest states)"))
    if left and [r for r, _ in _greedy(every, names, strong_first=False)] != rows:
        lost = [f for j, f in enumerate(names) if not any(r[j] for r in rows)
                and any(r[j] for r, _ in left)]
        txt += ("; left out, seeing faults only as transients: "
                + ", ".join(_transient_text(r, d, names) for r, d in left)
                + (f" ({', '.join(lost)} then not detected: request such a row with"
                   " --structure)" if lost else ""))
    return attempt.bank(rows, [d for _, d in chosen], BEST, txt)


def design_bank(model: PlantModel, *, structure=None, faults: Sequence[str] | None = None,
                disturbances: Sequence[str] = (), symbolic: bool = False,
                method: str = "auto", rtol: float | None = None) -> ResidualBank:
    """A bank of minimal-order, certified Jordan residual generators (module docstring).

    Parameters
    ----------
    model : PlantModel
    structure : str or sequence of rows, optional
        The structure matrix to realise, e.g. ``"110,101,011"`` (one row per residual, one
        digit per fault of ``faults``; 1 = sensitive). Default: the first achievable of the
        generalised observer scheme, the dedicated scheme, the best achievable rows, each
        with every row strongly realised; only when no row is, the same with rows that
        see some faults only as transients.
    faults : names, optional
        The columns (default: every declared fault). Faults not named are assumed zero.
    disturbances : names, optional
        Further inputs every residual is decoupled from (the model's disturbances always are).
    symbolic, method, rtol : as for :func:`design`.

    Returns
    -------
    ResidualBank
        Every row realised and re-checked; refusals name the row, the fault and the reason.
    """
    names, extra = _columns(model, faults, disturbances)
    attempt = _Rows(model, names, extra, dict(symbolic=symbolic, method=method, rtol=rtol))
    if structure is not None:
        return _requested_bank(attempt, structure)
    tried_txt: list = []
    bank = _scheme_bank(attempt, tried_txt) or _best_bank(attempt, tried_txt)
    if bank is not None:
        return bank
    tried_txt.append("no achievable row sees every fault it responds to with a nonzero"
                     " steady-state gain, so no bank isolates strongly: rows that see some"
                     " faults only as transients")
    return _scheme_bank(attempt, tried_txt, strong=False) or _best_bank(attempt, tried_txt,
                                                                         strong=False)


def _impossible_row(model, row, names, extra, symbolic, method, rtol) -> str:
    """The diagnosability analysis's verdict on a row the Jordan search did not realise:
    why no residual of any order can (a fault of the row not detectable with the row's
    zeros and the disturbances decoupled), or "" when the analysis finds the row
    achievable (the refusal then stays the search's, which tried orders below n)."""
    on = [f for f, c in zip(names, row) if c]
    off = [f for f, c in zip(names, row) if not c]
    if not on:
        return ""
    result = analyze(model, faults=on, disturbances=off + list(extra), symbolic=symbolic,
                     method=method, rtol=rtol)
    blind = [r for r in result.fault_results if not r.detectable]
    if not blind or any(r.via_substitution for r in blind):
        return ""  # (a "no" that rests on the argument-substitution search is no proof)
    return "; ".join(f"{r.fault}: {r.reason}" for r in blind)


def _bank(model, names, rows, designs, scheme, choice, attempts, extra) -> ResidualBank:
    refused = tuple((_row_text(r), why) for r, (d, why) in attempts.items() if d is None)
    return ResidualBank(model_name=designs[0].model_name, faults=tuple(names),
                        structure_matrix=tuple(tuple(r) for r in rows), designs=tuple(designs),
                        scheme=scheme, choice=choice, refused=refused,
                        disturbances=tuple(extra), time=designs[0].time)
