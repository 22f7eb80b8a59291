"""The joint drives of a physics scene: the robot's own position actuators where
it has them, servos the scene adds on its other joints, gains from the robot's
inertia.

**Position feedback.** MuJoCo's actuator force (``gaintype`` fixed, ``biastype``
affine) is

.. math::

    f = g_0\\, u + b_0 + b_1 L + b_2 \\dot L

with ``u`` the control (or, with activation dynamics, the activation), ``L``
the actuator length (``gear · q`` for a joint transmission). An actuator with
``b_1 < 0`` pulls towards a position: a ``<position>`` actuator is
``g_0 = k_p``, ``b = (0, -k_p, -k_v)``. At rest at a pose it exerts no force when

.. math::

    u^\\ast = -(b_0 + b_1 L) / g_0

(:func:`rest_controls`; ``u* = L`` for a position actuator): that is the
control a hold gives it. Left at ``u = 0`` it would pull its joint to zero and
fight the hold. A robot's position actuator on one of its hinge or slide
joints is that joint's servo (:func:`position_actuators`); its joint-space
gains are ``k_p = gear² g_0``, ``k_v = -gear² b_2``. Actuators without position feedback
(``<motor>``, ``<velocity>``) exert nothing at rest with zero control; the scene
adds its own servo on their joints.

**Gains of the scene's servos** (:func:`servo_gains`). With the other joints
held, joint ``j``'s servo ``τ = k_p (q^\ast - q) - k_v \\dot q`` moves the inertia
``M_jj``, the diagonal of the joint-space inertia ``M(q)`` at the robot's start
pose (``mj_fullM``, armature included) [kg·m² for a hinge, kg for a slide]. It
is a second-order system of natural frequency ``ω`` [rad/s] and damping ratio
``ζ`` when

.. math::

    k_{p,j} = ω^2 M_{jj} \\;[N·m/rad], \\qquad k_{v,j} = 2 ζ ω M_{jj} \\;[N·m·s/rad]

so the gains scale with the robot: the same bandwidth for a 1 kg and a 100 kg
robot. Choosing ``ω`` (:data:`DEFAULT_BANDWIDTH`):

* standing needs the two ankles stiffer than gravity's tipping stiffness
  ``m g h`` of the body above them: ``2 ω² M_ankle > m g h``, i.e.
  ``ω > (m g h / 2 M_ankle)^{1/2}``: 63 rad/s for the sample humanoid (58.5 kg,
  CoM 0.8 m up, ``M_ankle`` = 0.058 kg·m²), 48 for Unitree H1, 86 for G1, 114
  for Booster T1 (light feet, no heavy armature). With ``M_jj`` the servo's
  bandwidth is the one of the joint's lighter side (the foot), not of the body
  standing on it: gains from the stance inertia (``≈ m h²`` for an ankle)
  would make the light side ring against the floor contacts;
* ``ω Δt`` must stay well below the explicit integration limit 2 for the
  stiffness (0.3 at Δt = 2 ms; coupled modes run up to ~3 ω); ``k_v`` is
  integrated implicitly by ``implicitfast``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput

__all__ = [
    "DEFAULT_BANDWIDTH",
    "DEFAULT_DAMPING_RATIO",
    "ServoLaw",
    "position_actuators",
    "position_feedback",
    "rest_controls",
    "servo_gains",
]

DEFAULT_BANDWIDTH = 150.0
"""Natural frequency ``ω`` [rad/s] of the scene's servos (24 Hz; module docstring)."""

DEFAULT_DAMPING_RATIO = 1.0
"""Damping ratio ``ζ`` [-] of the scene's servos: critically damped, no overshoot."""

_ANGLE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def position_feedback(model: mujoco.MjModel) -> np.ndarray:
    """Mask (nu,) of the actuators that pull towards a position: fixed gain
    ``g_0 > 0`` and an affine bias with ``b_1 < 0`` (module docstring)."""
    return (
        (model.actuator_gaintype == mujoco.mjtGain.mjGAIN_FIXED)
        & (model.actuator_biastype == mujoco.mjtBias.mjBIAS_AFFINE)
        & (model.actuator_gainprm[:, 0] > 0)
        & (model.actuator_biasprm[:, 1] < 0)
    )


def position_actuators(
    model: mujoco.MjModel, joints: Sequence[int]
) -> dict[int, tuple[int, float, float]]:
    """The position actuators driving the hinge/slide ``joints`` alone.

    Returns:
        ``{joint id: (actuator id, kp [N·m/rad], kv [N·m·s/rad])}`` with the
        gains in joint space (``gear² g_0``, ``-gear² b_2``); a joint driven by
        several keeps the first.
    """
    wanted = {int(j) for j in joints}
    out: dict[int, tuple[int, float, float]] = {}
    for a in np.flatnonzero(position_feedback(model)):
        j = int(model.actuator_trnid[a, 0])
        if (
            model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT
            or j not in wanted
            or int(model.jnt_type[j]) not in _ANGLE
            or j in out
        ):
            continue
        gear2 = float(model.actuator_gear[a, 0]) ** 2
        kp = gear2 * float(model.actuator_gainprm[a, 0])
        kv = -gear2 * float(model.actuator_biasprm[a, 2])
        out[j] = (int(a), kp, kv)
    return out


