"""The world in the stack: the robot kept clear of its world's geometry.

:func:`pik_mj.ik.inverse_kinematics` and :func:`pik_mj.ik.fullbody_inverse_kinematics`
add, by default, a :class:`~pik_mj.tasks.collision.CollisionAvoidanceTask` on the
pairs of a robot geom and a world geom (the floor, a counter, a wall, a kettle)
that MuJoCo collides (:func:`pik_mj.robot.collisions.world_collision_pairs`), in a
level of its own directly above the targets: a target that would need a
collision is given up, not the clearance. Left out: pairs already touching at
the start (the feet on the floor, a hand on a handle), the planned contacts
(:attr:`WorldAvoidance.allowed`: the hand meant to touch the wall) and pairs
whose distance the solved joints cannot change. ``avoid_world=False`` turns it
off; a :class:`WorldAvoidance` sets its zones and planned contacts.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.robot import Robot
from pik_mj.robot.collisions import Allowed, world_collision_pairs
from pik_mj.tasks.collision import DEFAULT_YELLOW, CollisionAvoidanceTask

__all__ = ["WorldAvoidance", "world_avoidance"]


@dataclass(frozen=True)
class WorldAvoidance:
    """How a solve keeps the robot clear of its world.

    Attributes:
        clearance: Distance kept between the robot and the world [m] (irteus'
            orange zone, 0.1 of the yellow one); a pair nearer than that at the
            start keeps its start distance instead.
        reach: Pairs nearer than this [m] give rows (irteus' yellow zone,
            ``avoid-collision-distance``, ``> clearance``); farther pairs cost one
            bounding-volume test. Each step is linearized: a pair farther than
            this when a step starts has no row in it, so ``reach`` must exceed how
            far one step moves a link.
        gain: Velocity-damper gain in (0, 1]: a step closes at most this
            fraction of a pair's gap to ``clearance``.
        allowed: Planned contacts, let touch: a geom or body name (every pair
            with its geoms), or a pair of names (``("rarm_hand", "wall")``).
        touching: Pairs this near [m] at the start are contacts the robot
            already makes (feet on the floor), not watched.
    """

    clearance: float = 0.02
    reach: float = DEFAULT_YELLOW
    gain: float = 0.5
    allowed: Allowed = ()
    touching: float = 1e-3

    def __post_init__(self) -> None:
        inputs.real(self.clearance, "clearance", unit="m", low=0.0)
        inputs.real(self.reach, "reach", unit="m", low=self.clearance, low_open=True)
        inputs.real(self.gain, "gain", low=0.0, high=1.0, low_open=True)
        inputs.real(self.touching, "touching", unit="m", low=0.0)
        if isinstance(self.allowed, str) or not isinstance(self.allowed, Sequence):
            raise InvalidInput(
                f"allowed must be a list of names or pairs of names, got {self.allowed!r}"
            )


def world_avoidance(
    robot: Robot, avoid_world: Any, dofs: np.ndarray
) -> CollisionAvoidanceTask | None:
    """The world-avoidance task of a solve moving ``dofs`` (tangent-space indices),
    or None when ``avoid_world`` is False or no pair is left to watch.

    Args:
        robot: The robot at the solve's start.
        avoid_world: True (:class:`WorldAvoidance` defaults), False, or a
            :class:`WorldAvoidance`.
        dofs: The degrees of freedom the solve moves.

    Raises:
        InvalidInput: ``avoid_world`` is none of those; a bad planned contact.
        UnknownName: A planned contact naming neither a geom nor a body.
    """
    if avoid_world is False or avoid_world is None:
        return None
    if avoid_world is True:
        avoid_world = WorldAvoidance()
    if not isinstance(avoid_world, WorldAvoidance):
        raise InvalidInput(
            f"avoid_world must be True, False or a pik_mj.WorldAvoidance, got {avoid_world!r}"
        )
    pairs = world_collision_pairs(
        robot, dofs, allowed=avoid_world.allowed, touching=avoid_world.touching
    )
    if not pairs:
        return None
    return CollisionAvoidanceTask(
        robot.configuration,
        pairs,
        yellow=avoid_world.reach,
        orange=avoid_world.clearance,
        gain=avoid_world.gain,
        name="avoid_world",
    )
