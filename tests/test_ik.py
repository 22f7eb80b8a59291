"""irteus-style IK API (pik_mj.ik) on the 3-DoF arm and the humanoids."""

from __future__ import annotations

import mink
import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie

from pik_mj.balance import support_polygon
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.ik import (
    fullbody_inverse_kinematics,
    gaze_angle,
    inverse_kinematics,
    static_balance_point,
)
from pik_mj.robot import Robot
from pik_mj.robot.ground import sole_polygons
from pik_mj.tasks.collision import CollisionAvoidanceTask, collision_pairs

TIP_DOWN = np.array([0.0, 0.0, 1.0, 0.0])  # rotation by pi about y (w, x, y, z)
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


@pytest.fixture
def arm() -> Robot:
    robot = Robot.from_model("three_dof_arm")
    robot.set_angle_vector(np.deg2rad([30.0, 30.0, 30.0]))
    return robot


def _fk(robot: Robot, angles_deg) -> mink.SE3:
    q = robot.angle_vector()
    robot.set_angle_vector(np.deg2rad(angles_deg))
    X = robot.frame_pose("end")
    robot.set_angle_vector(q)
    return X


def _planar_fk(angles: np.ndarray) -> np.ndarray:
    """Tip of the 3-DoF arm by hand: links 0.1, 0.1, 0.02 from (0, 0, 0.02), y axes."""
    p, a = np.array([0.0, 0.02]), 0.0
    for theta, length in zip(angles, (0.1, 0.1, 0.02), strict=True):
        a += theta
        p = p + length * np.array([np.sin(a), np.cos(a)])
    return p


def test_three_dof_reach_matches_forward_kinematics(arm):
    target = _fk(arm, [20.0, 50.0, 40.0])
    res = inverse_kinematics(arm, target)
    assert res.converged and not res.reverted
    X = arm.frame_pose("end")
    assert np.linalg.norm(X.translation() - target.translation()) <= 1e-3
    assert np.linalg.norm((X.rotation().inverse() @ target.rotation()).log()) <= np.deg2rad(1)
    # Independent planar forward kinematics of the solution.
    tip = _planar_fk(arm.angle_vector())
    assert np.allclose(tip, target.translation()[[0, 2]], atol=1e-3)
    lo, hi = arm.joint_limits()
    assert np.all(arm.angle_vector() >= lo - 1e-9) and np.all(arm.angle_vector() <= hi + 1e-9)


def test_three_dof_failing_case_reverts_and_keeps_angles(arm):
    before = arm.angle_vector()
    res = inverse_kinematics(arm, ([0.039982, 0.0, 0.0], TIP_DOWN))  # seed printout
    assert not res.converged and res.reverted
    assert np.array_equal(arm.angle_vector(), before)
    assert res.tasks[1].error > 0.05  # far from the target: j2 would need 157°


def test_three_dof_no_revert_stretches_towards_target(arm):
    res = inverse_kinematics(
        arm, ([0.3, 0.0, 0.0], TIP_DOWN), rotation_axis=None, revert_if_fail=False, stop=80
    )
    assert not res.converged and not res.reverted
    gap = np.linalg.norm(arm.frame_pose("end").translation() - [0.3, 0.0, 0.0])
    closest = np.hypot(0.3, 0.02) - 0.22  # straight arm pointing at the target
    assert abs(gap - closest) < 1e-3


def test_translation_axis_frees_the_named_axis(arm):
    target = _fk(arm, [10.0, 40.0, 30.0]).translation() + np.array([0.0, 0.0, 0.05])
    res = inverse_kinematics(
        arm, (target, IDENTITY), rotation_axis=None, translation_axis="z", move_targets="end"
    )
    assert res.converged
    X = arm.frame_pose("end")
    e_local = X.rotation().as_matrix().T @ (X.translation() - target)
    assert np.linalg.norm(e_local[:2]) <= 1e-3  # x, y of the end frame matched
    assert abs(e_local[2]) > 1e-2  # z left free: not reached


def test_callable_target_is_evaluated_every_iteration(arm):
    calls = []
    target = _fk(arm, [-20.0, 60.0, 20.0])

    def fn():
        calls.append(1)
        return target

    res = inverse_kinematics(arm, fn)
    assert res.converged
    assert len(calls) >= res.iterations + 1


