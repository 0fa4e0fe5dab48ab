"""Every reference the program, the model files, the README and the pages of docs/ print
points into the repository: "METHOD §X" to a section of docs/METHOD.md, "seed NNN" to
docs/REFERENCES.md (and "seed NNN §X" to a section listed there), "README: X" to a
heading of the README; a page's first citation is a link to the page it cites; every
relative link of the README and docs/ resolves (file and heading); and no file points
outside the clone."""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
METHOD = ROOT / "docs" / "METHOD.md"
REFERENCES = ROOT / "docs" / "REFERENCES.md"

#: the README and the pages of docs/ (the guide; the API pages are built from docstrings)
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md")])
#: files whose text reaches users: the package (console output, report, docstrings),
#: the model files, the benchmarks, the README and docs/
CITING = sorted([*(ROOT / "observer_cad").rglob("*.py"), *(ROOT / "models").rglob("*.py"),
                 *(ROOT / "benchmarks").glob("*"), *PAGES, *(ROOT / "docs" / "api").glob("*.rst")])


def _cited(pattern: str) -> dict:
    """match -> first 'file:line' citing it"""
    found = {}
    for f in CITING:
        if not f.is_file():
            continue
        for i, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            for m in re.finditer(pattern, line):
                found.setdefault(m.group(1) if m.groups() else m.group(0),
                                 f"{f.relative_to(ROOT)}:{i}")
    return found


def _method_sections() -> set:
    """'1', '2', '2a', ... from headings like '## 2. The reduced model' / '### 2a. ...'"""
    heads = re.findall(r"^#+\s+(\d+[a-z]?)\.\s", METHOD.read_text(encoding="utf-8"), re.M)
    return set(heads)


def _reference_sections() -> dict:
    """seed number -> set of section numbers listed in its 'Sections:' outline"""
    text = REFERENCES.read_text(encoding="utf-8")
    out = {}
    for m in re.finditer(r"^## seed (\d{3})\n(.*?)(?=^## |\Z)", text, re.M | re.S):
        body = m.group(2)
        secs = set()
        sm = re.search(r"Sections[^:]*:(.*?)(?:\n\n|\Z)", body, re.S)
        if sm:
            secs = set(re.findall(r"(?:^|·)\s*(\d+)\s", sm.group(1)))
        out[m.group(1)] = secs
    return out


def test_docs_exist():
    assert METHOD.is_file(), "docs/METHOD.md is missing"
    assert REFERENCES.is_file(), "docs/REFERENCES.md is missing"


def test_every_cited_method_section_exists():
    cited = _cited(r"METHOD §\s?(\d+[a-z]?)")
    assert cited, "no 'METHOD §' citation found: the pattern is wrong"
    have = _method_sections()
    missing = {sec: where for sec, where in cited.items() if sec not in have}
    assert not missing, f"METHOD sections cited but not headings in docs/METHOD.md: {missing}"


def test_every_cited_seed_is_in_the_references():
    cited = _cited(r"\bseeds? (\d{3})\b")
    # "seeds 001, 002, 004": the further numbers of a list
    for sec, where in _cited(r"\bseeds \d{3}((?:(?:, | and | or )\d{3})+)").items():
        for n in re.findall(r"\d{3}", sec):
            cited.setdefault(n, where)
    assert cited, "no 'seed NNN' citation found: the pattern is wrong"
    listed = _reference_sections()
    missing = {n: where for n, where in cited.items() if n not in listed}
    assert not missing, f"seeds cited but not in docs/REFERENCES.md: {missing}"


def test_every_cited_paper_section_is_listed():
    cited = _cited(r"\bseed (\d{3} §\s?\d+)")
    listed = _reference_sections()
    missing = {}
    for ref, where in cited.items():
        n, sec = re.match(r"(\d{3}) §\s?(\d+)", ref).groups()
        if sec not in listed.get(n, set()):
            missing[ref] = where
    assert not missing, f"paper sections cited but not in docs/REFERENCES.md's outlines: {missing}"


