r"""The time-parameterized reference of a path in a scene: :class:`MotionReference`,
what the servos track while a motion plays (:func:`pik_mj.sim.motion.play`).

**Timing.** The ``joint-velocity-task`` (prioritized-IK manual) takes one
iteration to last ``Δt`` and bounds its step by the joint velocity limits,
``|Δθ_j| ≤ θ̇_max,j Δt``. Read backwards, a step ``Δq_i``
(``mj_differentiatePos``) takes at least

.. math::

    T_i = \max_j \frac{|\Delta q_{i,j}|}{s\, \dot\theta_{max,j}}

at a speed scale ``s``. The limits are, per degree of freedom: the caller's
(``max_velocity``), else a :class:`pik_mj.tasks.JointVelocityTask` of the
solve's levels, else the irteus joints' defaults (:data:`IRTEUS_MAX_VELOCITY`,
irteus manual: ``rotational-joint`` 5 rad/s, ``linear-joint`` π/4 m/s, the
``6dof-joint`` of a floating base 1.6 m/s and π/4 rad/s). The waypoints sit at
the nominal times ``σ_i = Σ_{k<i} T_k`` along a path linear between them in
joint space (``mj_integratePos``); each segment (one solve's iterates, from
the pose before its first iterate to its last) is travelled with the
minimum-jerk time scaling

.. math::

    \sigma(t) = \sigma_a + S_k\, \big(10 τ^3 - 15 τ^4 + 6 τ^5\big), \quad
    τ = (t - t_k) / T_k, \qquad T_k = \tfrac{15}{8}\, S_k

(``S_k`` the segment's nominal time), which starts and ends at rest with zero
acceleration: a sequence of solves (look, reach, lift) is a sequence of
motions, not one path whose direction turns abruptly at a solve's boundary.
The peak rate ``dσ/dt = 15 S_k / 8 T_k = 1`` keeps every joint within
``s θ̇_max``.

**Tracking.** The scene's position servos ``τ = k_p (u - q) - k_v q̇`` get the
target ``u = q_{ref} + (k_v / k_p)\, \dot q_{ref}`` (the damping then acts on the
velocity error) and the static torques of the waypoints
(:func:`pik_mj.sim.hold.holding_torques`, linear in ``σ`` between knots) as
feed-forward.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.sim.hold import holding_torques
from pik_mj.sim.path import Waypoints
from pik_mj.sim.physics import External, Physics

__all__ = [
    "IRTEUS_MAX_VELOCITY",
    "SEED_MAX_VELOCITY",
    "MotionReference",
    "PhysicsState",
    "velocity_limits",
]

IRTEUS_MAX_VELOCITY: dict[str, tuple[float, ...]] = {
    "hinge": (5.0,),
    "slide": (math.pi / 4,),
    "ball": (math.pi / 4,) * 3,
    "free": (0.08 / 0.05,) * 3 + (math.pi / 4,) * 3,
}
"""The ``max-joint-velocity`` defaults of the irteus joint classes (irteus manual)
per MuJoCo joint type [rad/s or m/s]: ``rotational-joint`` 5, ``linear-joint``
π/4, ``sphere-joint`` π/4 per axis, ``6dof-joint`` (0.08/0.05, 0.08/0.05,
0.08/0.05, π/4, π/4, π/4)."""

SEED_MAX_VELOCITY = IRTEUS_MAX_VELOCITY
"""Alias of :data:`IRTEUS_MAX_VELOCITY`."""

_PEAK_RATE = 15.0 / 8.0  # max of d/dτ (10τ³ - 15τ⁴ + 6τ⁵)
_KNOT_SPACING = 0.05  # [s] of nominal time between knots of the torque feed-forward

_DRIVEN = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
_JOINT_TYPES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "free",
    int(mujoco.mjtJoint.mjJNT_BALL): "ball",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}


def _min_jerk(tau: np.ndarray | float) -> np.ndarray | float:
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def _min_jerk_rate(tau: float) -> float:
    return 30.0 * tau**2 * (1.0 - tau) ** 2


def velocity_limits(
    scene: Physics,
    max_velocity: float | Mapping[str, float] | None = None,
    task_bounds: Mapping[int, tuple[float, float]] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper velocity limits (nv,) [rad/s or m/s] of the robot's degrees
    of freedom (``±inf`` for the environment's: objects are not driven).

    Per degree of freedom: ``max_velocity`` (one value for all, or by joint
    name), else ``task_bounds`` (``dof -> (min, max)``, from a joint velocity
    task), else :data:`IRTEUS_MAX_VELOCITY` by joint type.

    Raises:
        InvalidInput: A limit that is not a finite number > 0.
        UnknownName: A joint of ``max_velocity`` that does not exist.
    """
    rm = scene.robot.model
    lo, hi = np.full(rm.nv, -np.inf), np.full(rm.nv, np.inf)
    robot_joint = scene.robot_bodies[rm.jnt_bodyid]
    for j in np.flatnonzero(robot_joint):
        adr = int(rm.jnt_dofadr[j])
        v = np.array(IRTEUS_MAX_VELOCITY[_JOINT_TYPES[int(rm.jnt_type[j])]])
        lo[adr : adr + len(v)], hi[adr : adr + len(v)] = -v, v
    for dof, (a, b) in (task_bounds or {}).items():
        lo[dof], hi[dof] = a, b
    if max_velocity is not None:
        if isinstance(max_velocity, Mapping):
            items = [(rm.joint(name).id, v) for name, v in max_velocity.items()]
        else:
            items = [(int(j), max_velocity) for j in np.flatnonzero(robot_joint)]
        for j, v in items:
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InvalidInput(f"max_velocity must be > 0 [rad/s or m/s], got {v!r}")
            adr = int(rm.jnt_dofadr[j])
            n = len(IRTEUS_MAX_VELOCITY[_JOINT_TYPES[int(rm.jnt_type[j])]])
            lo[adr : adr + n], hi[adr : adr + n] = -v, v
    return lo, hi


