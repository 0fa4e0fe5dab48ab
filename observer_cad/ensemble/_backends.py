"""Where the chunks of an ensemble run: serially, on threads, on loky processes, or on a
Dask cluster.

:func:`map_chunks` maps ``task(payload, chunk)`` over ``chunks`` and yields
``(chunk, result)`` pairs as they complete (in any order: the caller orders them by the
chunk, which carries its global run indices, so results never depend on the backend).

* ``payload`` is shared by every chunk and may be large (the C source of the compiled
  engine, a scenario, a design): it is sent **once per worker** — threads share it;
  loky workers receive it pickled once in their initializer (a new payload restarts
  the reusable pool, the same payload reuses it warm); Dask workers receive its pickled
  bytes through ``client.scatter(blob, broadcast=True)`` and unpickle them once per
  worker process (checked against the client's SHA-256), even when Dask copies the
  bytes between workers a second time, as it may under load.
* Compiled code travels as a :class:`~observer_cad.codegen.LibrarySpec` inside the
  payload and is loaded on the worker with :func:`~observer_cad.codegen.load_library`
  (from the worker machine's content-hashed cache; never a pickled ctypes object).
* At most ``2 × workers`` chunks are in flight (submitted, not yet yielded): memory is
  bounded whatever the number of chunks.
* ``progress(n)`` is called in the calling thread with the number of chunks completed
  so far, before each pair is yielded.
* **Ctrl-C.**  A :class:`KeyboardInterrupt` while the iterator waits for results
  cancels what is pending, shuts the pool down at once (loky workers are killed, a Dask
  cluster started for the run is closed; a thread already inside a C call finishes
  that chunk, a thread cannot be stopped) and raises :class:`Interrupted`, whose
  ``done`` holds the chunks that had finished but were not yet yielded: with what was
  yielded before, that is everything finished, so the caller can write it.  A task
  that raises stops the map the same way and its exception propagates.

Threads scale only when the task releases the GIL: a ctypes call into a C loop does
(``ctypes.CDLL`` functions drop it for the call); Python-level work does not.
"""
from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import hashlib
import importlib.util
import logging
import os
import pickle
import re
import signal
import sys
import threading
from typing import Any, Callable, Iterator, Sequence

from ..errors import UsageError
from ..progress import PROGRESS_ENV

__all__ = ["Backend", "BACKEND_KINDS", "Interrupted", "map_chunks", "progress_bar",
           "DASK_MISSING", "dask_address_problem"]

BACKEND_KINDS = ("serial", "threads", "processes", "dask")
DASK_MISSING = "Dask is not installed: pip install 'observer_cad[cluster]'"
#: chunks in flight per worker (submitted and not yet yielded)
IN_FLIGHT_PER_WORKER = 2


def _default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


@dataclasses.dataclass(frozen=True)
class Backend:
    """Where :func:`map_chunks` runs: ``kind`` one of :data:`BACKEND_KINDS`;
    ``workers`` the number of threads / processes / Dask workers (default: the CPUs
    this process may use; ignored by ``serial``); ``address`` the Dask scheduler
    (``"tcp://host:8786"``; only with ``kind="dask"``), or None for a
    ``LocalCluster`` started for the run and closed after (``processes=True``,
    ``threads_per_worker=1``, ``n_workers=workers``, no dashboard)."""

    kind: str = "serial"
    workers: int = dataclasses.field(default_factory=_default_workers)
    address: str | None = None

    def __post_init__(self):
        if self.kind not in BACKEND_KINDS:
            raise UsageError(f"backend kind {self.kind!r} is not one of"
                             f" {', '.join(BACKEND_KINDS)}")
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) \
                or self.workers < 1:
            raise UsageError(f"backend workers must be a positive integer, got"
                             f" {self.workers!r}")
        if self.address is not None:
            if self.kind != "dask":
                raise UsageError(f"a scheduler address ({self.address!r}) needs the dask"
                                 f" backend, not {self.kind!r}")
            problem = dask_address_problem(self.address, in_process=True)
            if problem is not None:
                raise UsageError(f"Dask scheduler address {self.address!r} is not an address"
                                 f" such as tcp://host:8786: {problem}")
        if self.kind == "dask" and not _have_dask():
            raise UsageError(DASK_MISSING)


