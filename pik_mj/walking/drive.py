"""The joint drives of a walk's playback: what a real robot's servos do with a
walking pattern, within the robot's own gains and torque limits.

Every joint ``j`` tracks the pattern with the law of a torque-controlled joint
servo: position and velocity feedback plus the pattern's own torques as
feed-forward (:func:`~pik_mj.walking.playback.feedforward_torques`, inverse
dynamics with the ground reaction on the soles), limited to what the joint can
deliver:

.. math::

    \\tau_j = \\mathrm{clip}\\big(k_{p,j} (q^{ref}_j - q_j) + k_{v,j} (\\dot q^{ref}_j - \\dot q_j)
              + \\tau^{ff}_j,\\ \\tau^{min}_j,\\ \\tau^{max}_j\\big)

It is applied through the joint's servo in the scene (:attr:`pik_mj.sim.Scene.servo_actuators`:
the robot's own position actuator, or the one the scene added), a position
actuator of gains :math:`(k_a, b_a)` whose force at control :math:`u` is
:math:`k_a (u - q) - b_a \\dot q`: the control

.. math::

    u_j = q_j + (\\tau_j + b_{a,j} \\dot q_j) / k_{a,j}

makes it exert :math:`\\tau_j` now, MuJoCo's ``implicitfast`` keeping its own
damping :math:`b_a` implicit. With the actuator's own gains (:math:`k_p = k_a`,
:math:`k_v = b_a`) this is the control :math:`u = q^{ref} + (b_a \\dot q^{ref} +
\\tau^{ff}) / k_a` a robot sends its position servos.

**Gains.** A robot whose own position actuators drive its legs uses their gains
when they can carry the robot: every leg joint that turns about a horizontal axis
(pitch, roll) at least :data:`CARRY_RATIO` times as stiff as gravity's tipping
stiffness in single support, :math:`k_{a,j} \\ge \\kappa\\, m g z_c` (the robot, mass
:math:`m`, an inverted pendulum of height :math:`z_c` on the hip, knee and ankle in
series). Otherwise (no actuators, torque motors, or too soft: Booster T1's
:math:`k_a` = 75 N·m/rad against 332) each joint starts from its servo's gains in
the scene (:attr:`pik_mj.sim.Scene.servo_gains`: the robot's own actuator's, or
the scene's :math:`\\omega^2 M_{jj}`), those leg joints are raised to
:math:`\\kappa\\, m g z_c`, and every gain is capped where a tracking error of
:data:`LIMIT_ANGLE` would reach the joint's torque limit; :math:`k_v` follows
:math:`k_p` at the same damping ratio (:math:`k_v \\propto \\sqrt{k_p}`).

**Torque limits** are the robot's, from its MJCF: the joint's
``actuatorfrcrange``, else its actuator's ``forcerange`` (times the gear), else
for a torque motor its ``ctrlrange`` times gain and gear; none (±∞) when the
robot states none.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.sim import Scene

__all__ = ["GAINS", "JointDrive", "joint_drive", "torque_limits"]

GAINS = ("robot", "derived")
"""Where a drive's gains come from: the robot's own position actuators, or derived."""

CARRY_RATIO = 2.0
"""κ: a leg joint that carries the robot is at least κ times as stiff as gravity's
tipping stiffness m g z_c (the hip, knee and ankle give way in series)."""
LIMIT_ANGLE = 0.1
"""[rad] Tracking error at which a derived gain reaches the joint's torque limit."""

_HORIZONTAL = 0.5
"""|axis_z| below which a joint turns about a horizontal axis (pitch, roll)."""


def torque_limits(model: mujoco.MjModel, joints: Sequence[int]) -> np.ndarray:
    """The torque range (len(joints), 2) [N·m] (or [N]) each hinge/slide joint's
    actuators can exert (module docstring), ±inf where unlimited."""
    out = np.tile([-np.inf, np.inf], (len(joints), 1))
    for i, j in enumerate(joints):
        if model.jnt_actfrclimited[j]:
            out[i] = model.jnt_actfrcrange[j]
            continue
        for a in np.flatnonzero(
            (model.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT)
            & (model.actuator_trnid[:, 0] == j)
        ):
            gear = abs(float(model.actuator_gear[a, 0]))
            if model.actuator_forcelimited[a]:
                out[i] = gear * model.actuator_forcerange[a]
            elif (
                model.actuator_ctrllimited[a]
                and model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE
                and model.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
            ):
                out[i] = np.sort(gear * model.actuator_gainprm[a, 0] * model.actuator_ctrlrange[a])
            else:
                continue
            break
    return out


