r"""Motion playback of a solve (DESIGN.md §8): the iterates stepped in physics.

A solve's iterates (or the iterates of a sequence of solves) are a path in
configuration space. :class:`Waypoints` collects them in the open, as a
per-iteration callback::

    path = Waypoints(robot)                               # the start pose
    result = fullbody_inverse_kinematics(..., callback=[checks, log, path.segment("reach")])
    motion = scene.play(path)                             # a MotionReport

:func:`play` turns the path into a time-parameterized reference
(:class:`MotionReference`) that the scene's servos track while the physics
steps, in the same loop as a hold (:func:`pik_mj.sim.hold.track`: a hold is
the constant reference), and reports what happened (:class:`MotionReport`).

**Timing.** The seed's ``joint-velocity-task`` takes one iteration to last
``Δt`` and bounds its step by the joint velocity limits, ``|Δθ_j| ≤ θ̇_max,j Δt``.
Read backwards, a step ``Δq_i`` (``mj_differentiatePos``) takes at least

.. math::

    T_i = \max_j \frac{|\Delta q_{i,j}|}{s\, \dot\theta_{max,j}}

at a speed scale ``s``. The limits are, per degree of freedom: the caller's
(``max_velocity``), else a :class:`pik_mj.tasks.JointVelocityTask` of the
solve's levels, else the seed's joint defaults (:data:`SEED_MAX_VELOCITY`:
irteus ``rotational-joint`` 5 rad/s, ``linear-joint`` π/4 m/s, the
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
feed-forward. After the path the last pose is held for ``settle`` seconds.

**Contacts.** The planned contacts are the scene's ``allowed_contacts`` (the
soles, with anything) and the geom pairs of the static checks along the path:
a robot geom and the environment or robot geom it touches at a waypoint
(within the scene's ``contact_tolerance``, :meth:`Scene.touching`, and
penetrating by less than it), with each other only. Any other contact in the
physics is unexpected; a path that passes a limb through the body or an
obstacle between two waypoints shows up there.

**A sequence of scenes.** A grasp changes the physics (a weld): play the part
before it in the scene without the grasp, and the part after it in the scene
with it, continuing from the first part's final state
(``held.play(lift_path, start=reach_motion)``): the weld switches on at the
boundary. A hand without fingers, whose box ends around the handle, approaches
it in a scene with the hand's contacts with the object excluded
(``Scene.from_robot(robot, exclude=[(hand body, object body)])``: the open
fingers), the part before in the scene as it is (the kettle scenario).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import mink
import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.frames import Frame, names_of
from pik_mj.sim.hold import HoldCriteria, check_options, holding_torques, track
from pik_mj.sim.static import finite_or_none

if TYPE_CHECKING:
    from pik_mj.sim.scene import External, Scene
    from pik_mj.solve import IterationInfo, SolveResult

__all__ = [
    "DEFAULT_SETTLE",
    "DEFAULT_SPEED",
    "MOTION_CRITERIA",
    "SEED_MAX_VELOCITY",
    "Clearance",
    "MotionReference",
    "MotionReport",
    "PhysicsState",
    "Waypoint",
    "Waypoints",
    "min_distance",
    "play",
    "velocity_limits",
]

SEED_MAX_VELOCITY: dict[str, tuple[float, ...]] = {
    "hinge": (5.0,),
    "slide": (math.pi / 4,),
    "ball": (math.pi / 4,) * 3,
    "free": (0.08 / 0.05,) * 3 + (math.pi / 4,) * 3,
}
"""The seed's ``max-joint-velocity`` defaults per MuJoCo joint type [rad/s or
m/s]: ``rotational-joint`` 5, ``linear-joint`` π/4, ``sphere-joint`` π/4 per
axis, ``6dof-joint`` (0.08/0.05, 0.08/0.05, 0.08/0.05, π/4, π/4, π/4)."""

DEFAULT_SPEED = 0.2
"""Fraction of the joint velocity limits a motion moves at: 1 rad/s for a hinge,
0.32 m/s for a floating base. At half the seed's limits the servos of the
sample humanoid let its root lag 2-4 cm behind a lean (wall_contact,
fullbody_external_force); at 0.2 it stays within 1.5 cm."""

DEFAULT_SETTLE = 0.3
"""Time [s] the last pose is held after the path."""

MOTION_CRITERIA = HoldCriteria(max_drift=0.02)
"""Default pass/fail thresholds of a motion: the root within 2 cm of its
reference (a moving robot lags its reference by its servos' tracking error),
foot slip below 2 mm, no fall, no unexpected contact."""

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


# ---------------------------------------------------------------------------
# the path


@dataclass(frozen=True)
class Waypoint:
    """One configuration of a path.

    Attributes:
        q: Robot configuration (the robot model's ``nq``).
        segment: Label of the solve it comes from (the start pose: the first label).
        iteration: Iteration of that solve (0: the pose the solve started from).
    """

    q: np.ndarray
    segment: str
    iteration: int


class Waypoints:
    """A path of configurations, collected from solves (a per-iteration callback).

    Called with each :class:`~pik_mj.solve.IterationInfo`, it appends the
    configuration after the iteration, and notes the solve's frame tasks (whose
    frames :func:`play` compares with the reference) and joint velocity tasks
    (whose bounds time the steps). Successive solves append to the same path;
    :meth:`segment` names the next one, :meth:`finish` drops the iterates of a
    solve that reverted (the robot is back at its start).

    Args:
        start: The start pose: a :class:`pik_mj.Robot` (its current
            configuration), a ``mink.Configuration``, or a configuration.
        label: Label of the first segment.
    """

    def __init__(self, start: Any, label: str = "solve"):
        if hasattr(start, "configuration"):
            q0 = start.configuration.q
        elif isinstance(start, mink.Configuration):
            q0 = start.q
        else:
            q0 = start
        q0 = np.array(q0, dtype=float).reshape(-1)
        if not np.all(np.isfinite(q0)):
            raise InvalidInput("the start configuration of Waypoints holds NaN or inf")
        self.items: list[Waypoint] = [Waypoint(q0, str(label), 0)]
        self.label = str(label)
        self._first = 1  # index of the current segment's first iterate
        self.frames: dict[str, str] = {}  # move-target name -> frame type
        self.velocity_bounds: dict[int, tuple[float, float]] = {}  # dof -> (min, max)
        self._levels: Any = None

    def segment(self, label: str) -> Waypoints:
        """Start the segment ``label`` (the next solve's iterates); returns self,
        so that ``callback=[..., path.segment("grasp")]`` reads as what it does.
        The start pose belongs to the first segment."""
        self.label = str(label)
        if len(self.items) == 1:
            self.items[0] = Waypoint(self.items[0].q, self.label, 0)
        self._first = len(self.items)
        return self

    def __call__(self, info: IterationInfo) -> None:
        if info.levels is not self._levels:
            self._levels = info.levels
            self._note_tasks(info.levels)
        q = np.array(info.configuration.q, dtype=float)
        if q.shape != self.items[0].q.shape:
            raise InvalidInput(
                f"the solve's configuration has {q.size} entries, the path's start "
                f"{self.items[0].q.size}: collect one robot's solves in one path"
            )
        self.items.append(Waypoint(q, self.label, int(info.iteration)))

    def _note_tasks(self, levels: Sequence[Sequence[Any]]) -> None:
        from pik_mj.tasks.frame import FrameTask
        from pik_mj.tasks.joint_velocity import JointVelocityTask

        for task in (t for level in levels for t in level):
            if isinstance(task, FrameTask):
                self.frames.setdefault(task.move_target.name, task.move_target.frame_type)
            elif isinstance(task, JointVelocityTask):
                for dof, lo, hi in zip(task.dofs, task.min_vel, task.max_vel, strict=True):
                    self.velocity_bounds[int(dof)] = (float(lo), float(hi))

    def finish(self, result: SolveResult) -> SolveResult:
        """Drop the current segment's iterates if ``result`` reverted; returns it."""
        if result.reverted:
            del self.items[self._first :]
        return result

    @property
    def q(self) -> np.ndarray:
        """The configurations (N, nq)."""
        return np.array([w.q for w in self.items])

    def __len__(self) -> int:
        return len(self.items)

    def __repr__(self) -> str:
        labels = list(dict.fromkeys(w.segment for w in self.items))
        return f"Waypoints({len(self.items)} configurations, segments={labels})"


# ---------------------------------------------------------------------------
# timing


def velocity_limits(
    scene: Scene,
    max_velocity: float | Mapping[str, float] | None = None,
    task_bounds: Mapping[int, tuple[float, float]] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper velocity limits (nv,) [rad/s or m/s] of the robot's degrees
    of freedom (``±inf`` for the environment's: objects are not driven).

    Per degree of freedom: ``max_velocity`` (one value for all, or by joint
    name), else ``task_bounds`` (``dof -> (min, max)``, from a joint velocity
    task), else :data:`SEED_MAX_VELOCITY` by joint type.

    Raises:
        InvalidInput: A limit that is not a finite number > 0.
        UnknownName: A joint of ``max_velocity`` that does not exist.
    """
    rm = scene.robot.model
    lo, hi = np.full(rm.nv, -np.inf), np.full(rm.nv, np.inf)
    robot_joint = scene._robot_body[rm.jnt_bodyid]
    for j in np.flatnonzero(robot_joint):
        adr = int(rm.jnt_dofadr[j])
        v = np.array(SEED_MAX_VELOCITY[_JOINT_TYPES[int(rm.jnt_type[j])]])
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
            n = len(SEED_MAX_VELOCITY[_JOINT_TYPES[int(rm.jnt_type[j])]])
            lo[adr : adr + n], hi[adr : adr + n] = -v, v
    return lo, hi


# ---------------------------------------------------------------------------
# the reference


class _ServoLaw:
    r"""The controls of the scene's position actuators (its servos and the
    robot's own, joint transmissions) for a reference ``(q_ref, q̇_ref)``: an
    actuator's force ``g_0 u + b_0 + b_1 L + b_2 L̇`` with ``L = γ q`` becomes
    ``-b_1 γ (q_ref - q) - b_2 γ (q̇_ref - q̇)`` at

    .. math::

        u = -(b_0 + b_1 γ q_{ref} + b_2 γ \dot q_{ref}) / g_0

    (for a scene servo ``g_0 = k_p = -b_1``, ``b_2 = -k_v``, ``γ = 1``:
    ``u = q_ref + (k_v / k_p) q̇_ref``)."""

    def __init__(self, scene: Scene):
        m = scene.model
        nq, nv = scene.robot_nq, scene.robot.model.nv
        ids = [
            int(a)
            for a in scene._position_actuators
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
        scene: Scene,
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
        dofs = self.scene._servo_dofs
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
            self.data.qpos[:] = scene._qpos(q)
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
            d.qfrc_applied[scene._servo_dofs] = tau


# ---------------------------------------------------------------------------
# the report


@dataclass
class MotionReport:
    """What happened when a path was played in physics (:func:`play`).

    Attributes:
        passed: Every criterion holds (see ``failures``).
        failures: One line per failed criterion.
        duration: Time of the path [s] (then the last pose is held ``settle``).
        settle: Time the last pose was held [s].
        simulated: Simulated time [s] (shorter if the robot fell).
        speed: Fraction of the joint velocity limits.
        waypoint_times: Time [s] of each waypoint on the physics clock (the
            ``sim_time`` of a recording: the start state's time plus the
            waypoint's time from the start).
        segments: Segment label of each waypoint.
        tracking_error: Largest servo joint error ``|q - q_ref|`` [rad or m].
        tracking_joint: Joint where it was reached.
        frame_errors: Largest distance [m] of each task frame (the solves'
            frame tasks' move targets) to its reference position.
        drift: Largest distance of the root body to its reference position [m].
        min_margin: Smallest CoM margin [m] to the support polygon of the actual
            ground contacts (``-inf`` if contact was lost).
        slip: Largest foot slip relative to the reference [m].
        slip_per_geom: Slip of each planned contact geom [m].
        fell: The root dropped below ``fall_ratio`` of its reference height.
        planned_contacts: Robot geoms allowed to touch the environment
            anywhere (the scene's ``allowed_contacts``, the criteria's ``allowed``).
        planned_pairs: ``(robot geom, other geom)`` touching at a waypoint
            (:func:`planned_contacts`): allowed with each other only.
        unexpected_contacts: ``(robot geom, other geom, first time [s])``.
        thresholds: The pass/fail thresholds used.
        steps: Physics steps taken.
        timestep: Physics time step [s].
        final_state: The physics state at the end (``start`` of a next part).
        series: ``time`` [s], ``margin`` [m], ``tracking_error`` and
            ``waypoint`` every ``margin_every`` steps.
        wall_time: Wall-clock time [s] of the physics.
    """

    passed: bool
    failures: list[str]
    duration: float
    settle: float
    simulated: float
    speed: float
    waypoint_times: np.ndarray
    segments: list[str]
    tracking_error: float
    tracking_joint: str | None
    frame_errors: dict[str, float]
    drift: float
    min_margin: float
    slip: float
    slip_per_geom: dict[str, float]
    fell: bool
    planned_contacts: list[str]
    planned_pairs: list[tuple[str, str]]
    unexpected_contacts: list[tuple[str, str, float]]
    thresholds: dict[str, float]
    steps: int
    timestep: float
    final_state: PhysicsState = field(repr=False)
    series: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    wall_time: float = 0.0

    @property
    def max_frame_error(self) -> float:
        """Largest task-frame error [m] (0 without frames)."""
        return max(self.frame_errors.values(), default=0.0)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``min_com_margin`` None when contact was lost)."""
        frame = max(self.frame_errors, key=self.frame_errors.__getitem__, default=None)
        spans: dict[str, list[float]] = {}
        for label, t in zip(self.segments, self.waypoint_times, strict=True):
            spans.setdefault(label, [float(t), float(t)])[1] = float(t)
        return {
            "passed": self.passed,
            "failures": list(self.failures),
            "duration": self.duration,
            "settle": self.settle,
            "simulated": self.simulated,
            "speed": self.speed,
            "waypoints": len(self.waypoint_times),
            "segments": spans,
            "max_tracking_error": {
                "joints_rad": self.tracking_error,
                "joint": self.tracking_joint,
                "frames_m": self.max_frame_error,
                "frame": frame,
            },
            "frame_errors_m": dict(self.frame_errors),
            "max_drift": self.drift,
            "min_com_margin": finite_or_none(self.min_margin),
            "max_slip": self.slip,
            "slip_per_geom": dict(self.slip_per_geom),
            "contacts": {
                "planned": list(self.planned_contacts),
                "planned_pairs": [list(p) for p in self.planned_pairs],
                "unexpected": [list(c) for c in self.unexpected_contacts],
            },
            "fell": self.fell,
            "thresholds": dict(self.thresholds),
            "steps": self.steps,
            "timestep": self.timestep,
            "wall_time": self.wall_time,
        }

    def summary(self) -> str:
        """One line: the verdict and the figures."""
        margin = (
            f"{self.min_margin * 1e3:.1f} mm"
            if math.isfinite(self.min_margin)
            else "none (no ground contact)"
        )
        return (
            f"motion: {'PASSED' if self.passed else 'FAILED'} — {self.duration:.2f} s "
            f"(+{self.settle:g} s settle), {len(self.waypoint_times)} waypoints; tracking "
            f"error {self.tracking_error:.3f} rad, frames {self.max_frame_error * 1e3:.1f} mm; "
            f"drift {self.drift * 1e3:.1f} mm, slip {self.slip * 1e3:.2f} mm, min CoM margin "
            f"{margin}; {'FELL' if self.fell else 'no fall'}, "
            f"{len(self.unexpected_contacts)} unexpected contacts"
            + (f"; {'; '.join(self.failures)}" if self.failures else "")
        )


# ---------------------------------------------------------------------------
# clearance along a motion


def _geom_ids(model: mujoco.MjModel, geoms: Sequence[str | int], what: str) -> list[int]:
    if isinstance(geoms, (str, bytes)) or not isinstance(geoms, Sequence) or not geoms:
        raise InvalidInput(f"{what} must be a non-empty list of geom names or ids, got {geoms!r}")
    out = []
    for g in geoms:
        if isinstance(g, str):
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g)
            if i < 0:
                raise UnknownName("geom", g, names_of(model, "geom"))
            out.append(int(i))
        elif isinstance(g, (int, np.integer)) and 0 <= g < model.ngeom:
            out.append(int(g))
        else:
            raise InvalidInput(f"{what}: {g!r} is not a geom of the model (0..{model.ngeom - 1})")
    return out


def min_distance(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    geoms: Sequence[int],
    obstacles: Sequence[int],
    distmax: float = 1.0,
) -> float:
    """Smallest signed distance [m] between any of ``geoms`` and any of
    ``obstacles`` (geom ids) in ``data``: MuJoCo's ``mj_geomDistance``, negative
    when they penetrate (the depth), ``distmax`` when all are farther."""
    return min(
        mujoco.mj_geomDistance(model, data, g, o, distmax, None) for g in geoms for o in obstacles
    )


class Clearance:
    """The smallest distance [m] between ``geoms`` and ``obstacles`` along a
    motion, in the physics (``physics``) and in the reference the servos track
    (``reference``): a callback of :meth:`pik_mj.sim.Scene.play` (one instance
    may follow several parts of a motion, in scenes of the same world).

    Args:
        model: The scene's model (geom names are looked up in it).
        geoms: Geom names or ids (e.g. an arm's).
        obstacles: Geom names or ids (e.g. a box, a counter).
        distmax: Distances beyond it read as ``distmax`` [m].

    Attributes:
        physics: Smallest distance in the physics [m] (``inf`` before a sample).
        reference: Smallest distance in the reference [m].
        physics_time: When the physics' smallest distance was reached [s].
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        geoms: Sequence[str | int],
        obstacles: Sequence[str | int],
        distmax: float = 1.0,
    ):
        self.geoms = _geom_ids(model, geoms, "geoms")
        self.obstacles = _geom_ids(model, obstacles, "obstacles")
        self.distmax = inputs.real(distmax, "distmax", unit="m", low=0, low_open=True)
        self.physics = self.reference = math.inf
        self.physics_time = math.nan

    def __call__(self, sample: Any) -> None:
        d = min_distance(sample.model, sample.data, self.geoms, self.obstacles, self.distmax)
        if d < self.physics:
            self.physics, self.physics_time = d, float(sample.time)
        if sample.reference is not None:
            d = min_distance(
                sample.model, sample.reference, self.geoms, self.obstacles, self.distmax
            )
            self.reference = min(self.reference, d)


# ---------------------------------------------------------------------------
# play


def planned_contacts(scene: Scene, path: Waypoints) -> list[tuple[str, str]]:
    """The geom pairs ``(robot geom, other geom)`` touching at any waypoint (with
    the environment or self-contacts): the static checks' contacts
    (:meth:`Scene.touching`), within the scene's ``contact_tolerance`` of
    touching. A pair that penetrates deeper than the tolerance at a waypoint
    collides there: it is not planned. A planned pair is planned with its
    partner only: a hand meant to touch a handle that sweeps through the
    counter makes an unexpected contact."""
    pairs: dict[tuple[str, str], None] = {}
    tolerance = scene.contact_tolerance
    for w in path.items:
        for c in scene.touching(scene._qpos(w.q)):
            if c.dist >= -tolerance:
                pairs.setdefault((c.robot_geom, c.other_geom))
    return list(pairs)


def play(
    scene: Scene,
    path: Waypoints | ArrayLike,
    *,
    speed: float = DEFAULT_SPEED,
    max_velocity: float | Mapping[str, float] | None = None,
    settle: float = DEFAULT_SETTLE,
    criteria: HoldCriteria | None = None,
    external: Sequence[External] = (),
    external_ramp: bool = False,
    callback: Callback | Sequence[Callback] | None = None,
    every: int = 1,
    margin_every: int = 10,
    feedforward: bool = True,
    start: MotionReport | PhysicsState | None = None,
    planned: Sequence[tuple[str, str]] = (),
) -> MotionReport:
    """Play ``path`` in the scene's physics (module docstring).

    Args:
        scene: The scene (its robot's configurations are the path's).
        path: :class:`Waypoints`, or configurations (N, nq).
        speed: Fraction of the joint velocity limits, in (0, 1].
        max_velocity: Velocity limit [rad/s or m/s] of every robot joint, or by
            joint name (default: a joint velocity task of the solves, else the
            seed's, :func:`velocity_limits`).
        settle: Time [s] the last pose is held after the path (>= 0).
        criteria: Pass/fail thresholds (default :data:`MOTION_CRITERIA`; drift and slip
            measured against the reference; its ``allowed`` geoms are planned).
        external: Wrenches ``(frame, force, moment)`` acting during the motion.
        external_ramp: Let the wrenches grow with the path's progress (0 at the
            first waypoint, their value at the last): a load taken up while
            reaching, for a path solved with the full load.
        callback: A callable or a list, called with a
            :class:`~pik_mj.sim.hold.HoldSample` every ``every`` steps (its
            ``reference`` and ``waypoint`` are set).
        every: Steps between callback calls.
        margin_every: Steps between evaluations of the CoM margin and the frame errors.
        feedforward: Add the waypoints' static torques.
        start: A motion (or its state) to continue from, e.g. the part before a
            grasp in the scene without the grasp; None: from rest at the first
            waypoint.
        planned: More planned contacts ``(robot geom, other geom)``, e.g. a hand
            closing on a handle it overlaps at the grasp (a pair penetrating
            at a waypoint is not planned by itself).

    Returns:
        A :class:`MotionReport`.

    Raises:
        InvalidInput: Bad options, configurations of another robot, a start
            state of another model.
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    if not isinstance(path, Waypoints):
        q = np.asarray(path, dtype=float)
        if q.ndim != 2 or len(q) < 1:
            raise InvalidInput(f"path must be Waypoints or configurations (N, nq), got {q.shape}")
        path = Waypoints(q[0], "path")
        path.items += [Waypoint(x.copy(), "path", i) for i, x in enumerate(q[1:], 1)]
    if path.items[0].q.shape != (scene.robot_nq,):
        raise InvalidInput(
            f"the path's configurations have {path.items[0].q.size} entries, the scene's robot "
            f"{scene.robot_nq}"
        )
    if not (isinstance(speed, (int, float)) and 0.0 < speed <= 1.0):
        raise InvalidInput(f"speed must be in (0, 1] (a fraction of the limits), got {speed!r}")
    if not (math.isfinite(settle) and settle >= 0):
        raise InvalidInput(f"settle must be >= 0 [s], got {settle}")
    external = inputs.wrenches(external, "external")
    state = start.final_state if isinstance(start, MotionReport) else start
    if state is not None and not isinstance(state, PhysicsState):
        raise InvalidInput(f"start must be a MotionReport or PhysicsState, got {type(start)}")
    lower, upper = velocity_limits(scene, max_velocity, path.velocity_bounds)
    t_wall = time.perf_counter()
    reference = MotionReference(
        scene,
        path,
        lower,
        upper,
        speed=float(speed),
        external=external,
        external_ramp=external_ramp,
        feedforward=feedforward,
        start=state,
    )
    duration = reference.duration + settle
    criteria = check_options(
        MOTION_CRITERIA if criteria is None else criteria,
        max(duration, scene.model.opt.timestep),
        every=every,
        margin_every=margin_every,
    )
    for pair in planned:
        if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
            raise InvalidInput(f"planned contacts are (robot geom, other geom) pairs, got {pair!r}")
        scene._allowed([pair[0]])  # a robot geom (UnknownName lists them)
        scene.model.geom(pair[1])
    pairs = list(dict.fromkeys([*planned_contacts(scene, path), *map(tuple, planned)]))
    given = scene.allowed_contacts if criteria.allowed is None else scene._allowed(criteria.allowed)
    allowed = list(dict.fromkeys([*scene.allowed_contacts, *given]))
    frames = [Frame.find(scene.model, name, kind) for name, kind in path.frames.items()]
    run = track(
        scene,
        reference,
        max(duration, scene.model.opt.timestep),
        criteria=criteria,
        allowed=allowed,
        planned_pairs={frozenset(p) for p in pairs},
        external=external,
        callbacks=as_callbacks(callback),
        every=every,
        margin_every=margin_every,
        frames=frames,
    )
    t0 = 0.0 if state is None else state.time
    failures = run.failures(criteria, drift="root drift from the reference")
    return MotionReport(
        passed=not failures,
        failures=failures,
        duration=reference.duration,
        settle=float(settle),
        simulated=run.simulated,
        speed=float(speed),
        waypoint_times=t0 + reference.times,
        segments=[w.segment for w in path.items],
        tracking_error=run.tracking_error,
        tracking_joint=run.tracking_joint,
        frame_errors=run.frame_errors,
        drift=run.drift,
        min_margin=run.min_margin,
        slip=run.foot_slip,
        slip_per_geom=run.slip_per_geom,
        fell=run.fell,
        planned_contacts=allowed,
        planned_pairs=pairs,
        unexpected_contacts=[(a, b, t) for (a, b), t in run.unexpected.items()],
        thresholds=criteria.thresholds(),
        steps=run.steps,
        timestep=float(scene.model.opt.timestep),
        final_state=PhysicsState.of(scene.data),
        series=run.series,
        wall_time=time.perf_counter() - t_wall,
    )
