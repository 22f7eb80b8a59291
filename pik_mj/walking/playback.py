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
sensors on the sole sites, seed ``:calc-zmp-from-forces-moments``:
:func:`pik_mj.robot.sensors.zmp_from_force_sensors`), what a robot measures.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from pik_mj.balance import convex_hull_2d, halfplanes_from_polygon, signed_distance
from pik_mj.dynamics import joint_torques, root_wrench
from pik_mj.exceptions import InvalidInput
from pik_mj.record import Recorder
from pik_mj.robot.sensors import RobotSensors, zmp_from_force_sensors
from pik_mj.sim import ContactParams, Scene
from pik_mj.spatial import yaw_of
from pik_mj.walking.gait import DOUBLE_SUPPORT, wrap_angle
from pik_mj.walking.wholebody import DEFAULT_FEET, WalkPattern, sole_corners, support_margin

__all__ = [
    "SENSOR_VS_CONTACTS_RMS",
    "SENSOR_ZMP_RMS",
    "WALK_CONTACT",
    "PlaybackReport",
    "evaluate_walk",
    "feedforward_torques",
    "play_walk_pattern",
]

SENSOR_ZMP_RMS = 0.05
"""[m] RMS distance allowed between the ZMP from the feet's force sensors and the
planned ZMP over a walk's pattern (measured on the sample humanoid's walks:
40 mm; the servos track the pattern without balance feedback, and a foot lands
a few ticks early or late)."""

SENSOR_VS_CONTACTS_RMS = 2e-3
"""[m] RMS distance allowed between the ZMP from the feet's force sensors and the
ZMP of MuJoCo's contact forces (measured: 0.6 mm; the sensors leave out the
feet's own inertia)."""

WALK_CONTACT = ContactParams()
"""Sole/floor contact of the walks (``Scene.from_robot(robot, contact=WALK_CONTACT)``):
MuJoCo's defaults with friction 1."""


