"""Simulation-coupled static balance (pik_mj.sim): contacts, equilibrium, physics hold.

Poses are built with pik_mj.solve on the robot-only sample humanoid; its scene
(Scene.from_robot) adds a floor (and a wall). Numbers are checked against independent
constructions: support polygons from the sole boxes' geometry, force and moment
balance of the LP's contact forces, and the robot placement transform.
"""

from __future__ import annotations

import json

import mink
import mujoco
import numpy as np
import pytest

import pik_mj
from pik_mj import HoldCriteria, Recorder, balance
from pik_mj.exceptions import InvalidInput, SimulationUnstable, UnknownName
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.record import PATHS, read_recording
from pik_mj.robot import Robot
from pik_mj.robot.ground import sole_polygons
from pik_mj.sim import ContactParams, Scene, add_wall, floor_environment, validate_pose
from pik_mj.sim.motion import Clearance, min_distance
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.linear import LinearTask
from pik_mj.tasks.support_polygon import SupportPolygonTask

SOLES = ("rleg_sole", "lleg_sole")
WALL_X = 0.65  # wall face [m], facing -x, in front of the robot
HAND_ON_WALL = ["rleg_sole", "lleg_sole", "rarm_hand"]


# ----------------------------------------------------------------- helpers
def sole_bottom_corners(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """World corners (8, 3) of the bottom faces of both sole boxes (from geometry)."""
    out = []
    for name in SOLES:
        g = model.geom(name).id
        R, p, h = data.geom_xmat[g].reshape(3, 3), data.geom_xpos[g], model.geom_size[g]
        for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
            out.append(p + R @ np.array([sx * h[0], sy * h[1], -h[2]]))
    return np.array(out)


def check_force_balance(report, mass: float, gravity=(0.0, 0.0, -9.81)) -> None:
    """The LP's contact forces cancel gravity: sum f = -m g, sum (p - c) x f = 0."""
    env = report.environment_contacts
    f = report.forces
    p = np.array([c.position for c in env])
    w = mass * np.asarray(gravity)
    np.testing.assert_allclose(f.sum(axis=0), -w, atol=1e-6 * mass * 9.81)
    moment = np.cross(p - report.com, f).sum(axis=0)
    np.testing.assert_allclose(moment, 0.0, atol=1e-6 * mass * 9.81)
    # Each force lies in its contact's friction cone (pushes, |f_t| <= mu f_n).
    for c, fi in zip(env, f, strict=True):
        fn = fi @ c.normal
        assert fn >= -1e-6
        assert np.linalg.norm(fi - fn * c.normal) <= c.friction * fn + 1e-6


def feet_levels(robot: Robot) -> list:
    cfg = robot.configuration
    return [
        FrameTask(cfg, s, robot.frame_pose(s), name=s, thre=1e-4, rthre=1e-3)
        for s in ("rleg_end", "lleg_end")
    ]


def com_task(robot: Robot, x: float, p_limit: float = 0.03) -> LinearTask:
    """CoM (x, y) onto (x, 0): rows ``J_com[:2] dq = clamp(p_target - p_com)`` [m],
    at most ``p_limit`` [m] per iteration."""
    target = np.array([x, 0.0])

    def b(cfg: mink.Configuration) -> np.ndarray:
        e = target - robot.com()[:2]
        return e * min(1.0, p_limit / max(np.linalg.norm(e), 1e-12))

    return LinearTask(
        A=lambda cfg: robot.com_jacobian()[:2],
        b=b,
        threshold=2e-3,
        name="com_xy",
    )


def posture(robot: Robot, cost, check: bool = False) -> pik_mj.MinkTask:
    task = mink.PostureTask(robot.model, cost=cost)
    task.set_target(robot.configuration.q.copy())
    return pik_mj.MinkTask(task, check=check)


def humanoid_scene(**options) -> Scene:
    """The scene of a sample humanoid alone (floor added)."""
    return Scene.from_robot(Robot.from_model("sample_humanoid"), **options)


# ----------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def scene() -> Scene:
    return humanoid_scene()


@pytest.fixture(scope="module")
def reset_q(scene) -> np.ndarray:
    rm = scene.robot.model
    return rm.key_qpos[rm.key("reset_pose").id].copy()


@pytest.fixture(scope="module")
def lean():
    """CoM 8 cm ahead of the toes (x = 0.14 m), feet kept flat; per-iteration checks."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    log = scene.static_checker(mu=1.0)
    levels = [
        [mink.ConfigurationLimit(robot.model)],
        feet_levels(robot),
        [com_task(robot, 0.22)],
        [posture(robot, 1e-2)],
    ]
    result = pik_mj.solve(robot.configuration, levels, stop=100, callback=log)
    assert result.converged, result.summary()
    return robot, scene, log, result


@pytest.fixture(scope="module")
def crouch(scene):
    """Right hand to (0.6, 0.15, 0.49) m, CoM kept 2 cm inside the soles' polygon."""
    robot = Robot.from_model("sample_humanoid")
    robot.reset_pose()
    result = fullbody_inverse_kinematics(
        robot,
        [(np.array([0.6, 0.15, 0.49]), np.array([1.0, 0.0, 0.0, 0.0]))],
        limbs=["rarm"],
        rotation_axis=[None],
        balance=[
            SupportPolygonTask(
                robot.configuration,
                sole_polygons(robot),
                root_body=robot.root_body,
                margin=0.02,
            )
        ],
        stop=100,
    )
    assert result.converged, result.summary()
    q = robot.configuration.q.copy()
    return q, scene.static_check(q)


@pytest.fixture(scope="module")
def wall_pose():
    """Right hand's fingertips on a wall ahead, CoM 3 cm ahead of the toes."""
    robot = Robot.from_model("sample_humanoid")
    m = robot.model
    keep = np.zeros(m.nv)  # left arm and head stay where they are
    for j in range(m.njnt):
        if m.joint(j).name.startswith(("larm", "head")):
            keep[m.jnt_dofadr[j]] = 1.0
    # Hand z (towards the elbow) along -x: the fingertip face (0.05 m beyond the
    # site along -z_hand) 0.5 mm into the wall; rotation about hand z free.
    R_WT = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    hand = FrameTask(
        robot.configuration,
        "rarm_end",
        (np.array([WALL_X - 0.05 + 5e-4, -0.3, 1.2]), R_WT),
        rotation_axis="z",
        name="hand",
        thre=2e-4,
        rthre=1e-2,
    )
    levels = [
        [mink.ConfigurationLimit(m)],
        [*feet_levels(robot), posture(robot, keep)],
        [hand],
        [com_task(robot, 0.17)],
        [posture(robot, 1e-2)],
    ]
    result = pik_mj.solve(robot.configuration, levels, stop=100)
    assert result.converged, result.summary()
    return robot, robot.configuration.q.copy()


def wall_scene(with_wall: bool) -> Scene:
    env = floor_environment()
    if with_wall:
        add_wall(env, (WALL_X, 0.0, 0.0), (-1.0, 0.0, 0.0))
    return humanoid_scene(environment=env, allowed_contacts=HAND_ON_WALL)


# --------------------------------------------------------- reset pose
def test_reset_pose_static_check_matches_sole_geometry(scene, reset_q):
    report = scene.static_check(reset_q, scfr=True)
    assert report.feasible, report.message
    assert report.touching_geoms == sorted(SOLES)
    assert report.self_contacts == []
    # Independent: hull of the sole boxes' bottom corners and the robot-only CoM.
    robot = Robot.from_model("sample_humanoid")
    corners = sole_bottom_corners(robot.model, robot.data)
    region = balance.support_polygon([corners])
    expected = region.signed_distance(robot.com())
    assert expected > 0.05
    assert report.margin == pytest.approx(expected, abs=1e-6)
    np.testing.assert_allclose(report.com, robot.com(), atol=1e-9)
    assert report.support_polygon.shape == (4, 3)
    # Flat ground, mu = 1: the SCFR of the actual contacts is the support polygon.
    assert report.scfr_margin == pytest.approx(report.margin, abs=2e-4)
    check_force_balance(report, scene.mass)
    assert scene.mass == pytest.approx(robot.mass)
    json.dumps(report.to_dict())


def test_reset_pose_hold_passes(scene, reset_q):
    hold = scene.hold(reset_q, 3.0)
    assert hold.passed, hold.failures
    assert hold.steps == 1500 and hold.simulated == pytest.approx(3.0)
    assert hold.drift < 0.01 and hold.slip < 0.002 and not hold.fell
    assert set(hold.slip_per_geom) == set(SOLES)
    # Standing still, the margin over the hold is the static one (polygon of the
    # sole corners within the contact tolerance, as static_check).
    assert hold.min_margin == pytest.approx(scene.static_check(reset_q).margin, abs=1e-3)
    assert hold.unexpected_contacts == []
    json.dumps(hold.to_dict())


def test_hold_margin_counts_touching_soles_from_the_start(scene, reset_q):
    # Soles 1 um above the floor: touching for static_check (tolerance 2 mm), not
    # yet in contact for the physics (dist > 0) until the robot has sunk. The
    # margin at the start is the static one, not -inf (no physical contact yet)
    # nor one foot's polygon (some corners registering first).
    hover = reset_q.copy()
    hover[2] += 1e-6
    static = scene.static_check(hover)
    assert static.touching_geoms == sorted(SOLES) and static.margin > 0.09
    hold = scene.hold(hover, 0.5, margin_every=1)
    assert hold.passed, hold.failures
    assert hold.min_margin == pytest.approx(static.margin, abs=1e-3)


def test_hard_contacts_settle_shallow_and_default_to_them(scene, reset_q):
    # The Scene default is a 5 ms contact time constant; MuJoCo's 20 ms default
    # lets the standing robot sink ten times deeper into the floor.
    def depth(s: Scene) -> float:
        assert s.hold(reset_q, 1.0).passed
        return -min(s.data.contact[i].dist for i in range(s.data.ncon))

    hard, soft = depth(scene), depth(humanoid_scene(contact=ContactParams()))
    assert scene.model.geom("rleg_sole").solref[0] == 0.005
    assert 0.0 < hard < 1e-4
    assert soft > 4e-4 and soft > 5 * hard
    with pytest.raises(InvalidInput, match="two time steps"):
        humanoid_scene(timestep=0.004)


def test_crouched_reach_with_2cm_margin_holds_on_hard_contacts(crouch):
    # CoM 2 cm inside the front-left corner region of the soles at 0.58 m: tipping
    # over the edge needs the CoM raised by only r^2 / 2h = 0.35 mm. Released from
    # rest, the robot sinks into the floor until the contacts carry it; with the
    # soft 20 ms contact that transient rolls it over the sole edge.
    q, static = crouch
    assert static.feasible and static.margin == pytest.approx(0.02, abs=1e-3)
    hard = humanoid_scene().hold(q, 3.0)
    assert hard.passed, hard.failures
    assert hard.drift < 0.005 and hard.min_margin > 0.015
    soft = humanoid_scene(contact=ContactParams()).hold(q, 3.0)
    assert soft.fell and not soft.passed


def test_contact_tolerance_counts_touching_not_hovering(scene, reset_q):
    lifted = reset_q.copy()
    lifted[2] += 1.5e-3
    report = scene.static_check(lifted)
    assert report.touching_geoms == sorted(SOLES)
    dists = [c.dist for c in report.contacts]
    np.testing.assert_allclose(dists, 1.5e-3, atol=1e-8)
    assert report.feasible
    lifted[2] += 1.5e-3  # 3 mm > contact_tolerance = 2 mm
    report = scene.static_check(lifted)
    assert report.contacts == [] and not report.feasible
    assert report.margin == -np.inf and report.to_dict()["margin"] is None
    # The tolerance lives in a collision-only copy; the physics keeps margin 0.
    assert np.all(scene.model.geom_margin == 0.0)


def test_robot_placement_maps_the_pose(reset_q):
    pos, yaw = np.array([0.3, -0.2, 0.0]), 0.7
    placed = Robot.from_model("sample_humanoid", environment="room", at=(pos[0], pos[1], yaw))
    scene = Scene.from_robot(placed)
    scene.set_pose(placed.configuration.q)
    # the robot's configuration is the prefix of the scene's qpos, as it is
    np.testing.assert_array_equal(scene.data.qpos[: placed.model.nq], placed.configuration.q)
    robot = Robot.from_model("sample_humanoid")
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    for site in ("rarm_end", "lleg_end", "head_end"):
        expected = pos + R @ robot.data.site(site).xpos
        np.testing.assert_allclose(scene.data.site(site).xpos, expected, atol=1e-9)
    np.testing.assert_allclose(scene.com(), pos + R @ robot.com(), atol=1e-9)
    # Servo targets are the pose.
    for j in ("rleg_knee_p", "larm_elbow_p"):
        assert scene.data.actuator(f"{j}_servo").ctrl[0] == scene.data.joint(j).qpos[0]


# --------------------------------------------------------- CoM outside
def test_com_ahead_of_toes_is_infeasible_and_falls(lean):
    robot, scene, _, _ = lean
    q = robot.configuration.q
    report = scene.static_check(q, mu=1.0)
    assert report.touching_geoms == sorted(SOLES)
    assert not report.feasible and report.forces is None
    # Independent: distance beyond the front edge of the sole boxes (x = 0.14 m).
    toes = sole_bottom_corners(robot.model, robot.data)[:, 0].max()
    assert toes == pytest.approx(0.14, abs=1e-3)
    assert report.margin == pytest.approx(-(robot.com()[0] - toes), abs=1e-3)
    assert report.margin < -0.07
    hold = scene.hold(q)
    assert not hold.passed
    assert hold.fell and hold.drift > 0.1


def test_iteration_callback_records_every_iteration(lean):
    _, _, log, result = lean
    # Steps of at most 3 cm take the CoM from 1.4 cm to 22 cm: it crosses the toes.
    assert len(log.reports) == result.iterations >= 7
    assert log.reports[0].feasible and log.reports[0].margin > 0
    assert not log.reports[-1].feasible and log.reports[-1].margin < 0
    np.testing.assert_allclose(log.reports[-1].q, result.q)
    # Feasible exactly while the CoM is inside the polygon (flat ground, mu = 1).
    for r in log.reports:
        if abs(r.margin) > 1e-3:
            assert r.feasible == (r.margin > 0)
    assert len(log.to_dicts()) == result.iterations


# --------------------------------------------------------- hand on a wall
def test_hand_on_wall_balances_only_with_the_wall(wall_pose):
    robot, q = wall_pose
    toes = sole_bottom_corners(robot.model, robot.data)[:, 0].max()
    assert robot.com()[0] > toes + 0.02

    with_wall = wall_scene(True)
    report = with_wall.static_check(q, scfr=True)
    assert report.touching_geoms == sorted(HAND_ON_WALL)
    assert report.self_contacts == []
    hand = [c for c in report.environment_contacts if c.robot_geom == "rarm_hand"]
    assert all(c.other_geom == "wall" for c in hand)
    for c in hand:  # on the wall face, pushed back along -x
        assert c.position[0] == pytest.approx(WALL_X, abs=1e-3)
        np.testing.assert_allclose(c.normal, [-1.0, 0.0, 0.0], atol=1e-9)
    assert report.margin < -0.02  # outside the feet's polygon ...
    assert report.feasible  # ... yet balanced by the wall
    assert report.scfr_margin > 0.0
    check_force_balance(report, with_wall.mass)
    # The wall pushes back: on a frictionless floor nothing resists it.
    assert not with_wall.static_check(q, mu=0.0).feasible
    hold = with_wall.hold(q)
    assert hold.passed, hold.failures
    assert "rarm_hand" in hold.slip_per_geom

    without = wall_scene(False)
    report = without.static_check(q)
    assert report.touching_geoms == sorted(SOLES)
    assert not report.feasible
    hold = without.hold(q)
    assert not hold.passed and hold.fell


def test_unexpected_contact_fails_the_hold(wall_pose):
    _, q = wall_pose
    env = floor_environment()
    add_wall(env, (WALL_X, 0.0, 0.0), (-1.0, 0.0, 0.0))
    scene = humanoid_scene(environment=env)  # the hand is not allowed by default
    hold = scene.hold(q, 0.2)
    assert not hold.passed
    assert ("rarm_hand", "wall") in {(a, b) for a, b, _ in hold.unexpected_contacts}


# --------------------------------------------------------- guard
def test_absurd_velocity_raises(scene, reset_q, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to ./MUJOCO_LOG.TXT
    scene.set_pose(reset_q)
    scene.data.qvel[:] = 1e12
    with pytest.raises(SimulationUnstable, match="BADQVEL"):
        scene.step()


def test_nan_position_raises(scene, reset_q, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to ./MUJOCO_LOG.TXT
    scene.set_pose(reset_q)
    scene.data.qpos[scene.model.joint("rleg_knee_p").qposadr[0]] = np.nan
    with pytest.raises(SimulationUnstable, match="rleg_knee_p"):
        scene.step()


def test_diverging_servos_raise_during_hold(reset_q, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to ./MUJOCO_LOG.TXT
    # kp 1e8 on joints of ~0.01 kg m² at dt = 0.002: omega dt ~ 200, explicit
    # stiffness diverges within a few steps.
    scene = humanoid_scene(kp=1e8, kv=0.0)
    with pytest.raises(SimulationUnstable, match="unstable"):
        scene.hold(reset_q, 1.0)


# --------------------------------------------------------- recording, CLI
def test_hold_records_on_sim_time(tmp_path, scene, reset_q):
    path = tmp_path / "hold.rrd"
    with Recorder.to_file(path) as rec:
        hold = scene.hold(reset_q, 0.5, callback=rec.hold_logger(every=25))
    out = read_recording(path)
    drift = out[PATHS.hold_metric("drift")]
    (component,) = drift.temporal
    times, values = drift.series(component, "sim_time")
    assert len(times) == 250 // 25 + 1
    np.testing.assert_allclose(times, np.arange(11) * 0.05, atol=1e-9)
    assert max(np.ravel(values)) == pytest.approx(hold.drift, rel=0.2)
    assert "pelvis" in out[PATHS.bodies()].static["Ellipsoids3D:labels"]
    assert len(out[PATHS.bodies()].temporal["Ellipsoids3D:centers"]) == 250 // 25 + 1


def test_validate_pose():
    out = validate_pose("sample_humanoid", "reset_pose", duration=1.0)
    assert out["passed"] and out["static"]["feasible"] and out["hold"]["passed"]
    json.dumps(out)
    with pytest.raises(UnknownName, match="reset_pose"):
        validate_pose("sample_humanoid", "nope", duration=0.1)
    with pytest.raises(InvalidInput, match="shape"):
        validate_pose("sample_humanoid", np.zeros(5), duration=0.1)


def test_bad_inputs(scene, reset_q):
    with pytest.raises(UnknownName, match="rleg_sole"):
        scene.hold(reset_q, 0.1, criteria=HoldCriteria(allowed=["nope"]))
    with pytest.raises(InvalidInput, match="NaN"):
        scene.static_check(np.full(scene.robot_nq, np.nan))
    with pytest.raises(InvalidInput, match="horizontal"):
        add_wall(floor_environment(), (1, 0, 0), (0, 0, 1))
    with pytest.raises(UnknownName, match="rleg_knee_p"):
        humanoid_scene(kp={"nope": 1.0})


def test_degenerate_support_is_a_negative_distance():
    segment = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    region = balance.support_polygon([segment], allow_degenerate=True)
    assert region.vertices_3d.shape == (2, 3) and region.halfplanes is None
    assert region.signed_distance(np.array([0.5, 0.3, 1.0])) == pytest.approx(-0.3)
    assert region.signed_distance(np.array([2.0, 0.0, 0.0])) == pytest.approx(-1.0)
    point = balance.support_polygon([segment[:1]], allow_degenerate=True)
    assert point.signed_distance(np.array([0.3, 0.4, 0.0])) == pytest.approx(-0.5)
    assert region.shrunk(0.01).shape == (0, 3)


def test_robot_actuators_and_keyframe_ctrl_are_kept():
    from pik_mj.robot.loading import load_spec

    spec = load_spec("sample_humanoid")
    spec.add_actuator(name="knee_motor", target="rleg_knee_p", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    key = spec.key("reset_pose")
    key.ctrl = [0.25]
    scene = Scene.from_robot(Robot.from_model(spec))
    m = scene.model
    assert m.nu == 1 + len(scene.servo_joints) and m.actuator(0).name == "knee_motor"
    k = m.key("reset_pose").id
    assert m.key_ctrl[k, 0] == 0.25
    for j in ("rleg_knee_p", "larm_elbow_p", "rleg_hip_p"):
        a = m.actuator(f"{j}_servo").id
        assert m.key_ctrl[k, a] == m.key_qpos[k, m.joint(j).qposadr[0]]


# ------------------------------------------------------------------ grasp
def box_environment(mass: float = 2.0) -> mujoco.MjSpec:
    """A floor and a free 8 cm box ``box`` (``mass`` [kg]) far from the robot."""
    env = floor_environment()
    body = env.worldbody.add_body(name="box", pos=[2.0, 0.0, 0.5])
    body.add_freejoint(name="box_free")
    body.add_geom(name="box_geom", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.04] * 3, mass=mass)
    return env


def test_grasped_object_follows_the_hand_and_loads_the_balance(reset_q):
    m_box, g = 2.0, 9.81
    # Box 12 cm beside the right hand (away from the thigh), turned 90° about z.
    p_FO, R_FO = np.array([0.0, -0.12, 0.02]), np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    scene = humanoid_scene(
        environment=box_environment(m_box), grasps=[("rarm_end", "box", p_FO, R_FO)]
    )
    assert scene.carried_mass == pytest.approx(m_box)
    # Independent: the hand pose in the robot-only model, X_WO = X_WF X_FO.
    robot = Robot.from_model("sample_humanoid")
    X_WF = robot.frame_pose("rarm_end")
    p_WO = X_WF.translation() + X_WF.rotation().as_matrix() @ p_FO
    scene.set_pose(reset_q)
    qpos = scene.data.qpos.copy()
    adr = scene.model.jnt_qposadr[scene.model.joint("box_free").id]
    np.testing.assert_allclose(qpos[adr : adr + 3], p_WO, atol=1e-9)
    R_WO = np.zeros(9)
    mujoco.mju_quat2Mat(R_WO, qpos[adr + 3 : adr + 7])
    np.testing.assert_allclose(R_WO.reshape(3, 3), X_WF.rotation().as_matrix() @ R_FO, atol=1e-9)

    # Static check: the box is part of the system (CoM and weight).
    report = scene.static_check(reset_q)
    assert report.feasible and report.touching_geoms == sorted(SOLES)
    m_all = robot.mass + m_box
    np.testing.assert_allclose(report.com, (robot.mass * robot.com() + m_box * p_WO) / m_all)
    check_force_balance(report, m_all)

    # Physics: the weld carries the box's weight, the feet carry robot + box.
    hold = scene.hold(reset_q, 1.5)
    assert hold.passed, hold.failures
    assert hold.drift < 2e-3 and hold.slip < 1e-3
    d, m = scene.data, scene.model
    rows = (d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (
        d.efc_id == m.equality("grasp_box").id
    )
    f_weld = d.efc_force[rows][:3]  # on the hand, world frame [N]
    np.testing.assert_allclose(f_weld, [0.0, 0.0, -m_box * g], atol=0.01 * m_box * g)
    _, f_feet = scene.contact_forces()
    assert f_feet[:, 2].sum() == pytest.approx(m_all * g, rel=0.01)
    # The box stayed in the hand: X_WF(t) X_FO vs the box's pose, 1 mm.
    site = m.site("rarm_end").id
    expected = d.site_xpos[site] + d.site_xmat[site].reshape(3, 3) @ p_FO
    assert np.linalg.norm(d.xpos[m.body("box").id] - expected) < 1e-3

    with pytest.raises(UnknownName, match="rarm_end"):
        humanoid_scene(environment=box_environment(), grasps=[("rarm_hnd", "box", p_FO, R_FO)])
    with pytest.raises(UnknownName, match="box"):
        humanoid_scene(environment=box_environment(), grasps=[("rarm_end", "floor", p_FO, R_FO)])
    with pytest.raises(InvalidInput, match="rotation"):
        humanoid_scene(environment=box_environment(), grasps=[("rarm_end", "box", p_FO, 2 * R_FO)])


# ------------------------------------------------------- scene from a robot
def test_grasp_pair_reads_the_object_pose_from_the_robot():
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    # carry the kettle with the hand: put it 5 cm below the hand, turned 0.3 rad
    X_WF = robot.frame_pose("rarm_end")
    R = X_WF.rotation().as_matrix() @ np.array(
        [[np.cos(0.3), -np.sin(0.3), 0], [np.sin(0.3), np.cos(0.3), 0], [0, 0, 1]]
    )
    p = X_WF.translation() - np.array([0.0, 0.0, 0.05])
    k = robot.model.joint("kettle_free").qposadr[0]
    q = robot.configuration.q.copy()
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, R.ravel())
    q[k : k + 7] = np.r_[p, quat]
    robot.configuration.update(q)
    scene = Scene.from_robot(robot, grasps=[("rarm_end", "kettle")])
    (g,) = scene.grasps
    # independent: X_FO = X_WF^-1 X_WO from the robot's own frames
    X_FO = X_WF.inverse() @ robot.frame_pose("kettle", "body")
    np.testing.assert_allclose(g.p_FO, X_FO.translation(), atol=1e-12)
    np.testing.assert_allclose(g.R_FO, X_FO.rotation().as_matrix(), atol=1e-12)
    assert scene.carried_mass == pytest.approx(1.0)
    # the kettle follows the hand when the robot moves
    robot.set_angle_vector([-0.5], ["rarm_shoulder_p"])
    scene.set_pose(robot.configuration.q)
    hand = scene.data.site("rarm_end")
    expected = hand.xpos + hand.xmat.reshape(3, 3) @ g.p_FO
    np.testing.assert_allclose(scene.data.body("kettle").xpos, expected, atol=1e-12)
    assert scene.robot is robot


def _kettle_in_the_hand() -> tuple[Robot, np.ndarray]:
    """The robot at the counter with the kettle moved so that its handle bar
    passes through the right hand's site (the hand box around the bar), upright."""
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    q = robot.configuration.q.copy()
    k = robot.model.joint("kettle_free").qposadr[0]
    handle_in_kettle = robot.model.site("kettle_handle").pos  # [m], kettle frame
    q[k : k + 7] = np.r_[robot.frame_pose("rarm_end").translation() - handle_in_kettle, 1, 0, 0, 0]
    robot.configuration.update(q)
    return robot, q


def _hand_kettle(contacts) -> set[str]:
    return {c.other_geom for c in contacts if c.robot_geom == "rarm_hand"}


def test_scene_kinematics_of_a_robot_configuration():
    robot, q = _kettle_in_the_hand()
    scene = Scene.from_robot(robot)
    before = scene.data.qpos.copy()
    d = scene.kinematics(q)
    assert d is not scene.data and np.array_equal(scene.data.qpos, before)
    # Independent: the robot's own model (mink's forward kinematics).
    for name, kind in (("rarm_end", "site"), ("kettle", "body"), ("head_link", "body")):
        X = robot.frame_pose(name, kind)
        frame = d.site(name) if kind == "site" else d.body(name)
        np.testing.assert_allclose(frame.xpos, X.translation(), atol=1e-12)
        np.testing.assert_allclose(frame.xmat.reshape(3, 3), X.rotation().as_matrix(), atol=1e-12)
    np.testing.assert_allclose(scene.com(d), robot.com(), atol=1e-12)  # mj_comPos ran
    again = scene.kinematics(q, d)
    assert again is d
    with pytest.raises(InvalidInput, match="q"):
        scene.kinematics(q[:-1])
    with pytest.raises(InvalidInput, match="MjData"):
        scene.kinematics(q, mujoco.MjData(humanoid_scene().model))


def test_excluded_body_pair_never_touches():
    """The hand box around the kettle's handle bar touches it in the room as it
    is, in the static check and in the physics, and never with the pair excluded;
    every other contact is the same."""
    robot, q = _kettle_in_the_hand()
    room = Scene.from_robot(robot)
    open_hand = Scene.from_robot(robot, exclude=[("rarm_hand", "kettle")])
    assert open_hand.exclude == [("rarm_hand", "kettle")]
    qpos = room.kinematics(q).qpos
    seen = _hand_kettle(room.touching(qpos))
    assert "kettle_handle" in seen and all(g.startswith("kettle") for g in seen)
    assert _hand_kettle(open_hand.touching(qpos)) == set()
    others = {
        (c.robot_geom, c.other_geom) for c in room.touching(qpos) if c.robot_geom != "rarm_hand"
    }
    assert others == {
        (c.robot_geom, c.other_geom)
        for c in open_hand.touching(qpos)
        if c.robot_geom != "rarm_hand"
    }
    for scene, touches in ((room, True), (open_hand, False)):
        scene.set_pose(q)  # mj_forward: the physics' own contacts
        contacts = scene.contacts(scene.data, 0.0)
        assert bool(_hand_kettle(contacts)) == touches
    with pytest.raises(UnknownName, match="kettle"):
        Scene.from_robot(robot, exclude=[("rarm_hand", "kettel")])
    with pytest.raises(InvalidInput, match="pairs"):
        Scene.from_robot(robot, exclude=[("rarm_hand",)])
    with pytest.raises(InvalidInput, match="pairs"):
        Scene.from_robot(robot, exclude="rarm_hand")


def test_min_distance_and_clearance_names():
    """The kettle raised 5 cm above the counter: its pot's bottom is 5 cm from
    the counter's top (mj_geomDistance, cylinder against box)."""
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    scene = Scene.from_robot(robot)
    q = robot.configuration.q.copy()
    k = robot.model.joint("kettle_free").qposadr[0]
    q[k + 2] += 0.05
    d = scene.kinematics(q)
    ids = [scene.model.geom(n).id for n in ("kettle_pot", "counter")]
    assert min_distance(scene.model, d, ids[:1], ids[1:]) == pytest.approx(0.05, abs=1e-6)
    assert min_distance(scene.model, d, ids[:1], ids[1:], distmax=0.01) == 0.01
    clearance = Clearance(scene.model, ["kettle_pot", ids[0]], ["counter"])
    assert clearance.geoms == [ids[0], ids[0]] and clearance.physics == np.inf
    with pytest.raises(UnknownName, match="counter"):
        Clearance(scene.model, ["rarm_hand"], ["countr"])
    with pytest.raises(InvalidInput, match="geom"):
        Clearance(scene.model, "rarm_hand", ["counter"])


def test_scene_needs_a_robot_that_knows_its_world():
    with pytest.raises(InvalidInput, match=r"Robot\.from_model"):
        Scene.from_robot(Robot(mujoco.MjModel.from_xml_path(str(_model_file()))))
    with pytest.raises(InvalidInput, match=r"Robot\.from_model"):
        Scene.from_robot("sample_humanoid")
    in_room = Robot.from_model("sample_humanoid", environment="room")
    with pytest.raises(InvalidInput, match="already stands"):
        Scene.from_robot(in_room, environment=floor_environment())
    with pytest.raises(InvalidInput, match="shape"):
        Scene.from_robot(in_room).set_pose(np.zeros(37))  # the robot's nq is 44 here


def _model_file():
    from pik_mj.robot.loading import model_path

    return model_path("sample_humanoid")


def test_unnamed_joints_get_servos_and_keep_their_addresses():
    spec = mujoco.MjSpec.from_string(
        """<mujoco><compiler angle="radian"/><worldbody>
        <body name="base" pos="0 0 0.5"><geom type="box" size="0.1 0.1 0.1"/>
          <body pos="0 0 0.2"><joint type="hinge" axis="0 1 0" range="-1 1"/>
            <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
            <body pos="0.3 0 0"><joint type="hinge" axis="0 1 0" range="-1 1"/>
              <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
              <site name="tip" pos="0.3 0 0"/></body></body></body>
        </worldbody></mujoco>"""
    )
    robot = Robot.from_model(spec)
    # named after their bodies (unnamed too: body index in the MJCF) and their rank there
    assert robot.joint_names == ["body2_joint0", "body3_joint0"]
    assert [robot.model.geom(g).name for g in range(robot.model.ngeom)] == [
        "base_geom0",
        "body2_geom0",
        "body3_geom0",
    ]
    assert robot.limbs["arm"].joints == ("body2_joint0", "body3_joint0")  # a fixed-base chain
    scene = Scene.from_robot(robot)
    assert scene.servo_joints == ["body2_joint0", "body3_joint0"]
    q = np.array([0.3, -0.4])
    scene.set_pose(q)
    robot.configuration.update(q)
    np.testing.assert_allclose(scene.data.site("tip").xpos, robot.data.site("tip").xpos)
    np.testing.assert_allclose(scene.data.ctrl, q)  # servo targets at the pose


def test_hold_callbacks_receive_samples(scene, reset_q):
    samples: list = []
    seen: list = []

    def keep(sample) -> None:
        samples.append((sample.time, sample.step, sample.drift, sample.com.copy()))
        if sample.step in (0, 500):
            # forces on the robot from MuJoCo's contacts; the support polygon of
            # the touching soles and the CoM margin to it
            seen.append(
                (sample.contact_forces.sum(axis=0), sample.margin, len(sample.support_polygon))
            )

    hold = scene.hold(reset_q, 1.0, callback=[keep, lambda s: None], every=50)
    assert [t for t, *_ in samples] == pytest.approx(np.arange(11) * 0.1)
    assert [k for _, k, _, _ in samples] == list(range(0, 501, 50))
    assert max(d for *_, d, _ in samples) <= hold.drift
    weight = scene.mass * 9.81
    _, margin_start, n_start = seen[0]
    assert n_start == 4 and margin_start == pytest.approx(hold.min_margin, abs=1e-3)
    f_end, _, _ = seen[1]
    # standing still after 1 s: MuJoCo's contact forces carry the robot's weight
    assert f_end[2] == pytest.approx(weight, rel=0.01)
    np.testing.assert_allclose(f_end[:2], 0.0, atol=0.01 * weight)
    with pytest.raises(InvalidInput, match=r"callback\[1\] must be callable"):
        scene.hold(reset_q, 0.1, callback=[keep, "log"])
    assert len(samples) == 11  # nothing ran