#: the schemes of a scheduler another process can reach
_DASK_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
_HOST = re.compile(r"(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9.-]{0,252}))")


def dask_address_problem(address, *, in_process: bool = False) -> str | None:
    """What is wrong with a Dask scheduler address (``[scheme://]host:port``, ``scheme``
    one of tcp tls ws wss ucx, ``host`` a name, an IPv4 address or an IPv6 address in
    brackets, ``port`` 1–65535), or None: checked before any connection is tried.
    ``in_process``: an ``inproc://`` address (a cluster of this process, made from Python)
    is allowed too; from the command line it cannot name anything."""
    if not isinstance(address, str) or not address.strip():
        return "empty"
    if any(c.isspace() or ord(c) < 32 or ord(c) == 127 for c in address):
        return "white space or a control character"
    scheme, sep, rest = address.partition("://")
    if in_process and scheme == "inproc" and sep and rest:
        return None
    if not sep:
        scheme, rest = "tcp", address
    if scheme not in _DASK_SCHEMES:
        return (f"scheme {scheme!r} (allowed: {', '.join(_DASK_SCHEMES)}; inproc:// is this"
                " process's own)")
    if rest.startswith("[") and "]" not in rest:
        return "an IPv6 address without its closing ']'"
    host, colon, port = rest.rpartition(":")
    if not colon or not host:
        return "no host:port"
    if not _HOST.fullmatch(host):
        return f"host {host!r} is not a host name or address"
    if not (port.isdigit() and 1 <= int(port) <= 65535):
        return f"port {port!r} is not a number in 1–65535"
    return None


def _have_dask() -> bool:
    try:
        return importlib.util.find_spec("distributed") is not None
    except (ImportError, ValueError):
        return False


class Interrupted(KeyboardInterrupt):
    """Ctrl-C stopped :func:`map_chunks`: ``done`` lists the ``(chunk, result)`` pairs
    that had finished but had not been yielded yet."""

    def __init__(self, done=()):
        self.done = list(done)
        super().__init__(f"interrupted; {len(self.done)} finished chunk(s) not yet yielded")


# --- worker side -------------------------------------------------------------------------

#: per-process payloads by token: installed by the loky initializer, or on a Dask
#: worker by the first chunk that needs it (under the lock: a Dask worker may run
#: several threads)
_PAYLOADS: dict = {}
_PAYLOADS_LOCK = threading.Lock()


def _install_payload(token: str, blob: bytes) -> None:
    """loky initializer: unpickle the payload once in this worker process."""
    _PAYLOADS.clear()  # one payload per pool: an earlier one is garbage
    _PAYLOADS[token] = pickle.loads(blob)


def _call_installed(token: str, task, chunk):
    return task(_PAYLOADS[token], chunk)


def _call_with(task, payload, chunk):
    return task(payload, chunk)


def _call_unpickled(token: str, blob: bytes, task, chunk):
    """Dask: the payload travels as its pickled bytes and is unpickled here once per
    worker process, whatever Dask does with the bytes (under load a worker may fetch
    a scattered value from a peer a second time), after its SHA-256 is checked
    against the token computed by the client."""
    with _PAYLOADS_LOCK:
        if token not in _PAYLOADS:
            if _token(blob) != token:
                raise RuntimeError("the ensemble payload received by this Dask worker"
                                   " does not match the one the client sent")
            _PAYLOADS.clear()  # one payload at a time: an earlier map's is garbage
            _PAYLOADS[token] = pickle.loads(blob)
        payload = _PAYLOADS[token]
    return task(payload, chunk)


# --- the map -----------------------------------------------------------------------------

