#!/usr/bin/env python3
"""Build the documentation (HTML) and run its doctests, as .ci/run does.

    python3 docs/build.py            # HTML in docs/_build/html, then the doctests
    python3 docs/build.py --strict   # every warning is an error (sphinx -W)

Every Sphinx warning is attributed to the file it comes from: a docstring's module (the
``docstring of observer_cad.x.y`` of the warning), or a page of docs/. Without
``--strict`` the build fails on the warnings of files that the documentation work owns —
the pages of docs/ and the modules listed in :data:`OWNED` — and lists the others, per
module and kind, without failing (a view for work in progress). .ci/run runs
``--strict``: every warning anywhere fails, as with
``python3 -m sphinx -W --keep-going -b html docs docs/_build/html``.

The doctests (``>>>`` examples in the docstrings and in the pages) run with Sphinx's
doctest builder on the doctrees of the HTML build (no second read of the sources).
"""
from __future__ import annotations

import argparse
import importlib
import re
import subprocess
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
BUILD = DOCS / "_build"

#: files whose warnings fail the build now (besides every page of docs/)
OWNED = (
    "observer_cad/numerics/",
    "observer_cad/model/_expressions.py", "observer_cad/model/_matrices.py",
    "observer_cad/model/_random.py", "observer_cad/model/_task.py",
    "observer_cad/errors.py", "observer_cad/files.py", "observer_cad/progress.py",
    "observer_cad/version.py", "observer_cad/reporting/",
)
#: API pages that document modules outside OWNED only: a warning Sphinx places on the
#: page (a cross-reference made from a docstring's field type has no docstring location)
#: belongs to that stage package
OTHERS_PAGES = {f"docs/api/{p}.rst": f"observer_cad/{p}/ (a docstring on the page)" for p in (
    "synthesis", "analysis", "observers", "residuals", "simulation", "codegen", "ensemble",
    "demo", "cli")}
OTHERS_PAGES["docs/api/observer_cad.rst"] = "observer_cad/__init__.py re-exports (a docstring on the page)"

_WARNING = re.compile(r"^(?P<where>.*?): (?P<level>WARNING|ERROR|CRITICAL|SEVERE): (?P<msg>.*)$")
_DOCSTRING = re.compile(r"docstring of (?P<name>[\w.]+)")


def _module_file(dotted: str) -> str | None:
    """The repository path of the module that defines ``dotted``: the longest importable
    prefix, then the object's own ``__module__`` (a name re-exported by a package is
    defined in a private module)."""
    import inspect
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            nxt = getattr(obj, name, None)
            if nxt is None or not (inspect.isclass(nxt) or inspect.isfunction(nxt)):
                break
            obj = nxt
        mod = sys.modules.get(getattr(obj, "__module__", None) or "", None) \
            if not inspect.ismodule(obj) else obj
        f = getattr(mod, "__file__", None)
        if f:
            try:
                return Path(f).resolve().relative_to(ROOT).as_posix()
            except ValueError:
                return None
    return None


def attribute(line: str) -> tuple[str, str, str] | None:
    """(file, kind, message) of one warning line, or None for a line that is not one."""
    m = _WARNING.match(line.strip())
    if not m:
        return None
    where, msg = m.group("where"), m.group("msg")
    kind = re.sub(r"\s*\[[\w.]+\]$", "", msg)
    if kind.startswith("more than one target"):
        kind = re.sub(r":\s.*$", "", kind)          # keep the name, drop the candidates
    else:
        kind = re.sub(r"'[^']*'|\"[^\"]*\"", "'…'", kind)
    kind = kind.split(", other instance")[0]
    d = _DOCSTRING.search(where)
    if d:
        f = _module_file(d.group("name"))
        return (f or where.split(":")[0]), kind, msg
    path = where.split(":")[0]
    try:
        rel = Path(path).resolve().relative_to(ROOT).as_posix()
    except (ValueError, OSError):
        rel = path
    return OTHERS_PAGES.get(rel, rel), kind, msg


def owned(path: str) -> bool:
    if path in OTHERS_PAGES.values():
        return False
    if not path.startswith("observer_cad/"):
        return True            # docs/ pages, <unknown>: ours to fix
    return any(path == o or (o.endswith("/") and path.startswith(o)) for o in OWNED)


def run(cmd: list[str]) -> int:
    print("+", " ".join(cmd), flush=True)
    return subprocess.call(cmd, cwd=ROOT)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--strict", action="store_true", help="every warning fails (sphinx -W)")
    ap.add_argument("--no-doctest", action="store_true", help="HTML only")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    BUILD.mkdir(parents=True, exist_ok=True)
    log = BUILD / "warnings.txt"
    doctrees = str(BUILD / "doctrees")
    t0 = time.perf_counter()
    base = [sys.executable, "-m", "sphinx", "-E", "--keep-going", "-q", "-d", doctrees]
    if args.strict:
        rc = run(base + ["-W", "-w", str(log), "-b", "html", "docs", str(BUILD / "html")])
        if rc:
            return rc
    else:
        rc = run(base + ["-w", str(log), "-b", "html", "docs", str(BUILD / "html")])
        if rc:
            return rc
        found = [a for a in map(attribute, log.read_text(encoding="utf-8").splitlines()) if a]
        ours = [a for a in found if owned(a[0])]
        theirs = [a for a in found if not owned(a[0])]
        if theirs:
            per = defaultdict(Counter)
            for f, kind, _ in theirs:
                per[f][kind] += 1
            print(f"\n{len(theirs)} warning(s) in modules outside docs/ and {', '.join(OWNED)}"
                  " (to fix; then build with --strict):")
            for f in sorted(per):
                print(f"  {f}: {sum(per[f].values())}")
                for kind, n in per[f].most_common():
                    print(f"      {n} × {kind}")
        if ours:
            print(f"\n{len(ours)} warning(s) in the documentation's own files:")
            for f, _, msg in ours:
                print(f"  {f}: {msg}")
            return 1
    print(f"HTML: {BUILD / 'html' / 'index.html'} ({time.perf_counter() - t0:.0f} s)")
    if args.no_doctest:
        return 0
    t1 = time.perf_counter()
    rc = run([sys.executable, "-m", "sphinx", "-q", "-d", doctrees, "-b", "doctest", "docs",
              str(BUILD / "doctest")])
    out = BUILD / "doctest" / "output.txt"
    if out.is_file():
        tail = out.read_text(encoding="utf-8").split("Doctest summary")[-1]
        summary = [ln.strip() for ln in tail.splitlines() if re.match(r"\s*\d+ \w", ln)]
        print("doctests:", ", ".join(summary), f"({time.perf_counter() - t1:.0f} s)")
    return rc


if __name__ == "__main__":
    sys.exit(main())
