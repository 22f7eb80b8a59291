"""The floating base: the wrench its free joint's rows stand for, and the ZMP
of a motion (irteus manual: ``:calc-zmp``)."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from pik_mj.dynamics.inverse import ExternalSpec, frame_jacobian, joint_torques
from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.frames import Frame, robot_root_body


def free_root_body(model: mujoco.MjModel, root_body: str | None = None) -> int:
    """Id of the floating-base body: the robot's root body
    (:func:`pik_mj.robot.robot_root_body`), which must have a free joint."""
    b = robot_root_body(model, root_body)
    j = int(model.body_jntadr[b])
    if j < 0 or int(model.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_FREE):
        raise InvalidInput(
            f"body {model.body(b).name!r} has no free joint: a floating base is needed here"
        )
    return b


def _root_dofs(model: mujoco.MjModel, body: int) -> np.ndarray:
    j = int(model.body_jntadr[body])
    return np.arange(model.jnt_dofadr[j], model.jnt_dofadr[j] + 6)


def root_wrench(
    model: mujoco.MjModel, data: mujoco.MjData, tau: np.ndarray, root_body: str | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The world wrench on the floating base that the free-joint rows of ``tau`` stand for.

    With ``J_B`` the 6x6 block of the root body's world Jacobian on its own free
    joint (kinematics must be current),

    .. math::

        \\tau_{root} = J_B^T w_B \\;\\Rightarrow\\; w_B = J_B^{-T} \\tau_{root}

    Returns:
        ``(w_B (6,) = (f, n about p_WB), p_WB (3,))`` [N, N·m, m].
    """
    b = free_root_body(model, root_body)
    dofs = _root_dofs(model, b)
    J_B = frame_jacobian(model, data, Frame(model, model.body(b).name, "body", b))[:, dofs]
    return np.linalg.solve(J_B.T, tau[dofs]), data.xpos[b].copy()


def zmp_points(
    force: np.ndarray, moment: np.ndarray, about: np.ndarray | float = 0.0, z: float = 0.0
) -> np.ndarray:
    """Points (..., 2) on the plane at height ``z`` where the horizontal moment
    of the wrenches ``(f, n_a)`` (..., 3) [N, N·m], ``n_a`` about the points
    ``a`` (..., 3) [m] (default: the origin), vanishes (the ZMP; irteus manual:
    ``:calc-zmp``). With ``h = a_z - z``, from ``n_s = n_a + (a - s) × f``:

    .. math::

        s_x = a_x - \\frac{n_{a,y} + h f_x}{f_z}, \\qquad
        s_y = a_y - \\frac{h f_y - n_{a,x}}{f_z}

    Unchecked: ``f_z ≤ 0`` gives a meaningless or non-finite point
    (:func:`zmp_from_wrench` raises)."""
    f, n = np.asarray(force, dtype=float), np.asarray(moment, dtype=float)
    a = np.broadcast_to(np.asarray(about, dtype=float), f.shape)
    h = a[..., 2] - z
    return np.stack(
        [
            a[..., 0] - (n[..., 1] + h * f[..., 0]) / f[..., 2],
            a[..., 1] - (h * f[..., 1] - n[..., 0]) / f[..., 2],
        ],
        axis=-1,
    )


def zmp_from_wrench(f: np.ndarray, n_W0: np.ndarray, z: float) -> np.ndarray:
    """Point on the plane ``z`` where the horizontal moment of ``(f, n_W0)``
    (moment about the world origin) vanishes (:func:`zmp_points`).

    .. math::

        n_s = n_0 - s \\times f = 0_{xy} \\Rightarrow
        s_x = \\frac{z f_x - n_{0,y}}{f_z},\\; s_y = \\frac{z f_y + n_{0,x}}{f_z}

    Raises:
        PikError: ``f_z ≤ 0``: the ground does not push.
    """
    if f[2] <= 1e-9:
        raise PikError(
            f"the ground reaction has no upward force (f_z = {f[2]:.3g} N): the ZMP is undefined"
        )
    return zmp_points(f, n_W0, 0.0, z)


