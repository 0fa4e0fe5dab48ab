"""A digest of a model's structure: what a frozen design file records so that a model
that has changed since the design was made is recognised at load.

The digest is the SHA-256 of a canonical text: the names of every role (states, inputs,
faults, disturbances, noise, parameters), the time domain, the parameters' defaults,
the extracted matrices F, G, H, C, D, L, W and the nonlinear terms (function and row),
each printed by sympy's string printer (whose term order is canonical, so the text does
not depend on the run, the machine or the order the model file wrote its terms in).
Each part has its own short digest too, so a refusal can name the part that changed.
"""
from __future__ import annotations

import dataclasses
import hashlib

import sympy as sp

from ._plant import PlantModel
from ._structure import Structure

__all__ = ["ModelDigest", "structure_digest", "model_digest"]

@dataclasses.dataclass(frozen=True)
class ModelDigest:
    """``sha256``: the digest of the whole canonical text; ``parts``: part name → the first
    16 hex digits of that part's own digest."""

    sha256: str
    parts: tuple  # of (part, short digest)

    def to_json(self) -> dict:
        return {"sha256": self.sha256, "parts": dict(self.parts)}

    def differing(self, recorded) -> list:
        """The parts whose recorded short digests differ from these (all unknown: [])."""
        if not isinstance(recorded, dict):
            return []
        mine = dict(self.parts)
        return [p for p in mine if p in recorded and recorded[p] != mine[p]]


def _text(e) -> str:
    if isinstance(e, sp.MatrixBase):
        return str(sp.Matrix(e).tolist()) + f"@{e.rows}x{e.cols}"
    return str(e)


def _names(model: PlantModel) -> str:
    roles = ("states", "inputs", "faults", "disturbances", "noise")
    return ";".join(f"{r}:{','.join(str(s) for s in getattr(model, r))}" for r in roles) + \
        f";parameters:{','.join(sorted(str(p) for p in model.parameters))}" + \
        f";outputs:{len(model.outputs)}"


def _parameters(model: PlantModel) -> str:
    return ";".join(f"{p}={v}" for p, v in sorted(model.parameters.items(), key=lambda kv: str(kv[0])))


def _digest(parts: dict) -> ModelDigest:
    whole = hashlib.sha256()
    short = []
    for name in parts:
        text = parts[name].encode("utf-8")
        whole.update(name.encode() + b"\0" + text + b"\0")
        short.append((name, hashlib.sha256(text).hexdigest()[:16]))
    return ModelDigest(whole.hexdigest(), tuple(short))


def structure_digest(st: Structure) -> ModelDigest:
    """The digest of a structure extracted from a model (the module docstring)."""
    model = st.model
    parts = {"time": model.time, "names": _names(model), "parameters": _parameters(model)}
    for name in ("F", "G", "H", "C", "D", "L", "W"):
        parts[name] = _text(getattr(st, name))
    parts["terms"] = "|".join(f"{_text(t.function)}@{t.argument}@{_text(t.row)}"
                              for t in st.terms)
    return _digest(parts)


def model_digest(model: PlantModel) -> ModelDigest:
    """The digest of a model whose structure is not extracted (the DREM designs): its
    names, time, parameter defaults and its equations as written (canonical sympy text)."""
    parts = {"time": model.time, "names": _names(model), "parameters": _parameters(model),
             "dynamics": "|".join(_text(e) for e in model.dynamics),
             "outputs": "|".join(_text(e) for e in model.outputs)}
    return _digest(parts)
