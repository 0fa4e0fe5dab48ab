"""The README and the pages of docs/ show what the program prints.

Every output block (between ``<!-- output: COMMAND -->`` and ``<!-- end output -->``) is
run again and compared with what the page shows, after :func:`regenerate.normalise`
(durations, rates, worker counts: docs/regenerate.py says why). The command-line
reference of docs/CLI.md must be what the parser gives. A block that differs is fixed by
``python3 docs/regenerate.py`` (then read the diff: the program's output changed).
Blocks marked slow (simulations, ensembles, the C compiler) run with ``-m slow``.

The README's own promises are checked too: the quick start's test command is the one
.ci/run ends with, the tour stays short, its Python runs.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
sys.path.insert(0, str(ROOT / "docs"))
import regenerate  # noqa: E402  (docs/regenerate.py)

os.environ.setdefault("MPLBACKEND", "Agg")

BLOCKS = regenerate.all_blocks()
TEST_COMMAND = "python3 -m pip install -e '.[dev]' && python3 -m pytest"
FIX = "run python3 docs/regenerate.py and read the diff"


def _param(b):
    marks = [pytest.mark.slow] if b.slow else []
    return pytest.param(b, id=b.where, marks=marks)


def test_there_are_output_blocks_in_the_readme_and_the_docs():
    where = {b.path.name for b in BLOCKS}
    assert "README.md" in where and len(where) > 1, where
    assert any(not b.slow for b in BLOCKS if b.path == README)


@pytest.mark.parametrize("block", [_param(b) for b in BLOCKS])
def test_output_block_is_what_the_command_prints(block):
    fresh = regenerate.run_command(block.command)
    assert regenerate.normalise(fresh) == regenerate.normalise(block.text), (
        f"{block.where}: the block differs from what `{block.command}` prints now; {FIX}")


def test_cli_reference_is_the_parser():
    text = regenerate.CLI_PAGE.read_text(encoding="utf-8")
    assert regenerate.cli_region(text) == regenerate.cli_reference(), (
        f"docs/CLI.md lists other commands or options than observer_cad.cli.build_parser(); {FIX}")


def test_cli_reference_names_every_option():
    """Belt and braces for the generator: every option string of every command is in the page."""
    import argparse
    from observer_cad.cli import build_parser
    page = regenerate.CLI_PAGE.read_text(encoding="utf-8")
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        assert f"## observer-cad {name}" in page, name
        section = page.split(f"## observer-cad {name}", 1)[1].split("\n## ", 1)[0]
        for a in p._actions:
            for opt in a.option_strings:
                if opt not in ("-h", "--help"):
                    assert f"`{opt}`" in section, f"{name} {opt} is not in docs/CLI.md"


def test_normalise_masks_only_what_cannot_repeat():
    a = "2000 runs in 1.14 s (1,752 runs/s; compiled C, threads × 2, chunks of 116; wall clock 1.16 s)"
    b = "2000 runs in 9.9 s (201 runs/s; compiled C, threads × 8, chunks of 30; wall clock 10 s)"
    assert regenerate.normalise(a) == regenerate.normalise(b)
    assert regenerate.normalise("d ≥ 0.0412") != regenerate.normalise("d ≥ 0.044")
    assert regenerate.normalise("k = 2") != regenerate.normalise("k = 3")


def test_quick_start_commands():
    text = README.read_text(encoding="utf-8")
    quick = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    commands = re.findall(r"```sh\n(.*?)\n```", quick, re.S)
    assert commands[0].startswith("python3 -m pip install -e ") and "observer-cad demo" in commands[0]
    assert commands[1] == TEST_COMMAND


def test_ci_ends_with_the_readme_test_command():
    lines = [ln for ln in (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
             if ln.strip() and not ln.lstrip().startswith("#")]
    assert lines[-1] == TEST_COMMAND


def test_tour_is_short():
    lines = README.read_text(encoding="utf-8").splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("## A tour"))
    end = next(i for i, ln in enumerate(lines) if i > start and ln.startswith("## "))
    assert end - start <= 300, f"the tour has {end - start} lines (at most 300)"


def test_no_issue_numbers_in_the_readme_and_docs():
    bad = []
    for f in [README, *sorted((ROOT / "docs").glob("*.md"))]:
        for i, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"\bissues? ?#?\d+", line, re.I):
                bad.append(f"{f.relative_to(ROOT)}:{i}: {line.strip()[:80]}")
    assert not bad, "issue numbers (say what the thing does instead):\n" + "\n".join(bad)


def _python_blocks():
    return re.findall(r"```python\n(.*?)\n```", README.read_text(encoding="utf-8"), re.S)


def test_readme_model_is_the_shipped_model(tmp_path):
    """The tour's model file is models/electric_drive.py (the same structure)."""
    from observer_cad import extract_structure, load_model
    src = next(b for b in _python_blocks() if "model = PlantModel(" in b)
    f = tmp_path / "drive.py"
    f.write_text(src, encoding="utf-8")
    mine, shipped = load_model(f), load_model(ROOT / "models" / "electric_drive.py")
    a, b = extract_structure(mine), extract_structure(shipped)
    for name in ("F", "G", "H", "D", "L", "W"):
        assert getattr(a, name) == getattr(b, name), name
    assert mine.parameters == shipped.parameters and mine.bounds == shipped.bounds


@pytest.mark.slow
def test_readme_python_runs():
    src = next(b for b in _python_blocks() if "load_model(" in b)
    r = subprocess.run([sys.executable, "-c", src], cwd=ROOT, capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg"), timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == ["Task(unknown-input: estimate d, decoupled from rho) True",
                                     "True"], r.stdout


@pytest.mark.slow
def test_notebook_command_in_the_readme_runs(tmp_path):
    """The README's command runs the notebook top to bottom (here with its outputs in a
    temporary directory and this checkout's package on the kernel's path)."""
    text = README.read_text(encoding="utf-8")
    command = re.search(r"&& (python3 -m jupyter nbconvert [^\n]*)", text).group(1)
    argv = command.split()
    argv[argv.index("--output-dir") + 1] = str(tmp_path / "nb")
    argv[0] = sys.executable
    env = dict(os.environ, OBSERVER_CAD_TOUR_OUT=str(tmp_path / "out"), MPLBACKEND="Agg",
               PYTHONPATH=os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    r = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (tmp_path / "nb" / "tour.ipynb").is_file()


def test_notebook_command_in_the_readme():
    """The README's way to run the notebook uses what the dev extra installs."""
    text = README.read_text(encoding="utf-8")
    assert "jupyter nbconvert --to notebook --execute examples/tour.ipynb" in text
    import tomllib
    dev = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))[
        "project"]["optional-dependencies"]["dev"]
    assert any(d.startswith("nbconvert") for d in dev) and any(d.startswith("nbclient") for d in dev)
