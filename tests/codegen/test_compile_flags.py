"""Size-aware optimisation level: large generated C is compiled at -O1
instead of -O3, explicit flags are used as given, and the flags are part of every cache
key (content key and pre-translation fingerprint), so a library built with one level is
never reused for another.  The compile-time and per-step figures that justify the
threshold are measured by benchmarks/bench_latency.py, not here."""
from __future__ import annotations

import importlib
import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("casadi")

from observer_cad.codegen import (FLAGS, LARGE_LEVEL, LARGE_SOURCE, CompiledSimulator,
                                  compile_function, compile_source, fingerprint,
                                  observer_step, size_aware_flags)
from observer_cad.model import load_model
from observer_cad.observers import build_observer
from observer_cad.synthesis import design

ROOT = Path(__file__).resolve().parents[2]
HAVE_CC = any(os.path.exists(os.path.join(d, "cc")) for d in os.environ.get("PATH", "").split(":"))
needs_cc = pytest.mark.skipif(not HAVE_CC, reason="no C compiler")
_compile = importlib.import_module("observer_cad.codegen._compile")

SMALL = "double f(double x) { return 2 * x; }\n"


@pytest.fixture(scope="module")
def drive():
    m = load_model(ROOT / "models" / "electric_drive.py")
    return m, build_observer(m, design(m, observer="diagnostic"))


def test_small_source_keeps_the_default_flags():
    assert size_aware_flags(SMALL) == FLAGS
    assert "-O3" in FLAGS


def test_large_source_is_compiled_at_the_large_level():
    big = SMALL + " " * LARGE_SOURCE
    flags = size_aware_flags(big)
    assert flags[0] == LARGE_LEVEL and "-O3" not in flags
    assert flags[1:] == FLAGS[1:]      # only the level changes: still a shared PIC library
    # any base set: its -O3 is replaced, the rest kept in order
    assert size_aware_flags(big, ("-O3", "-shared", "-fPIC", "-fno-semantic-interposition")) \
        == (LARGE_LEVEL, "-shared", "-fPIC", "-fno-semantic-interposition")
    # a base without -O3 (an explicit level) is left alone
    assert size_aware_flags(big, ("-O2", "-shared")) == ("-O2", "-shared")


def test_the_threshold_is_strict():
    assert size_aware_flags("x" * LARGE_SOURCE) == FLAGS
    assert size_aware_flags("x" * (LARGE_SOURCE + 1))[0] == LARGE_LEVEL


@needs_cc
def test_content_key_includes_the_flags(tmp_path):
    a = compile_source(SMALL, "flagtest", cache=tmp_path)
    b = compile_source(SMALL, "flagtest", cache=tmp_path, flags=(LARGE_LEVEL, "-shared", "-fPIC"))
    assert a.flags == FLAGS and b.flags == (LARGE_LEVEL, "-shared", "-fPIC")
    assert a.key != b.key and a.path != b.path
    assert not b.cached                 # the -O3 library was not reused for -O1
    again = compile_source(SMALL, "flagtest", cache=tmp_path)
    assert again.cached and again.key == a.key


@needs_cc
def test_fingerprint_includes_the_flags_and_the_size_rule(monkeypatch):
    parts = ("x", 1)
    auto = fingerprint(parts)
    assert auto != fingerprint(parts, flags=FLAGS)
    assert fingerprint(parts, flags=FLAGS) != fingerprint(parts, flags=(LARGE_LEVEL, "-shared", "-fPIC"))
    monkeypatch.setattr(_compile, "LARGE_SOURCE", 10)
    assert fingerprint(parts) != auto, "changing the size rule must invalidate fingerprints"


@needs_cc
def test_simulator_uses_the_large_level_above_the_threshold_and_remembers_it(drive, tmp_path,
                                                                            monkeypatch):
    m, o = drive
    small = CompiledSimulator(m, o, cache=tmp_path)
    assert "-O3" in small.flags and len(small.source) <= LARGE_SOURCE
    monkeypatch.setattr(_compile, "LARGE_SOURCE", 100)   # every source is "large" now
    big = CompiledSimulator(m, o, cache=tmp_path)
    assert not big.cached, "the -O3 library was reused for the size-aware -O1 build"
    assert big.flags[0] == LARGE_LEVEL and "-O3" not in big.flags
    assert big.path != small.path
    hit = CompiledSimulator(m, o, cache=tmp_path)
    assert hit.cached and not hit.translated and hit.flags == big.flags
    # same numbers whatever the level (this step has no reassociation-sensitive sums)
    t = np.arange(50.0)
    V = np.random.default_rng(0).uniform(-0.1, 0.1, (50, small.nv))
    s0 = np.full(small.ns, 0.1)
    S1, Y1, O1 = small.run_arrays(t, V, s0)
    S2, Y2, O2 = big.run_arrays(t, V, s0)
    np.testing.assert_allclose(S2, S1, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(O2, O1, rtol=1e-12, atol=1e-12)


@needs_cc
def test_explicit_flags_are_used_as_given(drive, tmp_path, monkeypatch):
    m, o = drive
    monkeypatch.setattr(_compile, "LARGE_SOURCE", 100)
    cs = CompiledSimulator(m, o, cache=tmp_path, flags=("-O3", "-shared", "-fPIC"))
    assert cs.flags == ("-O3", "-shared", "-fPIC")
    cf = compile_function(observer_step(o), cache=tmp_path, flags=("-O2", "-shared", "-fPIC"))
    assert cf.flags == ("-O2", "-shared", "-fPIC")
    auto = compile_function(observer_step(o), cache=tmp_path)
    assert auto.flags[0] == LARGE_LEVEL and auto.path != cf.path
