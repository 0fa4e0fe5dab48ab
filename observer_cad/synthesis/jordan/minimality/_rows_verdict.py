"""The answer to "can k rows give z = M x?" (METHOD §2b)."""
from __future__ import annotations

import dataclasses

__all__ = ["RowsVerdict"]


@dataclasses.dataclass(frozen=True)
class RowsVerdict:
    """Can k rows give z = M x — k = q + 1 (:func:`q_plus_one_rows_possible`), k = q + 2
    (:func:`q_plus_two_rows_possible`) or k = n − rank H − 1 (:func:`basis_minus_one_rows_possible`),
    q = rank [M; H] − rank H?

    ``analysed``: False when the case is outside what is decided (``evidence`` says why);
    ``possible``: some w gives k distinct real stable λ (a necessary condition; a design
    still has to be built and certified); ``lambdas``: such λ when found (exact);
    ``evidence``: one line; ``k``: the number of rows asked about (0 when not analysed
    before it was known); ``rows``: when known, one row Φ_i (1 × n, exact) of each λ of
    ``lambdas`` whose images fit together (the design still checks and certifies them)."""

    analysed: bool
    possible: bool
    lambdas: tuple
    evidence: str
    k: int = 0
    rows: tuple = ()
