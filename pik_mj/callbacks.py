"""Per-step callbacks: one callable or a list of them, checked where they enter.

:func:`pik_mj.solve` (an :class:`~pik_mj.solve.IterationInfo` per iteration) and
:meth:`pik_mj.sim.Scene.hold` (a :class:`~pik_mj.sim.HoldSample` every few
steps) call each callback of the list in order, so per-step work is composed in
the open: ``callback=[checks, recorder.solve_logger("reach", checks=checks),
Progress("reach")]`` (the static checks run first, so the logger sees them).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from pik_mj.exceptions import InvalidInput

Callback = Callable[[Any], None]

CALL_EVERY = "call_every"
"""The attribute by which a physics callback says how many steps apart it needs
its calls (an int >= 1, e.g. a recorder's loggers: the viewer's rate); a
callback without it is called every step, the slow path (a Python call per
step)."""


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


def call_stride(callbacks: Sequence[Callback], every: int | None = None) -> int:
    """Steps between the calls of physics ``callbacks``: ``every`` when given,
    else the greatest common divisor of their :data:`CALL_EVERY` (so each is
    called at every multiple of its own; 1 if any has none, or without
    callbacks)."""
    if every is not None:
        return every
    strides = [getattr(c, CALL_EVERY, 1) for c in callbacks]
    return math.gcd(*strides) if strides else 1
