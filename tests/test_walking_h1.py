"""Unitree H1 walks on rolling soles (:mod:`pik_mj.walking.rolling_gait`): its legs
have no ankle roll, so with both soles flat its CoM cannot sway; the soles' roll below
the CoM lets the pelvis roll. Its gait from that reach, the ZMP reference within the
ankle's torque, the refusal of a robot that cannot sway either way, and 6 strides
forward (7 steps) in physics; the go-pos is in ``test_walking_h1_go_pos.py`` (a file
of its own so that the two walks run on two workers).

Costs on a 2-core machine, unloaded: H1's gait ~3 s, its forward walk ~100 s (the
pattern's IK with three passes of the ZMP correction).
"""

from __future__ import annotations

import math
import re

import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie

from pik_mj.balance import convex_hull_2d, halfplanes_from_polygon
from pik_mj.exceptions import InvalidInput
from pik_mj.robot import Robot
from pik_mj.robot.ground import robot_soles
from pik_mj.walking.drive import torque_limits
from pik_mj.walking.robot_gait import (
    STEP_TIME_RATIO,
    SWAY_RATIO,
    robot_gait,
    sideways_reach,
)
from pik_mj.walking.rolling_gait import ANKLE_TORQUE_RATIO, ROLL_LIFT, ROLL_SWAY
from pik_mj.walking.walk import Walk, walk
from pik_mj.walking.wholebody import feet_from_robot

GO_POS = (0.5, 0.2, math.radians(30.0))  # the goal: 0.5 m ahead, 0.2 m left, 30° left


@pytest.fixture(scope="module")
def h1():
    requires_menagerie("unitree_h1")
    robot = Robot.from_model("unitree_h1")
    soles = robot_soles(robot)
    return robot, soles, robot_gait(robot, soles)


def test_unitree_h1_sways_only_with_rolling_soles(h1):
    """H1's legs have no ankle roll: with both soles flat its CoM moves sideways a few
    millimetres of the quarter of its feet's 0.41 m separation a step needs; with
    the soles' roll asked below the CoM it reaches it. Its gait is the rolling one,
    by the formulas of :mod:`pik_mj.walking.rolling_gait` from that reach."""
    robot, soles, gait = h1
    need = SWAY_RATIO * gait.foot_separation
    flat = sideways_reach(robot, soles, need)
    rolled = sideways_reach(robot, soles, need, rolling_soles=True)
    assert flat < 0.01 and rolled > 0.5 * need
    assert gait.rolling_soles and gait.to_dict()["rolling_soles"]
    tc = math.sqrt(gait.com_height / 9.81)
    edge = 0.5 * gait.foot_separation
    sway = edge * (1 - 1 / math.cosh(gait.step_time / (2 * tc)))  # the periodic sway
    shorter = edge * (1 - 1 / math.cosh((gait.step_time - gait.dt) / (2 * tc)))
    longer = edge * (1 - 1 / math.cosh((gait.step_time + gait.dt) / (2 * tc)))
    assert shorter < ROLL_SWAY * rolled < longer and sway < rolled
    flat_step = gait.dt * round(STEP_TIME_RATIO * tc / gait.dt)
    assert gait.initial_stand_time == pytest.approx(flat_step - gait.step_time)
    assert gait.parameters().rolling_soles and "rolling_soles" in gait.table()


def test_h1_zmp_reference_is_deepest_in_the_sole_within_the_ankle_torque(h1):
    """The linear program's point against a brute-force grid over the sole: no grid
    point whose ankle torque (the ankle's axis x lever, from MuJoCo's kinematics)
    stays within the bound is farther from the sole's edges."""
    robot, soles, gait = h1
    model, data = robot.model, mujoco.MjData(robot.model)
    data.qpos[:] = robot.start_q()
    mujoco.mj_forward(model, data)
    weight = model.body_subtreemass[robot.root_body_id] * 9.81
    sole = soles["rleg"]
    p_WS, R_WS = sole.pose(model, data)
    ankle = model.joint("right_ankle").id
    bound = ANKLE_TORQUE_RATIO * torque_limits(model, [ankle])[0, 1]
    hull = halfplanes_from_polygon(convex_hull_2d(sole.outline))

    def torque(c):
        lever = p_WS + R_WS @ np.array([c[0], c[1], 0.0]) - data.xanchor[ankle]
        return float(data.xaxis[ankle] @ np.cross(lever, [0.0, 0.0, weight]))

    def margin(c):
        return float(np.min(hull.A @ c + hull.b))

    best = max(
        (margin(c), tuple(c))
        for c in np.mgrid[-0.12:0.06:0.002, -0.03:0.03:0.002].reshape(2, -1).T
        if abs(torque(c)) <= bound
    )
    chosen = np.array(gait.zmp_offsets["rleg"][:2])
    assert abs(torque(chosen)) <= bound + 1e-6
    assert margin(chosen) >= best[0] - 1e-6
    assert margin(chosen) < best[0] + 2e-3  # the grid's spacing
    assert abs(torque(np.zeros(2))) > bound  # the sole frame's origin would ask more


def test_a_robot_that_cannot_sway_even_on_rolling_soles_is_refused_saying_why(h1):
    """Feet 2 m apart: a step would need the CoM 0.5 m to the side, which H1 reaches
    neither with flat nor with rolling soles."""
    robot = h1[0]
    with pytest.raises(InvalidInput) as refused:
        robot_gait(robot, foot_separation=2.0)
    found = re.search(
        r"cannot move its CoM sideways .*: (\d+) mm of the (\d+) mm .* with the soles rolling "
        r"about their long axis, (\d+) mm",
        str(refused.value),
    )
    assert found, str(refused.value)
    flat, need, rolled = (float(v) for v in found.groups())
    assert need == 500 and flat < 10 and 10 < rolled < 250


def walks_on_rolling_soles(done: Walk, soles, steps: int) -> None:
    """The checks of an H1 walk: ``steps`` footsteps; the ZMP of the pattern's
    inverse dynamics inside the soles at every tick, and the ZMP of MuJoCo's contact
    forces inside the soles where they are; no fall; feet and root within 5 cm of
    the plan. The soles roll by a fraction of a degree (their polygon's corners
    within ROLL_LIFT of one height), the pelvis by degrees."""
    report, pattern = done.report, done.pattern
    margin = done.figures["zmp_margin_computed_min_m"]
    print(f"\nH1: {margin * 1e3:.1f} mm, {report.to_dict()}")
    assert len(pattern.plan.footsteps) == steps
    assert pattern.support_margin("computed").min() > 0.0
    assert np.nanmin(report.zmp_margin) > 0.0
    assert not report.fell and report.fall is None, report.to_dict()
    assert report.final_midfeet_error < 0.05 and report.final_root_error < 0.05
    assert done.passed, done.checks
    lift, pelvis = 0.0, 0.0
    for leg, R in pattern.feet_R.items():
        corners = np.c_[soles[leg].outline, np.zeros(len(soles[leg].outline))]
        heights = np.einsum("kij,nj->kni", R, corners)[..., 2]
        lift = max(lift, float(np.max(np.ptp(heights, axis=1))))
    for q in pattern.q:
        w, x, y, z = q[3:7]
        pelvis = max(pelvis, abs(math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))))
    assert lift < ROLL_LIFT and pelvis > math.radians(3.0)


@pytest.mark.long
def test_unitree_h1_walks_six_strides_on_rolling_soles(h1):
    robot, soles, gait = h1
    robot.reset_pose()
    steps = gait.straight_steps(6, feet_from_robot(robot, soles))
    walks_on_rolling_soles(walk(robot, steps, gait, soles=soles), soles, 7)
