"""Top-level tasks and payloads for the backend tests (importable by loky and Dask
workers as ``tests.ensemble.tasks``)."""
from __future__ import annotations

import ctypes
import os
import time

import numpy as np

from observer_cad.codegen import load_library, loaded_libraries

#: a deterministic loop per run: a damped oscillator driven by sin, started from the
#: run's global index, ``steps`` steps; out[k] is run first + k's final x + v
SOURCE = r"""
#include <math.h>
void ens_runs(long first, long count, long steps, double* out) {
  long k, s;
  for (k = 0; k < count; ++k) {
    long i = first + k;
    double x = 0.1 + 1e-3 * (double)(i % 997), v = 0.0;
    for (s = 0; s < steps; ++s) {
      double a = -x - 0.1 * v + 0.5 * sin(0.01 * (double)s + (double)i);
      v += 0.01 * a;
      x += 0.01 * v;
    }
    out[k] = x + v;
  }
}
"""

#: per-process count of payload unpickling (CountedPayload._rebuild)
REBUILT = {"n": 0}


def _rebuild(spec, steps):
    REBUILT["n"] += 1
    return CountedPayload(spec, steps)


class CountedPayload:
    """A payload that counts, in each process, how often it was unpickled there."""

    def __init__(self, spec, steps):
        self.spec, self.steps = spec, steps

    def __reduce__(self):
        return (_rebuild, (self.spec, self.steps))


def runs(payload, chunk):
    """chunk = (first, count): the final values of runs first … first + count − 1,
    computed by the C library of ``payload.spec`` loaded in this process."""
    first, count = chunk
    lib = load_library(payload.spec)
    fn = lib.ens_runs
    fn.restype = None
    fn.argtypes = [ctypes.c_long, ctypes.c_long, ctypes.c_long,
                   np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")]
    out = np.empty(count)
    fn(first, count, payload.steps, out)
    return out


def runs_counted(payload, chunk):
    """(values, pid, times this process unpickled a payload, libraries loaded here)."""
    return runs(payload, chunk), os.getpid(), REBUILT["n"], loaded_libraries()


def slow(payload, chunk):
    """A slow chunk (for the interrupt test): sleeps, returns (chunk, pid)."""
    time.sleep(payload)
    return chunk, os.getpid()


def fails(payload, chunk):
    if chunk == 3:
        raise ValueError(f"chunk {chunk} failed")
    return chunk


def sigint_default():
    """Popen preexec_fn: the child takes Ctrl-C even when the test run itself ignores SIGINT
    (a shell starts background jobs with SIGINT ignored, and children inherit that)."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_DFL)
