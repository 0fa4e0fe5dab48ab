"""Design results: immutable values carrying the task, the structure, the matrices, the
conditions, the assumptions and the certificate that re-checked them.

A :class:`Design` serialises with :meth:`Design.to_json` and comes back with
:meth:`Design.from_json`, which parses every expression with a whitelist reader (data
never executes) and re-certifies the matrices against the model before trusting them.
Its :attr:`Design.request` records the options that, passed back to
:func:`observer_cad.synthesis`, reproduce it.
"""
from __future__ import annotations

import dataclasses
import enum
import math
from types import MappingProxyType
from typing import Mapping

import numpy as np
import sympy as sp
from sympy.polys.matrices import DomainMatrix
from sympy.polys.matrices.exceptions import DMError
from sympy.polys.polyerrors import CoercionFailed

from ...errors import CertificateError, ObserverCadError, UsageError
from ...model import ObserverKind, PlantModel, Structure, Task, extract_structure
from ..certificates import complete_assumptions
from ..certificates import MODEL_PREFIX, Certificate, certify_against_model, certify_design
from ..certificates import (CONDITIONING_NAME, CONDITIONING_REFERENCE, conditioning_numbers,
                            conditioning_verdict)
from ._expr import parse_json_expression
from ...numerics import exact_rank_value, np_exact, with_full_int_text
from ._poles import certify_poles
from ._reduced import (INJECTIONS, estimate_outputs, output_symbols, reduced_equations,
                       residual_outputs, sliding_equations)
from ..certificates import fault_signature

__all__ = ["Condition", "Design", "DesignMatrices", "DesignRequest", "Form", "Method",
           "NonlinearSubstitution", "SlidingGainInputs", "MATRIX_ORDER"]

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
    :func:`observer_cad.synthesis.gain_bound`): ``delta`` bounds |x̂*(0) − x*(0)|,
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


def _latex_name(name: str) -> str:
    """Φ, F^*, H_z, F_{diag}, … for a matrix name."""
    base = name.replace("Phi", r"\Phi").replace("Hz", "H_z").replace("_star", "^*")
    return base.replace("_diag", r"_{\mathrm{diag}}")


def _declared(model: PlantModel) -> list:
    return [s for role in ("states", "inputs", "faults", "disturbances", "noise")
            for s in getattr(model, role)] + list(model.parameters)


