"""An honest fall test (issues 37, 39): a fall is the trunk tilting, the root
leaving its footprint or the root sinking, each reported with its figure and
time; thresholds from the robot's feet."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from test_any_robot import humanoid

from pik_mj import HoldCriteria, Robot, Scene
from pik_mj.sim.falls import FALLBACK_TILT, fall_limits, fall_measures, first_fall
from pik_mj.sim.tracking import FALL_CHECK_EVERY, RECORD_EVERY

HIPS = ("rleg_hip_p", "lleg_hip_p")


def _R(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return {
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def test_tilt_is_the_turn_of_the_up_axis_and_ignores_yaw():
    up = np.array([0.0, 0.0, 1.0])
    R_ref = _R("z", 0.7)  # the reference faces some way
    R = np.stack([_R("z", 1.9) @ R_ref, _R("y", 0.4) @ R_ref, _R("z", 0.3) @ _R("y", -0.6) @ R_ref])
    p = np.array([[0.0, 0.0, 1.0], [0.3, 0.4, 0.9], [0.0, 0.0, 0.5]])
    tilt, drift, height, ref_height = fall_measures(p, R, [0.0, 0.0, 1.0], R_ref, up)
    np.testing.assert_allclose(tilt, [0.0, 0.4, 0.6], atol=1e-12)
    np.testing.assert_allclose(drift, [0.0, 0.5, 0.0], atol=1e-12)  # horizontal only
    np.testing.assert_allclose(height, [1.0, 0.9, 0.5])
    np.testing.assert_allclose(ref_height, 1.0)
    limits = fall_limits(None, None, 0.8, foot=0.2, com_height=0.6, root_height=1.0)
    assert limits.tilt == pytest.approx(math.atan(0.2 / 0.6)) and limits.drift == 0.2
    times = np.array([0.1, 0.2, 0.3])
    fall = first_fall(times, tilt, drift, height, ref_height, limits)
    assert (fall.kind, fall.time, fall.value) == ("tilt", 0.2, pytest.approx(0.4))
    only_drift = fall_limits(1.0, 0.3, 0.8, foot=0.2, com_height=0.6, root_height=1.0)
    assert first_fall(times, tilt, drift, height, ref_height, only_drift).kind == "drift"
    sinking = fall_limits(1.0, 1.0, 0.8, foot=None, com_height=None, root_height=1.0)
    fall = first_fall(times, tilt, drift, height, ref_height, sinking)
    assert (fall.kind, fall.time, fall.limit) == ("height", 0.3, pytest.approx(0.8))
    armless = fall_limits(None, None, 0.8, foot=None, com_height=None, root_height=1.2)
    assert armless.tilt == FALLBACK_TILT and armless.drift == pytest.approx(0.3)


@pytest.fixture(scope="module")
def robot() -> Robot:
    return Robot.from_model(mujoco.MjSpec.from_string(humanoid()))


def _scene(robot: Robot, hip_kp: float) -> Scene:
    """The 16 kg humanoid with weak hip pitch servos: its torso (8 kg, CoM 15 cm
    above the hips) stands on them in unstable equilibrium below
    ``2 kp < m g l ≈ 11.8 N·m/rad``."""
    return Scene.from_robot(robot, kp=dict.fromkeys(HIPS, hip_kp), kv=dict.fromkeys(HIPS, 0.5))


def test_a_trunk_toppling_at_full_root_height_is_a_fall(robot):
    """The torso topples about the hips past 40° while the root stays above 90 %
    of its height: the old height-only test called that standing."""
    scene = _scene(robot, hip_kp=1.0)
    q = robot.configuration.q.copy()
    report = scene.hold(q, 3.0, criteria=HoldCriteria(stop_on_fall=False))
    h0, h1 = report.root_height
    assert report.tilt > math.radians(40) and h1 > 0.9 * h0  # tilted, root high
    assert report.fell and not report.passed
    fall = report.fall
    assert fall.kind == "tilt" and fall.value > fall.limit
    said = [f for f in report.failures if "trunk tilted" in f and f"{fall.time:.3f} s" in f]
    assert said and "°" in said[0]
    # the threshold: atan(foot length / CoM height above the feet), read independently
    d = scene.kinematics(q)
    feet = [scene.model.geom(g).id for g in scene.foot_geoms]
    com_h = float(scene.com(d)[2] - d.geom_xpos[feet, 2].mean())
    foot = math.hypot(2 * 0.08, 2 * 0.045)  # the sole box's horizontal diagonal
    assert report.thresholds["fall_tilt"] == pytest.approx(math.atan2(foot, com_h), rel=1e-6)
    at_40 = scene.hold(q, 3.0, criteria=HoldCriteria(fall_tilt=math.radians(40), fall_drift=1.0))
    assert at_40.fall.kind == "tilt" and at_40.fall.time > fall.time
    assert math.radians(40) < at_40.fall.value < math.radians(45)  # stopped at the fall
    # the run stops within the fall checks' stride of the fall
    stride = FALL_CHECK_EVERY * RECORD_EVERY * scene.model.opt.timestep
    assert at_40.fall.time <= at_40.simulated <= at_40.fall.time + stride + 1e-9


def test_a_standing_hold_is_no_fall(robot):
    report = _scene(robot, hip_kp=5.0).hold(robot.configuration.q.copy(), 3.0)
    assert report.passed and not report.fell and report.fall is None, report.failures
    assert report.tilt < math.radians(1)
    assert report.to_dict()["fall"] is None
