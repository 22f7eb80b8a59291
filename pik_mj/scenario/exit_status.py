"""Exit statuses of pik_mj's commands (``pik-mj``, ``python -m pik_mj.sweep``, a
scenario's ``main``), and the guard that turns a usage error or Ctrl-C into one.

* 0 (:data:`EXIT_PASSED`): every check held (a sweep: every case ran);
* 1 (:data:`EXIT_FAILED`): a check failed, or the work raised;
* 2 (:data:`EXIT_USAGE`): bad usage, reported in one line without a traceback;
* 130 (:data:`EXIT_INTERRUPTED`): interrupted (Ctrl-C).
"""

from __future__ import annotations

import sys
from collections.abc import Callable

from pik_mj.exceptions import PikError

EXIT_PASSED, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


def exit_code(exc: SystemExit) -> int:
    """The exit status of argparse's SystemExit (--help: 0, a usage error: 2)."""
    if exc.code is None:
        return EXIT_PASSED
    return exc.code if isinstance(exc.code, int) else EXIT_USAGE


def guarded(command: Callable[[], int], prog: str = "pik-mj") -> int:
    """Run ``command`` and return its exit status; argparse's exit (``--help``, a usage
    error, already printed) gives its status, a :class:`~pik_mj.exceptions.PikError`
    one line on stderr and 2, Ctrl-C 130 once the command has unwound."""
    try:
        return command()
    except SystemExit as exc:
        return exit_code(exc)
    except PikError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
