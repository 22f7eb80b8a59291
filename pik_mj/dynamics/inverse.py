"""Inverse dynamics with external wrenches (irteus manual: ``:torque-vector``):
``τ = M(q) q̈ + c(q, q̇) − τ_passive − Σ J_kᵀ w_k``, MuJoCo's ``mj_inverse``
with the constraint solver disabled."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame

_STAGE_NONE = int(mujoco.mjtStage.mjSTAGE_NONE)
_STAGE_POS = int(mujoco.mjtStage.mjSTAGE_POS)
_STAGE_VEL = int(mujoco.mjtStage.mjSTAGE_VEL)
_NO_CONSTRAINT = int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)

ExternalSpec = tuple[str, Sequence[float] | np.ndarray, Sequence[float] | np.ndarray]
"""``(frame name, force (3,) [N], moment (3,) [N·m])``, world frame, acting on the robot
at the frame's origin."""


def _state(
    model: mujoco.MjModel, q: object, qvel: object, qacc: object
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q, q̇, q̈)`` checked; a velocity or acceleration given as 0 is zeros."""
    q = inputs.flat_vector(q, model.nq, "q (length nq)")
    v = (
        np.zeros(model.nv)
        if np.isscalar(qvel) and qvel == 0
        else inputs.flat_vector(qvel, model.nv, "qvel")
    )
    a = (
        np.zeros(model.nv)
        if np.isscalar(qacc) and qacc == 0
        else inputs.flat_vector(qacc, model.nv, "qacc")
    )
    return q, v, a


def _inverse(
    model: mujoco.MjModel, data: mujoco.MjData, q: np.ndarray, v: np.ndarray, a: np.ndarray
) -> np.ndarray:
    """``qfrc_inverse = M a + c(q, v) − τ_passive`` with constraints disabled (nv,)."""
    return inverse_dynamics(model, data, q, v[None], a[None])[0]


def inverse_dynamics(
    model: mujoco.MjModel, data: mujoco.MjData, q: np.ndarray, qvel: np.ndarray, qacc: np.ndarray
) -> np.ndarray:
    """``M(q) q̈_k + c(q, q̇_k) − τ_passive(q, q̇_k)`` (k, nv) at one configuration
    ``q`` (nq,) for the velocities ``qvel`` and accelerations ``qacc`` (k, nv):
    ``mj_inverse`` with the constraint solver disabled (no contact forces),
    unchecked (the callers' inputs are); the position stage (kinematics, mass
    matrix) computed once, for the first pair; the sensors not evaluated
    (``mj_inverseSkip``: ``sensordata`` is not written). ``data`` ends with the
    kinematics at ``q``."""
    return inverse_dynamics_many(model, data, np.asarray(q)[None], qvel[None], qacc[None])[0]


def inverse_dynamics_many(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q: np.ndarray,
    qvel: np.ndarray,
    qacc: np.ndarray,
    each: Callable[[int], None] | None = None,
) -> np.ndarray:
    """:func:`inverse_dynamics` at each configuration ``q[i]`` (k, nq) for its
    velocities ``qvel[i]`` and accelerations ``qacc[i]`` (k, p, nv): (k, p, nv);
    the velocity stage is skipped too where a pair's velocity is the one before
    (order the pairs so: equal velocities next to each other). ``each(i)``,
    when given, is called after configuration ``i``'s, ``data`` then holding
    its kinematics."""
    k, p = qvel.shape[:2]
    out = np.empty((k, p, model.nv))
    qpos, v, a, tau = data.qpos, data.qvel, data.qacc, data.qfrc_inverse
    # each pair after the first: its velocity, its acceleration new (else the
    # pair before's stays in data), the stage mj_inverseSkip skips
    new_v = ~np.all(qvel[:, 1:] == qvel[:, :-1], axis=2)
    new_a = ~np.all(qacc[:, 1:] == qacc[:, :-1], axis=2)
    skip = np.where(new_v, _STAGE_POS, _STAGE_VEL)
    later = np.stack([new_v, new_a, skip], axis=2).tolist()  # (k, p - 1, 3)
    saved = model.opt.disableflags
    model.opt.disableflags = saved | _NO_CONSTRAINT
    try:
        for i in range(k):
            qpos[:] = q[i]
            vel, acc, tau_i = qvel[i], qacc[i], out[i]
            v[:], a[:] = vel[0], acc[0]
            mujoco.mj_inverseSkip(model, data, _STAGE_NONE, 1)  # mj_inverse, no sensors
            tau_i[0] = tau
            for j, (write_v, write_a, stage) in enumerate(later[i], 1):
                if write_v:
                    v[:] = vel[j]
                if write_a:
                    a[:] = acc[j]
                mujoco.mj_inverseSkip(model, data, stage, 1)
                tau_i[j] = tau
            if each is not None:
                each(i)
    finally:
        model.opt.disableflags = saved
    return out


def frame_jacobian(model: mujoco.MjModel, data: mujoco.MjData, frame: Frame) -> np.ndarray:
    """``[J_p; J_ω]`` (6, nv) of a frame origin, world frame (kinematics must be current)."""
    J_p, J_w = frame.jacobians(data)
    return np.vstack([J_p, J_w])


def _external_wrenches(
    model: mujoco.MjModel, external: Sequence[ExternalSpec]
) -> list[tuple[Frame, np.ndarray]]:
    if isinstance(external, (str, bytes)) or not isinstance(external, Sequence):
        raise InvalidInput("external must be a list of (frame, force (3,), moment (3,)) tuples")
    out = []
    for i, item in enumerate(external):
        if not isinstance(item, (tuple, list)) or len(item) not in (2, 3):
            raise InvalidInput(
                f"external[{i}] must be (frame name, force (3,)[, moment (3,)]), got {item!r}"
            )
        name = item[0]
        frame = name if isinstance(name, Frame) else Frame.find(model, name)
        f = inputs.flat_vector(item[1], 3, f"external[{i}] force")
        n = (
            inputs.flat_vector(item[2], 3, f"external[{i}] moment")
            if len(item) == 3
            else np.zeros(3)
        )
        out.append((frame, np.concatenate([f, n])))
    return out


def external_torques(
    model: mujoco.MjModel, data: mujoco.MjData, external: Sequence[ExternalSpec]
) -> np.ndarray:
    """``Σ J_kᵀ w_k`` (nv,) of the external wrenches ``(frame, force (3,) [N],
    moment (3,) [N·m])`` (world frame, at each frame's origin) at the kinematics
    current in ``data``."""
    total = np.zeros(model.nv)
    for frame, w in _external_wrenches(model, external):
        total += frame_jacobian(model, data, frame).T @ w
    return total


def joint_torques(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q: Sequence[float] | np.ndarray,
    qvel: Sequence[float] | np.ndarray | float = 0.0,
    qacc: Sequence[float] | np.ndarray | float = 0.0,
    external: Sequence[ExternalSpec] = (),
) -> np.ndarray:
    """Generalized forces that produce ``qacc`` at ``(q, qvel)`` under external wrenches.

    .. math::

        \\tau = \\underbrace{M(q)\\ddot q + c(q,\\dot q) - \\tau_{passive}}_{
        \\texttt{mj\\_inverse}} - \\sum_k J_k^T w_k

    For a floating base the free joint's rows are the wrench the base would need
    (zero only when the external wrenches balance the motion); see
    :func:`static_torques` for a robot standing on its feet.

    Args:
        model: The model.
        data: Workspace; its ``qpos``, ``qvel``, ``qacc`` and kinematics are overwritten.
        q: Configuration (nq,).
        qvel: Velocity (nv,) [rad/s, m/s], or 0.
        qacc: Acceleration (nv,) [rad/s², m/s²], or 0.
        external: ``[(frame name, force (3,) [N], moment (3,) [N·m]), ...]``: wrenches
            ACTING ON the robot at each frame's origin (site, body or geom), world frame.

    Returns:
        ``τ`` (nv,) [N·m for hinges, N for slides; free-joint rows as MuJoCo's dofs].
    """
    q, v, a = _state(model, q, qvel, qacc)
    tau = _inverse(model, data, q, v, a)
    return tau - external_torques(model, data, external)
