"""Command-line interface: ``observer-cad show|design|simulate|ensemble|monitor|codegen|analyze|demo``.

Every user error prints one line ``observer-cad: error: ...`` on stderr and exits with
status 2; a simulation that produced a value that is not finite (NaN, ±inf) exits with
status 4 (one line naming the first: time, signal, likely cause); no traceback is shown.

This module runs a command and turns its failures into those lines and exit statuses.
The rooms: the parser in ``_parser``; what the options ask for (model, design, observer,
threshold) in ``_from_args``; the commands by family — ``show`` and ``analyze`` in
``_model_commands``, ``design`` and ``codegen`` in ``_design_commands``, ``simulate`` and
``ensemble`` in ``_run_commands``, ``monitor`` in ``_monitor_command``, ``demo`` in ``_demo_command``.
"""
from __future__ import annotations

import sys

from ..errors import NonFiniteError, ObserverCadError, describe_failure
from ..progress import reporting
from ._demo_command import cmd_demo
from ._design_commands import cmd_codegen, cmd_design
from ._model_commands import cmd_analyze, cmd_show
from ._monitor_command import cmd_monitor
from ._parser import PROG, build_parser
from ._run_commands import cmd_ensemble, cmd_simulate

__all__ = ["main"]


def _terminate(signum, frame):  # pragma: no cover - exercised by a subprocess test
    """SIGTERM as an exception (exit 143): clean-up code runs (staging folders, temporary
    files), as for Ctrl-C; Python's default would end the process on the spot."""
    raise SystemExit(128 + signum)


def main(argv=None) -> int:
    """The ``observer-cad`` command (SIGTERM handled as an exit while it runs)."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        return _main(argv)
    old = signal.signal(signal.SIGTERM, _terminate)
    try:
        return _main(argv)
    finally:
        signal.signal(signal.SIGTERM, old)


def _main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 2
        run = {"show": cmd_show, "design": cmd_design, "simulate": cmd_simulate,
               "codegen": cmd_codegen, "analyze": cmd_analyze, "ensemble": cmd_ensemble,
               "monitor": cmd_monitor, "demo": cmd_demo}[args.command]
        if args.command == "demo":  # the demo prints its own progress
            return run(args)
        with reporting():  # stage lines on stderr after 2 s, on a terminal (progress.py)
            return run(args)
    except ObserverCadError as exc:
        msg = " / ".join(part.strip() for part in str(exc).splitlines() if part.strip())
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 4 if isinstance(exc, NonFiniteError) else 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as exc:  # noqa: BLE001 - never a bare traceback for the user
        internal, line = describe_failure(exc)
        if not internal:  # the environment's (a package not installed), not a bug
            print(f"{PROG}: error: {line}", file=sys.stderr)
            return 2
        print(f"{PROG}: {line} (please report this with the command that caused it)",
              file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
