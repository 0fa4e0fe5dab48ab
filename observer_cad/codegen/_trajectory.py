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
struct of 8-byte fields, ``_BATCH_FIELDS``: a ctypes call with one argument costs a
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
from ._library import LibrarySpec, load_library
from ._compile import (CACHE_LOCK, FLAGS, STATS, CodegenError, compile_source, compiler,
                       fingerprint, forget_fingerprint, generate_c, lookup_fingerprint,
                       record_fingerprint, size_aware_flags, source_key)
from ._translate import describe, joint_identity, joint_step, joint_step_name

__all__ = ["CompiledSimulator", "simulate_compiled", "loop_source", "TRAJ_FLAGS"]

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


# ---- the argument block of NAME_batch: one 8-byte field each (C struct and Python index
# are generated from this one table; pointers, integers, the seed, and TOL as a double)
_BATCH_FIELDS = (
    ("R", "casadi_int"), ("N", "casadi_int"), ("t", "const casadi_real*"),
    ("BASE", "const casadi_real*"), ("SU", "const casadi_real*"), ("SN", "const casadi_real*"),
    ("KIND", "const int*"), ("SEED", "uint64_t"), ("SAMPLES", "const int64_t*"),
    ("P", "const casadi_real*"), ("S0", "const casadi_real*"),
    ("T", "casadi_real*"), ("TR", "casadi_int"),
    ("S", "casadi_real*"), ("KS", "casadi_int"), ("SR", "casadi_int"), ("SC", "casadi_int"),
    ("Y", "casadi_real*"), ("YR", "casadi_int"), ("YC", "casadi_int"),
    ("O", "casadi_real*"), ("OR", "casadi_int"), ("OC", "casadi_int"),
    ("DELAY", "const casadi_int*"),
    ("V", "casadi_real*"), ("VR", "casadi_int"), ("VC", "casadi_int"),
    ("FIN", "int*"),
    ("IV", "const int*"), ("NI", "casadi_int"), ("I0", "casadi_int"), ("TOL", "casadi_real"),
    ("IVOUT", "casadi_real*"), ("STORE", "casadi_int"),
)
_AI = {name: i for i, (name, _) in enumerate(_BATCH_FIELDS)}
_NARGS = len(_BATCH_FIELDS)


