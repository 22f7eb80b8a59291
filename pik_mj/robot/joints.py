"""The joints of a robot in a model: its angle vector (hinge and slide joints, by
name), their ``qpos`` addresses and limits, its free joint and its part of ``qpos``.

The robot is the subtree of one top-level body (:func:`pik_mj.frames.robot_root_body`);
a model may hold more (an environment's objects), whose joints are not the robot's.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, UnknownName

QPOS_SIZE = {
    int(mujoco.mjtJoint.mjJNT_FREE): 7,
    int(mujoco.mjtJoint.mjJNT_BALL): 4,
    int(mujoco.mjtJoint.mjJNT_SLIDE): 1,
    int(mujoco.mjtJoint.mjJNT_HINGE): 1,
}
"""Entries of ``qpos`` of each MuJoCo joint type."""

ANGLE_JOINT_TYPES = (
    int(mujoco.mjtJoint.mjJNT_HINGE),
    int(mujoco.mjtJoint.mjJNT_SLIDE),
)
"""The joint types of an angle vector (irteus ``:angle-vector``): one value each."""


class RobotJoints:
    """The joints of the robot whose top-level body is ``root_id`` in ``model``.

    Args:
        model: The compiled model.
        root_id: Id of the robot's top-level body.

    Attributes:
        ids: Every joint of the robot (free, ball, hinge, slide), in model order.
        angle_ids: Its hinge and slide joints (the angle vector), in model order.
        names: Their names, in the same order.
    """

    def __init__(self, model: mujoco.MjModel, root_id: int):
        self.model = model
        self.root_id = int(root_id)
        in_robot = model.body_rootid[model.jnt_bodyid] == self.root_id
        self.ids = np.flatnonzero(in_robot)
        self.angle_ids = np.flatnonzero(in_robot & np.isin(model.jnt_type, ANGLE_JOINT_TYPES))
        self.names: list[str] = [
            mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(j)) or ""
            for j in self.angle_ids
        ]
        self._index = {n: i for i, n in enumerate(self.names)}

    def angle_joint_id(self, name: str) -> int:
        """Id of the robot's hinge or slide joint ``name``.

        Raises:
            InvalidInput: ``name`` is a ball or free joint of the robot.
            UnknownName: The robot has no joint ``name`` (lists its angle joints).
        """
        i = self._index.get(name)
        if i is not None:
            return int(self.angle_ids[i])
        j = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if j >= 0 and j in self.ids:
            kind = mujoco.mjtJoint(self.model.jnt_type[j]).name
            raise InvalidInput(
                f"joint {name!r} is a {kind} joint; angle vectors hold only hinge "
                "and slide joints (use set_root_pose for the free joint)"
            )
        raise UnknownName("joint", name, self.names)

    def angle_ids_of(self, names: Sequence[str] | None) -> np.ndarray:
        """Joint ids of the hinge/slide joints ``names`` (all of :attr:`names` if None).

        Raises:
            InvalidInput: ``names`` is not a list of names, or holds a ball/free joint.
            UnknownName: A joint the robot does not have.
        """
        if names is None:
            return self.angle_ids
        names = inputs.names(names, "names (of joints)")
        return np.array([self.angle_joint_id(n) for n in names], dtype=int)

    def qpos_addresses(self, names: Sequence[str] | None) -> np.ndarray:
        """Indices in ``qpos`` of the hinge/slide joints ``names`` (all if None)."""
        return self.model.jnt_qposadr[self.angle_ids_of(names)]

    def free_qposadr(self) -> int | None:
        """Index in ``qpos`` of the root body's free joint, or None without one."""
        j = self.model.body_jntadr[self.root_id]
        if j >= 0 and self.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            return int(self.model.jnt_qposadr[j])
        return None

    def qpos_end(self) -> int:
        """One past the last ``qpos`` entry of the robot's joints (0 without joints)."""
        ends = [
            int(self.model.jnt_qposadr[j]) + QPOS_SIZE[int(self.model.jnt_type[j])]
            for j in self.ids
        ]
        return max(ends, default=0)

    def limits(self, names: Sequence[str] | None) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper limits [rad or m] of the hinge/slide joints ``names`` (all if
        None); ±inf where unlimited."""
        ids = self.angle_ids_of(names)
        limited = self.model.jnt_limited[ids].astype(bool)
        lower = np.where(limited, self.model.jnt_range[ids, 0], -np.inf)
        upper = np.where(limited, self.model.jnt_range[ids, 1], np.inf)
        return lower, upper