@dataclasses.dataclass(frozen=True)
class Design:
    """A certified reduced-order model (METHOD §2) and the decisions behind it.

    ``task`` says what it is for (observer kind, inputs estimated/detected, decoupled,
    bounded, assumed zero, z = M x); ``structure`` is the plant structure it was derived
    from (parameters substituted unless symbolic); ``matrices`` the typed
    :class:`DesignMatrices`. ``assumptions`` are the relations (``Ne(k4, 0)``) under which
    a symbolic result holds. ``choice`` explains which null-space member was taken and why;
    ``attempts`` records every k tried; ``request`` reproduces the design.
    """

    model_name: str
    task: Task
    structure: Structure
    form: Form
    k: int
    matrices: DesignMatrices
    conditions: tuple
    assumptions: tuple
    certificate: Certificate
    symbolic: bool
    method: Method
    choice: str
    attempts: tuple
    null_space: tuple = ()  # reduced-echelon basis of the members at k (exact designs)
    time: str = "continuous"  # of the plant, hence of the observer
    lambdas: tuple = ()  # Jordan form: the eigenvalue of each row
    closed_loop_eigenvalues: tuple = ()
    nonlinear: tuple = ()  # of NonlinearSubstitution
    equations: tuple = ()  # observer right-hand sides (sympy expressions)
    observer_states: tuple = ()  # symbols of x* (xs1, xs2, ...)
    outputs: tuple = ()  # (name, sympy expression) of the observer's outputs
    approximate: bool = False
    residual_norm: float | None = None
    parameters: Mapping = dataclasses.field(default_factory=dict)  # observer gains: symbol → value
    request: DesignRequest | None = None
    signature: tuple = ()  # of FaultSensitivity: every declared fault vs the residual
    sliding_inputs: SlidingGainInputs | None = None  # sliding-mode designs: δ, N*

    def __post_init__(self):
        if isinstance(self.matrices, Mapping):
            object.__setattr__(self, "matrices", DesignMatrices.from_mapping(self.matrices))
        object.__setattr__(self, "form", Form(self.form))
        object.__setattr__(self, "method", Method(self.method))
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))
        object.__setattr__(self, "assumptions", self._complete_assumptions())
        object.__setattr__(self, "certificate", self._with_model_check())
        object.__setattr__(self, "conditions", self._with_conditioning())

    def _with_model_check(self) -> Certificate:
        """The designer's certificate with the identities re-derived from the model's own
        equations (:func:`~observer_cad.synthesis.certify_against_model`) added, once: the
        designer checked the matrices against the extracted structure, this checks them
        against the right-hand side and outputs the engineer wrote. A failure raises
        :class:`~observer_cad.errors.CertificateError`: a design that fails is never an
        output."""
        cert = self.certificate
        if self.structure is None or cert is None or any(
                i.name.startswith(MODEL_PREFIX) for i in cert.identities):
            return cert
        ids = certify_against_model(
            self.structure.model, self.matrices.as_dict(), self.task, nonlinear=self.nonlinear,
            observer_states=self.observer_states, exact=cert.exact,
            tolerance=cert.tolerance if cert.tolerance is not None else 1e-9,
            approximate=self.approximate)
        full = Certificate(tuple(cert.identities) + ids, cert.exact, cert.tolerance)
        if not full.passed:
            raise CertificateError(
                f"{self.structure.model.where}: the design fails its certificate against the"
                f" model's own equations: {full.summary()}")
        return full

    def _with_conditioning(self) -> tuple:
        """The designer's conditions with the conditioning condition (scale of Φ, noise
        gain; required=False) recomputed for these matrices and put last
        (:mod:`observer_cad.synthesis.certificates._conditioning`)."""
        conds = tuple(c for c in self.conditions if c.name != CONDITIONING_NAME)
        if self.structure is None:
            return conds
        params = dict(self.structure.model.parameters)
        nums = conditioning_numbers(self.task.observer.value, self.matrices, self.structure.H,
                                    params)
        holds, detail = conditioning_verdict(nums, at_defaults=bool(params))
        return conds + (Condition(CONDITIONING_NAME, holds, detail, CONDITIONING_REFERENCE,
                                  required=False),)

    @property
    def conditioning(self) -> "Condition":
        """The conditioning condition (always present; see README "Conditioning")."""
        return next(c for c in self.conditions if c.name == CONDITIONING_NAME)

    def _complete_assumptions(self) -> tuple:
        """The designer's assumptions (pivots, D* ≠ 0, rank Φ = k, minimality) plus the
        nonzero condition of every denominator in the model's parameters of everything
        the design reports: every matrix, the nonlinear substitutions, the observer
        equations and outputs, the gains, λ and the closed-loop eigenvalues (see
        :mod:`observer_cad.synthesis.certificates._assumptions`). Every design passes through here,
        so no designer can forget one."""
        params = tuple(self.structure.model.parameters) if self.structure is not None else ()
        if not params:
            return tuple(self.assumptions)
        mats = [M for _, M in self.matrices.items()]
        for ns in self.nonlinear:
            mats += [ns.A1, ns.A2]
        exprs = list(self.equations) + [e for _, e in self.outputs]
        exprs += list(self.parameters.values()) + list(self.lambdas)
        exprs += list(self.closed_loop_eigenvalues)
        exprs += [ns.argument for ns in self.nonlinear]
        return complete_assumptions(self.assumptions, matrices=mats, expressions=exprs,
                                    parameters=params)

    # -- what the task says, for convenience
    @property
    def observer(self) -> ObserverKind:
        return self.task.observer

    @property
    def unknown_input(self) -> str | None:
        return self.task.unknown_input

    @property
    def decoupled(self) -> tuple:
        return self.task.decoupled

    @property
    def estimate(self) -> str | None:
        return self.task.estimate

    @property
    def ordered_matrices(self):
        return self.matrices.items()

    @property
    def signature_map(self) -> dict:
        """Fault name → True (the residual is sensitive to it) / False (decoupled)."""
        return {s.name: bool(s.sensitive) for s in self.signature}

    def with_signature(self) -> "Design":
        """The same design with its full fault signature (:func:`fault_signature`) computed
        from its matrices and structure; the relations a detected or estimated fault's
        sensitivity needs join the assumptions."""
        sig = fault_signature(self.matrices, self.structure, self.task)
        extra = [c for s in sig if s.role in ("detected", "estimated") for c in s.conditions
                 if c not in self.assumptions]
        assumptions = tuple(self.assumptions) + tuple(sorted(set(extra), key=str))
        return dataclasses.replace(self, signature=sig, assumptions=assumptions)

    def with_task(self, **changes) -> "Design":
        """The same design with its task changed (e.g. the observer kind it serves)."""
        return dataclasses.replace(self, task=dataclasses.replace(self.task, **changes))

    def __repr__(self) -> str:
        cert = "certified" if self.certificate.passed else "NOT certified"
        approx = ", APPROXIMATE" if self.approximate else ""
        return (f"<Design {self.observer.value} for {self.model_name}: {self.task.describe()};"
                f" {self.form.value} form, k = {self.k}, {self.method.value}{approx}, {cert}>")

    def _repr_markdown_(self) -> str:
        """Notebook view: what, the matrices (LaTeX), the conditions, the assumptions."""
        cert = "**certified**" if self.certificate.passed else "**NOT certified**"
        lines = [f"**Design** `{self.observer.value}` for `{self.model_name}`: "
                 f"{self.task.describe()} — {self.form.value} form, k = {self.k},"
                 f" {self.method.value} arithmetic, {cert}"
                 + (" — **APPROXIMATE**" if self.approximate else ""), ""]
        for name, M in self.matrices.items():
            lines.append(f"$${_latex_name(name)} = {sp.latex(sp.Matrix(M))}$$")
        lines += ["", "| | condition | evidence |", "|---|---|---|"]
        for c in self.conditions:
            mark = "✅" if c.holds else ("❌" if c.required else "—")
            detail = c.detail.replace("|", "\\|")
            lines.append(f"| {mark} | {c.name} | {detail} |")
        if self.signature:
            lines += ["", "Fault signature (1 = the residual responds): " + ", ".join(
                f"`{f.name}` {int(bool(f.sensitive))}" for f in self.signature)]
        if self.assumptions:
            lines += ["", "Assumptions: " + ", ".join(f"${sp.latex(a)}$" for a in self.assumptions)]
        return "\n".join(lines)

    def _repr_latex_(self) -> str:
        body = r" \\ ".join(f"{_latex_name(n)} &= {sp.latex(sp.Matrix(M))}"
                             for n, M in self.matrices.items())
        return r"$\begin{aligned}" + body + r"\end{aligned}$"

    @with_full_int_text  # exact rationals of any length are written in full
    def to_json(self) -> dict:
        """The JSON object the CLI prints with ``--json``."""
        def rows(M):
            M = sp.Matrix(M)
            return [[str(M[i, j]) for j in range(M.cols)] for i in range(M.rows)]
        return {
            "model": self.model_name,
            "k": self.k,
            "form": self.form.value,
            "method": self.method.value,
            "unknown_input": self.unknown_input,
            "decoupled": list(self.decoupled),
            "matrices": {n: rows(M) for n, M in self.ordered_matrices},
            "conditions": [c.to_json() for c in self.conditions],
            "assumptions": [str(a) for a in self.assumptions],
            "choice": self.choice,
            "attempts": list(self.attempts),
            "null_space": [[str(e) for e in v] for v in self.null_space],
            "observer": self.observer.value,
            "time": self.time,
            "estimate": self.estimate,
            "lambdas": [str(v) for v in self.lambdas],
            "closed_loop_eigenvalues": [str(v) for v in self.closed_loop_eigenvalues],
            "nonlinear": [n.to_json() for n in self.nonlinear],
            "states": [str(s) for s in self.observer_states],
            "equations": [str(e) for e in self.equations],
            "outputs": {name: str(e) for name, e in self.outputs},
            "approximate": bool(self.approximate),
            **({"residual_norm": self.residual_norm} if self.approximate else {}),
            "certificate": {"passed": self.certificate.passed,
                            "exact": self.certificate.exact,
                            "tolerance": self.certificate.tolerance,
                            "identities": [{"name": i.name, "holds": i.holds,
                                            "residual": i.residual}
                                           for i in self.certificate.identities]},
            "symbolic": bool(self.symbolic),
            "task": self.task.to_json(),
            "parameters": {str(p): str(v) for p, v in self.parameters.items()},
            "request": self.request.to_json() if self.request is not None else None,
            "signature": self.signature_map,
            "signature_detail": [s.to_json() for s in self.signature],
            **({"sliding_inputs": self.sliding_inputs.to_json()}
               if self.sliding_inputs is not None else {}),
        }

    @classmethod
    @with_full_int_text  # messages and identities may print rationals of any length
    def from_json(cls, data, model: PlantModel) -> "Design":
        """A design from its JSON (:meth:`to_json`) for ``model``.

        Every expression is read by a whitelist parser (numbers, the model's and the
        design's own names, arithmetic and a fixed list of functions); the task is
        re-resolved against the model; the matrices are re-certified against the model's
        structure (exactly, or in floating point within the recorded tolerance, itself
        bounded, for float and approximate designs); the equations and outputs must be the
        ones the matrices give. A design that does not fit the model or fails its
        certificate raises; nothing is trusted because it was on disk. A value of the wrong
        type or shape anywhere is one UsageError naming what Python or sympy refused.
        """
        try:
            return cls._from_json(data, model)
        except (TypeError, AttributeError, ValueError, KeyError, IndexError, sp.ShapeError,
                DMError) as exc:
            if isinstance(exc, ObserverCadError):  # (a UsageError is a ValueError too)
                raise
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise UsageError(f"a design's JSON is malformed (a value of the wrong type or"
                             f" shape: {type(exc).__name__}: {first[:160]})") from None

    @classmethod
    def _from_json(cls, data, model: PlantModel) -> "Design":
        if not isinstance(data, dict) or not isinstance(data.get("matrices"), dict):
            raise UsageError("not a design: a JSON object with 'matrices' is expected")
        if not isinstance(model, PlantModel):
            raise UsageError("Design.from_json needs the PlantModel the design is for")
        for key in ("k", "form", "method", "observer", "time", "states", "equations", "outputs"):
            if key not in data:
                raise UsageError(f"not a design: the key '{key}' is missing")
        task_data = data.get("task") or {
            "observer": data["observer"],
            "targets": [data["unknown_input"]] if data.get("unknown_input") else [],
            "decoupled": list(data.get("decoupled", [])), "estimate": data.get("estimate")}
        task = Task.from_json(task_data, model)
        symbolic = bool(data.get("symbolic", False))
        work = model if (symbolic or not model.parameters) else model.substitute_parameters()
        if data["time"] != work.time:
            raise UsageError(f"{model.where}: the design is {data['time']}-time, the model"
                             f" {work.time}-time")
        st = extract_structure(work)
        k = data["k"]
        if not isinstance(k, int) or isinstance(k, bool) or k < 1:
            raise UsageError("a design's k must be a positive integer")
        if not isinstance(data["states"], list):
            raise UsageError("a design's 'states' must list the observer's states")
        names = {s.name: s for s in _declared(model)}
        xs = []
        for s in data["states"]:
            if not isinstance(s, str) or not s.isidentifier():
                raise UsageError(f"a design state name must be an identifier, got {s!r}")
            xs.append(names.setdefault(s, sp.Symbol(s)))
        for j in range(1, len(work.outputs) + 1):
            names.setdefault(f"y{j}", sp.Symbol(f"y{j}"))
        params = {}
        for p, v in (data.get("parameters") or {}).items():
            if not isinstance(p, str) or not p.isidentifier():
                raise UsageError(f"a design parameter name must be an identifier, got {p!r}")
            sym = names.setdefault(p, sp.Symbol(p))
            params[sym] = parse_json_expression(v, names, f"parameters.{p}")

        def expr(text, where):
            return parse_json_expression(text, names, where)

        mats = {}
        for name, rows_ in data["matrices"].items():
            if name not in MATRIX_ORDER:
                raise UsageError(f"a design has an unknown matrix {name!r}")
            if not isinstance(rows_, list) or not all(isinstance(r, list) for r in rows_):
                raise UsageError(f"matrix {name} must be a list of rows")
            widths = {len(r) for r in rows_}
            if len(widths) > 1:
                raise UsageError(f"matrix {name}: rows of different lengths")
            mats[name] = sp.Matrix(len(rows_), widths.pop() if widths else 0,
                                   [expr(e, f"matrices.{name}") for r in rows_ for e in r])
        for name in ("Phi", "F_star", "J_star", "G_star"):
            if name not in mats:
                raise UsageError(f"not a design: matrix {name} is missing")
        nonlinear = []
        for item in data.get("nonlinear", []):
            try:
                nonlinear.append(NonlinearSubstitution(
                    int(item["index"]), expr(item["function"], "nonlinear.function"),
                    expr(item["argument"], "nonlinear.argument"),
                    sp.Matrix([[expr(e, "nonlinear.A1") for e in item["A1"]]]),
                    sp.Matrix([[expr(e, "nonlinear.A2") for e in item["A2"]]])))
            except (KeyError, TypeError, ValueError):
                raise UsageError("a design's nonlinear substitution is malformed") from None
        outputs = data["outputs"]
        if not isinstance(outputs, dict):
            raise UsageError("a design's 'outputs' must be an object")
        approximate = data.get("approximate", False)
        if not isinstance(approximate, bool):
            raise UsageError("a design's 'approximate' must be true or false")
        cert_data = data.get("certificate") or {}
        if not isinstance(cert_data, dict):
            raise UsageError("a design's 'certificate' must be an object")
        exact = cert_data.get("exact", True)
        if not isinstance(exact, bool):
            raise UsageError("a design's certificate 'exact' must be true or false")
        exact = exact and not approximate
        # re-certify: the loaded matrices against the model's structure
        plant = dict(F=st.F, G=st.G, H=st.H, C=st.C, D=task.D(st), L=task.L(st))
        M_task = task.M if "Hz" in mats else None
        tol = None if exact else _float_tolerance(cert_data.get("tolerance"), plant, mats, M_task)
        subs = [(ns.index, sp.Matrix(st.A[ns.index - 1, :]), ns.A1, ns.A2) for ns in nonlinear]
        # (an approximate design's Φ L is its residual, not an identity: recomputed below)
        cert = certify_design(plant, mats, M=M_task, substitutions=subs,
                              decoupled=task.observer != ObserverKind.INTERVAL and not approximate,
                              exact=exact, tolerance=tol if tol is not None else 1e-9)
        residual_norm = (_residual_norm(data.get("residual_norm"), mats, plant["L"])
                         if approximate else None)
        conditions = tuple(Condition.from_json(c) for c in data.get("conditions", []))
        request = None
        if data.get("request") is not None:
            request = DesignRequest.from_json(data["request"], names)
        sliding_inputs = (SlidingGainInputs.from_json(data["sliding_inputs"])
                          if data.get("sliding_inputs") is not None else None)
        recorded = data.get("signature")
        if recorded is not None and (not isinstance(recorded, dict) or not all(
                isinstance(k, str) and isinstance(v, bool) for k, v in recorded.items())):
            raise UsageError("a design's 'signature' must map fault names to true/false")
        made = cls(
            model_name=work.name, task=task, structure=st, form=data["form"], k=k,
            matrices=mats, conditions=conditions,
            assumptions=tuple(expr(a, "assumptions") for a in data.get("assumptions", [])),
            certificate=cert, symbolic=symbolic, method=data["method"],
            choice=str(data.get("choice", "")), attempts=tuple(map(str, data.get("attempts", []))),
            null_space=tuple(sp.Matrix([[expr(e, "null_space") for e in v]])
                             for v in data.get("null_space", [])),
            time=work.time, lambdas=tuple(expr(v, "lambdas") for v in data.get("lambdas", [])),
            closed_loop_eigenvalues=tuple(expr(v, "closed_loop_eigenvalues")
                                          for v in data.get("closed_loop_eigenvalues", [])),
            nonlinear=tuple(nonlinear),
            equations=tuple(expr(e, "equations") for e in data["equations"]),
            observer_states=tuple(xs),
            outputs=tuple((str(n), expr(e, f"outputs.{n}")) for n, e in outputs.items()),
            approximate=approximate,
            residual_norm=residual_norm,
            parameters=params, request=request, sliding_inputs=sliding_inputs)
        if sliding_inputs is not None and made.observer != ObserverKind.SLIDING_MODE:
            raise UsageError("'sliding_inputs' belong to a sliding-mode design only")
        # a gain K is re-checked too: det(sI − F* + K H*) = Π(s − μ) for the recorded μ
        m = made.matrices
        if m.K is not None:  # (a file that drops the eigenvalues does not skip the check)
            mu = made.closed_loop_eigenvalues
            if len(mu) != sp.Matrix(m.F_star).rows:
                raise UsageError(f"the design has a gain K but records {len(mu)} closed-loop"
                                 f" eigenvalues for {sp.Matrix(m.F_star).rows} states: not a"
                                 " design this tool writes")
            if exact:
                certify_poles(m.F_star, m.H_star, m.K, mu)
            else:
                _float_poles(m.F_star, m.H_star, m.K, mu)
        # the signature is recomputed from the matrices, never read: a recorded one must agree
        sig = fault_signature(made.matrices, st, task)
        if recorded:
            mine = {s.name: bool(s.sensitive) for s in sig}
            for name, val in recorded.items():
                if name not in mine:
                    raise UsageError(f"the design's recorded signature names {name!r}, which is"
                                     f" not a fault of the model (its faults:"
                                     f" {', '.join(mine) or 'none'})")
                if mine[name] != val:
                    raise UsageError(f"the design's recorded signature says {name} is "
                                     f"{'sensitive' if val else 'decoupled'}, but its matrices"
                                     f" make the residual {'sensitive' if mine[name] else 'decoupled'}")
        if sp.Matrix(mats["Phi"]).rows != k or sp.Matrix(mats["F_star"]).shape != (k, k):
            raise UsageError(f"the design says k = {k}, but Φ has {sp.Matrix(mats['Phi']).rows}"
                             " rows: not a design this tool writes")
        if "L_star" in mats and task.observer != ObserverKind.INTERVAL and not approximate:
            # decoupled: L* = Φ L, which the certificate proved 0 (observers read L*)
            if not all(_same_expression(e, 0) for e in sp.Matrix(mats["L_star"])):
                raise UsageError("the design decouples its disturbances (Φ L = 0) but records"
                                 " L* ≠ 0: not a design this tool writes")
        if "T" in mats:  # the seed-001 diagonal form: what T makes of the certified design
            _check_diagonal_form(made.matrices, plant, task.M)
        _check_substitutions(made, st)  # (after the matrices' own certificates)
        if made.lambdas:  # a Jordan design's λ are F*'s diagonal (reports show them)
            F = sp.Matrix(made.matrices.F_star)
            if not (F.is_diagonal() and len(made.lambdas) == F.rows and all(
                    _same_expression(v, F[i, i]) for i, v in enumerate(made.lambdas))):
                raise UsageError("the design's lambdas are not the diagonal of its F*: not a"
                                 " design this tool writes")
        _check_equations(made, work)
        return dataclasses.replace(made, signature=sig)


