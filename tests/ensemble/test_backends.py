"""The ensemble backends: the same deterministic task — a tiny C
library loaded with load_library, called on numpy buffers — gives identical results
on every backend; compiled code reaches workers by value and is refused when its key
does not match; the payload is sent once per worker; Ctrl-C leaves the finished
results; bad backend values are one-line UsageErrors."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from observer_cad.codegen import (CodegenError, LibrarySpec, compile_source, library_spec,
                                  load_library)
from observer_cad.ensemble import (DASK_MISSING, Backend, Interrupted, map_chunks,
                                   progress_bar)
from observer_cad.errors import UsageError

from tests.ensemble.tasks import (SOURCE, CountedPayload, fails, runs, runs_counted,
                                  sigint_default)

ROOT = Path(__file__).resolve().parents[2]
RUNS, CHUNK, STEPS = 200, 16, 500
CHUNKS = [(first, min(CHUNK, RUNS - first)) for first in range(0, RUNS, CHUNK)]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """A private compile cache, also seen by the workers (they inherit the environment)."""
    d = tmp_path_factory.mktemp("ens_cache")
    old = os.environ.get("OBSERVER_CAD_CACHE")
    os.environ["OBSERVER_CAD_CACHE"] = str(d)
    yield d
    if old is None:
        os.environ.pop("OBSERVER_CAD_CACHE", None)
    else:
        os.environ["OBSERVER_CAD_CACHE"] = old


@pytest.fixture(scope="module")
def spec(cache):
    return library_spec(SOURCE, "ens_test", compile_source(SOURCE, "ens_test"))


@pytest.fixture(scope="module")
def expected(spec):
    """Run by run in this process, one run per call: the oracle every backend must match."""
    p = CountedPayload(spec, STEPS)
    return np.concatenate([runs(p, (i, 1)) for i in range(RUNS)])


def _collect(pairs):
    got = sorted(pairs, key=lambda cr: cr[0][0])
    assert [c for c, _ in got] == CHUNKS  # every chunk once
    return got


def _values(got):
    return np.concatenate([r[0] if isinstance(r, tuple) else r for _, r in got])


# --- identical results -----------------------------------------------------------------

@pytest.mark.parametrize("backend", [  # a pool of processes costs ~3 s: slow step
    Backend("serial"), Backend("threads", 2),
    pytest.param(Backend("processes", 2), marks=pytest.mark.slow)], ids=lambda b: b.kind)
def test_identical_results(backend, spec, expected):
    seen = []
    got = _collect(map_chunks(runs_counted, CountedPayload(spec, STEPS), CHUNKS,
                              backend=backend, progress=seen.append))
    assert np.array_equal(_values(got), expected)  # bit for bit, whatever the chunking
    assert seen == list(range(1, len(CHUNKS) + 1))  # progress(n): n completed, in order
    if backend.kind == "processes":
        pids = {r[1] for _, r in got}
        assert os.getpid() not in pids and 1 <= len(pids) <= 2
        # payload sent once per worker: every chunk saw exactly one unpickling in its
        # worker process, and each worker loaded the library once
        assert {r[2] for _, r in got} == {1}
        assert {r[3] for _, r in got} == {1}


def test_identical_results_dask_in_process(spec, expected):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        b = Backend("dask", 2, address=cluster.scheduler_address)
        got = _collect(map_chunks(runs_counted, CountedPayload(spec, STEPS), CHUNKS,
                                  backend=b))
    assert np.array_equal(_values(got), expected)


@pytest.mark.slow
def test_identical_results_dask_local_processes(spec, expected):
    pytest.importorskip("distributed")
    got = _collect(map_chunks(runs_counted, CountedPayload(spec, STEPS), CHUNKS,
                              backend=Backend("dask", 2)))
    assert np.array_equal(_values(got), expected)
    pids = {r[1] for _, r in got}
    assert os.getpid() not in pids and len(pids) <= 2
    assert {r[2] for _, r in got} == {1}  # unpickled once per worker process


def test_dask_payload_unpickled_once_per_process_and_checked(spec):
    """Dask may deliver the scattered bytes to a worker twice (under load a worker
    fetched them again from a peer, and the payload was unpickled twice there: CI,
    stop 24); the worker-side call unpickles a token's bytes once per process, and
    refuses bytes whose SHA-256 is not the client's token."""
    import pickle

    from observer_cad.ensemble import _backends
    from tests.ensemble import tasks

    blob = pickle.dumps(CountedPayload(spec, STEPS))
    token = _backends._token(blob)
    before = tasks.REBUILT["n"]
    first = _backends._call_unpickled(token, blob, runs_counted, (0, 3))
    again = _backends._call_unpickled(token, bytes(blob), runs_counted, (3, 2))  # a copy
    assert tasks.REBUILT["n"] == before + 1 and first[2] == again[2] == before + 1
    with pytest.raises(RuntimeError, match="does not match"):
        _backends._call_unpickled("0" * 64, blob, runs_counted, (0, 1))


def test_chunking_does_not_change_results(spec, expected):
    chunks = [(0, 1), (1, 7), (8, 100), (108, 92)]
    got = sorted(map_chunks(runs, CountedPayload(spec, STEPS), chunks,
                            backend=Backend("threads", 2)))
    assert np.array_equal(np.concatenate([r for _, r in got]), expected)


def test_in_flight_is_bounded():
    """At most 2 × workers chunks are submitted ahead of what was yielded: while the
    caller holds the first result, only 4 (+1 replacing it) of the 13 tasks started."""
    started = []
    backend = Backend("threads", 2)
    it = map_chunks(_record_start, started, CHUNKS, backend=backend)
    next(it)
    time.sleep(0.2)  # the pool would start every chunk meanwhile if it could
    assert len(started) <= 2 * backend.workers + 1 < len(CHUNKS)
    assert len(list(it)) + 1 == len(CHUNKS)