def map_chunks(task: Callable[[Any, Any], Any], payload: Any, chunks: Sequence, *,
               backend: Backend, progress: Callable[[int], None] | None = None
               ) -> Iterator[tuple]:
    """Yield ``(chunk, task(payload, chunk))`` for every chunk, as they complete, on
    ``backend`` (see the module docstring: payload once per worker, at most
    ``2 × workers`` chunks in flight, ``progress(n_completed)`` in the calling thread,
    :class:`Interrupted` on Ctrl-C).  ``task`` must be a picklable top-level function
    for ``processes`` and ``dask``; ``payload`` and the chunks picklable values.
    Closing the iterator early (``break``, ``close()``) cancels what is pending."""
    if not isinstance(backend, Backend):
        raise UsageError(f"backend must be a Backend, got {type(backend).__name__}")
    chunks = list(chunks)
    guard = _SigintGuard()
    if backend.kind == "serial":
        return _guarded(_serial(task, payload, chunks, progress, guard), guard)
    if backend.kind == "dask":
        return _guarded(_dask(task, payload, chunks, backend, progress, guard), guard)
    return _guarded(_pool(task, payload, chunks, backend, progress, guard), guard)


#: how often a waiting map looks for a held Ctrl-C (seconds)
POLL = 0.05


class _SigintGuard:
    """Ctrl-C while a map runs (main thread, default SIGINT handler only).

    A KeyboardInterrupt raised asynchronously inside ``concurrent.futures`` or loky
    can leave a future's lock held (``wait`` acquires the locks of every future one by
    one) and deadlock the shutdown that follows — seen here, 1 run in ~20.  So the
    handler only *holds* the request; the map raises KeyboardInterrupt itself at a safe
    point (:meth:`poll`, between timed waits, or when the caller asks for the next
    pair).  Exceptions: while the task itself runs in the calling thread (the serial
    backend, ``immediate``) and on a second Ctrl-C, it raises at once."""

    def __init__(self):
        self.immediate = False
        self.requested = False
        self.old = None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread() and \
                signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            self.old = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        if self.immediate or self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def poll(self) -> None:
        """Raise KeyboardInterrupt here when a Ctrl-C is held."""
        if self.requested:
            raise KeyboardInterrupt

    def __exit__(self, *exc):
        if self.old is not None:
            signal.signal(signal.SIGINT, self.old)
            self.old = None
        return False


def _guarded(inner, guard):
    """``inner`` (a map generator) with Ctrl-C delivered as :class:`Interrupted` from
    inside it, whenever it arrives (see :class:`_SigintGuard`)."""
    with guard, contextlib.closing(inner):
        while True:
            try:
                try:
                    guard.poll()
                    item = next(inner)
                except Interrupted:
                    raise
                except KeyboardInterrupt:  # held while the caller had the last pair
                    item = inner.throw(KeyboardInterrupt())
            except StopIteration:
                return
            except KeyboardInterrupt as exc:
                if isinstance(exc, Interrupted):
                    raise
                raise Interrupted(()) from None
            yield item


def _serial(task, payload, chunks, progress, guard):
    done = []
    try:
        for n, chunk in enumerate(chunks, 1):
            guard.immediate = True  # the task runs here: Ctrl-C stops it at once
            try:
                result = task(payload, chunk)
            finally:
                guard.immediate = False
            done.append((chunk, result))
            if progress is not None:
                progress(n)
            done.pop()
            yield chunk, result
    except KeyboardInterrupt:
        raise Interrupted(done) from None


def _token(blob: bytes) -> str:
    return hashlib.sha256(blob).hexdigest()