def test_method_and_references_cite_each_other_inside_the_repository():
    assert "REFERENCES.md" in METHOD.read_text(encoding="utf-8")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "## References" in readme
    assert "docs/REFERENCES.md" in readme and "docs/METHOD.md" in readme
    for n in ("000", "001", "002", "003", "004"):
        assert f"seed {n}" in readme.split("## References", 1)[1], f"README References lacks seed {n}"


def _slug(heading: str) -> str:
    """The anchor a forge (and MyST's heading anchors) gives a Markdown heading."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _anchors(path: Path) -> set:
    text = re.sub(r"```.*?```", "", path.read_text(encoding="utf-8"), flags=re.S)
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+?)\s*$", text, re.M)}


def test_readme_citations_name_a_readme_heading():
    """The program cites "README: Conditioning": that heading stays in the README."""
    cited = _cited(r"README: ([A-Z][\w ]*\w)")
    cited.update(_cited(r"'([A-Z][\w ]*\w)' in the README"))
    assert cited, "no 'README: X' citation found: the pattern is wrong"
    heads = {h.lower() for h in re.findall(r"^#+\s+(.+?)\s*$",
                                           (ROOT / "README.md").read_text(encoding="utf-8"), re.M)}
    missing = {c: where for c, where in cited.items() if c.lower() not in heads}
    assert not missing, f"README headings cited by the program but not in the README: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_first_citation_is_a_link(page):
    """A reader meets "seed 000 §9" or "METHOD §2b" first in a paragraph that links the
    page where it is looked up."""
    text = page.read_text(encoding="utf-8")
    paragraphs = re.split(r"\n\s*\n", text)
    for pattern, target in ((r"\bseeds? \d{3}", "REFERENCES.md"), (r"METHOD §", "METHOD.md")):
        if page.name == target:
            continue
        first = next((p for p in paragraphs if re.search(pattern, p)), None)
        if first is not None:
            assert f"({'docs/' if page.name == 'README.md' else ''}{target}" in first, (
                f"{page.relative_to(ROOT)}: the first citation ({pattern}) has no link to {target}:"
                f"\n{first[:300]}")


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_resolve(page):
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    bad = []
    for m in re.finditer(r"\]\(([^)\s]+)\)", text):
        link = m.group(1)
        if re.match(r"[a-z]+:", link):
            continue                          # an absolute URL, a mailto
        path, _, anchor = link.partition("#")
        target = (page.parent / path).resolve() if path else page
        if not target.exists():
            bad.append(f"{link}: no such file")
        elif anchor and target.suffix == ".md" and anchor not in _anchors(target):
            bad.append(f"{link}: no heading with that anchor in {target.name}")
    assert not bad, f"{page.relative_to(ROOT)}: " + "; ".join(bad)


def _tracked_text_files():
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: cannot list the tracked files")
    return [ROOT / p for p in out if p.endswith((".py", ".md", ".json", ".toml", ".ipynb", ".txt"))]


def test_nothing_points_outside_the_repository():
    bad = []
    for f in _tracked_text_files():
        if not f.is_file() or f == Path(__file__).resolve():
            continue
        for i, line in enumerate(f.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if re.search(r"/work/|\.\./shared|shared/seeds|\bshared/[A-Z]+\.md", line):
                bad.append(f"{f.relative_to(ROOT)}:{i}: {line.strip()[:100]}")
    assert not bad, "references to paths outside the repository:\n" + "\n".join(bad)


@pytest.mark.parametrize("path", ["sim/signals.csv", "c/estimator.c", "estimator", "out/report.md",
                                  "examples/tour_out/c/x.c", "examples/.ipynb_checkpoints/x.ipynb",
                                  ".venv/bin/python", "venv/bin/python"])
def test_gitignore_covers_what_the_tour_writes(path):
    """The README tour writes sim/, c/, estimator (and the demo out/); the notebook its
    tour_out/ and checkpoints; a venv may sit in the clone."""
    try:
        r = subprocess.run(["git", "check-ignore", "-q", "--no-index", path], cwd=ROOT)
    except OSError:
        pytest.skip("git is not installed")
    if r.returncode == 128:
        pytest.skip("not a git checkout")
    assert r.returncode == 0, f"{path} is not ignored by .gitignore"
