"""Sphinx configuration: the API reference built from the docstrings, and the Markdown
pages of docs/ (the guide: command line, file formats, method, references).

Build (warnings as errors, as .ci/run does through docs/build.py)::

    python3 -m sphinx -W --keep-going -b html docs docs/_build/html
    python3 -m sphinx -b doctest docs docs/_build/doctest    # the docstrings' examples

Extensions:

- ``sphinx.ext.autodoc``: the reference is the docstrings themselves, imported from the
  package, one page per stage package, its ``__all__`` (nothing to keep in sync by hand);
- ``sphinx.ext.napoleon``: the docstrings are mostly prose with reStructuredText markup,
  a few with NumPy-style ``Parameters`` sections; napoleon renders those sections and
  leaves the prose alone (numpydoc would reformat every docstring and insist on its
  section grammar);
- ``sphinx.ext.doctest``: ``>>>`` examples in docstrings and pages run under
  ``-b doctest``;
- ``myst_parser``: the guide pages stay Markdown, readable on a forge and in a clone.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))          # this checkout's package, not an installed one
os.environ.setdefault("MPLBACKEND", "Agg")

import observer_cad  # noqa: E402

project = "observer_cad"
author = "observer_cad developers"
release = observer_cad.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.doctest",
    "myst_parser",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

# autodoc: a stage page documents the names of the package's __all__ (imported from its
# private modules), with their docstrings; constants without their (sometimes long) values
autodoc_default_options = {
    "members": True,
    "undoc-members": True,
    "show-inheritance": True,
    "no-value": True,
}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_preserve_defaults = True
# the docstrings' own Examples sections are doctests; napoleon keeps them as such
napoleon_numpy_docstring = True
napoleon_google_docstring = False
# A bare attribute name in a docstring's type position (``names``, ``A``, ``N``) becomes a
# cross-reference that several classes' attributes answer; Sphinx links the first, and the
# ambiguity is not an error of the documentation (unresolved references still are)
suppress_warnings = ["ref.python"]

# MyST: GitHub-style heading anchors, so that links like METHOD.md#2b-jordan-canonical-form
# work both on a forge and in the built pages; $…$ math is not used (the pages write
# formulas in plain Unicode)
myst_heading_anchors = 4
myst_enable_extensions = []

# doctest: every group starts from the package and numpy/sympy
doctest_global_setup = """
import sympy as sp
import observer_cad
"""

html_theme = "alabaster"
html_title = "observer_cad"
html_static_path: list = []
