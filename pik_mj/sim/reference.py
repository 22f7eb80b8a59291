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
the nominal times ``σ_i = Σ_{k<i} T_k``; each segment (one solve's iterates)
is travelled with a minimum-jerk time scaling that starts and ends at rest
(:class:`~pik_mj.sim.timing.Timing`): a sequence of solves (look, reach,
lift) is a sequence of motions, not one path whose direction turns abruptly at
a solve's boundary.

**What the drives deliver.** The torques the path needs at that timing
(inverse dynamics along the reference with the contact forces that carry the
robot) are checked against each servo joint's drive (force and control
ranges, its gains near a range end; :mod:`pik_mj.sim.drives`): a segment
whose torques pass a share of the bounds is slowed down, a path whose poses
need more than the drives give even at rest is not played and the joints are
named (:func:`pik_mj.sim.effort.plan_torques`).

**Geometry and balance.** Within a segment the path turns at its interior
waypoints through smooth blends (:class:`~pik_mj.sim.blends.BlendedPath`):
the joints' rates turn continuously, not at once. A segment whose planned
zero-moment point (inverse dynamics of the floating base along the reference)
would leave the support polygon's reserve is slowed down
(:func:`pik_mj.sim.zmp.stretch_for_balance`).

**Tracking.** The scene's position servos ``τ = k_p (u - q) - k_v q̇`` get the
target ``u = q_{ref} + (k_v / k_p)\, \dot q_{ref} + τ_{ff} / k_p`` (the damping
then acts on the velocity error; :class:`~pik_mj.sim.servos.ServoLaw`) with
the planned torques ``τ_ff`` (linear in time between knots) as feed-forward,
through the actuators: MuJoCo clamps them with the rest of the drive's force.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.sim.blends import BlendedPath
from pik_mj.sim.effort import plan_torques
from pik_mj.sim.knots import PathDynamics
from pik_mj.sim.path import Waypoints
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.timing import Timing
from pik_mj.sim.zmp import stretch_for_balance

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

