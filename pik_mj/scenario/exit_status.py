"""Exit statuses of pik_mj's commands (``pik-mj``, ``python -m pik_mj.sweep``, a
scenario's ``main``), and the guard that turns a usage error or Ctrl-C into one.

* 0 (:data:`EXIT_PASSED`): every check held (a sweep: every case ran);
* 1 (:data:`EXIT_FAILED`): a check failed, the work raised, or an output could
  not be written completely (:class:`~pik_mj.exceptions.OutputError`: a full
  disk; one line naming the file);
* 2 (:data:`EXIT_USAGE`): bad usage, reported in one line without a traceback;
* 130 (:data:`EXIT_INTERRUPTED`): interrupted (Ctrl-C);
* 141 (:data:`EXIT_CLOSED_PIPE`): standard output was closed by its reader
  (``pik-mj list | head -c 10``), as for a process ended by ``SIGPIPE``; quietly.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable

from pik_mj.exceptions import OutputError, PikError

EXIT_PASSED, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
EXIT_CLOSED_PIPE = 128 + 13  # SIGPIPE


def exit_code(exc: SystemExit) -> int:
    """The exit status of argparse's SystemExit (--help: 0, a usage error: 2)."""
    if exc.code is None:
        return EXIT_PASSED
    return exc.code if isinstance(exc.code, int) else EXIT_USAGE


def guarded(command: Callable[[], int], prog: str = "pik-mj") -> int:
    """Run ``command`` and return its exit status; argparse's exit (``--help``, a usage
    error, already printed) gives its status, a closed standard output 141 quietly
    (:func:`closed_pipe`), an
    :class:`~pik_mj.exceptions.OutputError` one line on stderr and 1, another
    :class:`~pik_mj.exceptions.PikError` one line on stderr and 2, Ctrl-C 130 once
    the command has unwound."""
    try:
        status = _status(command, prog)
        sys.stdout.flush()  # a reader gone shows here, not in the interpreter's last flush
        return status
    except BrokenPipeError:
        return closed_pipe()


def _status(command: Callable[[], int], prog: str) -> int:
    """``command``'s exit status, every outcome but a closed standard output mapped
    to one (see :func:`guarded`)."""
    try:
        return command()
    except SystemExit as exc:
        return exit_code(exc)
    except OutputError as exc:  # the work ran, its output is lost or incomplete
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except PikError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def closed_pipe() -> int:
    """Standard output's reader is gone: point it at ``/dev/null`` (so that the
    interpreter's last flush does not complain) and return :data:`EXIT_CLOSED_PIPE`."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)
    return EXIT_CLOSED_PIPE