def zmp_from_inverse_dynamics(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q: Sequence[float] | np.ndarray,
    qvel: Sequence[float] | np.ndarray | float = 0.0,
    qacc: Sequence[float] | np.ndarray | float = 0.0,
    z: float = 0.0,
    *,
    external: Sequence[ExternalSpec] = (),
    root_body: str | None = None,
) -> np.ndarray:
    """ZMP of a floating-base motion from ``mj_inverse`` (irteus ``:calc-zmp``).

    The free-joint rows of the inverse dynamics (minus the external wrenches)
    are the total wrench the ground must apply, ``(f, n_B)`` about the base
    origin ``p_WB`` (:func:`root_wrench`). Its moment about the world origin is
    ``n_0 = n_B + p_WB × f``, and the ZMP is the point ``s = (s_x, s_y, z)`` of
    the ground plane about which the horizontal moment vanishes:

    .. math::

        s_x = \\frac{z f_x - n_{0,y}}{f_z}, \\qquad
        s_y = \\frac{z f_y + n_{0,x}}{f_z}

    Args:
        model: Model with a free joint.
        data: Workspace (overwritten).
        q: Configuration (nq,).
        qvel: Velocity (nv,) or 0.
        qacc: Acceleration (nv,) or 0.
        z: Height of the ground plane [m].
        external: Other wrenches acting on the robot (see :func:`joint_torques`).
        root_body: The floating-base body (default: see :func:`free_root_body`).

    Returns:
        ``(s_x, s_y)`` [m].

    Raises:
        PikError: The ground would have to pull (``f_z <= 0``).
    """
    tau = joint_torques(model, data, q, qvel, qacc, external)
    w_B, p_WB = root_wrench(model, data, tau, root_body)
    f = w_B[:3]
    return zmp_from_wrench(f, w_B[3:] + np.cross(p_WB, f), float(z))


def zmp_of_motion(
    model: mujoco.MjModel,
    qs: np.ndarray,
    dt: float,
    z: float = 0.0,
    *,
    root_body: str | None = None,
) -> np.ndarray:
    """ZMP along a sampled motion, velocities and accelerations by finite differences.

    With ``q_{k+1} ⊖ q_k`` the tangent difference (``mj_differentiatePos``),

    .. math::

        \\dot q_k = \\frac{q_{k+1} \\ominus q_{k-1}}{2\\,dt}, \\qquad
        \\ddot q_k = \\frac{(q_{k+1} \\ominus q_k) - (q_k \\ominus q_{k-1})}{dt^2}

    (exact for motions quadratic in time). The first and last samples use the
    one-sided velocity and their neighbour's acceleration.

    Args:
        model: Model with a free joint.
        qs: Configurations (T, nq), T >= 3, sampled every ``dt``.
        dt: Sample period [s].
        z: Ground height [m].
        root_body: The floating-base body.

    Returns:
        ZMP per sample (T, 2) [m].
    """
    qs = np.asarray(qs, dtype=float)
    if qs.ndim != 2 or qs.shape[1] != model.nq or qs.shape[0] < 3:
        raise InvalidInput(f"qs must have shape (T >= 3, nq = {model.nq}), got {qs.shape}")
    if not np.all(np.isfinite(qs)):
        raise InvalidInput("qs holds NaN or inf")
    if not (np.isfinite(dt) and dt > 0):
        raise InvalidInput(f"dt must be a positive number of seconds, got {dt}")
    T = qs.shape[0]
    diff = np.zeros((T - 1, model.nv))  # (q_{k+1} ⊖ q_k) / dt
    for k in range(T - 1):
        mujoco.mj_differentiatePos(model, diff[k], dt, qs[k], qs[k + 1])
    vel = np.vstack([diff[:1], 0.5 * (diff[:-1] + diff[1:]), diff[-1:]])
    acc = (diff[1:] - diff[:-1]) / dt
    acc = np.vstack([acc[:1], acc, acc[-1:]])
    data = mujoco.MjData(model)
    return np.array(
        [
            zmp_from_inverse_dynamics(model, data, qs[k], vel[k], acc[k], z, root_body=root_body)
            for k in range(T)
        ]
    )
