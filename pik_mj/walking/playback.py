"""Play a :class:`~pik_mj.walking.wholebody.WalkPattern` in MuJoCo physics.

The robot stands in its :class:`pik_mj.sim.Scene` (made with
:meth:`~pik_mj.sim.Scene.from_robot`: a floor, a position servo on every hinge
joint; the walks use :data:`WALK_CONTACT`); the physics starts at rest in the
pattern's first configuration and the servo targets follow the pattern, linearly
interpolated at the physics rate. With MuJoCo's position actuator
:math:`\\tau = k_p (u - q) - k_v \\dot q`, the control

.. math::

    u(t) = q_{ref}(t) + \\frac{k_v}{k_p} \\dot q_{ref}(t)
    \\;\\Rightarrow\\;
    \\tau = k_p (q_{ref} - q) + k_v (\\dot q_{ref} - \\dot q)

(``velocity_feedforward``) makes the damping act on the velocity error. The
pattern's own joint torques (inverse dynamics with the ground reaction on the
support soles, :func:`feedforward_torques`) are added as ``qfrc_applied``
(``torque_feedforward``), so the servos only correct deviations. There is no
balance feedback: the pattern must carry the robot on its own. After the
pattern the last targets (and torques) are held for ``settle_time``.

Measured at each pattern tick: root height, sole positions, CoM, the ZMP of
the floor contact forces (all contact points lie on the floor plane, so it is
their force-weighted centre, :math:`p = \\sum_i f_{z,i} p_i / \\sum_i f_{z,i}`),
and the ZMP from the feet's force sensors (the robot's MJCF ``force``/``torque``
sensors on the sole sites, irteus manual: ``:calc-zmp-from-forces-moments``;
:func:`pik_mj.robot.sensors.zmp_from_force_sensors`), what a robot measures.

The playback reports through callbacks: each gets a :class:`WalkSample` at every
sample (a recorder's walk logger is one, :meth:`pik_mj.record.Recorder.walk_logger`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from pik_mj.balance import convex_hull_2d, halfplanes_from_polygon, signed_distance
from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.dynamics import joint_torques, root_wrench
from pik_mj.exceptions import InvalidInput
from pik_mj.robot.sensors import ForceSensor, RobotSensors, zmp_from_force_sensors
from pik_mj.sim import ContactParams, Scene
from pik_mj.spatial import yaw_of
from pik_mj.walking.gait import DOUBLE_SUPPORT, wrap_angle
from pik_mj.walking.report import (
    SENSOR_VS_CONTACTS_RMS,
    SENSOR_ZMP_RMS,
    PlaybackReport,
    evaluate_walk,
    walk_motion,
)
from pik_mj.walking.wholebody import DEFAULT_FEET, WalkPattern, sole_corners

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


def feedforward_torques(
    model: mujoco.MjModel,
    pattern: WalkPattern,
    feet_frames: Mapping[str, str] = DEFAULT_FEET,
) -> np.ndarray:
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
    and :func:`pik_mj.dynamics.joint_torques` with these contact wrenches gives
    the joint torques; the free-joint rows then vanish.

    Args:
        model: The robot model of the pattern.
        pattern: The walking pattern.
        feet_frames: Sole site of each limb.

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
        external = [(feet_frames[lb], alpha[lb] * f, alpha[lb] * residual) for lb in limbs]
        tau[k] = joint_torques(model, data, pattern.q[k], qvel[k], qacc[k], external)
    return tau


@dataclass(frozen=True)
class _Servos:
    """The servo targets of a pattern: the joints' positions and velocities, and
    the feedforward torques, per tick, over the scene's servo joints."""

    q_adr: np.ndarray  # qpos address of each servo joint
    dofs: np.ndarray  # dof of each servo joint
    act_ids: np.ndarray  # its actuator
    gains: np.ndarray  # its (kp, kv)
    q_ref: np.ndarray  # (K, joints) [rad]
    qd_ref: np.ndarray  # (K, joints) [rad/s]
    gain_v: np.ndarray  # kv / kp with velocity feedforward, else 0
    tau_ff: np.ndarray  # (K, joints) [N m]

    @classmethod
    def of(
        cls,
        pattern: WalkPattern,
        scene: Scene,
        feet_frames: Mapping[str, str],
        *,
        velocity_feedforward: bool,
        torque_feedforward: bool,
    ) -> _Servos:
        joints = scene.servo_joints
        rm = scene.robot.model  # its joints are the scene's first ones
        q_adr = np.array([rm.jnt_qposadr[rm.joint(j).id] for j in joints])
        dofs = np.array([rm.jnt_dofadr[rm.joint(j).id] for j in joints])
        gains = np.array([scene.servo_gains[j] for j in joints])
        q_ref = pattern.q[:, q_adr]
        if torque_feedforward:
            tau_ff = feedforward_torques(rm, pattern, feet_frames)[:, dofs]
        else:
            tau_ff = np.zeros_like(q_ref)
        return cls(
            q_adr=q_adr,
            dofs=dofs,
            act_ids=np.array([scene.servo_actuators[j] for j in joints]),
            gains=gains,
            q_ref=q_ref,
            qd_ref=np.gradient(q_ref, pattern.dt, axis=0),
            gain_v=gains[:, 1] / gains[:, 0] if velocity_feedforward else np.zeros(len(joints)),
            tau_ff=tau_ff,
        )

    def apply(self, data: mujoco.MjData, s: float) -> None:
        """Set the controls and applied forces at ``s`` ticks into the pattern
        (linear between ticks, the last tick's held after the pattern)."""
        K = len(self.q_ref)
        j = min(int(s), K - 1)
        a = min(s - j, 1.0) if j < K - 1 else 0.0
        j1 = min(j + 1, K - 1)
        target = (1.0 - a) * self.q_ref[j] + a * self.q_ref[j1]
        if j < K - 1:
            target = target + self.gain_v * ((1.0 - a) * self.qd_ref[j] + a * self.qd_ref[j1])
        data.ctrl[self.act_ids] = target
        data.qfrc_applied[self.dofs] = (1.0 - a) * self.tau_ff[j] + a * self.tau_ff[j1]


