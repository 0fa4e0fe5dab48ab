"""The values a design is made of: its form and arithmetic, a checked condition, an
argument substitution, the typed matrices, the sliding-mode gain inputs, and the request
that reproduces it (:class:`~observer_cad.synthesis.core.Design` holds them).
"""
from __future__ import annotations

import dataclasses
import enum
import math
from typing import Mapping

import sympy as sp

from ...errors import UsageError
from ._expr import parse_json_expression

__all__ = ["Condition", "DesignMatrices", "DesignRequest", "Form", "Method",
           "NonlinearSubstitution", "SlidingGainInputs", "MATRIX_ORDER", "PROOF_SECONDS"]

#: Order in which a design's matrices are printed and serialised.
MATRIX_ORDER = ("Phi", "F_star", "J_star", "R_star", "H_star", "G_star", "D_star", "L_star",
                "C_star", "Hz", "Q", "K", "T", "F_diag", "J_diag", "Phi_diag", "G_diag",
                "Hz_diag")


class Form(str, enum.Enum):
    """The reduced model's form: identification canonical (METHOD §2a) or Jordan (§2b)."""

    CANONICAL = "canonical"
    JORDAN = "jordan"

    def __str__(self) -> str:
        return self.value


class Method(str, enum.Enum):
    """Exact (rational / rational-function) or float (SVD with evidence) synthesis."""

    EXACT = "exact"
    FLOAT = "float"

    def __str__(self) -> str:
        return self.value


@dataclasses.dataclass(frozen=True)
class Condition:
    """A checked synthesis condition: what, whether it holds, the evidence, the source."""

    name: str
    holds: bool
    detail: str = ""
    reference: str = ""
    required: bool = True  # False: reported for information, the design does not rest on it

    def to_json(self) -> dict:
        return {"name": self.name, "holds": bool(self.holds), "detail": self.detail,
                "reference": self.reference, "required": self.required}

    @classmethod
    def from_json(cls, data) -> "Condition":
        if not isinstance(data, dict) or not isinstance(data.get("name"), str) \
                or not isinstance(data.get("holds"), bool):
            raise UsageError("a design condition must be an object with 'name' and 'holds'")
        return cls(data["name"], data["holds"], str(data.get("detail", "")),
                   str(data.get("reference", "")), bool(data.get("required", True)))


@dataclasses.dataclass(frozen=True)
class NonlinearSubstitution:
    """Ψ*_j = φ_j(A*_1j x* + A*_2j y, u) for one nonzero column j of C* (METHOD §2c)."""

    index: int  # j, 1-based
    function: sp.Expr  # φ_j(argument, u) as an expression in the reduced variables
    argument: sp.Expr  # A*_1j x* + A*_2j y
    A1: sp.Matrix
    A2: sp.Matrix

    def to_json(self) -> dict:
        return {"index": self.index, "function": str(self.function),
                "argument": str(self.argument),
                "A1": [str(e) for e in self.A1], "A2": [str(e) for e in self.A2]}


@dataclasses.dataclass(frozen=True)
class DesignMatrices:
    """The matrices of a reduced model (METHOD §2). Φ, F*, J*, G* every design has; the
    others are ``None`` where the design has none: R*, H* (measured combination
    y* = R* y = H* x*), D* (the estimated or detected inputs), L* (interval designs: the
    bounded disturbances), C* (nonlinear terms), H_z, Q (z = H_z x* + Q y), K (output
    injection), and the diagonal (Metzler) form T, F_diag, J_diag, Phi_diag, G_diag,
    Hz_diag of seed 001 method 1."""

    Phi: sp.ImmutableMatrix
    F_star: sp.ImmutableMatrix
    J_star: sp.ImmutableMatrix
    G_star: sp.ImmutableMatrix
    R_star: sp.ImmutableMatrix | None = None
    H_star: sp.ImmutableMatrix | None = None
    D_star: sp.ImmutableMatrix | None = None
    L_star: sp.ImmutableMatrix | None = None
    C_star: sp.ImmutableMatrix | None = None
    Hz: sp.ImmutableMatrix | None = None
    Q: sp.ImmutableMatrix | None = None
    K: sp.ImmutableMatrix | None = None
    T: sp.ImmutableMatrix | None = None
    F_diag: sp.ImmutableMatrix | None = None
    J_diag: sp.ImmutableMatrix | None = None
    Phi_diag: sp.ImmutableMatrix | None = None
    G_diag: sp.ImmutableMatrix | None = None
    Hz_diag: sp.ImmutableMatrix | None = None

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is not None and not isinstance(v, sp.ImmutableMatrix):
                object.__setattr__(self, f.name, sp.ImmutableMatrix(v))

    @classmethod
    def from_mapping(cls, mats: Mapping) -> "DesignMatrices":
        """From a name → matrix mapping (the designers' working dicts); unknown names are
        an error, so a typo cannot silently drop a matrix."""
        unknown = set(mats) - set(MATRIX_ORDER)
        if unknown:
            raise ValueError(f"unknown design matrices: {', '.join(sorted(unknown))}")
        return cls(**dict(mats))

    def items(self):
        """(name, matrix) of the matrices present, in :data:`MATRIX_ORDER`."""
        return [(n, getattr(self, n)) for n in MATRIX_ORDER if getattr(self, n) is not None]

    def as_dict(self) -> dict:
        return dict(self.items())

    def replace(self, **changes) -> "DesignMatrices":
        return dataclasses.replace(self, **changes)

    @property
    def diagonal(self) -> bool:
        """True for canonical designs that carry seed 001's diagonal (Metzler) form."""
        return self.F_diag is not None


