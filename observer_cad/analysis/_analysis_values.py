"""The values a diagnosability analysis returns (:func:`~observer_cad.analysis.analyze`):
one fault's detectability, one pair's isolability, an achievable row of the structure
matrix, a suggested measurement, and the whole :class:`Analysis`.
"""
from __future__ import annotations

import dataclasses

__all__ = ["FaultAnalysis", "PairAnalysis", "StructureRow", "Suggestion", "Analysis"]


@dataclasses.dataclass(frozen=True)
class FaultAnalysis:
    """Detectability of one fault with the disturbances decoupled.

    ``min_order`` is the smallest k of a detecting residual generator (None when not
    detectable); ``reason`` one line when not detectable, else ""; ``via_substitution``
    True when the answer rests on the argument substitution of a nonlinear term;
    ``assumptions`` the nonzero conditions this answer needs (symbolic models).
    """

    fault: str
    detectable: bool
    min_order: int | None
    reason: str = ""
    via_substitution: bool = False
    assumptions: tuple = ()

    def to_json(self) -> dict:
        return {"fault": self.fault, "detectable": self.detectable,
                "min_order": self.min_order, "reason": self.reason,
                "via_substitution": self.via_substitution,
                "assumptions": [str(a) for a in self.assumptions]}


@dataclasses.dataclass(frozen=True)
class PairAnalysis:
    """Isolability of two faults a, b.

    ``a_from_b``: a residual sensitive to a and decoupled from b exists (order
    ``a_from_b_order``); ``b_from_a`` the converse. The pair is (strongly) ``isolable``
    when both exist. ``reason``: one line per failing direction.
    """

    faults: tuple
    a_from_b: bool
    b_from_a: bool
    a_from_b_order: int | None = None
    b_from_a_order: int | None = None
    reason: str = ""
    via_substitution: bool = False
    assumptions: tuple = ()

    @property
    def isolable(self) -> bool:
        return self.a_from_b and self.b_from_a

    def to_json(self) -> dict:
        a, b = self.faults
        return {"faults": [a, b], "isolable": self.isolable,
                "first_from_second": self.a_from_b, "second_from_first": self.b_from_a,
                "orders": [self.a_from_b_order, self.b_from_a_order],
                "reason": self.reason, "via_substitution": self.via_substitution}


@dataclasses.dataclass(frozen=True)
class StructureRow:
    """One achievable row of the structure matrix: a residual decoupled from the
    disturbances and from the faults ``decoupled``, sensitive to each of ``sensitive``
    (every other fault is then decoupled as well: it cannot be seen).

    ``requested`` is the set of faults that was asked to be decoupled; ``decoupled``
    adds the faults that turned out undetectable with it.
    """

    requested: tuple
    decoupled: tuple
    sensitive: tuple
    via_substitution: bool = False
    #: the least order of a residual with this row (computed for the strong rows)
    order: int | None = None

    def row(self, faults) -> dict:
        return {f: int(f in self.sensitive) for f in faults}


@dataclasses.dataclass(frozen=True)
class StrongFault:
    """Strong detectability of one fault, disturbances decoupled: a residual whose gain
    to the fault is nonzero at every analysed frequency (at ω = 0: a nonzero
    steady-state gain), and the least order of one; ``strongly_detectable`` None when
    not computed (see the analysis notes)."""

    fault: str
    strongly_detectable: bool | None
    min_order: int | None = None


@dataclasses.dataclass(frozen=True)
class Suggestion:
    """An extra measurement that makes a fault detectable (``other`` None) or isolable
    from ``other``: a state (``x2``) or a candidate output expression."""

    fault: str
    other: str | None
    measurement: str
    min_order: int

    @property
    def goal(self) -> str:
        return f"detect {self.fault}" if self.other is None else \
            f"isolate {self.fault} from {self.other}"

    def to_json(self) -> dict:
        return {"goal": self.goal, "fault": self.fault, "from": self.other,
                "measurement": self.measurement, "min_order": self.min_order}