def loop_source(f, nv: int) -> str:
    """The C trajectory loops around the casadi-generated joint step ``f`` (with a
    run-time parameter input): ``NAME_traj`` and ``NAME_batch`` (module docstring)."""
    name = f.name()
    ns, ny, no = (f.size1_out(i) for i in range(3))
    npar = f.size1_in(2)
    sz_arg, sz_res = max(f.sz_arg(), 4), max(f.sz_res(), 3)
    sz_iw, sz_w = max(f.sz_iw(), 1), max(f.sz_w(), 1)
    fields = "\n".join(f"  {ctype} {fname};" for fname, ctype in _BATCH_FIELDS)
    # finiteness: the sum of a run's every state and output value is finite only if each
    # of them is (NaN and ±inf propagate through a sum); a finite sum proves the run
    # finite, an overflowing one only sends the run to the exact check.  One add per
    # value (x - x per value cost twice as much: measured), summed pairwise per step
    terms = [f"cur[{j}]" for j in range(ns)] + [f"yb[{j}]" for j in range(ny)] + \
        [f"ob[{j}]" for j in range(no)]
    while len(terms) > 1:
        terms = [f"({terms[k]} + {terms[k + 1]})" if k + 1 < len(terms) else terms[k]
                 for k in range(0, len(terms), 2)]
    check = terms[0] if terms else "0.0"
    # signals are generated a tile of steps at a time into a scratch buffer, one row per
    # step, that the step reads in place (interleaved A/B, CPU time: rows instead of
    # gathering from columns +5 % on the three-tank interval ensemble; 32 steps rather
    # than 256 +2 % there and +6 % on the electric drive at 10⁵ steps; ≤ 32 KiB)
    tile = max(8, min(32, 4096 // max(nv, 1)))
    return RANDOM_C + f"""
/* ---- trajectory loops generated by observer_cad.codegen ---- */
CASADI_SYMBOL_EXPORT int {name}_traj(casadi_int N, const casadi_real* t, const casadi_real* V,
                                     const casadi_real* p, casadi_real* S, casadi_real* Y,
                                     casadi_real* O) {{
  const casadi_real* arg[{sz_arg}];
  casadi_real* res[{sz_res}];
  casadi_int iw[{sz_iw}];
  casadi_real w[{sz_w}];
  casadi_real last[{max(ns, 1)}];
  casadi_real h;
  casadi_int i;
  for (i = 0; i < {sz_arg}; ++i) arg[i] = 0;
  for (i = 0; i < {sz_res}; ++i) res[i] = 0;
  arg[2] = p;
  for (i = 0; i < N; ++i) {{
    h = (i + 1 < N) ? t[i + 1] - t[i] : 0.0;
    arg[0] = S + i * {ns};
    arg[1] = V + i * {nv};
    arg[3] = &h;
    res[0] = (i + 1 < N) ? S + (i + 1) * {ns} : last;
    res[1] = Y + i * {ny};
    res[2] = O + i * {no};
    if ({name}(arg, res, iw, w, 0)) return (int)(1 + i);
  }}
  return 0;
}}

/* the arguments of {name}_batch (TrajectoryEngine fills them: every field 8 bytes) */
typedef struct {{
{fields}
}} {name}_batch_args;

CASADI_SYMBOL_EXPORT int {name}_batch_fields(void) {{ return {_NARGS}; }}

CASADI_SYMBOL_EXPORT int {name}_batch(const {name}_batch_args* A) {{
  const casadi_int R = A->R, N = A->N, KS = A->KS, NI = A->NI, I0 = A->I0, STORE = A->STORE;
  const casadi_int SC = A->SC, YC = A->YC, OC = A->OC, VC = A->VC;
  const casadi_real *t = A->t, *BASE = A->BASE, *SU = A->SU, *SN = A->SN;
  const int* KIND = A->KIND;
  const casadi_int* DELAY = A->DELAY;
  const int* IV = A->IV;
  const casadi_real TOL = A->TOL;
  const uint64_t seed_key = oc_mix(A->SEED + UINT64_C(0x9E3779B97F4A7C15));
  const casadi_real* arg[{sz_arg}];
  casadi_real* res[{sz_res}];
  casadi_int iw[{sz_iw}];
  casadi_real w[{sz_w}];
  casadi_real sa[{max(ns, 1)}], sb[{max(ns, 1)}], yb[{max(ny, 1)}], ob[{max(no, 1)}];
  /* the signals of a tile of {tile} steps, one row per step (step i reads row i − i0 in
     place); rj: the random signals, dj: the others */
  casadi_real scr[{max(nv, 1) * tile}];
  const casadi_real* v;
  int rj[{max(nv, 1)}], dj[{max(nv, 1)}], nr = 0, nd = 0, q;
  uint64_t k1[{max(nv, 1)}], k2[{max(nv, 1)}], z[{max(nv, 1)}];
  casadi_real *cur, *nxt, *tmp;
  casadi_real h, chk;
  /* at most {max(no, 1)} intervals (run_batch checks): truth a signal?, its index, lower,
     upper; violations, smallest slack, largest width, first violation */
  int ivs[{max(no, 1)}], ivx[{max(no, 1)}], ivl[{max(no, 1)}], ivh[{max(no, 1)}];
  casadi_real ivc[{max(no, 1)}], ivm[{max(no, 1)}], ivw[{max(no, 1)}], ivf[{max(no, 1)}];
  casadi_int r, i, i0, i1, j, m;
  for (i = 0; i < {sz_arg}; ++i) arg[i] = 0;
  for (i = 0; i < {sz_res}; ++i) res[i] = 0;
  for (j = 0; j < {nv}; ++j) {{ if (KIND[j]) rj[nr++] = (int)j; else dj[nd++] = (int)j; }}
  if (NI > {max(no, 1)}) return -1;
  for (m = 0; m < NI; ++m) {{
    ivs[m] = IV[4 * m]; ivx[m] = IV[4 * m + 1]; ivl[m] = IV[4 * m + 2]; ivh[m] = IV[4 * m + 3];
  }}
  for (r = 0; r < R; ++r) {{
    /* run r (sample SAMPLES[r]); output X of run r, column j, step i at
       X[r * XR + j * XC + i] (only with STORE) */
    const uint64_t run_key = oc_mix(seed_key + (uint64_t)A->SAMPLES[r]);
    casadi_real* Sr = A->S + r * A->SR;
    casadi_real* Yr = A->Y + r * A->YR;
    casadi_real* Or = A->O + r * A->OR;
    casadi_real* Vr = A->V + r * A->VR;
    cur = sa;
    nxt = sb;
    for (j = 0; j < {ns}; ++j) cur[j] = A->S0[r * {ns} + j];
    arg[2] = A->P + r * {npar};
    /* the intervals' summaries so far, in locals (nothing else can write them: the
       compiler keeps them out of memory; measured +4 %) */
    for (m = 0; m < NI; ++m) {{
      ivc[m] = 0; ivm[m] = INFINITY; ivw[m] = -INFINITY; ivf[m] = -1;
    }}
    /* the keys of stream_keys(seed, run, (2j, 2j + 1)) */
    for (q = 0; q < nr; ++q) {{
      k1[q] = oc_mix(run_key + (uint64_t)(2 * rj[q]));
      k2[q] = oc_mix(run_key + (uint64_t)(2 * rj[q] + 1));
      z[q] = k1[q];
    }}
    if (STORE && A->T) {{
      casadi_real* Tr = A->T + r * A->TR;
      for (i = 0; i < N; ++i) Tr[i] = t[i];
    }}
    chk = 0;
    for (i0 = 0; i0 < N; i0 = i1) {{
      i1 = i0 + {tile} < N ? i0 + {tile} : N;
      /* the signals of steps i0 … i1 − 1 (BASE, SU, SN are (nv, N)): the arithmetic and
         order of SignalProgram.values — base + su·U, then + sn·Z where sn ≠ 0; sample i
         of a stream from the hash state key + (i + 1) G */
      for (q = 0; q < nr; ++q) {{
        const casadi_real* b = BASE + rj[q] * N;
        const casadi_real* su = SU + rj[q] * N;
        casadi_real* col = scr + rj[q];
        uint64_t zq = z[q];
        for (i = i0; i < i1; ++i) {{
          zq += UINT64_C(0x9E3779B97F4A7C15);
          col[(i - i0) * {nv}] = b[i] + su[i] * oc_unit(zq);
        }}
        z[q] = zq;
        if (KIND[rj[q]] & 2) {{
          const casadi_real* sn = SN + rj[q] * N;
          for (i = i0; i < i1; ++i)
            if (sn[i] != 0) col[(i - i0) * {nv}] += sn[i] * oc_normal(k1[q], k2[q], (long long)i);
        }}
      }}
      for (q = 0; q < nd; ++q) {{
        const casadi_real* b = BASE + dj[q] * N;
        casadi_real* col = scr + dj[q];
        for (i = i0; i < i1; ++i) col[(i - i0) * {nv}] = b[i];
      }}
      for (i = i0; i < i1; ++i) {{
        v = scr + (i - i0) * {nv};
        h = (i + 1 < N) ? t[i + 1] - t[i] : 0.0;
        arg[0] = cur;
        arg[1] = v;
        arg[3] = &h;
        res[0] = nxt;
        res[1] = yb;
        res[2] = ob;
        if ({name}(arg, res, iw, w, 0)) return (int)(1 + r * N + i);
        if (STORE) {{
          for (j = 0; j < KS; ++j) Sr[j * SC + i] = cur[j];
          for (j = 0; j < {ny}; ++j) Yr[j * YC + i] = yb[j];
          /* observer output j is produced DELAY[j] steps late: stored where it belongs */
          for (j = 0; j < {no}; ++j) if (i >= DELAY[j]) Or[j * OC + i - DELAY[j]] = ob[j];
          for (j = 0; j < {nv}; ++j) Vr[j * VC + i] = v[j];
        }}
        chk += {check};
        /* interval summaries of the run (summarise's operations, while the samples are
           in registers): violations, smallest slack, largest width, first violation */
        if (i >= I0) for (m = 0; m < NI; ++m) {{
          casadi_real zt = ivs[m] ? v[ivx[m]] : cur[ivx[m]], lo = ob[ivl[m]], hi = ob[ivh[m]];
          casadi_real a = zt - lo, b = hi - zt, sl = b < a ? b : a, wd = hi - lo;
          if (!(sl >= -TOL)) {{ if (ivf[m] < 0) ivf[m] = (casadi_real)i; ivc[m] += 1; }}
          if (sl < ivm[m]) ivm[m] = sl;
          if (wd > ivw[m]) ivw[m] = wd;
        }}
        tmp = cur; cur = nxt; nxt = tmp;
      }}
    }}
    if (STORE)  /* the last DELAY[j] samples of a delayed output are not available */
      for (j = 0; j < {no}; ++j)
        for (i = (DELAY[j] < N ? N - DELAY[j] : 0); i < N; ++i) Or[j * OC + i] = NAN;
    /* finite: every state, output and observer output of the run (the signals are
       finite whenever the program is: the caller checks it once) */
    A->FIN[r] = chk - chk == 0;
    for (m = 0; m < NI; ++m) {{
      casadi_real* o4 = A->IVOUT + (r * NI + m) * 4;
      o4[0] = ivc[m]; o4[1] = ivm[m]; o4[2] = ivw[m]; o4[3] = ivf[m];
    }}
  }}
  return 0;
}}
"""


_DUMMY = np.zeros(8)
_DUMMY_PTR = _DUMMY.ctypes.data
_NO_INTERVALS = np.zeros(4, dtype=np.intc)
_NO_INTERVALS_PTR = _NO_INTERVALS.ctypes.data
#: the fields of the argument block that point at per-run data, and the step from one run
#: to the next (bytes; ``ns``/``np``: per joint state / parameter, a name: that field × 8)
_PER_RUN = (("SAMPLES", 8, None), ("P", 8, "np"), ("S0", 8, "ns"), ("T", 8, "TR"),
            ("S", 8, "SR"), ("Y", 8, "YR"), ("O", 8, "OR"), ("V", 8, "VR"), ("FIN", 4, None),
            ("IVOUT", 32, "NI"))


def _pointer(a) -> int:
    return a.ctypes.data if a.size else _DUMMY_PTR


class _Args:
    """One argument block of ``NAME_batch`` (the C struct ``NAME_batch_args``: a uint64
    per entry of ``_BATCH_FIELDS``, ``TOL`` a double) in ctypes-owned memory, followed by
    room for the runs' finiteness flags (``FIN`` points there).  ``keep`` holds the arrays
    the pointers refer to."""

    __slots__ = ("buf", "ptr", "keep", "runs")

    def __init__(self, runs: int, template: "_Args | None" = None):
        self.runs = runs
        self.buf = (ctypes.c_uint64 * (_NARGS + (runs + 1) // 2))()
        self.ptr = ctypes.addressof(self.buf)
        self.keep = ()
        if template is not None:
            ctypes.memmove(self.ptr, template.ptr, 8 * _NARGS)
            self.keep = template.keep
        self.buf[_AI["R"]] = runs
        self.buf[_AI["FIN"]] = self.ptr + 8 * _NARGS

    def set(self, **fields) -> None:
        buf = self.buf
        for k, v in fields.items():
            buf[_AI[k]] = v

    def set_float(self, name: str, x: float) -> None:
        ctypes.c_double.from_address(self.ptr + 8 * _AI[name]).value = x

    def finite(self) -> np.ndarray:
        """(R,) bool: the runs whose states and outputs were all finite."""
        return np.frombuffer(self.buf, dtype=np.intc, count=self.runs, offset=8 * _NARGS) != 0

    def all_finite(self) -> bool:
        if self.runs == 1:
            return ctypes.c_int.from_address(self.ptr + 8 * _NARGS).value != 0
        return bool(self.finite().all())

    def part(self, a: int, b: int, dims: dict) -> "_Args":
        """The block for runs a … b − 1 of this one (same outputs, same flags)."""
        part = _Args(b - a, self)
        buf = self.buf
        for name, size, per in _PER_RUN:
            k = _AI[name]
            if buf[k]:
                n = 1 if per is None else (dims[per] if per in dims else buf[_AI[per]])
                part.buf[k] = buf[k] + a * size * n
        part.buf[_AI["FIN"]] = self.ptr + 8 * _NARGS + 4 * a
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
            self._batch = _batch_function(lib, self.fname)
        return self._batch

    def _dims(self) -> dict:
        return {"ns": self.ns, "np": self.np}

    def _call(self, args: _Args) -> int:
        return self._function()(args.ptr)

    def program_fields(self, program) -> dict:
        """The argument-block fields of a signal program (kept for the last few)."""
        hit = self._signals.get(id(program))
        if hit is not None and hit[0] is program:
            return hit[1]
        base, su, sn = program.columns
        kind = np.array([(1 if program.random[j] else 0) | (2 if program.normal[j] else 0)
                         for j in range(self.nv)], dtype=np.intc)
        fields = {"BASE": _pointer(base), "SU": _pointer(su), "SN": _pointer(sn),
                  "KIND": _pointer(kind), "_keep": (base, su, sn, kind)}
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
        args = _Args(R)
        args.keep = (t, samples, P, S0, S, Y, O, V, T, delay, iv, ivout, prog["_keep"])
        args.set(N=N, t=_pointer(t), BASE=prog["BASE"], SU=prog["SU"], SN=prog["SN"],
                 KIND=prog["KIND"], SEED=int(seed) % 2 ** 64, SAMPLES=_pointer(samples),
                 P=_pointer(P), S0=_pointer(S0),
                 T=0 if T is None else _pointer(T), TR=N,
                 S=_pointer(S), KS=ks, SR=ks * N, SC=N,
                 Y=_pointer(Y), YR=self.ny * N, YC=N,
                 O=_pointer(O), OR=self.no * N, OC=N, DELAY=_pointer(delay),
                 V=_pointer(V), VR=self.nv * N, VC=N,
                 IV=_pointer(iv), NI=int(n_iv), I0=int(start), IVOUT=_pointer(ivout),
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


def _batch_function(lib, fname):
    """``NAME_batch`` of a loaded library, checked to take this module's argument block."""
    try:
        fn = getattr(lib, f"{fname}_batch")
        nfields = getattr(lib, f"{fname}_batch_fields")
    except AttributeError:
        raise CodegenError(f"{fname}_batch is missing from the library") from None
    nfields.restype = ctypes.c_int
    nfields.argtypes = []
    if nfields() != _NARGS:
        raise CodegenError(f"{fname}_batch takes another argument block ({nfields()} fields,"
                           f" not {_NARGS}): a library of another version")
    fn.restype = ctypes.c_int
    fn.argtypes = [_P]
    return fn


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
            ptr = _pointer(blk)
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
    args: _Args
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
                _batch_function(lib, fname)

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
        batch = _batch_function(lib, fname)
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
            rc = self._fn(N, _pointer(t), _pointer(V), _pointer(p), _pointer(S), _pointer(Y),
                              _pointer(O))
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
        args = _Args(R)
        args.keep = (t, samples_, P, S0, delay, sig["_keep"])
        # the result's block: columns (t, states, outputs, signals, observer outputs) of
        # (R, N) each; a column is contiguous, run r's samples at r·N
        RN = R * N
        nx = len(m.states)
        args.set(N=N, t=_pointer(t), BASE=sig["BASE"], SU=sig["SU"], SN=sig["SN"],
                 KIND=sig["KIND"], SEED=int(scenario.seed) % 2 ** 64, SAMPLES=_pointer(samples_),
                 P=_pointer(P), S0=_pointer(S0), TR=N, KS=nx, SR=N, SC=RN, YR=N, YC=RN,
                 OR=N, OC=RN, DELAY=_pointer(delay), VR=N, VC=RN, IV=_NO_INTERVALS_PTR,
                 NI=0, I0=0, IVOUT=_DUMMY_PTR, STORE=1)
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
        args = _Args(R, rs.args)
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