@dataclasses.dataclass(frozen=True)
class SlidingGainInputs:
    """What a sliding-mode design's gain bound rests on besides the model (seed 002 §5,
    :func:`observer_cad.synthesis.gain_bound`): ``delta`` bounds abs(x̂*(0) − x*(0)),
    ``lipschitz`` is the Lipschitz constant N* of C*Ψ* in x* (None when C* = 0). Recorded
    so that building the observer recomputes the bound for the gains it is given."""

    delta: float
    lipschitz: float | None = None

    def __post_init__(self):
        for name in ("delta", "lipschitz"):
            v = getattr(self, name)
            if v is None and name == "lipschitz":
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or v < 0 or (name == "delta" and v == 0):
                raise UsageError(f"a sliding-mode design's {name} must be a finite"
                                 f" {'positive' if name == 'delta' else 'non-negative'} number,"
                                 f" got {v!r}")
            object.__setattr__(self, name, float(v))

    def to_json(self) -> dict:
        return {"delta": self.delta, "lipschitz": self.lipschitz}

    @classmethod
    def from_json(cls, data) -> "SlidingGainInputs":
        if not isinstance(data, dict) or set(data) - {"delta", "lipschitz"} or "delta" not in data:
            raise UsageError("a design's 'sliding_inputs' must be an object with 'delta' (and"
                             " 'lipschitz')")
        return cls(data["delta"], data.get("lipschitz"))


#: the default time budget (seconds) of the Jordan minimality proof (METHOD §2b)
PROOF_SECONDS = 2.0


@dataclasses.dataclass(frozen=True)
class DesignRequest:
    """The options of :func:`observer_cad.synthesis` that reproduce a design, with every
    choice the synthesis made filled in (the λ and closed-loop eigenvalues it used, the
    method it took). ``proof_seconds``: the time budget of the Jordan minimality proof
    (None: exhaustive); left out of the JSON when it is the default."""

    observer: str
    faults: tuple = ()
    disturbances: tuple = ()
    estimate: str | None = None
    form: str | None = None
    lambdas: tuple | None = None
    eigenvalues: tuple | None = None
    variant: str = "plain"
    robust: bool = False
    symbolic: bool = False
    method: str = "auto"
    rtol: float | None = None
    proof_seconds: float | None = PROOF_SECONDS

    def options(self) -> dict:
        """Keyword arguments for :func:`observer_cad.synthesis`."""
        out = dataclasses.asdict(self)
        out["faults"] = list(self.faults)
        out["disturbances"] = list(self.disturbances)
        for key in ("lambdas", "eigenvalues"):
            if out[key] is not None:
                out[key] = list(out[key])
        return out

    def to_json(self) -> dict:
        out = self.options()
        if out["proof_seconds"] == PROOF_SECONDS:
            del out["proof_seconds"]
        for key in ("lambdas", "eigenvalues"):
            if out[key] is not None:
                out[key] = [str(v) for v in out[key]]
        return out

    @classmethod
    def from_json(cls, data, names: Mapping) -> "DesignRequest":
        if not isinstance(data, dict):
            raise UsageError("a design's 'request' must be a JSON object")
        allowed = {f.name for f in dataclasses.fields(cls)}
        extra = set(data) - allowed
        if extra:
            raise UsageError(f"a design's request has unknown keys: {', '.join(sorted(extra))}")
        kw = dict(data)
        for key in ("faults", "disturbances"):
            v = kw.get(key, [])
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise UsageError(f"request.{key} must be a list of names")
            kw[key] = tuple(v)
        for key in ("lambdas", "eigenvalues"):
            v = kw.get(key)
            if v is not None:
                if not isinstance(v, list):
                    raise UsageError(f"request.{key} must be a list")
                kw[key] = tuple(parse_json_expression(x, names, f"request.{key}") for x in v)
        for key, typ in (("observer", str), ("variant", str), ("method", str),
                         ("robust", bool), ("symbolic", bool)):
            if key in kw and not isinstance(kw[key], typ):
                raise UsageError(f"request.{key} must be a {typ.__name__}")
        if kw.get("rtol") is not None and not isinstance(kw["rtol"], (int, float)):
            raise UsageError("request.rtol must be a number")
        if kw.get("proof_seconds") is not None and (isinstance(kw["proof_seconds"], bool) or not
                                                    isinstance(kw["proof_seconds"], (int, float))):
            raise UsageError("request.proof_seconds must be a number of seconds or null")
        return cls(**kw)
