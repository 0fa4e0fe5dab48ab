"""Float helpers shared by the float synthesis paths: correctly rounded conversion of
exact matrices to numpy, float arrays back to sympy, floats to rationals without touching
exact numbers, and single-threaded BLAS."""
from __future__ import annotations

import contextlib
import functools
import sys
import threading

import numpy as np
import sympy as sp

__all__ = ["np_exact", "to_sympy_float", "SingleThreadBLAS", "rationalize_floats",
           "rational_approximation", "algebraic_to_float", "ALGEBRAIC_DIGITS", "readable",
           "READABLE_DIGITS", "full_int_text",
           "with_full_int_text"]

#: significant digits of the Float that stands for a CRootOf in numeric code
ALGEBRAIC_DIGITS = 30

#: a rational whose numerator or denominator has more digits than this is shown rounded
READABLE_DIGITS = 40


_FULL_TEXT_LOCK = threading.Lock()
_full_text_users = 0
_full_text_saved = 0


@contextlib.contextmanager
def full_int_text():
    """Within it, ``str`` of an integer of any length works: Python refuses more than
    4,300 digits by default (a guard for *parsing* untrusted text; our readers cap an
    expression's length themselves). Exact designs of large float-based plants can carry
    rationals that long. Threads share the limit, so it is lifted by the first block that
    enters and restored by the last that leaves."""
    global _full_text_users, _full_text_saved
    with _FULL_TEXT_LOCK:
        if _full_text_users == 0:
            _full_text_saved = sys.get_int_max_str_digits()
            sys.set_int_max_str_digits(0)
        _full_text_users += 1
    try:
        yield
    finally:
        with _FULL_TEXT_LOCK:
            _full_text_users -= 1
            if _full_text_users == 0:
                sys.set_int_max_str_digits(_full_text_saved)


def with_full_int_text(fn):
    """Decorator: run ``fn`` inside :func:`full_int_text`."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with full_int_text():
            return fn(*args, **kwargs)
    return wrapper


def readable(obj) -> str:
    """Text of a sympy expression or matrix (or a list of them) for messages: rationals
    whose numerator or denominator exceed :data:`READABLE_DIGITS` digits are shown as
    12-digit floats marked ``≈``. Exact values stay exact everywhere else; this only keeps
    a condition's detail readable (and printable: Python refuses to convert integers of
    more than 4,300 digits to text)."""
    limit = int(READABLE_DIGITS * 3.3219)  # bits

    def big(r):
        return r.p.bit_length() > limit or r.q.bit_length() > limit

    def one(e):
        e = sp.sympify(e)
        atoms = [r for r in e.atoms(sp.Rational) if big(r)]
        if not atoms:
            return str(e)
        marks = {r: sp.Symbol(f"≈{sp.Float(r, 12)}") for r in atoms}
        return str(e.xreplace(marks))

    if isinstance(obj, (list, tuple)):
        return "[" + ", ".join(readable(o) for o in obj) + "]"
    if isinstance(obj, sp.MatrixBase):
        return readable(obj.tolist())
    return one(obj)


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



def _float_rational(f: sp.Float) -> sp.Expr:
    if not f.is_finite:
        return f
    # a double: its shortest round-trip decimal (0.1 -> 1/10); more precise Floats: all
    # the digits they carry
    text = repr(float(f)) if f._prec <= 53 else str(f)
    return sp.Rational(text)


def rationalize_floats(expr):
    """``expr`` with every floating-point number replaced by the rational its decimal
    string denotes (``0.1`` → 1/10, ``2.5e-3`` → 1/400); exact numbers — rationals of
    any size, ``sqrt(2)``, π — are returned untouched.

    This is what ``sympy.nsimplify`` must never be used for: ``nsimplify`` guesses a
    "simple" closed form, and for an exact rational with large terms it returns a product
    of irrational powers (``nsimplify(313319610133/450092401851)`` =
    ``2**(20/101)*3**(37/707)*5**(354/707)*7**(611/707)/21``). Python ``float`` and
    ``int`` are accepted; infinities and NaN stay as they are.
    """
    if isinstance(expr, bool):
        raise TypeError("rationalize_floats: a bool is not a number")
    if isinstance(expr, float):
        return _float_rational(sp.Float(expr))
    if isinstance(expr, int):
        return sp.Integer(expr)
    e = sp.sympify(expr)
    if isinstance(e, sp.MatrixBase):
        return e.applyfunc(rationalize_floats)
    if isinstance(e, sp.Float):
        return _float_rational(e)
    floats = e.atoms(sp.Float) if isinstance(e, sp.Basic) else set()
    if not floats:
        return e
    return e.xreplace({f: _float_rational(f) for f in floats})


def algebraic_to_float(expr):
    """``expr`` with every ``CRootOf`` (an irrational Jordan λ of degree ≥ 3) replaced by
    its value as a Float of :data:`ALGEBRAIC_DIGITS` significant digits — for code that
    evaluates numerically (``lambdify``, substituting numbers for the plant's symbols).

    Both fail on the exact root: ``lambdify`` prints ``CRootOf(...)``, a name numpy does
    not have, and ``xreplace`` of a plant symbol that happens to be the root's polynomial
    variable (sympy writes roots in ``x``; a model may have a state ``x``) rebuilds the
    polynomial with a number in place of its variable. Anything without a ``CRootOf``
    is returned as it is.
    """
    e = sp.sympify(expr)
    if not isinstance(e, sp.Basic):
        return e
    if isinstance(e, sp.MatrixBase):
        return e.applyfunc(algebraic_to_float)
    roots = e.atoms(sp.CRootOf)
    if not roots:
        return e
    return e.xreplace({r: sp.Float(r.evalf(ALGEBRAIC_DIGITS), ALGEBRAIC_DIGITS) for r in roots})


def rational_approximation(x, tolerance: float) -> sp.Rational:
    """The simplest rational within ``tolerance`` (relative to max(1, ``|x|``)) of a float
    ``x`` — for floats that stand for a simple value (a pole from ``nroots``). An exact
    number is returned unchanged.

    Examples
    --------
    >>> from observer_cad.numerics import rational_approximation
    >>> rational_approximation(0.3333333333333, 1e-9)
    1/3
    """
    e = sp.sympify(x)
    if not isinstance(e, sp.Float):
        if e.is_Rational or not e.is_number or e.atoms(sp.Float) == set():
            return e
    from fractions import Fraction
    v = float(e)
    scale = max(1.0, abs(v))
    f = Fraction(v)
    den = 1
    while True:  # smallest denominator whose best approximation is within the tolerance
        g = f.limit_denominator(den)
        if abs(float(g) - v) <= tolerance * scale or den >= 10 ** 15:
            return sp.Rational(g.numerator, g.denominator)
        den *= 2


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
