"""Design results: immutable values carrying matrices, conditions, assumptions and
the certificate that re-checked them."""
from __future__ import annotations

import dataclasses
from typing import Mapping

import sympy as sp

from ._certificate import Certificate

__all__ = ["Condition", "Design", "NonlinearSubstitution", "MATRIX_ORDER"]

#: Order in which a design's matrices are printed and serialised.
MATRIX_ORDER = ("Phi", "F_star", "J_star", "R_star", "H_star", "G_star", "D_star", "L_star",
                "C_star", "Hz", "Q", "K")


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
class Design:
    """A certified reduced-order model (METHOD §2) and the decisions behind it.

    ``matrices`` maps names (``Phi``, ``F_star``, ``J_star``, ``R_star``, ``H_star``,
    ``G_star``, ``D_star``, ``L_star``, ...) to sympy matrices. ``assumptions`` are the
    relations (``Ne(k4, 0)``) under which a symbolic result holds. ``choice`` explains
    which null-space member was taken and why; ``attempts`` records every k tried.
    """

    model_name: str
    form: str
    k: int
    matrices: dict
    conditions: tuple
    assumptions: tuple
    certificate: Certificate
    unknown_input: str | None
    decoupled: tuple
    symbolic: bool
    method: str  # "exact" or "float"
    choice: str
    attempts: tuple
    null_space: tuple = ()  # reduced-echelon basis of the members at k (exact designs)
    observer: str = "unknown-input"
    time: str = "continuous"  # of the plant, hence of the observer
    estimate: str | None = None  # z = M x for virtual sensors / interval observers
    lambdas: tuple = ()  # Jordan form: the eigenvalue of each row
    closed_loop_eigenvalues: tuple = ()
    nonlinear: tuple = ()  # of NonlinearSubstitution
    equations: tuple = ()  # observer right-hand sides (sympy expressions)
    observer_states: tuple = ()  # symbols of x* (xs1, xs2, ...)
    outputs: tuple = ()  # (name, sympy expression) of the observer's outputs
    approximate: bool = False
    residual_norm: float | None = None
    parameters: Mapping = dataclasses.field(default_factory=dict)  # observer gains: symbol → value

    def matrix(self, name: str) -> sp.Matrix:
        return self.matrices[name]

    @property
    def ordered_matrices(self):
        names = [n for n in MATRIX_ORDER if n in self.matrices]
        names += [n for n in self.matrices if n not in names]
        return [(n, self.matrices[n]) for n in names]

    def to_json(self) -> dict:
        """The JSON object the CLI prints with ``--json``."""
        def rows(M):
            M = sp.Matrix(M)
            return [[str(M[i, j]) for j in range(M.cols)] for i in range(M.rows)]
        return {
            "model": self.model_name,
            "k": self.k,
            "form": self.form,
            "method": self.method,
            "unknown_input": self.unknown_input,
            "decoupled": list(self.decoupled),
            "matrices": {n: rows(M) for n, M in self.ordered_matrices},
            "conditions": [c.to_json() for c in self.conditions],
            "assumptions": [str(a) for a in self.assumptions],
            "choice": self.choice,
            "attempts": list(self.attempts),
            "null_space": [[str(e) for e in v] for v in self.null_space],
            "observer": self.observer,
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
        }
