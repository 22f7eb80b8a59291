"""A progress display for solves: a callback of :func:`pik_mj.solve` (or the IK
wrappers) that shows how far a solve is.

On a terminal the line is redrawn in place (``\\r``) as a bar of the iterations
run out of ``total``; on anything else (a pipe, a log file, a CI job) it prints
one plain line per iteration, so the output stays readable. :meth:`Progress.finish`
ends the line with the solve's outcome::

    progress = Progress("reach", total=100)
    result = fullbody_inverse_kinematics(robot, ..., stop=100, callback=[checks, progress])
    progress.finish(result)
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

from pik_mj.exceptions import InvalidInput

__all__ = ["Progress"]


class Progress:
    """Per-iteration progress of one solve.

    Args:
        label: What is solved (printed first).
        total: Most iterations the solve may run (its ``stop``), for the bar; None
            shows a counter instead.
        stream: Where to write (default ``sys.stderr``); None writes nothing.
        width: Bar width [characters].

    Attributes:
        iterations: Iterations seen so far.
        elapsed: Sum of their wall times [s].
    """

    def __init__(
        self,
        label: str,
        *,
        total: int | None = None,
        stream: TextIO | Any | None = sys.stderr,
        width: int = 30,
    ):
        if total is not None and (not isinstance(total, int) or total < 1):
            raise InvalidInput(f"total must be a positive number of iterations, got {total!r}")
        self.label = str(label)
        self.total = total
        self.stream = stream
        self.width = int(width)
        self.iterations = 0
        self.elapsed = 0.0
        isatty = getattr(stream, "isatty", None)
        self.terminal = bool(isatty()) if callable(isatty) else False

    def line(self) -> str:
        """The text shown now (no line ending)."""
        ms = 1e3 * self.elapsed / max(self.iterations, 1)
        if self.total is None:
            return f"{self.label}: iteration {self.iterations:4d} ({ms:.1f} ms/iteration)"
        done = min(self.iterations, self.total)
        n = round(self.width * done / self.total)
        bar = "#" * n + "." * (self.width - n)
        return f"{self.label} [{bar}] iteration {done}/{self.total} ({ms:.1f} ms/iteration)"

    def __call__(self, info: Any) -> None:
        """Count one iteration (an :class:`~pik_mj.solve.IterationInfo`)."""
        self.iterations = int(info.iteration)
        self.elapsed += float(info.elapsed)
        if self.stream is None:
            return
        if self.terminal:
            self.stream.write("\r" + self.line())
        else:
            self.stream.write(self.line() + "\n")
        self.stream.flush()

    def finish(self, result: Any) -> None:
        """End the display with the outcome of ``result`` (a
        :class:`~pik_mj.solve.SolveResult`)."""
        if self.stream is None:
            return
        outcome = "converged" if result.converged else "NOT converged"
        if getattr(result, "reverted", False):
            outcome += ", reverted"
        text = f"{self.label}: {result.iterations} iterations, {outcome}"
        # on a terminal: over the bar, clearing the rest of its line (ANSI EL)
        self.stream.write(f"\r{text}\x1b[K\n" if self.terminal else text + "\n")
        self.stream.flush()
