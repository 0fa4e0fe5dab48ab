"""Rewrite one results section of benchmarks/README.md (between its marker comments),
atomically: shared by every benchmark script's ``--write``."""
from pathlib import Path

from observer_cad.files import atomic_write_text


def write_section(readme: Path, begin: str, end: str, table: str) -> None:
    """Replace the text between ``begin`` and ``end`` in ``readme`` with ``table``."""
    text = readme.read_text() if readme.exists() else ""
    if begin not in text or end not in text:
        raise SystemExit(f"{readme}: the markers {begin!r} and {end!r} are missing")
    before, rest = text.split(begin, 1)
    _, after = rest.split(end, 1)
    atomic_write_text(readme, before + begin + "\n" + table + "\n" + end + after)
