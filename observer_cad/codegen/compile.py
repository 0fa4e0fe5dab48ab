"""C code generation, compilation and a content-addressed cache of shared libraries.

* C comes from casadi's :class:`casadi.CodeGenerator` with ``casadi_real`` = ``double``
  (a ``float`` library loads without a type check and returns garbage).
* It is compiled by the system C compiler (``$CC``, else ``cc``) with
  ``-O3 -shared -fPIC`` into ``CACHE/NAME-KEY.so``; ``CACHE`` is ``$OBSERVER_CAD_CACHE``
  or ``~/.cache/observer_cad``; ``KEY`` is the sha256 of the C source, the compiler
  (resolved path and ``--version``) and the flags.  A changed model changes the C and
  so the key: it recompiles; the same source is a cache hit (no compiler run).
* Writes are atomic: the compiler writes a temporary file in the cache directory,
  which :func:`os.replace` renames onto the entry.  Two processes compiling the same
  function at once both succeed (the later rename replaces an identical file); a
  compile killed halfway leaves at most a ``.tmp-*`` file, never an entry.  An entry
  that fails to load anyway is removed and rebuilt.
* A missing compiler or a compiler error raises :class:`CodegenError` (one line, with
  the compiler's first error); the interpreted casadi Function is untouched and usable.
"""
from __future__ import annotations

import dataclasses
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import casadi as ca

from ..errors import ObserverCadError

__all__ = ["CodegenError", "cache_dir", "compiler", "generate_c", "compile_source",
           "compile_function", "compile_or_interpret", "CompiledFunction", "STATS", "FLAGS"]

FLAGS = ("-O3", "-shared", "-fPIC")
STATS = {"compiles": 0, "hits": 0}
_LOCK = threading.Lock()
_CC_ID: dict = {}


class CodegenError(ObserverCadError):
    """C code generation or compilation failed (no compiler, compiler error, bad library)."""


def cache_dir(path=None) -> Path:
    if path is not None:
        return Path(path)
    env = os.environ.get("OBSERVER_CAD_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "observer_cad"


def compiler(cc=None) -> str:
    """The compiler's resolved path; CodegenError when it does not exist."""
    name = cc or os.environ.get("CC") or "cc"
    path = shutil.which(name)
    if path is None:
        raise CodegenError(f"C compiler '{name}' not found (set CC to a C compiler, e.g. gcc);"
                           " the interpreted casadi function is still usable")
    return path


def _compiler_id(path: str) -> str:
    try:
        st = os.stat(path)
    except OSError as exc:
        raise CodegenError(f"C compiler '{path}': {exc.strerror}") from None
    key = (path, st.st_mtime_ns, st.st_size)
    hit = _CC_ID.get(key)
    if hit is None:
        try:
            r = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=30)
            ver = (r.stdout or r.stderr).strip().splitlines()[:1]
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise CodegenError(f"C compiler '{path}' does not run: {exc}") from None
        hit = f"{path}\n{ver[0] if ver else ''}"
        _CC_ID[key] = hit
    return hit


def generate_c(f: ca.Function, *, header_comment: str | None = None) -> str:
    """C source of ``f`` (casadi_real = double, no header, no main)."""
    cg = ca.CodeGenerator(f"{f.name()}.c", {"casadi_real": "double", "with_header": False})
    cg.add(f)
    src = cg.dump()
    doc = header_comment if header_comment is not None else getattr(f, "__doc__", None)
    if doc and not doc.lstrip().startswith("Function object"):
        src = "/*\n" + doc.replace("*/", "* /") + "\n*/\n" + src
    return src


@dataclasses.dataclass(frozen=True)
class CompileResult:
    path: Path
    key: str
    cached: bool
    seconds: float


def _cleanup(*paths):
    for p in paths:
        try:
            os.unlink(p)
        except OSError:
            pass


def compile_source(source: str, name: str, *, cache=None, cc=None, flags=FLAGS,
                   check=None) -> CompileResult:
    """Compile C ``source`` to ``CACHE/NAME-KEY.so`` (or reuse it).  ``check(path)``, if
    given, validates a cached entry (e.g. by loading it); a failing entry is rebuilt."""
    t0 = time.perf_counter()
    ccpath = compiler(cc)
    flags = tuple(flags)
    key = hashlib.sha256("\0".join([source, _compiler_id(ccpath), " ".join(flags)])
                         .encode()).hexdigest()
    d = cache_dir(cache)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CodegenError(f"cache directory {d}: {exc.strerror}") from None
    final = d / f"{name}-{key[:32]}.so"
    if final.is_file():
        ok = True
        if check is not None:
            try:
                check(final)
            except Exception:  # noqa: BLE001 - a bad entry is rebuilt
                ok = False
                _cleanup(final)
        if ok:
            with _LOCK:
                STATS["hits"] += 1
            return CompileResult(final, key, True, time.perf_counter() - t0)
    fd, csrc = tempfile.mkstemp(prefix=f".tmp-{name}-", suffix=".c", dir=d)
    tmp_so = csrc[:-2] + ".so"
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(source)
        cmd = [ccpath, *flags, "-o", tmp_so, csrc, "-lm"]
        try:
            r = subprocess.run(cmd, capture_output=True, text=True)
        except OSError as exc:
            raise CodegenError(f"C compiler '{ccpath}' failed to start: {exc.strerror}") from None
        if r.returncode != 0 or not os.path.isfile(tmp_so):
            lines = [ln for ln in (r.stderr or r.stdout or "").splitlines() if "error" in ln]
            first = lines[0] if lines else ((r.stderr or r.stdout).strip().splitlines() or ["?"])[0]
            raise CodegenError(f"compiling {name} with {ccpath} failed (exit {r.returncode}):"
                               f" {first.strip()}; the interpreted casadi function is still usable")
        os.replace(tmp_so, final)
        # keep the source next to the library for inspection (also atomic)
        os.replace(csrc, final.with_suffix(".c"))
    finally:
        _cleanup(csrc, tmp_so)
    with _LOCK:
        STATS["compiles"] += 1
    return CompileResult(final, key, False, time.perf_counter() - t0)


@dataclasses.dataclass(frozen=True)
class CompiledFunction:
    """A compiled casadi Function (``function``: loaded by ``casadi.external``), the
    library it came from and whether it was a cache hit."""

    function: ca.Function
    path: Path
    cached: bool
    seconds: float

    def __call__(self, *args, **kw):
        return self.function(*args, **kw)


def _load(name: str, path: Path) -> ca.Function:
    try:
        return ca.external(name, str(path))
    except RuntimeError as exc:
        msg = str(exc).strip().splitlines()
        raise CodegenError(f"cannot load {path}: {msg[-1] if msg else exc}") from None


def compile_function(f: ca.Function, *, cache=None, cc=None, flags=FLAGS) -> CompiledFunction:
    """Generate, compile (or reuse) and load ``f``; the result behaves like ``f``."""
    t0 = time.perf_counter()
    src = generate_c(f)
    name = f.name()
    res = compile_source(src, name, cache=cache, cc=cc, flags=flags,
                         check=lambda p: _load(name, p))
    g = _load(name, res.path)
    g.__doc__ = getattr(f, "__doc__", None)
    return CompiledFunction(g, res.path, res.cached, time.perf_counter() - t0)


def compile_or_interpret(f: ca.Function, **kw):
    """The compiled function, or ``f`` itself (with the reason) when compilation fails."""
    try:
        return compile_function(f, **kw).function, None
    except CodegenError as exc:
        return f, str(exc)
