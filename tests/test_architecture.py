"""The package layout is the pipeline: every import (module level or inside a function)
goes to the same or an earlier stage, never to another module's private name, never
into another subpackage's private modules, and the import graph has no cycle."""
from __future__ import annotations

import ast
import importlib
import pathlib
import pkgutil

import pytest

import observer_cad

PKG = pathlib.Path(observer_cad.__file__).parent
#: stage of every top-level module or subpackage; a module may import its own stage or earlier
STAGES = {"errors": 0, "files": 0, "version": 0, "progress": 0, "model": 1, "numerics": 2,
          "synthesis": 3, "analysis": 4, "observers": 5, "residuals": 6, "simulation": 7,
          "codegen": 8, "ensemble": 9, "reporting": 10, "demo": 11, "cli": 12,
          "__main__": 13, "drem": 13}  # drem: alias kept for model files written for 0.1


def _modules():
    for f in sorted(PKG.rglob("*.py")):
        parts = list(f.relative_to(PKG).with_suffix("").parts)
        yield f, parts


def _imports(f, parts):
    """(absolute target module, imported names) for every import in a file."""
    is_pkg = parts[-1] == "__init__"
    here = ["observer_cad"] + (parts[:-1] if is_pkg else parts[:-1])
    for node in ast.walk(ast.parse(f.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[:len(here) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            yield node.lineno, target, [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name, []


def _stage(parts):
    return STAGES[parts[0]]


def _edges():
    for f, parts in _modules():
        if parts == ["__init__"]:
            continue  # the top level re-exports the API
        for line, target, names in _imports(f, parts):
            if target.split(".")[0] != "observer_cad":
                continue
            tparts = target.split(".")[1:]
            yield f, parts, line, tparts, names


def test_every_module_is_in_a_known_stage():
    unknown = [str(f) for f, parts in _modules() if parts != ["__init__"] and parts[0] not in STAGES]
    assert not unknown, f"modules outside the pipeline stages: {unknown}"


def test_imports_go_to_earlier_stages_only():
    bad = []
    for f, parts, line, tparts, names in _edges():
        if not tparts:
            bad.append(f"{f.relative_to(PKG)}:{line} imports the top-level package")
            continue
        if _stage(tparts) > _stage(parts):
            bad.append(f"{f.relative_to(PKG)}:{line} ({parts[0]}) imports {'.'.join(tparts)}"
                       f" from a later stage")
    assert not bad, "\n".join(bad)


def test_no_private_names_cross_module_boundaries():
    bad = []
    for f, parts, line, tparts, names in _edges():
        for n in names:
            if n.startswith("_"):
                bad.append(f"{f.relative_to(PKG)}:{line} imports private name {n}")
        # into another subpackage only through its __init__
        if tparts and tparts[0] != parts[0] and len(tparts) > 1 and tparts[1].startswith("_"):
            bad.append(f"{f.relative_to(PKG)}:{line} reaches into {'.'.join(tparts)}")
    assert not bad, "\n".join(bad)


def test_import_graph_has_no_cycle():
    graph = {}
    for f, parts, line, tparts, names in _edges():
        src = ".".join(p for p in parts if p != "__init__")
        for tgt in [".".join(tparts)] + [".".join(tparts + [n]) for n in names]:
            if (PKG / pathlib.Path(*tgt.split("."))).with_suffix(".py").exists() or \
                    (PKG / pathlib.Path(*tgt.split(".")) / "__init__.py").exists():
                if tgt != src:
                    graph.setdefault(src, set()).add(tgt)
    # a subpackage's __init__ depends on its modules: only module-to-module edges count
    state, stack = {}, []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt in parts_of_init(node):
                continue
            if state.get(nxt) == 1:
                cyc = stack[stack.index(nxt):] + [nxt]
                pytest.fail("import cycle: " + " → ".join(cyc))
            if state.get(nxt) is None:
                visit(nxt)
        stack.pop()
        state[node] = 2

    def parts_of_init(node):  # a module importing its own package's __init__ would be a cycle
        return ()

    for node in sorted(graph):
        if state.get(node) is None:
            visit(node)


@pytest.mark.parametrize("name", sorted(m.name for m in pkgutil.walk_packages(
    observer_cad.__path__, "observer_cad.") if not m.name.endswith("__main__")))
def test_every_module_imports_on_its_own(name):
    importlib.import_module(name)


def test_subpackages_export_explicitly():
    for sub in STAGES:
        init = PKG / sub / "__init__.py"
        if not init.exists():
            continue
        mod = importlib.import_module(f"observer_cad.{sub}")
        assert hasattr(mod, "__all__"), f"observer_cad.{sub} has no __all__"
        for name in mod.__all__:
            assert hasattr(mod, name), f"observer_cad.{sub}.__all__ lists missing {name}"


def test_public_api_at_top_level():
    from observer_cad import (CompiledSimulator, Design, Task, build_observer, design,  # noqa: F401
                              load_model, simulate)
    assert callable(design) and callable(build_observer) and callable(simulate)
