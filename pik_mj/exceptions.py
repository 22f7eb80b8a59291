"""Exceptions raised by pik_mj. Every one derives from :class:`PikError`."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any


class PikError(Exception):
    """Root of every exception pik_mj raises."""


class InvalidInput(PikError, ValueError):
    """An argument has the wrong shape, type, or value (NaN/inf, inverted bounds)."""


class UnknownName(PikError, KeyError):
    """A name (body, site, joint, geom, limb, scenario, ...) that does not exist.

    The message lists the valid names so the caller can correct the call.
    """

    def __init__(self, kind: str, name: str, valid: Iterable[str]):
        self.kind = kind
        self.name = name
        self.valid = sorted(str(v) for v in valid)
        shown = self.valid if len(self.valid) <= 60 else [*self.valid[:60], "..."]
        super().__init__(f"{kind} {name!r} does not exist. Valid {kind} names: {shown}")

    def __str__(self) -> str:  # KeyError would print the repr of the message.
        return str(self.args[0])


class InfeasibleHardConstraints(PikError):
    """The hard rows of level 0 admit no step: the problem cannot be solved."""


class QPFailure(PikError):
    """A level's QP could not be solved.

    Attributes:
        level: Priority level (k >= 1) whose QP failed.
        status: Solver status string.
        problem: The problem that failed (a :class:`pik_mj.cascade.LevelProblem`),
            so the failure can be reproduced outside the solve loop.
    """

    def __init__(self, level: int, status: str, problem: Any = None):
        self.level = level
        self.status = status
        self.problem = problem
        super().__init__(f"QP of priority level {level} failed: {status}")


class SimulationUnstable(PikError):
    """MuJoCo reported a warning (instability, NaN state) while stepping."""
