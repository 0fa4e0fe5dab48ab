"""Exceptions raised by observer_cad.

Every error a user can provoke is an :class:`ObserverCadError`; its message is one
line that names the problem and where it is (model file, symbol, equation). The CLI
prints that line and exits with status 2.
"""
from __future__ import annotations

import errno


class ObserverCadError(Exception):
    """Base class of every error observer_cad raises on purpose."""


class ModelError(ObserverCadError, ValueError):
    """A plant model is malformed (undeclared symbol, wrong role, not affine, ...)."""


class DimensionError(ModelError):
    """Lengths or shapes of the model's parts do not agree."""


class InfeasibleDesignError(ObserverCadError):
    """No design satisfies the requested conditions.

    ``attempts`` lists, for every k tried, the condition that failed.
    """

    def __init__(self, message: str, attempts: tuple = ()):
        super().__init__(message)
        self.attempts = tuple(attempts)


class CertificateError(ObserverCadError):
    """A synthesised design failed the independent re-check of its defining identities."""


class UsageError(ObserverCadError):
    """An option given to the CLI or a public function is invalid."""


class FailedConditionError(UsageError):
    """An observer was built but fails a required condition (e.g. an unstable gain): it
    must not be used. ``observer`` is what was built (to show its conditions)."""

    def __init__(self, message: str, observer=None):
        super().__init__(message)
        self.observer = observer


class ExpressionError(UsageError):
    """Text that should denote an expression (a scenario signal, a CLI value) is not one
    the whitelist grammar accepts; ``reason`` says what was rejected."""

    def __init__(self, message: str, reason: str = ""):
        super().__init__(message)
        self.reason = reason or message


class NonFiniteError(ObserverCadError):
    """A simulation produced a value that is not finite (NaN or ±inf). The CLI exits
    with status 4 (not 2: the input was well-formed, the trajectory left the domain)."""


def describe_failure(exc: BaseException) -> tuple[bool, str]:
    """One line for an exception that is not an :class:`ObserverCadError`, and whether it
    is an internal error (a bug to report) rather than the environment's: a Python
    package that is not installed is named, with the command that installs it."""
    if (isinstance(exc, ModuleNotFoundError) and exc.name
            and exc.name.split(".")[0] != "observer_cad"):  # (our own: a packaging bug)
        top = exc.name.split(".")[0]
        dist = _DISTRIBUTIONS.get(top, top)
        return False, (f"the Python package {top!r} is not installed (observer-cad needs it"
                       f" here): python3 -m pip install {dist}")
    if isinstance(exc, OSError) and exc.errno in _FILE_SYSTEM_ERRNOS:
        # the machine's (a full disk, a read-only folder, permissions), not a bug
        where = f"{exc.filename}: " if exc.filename else ""
        return False, f"{where}cannot write or read a file: {exc.strerror or type(exc).__name__}"
    first = str(exc).splitlines()[0] if str(exc) else ""
    return True, f"internal error: {type(exc).__name__}: {first}"


#: OSError numbers that describe the file system, not a bug: full, read-only, no permission,
#: a file where a folder is expected (or the reverse), a name too long, too many open files
_FILE_SYSTEM_ERRNOS = frozenset(
    getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EROFS", "EACCES", "EPERM", "EEXIST",
                                      "EISDIR", "ENOTDIR", "ENAMETOOLONG", "EMFILE", "ENFILE",
                                      "EFBIG", "ENOENT")
    if hasattr(errno, name))


#: import names whose PyPI distribution is named differently (Dask through the package's own
#: extra, the same hint as the ensemble's DASK_MISSING; quoted for shells that expand [])
_DISTRIBUTIONS = {"flint": "python-flint", "distributed": "'observer_cad[cluster]'",
                  "dask": "'observer_cad[cluster]'", "yaml": "pyyaml"}
