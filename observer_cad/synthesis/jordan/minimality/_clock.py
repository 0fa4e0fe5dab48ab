"""The time budget of a minimality proof (METHOD §2b, "k is minimal over λ").

The proofs are informational (their condition is not required), yet some take tens of
seconds. :class:`ProofClock` carries the deadline; the proof's stages and the cell loops
of the covers call :meth:`ProofClock.check` between steps, which raises
:class:`ProofStopped` once the budget is spent. The stage that catches it reports what it
had not decided, and the minimality condition the range the least order lies in.
No threads: a step that has started runs to its end, so a proof may overrun its budget
by one step.
"""
from __future__ import annotations

import dataclasses
import math
import time

from ....errors import UsageError

__all__ = ["ProofClock", "ProofStopped", "UNLIMITED", "proof_seconds_value"]


class ProofStopped(Exception):
    """The proof's time budget was spent before a step (raised by :meth:`ProofClock.check`)."""


@dataclasses.dataclass(frozen=True)
class ProofClock:
    """A deadline on the monotonic clock, or none (``seconds`` None: the exhaustive proof).

    Parameters
    ----------
    seconds : float or None
        The budget; None for no limit.
    deadline : float or None
        ``time.monotonic()`` at which the budget is spent.
    """

    seconds: float | None = None
    deadline: float | None = None

    @classmethod
    def start(cls, seconds: float | None) -> "ProofClock":
        """A clock whose budget of ``seconds`` starts now (None: no limit)."""
        return cls(seconds, None if seconds is None else time.monotonic() + seconds)

    def check(self) -> None:
        """Raise :class:`ProofStopped` when the budget is spent.

        Raises
        ------
        ProofStopped
            The deadline has passed.
        """
        if self.deadline is not None and time.monotonic() >= self.deadline:
            raise ProofStopped(self.seconds)

    def describe(self) -> str:
        """The budget in words, e.g. ``"2 s"``."""
        return "no limit" if self.seconds is None else f"{self.seconds:g} s"


#: the clock of an exhaustive proof (never stops)
UNLIMITED = ProofClock()


def proof_seconds_value(value) -> float | None:
    """The time budget of the minimality proof from an option: a number of seconds ≥ 0,
    or None / ``"exhaustive"`` / ``"inf"`` for the exhaustive proof (no limit).

    Parameters
    ----------
    value : float, int, str or None

    Returns
    -------
    float or None
        Seconds, or None for no limit.

    Raises
    ------
    UsageError
        Not a number, negative or NaN (one line).
    """
    if value is None or (isinstance(value, str) and value.strip().lower() in ("exhaustive", "none")):
        return None
    if isinstance(value, bool):
        raise UsageError(f"proof_seconds must be a number of seconds ≥ 0 or 'exhaustive', got {value!r}")
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"proof_seconds must be a number of seconds ≥ 0 or 'exhaustive',"
                         f" got {value!r}") from None
    if math.isnan(seconds) or seconds < 0:
        raise UsageError(f"proof_seconds must be a number of seconds ≥ 0 or 'exhaustive',"
                         f" got {value!r}")
    return None if math.isinf(seconds) else seconds
