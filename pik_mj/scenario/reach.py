"""Where an arm's hand can go: the hand frame's poses at configurations of the arm
sampled uniformly within its joint ranges, placed by MuJoCo's forward kinematics
(``mj_kinematics``), the rest of the robot as it stands.

A joint without limits is sampled over ``[-π, π]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.frames import Frame
from pik_mj.robot import Robot
from pik_mj.scenario.stature import Hand

UNLIMITED = np.pi
"""Half range [rad] sampled for a joint without limits."""


@dataclass(frozen=True)
class ArmSamples:
    """Sampled configurations of an arm and where they put its hand.

    Attributes:
        joints: The arm's joints, in the order of ``q``'s columns.
        q: Joint positions, shape (n, len(joints)) [rad or m].
        p: The hand frame's positions in the world, shape (n, 3) [m].
        R: The hand frame's orientations ``R_WH``, shape (n, 3, 3).
    """

    joints: tuple[str, ...]
    q: np.ndarray
    p: np.ndarray
    R: np.ndarray


def sample_arm(robot: Robot, hand: Hand, n: int, rng: np.random.Generator) -> ArmSamples:
    """``n`` configurations of ``hand``'s arm drawn uniformly within its joint ranges
    and the hand frame's pose at each (the other joints as they are now)."""
    m = robot.model
    joints = tuple(robot.limb(hand.arm).joints)
    lo, hi = robot.joint_limits(joints)
    lo = np.where(np.isfinite(lo), lo, -UNLIMITED)
    hi = np.where(np.isfinite(hi), hi, UNLIMITED)
    adr = [int(m.joint(j).qposadr[0]) for j in joints]
    frame = Frame.find(m, hand.frame, hand.frame_type)
    data = mujoco.MjData(m)
    data.qpos[:] = robot.data.qpos
    q = rng.uniform(lo, hi, size=(n, len(joints)))
    p, R = np.empty((n, 3)), np.empty((n, 3, 3))
    for k in range(n):
        data.qpos[adr] = q[k]
        mujoco.mj_kinematics(m, data)
        p[k], R[k] = frame.position(data), frame.rotation(data)
    return ArmSamples(joints=joints, q=q, p=p, R=R)
