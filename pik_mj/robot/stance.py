"""A flat stance: a start pose whose soles are turned horizontal by the leg joints.

A zero pose whose soles are tilted (dm_control's humanoid stands on capsules
pitched by a few mrad) rocks onto their edges in physics. :func:`flat_stance`
turns each foot by the rotation ``R_c``, the smallest one taking its sole's
normal ``n`` (:func:`pik_mj.robot.floor_contact.sole_normal`) to up:

.. math::

    R_c = \\exp\\!\\big(\\theta\\, \\hat a\\big), \\qquad
    a = n \\times e_z, \\quad \\theta = \\operatorname{atan2}(\\|a\\|, n_z)

with a stack for :func:`pik_mj.solve.solve` built from core tasks: the guard
level (:func:`pik_mj.robot.stack.guard_level`: limits, couplings, everything but
the legs frozen), each foot's end frame onto ``(p_WF, R_c R_WF)`` with its height
free (the robot is put down after), the posture. The base stays where it was.
"""

from __future__ import annotations

import mink
import numpy as np

from pik_mj.robot.floor_contact import sole_normal
from pik_mj.robot.robot_model import RobotModel
from pik_mj.robot.stack import guard_level, posture_task
from pik_mj.solve import solve
from pik_mj.tasks.frame import FrameTask

FLAT_TILT = 1e-4
"""[rad] Soles tilted by at most this much already stand flat."""

STANCE_THRE = 1e-4
"""[m] and [rad] Position and rotation tolerance of the feet's targets."""

STANCE_STOP = 50
"""Iterations of the stance's solve at most."""

POSTURE_WEIGHT = 1e-2
"""[cost/rad²] Cost of moving the legs away from the zero pose (last level)."""


def flat_stance(robot: RobotModel, tolerance: float = FLAT_TILT) -> np.ndarray | None:
    """The robot's configuration ``q`` (nq,) with the feet of its legs (``rleg``,
    ``lleg``) turned so that their soles are horizontal (module docstring), or None
    for a fixed base, a robot without legs, soles already flat within ``tolerance``
    [rad] or spanning no area, or a solve that does not converge. The robot's
    configuration is left as it was.
    """
    adr = robot.free_qposadr
    legs = {x: robot.limbs[x] for x in ("rleg", "lleg") if x in robot.limbs}
    if adr is None or not legs:
        return None
    targets = []
    tilt = 0.0
    for leg, limb in legs.items():
        n = sole_normal(robot.model, robot.data, robot.foot_geoms([leg]))
        if n is None:
            return None
        axis = np.cross(n, [0.0, 0.0, 1.0])
        angle = float(np.arctan2(np.linalg.norm(axis), n[2]))
        tilt = max(tilt, angle)
        R_c = mink.SO3.exp(axis / max(np.linalg.norm(axis), 1e-12) * angle)
        X = robot.frame_pose(limb.end_frame, limb.end_frame_type)
        targets.append((X.translation(), (R_c @ X.rotation()).as_matrix()))
    if tilt <= tolerance:
        return None
    configuration = robot.configuration
    feet = [
        FrameTask(
            configuration,
            limb.end_frame,
            target,
            move_target_type=limb.end_frame_type,
            translation_axis="z",  # the height is free: the robot is put down after
            thre=STANCE_THRE,
            rthre=STANCE_THRE,
            name=f"flat_sole:{limb.end_frame}",
        )
        for limb, target in zip(legs.values(), targets, strict=True)
    ]
    joints = [j for limb in legs.values() for j in limb.joints]
    levels = [
        guard_level(configuration, joints),
        feet,
        [posture_task(configuration, POSTURE_WEIGHT)],
    ]
    q0 = configuration.q.copy()
    try:
        if not solve(configuration, levels, stop=STANCE_STOP, revert_if_fail=True).converged:
            return None
        q = configuration.q.copy()
        q[adr : adr + 7] = q0[adr : adr + 7]  # the base stays exactly where it was
        return q
    finally:
        configuration.update(q0)
