"""``observer-cad demo``: the seed papers' examples, written into a staging folder and
moved into ``--out`` at the end (the demo itself is :mod:`observer_cad.demo`).
"""
from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["cmd_demo"]


class _ShownAs:
    """A text stream that prints ``final`` where the text says ``staging`` (the demo logs
    the paths it writes; they are moved from the staging folder into place at the end)."""

    def __init__(self, stream, staging: Path, final: Path):
        self.stream, self.staging, self.final = stream, str(staging), str(final)

    def write(self, text: str) -> int:
        return self.stream.write(text.replace(self.staging, self.final))

    def flush(self) -> None:
        self.stream.flush()


def cmd_demo(args) -> int:
    from ..files import staged_directory
    from ..demo import EXAMPLES_DIR, run_demo
    out = Path(args.out)
    with staged_directory(out, command="demo") as stage:  # an error leaves --out as it was
        return run_demo(EXAMPLES_DIR, stage, compile=not args.no_compile,
                        stream=_ShownAs(sys.stdout, stage, out))
