"""The compiled trajectory loops, called through ctypes.

:class:`TrajectoryEngine` runs ``NAME_batch`` (the C of :mod:`observer_cad.codegen`
``_loops``) on a library it loads itself — picklable, so that an ensemble's workers get it
— and :class:`BatchArgs` is the loop's argument block in ctypes-owned memory (one 8-byte
field per entry of :data:`~observer_cad.codegen._loops.BATCH_FIELDS`). The loops release
the GIL, so runs proceed on several threads at once.
"""
from __future__ import annotations

import ctypes
import threading

import numpy as np

from ..errors import UsageError
from ._compile import CodegenError
from ._library import load_library
from ._loops import BATCH_INDEX, BATCH_NARGS

__all__ = ["TrajectoryEngine", "BatchArgs", "batch_function", "pointer", "DUMMY_PTR",
           "NO_INTERVALS_PTR"]

_P = ctypes.c_void_p

_DUMMY = np.zeros(8)
DUMMY_PTR = _DUMMY.ctypes.data
_NO_INTERVALS = np.zeros(4, dtype=np.intc)
NO_INTERVALS_PTR = _NO_INTERVALS.ctypes.data
#: the fields of the argument block that point at per-run data, and the step from one run
#: to the next (bytes; ``ns``/``np``: per joint state / parameter, a name: that field × 8)
_PER_RUN = (("SAMPLES", 8, None), ("P", 8, "np"), ("S0", 8, "ns"), ("T", 8, "TR"),
            ("S", 8, "SR"), ("Y", 8, "YR"), ("O", 8, "OR"), ("V", 8, "VR"), ("FIN", 4, None),
            ("IVOUT", 32, "NI"))


def pointer(a) -> int:
    return a.ctypes.data if a.size else DUMMY_PTR


