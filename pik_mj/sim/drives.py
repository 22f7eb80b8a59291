r"""What the robot's joint drives can deliver: the torque bounds of each servo
joint, and whether a pose's or a path's torques fit in them.

A servo joint ``j`` is driven by one position actuator (the robot's own or one
the scene added, :mod:`pik_mj.sim.servos`) whose joint torque at control ``u`` is

.. math::

    \tau_j(u) = \gamma \big(g_0 u + b_0 + b_1 \gamma q_j + b_2 \gamma \dot q_j\big)

(``γ`` its gear). MuJoCo clamps it three ways, all taken here:
``u`` to ``ctrlrange`` (``ctrllimited``: a position actuator with
``inheritrange`` cannot aim beyond the joint's range, so its gains decide how
much torque it has near a range end), the actuator force to ``forcerange``
(``forcelimited``) and the sum of the actuator forces on the joint to the
joint's ``actuatorfrcrange`` (``jnt_actfrclimited``). The bounds
``[τ_min, τ_max]`` of :func:`torque_bounds` are the intersection.

A position servo whose control is at its range's end (a pose at the joint's range
end, the control range the joint's) gives a torque only as its joint gives way: its
torque grows by its stiffness ``-γ² b_1`` per unit the joint sags from the control's
end. What a servo can hold is therefore judged over the poses within
:data:`SERVO_GIVE` of the pose (:func:`servo_bounds`): the torque a drive gives there,
with the joint that much off its target, which the tracking tolerances accept. A servo the
scene adds on a joint the robot drives with a motor (``<motor>``) gets that
motor's torque range (:func:`motor_torque_range`) as its force range: it
stands for the robot's drive, not for a stronger one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from pik_mj.sim.servos import position_feedback

__all__ = [
    "SERVO_GIVE",
    "DriveShortfall",
    "motor_torque_range",
    "servo_bounds",
    "shortfalls",
    "torque_bounds",
]

SERVO_GIVE = 0.01
"""How far [rad or m] a servo joint may give way from its pose to deliver a torque
(:func:`servo_bounds`)."""


def motor_torque_range(model: mujoco.MjModel, joint: int) -> tuple[float, float] | None:
    """Joint torque range [N·m or N] of the actuators without position feedback
    (motors) driving ``joint`` alone: ``γ g_0 ctrlrange`` (``ctrllimited``, fixed
    gain, no bias) intersected with ``γ forcerange`` (``forcelimited``), summed over
    the motors; None when no motor on the joint is limited."""
    lo = hi = 0.0
    limited = False
    for a in np.flatnonzero(~position_feedback(model)):
        if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        if int(model.actuator_trnid[a, 0]) != joint:
            continue
        gear = float(model.actuator_gear[a, 0])
        span = np.array([-np.inf, np.inf])
        plain = (
            model.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
            and model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE
        )
        if model.actuator_ctrllimited[a] and plain:
            span = np.sort(gear * model.actuator_gainprm[a, 0] * model.actuator_ctrlrange[a])
        if model.actuator_forcelimited[a]:
            f = np.sort(gear * model.actuator_forcerange[a])
            span = np.array([max(span[0], f[0]), min(span[1], f[1])])
        if not np.all(np.isfinite(span)):
            return None  # an unlimited motor: the drive has no stated limit
        lo, hi, limited = lo + float(span[0]), hi + float(span[1]), True
    return (lo, hi) if limited else None


def torque_bounds(
    model: mujoco.MjModel,
    actuators: np.ndarray,
    qpos: np.ndarray,
    qvel: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Torque bounds ``(τ_min, τ_max)`` [N·m or N] of the servo ``actuators``
    (ids, joint transmissions) at configurations ``qpos`` (k, nq) and velocities
    ``qvel`` (k, nv) (default zero): the module docstring's clamps.

    Returns:
        Two arrays (k, len(actuators)); ``±inf`` where nothing limits.
    """
    drives = _drives(model, np.asarray(actuators, dtype=int))
    return _bounds(drives, np.atleast_2d(np.asarray(qpos, float)), qvel)


class _Drives(NamedTuple):
    """The model's values :func:`torque_bounds` reads of some actuators (n,):
    their joints' ``qpos`` and dof addresses, gears, gains ``g_0``, biases
    ``b`` (n, 3), control range ``u`` (2, n) (``±inf`` unlimited), sorted force
    range ``γ f`` (n, 2) and whether it limits, the joints' actuator force
    range (n, 2) and whether it limits."""

    qposadr: np.ndarray
    dofadr: np.ndarray
    gear: np.ndarray
    g0: np.ndarray
    b: np.ndarray
    u: np.ndarray
    force: np.ndarray
    force_limited: np.ndarray
    joint_limited: np.ndarray
    joint_range: np.ndarray