#: The loosest float certificate a design file may ask for, relative to the size of the
#: identities' terms (the float paths certify at 1e-10 … 1e-8 of it; a file is data, so its
#: tolerance is bounded, never taken as it is)
LOADED_TOLERANCE_RTOL = 1e-6


def _float_tolerance(tol, plant: dict, mats: dict, M) -> float:
    """A float design's recorded certificate tolerance, checked: a finite positive number
    at most :data:`LOADED_TOLERANCE_RTOL` times the largest product of norms the identities
    subtract (‖Φ‖‖F‖, ‖F*‖‖Φ‖, ‖J*‖‖H‖, …, computed here from the loaded matrices)."""
    if isinstance(tol, bool) or not isinstance(tol, (int, float)):
        raise UsageError("a float design must record its certificate tolerance (a number)")
    if not (math.isfinite(tol) and tol > 0):
        raise UsageError(f"a design's certificate tolerance must be a finite positive number,"
                         f" got {tol!r}")

    def nrm(X):
        X = sp.Matrix(X)
        return float(np.linalg.norm(np_exact(X))) if X.rows * X.cols else 0.0

    phi = nrm(mats["Phi"])
    sizes = [phi * nrm(plant[k]) for k in ("F", "G", "D", "L", "C")]
    sizes += [nrm(mats["F_star"]) * phi, nrm(mats["J_star"]) * nrm(plant["H"])]
    for a, b in (("H_star", None), ("R_star", "H"), ("Hz", None), ("Q", "H")):
        if a in mats:
            sizes.append(nrm(mats[a]) * (phi if b is None else nrm(plant[b])))
    if M is not None:
        sizes.append(nrm(M))
    cap = LOADED_TOLERANCE_RTOL * max([1.0] + sizes)
    if tol > cap:
        raise UsageError(f"a design's certificate tolerance {tol:.3g} exceeds"
                         f" {LOADED_TOLERANCE_RTOL:g} of the size of its identities' terms"
                         f" ({cap:.3g}): not a design this tool writes")
    return float(tol)