def _pool(task, payload, chunks, backend, progress, guard):
    """threads and loky processes: concurrent.futures executors."""
    if backend.kind == "threads":
        executor = cf.ThreadPoolExecutor(max_workers=backend.workers,
                                         thread_name_prefix="observer-cad-chunk")

        def submit(chunk):
            return executor.submit(_call_with, task, payload, chunk)

        def stop(interrupted):
            executor.shutdown(wait=not interrupted, cancel_futures=True)
    else:
        from joblib.externals.loky import get_reusable_executor
        blob = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
        token = _token(blob)
        executor = get_reusable_executor(max_workers=backend.workers,
                                         initializer=_install_payload,
                                         initargs=(token, blob))
        del blob

        def submit(chunk):
            return executor.submit(_call_installed, token, task, chunk)

        def stop(interrupted):
            if interrupted:  # kill the workers now (and wait for that: no orphans); the
                # next map starts fresh ones
                _kill_loky(executor)
            # otherwise the reusable pool stays warm for the next map (loky stops idle
            # workers after its timeout, 300 s)

    def cancel(fs):
        if backend.kind == "processes":
            return  # stop() kills the workers, loky fails what was pending
        for f in fs:
            f.cancel()  # only chunks not started yet can be cancelled
        if backend.kind == "threads":
            # a thread inside a C call cannot be stopped: wait for the chunks already
            # running (one chunk's time at most) and keep their results; a second
            # Ctrl-C stops waiting
            with contextlib.suppress(KeyboardInterrupt):
                cf.wait(fs)

    def drop(fs):
        if backend.kind == "threads":
            for f in fs:
                f.cancel()

    def wait(fs):
        while True:
            done = cf.wait(fs, timeout=POLL, return_when=cf.FIRST_COMPLETED)[0]
            if done:
                return done
            guard.poll()

    yield from _drive(chunks, backend.workers, submit, stop, progress, guard,
                      wait=wait, cancel=cancel, drop=drop)


def _kill_loky(executor) -> None:
    """Shut a loky executor down killing its workers, waiting until they are gone.

    Works around two races in loky's manager thread (joblib 1.5/1.6) that otherwise
    kill that thread with a traceback on stderr — and in the first case leave the
    workers running for ~40 s: a future cancelled by the caller makes its
    ``flag_executor_shutting_down`` raise InvalidStateError, so pending futures are
    not cancelled (the shutdown fails them itself); a work id still queued when the
    pending items are dropped makes ``add_call_item_to_queue`` raise KeyError, so the
    queue of work ids (not yet handed to a worker) is emptied first."""
    ids = getattr(executor, "_work_ids", None)
    if ids is not None:
        with contextlib.suppress(Exception):
            while True:
                ids.get_nowait()
    hook = threading.excepthook

    def quiet(args):  # anything else is reported as usual
        if not (args.thread is not None and args.thread.name == "ExecutorManagerThread"
                and args.exc_type in (KeyError, cf.InvalidStateError)):
            hook(args)

    threading.excepthook = quiet
    try:
        executor.shutdown(wait=True, kill_workers=True)
    finally:
        threading.excepthook = hook


def _drive(chunks, workers, submit, stop, progress, guard, *, wait, cancel, drop=None,
           result=None):
    """The bounded submit / wait / yield loop shared by every concurrent backend.
    ``submit(chunk) -> future``; ``wait(pending) -> futures completed`` (blocking until
    at least one is); ``cancel(pending)`` on Ctrl-C (may wait for running chunks),
    ``drop(pending)`` on any other exit with work pending (default ``cancel``);
    ``stop(interrupted)`` shuts the pool down."""
    drop = drop or cancel
    result_of = result or (lambda f: f.result())
    limit = max(1, IN_FLIGHT_PER_WORKER * workers)
    todo = iter(chunks)
    pending: dict = {}
    ready: list = []  # completed, not yet yielded
    completed = 0
    interrupted = False
    try:
        try:
            for chunk in todo:
                pending[submit(chunk)] = chunk
                if len(pending) >= limit:
                    break
            while pending:
                guard.poll()
                for f in wait(list(pending)):
                    ready.append((pending.pop(f), f))
                while ready:
                    chunk, f = ready[0]
                    result = result_of(f)  # a task's exception propagates here
                    ready.pop(0)
                    completed += 1
                    nxt = next(todo, _END)
                    if nxt is not _END:
                        pending[submit(nxt)] = nxt
                    if progress is not None:
                        progress(completed)
                    yield chunk, result
        except KeyboardInterrupt:
            interrupted = True
            cancel(list(pending))  # a thread pool also waits for its running chunks
            done = []
            for chunk, f in ready + [(c, f) for f, c in pending.items()]:
                if f.done() and not f.cancelled():
                    try:
                        done.append((chunk, result_of(f)))
                    except BaseException:  # noqa: BLE001 - a failed chunk is not finished
                        pass
            raise Interrupted(done) from None
        except BaseException:
            interrupted = True  # a failing task or a closed iterator: drop the rest now
            drop(list(pending))
            raise
    finally:
        stop(interrupted)


