"""The world in the stack: the full-body entry points keep the robot clear of its
world's geometry by default (:mod:`pik_mj.ik.world`), on pairs chosen as MuJoCo
collides them (:mod:`pik_mj.robot.collisions`).

Two reaches whose straight path goes through the world: the sample humanoid's
right arm past a box hanging across its way (``models/obstacle.xml``, the hand's
orientation kept: :func:`pik_mj.inverse_kinematics`), and the README's first
example, the hand 15 cm short of the kettle handle in the room (the counter in
the way: :func:`pik_mj.fullbody_inverse_kinematics`). With the default stack the
smallest arm–obstacle distance over every iterate (MuJoCo's ``mj_geomDistance``)
stays at the clearance; with ``avoid_world=False`` the arm goes through.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie

import pik_mj
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.ik.arguments import root_dofs
from pik_mj.ik.world import WorldAvoidance
from pik_mj.robot.collisions import robot_geoms, self_collision_pairs, world_collision_pairs
from pik_mj.robot.loading import MODELS_DIR
from pik_mj.robot.stack import moving_dofs
from pik_mj.tasks.collision import CollisionAvoidanceTask
from pik_mj.tasks.collision_pairs import collidable_pairs, geoms_named

GEAR_HUMANOID = Path(__file__).parent / "mjcf" / "gear_humanoid.xml"
CLEARANCE = WorldAvoidance().clearance
TOLERANCE = 1.5e-4  # [m] the avoidance's stop-test margin, and the solver's


def _min_distance(robot: pik_mj.Robot, geoms, others) -> float:
    m, d = robot.model, robot.data
    return min(mujoco.mj_geomDistance(m, d, a, b, 1.0, None) for a in geoms for b in others)


def _solve_watching(robot, function, targets, geoms, others, **options):
    """``function``'s solve from the robot's start, the smallest distance of
    ``geoms`` to ``others`` at the start and after every iteration [m]."""
    q0 = robot.configuration.q.copy()
    seen = [_min_distance(robot, geoms, others)]
    result = function(
        robot,
        targets,
        callback=lambda _i: seen.append(_min_distance(robot, geoms, others)),
        **options,
    )
    robot.configuration.update(q0)
    return result, min(seen)


@pytest.fixture(scope="module")
def in_room() -> pik_mj.Robot:
    return pik_mj.Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")


def test_world_pairs_as_mujoco_collides_them(in_room):
    robot = in_room
    m = robot.model
    own = set(robot_geoms(robot).tolist())
    pairs = world_collision_pairs(robot, touching=1e-3)
    ids = {(p.geom1, p.geom2) for p in pairs}
    assert all(p.geom1 in own and p.geom2 not in own for p in pairs)  # robot geom first
    collidable = {tuple(p) for p in collidable_pairs(m).tolist()}
    assert {tuple(sorted(p)) for p in ids} <= collidable
    # the soles stand on the floor: contacts the robot makes, not watched
    floor = m.geom("floor").id
    soles = {m.geom(n).id for n in ("rleg_sole", "lleg_sole")}
    assert not {(s, floor) for s in soles} & ids
    assert {(m.geom("rarm_hand").id, m.geom("counter").id), (m.geom("pelvis").id, floor)} <= ids
    # every robot-world pair MuJoCo collides is watched but those touching now
    every = {tuple(sorted(p)) for p in collidable if (p[0] in own) != (p[1] in own)}
    touching = {
        p for p in every if mujoco.mj_geomDistance(m, robot.data, p[0], p[1], 1.0, None) <= 1e-3
    }
    assert {tuple(sorted(p)) for p in ids} == every - touching
    # planned contacts: a name frees every pair of its geoms, two names the pairs between them
    hand_counter = {
        (p.name1, p.name2) for p in world_collision_pairs(robot, allowed=[("rarm_hand", "counter")])
    }
    assert ("rarm_hand", "counter") not in hand_counter and (
        "rarm_lower",
        "counter",
    ) in hand_counter
    no_counter = {p.name2 for p in world_collision_pairs(robot, allowed=["counter"])}
    assert "counter" not in no_counter and "floor" in no_counter
    # the arm's joints alone (a fixed root) move only the arm's pairs
    arm = moving_dofs(m, robot.limb("rarm").joints)
    arm_bodies = {"rarm_upper", "rarm_lower", "rarm_hand"}
    moved = world_collision_pairs(robot, arm)
    assert moved and {m.body(m.geom_bodyid[p.geom1]).name for p in moved} <= arm_bodies
    with pytest.raises(UnknownName, match="allowed geom or body"):
        world_collision_pairs(robot, allowed=["countr"])
    with pytest.raises(InvalidInput, match="pair of them"):
        world_collision_pairs(robot, allowed=[("rarm_hand", "counter", "kettle")])


def test_the_floor_is_bounded_like_any_geom(in_room):
    """The floor plane's pairs are measured only when near (MuJoCo's plane bound),
    never missing one: brute force over random poses and heights."""
    robot = in_room
    m = robot.model
    task = CollisionAvoidanceTask(robot.configuration, world_collision_pairs(robot), yellow=0.2)
    q0 = robot.configuration.q.copy()
    rng = np.random.default_rng(2)
    lo, hi = robot.joint_limits()
    skipped = []
    for _ in range(8):
        robot.set_angle_vector(rng.uniform(lo, hi))
        q = robot.configuration.q.copy()
        q[2] += rng.uniform(-0.3, 0.3)  # the root up or down: the legs into the floor or off it
        robot.configuration.update(q)
        brute = np.array(
            [mujoco.mj_geomDistance(m, robot.data, p.geom1, p.geom2, 0.2, None) for p in task.pairs]
        )
        near = task.near_pairs(robot.data, 0.2)
        assert set(np.flatnonzero(brute < 0.2 - 1e-9)) <= set(near.tolist())  # distmax: beyond
        floor = [i for i, p in enumerate(task.pairs) if p.name2 == "floor"]
        skipped.append(1 - len(set(near.tolist()) & set(floor)) / len(floor))
    robot.configuration.update(q0)
    assert np.mean(skipped) > 0.3  # the floor's pairs are not all measured every time


@pytest.mark.parametrize("qp_solver", ["osqp", "daqp-hqp"])
def test_inverse_kinematics_keeps_the_arm_off_the_box(qp_solver):
    robot = pik_mj.Robot.from_model("sample_humanoid", environment=MODELS_DIR / "obstacle.xml")
    m = robot.model
    arm = geoms_named(m, ["rarm_upper", "rarm_lower", "rarm_hand"], "arm")
    box = [m.geom("obstacle").id]
    target = (np.array([0.38, -0.25, 0.95]), np.array([1.0, 0.0, 0.0, 0.0]))
    found = {}
    for avoid in (True, False):
        result, found[avoid] = _solve_watching(
            robot, pik_mj.inverse_kinematics, target, arm, box,
            limbs="rarm", avoid_world=avoid, qp_solver=qp_solver, stop=100,
        )  # fmt: skip
        if avoid:
            assert result.converged
    print(f"{qp_solver}: min arm-box distance {found[True]:.4f} m with, {found[False]:.4f} without")
    assert found[True] >= CLEARANCE - TOLERANCE
    assert found[False] < 0.0


def test_the_readme_reach_keeps_the_arm_off_the_counter(in_room):
    robot = in_room
    m = robot.model
    arm = geoms_named(m, ["rarm_upper", "rarm_lower", "rarm_hand"], "arm")
    counter = [m.geom("counter").id]
    near = robot.frame_pose("kettle_handle").translation() - np.array([0.15, 0.0, 0.0])
    found = {}
    for avoid in (True, False):
        result, found[avoid] = _solve_watching(
            robot, pik_mj.fullbody_inverse_kinematics, [(near, [1.0, 0.0, 0.0, 0.0])], arm,
            counter, limbs=["rarm"], rotation_axis=[None], avoid_world=avoid,
        )  # fmt: skip
        assert result.converged
    print(f"min arm-counter distance {found[True]:.4f} m with, {found[False]:.4f} without")
    assert found[True] >= CLEARANCE - TOLERANCE
    assert found[False] < 0.0


def test_a_hand_turning_at_the_counter_edge_keeps_every_corner_off(in_room):
    """A target under the counter's top edge, 13 cm short of the handle: the hand's
    box faces the counter's front and turns about its nearest corner; one witness
    row per pair lets the other corner in (14.5 mm after 30 iterations, against a
    20 mm clearance); the remembered witness points keep both out."""
    robot = in_room
    m = robot.model
    target = robot.frame_pose("kettle_handle").translation() + np.array([-0.128, -0.037, -0.073])
    hand, counter = [m.geom("rarm_hand").id], [m.geom("counter").id]
    result, found = _solve_watching(
        robot, pik_mj.fullbody_inverse_kinematics, [(target, [1.0, 0.0, 0.0, 0.0])], hand,
        counter, limbs=["rarm"], rotation_axis=[None], stop=30, revert_if_fail=False,
    )  # fmt: skip
    assert not result.converged  # the target is given up, not the clearance
    assert found >= CLEARANCE - TOLERANCE


@pytest.mark.parametrize("name", ["unitree_g1", "unitree_h1", "booster_t1"])
def test_every_robot_reaches_for_the_kettle_clear_of_the_room(name):
    """The README's reach on each robot as shipped and on the synthetic gear
    humanoid, in the room: with the default stack no robot-world pair the solve
    watches comes nearer than the clearance on any iterate (``mj_geomDistance``)
    and the feet stay within 1e-4 m of where they stand; without, the robot
    goes into its world."""
    if name == "gear_humanoid":
        name = str(GEAR_HUMANOID)
    else:
        requires_menagerie(name)
    robot = pik_mj.Robot.from_model(name, environment="room", at="spot_counter_front")
    m = robot.model
    dofs = moving_dofs(m, robot.limb("rarm").joints, root_dofs(robot))
    pairs = world_collision_pairs(robot, dofs, touching=WorldAvoidance().touching)
    feet = [(robot.limb(leg).end_frame, robot.limb(leg).end_frame_type) for leg in ("rleg", "lleg")]
    start = np.array([robot.frame_pose(*f).translation() for f in feet])
    target = robot.frame_pose("kettle_handle").translation() - np.array([0.15, 0.0, 0.0])
    q0 = robot.configuration.q.copy()
    found, drift = {}, []
    for avoid in (True, False):
        seen = []

        def watch(_info, seen=seen, avoid=avoid):
            seen.append(
                min(
                    mujoco.mj_geomDistance(m, robot.data, p.geom1, p.geom2, 1.0, None)
                    for p in pairs
                )
            )
            if avoid:
                now = np.array([robot.frame_pose(*f).translation() for f in feet])
                drift.append(np.abs(now - start).max())

        pik_mj.fullbody_inverse_kinematics(
            robot, [(target, [1.0, 0.0, 0.0, 0.0])], limbs=[robot.limb("rarm").name],
            rotation_axis=[None], avoid_world=avoid, revert_if_fail=False, callback=watch,
        )  # fmt: skip
        robot.configuration.update(q0)
        found[avoid] = min(seen)
    print(f"{name}: min robot-world distance {found[True]:.4f} m with, {found[False]:.4f} without")
    assert found[True] >= CLEARANCE - TOLERANCE
    assert max(drift) <= 1e-4
    assert found[False] < CLEARANCE - TOLERANCE


# Its keyframe breaks level 0 (tests/test_robot_as_shipped.py checks those warnings).
@pytest.mark.filterwarnings("ignore:held joints break level 0:RuntimeWarning")
@pytest.mark.filterwarnings("ignore:the start configuration is outside:RuntimeWarning")
def test_a_pair_only_robot_meets_its_world_only_where_mujoco_does():
    """The synthetic gear humanoid's geoms collide only through its ``<pair>``s,
    but its soles (contype 0, conaffinity 1). A bar sized from its arm, across
    the hand's way: the solve watches the soles' pairs with the bar alone, the
    hand goes through the bar with avoidance on as with it off, and MuJoCo's own
    collision (``mj_collision``) finds no arm-bar contact there either."""
    alone = pik_mj.Robot.from_model(str(GEAR_HUMANOID))
    arm = alone.limb("rarm")
    hand = alone.frame_pose(arm.end_frame, arm.end_frame_type).translation()
    shoulder = alone.data.xpos[alone.model.body(arm.root_body).id]
    length = np.linalg.norm(hand - shoulder)
    target = shoulder + np.array([0.9 * length, 0.0, 0.0])
    env = pik_mj.floor_environment()
    pik_mj.add_box(env, "bar", (hand + target) / 2, 0.1 * length * np.array([1.0, 5.0, 1.0]))
    robot = pik_mj.Robot.from_model(str(GEAR_HUMANOID), environment=env)
    m = robot.model
    watched = {(p.name1, p.name2) for p in world_collision_pairs(robot, touching=1e-3)}
    assert watched == {("rleg_sole", "bar"), ("lleg_sole", "bar")}
    own, bar = robot_geoms(robot), m.geom("bar").id
    q0, deepest = robot.configuration.q.copy(), []

    def keep_deepest(_info):
        d = _min_distance(robot, own, [bar])
        if not deepest or d < deepest[0]:
            deepest[:] = [d, robot.configuration.q.copy()]

    options = dict(limbs=[arm.name], rotation_axis=[None], revert_if_fail=False)
    pik_mj.fullbody_inverse_kinematics(
        robot, [(target, [1.0, 0.0, 0.0, 0.0])], avoid_world=False, callback=keep_deepest, **options
    )
    robot.configuration.update(q0)
    _, with_avoidance = _solve_watching(
        robot,
        pik_mj.fullbody_inverse_kinematics,
        [(target, [1.0, 0.0, 0.0, 0.0])],
        own,
        [bar],
        **options,
    )
    assert deepest[0] < 0.0 and with_avoidance == pytest.approx(deepest[0], abs=1e-9)
    data = mujoco.MjData(m)
    data.qpos[:] = deepest[1]
    mujoco.mj_forward(m, data)
    contacts = data.contact.geom[: data.ncon]
    assert not np.any((contacts == bar).any(axis=1) & np.isin(contacts, own).any(axis=1))


def test_a_robot_alone_has_no_world_and_a_pair_only_robot_watches_its_pairs():
    robot = pik_mj.Robot.from_model("sample_humanoid")
    assert world_collision_pairs(robot) == []
    shipped = pik_mj.Robot.from_model(str(GEAR_HUMANOID))
    m = shipped.model
    pairs = self_collision_pairs(shipped)
    explicit = {
        tuple(sorted(p)) for p in zip(m.pair_geom1.tolist(), m.pair_geom2.tolist(), strict=True)
    }
    assert {tuple(sorted((p.geom1, p.geom2))) for p in pairs} <= explicit and len(pairs) > 50
    arm = moving_dofs(m, shipped.limb("rarm").joints)
    assert 0 < len(self_collision_pairs(shipped, arm)) < len(pairs)


@pytest.mark.parametrize(
    "bad, match",
    [
        ("yes", "avoid_world must be True, False"),
        (WorldAvoidance, "avoid_world must be True, False"),
    ],
)
def test_bad_avoid_world(in_room, bad, match):
    q0 = in_room.configuration.q.copy()
    with pytest.raises(InvalidInput, match=match):
        pik_mj.inverse_kinematics(
            in_room, (np.zeros(3), [1.0, 0, 0, 0]), limbs="rarm", avoid_world=bad
        )
    np.testing.assert_array_equal(in_room.configuration.q, q0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"clearance": 0.3}, "reach must be"),
        ({"gain": 0.0}, "gain must be"),
        ({"clearance": -0.01}, "clearance must be"),
        ({"allowed": "counter"}, "allowed must be a list"),
    ],
)
def test_bad_world_avoidance(kwargs, match):
    with pytest.raises(InvalidInput, match=match):
        WorldAvoidance(**kwargs)