def _residual_norm(recorded, mats: dict, L) -> float:
    """An approximate design's ‖Φ L‖_F, recomputed from the loaded Φ and the model's L; a
    recorded value that differs (beyond rounding) is refused."""
    Ln = np_exact(sp.Matrix(L))
    value = float(np.linalg.norm(np_exact(sp.Matrix(mats["Phi"])) @ Ln)) if Ln.size else 0.0
    if recorded is not None and (isinstance(recorded, bool) or not isinstance(recorded, (int, float))
                                 or abs(recorded - value) > 1e-9 * max(1.0, value)):
        raise UsageError(f"a design's recorded residual_norm {recorded!r} is not ‖Φ L‖_F ="
                         f" {value:.6e} of its matrices")
    return value


def _check_substitutions(d: "Design", st) -> None:
    """Each argument substitution of a design file is the model's term φ_j with its
    argument A_j x written as A*_1j x* + A*_2j y (A*_1j, A*_2j certified above), and there
    is one for every nonzero column of C* — a changed function, or one left out, would
    change the observer while the matrices still pass (METHOD §2c)."""
    xs = sp.Matrix(list(d.observer_states))
    ys = sp.Matrix(list(output_symbols(sp.Matrix(st.H).rows)))
    m = d.matrices.as_dict()
    Cs = sp.Matrix(m["C_star"]) if "C_star" in m else None
    need = ({j + 1 for j in range(Cs.cols) if any(e != 0 for e in Cs[:, j])}
            if Cs is not None else set())
    have = [ns.index for ns in d.nonlinear]
    if sorted(have) != sorted(need):
        raise UsageError(f"the design's argument substitutions are for the terms"
                         f" {sorted(have) or 'none'}, but C* has nonzero columns"
                         f" {sorted(need) or 'none'}: not a design this tool writes")
    for ns in d.nonlinear:
        if not 1 <= ns.index <= len(st.terms) or ns.A1.shape != (1, len(xs)) \
                or ns.A2.shape != (1, len(ys)):
            raise UsageError(f"the design's argument substitution {ns.index} does not fit the"
                             " model's terms")
        t = st.terms[ns.index - 1]
        arg = sp.expand((ns.A1 * xs)[0, 0] + (ns.A2 * ys)[0, 0])
        if not (_same_expression(ns.argument, arg)
                and _same_expression(ns.function, t.function.xreplace({t.argument: arg}))):
            raise UsageError(f"the design's argument substitution {ns.index} is not the model's"
                             f" term {t.function} with A*_1 x* + A*_2 y as its argument: not a"
                             " design this tool writes")


