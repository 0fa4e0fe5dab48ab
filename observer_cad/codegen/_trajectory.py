"""Whole-trajectory simulation of plant + observer in one compiled call.

The joint step ``NAME_sim_step(s, v, p, h) -> (s_next, y, out)``
(:func:`observer_cad.codegen.joint_step` with ``parameters=True``: the model's and the
observer's parameters are a run-time input ``p``, so one library serves every parameter
sample) is generated as C by casadi; two small generated C loops iterate it over numpy
buffers::

    int NAME_traj(casadi_int N, const double *t, const double *V, const double *p,
                  double *S, double *Y, double *O);
    int NAME_batch(const NAME_batch_args *A);

``t`` (N) time grid (``h = t[i+1] - t[i]``, exactly as the reference simulator computes
it), ``V`` (N, nv) the held signals (inputs, faults, disturbances, noise; C order), ``S``
(N, ns) joint states — row 0 holds the initial state on entry — ``Y`` (N, ny) plant
outputs, ``O`` (N, no) observer outputs.  ``NAME_batch`` takes one argument block (a
struct of 8-byte fields, ``BATCH_FIELDS``: a ctypes call with one argument costs a
fraction of one with twenty) and runs R runs one after the other from their initial
joint states ``S0`` (R, ns), with their parameters ``P`` (R, np), generating each run's
signals from the scenario's :class:`~observer_cad.simulation.SignalProgram` — ``v = BASE
+ SU·U + SN·Z`` with the counter-based generator keyed by (``SEED``, ``SAMPLES[r]``,
stream), the numpy reference's uniform samples bit for bit (normal ones to the last bits
of libm's log1p/cos) (:mod:`observer_cad.simulation` ``_random``), a tile of steps at a
time into a small scratch buffer — and writes, with ``STORE``, one contiguous time
series per run and column: the first ``KS`` joint states, the plant outputs, the
observer outputs (a delayed one shifted into place, NaN where not available), the
signals and optionally the time grid, each at ``X + r·XR + j·XC`` (run and column
strides: the ensemble's (R, k, N) buffers and :meth:`CompiledSimulator.simulate`'s
column-major result block alike).  It also decides per run whether every state and
output was finite, and can summarise intervals on the fly (``IV``).  ``NAME_traj``
reads row i and writes row i + 1 of ``S`` directly; ``NAME_batch`` steps on two small
state buffers: no casadi ``DM`` round trips either way.  The loops are called through
ctypes, which releases the GIL, so runs proceed on several threads at once
(:meth:`CompiledSimulator.simulate` with ``runs=R``).

:meth:`CompiledSimulator.simulate` returns the same
:class:`~observer_cad.simulation.SimulationResult` (columns and order) as
:func:`observer_cad.simulation.simulate` for the same scenario, including the scenario's
sampled parameters, initial states and cases.  What does not change from call to call
— the grid, the signal program, the runs' draws, the argument block — is kept with the
scenario (the last few), and a result's memory is reused once the result is gone
(``_Blocks``), so a repeated scenario-in, result-out call costs the compiled loop and a
few microseconds.

Where the parts live: the loops' C (and ``BATCH_FIELDS``) in ``_loops``, the argument
block and the picklable :class:`TrajectoryEngine` that calls ``NAME_batch`` in
``_engine``, the simulator that compiles and runs them here.
"""
from __future__ import annotations

import ctypes
import dataclasses
import os
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..model import PlantModel
from ..observers import Observer, output_symbols
from ..simulation import (RANDOM_C, Scenario, SimulationResult, check_memory, column_units,
                          draw_plan, finish_result, memory_limit, parameter_layout, signal_program)
from ._library import LibrarySpec
from ._compile import (CACHE_LOCK, FLAGS, STATS, CodegenError, compile_source, compiler,
                       fingerprint, forget_fingerprint, generate_c, lookup_fingerprint,
                       record_fingerprint, size_aware_flags, source_key)
from ._engine import (DUMMY_PTR, NO_INTERVALS_PTR, BatchArgs, TrajectoryEngine, batch_function,
                      pointer)
from ._loops import loop_source
from ._translate import describe, joint_identity, joint_step, joint_step_name

__all__ = ["CompiledSimulator", "simulate_compiled", "TRAJ_FLAGS"]

