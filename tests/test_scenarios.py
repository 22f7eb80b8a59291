"""The scenario registry, the scenario support, and figures of single scenarios.

(Every scenario runs green, with its recording read back, in
tests/test_run_recording.py.)"""

from __future__ import annotations

import inspect
import json
from pathlib import Path

import numpy as np
import pik_mj.scenarios
import pytest
from scipy.spatial import ConvexHull

from pik_mj import Recorder, Robot, Scene, UnknownName
from pik_mj.balance import support_polygon
from pik_mj.cli import load_scenario, read_pose_file
from pik_mj.scenario import RobotRefused, ScenarioResult, Stature, jsonable
from pik_mj.scenario.reach import sample_arm
from pik_mj.sim import validate_pose


def test_registry_is_the_package():
    names = pik_mj.scenarios.SCENARIOS
    assert pik_mj.scenarios.DEFAULT in names and len(set(names)) == len(names) == 9
    for name in names:
        module = load_scenario(name)
        assert module.__name__ == f"pik_mj.scenarios.{name}" and module.NAME == name
        assert module.__doc__.strip().splitlines()[0]  # the description
        run = inspect.signature(module.run).parameters
        assert next(iter(run)) == "recorder"
        assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in list(run.values())[1:])
        assert callable(module.main)
    with pytest.raises(UnknownName, match="fullbody_reach"):
        load_scenario("nope")


def test_scene_of_a_robot_placed_in_the_room_checks_its_configuration():
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_wall")
    robot.set_angle_vector([0.4, 0.3], ["torso_waist_y", "rarm_shoulder_p"])
    report = Scene.from_robot(robot).static_check(robot.configuration.q)
    # the IK model and the scene (its copy with a floor, servos, contact
    # parameters) agree on the CoM ...
    assert np.allclose(report.com, robot.com(), atol=1e-12)
    assert report.touching_geoms == ["lleg_sole", "rleg_sole"]
    # ... and the scene's contact hull is the hull of the sole boxes' bottom corners
    # computed from the IK model's geom poses
    m, d = robot.model, robot.data
    corners = []
    for name in ("rleg_sole", "lleg_sole"):
        g = m.geom(name).id
        R, (hx, hy, hz) = d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
        corners += [
            d.geom_xpos[g] + R @ [sx * hx, sy * hy, -hz] for sx in (-1, 1) for sy in (-1, 1)
        ]
    hull = ConvexHull(np.array(corners)[:, :2])
    expected = np.array(corners)[hull.vertices, :2]
    got = report.support_polygon[:, :2]
    assert len(got) == len(expected) == 4
    assert all(np.min(np.linalg.norm(got - e, axis=1)) < 1e-6 for e in expected)
    # the iso-margin outline passes through the CoM's projection
    outline = support_polygon([report.margin_outline]).signed_distance(report.com)
    assert abs(outline) < 1e-9


def test_dm_humanoid_stands_on_its_floor_in_static_equilibrium():
    robot = Robot.from_model("dm_humanoid")
    report = Scene.from_robot(robot).static_check(robot.configuration.q)
    assert report.feasible and report.margin > 0.02
    assert report.touching_geoms == [
        "left_left_foot",
        "left_right_foot",
        "right_left_foot",
        "right_right_foot",
    ]


def test_shrunk_polygon_is_the_inward_offset():
    square = np.array([[0, 0, 0.1], [0.2, 0, 0.1], [0.2, 0.3, 0.1], [0, 0.3, 0.1]])
    region = support_polygon([square])
    assert np.allclose(
        region.shrunk(0.05),
        [[0.05, 0.05, 0.1], [0.15, 0.05, 0.1], [0.15, 0.25, 0.1], [0.05, 0.25, 0.1]],
    )
    assert region.shrunk(0.11).shape == (0, 3)  # past the inradius: gone


def test_fullbody_reach_on_dm_humanoid(tmp_path):
    with Recorder.to_file(tmp_path / "dm.rrd") as recorder:
        result = load_scenario("fullbody_reach").run(recorder, model="dm_humanoid", hold=0.0)
    assert result.passed, result.summary()
    f = result.figures
    assert f["model"] == "dm_humanoid"
    assert f["feet_moved_m"] <= 1e-4 and f["com_xy_error_m"] <= 1e-3 and f["com_margin_m"] > 0
    assert result.balance is None and result.robot_state["model"] == "dm_humanoid"


def test_three_dof_boundary_matches_the_joint_limit_geometry(tmp_path):
    with Recorder.to_file(tmp_path / "arm.rrd") as recorder:
        f = load_scenario("three_dof_reach").run(recorder).figures
    # tip down at height 0 needs the elbow bend 2 acos(x / 0.2) <= 100°
    x_min = 0.2 * np.cos(np.deg2rad(50.0))
    assert f["x_min_analytic_m"] == pytest.approx(x_min)
    assert min(f["reached_x_m"]) >= x_min - 2e-3 and max(f["failed_x_m"]) <= x_min + 2e-3
    assert np.allclose(f["failing_case_angles_deg"], 30.0)


