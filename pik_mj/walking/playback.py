"""Play a :class:`~pik_mj.walking.wholebody.WalkPattern` in MuJoCo physics.

The robot stands in its :class:`pik_mj.sim.Scene` (made with
:meth:`~pik_mj.sim.Scene.from_robot`: a floor, a servo on every hinge joint; the
walks use :data:`WALK_CONTACT`); the physics starts at rest in the pattern's
first configuration, which the servos hold for a lead time before the pattern
plays. At every physics step each joint's servo exerts the torque
of :class:`~pik_mj.walking.drive.JointDrive`: position and velocity feedback
towards the pattern (linear between its ticks) plus the pattern's own joint
torques (inverse dynamics with the ground reaction on the support soles,
:func:`feedforward_torques`), within the robot's torque limits, with the robot's
own servo gains where they can carry it. The only balance feedback is the
stabilizer's (:mod:`pik_mj.sim.stabilizer`: the stance ankles' targets turned
against the body's inclination error); the pattern carries the rest. After the
pattern the last targets (and torques) are held for ``settle_time``.

Measured at each pattern tick: root height, sole positions, CoM, the ZMP of
the floor contact forces (all contact points lie on the floor plane, so it is
their force-weighted centre, :math:`p = \\sum_i f_{z,i} p_i / \\sum_i f_{z,i}`)
and its margin in the support polygon of the soles touching the floor at their
actual poses (:mod:`pik_mj.walking.support`), and the ZMP from the feet's force
sensors where the robot has them (its MJCF ``force``/``torque`` sensors on the
feet, irteus manual: ``:calc-zmp-from-forces-moments``;
:func:`pik_mj.robot.sensors.zmp_from_force_sensors`), what a robot measures.

The playback reports through callbacks: each gets a :class:`WalkSample` at every
sample (a recorder's walk logger is one, :meth:`pik_mj.record.Recorder.walk_logger`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.dynamics import joint_torques, root_wrench
from pik_mj.exceptions import InvalidInput
from pik_mj.robot.ground import subtree_bodies
from pik_mj.robot.sensors import RobotSensors, zmp_from_force_sensors
from pik_mj.sim import ContactParams, Fall, Scene
from pik_mj.sim.falls import fall_limits, fall_measures, first_fall
from pik_mj.sim.stabilizer import TiltStabilizer, tilt_stabilizer
from pik_mj.spatial import quat_to_matrix, yaw_of
from pik_mj.walking.drive import JointDrive, joint_drive
from pik_mj.walking.gait import DOUBLE_SUPPORT, wrap_angle
from pik_mj.walking.report import (
    SENSOR_VS_CONTACTS_RMS,
    SENSOR_ZMP_RMS,
    PlaybackReport,
    evaluate_walk,
    walk_motion,
)
from pik_mj.walking.support import zmp_margin
from pik_mj.walking.wholebody import WalkPattern

__all__ = [
    "SENSOR_VS_CONTACTS_RMS",
    "SENSOR_ZMP_RMS",
    "WALK_CONTACT",
    "PlaybackReport",
    "WalkSample",
    "evaluate_walk",
    "feedforward_torques",
    "play_walk_pattern",
    "walk_motion",
]

WALK_CONTACT = ContactParams()
"""Sole/floor contact of the walks (``Scene.from_robot(robot, contact=WALK_CONTACT)``):
MuJoCo's defaults with friction 1."""


@dataclass(frozen=True)
class WalkSample:
    """What :func:`play_walk_pattern` passes its callbacks at each sample (the
    pattern's ticks, then the settling), before the physics steps on; ``data`` is
    valid during the call.

    Attributes:
        k: Index of the sample (a tick of the pattern while ``k < len(pattern.t)``).
        time: Time from the start of the pattern [s], ``k * pattern.dt``.
        model: The scene's physics model.
        data: The physics state now (do not modify).
        pattern: The pattern played.
        root_body: Name of the robot's root body in the scene.
        com: Robot CoM (3,) [m].
        zmp: ZMP of the floor contact forces (2,) [m] (NaN without contact).
    """

    k: int
    time: float
    model: mujoco.MjModel
    data: mujoco.MjData
    pattern: WalkPattern
    root_body: str
    com: np.ndarray
    zmp: np.ndarray


