"""A path of configurations collected from solves: :class:`Waypoints`.

A solve's iterates (or the iterates of a sequence of solves) are a path in
configuration space. :class:`Waypoints` collects them in the open, as a
per-iteration callback::

    path = Waypoints(robot)                               # the start pose
    result = fullbody_inverse_kinematics(..., callback=[checks, log, path.segment("reach")])
    motion = scene.play(path)                             # a MotionReport

It notes the solves' frame tasks (whose frames the playback compares with the
reference) and joint velocity tasks (whose bounds time the steps,
:func:`pik_mj.sim.reference.velocity_limits`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.solve import IterationInfo, SolveResult
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.joint_velocity import JointVelocityTask

__all__ = ["Waypoint", "Waypoints"]


@dataclass(frozen=True)
class Waypoint:
    """One configuration of a path.

    Attributes:
        q: Robot configuration (the robot model's ``nq``).
        segment: Label of the solve it comes from (the start pose: the first label).
        iteration: Iteration of that solve (0: the pose the solve started from).
    """

    q: np.ndarray
    segment: str
    iteration: int


class Waypoints:
    """A path of configurations, collected from solves (a per-iteration callback).

    Called with each :class:`~pik_mj.solve.IterationInfo`, it appends the
    configuration after the iteration, and notes the solve's frame tasks (whose
    frames :func:`play` compares with the reference) and joint velocity tasks
    (whose bounds time the steps). Successive solves append to the same path;
    :meth:`segment` names the next one, :meth:`finish` drops the iterates of a
    solve that reverted (the robot is back at its start).

    Args:
        start: The start pose: a :class:`pik_mj.Robot` (its current
            configuration), a ``mink.Configuration``, or a configuration.
        label: Label of the first segment.
    """

    def __init__(self, start: Any, label: str = "solve"):
        if hasattr(start, "configuration"):
            q0 = start.configuration.q
        elif isinstance(start, mink.Configuration):
            q0 = start.q
        else:
            q0 = start
        q0 = np.array(q0, dtype=float).reshape(-1)
        if not np.all(np.isfinite(q0)):
            raise InvalidInput("the start configuration of Waypoints holds NaN or inf")
        self.items: list[Waypoint] = [Waypoint(q0, str(label), 0)]
        self.label = str(label)
        self._first = 1  # index of the current segment's first iterate
        self.frames: dict[str, str] = {}  # move-target name -> frame type
        self.velocity_bounds: dict[int, tuple[float, float]] = {}  # dof -> (min, max)
        self._levels: Any = None

    def segment(self, label: str) -> Waypoints:
        """Start the segment ``label`` (the next solve's iterates); returns self,
        so that ``callback=[..., path.segment("grasp")]`` reads as what it does.
        The start pose belongs to the first segment."""
        self.label = str(label)
        if len(self.items) == 1:
            self.items[0] = Waypoint(self.items[0].q, self.label, 0)
        self._first = len(self.items)
        return self

    def __call__(self, info: IterationInfo) -> None:
        if info.levels is not self._levels:
            self._levels = info.levels
            self._note_tasks(info.levels)
        q = np.array(info.configuration.q, dtype=float)
        if q.shape != self.items[0].q.shape:
            raise InvalidInput(
                f"the solve's configuration has {q.size} entries, the path's start "
                f"{self.items[0].q.size}: collect one robot's solves in one path"
            )
        self.items.append(Waypoint(q, self.label, int(info.iteration)))

    def _note_tasks(self, levels: Sequence[Sequence[Any]]) -> None:
        for task in (t for level in levels for t in level):
            if isinstance(task, FrameTask):
                self.frames.setdefault(task.move_target.name, task.move_target.frame_type)
            elif isinstance(task, JointVelocityTask):
                for dof, lo, hi in zip(task.dofs, task.min_vel, task.max_vel, strict=True):
                    self.velocity_bounds[int(dof)] = (float(lo), float(hi))

    def check_finite(self, model: mujoco.MjModel) -> None:
        """Raise unless every configuration of the path is finite.

        Args:
            model: The model whose ``qpos`` the configurations are (a prefix of
                it): it names the joint.

        Raises:
            InvalidInput: The first waypoint holding NaN or inf: its index,
                segment and iteration, and the joint of the entry.
        """
        q = self.q
        bad = np.argwhere(~np.isfinite(q))
        if not len(bad):
            return
        i, k = (int(v) for v in bad[0])
        w = self.items[i]
        joint = int(np.searchsorted(model.jnt_qposadr, k, side="right")) - 1
        name = model.joint(joint).name if joint >= 0 else f"qpos[{k}]"
        raise InvalidInput(
            f"waypoint {i} of {len(self.items)} (segment {w.segment!r}, iteration "
            f"{w.iteration}) is not finite: joint {name!r} (qpos[{k}]) = {q[i, k]}; "
            "give finite configurations"
        )

    def finish(self, result: SolveResult) -> SolveResult:
        """Drop the current segment's iterates if ``result`` reverted; returns it."""
        if result.reverted:
            del self.items[self._first :]
        return result

    @property
    def q(self) -> np.ndarray:
        """The configurations (N, nq)."""
        return np.array([w.q for w in self.items])

    def __len__(self) -> int:
        return len(self.items)

    def __repr__(self) -> str:
        labels = list(dict.fromkeys(w.segment for w in self.items))
        return f"Waypoints({len(self.items)} configurations, segments={labels})"
