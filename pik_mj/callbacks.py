"""Per-step callbacks: one callable or a list of them, checked where they enter.

:func:`pik_mj.solve` (an :class:`~pik_mj.solve.IterationInfo` per iteration) and
:meth:`pik_mj.sim.Scene.hold` (a :class:`~pik_mj.sim.HoldSample` every few
steps) call each callback of the list in order, so per-step work is composed in
the open: ``callback=[checks, recorder.solve_logger("reach", checks=checks),
Progress("reach")]`` (the static checks run first, so the logger sees them).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from pik_mj.exceptions import InvalidInput

Callback = Callable[[Any], None]


def as_callbacks(callback: Callback | Sequence[Callback] | None) -> list[Callback]:
    """The callbacks of ``callback`` (None, one callable, or a sequence of them).

    Raises:
        InvalidInput: An entry is not callable (raised before anything runs).
    """
    if callback is None:
        return []
    if callable(callback):
        return [callback]
    if isinstance(callback, (str, bytes)) or not isinstance(callback, Sequence):
        raise InvalidInput(
            "callback must be a callable or a list of callables (each called with the "
            f"step's information), got {callback!r} ({type(callback).__name__})"
        )
    out = list(callback)
    for i, c in enumerate(out):
        if not callable(c):
            raise InvalidInput(
                f"callback[{i}] must be callable (every entry of the list is called with "
                f"the step's information), got {c!r} ({type(c).__name__})"
            )
    return out
