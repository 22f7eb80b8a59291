"""Whole-body walking pattern: inverse-dynamics ZMP, IK per tick, physics playback."""

from __future__ import annotations

import time

import mujoco
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from pik_mj.dynamics import zmp_of_motion
from pik_mj.exceptions import InvalidInput
from pik_mj.record import PATHS, Recorder, read_recording
from pik_mj.robot import Robot
from pik_mj.robot.ground import robot_soles
from pik_mj.sim import Scene
from pik_mj.walking import GaitParameters, go_pos, straight_steps
from pik_mj.walking.playback import (
    WALK_CONTACT,
    evaluate_walk,
    feedforward_torques,
    play_walk_pattern,
    walk_motion,
)
from pik_mj.walking.wholebody import calc_walk_pattern, feet_from_robot

G = 9.81  # the sample humanoid's |gravity| [m/s^2]
TIMES: dict[str, float] = {}


@pytest.fixture(scope="module")
def walk():
    robot = Robot.from_model("sample_humanoid")
    t0 = time.perf_counter()
    steps = straight_steps(4, 0.12, feet_from_robot(robot))
    pattern = calc_walk_pattern(robot, steps, GaitParameters(dt=0.02))
    TIMES["pattern_s"] = time.perf_counter() - t0
    return robot, pattern


def test_inverse_dynamics_zmp_is_cart_table_for_a_translating_robot():
    """A rigid robot translating along c(t): p = c_xy - (c_z - z_g) c''_xy / (g + c''_z)."""
    robot = Robot.from_model("sample_humanoid")
    model = robot.model
    q0 = robot.configuration.q.copy()
    c0 = robot.com()
    dt = 1e-3
    t = np.arange(0.0, 1.0, dt)
    w = 2.0 * np.pi * np.array([1.3, 0.7, 1.1])  # [rad/s]
    amp = np.array([0.05, 0.08, 0.02])  # [m]
    disp = amp * np.sin(np.outer(t, w))
    acc = -amp * w**2 * np.sin(np.outer(t, w))
    qs = np.repeat(q0[None], len(t), axis=0)
    qs[:, :3] += disp
    z_g = -0.05
    zmp = zmp_of_motion(model, qs, dt, z_g, root_body="pelvis")
    c = c0 + disp
    expected = c[:, :2] - (c[:, 2:] - z_g) * acc[:, :2] / (G + acc[:, 2:])
    err = np.abs(zmp - expected)[1:-1]
    assert err.max() < 2e-5
    # Sanity: the acceleration term matters (~10 cm here), so the test can fail.
    assert np.abs(expected - c[:, :2]).max() > 0.05


def test_ik_tracks_the_plan(walk):
    _, pattern = walk
    assert pattern.ik_feet_error.max() < 1e-4  # [m]
    assert pattern.ik_com_error[1:].max() < 1e-4  # [m], the IK's tolerance (ik_thre)
    assert np.median(pattern.ik_com_error[1:]) < 1e-6  # converged well past it on most ticks
    # Soles flat with the planned heading.
    for lb in ("rleg", "lleg"):
        R = pattern.feet_R[lb]
        np.testing.assert_allclose(R[:, 2, 2], 1.0, atol=1e-6)
        yaw = np.arctan2(R[:, 1, 0], R[:, 0, 0])
        np.testing.assert_allclose(yaw, pattern.plan.feet_yaw[lb], atol=2e-3)
    # The feet end on the plan's final footsteps.
    for lb, foot in pattern.plan.final_feet.items():
        np.testing.assert_allclose(pattern.feet_p[lb][-1], foot.p_W, atol=1e-4)


def test_zmp_inside_support_polygon_and_tracking(walk):
    _, pattern = walk
    # the soles measured on the robot are the sample humanoid's 0.22 m x 0.12 m boxes
    for sole in pattern.soles.values():
        assert sole.size == pytest.approx((0.22, 0.12), abs=1e-12)
    margin = pattern.support_margin("computed")
    tracking = pattern.zmp_tracking()
    print(
        f"\nZMP margin min {margin.min() * 1e3:.1f} mm; cart vs ref max "
        f"{tracking['cart_max'] * 1e3:.1f} rms {tracking['cart_rms'] * 1e3:.1f} mm; "
        f"computed vs ref max {tracking['computed_max'] * 1e3:.1f} rms "
        f"{tracking['computed_rms'] * 1e3:.1f} mm; pattern {TIMES['pattern_s']:.1f} s"
    )
    assert margin.min() > 0.03  # [m]
    assert tracking["cart_max"] < 0.01
    assert tracking["computed_rms"] < 0.03
    # Brute force: scipy's hull (Qhull) facets give the same signed distance.
    plan = pattern.plan
    for k in range(0, len(pattern.t), 7):
        limbs = ("rleg", "lleg") if plan.support[k] == "double" else (plan.support[k],)
        corners = np.vstack(
            [_box_corners(plan.feet_p[lb][k], plan.feet_yaw[lb][k]) for lb in limbs]
        )
        eq = ConvexHull(corners).equations  # outward unit normals: n . p + d <= 0 inside
        expected = -np.max(eq[:, :2] @ pattern.zmp_computed[k] + eq[:, 2])
        assert margin[k] == pytest.approx(expected, abs=1e-9)


