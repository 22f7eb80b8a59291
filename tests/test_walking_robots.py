"""Walking on the robots users bring: a gait derived from the robot, its soles from
MuJoCo's contacts, its own servos and torque limits, the body-inclination
stabilizer; a synthetic humanoid without sites on off-centre mesh soles walks,
and Unitree G1 and Booster T1 walk 6 steps forward and go to (0.5 m, 0.2 m, 30°)
where MENAGERIE_ROOT has them (H1: tests/test_walking_h1*.py).

Costs on a 2-core machine: the synthetic walk's pattern ~10 s and each playback
~5 s; each Menagerie walk ~15-25 s.
"""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie
from mesh_sole_humanoid import ANKLE_HEIGHT, SHANK, STAND, THIGH, mesh_sole_humanoid

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.ground import robot_soles
from pik_mj.sim import Scene
from pik_mj.walking.drive import CARRY_RATIO, LIMIT_ANGLE, joint_drive, torque_limits
from pik_mj.walking.footsteps import straight_steps
from pik_mj.walking.gait import Footstep, GaitParameters, plan_gait
from pik_mj.walking.playback import WALK_CONTACT, play_walk_pattern
from pik_mj.walking.robot_gait import (
    FOOT_CLEARANCE,
    HIP_RATIO,
    STEP_TIME_RATIO,
    gait_value,
    robot_gait,
    single_support_limit,
)
from pik_mj.walking.walk import walk
from pik_mj.walking.wholebody import calc_walk_pattern, corrected_plan, feet_from_robot

STRIDES = 3  # strides of the test walks (the benchmark walks 6)


def _synthetic() -> Robot:
    return Robot.from_model(mujoco.MjSpec.from_string(mesh_sole_humanoid()))


@pytest.fixture(scope="module")
def synthetic_walk():
    robot = _synthetic()
    soles = robot_soles(robot)
    gait = robot_gait(robot, soles)
    steps = gait.straight_steps(STRIDES, feet_from_robot(robot, soles))
    return robot, walk(robot, steps, gait, soles=soles)


# ------------------------------------------------------------------------- gait
def test_gait_from_the_synthetic_humanoids_legs_soles_and_mass():
    """Leg length, hip height and hip width as the MJCF builds them; the CoM height,
    step time and feet separation by the module's formulas from them."""
    robot = _synthetic()
    soles = robot_soles(robot)
    gait = robot_gait(robot, soles)
    geo = gait.geometry
    ankle_to_sole = float(np.linalg.norm(soles["rleg"].p_BS))  # the sole is off the ankle
    assert ankle_to_sole > ANKLE_HEIGHT + 0.01
    assert geo.leg_length == pytest.approx(THIGH + SHANK + ankle_to_sole, abs=1e-6)
    bend = -STAND["hip_p"]  # the thigh leans forward by this, the shank back by as much
    assert geo.hip_height == pytest.approx((THIGH + SHANK) * math.cos(bend) + ANKLE_HEIGHT, 1e-6)
    assert geo.hip_width == pytest.approx(0.16, abs=1e-9)
    lowered = geo.hip_height - min(geo.hip_height, HIP_RATIO * geo.leg_length)
    assert gait.com_height == pytest.approx(geo.com_height - lowered, abs=1e-12)
    tc = math.sqrt(gait.com_height / np.linalg.norm(robot.model.opt.gravity))
    assert gait.step_time == pytest.approx(gait.dt * round(STEP_TIME_RATIO * tc / gait.dt))
    assert gait.double_support_time == pytest.approx(tc)
    width = soles["rleg"].size[1]
    expected = min(geo.foot_separation, max(0.16, width + FOOT_CLEARANCE))
    assert gait.foot_separation == pytest.approx(expected)
    table = gait.table()
    assert all(name in table for name in gait.to_dict())


def test_gait_values_given_instead_of_derived():
    robot = _synthetic()
    gait = robot_gait(robot, stride=0.05, step_time=1.0)
    assert gait.stride == 0.05 and gait.step_time == 1.0
    assert gait.given == ("stride", "step_time")
    lines = {line.split()[0]: line for line in gait.table().splitlines()}
    assert lines["stride"].endswith("given") and not lines["step_height"].endswith("given")
    assert gait_value("stride=0.1") == ("stride", 0.1)
    with pytest.raises(InvalidInput, match="NAME one of"):
        gait_value("stride")
    with pytest.raises(InvalidInput, match="not a number"):
        gait_value("stride=far")
    with pytest.raises(UnknownName, match="stride"):
        robot_gait(robot, strides=0.1)
    with pytest.raises(InvalidInput, match="step_height must be a finite number > 0"):
        robot_gait(robot, step_height=-0.01)
    with pytest.raises(InvalidInput, match="shorter than the step_time"):
        robot_gait(robot, double_support_time=2.0, step_time=1.0)