@pytest.mark.parametrize("model", ["sample_humanoid", "dm_humanoid"])
def test_fullbody_reach_feet_fixed_com_between_feet(model):
    robot = Robot.from_model(model)
    feet = [robot.limb(x) for x in ("rleg", "lleg")]
    X0 = [robot.frame_pose(f.end_frame, f.end_frame_type) for f in feet]
    mid = 0.5 * (X0[0].translation() + X0[1].translation())
    p_root0, quat0 = robot.root_pose()
    target = p_root0 + np.array([0.3, 0.1, -0.4])
    res = fullbody_inverse_kinematics(
        robot, [(target, IDENTITY)], limbs=["larm"], rotation_axis=None, stop=100
    )
    assert res.converged
    X1 = [robot.frame_pose(f.end_frame, f.end_frame_type) for f in feet]
    for a, b in zip(X0, X1, strict=True):
        assert np.linalg.norm(a.translation() - b.translation()) <= 1e-4
        assert np.linalg.norm((a.rotation().inverse() @ b.rotation()).log()) <= 1e-3
    com = robot.com()
    assert np.linalg.norm(com[:2] - mid[:2]) <= 1e-3
    # between the feet: on the segment joining them, inside the soles' hull
    from pik_mj.balance import support_polygon

    assert support_polygon(sole_polygons(robot)).signed_distance(com) > 0
    hand = robot.limb("larm")
    assert (
        np.linalg.norm(robot.frame_pose(hand.end_frame, hand.end_frame_type).translation() - target)
        <= 1e-3
    )
    p_root1, quat1 = robot.root_pose()
    turned = np.linalg.norm((mink.SO3(quat0).inverse() @ mink.SO3(quat1)).log())
    assert np.linalg.norm(p_root1 - p_root0) + turned > 0.01  # the floating base was used


def test_inverse_kinematics_freezes_floating_base_and_other_limbs():
    robot = Robot.from_model("sample_humanoid")
    p0, quat0 = robot.root_pose()
    legs0 = robot.angle_vector(robot.limb("rleg").joints)
    hand = robot.frame_pose("rarm_end").translation()
    res = inverse_kinematics(
        robot, (hand + np.array([0.15, 0.0, 0.15]), IDENTITY), limbs="rarm", rotation_axis=None
    )
    assert res.converged
    p1, quat1 = robot.root_pose()
    assert np.linalg.norm(p1 - p0) <= 1e-5 and np.linalg.norm(quat1 - quat0) <= 1e-5
    assert np.allclose(robot.angle_vector(robot.limb("rleg").joints), legs0, atol=1e-5)


def test_look_at_points_the_head_at_the_target():
    robot = Robot.from_model("sample_humanoid")
    point = robot.frame_pose("head_end").translation() + np.array([0.6, -0.3, -0.5])
    res = inverse_kinematics(robot, [], look_at=point)
    assert res.converged
    # independent: the site's x axis from MuJoCo's site_xmat against the direction
    d = point - robot.data.site("head_end").xpos
    a = robot.data.site("head_end").xmat.reshape(3, 3)[:, 0]
    angle = np.arccos(a @ d / np.linalg.norm(d))
    assert angle <= np.deg2rad(1.0)
    assert abs(angle - gaze_angle(robot, point)) < 1e-9


def test_static_balance_point_balances_moments():
    robot = Robot.from_model("sample_humanoid")
    rng = np.random.default_rng(3)
    forces = [
        ("rarm_end", rng.normal(0, 20, 3), rng.normal(0, 5, 3)),
        ("larm_end", rng.normal(0, 20, 3), rng.normal(0, 5, 3)),
    ]
    h = 0.0
    p = static_balance_point(robot, forces, h)
    assert p[2] == h
    g = robot.model.opt.gravity * robot.mass
    moment = np.cross(robot.com() - p, g)
    for name, f, n in forces:
        moment += np.cross(robot.data.site(name).xpos - p, f) + n
    # the ground reaction at p (a force only) balances the horizontal moments
    assert np.allclose(moment[:2], 0.0, atol=1e-9)


def test_fullbody_external_forces_move_the_com_by_the_static_formula():
    robot = Robot.from_model("sample_humanoid")
    f, n = np.array([-20.0, 0.0, 0.0]), np.array([10.0, 0.0, 0.0])
    forces = [("rarm_end", f, n), ("larm_end", f, n)]
    res = fullbody_inverse_kinematics(robot, [], external_forces=forces, stop=100)
    assert res.converged
    feet = [robot.data.site(s).xpos.copy() for s in ("rleg_end", "lleg_end")]
    mid = 0.5 * (feet[0] + feet[1])
    m_g = robot.mass * 9.81
    com = robot.com()
    hands = [robot.data.site(s).xpos for s in ("rarm_end", "larm_end")]
    # x: m g (c_x - mid_x) = -Σ (r_z - h) f_x ;  y: m g (c_y - mid_y) = Σ n_x
    dx = -sum((r[2] - mid[2]) * f[0] for r in hands) / m_g
    dy = sum(n[0] for _ in hands) / m_g
    assert com[0] - mid[0] == pytest.approx(dx, abs=1e-3)
    assert com[1] - mid[1] == pytest.approx(dy, abs=1e-3)
    assert dx > 0.03  # it leans against the pull


