"""Progress of long computations, as stage lines on stderr.

Library code says where it is with :func:`report` (``report("designing: k = 3 of at
most 299")``); nothing is printed unless a reporter is active. :func:`reporting` makes
one active for a block (the CLI wraps ``show``, ``design``, ``simulate`` and ``codegen``
in it). A reporter prints a line only

- once ``after`` seconds (default 2) have passed since the block began — short runs
  print nothing — and
- when its stream is a terminal, or when ``OBSERVER_CAD_PROGRESS=1`` is set (for logs);
  pipes, files and the test suite see nothing otherwise;

and, for the steps of a loop, at most one line per ``every`` seconds (default 1), so
a loop over k cannot flood the terminal (a change of stage, ``stage=True``, always
prints). A background heartbeat repeats the latest message when nothing was printed
for ``heartbeat`` seconds (default 5), so a long silent step — loading a large model
file, one expensive rank decision — still shows that the run is alive. Lines read ``observer-cad: designing: k = 3 of at most 299 (12.4 s)``.
The reporter lives in a :class:`contextvars.ContextVar`: no global state to reset.
"""
from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import threading
import time
from typing import Callable, TextIO

__all__ = ["report", "reporting", "Reporter", "PROGRESS_ENV", "silenced"]

#: Set to 1 to print progress on a stream that is not a terminal.
PROGRESS_ENV = "OBSERVER_CAD_PROGRESS"


class Reporter:
    """Prints progress lines on ``stream`` after ``after`` seconds, at most one per
    ``every`` seconds; see the module docstring. ``clock`` is injectable for tests."""

    def __init__(self, stream: TextIO | None = None, *, after: float = 2.0,
                 every: float = 1.0, heartbeat: float | None = 5.0,
                 enabled: bool | None = None, prefix: str = "observer-cad",
                 clock: Callable[[], float] = time.monotonic):
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty()) or os.environ.get(PROGRESS_ENV) == "1"
        self.enabled = enabled
        self.after, self.every, self.prefix, self.clock = after, every, prefix, clock
        self.heartbeat = heartbeat
        self.start = clock()
        self.last: float | None = None
        self.pending: str | None = None  # the latest message (what a heartbeat repeats)
        self.lines: list = []  # what was printed (for tests and summaries)
        self._lock = threading.Lock()

    def __call__(self, message: str, *, stage: bool = False) -> None:
        if not self.enabled:
            return
        with self._lock:
            self.pending = message
            now = self.clock()
            elapsed = now - self.start
            if elapsed < self.after:
                return
            if not stage and self.last is not None and now - self.last < self.every:
                return
            self._print(message, now)

    def beat(self) -> None:
        """Repeat the latest message when nothing was printed for ``heartbeat`` seconds
        (a long step inside one stage, or a slow first stage such as loading the model)."""
        with self._lock:
            if not self.enabled or self.pending is None or self.heartbeat is None:
                return
            now = self.clock()
            if now - self.start < self.after:
                return
            if self.last is not None and now - self.last < self.heartbeat:
                return
            self._print(self.pending + (", still running" if self.last is not None else ""),
                        now)

    def _print(self, message: str, now: float) -> None:
        self.last = now
        line = f"{self.prefix}: {message} ({now - self.start:.1f} s)"
        self.lines.append(line)
        try:
            print(line, file=self.stream, flush=True)
        except (OSError, ValueError):  # a closed or broken stream: progress is optional
            self.enabled = False


_current: contextvars.ContextVar = contextvars.ContextVar("observer_cad_progress", default=None)


def report(message: str, *, stage: bool = False) -> None:
    """Tell the active reporter (if any) where the computation is; cheap when none.
    ``stage=True`` marks a change of stage (printed even within ``every`` seconds of the
    previous line); steps inside a loop leave it False."""
    rep = _current.get()
    if rep is not None:
        rep(message, stage=stage)


@contextlib.contextmanager
def reporting(reporter: Reporter | None = None, **options):
    """Make ``reporter`` (default: ``Reporter(**options)`` on stderr) active in the block."""
    rep = reporter if reporter is not None else Reporter(**options)
    token = _current.set(rep)
    stop = threading.Event()
    beater = None
    if rep.enabled and rep.heartbeat is not None:  # a daemon: never keeps the process alive
        def loop():
            while not stop.wait(0.5):
                rep.beat()
        beater = threading.Thread(target=loop, name="observer-cad-progress", daemon=True)
        beater.start()
    try:
        yield rep
    finally:
        stop.set()
        if beater is not None:
            beater.join(timeout=1.0)
        _current.reset(token)


@contextlib.contextmanager
def silenced():
    """No progress line from the active reporter in the block (while a progress bar
    draws on the same stream)."""
    rep = _current.get()
    if rep is None:
        yield
        return
    with rep._lock:
        was, rep.enabled = rep.enabled, False
    try:
        yield
    finally:
        with rep._lock:
            rep.enabled = was
