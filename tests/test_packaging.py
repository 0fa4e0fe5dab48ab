"""The example models ship inside the package (``observer_cad/examples``), as one copy.

In the repository ``observer_cad/examples`` is a symbolic link to ``models/``; setuptools
copies the files behind it into the sdist and the wheel, selected by the pyproject
``package-data`` patterns. CI builds the wheel, installs it into a fresh venv and runs
``observer-cad demo`` from another directory (``.ci/run``); these tests check the cheap
part: that the link is intact, that every example file matches a pattern, and that the
demo's files are there."""
from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path

import pytest

from observer_cad.demo import CASES, DIAGNOSABILITY, EXAMPLES_DIR, run_demo
from observer_cad.errors import UsageError

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"


def test_examples_are_the_repository_models():
    assert EXAMPLES_DIR.is_symlink(), "observer_cad/examples must stay a link to models/"
    assert EXAMPLES_DIR.resolve() == MODELS.resolve()


def test_every_example_file_matches_a_package_data_pattern():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = config["tool"]["setuptools"]["package-data"]["observer_cad.examples"]
    files = [p.relative_to(MODELS).as_posix() for p in MODELS.rglob("*")
             if p.is_file() and "__pycache__" not in p.parts]
    assert files
    unshipped = [f for f in files if not any(fnmatch.fnmatch(f, pat) for pat in patterns)]
    assert not unshipped, f"not in the wheel (add a package-data pattern): {unshipped}"


def test_every_demo_model_and_scenario_is_an_example():
    for case in CASES:
        assert (EXAMPLES_DIR / case.model).is_file(), case.model
        for run in case.runs:
            assert (EXAMPLES_DIR / "scenarios" / f"{run.scenario}.json").is_file(), run.scenario
    # the diagnosability example: the analysed model, the bank's model and scenario
    for model in (DIAGNOSABILITY.analysis_model, DIAGNOSABILITY.bank_model):
        assert (EXAMPLES_DIR / model).is_file(), model
    assert (EXAMPLES_DIR / "scenarios" / f"{DIAGNOSABILITY.scenario}.json").is_file()


def test_demo_without_its_examples_is_a_one_line_error(tmp_path):
    with pytest.raises(UsageError, match="example models are not there"):
        run_demo(tmp_path / "nowhere", tmp_path / "out")
