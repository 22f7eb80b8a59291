"""A robot as some are shipped (tests/mjcf/gear_humanoid.xml): gear side bodies on
its arms, self-collision declared only as ``<contact><pair>``s, a keyframe that
breaks level-0 rows outside the solved limbs. Used as it is, it gets full arms,
every declared pair watched, and a solve that starts by repairing its held joints."""

from __future__ import annotations

import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest

import pik_mj
from pik_mj.robot.floor_contact import subtree_bodies
from pik_mj.robot.stack import held_breaches
from pik_mj.tasks.collision_pairs import collision_pairs

GEAR_HUMANOID = Path(__file__).parent / "mjcf" / "gear_humanoid.xml"


@pytest.fixture(scope="module")
def robot() -> pik_mj.Robot:
    return pik_mj.Robot.from_model(str(GEAR_HUMANOID))


def test_arms_follow_the_chain_through_gear_bodies(robot):
    """The welded gears (shoulder, wrist, gripper) and the elbow's drive gear (a hinge
    of its own, coupled to the elbow) are side bodies; the gripper's two coupled
    fingers end the arm at the hand."""
    for side in ("rarm", "larm"):
        limb = robot.limb(side)
        assert limb.joints == tuple(
            f"{side}_{j}" for j in ("shoulder_p", "shoulder_r", "elbow_p", "wrist_y")
        )
        assert (limb.end_frame, limb.end_frame_type, limb.root_body) == (
            f"{side}_end",
            "site",
            f"{side}_upper",
        )
    assert robot.limb("rleg").end_frame == "rleg_end" and len(robot.limb("rleg").joints) == 6


def test_every_declared_pair_is_watched(robot):
    """Every geom has contype = conaffinity = 0 but the soles: the self-collision pairs
    are the MJCF's explicit pairs, those apart in the start pose."""
    m, d = robot.model, robot.data
    links = [m.body(int(b)).name for b in subtree_bodies(m, robot.root_body_id)]
    watched = {(p.geom1, p.geom2) for p in collision_pairs(m, d, links)}
    explicit = {
        tuple(sorted(p)) for p in zip(m.pair_geom1.tolist(), m.pair_geom2.tolist(), strict=True)
    }
    apart = {p for p in explicit if mujoco.mj_geomDistance(m, d, p[0], p[1], 1.0, None) > 0.0}
    assert m.npair == 61 and len(apart) >= 55
    assert {tuple(sorted(p)) for p in watched} == apart


def _mujoco_violations(robot: pik_mj.Robot, q: np.ndarray) -> tuple[float, float]:
    """MuJoCo's own measure of level 0 at ``q``: the largest equality violation and
    the deepest joint-limit violation (``efc_pos`` of those constraint rows) [rad, m]."""
    m = robot.model
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    kind, pos = d.efc_type[: d.nefc], d.efc_pos[: d.nefc]
    equality = np.abs(pos[kind == mujoco.mjtConstraint.mjCNSTR_EQUALITY])
    limit = pos[kind == mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT]
    return float(np.max(equality, initial=0.0)), float(np.max(-limit, initial=0.0))


@pytest.mark.parametrize("qp_solver", ["osqp", "daqp-hqp"])
def test_held_joints_breaking_level_0_are_repaired_with_a_warning(robot, qp_solver):
    """A reach with the right arm: the left elbow (0, outside [-2.234, -0.0035]) and
    both grippers (fingers 0.01 and 0 against ``finger_b = finger_a``) are held and
    break level 0; the first step puts them on its rows, the reach converges."""
    m = robot.model
    q0 = robot.configuration.q.copy()
    assert _mujoco_violations(robot, q0) == pytest.approx((0.01, 0.0035))
    hand = robot.frame_pose("rarm_end").translation()
    with pytest.warns(RuntimeWarning) as caught:
        result = pik_mj.fullbody_inverse_kinematics(
            robot,
            [(hand + np.array([0.04, 0.0, 0.02]), [1.0, 0.0, 0.0, 0.0])],
            limbs=["rarm"],
            rotation_axis=[None],
            qp_solver=qp_solver,
        )
    messages = [str(w.message) for w in caught]
    message = next(m for m in messages if m.startswith("held joints break level 0"))
    # and the solve's own warning of a start outside the ranges, naming both elbows
    assert any(
        m.startswith("the start configuration is outside the joint ranges")
        and "rarm_elbow_p 0 not in" in m
        and "larm_elbow_p 0 not in" in m
        for m in messages
    ), messages
    for named in ("larm_elbow_p outside its range by 0.0035", "rarm_finger_b follows",
                  "larm_finger_b follows", "larm_elbow_drive follows"):  # fmt: skip
        assert named in message
    try:
        assert result.converged
        q = robot.configuration.q
        equality, limit = _mujoco_violations(robot, q)
        assert equality < 1e-8 and limit < 1e-9
        assert q[m.joint("larm_elbow_p").qposadr[0]] == pytest.approx(-0.0035, abs=1e-9)
        for held in ("larm_shoulder_p", "neck_y", "rarm_finger_a", "larm_finger_a"):
            a = m.joint(held).qposadr[0]
            assert q[a] == pytest.approx(q0[a], abs=1e-9)
    finally:
        robot.configuration.update(q0)


def test_a_failed_solve_restores_the_start_as_shipped(robot):
    q0 = robot.configuration.q.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        result = pik_mj.inverse_kinematics(
            robot, (np.array([2.0, 0.0, 0.3]), [1.0, 0.0, 0.0, 0.0]), limbs="rarm", stop=5
        )
    assert not result.converged and result.reverted
    np.testing.assert_array_equal(robot.configuration.q, q0)


def test_no_breach_no_warning():
    """A start on its rows: nothing repaired, nothing said."""
    robot = pik_mj.Robot.from_model("sample_humanoid")
    moving = np.arange(6)
    what, freed = held_breaches(robot.configuration, moving, ())
    assert what == [] and freed.size == 0
    hand = robot.frame_pose("rarm_end").translation()
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        target = (hand + np.array([0.02, 0.0, 0.02]), [1.0, 0.0, 0.0, 0.0])
        pik_mj.inverse_kinematics(robot, target, limbs="rarm", rotation_axis=None)