# ------------------------------------------------------------------------ drive
def test_drive_within_the_robots_torque_limits():
    """The synthetic humanoid's motors: its torque limits are their ctrlrange; its
    servos (added by the scene) get derived gains, those of the leg joints that
    carry it at least κ m g z_c unless the limit caps them; the controls make MuJoCo's
    actuators exert exactly the torques asked (its own actuator force)."""
    robot = _synthetic()
    model = robot.model
    ids = [model.joint(j).id for j in robot.joint_names]
    limits = torque_limits(model, ids)
    for (lo, hi), j in zip(limits, robot.joint_names, strict=True):
        motor = model.actuator(j)
        assert (lo, hi) == pytest.approx(tuple(motor.ctrlrange))
    scene = Scene.from_robot(robot, contact=WALK_CONTACT)
    gait = robot_gait(robot)
    drive = joint_drive(scene, robot.start_q(), gait.com_height, ("rleg", "lleg"))
    assert drive.gains == "derived"
    tipping = scene.mass * 9.81 * gait.com_height
    assert drive.tipping_stiffness == pytest.approx(tipping, rel=1e-3)
    knee = drive.joints.index("right_knee")
    assert drive.kp[knee] == pytest.approx(
        min(max(scene.servo_gains["right_knee"][0], CARRY_RATIO * tipping), 80 / LIMIT_ANGLE)
    )
    scene.set_pose(robot.start_q())
    tau = np.random.default_rng(0).uniform(-5.0, 5.0, len(drive.joints))
    drive.apply(scene.data, tau)
    mujoco.mj_forward(scene.model, scene.data)
    np.testing.assert_allclose(scene.data.qfrc_actuator[drive.dofs], tau, atol=1e-9)
    with pytest.raises(InvalidInput, match="no position actuator"):
        joint_drive(scene, robot.start_q(), gait.com_height, ("rleg", "lleg"), gains="robot")


# ---------------------------------------------------------------------- walking
def test_a_humanoid_without_sites_on_off_centre_mesh_soles_walks(synthetic_walk):
    """Footsteps in the sole frames from MuJoCo's contacts, the soles and CoM tracked,
    self-collision kept, the ZMP of the inverse dynamics inside the soles' polygons;
    played with its motors within their limits, it walks without falling to where
    planned."""
    robot, done = synthetic_walk
    pattern, report = done.pattern, done.report
    assert robot.model.nsite == 0
    assert len(pattern.plan.footsteps) == STRIDES + 1
    assert pattern.ik_feet_error.max() < 1e-4 and pattern.ik_com_error[1:].max() < 1e-4
    assert pattern.self_collision_pairs > 0
    assert pattern.support_margin("computed").min() > 0.005
    assert not report.fell and report.fall is None, done.figures
    assert report.final_midfeet_error < 0.05 and report.final_root_error < 0.05
    assert report.params["torque_demand_max_ratio"] < 1.0
    assert report.params["torque_saturated_fraction"] == 0.0
    assert done.figures["sim_zmp_contacts_margin_min_m"] > -2e-3
    assert done.passed, done.checks
    final = feet_from_robot(robot, pattern.soles)
    for leg, foot in pattern.plan.final_feet.items():
        np.testing.assert_allclose(final[leg].p_W, foot.p_W, atol=1e-4)


def test_without_the_stabilizer_the_synthetic_humanoid_falls(synthetic_walk):
    """The body-inclination feedback is what keeps it up (the check can fail): the
    same pattern, same servos, without it, tips over (trunk tilt)."""
    robot, done = synthetic_walk
    report = play_walk_pattern(
        done.pattern, Scene.from_robot(robot, contact=WALK_CONTACT), stabilize=False
    )
    assert report.fell and report.fall is not None and report.fall.kind == "tilt"


MENAGERIE_WALKERS = {"unitree_g1": "robot", "booster_t1": "derived"}
GO_POS = (0.5, 0.2, math.radians(30.0))  # the goal: 0.5 m ahead, 0.2 m left, 30° left