class BatchArgs:
    """One argument block of ``NAME_batch`` (the C struct ``NAME_batch_args``: a uint64
    per entry of ``BATCH_FIELDS``, ``TOL`` a double) in ctypes-owned memory, followed by
    room for the runs' finiteness flags (``FIN`` points there).  ``keep`` holds the arrays
    the pointers refer to."""

    __slots__ = ("buf", "ptr", "keep", "runs")

    def __init__(self, runs: int, template: "BatchArgs | None" = None):
        self.runs = runs
        self.buf = (ctypes.c_uint64 * (BATCH_NARGS + (runs + 1) // 2))()
        self.ptr = ctypes.addressof(self.buf)
        self.keep = ()
        if template is not None:
            ctypes.memmove(self.ptr, template.ptr, 8 * BATCH_NARGS)
            self.keep = template.keep
        self.buf[BATCH_INDEX["R"]] = runs
        self.buf[BATCH_INDEX["FIN"]] = self.ptr + 8 * BATCH_NARGS

    def set(self, **fields) -> None:
        buf = self.buf
        for k, v in fields.items():
            buf[BATCH_INDEX[k]] = v

    def set_float(self, name: str, x: float) -> None:
        ctypes.c_double.from_address(self.ptr + 8 * BATCH_INDEX[name]).value = x

    def finite(self) -> np.ndarray:
        """(R,) bool: the runs whose states and outputs were all finite."""
        return np.frombuffer(self.buf, dtype=np.intc, count=self.runs, offset=8 * BATCH_NARGS) != 0

    def all_finite(self) -> bool:
        if self.runs == 1:
            return ctypes.c_int.from_address(self.ptr + 8 * BATCH_NARGS).value != 0
        return bool(self.finite().all())

    def part(self, a: int, b: int, dims: dict) -> "BatchArgs":
        """The block for runs a … b − 1 of this one (same outputs, same flags)."""
        part = BatchArgs(b - a, self)
        buf = self.buf
        for name, size, per in _PER_RUN:
            k = BATCH_INDEX[name]
            if buf[k]:
                n = 1 if per is None else (dims[per] if per in dims else buf[BATCH_INDEX[per]])
                part.buf[k] = buf[k] + a * size * n
        part.buf[BATCH_INDEX["FIN"]] = self.ptr + 8 * BATCH_NARGS + 4 * a
        part.keep = (self,)
        return part


class TrajectoryEngine:
    """The compiled trajectory loops of a :class:`CompiledSimulator`, without the model:
    what an ensemble worker needs.  Picklable (the library travels as its
    :class:`~observer_cad.codegen.LibrarySpec`: C source and content key); a worker —
    another process, another machine — loads the library from its own content-hashed
    cache on first use (compiling it there if it is missing; a library whose key differs
    is refused)."""

    def __init__(self, spec, fname: str, dims: tuple, inputs: tuple):
        self.spec, self.fname, self.inputs = spec, fname, tuple(inputs)
        self.ns, self.ny, self.no, self.nv, self.np = dims
        self._batch = None
        self._signals = {}  # id(program) → (program, its pointers and signal kinds)
        self._lock = threading.Lock()

    def __getstate__(self):
        return {"spec": self.spec, "fname": self.fname, "inputs": self.inputs,
                "dims": (self.ns, self.ny, self.no, self.nv, self.np)}

    def __setstate__(self, state):
        self.__init__(state["spec"], state["fname"], state["dims"], state["inputs"])

    def _function(self):
        if self._batch is None:
            lib = load_library(self.spec)
            self._batch = batch_function(lib, self.fname)
        return self._batch

    def _dims(self) -> dict:
        return {"ns": self.ns, "np": self.np}

    def _call(self, args: BatchArgs) -> int:
        return self._function()(args.ptr)

    def program_fields(self, program) -> dict:
        """The argument-block fields of a signal program (kept for the last few)."""
        hit = self._signals.get(id(program))
        if hit is not None and hit[0] is program:
            return hit[1]
        base, su, sn = program.columns
        kind = np.array([(1 if program.random[j] else 0) | (2 if program.normal[j] else 0)
                         for j in range(self.nv)], dtype=np.intc)
        fields = {"BASE": pointer(base), "SU": pointer(su), "SN": pointer(sn),
                  "KIND": pointer(kind), "_keep": (base, su, sn, kind)}
        with self._lock:
            if len(self._signals) >= 8:
                self._signals.pop(next(iter(self._signals)))
            self._signals[id(program)] = (program, fields)
        return fields

    def run_batch(self, t, program, seed: int, samples, P, S0, *, S=None, Y=None, O=None, V=None,
                  T=None, delays=None, finite=None, intervals=None, store: bool = True):
        """Runs of a scenario in one compiled call: ``program`` the
        :class:`~observer_cad.simulation.SignalProgram` on the grid ``t``, ``samples`` (R,)
        the sample indices (their random signals come from (seed, sample)), ``P`` (R, np)
        run-time parameters, ``S0`` (R, ns) initial joint states.  Outputs ``S`` (R, k, N)
        — the first k ≤ ns joint states —, ``Y`` (R, ny, N), ``O`` (R, no, N), ``V``
        (R, nv, N) — one contiguous time series per run and column — C-contiguous
        (created when None, S with every joint state), ``T`` (R, N) the time grid per run
        (optional); ``delays`` (no,) the observer outputs' delays: output j is produced
        ``delays[j]`` steps late and stored where it belongs (as
        :func:`~observer_cad.simulation.align_delay`: its last ``delays[j]`` samples NaN;
        default none); ``finite`` (R,) bool, set True for the runs whose every value is
        finite (False: some value may not be — check exactly).  ``intervals``: ``(spec,
        start, tol, out)`` — ``spec`` (nI, 4) ints (truth is a signal: 1 / a state: 0, its
        index, the lower and upper observer outputs), summaries over samples ≥ ``start``
        into ``out`` (R, nI, 4): violations (slack < −tol), smallest slack, largest width,
        first violation index (−1 none).  ``store=False``: ``S``, ``Y``, ``O``, ``V``,
        ``T`` are not written (when the loop's summaries are all that is wanted).  Returns ``(S, Y, O, V)``."""
        t = np.ascontiguousarray(t, dtype=np.float64)
        N = t.size
        samples = np.ascontiguousarray(np.atleast_1d(np.asarray(samples, dtype=np.int64)))
        R = samples.size
        if program.base.shape != (N, self.nv) or tuple(program.names) != self.inputs:
            raise UsageError("the signal program does not match this simulator's grid and signals")
        P = np.ascontiguousarray(P, dtype=np.float64).reshape(R, self.np)
        S0 = np.ascontiguousarray(S0, dtype=np.float64).reshape(R, self.ns)
        S = np.empty((R, self.ns, N)) if S is None else S
        Y = np.empty((R, self.ny, N)) if Y is None else Y
        O = np.empty((R, self.no, N)) if O is None else O
        V = np.empty((R, self.nv, N)) if V is None else V
        ks = S.shape[1] if S.ndim == 3 else -1
        for a, k, what in ((S, ks, "S"), (Y, self.ny, "Y"), (O, self.no, "O"), (V, self.nv, "V")):
            if a.shape != (R, k, N) or a.dtype != np.float64 or not a.flags.c_contiguous \
                    or not a.flags.writeable:
                raise UsageError(f"{what} must be a writeable C-contiguous float64 ({R}, {k}, {N}) array")
        if not 0 <= ks <= self.ns:
            raise UsageError(f"S must have at most {self.ns} states (R, k, N), got {S.shape}")
        if T is not None and (T.shape != (R, N) or T.dtype != np.float64
                              or not T.flags.c_contiguous or not T.flags.writeable):
            raise UsageError(f"T must be a writeable C-contiguous float64 ({R}, {N}) array")
        delay = np.zeros(max(self.no, 1), dtype=np.int64)
        if delays is not None:
            delays = np.asarray(delays, dtype=np.int64).reshape(-1)
            if delays.shape != (self.no,) or (delays < 0).any():
                raise UsageError(f"delays must be {self.no} whole numbers ≥ 0")
            delay[:self.no] = delays
        if N == 0 or R == 0:
            return S, Y, O, V
        if intervals is None:
            iv, n_iv, start, tol, ivout = _NO_INTERVALS, 0, 0, 0.0, _DUMMY
        else:
            iv, start, tol, ivout = intervals
            iv = np.ascontiguousarray(iv, dtype=np.intc).reshape(-1, 4)
            n_iv = iv.shape[0]
            if ivout.shape != (R, n_iv, 4) or ivout.dtype != np.float64 \
                    or not ivout.flags.c_contiguous:
                raise UsageError(f"intervals: out must be a C-contiguous float64 ({R}, {n_iv}, 4) array")
            if n_iv > max(self.no, 1):
                raise UsageError(f"intervals: at most {max(self.no, 1)} (one per observer"
                                 f" output), got {n_iv}")
            if n_iv and (iv[:, 1].min() < 0 or iv[:, 2:].min() < 0 or iv[:, 2:].max() >= self.no
                         or iv[:, 1][iv[:, 0] == 0].max(initial=-1) >= self.ns
                         or iv[:, 1][iv[:, 0] != 0].max(initial=-1) >= self.nv):
                raise UsageError("intervals: an index is out of range")
        prog = self.program_fields(program)
        args = BatchArgs(R)
        args.keep = (t, samples, P, S0, S, Y, O, V, T, delay, iv, ivout, prog["_keep"])
        args.set(N=N, t=pointer(t), BASE=prog["BASE"], SU=prog["SU"], SN=prog["SN"],
                 KIND=prog["KIND"], SEED=int(seed) % 2 ** 64, SAMPLES=pointer(samples),
                 P=pointer(P), S0=pointer(S0),
                 T=0 if T is None else pointer(T), TR=N,
                 S=pointer(S), KS=ks, SR=ks * N, SC=N,
                 Y=pointer(Y), YR=self.ny * N, YC=N,
                 O=pointer(O), OR=self.no * N, OC=N, DELAY=pointer(delay),
                 V=pointer(V), VR=self.nv * N, VC=N,
                 IV=pointer(iv), NI=int(n_iv), I0=int(start), IVOUT=pointer(ivout),
                 STORE=1 if store else 0)
        args.set_float("TOL", float(tol))
        rc = self._call(args)
        if finite is not None:
            finite[:] = args.finite() & program.finite
        if rc:
            raise self._failure(rc, N, samples)
        return S, Y, O, V

    def _failure(self, rc: int, N: int, samples) -> CodegenError:
        """The error of a batch over ``samples`` that returned ``rc`` ≠ 0."""
        if rc < 0:
            return CodegenError(f"{self.fname}_batch refused its arguments")
        r, i = divmod(rc - 1, N)
        return CodegenError(f"{self.fname} failed at step {i} of run {int(samples[r])}")


def batch_function(lib, fname):
    """``NAME_batch`` of a loaded library, checked to take this module's argument block."""
    try:
        fn = getattr(lib, f"{fname}_batch")
        nfields = getattr(lib, f"{fname}_batch_fields")
    except AttributeError:
        raise CodegenError(f"{fname}_batch is missing from the library") from None
    nfields.restype = ctypes.c_int
    nfields.argtypes = []
    if nfields() != BATCH_NARGS:
        raise CodegenError(f"{fname}_batch takes another argument block ({nfields()} fields,"
                           f" not {BATCH_NARGS}): a library of another version")
    fn.restype = ctypes.c_int
    fn.argtypes = [_P]
    return fn
