"""Motions within what the actuators deliver (issue 37): each servo joint's torque
bounds as MuJoCo clamps them, a pose a drive cannot hold is refused before any
stepping, a path too fast for its drives is slowed down, and a robot whose servos
cannot keep it standing (Booster T1) is told so, naming the joints."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie
from test_any_robot import humanoid

from pik_mj import Robot, Scene, Waypoints, fullbody_inverse_kinematics
from pik_mj.sim.drives import SERVO_GIVE, servo_bounds, torque_bounds
from pik_mj.sim.effort import DRIVE_RESERVE
from pik_mj.sim.motion import MotionReference, velocity_limits
from pik_mj.sim.path import Waypoint

SHOULDER = "rarm_shoulder_p"
ARM_OUT = -1.5  # [rad] the right arm forward, nearly horizontal

PENDULA = """
<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="a"><joint name="a" axis="0 1 0"/><geom size="0.05" mass="1"/></body>
    <body name="b" pos="1 0 0"><joint name="b" axis="0 1 0"/><geom size="0.05" mass="1"/></body>
    <body name="c" pos="2 0 0">
      <joint name="c" axis="0 1 0" actuatorfrcrange="-3 3"/><geom size="0.05" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <position joint="a" kp="40" kv="1" ctrlrange="-0.5 0.5"/>
    <position joint="b" kp="40" gear="2" forcerange="-5 5"/>
    <position joint="c" kp="40"/>
  </actuator>
