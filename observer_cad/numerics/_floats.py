"""Float helpers shared by the float synthesis paths: correctly rounded conversion of
exact matrices to numpy, float arrays back to sympy, and single-threaded BLAS."""
from __future__ import annotations

import numpy as np
import sympy as sp

__all__ = ["np_exact", "to_sympy_float", "SingleThreadBLAS"]


def _to_np(M):
    M = sp.Matrix(M)
    if M.rows == 0 or M.cols == 0:
        return np.zeros(M.shape)
    return np.array(M.evalf(), dtype=float)


def np_exact(M) -> np.ndarray:
    """A numeric sympy matrix as floats, every entry correctly rounded.

    Rational matrices are read from their DomainMatrix (``p / q`` in Python is
    correctly rounded, and 3,600 entries take under a millisecond, against ~50 ms for
    ``evalf``, which also keeps 15 digits only); anything else goes through
    ``evalf(20)``.
    """
    r, c = M.shape
    if r == 0 or c == 0:
        return np.zeros((r, c))
    rep = getattr(M, "_rep", None)
    dom = getattr(rep, "domain", None)
    if dom is not None and (dom.is_QQ or dom.is_ZZ):
        return np.array([float(e) for e in rep.to_list_flat()], dtype=float).reshape(r, c)
    return np.array(sp.Matrix(M).evalf(20), dtype=float)


def to_sympy_float(A) -> sp.Matrix:
    """A float array as a sympy matrix (exact zeros stay Integer 0)."""
    A = np.atleast_2d(np.asarray(A, dtype=float))
    r, c = A.shape
    if r == 0 or c == 0:
        return sp.zeros(r, c)
    zero = sp.Integer(0)
    return sp.Matrix(r, c, [zero if x == 0.0 else sp.Float(float(x)) for x in A.ravel()])



class SingleThreadBLAS:
    """Context manager: OpenBLAS limited to one thread, restored afterwards.

    The float path's matrices are at most a few hundred wide, where BLAS threads bring
    nothing; but OpenBLAS's threaded kernels (used for the singular vectors from ~64
    rows on) stall for ~0.1 s per call when another process occupies the second core
    of a 2-core machine (measured: an 80×77 ``svd`` 96 ms instead of 1 ms, the n = 60
    design 1.4 s instead of 0.02 s). numpy has no API for it, so the library numpy
    loaded is found in ``/proc/self/maps`` (Linux) and its ``*set_num_threads*`` is
    called through ctypes, as threadpoolctl does. Anything unexpected: a no-op.
    Not re-entrant across threads (the setting is process-wide).
    """

    _funcs = None  # (get, set) or () when unavailable

    @classmethod
    def _find(cls):
        if cls._funcs is not None:
            return cls._funcs
        cls._funcs = ()
        try:
            import ctypes
            with open("/proc/self/maps") as fh:
                paths = (line.split()[-1] for line in fh if line.strip())
                libs = sorted({q for q in paths if "openblas" in q.lower() and ".so" in q})
            for lib in libs:
                h = ctypes.CDLL(lib)
                for suffix in ("64_", ""):
                    for prefix in ("scipy_openblas", "openblas"):
                        get = getattr(h, f"{prefix}_get_num_threads{suffix}", None)
                        set_ = getattr(h, f"{prefix}_set_num_threads{suffix}", None)
                        if get is not None and set_ is not None:
                            get.restype = ctypes.c_int
                            set_.argtypes = [ctypes.c_int]
                            cls._funcs = (get, set_)
                            return cls._funcs
        except Exception:  # pragma: no cover - platform without /proc or ctypes quirks
            cls._funcs = ()
        return cls._funcs

    def __enter__(self):
        funcs = self._find()
        self._old = None
        if funcs:
            try:
                self._old = funcs[0]()
                if self._old != 1:
                    funcs[1](1)
            except Exception:  # pragma: no cover
                self._old = None
        return self

    def __exit__(self, *exc):
        if self._old is not None and self._old != 1:
            try:
                self._funcs[1](self._old)
            except Exception:  # pragma: no cover
                pass
        return False
