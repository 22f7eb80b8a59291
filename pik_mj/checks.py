"""Checks of the levels a solve is given, where they enter: a list of lists of
tasks, each entry coerced to a :class:`~pik_mj.tasks.task.Task`.

Options are checked by :mod:`pik_mj.inputs` (numpy scalars accepted, bools
refused where a number is due), and so is the configuration
(:func:`pik_mj.inputs.mink_configuration`); tasks' rows are checked once at the
start of a solve (:func:`pik_mj.solve.evaluate_level`).
"""

from __future__ import annotations

from collections.abc import Sequence

from pik_mj.exceptions import InvalidInput
from pik_mj.inputs import mink_configuration
from pik_mj.tasks.mink_adapter import as_task
from pik_mj.tasks.task import Task

__all__ = ["check_configuration", "normalize_levels"]

check_configuration = mink_configuration
"""The configuration a solve starts from, checked (the name callers of this
module know :func:`pik_mj.inputs.mink_configuration` by)."""


def normalize_levels(levels: Sequence[Sequence[object]], dt: float) -> list[list[Task]]:
    """Coerce and validate the user's levels (level 0 hard, then priorities)."""
    if isinstance(levels, (str, bytes)) or not isinstance(levels, Sequence):
        raise InvalidInput("levels must be a list of lists of tasks: [[hard...], [level1...], ...]")
    if len(levels) < 2:
        raise InvalidInput(
            f"levels has {len(levels)} entries; give level 0 (hard rows, may be empty) "
            "and at least one level to solve"
        )
    out: list[list[Task]] = []
    for k, level in enumerate(levels):
        if not isinstance(level, Sequence) or isinstance(level, (str, bytes)):
            raise InvalidInput(f"level {k} must be a list of tasks, got {type(level).__name__}")
        if k > 0 and len(level) == 0:
            raise InvalidInput(f"level {k} is empty; every level after level 0 needs a task")
        out.append([as_task(t, dt) for t in level])
    return out