def test_failed_check_fails_the_scenario():
    r = ScenarioResult("x")
    assert r.check("fine", True) and r.passed
    assert not r.check("broken", False, "detail")
    assert not r.passed and r.messages[-1] == "[FAILED] broken: detail"
    assert r.to_dict()["passed"] is False


def test_kettle_is_held_in_the_hand_during_the_hold(tmp_path):
    with Recorder.to_file(tmp_path / "kettle.rrd") as recorder:
        # the hold alone (its motion: tests/test_motion_scenarios.py)
        result = load_scenario("kettle").run(recorder, hold=1.5, speed=0.0)
    assert result.passed, result.summary()
    hold = result.balance["hold"]
    assert hold["drift"] < 0.01 and hold["slip"] < 0.002 and hold["unexpected_contacts"] == []
    lift = result.figures["kettle_lift_m"]
    # lifted 0.1 m; the hand turns about the vertical bar (the lift leaves the rotation
    # about the grip free), which swings the kettle's origin, off the bar, by a few mm
    assert abs(lift[2] - 0.1) < 2e-3 and np.linalg.norm(lift[:2]) < 5e-3
    # The static check's system is the robot and the 1 kg kettle: the LP's
    # contact forces carry both weights.
    forces = np.array(result.balance["static"]["forces"])
    m_kettle = 1.0  # room.xml: kettle geoms 0.74 + 0.05 + 0.05 + 0.03 + 0.03 + 0.1 kg
    assert forces[:, 2].sum() == pytest.approx((result.robot.mass + m_kettle) * 9.81, rel=1e-6)
    # and the system's CoM is the mass-weighted mean of the robot's and the kettle's
    m = result.robot.model
    kettle_com = result.robot.data.xipos[m.body("kettle").id]
    expected = (result.robot.mass * result.robot.com() + m_kettle * kettle_com) / (
        result.robot.mass + m_kettle
    )
    np.testing.assert_allclose(result.balance["static"]["com"], expected, atol=1e-6)

    # `pik-mj validate` of the run's JSON rebuilds the scene with the grasp:
    # the kettle is carried again, not left on the counter.
    path = tmp_path / "kettle.json"
    path.write_text(json.dumps(jsonable(result.to_dict())))
    pose = read_pose_file(path)
    # the scene made for the robot, written as MJCF (scenario.scenes.scene_file)
    assert Path(pose["source"].environment).name.startswith("kettle-sample_humanoid-")
    assert pose["source"].at is None
    [(frame, body, p_FO, R_FO)] = pose["grasps"]
    # the grasp frame is the hand's body (its origin at the wrist); the kettle's origin,
    # the middle of its body, hangs about 0.21 m below it, the handle in the hand
    assert (frame, body) == ("rarm_hand", "kettle") and np.linalg.norm(p_FO) < 0.3
    np.testing.assert_allclose(np.array(R_FO) @ np.array(R_FO).T, np.eye(3), atol=1e-9)
    report = validate_pose(
        pose["source"],
        pose["q"],
        1.0,
        allowed=pose["allowed_contacts"],
        grasps=pose["grasps"],
    )
    assert report["passed"], report
    # the static check's system holds the kettle's 1 kg, and the hold carries it
    forces = np.array(report["static"]["forces"])
    assert forces[:, 2].sum() == pytest.approx((result.robot.mass + m_kettle) * 9.81, rel=1e-6)
    assert report["hold"]["unexpected_contacts"] == []


class _Called(Exception):
    """Raised by a stand-in ``run`` with the keywords ``main`` gave it."""

    def __init__(self, options: dict):
        super().__init__("run called")
        self.options = options


@pytest.mark.parametrize("name", [n for n in pik_mj.scenarios.SCENARIOS if "walk" not in n])
def test_main_gives_run_the_parsed_options(name, tmp_path, monkeypatch):
    """Every scenario's ``main`` hands its parsed options to its ``run`` through
    ``run_options``: ``--hold``/``--speed``/``--quiet`` as given, the default model
    and the robot its check built, and only keywords ``run`` takes."""
    module = load_scenario(name)
    params = inspect.signature(module.run).parameters

    def fake_run(recorder, **options):
        raise _Called(options)

    monkeypatch.setattr(module, "run", fake_run)
    argv = ["--save", str(tmp_path / "x.rrd"), "--quiet"]
    if "hold" in params:
        argv += ["--hold", "1.5", "--speed", "0.5"]
    with pytest.raises(_Called) as called:
        module.main(argv)
    options = called.value.options
    options.pop("steps", None)  # cocktail_shaker's own option
    assert set(options) <= set(params)
    assert options["quiet"] is True
    assert options["model"] == module.ROBOT.default
    assert isinstance(options["robot"], Robot) and options["description"] is None
    if "hold" in params:
        assert (options["hold"], options["speed"]) == (1.5, 0.5)


