"""Every seed example runs green through the scenario registry."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from pik_mj.cli import read_pose_file
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.robot import Robot
from pik_mj.scenarios import (
    REGISTRY,
    Scenario,
    ScenarioResult,
    ScenarioScene,
    _shrunk_polygon,
    jsonable,
    robot_at_spot,
    run_scenario,
)
from pik_mj.sim import validate_pose

KEYS = {"name", "passed", "converged", "iterations", "tasks", "timing", "figures", "messages"}
IK_SCENARIOS = sorted(n for n, e in REGISTRY.items() if not e.walking)


@pytest.mark.parametrize("name", IK_SCENARIOS)
def test_scenario_passes(name):
    # Walking scenarios run (shorter) in tests/test_run_recording.py.
    result = run_scenario(name)
    assert result.passed, result.summary()
    d = result.to_dict()
    assert KEYS <= set(d)
    json.dumps(d, allow_nan=False)  # JSON-ready
    assert d["timing"]["iteration_ms"] and all(t > 0 for t in d["timing"]["iteration_ms"])
    for task in d["tasks"]:
        assert {"name", "level", "error", "satisfied"} <= set(task)
    assert all(m.startswith("[ok]") for m in result.messages)
    assert result.balance is None  # no hold unless asked (pik-mj run asks)
    if result.robot is not None and result.robot.has_floating_base:
        # a static check in simulation on every iteration of every solve
        sim = d["simulation"]
        assert sim["iterations_checked"] == d["timing"]["total_iterations"]
        for label, solve in result.solves.items():
            assert len(result.static_reports.get(label, [])) == solve.iterations
        # the scene's CoM (scene model) is the robot's (scenario model) at the end
        last = [r for rs in result.static_reports.values() for r in rs][-1]
        if not list(result.solves.values())[-1].reverted:
            assert np.allclose(last.com, result.robot.com(), atol=1e-9)
        assert d["robot"]["q"] and d["robot"]["model"] == "sample_humanoid"
    else:
        assert d["simulation"] is None and d["robot"] is None


def test_walking_scenarios_are_registered_with_the_run_convention():
    import inspect

    for name in ("walk_forward", "walk_go_pos"):
        entry = REGISTRY[name]
        assert entry.walking and entry.missing() == []
        params = inspect.signature(entry.load()).parameters
        assert next(iter(params)) == "out" and params["out"].default is None
        assert params["progress"].kind is inspect.Parameter.KEYWORD_ONLY
    with pytest.raises(InvalidInput, match="takes no parameter"):
        run_scenario("walk_forward", params={"nope": 1})


def test_scene_of_a_robot_placed_in_the_room_maps_its_configuration():
    robot = robot_at_spot("sample_humanoid", "spot_wall")
    robot.set_angle_vector([0.4, 0.3], ["torso_waist_y", "rarm_shoulder_p"])
    scene = ScenarioScene.for_robot(robot)
    assert (scene.model, scene.environment) == ("sample_humanoid", "room")
    assert np.all(scene.robot_pos == 0.0)
    report = scene.static_check()
    # two independent MuJoCo models (robot+room composed once for the IK, robot and
    # room composed again for the scene) agree on the CoM ...
    assert np.allclose(report.com, robot.com(), atol=1e-9)
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


def test_scene_lowers_a_floating_robot_onto_the_floor():
    robot = Robot.load("dm_humanoid")
    scene = ScenarioScene.for_robot(robot)
    m, d = robot.model, robot.data
    # independent: lowest point of the foot capsules = end point z - radius
    bottoms = []
    for g in range(m.ngeom):
        if "foot" in m.body(m.geom_bodyid[g]).name:
            r, h = m.geom_size[g][0], m.geom_size[g][1]
            axis = d.geom_xmat[g].reshape(3, 3)[:, 2]
            bottoms.append(min(d.geom_xpos[g][2] + s * h * axis[2] for s in (-1, 1)) - r)
    assert scene.robot_pos[2] == pytest.approx(-min(bottoms), abs=1e-9)
    assert abs(scene.ground_gap()) < 1e-9
    assert scene.static_check().feasible


def test_shrunk_polygon_is_the_inward_offset():
    square = np.array([[0, 0, 0.1], [0.2, 0, 0.1], [0.2, 0.3, 0.1], [0, 0.3, 0.1]])
    inner = _shrunk_polygon(square, 0.05)
    assert np.allclose(
        inner, [[0.05, 0.05, 0.1], [0.15, 0.05, 0.1], [0.15, 0.25, 0.1], [0.05, 0.25, 0.1]]
    )
    assert _shrunk_polygon(square, 0.11).shape == (0, 3)  # past the inradius: gone


def test_fullbody_reach_on_dm_humanoid():
    result = run_scenario("fullbody_reach", model="dm_humanoid")
    assert result.passed, result.summary()
    f = result.figures
    assert f["model"] == "dm_humanoid"
    assert f["feet_moved_m"] <= 1e-4 and f["com_xy_error_m"] <= 1e-3 and f["com_margin_m"] > 0


def test_three_dof_boundary_matches_the_joint_limit_geometry():
    f = run_scenario("three_dof_reach").figures
    # tip down at height 0 needs the elbow bend 2 acos(x / 0.2) <= 100°
    x_min = 0.2 * np.cos(np.deg2rad(50.0))
    assert f["x_min_analytic_m"] == pytest.approx(x_min)
    assert min(f["reached_x_m"]) >= x_min - 2e-3 and max(f["failed_x_m"]) <= x_min + 2e-3
    assert np.allclose(f["failing_case_angles_deg"], 30.0)


def test_registry_errors_and_waiting_scenarios(monkeypatch):
    with pytest.raises(UnknownName, match="fullbody_reach"):
        run_scenario("nope")
    with pytest.raises(InvalidInput, match="takes no model"):
        run_scenario("kettle", model="dm_humanoid")
    waiting = Scenario(
        "waits",
        "needs a module",
        fn=lambda out, **k: ScenarioResult("waits"),
        requires=("pik_mj.not_written_yet",),
    )
    monkeypatch.setitem(REGISTRY, "waits", waiting)
    assert waiting.missing() == ["pik_mj.not_written_yet"]
    with pytest.raises(PikError, match="waiting"):
        run_scenario("waits")
    assert REGISTRY["wall_contact"].missing() == []  # pik_mj.tasks.scfr exists


def test_failed_check_fails_the_scenario():
    r = ScenarioResult("x")
    assert r.check("fine", True) and r.passed
    assert not r.check("broken", False, "detail")
    assert not r.passed and r.messages[-1] == "[FAILED] broken: detail"
    assert r.to_dict()["passed"] is False


def test_kettle_is_held_in_the_hand_during_the_hold(tmp_path):
    result = run_scenario("kettle", hold=1.5)
    assert result.passed, result.summary()
    hold = result.balance["hold"]
    assert hold["drift"] < 0.01 and hold["slip"] < 0.002 and hold["unexpected_contacts"] == []
    lift = result.figures["kettle_lift_m"]
    assert abs(lift[2] - 0.1) < 2e-3 and np.linalg.norm(lift[:2]) < 2e-3
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
    [(frame, body, p_FO, R_FO)] = pose["grasps"]
    assert (frame, body) == ("rarm_end", "kettle") and np.linalg.norm(p_FO) < 0.2
    np.testing.assert_allclose(np.array(R_FO) @ np.array(R_FO).T, np.eye(3), atol=1e-9)
    report = validate_pose(
        pose["model"],
        pose["q"],
        pose["environment"],
        1.0,
        robot_pos=pose["robot_pos"],
        allowed=pose["allowed_contacts"],
        grasps=pose["grasps"],
    )
    assert report["passed"], report
    # the static check's system holds the kettle's 1 kg, and the hold carries it
    forces = np.array(report["static"]["forces"])
    assert forces[:, 2].sum() == pytest.approx((result.robot.mass + m_kettle) * 9.81, rel=1e-6)
    assert report["hold"]["unexpected_contacts"] == []
