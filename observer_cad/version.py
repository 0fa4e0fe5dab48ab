"""The package version, from one source: the installed distribution's metadata
(``importlib.metadata``), or, when the package runs from a source tree that was never
installed, the ``version`` in the ``pyproject.toml`` next to it.

Stage 0: imports nothing from the package, so every stage (and ``observer-cad
--version``) can ask for it.
"""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

__all__ = ["DISTRIBUTION", "package_version"]

#: the distribution name in ``pyproject.toml`` ``[project] name``
DISTRIBUTION = "observer_cad"


def _pyproject_version(pyproject: Path) -> str | None:
    try:
        import tomllib
        data = tomllib.loads(pyproject.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    project = data.get("project", {})
    if project.get("name", "").replace("-", "_") != DISTRIBUTION:
        return None
    v = project.get("version")
    return v if isinstance(v, str) else None


def package_version() -> str:
    """``importlib.metadata.version("observer_cad")``; without installed metadata, the
    source tree's ``pyproject.toml`` version; ``"0+unknown"`` when neither exists."""
    try:
        return importlib.metadata.version(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        pass
    v = _pyproject_version(Path(__file__).resolve().parent.parent / "pyproject.toml")
    return v if v is not None else "0+unknown"