@dataclasses.dataclass(frozen=True)
class Analysis:
    """The diagnosability of a model's faults with its disturbances decoupled.

    ``fault_results`` (one :class:`FaultAnalysis` per fault, in order), ``pairs``
    (:class:`PairAnalysis` for every pair), ``structure`` (the distinct achievable rows,
    :class:`StructureRow`; complete when ``structure_complete``), ``suggestions``
    (:class:`Suggestion`) and ``unhelped`` (goals no single listed measurement reaches),
    ``assumptions`` (union over every answer), ``notes`` (nonlinear terms, limits).
    """

    model_name: str
    time: str
    faults: tuple
    disturbances: tuple
    symbolic: bool
    fault_results: tuple
    pairs: tuple
    structure: tuple
    structure_complete: bool
    suggestions: tuple
    unhelped: tuple
    assumptions: tuple
    notes: tuple = ()
    candidates: tuple = ()
    #: the frequencies of the strong answers (exact rationals; rad per time unit, or per
    #: sample in discrete time), one :class:`StrongFault` per fault, and the strong
    #: structure matrix rows (:class:`StructureRow` with ``order``); empty when skipped
    frequencies: tuple = ()
    strong: tuple = ()
    strong_structure: tuple = ()

    @property
    def strongly_detectable(self) -> dict:
        """fault -> bool (None when strong detectability was not computed)."""
        got = {s.fault: s.strongly_detectable for s in self.strong}
        return {f: got.get(f) for f in self.faults}

    @property
    def transient_only(self) -> tuple:
        """The faults detectable only as a transient (weakly, not strongly)."""
        strong = self.strongly_detectable
        return tuple(r.fault for r in self.fault_results
                     if r.detectable and strong.get(r.fault) is False)

    def __repr__(self) -> str:
        det = sum(1 for r in self.fault_results if r.detectable)
        iso = sum(1 for p in self.pairs if p.isolable)
        return (f"<Analysis of {self.model_name}: {det} of {len(self.faults)} faults detectable,"
                f" {iso} of {len(self.pairs)} pairs isolable, {len(self.structure)} achievable"
                f" structure rows>")

    def _repr_markdown_(self) -> str:
        """Notebook view: detectability (weak, and strong when computed), isolability and
        the achievable structure matrices."""
        strong = {s.fault: s for s in (self.strong or ())}
        lines = [f"**Diagnosability** of `{self.model_name}` with"
                 f" {', '.join(self.disturbances) or 'nothing'} decoupled", "",
                 "| fault | detectable | minimal order | strongly detectable | reason |",
                 "|---|---|---|---|---|"]
        for r in self.fault_results:
            sf = strong.get(r.fault)
            st = ("—" if sf is None or sf.strongly_detectable is None else
                  f"✅ (order {sf.min_order})" if sf.strongly_detectable else "❌ transient only"
                  if r.detectable else "❌")
            lines.append(f"| {r.fault} | {'✅' if r.detectable else '❌'} |"
                         f" {r.min_order if r.min_order is not None else '—'} | {st} |"
                         f" {r.reason.replace('|', '/')} |")
        if self.pairs:
            lines += ["", "| pair | isolable |", "|---|---|"]
            lines += [f"| {a} / {b} | {'✅' if p.isolable else '❌'} |"
                      for p in self.pairs for a, b in [p.faults]]
        if self.structure:
            lines += ["", "| decoupled | " + " | ".join(self.faults) + " |",
                      "|---|" + "---|" * len(self.faults)]
            for row in self.structure:
                bits = row.row(self.faults)
                lines.append(f"| {', '.join(row.decoupled) or '—'} | "
                             + " | ".join(str(bits[f]) for f in self.faults) + " |")
        if self.strong:
            lines += ["", "Strong structure rows (every 1 with a nonzero gain at the analysed"
                      f" frequencies ω = {', '.join(map(str, self.frequencies))}):", ""]
            if self.strong_structure:
                lines += ["| decoupled | " + " | ".join(self.faults) + " | order |",
                          "|---|" + "---|" * (len(self.faults) + 1)]
                for row in self.strong_structure:
                    bits = row.row(self.faults)
                    lines.append(f"| {', '.join(row.decoupled) or '—'} | "
                                 + " | ".join(str(bits[f]) for f in self.faults)
                                 + f" | {row.order} |")
            else:
                lines.append("none: no fault is strongly detectable")
        return "\n".join(lines)

    def fault(self, name: str) -> FaultAnalysis:
        for r in self.fault_results:
            if r.fault == name:
                return r
        raise KeyError(name)

    def pair(self, a: str, b: str) -> PairAnalysis:
        for p in self.pairs:
            if p.faults == (a, b):
                return p
            if p.faults == (b, a):
                return dataclasses.replace(
                    p, faults=(a, b), a_from_b=p.b_from_a, b_from_a=p.a_from_b,
                    a_from_b_order=p.b_from_a_order, b_from_a_order=p.a_from_b_order)
        raise KeyError((a, b))

    @property
    def detectable(self) -> dict:
        return {r.fault: r.detectable for r in self.fault_results}

    @property
    def min_order(self) -> dict:
        return {r.fault: r.min_order for r in self.fault_results}

    def to_json(self) -> dict:
        """The object ``observer-cad analyze --json`` prints."""
        return {
            "model": self.model_name,
            "time": self.time,
            "faults": list(self.faults),
            "disturbances": list(self.disturbances),
            "symbolic": self.symbolic,
            "detectable": self.detectable,
            "min_order": self.min_order,
            "reasons": {r.fault: r.reason for r in self.fault_results if r.reason},
            "isolable": [p.to_json() for p in self.pairs],
            "structure_matrices": [s.row(self.faults) for s in self.structure],
            "structure_rows": [{"decoupled": list(s.decoupled), "sensitive": list(s.sensitive),
                                "via_substitution": s.via_substitution}
                               for s in self.structure],
            "structure_complete": self.structure_complete,
            "suggestions": [s.to_json() for s in self.suggestions],
            "unhelped": list(self.unhelped),
            "candidates": list(self.candidates),
            "assumptions": [str(a) for a in self.assumptions],
            "notes": list(self.notes),
            "fault_results": [r.to_json() for r in self.fault_results],
            "frequencies": [str(w) for w in self.frequencies],
            "strongly_detectable": self.strongly_detectable,
            "strong_min_order": {s.fault: s.min_order for s in self.strong},
            "strong_structure_matrices": [s.row(self.faults) for s in self.strong_structure],
            "strong_structure_rows": [{"decoupled": list(s.decoupled),
                                       "sensitive": list(s.sensitive), "order": s.order}
                                      for s in self.strong_structure],
        }