@pytest.mark.parametrize(
    ("joints", "holds_axis"),
    [
        (["rarm_shoulder_p", "rarm_shoulder_r", "rarm_shoulder_y", "rarm_elbow_p"], False),
        (["rarm_shoulder_p", "rarm_elbow_p"], None),  # refused
    ],
)
def test_cocktail_shaker_on_a_shorter_right_arm(tmp_path, joints, holds_axis):
    """The sample humanoid described with a right arm of fewer joints: 4 joints hold
    the shaker's end by position (the grip left free), 2 are refused in one line; the
    sample humanoid's own 7-joint arm holds the grip along the shaker axis."""
    shaker = load_scenario("cocktail_shaker")
    path = tmp_path / "short_arm.toml"
    path.write_text(
        'model = "sample_humanoid"\n[limbs.rarm]\nend = "rarm_end"\n'
        f"joints = {json.dumps(joints)}\n"
    )
    if holds_axis is None:
        with pytest.raises(RobotRefused, match="its right arm has 2 joints; holding the "
                           r"shaker's end asks 3 \(its position\)"):  # fmt: skip
            shaker.ROBOT.check(None, str(path))
        return
    _, robot = shaker.ROBOT.check(None, str(path))
    assert robot.limb("rarm").joints == tuple(joints)
    assert shaker.Shaker(Stature.of(robot), robot).holds_axis is holds_axis
    whole = Robot.from_model("sample_humanoid")
    assert len(whole.limb("rarm").joints) >= shaker.AXIS_JOINTS
    assert shaker.Shaker(Stature.of(whole), whole).holds_axis


def test_sampled_arm_poses_are_the_robots_kinematics():
    """Each sampled configuration of an arm lies within its joint ranges and, set on
    the robot, puts the hand frame where the sample says (the robot's own frame
    transform); sampling leaves the robot as it stands."""
    robot = Robot.from_model("sample_humanoid")
    hand = Stature.of(robot).hands["larm"]
    q0 = robot.angle_vector()
    samples = sample_arm(robot, hand, 40, np.random.default_rng(1))
    np.testing.assert_array_equal(robot.angle_vector(), q0)
    lo, hi = robot.joint_limits(samples.joints)
    assert samples.q.shape == (40, len(samples.joints)) == (40, len(robot.limb("larm").joints))
    assert np.all((samples.q >= lo) & (samples.q <= hi))
    assert np.ptp(samples.p, axis=0).min() > 0.1  # spread over the arm's reach
    for k in (0, 17, 39):
        robot.set_angle_vector(samples.q[k], samples.joints)
        X_WH = hand.pose(robot)
        np.testing.assert_allclose(X_WH.translation(), samples.p[k], atol=1e-9)
        np.testing.assert_allclose(X_WH.rotation().as_matrix(), samples.R[k], atol=1e-9)


def test_cocktail_shaker_placed_from_the_arms_reach():
    """The sample humanoid's hands reach well across its middle plane: the manual's
    start, the whole swing, a shaker long enough for its box hands (half length
    0.045 m along the grip axis, ``ORANGE`` apart). With both shoulders unable to
    turn the arms inwards (roll and yaw ranges cut at 0), the hands do not reach the
    middle plane: the start is a sampled left-hand position (within the arm's length
    of its shoulder), not the manual's, and the shake does not swing."""
    shaker = load_scenario("cocktail_shaker")
    robot = Robot.from_model("sample_humanoid")
    stature = Stature.of(robot)
    held = shaker.Shaker(stature, robot)
    box = robot.model.geom("larm_hand").size[0]
    assert held.clearance(robot) == pytest.approx(2 * box + shaker.ORANGE, abs=1e-4)
    L = stature.arm_lengths["larm"]
    assert held.length == pytest.approx(max(shaker.SHAKER * L, 2 * box + shaker.ORANGE), abs=1e-4)
    middle = np.mean([stature.shoulders[a] for a in shaker.ARMS], axis=0)
    start = middle + L * stature.direction(shaker.START)
    place = shaker.placement(robot, stature, held, start, middle)
    assert place.manual and place.scale == 1.0 and place.start is start
    assert place.across >= held.length
    inwards = {"larm_shoulder_r": (0.0, 2.6), "rarm_shoulder_r": (-2.6, 0.0)}
    inwards |= {"larm_shoulder_y": (0.0, 1.6), "rarm_shoulder_y": (-1.6, 0.0)}
    for joint, limits in inwards.items():
        robot.model.joint(joint).range[:] = limits
    place = shaker.placement(robot, stature, held, start, middle)
    assert not place.manual and place.across < 0 and place.scale == 0.0
    assert np.linalg.norm(place.start - start) > 0.1 * L
    assert np.linalg.norm(place.start - stature.shoulders["larm"]) <= L