@pytest.fixture(scope="module", params=list(MENAGERIE_WALKERS))
def menagerie_walker(request):
    name = request.param
    requires_menagerie(name)
    robot = Robot.from_model(name)
    soles = robot_soles(robot)
    return name, robot, soles, robot_gait(robot, soles)


def _walks_as_planned(done, name: str, steps: int) -> None:
    """The checks of a Menagerie walk (the issue's): its footsteps, no fall, the ZMP of
    the pattern's inverse dynamics inside the support polygon, the servos the
    robot's own where they can carry it and within its torque limits, the feet and
    the root ending within 5 cm of the plan."""
    report = done.report
    print(f"\n{name}: {done.figures['zmp_margin_computed_min_m'] * 1e3:.1f} mm, {report.to_dict()}")
    assert len(done.pattern.plan.footsteps) == steps
    assert report.params["gains"] == MENAGERIE_WALKERS[name]
    assert done.pattern.support_margin("computed").min() > 0.005
    assert not report.fell and report.fall is None, report.to_dict()
    assert report.final_midfeet_error < 0.05 and report.final_root_error < 0.05
    assert report.params["torque_saturated_fraction"] < 0.01
    assert done.passed, done.checks


def test_menagerie_robot_walks_six_steps_forward(menagerie_walker):
    """G1 on its own position servos (kp 500 > κ m g z_c), T1 on derived gains (its
    own kp 75 is below κ m g z_c = 332 N·m/rad): 6 strides and a closing step."""
    name, robot, soles, gait = menagerie_walker
    steps = gait.straight_steps(6, feet_from_robot(robot, soles))
    robot.reset_pose()
    _walks_as_planned(walk(robot, steps, gait, soles=soles), name, 7)


def test_menagerie_robot_goes_to_a_pose(menagerie_walker):
    """go-pos (0.5 m, 0.2 m, 30°): the feet end turned as planned too."""
    name, robot, soles, gait = menagerie_walker
    robot.reset_pose()
    start = feet_from_robot(robot, soles)
    steps = gait.go_pos(*GO_POS, start)
    done = walk(robot, steps, gait, soles=soles)
    _walks_as_planned(done, name, len(steps))
    assert len(steps) >= 6
    assert done.report.final_yaw_error < math.radians(5.0)
    final = feet_from_robot(robot, soles)  # the pattern's last configuration
    for leg, foot in final.items():
        assert foot.yaw - start[leg].yaw == pytest.approx(GO_POS[2], abs=2e-3)


def test_initial_stand_delays_the_plan_by_its_time():
    """``initial_stand_time`` T_0: the first T_0 stand on the initial feet with the ZMP
    reference at their middle, then the feet, ZMP reference and support labels are
    those of the plan without it, T_0 later; negative T_0 is refused."""
    feet = {"rleg": ((0.0, -0.1, 0.0), 0.0), "lleg": ((0.0, 0.1, 0.0), 0.0)}
    start = {lb: Footstep(lb, np.array(p), yaw) for lb, (p, yaw) in feet.items()}
    steps = straight_steps(2, 0.1, start, foot_separation=0.2)
    base = GaitParameters(step_time=0.5, dt=0.02)
    plain = plan_gait(feet, steps, base, com_height=0.8)
    late = plan_gait(feet, steps, replace(base, initial_stand_time=0.3), com_height=0.8)
    n = 15  # 0.3 s
    assert len(late.t) == len(plain.t) + n
    np.testing.assert_allclose(late.zmp_ref[:n], np.zeros((n, 2)), atol=1e-12)
    np.testing.assert_allclose(late.zmp_ref[n:], plain.zmp_ref, atol=1e-12)
    for lb in feet:
        np.testing.assert_allclose(late.feet_p[lb][n:], plain.feet_p[lb], atol=1e-12)
    assert list(late.support[n:]) == list(plain.support)
    assert set(late.support[:n]) == {"double"}
    with pytest.raises(InvalidInput, match="initial_stand_time"):
        replace(base, initial_stand_time=-0.1)