def _drives(model: mujoco.MjModel, a: np.ndarray) -> _Drives:
    """The :class:`_Drives` of the actuators ``a``."""
    joints = model.actuator_trnid[a, 0]
    gear = model.actuator_gear[a, 0]
    return _Drives(
        qposadr=model.jnt_qposadr[joints],
        dofadr=model.jnt_dofadr[joints],
        gear=gear,
        g0=model.actuator_gainprm[a, 0],
        b=model.actuator_biasprm[a, :3],
        u=np.where(
            model.actuator_ctrllimited[a].astype(bool)[None],
            model.actuator_ctrlrange[a].T,
            [[-np.inf], [np.inf]],
        ),
        force=np.sort(gear[:, None] * model.actuator_forcerange[a], axis=1),
        force_limited=model.actuator_forcelimited[a].astype(bool),
        joint_limited=model.jnt_actfrclimited[joints].astype(bool),
        joint_range=model.jnt_actfrcrange[joints],
    )


def _bounds(
    drives: _Drives, qpos: np.ndarray, qvel: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`torque_bounds` of the :func:`_drives` at ``qpos`` (k, nq)."""
    gear, b = drives.gear, drives.b
    q = qpos[:, drives.qposadr]
    qd = 0.0 if qvel is None else np.atleast_2d(qvel)[:, drives.dofadr]
    bias = b[:, 0] + b[:, 1] * gear * q + b[:, 2] * gear * qd
    with np.errstate(invalid="ignore"):
        ends = gear * (drives.g0 * drives.u[:, None, :] + bias[None])  # (2, k, n)
    lo, hi = np.fmin(ends[0], ends[1]), np.fmax(ends[0], ends[1])
    force, limited = drives.force, drives.force_limited
    lo = np.where(limited, np.maximum(lo, force[:, 0]), lo)
    hi = np.where(limited, np.minimum(hi, force[:, 1]), hi)
    joint_limited, joint_range = drives.joint_limited, drives.joint_range
    lo = np.where(joint_limited, np.maximum(lo, joint_range[:, 0]), lo)
    hi = np.where(joint_limited, np.minimum(hi, joint_range[:, 1]), hi)
    return lo, hi


def servo_bounds(
    model: mujoco.MjModel, actuators: np.ndarray, qpos: np.ndarray, give: float = SERVO_GIVE
) -> tuple[np.ndarray, np.ndarray]:
    """Torque bounds ``(τ_min, τ_max)`` [N·m or N] (k, len(actuators)) the servo
    ``actuators`` reach at rest when their joints give way by up to ``give`` [rad or
    m] from the configurations ``qpos`` (k, nq): the widest of :func:`torque_bounds`
    at ``q_j ± give`` on each servo joint (module docstring: a servo at its control
    range's end holds by sagging)."""
    drives = _drives(model, np.asarray(actuators, dtype=int))
    qpos = np.atleast_2d(np.asarray(qpos, float))
    k = len(qpos)
    moved = np.concatenate([qpos, qpos])  # the joints at -give, then at +give
    moved[:k, drives.qposadr] += -give
    moved[k:, drives.qposadr] += give
    lo, hi = _bounds(drives, moved, None)
    return np.minimum(lo[:k], lo[k:]), np.maximum(hi[:k], hi[k:])


@dataclass(frozen=True)
class DriveShortfall:
    """A joint whose drive cannot give the torque a pose needs at rest.

    Attributes:
        joint: The joint's name.
        torque: The torque it needs [N·m or N].
        bound: The bound it passes (``τ_min`` or ``τ_max``) [N·m or N].
        where: Which pose (e.g. ``"the held pose"``, ``"waypoint 3 (t = 0.52 s)"``).
    """

    joint: str
    torque: float
    bound: float
    where: str

    def describe(self) -> str:
        return (
            f"joint {self.joint!r} needs {self.torque:.1f} N·m at rest at {self.where}; "
            f"its drive gives {'at most' if self.torque > self.bound else 'at least'} "
            f"{self.bound:.1f} N·m"
        )


def shortfalls(
    names: list[str],
    tau: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    where: list[str],
) -> list[DriveShortfall]:
    """The worst shortfall of each joint over ``k`` poses: ``tau`` (k, n) outside
    ``[lo, hi]`` (k, n), ``names`` the n joints, ``where`` the k poses."""
    tau = np.atleast_2d(tau)
    excess = np.maximum(tau - hi, lo - tau)  # > 0 outside
    out = []
    for j in np.flatnonzero(np.any(excess > 0, axis=0)):
        k = int(np.argmax(excess[:, j]))
        bound = hi[k, j] if tau[k, j] > hi[k, j] else lo[k, j]
        out.append(DriveShortfall(names[j], float(tau[k, j]), float(bound), where[k]))
    return out