# -fno-semantic-interposition lets gcc inline the exported casadi step into the loop
# (with plain -fPIC an exported symbol may be interposed, so it is called): measured
# ≈ 12.6 → 6.3–8.7 ns/step on the 4-state electric-drive joint step.
# -fno-math-errno: sqrt becomes the sqrtsd instruction alone, without the branch to
# libm that sets errno for a negative argument (the values are the same, IEEE sqrt
# either way; nothing reads errno): measured ≈ 3 % on the three-tank interval ensemble.
# -ffp-contract=off: base + su·U must round as numpy rounds it (the signals are
# bit-identical to the reference); where the target has FMA by default (aarch64) gcc
# would otherwise fuse the multiply-add.
# Retried with plain FLAGS if the compiler rejects them.  They are made size-aware (-O1
# for large C, codegen.size_aware_flags) unless flags are given.
TRAJ_FLAGS = FLAGS + ("-fno-semantic-interposition", "-fno-math-errno", "-ffp-contract=off")

_P = ctypes.c_void_p


#: result memory a :class:`CompiledSimulator` keeps for reuse after its results are gone
RECYCLE_BYTES = 64 * 1024 ** 2


class _Blocks:
    """The memory of :meth:`CompiledSimulator.simulate`'s results, reused once every array
    of a result has been dropped.

    Writing a fresh array first touches its pages, one page fault per 4 KiB; on a VM
    that costs about as much as simulating the samples that fill them (measured:
    benchmarks/README.md, scenario-in, result-out).  A result's columns are views of one
    block; when none is left — CPython's reference count of the block is then that of
    this list alone — the block serves the next result of the same size.  At most
    ``limit`` bytes are kept (the oldest free blocks go first)."""

    def __init__(self, limit: int):
        self.limit = limit
        self.blocks = []  # [array, its address]
        self.lock = threading.Lock()
        probe = [np.empty(0)]
        self.free_refs = sys.getrefcount(probe[0])  # a block only this list holds

    def _free(self, k) -> bool:
        return sys.getrefcount(self.blocks[k][0]) == self.free_refs

    def take(self, n: int) -> tuple:
        """``(view, address)``: a view of a block of n float64 (hold the view: while it or
        any view of it lives, the block is not handed out again)."""
        with self.lock:
            for k in range(len(self.blocks)):
                if self.blocks[k][0].size == n and self._free(k):
                    return self.blocks[k][0][:], self.blocks[k][1]
            blk = np.empty(n)
            ptr = pointer(blk)
            if 8 * n <= self.limit:
                held = sum(b[0].nbytes for b in self.blocks)
                k = 0
                while held + 8 * n > self.limit and k < len(self.blocks):
                    if self._free(k):
                        held -= self.blocks.pop(k)[0].nbytes
                    else:
                        k += 1
                while held + 8 * n > self.limit:  # in use: their results keep them
                    held -= self.blocks.pop(0)[0].nbytes
                self.blocks.append([blk, ptr])
            return blk[:], ptr


@dataclasses.dataclass(frozen=True, eq=False)
class _Runs:
    """Runs of a scenario's case as :meth:`CompiledSimulator.simulate` runs them: grid,
    program, sizes, the argument block without its outputs, where the outputs go in the
    result's block (elements), the sampled plant parameters (name → (R,))."""

    t: np.ndarray
    program: object
    R: int
    N: int
    ncols: int
    bytes: int
    args: BatchArgs
    offsets: dict
    plant: dict


