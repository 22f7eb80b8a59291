"""The IK stack of a walk's ticks (:func:`pik_mj.walking.wholebody.calc_walk_pattern`)
and the bent knees it starts from.

* level 0 (hard): joint limits and the MJCF couplings
  (:func:`pik_mj.robot.stack.guard_level`), and self-collision: every pair of the
  robot's geoms MuJoCo collides (:func:`pik_mj.tasks.collision_pairs`, as the
  robot ships: ``<contact><pair>``, ``<exclude>``, ``contype``/``conaffinity``)
  kept apart (:class:`~pik_mj.tasks.CollisionAvoidanceTask`);
* level 1: both soles on their planned poses (position, heading, sole flat) and
  the CoM on the preview trajectory (xy) at the cart-table height (z);
* level 2: the root body upright with the mid-feet heading, the joints other
  than the legs' at the walk's pose (the legs carry the CoM, not the waist);
* level 3: posture towards the first tick's pose (:data:`POSTURE_WEIGHT`).

**Rolling soles** (``rolling_soles``), for legs without a joint that keeps a sole
flat while the leg leans sideways (no ankle roll: Unitree H1). With both soles
flat, each leg's hip roll axis stays a fixed horizontal distance :math:`w` from
its sole, and the pelvis carries the two axes a fixed distance :math:`d` apart: a
pelvis roll :math:`\\phi` needs :math:`d \\cos \\phi` = the axes' horizontal
distance, so :math:`\\phi = 0` and the pelvis can neither roll nor move
sideways. The lock is of second order: a sole rolled by :math:`\\psi` about its
long (x) axis moves its hip roll axis by :math:`L \\sin \\psi` (:math:`L` the
hip's height above the sole), and :math:`d (1 - \\cos \\phi) = 2 L \\sin \\psi` gives
:math:`\\phi` of tens of degrees for a fraction of a degree of sole roll. So level
1 leaves each sole's roll about its own x axis free and level 2 asks it flat,
below the CoM; the root's roll is free (level 2 keeps its pitch and heading):
the CoM sways by the pelvis rolling, the soles rolling only as much as the CoM
needs in double support (flat in single support).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import mink
import numpy as np

from pik_mj.robot import Robot
from pik_mj.robot.ground import Sole
from pik_mj.robot.stack import guard_level, posture_task
from pik_mj.spatial import rot_z
from pik_mj.tasks.collision import CollisionAvoidanceTask
from pik_mj.tasks.collision_pairs import collision_pairs
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.mink_adapter import MinkTask
from pik_mj.walking.gait import GaitPlan

__all__ = [
    "KNEE_BEND",
    "POSTURE_WEIGHT",
    "SELF_COLLISION_ORANGE",
    "SELF_COLLISION_YELLOW",
    "STRAIGHT_KNEE",
    "WalkTasks",
    "bent_knees",
    "flat_sole_tasks",
]

SELF_COLLISION_YELLOW = 0.05
"""[m] Robot geoms nearer than this get a self-collision row (irteus' yellow zone)."""
SELF_COLLISION_ORANGE = 0.005
"""[m] The distance robot geoms keep (irteus' orange zone; a pair nearer at the start
keeps its start distance)."""

POSTURE_WEIGHT = 1e-2
"""[cost/rad²] Cost of moving away from the first tick's pose (the last level)."""
KNEE_BEND = 0.4
"""[rad] How far :func:`bent_knees` bends a straight knee before the first tick."""
STRAIGHT_KNEE = float(np.sin(np.deg2rad(10.0)))
"""A knee bent by less than 10° is straight (:func:`bent_knees`)."""


def bent_knees(robot: Robot, legs: Sequence[str], bend: float = KNEE_BEND) -> np.ndarray:
    """The robot's configuration with each straight knee bent by ``bend`` [rad]: the
    first tick's start (the irteus manual's ``init-pose-function``). A straight leg
    is singular: lowering its hip to the walk's CoM height has no first-order
    knee motion, and the IK would crouch with the waist instead.

    A leg's knee is a pitch joint between its first and last (hip and ankle
    pitch; axes within 25° of lateral), of axis :math:`a` at anchor :math:`k`. Turning
    it moves the ankle :math:`p_A` along :math:`a \\times (p_A - k)`, which changes
    the hip–ankle distance :math:`\\|p_A - p_H\\|` at the rate

    .. math::

        \\sigma = \\frac{|u^T (a \\times (p_A - k))|}{\\|p_A - k\\|}, \\qquad
        u = \\frac{p_A - p_H}{\\|p_A - p_H\\|}

    (the sine of the knee's bend, 0 straight); a knee with :math:`\\sigma <`
    :data:`STRAIGHT_KNEE` turns towards the far end of its range.
    """
    model, data = robot.model, robot.data
    q = robot.configuration.q.copy()
    for leg in legs:
        joints = [model.joint(j).id for j in robot.limb(leg).joints]
        pitch = [j for j in joints if abs(data.xaxis[j][1]) > 0.9]
        if len(pitch) < 3:
            continue
        hip, ankle = data.xanchor[pitch[0]], data.xanchor[pitch[-1]]
        u = (ankle - hip) / max(float(np.linalg.norm(ankle - hip)), 1e-12)
        for knee in pitch[1:-1]:
            lever = ankle - data.xanchor[knee]
            rate = abs(u @ np.cross(data.xaxis[knee], lever)) / max(np.linalg.norm(lever), 1e-12)
            if rate >= STRAIGHT_KNEE:
                continue
            adr = model.jnt_qposadr[knee]
            lo, hi = model.jnt_range[knee] if model.jnt_limited[knee] else (-np.pi, np.pi)
            toward = hi if hi - q[adr] >= q[adr] - lo else lo
            q[adr] += np.clip(toward - q[adr], -bend, bend)
    return q


@dataclass(frozen=True)
class WalkTasks:
    """The IK stack of a walk's ticks (module docstring) and its tasks.

    Attributes:
        feet: Each leg's sole task (level 1; its roll free with rolling soles).
        soles: Each leg's sole.
        com: The CoM task (level 1).
        upright: The root upright with the mid-feet heading (level 2; its roll
            free with rolling soles).
        levels: The stack, level 0 first.
        pairs: Self-collision pairs kept apart at level 0.
        flat: Each leg's sole kept flat (level 2) with rolling soles, else empty.
    """

    feet: dict[str, FrameTask]
    soles: dict[str, Sole]
    com: CentroidTask
    upright: FrameTask
    levels: list[list[Any]]
    pairs: int
    flat: dict[str, FrameTask] = field(default_factory=dict)

    @property
    def postures(self) -> list[mink.PostureTask]:
        """The posture tasks (upper body, whole body), their targets the walk's pose."""
        return [self.levels[2][-1].task, self.levels[3][0].task]

    @classmethod
    def of(
        cls,
        robot: Robot,
        soles: Mapping[str, Sole],
        upright_body: str,
        thre: float,
        rthre: float,
        self_collision: bool,
        rolling_soles: bool = False,
    ) -> WalkTasks:
        """The stack of ``robot`` walking on ``soles`` (module docstring); ``thre``
        [m] and ``rthre`` [rad] the soles' and CoM's stop tolerances."""
        configuration = robot.configuration
        roll = "x" if rolling_soles else True  # "x": the rotation about x left free
        feet = {
            leg: FrameTask(
                configuration,
                sole.body,
                (robot.data.xpos[robot.model.body(sole.body).id].copy(), np.eye(3)),
                move_target_type="body",
                rotation_axis=roll,
                thre=thre,
                rthre=rthre,
                name=f"foot:{leg}",
            )
            for leg, sole in soles.items()
        }
        com = CentroidTask(
            configuration, np.zeros(3), translation_axis=True, centroid_thre=thre, name="com"
        )
        upright = FrameTask(
            configuration,
            upright_body,
            (np.zeros(3), np.eye(3)),
            move_target_type="body",
            translation_axis=None,
            rotation_axis=roll,
            rthre=rthre,
            name=f"upright:{upright_body}",
        )
        adr = robot.model.jnt_dofadr[robot.model.body_jntadr[robot.root_body_id]]
        guard = guard_level(configuration, robot.joint_names, range(adr, adr + 6))
        pairs = _self_collision(robot) if self_collision else None
        if pairs is not None:
            guard.append(pairs)
        upper = _upper_body_posture(robot, soles)
        flat = flat_sole_tasks(robot, soles) if rolling_soles else {}
        levels: list[list[Any]] = [
            guard,
            [*feet.values(), com],
            [*flat.values(), upright, upper],
            [posture_task(configuration, POSTURE_WEIGHT)],
        ]
        n_pairs = 0 if pairs is None else len(pairs.pairs)
        return cls(feet, dict(soles), com, upright, levels, n_pairs, flat)

    def aim(self, plan: GaitPlan, k: int, com_ref: np.ndarray) -> None:
        """Set the targets to the plan's tick ``k``: each foot body where its sole
        lands on the plan (:math:`X_{WS}^* X_{BS}^{-1}`), the CoM ``com_ref`` [m],
        the root upright with the mid-feet heading."""
        yaw_mid = 0.0
        for leg, task in self.feet.items():
            sole = self.soles[leg]
            yaw = float(plan.feet_yaw[leg][k])
            R_WB = rot_z(yaw) @ sole.R_BS.T
            target = (plan.feet_p[leg][k] - R_WB @ sole.p_BS, R_WB)
            task.set_target(target)
            if leg in self.flat:
                self.flat[leg].set_target(target)
            yaw_mid += yaw / len(self.feet)
        self.com.set_target(com_ref)
        self.upright.set_target((np.zeros(3), rot_z(yaw_mid)))


def flat_sole_tasks(robot: Robot, soles: Mapping[str, Sole]) -> dict[str, FrameTask]:
    """Each foot body's roll about its x axis, to be kept flat below the soles'
    other rows (rolling soles, module docstring); targets set per tick."""
    return {
        leg: FrameTask(
            robot.configuration,
            sole.body,
            (np.zeros(3), np.eye(3)),
            move_target_type="body",
            translation_axis=None,
            rotation_axis="yz",
            name=f"flat:{leg}",
        )
        for leg, sole in soles.items()
    }


def _upper_body_posture(robot: Robot, soles: Mapping[str, Sole]) -> MinkTask:
    """Cost 1 [cost/rad²] on moving the joints of the robot that are not the legs'
    (``soles``) away from the walk's pose: the legs and the floating base carry the
    CoM, the waist and the arms stay."""
    model = robot.model
    legs = {j for leg in soles for j in robot.limb(leg).joints}
    cost = np.zeros(model.nv)
    for name in robot.joint_names:
        if name not in legs:
            cost[model.jnt_dofadr[model.joint(name).id]] = 1.0
    task = mink.PostureTask(model, cost=cost)
    task.set_target_from_configuration(robot.configuration)
    return MinkTask(task, name="upper_body_posture", check=False)


def _self_collision(robot: Robot) -> CollisionAvoidanceTask | None:
    """The self-collision rows of the walk (module docstring), or None when the
    robot's geoms never collide with each other."""
    model = robot.model
    bodies = [model.body(b).name for b in robot.bodies() if model.body_geomnum[model.body(b).id]]
    pairs = collision_pairs(model, robot.data, bodies)
    if not pairs:
        return None
    return CollisionAvoidanceTask(
        robot.configuration,
        pairs,
        yellow=SELF_COLLISION_YELLOW,
        orange=SELF_COLLISION_ORANGE,
        name="self_collision",
    )