def _check_diagonal_form(mats, plant: dict, M) -> None:
    """The diagonal form of seed 001 (method 1) that interval observers are built from:
    with T from the file, F_diag = T⁻¹ (F* − K H*) T diagonal, J_diag = T⁻¹ (J* + K R*),
    Φ_diag = T⁻¹ Φ, G_diag = T⁻¹ G*, H_z,diag = H_z T, recomputed exactly and compared,
    then certified as a design of its own (its identities against the plant)."""
    m = {k: sp.Matrix(v) for k, v in mats.as_dict().items()}
    T = m["T"]
    bad_t = UsageError("the design's T is not an invertible k × k matrix: not a design this"
                       " tool writes")
    if T.rows != T.cols or T.rows != m["F_star"].rows:
        raise bad_t
    K = m.get("K", sp.zeros(m["F_star"].rows, m["J_star"].cols))
    try:  # rational matrices (the usual case): exact arithmetic over QQ, fast for long numbers
        Q = {k: DomainMatrix.from_Matrix(v).convert_to(sp.QQ) for k, v in
             dict(m, K=K).items() if k in ("T", "F_star", "H_star", "J_star", "R_star", "Phi",
                                            "G_star", "Hz", "K", "F_diag", "J_diag",
                                            "Phi_diag", "G_diag", "Hz_diag")}
        if exact_rank_value(T) < T.rows:
            raise bad_t
        # T X = Y instead of X = T⁻¹ Y: products only (inverting a matrix of long rationals
        # cost seconds)
        Tq = Q["T"]

        def left(name):  # T · X_diag, or None when the file lacks it or its shape is wrong
            X = Q.get(name)
            return Tq * X if X is not None and X.shape[0] == Tq.shape[1] else None

        pairs = {"F_diag": (left("F_diag"), (Q["F_star"] - Q["K"] * Q["H_star"]) * Tq),
                 "J_diag": (left("J_diag"), Q["J_star"] + Q["K"] * Q["R_star"]),
                 "Phi_diag": (left("Phi_diag"), Q["Phi"]), "G_diag": (left("G_diag"), Q["G_star"]),
                 "Hz_diag": (Q.get("Hz_diag"), Q["Hz"] * Tq)}
        same = {k: a is not None and a.shape == b.shape and a == b for k, (a, b) in pairs.items()}
    except (CoercionFailed, KeyError):  # parameters or algebraic numbers: sympy, cancelled
        if T.det() == 0:
            raise bad_t from None
        Ti = T.inv()
        want = {"F_diag": Ti * (m["F_star"] - K * m["H_star"]) * T,
                "J_diag": Ti * (m["J_star"] + K * m["R_star"]), "Phi_diag": Ti * m["Phi"],
                "G_diag": Ti * m["G_star"], "Hz_diag": m["Hz"] * T}
        same = {k: k in m and m[k].shape == W.shape and all(
            _same_expression(a, b) for a, b in zip(m[k], W)) for k, W in want.items()}
    for name, ok in same.items():
        if not ok:
            raise UsageError(f"the design's {name} is not what its T makes of the certified"
                             " matrices: not a design this tool writes")
    if not m["F_diag"].is_diagonal():
        raise UsageError("the design's F_diag is not diagonal: not a design this tool writes")
    certify_design(plant, {"Phi": m["Phi_diag"], "F_star": m["F_diag"], "J_star": m["J_diag"],
                           "G_star": m["G_diag"], "Hz": m["Hz_diag"], "Q": m["Q"]}, M=M)


