"""Collision avoidance rows: distances from MuJoCo, FD-checked rows, pair lists, a solve.

The scenario: the 3-DoF arm swings from q = (0.2, 0.1, 0.1) to a pose whose
straight path (what the solve takes without avoidance) passes through a box
added with MjSpec. With the avoidance task above the target the arm goes
around it and keeps the orange-zone distance; without it, it collides.
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np
import pytest

from pik_mj import FrameTask, solve
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.loading import load_spec
from pik_mj.tasks.collision import (
    RECALL,
    CollisionAvoidanceTask,
    collision_pairs,
    moving_pairs,
    pair_distance,
)
from pik_mj.tasks.task import TaskRows

YELLOW, ORANGE = 0.05, 0.01
Q_START = np.array([0.2, 0.1, 0.1])
Q_GOAL = np.array([1.2, 0.5, 0.3])


def _arm_with_obstacle(pos=(0.1, 0.0, 0.2)) -> mujoco.MjModel:
    spec = load_spec("three_dof_arm")
    spec.worldbody.add_geom(
        name="obstacle", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.05, 0.02], pos=list(pos)
    )
    return spec.compile()


def _solve_arm(with_avoidance: bool, above_target: bool = True):
    """Returns (result, minimum distance over the iterates, final distance, pairs)."""
    model = _arm_with_obstacle()
    conf = mink.Configuration(model)
    conf.update(Q_GOAL)
    target = conf.get_transform_frame_to_world("end", "site")
    conf.update(Q_START)
    ca = CollisionAvoidanceTask.from_links(
        conf, ["l2", "l3", "l4"], ["obstacle"], yellow=YELLOW, orange=ORANGE
    )
    hand = FrameTask(
        conf, "end", target, translation_axis="y", rotation_axis="zx", p_limit=0.02, r_limit=0.1
    )
    hard = [mink.ConfigurationLimit(model)]
    if not with_avoidance:
        levels = [hard, [hand]]
    elif above_target:
        levels = [hard, [ca], [hand]]
    else:
        levels = [hard, [hand], [ca]]
    seen = [ca.distances(conf).min()]
    res = solve(
        conf,
        levels,
        stop=200,
        revert_if_fail=False,
        callback=lambda info: seen.append(ca.distances(info.configuration).min()),
    )
    return res, min(seen), ca.distances(conf).min(), ca.pairs


def test_avoidance_above_target_keeps_orange_zone():
    res_free, dmin_free, _, pairs = _solve_arm(with_avoidance=False)
    res_ca, dmin_ca, d_final, _ = _solve_arm(with_avoidance=True)
    print(f"min distance without avoidance {dmin_free:.4f} m, with {dmin_ca:.4f} m")
    assert {(p.name1, p.name2) for p in pairs} == {
        ("l2_box", "l4_box"),  # self pair: not adjacent, apart at the reference pose
        ("l2_box", "obstacle"),
        ("l3_box", "obstacle"),
        ("l4_box", "obstacle"),
    }
    assert res_free.converged and dmin_free < 0.0  # the direct path goes through the box
    assert res_ca.converged  # the target itself is clear of the box: it is still reached
    assert dmin_ca >= ORANGE - 5e-4
    assert d_final > ORANGE


def test_avoidance_below_target_gives_way():
    """With 3 target rows on 3 joints nothing is left for avoidance at a lower level."""
    res, dmin, _, _ = _solve_arm(with_avoidance=True, above_target=False)
    assert res.converged
    assert dmin < 0.0


def _fd_check(conf: mink.Configuration, task: CollisionAvoidanceTask, rng) -> None:
    rows = task.compute_rows(conf)
    n = len(task.row_pairs)
    assert rows.C.shape[0] == n * (1 + 2 * RECALL)  # then the remembered points' rows
    rows = TaskRows.inequality(rows.C[:n], rows.d_lower[:n], np.inf, 1.0)
    d0 = task.distances(conf)[task.row_pairs]  # row r is pair row_pairs[r]
    q0 = conf.q.copy()
    eps = 1e-6
    active = np.isfinite(rows.d_lower) & np.any(rows.C != 0, axis=1)
    assert active.any()
    for _ in range(3):
        x = rng.normal(size=conf.model.nv)
        conf.integrate_inplace(eps * x, 1.0)
        fd = (task.distances(conf)[task.row_pairs] - d0) / eps
        conf.update(q0)
        np.testing.assert_allclose((rows.C @ x)[active], fd[active], rtol=1e-3, atol=1e-5)


def test_rows_match_finite_differences_separated_and_penetrating():
    rng = np.random.default_rng(0)
    model = _arm_with_obstacle()
    conf = mink.Configuration(model)
    task = CollisionAvoidanceTask(conf, [("l3_box", "obstacle")], yellow=0.2, orange=0.01)
    conf.update(np.array([0.15, 0.2, 0.1]))  # l3 near the box, apart
    assert 0.0 < task.distances(conf)[0] < 0.2
    _fd_check(conf, task, rng)
    conf.update(np.array([0.35, 0.2, 0.1]))  # l3 through the box
    assert task.distances(conf)[0] < 0.0
    _fd_check(conf, task, rng)
    # Inside the orange zone the row pushes out: lower bound > 0.
    assert task.compute_rows(conf).d_lower[0] > 0.0
    assert task.compute_error(conf)[0] > ORANGE
    assert not task.is_satisfied(conf)


def test_yellow_zone_rows():
    """A pair outside the yellow zone gives no row; once it has come inside, it
    keeps a row, inactive (0·x >= -d_y) whenever it is outside again."""
    model = _arm_with_obstacle(pos=(0.0, 0.5, 0.1))  # far from the arm
    conf = mink.Configuration(model)
    conf.update(Q_START)
    task = CollisionAvoidanceTask(conf, [("l3_box", "obstacle")], yellow=0.05)
    assert task.compute_rows(conf).C.shape == (0, 3)
    assert task.is_satisfied(conf)
    # Independent distance: box centre-to-centre minus half sizes along y.
    d = task.distances(conf)[0]
    gap = conf.data.geom_xpos[model.geom("obstacle").id][1] - 0.05 - 0.005
    assert d == pytest.approx(gap, abs=1e-3)
    assert task.distances(conf, distmax=0.05)[0] == 0.05  # capped
    # an obstacle 13 mm from l3: inside the yellow zone
    model2 = _arm_with_obstacle(pos=(0.075, 0.0, 0.15))
    conf2 = mink.Configuration(model2)
    conf2.update(Q_START)
    near = CollisionAvoidanceTask(conf2, [("l3_box", "obstacle")], yellow=0.05)
    rows = near.compute_rows(conf2)
    assert rows.C.shape == (1 + 2 * RECALL, 3) and np.any(rows.C[0] != 0)
    assert rows.d_lower[0] < 0.0
    assert np.all(rows.C[1:] == 0.0) and np.all(rows.d_lower[1:] == -0.05)  # nothing recalled yet
    conf2.update(np.array([-1.5, 0.0, 0.0]))  # the arm swung away from the obstacle
    assert near.distances(conf2, 0.05)[0] == 0.05
    rows = near.compute_rows(conf2)
    assert rows.C.shape == (1 + 2 * RECALL, 3) and np.all(rows.C == 0.0)
    assert np.all(rows.d_lower == -0.05)


def test_pair_inside_the_orange_zone_keeps_its_start_distance():
    """The obstacle 3.6 mm from l3 at the start (orange zone 1 cm): the pair's bound
    is its start distance, the task is satisfied at the start, and a target that
    pulls the arm towards the obstacle is given up at that distance, not pushed
    out to 1 cm (which the old bound did, never satisfied)."""
    model = _arm_with_obstacle(pos=(0.065, 0.0, 0.15))
    conf = mink.Configuration(model)
    conf.update(Q_START)
    task = CollisionAvoidanceTask(conf, [("l3_box", "obstacle")], yellow=0.05, orange=0.01)
    d0 = task.distances(conf)[0]
    assert 0.0 < d0 < 0.01
    assert task.bounds[0] == pytest.approx(d0)
    assert task.is_satisfied(conf) and task.compute_error(conf)[0] == 0.0
    assert task.compute_rows(conf).d_lower[0] == pytest.approx(0.0)  # may not come closer
    start_tip = conf.data.site("end").xpos.copy()
    toward = (start_tip + np.array([0.1, 0.0, 0.0]), np.eye(3))  # through the obstacle
    hand = FrameTask(conf, "end", toward, rotation_axis=None)
    seen = [d0]
    solve(
        conf,
        [[mink.ConfigurationLimit(model)], [task], [hand]],
        stop=30,
        revert_if_fail=False,
        callback=lambda info: seen.append(task.distances(info.configuration)[0]),
    )
    assert min(seen) >= d0 - 1e-4


def _brute_force(model: mujoco.MjModel, data: mujoco.MjData, pairs, distmax: float):
    return np.array(
        [mujoco.mj_geomDistance(model, data, p.geom1, p.geom2, distmax, None) for p in pairs]
    )


def test_prefilter_never_drops_a_near_pair_and_evaluate_agrees():
    """Random poses of the sample humanoid, every pair of its bodies: the pairs
    the bounding spheres/boxes let through include every pair nearer than the
    yellow zone (brute force over all pairs with mj_geomDistance), and the
    distances equal the brute force ones; evaluate() gives compute_rows'
    rows, compute_error's norm and is_satisfied's verdict."""
    robot = Robot.from_model("sample_humanoid")
    m = robot.model
    bodies = [m.body(b).name for b in range(1, m.nbody) if m.body_geomnum[b] > 0]
    pairs = collision_pairs(m, robot.data, bodies)
    task = CollisionAvoidanceTask(robot.configuration, pairs, yellow=0.1, orange=0.01)
    rng = np.random.default_rng(5)
    lo, hi = robot.joint_limits()
    skipped = []
    for _ in range(10):
        robot.set_angle_vector(rng.uniform(lo, hi))
        data = robot.data
        brute = _brute_force(m, data, pairs, 0.1)
        near = task.near_pairs(data, 0.1)
        assert set(np.flatnonzero(brute < 0.1)) <= set(near.tolist())
        assert np.array_equal(task.distances(robot.configuration, 0.1), brute)
        skipped.append(1 - len(near) / len(pairs))
        state = task.evaluate(robot.configuration)
        rows = task.compute_rows(robot.configuration)
        assert np.array_equal(state.rows.C, rows.C)
        assert np.array_equal(state.rows.d_lower, rows.d_lower)
        assert state.error == pytest.approx(np.linalg.norm(task.compute_error(robot.configuration)))
        assert state.satisfied == task.is_satisfied(robot.configuration)
    assert np.mean(skipped) > 0.5  # most pairs are never measured


def test_floating_base_rows_only_on_the_joints_between_the_bodies():
    """The sample humanoid in random poses, every pair in a 0.3 m yellow zone: each
    row is zero (to rounding) outside the joints between its two bodies, the
    floating base's columns included (it moves both witness points alike), not
    zero on them, and the rows match finite differences of MuJoCo's distances for
    random motions of every joint, floating base included."""
    robot = Robot.from_model("sample_humanoid")
    m, conf = robot.model, robot.configuration
    bodies = [m.body(b).name for b in range(1, m.nbody) if m.body_geomnum[b] > 0]
    pairs = collision_pairs(m, robot.data, bodies)
    rng = np.random.default_rng(3)
    lo, hi = robot.joint_limits()
    q_start = robot.angle_vector()
    for _ in range(3):
        robot.set_angle_vector(q_start + 0.3 * rng.uniform(lo, hi))
        task = CollisionAvoidanceTask(conf, pairs, yellow=0.3, orange=0.0)
        rows = task.compute_rows(conf)
        assert len(task.row_pairs) > 10
        for r, i in enumerate(task.row_pairs):
            b1, b2 = (m.geom_bodyid[g] for g in (pairs[i].geom1, pairs[i].geom2))
            between = np.zeros(m.nv, dtype=bool)
            for b in _ancestors(m, b1) ^ _ancestors(m, b2):  # up to the common ancestor
                between[m.body_dofadr[b] : m.body_dofadr[b] + m.body_dofnum[b]] = True
            assert np.all(np.abs(rows.C[r, ~between]) < 1e-12)
            assert np.any(np.abs(rows.C[r, between]) > 1e-6)
        base = m.body_dofadr[robot.root_body_id]
        assert np.all(np.abs(rows.C[:, base : base + 6]) < 1e-12)
        _fd_check(conf, task, rng)


def _ancestors(model: mujoco.MjModel, b: int) -> set[int]:
    out = {int(b)}
    while b != 0:
        b = model.body_parentid[b]
        out.add(int(b))
    return out


def test_moving_pairs_are_those_whose_distance_changes():
    """Pairs kept for the right arm's joints are exactly those whose distance
    changes when those joints (and only those) move at random."""
    robot = Robot.from_model("sample_humanoid")
    m = robot.model
    bodies = [m.body(b).name for b in range(1, m.nbody) if m.body_geomnum[b] > 0]
    pairs = collision_pairs(m, robot.data, bodies)
    arm = list(robot.limb("rarm").joints)
    kept = set(moving_pairs(m, pairs, arm))
    before = _brute_force(m, robot.data, pairs, 10.0)
    rng = np.random.default_rng(2)
    robot.set_angle_vector(robot.angle_vector(arm) + rng.uniform(-0.5, 0.5, len(arm)), arm)
    changed = np.abs(_brute_force(m, robot.data, pairs, 10.0) - before) > 1e-9
    assert {p for p, c in zip(pairs, changed, strict=True) if c} == kept
    assert 0 < len(kept) < len(pairs)
    with pytest.raises(UnknownName):
        moving_pairs(m, pairs, ["rarm_elbow"])


def test_pair_list_like_the_seed_example():
    """Seed: forearm, upper arm, torso, base → forearm–torso, forearm–base, upper–base."""
    robot = Robot.from_model("sample_humanoid")
    robot.reset_pose()
    model, data = robot.model, robot.data
    links = ["rarm_lower", "rarm_upper", "torso_chest", "pelvis"]
    pairs = collision_pairs(model, data, links)
    body_pairs = {
        frozenset(
            (
                model.body(model.geom_bodyid[p.geom1]).name,
                model.body(model.geom_bodyid[p.geom2]).name,
            )
        )
        for p in pairs
    }
    assert body_pairs == {
        frozenset(("rarm_lower", "torso_chest")),
        frozenset(("rarm_lower", "pelvis")),
        frozenset(("rarm_upper", "pelvis")),
    }
    names = {(p.name1, p.name2) for p in pairs}
    assert names == {
        ("rarm_lower", "torso_abdomen"),
        ("rarm_lower", "torso_chest"),
        ("rarm_lower", "pelvis"),
        ("rarm_upper", "pelvis"),
    }
    # Pairs closer than `touching` at the reference pose are dropped.
    dist = {(p.name1, p.name2): pair_distance(model, data, p, 10.0).distance for p in pairs}
    cut = float(np.median(list(dist.values())))
    kept = {(p.name1, p.name2) for p in collision_pairs(model, data, links, touching=cut)}
    assert kept == {k for k, v in dist.items() if v > cut}
    # Obstacles: a body stands for its geoms, a geom for itself.
    spec = load_spec("sample_humanoid")
    box = spec.worldbody.add_body(name="table", pos=[0.4, 0.0, 0.7])
    box.add_geom(name="table_top", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.2, 0.3, 0.02])
    box.add_geom(name="table_leg", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.02, 0.3])
    m2 = spec.compile()
    d2 = mujoco.MjData(m2)
    d2.qpos[:] = m2.key("reset_pose").qpos
    mujoco.mj_kinematics(m2, d2)
    env = collision_pairs(m2, d2, ["rarm_hand"], ["table"])
    assert {(p.name1, p.name2) for p in env} == {
        ("rarm_hand", "table_top"),
        ("rarm_hand", "table_leg"),
    }
    with pytest.raises(UnknownName, match="rarm_hnd"):
        collision_pairs(model, data, ["rarm_hnd"])
    with pytest.raises(UnknownName):
        collision_pairs(m2, d2, ["rarm_hand"], ["tabel"])


def test_bad_input():
    model = _arm_with_obstacle()
    conf = mink.Configuration(model)
    with pytest.raises(UnknownName, match="obstacl"):
        CollisionAvoidanceTask(conf, [("l3_box", "obstacl")])
    with pytest.raises(InvalidInput):
        CollisionAvoidanceTask(conf, [("l3_box", "l3_box")])
    with pytest.raises(InvalidInput):
        CollisionAvoidanceTask(conf, [("l3_box", "obstacle")], yellow=0.01, orange=0.02)
    with pytest.raises(InvalidInput):
        CollisionAvoidanceTask.from_links(conf, ["l4"], [])