def _box_corners(p: np.ndarray, yaw: float) -> np.ndarray:
    """The corners (4, 2) [m] of the sample humanoid's 0.22 m x 0.12 m sole box centred
    at ``p`` turned by ``yaw``."""
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.array([[0.11, 0.06], [-0.11, 0.06], [-0.11, -0.06], [0.11, -0.06]])
    return p[:2] + local @ np.array([[c, -s], [s, c]]).T


def test_computed_zmp_matches_centroidal_momentum(walk):
    """Independent formulation: ZMP from the CoM and the angular momentum about it.

    .. math::
        p = c_{xy} - \\frac{(c_z - z_g)\\,\\ddot c_{xy}}{g + \\ddot c_z}
            + \\frac{[-\\dot L_y, \\dot L_x]}{m (g + \\ddot c_z)}
    """
    robot, pattern = walk
    model, data = robot.model, mujoco.MjData(robot.model)
    dt = pattern.dt
    q = pattern.q
    K = len(q)
    c = np.empty((K, 3))
    L = np.empty((K, 3))
    for k in range(K):
        v = np.zeros(model.nv)
        if 0 < k < K - 1:
            mujoco.mj_differentiatePos(model, v, 2 * dt, q[k - 1], q[k + 1])
        data.qpos[:], data.qvel[:] = q[k], v
        mujoco.mj_forward(model, data)
        mujoco.mj_subtreeVel(model, data)
        c[k] = data.subtree_com[1]
        L[k] = data.subtree_angmom[1]
    m = robot.mass
    c_dd = (c[2:] - 2 * c[1:-1] + c[:-2]) / dt**2
    L_d = (L[2:] - L[:-2]) / (2 * dt)
    z_g = pattern.plan.ground_z
    fz = m * (G + c_dd[:, 2])
    p = c[1:-1, :2] - (c[1:-1, 2:] - z_g) * m * c_dd[:, :2] / fz[:, None]
    p += np.column_stack([-L_d[:, 1], L_d[:, 0]]) / fz[:, None]
    inner = slice(2, K - 3)  # L_d uses velocities that are themselves central differences
    err = np.linalg.norm(p[inner] - pattern.zmp_computed[1:-1][inner], axis=1)
    rms = float(np.sqrt(np.mean(err**2)))
    print(f"\ncentroidal vs inverse-dynamics ZMP: max {err.max():.2e} m, rms {rms:.2e} m")
    # The stencils differ (L' spans 4 dt): O(dt^2 x jerk) at lift-off and touch-down.
    assert err.max() < 1e-2  # [m]
    assert rms < 3e-3  # [m]
    # The angular-momentum term is several cm: a sign error would fail the test.
    l_term = np.linalg.norm(np.column_stack([-L_d[:, 1], L_d[:, 0]]) / fz[:, None], axis=1)
    assert l_term.max() > 0.03


def test_feedforward_torques_balance_the_base(walk):
    robot, pattern = walk
    tau = feedforward_torques(robot.model, pattern)
    weight = robot.mass * G
    assert np.abs(tau[:, :6]).max() < 1e-4 * weight
    # The stance knee carries the weight: tens of N m, not zero.
    assert np.abs(tau[:, 6:]).max() > 20.0