def _float_poles(F, H, K, mu) -> None:
    """A float design's gain: the eigenvalues of F* − K H* are the recorded ones (each
    within 1e-6 relative of its nearest, in floating point)."""
    A = np_exact(sp.Matrix(F) - sp.Matrix(K) * sp.Matrix(H))
    got = np.sort_complex(np.linalg.eigvals(A))
    want = np.sort_complex(np.array([complex(sp.N(v)) for v in mu]))
    if not np.allclose(got, want, rtol=1e-6, atol=1e-9):
        raise UsageError("the design's closed-loop eigenvalues are not those of F* − K H*:"
                         " not a design this tool writes")


def _same_expression(a, b) -> bool:
    d = sp.expand(a - b)
    return d == 0 or sp.simplify(d) == 0


def _check_equations(d: "Design", work) -> None:
    """The equations and outputs a design file carries are what its (certified) matrices
    give — the observer is built from them, so they are checked, not trusted: the
    reduced model F* x* + J* y + G* u + C* Ψ* + K r (when K is there; METHOD §2), its
    estimates z = H_z x* + Q y and residuals r = R* y − H* x*, or the sliding-mode
    injection (seed 002 §5). A design without states, equations and outputs (the robust
    canonical designs: matrices only) has none to check."""
    if not (d.observer_states or d.equations or d.outputs):
        return
    m = d.matrices.as_dict()
    xs = tuple(d.observer_states)
    ys = output_symbols(len(work.outputs))
    if d.observer == ObserverKind.SLIDING_MODE:
        fault = d.task.targets[0] if d.task.targets else ""
        options = [sliding_equations(m, work.inputs, xs[:1], ys, str(fault), inj,
                                     nonlinear=d.nonlinear)
                   for inj in INJECTIONS]
        candidates = [(u, dict(o)) for states, u, o in options
                      if [str(s) for s in states] == [str(s) for s in xs]]
    else:
        outs = {}
        if "Hz" in m:
            z = list(estimate_outputs(m, xs, ys))
            outs.update({("z" if len(z) == 1 else f"z{i + 1}"): e for i, e in enumerate(z)})
        if "R_star" in m and "H_star" in m:
            r = list(residual_outputs(m, xs, ys))
            outs.update({("r" if len(r) == 1 else f"r{i + 1}"): e for i, e in enumerate(r)})
        candidates = [(reduced_equations(m, work.inputs, xs, ys, nonlinear=d.nonlinear), outs)]
    for update, outs in candidates:
        if len(update) == len(d.equations) and all(
                _same_expression(a, b) for a, b in zip(d.equations, update)):
            break
    else:
        raise UsageError("the design's equations are not the ones its matrices give (the"
                         " observer is built from them): not a design this tool writes")
    for name, e in d.outputs:
        if name not in outs or not _same_expression(e, outs[name]):
            raise UsageError(f"the design's output {name} is not the one its matrices give:"
                             " not a design this tool writes")
    # and none is missing: the observers read them by name
    kind = d.observer
    need = (set(outs) if kind == ObserverKind.SLIDING_MODE else
            {n for n in outs if n[0] == "z"} if kind in (ObserverKind.VIRTUAL_SENSOR,
                                                          ObserverKind.INTERVAL) else
            {n for n in outs if n[0] == "r"} if kind == ObserverKind.DIAGNOSTIC else set())
    missing = sorted(need - {n for n, _ in d.outputs})
    if missing:
        raise UsageError(f"the design's outputs lack {', '.join(missing)}: not a design this"
                         " tool writes")
