"""One loader for frozen design files: a single design of any kind made by
:func:`~observer_cad.synthesis.design`, or a residual bank (:class:`ResidualBank`), read
from what :func:`~observer_cad.reporting.write_design_json` wrote and recomputed, never
believed (:func:`~observer_cad.synthesis.load_design_data`).

A bank is designed again with its recorded columns, disturbances and options (with the
recorded rows when they were requested): its rows, scheme, refusals, assumptions and
detectable and isolable faults must be the recomputed ones, and each residual's design is
compared field by field as a single design is. The bank returned is the recomputed one.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

from ..errors import ObserverCadError, UsageError
from ..files import read_json_file
from ..model import PlantModel
from ..synthesis import Design, load_design_data, recomputed_design
from ._bank import BEST, DOS, GOS, REQUESTED, ResidualBank, design_bank

__all__ = ["load_design", "design_from_data", "BANK_KIND"]

#: the ``kind`` a residual bank's JSON records
BANK_KIND = "residual-bank"


def load_design(path, model: PlantModel) -> Design | ResidualBank:
    """The design (or residual bank) in the file ``path`` for ``model``, recomputed and
    compared (the module docstring); every refusal is one UsageError naming the file."""
    data = read_json_file(path, "design")
    try:
        return design_from_data(data, model)
    except UsageError as exc:
        raise UsageError(f"design file {Path(path)}: {exc}") from None
    except ObserverCadError as exc:  # e.g. a bank column the model does not declare
        raise type(exc)(f"design file {Path(path)}: {exc}") from None


def design_from_data(data, model: PlantModel) -> Design | ResidualBank:
    """The design or bank a design file's JSON describes (:func:`load_design`)."""
    if isinstance(data, dict) and data.get("kind") == BANK_KIND:
        return _bank_from_data(data, model)
    if isinstance(data, dict) and data.get("observer") == "drem":
        raise UsageError("a DREM design is loaded with its model's DREM declaration"
                         " (observer-cad --observer drem --design FILE)")
    if not isinstance(data, dict) or not isinstance(data.get("matrices"), dict):
        raise UsageError("not a design: neither 'matrices' (a design) nor kind"
                         f" '{BANK_KIND}' (a residual bank)")
    return load_design_data(data, model)


def _bank_from_data(data: dict, model: PlantModel) -> ResidualBank:
    loaded = ResidualBank.from_json(data, model)  # every design parsed and certified
    if not loaded.designs:
        raise UsageError("a residual bank needs at least one design")
    for i, dj in enumerate(data["designs"], 1):
        if "model_hash" not in dj:
            raise UsageError(f"residual r{i} records no 'model_hash' (the structure of the"
                             " model it was made for): design again")
    req = loaded.designs[0].request
    if req is None:
        raise UsageError("residual r1 records no 'request': the bank cannot be recomputed")
    if loaded.scheme not in (GOS, DOS, BEST, REQUESTED):
        raise UsageError(f"the bank's scheme {loaded.scheme[:60]!r} is not one this tool"
                         " chooses")
    try:
        fresh = design_bank(model, structure=loaded.structure_matrix if loaded.scheme == REQUESTED
                            else None, faults=list(loaded.faults),
                            disturbances=list(loaded.disturbances), symbolic=req.symbolic,
                            method=req.method, rtol=req.rtol)
    except ObserverCadError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UsageError(f"designing the bank again fails ({first}): the file does not"
                         " describe a bank of this model") from None
    want = fresh.to_json()
    for key in ("faults", "structure_matrix", "strong_structure", "transient_only", "scheme",
                "choice", "detectable", "isolable", "refused", "disturbances", "assumptions",
                "time"):
        if key in data and data[key] != want[key]:
            raise UsageError(f"the bank's recorded {key} differs from the recomputed one:"
                             " the file is not what designing again gives (refused, never"
                             " believed)")
    designs = []
    for i, (dj, d, f) in enumerate(zip(data["designs"], loaded.designs, fresh.designs), 1):
        try:
            designs.append(recomputed_design(dj, d, f))
        except UsageError as exc:
            raise UsageError(f"residual r{i}: {exc}") from None
    return dataclasses.replace(fresh, designs=tuple(designs))
