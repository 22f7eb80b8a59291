"""The balance feedback of holds and motions (pik_mj.sim.balancing): a robot whose
ankle servos are softer than its weight's tipping stiffness ``m g h`` stands
with it and drifts away without it; a robot with stiff ankles plays without it.
The robot is the synthetic mesh-sole humanoid with position servos (its ankles'
``kp`` set per test) instead of its torque motors.
"""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest
from mesh_sole_humanoid import mesh_sole_humanoid

from pik_mj.robot import Robot
from pik_mj.sim import Scene
from pik_mj.sim.balancing import FEEDBACK_PERIOD, SERVOS_ALONE, balance_feedback, stance

WEAK_ANKLE = 40.0
"""[N·m/rad] per ankle joint: 2 × 40 = 80 < m g h ≈ 124 of the 22 kg humanoid."""
STIFF_ANKLE = 100.0
"""[N·m/rad]: 2 × 100 = 200 > m g h."""
OTHER = 800.0
"""[N·m/rad] The other joints' servos."""


def _servo_humanoid(k_ankle: float) -> Robot:
    """The mesh-sole humanoid with a ``<position>`` servo on every joint (``kp``
    ``k_ankle`` on the ankles, :data:`OTHER` elsewhere; ``kv = 0.05 kp``)."""

    def servo(m: re.Match) -> str:
        k = k_ankle if "ankle" in m.group(2) else OTHER
        return f'<position name="{m.group(1)}" joint="{m.group(2)}" kp="{k}" kv="{0.05 * k}"/>'

    xml = re.sub(
        r'<motor name="([^"]+)" joint="([^"]+)" ctrlrange="[^"]+"/>',
        servo,
        mesh_sole_humanoid("servo_humanoid"),
    )
    return Robot.from_model(mujoco.MjSpec.from_string(xml))


@pytest.fixture(scope="module")
def weak():
    robot = _servo_humanoid(WEAK_ANKLE)
    return robot, Scene.from_robot(robot)


def test_stance_figures_are_the_ankle_servos_and_m_g_h(weak):
    """k_ankle: both ankle pitch servos (axes across the feet); m g h from the
    robot's mass and its CoM above the ankle axes, computed here from MuJoCo's
    kinematics."""
    robot, scene = weak
    q = robot.configuration.q
    figures = stance(scene, q)
    assert figures.ankle_stiffness == pytest.approx(2 * WEAK_ANKLE, rel=1e-9)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[: len(q)] = q
    mujoco.mj_forward(m, d)
    root = m.body("pelvis").id
    ankles = [m.joint(f"{s}_ankle_pitch").id for s in ("right", "left")]
    h = d.subtree_com[root][2] - np.mean(d.xanchor[ankles][:, 2])
    mgh = m.body_subtreemass[root] * 9.81 * h
    assert figures.tipping_stiffness == pytest.approx(mgh, rel=1e-9)
    assert figures.needs_feedback
    feedback = balance_feedback(scene, q)
    names = sorted(m.actuator(a).name for a in feedback.actuators)
    assert names == sorted(f"{s}_ankle_{j}" for s in ("right", "left") for j in ("pitch", "roll"))
    np.testing.assert_allclose(feedback.scale, 1.0)  # <position>: the control is the target
    assert feedback.period * m.opt.timestep == pytest.approx(FEEDBACK_PERIOD)


def test_weak_ankles_stand_with_the_feedback_and_drift_away_without(weak):
    robot, scene = weak
    q = robot.configuration.q
    held = scene.hold(q, 3.0)
    alone = scene.hold(q, 3.0, balance=False)
    assert held.balance_feedback["on"] and not alone.balance_feedback["on"]
    assert held.passed, held.failures
    assert held.drift < 0.005 and held.tilt < 0.01
    assert not alone.passed
    assert alone.drift > 0.04 and alone.tilt > 0.1
    assert not any(SERVOS_ALONE in f for f in alone.failures)


def test_a_diagnosis_with_the_feedback_on_says_it_is_of_the_servos_alone(weak):
    """Without the feed-forward the servos sag and the hold drifts even with the
    feedback; the growing mode its report names is the servos' alone, and it says so."""
    robot, scene = weak
    sagged = scene.hold(robot.configuration.q, 3.0, feedforward=False)
    assert sagged.balance_feedback["on"] and not sagged.passed
    modes = [f for f in sagged.failures if "grows x2" in f]
    assert modes and all(f.endswith(SERVOS_ALONE) for f in modes)


def test_the_feedback_is_the_same_whatever_the_chunks(weak):
    """A hold with callbacks every 7 steps (chunks cut there) and ``hold_many``
    (a rollout of many) give the hold's figures: the feedback updates at every
    period, whatever the steps are stepped in."""
    robot, scene = weak
    q = robot.configuration.q
    plain = scene.hold(q, 1.0)
    calls = []
    chunked = scene.hold(q, 1.0, callback=calls.append, every=7)
    (many,) = scene.hold_many([q], 1.0)
    assert len(calls) == 1 + 500 // 7 + 1  # the start, every 7th step, the end
    for other in (chunked, many):
        assert other.drift == pytest.approx(plain.drift, abs=1e-9)
        assert other.tilt == pytest.approx(plain.tilt, abs=1e-9)
        np.testing.assert_allclose(other.final_displacement, plain.final_displacement, atol=1e-9)


def test_a_motion_of_weak_ankles_needs_the_feedback(weak):
    """Arms raised forward (the CoM moves forward), then held 3 s: played with
    the feedback it passes, without it the robot tips forward."""
    robot, scene = weak
    q0 = robot.configuration.q
    q1 = q0.copy()
    for side in ("right", "left"):
        q1[robot.model.joint(f"{side}_shoulder_pitch").qposadr[0]] = -1.2
    path = np.array([q0, q1])
    played = scene.play(path, speed=0.5, settle=3.0)
    alone = scene.play(path, speed=0.5, settle=3.0, balance=False)
    assert played.balance_feedback["on"]
    assert played.passed, played.failures
    assert played.drift < 0.005
    assert not alone.passed
    assert alone.drift > 0.05


def test_stiff_ankles_play_without_the_feedback():
    robot = _servo_humanoid(STIFF_ANKLE)
    scene = Scene.from_robot(robot)
    q = robot.configuration.q
    figures = stance(scene, q)
    assert figures.ankle_stiffness == pytest.approx(2 * STIFF_ANKLE, rel=1e-9)
    assert not figures.needs_feedback
    assert balance_feedback(scene, q) is None
    held = scene.hold(q, 1.0)
    assert held.passed and held.balance_feedback == {
        "on": False,
        "ankle_stiffness": pytest.approx(2 * STIFF_ANKLE),
        "tipping_stiffness": pytest.approx(figures.tipping_stiffness),
    }