class _ServoLaw:
    r"""The controls of the scene's position actuators (its servos and the
    robot's own, joint transmissions) for a reference ``(q_ref, q̇_ref)``: an
    actuator's force ``g_0 u + b_0 + b_1 L + b_2 L̇`` with ``L = γ q`` becomes
    ``-b_1 γ (q_ref - q) - b_2 γ (q̇_ref - q̇)`` at

    .. math::

        u = -(b_0 + b_1 γ q_{ref} + b_2 γ \dot q_{ref}) / g_0

    (for a scene servo ``g_0 = k_p = -b_1``, ``b_2 = -k_v``, ``γ = 1``:
    ``u = q_ref + (k_v / k_p) q̇_ref``)."""

    def __init__(self, scene: Physics):
        m = scene.model
        nq, nv = scene.robot_nq, scene.robot.model.nv
        ids = [
            int(a)
            for a in scene.position_actuators
            if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
            and int(m.jnt_type[m.actuator_trnid[a, 0]]) in _DRIVEN
            and m.jnt_qposadr[m.actuator_trnid[a, 0]] < nq
            and m.jnt_dofadr[m.actuator_trnid[a, 0]] < nv
        ]
        self.ids = np.array(ids, dtype=int)
        joints = m.actuator_trnid[self.ids, 0]
        self.qadr, self.dof = m.jnt_qposadr[joints], m.jnt_dofadr[joints]
        self.gear = m.actuator_gear[self.ids, 0]
        self.g0 = m.actuator_gainprm[self.ids, 0]
        self.b = m.actuator_biasprm[self.ids, :3]

    def write(self, d: mujoco.MjData, q: np.ndarray, qd: np.ndarray) -> None:
        b0, b1, b2 = self.b.T
        L, Ld = self.gear * q[self.qadr], self.gear * qd[self.dof]
        d.ctrl[self.ids] = -(b0 + b1 * L + b2 * Ld) / self.g0


@dataclass(frozen=True)
class PhysicsState:
    """The physics state a motion ended in (what a following one starts from).

    Attributes:
        time: Simulated time [s].
        qpos, qvel, act: MuJoCo's state.
        nq: The scene's ``nq`` (checked on use).
    """

    time: float
    qpos: np.ndarray
    qvel: np.ndarray
    act: np.ndarray

    @classmethod
    def of(cls, data: mujoco.MjData) -> PhysicsState:
        return cls(float(data.time), data.qpos.copy(), data.qvel.copy(), data.act.copy())