@dataclass(frozen=True)
class JointDrive:
    """The servo law of a playback (module docstring) over the scene's servo joints.

    Attributes:
        joints: The joints (``scene.servo_joints``).
        q_adr: Their qpos addresses.
        dofs: Their dof addresses.
        actuators: Their servos' actuator ids in the scene.
        kp: Loop stiffness per joint [N·m/rad].
        kv: Loop damping per joint [N·m·s/rad].
        k_a: Each servo actuator's own stiffness ``gear² g_0`` [N·m/rad].
        b_a: Each servo actuator's own damping [N·m·s/rad].
        limits: Torque range per joint (n, 2) [N·m].
        gains: ``"robot"`` (the robot's own actuators' gains) or ``"derived"``.
        tipping_stiffness: :math:`m g z_c` [N·m/rad].
    """

    joints: tuple[str, ...]
    q_adr: np.ndarray
    dofs: np.ndarray
    actuators: np.ndarray
    kp: np.ndarray
    kv: np.ndarray
    k_a: np.ndarray
    b_a: np.ndarray
    limits: np.ndarray
    gains: str
    tipping_stiffness: float

    def torques(
        self,
        data: mujoco.MjData,
        q_ref: np.ndarray,
        qd_ref: np.ndarray,
        tau_ff: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(τ, τ_wanted)`` [N·m] per joint at the state in ``data``: the law
        clipped to the limits, and before clipping."""
        q, qd = data.qpos[self.q_adr], data.qvel[self.dofs]
        wanted = self.kp * (q_ref - q) + self.kv * (qd_ref - qd) + tau_ff
        return np.clip(wanted, self.limits[:, 0], self.limits[:, 1]), wanted

    def apply(self, data: mujoco.MjData, tau: np.ndarray) -> None:
        """Set the servos' controls so that they exert ``tau`` [N·m] now."""
        q, qd = data.qpos[self.q_adr], data.qvel[self.dofs]
        data.ctrl[self.actuators] = q + (tau + self.b_a * qd) / self.k_a

    def to_dict(self) -> dict[str, object]:
        """The drive's summary: the gains' origin, their range, the limits' range."""
        finite = np.isfinite(self.limits[:, 1])
        return {
            "gains": self.gains,
            "kp_min": float(self.kp.min()),
            "kp_max": float(self.kp.max()),
            "kv_max": float(self.kv.max()),
            "tipping_stiffness": self.tipping_stiffness,
            "torque_limited_joints": int(finite.sum()),
        }


def joint_drive(
    scene: Scene,
    q0: np.ndarray,
    com_height: float,
    legs: Sequence[str],
    gains: str | None = None,
) -> JointDrive:
    """The drive of ``scene``'s servo joints for a walk whose CoM is ``com_height``
    [m] above the soles (module docstring), gains measured at the robot
    configuration ``q0``.

    Args:
        scene: The robot's scene.
        q0: The pattern's first configuration (the robot's ``nq``).
        com_height: ``z_c`` [m].
        legs: The robot's legs (their joints decide whether its own gains can carry it).
        gains: ``"robot"`` or ``"derived"`` (:data:`GAINS`) to choose; None: the
            robot's own where they can carry it (module docstring).

    Raises:
        InvalidInput: ``gains`` is not one of :data:`GAINS` or None, or ``"robot"``
            for joints without the robot's own position actuator.
    """
    if gains is not None and gains not in GAINS:
        raise InvalidInput(f"gains must be one of {list(GAINS)} or None, got {gains!r}")
    rm = scene.robot.model
    names = tuple(scene.servo_joints)
    ids = [rm.joint(j).id for j in names]
    actuators = np.array([scene.servo_actuators[j] for j in names])
    model = scene.model
    gear2 = model.actuator_gear[actuators, 0] ** 2
    k_a = gear2 * model.actuator_gainprm[actuators, 0]
    b_a = -gear2 * model.actuator_biasprm[actuators, 2]
    tipping = scene.mass * float(np.linalg.norm(model.opt.gravity)) * com_height
    data = mujoco.MjData(rm)
    data.qpos[:] = q0
    mujoco.mj_kinematics(rm, data)
    leg_joints = {j for leg in legs for j in scene.robot.limb(leg).joints}
    carrying = np.array(
        [
            n in leg_joints and abs(data.xaxis[j][2]) < _HORIZONTAL
            for n, j in zip(names, ids, strict=True)
        ]
    )
    own = np.array([n in scene.robot_servos for n in names])
    if gains == "robot" and not own.all():
        missing = [n for n, o in zip(names, own, strict=True) if not o]
        raise InvalidInput(f"gains='robot': joints {missing} have no position actuator")
    limits = torque_limits(rm, ids)
    stiff = CARRY_RATIO * tipping
    can_carry = own[carrying].all() and bool(np.all(k_a[carrying] >= stiff))
    if gains == "robot" or (gains is None and can_carry):
        kp, kv, origin = k_a.copy(), b_a.copy(), "robot"
    else:
        kp, kv = (np.array([scene.servo_gains[n][i] for n in names]) for i in (0, 1))
        target = np.where(carrying, np.maximum(kp, stiff), kp)
        cap = np.minimum(limits[:, 1], -limits[:, 0]) / LIMIT_ANGLE
        target = np.minimum(target, cap)
        # the same damping ratio: k_v / sqrt(k_p) stays (k_v = 2 ζ sqrt(k_p M))
        kv = kv * np.sqrt(target / np.maximum(kp, 1e-12))
        kp, origin = target, "derived"
    return JointDrive(
        joints=names,
        q_adr=np.array([rm.jnt_qposadr[j] for j in ids]),
        dofs=np.array([rm.jnt_dofadr[j] for j in ids]),
        actuators=actuators,
        kp=kp,
        kv=kv,
        k_a=k_a,
        b_a=b_a,
        limits=limits,
        gains=origin,
        tipping_stiffness=tipping,
    )
