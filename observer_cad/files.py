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
           "staged_directory", "new_file_mode", "check_output_targets", "MANIFEST"]

#: the hidden file in an output folder that lists, per command, the files the last run of
#: that command wrote there: the next run of the command removes those it does not write
#: again (a folder's files are its last run's); files observer-cad did not write (not
#: listed) are never touched
MANIFEST = ".observer-cad-files.json"


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


def _blocked(out: Path, dst: Path, *, folder: bool = False) -> Path | None:
    """The path in ``out`` that stops ``dst`` being written (a directory where a file goes,
    a file where a folder goes, a file where one of its parent folders goes), or None."""
    for q in [dst, *dst.parents]:
        if q == out or not q.is_relative_to(out):
            continue
        if q == dst:
            if (q.exists() and not q.is_dir()) if folder else q.is_dir():
                return q
        elif q.exists() and not q.is_dir():
            return q
    return None


def _obstacle(out: Path, blocked: Path, dst: Path, folder: bool) -> UsageError:
    what = "a directory" if blocked == dst and not folder else "a file"
    return UsageError(f"{blocked}: cannot write {dst.name} there ({what} is in the way); {out}"
                      " is left as it was")


def check_output_targets(out_dir, files=(), folders=()) -> None:
    """A one-line :class:`UsageError` when something in ``out_dir`` stands where one of
    ``files`` or ``folders`` (paths relative to it) is to be written: checked before a
    command's work, so that an obstacle is met before anything is computed or written."""
    out = Path(out_dir)
    for rel, folder in [*((f, False) for f in files), *((d, True) for d in folders)]:
        blocked = _blocked(out, out / rel, folder=folder)
        if blocked is not None:
            raise _obstacle(out, blocked, out / rel, folder)


def _safe_relative(rel) -> Path | None:
    """``rel`` (from a manifest: data, not trusted) as a plain relative path, or None."""
    if not isinstance(rel, str) or not rel or "\x00" in rel:
        return None
    p = Path(rel)
    if p.is_absolute() or any(part in ("..", ".", "") for part in p.parts):
        return None
    return p


def _read_manifest(out: Path) -> dict:
    try:
        data = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return {}
    return data if isinstance(data, dict) else {}


def _remove_stale(out: Path, command: str, written: set) -> None:
    """Remove the files the last ``command`` listed in the manifest and this run did not
    write (no symlinked folder followed: only files inside ``out``), then record
    ``written``."""
    manifest = _read_manifest(out)
    old = manifest.get(command, [])
    for rel in old if isinstance(old, list) else []:
        p = _safe_relative(rel)
        if p is None or str(p) in written:
            continue
        target = out / p
        if any((out / q).is_symlink() for q in list(p.parents)[:-1]) or \
                not (target.is_file() or target.is_symlink()):
            continue
        try:
            target.unlink()
            for parent in list(p.parents)[:-1]:  # folders it leaves empty
                (out / parent).rmdir()
        except OSError:
            pass
    manifest[command] = sorted(written)
    atomic_write_text(out / MANIFEST, json.dumps(manifest, indent=1) + "\n")


@contextlib.contextmanager
def staged_directory(out_dir, *, command: str | None = None):
    """A hidden staging folder inside ``out_dir`` to write a command's files into; when
    the block ends without an exception each file is moved into place (``os.replace``,
    subfolders kept) once every target has been checked (no directory where a file goes,
    no file where a folder goes); otherwise the staging folder is removed — and
    ``out_dir`` too if this call created it and it is still empty. So an error while
    writing (a full disk, a plot that fails, an obstacle) leaves ``out_dir`` as it was,
    never half old and half new. With ``command``, the files the last run of that command
    wrote there (:data:`MANIFEST`) and this one does not are removed afterwards."""
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
            blocked = _blocked(out, dst)
            if blocked is not None:
                raise _obstacle(out, blocked, dst, False)
        for src in files:
            dst = out / src.relative_to(stage)
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dst)
        done = True
        if command is not None:
            _remove_stale(out, command, {str(src.relative_to(stage)) for src in files})
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if not done and created:
            try:  # only if still empty: another process may have written there meanwhile
                out.rmdir()
            except OSError:
                pass