def test_support_polygon_balance_option_keeps_com_inside():
    robot = Robot.from_model("sample_humanoid")
    p_root, _ = robot.root_pose()
    res = fullbody_inverse_kinematics(
        robot,
        [(p_root + np.array([0.55, 0.2, -0.1]), IDENTITY)],
        limbs=["larm"],
        rotation_axis=None,
        balance="support_polygon",
        stop=100,
    )
    assert res.converged
    from pik_mj.balance import support_polygon

    assert support_polygon(sole_polygons(robot)).signed_distance(robot.com()) >= -1e-3


def _arm_torso_contacts(robot: Robot, arm: list[str], body: list[str]) -> set[tuple[str, str]]:
    """Arm-body geom pairs MuJoCo's collision detection reports (dist <= 0)."""
    m = robot.model
    d = mujoco.MjData(m)
    d.qpos[:] = robot.configuration.q
    mujoco.mj_forward(m, d)
    out = set()
    for c in d.contact[: d.ncon]:
        b1, b2 = (m.body(m.geom_bodyid[g]).name for g in (c.geom1, c.geom2))
        if c.dist <= 0 and {b1, b2} & set(arm) and {b1, b2} & set(body):
            out.add((m.geom(c.geom1).name, m.geom(c.geom2).name))
    return out


def test_fullbody_collision_avoidance_keeps_the_forearm_off_the_body():
    # Right hand to a point just ahead of the belly, slightly left: the plain
    # solution pushes the forearm 8 cm into the pelvis; with avoidance (level 1,
    # above the hand) the arm keeps the 1 cm orange zone and still reaches.
    robot = Robot.from_model("sample_humanoid")
    arm, body = ["rarm_upper", "rarm_lower", "rarm_hand"], ["pelvis", "torso_chest"]
    pairs = collision_pairs(robot.model, robot.data, arm + body)
    target = np.array([0.22, 0.01, 0.88])
    feet = [robot.frame_pose(s).translation() for s in ("rleg_end", "lleg_end")]
    clearance, contacts = {}, {}
    for avoid in (False, True):
        robot.reset_pose()
        task = CollisionAvoidanceTask(robot.configuration, pairs, yellow=0.1, orange=0.01)
        res = fullbody_inverse_kinematics(
            robot,
            [(target, IDENTITY)],
            limbs=["rarm"],
            rotation_axis=[None],
            collision_avoidance=task if avoid else (),
            stop=100,
        )
        assert res.converged, res.summary()
        hand = robot.frame_pose("rarm_end").translation()
        assert np.linalg.norm(hand - target) <= 1e-3
        for s, p in zip(("rleg_end", "lleg_end"), feet, strict=True):
            assert np.linalg.norm(robot.frame_pose(s).translation() - p) <= 1e-3
        clearance[avoid] = task.distances(robot.configuration).min()
        contacts[avoid] = _arm_torso_contacts(robot, arm, body)
        assert any(t.name == "collision" for t in res.tasks) == avoid
    assert clearance[False] < -0.05 and contacts[False]
    assert clearance[True] >= 0.01 - 1e-3 and not contacts[True]


def test_inverse_kinematics_collision_avoidance_sits_above_the_target():
    # The same reach with the arm alone (root and waist fixed): without
    # avoidance the forearm ends 8 cm inside the pelvis; with it (the level
    # above the hand's target) the arm keeps the 1 cm orange zone and still
    # reaches.
    robot = Robot.from_model("sample_humanoid")
    arm, body = ["rarm_upper", "rarm_lower", "rarm_hand"], ["pelvis", "torso_chest"]
    pairs = collision_pairs(robot.model, robot.data, arm + body)
    clearance, contacts = {}, {}
    target = np.array([0.22, 0.01, 0.88])
    for avoid in (False, True):
        robot.reset_pose()
        task = CollisionAvoidanceTask(robot.configuration, pairs, yellow=0.1, orange=0.01)
        res = inverse_kinematics(
            robot,
            (target, IDENTITY),
            limbs="rarm",
            rotation_axis=None,
            collision_avoidance=task if avoid else (),
            stop=100,
        )
        assert res.converged, res.summary()
        assert np.linalg.norm(robot.frame_pose("rarm_end").translation() - target) <= 1e-3
        clearance[avoid] = task.distances(robot.configuration).min()
        contacts[avoid] = _arm_torso_contacts(robot, arm, body)
        levels = {t.name: t.level for t in res.tasks}
        assert ("collision" in levels) == avoid
        if avoid:
            assert levels["collision"] < levels["target:rarm_end"]
    assert clearance[False] < -0.05 and contacts[False]
    assert clearance[True] >= 0.01 - 1e-3 and not contacts[True]


