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
from pik_mj.models import load_spec
from pik_mj.robot import Robot
from pik_mj.tasks.collision import CollisionAvoidanceTask, collision_pairs, pair_distance

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
    d0 = task.distances(conf)
    q0 = conf.q.copy()
    eps = 1e-6
    active = np.isfinite(rows.d_lower) & np.any(rows.C != 0, axis=1)
    assert active.any()
    for _ in range(3):
        x = rng.normal(size=conf.model.nv)
        conf.integrate_inplace(eps * x, 1.0)
        fd = (task.distances(conf) - d0) / eps
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


def test_yellow_zone_inactive_rows():
    model = _arm_with_obstacle(pos=(0.0, 0.5, 0.1))  # far from the arm
    conf = mink.Configuration(model)
    conf.update(Q_START)
    task = CollisionAvoidanceTask(conf, [("l3_box", "obstacle")], yellow=0.05)
    rows = task.compute_rows(conf)
    assert np.all(rows.C == 0.0)  # 0·x >= lower always holds
    assert rows.d_lower[0] < 0.0 and rows.d_upper[0] == np.inf
    assert task.is_satisfied(conf)
    # Independent distance: box centre-to-centre minus half sizes along y.
    d = task.distances(conf)[0]
    data = conf.data
    gap = data.geom_xpos[model.geom("obstacle").id][1] - 0.05 - 0.005
    assert d == pytest.approx(gap, abs=1e-3)


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