class _Measurements:
    """What a playback measures at each sample (NaN where not taken).

    Attributes:
        root_p, com, feet_p, zmp, zmp_sensors, zmp_sensors_margin: As in
            :class:`PlaybackReport`.
        bad: Robot geoms other than the soles that touched the floor.
    """

    def __init__(
        self, pattern: WalkPattern, scene: Scene, feet_frames: Mapping[str, str], n: int
    ) -> None:
        model = scene.model
        self.scene = scene
        self.sole_size = pattern.sole_size
        self.ground = float(pattern.plan.ground_z)
        self.root_id = model.body(scene.root_body).id
        self.robot_geom = np.asarray(model.body_rootid)[model.geom_bodyid] == self.root_id
        self.allowed = {model.geom(name).id for name in scene.allowed_contacts}
        self.site_ids = {lb: model.site(s).id for lb, s in feet_frames.items()}
        self.site_of = {s: lb for lb, s in feet_frames.items()}
        robot_bodies = [
            model.body(b).name
            for b in range(1, model.nbody)
            if model.body_rootid[b] == self.root_id
        ]
        self.foot_sensors: list[ForceSensor] = [
            f
            for f in RobotSensors.from_model(model, bodies=robot_bodies).force_sensors
            if f.name in feet_frames.values() and f.force is not None and f.torque is not None
        ]
        self.root_p = np.full((n, 3), np.nan)
        self.com = np.full((n, 3), np.nan)
        self.feet_p = {lb: np.full((n, 3), np.nan) for lb in self.site_ids}
        self.zmp = np.full((n, 2), np.nan)
        self.zmp_sensors = np.full((n if self.foot_sensors else 0, 2), np.nan)
        self.zmp_sensors_margin = np.full(n if self.foot_sensors else 0, np.nan)
        self.bad: set[str] = set()
        self._force = np.zeros(6)

    def take(self, k: int) -> None:
        """Measure sample ``k`` in the scene's state now."""
        model, data = self.scene.model, self.scene.data
        self.root_p[k] = data.xpos[self.root_id]
        self.com[k] = self.scene.com()
        for lb, s in self.site_ids.items():
            self.feet_p[lb][k] = data.site_xpos[s]
        self._contact_zmp(k, model, data)
        if self.foot_sensors:
            self._sensor_zmp(k, model, data)

    def _contact_zmp(self, k: int, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The ZMP of the floor contact forces, and the robot geoms other than
        the soles on the floor."""
        fz_sum, p_sum = 0.0, np.zeros(2)
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
        if fz_sum > 1e-6:
            self.zmp[k] = p_sum / fz_sum

    def _sensor_zmp(self, k: int, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The ZMP from the feet's force sensors and its margin to the hull of
        the soles carrying it, at their actual poses."""
        measured = zmp_from_force_sensors(model, data, self.foot_sensors, z=self.ground)
        if measured is None:
            return
        self.zmp_sensors[k] = measured.point[:2]
        sites = [self.site_ids[self.site_of[f]] for f in measured.cops]
        soles = [
            sole_corners(data.site_xpos[s], yaw_of(data.site_xmat[s].reshape(3, 3)), self.sole_size)
            for s in sites
        ]
        hull = halfplanes_from_polygon(convex_hull_2d(np.vstack(soles)))
        self.zmp_sensors_margin[k] = signed_distance(hull, self.zmp_sensors[k])


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
    velocity_feedforward: bool = True,
    torque_feedforward: bool = True,
    feet_frames: Mapping[str, str] = DEFAULT_FEET,
    fall_ratio: float = 0.8,
    callback: Callback | Sequence[Callback] | None = None,
) -> PlaybackReport:
    """Play ``pattern`` with the scene's joint servos and measure the outcome.

    Args:
        pattern: The walking pattern (configurations of the scene's robot).
        scene: The robot's scene (:meth:`pik_mj.sim.Scene.from_robot`; its servo
            gains, time step and contacts are the playback's).
        settle_time: Time the last targets are held after the pattern [s].
        velocity_feedforward: Damp the velocity error instead of the velocity
            (module docstring).
        torque_feedforward: Add the pattern's joint torques
            (:func:`feedforward_torques`) to the servo torques (``qfrc_applied``).
        feet_frames: Sole site of each limb.
        fall_ratio: Root height ratio below which the robot counts as fallen;
            the simulation stops there.
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
    servos = _Servos.of(
        pattern,
        scene,
        feet_frames,
        velocity_feedforward=velocity_feedforward,
        torque_feedforward=torque_feedforward,
    )
    K = len(pattern.t)
    N = K + round(settle_time / pattern.dt)
    t_samples = np.arange(N) * pattern.dt
    run = _Measurements(pattern, scene, feet_frames, N)

    scene.set_pose(pattern.q[0])
    t0 = data.time
    wall0 = time.perf_counter()
    standing = float(data.xpos[run.root_id, 2])
    n_done = N
    joint_err = 0.0
    for k in range(N):
        run.take(k)
        if k < K:
            q_err = np.abs(data.qpos[servos.q_adr] - servos.q_ref[k])
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
        if run.root_p[k, 2] < fall_ratio * standing:
            n_done = k + 1
            break
        if k == N - 1:
            break
        t_next = t0 + t_samples[k + 1]
        while data.time < t_next - 0.5 * timestep:
            servos.apply(data, (data.time - t0) / pattern.dt)
            scene.step(1)
    wall = time.perf_counter() - wall0
    return _report(
        pattern,
        scene,
        run,
        t_samples[:n_done],
        standing=standing,
        fall_ratio=fall_ratio,
        joint_err=joint_err,
        wall=wall,
        params={
            "kp": float(servos.gains[:, 0].max()),
            "kv": float(servos.gains[:, 1].max()),
            "timestep": timestep,
            "settle_time": settle_time,
            "velocity_feedforward": velocity_feedforward,
            "torque_feedforward": torque_feedforward,
        },
    )


def _report(
    pattern: WalkPattern,
    scene: Scene,
    run: _Measurements,
    t: np.ndarray,
    *,
    standing: float,
    fall_ratio: float,
    joint_err: float,
    wall: float,
    params: dict[str, Any],
) -> PlaybackReport:
    """The :class:`PlaybackReport` of the samples ``t`` taken (the first
    ``len(t)``), the scene in its final state."""
    plan, data = pattern.plan, scene.data
    n_done, K = len(t), len(pattern.t)
    yaw_error = 0.0
    for lb, site in run.site_ids.items():
        e = wrap_angle(yaw_of(data.site_xmat[site].reshape(3, 3)) - plan.final_feet[lb].yaw)
        yaw_error = max(yaw_error, abs(float(e)))
    sl = slice(0, n_done)
    heights = run.root_p[sl, 2]
    mid_final = np.mean([run.feet_p[lb][n_done - 1] for lb in run.site_ids], axis=0)
    slip, ferr = 0.0, 0.0
    for lb in run.site_ids:
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
        zmp_force_sensors=run.zmp_sensors[sl],
        zmp_force_sensors_margin=run.zmp_sensors_margin[sl],
        standing_height=standing,
        root_height_min=float(heights.min()),
        fell=bool(heights.min() < fall_ratio * standing or run.bad),
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