# ---------------------------------------------------------------- bad input
def test_unknown_limb_lists_valid_limbs():
    robot = Robot.from_model("sample_humanoid")
    with pytest.raises(UnknownName) as err:
        inverse_kinematics(robot, (np.zeros(3), IDENTITY), limbs="tail")
    assert "rarm" in str(err.value) and "tail" in str(err.value)


def test_unknown_frame_and_joint_names(arm):
    with pytest.raises(UnknownName, match="nope"):
        inverse_kinematics(arm, (np.zeros(3), IDENTITY), move_targets="nope")
    with pytest.raises(UnknownName, match="joint0"):
        inverse_kinematics(arm, (np.zeros(3), IDENTITY), joints=["joint9"])


@pytest.mark.parametrize(
    "target",
    [
        (np.zeros(2), IDENTITY),  # position of 2 numbers
        (np.zeros(3), np.zeros(4)),  # zero quaternion
        np.eye(3),  # not a pose
        "end",  # a string is not a target here
        (np.array([np.nan, 0, 0]), IDENTITY),
    ],
)
def test_bad_targets_raise_invalid_input(arm, target):
    before = arm.angle_vector()
    with pytest.raises(InvalidInput):
        inverse_kinematics(arm, target)
    assert np.array_equal(arm.angle_vector(), before)


def test_mismatched_lists_and_bad_callables():
    robot = Robot.from_model("sample_humanoid")
    q0 = robot.configuration.q.copy()
    p = robot.frame_pose("rarm_end").translation()
    with pytest.raises(InvalidInput, match="one per target"):
        inverse_kinematics(robot, [(p, IDENTITY)], limbs=["rarm", "larm"])
    with pytest.raises(InvalidInput, match="limbs"):
        inverse_kinematics(robot, (p, IDENTITY))  # several limbs: which one?
    with pytest.raises(InvalidInput, match="callable"):
        inverse_kinematics(robot, lambda: "garbage", limbs="rarm")
    assert np.array_equal(robot.configuration.q, q0)


def test_fullbody_needs_a_floating_base_and_model_paths_must_exist(arm, tmp_path):
    with pytest.raises(InvalidInput, match="floating base"):
        fullbody_inverse_kinematics(arm, [])
    with pytest.raises(InvalidInput, match="does not exist"):
        Robot.from_model(tmp_path / "missing.xml")
    robot = Robot.from_model("sample_humanoid")
    with pytest.raises(InvalidInput, match="not both"):
        fullbody_inverse_kinematics(
            robot,
            [],
            centroid_offset=lambda r: r.com(),
            external_forces=[("rarm_end", np.zeros(3), np.zeros(3))],
        )
    with pytest.raises(InvalidInput, match="balance"):
        fullbody_inverse_kinematics(robot, [], balance="zmp")
    with pytest.raises(InvalidInput, match="collision_avoidance"):
        fullbody_inverse_kinematics(robot, [], collision_avoidance="rarm_hand")


# ------------------------------------------------- progress from a hard start
def _feet_watch(robot: Robot):
    """A callback recording the largest move of either foot's end frame from its
    start [m] over the iterates, and the list it fills."""
    ends = [robot.limb(x) for x in ("rleg", "lleg")]
    starts = [robot.frame_pose(e.end_frame, e.end_frame_type).translation() for e in ends]
    moves: list[float] = []

    def watch(info) -> None:
        data = info.configuration.data
        for e, p0 in zip(ends, starts, strict=True):
            frame = data.site(e.end_frame) if e.end_frame_type == "site" else data.body(e.end_frame)
            moves.append(float(np.linalg.norm(frame.xpos - p0)))

    return watch, moves


