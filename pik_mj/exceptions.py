"""Exceptions raised by pik_mj. Every one derives from :class:`PikError`."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
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


class NoCollisionGeometry(InvalidInput):
    """The bodies asked about carry no collision geom: nothing of them touches a floor."""


class LimbsNotFound(InvalidInput):
    """The kinematic tree does not give the limbs asked for.

    The message lists what the search saw, the limbs found (name, joint count, end
    frame) and how to describe the limbs instead.

    Attributes:
        found: The limbs that were found, by name (:class:`pik_mj.robot.Limb`).
        details: What the search saw (standing pose, touching bodies, branches).
    """

    HINT = (
        "Describe the limbs instead: a robot description file (TOML), e.g.\n"
        "    [limbs.rarm]\n"
        '    end = "right_hand"          # a site or body; joints: from the branch to it\n'
        "    [limbs.rleg]\n"
        '    end = "right_foot"\n'
        '    joints = ["right_hip", "right_knee", "right_ankle"]   # optional\n'
        "given as Robot.from_model(model, description=PATH), or on the command line as\n"
        "    pik-mj run fullbody_reach --model MODEL --description PATH"
    )

    def __init__(self, message: str, found: Mapping[str, Any], details: Sequence[str]):
        self.found = dict(found)
        self.details = list(details)
        summary = ", ".join(
            f"{n} ({len(x.joints)} joints → {x.end_frame_type} {x.end_frame!r})"
            for n, x in self.found.items()
        )
        lines = [message, *(f"  {d}" for d in self.details)]
        lines.append(f"  limbs found: {summary or 'none'}")
        lines.append(self.HINT)
        super().__init__("\n".join(lines))


class OptionError(InvalidInput):
    """A scenario option the user gave cannot be used (e.g. no viewer at
    ``--connect``'s address): ``pik-mj run`` exits 2 with the message, no traceback."""


class RenderingUnavailable(PikError):
    """No OpenGL backend can render offscreen in this process."""


class ScenarioWaiting(PikError):
    """A scenario needs a pik_mj module that does not exist yet.

    Attributes:
        missing: Name of that module.
    """

    def __init__(self, name: str, missing: str):
        super().__init__(f"scenario {name!r} is waiting for {missing} (not available yet)")
        self.missing = missing


class OutputError(PikError):
    """An output could not be written completely (a full disk, an I/O error): the
    message names the file, the operating system's reason and what is left of it.
    ``pik-mj`` exits 1 with the message, no traceback."""


class WriterBusy(InvalidInput):
    """A file or directory is being written by another writer (a second
    ``Recorder`` on one ``.rrd``, a second ``pik-mj sweep`` on one directory).

    Attributes:
        path: What is being written.
        holder: Who holds it (``"pid 123 on host"``), or None when unknown.
    """

    def __init__(self, what: str, path: str, holder: str | None):
        by = f" by {holder}" if holder else " by another writer"
        super().__init__(
            f"{what} {path!r} is being written{by}; wait for it to finish, stop it, "
            "or write elsewhere"
        )
        self.path = path
        self.holder = holder
