"""A new robot's scenario, written without touching pik_mj: a small legged robot
defined here as an MJCF string, used through the top-level names of ``pik_mj``
only — robot, scene, a reach with the feet fixed, the static check, the physics
hold, and a recording read back."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pik_mj

WALKER = """
<mujoco model="little_walker">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.002"/>
  <default>
    <joint type="hinge" damping="0.5" armature="0.05" limited="true"/>
    <geom contype="1" conaffinity="1" rgba="0.7 0.7 0.8 1"/>
  </default>
  <worldbody>
    <body name="torso" pos="0 0 1.0">
      <freejoint name="root"/>
      <geom name="torso" type="box" size="0.08 0.12 0.15" pos="0 0 0.1" mass="8"/>
      <body name="rleg_thigh" pos="0 -0.07 -0.05">
        <joint name="rleg_hip_r" axis="1 0 0" range="-0.5 0.5"/>
        <joint name="rleg_hip_p" axis="0 1 0" range="-1.5 1.0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.03" mass="1.5"/>
        <body name="rleg_shank" pos="0 0 -0.25">
          <joint name="rleg_knee_p" axis="0 1 0" range="0 2.2"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.025" mass="1"/>
          <body name="rleg_foot" pos="0 0 -0.25">
            <joint name="rleg_ankle_p" axis="0 1 0" range="-1 1"/>
            <joint name="rleg_ankle_r" axis="1 0 0" range="-0.5 0.5"/>
            <geom name="rleg_sole" type="box" size="0.08 0.045 0.02" pos="0.02 0 -0.02"
                  mass="0.5"/>
            <site name="rleg_end" pos="0.02 0 -0.04"/>
          </body>
        </body>
      </body>
      <body name="lleg_thigh" pos="0 0.07 -0.05">
        <joint name="lleg_hip_r" axis="1 0 0" range="-0.5 0.5"/>
        <joint name="lleg_hip_p" axis="0 1 0" range="-1.5 1.0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.03" mass="1.5"/>
        <body name="lleg_shank" pos="0 0 -0.25">
          <joint name="lleg_knee_p" axis="0 1 0" range="0 2.2"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.025" mass="1"/>
          <body name="lleg_foot" pos="0 0 -0.25">
            <joint name="lleg_ankle_p" axis="0 1 0" range="-1 1"/>
            <joint name="lleg_ankle_r" axis="1 0 0" range="-0.5 0.5"/>
            <geom name="lleg_sole" type="box" size="0.08 0.045 0.02" pos="0.02 0 -0.02"
                  mass="0.5"/>
            <site name="lleg_end" pos="0.02 0 -0.04"/>
          </body>
        </body>
      </body>
      <body name="rarm_upper" pos="0 -0.16 0.2">
        <joint name="rarm_shoulder_p" axis="0 1 0" range="-2.5 1.0"/>
        <joint name="rarm_shoulder_r" axis="1 0 0" range="-1.5 0.3"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" mass="0.6"/>
        <body name="rarm_lower" pos="0 0 -0.2">
          <joint name="rarm_elbow_p" axis="0 1 0" range="-2.2 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" mass="0.4"/>
          <site name="rarm_end" pos="0 0 -0.22"/>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <!-- knees bent, soles flat (hip + knee + ankle = 0); its height is left to
         pik_mj, which stands the robot on the floor -->
    <key name="reset_pose" qpos="0 0 0.9 1 0 0 0  0 -0.3 0.6 -0.3 0  0 -0.3 0.6 -0.3 0  0 0 -0.4"/>
  </keyframe>
</mujoco>
"""


def test_a_new_robot_reaches_stands_holds_and_is_recorded(tmp_path):
    path = tmp_path / "little_walker.xml"
    path.write_text(WALKER)
    robot = pik_mj.Robot.from_model(path)
    assert robot.root_body == "torso" and robot.has_floating_base
    assert set(robot.limbs) == {"rarm", "rleg", "lleg"}  # found from the kinematic tree
    # its start pose stands on the floor: the soles' bottom faces at z = 0
    for sole in ("rleg_sole", "lleg_sole"):
        g = robot.model.geom(sole)
        corners = robot.data.geom(sole).xpos[2] - g.size[2]
        assert corners == pytest.approx(0.0, abs=1e-9)
    # what rebuilds it is JSON
    again = pik_mj.Robot.from_source(json.loads(json.dumps(robot.source.to_dict())))
    np.testing.assert_array_equal(again.configuration.q, robot.configuration.q)

    scene = pik_mj.Scene.from_robot(robot)
    assert scene.allowed_contacts == ["rleg_sole", "lleg_sole"]
    feet0 = [robot.frame_pose(s).translation() for s in ("rleg_end", "lleg_end")]
    target = robot.frame_pose("rarm_end").translation() + np.array([0.15, -0.05, -0.1])

    recorder = pik_mj.Recorder.to_file(tmp_path / "walker.rrd", application_id="walker")
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    checks = scene.static_checker()
    log = recorder.solve_logger("reach", checks=checks)
    progress = pik_mj.Progress("reach", total=100, stream=None)
    result = pik_mj.fullbody_inverse_kinematics(
        robot,
        [(target, np.array([1.0, 0.0, 0.0, 0.0]))],
        limbs=["rarm"],
        rotation_axis=[None],
        stop=100,
        callback=[checks, log, progress],
    )
    log.finish(result)
    assert result.converged, result.summary()
    assert progress.iterations == result.iterations == len(checks.reports)
    hand = robot.frame_pose("rarm_end").translation()
    assert np.linalg.norm(hand - target) <= 1e-3
    for p0, s in zip(feet0, ("rleg_end", "lleg_end"), strict=True):
        assert np.linalg.norm(robot.frame_pose(s).translation() - p0) <= 1e-4
    # the centroid stays over the middle of the feet (level 1, xy)
    mid = 0.5 * (feet0[0] + feet0[1])
    assert np.linalg.norm(robot.com()[:2] - mid[:2]) <= 1e-3

    q = robot.configuration.q.copy()
    static = scene.static_check(q)
    assert static.feasible and static.touching_geoms == ["lleg_sole", "rleg_sole"]
    assert static.margin > 0.05  # the CoM well inside the soles' polygon
    np.testing.assert_allclose(static.com, robot.com(), atol=1e-12)  # one world
    hold = scene.hold(q, 1.0, criteria=pik_mj.HoldCriteria(), callback=recorder.hold_logger())
    assert hold.passed, hold.failures
    assert hold.drift < 2e-3 and hold.slip < 1e-3 and not hold.fell
    recorder.close()

    rec = pik_mj.read_recording(tmp_path / "walker.rrd")
    assert "torso" in rec["world/robot/bodies"].static["Ellipsoids3D:labels"]
    times, values = rec["errors/level_2/reach/target_rarm_end"].series(
        "Scalars:scalars", "iteration"
    )
    assert times.tolist() == list(range(1, result.iterations + 1))
    final = next(t for t in result.tasks if t.name == "target:rarm_end")
    assert values[-1][0] == pytest.approx(final.error, rel=1e-9)
    _, feasible = rec["balance/feasible"].series("Scalars:scalars", "iteration")
    assert [bool(f[0]) for f in feasible] == [r.feasible for r in checks.reports]
    times, drift = rec["hold/drift"].series("Scalars:scalars", "sim_time")
    assert times[-1] == pytest.approx(hold.simulated)
    assert max(d[0] for d in drift) == pytest.approx(hold.drift, rel=1e-6)