def _stance_intervals(support: np.ndarray, limb: str) -> list[tuple[int, int]]:
    """``[start, end)`` tick ranges in which ``limb`` supports."""
    on = np.array([s == DOUBLE_SUPPORT or s == limb for s in support], dtype=bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def feedforward_torques(model: mujoco.MjModel, pattern: WalkPattern) -> np.ndarray:
    """Joint torques of the pattern with the ground reaction on the soles.

    Per tick, with velocities and accelerations by central differences, the
    total ground wrench :math:`(f, n_O)` is the free-joint rows of the inverse
    dynamics (:func:`pik_mj.dynamics.root_wrench`). It is split between the
    support soles :math:`S_i` (all on the support foot in single support; in
    double support by the position :math:`\\alpha` of the reference ZMP along
    the segment between the soles) as

    .. math::

        f_i = \\alpha_i f, \\qquad
        n_i = \\alpha_i \\Big(n_O - \\sum_j p_{S_j} \\times f_j\\Big)

    (so :math:`\\sum_i f_i = f`, :math:`\\sum_i n_i + p_{S_i} \\times f_i = n_O`),
    each acting on its foot body B (moment :math:`n_i + (p_{S_i} - p_B) \\times f_i`
    about B's origin), and :func:`pik_mj.dynamics.joint_torques` with these contact
    wrenches gives the joint torques; the free-joint rows then vanish.

    Args:
        model: The robot model of the pattern.
        pattern: The walking pattern.

    Returns:
        Generalized forces (K, nv) [N m]; free-joint rows ~0.
    """
    plan = pattern.plan
    data = mujoco.MjData(model)
    K, nv = len(pattern.t), model.nv
    padded = np.vstack([pattern.q[:1], pattern.q, pattern.q[-1:]])
    diff = np.empty((K + 1, nv))
    for k in range(K + 1):
        mujoco.mj_differentiatePos(model, diff[k], pattern.dt, padded[k], padded[k + 1])
    qvel = 0.5 * (diff[:-1] + diff[1:])
    qacc = (diff[1:] - diff[:-1]) / pattern.dt
    limbs = plan.params.all_limbs
    tau = np.empty((K, nv))
    for k in range(K):
        full = joint_torques(model, data, pattern.q[k], qvel[k], qacc[k])
        w_B, p_WB = root_wrench(model, data, full, pattern.root_body)
        f, n_O = w_B[:3], w_B[3:] + np.cross(p_WB, w_B[:3])
        p = {lb: plan.feet_p[lb][k] for lb in limbs}
        if plan.support[k] == DOUBLE_SUPPORT:
            d = p[limbs[1]][:2] - p[limbs[0]][:2]
            a = float(np.clip(d @ (plan.zmp_ref[k] - p[limbs[0]][:2]) / (d @ d), 0.0, 1.0))
            alpha = {limbs[0]: 1.0 - a, limbs[1]: a}
        else:
            alpha = {lb: float(lb == plan.support[k]) for lb in limbs}
        residual = n_O - sum(np.cross(p[lb], alpha[lb] * f) for lb in limbs)
        external = []
        for lb in limbs:
            sole = pattern.soles[lb]
            p_S, R_WS = pattern.feet_p[lb][k], pattern.feet_R[lb][k]
            p_B = p_S - R_WS @ sole.R_BS.T @ sole.p_BS
            f_i = alpha[lb] * f
            external.append((sole.body, f_i, alpha[lb] * residual + np.cross(p_S - p_B, f_i)))
        tau[k] = joint_torques(model, data, pattern.q[k], qvel[k], qacc[k], external)
    return tau


@dataclass(frozen=True)
class _Reference:
    """The pattern over the drive's joints, per tick: positions, velocities and
    feed-forward torques, read between ticks linearly."""

    q: np.ndarray  # (K, joints) [rad]
    qd: np.ndarray  # (K, joints) [rad/s]
    tau: np.ndarray  # (K, joints) [N m]

    @classmethod
    def of(cls, pattern: WalkPattern, drive: JointDrive, model: mujoco.MjModel, feedforward: bool):
        q = pattern.q[:, drive.q_adr]
        tau = feedforward_torques(model, pattern)[:, drive.dofs] if feedforward else 0.0 * q
        return cls(q, np.gradient(q, pattern.dt, axis=0), tau)

    def at(self, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, tau)`` at ``s`` ticks into the pattern (the last tick held
        after it, at rest)."""
        K = len(self.q)
        j = min(int(s), K - 1)
        if j >= K - 1:
            return self.q[-1], 0.0 * self.qd[-1], self.tau[-1]
        a = s - j
        return (
            (1.0 - a) * self.q[j] + a * self.q[j + 1],
            (1.0 - a) * self.qd[j] + a * self.qd[j + 1],
            (1.0 - a) * self.tau[j] + a * self.tau[j + 1],
        )


class _Saturation:
    """How often and how far the wanted torques exceeded the limits."""

    def __init__(self, drive: JointDrive) -> None:
        self.drive = drive
        self.steps = 0
        self.saturated = 0
        self.ratio = np.zeros(len(drive.joints))  # max |wanted| / |limit|
        self._hi, self._lo = drive.limits[:, 1], drive.limits[:, 0]  # (lo < 0 < hi)

    def add(self, wanted: np.ndarray, applied: np.ndarray) -> None:
        self.steps += 1
        if not np.array_equal(wanted, applied):
            self.saturated += 1
        np.maximum(self.ratio, np.maximum(wanted / self._hi, wanted / self._lo), out=self.ratio)

    def to_dict(self) -> dict[str, Any]:
        worst = int(np.argmax(self.ratio))
        return {
            "torque_saturated_fraction": self.saturated / max(self.steps, 1),
            "torque_demand_max_ratio": float(self.ratio[worst]),
            "torque_demand_max_joint": self.drive.joints[worst],
        }


class _Measurements:
    """What a playback measures at each sample (NaN where not taken).

    Attributes:
        root_p, com, feet_p, zmp, zmp_margin, zmp_sensors, zmp_sensors_margin: As in
            :class:`PlaybackReport`.
        bad: Robot geoms other than the soles that touched the floor.
    """

    def __init__(self, pattern: WalkPattern, scene: Scene, n: int) -> None:
        model = scene.model
        self.scene = scene
        self.soles = pattern.soles
        self.ground = float(pattern.plan.ground_z)
        self.root_id = model.body(scene.root_body).id
        self.robot_geom = np.asarray(model.body_rootid)[model.geom_bodyid] == self.root_id
        self.allowed = {model.geom(name).id for name in scene.allowed_contacts}
        self.leg_of_geom = {
            int(g): leg
            for leg, sole in self.soles.items()
            for g in np.flatnonzero(
                np.isin(model.geom_bodyid, subtree_bodies(model, model.body(sole.body).id))
            )
        }
        sensors = {f.name: f for f in RobotSensors.from_model(model).force_sensors}
        self.foot_sensors = [sensors[name] for name in pattern.force_sensors.values()]
        self.leg_of_sensor = {name: leg for leg, name in pattern.force_sensors.items()}
        self.root_p = np.full((n, 3), np.nan)
        self.root_R = np.full((n, 3, 3), np.nan)
        self.com = np.full((n, 3), np.nan)
        self.feet_p = {lb: np.full((n, 3), np.nan) for lb in self.soles}
        self.zmp = np.full((n, 2), np.nan)
        self.zmp_margin = np.full(n, np.nan)
        self.zmp_sensors = np.full((n if self.foot_sensors else 0, 2), np.nan)
        self.zmp_sensors_margin = np.full(n if self.foot_sensors else 0, np.nan)
        self.bad: set[str] = set()
        self._force = np.zeros(6)

    def take(self, k: int) -> None:
        """Measure sample ``k`` in the scene's state now."""
        model, data = self.scene.model, self.scene.data
        self.root_p[k] = data.xpos[self.root_id]
        self.root_R[k] = data.xmat[self.root_id].reshape(3, 3)
        self.com[k] = self.scene.com()
        for lb, sole in self.soles.items():
            self.feet_p[lb][k] = sole.pose(model, data)[0]
        self._contact_zmp(k, model, data)
        if self.foot_sensors:
            self._sensor_zmp(k, model, data)

    def _polygons(self, legs: set[str]) -> list[np.ndarray]:
        model, data = self.scene.model, self.scene.data
        return [self.soles[lb].polygon(model, data)[:, :2] for lb in sorted(legs)]

    def _contact_zmp(self, k: int, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The ZMP of the floor contact forces and its margin in the hull of the
        soles touching the floor; the robot geoms other than the soles on it."""
        fz_sum, p_sum = 0.0, np.zeros(2)
        touching: set[str] = set()
        for i in range(data.ncon):
            c = data.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if self.robot_geom[g1] == self.robot_geom[g2]:
                continue
            g_robot = g1 if self.robot_geom[g1] else g2
            if g_robot not in self.allowed:
                self.bad.add(model.geom(g_robot).name)
            mujoco.mj_contactForce(model, data, i, self._force)
            f_W = np.asarray(c.frame).reshape(3, 3).T @ self._force[:3]
            fz = abs(f_W[2])
            fz_sum += fz
            p_sum += fz * np.asarray(c.pos[:2])
            if g_robot in self.leg_of_geom and fz > 1e-6:
                touching.add(self.leg_of_geom[g_robot])
        if fz_sum > 1e-6:
            self.zmp[k] = p_sum / fz_sum
            if touching:
                self.zmp_margin[k] = zmp_margin(self.zmp[k], self._polygons(touching))

    def _sensor_zmp(self, k: int, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The ZMP from the feet's force sensors and its margin to the hull of
        the soles carrying it, at their actual poses."""
        measured = zmp_from_force_sensors(model, data, self.foot_sensors, z=self.ground)
        if measured is None:
            return
        self.zmp_sensors[k] = measured.point[:2]
        legs = {self.leg_of_sensor[f] for f in measured.cops}
        self.zmp_sensors_margin[k] = zmp_margin(self.zmp_sensors[k], self._polygons(legs))


class _Falls:
    """The fall verdict of a playback (:mod:`pik_mj.sim.falls`): the root's tilt,
    drift and height at each sample against the pattern's root pose at that tick
    (its last one after it; ``p_ref``, ``R_ref`` per tick), thresholds from the
    robot's feet."""

    def __init__(
        self, pattern: WalkPattern, scene: Scene, ratio: float, standing: float, n: int
    ) -> None:
        adr = scene.robot.free_qposadr
        assert adr is not None  # calc_walk_pattern refuses robots without a free joint
        self.p_ref = pattern.q[:, adr : adr + 3]
        self.R_ref = np.array([quat_to_matrix(quat) for quat in pattern.q[:, adr + 3 : adr + 7]])
        self.up = scene.up()
        self.standing = standing
        self.limits = fall_limits(
            None,
            None,
            ratio,
            foot=scene.foot_length,
            com_height=pattern.plan.com_height,
            root_height=standing,
        )
        self.tilt, self.drift = np.full(n, np.nan), np.full(n, np.nan)
        self.fall: Fall | None = None

    def fallen(self, k: int, t: float, p_WB: np.ndarray, R_WB: np.ndarray) -> bool:
        """Measure sample ``k`` at time ``t`` [s]; whether the robot has fallen."""
        j = min(k, len(self.p_ref) - 1)
        tilt, drift, h, h_ref = fall_measures(p_WB, R_WB, self.p_ref[j], self.R_ref[j], self.up)
        self.tilt[k], self.drift[k] = tilt[0], drift[0]
        self.fall = first_fall(np.array([t]), tilt, drift, h, h_ref, self.limits)
        return self.fall is not None


def _check_playback(
    scene: Scene, pattern: WalkPattern, settle_time: float, fall_ratio: float
) -> None:
    """Raise :class:`~pik_mj.exceptions.InvalidInput` on a bad playback request."""
    if not isinstance(scene, Scene):
        raise InvalidInput(
            f"play_walk_pattern needs the robot's Scene (Scene.from_robot), got "
            f"{type(scene).__name__}"
        )
    if not (math.isfinite(settle_time) and settle_time >= 0):
        raise InvalidInput(f"settle_time must be finite and >= 0, got {settle_time}")
    if not 0.0 < fall_ratio < 1.0:
        raise InvalidInput(f"fall_ratio must be in (0, 1), got {fall_ratio}")
    if pattern.q.shape[1] != scene.robot_nq:
        raise InvalidInput(
            f"the pattern has configurations of size {pattern.q.shape[1]}, the scene's "
            f"robot {scene.robot_nq}: play it with the robot it was made for"
        )


def play_walk_pattern(
    pattern: WalkPattern,
    scene: Scene,
    *,
    settle_time: float = 1.0,
    lead_time: float = 0.1,
    torque_feedforward: bool = True,
    gains: str | None = None,
    stabilize: bool = True,
    fall_ratio: float = 0.8,
    callback: Callback | Sequence[Callback] | None = None,
) -> PlaybackReport:
    """Play ``pattern`` with the robot's joint servos and measure the outcome.

    Args:
        pattern: The walking pattern (configurations of the scene's robot).
        scene: The robot's scene (:meth:`pik_mj.sim.Scene.from_robot`; its servo
            actuators, time step and contacts are the playback's).
        settle_time: Time the last targets are held after the pattern [s].
        lead_time: Time the first tick is held before the pattern starts [s]: the
            robot, put at rest in that pose, settles on its soles with the
            servos on, so that the first sample measures the forces they hold
            it with (the feet's force sensors, which include the feet's own
            inertia, read the contact forces from then on).
        torque_feedforward: Add the pattern's joint torques
            (:func:`feedforward_torques`) to the servo law
            (:class:`~pik_mj.walking.drive.JointDrive`).
        gains: The servo gains, ``"robot"`` or ``"derived"``; None: the robot's
            own where they can carry it (:func:`~pik_mj.walking.drive.joint_drive`).
        stabilize: Turn the stance ankles' targets against the body's
            inclination error (:mod:`pik_mj.sim.stabilizer`).
        fall_ratio: Root height ratio below which the robot counts as fallen
            (:mod:`pik_mj.sim.falls`: so does a trunk tilted beyond
            ``atan(L / z_c)`` or a root drifted more than ``L`` from the pattern's,
            ``L`` the foot's length); the simulation stops there.
        callback: A callable or a list, each called with a :class:`WalkSample`
            at every sample, in order (e.g. a recorder's
            :meth:`~pik_mj.record.Recorder.walk_logger`).

    Returns:
        A :class:`PlaybackReport`.

    Raises:
        SimulationUnstable: MuJoCo warned or the state became non-finite.
        InvalidInput: Bad times, or a pattern for another robot.
    """
    _check_playback(scene, pattern, settle_time, fall_ratio)
    callbacks = as_callbacks(callback)
    model, data = scene.model, scene.data
    timestep = float(model.opt.timestep)
    legs = pattern.plan.params.all_limbs
    drive = joint_drive(scene, pattern.q[0], pattern.plan.com_height, legs, gains)
    ref = _Reference.of(pattern, drive, scene.robot.model, torque_feedforward)
    stabilizer = None
    if stabilize:
        leg_joints = {leg: scene.robot.limb(leg).joints for leg in legs}
        stabilizer = tilt_stabilizer(
            scene.model, pattern.q[0], scene.root_body, drive.joints, leg_joints
        )
    saturation = _Saturation(drive)
    K = len(pattern.t)
    N = K + round(settle_time / pattern.dt)
    t_samples = np.arange(N) * pattern.dt
    run = _Measurements(pattern, scene, N)

    def control(s: float) -> tuple[np.ndarray, np.ndarray]:
        """The drive's torques (clipped, wanted) ``s`` ticks into the pattern."""
        q_ref, qd_ref, tau_ff = ref.at(s)
        if stabilizer is not None:
            q_ref = q_ref + _stabilize(stabilizer, falls.R_ref, pattern, data, s, len(drive.joints))
        return drive.torques(data, q_ref, qd_ref, tau_ff)

    scene.set_pose(pattern.q[0])
    wall0 = time.perf_counter()
    falls = _Falls(pattern, scene, fall_ratio, float(data.xpos[run.root_id, 2]), N)
    t0 = data.time + timestep * round(lead_time / timestep)
    while data.time < t0 - 0.5 * timestep:  # settle on the soles, the servos holding tick 0
        drive.apply(data, control(0.0)[0])
        scene.step(1)
    n_done = N
    joint_err = 0.0
    for k in range(N):
        run.take(k)
        if k < K:
            q_err = np.abs(data.qpos[drive.q_adr] - ref.q[k])
            joint_err = max(joint_err, float(np.max(q_err)))
        if callbacks:
            sample = WalkSample(
                k,
                float(t_samples[k]),
                model,
                data,
                pattern,
                scene.root_body,
                run.com[k],
                run.zmp[k],
            )
            for call in callbacks:
                call(sample)
        if falls.fallen(k, float(t_samples[k]), run.root_p[k], run.root_R[k]):
            n_done = k + 1
            break
        if k == N - 1:
            break
        t_next = t0 + t_samples[k + 1]
        while data.time < t_next - 0.5 * timestep:
            tau, wanted = control((data.time - t0) / pattern.dt)
            saturation.add(wanted, tau)
            drive.apply(data, tau)
            scene.step(1)
    wall = time.perf_counter() - wall0
    return _report(
        pattern,
        scene,
        run,
        t_samples[:n_done],
        falls=falls,
        joint_err=joint_err,
        wall=wall,
        params={
            **drive.to_dict(),
            **saturation.to_dict(),
            "timestep": timestep,
            "settle_time": settle_time,
            "torque_feedforward": torque_feedforward,
            "stabilize": stabilize,
        },
    )


def _stabilize(
    stabilizer: TiltStabilizer,
    R_ref: np.ndarray,
    pattern: WalkPattern,
    data: mujoco.MjData,
    s: float,
    n: int,
) -> np.ndarray:
    """The stabilizer's target offsets (n,) [rad] at ``s`` ticks into the pattern:
    its nearest tick's root rotation (of ``R_ref`` (K, 3, 3)) and stance legs."""
    k = min(round(s), len(pattern.t) - 1)
    label = pattern.support[k]
    stance = pattern.plan.params.all_limbs if label == DOUBLE_SUPPORT else (label,)
    return stabilizer.correction(data, R_ref[k], stance, n)


def _report(
    pattern: WalkPattern,
    scene: Scene,
    run: _Measurements,
    t: np.ndarray,
    *,
    falls: _Falls,
    joint_err: float,
    wall: float,
    params: dict[str, Any],
) -> PlaybackReport:
    """The :class:`PlaybackReport` of the samples ``t`` taken (the first
    ``len(t)``), the scene in its final state."""
    plan, data = pattern.plan, scene.data
    n_done, K = len(t), len(pattern.t)
    yaw_error = 0.0
    for lb, sole in pattern.soles.items():
        e = wrap_angle(yaw_of(sole.pose(scene.model, data)[1]) - plan.final_feet[lb].yaw)
        yaw_error = max(yaw_error, abs(float(e)))
    sl = slice(0, n_done)
    heights = run.root_p[sl, 2]
    mid_final = np.mean([run.feet_p[lb][n_done - 1] for lb in run.soles], axis=0)
    slip, ferr = 0.0, 0.0
    for lb in run.soles:
        for a, b in _stance_intervals(plan.support[: min(n_done, K)], lb):
            xy = run.feet_p[lb][a:b, :2]
            slip = max(slip, float(np.max(np.linalg.norm(xy - xy[0], axis=1))))
            d = np.linalg.norm(xy - plan.feet_p[lb][a:b, :2], axis=1)
            ferr = max(ferr, float(d.max()))
    return PlaybackReport(
        t=t,
        root_p=run.root_p[sl],
        com=run.com[sl],
        feet_p={lb: v[sl] for lb, v in run.feet_p.items()},
        zmp=run.zmp[sl],
        zmp_margin=run.zmp_margin[sl],
        zmp_force_sensors=run.zmp_sensors[sl],
        zmp_force_sensors_margin=run.zmp_sensors_margin[sl],
        standing_height=falls.standing,
        root_height_min=float(heights.min()),
        fell=falls.fall is not None or bool(run.bad),
        fall=falls.fall,
        tilt_max=float(np.max(falls.tilt[sl])),
        drift_max=float(np.max(falls.drift[sl])),
        bad_contacts=sorted(run.bad),
        final_midfeet_error=float(np.linalg.norm(mid_final[:2] - plan.final_midpoint[:2])),
        final_root_error=float(np.linalg.norm(run.root_p[n_done - 1, :2] - pattern.q[-1, :2])),
        final_yaw_error=yaw_error,
        foot_slip=slip,
        foot_error=ferr,
        joint_error_max=joint_err,
        wall_time=wall,
        planned_contacts=sorted(scene.allowed_contacts),
        params=params,
    )
