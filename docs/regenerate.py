#!/usr/bin/env python3
"""Regenerate every output block of the README and of docs/*.md from the command it shows,
and the command-line reference (docs/CLI.md) from ``observer_cad.cli.build_parser()``.

    python3 docs/regenerate.py            # rewrite the blocks in place
    python3 docs/regenerate.py --check    # exit 1 and name the blocks that differ
    python3 docs/regenerate.py --fast     # skip the blocks marked slow

A block is written between two marker comments; the opening marker holds the command::

    <!-- output: observer-cad design models/three_tank.py --observer virtual-sensor --estimate x1 | head -n 12 -->
    ```console
    $ observer-cad design models/three_tank.py --observer virtual-sensor --estimate x1 | head -n 12
    ... what the command printed ...
    ```
    <!-- end output -->

``<!-- output slow: ... -->`` marks a block that takes more than a second or two (a
simulation, an ensemble, the C compiler): ``tests/test_readme.py`` checks it only in the
slow run. The block between the markers is replaced whole; edit the marker, never the block.

How a command runs:

- ``observer-cad ARGS`` runs this checkout's ``observer_cad.cli.main(ARGS)`` in-process
  (no interpreter start-up per block), in a fresh temporary directory in which ``models``
  and ``examples`` are links to the repository's ``models/`` and ``examples/`` — so the paths shown are the ones a reader
  types from a clone, and what the command writes (``sim/``, ``c/``) goes to the
  temporary directory. stdout is shown; stderr too when the exit status is not 0, then a
  last line ``[exit status N]``.
- ``| head -n N``, ``| tail -n N``, ``| sed -n 'A,Bp'`` (ranges joined by ``;``) and
  ``| grep -E 'REGEX'`` filter the output as the shell would (they are emulated, so the
  command shown is one a reader can paste).
- ``sh: COMMAND`` runs COMMAND with bash in the temporary directory, with an
  ``observer-cad`` on PATH that runs this checkout; used for blocks that chain commands
  with a C compiler. Each command of an ``&&`` chain is shown on its own prompt line.
  Always mark such a block slow.

What is normalised — only what cannot be the same twice (:func:`normalise`):

- durations: a number followed by ``s``, ``ms``, ``µs`` or ``min`` (``2.36 s``), and
  rates (``8,484 runs/s``) become ``<t>`` when comparing: the block keeps the figures of
  the run that wrote it;
- the worker count and chunk size of an ensemble (``threads × 2, chunks of 116``): they
  follow the machine's cores;
- ``(cache hit)`` after ``compiled C`` is never written: a reader's first run compiles;
- the temporary directory's absolute path, should a command print it, becomes ``.``;
- trailing spaces.

The command-line reference is the region of docs/CLI.md between
``<!-- cli-reference -->`` and ``<!-- end cli-reference -->``, one table per command built
from the parser's actions (option, argument, default, help): no argparse line-wrapping,
so it is the same on every Python and terminal.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: the files whose blocks are regenerated
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
CLI_PAGE = ROOT / "docs" / "CLI.md"

OPEN = re.compile(r"^<!-- output( slow)?: (.+?) -->$")
CLOSE = "<!-- end output -->"
CLI_OPEN, CLI_CLOSE = "<!-- cli-reference -->", "<!-- end cli-reference -->"
#: a shown command is wrapped (`` \`` continuations) before an option past this column
WRAP = 92


@dataclass(frozen=True)
class Block:
    """One output block: where it is, its command, whether it is slow, its current text."""
    path: Path
    line: int           # 1-based line of the opening marker
    command: str
    slow: bool
    text: str           # the lines between the markers, joined with newlines

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def find_blocks(path: Path) -> list[Block]:
    """The output blocks of a Markdown file, in order."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = OPEN.match(lines[i].strip())
        if m:
            j = i + 1
            while j < len(lines) and lines[j].strip() != CLOSE:
                if OPEN.match(lines[j].strip()):
                    raise SystemExit(f"{path.name}:{j + 1}: an output block opens inside another")
                j += 1
            if j == len(lines):
                raise SystemExit(f"{path.name}:{i + 1}: output block without '{CLOSE}'")
            blocks.append(Block(path, i + 1, m.group(2), bool(m.group(1)),
                                "\n".join(lines[i + 1:j])))
            i = j
        i += 1
    return blocks