def rest_controls(model: mujoco.MjModel, data: mujoco.MjData, actuators: np.ndarray) -> np.ndarray:
    """``u* = -(b_0 + b_1 L) / g_0`` of ``actuators`` (ids) at the pose in ``data``
    (``actuator_length`` current, e.g. after ``mj_fwdPosition``): the controls
    at which they exert no force at rest there (module docstring)."""
    a = np.asarray(actuators, dtype=int)
    b = model.actuator_biasprm[a]
    return -(b[:, 0] + b[:, 1] * data.actuator_length[a]) / model.actuator_gainprm[a, 0]


def servo_gains(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    joints: Sequence[int],
    bandwidth: float = DEFAULT_BANDWIDTH,
    damping_ratio: float = DEFAULT_DAMPING_RATIO,
) -> tuple[np.ndarray, np.ndarray]:
    """``(kp, kv)`` of servos on the hinge/slide ``joints`` at configuration ``qpos``:
    ``kp_j = ω² M_jj``, ``kv_j = 2 ζ ω M_jj`` (module docstring).

    Args:
        model: The model.
        qpos: Configuration (nq,) whose joint-space inertia ``M`` (``mj_fullM``) is used.
        joints: Joint ids.
        bandwidth: ``ω`` [rad/s] > 0.
        damping_ratio: ``ζ`` [-] >= 0.

    Returns:
        Two arrays (len(joints),): kp [N·m/rad or N/m], kv [N·m·s/rad or N·s/m].
    """
    if not (math.isfinite(bandwidth) and bandwidth > 0):
        raise InvalidInput(f"servo bandwidth must be > 0 [rad/s], got {bandwidth}")
    if not (math.isfinite(damping_ratio) and damping_ratio >= 0):
        raise InvalidInput(f"servo damping ratio must be >= 0, got {damping_ratio}")
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_fwdPosition(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    m_jj = np.diag(M)[model.jnt_dofadr[np.asarray(joints, dtype=int)]]
    return bandwidth**2 * m_jj, 2.0 * damping_ratio * bandwidth * m_jj


class ServoLaw:
    r"""The controls of position actuators on hinge/slide joints (joint
    transmissions) for a reference ``(q_ref, q̇_ref)`` and a feed-forward torque
    ``τ_ff``: an actuator's joint torque ``γ (g_0 u + b_0 + b_1 L + b_2 L̇)`` with
    ``L = γ q`` becomes ``-γ² b_1 (q_ref - q) - γ² b_2 (q̇_ref - q̇) + τ_ff`` at

    .. math::

        u = -\big(b_0 + b_1 γ q_{ref} + b_2 γ \dot q_{ref} - τ_{ff} / γ\big) / g_0

    (for a scene servo ``g_0 = k_p = -b_1``, ``b_2 = -k_v``, ``γ = 1``:
    ``u = q_ref + (k_v / k_p) q̇_ref + τ_ff / k_p``). The feed-forward goes
    through the actuator, so MuJoCo clamps it with the rest of the actuator's
    force (``ctrlrange``, ``forcerange``, the joint's ``actuatorfrcrange``). A
    joint driven by several of them gets its feed-forward on the first.

    Args:
        model: The model.
        actuators: Position actuators (ids, :func:`position_feedback`); those on
            joints other than hinge/slide joints within the first ``nq``
            coordinates and ``nv`` dofs are left out.
        nq, nv: The robot's configuration and velocity sizes.

    Attributes:
        ids: The actuators driven.
        qadr, dof: Their joints' ``qpos`` and dof addresses.
    """

    def __init__(self, model: mujoco.MjModel, actuators: Sequence[int], nq: int, nv: int):
        m = model
        ids = [
            int(a)
            for a in actuators
            if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
            and int(m.jnt_type[m.actuator_trnid[a, 0]]) in _ANGLE
            and m.jnt_qposadr[m.actuator_trnid[a, 0]] < nq
            and m.jnt_dofadr[m.actuator_trnid[a, 0]] < nv
        ]
        self.ids = np.array(ids, dtype=int)
        joints = m.actuator_trnid[self.ids, 0]
        self.qadr, self.dof = m.jnt_qposadr[joints], m.jnt_dofadr[joints]
        self.gear = m.actuator_gear[self.ids, 0]
        self.g0 = m.actuator_gainprm[self.ids, 0]
        self.b = m.actuator_biasprm[self.ids, :3]
        _, first = np.unique(self.dof, return_index=True)
        self.feeds = np.zeros(len(self.ids), dtype=bool)
        self.feeds[first] = True

    def controls(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray | None = None) -> np.ndarray:
        """Controls (k, len(ids)) for references ``q`` (k, nq), ``qd`` (k, nv) and
        feed-forward ``tau`` (k, nv) [N·m or N] (None: none); single rows too."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        tau = None if tau is None else np.asarray(tau, float)[..., self.dof]
        return self.joint_controls(q[..., self.qadr], qd[..., self.dof], tau)

    def joint_controls(
        self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray | None = None
    ) -> np.ndarray:
        """:meth:`controls` from the driven joints' values alone: ``q``, ``qd`` and
        ``tau`` (k, len(ids)), each actuator's joint's (``qadr``, ``dof``)."""
        b0, b1, b2 = self.b.T
        L, Ld = self.gear * q, self.gear * qd
        u = -(b0 + b1 * L + b2 * Ld)
        if tau is not None:
            u = u + np.where(self.feeds, tau / self.gear, 0.0)
        return u / self.g0
