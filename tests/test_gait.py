"""Gait timing, ZMP reference, cycloid swing feet and footstep planning."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.walking import Footstep, GaitParameters, go_pos, plan_gait, straight_steps

FEET = {
    "rleg": (np.array([0.0, -0.1, 0.0]), 0.0),
    "lleg": (np.array([0.0, 0.1, 0.0]), 0.0),
}
HALF_X, HALF_Y = 0.11, 0.06  # sole rectangle half-sizes [m]
OFFSETS = {"rleg": np.array([0.01, 0.01, 0.0]), "lleg": np.array([0.01, -0.01, 0.0])}
SEP = 0.2


def _turning_plan(**kw):
    params = GaitParameters(zmp_offsets=OFFSETS, **kw)
    steps = go_pos(0.4, 0.1, np.deg2rad(40.0), FEET)
    return plan_gait(FEET, steps, params, com_height=0.8), steps


def _corners(p, yaw):
    R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    local = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [HALF_X, HALF_Y]
    return p[:2] + local @ R.T


def _inside(point, corners, tol=1e-12):
    hull = ConvexHull(corners)
    return np.all(hull.equations[:, :2] @ point + hull.equations[:, 2] <= tol)


def test_total_duration_and_sampling():
    for step_time, dt in [(1.0, 0.01), (0.8, 0.01), (1.0, 0.1)]:
        params = GaitParameters(step_time=step_time, dt=dt)
        steps = straight_steps(3, 0.1, FEET)
        plan = plan_gait(FEET, steps, params, com_height=0.8)
        S = len(steps)
        assert plan.duration == pytest.approx((S + 2) * step_time)
        assert len(plan.t) == round((S + 2) * step_time / dt) + 1
        assert plan.t[-1] == pytest.approx((S + 2) * step_time)
        np.testing.assert_allclose(np.diff(plan.t), dt)
        # Every footstep phase has (1 - r) T / dt - 1 strictly-single ticks.
        for j in range(1, S + 1):
            n_single = np.sum((plan.step_index == j) & (plan.support != "double"))
            assert n_single == round(0.8 * step_time / dt) - 1


def test_support_feet_are_stationary_and_labels_alternate():
    plan, steps = _turning_plan()
    for k in range(len(plan.t) - 1):
        label = plan.support[k]
        still = ["rleg", "lleg"] if label == "double" else [label]
        if label == "double" and plan.support[k + 1] != "double":
            continue  # lift-off happens after this sample: checked below
        for limb in still:
            np.testing.assert_allclose(plan.feet_p[limb][k + 1], plan.feet_p[limb][k], atol=1e-12)
            assert plan.feet_yaw[limb][k + 1] == pytest.approx(plan.feet_yaw[limb][k], abs=1e-12)
    # Single support alternates as the footsteps say (support = the other leg).
    for j, step in enumerate(steps, start=1):
        labels = set(plan.support[(plan.step_index == j) & (plan.support != "double")])
        assert labels == {"lleg" if step.limb == "rleg" else "rleg"}
    assert set(plan.support[plan.step_index == 0]) == {"double"}
    assert set(plan.support[plan.step_index == len(steps) + 1]) == {"double"}


def test_swing_cycloid_height_and_zero_end_velocities():
    dt = 0.001
    params = GaitParameters(step_time=1.0, dt=dt, step_height=0.05, double_support_ratio=0.2)
    steps = straight_steps(2, 0.15, FEET)
    plan = plan_gait(FEET, steps, params, com_height=0.8)
    peak_speed = []
    for j, step in enumerate(steps, start=1):
        rows = np.flatnonzero(plan.step_index == j)
        p = plan.feet_p[step.limb][rows]
        v = np.diff(p, axis=0) / dt
        speed = np.linalg.norm(v, axis=1)
        peak_speed.append(speed.max())
        # Maximum height = step_height (flat ground), reached at mid-swing, where
        # the horizontal position is the midpoint of source and destination.
        assert p[:, 2].max() == pytest.approx(0.05, abs=1e-12)
        mid = rows[np.argmax(p[:, 2])]
        assert plan.swing_phase[mid] == pytest.approx(0.5, abs=1e-9)
        src = plan.feet_p[step.limb][rows[0]]
        np.testing.assert_allclose(
            plan.feet_p[step.limb][mid][:2], (src[:2] + step.p_W[:2]) / 2, atol=1e-12
        )
        np.testing.assert_allclose(p[-1], step.p_W, atol=1e-12)
        # Velocity over the first and last tick of swing: ~0 relative to the peak
        # (cycloid: horizontal ~ sigma^3, vertical ~ sigma^2 near the ends).
        moving = np.flatnonzero(speed > 0)
        first, last = moving[0], moving[-1]
        assert speed[first] < 0.01 * speed.max()
        assert speed[last] < 0.01 * speed.max()
        # Closed form at a sample: s(phi) and h (1 - cos phi) / 2.
        k = rows[len(rows) // 3]
        phi = 2 * np.pi * plan.swing_phase[k]
        s = (phi - np.sin(phi)) / (2 * np.pi)
        expected = src + s * (step.p_W - src)
        expected[2] += 0.05 * (1 - np.cos(phi)) / 2
        np.testing.assert_allclose(plan.feet_p[step.limb][k], expected, atol=1e-12)
    assert min(peak_speed) > 0.3  # the feet do move (0.15-0.3 m in 0.8 s)


def test_zmp_reference_inside_support_polygon_and_on_support_point():
    plan, _ = _turning_plan()
    for k in range(len(plan.t)):
        label = plan.support[k]
        limbs = ["rleg", "lleg"] if label == "double" else [label]
        corners = np.vstack([_corners(plan.feet_p[lb][k], plan.feet_yaw[lb][k]) for lb in limbs])
        if label == "double":
            assert _inside(plan.zmp_ref[k], corners), k
        else:
            p, yaw = plan.feet_p[label][k], plan.feet_yaw[label][k]
            R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
            local = R.T @ (plan.zmp_ref[k] - p[:2])
            np.testing.assert_allclose(local, OFFSETS[label][:2], atol=1e-12)
            assert abs(local[0]) <= HALF_X and abs(local[1]) <= HALF_Y


def test_zmp_reference_start_end_and_double_support_interpolation():
    params = GaitParameters(step_time=1.0, dt=0.01, double_support_ratio=0.2)
    steps = straight_steps(2, 0.15, FEET)
    plan = plan_gait(FEET, steps, params, com_height=0.8)
    np.testing.assert_allclose(plan.zmp_ref[0], [0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(plan.zmp_ref[-1], plan.final_midpoint[:2], atol=1e-15)
    # Boundary of phase 1 -> 2 at t = 2 s: midpoint of the two support points;
    # the ramp is linear over [1.9, 2.1] s.
    k0, k1, k2 = (round(t / 0.01) for t in (1.9, 2.0, 2.1))
    z1 = plan.feet_p["rleg"][k0, :2]  # support of step 1 (lleg swings)
    z2 = steps[0].p_W[:2]  # support of step 2 (rleg swings)
    np.testing.assert_allclose(plan.zmp_ref[k0], z1, atol=1e-12)
    np.testing.assert_allclose(plan.zmp_ref[k1], (z1 + z2) / 2, atol=1e-12)
    np.testing.assert_allclose(plan.zmp_ref[k2], z2, atol=1e-12)
    second = np.diff(plan.zmp_ref[k0 : k2 + 1], 2, axis=0)
    np.testing.assert_allclose(second, 0.0, atol=1e-12)
    # Without double support at the ends: start on the first support foot,
    # end on the last one.
    params = GaitParameters(start_with_double_support=False, end_with_double_support=False)
    plan = plan_gait(FEET, steps, params, com_height=0.8)
    np.testing.assert_allclose(plan.zmp_ref[0], [0.0, -0.1], atol=1e-15)
    last_support = next(s for s in plan.final_feet.values() if s.limb != steps[-1].limb)
    np.testing.assert_allclose(plan.zmp_ref[-1], last_support.p_W[:2], atol=1e-15)


def test_go_pos_reaches_goal_within_reach_limits():
    limits = dict(max_stride_x=0.15, max_stride_y=0.08, max_turn=np.deg2rad(30.0))
    x, y, theta = 0.5, 0.15, np.deg2rad(45.0)
    steps = go_pos(x, y, theta, FEET, **limits)
    # Seed: first swing leg on the side of motion (left), then alternate.
    assert steps[0].limb == "lleg"
    assert all(a.limb != b.limb for a, b in itertools.pairwise(steps))
    _assert_goal_and_reach(steps, x, y, theta, **limits)


@pytest.mark.parametrize(
    "goal",
    [
        (0.0, 0.0, np.deg2rad(90.0)),
        (0.0, -0.3, 0.0),
        (-0.4, 0.0, 0.0),
        (1.0, -0.2, -0.5),
    ],
)
def test_go_pos_other_goals(goal):
    steps = go_pos(*goal, FEET)
    _assert_goal_and_reach(steps, *goal)
    if goal[1] < 0:
        assert steps[0].limb == "rleg"


MAX_TURN = float(np.deg2rad(30.0))


def _assert_goal_and_reach(
    steps, x, y, theta, max_stride_x=0.15, max_stride_y=0.08, max_turn=MAX_TURN
):
    final = {s.limb: s for s in steps}
    goal = np.array([x, y, 0.0])
    side = np.array([-np.sin(theta), np.cos(theta), 0.0]) * SEP / 2
    np.testing.assert_allclose(final["lleg"].p_W, goal + side, atol=1e-6)
    np.testing.assert_allclose(final["rleg"].p_W, goal - side, atol=1e-6)
    for limb in ("rleg", "lleg"):
        assert abs(np.angle(np.exp(1j * (final[limb].yaw - theta)))) < 1e-6
    # Reach, recomputed here: the swing foot in the frame of the standing foot.
    stance = {lb: Footstep(lb, p, yaw) for lb, (p, yaw) in FEET.items()}
    for step in steps:
        other = stance["lleg" if step.limb == "rleg" else "rleg"]
        c, s = np.cos(other.yaw), np.sin(other.yaw)
        d = step.p_W - other.p_W
        dx, dy = c * d[0] + s * d[1], -s * d[0] + c * d[1]
        outward = (dy if step.limb == "lleg" else -dy) - SEP
        dyaw = np.angle(np.exp(1j * (step.yaw - other.yaw)))
        assert abs(dx) <= max_stride_x + 1e-9
        assert -0.02 - 1e-9 <= outward <= max_stride_y + 1e-9
        assert abs(dyaw) <= max_turn + 1e-9
        stance[step.limb] = step


def test_straight_steps_reproduce_seed_example():
    steps = straight_steps(4, 0.1, FEET)
    expected = [
        ("lleg", 0.1),
        ("rleg", 0.2),
        ("lleg", 0.3),
        ("rleg", 0.4),
        ("lleg", 0.4),
    ]
    assert [(s.limb, round(s.p_W[0], 12)) for s in steps] == expected
    for s in steps:
        assert s.p_W[1] == pytest.approx(0.1 if s.limb == "lleg" else -0.1)
    assert straight_steps(0, 0.1, FEET) == []
    assert go_pos(0.0, 0.0, 0.0, FEET) == []


def test_bad_input_raises():
    with pytest.raises(UnknownName, match="rleg"):
        plan_gait(FEET, [Footstep("larm", np.zeros(3), 0.0)], com_height=0.8)
    with pytest.raises(UnknownName):
        plan_gait({**FEET, "head": (np.zeros(3), 0.0)}, [], com_height=0.8)
    with pytest.raises(InvalidInput, match="missing"):
        plan_gait({"rleg": FEET["rleg"]}, [], com_height=0.8)
    with pytest.raises(InvalidInput, match="p_W"):
        Footstep("rleg", np.array([0.0, np.nan, 0.0]), 0.0)
    with pytest.raises(InvalidInput, match="yaw"):
        Footstep("rleg", np.zeros(3), float("inf"))
    with pytest.raises(InvalidInput, match="step_time"):
        GaitParameters(step_time=-1.0)
    with pytest.raises(InvalidInput, match="dt"):
        GaitParameters(dt=0.0)
    with pytest.raises(InvalidInput, match="double_support_ratio"):
        GaitParameters(double_support_ratio=1.0)
    with pytest.raises(InvalidInput, match="double_support_ratio"):
        GaitParameters(double_support_ratio=-0.1)
    with pytest.raises(InvalidInput, match="step_height"):
        GaitParameters(step_height=float("nan"))
    with pytest.raises(UnknownName):
        GaitParameters(zmp_offsets={"rarm": (0, 0, 0)})
    with pytest.raises(InvalidInput, match="com_height"):
        plan_gait(FEET, [], com_height=0.0)
    with pytest.raises(InvalidInput, match="finite"):
        go_pos(np.nan, 0.0, 0.0, FEET)
    with pytest.raises(InvalidInput, match="theta"):
        go_pos(0.0, 0.0, 4.0, FEET)
    with pytest.raises(InvalidInput, match="max_stride_x"):
        go_pos(0.5, 0.0, 0.0, FEET, max_stride_x=-0.1)
    with pytest.raises(InvalidInput, match="steps"):
        go_pos(5.0, 0.0, 0.0, FEET, max_steps=3)
    with pytest.raises(InvalidInput, match="n_steps"):
        straight_steps(-1, 0.1, FEET)