def all_blocks() -> list[Block]:
    return [b for p in DOCUMENTS for b in find_blocks(p)]


# ----------------------------------------------------------------------------- running

def _split_pipeline(command: str) -> tuple[str, list[list[str]]]:
    """'observer-cad … | head -n 3' -> ('observer-cad …', [['head', '-n', '3']])"""
    parts = [p.strip() for p in re.split(r"\s\|\s", command)]
    return parts[0], [shlex.split(p) for p in parts[1:]]


def _filter(text: str, argv: list[str]) -> str:
    lines = text.splitlines()
    if argv[:2] == ["head", "-n"] and len(argv) == 3:
        lines = lines[:int(argv[2])]
    elif argv[:2] == ["tail", "-n"] and len(argv) == 3:
        lines = lines[-int(argv[2]):]
    elif argv[:2] == ["sed", "-n"] and len(argv) == 3:
        keep = []
        for rng in argv[2].split(";"):
            m = re.fullmatch(r"(\d+)(?:,(\d+))?p", rng.strip())
            if not m:
                raise SystemExit(f"unsupported sed range {rng!r}")
            a, b = int(m.group(1)), int(m.group(2) or m.group(1))
            keep.extend(lines[a - 1:b])
        lines = keep
    elif argv[:2] == ["grep", "-E"] and len(argv) == 3:
        lines = [ln for ln in lines if re.search(argv[2], ln)]
    else:
        raise SystemExit(f"unsupported filter {' '.join(argv)!r} (head -n, tail -n, sed -n, grep -E)")
    return "\n".join(lines) + ("\n" if lines else "")


def _workdir() -> tempfile.TemporaryDirectory:
    tmp = tempfile.TemporaryDirectory(prefix="observer_cad_docs_")
    os.symlink(ROOT / "models", Path(tmp.name) / "models")
    os.symlink(ROOT / "examples", Path(tmp.name) / "examples")  # recorded data for monitor
    return tmp


def _run_cli(argv: list[str], cwd: str) -> tuple[int, str, str]:
    """observer_cad.cli.main(argv) in-process, in cwd; (status, stdout, stderr)."""
    if str(ROOT) not in sys.path[:1]:
        sys.path.insert(0, str(ROOT))
    from observer_cad.cli import main
    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    saved = {k: os.environ.pop(k, None) for k in ("OBSERVER_CAD_PROGRESS",)}
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = main(argv)
            except SystemExit as exc:  # --help, --version
                rc = exc.code if isinstance(exc.code, int) else 0
    finally:
        os.chdir(old)
        for k, v in saved.items():
            if v is not None:
                os.environ[k] = v
    return rc or 0, out.getvalue(), err.getvalue()


def _run_shell(script: str, cwd: str) -> tuple[int, str, str]:
    bindir = Path(cwd) / ".bin"
    bindir.mkdir(exist_ok=True)
    shim = bindir / "observer-cad"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m observer_cad "$@"\n')
    shim.chmod(0o755)
    env = dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}",
               PYTHONPATH=os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    env.pop("OBSERVER_CAD_PROGRESS", None)
    # no pipefail: `… | head` closes the pipe early, and whether the writer then dies of
    # SIGPIPE (status 141) depends on timing; the chain's && still stops at a failure
    r = subprocess.run(["bash", "-c", script], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=600)
    return r.returncode, r.stdout, r.stderr