@dataclass(frozen=True)
class PlaybackReport:
    """What happened when a walk pattern was played in physics.

    Samples are taken at the pattern's ticks and on during the settling time.

    Attributes:
        t: Sample times (N,) [s] from the start of the pattern.
        root_p: Root body position (N, 3) [m].
        com: Robot CoM (N, 3) [m].
        feet_p: Sole frame position per limb (N, 3) [m].
        zmp: ZMP of the floor contact forces (N, 2) [m] (NaN without contact).
        zmp_force_sensors: ZMP from the feet's force sensors (N, 2) [m] (NaN
            when no foot sensor carries 1 N; empty when the feet have none).
        zmp_force_sensors_margin: Its signed distance [m] to the support polygon
            of the feet carrying it (the hull of their soles at their actual
            poses, positive inside) (N,).
        standing_height: Root height at t = 0 [m].
        root_height_min: Lowest root height [m].
        fell: The root went below ``fall_ratio * standing_height``, or a robot geom
            other than the soles touched the floor.
        bad_contacts: Robot geoms other than the soles that touched the floor.
        final_midfeet_error: Horizontal distance of the final mid-feet point to
            the planned one [m].
        final_root_error: Horizontal distance of the final root position to the
            pattern's last one [m].
        final_yaw_error: Largest heading error of a sole at the end [rad].
        foot_slip: Largest horizontal drift of a foot within one of its stance
            intervals (planned support) [m].
        foot_error: Largest horizontal distance of a supporting foot to its
            planned position [m].
        joint_error_max: Largest servo tracking error during the pattern [rad].
        wall_time: Wall time of the simulation [s].
        planned_contacts: Robot geoms allowed to touch the floor (the soles).
    """

    t: np.ndarray
    root_p: np.ndarray
    com: np.ndarray
    feet_p: dict[str, np.ndarray]
    zmp: np.ndarray
    standing_height: float
    root_height_min: float
    fell: bool
    bad_contacts: list[str]
    final_midfeet_error: float
    final_root_error: float
    final_yaw_error: float
    foot_slip: float
    foot_error: float
    joint_error_max: float
    wall_time: float
    params: dict[str, Any] = field(default_factory=dict)
    zmp_force_sensors: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    zmp_force_sensors_margin: np.ndarray = field(default_factory=lambda: np.zeros(0))
    planned_contacts: list[str] = field(default_factory=list)

    @property
    def height_ratio_min(self) -> float:
        """Lowest root height over the standing height."""
        return self.root_height_min / self.standing_height

    def passed(self, height_ratio: float = 0.8, final_tolerance: float = 0.05) -> bool:
        """Did not fall, stayed above ``height_ratio`` and ended within ``final_tolerance`` [m]."""
        return (
            not self.fell
            and self.height_ratio_min >= height_ratio
            and self.final_midfeet_error <= final_tolerance
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no time series)."""
        return {
            "standing_height": self.standing_height,
            "root_height_min": self.root_height_min,
            "height_ratio_min": self.height_ratio_min,
            "fell": self.fell,
            "bad_contacts": self.bad_contacts,
            "final_midfeet_error": self.final_midfeet_error,
            "final_root_error": self.final_root_error,
            "final_yaw_error": self.final_yaw_error,
            "foot_slip": self.foot_slip,
            "foot_error": self.foot_error,
            "joint_error_max": self.joint_error_max,
            "wall_time": self.wall_time,
            **self.params,
        }


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


def play_walk_pattern(
    pattern: WalkPattern,
    scene: Scene,
    *,
    settle_time: float = 1.0,
    velocity_feedforward: bool = True,
    torque_feedforward: bool = True,
    feet_frames: Mapping[str, str] = DEFAULT_FEET,
    fall_ratio: float = 0.8,
    recorder: Recorder | None = None,
    record_every: int = 2,
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
        recorder: If given, logged on the ``sim_time`` timeline: the body poses
            every ``record_every`` ticks, then the walk's series
            (:meth:`pik_mj.record.Recorder.log_walk`: footsteps, ZMPs, CoM,
            support polygon, margins).
        record_every: Log every n-th pattern tick.

    Returns:
        A :class:`PlaybackReport`.

    Raises:
        SimulationUnstable: MuJoCo warned or the state became non-finite.
        InvalidInput: Bad times, or a pattern for another robot.
    """
    if not isinstance(scene, Scene):
        raise InvalidInput(
            f"play_walk_pattern needs the robot's Scene (Scene.from_robot), got "
            f"{type(scene).__name__}"
        )
    if not (math.isfinite(settle_time) and settle_time >= 0):
        raise InvalidInput(f"settle_time must be finite and >= 0, got {settle_time}")
    if not 0.0 < fall_ratio < 1.0:
        raise InvalidInput(f"fall_ratio must be in (0, 1), got {fall_ratio}")
    if int(record_every) != record_every or record_every < 1:
        raise InvalidInput(f"record_every must be an integer >= 1, got {record_every}")
    model, data = scene.model, scene.data
    timestep = float(model.opt.timestep)
    if pattern.q.shape[1] != scene.robot_nq:
        raise InvalidInput(
            f"the pattern has configurations of size {pattern.q.shape[1]}, the scene's "
            f"robot {scene.robot_nq}: play it with the robot it was made for"
        )
    joints = scene.servo_joints
    rm = scene.robot.model  # its joints are the scene's first ones
    q_adr = np.array([rm.jnt_qposadr[rm.joint(j).id] for j in joints])
    dofs = np.array([rm.jnt_dofadr[rm.joint(j).id] for j in joints])
    act_ids = np.array([scene.servo_actuators[j] for j in joints])
    gains = np.array([scene.servo_gains[j] for j in joints])
    q_ref = pattern.q[:, q_adr]
    qd_ref = np.gradient(q_ref, pattern.dt, axis=0)
    gain_v = gains[:, 1] / gains[:, 0] if velocity_feedforward else np.zeros(len(joints))
    if torque_feedforward:
        tau_ff = feedforward_torques(rm, pattern, feet_frames)[:, dofs]
    else:
        tau_ff = np.zeros_like(q_ref)

    root_id = model.body(scene.root_body).id
    robot_geom = np.asarray(model.body_rootid)[model.geom_bodyid] == root_id
    allowed = {model.geom(n).id for n in scene.allowed_contacts}
    site_ids = {lb: model.site(s).id for lb, s in feet_frames.items()}
    plan = pattern.plan

    K = len(pattern.t)
    n_settle = round(settle_time / pattern.dt)
    N = K + n_settle
    t_samples = np.arange(N) * pattern.dt
    root_p = np.full((N, 3), np.nan)
    com = np.full((N, 3), np.nan)
    feet_p = {lb: np.full((N, 3), np.nan) for lb in site_ids}
    zmp = np.full((N, 2), np.nan)
    robot_bodies = [
        model.body(b).name for b in range(1, model.nbody) if model.body_rootid[b] == root_id
    ]
    foot_sensors = [
        f
        for f in RobotSensors.from_model(model, bodies=robot_bodies).force_sensors
        if f.name in feet_frames.values() and f.force is not None and f.torque is not None
    ]
    zmp_sensors = np.full((N if foot_sensors else 0, 2), np.nan)
    zmp_sensors_margin = np.full(N if foot_sensors else 0, np.nan)
    site_of = {s: lb for lb, s in feet_frames.items()}
    ground = float(plan.ground_z)
    bad: set[str] = set()
    joint_err = 0.0

    scene.set_pose(pattern.q[0])
    t0 = data.time
    if recorder is not None:
        recorder.log_model_geometry(model, data, robot_root_body=scene.root_body)
    force = np.zeros(6)
    wall0 = time.perf_counter()
    standing = float(data.xpos[root_id, 2])
    n_done = N
    for k in range(N):
        # --- sample
        root_p[k] = data.xpos[root_id]
        com[k] = scene.com()
        for lb, s in site_ids.items():
            feet_p[lb][k] = data.site_xpos[s]
        fz_sum, p_sum = 0.0, np.zeros(2)
        for i in range(data.ncon):
            c = data.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if robot_geom[g1] == robot_geom[g2]:
                continue
            g_robot = g1 if robot_geom[g1] else g2
            if g_robot not in allowed:
                bad.add(model.geom(g_robot).name)
            mujoco.mj_contactForce(model, data, i, force)
            f_W = np.asarray(c.frame).reshape(3, 3).T @ force[:3]
            fz = abs(f_W[2])
            fz_sum += fz
            p_sum += fz * np.asarray(c.pos[:2])
        if fz_sum > 1e-6:
            zmp[k] = p_sum / fz_sum
        if foot_sensors:
            measured = zmp_from_force_sensors(model, data, foot_sensors, z=ground)
            if measured is not None:
                zmp_sensors[k] = measured.point[:2]
                soles = [
                    sole_corners(
                        data.site_xpos[site_ids[site_of[f]]],
                        yaw_of(data.site_xmat[site_ids[site_of[f]]].reshape(3, 3)),
                        pattern.sole_size,
                    )
                    for f in measured.cops
                ]
                hull = halfplanes_from_polygon(convex_hull_2d(np.vstack(soles)))
                zmp_sensors_margin[k] = signed_distance(hull, zmp_sensors[k])
        if k < K:
            joint_err = max(joint_err, float(np.max(np.abs(data.qpos[q_adr] - q_ref[k]))))
        if recorder is not None and k % record_every == 0:
            recorder.log_body_poses(data, timeline="sim_time", time=t_samples[k])
        if root_p[k, 2] < fall_ratio * standing:
            n_done = k + 1
            break
        if k == N - 1:
            break
        # --- step to the next tick
        t_next = t0 + t_samples[k + 1]
        while data.time < t_next - 0.5 * timestep:
            s = (data.time - t0) / pattern.dt
            j = min(int(s), K - 1)
            a = min(s - j, 1.0) if j < K - 1 else 0.0
            j1 = min(j + 1, K - 1)
            target = (1.0 - a) * q_ref[j] + a * q_ref[j1]
            if j < K - 1:
                target = target + gain_v * ((1.0 - a) * qd_ref[j] + a * qd_ref[j1])
            data.ctrl[act_ids] = target
            data.qfrc_applied[dofs] = (1.0 - a) * tau_ff[j] + a * tau_ff[j1]
            scene.step(1)
    wall = time.perf_counter() - wall0
    yaw_error = 0.0
    for lb, site in site_ids.items():
        e = wrap_angle(yaw_of(data.site_xmat[site].reshape(3, 3)) - plan.final_feet[lb].yaw)
        yaw_error = max(yaw_error, abs(float(e)))

    sl = slice(0, n_done)
    heights = root_p[sl, 2]
    mid_final = np.mean([feet_p[lb][n_done - 1] for lb in site_ids], axis=0)
    slip, ferr = 0.0, 0.0
    for lb in site_ids:
        for a, b in _stance_intervals(plan.support[: min(n_done, K)], lb):
            xy = feet_p[lb][a:b, :2]
            slip = max(slip, float(np.max(np.linalg.norm(xy - xy[0], axis=1))))
            d = np.linalg.norm(xy - plan.feet_p[lb][a:b, :2], axis=1)
            ferr = max(ferr, float(d.max()))
    fell = bool(heights.min() < fall_ratio * standing or bad)
    report = PlaybackReport(
        t=t_samples[sl],
        root_p=root_p[sl],
        com=com[sl],
        feet_p={lb: v[sl] for lb, v in feet_p.items()},
        zmp=zmp[sl],
        zmp_force_sensors=zmp_sensors[sl],
        zmp_force_sensors_margin=zmp_sensors_margin[sl],
        standing_height=standing,
        root_height_min=float(heights.min()),
        fell=fell,
        bad_contacts=sorted(bad),
        final_midfeet_error=float(np.linalg.norm(mid_final[:2] - plan.final_midpoint[:2])),
        final_root_error=float(np.linalg.norm(root_p[n_done - 1, :2] - pattern.q[-1, :2])),
        final_yaw_error=yaw_error,
        foot_slip=slip,
        foot_error=ferr,
        joint_error_max=joint_err,
        wall_time=wall,
        planned_contacts=sorted(scene.allowed_contacts),
        params={
            "kp": float(gains[:, 0].max()),
            "kv": float(gains[:, 1].max()),
            "timestep": timestep,
            "settle_time": settle_time,
            "velocity_feedforward": velocity_feedforward,
            "torque_feedforward": torque_feedforward,
        },
    )
    if recorder is not None:
        recorder.log_walk(pattern, report)
    return report


