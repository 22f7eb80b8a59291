"""Joint velocity limits (prioritized-IK manual: ``joint-velocity-task``).

One iteration of the solve loop is taken to last ``Δt`` (``periodic-time``),
so a velocity limit bounds the step on each degree of freedom:

.. math::

    \\dot\\theta_{min} \\Delta t \\le x + \\omega \\le \\dot\\theta_{max} \\Delta t

with ``θ̇`` in [rad/s] or [m/s] (a ball joint's three and a free joint's six
tangent components: linear world velocity, then body angular velocity).
"""

from __future__ import annotations

from collections.abc import Sequence

import mink
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.tasks.joint_limit import joint_list, per_entry
from pik_mj.tasks.task import Task, TaskRows, diagonal_weights

DEFAULT_PERIODIC_TIME = 0.05
"""The prioritized-IK manual's default ``periodic-time`` [s]."""


def _per_dof(value, n: int, what: str) -> np.ndarray:
    return per_entry(value, n, what, "degree of freedom")


class JointVelocityTask(Task):
    """Per-iteration step bounds from joint velocity limits.

    Args:
        configuration: Robot configuration (for name lookup).
        joints: A joint name or names (any type).
        max_vel: Upper velocity limits [rad/s or m/s], float or one per degree
            of freedom of ``joints`` (in order). MuJoCo models carry no velocity
            limits, so this is required.
        min_vel: Lower limits; default ``-max_vel``.
        periodic_time: ``Δt`` of one iteration [s] (> 0).
        w: Slack weight(s), float or one per degree of freedom.
        check: Whether the solve loop's stop test looks at this task (it holds
            whenever ``min_vel <= 0 <= max_vel``).
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        joints: str | Sequence[str],
        max_vel: float | Sequence[float],
        min_vel: float | Sequence[float] | None = None,
        *,
        periodic_time: float = DEFAULT_PERIODIC_TIME,
        w: float | Sequence[float] = 1.0,
        check: bool = True,
        name: str | None = None,
    ):
        model = configuration.model
        self.joints = joint_list(
            model, joints, ("hinge", "slide", "ball", "free"), "JointVelocityTask joint"
        )
        self.dofs = np.concatenate([j.dofs for j in self.joints])
        n = self.dofs.size
        self.max_vel = _per_dof(max_vel, n, "max_vel")
        self.min_vel = -self.max_vel if min_vel is None else _per_dof(min_vel, n, "min_vel")
        if np.any(self.min_vel > self.max_vel):
            i = int(np.argmax(self.min_vel > self.max_vel))
            raise InvalidInput(
                f"inverted velocity limits on degree of freedom {i}: "
                f"min_vel {self.min_vel[i]} > max_vel {self.max_vel[i]}"
            )
        if not (np.isfinite(periodic_time) and periodic_time > 0):
            raise InvalidInput(f"periodic_time must be a finite time > 0 [s], got {periodic_time}")
        self.periodic_time = float(periodic_time)
        self.w = diagonal_weights(w, n, "w")
        if np.any(self.w <= 0):
            raise InvalidInput(f"slack weights w must be > 0, got {self.w}")
        self.check = check
        names = [j.name for j in self.joints]
        self.name = name or (f"velocity:{names[0]}" if len(names) == 1 else "velocity")
        self._C = np.zeros((n, model.nv))
        self._C[np.arange(n), self.dofs] = 1.0

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        dt = self.periodic_time
        return TaskRows.inequality(self._C, self.min_vel * dt, self.max_vel * dt, self.w)

    def __repr__(self) -> str:
        return (
            f"JointVelocityTask(name={self.name!r}, joints={[j.name for j in self.joints]}, "
            f"periodic_time={self.periodic_time})"
        )
