"""A compiled library described by value, loadable in any process (an ensemble's workers).

A ctypes handle cannot be pickled, and a path to a ``.so`` means nothing on another
machine.  :class:`LibrarySpec` is what travels instead: the C source, the library name
prefix and compiler flags given to :func:`~observer_cad.codegen.compile_source`, the
content key it reported, and the compiler asked for.  :func:`load_library` turns it back
into a :class:`ctypes.CDLL` in whichever process calls it (a thread, a loky worker, a
Dask worker on another host):

* it calls ``compile_source(spec.source, spec.name, flags=spec.flags, cc=spec.cc)``,
  which reuses this machine's verified cache entry (SHA-256 checked, owner and mode
  checked; see :mod:`observer_cad.codegen._compile`) or compiles the source into it;
* it **refuses** (:class:`~observer_cad.codegen.CodegenError`, one line) when the key
  obtained differs from ``spec.key``: the key hashes the source, the compiler (path and
  ``--version``) and the flags, so a library built from other sources, or by another
  compiler, is never used for results that claim this one;
* it is memoised per process (a dict under a lock): the first call in a worker pays
  the cache look-up (one SHA-256 of the library, ~1 ms) or the compile; later calls
  return the same handle.

    r = compile_source(src, "ens_step")
    spec = library_spec(src, "ens_step", r)      # picklable, a few kB to MBs of C
    lib = load_library(spec)                     # in the worker: ctypes.CDLL
"""
from __future__ import annotations

import ctypes
import dataclasses
import threading

from ._compile import CodegenError, compile_source

__all__ = ["LibrarySpec", "library_spec", "load_library", "loaded_libraries"]


@dataclasses.dataclass(frozen=True)
class LibrarySpec:
    """A compiled C library by value (picklable): ``source`` the C text, ``name`` the
    library name prefix given to ``compile_source``, ``flags`` the compiler flags it was
    built with (as reported by ``CompileResult.flags``), ``key`` the content key
    ``compile_source`` reported (sha256 of source, compiler and flags), ``cc`` the
    compiler asked for (None: ``$CC`` or ``cc`` of the process that loads it)."""

    source: str
    name: str
    flags: tuple
    key: str
    cc: str | None = None

    def __post_init__(self):
        object.__setattr__(self, "flags", tuple(self.flags))

    def __repr__(self):  # the source can be megabytes: never print it
        return (f"LibrarySpec(name={self.name!r}, key={self.key[:16]}…, flags={self.flags!r},"
                f" cc={self.cc!r}, source={len(self.source)} chars)")


def library_spec(source: str, name: str, result, *, cc: str | None = None) -> LibrarySpec:
    """The :class:`LibrarySpec` of ``result`` (a ``CompileResult`` of
    ``compile_source(source, name, cc=cc, ...)``)."""
    return LibrarySpec(source=source, name=name, flags=tuple(result.flags), key=result.key,
                       cc=cc)


_LOADED: dict = {}
_LOCK = threading.Lock()


def load_library(spec: LibrarySpec, *, cache=None) -> ctypes.CDLL:
    """The library of ``spec`` loaded with ctypes in this process (memoised per process):
    found in this machine's content-hashed cache, or compiled into it, by
    ``compile_source``; CodegenError (one line) when the key obtained is not
    ``spec.key`` (other sources, flags or compiler) or when it cannot be compiled."""
    if not isinstance(spec, LibrarySpec):
        raise CodegenError(f"load_library needs a LibrarySpec, got {type(spec).__name__}")
    memo = (spec.key, spec.name, spec.flags, spec.cc, cache)
    with _LOCK:
        hit = _LOADED.get(memo)
        if hit is not None and (hit[0] is spec.source or hit[0] == spec.source):
            return hit[1]
        result = compile_source(spec.source, spec.name, cache=cache, cc=spec.cc,
                                flags=spec.flags)
        if result.key != spec.key:
            raise CodegenError(
                f"library {spec.name}: this machine builds key {result.key[:16]}… from the"
                f" given source and flags with its compiler, not {spec.key[:16]}…; refusing"
                " to use a library built from other sources or by another compiler")
        try:
            lib = ctypes.CDLL(str(result.path))
        except OSError as exc:
            raise CodegenError(f"library {result.path} does not load: {exc}") from None
        _LOADED[memo] = (spec.source, lib)
        return lib


def loaded_libraries() -> int:
    """How many libraries :func:`load_library` has loaded in this process (for tests and
    diagnostics: a worker should load each library once)."""
    with _LOCK:
        return len(_LOADED)
