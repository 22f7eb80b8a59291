"""The torques that hold a pose or move it along a path: :func:`holding_torques`
(inverse dynamics with the contact forces that carry the robot), and the joints
whose drive cannot give them (:func:`drive_shortfalls`)."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj.dynamics import contact_wrenches, joint_torques, root_wrench
from pik_mj.sim.drives import DriveShortfall, servo_bounds, shortfalls
from pik_mj.sim.physics import ContactInfo, External, Physics
from pik_mj.sim.static import point_contacts

__all__ = ["drive_shortfalls", "holding_torques"]


def holding_torques(
    scene: Physics,
    q: ArrayLike,
    external: Sequence[External] = (),
    *,
    qvel: np.ndarray | None = None,
    qacc: np.ndarray | None = None,
    data: mujoco.MjData | None = None,
    contacts: Sequence[ContactInfo] | None = None,
) -> np.ndarray | None:
    r"""Generalized forces that move the robot through ``q`` at velocity ``qvel``
    and acceleration ``qacc`` (default: hold it still) under gravity, the
    contact forces and the external wrenches:

    .. math::

        \tau = \underbrace{M \ddot q + c(q, \dot q) - \tau_{passive}}_{\texttt{mj\_inverse}}
           - \sum_i J_{p}(p_i)^T f_i - \sum_e J_e^T w_e - \sum_o J_{p,F_o}(c_o)^T m_o g

    (:func:`pik_mj.dynamics.joint_torques`; ``τ_passive``: the joints' springs,
    dm_control's humanoid has them). The free joint's rows of the rest are the
    wrench the contacts must apply (:func:`pik_mj.dynamics.root_wrench`); ``f_i``
    are the least-norm forces inside the friction pyramids at the robot's
    environment contacts ``p_i`` (within the scene's ``contact_tolerance``,
    :meth:`~pik_mj.sim.physics.Physics.touching`) that apply it
    (:func:`pik_mj.dynamics.contact_wrenches`; an equilibrium LP's forces are
    any feasible point, often on a cone's edge, which would push the feet to
    slip). A grasped object's weight ``m_o g`` acts at its CoM ``c_o`` on the
    grasping frame's body (the weld carries it in the physics). A robot
    without a free joint is held by its fixed base: no contact forces. The rows
    on the servo joints are the feed-forward of the servos; the free-joint rows
    are ~0.

    Args:
        scene: The scene.
        q: Robot configuration (``robot_nq``).
        external: Wrenches ``(frame, force, moment)`` acting on the robot.
        qvel, qacc: Robot velocity and acceleration (``robot.model.nv``) [rad/s,
            rad/s²]; None: zero.
        data: Workspace (default: a new ``MjData`` of the scene's model).
        contacts: The robot's environment contacts at ``q`` when known (default:
            ``scene.touching``'s).

    Returns:
        ``(nv,)`` [N, N·m] of the scene's model, or None when no contact forces
        within the friction pyramids apply the wrench (no equilibrium).
    """
    m = scene.model
    d = mujoco.MjData(m) if data is None else data
    qpos = scene.qpos_of(q)
    v, a = np.zeros(m.nv), np.zeros(m.nv)
    nv = scene.robot.model.nv
    if qvel is not None:
        v[:nv] = qvel
    if qacc is not None:
        a[:nv] = qacc
    wrenches = [(f, np.asarray(F, float), np.asarray(M, float)) for f, F, M in external]
    tau = joint_torques(m, d, qpos, v, a, wrenches)
    jacp = np.zeros((3, m.nv))
    gravity = np.asarray(m.opt.gravity, dtype=float)
    for frame, b in scene.held_objects:
        # the weight of a grasped object hangs on the frame's body at its CoM
        mujoco.mj_jac(m, d, jacp, None, d.subtree_com[b], frame.body_id)
        tau -= jacp.T @ (m.body_subtreemass[b] * gravity)
    if not scene.robot.has_floating_base:
        return tau
    w_B, p_WB = root_wrench(m, d, tau, scene.root_body)
    total = np.concatenate([w_B[:3], w_B[3:] + np.cross(p_WB, w_B[:3])])
    if contacts is None:
        contacts = scene.touching(qpos)
    env = [c for c in contacts if not c.self_contact]
    solved = contact_wrenches(point_contacts(env), total)
    if solved is None:
        return None
    for c, f in zip(env, solved[:, :3], strict=True):
        body = int(m.geom_bodyid[scene.geom_ids[c.robot_geom]])
        mujoco.mj_jac(m, d, jacp, None, c.position, body)
        tau -= jacp.T @ f
    return tau


def drive_shortfalls(scene: Physics, q: np.ndarray, tau: np.ndarray) -> list[DriveShortfall]:
    """The servo joints whose drive cannot give ``tau`` (nv,) at rest at ``q``, the
    joint giving way a little (:func:`pik_mj.sim.drives.servo_bounds`)."""
    actuators = np.array([scene.servo_actuators[j] for j in scene.servo_joints], dtype=int)
    lo, hi = servo_bounds(scene.model, actuators, scene.qpos_of(q))
    return shortfalls(list(scene.servo_joints), tau[scene.servo_dofs], lo, hi, ["the held pose"])