def run_command(command: str) -> str:
    """What the block of ``command`` shows: the prompt line(s), the output, and, when the
    status is not 0, stderr and ``[exit status N]``."""
    with _workdir() as cwd:
        if command.startswith("sh: "):
            script = command[4:]
            rc, out, err = _run_shell(script, cwd)
            shown = script.split(" && ")       # one prompt per command of the chain
        else:
            head, filters = _split_pipeline(command)
            argv = shlex.split(head)
            if argv[0] != "observer-cad":
                raise SystemExit(f"a block's command must start with observer-cad or sh: ({command!r})")
            rc, out, err = _run_cli(argv[1:], cwd)
            for f in filters:
                out = _filter(out, f)
            shown = command
        text = out
        if rc != 0:
            text += err + f"[exit status {rc}]\n"
        text = text.replace(os.path.realpath(cwd), ".").replace(cwd, ".")
    text = text.replace("compiled C (cache hit)", "compiled C")
    body = "\n".join(line.rstrip() for line in text.rstrip("\n").splitlines())
    prompts = "\n".join(map(_prompt, shown if isinstance(shown, list) else [shown]))
    return "```console\n" + prompts + ("\n" + body if body else "") + "\n```"


def _prompt(command: str) -> str:
    """'$ command', wrapped with `` \\`` before an option (with its values) once a line
    would pass WRAP columns."""
    chunks: list[str] = []
    for w in command.split(" "):
        if not chunks or (w.startswith("--") and not chunks[-1].endswith("|")):
            chunks.append(w)
        else:
            chunks[-1] += " " + w
    lines, cur = [], "$ " + chunks[0]
    for c in chunks[1:]:
        if len(cur) + 1 + len(c) > WRAP:
            lines.append(cur + " \\")
            cur = "    " + c
        else:
            cur += " " + c
    lines.append(cur)
    return "\n".join(lines)


_DURATION = re.compile(r"\b\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)? ?(?:s|ms|µs|us|min)\b")
_RATE = re.compile(r"\b\d[\d,]*(?:\.\d+)? (runs|steps)/s\b")
_WORKERS = re.compile(r"(threads|processes|workers) × \d+")
_CHUNKS = re.compile(r"chunks of \d+")


def normalise(text: str) -> str:
    """The block text with what cannot repeat masked (module docstring)."""
    text = _RATE.sub(r"<t> \1/s", text)
    text = _DURATION.sub("<t>", text)
    text = _WORKERS.sub(r"\1 × <n>", text)
    text = _CHUNKS.sub("chunks of <n>", text)
    return "\n".join(line.rstrip() for line in text.splitlines())


# ------------------------------------------------------------------ command-line reference

def _argument(action: argparse.Action) -> str:
    if action.nargs == 0:
        return ""
    if action.choices and not isinstance(action.choices, dict):
        arg = "{" + ",".join(map(str, action.choices)) + "}"
    else:
        arg = action.metavar or action.dest.upper()
    if action.nargs in ("+", "*"):
        arg += " ..."
    elif action.nargs == "?":
        arg = f"[{arg}]"
    return arg


def _default(action: argparse.Action) -> str:
    d = action.default
    if d is None or d is argparse.SUPPRESS or d is False or d == [] or action.nargs == 0:
        return ""
    return f"`{d}`"


def _cell(text: str) -> str:
    """Table-cell text: pipes escaped, angle brackets as entities (``<signal>_hat`` is
    not an HTML tag), one line."""
    return ((text or "").replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")
            .replace("\n", " "))


def _table(actions: list[argparse.Action]) -> list[str]:
    rows = ["| name | argument | default | what it does |", "|---|---|---|---|"]
    for a in actions:
        if a.help == argparse.SUPPRESS or isinstance(a, argparse._SubParsersAction):
            continue
        name = ", ".join(f"`{o}`" for o in a.option_strings) or f"`{a.metavar or a.dest}`"
        extra = " (required)" if a.required and a.option_strings else ""
        if isinstance(a, argparse._AppendAction) and "repeatable" not in (a.help or ""):
            extra += " (repeatable)"
        arg = _argument(a) if a.option_strings else ""   # a positional is its own name
        rows.append(f"| {name} | {_cell(f'`{arg}`' if arg else '')} | {_cell(_default(a))} "
                    f"| {_cell(a.help or '')}{extra} |")
    return rows