def test_playback_walks_to_the_goal(walk, tmp_path):
    robot, pattern = walk
    out = tmp_path / "walk.rrd"
    scene = Scene.from_robot(robot, contact=WALK_CONTACT)
    with Recorder.to_file(out) as rec:
        log = rec.walk_logger(every=10)
        samples = []  # each callback gets every sample, in order
        seen = [log, lambda s: samples.append((s.k, s.time, s.com.copy(), s.zmp.copy()))]
        report = log.finish(play_walk_pattern(pattern, scene, callback=seen))
    print(f"\nplayback: {report.to_dict()}")
    assert [k for k, _, _, _ in samples] == list(range(len(report.t)))
    np.testing.assert_array_equal([t for _, t, _, _ in samples], report.t)
    np.testing.assert_array_equal([c for _, _, c, _ in samples], report.com)
    np.testing.assert_array_equal([z for _, _, _, z in samples], report.zmp)
    assert not report.fell
    assert report.height_ratio_min >= 0.8
    assert report.final_midfeet_error < 0.05  # [m]
    assert report.foot_slip < 0.01  # [m]
    figures, checks = evaluate_walk(pattern, report)
    assert all(ok for _, ok, _ in checks), checks
    assert figures["sim_fell"] is False
    entities = read_recording(out)
    assert "pelvis" in entities[PATHS.bodies()].static["Ellipsoids3D:labels"]
    times, _ = entities[PATHS.bodies()].series("Ellipsoids3D:centers", "sim_time")
    assert times[-1] >= pattern.duration
    # The ZMP from the feet's force/torque sensors (seed :calc-zmp-from-forces-moments)
    # at every tick: the ZMP of MuJoCo's contact forces within 2 mm RMS (an
    # independent computation), inside the soles carrying it, within 5 cm RMS of
    # the planned ZMP; plotted in the recording.
    K = len(pattern.t)
    assert figures["sim_zmp_force_sensors_ticks"] == K
    assert figures["sim_zmp_force_sensors_vs_contacts_rms_m"] < 2e-3
    assert figures["sim_zmp_force_sensors_margin_min_m"] > 0.0
    assert figures["sim_zmp_force_sensors_vs_ref_rms_m"] < 0.05
    assert report.zmp_force_sensors.shape == report.zmp.shape
    t, x = entities[PATHS.walk_series("x", "zmp_force_sensors")].series(
        "Scalars:scalars", "sim_time"
    )
    np.testing.assert_allclose(t, report.t, atol=1e-9)
    np.testing.assert_allclose([v[0] for v in x], report.zmp_force_sensors[:, 0])
    assert PATHS.walk_series("margin", "zmp_force_sensors") in entities
    # the walk as a scenario's motion section: the keys of a played solve's
    motion = walk_motion(pattern, report)
    assert set(motion) >= {"duration", "max_tracking_error", "min_com_margin", "max_slip"}
    assert motion["passed"] and not motion["fell"] and motion["contacts"]["unexpected"] == []
    assert motion["duration"] == pytest.approx(pattern.duration + 1.0, abs=2 * pattern.dt)
    assert motion["min_zmp_margin"] == figures["sim_zmp_force_sensors_margin_min_m"]
    assert motion["max_slip"] == report.foot_slip
    drift = np.linalg.norm(report.root_p[:K] - pattern.q[:, :3], axis=1).max()
    assert motion["max_drift"] == pytest.approx(drift) and 0 < drift < 0.05
    assert motion["contacts"]["planned"] == sorted(scene.allowed_contacts)


def test_playback_without_feedforward_at_kp_3000_fails(walk):
    """The feed-forward torques and the stabilizer are what make kp = 3000 enough
    (the check can fail)."""
    robot, pattern = walk
    report = play_walk_pattern(
        pattern,
        Scene.from_robot(robot, contact=WALK_CONTACT, kp=3000.0, kv=60.0),
        torque_feedforward=False,
        stabilize=False,
        settle_time=0.0,
    )
    assert report.fell or report.final_midfeet_error > 0.05
    assert not walk_motion(pattern, report)["passed"]


def test_go_pos_turns_the_feet():
    robot = Robot.from_model("sample_humanoid")
    theta = np.deg2rad(30.0)
    steps = go_pos(0.15, 0.0, theta, feet_from_robot(robot))
    pattern = calc_walk_pattern(robot, steps, GaitParameters(dt=0.05, step_time=0.8), stop=3)
    feet = feet_from_robot(robot)
    for lb, foot in feet.items():
        assert foot.yaw == pytest.approx(theta, abs=2e-3)
        np.testing.assert_allclose(foot.p_W, pattern.plan.final_feet[lb].p_W, atol=1e-4)
    assert pattern.support_margin().min() > 0.0


def test_bad_input():
    arm = Robot.from_model("three_dof_arm")
    with pytest.raises(InvalidInput, match="free joint"):
        calc_walk_pattern(arm, [])
    robot = Robot.from_model("sample_humanoid")
    with pytest.raises(InvalidInput, match="lleg"):
        calc_walk_pattern(robot, [], soles={"rleg": robot_soles(robot)["rleg"]})
    pattern = calc_walk_pattern(
        robot, straight_steps(0, 0.1, feet_from_robot(robot)), GaitParameters(dt=0.1, step_time=0.5)
    )
    with pytest.raises(InvalidInput, match="Scene"):
        play_walk_pattern(pattern, "sample_humanoid")
    with pytest.raises(InvalidInput, match="settle_time"):
        play_walk_pattern(pattern, Scene.from_robot(robot), settle_time=-1.0)
    arm_scene = Scene.from_robot(Robot.from_model("three_dof_arm"))
    with pytest.raises(InvalidInput, match="robot it was made for"):
        play_walk_pattern(pattern, arm_scene)