def test_single_support_limit_is_where_the_pendulum_takes_the_com_out_of_reach():
    """The closed form against the cart-table pendulum c'' = (c - p) / T_c^2
    integrated step by step (RK4) from c = r at rest, p = e: the time c reaches -r."""
    reach, edge, tc = 0.004, 0.173, 0.3
    c, v, t, h = reach, 0.0, 0.0, 1e-5

    def acc(x):
        return (x - edge) / tc**2

    while c > -reach:
        k1, l1 = v, acc(c)
        k2, l2 = v + 0.5 * h * l1, acc(c + 0.5 * h * k1)
        k3, l3 = v + 0.5 * h * l2, acc(c + 0.5 * h * k2)
        k4, l4 = v + h * l3, acc(c + h * k3)
        c, v, t = (
            c + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4),
            v + h / 6 * (l1 + 2 * l2 + 2 * l3 + l4),
            t + h,
        )
    assert single_support_limit(reach, edge, tc) == pytest.approx(t, abs=2e-5)
    assert 0.08 < t < 0.1


def test_corrected_plan_moves_the_cart_table_zmp_by_the_zmp_error():
    """Kajita's second stage: a motion whose ZMP missed the reference by a constant
    offset d (from 1 s on) gets a CoM whose cart-table ZMP is moved by −d once the
    preview has caught up, and the corrected plan still obeys the cart-table
    relation p = c − (z_c / g) c̈ (computed here by hand)."""
    robot = _synthetic()
    soles = robot_soles(robot)
    gait = robot_gait(robot, soles)
    plan = plan_gait(
        feet_from_robot(robot, soles),
        gait.straight_steps(2, feet_from_robot(robot, soles)),
        gait.parameters(),
        com_height=gait.com_height,
    )
    offset = np.array([0.01, -0.02])  # [m]
    missed = plan.zmp_ref + np.where(plan.t[:, None] >= 1.0, offset, 0.0)
    corrected = corrected_plan(plan, missed)
    moved = corrected.zmp - plan.zmp
    late = plan.t >= 1.0 + gait.step_time  # the preview tracks a step within a step
    np.testing.assert_allclose(moved[late], -offset[None].repeat(late.sum(), 0), atol=2e-3)
    np.testing.assert_allclose(moved[plan.t < 1.0 - gait.preview_time], 0.0, atol=1e-3)
    cart = corrected.com - gait.com_height / gait.geometry.gravity * corrected.com_acc
    np.testing.assert_allclose(corrected.zmp, cart, atol=1e-9)
    np.testing.assert_allclose(corrected.feet_p["rleg"], plan.feet_p["rleg"])


# ---------------------------------------------------------------- dm_humanoid
@pytest.fixture(scope="module")
def dm_walk():
    """dm_control's humanoid, 2 strides: its heavy limbs' momentum takes the ZMP of
    the tracked cart-table pattern ~18 mm out of its 6 cm wide capsule soles."""
    robot = Robot.from_model("dm_humanoid")
    soles = robot_soles(robot)
    gait = robot_gait(robot, soles)
    steps = gait.straight_steps(2, feet_from_robot(robot, soles))
    return robot, soles, gait, steps, walk(robot, steps, gait, soles=soles)


def test_two_stage_correction_repeats_until_the_zmp_is_inside(dm_walk):
    """The correction repeated on each pass's ZMP error brings the ZMP of the
    inverse dynamics inside the soles, where one pass leaves it outside (the check
    can fail)."""
    robot, soles, gait, steps, done = dm_walk
    assert done.pattern.zmp_corrections >= 2
    assert done.pattern.support_margin("computed").min() > 0.0
    robot.reset_pose()
    once = calc_walk_pattern(
        robot, steps, gait.parameters(), com_height=gait.com_height, soles=soles, max_corrections=1
    )
    assert once.zmp_corrections == 1
    assert once.support_margin("computed").min() < 0.0


def test_dm_humanoid_walks_and_its_force_sensors_read_the_contacts(dm_walk):
    """No fall, every check of the walk (among them the ZMP of the feet's force
    sensors within 2 mm RMS of the contact forces'); the first sample too, which the
    lead time makes one of a robot held by its servos: without it the servos are
    off at that instant and the sensors, which include the feet's inertia, read
    38 mm away from the contacts (the check can fail)."""
    robot, done = dm_walk[0], dm_walk[-1]
    assert done.passed, done.checks
    first = done.report.zmp_force_sensors[0] - done.report.zmp[0]
    assert np.linalg.norm(first) < 1e-3
    cold = play_walk_pattern(
        done.pattern, Scene.from_robot(robot, contact=WALK_CONTACT), lead_time=0.0, settle_time=0
    )
    assert np.linalg.norm(cold.zmp_force_sensors[0] - cold.zmp[0]) > 0.01