def _record_start(started, chunk):
    started.append(chunk)
    return chunk


def test_task_error_propagates_and_stops(spec):
    for kind in ("serial", "threads"):
        with pytest.raises(ValueError, match="chunk 3 failed"):
            list(map_chunks(fails, None, range(10), backend=Backend(kind, 2)))


# --- compiled code by value --------------------------------------------------------------

def test_library_spec_pickles_and_loads_once(spec):
    import pickle
    back = pickle.loads(pickle.dumps(spec))
    assert back == spec and "chars" in repr(spec) and SOURCE not in repr(spec)
    assert load_library(back) is load_library(spec)  # memoised per process


def test_load_library_compiles_a_missing_entry(tmp_path, spec):
    """A worker whose cache lacks the library compiles it (same key) and loads it."""
    lib = load_library(spec, cache=tmp_path)
    assert list(tmp_path.glob("ens_test-*.so"))
    assert lib.ens_runs is not None


def test_key_mismatch_is_refused(spec):
    other = LibrarySpec(source=SOURCE + "\n/* changed */\n", name=spec.name,
                        flags=spec.flags, key=spec.key)
    with pytest.raises(CodegenError, match="refusing") as exc:
        load_library(other)
    assert "\n" not in str(exc.value)
    flags = LibrarySpec(source=SOURCE, name=spec.name, flags=("-O1", "-shared", "-fPIC"),
                        key=spec.key)
    with pytest.raises(CodegenError, match="refusing"):
        load_library(flags)


# --- Ctrl-C ------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["threads", pytest.param("processes", marks=pytest.mark.slow)])
def test_interrupt_leaves_finished_results(kind, tmp_path):
    """SIGINT to the process group (as a terminal's Ctrl-C): the map stops without a
    hang, Interrupted carries finished chunks not yet yielded, no worker survives."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), OBSERVER_CAD_CACHE=str(tmp_path))
    p = subprocess.Popen([sys.executable, str(Path(__file__).with_name("interrupt_child.py")),
                          kind], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=env, cwd=str(tmp_path), start_new_session=True,
                         preexec_fn=sigint_default)
    try:
        assert p.stdout.readline().strip() == "READY"
        os.killpg(p.pid, signal.SIGINT)
        out, err = p.communicate(timeout=120)  # a hang guard, not a timing goal
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    assert p.returncode == 0, err
    rep = json.loads(out.strip().splitlines()[-1])
    assert "finished" not in rep  # 400 × 0.3 s could not have finished
    yielded, done = rep["yielded"], rep["done"]
    assert len(yielded) >= 4 and not set(yielded) & set(done)
    assert len(yielded) + len(done) < 400
    if kind == "threads":
        # the two chunks running in threads finish and are handed back
        assert len(done) >= 2
    else:
        assert os.getpid() not in rep["pids"]
        for pid in rep["pids"]:  # no orphan workers (zombies awaiting a reaper are dead)
            for _ in range(100):
                if not _alive(pid):
                    break
                time.sleep(0.05)
            assert not _alive(pid), f"worker {pid} survived the interrupt"


def _alive(pid: int) -> bool:
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "State:\tZ" not in text


def test_serial_interrupt_raises_interrupted():
    def task(payload, chunk):
        if chunk == 2:
            raise KeyboardInterrupt
        return chunk
    it = map_chunks(task, None, range(5), backend=Backend("serial"))
    assert [c for c, _ in (next(it), next(it))] == [0, 1]
    with pytest.raises(Interrupted) as exc:
        next(it)
    assert isinstance(exc.value, KeyboardInterrupt) and exc.value.done == []


# --- bad values ------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, match", [
    ({"kind": "gpu"}, "backend kind 'gpu' is not one of serial, threads, processes, dask"),
    ({"kind": "threads", "workers": 0}, "positive integer, got 0"),
    ({"kind": "threads", "workers": 2.5}, "positive integer, got 2.5"),
    ({"kind": "threads", "workers": True}, "positive integer, got True"),
    ({"kind": "processes", "address": "tcp://h:8786"}, "needs the dask backend"),
    ({"kind": "dask", "address": "tcp://h :8786"}, "is not an address"),
    ({"kind": "dask", "address": ""}, "is not an address"),
])
def test_bad_backend_values(kwargs, match):
    with pytest.raises(UsageError, match=match) as exc:
        Backend(**kwargs)
    assert "\n" not in str(exc.value)


def test_dask_missing_is_a_usage_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(UsageError) as exc:
        Backend("dask")
    assert str(exc.value) == DASK_MISSING


def test_map_chunks_needs_a_backend():
    with pytest.raises(UsageError, match="backend must be a Backend"):
        map_chunks(runs, None, [], backend="threads")


def test_default_workers_are_the_usable_cpus():
    assert Backend("threads").workers == len(os.sched_getaffinity(0))


# --- progress bar ------------------------------------------------------------------------

def test_progress_bar_off_when_not_a_terminal(capsys, monkeypatch):
    monkeypatch.delenv("OBSERVER_CAD_PROGRESS", raising=False)
    with progress_bar(10, desc="runs") as bar:
        bar(3)
        bar.update(2)
    assert bar.n == 0 and capsys.readouterr().err == ""


def test_progress_bar_on_with_the_environment_variable(capsys, monkeypatch):
    monkeypatch.setenv("OBSERVER_CAD_PROGRESS", "1")
    with progress_bar(10, desc="chunks", unit="chunk") as bar:
        for n in (1, 4, 10):
            bar(n)
        assert bar.n == 10
    err = capsys.readouterr().err
    assert "chunks" in err and "10/10" in err
