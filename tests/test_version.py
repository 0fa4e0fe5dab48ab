"""`observer_cad.__version__` and `observer-cad --version` give one version, read from the
installed distribution's metadata or, without metadata, from pyproject.toml."""
from __future__ import annotations

import importlib.metadata
import subprocess
import sys
import tomllib
from pathlib import Path

import observer_cad
from observer_cad import version as version_module
from observer_cad.cli import main

ROOT = Path(__file__).resolve().parent.parent


def _pyproject_version():
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]


def test_version_is_the_pyproject_version():
    assert observer_cad.__version__ == _pyproject_version()


def test_without_metadata_the_source_tree_pyproject_is_read(monkeypatch):
    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)
    monkeypatch.setattr(importlib.metadata, "version", missing)
    assert version_module.package_version() == _pyproject_version()


def test_cli_version(capsys):
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    out = capsys.readouterr().out.strip()
    assert out == f"observer-cad {observer_cad.__version__}"


def test_cli_version_as_a_process():
    r = subprocess.run([sys.executable, "-m", "observer_cad", "--version"], capture_output=True,
                       text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == f"observer-cad {observer_cad.__version__}"
