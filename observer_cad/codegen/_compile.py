"""C code generation, compilation and a content-addressed cache of shared libraries.

* C comes from casadi's :class:`casadi.CodeGenerator` with ``casadi_real`` = ``double``
  (a ``float`` library loads without a type check and returns garbage).
* It is compiled by the system C compiler (``$CC``, else ``cc``) with
  ``-O3 -shared -fPIC`` into ``CACHE/NAME-KEY.so`` — size-aware: C larger than
  :data:`LARGE_SOURCE` bytes is compiled at ``-O1`` (:func:`size_aware_flags`; explicit
  ``flags=`` are used as given); ``CACHE`` is ``$OBSERVER_CAD_CACHE``
  or ``~/.cache/observer_cad``; ``KEY`` is the sha256 of the C source, the compiler
  (resolved path and ``--version``) and the flags actually used.  A changed model changes the C and
  so the key: it recompiles; the same source is a cache hit (no compiler run).
* Writes are atomic: the compiler writes a temporary file in the cache directory,
  which :func:`os.replace` renames onto the entry.  Two processes compiling the same
  function at once both succeed (the later rename replaces an identical file); a
  compile killed halfway leaves at most a ``.tmp-*`` file, never an entry.  An entry
  that fails to load anyway is removed and rebuilt.
* A missing compiler or a compiler error raises :class:`CodegenError` (one line, with
  the compiler's first error); the interpreted casadi Function is untouched and usable.

**Integrity: what the checksum detects, and what it does not.**  Every library has a
checksum file ``NAME-KEY.so.sha256`` (``sha256sum -c`` format), written atomically after
it.  Before a library is loaded (``casadi.external`` or ctypes) its SHA-256 is computed
and compared — so a truncated, corrupted or partly overwritten library is never mapped
(no SIGBUS); a missing, mismatched or unreadable checksum makes the entry be rebuilt
atomically (entries of earlier versions, which had no checksum, are rebuilt once).  The
checksum lives in the same folder as the library, so it detects *corruption*, not
*forgery*: whoever can write the cache folder can replace a library together with its
``.sha256`` (and a ``.ref``), and a later process loads it.  Only the libraries this
process compiled itself are checked against a hash kept in memory (:data:`_BUILT`), which
no writer of the folder can change.  Protection from other users comes from the
ownership and permission checks below; the cache folder is to be trusted like the
installed package.  Entries (library,
checksum, ``.ref``) must be regular files owned by the current user and not writable by
group or others, else they are refused and rebuilt (one warning line on stderr).  The
cache directory itself must be owned by the current user, not writable by group or
others, and writable: otherwise — or when it cannot be created — a private cache is used
instead (``$TMPDIR/observer_cad-UID``, mode 0700, or a fresh ``mkdtemp`` directory) with
one warning line on stderr naming both.

**Fingerprints (cache hits without translation).**  Computing ``KEY`` needs the C,
i.e. the sympy → casadi translation and casadi's code generation (10–30 ms).  Callers
that start from sympy (:func:`compile_observer_step`, :func:`compile_plant_step`,
:class:`~observer_cad.codegen.CompiledSimulator`) also pass a cheap
*pre-translation fingerprint*: the sha256 of a structural serialisation of the
equations (:func:`structure`: node types, exact numbers, symbols with their
assumptions — what ``sympy.srepr`` says, 30–50× faster), the options (step size,
discretisation, names), the casadi and sympy versions, a digest of this package's
codegen sources, the compiler (resolved path, size and mtime of the binary) and the
flags.  ``CACHE/NAME-FP.ref`` (JSON, written atomically after the library) maps the
fingerprint to the library ``NAME-KEY.so`` and keeps the function's name and
docstring, so a hit reads one small file and loads the library: no translation, no C
generation, no compiler run.  The content hash stays the artefact key: a changed model
changes the fingerprint, misses, is translated, and recompiles only if its C changed.
A ``.ref`` whose library is missing or does not load is ignored (and replaced after the
rebuild), and so is one whose library name does not agree with its own function name and
key (``NAME-KEY.so``) or, in the process that wrote it, differs from what it recorded: a
``.ref`` is a shortcut, believed only as far as these checks go (a writer of the folder
can still point it at another valid library of the same name and key prefix it made).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import stat
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import casadi as ca
import sympy as sp

from ..errors import ObserverCadError

__all__ = ["CACHE_LOCK", "CodegenError", "cache_dir", "usable_cache_dir", "verify_library",
           "compiler", "generate_c", "compile_source", "source_key",
           "compile_function", "compile_or_interpret", "CompiledFunction", "STATS", "FLAGS",
           "LARGE_SOURCE", "LARGE_LEVEL", "size_aware_flags",
           "structure", "fingerprint", "lookup_fingerprint", "record_fingerprint",
           "forget_fingerprint", "compile_observer_step", "compile_plant_step"]

FLAGS = ("-O3", "-shared", "-fPIC")
#: Generated C longer than this (characters) is compiled at :data:`LARGE_LEVEL` instead
#: of -O3.  casadi emits one straight-line function per step, and gcc's -O3 passes
#: (PRE, load CSE after reload, register allocation over thousands of temporaries) grow
#: faster than linearly with it.  Measured (benchmarks/bench_latency.py, gcc 12): a
#: 60-state random plant + diagnostic observer (220 kB of C) takes 7.5 s CPU at -O3 and
#: 1.5 s at -O1, and runs *faster* at -O1 (2.6 vs 3.5 µs/step); the DREM example (120 kB)
#: 1.9 → 0.9 s, 1.33 → 1.39 µs/step (+5 %); below ~20 kB -O3 costs < 0.1 s more and
#: its steps are 20–30 % faster, so small steps keep -O3.
LARGE_SOURCE = 50_000
LARGE_LEVEL = "-O1"
#: compiles: compiler runs; hits: content-key hits (C generated, compiler skipped);
#: fingerprint_hits: pre-translation hits (no translation, no C generation)
STATS = {"compiles": 0, "hits": 0, "fingerprint_hits": 0}
CACHE_LOCK = threading.Lock()
_CC_ID: dict = {}
_SRC_DIGEST: list = []


class CodegenError(ObserverCadError):
    """C code generation or compilation failed (no compiler, compiler error, bad library)."""


def size_aware_flags(source: str, flags=FLAGS) -> tuple:
    """``flags`` for compiling ``source``: ``-O3`` replaced by :data:`LARGE_LEVEL` when
    the source is longer than :data:`LARGE_SOURCE` characters (see there for the
    measurements), else ``flags`` unchanged."""
    flags = tuple(flags)
    if len(source) > LARGE_SOURCE and "-O3" in flags:
        return tuple(LARGE_LEVEL if f == "-O3" else f for f in flags)
    return flags


def _policy(flags) -> str:
    """The flags as they enter a fingerprint: explicit flags verbatim; ``None`` (the
    size-aware default) as FLAGS plus the size rule, so that changing the rule changes
    every fingerprint."""
    if flags is None:
        return " ".join(FLAGS) + f" [size-aware: {LARGE_LEVEL} above {LARGE_SOURCE}]"
    return " ".join(flags)


def cache_dir(path=None) -> Path:
    """The requested cache directory: ``path``, ``$OBSERVER_CAD_CACHE`` or
    ``~/.cache/observer_cad`` (see :func:`usable_cache_dir` for the one actually used)."""
    if path is not None:
        return Path(path)
    env = os.environ.get("OBSERVER_CAD_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "observer_cad"


_WARNED: set = set()
_PRIVATE: list = []


def _warn(message: str) -> None:
    """One line on stderr, once per process and message."""
    with CACHE_LOCK:
        if message in _WARNED:
            return
        _WARNED.add(message)
    print(f"observer-cad: warning: {message}", file=sys.stderr)


def _untrusted(st) -> str | None:
    """Why a file or directory with this stat is not trusted, or None."""
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return f"is owned by another user (uid {st.st_uid})"
    if st.st_mode & 0o022:
        return "is writable by group or others"
    return None


def _dir_problem(d: Path) -> str | None:
    try:
        st = os.stat(d)
    except OSError as exc:
        return f"cannot be read ({exc.strerror})"
    if not stat.S_ISDIR(st.st_mode):
        return "is not a directory"
    bad = _untrusted(st)
    if bad:
        return bad
    if not os.access(d, os.W_OK | os.X_OK):
        return "is not writable"
    return None


def _private_cache() -> Path:
    """A cache only the current user can write: ``$TMPDIR/observer_cad-UID`` (mode 0700)
    when it is trustworthy, else a fresh ``mkdtemp`` directory (mode 0700)."""
    with CACHE_LOCK:
        if _PRIVATE and _dir_problem(_PRIVATE[0]) is None:
            return _PRIVATE[0]
        uid = os.getuid() if hasattr(os, "getuid") else 0
        p = Path(tempfile.gettempdir()) / f"observer_cad-{uid}"
        try:
            p.mkdir(mode=0o700, exist_ok=True)
        except OSError:
            pass
        if _dir_problem(p) is not None:
            try:
                p = Path(tempfile.mkdtemp(prefix="observer_cad-"))
            except OSError as exc:
                raise CodegenError(f"no usable compile cache: cannot create a private"
                                   f" temporary directory ({exc.strerror})") from None
        _PRIVATE[:] = [p]
        return p


def usable_cache_dir(path=None) -> Path:
    """The cache directory to use: :func:`cache_dir` (created with mode 0700 if missing)
    when it is owned by the current user, not writable by group or others, and writable;
    otherwise a private cache (:func:`_private_cache`), with one warning line on stderr."""
    d = cache_dir(path)
    try:
        d.mkdir(parents=True, exist_ok=True, mode=0o700)
    except OSError as exc:
        problem = f"cannot be created ({exc.strerror or type(exc).__name__})"
    else:
        problem = _dir_problem(d)
    if problem is None:
        return d
    p = _private_cache()
    _warn(f"compile cache {d} {problem}; using the private cache {p} instead")
    return p


def _file_problem(path: Path) -> str | None:
    """Why a cache file is not trusted (missing, not a regular file, foreign, loose
    permissions), or None."""
    try:
        st = os.lstat(path)
    except OSError:
        return "is missing"
    if not stat.S_ISREG(st.st_mode):
        return "is not a regular file"
    return _untrusted(st)


def _sha256_file(path: Path) -> str | None:
    h = hashlib.sha256()
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
        with os.fdopen(fd, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
    except OSError:
        return None
    return h.hexdigest()


def _sum_path(library: Path) -> Path:
    return library.with_name(library.name + ".sha256")


def verify_library(library) -> str | None:
    """None when ``library`` may be loaded: it and its checksum file are regular files
    owned by the current user, not writable by group or others, and the library's
    SHA-256 is the one recorded; otherwise the reason (the entry is then rebuilt)."""
    library = Path(library)
    for p in (library, _sum_path(library)):
        bad = _file_problem(p)
        if bad:
            return f"{p.name} {bad}"
    try:
        with open(_sum_path(library), "rb") as fh:
            text = fh.read(512).decode("ascii")
        recorded = text.split()[0]
    except (OSError, UnicodeDecodeError, IndexError):
        return f"{_sum_path(library).name} is unreadable"
    actual = _sha256_file(library)
    if actual is None or actual != recorded:
        return f"{library.name} does not match its recorded SHA-256"
    built = _BUILT.get(str(library))
    if built is not None and built != actual:  # this process compiled it: its own record
        return f"{library.name} is not the library this process compiled"
    return None


#: SHA-256 of every library this process compiled, by path: kept in memory, where a
#: writer of the cache folder cannot change it (a library replaced together with its
#: ``.sha256`` after this process built it is refused; one built by an earlier process
#: is only checked against its ``.sha256``, which detects corruption, not forgery)
_BUILT: dict = {}
#: the library each fingerprint this process recorded maps to (the same, for ``.ref``)
_REFS: dict = {}


def _refuse(path: Path, reason: str) -> None:
    """A refused entry: warn when it is foreign or writable by others (a possible attack);
    a missing or mismatched checksum is rebuilt silently (an old or broken entry)."""
    if "owned by another user" in reason or "writable by group" in reason:
        _warn(f"compile cache entry {path.parent / reason.split(' ')[0]} {reason.split(' ', 1)[1]};"
              " not loaded, rebuilt")


def _write_sum(library: Path, digest: str) -> None:
    """``NAME.so.sha256`` atomically (``sha256sum -c`` format)."""
    d = library.parent
    fd, tmp = tempfile.mkstemp(prefix=f".tmp-{library.name}-", suffix=".sha256", dir=d)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(f"{digest}  {library.name}\n")
        os.replace(tmp, _sum_path(library))
    finally:
        _cleanup(tmp)


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


def _compiler_stat_id(path: str) -> str:
    """A cheap identity of the compiler binary for fingerprints (no process started):
    the resolved path, size and mtime of the file ``path`` leads to."""
    real = os.path.realpath(path)
    try:
        st = os.stat(real)
    except OSError as exc:
        raise CodegenError(f"C compiler '{path}': {exc.strerror}") from None
    return f"{path}->{real}:{st.st_size}:{st.st_mtime_ns}"


def _codegen_digest() -> str:
    """sha256 of this subpackage's sources (computed once per process): a change to the
    translator, the trajectory loops (their C, their argument block, the simulator) or
    the cache invalidates every fingerprint."""
    if not _SRC_DIGEST:
        h = hashlib.sha256()
        here = Path(__file__).resolve().parent
        for nm in ("_translate.py", "_trajectory.py", "_loops.py", "_engine.py", "_compile.py"):
            try:
                h.update((here / nm).read_bytes())
            except OSError:
                h.update(nm.encode())
        _SRC_DIGEST.append(h.hexdigest())
    return _SRC_DIGEST[0]


def structure(*items) -> str:
    """A structural serialisation of sympy expressions (and plain values), as
    unambiguous as ``sympy.srepr`` but linear in the number of *unique* nodes and
    30–50× faster: each node is written once as ``Type(#child, …)`` and referred to by
    its index; numbers exactly (``Q(p,q)`` rationals, ``F(mpf)`` floats), symbols by
    class, name, dummy index and assumptions.  Non-sympy items (str, int, float, None,
    tuples, lists, dicts) are written with ``repr``-like tokens."""
    memo: dict = {}
    out: list = []

    def walk(e):
        if isinstance(e, sp.Basic):
            k = memo.get(e)
            if k is not None:
                return k
            if e.is_Symbol:
                extra = f",{e.dummy_index}" if isinstance(e, sp.Dummy) else ""
                tok = (f"{type(e).__name__}({e.name!r}{extra};"
                       f"{sorted(e.assumptions0.items())})")
            elif e.is_Rational:
                tok = f"Q({e.p},{e.q})"
            elif e.is_Float:
                tok = f"F{e._mpf_}"
            else:
                tok = type(e).__name__ + "(" + ",".join(walk(a) for a in e.args) + ")"
            out.append(tok)
            k = f"#{len(out) - 1}"
            memo[e] = k
            return k
        if isinstance(e, (list, tuple)):
            return "[" + ",".join(walk(a) for a in e) + "]"
        if isinstance(e, dict) or hasattr(e, "items"):
            return "{" + ",".join(f"{walk(a)}:{walk(b)}" for a, b in e.items()) + "}"
        if isinstance(e, (str, int, float, bool)) or e is None:
            return f"{type(e).__name__}:{e!r}"
        return walk(sp.sympify(e))

    roots = [walk(x) for x in items]
    return "\n".join(out) + "\n=" + ",".join(roots)


def fingerprint(parts, *, cc=None, flags=None) -> str:
    """The pre-translation cache key: sha256 of ``structure(*parts)`` (the caller's
    equations and options), the casadi and sympy versions, the codegen sources' digest,
    the compiler's cheap identity and the flags (``None``: the size-aware default, with
    its rule).  CodegenError without a compiler."""
    ccpath = compiler(cc)
    h = hashlib.sha256()
    for piece in (structure(*parts), ca.__version__, sp.__version__, _codegen_digest(),
                  _compiler_stat_id(ccpath), _policy(flags)):
        h.update(piece.encode())
        h.update(b"\0")
    return h.hexdigest()


def _ref_path(d: Path, name: str, fp: str) -> Path:
    return d / f"{name}-{fp[:32]}.ref"


def lookup_fingerprint(fp: str, name: str, *, cache=None) -> dict | None:
    """The record a fingerprint maps to (``library`` an existing path, ``function``,
    ``doc``, ``key``, ``flags`` a tuple, empty when not recorded), or None."""
    d = usable_cache_dir(cache)
    ref = _ref_path(d, name, fp)
    bad = _file_problem(ref)
    if bad:
        if bad != "is missing":
            _refuse(ref, f"{ref.name} {bad}")
        return None
    try:
        rec = json.loads(ref.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(rec, dict) or rec.get("fingerprint") != fp:
        return None
    lib = rec.get("library")
    if not isinstance(lib, str) or "/" in lib or os.sep in lib or lib.startswith("."):
        return None
    key, function = rec.get("key"), rec.get("function") or name
    if not (isinstance(key, str) and len(key) == 64 and all(c in "0123456789abcdef" for c in key)
            and isinstance(function, str)
            and lib in (f"{name}-{key[:32]}.so", f"{function}-{key[:32]}.so")):
        return None  # a redirect to a library of another name or key: translated again
    path = d / lib
    if _REFS.get((str(d), name, fp), path) != path:
        return None  # this process recorded another library for this fingerprint
    bad = verify_library(path)
    if bad:
        _refuse(path, bad)
        return None
    rec["library"] = path
    fl = rec.get("flags")
    rec["flags"] = tuple(fl) if isinstance(fl, list) and all(isinstance(x, str) for x in fl) else ()
    return rec


def record_fingerprint(fp: str, name: str, library: Path, *, cache=None, function=None,
                       doc=None, key=None, flags=None) -> None:
    """Write ``CACHE/NAME-FP.ref`` atomically (a temporary file, then os.replace).
    Failure to write is not an error (the next call just translates again)."""
    d = usable_cache_dir(cache)
    _REFS[(str(d), name, fp)] = d / Path(library).name
    rec = {"fingerprint": fp, "library": Path(library).name, "function": function,
           "doc": doc, "key": key, "casadi": ca.__version__,
           "flags": list(flags) if flags is not None else None}
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".tmp-{name}-", suffix=".ref", dir=d)
    except OSError:
        return
    try:
        with os.fdopen(fd, "w") as fh:
            json.dump(rec, fh)
        os.replace(tmp, _ref_path(d, name, fp))
    except OSError:
        pass
    finally:
        _cleanup(tmp)


def forget_fingerprint(fp: str, name: str, *, cache=None) -> None:
    _cleanup(_ref_path(usable_cache_dir(cache), name, fp))


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
    """A compiled library: its path, content key, whether it was a cache hit, the time
    taken and the compiler flags it was built with."""

    path: Path
    key: str
    cached: bool
    seconds: float
    flags: tuple = ()


def _cleanup(*paths):
    for p in paths:
        try:
            os.unlink(p)
        except OSError:
            pass


def compile_source(source: str, name: str, *, cache=None, cc=None, flags=None,
                   check=None) -> CompileResult:
    """Compile C ``source`` to ``CACHE/NAME-KEY.so`` (or reuse it).  ``flags``: the
    compiler flags, or None for :data:`FLAGS` made size-aware (:func:`size_aware_flags`);
    the key includes the flags actually used.  A cached entry is
    used only when :func:`verify_library` accepts it (and ``check(path)``, if given, e.g.
    loading it, succeeds); otherwise it is rebuilt atomically.  When the cache cannot
    take the entry (not writable, a directory in the way) the private cache is used."""
    t0 = time.perf_counter()
    ccpath = compiler(cc)
    flags = size_aware_flags(source) if flags is None else tuple(flags)
    key = source_key(source, ccpath, flags)
    d = usable_cache_dir(cache)
    try:
        return _compile_into(d, source, name, key, ccpath, flags, check, t0)
    except _CacheWriteError as exc:
        p = _private_cache()
        if p == d:
            raise CodegenError(f"compile cache {d}: cannot write {exc}") from None
        _warn(f"compile cache {d}: cannot write {exc}; using the private cache {p} instead")
        return _compile_into(p, source, name, key, ccpath, flags, check, t0)


def source_key(source: str, ccpath, flags) -> str:
    """The artefact key of C ``source`` built by the compiler ``ccpath`` (a resolved path,
    :func:`compiler`) with ``flags``: what names ``CACHE/NAME-KEY.so``."""
    return hashlib.sha256("\0".join([source, _compiler_id(ccpath), " ".join(flags)])
                          .encode()).hexdigest()


class _CacheWriteError(Exception):
    """Internal: the cache directory did not take a file (reason as the message)."""


def _compile_into(d: Path, source, name, key, ccpath, flags, check, t0) -> CompileResult:
    final = d / f"{name}-{key[:32]}.so"
    if os.path.lexists(final):
        bad = verify_library(final)
        if bad is None and check is not None:
            try:
                check(final)
            except Exception:  # noqa: BLE001 - a bad entry is rebuilt
                bad = "does not load"
        if bad is None:
            with CACHE_LOCK:
                STATS["hits"] += 1
            return CompileResult(final, key, True, time.perf_counter() - t0, flags)
        _refuse(final, bad)
    try:
        fd, csrc = tempfile.mkstemp(prefix=f".tmp-{name}-", suffix=".c", dir=d)
    except OSError as exc:
        raise _CacheWriteError(f"a temporary file ({exc.strerror})") from None
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
        try:
            os.chmod(tmp_so, 0o644)  # never group/other-writable, whatever the umask
            digest = _sha256_file(Path(tmp_so))
            if digest is None:
                raise OSError(0, "the compiled library cannot be read")
            os.replace(tmp_so, final)
            _BUILT[str(final)] = digest
            _write_sum(final, digest)
            # keep the source next to the library for inspection (also atomic)
            os.chmod(csrc, 0o644)
            os.replace(csrc, final.with_suffix(".c"))
        except OSError as exc:
            raise _CacheWriteError(f"{final.name} ({exc.strerror or exc})") from None
    finally:
        _cleanup(csrc, tmp_so)
    with CACHE_LOCK:
        STATS["compiles"] += 1
    return CompileResult(final, key, False, time.perf_counter() - t0, flags)


@dataclasses.dataclass(frozen=True)
class CompiledFunction:
    """A compiled casadi Function (``function``: loaded by ``casadi.external``), the
    library it came from, whether it was a cache hit, whether the sympy → casadi
    translation ran (False on a fingerprint hit) and the compiler flags of the library
    (``()`` when a fingerprint record from an earlier version does not say)."""

    function: ca.Function
    path: Path
    cached: bool
    seconds: float
    translated: bool = True
    flags: tuple = ()

    def __call__(self, *args, **kw):
        return self.function(*args, **kw)


def _load(name: str, path: Path) -> ca.Function:
    try:
        return ca.external(name, str(path))
    except RuntimeError as exc:
        msg = str(exc).strip().splitlines()
        raise CodegenError(f"cannot load {path}: {msg[-1] if msg else exc}") from None


def compile_function(f, *, cache=None, cc=None, flags=None, identity=None,
                     name: str | None = None) -> CompiledFunction:
    """Generate, compile (or reuse) and load ``f``; the result behaves like ``f``.

    ``f`` is a casadi Function, or a zero-argument callable building one (called only
    when the cache cannot answer without it).  ``identity``: a tuple of sympy
    expressions and plain values that determines ``f`` *before* translation (the
    equations and the options it is built from); with it, a hit on the fingerprint
    (:func:`fingerprint`) loads the library without calling ``f`` or generating C.
    ``name`` (the Function's name) is required when ``f`` is a callable.  ``flags``:
    None for the size-aware default (:func:`compile_source`), else used as given.
    """
    t0 = time.perf_counter()
    flags = None if flags is None else tuple(flags)
    fp = None
    if name is None:
        if not isinstance(f, ca.Function):
            raise TypeError("compile_function: name= is required when f is a builder")
        name = f.name()
    if identity is not None:
        fp = fingerprint(("compile_function", name, tuple(identity)), cc=cc, flags=flags)
        rec = lookup_fingerprint(fp, name, cache=cache)
        if rec is not None:
            try:
                g = _load(str(rec.get("function") or name), rec["library"])
            except CodegenError:
                forget_fingerprint(fp, name, cache=cache)
            else:
                g.__doc__ = rec.get("doc")
                with CACHE_LOCK:
                    STATS["fingerprint_hits"] += 1
                return CompiledFunction(g, rec["library"], True, time.perf_counter() - t0,
                                        translated=False, flags=rec["flags"])
    if not isinstance(f, ca.Function):
        f = f()
    src = generate_c(f)
    fname = f.name()
    res = compile_source(src, fname, cache=cache, cc=cc, flags=flags,
                         check=lambda p: _load(fname, p))
    g = _load(fname, res.path)
    g.__doc__ = getattr(f, "__doc__", None)
    if fp is not None:
        record_fingerprint(fp, name, res.path, cache=cache, function=fname, doc=g.__doc__,
                           key=res.key, flags=res.flags)
    return CompiledFunction(g, res.path, res.cached, time.perf_counter() - t0,
                            flags=res.flags)


def compile_observer_step(observer, *, h: float | None = None, name: str | None = None,
                          cse: bool = False, discretisation: str = "rk4", cache=None, cc=None,
                          flags=None) -> CompiledFunction:
    """:func:`~observer_cad.codegen.observer_step`, compiled; a second call for
    the same observer and options is a fingerprint hit (no translation, no C)."""
    from ._translate import observer_identity, observer_step, observer_step_name
    ident = observer_identity(observer, h=h, name=name, cse=cse, discretisation=discretisation)
    return compile_function(
        lambda: observer_step(observer, h=h, name=name, cse=cse, discretisation=discretisation),
        cache=cache, cc=cc, flags=flags, identity=ident,
        name=observer_step_name(observer, name))


def compile_plant_step(model, *, h: float | None = None, name: str | None = None,
                       substitute_parameters: bool = False, cache=None, cc=None,
                       flags=None) -> CompiledFunction:
    """:func:`~observer_cad.codegen.plant_step`, compiled (fingerprint-cached)."""
    from ._translate import plant_identity, plant_step, plant_step_name
    ident = plant_identity(model, h=h, name=name, substitute_parameters=substitute_parameters)
    return compile_function(
        lambda: plant_step(model, h=h, name=name, substitute_parameters=substitute_parameters),
        cache=cache, cc=cc, flags=flags, identity=ident, name=plant_step_name(model, name))


def compile_or_interpret(f: ca.Function, **kw):
    """The compiled function, or ``f`` itself (with the reason) when compilation fails."""
    try:
        return compile_function(f, **kw).function, None
    except CodegenError as exc:
        return f, str(exc)
