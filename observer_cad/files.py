"""Atomic file output: a file is either its old content or its complete new content,
never half-written (a temporary file in the same folder, then ``os.replace``)."""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from pathlib import Path

from .errors import UsageError

__all__ = ["atomic_write_text", "atomic_write_bytes", "atomic_writer", "read_json_file",
           "staged_directory", "new_file_mode"]


def new_file_mode() -> int:
    """The mode a new file gets from ``open`` here: 0o666 without the process umask.
    (``mkstemp`` makes its files 0o600; an output file should be as readable as any
    other the user writes.)"""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_text(path: Path, text: str) -> None:
    """Write a file atomically: a temporary file in the same folder, then os.replace."""
    with atomic_writer(path) as fh:
        fh.write(text)


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write binary ``data`` atomically (a temporary file in the same folder, then
    os.replace), e.g. a zip archive built in memory."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, new_file_mode())
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


@contextlib.contextmanager
def atomic_writer(path: Path, *, encoding: str | None = None):
    """A text stream to a temporary file in ``path``'s folder, renamed to ``path`` when
    the block ends without an exception (removed otherwise): for files written
    piecewise, e.g. streamed CSV."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, new_file_mode())
        with os.fdopen(fd, "w", newline="", encoding=encoding) as fh:
            yield fh
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def read_json_file(path, what: str):
    """The JSON value in a file, or a one-line :class:`UsageError` naming the file: missing,
    unreadable, not UTF-8, not valid JSON, or nested too deeply."""
    p = Path(path)
    if not p.is_file():
        raise UsageError(f"{path}: no such {what} file")
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise UsageError(f"{path}: not valid JSON: {exc}") from None
    except RecursionError:
        raise UsageError(f"{path}: not valid JSON: nested too deeply") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{path}: cannot read the {what}:"
                         f" {getattr(exc, 'strerror', None) or type(exc).__name__}") from None


@contextlib.contextmanager
def staged_directory(out_dir):
    """A hidden staging folder inside ``out_dir`` to write a command's files into; when
    the block ends without an exception each file is moved into place (``os.replace``,
    subfolders kept) once every target has been checked (no directory where a file goes,
    no file where a folder goes); otherwise the staging folder is removed — and
    ``out_dir`` too if this call created it and it is still empty. So an error while
    writing (a full disk, a plot that fails, an obstacle) leaves ``out_dir`` as it was,
    never half old and half new."""
    out = Path(out_dir)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(prefix=".staging-", dir=out))
    except OSError as exc:
        raise UsageError(f"{out_dir}: cannot create the output directory:"
                         f" {exc.strerror or exc}") from None
    done = False
    try:
        yield stage
        files = sorted(p for p in stage.rglob("*") if p.is_file())
        for src in files:  # every target checked before the first is replaced
            dst = out / src.relative_to(stage)
            blocked = next((q for q in [dst, *dst.parents] if q != out and q.is_relative_to(out)
                            and (q.is_dir() if q == dst else (q.exists() and not q.is_dir()))),
                           None)
            if blocked is not None:
                raise UsageError(f"{blocked}: cannot write {dst.name} there ("
                                 f"{'a directory' if blocked == dst else 'a file'} is in the"
                                 f" way); {out} is left as it was")
        for src in files:
            dst = out / src.relative_to(stage)
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dst)
        done = True
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if not done and created:
            try:  # only if still empty: another process may have written there meanwhile
                out.rmdir()
            except OSError:
                pass
