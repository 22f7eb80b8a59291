"""Motion playback of a solve (pik_mj.sim.motion): timing, the verdict, the recording."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from pik_mj import InvalidInput, Recorder, Robot, Scene, Waypoints, fullbody_inverse_kinematics
from pik_mj.record import PATHS, read_recording
from pik_mj.sim.motion import MotionReference, velocity_limits

SCALAR = "Scalars:scalars"


@pytest.fixture(scope="module")
def reach():
    """The fullbody_reach scenario's solve: the left hand 0.4 m forward and 0.6 m
    down from the pelvis, feet fixed, CoM over the feet; its iterates."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    feet = [robot.frame_pose(f).translation() for f in ("rleg_end", "lleg_end")]
    target = robot.root_pose()[0] + np.array([0.4, 0.1, -0.6])
    path = Waypoints(robot, "reach")
    res = fullbody_inverse_kinematics(
        robot,
        [(target, np.array([1.0, 0.0, 0.0, 0.0]))],
        limbs=["larm"],
        rotation_axis=[None],
        target_centroid_pos=0.5 * (feet[0] + feet[1]),
        stop=100,
        callback=[path],
    )
    assert res.converged
    return robot, scene, path


def test_steps_are_timed_by_the_joint_velocity_limits():
    """Two steps of a shoulder and an elbow, the second segment its own solve:
    each segment lasts 15/8 of its nominal time Σ max_j |Δq_j| / (s v_j), starts
    and ends at rest, and the reference's joint rate, by finite differences,
    peaks at s v_max (the limit is reached, not passed)."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    adr = {j: robot.model.joint(j).qposadr[0] for j in ("rarm_shoulder_p", "rarm_elbow_p")}
    q1, q2 = q0.copy(), q0.copy()
    q1[adr["rarm_shoulder_p"]] -= 0.6
    q1[adr["rarm_elbow_p"]] -= 0.2
    q2[:] = q1
    q2[adr["rarm_elbow_p"]] -= 0.9
    path = Waypoints(q0, "first")
    path.items.append(path.items[0].__class__(q1, "first", 1))
    path.items.append(path.items[0].__class__(q2, "second", 1))
    speed, v = 0.5, 5.0  # the seed's rotational-joint limit [rad/s]
    lower, upper = velocity_limits(scene)
    assert upper[robot.model.joint("rarm_elbow_p").dofadr[0]] == v
    ref = MotionReference(scene, path, lower, upper, speed=speed, feedforward=False)
    d1, d2 = 15 / 8 * 0.6 / (speed * v), 15 / 8 * 0.9 / (speed * v)
    assert ref.duration == pytest.approx(d1 + d2, rel=1e-12)
    np.testing.assert_allclose(ref.times, [0.0, d1, d1 + d2], atol=1e-4)
    dt = 1e-4
    ts = np.arange(0.0, ref.duration + dt, dt)
    qs = []
    for t in ts:
        ref.update(t)
        qs.append(ref.data.qpos[[adr["rarm_shoulder_p"], adr["rarm_elbow_p"]]].copy())
    rate = np.abs(np.diff(np.array(qs), axis=0)) / dt
    assert rate.max() == pytest.approx(speed * v, rel=2e-3)
    # at rest at the start, between the segments and at the end
    k = round(d1 / dt)
    assert rate[0].max() < 1e-3 and rate[k - 1].max() < 2e-2 and rate[-1].max() < 1e-3
    np.testing.assert_allclose(qs[-1], q2[[adr["rarm_shoulder_p"], adr["rarm_elbow_p"]]])


def test_the_reach_played_at_the_default_speed_passes(reach):
    """The fullbody reach's iterates, played at 0.2 of the seed's limits: no fall,
    the feet still (slip < 2 mm), the root within 2 cm of its reference, the
    CoM margin of the actual contacts positive throughout, no unexpected contact;
    the waypoints on the physics clock in order."""
    _, scene, path = reach
    motion = scene.play(path)
    assert motion.passed, motion.summary()
    assert not motion.fell and motion.slip < 2e-3 and motion.drift < 0.02
    assert motion.min_margin > 0.05
    assert motion.unexpected_contacts == []
    assert np.all(np.diff(motion.waypoint_times) >= 0)
    assert motion.waypoint_times[-1] == pytest.approx(motion.duration)
    assert motion.tracking_error < 0.2  # [rad] (0.16 with the derived servo gains of main)
    assert set(motion.frame_errors) == {"larm_end", "rleg_end", "lleg_end"}


def test_a_too_fast_motion_is_caught(reach):
    """The same iterates at 40 rad/s (8 times the seed's joint limit, 12 times
    the default speed) timed by the velocity limits alone: the verdict fails on
    foot slip or a fall, and says so. With the torque and ZMP plan the same
    limits are slowed down to what the robot's balance allows, and it does not
    fall."""
    _, scene, path = reach
    motion = scene.play(path, speed=1.0, max_velocity=40.0, feedforward=False)
    assert motion.duration < 0.3
    assert not motion.passed
    assert motion.fell or motion.slip >= 2e-3, motion.summary()
    assert any(f.startswith(("foot slip", "fell")) for f in motion.failures), motion.failures
    planned = scene.play(path, speed=1.0, max_velocity=40.0)
    assert planned.duration > 1.0 and not planned.fell, planned.failures


def test_the_motion_is_recorded_on_sim_time(reach, tmp_path):
    """The motion logger's series read back: the tracking error every 10th
    sample, each waypoint's index at its time, the reference robot's poses."""
    robot, scene, path = reach
    rec = Recorder.to_file(tmp_path / "m.rrd", "test")
    rec.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    samples = []
    log = rec.motion_logger(every=10)
    motion = scene.play(
        path, speed=0.5, callback=[log, lambda s: samples.append((s.time, s.tracking_error))]
    )
    log.finish(motion)
    rec.close()
    data = read_recording(tmp_path / "m.rrd")
    t, err = data[PATHS.motion_metric("tracking_error")].series(SCALAR, "sim_time")
    kept = samples[::10] + ([samples[-1]] if (len(samples) - 1) % 10 else [])
    np.testing.assert_allclose(t, [s[0] for s in kept], atol=1e-9)
    np.testing.assert_allclose([e[0] for e in err], [s[1] for s in kept])
    t, index = data[PATHS.motion_metric("waypoint")].series(SCALAR, "sim_time")
    np.testing.assert_allclose(t, motion.waypoint_times, atol=1e-9)
    assert [i[0] for i in index] == list(range(len(path)))
    assert f"{PATHS.reference}/bodies" in data


def test_a_motion_in_parts_counts_its_waypoints_on(reach, tmp_path):
    """A motion played in two parts, the second from the first's state, one
    ``finish`` each: ``motion/waypoint`` runs 0..n-1 over both parts on one
    ``sim_time``, the second part's waypoints after the first's, and the text
    names each part's first segment with its index in the whole motion."""
    robot, scene, path = reach
    q = path.q
    half = len(q) // 2
    rec = Recorder.to_file(tmp_path / "parts.rrd", "test")
    rec.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    log = rec.motion_logger(every=50)
    first = scene.play(q[: half + 1], speed=0.5, callback=[log])
    log.finish(first)
    second = scene.play(q[half:], speed=0.5, start=first, callback=[log])
    log.finish(second)
    rec.close()
    n1, n2 = len(first.waypoint_times), len(second.waypoint_times)
    assert (n1, n2) == (half + 1, len(q) - half)
    data = read_recording(tmp_path / "parts.rrd")
    t, index = data[PATHS.motion_metric("waypoint")].series(SCALAR, "sim_time")
    assert [i[0] for i in index] == list(range(n1 + n2))
    assert np.all(np.diff(t) >= 0) and t[n1] >= t[n1 - 1]
    texts = [batch[0] for _, batch in data[PATHS.events].temporal["TextLog:text"]]
    starts = [line for line in texts if "starts segment" in line]
    assert starts[0].startswith("motion: waypoint 0 ")
    assert starts[-1].startswith(f"motion: waypoint {n1} ")


def test_bad_input(reach):
    _, scene, path = reach
    with pytest.raises(InvalidInput, match="speed"):
        scene.play(path, speed=0.0)
    with pytest.raises(InvalidInput, match="max_velocity"):
        scene.play(path, max_velocity=-1.0)
    with pytest.raises(InvalidInput, match="entries"):
        scene.play(np.zeros((3, 5)))
    with pytest.raises(InvalidInput, match="planned"):
        scene.play(path, planned=["rarm_hand"])
    assert mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_GEOM, "floor") >= 0