class MotionReference:
    """The time-parameterized reference of a path in a scene (module docstring).

    Args:
        scene: The scene whose servos track it.
        path: The waypoints.
        lower, upper: Velocity limits (nv,) [rad/s or m/s] (:func:`velocity_limits`).
        speed: Fraction of the limits, in (0, 1].
        external: Wrenches acting during the motion (in the static torques).
        external_ramp: The wrenches grow with the path's progress ``σ / S``,
            from 0 at the first waypoint to their value at the last (:attr:`load`).
        feedforward: Add the static torques of the waypoints.
        start: Physics state to continue from, or None (reset, the first
            waypoint at rest).

    Attributes:
        times: Time [s] of each waypoint from the start.
        duration: Time [s] of the path (the last waypoint's).
        nominal: Nominal time ``σ_i`` [s] of each waypoint.
        data: Kinematics of the reference now.
        waypoint: Index of the last waypoint passed.
        load: Scale of the external wrenches now.
    """

    moving = True

    def __init__(
        self,
        scene: Physics,
        path: Waypoints,
        lower: np.ndarray,
        upper: np.ndarray,
        *,
        speed: float,
        external: Sequence[External] = (),
        external_ramp: bool = False,
        feedforward: bool = True,
        start: PhysicsState | None = None,
    ):
        self.scene = scene
        self._ramp = bool(external_ramp)
        self.load = 0.0 if self._ramp else 1.0
        rm = scene.robot.model
        self._rm = rm
        self.q = path.q
        n = len(self.q)
        self._dv = np.zeros((max(n - 1, 0), rm.nv))
        for i in range(n - 1):
            mujoco.mj_differentiatePos(rm, self._dv[i], 1.0, self.q[i], self.q[i + 1])
        rate = np.where(self._dv >= 0, upper, -lower) * speed  # [rad/s] per dof and step
        with np.errstate(divide="ignore", invalid="ignore"):
            steps = np.where(self._dv == 0.0, 0.0, np.abs(self._dv) / rate)
        self._T = steps.max(axis=1) if n > 1 else np.zeros(0)
        self.nominal = np.concatenate([[0.0], np.cumsum(self._T)])
        # each segment (solve) starts and ends at rest: its own min-jerk scaling
        labels = [w.segment for w in path.items]
        firsts = [0] + [i for i in range(1, n) if labels[i] != labels[i - 1]]
        ends = [f - 1 for f in firsts[1:]] + [n - 1]
        self._seg_s = np.array(
            [
                [self.nominal[max(a - 1, 0)], self.nominal[b]]
                for a, b in zip(firsts, ends, strict=True)
            ]
        )
        self._seg_D = _PEAK_RATE * (self._seg_s[:, 1] - self._seg_s[:, 0])
        self._seg_t = np.concatenate([[0.0], np.cumsum(self._seg_D)])
        self.duration = float(self._seg_t[-1])
        table = np.linspace(0.0, 1.0, 4001)
        self.times = np.zeros(n)
        for k, (a, b) in enumerate(zip(firsts, ends, strict=True)):
            s0, s1 = self._seg_s[k]
            if s1 > s0:
                frac = (self.nominal[a : b + 1] - s0) / (s1 - s0)
                self.times[a : b + 1] = self._seg_t[k] + self._seg_D[k] * np.interp(
                    frac, _min_jerk(table), table
                )
            else:
                self.times[a : b + 1] = self._seg_t[k]
        self._start = start
        self.data = mujoco.MjData(scene.model)  # the environment at qpos0
        self.waypoint = 0
        self._servos = _ServoLaw(scene)
        self._knots, self._tau = self._torques(external) if feedforward else (None, None)
        self._q_ref = self.q[0].copy()
        self._qd_ref = np.zeros(rm.nv)

    def _torques(
        self, external: Sequence[External]
    ) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
        """Static torques on the servo dofs at knots spaced ``_KNOT_SPACING`` of
        nominal time apart (and the last waypoint); knots without static
        equilibrium are left out. Returns (knots' nominal times (k,), torques
        (k, servos)), or (None, None) when no knot has an equilibrium."""
        keep, last = [], -math.inf
        for i, s in enumerate(self.nominal):
            if s - last >= _KNOT_SPACING or i == len(self.nominal) - 1:
                keep.append(i)
                last = s
        dofs = self.scene.servo_dofs
        S = float(self.nominal[-1])
        knots, taus = [], []
        for i in keep:
            load = (self.nominal[i] / S if S > 0 else 1.0) if self._ramp else 1.0
            scaled = [
                (f, load * np.asarray(F, float), load * np.asarray(M, float))
                for f, F, M in external
            ]
            tau = holding_torques(self.scene, self.q[i], scaled)
            if tau is not None:
                knots.append(self.nominal[i])
                taus.append(tau[dofs])
        if not knots:
            return None, None
        return np.array(knots), np.array(taus)

    # -- the loop's interface ------------------------------------------------

    def begin(self) -> None:
        """Reset the physics to the first waypoint at rest (or continue from the
        start state) and write the controls of time 0."""
        scene = self.scene
        m, d = scene.model, scene.data
        if self._start is None:
            mujoco.mj_resetData(m, d)
            scene.set_pose(self.q[0])
        else:
            st = self._start
            if st.qpos.shape != (m.nq,) or st.qvel.shape != (m.nv,) or st.act.shape != (m.na,):
                raise InvalidInput(
                    "the start state is not of this scene's model (nq, nv, na differ): "
                    "continue a motion only in a scene of the same robot and world"
                )
            mujoco.mj_resetData(m, d)
            d.time = st.time
            d.qpos[:], d.qvel[:], d.act[:] = st.qpos, st.qvel, st.act
        self._t0 = float(d.time)
        self.update(0.0)
        mujoco.mj_forward(m, d)

    def update(self, t: float) -> None:
        """The reference at time ``t`` [s]: kinematics, servo targets and torques."""
        scene, rm = self.scene, self._rm
        S = float(self.nominal[-1])
        k = int(np.searchsorted(self._seg_t, t, side="right") - 1)
        if 0 <= k < len(self._seg_D) and self._seg_D[k] > 0:
            (s0, s1), D = self._seg_s[k], self._seg_D[k]
            tau_t = (t - self._seg_t[k]) / D
            s = s0 + (s1 - s0) * float(_min_jerk(tau_t))
            rate = (s1 - s0) / D * _min_jerk_rate(tau_t)  # dσ/dt
        else:
            s, rate = S, 0.0
        if self._ramp:
            self.load = s / S if S > 0 else 1.0
        i = int(np.searchsorted(self.nominal, s, side="right") - 1)
        i = min(max(i, 0), len(self.q) - 1)
        self.waypoint = int(np.searchsorted(self.times, t, side="right") - 1)
        q = self.q[i].copy()
        if i < len(self.q) - 1 and self._T[i] > 0:
            alpha = (s - self.nominal[i]) / self._T[i]
            mujoco.mj_integratePos(rm, q, self._dv[i], alpha)
            self._qd_ref = self._dv[i] * (rate / self._T[i])
        else:
            self._qd_ref = np.zeros(rm.nv)
        self._q_ref = q
        if scene.grasps:  # the grasped objects follow the hand
            self.data.qpos[:] = scene.qpos_of(q)
        else:  # the waypoints were checked (planned_contacts): no check per step
            self.data.qpos[: len(q)] = q
        mujoco.mj_kinematics(scene.model, self.data)
        d = scene.data
        self._servos.write(d, q, self._qd_ref)
        if self._knots is not None:  # linear in σ between knots, constant outside
            knots = self._knots
            j = int(np.clip(np.searchsorted(knots, s, side="right") - 1, 0, len(knots) - 1))
            if j == len(knots) - 1 or s <= knots[0]:
                tau = self._tau[j]
            else:
                w = (s - knots[j]) / (knots[j + 1] - knots[j])
                tau = (1.0 - w) * self._tau[j] + w * self._tau[j + 1]
            d.qfrc_applied[scene.servo_dofs] = tau