def _played_ticks(
    pattern: WalkPattern, report: PlaybackReport
) -> tuple[int, np.ndarray, np.ndarray]:
    """``K``, the pattern's ticks that were played, and over them the ticks
    where the ZMP of the contact forces exists, and those where the ZMP from
    the feet's force sensors exists too (empty when the feet have none)."""
    K = min(len(pattern.t), len(report.t))
    contacts = np.all(np.isfinite(report.zmp[:K]), axis=1)
    sensed = np.all(np.isfinite(report.zmp_force_sensors[:K]), axis=1)
    return K, contacts, (sensed & contacts) if len(sensed) else sensed


def walk_motion(
    pattern: WalkPattern,
    report: PlaybackReport,
    *,
    height_ratio: float = 0.8,
    final_tolerance: float = 0.05,
) -> dict[str, Any]:
    """A walk played in physics as the ``motion`` section of a scenario's JSON,
    with the keys of :meth:`pik_mj.scenario.ScenarioResult.motion`.

    ``passed``: :meth:`PlaybackReport.passed`; ``duration`` [s]: the pattern and
    the settling; ``max_tracking_error``: the servos' joint error [rad] and the
    supporting feet's distance to their planned positions [m]; ``max_slip``: a
    foot's drift within a stance [m]; ``max_drift``: the root's largest
    distance to the pattern's root position ``‖p_root − q_ref[:3]‖`` [m];
    ``min_com_margin``: None (a walk's CoM leaves the single-support polygon by
    design) and ``min_zmp_margin`` [m] instead, that of the ZMP from the feet's
    force sensors to the support polygon of the feet carrying it over the
    pattern's ticks (:func:`evaluate_walk`'s ``sim_zmp_force_sensors_margin_min_m``;
    None without force sensors); ``contacts``: the soles planned, robot geoms on the floor
    unexpected; ``fell``; the playback's own summary under ``parts["walk"]``.
    """
    K, _, sensed = _played_ticks(pattern, report)
    drift = np.linalg.norm(report.root_p[:K] - pattern.q[:K, :3], axis=1)
    margins = report.zmp_force_sensors_margin[:K][sensed]
    return {
        "passed": report.passed(height_ratio, final_tolerance),
        "duration": float(report.t[-1] - report.t[0]) if len(report.t) else 0.0,
        "max_tracking_error": {
            "joints_rad": report.joint_error_max,
            "frames_m": report.foot_error,
        },
        "min_com_margin": None,
        "min_zmp_margin": float(margins.min()) if margins.size else None,
        "max_slip": report.foot_slip,
        "max_drift": float(np.nanmax(drift)) if K else 0.0,
        "contacts": {
            "planned": list(report.planned_contacts),
            "planned_pairs": [],
            "unexpected": [[g, "floor", None] for g in report.bad_contacts],
        },
        "fell": report.fell,
        "parts": {"walk": report.to_dict()},
    }