</mujoco>"""


def test_torque_bounds_are_the_clamps_mujoco_applies():
    """Bounds from the control range (the gains decide the torque there), the
    force range times the gear, the joint's actuatorfrcrange: MuJoCo's own
    ``qfrc_actuator`` at the extreme controls is the reference."""
    m = mujoco.MjModel.from_xml_string(PENDULA)
    d = mujoco.MjData(m)
    q = np.array([0.2, -0.1, 0.3])
    lo, hi = torque_bounds(m, np.arange(3), q[None])
    for ctrl, bound in ((-1e6, lo[0]), (1e6, hi[0])):
        d.qpos[:] = q
        d.ctrl[:] = ctrl
        mujoco.mj_forward(m, d)
        np.testing.assert_allclose(d.qfrc_actuator, bound, rtol=1e-12)
    np.testing.assert_allclose(lo[0], [40 * (-0.5 - 0.2), -10.0, -3.0])
    np.testing.assert_allclose(hi[0], [40 * (0.5 - 0.2), 10.0, 3.0])


def test_a_servo_at_its_control_range_end_holds_by_giving_way():
    """Joint ``a`` at its control range's end (0.5): there its servo gives no torque
    towards the inside of the range, but with the joint :data:`SERVO_GIVE` further
    in it gives ``kp · SERVO_GIVE`` (MuJoCo's ``qfrc_actuator`` there is the
    reference); the force and joint ranges of ``b`` and ``c`` stay as they are."""
    m = mujoco.MjModel.from_xml_string(PENDULA)
    d = mujoco.MjData(m)
    q = np.array([0.5, -0.1, 0.3])
    lo, hi = torque_bounds(m, np.arange(3), q[None])
    assert hi[0, 0] == pytest.approx(0.0, abs=1e-12)
    lo_s, hi_s = servo_bounds(m, np.arange(3), q[None])
    for ctrl, sign, bound in ((1e6, -1.0, hi_s[0, 0]), (-1e6, 1.0, lo_s[0, 0])):
        d.qpos[:] = q + sign * SERVO_GIVE
        d.ctrl[:] = ctrl
        mujoco.mj_forward(m, d)
        assert d.qfrc_actuator[0] == pytest.approx(bound, rel=1e-12)
    assert hi_s[0, 0] == pytest.approx(40 * SERVO_GIVE)
    np.testing.assert_allclose([lo_s[0, 1:], hi_s[0, 1:]], [lo[0, 1:], hi[0, 1:]])


def _robot(extra_joint: str = "", actuators: str = "") -> Robot:
    xml = humanoid(extra=f"<actuator>{actuators}</actuator>" if actuators else "")
    old = f'<joint name="{SHOULDER}" axis="0 1 0" range="-2.5 2.5"/>'
    assert old in xml
    xml = xml.replace(old, old.replace("/>", f" {extra_joint}/>"))
    return Robot.from_model(mujoco.MjSpec.from_string(xml))


def test_a_motor_s_torque_range_bounds_the_servo_standing_in_for_it():
    """A ``<motor>`` (gear 10, ctrlrange ±0.3) on the elbow: the scene's servo there
    exerts at most ±3 N·m, whatever its error."""
    robot = _robot(actuators='<motor joint="rarm_elbow_p" gear="10" ctrlrange="-0.3 0.3"/>')
    scene = Scene.from_robot(robot)
    m, d = scene.model, scene.data
    scene.set_pose(robot.configuration.q)
    servo = scene.servo_actuators["rarm_elbow_p"]
    dof = m.joint("rarm_elbow_p").dofadr[0]
    for target, torque in ((5.0, 3.0), (-5.0, -3.0)):
        d.ctrl[servo] = target
        mujoco.mj_forward(m, d)
        assert d.qfrc_actuator[dof] == pytest.approx(torque)


def _arm_out(robot: Robot) -> np.ndarray:
    q = robot.configuration.q.copy()
    q[robot.model.joint(SHOULDER).qposadr[0]] = ARM_OUT
    return q


def test_a_pose_the_drive_cannot_hold_is_refused_before_stepping():
    """The arm held out needs the shoulder's gravity torque (MuJoCo's
    ``qfrc_bias`` there: the feet's contact forces do not reach the arm), beyond
    its 1.2 N·m: neither the hold nor the path to it is stepped, and both name
    the joint with its torque and bound."""
    robot = _robot('actuatorfrcrange="-1.2 1.2"')
    scene = Scene.from_robot(robot)
    q = _arm_out(robot)
    d = scene.kinematics(q)
    mujoco.mj_forward(scene.model, d)
    gravity = d.qfrc_bias[scene.model.joint(SHOULDER).dofadr[0]]
    assert abs(gravity) > 1.2
    hold = scene.hold(q, 1.0)
    assert not hold.passed and hold.steps == 0 and hold.simulated == 0.0
    (line,) = hold.failures
    assert "cannot hold" in line and repr(SHOULDER) in line
    assert f"{gravity:.1f} N·m" in line and f"{-1.2:.1f} N·m" in line
    path = Waypoints(robot.configuration.q.copy(), "raise")
    path.items.append(Waypoint(q, "raise", 1))
    motion = scene.play(path)
    assert not motion.passed and motion.steps == 0
    assert "cannot track" in motion.failures[0] and repr(SHOULDER) in motion.failures[0]


def _shoulder_torques(scene: Scene, ref: MotionReference, dt: float = 2e-3) -> np.ndarray:
    """The shoulder's inverse-dynamics torque along the reference, by finite
    differences of its poses (``mj_inverse``, constraints off: the contacts do not
    reach the arm's rows)."""
    m, rm = scene.model, scene.robot.model
    ts = np.arange(0.0, ref.duration, dt)
    qs = []
    for t in ts:
        ref.update(t)
        qs.append(ref.data.qpos[: rm.nq].copy())
    d = mujoco.MjData(m)
    dof = m.joint(SHOULDER).dofadr[0]
    flags = m.opt.disableflags
    m.opt.disableflags = flags | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    out = []
    for k in range(1, len(qs) - 1):
        v0, v1 = np.zeros(rm.nv), np.zeros(rm.nv)
        mujoco.mj_differentiatePos(rm, v0, dt, qs[k - 1], qs[k])
        mujoco.mj_differentiatePos(rm, v1, dt, qs[k], qs[k + 1])
        d.qpos[: rm.nq], d.qvel[: rm.nv], d.qacc[: rm.nv] = qs[k], 0.5 * (v0 + v1), (v1 - v0) / dt
        mujoco.mj_inverse(m, d)
        out.append(d.qfrc_inverse[dof])
    m.opt.disableflags = flags
    return np.array(out)


def test_a_path_too_fast_for_its_drive_is_slowed_down():
    """The arm raised at the full joint speed needs more than the shoulder's 3 N·m:
    the timing is stretched until the torque, by independent inverse dynamics of
    the reference, stays within the drive's reserve; played so, the servo tracks
    within 0.02 rad, where the fast path, without the plan, lags by 0.1 rad."""
    robot = _robot('actuatorfrcrange="-3 3"')
    scene = Scene.from_robot(robot)
    path = Waypoints(robot.configuration.q.copy(), "raise")
    path.items.append(Waypoint(_arm_out(robot), "raise", 1))
    lower, upper = velocity_limits(scene)
    fast = MotionReference(scene, path, lower, upper, speed=1.0, feedforward=False)
    planned = MotionReference(scene, path, lower, upper, speed=1.0)
    assert np.abs(_shoulder_torques(scene, fast)).max() > 3.0
    assert planned.duration > 1.5 * fast.duration and planned.torques.stretched
    assert np.abs(_shoulder_torques(scene, planned)).max() <= 1.03 * DRIVE_RESERVE * 3.0
    played = scene.play(path, speed=1.0)
    assert played.passed and played.tracking_error < 0.02, played.summary()
    assert played.duration == pytest.approx(planned.duration)
    lagging = scene.play(path, speed=1.0, feedforward=False)
    assert lagging.tracking_error > 0.1


def test_booster_t1_reach_says_which_servos_cannot_keep_it_standing():
    """T1's own position actuators (kp 75) leave its ankles less stiff than
    gravity's tipping stiffness: the reach, played, tips forward, and the report
    says so with the growth of the unstable mode and the joints it moves."""
    requires_menagerie("booster_t1")
    robot = Robot.from_model("booster_t1", required_limbs=["rleg", "lleg", "larm"])
    scene = Scene.from_robot(robot)
    legs = [robot.limb(x) for x in ("rleg", "lleg")]
    feet = [robot.frame_pose(leg.end_frame, leg.end_frame_type).translation() for leg in legs]
    hand = robot.limb("larm")
    p_hand = robot.frame_pose(hand.end_frame, hand.end_frame_type).translation()
    shoulder = robot.frame_pose(hand.root_body, "body").translation()
    target = p_hand + np.linalg.norm(p_hand - shoulder) * np.array([0.6, 0.2, 0.4])
    path = Waypoints(robot, "reach")
    fullbody_inverse_kinematics(
        robot,
        [(target, np.array([1.0, 0.0, 0.0, 0.0]))],
        limbs=["larm"],
        rotation_axis=[None],
        target_centroid_pos=0.5 * (feet[0] + feet[1]),
        centroid_axes="z",
        stop=100,
        callback=[path],
    )
    motion = scene.play(path)
    if motion.passed:  # it holds: the other outcome
        assert not motion.fell and motion.drift < 0.02
        return
    assert motion.fell or motion.drift >= 0.02
    said = [f for f in motion.failures if "servos cannot keep the robot still" in f]
    assert said, motion.failures
    assert "Ankle_Pitch" in said[0] and "kp 75" in said[0]
    doubling = float(said[0].split("every ")[1].split(" s")[0])
    assert 0.1 < doubling < motion.simulated
    assert math.isfinite(motion.tilt)
