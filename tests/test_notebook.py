"""examples/tour.ipynb (model → design → simulate → plot → codegen) runs top to bottom
with nbclient, and the committed notebook carries no outputs."""
from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOK = ROOT / "examples" / "tour.ipynb"


def test_committed_notebook_has_no_outputs():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    dirty = [i for i, c in enumerate(nb["cells"]) if c["cell_type"] == "code"
             and (c.get("outputs") or c.get("execution_count") is not None)]
    assert not dirty, f"code cells with outputs or execution counts (strip them): {dirty}"


def test_notebook_uses_the_public_api_only():
    src = "\n".join("".join(c["source"]) for c in
                    json.loads(NOTEBOOK.read_text(encoding="utf-8"))["cells"] if c["cell_type"] == "code")
    assert "from observer_cad import build_observer, design, load_model, load_scenario, simulate" in src
    assert "from observer_cad.codegen import export_observer" in src
    assert not re.search(r"\._(?!_|repr)", src), "the tour reaches into a private name"


@pytest.mark.slow
def test_notebook_executes(tmp_path, monkeypatch):
    nbclient = pytest.importorskip("nbclient", reason="nbclient is not installed"
                                   " (pip install -e '.[dev]')")
    import nbformat  # a dependency of nbclient; ipykernel and pandas come with '.[dev]' too
    nb = nbformat.read(str(NOTEBOOK), as_version=4)
    out = tmp_path / "out"
    monkeypatch.setenv("OBSERVER_CAD_TOUR_OUT", str(out))
    # the kernel imports this checkout's package first, as the tests do
    pp = os.environ.get("PYTHONPATH")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT)] + ([pp] if pp else [])))
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(ROOT / "examples")}})
    client.execute()  # raises CellExecutionError naming the failing cell
    text = "\n".join(o.get("text", "") for c in nb.cells if c.cell_type == "code"
                     for o in c.get("outputs", []) if o.get("output_type") == "stream")
    assert "certificate passed: True" in text
    assert "max |d_hat - d| =" in text
    written = {p.name for p in (out / "c").iterdir()}
    assert any(n.endswith(".h") for n in written), written
    assert any(n.endswith("_example.c") for n in written), written
    assert (out / "sim" / "signals.units.json").is_file()