_END = object()


def _dask(task, payload, chunks, backend, progress, guard):
    try:
        import distributed
    except ImportError:
        raise UsageError(DASK_MISSING) from None
    with contextlib.ExitStack() as stack:
        if backend.address is None:
            cluster = stack.enter_context(distributed.LocalCluster(
                n_workers=backend.workers, threads_per_worker=1, processes=True,
                dashboard_address=None, silence_logs=logging.ERROR))
            client = stack.enter_context(distributed.Client(cluster))
        else:
            try:
                client = stack.enter_context(distributed.Client(backend.address,
                                                                timeout="30s"))
            except (OSError, TimeoutError, ValueError, TypeError) as exc:
                first = (str(exc).splitlines() or [type(exc).__name__])[0]
                raise UsageError(f"cannot connect to the Dask scheduler at"
                                 f" {backend.address}: {first}") from None
        blob = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
        token = _token(blob)
        remote = client.scatter(blob, broadcast=True)
        del blob
        # a cluster of W workers (an existing one may have more than backend.workers)
        workers = max(1, len(client.scheduler_info().get("workers", {})) or backend.workers)

        # results are pushed to this process as they complete (one message per
        # chunk, no round trip per result)
        ac = distributed.as_completed(with_results=True)
        got: dict = {}

        def submit(chunk):
            f = client.submit(_call_unpickled, token, remote, task, chunk, pure=False)
            ac.add(f)
            return f

        def wait(pending):
            while True:
                with ac.thread_condition:
                    if not ac.has_ready():
                        ac.thread_condition.wait(timeout=POLL)
                if ac.has_ready():
                    batch = ac.next_batch(block=False)  # a failed task raises here
                    for f, r in batch:
                        got[f.key] = r
                    return [f for f, _ in batch]
                guard.poll()

        def cancel(fs):
            if fs:
                client.cancel(fs)

        yield from _drive(chunks, workers, submit, lambda interrupted: None, progress,
                          guard, wait=wait, cancel=cancel, result=lambda f: got.pop(f.key))


# --- progress bar ------------------------------------------------------------------------

class _Bar:
    """A tqdm bar driven by :func:`map_chunks`' ``progress(n)`` (``bar(n)`` sets the
    position to n) or by increments (``bar.update(k)``)."""

    def __init__(self, tq):
        self.tqdm = tq

    def __call__(self, n: int) -> None:
        if self.tqdm is not None and n > self.tqdm.n:
            self.tqdm.update(n - self.tqdm.n)

    def update(self, k: int = 1) -> None:
        if self.tqdm is not None:
            self.tqdm.update(k)

    @property
    def n(self) -> int:
        return self.tqdm.n if self.tqdm is not None else 0


@contextlib.contextmanager
def progress_bar(total: int, *, desc: str = "runs", enabled: bool | None = None,
                 unit: str = "run", stream=None):
    """A tqdm progress bar on stderr (``stream``) for a block; yields a callable
    (``bar(n)``: n of ``total`` done; ``bar.update(k)``: k more).  ``enabled=None``:
    shown when the stream is a terminal or ``OBSERVER_CAD_PROGRESS=1`` (as the stage
    lines of :mod:`observer_cad.progress`); a disabled bar costs nothing and prints
    nothing."""
    stream = stream if stream is not None else sys.stderr
    if enabled is None:
        isatty = getattr(stream, "isatty", None)
        enabled = bool(isatty and isatty()) or os.environ.get(PROGRESS_ENV) == "1"
    if not enabled:
        yield _Bar(None)
        return
    from tqdm import tqdm
    tq = tqdm(total=total, desc=desc, unit=unit, file=stream, dynamic_ncols=True,
              mininterval=0.25, smoothing=0.1)
    try:
        yield _Bar(tq)
    finally:
        tq.close()