def cli_reference() -> str:
    """The Markdown of every command and option, from the parser itself."""
    if str(ROOT) not in sys.path[:1]:
        sys.path.insert(0, str(ROOT))
    from observer_cad.cli import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {c.dest: c.help for c in sub._choices_actions}
    out = [f"`{parser.prog}` — {parser.description}", "", "| command | what it does |",
           "|---|---|"]
    out += [f"| [`{name}`](#observer-cad-{name}) | {_cell(helps.get(name, ''))} |" for name in sub.choices]
    out += ["", "Options before the command:", ""] + _table(
        [a for a in parser._actions if a.option_strings and a.dest != "help"])
    for name, p in sub.choices.items():
        out += ["", f"## observer-cad {name}", ""]
        if p.description:
            out += [_cell(p.description.strip()).replace("\\|", "|"), ""]
        for group in p._action_groups:
            actions = [a for a in group._group_actions if a.dest != "help"]
            if not actions:
                continue
            title = group.title
            if title in ("positional arguments", "options", "optional arguments"):
                title = "arguments" if title.startswith("positional") else "options"
            out += [f"**{title}**" + (f" — {group.description}" if group.description else ""), ""]
            out += _table(actions) + [""]
        while out[-1] == "":
            out.pop()
    return "\n".join(out)


def _replace_region(text: str, start: str, end: str, body: str, name: str) -> str:
    i, j = text.find(start), text.find(end)
    if i < 0 or j < i:
        raise SystemExit(f"{name}: markers {start} … {end} not found")
    return text[:i + len(start)] + "\n" + body + "\n" + text[j:]


def cli_region(text: str) -> str:
    i, j = text.find(CLI_OPEN), text.find(CLI_CLOSE)
    if i < 0 or j < i:
        raise SystemExit(f"{CLI_PAGE.name}: markers {CLI_OPEN} … {CLI_CLOSE} not found")
    return text[i + len(CLI_OPEN):j].strip("\n")


# ------------------------------------------------------------------------------ main

def regenerate(check: bool = False, fast: bool = False, only: str | None = None) -> list[str]:
    """Rewrite (or, with check, compare) every block; the list of blocks that differ."""
    differ = []
    for path in DOCUMENTS:
        text = path.read_text(encoding="utf-8")
        new = text
        for b in find_blocks(path):
            if (fast and b.slow) or (only and only not in b.command):
                continue
            t0 = __import__("time").perf_counter()
            fresh = run_command(b.command)
            dt = __import__("time").perf_counter() - t0
            print(f"{b.where}: {dt:5.1f} s  {b.command[:90]}", file=sys.stderr)
            if normalise(fresh) != normalise(b.text):
                differ.append(b.where)
                old_marker = f"<!-- output{' slow' if b.slow else ''}: {b.command} -->"
                new = new.replace(f"{old_marker}\n{b.text}\n{CLOSE}" if b.text else f"{old_marker}\n{CLOSE}",
                                  f"{old_marker}\n{fresh}\n{CLOSE}", 1)
        if path == CLI_PAGE and not only:
            ref = cli_reference()
            if cli_region(new) != ref:
                differ.append(f"{path.relative_to(ROOT)}: command-line reference")
                new = _replace_region(new, CLI_OPEN, CLI_CLOSE, ref, path.name)
        if new != text and not check:
            path.write_text(new, encoding="utf-8")
    return differ


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="compare only; exit 1 if a block differs")
    ap.add_argument("--fast", action="store_true", help="skip the blocks marked slow")
    ap.add_argument("--only", metavar="TEXT", help="only the blocks whose command contains TEXT")
    args = ap.parse_args(argv)
    os.environ.setdefault("MPLBACKEND", "Agg")
    differ = regenerate(check=args.check, fast=args.fast, only=args.only)
    verb = "differ" if args.check else "rewritten"
    for d in differ:
        print(f"{verb}: {d}")
    if not differ:
        print("every block is up to date")
    return 1 if (args.check and differ) else 0


if __name__ == "__main__":
    sys.exit(main())