_DRIVEN = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
_JOINT_TYPES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "free",
    int(mujoco.mjtJoint.mjJNT_BALL): "ball",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}


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
    dofs: list[int] = []
    limits: list[float] = []
    adrs, types = rm.jnt_dofadr.tolist(), rm.jnt_type.tolist()
    for j in np.flatnonzero(robot_joint).tolist():
        adr, v = adrs[j], IRTEUS_MAX_VELOCITY[_JOINT_TYPES[types[j]]]
        dofs += range(adr, adr + len(v))
        limits += v
    hi[dofs] = limits
    lo[dofs] = -hi[dofs]
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
        external: Wrenches acting during the motion (in the feed-forward).
        external_ramp: The wrenches grow with the path's progress ``σ / S``,
            from 0 at the first waypoint to their value at the last (:attr:`load`).
        feedforward: Plan the torques (:func:`pik_mj.sim.effort.plan_torques`):
            the servos' feed-forward, and the timing slowed down where the
            drives need it. False: the velocity limits alone, no feed-forward.
        start: Physics state to continue from, or None (reset, the first
            waypoint at rest).

    Attributes:
        timing: The path's :class:`~pik_mj.sim.timing.Timing`.
        times: Time [s] of each waypoint from the start.
        duration: Time [s] of the path (the last waypoint's).
        nominal: Nominal time ``σ_i`` [s] of each waypoint.
        torques: The :class:`~pik_mj.sim.effort.TorquePlan` (None without feed-forward).
        shortfalls: Joints whose drives cannot hold the path at rest (then it
            cannot be played).
        path: The :class:`~pik_mj.sim.blends.BlendedPath` played.
        balance_stretch: Segments slowed down for the ZMP, ``{segment index: c}``.
        data: Kinematics of the reference now.
        waypoint: Index of the last waypoint passed.
        load: Scale of the external wrenches now.

    Raises:
        InvalidInput: A waypoint that is not finite (its index and joint).
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
        path.check_finite(scene.model)  # the knots' poses are not checked one by one
        self.q = path.q
        n = len(self.q)
        self._dv = np.zeros((max(n - 1, 0), rm.nv))
        for i in range(n - 1):
            mujoco.mj_differentiatePos(rm, self._dv[i], 1.0, self.q[i], self.q[i + 1])
        rate = np.where(self._dv >= 0, upper, -lower) * speed  # [rad/s] per dof and step
        with np.errstate(divide="ignore", invalid="ignore"):
            steps = np.where(self._dv == 0.0, 0.0, np.abs(self._dv) / rate)
        labels = [w.segment for w in path.items]
        self.timing = Timing(steps.max(axis=1) if n > 1 else np.zeros(0), labels)
        self.nominal = self.timing.nominal
        self.path = BlendedPath(rm, self.q, self._dv, self.timing)
        knots = PathDynamics(scene, self.path, external, self._ramp)  # for both plans
        if feedforward and np.any(rm.jnt_type == mujoco.mjtJoint.mjJNT_FREE):
            knots.many(knots.sigma)  # the ZMP plan's knots (all): evaluated together
        self.torques = (
            plan_torques(scene, self.q, self._dv, self.timing, external, self._ramp, knots)
            if feedforward
            else None
        )
        self.shortfalls = [] if self.torques is None else self.torques.shortfalls
        self.balance_stretch = (
            stretch_for_balance(scene, self.path, self.timing, external, self._ramp, knots)
            if feedforward and not self.shortfalls
            else {}
        )
        self.duration = self.timing.duration
        self.times = self.timing.waypoint_times()
        self._start = start
        self.data: mujoco.MjData | None = None  # begin()'s: the environment at qpos0
        self.waypoint = 0
        self._servos = scene.servo_law
        self._ctrl = np.zeros(scene.model.nu)

    # -- the loop's interface ------------------------------------------------

    def begin(self, data: mujoco.MjData | None = None) -> None:
        """Reset the physics to the first waypoint at rest (or continue from the
        start state) and write the controls of time 0; the reference's
        kinematics in ``data`` (at its reset state: the environment at
        ``qpos0``; default: a new data of the scene's model)."""
        scene = self.scene
        m, d = scene.model, scene.data
        self.data = mujoco.MjData(m) if data is None else data
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
        self._ctrl = d.ctrl.copy()
        d.ctrl[:] = self.controls(np.zeros(1))[0]
        self.update(0.0)
        mujoco.mj_forward(m, d)

    def update(self, t: float) -> None:
        """The reference at time ``t`` [s]: its kinematics (:attr:`data`),
        :attr:`waypoint` and :attr:`load`."""
        for _ in self.updates(np.array([t], dtype=float)):
            pass

    def updates(self, times: np.ndarray) -> Iterator[None]:
        """The reference at each of ``times`` [s] in turn (as :meth:`update`; the
        timing evaluated for all of them at once), yielding after each."""
        scene, rm, timing = self.scene, self._rm, self.timing
        times = np.asarray(times, dtype=float)
        sigma, _, _ = timing.progress(times)
        loads = self.loads(times)
        waypoints = np.searchsorted(self.times, times, side="right") - 1
        bases, deltas, _, _ = self.path.offsets(sigma)
        if self.data is None:  # moved before begin(): a data of its own
            self.data = mujoco.MjData(scene.model)
        for base, delta, load, waypoint in zip(
            bases.tolist(), deltas, loads.tolist(), waypoints.tolist(), strict=True
        ):
            self.load, self.waypoint = load, waypoint
            q = self.q[base].copy()
            mujoco.mj_integratePos(rm, q, delta, 1.0)
            if scene.grasps:  # the grasped objects follow the hand
                self.data.qpos[:] = scene.qpos_of(q)
            else:  # the waypoints were checked (planned_contacts): no check per step
                self.data.qpos[: len(q)] = q
            mujoco.mj_kinematics(scene.model, self.data)
            yield

    def controls(self, t: np.ndarray) -> np.ndarray:
        """The actuators' controls (len(t), nu) at times ``t`` [s] from the start:
        the servos' (:class:`~pik_mj.sim.servos.ServoLaw`) for the reference's
        servo joint positions and rates and the planned feed-forward; the other
        actuators' as :meth:`begin` found them."""
        timing, law = self.timing, self._servos
        sigma, rate, accel = timing.progress(t)
        base, delta, slope, _ = self.path.offsets(sigma, law.dof)  # the driven joints' only
        q = self.q[:, law.qadr][base] + delta
        qd = slope * rate[:, None]
        tau = None if self.torques is None else self.torques.at(sigma, rate, accel, law.dof)
        ctrl = np.empty((len(t), len(self._ctrl)))
        ctrl[:] = self._ctrl
        ctrl[:, law.ids] = law.joint_controls(q, qd, tau)
        return ctrl

    def loads(self, t: np.ndarray) -> np.ndarray:
        """The scale (len(t),) of the external wrenches: ``σ / S`` with the ramp, else 1."""
        if not self._ramp:
            return np.ones(len(t))
        S = float(self.nominal[-1])
        return self.timing.progress(t)[0] / S if S > 0 else np.ones(len(t))
