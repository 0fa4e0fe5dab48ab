"""Counter-based random numbers: a run's samples depend only on (seed, run, stream, step).

Ensembles are cut into chunks and spread over threads, processes and machines; a run's
random signals, parameters and initial states must not depend on which chunk or worker
computes it, nor on how many runs there are.  A counter-based generator gives that by
construction: each sample is a hash of its coordinates, so any subset of runs is computed
alone and bit-for-bit equal to the same runs inside a larger ensemble.

The hash is the splitmix64 finaliser (Steele, Lea & Flood, "Fast splittable pseudorandom
number generators", OOPSLA 2014; the output function of ``java.util.SplittableRandom``)::

    mix(z) = z ^ (z >> 31) after z = (z ^ (z >> 30)) · 0xBF58476D1CE4E5B9,
                                 z = (z ^ (z >> 27)) · 0x94D049BB133111EB
    key(seed, run, stream) = mix(mix(mix(seed + G) + run) + stream)
    u(key, i) = (mix(key + (i + 1) · G) >> 11) · 2⁻⁵³        ∈ [0, 1)

all arithmetic modulo 2⁶⁴, G = 0x9E3779B97F4A7C15.  Sample i of a stream is the splitmix64
sequence seeded with the key.  Normal samples use the Box–Muller transform of the two
uniform streams 2j and 2j + 1: z = √(−2 ln(1 − u₁)) · cos(2π u₂).

The compiled trajectory loop (:mod:`observer_cad.codegen`) implements the same
arithmetic in C (:data:`RANDOM_C`: ``oc_key`` the keys, ``oc_uniform`` / ``oc_normal``
sample i of a stream; the loop walks a stream with the running sum key + (i + 1) · G,
the same numbers): keys and uniform samples are the same bits (tested); normal samples
agree to the last bits of the C library's ``log1p``/``cos`` against numpy's (tested to
1e-14).
"""
from __future__ import annotations

import numpy as np

__all__ = ["GOLDEN", "mix64", "stream_keys", "uniform_samples", "normal_samples",
           "PARAMETER_STREAMS", "RANDOM_C"]

#: the splitmix64 increment (2⁶⁴ / golden ratio, odd)
GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = (np.uint64(k) for k in (30, 27, 31, 11))
_SCALE = 2.0 ** -53
#: streams 0 … 2·(signals) − 1 belong to the signals (2j, 2j + 1 for signal j); the
#: per-run quantities (parameters, initial states) use streams from here on
PARAMETER_STREAMS = 1 << 32


def mix64(z):
    """The splitmix64 finaliser on uint64 values (array in, array out; wraps mod 2⁶⁴)."""
    z = np.asarray(z, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = (z ^ (z >> _S30)) * _M1
        z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


def _u64(v) -> np.ndarray:
    a = np.asarray(v)
    if a.dtype.kind == "u":
        return a.astype(np.uint64)
    return np.asarray(a, dtype=np.int64).astype(np.uint64)


def stream_keys(seed: int, runs, streams) -> np.ndarray:
    """The keys of ``streams`` for ``runs``: shape (len(runs), len(streams)), uint64."""
    runs = _u64(np.atleast_1d(runs))
    streams = _u64(np.atleast_1d(streams))
    with np.errstate(over="ignore"):
        k = mix64(np.uint64(int(seed) % 2 ** 64) + GOLDEN)
        k = mix64(k + runs)[:, None]
        return mix64(k + streams[None, :])


def uniform_samples(keys, steps: int, first: int = 0) -> np.ndarray:
    """Samples ``first … first + steps − 1`` of the streams ``keys`` (any shape K):
    shape K + (steps,), uniform on [0, 1)."""
    keys = np.asarray(keys, dtype=np.uint64)
    i = np.arange(first + 1, first + steps + 1, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = mix64(keys[..., None] + i * GOLDEN)
    return (z >> _S11).astype(np.float64) * _SCALE


def normal_samples(keys1, keys2, steps: int, first: int = 0) -> np.ndarray:
    """Standard normal samples by Box–Muller from two uniform streams."""
    u1 = uniform_samples(keys1, steps, first)
    u2 = uniform_samples(keys2, steps, first)
    return np.sqrt(-2.0 * np.log1p(-u1)) * np.cos(2.0 * np.pi * u2)


#: the same generator in C (static functions, prefixed ``oc_``), pasted into the
#: compiled trajectory loop
RANDOM_C = r"""
#include <stdint.h>
#include <math.h>
static inline uint64_t oc_mix(uint64_t z) {
  z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
  z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
  return z ^ (z >> 31);
}
/* key(seed, run, stream) of stream_keys; seed already reduced mod 2^64 */
static inline uint64_t oc_key(uint64_t seed, int64_t run, uint64_t stream) {
  return oc_mix(oc_mix(oc_mix(seed + UINT64_C(0x9E3779B97F4A7C15)) + (uint64_t)run) + stream);
}
/* the uniform sample of the hash state z = key + (i + 1) G */
static inline double oc_unit(uint64_t z) {
  /* < 2^53: exact as a signed conversion (cheaper than unsigned on x86-64) */
  return (double)(int64_t)(oc_mix(z) >> 11) * 0x1.0p-53;
}
static inline double oc_uniform(uint64_t key, long long i) {
  return oc_unit(key + (uint64_t)(i + 1) * UINT64_C(0x9E3779B97F4A7C15));
}
static inline double oc_normal(uint64_t key1, uint64_t key2, long long i) {
  double u1 = oc_uniform(key1, i), u2 = oc_uniform(key2, i);
  return sqrt(-2.0 * log1p(-u1)) * cos(6.283185307179586 * u2);
}
"""