class CompiledSimulator:
    """Plant + observer compiled into one trajectory function.

    ``CompiledSimulator(model, observer)`` translates, generates, compiles (or reuses
    the cached library) and loads.  A library already built for the same equations,
    options, compiler and flags is found by its pre-translation fingerprint
    (:func:`~observer_cad.codegen.fingerprint`) and loaded without translating
    or generating C (``.translated`` is then False).  ``.step`` is the interpreted
    casadi joint step (built on first use after a fingerprint hit), ``.source`` the C
    of the library, ``.seconds`` the time the construction took, ``.cached`` whether
    the library came from the cache, ``.flags`` the compiler flags of the library
    (``flags=None``: TRAJ_FLAGS, size-aware; explicit flags are used as given).
    """

    def __init__(self, model: PlantModel, observer: Observer | None, *, cache=None, cc=None,
                 flags=None, name: str | None = None):
        t0 = time.perf_counter()
        self.model = model
        self.observer = observer
        if observer is not None and observer.time != self.model.time:
            raise UsageError(f"observer is {observer.time}-time but the model is"
                             f" {self.model.time}-time")
        m = self.model
        self._name = name
        self._step = None
        self._source = None
        self._programs = {}
        self._lock = threading.Lock()
        self._blocks = _Blocks(RECYCLE_BYTES)
        self._engine = None
        self._local = None
        self._units = None
        self._names = None
        self._outputs = tuple(observer.outputs) if observer is not None else ()
        self._delays = {name: int(observer.delays.get(name, 0)) for name, _ in self._outputs}
        self._cc = cc
        self.translated = False
        self.inputs = list(m.inputs) + list(m.faults) + list(m.disturbances) + list(m.noise)
        self.ns = len(m.states) + (len(observer.states) if observer is not None else 0)
        self.ny = len(m.outputs)
        self.no = len(observer.outputs) if observer is not None else 0
        self.nv = len(self.inputs)
        self.layout = parameter_layout(m, observer)
        self.np = len(self.layout.plant) + len(self.layout.observer)
        #: the nominal run-time parameter vector: the model's values, the observer's
        self.nominal = np.array([float(v) for v in m.parameter_values().values()]
                                + [float(v) for v in observer.parameters.values()],
                                dtype=float) if self.np else np.zeros(0)
        fname = joint_step_name(m, observer, name)
        lib_name = f"{fname}_traj"
        flag_sets = [TRAJ_FLAGS, FLAGS] if flags is None else [tuple(flags)]
        # RANDOM_C is pasted into the loops but lives in simulation: part of the identity
        ident = ("trajectory", joint_identity(m, observer, name=name, parameters=True),
                 "auto" if flags is None else tuple(flags), RANDOM_C)
        fp = fingerprint(ident, cc=cc, flags=None if flags is None else flag_sets[0])
        rec = lookup_fingerprint(fp, lib_name, cache=cache)
        if rec is not None:
            try:
                self._open(rec["library"], fname)
            except CodegenError:
                forget_fingerprint(fp, lib_name, cache=cache)
                rec = None
            else:
                self.path, self.cached, self.flags = rec["library"], True, rec["flags"]
                self.key = rec.get("key")
                with CACHE_LOCK:
                    STATS["fingerprint_hits"] += 1
        if rec is None:
            step = self.step
            src = generate_c(step) + loop_source(step, self.nv)
            self._source = src
            if flags is None:
                flag_sets = [size_aware_flags(src, fs) for fs in flag_sets]

            def check(path):
                lib = ctypes.CDLL(str(path))
                getattr(lib, f"{fname}_traj")
                batch_function(lib, fname)

            try:
                res = compile_source(src, lib_name, cache=cache, cc=cc, flags=flag_sets[0],
                                     check=check)
            except CodegenError as exc:
                if len(flag_sets) == 1 or ("C compiler" in str(exc) and "not found" in str(exc)):
                    raise
                res = compile_source(src, lib_name, cache=cache, cc=cc, flags=flag_sets[1],
                                     check=check)
            self.path, self.cached, self.flags, self.key = res.path, res.cached, res.flags, res.key
            self._open(res.path, fname)
            record_fingerprint(fp, lib_name, res.path, cache=cache, function=fname,
                               doc=describe(step), key=res.key, flags=res.flags)
        self.library_name = lib_name
        self.seconds = time.perf_counter() - t0

    def _open(self, path, fname):
        try:
            lib = ctypes.CDLL(str(path))
            fn = getattr(lib, f"{fname}_traj")
        except (OSError, AttributeError) as exc:
            raise CodegenError(f"cannot load {path}: {exc}") from None
        batch = batch_function(lib, fname)
        fn.restype = ctypes.c_int
        fn.argtypes = [ctypes.c_longlong, _P, _P, _P, _P, _P, _P]
        self._lib, self._fn, self._batch, self._fname = lib, fn, batch, fname

    @property
    def step(self):
        """The interpreted casadi joint step ``NAME_sim_step(s, v, p, h)`` (translated on
        first use)."""
        if self._step is None:
            self._step = joint_step(self.model, self.observer, name=self._name, parameters=True)
            self.translated = True
        return self._step

    @property
    def source(self) -> str:
        """The C source of the library (the casadi step and the trajectory loops)."""
        if self._source is None:
            try:  # the cached copy, if it is the library's source (its key says so)
                text = Path(self.path).with_suffix(".c").read_text(encoding="utf-8")
                if self.key is None or source_key(text, compiler(self._cc),
                                                  tuple(self.flags)) != self.key:
                    text = None
            except (OSError, UnicodeDecodeError, CodegenError):
                text = None
            self._source = (text if text is not None else
                            generate_c(self.step) + loop_source(self.step, self.nv))
        return self._source

    # ------------------------------------------------------------------ raw arrays
    def _parameters(self, p):
        if p is None:
            return self.nominal
        p = np.ascontiguousarray(p, dtype=np.float64)
        if p.shape != (self.np,):
            raise UsageError(f"p must have shape ({self.np},) (parameters: "
                             f"{', '.join(self.layout.names) or 'none'}), got {p.shape}")
        return p

    def run_arrays(self, t, V, s0=None, *, p=None, S=None, Y=None, O=None):
        """One trajectory on numpy buffers.  ``t`` (N,), ``V`` (N, nv) float64 C-contiguous
        (not copied when already so); ``p`` the run-time parameters (``.layout`` order;
        default ``.nominal``); ``S`` (N, ns), ``Y`` (N, ny), ``O`` (N, no) preallocated
        outputs (created when None).  ``s0`` the initial joint state (else ``S[0]`` as
        given).  Returns ``(S, Y, O)``."""
        t = np.ascontiguousarray(t, dtype=np.float64)
        N = t.shape[0]
        V = np.ascontiguousarray(V, dtype=np.float64)
        if V.shape != (N, self.nv):
            raise UsageError(f"V must have shape ({N}, {self.nv}), got {V.shape}")
        p = self._parameters(p)
        S = np.empty((N, self.ns)) if S is None else S
        Y = np.empty((N, self.ny)) if Y is None else Y
        O = np.empty((N, self.no)) if O is None else O
        for a, k, what in ((S, self.ns, "S"), (Y, self.ny, "Y"), (O, self.no, "O")):
            if a.shape != (N, k) or a.dtype != np.float64 or not a.flags.c_contiguous \
                    or not a.flags.writeable:
                raise UsageError(f"{what} must be a writeable C-contiguous float64 ({N}, {k}) array")
        if s0 is not None:
            S[0] = s0
        if N:
            rc = self._fn(N, pointer(t), pointer(V), pointer(p), pointer(S), pointer(Y),
                              pointer(O))
            if rc:
                raise CodegenError(f"{self._fname} failed at step {rc - 1}")
        return S, Y, O

    def engine(self) -> TrajectoryEngine:
        """The compiled loops as a picklable :class:`TrajectoryEngine` (for workers)."""
        if self._engine is None:
            spec = LibrarySpec(source=self.source, name=self.library_name,
                               flags=tuple(self.flags), key=self.key, cc=self._cc)
            eng = TrajectoryEngine(spec, self._fname, self._dims(), tuple(s.name for s in self.inputs))
            eng._batch = self._batch  # this process has it loaded already
            self._engine = eng
        return self._engine

    def _dims(self) -> tuple:
        return (self.ns, self.ny, self.no, self.nv, self.np)

    def local_engine(self) -> TrajectoryEngine:
        """The compiled loops as a :class:`TrajectoryEngine` for this process only (no
        library spec: not for other processes; threads share it)."""
        if self._local is None:
            eng = TrajectoryEngine(None, self._fname, self._dims(), tuple(s.name for s in self.inputs))
            eng._batch = self._batch
            self._local = eng
        return self._local

    def run_batch(self, t, program, seed: int, samples, P, S0, **out):
        """:meth:`TrajectoryEngine.run_batch` on this simulator's library."""
        return self.local_engine().run_batch(t, program, seed, samples, P, S0, **out)

    # ------------------------------------------------------------------ scenarios
    def program(self, scenario: Scenario, case: str | None = None):
        """``(t, program)``: the scenario's grid and
        :class:`~observer_cad.simulation.SignalProgram` (kept for the last few scenarios:
        a repeated call skips evaluating the signals)."""
        hit = self._cached(scenario, ("program", case))
        if hit is None:
            t = scenario.grid(self.model.time)
            hit = self._keep(scenario, ("program", case),
                             (t, signal_program(self.model, scenario, t, case=case)))
        return hit

    def plan(self, scenario: Scenario):
        """The scenario's :class:`~observer_cad.simulation.DrawPlan` (kept like programs)."""
        hit = self._cached(scenario, ("plan",))
        if hit is None:
            hit = self._keep(scenario, ("plan",), draw_plan(self.model, self.observer, scenario))
        return hit

    def _cached(self, scenario, what):
        hit = self._programs.get((id(scenario),) + what)
        return hit[1] if hit is not None and hit[0] is scenario else None

    def _keep(self, scenario, what, value):
        # a scenario is a frozen value: what is derived from it is kept with it (the
        # entry holds the scenario, so its id is not reused while the entry lives)
        with self._lock:
            if len(self._programs) >= 16:
                self._programs.pop(next(iter(self._programs)))
            self._programs[(id(scenario),) + what] = (scenario, value)
        return value

    def prepare(self, scenario: Scenario, runs: int | None = None, *, first_run: int = 0,
                case: str | None = None, samples: int | None = None):
        """The inputs of :meth:`run_arrays` for a scenario: ``(t, runs, steps, V, s0)``, V the
        signals per run (runs × steps × inputs), s0 the joint initial state of the first
        run [x(0); ξ(0)].  (Parameters: :meth:`draws`.)"""
        R = 1 if runs is None else int(runs)
        t, prog = self.program(scenario, case)
        V = prog.values(scenario.seed, np.arange(first_run, first_run + R))
        d = self.draws(scenario, R, first_run=first_run, samples=samples)
        return t, R, t.size, V, np.concatenate([d.x0[0], d.xi0[0]])

    def draws(self, scenario: Scenario, runs: int, *, first_run: int = 0, samples=None):
        """The per-run quantities (:func:`~observer_cad.simulation.draw_runs`)."""
        ks = np.arange(first_run, first_run + int(runs))
        return self.plan(scenario).draw(ks, total=samples or first_run + int(runs))

    def _runs(self, scenario: Scenario, case, first_run: int, R: int, samples) -> "_Runs":
        """What :meth:`simulate` needs of runs ``first_run …`` of a scenario's case: the
        grid, the draws, the argument block's inputs (kept like programs: a repeated call
        draws nothing and converts nothing)."""
        what = ("runs", case, first_run, R, samples)
        hit = self._cached(scenario, what)
        if hit is not None:
            return hit
        m = self.model
        ncols = 1 + len(m.states) + self.ny + self.nv + self.no
        check_memory(scenario, m.time, runs=R, columns=ncols)
        t, prog = self.program(scenario, case)
        N = t.size
        d = self.draws(scenario, R, first_run=first_run, samples=samples)
        samples_ = np.ascontiguousarray(d.samples, dtype=np.int64)
        P = np.ascontiguousarray(d.P, dtype=np.float64)
        S0 = np.ascontiguousarray(np.concatenate([d.x0, d.xi0], axis=1), dtype=np.float64)
        eng = self.local_engine()
        sig = eng.program_fields(prog)
        delay = np.zeros(max(self.no, 1), dtype=np.int64)
        delay[:self.no] = [self._delays[name] for name, _ in self._outputs]
        args = BatchArgs(R)
        args.keep = (t, samples_, P, S0, delay, sig["_keep"])
        # the result's block: columns (t, states, outputs, signals, observer outputs) of
        # (R, N) each; a column is contiguous, run r's samples at r·N
        RN = R * N
        nx = len(m.states)
        args.set(N=N, t=pointer(t), BASE=sig["BASE"], SU=sig["SU"], SN=sig["SN"],
                 KIND=sig["KIND"], SEED=int(scenario.seed) % 2 ** 64, SAMPLES=pointer(samples_),
                 P=pointer(P), S0=pointer(S0), TR=N, KS=nx, SR=N, SC=RN, YR=N, YC=RN,
                 OR=N, OC=RN, DELAY=pointer(delay), VR=N, VC=RN, IV=NO_INTERVALS_PTR,
                 NI=0, I0=0, IVOUT=DUMMY_PTR, STORE=1)
        offsets = {"T": 0, "S": RN, "Y": (1 + nx) * RN, "V": (1 + nx + self.ny) * RN,
                   "O": (1 + nx + self.ny + self.nv) * RN}
        plant = {name: np.array(v) for name, v in d.plant.items()}
        runs = _Runs(t, prog, R, N, ncols, ncols * RN * 8, args, offsets, plant)
        return self._keep(scenario, what, runs)

    def _columns(self):
        """The result's column names in block order, its CSV order, its delays."""
        if self._names is None:
            m = self.model
            ys = [str(y) for y in output_symbols(len(m.outputs))]
            names = (["t"] + [s.name for s in m.states] + ys + [s.name for s in self.inputs]
                     + [name for name, _ in self._outputs])
            order = tuple(["t"] + [s.name for s in m.states] + ys
                          + [s.name for s in self.inputs if s not in m.noise]
                          + [name for name, _ in self._outputs])
            self._names = (tuple(names), order)
        return self._names

    def simulate(self, scenario: Scenario, *, runs: int | None = None,
                 threads: int | None = None, keep_nonfinite: bool = False, first_run: int = 0,
                 case: str | None = None, samples: int | None = None) -> SimulationResult:
        """As :func:`observer_cad.simulation.simulate` (same columns, same order, the same
        samples, memory limit and finiteness check); with ``runs=R`` the runs are split
        over ``threads`` threads (default: every core).

        The columns of a result are views of one block of memory, reused for a later
        result once every column of this one has been dropped (``RECYCLE_BYTES``)."""
        if scenario.sample_time is not None:
            raise UsageError(f"{scenario.source or 'scenario'}: \"sample_time\" runs the"
                             " observer as deployed, which the joint compiled trajectory does"
                             " not: simulate(model, observer, scenario,"
                             " engine=CompiledMonitorEngine(observer))")
        R = 1 if runs is None else int(runs)
        if R < 1:
            raise UsageError(f"runs must be at least 1, got {runs}")
        first_run = int(first_run)
        if first_run < 0:
            raise UsageError(f"first_run must be ≥ 0, got {first_run}")
        if case is None and scenario.cases:  # the first case, as the reference simulator
            case = scenario.case_names[0]
        rs = self._runs(scenario, case, first_run, R, samples)
        if rs.bytes > memory_limit():  # the limit is read again: it may have changed
            check_memory(scenario, self.model.time, runs=R, columns=rs.ncols)
        N = rs.N
        view, ptr = self._blocks.take(rs.ncols * R * N)
        args = BatchArgs(R, rs.args)
        off = rs.offsets
        args.set(T=ptr + 8 * off["T"], S=ptr + 8 * off["S"], Y=ptr + 8 * off["Y"],
                 O=ptr + 8 * off["O"], V=ptr + 8 * off["V"])
        engine = self.local_engine()
        nthreads = 1 if R == 1 else min(R, threads or os.cpu_count() or 1)
        if nthreads > 1:
            edges = np.linspace(0, R, nthreads + 1).astype(int)
            parts = [args.part(int(a), int(b), engine._dims()) for a, b in zip(edges[:-1], edges[1:])]
            with ThreadPoolExecutor(nthreads) as ex:
                rcs = list(ex.map(engine._call, parts))
            rc = next((c if c < 0 else c + int(a) * N for c, a in zip(rcs, edges) if c), 0)
        else:
            rc = engine._call(args)
        if rc:
            raise engine._failure(rc, N, range(first_run, first_run + R))
        finite = rs.program.finite and args.all_finite()
        names, order = self._columns()
        block = view.reshape(len(names), R, N)
        cols = {name: block[c] for c, name in enumerate(names)}
        if self._units is None:  # the units depend on the names only
            self._units = column_units(self.model, self.observer, cols)
        res = finish_result(cols, order, dict(self._delays), rs.t, self.model, self.observer, runs,
                            keep_nonfinite, where=scenario.source, units=self._units,
                            finite=finite)
        if rs.plant:
            res = dataclasses.replace(res, parameters={
                k: (v.copy() if runs is not None else v[0]) for k, v in rs.plant.items()})
        return res

    def simulate_many(self, scenarios, *, threads: int | None = None) -> list:
        """Many scenarios at once on threads (ctypes releases the GIL)."""
        scenarios = list(scenarios)
        nthreads = min(len(scenarios) or 1, threads or os.cpu_count() or 1)
        if nthreads <= 1:
            return [self.simulate(sc) for sc in scenarios]
        with ThreadPoolExecutor(nthreads) as ex:
            return list(ex.map(lambda sc: self.simulate(sc, threads=1), scenarios))


def simulate_compiled(model: PlantModel, observer: Observer | None, scenario: Scenario, *,
                      runs: int | None = None, cache=None, cc=None) -> SimulationResult:
    """One-shot :func:`~observer_cad.simulation.simulate` through the compiled path."""
    return CompiledSimulator(model, observer, cache=cache, cc=cc).simulate(scenario, runs=runs)
