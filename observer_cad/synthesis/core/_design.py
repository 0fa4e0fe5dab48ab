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
from types import MappingProxyType
from typing import Mapping

import sympy as sp
from sympy.polys.matrices.exceptions import DMError

from ...errors import CertificateError, ObserverCadError, UsageError
from ...model import ObserverKind, PlantModel, Structure, Task, structure_digest
from ...numerics import with_full_int_text
from ..certificates import (CONDITIONING_NAME, CONDITIONING_REFERENCE, MODEL_PREFIX,
                            Certificate, certify_against_model, complete_assumptions,
                            conditioning_numbers, conditioning_verdict, fault_signature)
from ._design_file import design_from_json
from ._feedthrough import feedthrough_outputs_error
from ._values import Condition, DesignMatrices, DesignRequest, Form, Method, SlidingGainInputs

__all__ = ["Design"]


def _latex_name(name: str) -> str:
    """Φ, F^*, H_z, F_{diag}, … for a matrix name."""
    base = name.replace("Phi", r"\Phi").replace("Hz", "H_z").replace("_star", "^*")
    return base.replace("_diag", r"_{\mathrm{diag}}")


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
        why = feedthrough_outputs_error(self)
        if why:  # (inputs in the outputs: r = R* (y − Gy u) − H* x*, z = Hz x* + Q (y − Gy u))
            raise CertificateError(f"{self.structure.model.where}: the design fails its"
                                   f" certificate against the model's own outputs: {why}")
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
            **({"model_hash": structure_digest(self.structure).to_json()}
               if self.structure is not None else {}),
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

        This is the parsing and certifying step only: the conditions, assumptions and
        λ it returns are the file's. A design file is loaded with
        :func:`observer_cad.analysis.load_design` (or
        :func:`observer_cad.synthesis.load_design_data`), which also checks the model
        hash and recomputes every reported value, comparing the recorded ones.
        """
        try:
            return design_from_json(cls, data, model)
        except (TypeError, AttributeError, ValueError, KeyError, IndexError, sp.ShapeError,
                DMError) as exc:
            if isinstance(exc, ObserverCadError):  # (a UsageError is a ValueError too)
                raise
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise UsageError(f"a design's JSON is malformed (a value of the wrong type or"
                             f" shape: {type(exc).__name__}: {first[:160]})") from None