FEET_TRADED = pytest.mark.xfail(
    strict=True,
    reason="the CoM starts 0.38 m behind H1's soles: the support-polygon rows, in level 1 "
    "with the feet, ask more than one step gives, and the level's least squares moves the "
    "feet up to 51 mm on the way back (converged, feet back at the end); the balance in a "
    "level of its own below the feet keeps them (branch r-robots-balance-level)",
)


@pytest.mark.parametrize("name", ["booster_t1", pytest.param("unitree_h1", marks=FEET_TRADED)])
def test_balance_starting_outside_the_support_polygon_is_brought_back_in(name):
    """Both hips bent 0.5 rad: the CoM starts behind the soles (outside the support
    polygon). The balance task brings it back inside, the feet kept within 1e-4 m on
    every iterate."""
    requires_menagerie(name)
    robot = Robot.from_model(name)
    hips = [j for j in robot.joint_names if "hip" in j.lower() and "pitch" in j.lower()]
    robot.set_angle_vector([-0.5] * len(hips), hips)
    region = support_polygon(sole_polygons(robot))
    assert region.signed_distance(robot.com()) < -0.01
    watch, moves = _feet_watch(robot)
    result = fullbody_inverse_kinematics(
        robot, [], balance="support_polygon", avoid_world=False, stop=50, callback=watch
    )
    assert result.converged, result.summary()
    assert region.signed_distance(robot.com()) >= -1e-3
    assert max(moves) <= 1e-4


@pytest.mark.parametrize("name", ["booster_t1", "unitree_h1"])
def test_a_target_out_of_reach_is_approached_from_the_first_step(name):
    """The right hand's target two arm lengths ahead of the shoulder: the solve does
    not converge, but every iterate moves (no step of length 0), the hand ends more
    than half its shoulder distance nearer the target, and the feet stay within
    1e-4 m."""
    requires_menagerie(name)
    robot = Robot.from_model(name)
    arm = robot.limb("rarm")
    shoulder = robot.frame_pose(arm.root_body, "body").translation()
    hand0 = robot.frame_pose(arm.end_frame, arm.end_frame_type).translation()
    reach = np.linalg.norm(hand0 - shoulder)
    target = shoulder + np.array([2.0 * reach, 0.0, 0.0])
    watch, moves = _feet_watch(robot)
    result = fullbody_inverse_kinematics(
        robot,
        [(target, IDENTITY)],
        limbs=["rarm"],
        rotation_axis=[None],
        stop=40,
        revert_if_fail=False,
        avoid_world=False,
        callback=watch,
    )
    hand = robot.frame_pose(arm.end_frame, arm.end_frame_type).translation()
    assert not result.converged and result.iterations == 40
    assert min(result.step_lengths) > 0
    start, end = np.linalg.norm(target - hand0), np.linalg.norm(target - hand)
    assert end < start - 0.5 * reach
    assert max(moves) <= 1e-4


FEET_TRADED_FOR_A_PULL = pytest.mark.xfail(
    strict=True,
    reason="the balance is in level 1 with the feet: a balance no step reaches is traded "
    "against the feet by the level's least squares (sample humanoid 0.17 mm, T1 35 mm); "
    "the balance in a level of its own below the feet keeps them (branch "
    "r-robots-balance-level)",
)


@pytest.mark.parametrize(
    "name",
    [
        pytest.param("sample_humanoid", marks=FEET_TRADED_FOR_A_PULL),
        pytest.param("booster_t1", marks=FEET_TRADED_FOR_A_PULL),
    ],
)
def test_a_pull_no_lean_balances_is_given_up_with_the_feet_kept(name):
    """A forward pull of the robot's weight at the right hand: no lean
    within the root's bounds puts the static balance point over the feet. The
    balance is given up (not converged), not the feet: within 1e-4 m on every
    iterate."""
    if name != "sample_humanoid":
        requires_menagerie(name)
    robot = Robot.from_model(name)
    arm = robot.limb("rarm")
    hand = robot.frame_pose(arm.end_frame, arm.end_frame_type).translation()
    pull = [1.0 * robot.mass * 9.81, 0.0, 0.0]
    watch, moves = _feet_watch(robot)
    result = fullbody_inverse_kinematics(
        robot,
        [(hand, IDENTITY)],
        limbs=["rarm"],
        rotation_axis=[None],
        external_forces=[(arm.end_frame, pull, [0.0, 0.0, 0.0])],
        avoid_world=False,
        stop=40,
        revert_if_fail=False,
        callback=watch,
    )
    assert not result.converged
    assert max(moves) <= 1e-4