def evaluate_walk(
    pattern: WalkPattern,
    report: PlaybackReport,
    *,
    height_ratio: float = 0.8,
    final_tolerance: float = 0.05,
) -> tuple[dict[str, Any], list[tuple[str, bool, str]]]:
    """Figures of a walk and the checks of the walking scenarios.

    Checks: the inverse-dynamics ZMP inside the planned support polygon at every
    tick; in physics no fall, root height >= ``height_ratio`` of standing, final
    mid-feet point within ``final_tolerance`` [m] of the plan.

    Returns:
        ``(figures, [(label, ok, detail), ...])``.
    """
    margin = pattern.support_margin("computed")
    k_min = int(np.argmin(margin))
    K, ok_rows, ok = _played_ticks(pattern, report)
    measured = report.zmp[:K]
    sim_err = np.linalg.norm(measured[ok_rows] - pattern.zmp_ref[:K][ok_rows], axis=1)
    figures: dict[str, Any] = {
        "footsteps": len(pattern.plan.footsteps),
        "ticks": len(pattern.t),
        "dt_s": pattern.dt,
        "duration_s": pattern.duration,
        "ik_time_s": pattern.solve_time,
        "ik_ms_per_tick": 1e3 * pattern.solve_time / len(pattern.t),
        "ik_iterations_per_tick": float(np.mean(pattern.ik_iterations[1:])),
        "ik_feet_error_max_m": float(pattern.ik_feet_error.max()),
        "ik_com_error_max_m": float(pattern.ik_com_error[1:].max()),
        "zmp_margin_computed_min_m": float(margin[k_min]),
        "zmp_margin_computed_min_at_s": float(pattern.t[k_min]),
        "zmp_margin_cart_min_m": float(pattern.support_margin("cart").min()),
        **{f"zmp_{k}_m": v for k, v in pattern.zmp_tracking().items()},
        "sim_zmp_vs_ref_max_m": float(sim_err.max()) if sim_err.size else float("nan"),
        "sim_zmp_vs_ref_rms_m": float(np.sqrt(np.mean(sim_err**2)))
        if sim_err.size
        else float("nan"),
        **{f"sim_{k}": v for k, v in report.to_dict().items()},
    }
    sensed = report.zmp_force_sensors[:K]
    has_sensors = len(sensed) > 0 and bool(np.all(np.isfinite(sensed), axis=1).any())
    if has_sensors:
        e_ref = np.linalg.norm(sensed[ok] - pattern.zmp_ref[:K][ok], axis=1)
        e_contacts = np.linalg.norm(sensed[ok] - measured[ok], axis=1)
        planned = support_margin(
            pattern.plan,
            np.where(ok[:, None], sensed, pattern.zmp_ref[:K]),
            pattern.sole_size,
        )[ok]
        figures |= {
            "sim_zmp_force_sensors_ticks": int(ok.sum()),
            "sim_zmp_force_sensors_vs_ref_rms_m": float(np.sqrt(np.mean(e_ref**2))),
            "sim_zmp_force_sensors_vs_ref_max_m": float(e_ref.max()),
            "sim_zmp_force_sensors_vs_contacts_rms_m": float(np.sqrt(np.mean(e_contacts**2))),
            "sim_zmp_force_sensors_margin_min_m": float(
                np.min(report.zmp_force_sensors_margin[:K][ok])
            ),
            "sim_zmp_force_sensors_planned_margin_min_m": float(planned.min()),
        }
    checks = [
        (
            "ZMP from inverse dynamics inside the support polygon at every tick",
            bool(margin.min() > 0.0),
            f"min margin {margin.min() * 1e3:.1f} mm at t = {pattern.t[k_min]:.2f} s",
        ),
        (
            "physics playback: no fall",
            not report.fell,
            f"bad contacts {report.bad_contacts}" if report.bad_contacts else "",
        ),
        (
            f"physics playback: root height >= {height_ratio:.0%} of standing",
            report.height_ratio_min >= height_ratio,
            f"min {report.height_ratio_min:.3f}",
        ),
        (
            f"physics playback: ends within {final_tolerance * 100:.0f} cm of the plan",
            report.final_midfeet_error <= final_tolerance,
            f"mid-feet error {report.final_midfeet_error * 1e3:.1f} mm",
        ),
    ]
    if has_sensors:
        f = figures
        checks += [
            (
                "ZMP from the feet's force sensors inside the support polygon of the feet "
                "carrying it, at every tick",
                f["sim_zmp_force_sensors_margin_min_m"] > 0.0,
                f"min margin {f['sim_zmp_force_sensors_margin_min_m'] * 1e3:.1f} mm",
            ),
            (
                f"ZMP from the feet's force sensors within {SENSOR_ZMP_RMS * 1e3:.0f} mm RMS "
                "of the planned ZMP",
                f["sim_zmp_force_sensors_vs_ref_rms_m"] <= SENSOR_ZMP_RMS,
                f"RMS {f['sim_zmp_force_sensors_vs_ref_rms_m'] * 1e3:.1f} mm, max "
                f"{f['sim_zmp_force_sensors_vs_ref_max_m'] * 1e3:.1f} mm",
            ),
            (
                f"ZMP from the feet's force sensors equals the ZMP of MuJoCo's contact "
                f"forces ({SENSOR_VS_CONTACTS_RMS * 1e3:.0f} mm RMS)",
                f["sim_zmp_force_sensors_vs_contacts_rms_m"] <= SENSOR_VS_CONTACTS_RMS,
                f"RMS {f['sim_zmp_force_sensors_vs_contacts_rms_m'] * 1e3:.2f} mm",
            ),
        ]
    return figures, checks
