"""Joint, centroid and virtual-root tasks against finite differences and brute force.

Every Jacobian is compared with central differences of the task's error (or, for
inequality tasks, of its row values ``d(q)``), perturbing ``q`` with
``mujoco.mj_integratePos`` along each tangent direction (eps 1e-6, tol 1e-6).
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np
import pytest
from fd import fd_jacobian

import pik_mj
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.ik.virtual_root import solve_with_virtual_root, with_virtual_root
from pik_mj.qp import OSQP_DEFAULTS
from pik_mj.robot import Robot
from pik_mj.robot.loading import load_model
from pik_mj.tasks.com import CentroidTask, robot_root_body
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.joint_coupling import JointCouplingTask
from pik_mj.tasks.joint_limit import JointLimitTask
from pik_mj.tasks.joint_velocity import JointVelocityTask
from pik_mj.tasks.mink_adapter import MinkLimit, _BoxRows
from pik_mj.tasks.task import EqualityTask

EPS = 1e-6
TOL = 1e-6

BALL_XML = """
<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="base">
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
      <body name="link" pos="0 0 0.05">
        <joint name="ball" type="ball" range="0 0.6"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02" mass="0.5"/>
        <site name="tip" pos="0 0 0.3"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def random_posture(model: mujoco.MjModel, seed: int) -> np.ndarray:
    """``qpos0`` with a random free-base pose and joints uniform in 80 % of their range."""
    rng = np.random.default_rng(seed)
    q = model.qpos0.copy()
    for j in range(model.njnt):
        a = model.jnt_qposadr[j]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            quat = rng.normal(size=4)
            q[a : a + 3] = rng.normal(scale=0.2, size=3)
            q[a + 3 : a + 7] = quat / np.linalg.norm(quat)
        elif model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            quat = np.r_[1.0, rng.normal(scale=0.2, size=3)]
            q[a : a + 4] = quat / np.linalg.norm(quat)
        elif model.jnt_limited[j]:
            lo, hi = model.jnt_range[j]
            q[a] = 0.5 * (lo + hi) + 0.4 * (hi - lo) * rng.uniform(-1, 1)
    return q


@pytest.fixture(scope="module")
def humanoid():
    return load_model("dm_humanoid")


@pytest.fixture(scope="module")
def arm():
    return load_model("three_dof_arm")


@pytest.fixture(scope="module")
def ball_model():
    return mujoco.MjModel.from_xml_string(BALL_XML)


def configured(model, q) -> mink.Configuration:
    cfg = mink.Configuration(model)
    cfg.update(q)
    return cfg


# ----------------------------------------------------------------------------- limits


@pytest.mark.parametrize("name", ["humanoid", "arm"])
def test_joint_limit_rows_are_range_minus_angle_with_fd_jacobian(name, request):
    model = request.getfixturevalue(name)
    q = random_posture(model, 1)
    cfg = configured(model, q)
    task = JointLimitTask.all_limited(cfg)
    rows = task.compute_rows(cfg)
    limited = [j for j in range(model.njnt) if model.jnt_limited[j]]
    assert len(task.joints) == len(limited)
    for i, j in enumerate(limited):
        name_j = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        angle = cfg.data.joint(name_j).qpos[0]
        assert rows.d_lower[i] == pytest.approx(model.jnt_range[j, 0] - angle, abs=1e-12)
        assert rows.d_upper[i] == pytest.approx(model.jnt_range[j, 1] - angle, abs=1e-12)
    J_fd = fd_jacobian(model, q, task.values)
    assert np.max(np.abs(J_fd - rows.C)) < TOL


def test_ball_joint_cone_row_matches_fd_and_mujoco_angle(ball_model):
    q = np.array([np.cos(0.35), 0.6 * np.sin(0.35), -0.8 * np.sin(0.35), 0.0])
    cfg = configured(ball_model, q)
    task = JointLimitTask(cfg, "ball")
    assert task.check_margin[0] == 1e-3 and task.max_angle[0] == pytest.approx(0.6)
    # MuJoCo's own quaternion -> rotation vector.
    rvec = np.zeros(3)
    mujoco.mju_quat2Vel(rvec, q, 1.0)
    assert task.values(cfg)[0] == pytest.approx(np.linalg.norm(rvec), abs=1e-12)
    rows = task.compute_rows(cfg)
    assert rows.d_upper[0] == pytest.approx(0.6 - 0.7, abs=1e-12)
    assert np.isneginf(rows.d_lower[0])
    J_fd = fd_jacobian(ball_model, q, task.values)
    assert np.max(np.abs(J_fd - rows.C)) < TOL
    assert task.violations(cfg)["ball"] == pytest.approx(0.1, abs=1e-12)
    assert not task.is_satisfied(cfg)


@pytest.mark.parametrize("name", ["humanoid", "arm", "ball_model"])
def test_mink_configuration_limit_rows_are_minks_bit_for_bit(name, request):
    """The adapter computes a ConfigurationLimit's ``h`` itself after checking
    it once against mink's call (ball joints: mink's call every time); at
    postures inside and outside the ranges its rows are mink's, bit for bit,
    and ``G`` stays the same read-only object."""
    model = request.getfixturevalue(name)
    limit = mink.ConfigurationLimit(model, gain=0.9)
    adapter = MinkLimit(limit)
    cfg = configured(model, random_posture(model, 0))
    first = adapter.compute_rows(cfg)
    assert isinstance(adapter._box, _BoxRows) == (name != "ball_model")
    rng = np.random.default_rng(3)
    for seed in range(6):
        q = random_posture(model, seed)
        if seed % 2:  # some hinges past their ranges
            for j in range(model.njnt):
                if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
                    q[model.jnt_qposadr[j]] += rng.normal(scale=1.0)
        cfg.update(q)
        rows = adapter.compute_rows(cfg)
        G, h = limit.compute_qp_inequalities(cfg, 1.0)
        assert np.array_equal(rows.C, G) and np.array_equal(rows.d_upper, h)
        assert not rows.C.flags.writeable
        if name != "ball_model":
            assert rows.C is first.C
        assert np.all(rows.d_lower == -np.inf)
        state = adapter.evaluate(cfg)
        violation = np.maximum(-h, 0.0)
        assert state.error == pytest.approx(np.linalg.norm(violation), rel=1e-15)
        assert state.satisfied == bool(violation.max() <= adapter.check_margin)


@pytest.mark.parametrize("name", ["humanoid", "arm"])
def test_mink_posture_rows_are_minks_and_follow_cost_changes(name, request):
    """The adapter keeps a PostureTask's Jacobian (constant) and its cost²
    weights; at every posture its rows are mink's own (``J``, ``-gain e``,
    ``cost²``) bit for bit, and a cost changed in place by ``set_cost`` (the
    same array object) changes the weights at the next evaluation: a stale
    cache fails this test."""
    model = request.getfixturevalue(name)
    posture = mink.PostureTask(model, cost=0.3, gain=0.7)
    cfg = configured(model, random_posture(model, 0))
    posture.set_target_from_configuration(cfg)
    adapter = pik_mj.MinkTask(posture, check=False)
    first = adapter.evaluate(cfg).rows
    for seed in range(1, 5):
        cfg.update(random_posture(model, seed))
        if seed == 3:
            cost = posture.cost
            posture.set_cost(np.linspace(0.1, 2.0, model.nv))
            assert posture.cost is cost  # written in place
        state = adapter.evaluate(cfg)
        e = posture.compute_error(cfg)
        assert np.array_equal(state.rows.A, posture.compute_jacobian(cfg))
        assert state.rows.A is first.A and not state.rows.A.flags.writeable
        assert np.array_equal(state.rows.b, -0.7 * e)
        assert np.array_equal(state.rows.w_A, posture.cost**2)
        assert state.error == pytest.approx(np.linalg.norm(e), rel=1e-14)
        assert state.satisfied == bool(np.abs(e).max() <= 1e-3)


def test_ball_joint_limit_holds_in_a_solve(ball_model):
    cfg = configured(ball_model, ball_model.qpos0.copy())
    limit = JointLimitTask(cfg, "ball")
    # The tip 90 degrees over: needs a 1.57 rad rotation, the cone allows 0.6.
    reach = FrameTask(cfg, "tip", ([0.3, 0.0, 0.05], [1, 0, 0, 0]), rotation_axis=None)
    result = pik_mj.solve(cfg, [[limit], [reach]], stop=40, revert_if_fail=False)
    assert not result.converged
    assert limit.values(cfg)[0] <= 0.6 + 1e-3
    assert limit.values(cfg)[0] >= 0.6 - 1e-2  # pressed against the cone


def test_joint_limit_reports_violations_per_joint(arm):
    q = np.array([2.0, 0.1, -1.9])
    cfg = configured(arm, q)
    task = JointLimitTask.all_limited(cfg)
    lim = arm.jnt_range[0, 1]
    v = task.violations(cfg)
    assert v["joint0"] == pytest.approx(2.0 - lim)
    assert v["joint1"] == 0.0
    assert v["joint2"] == pytest.approx(1.9 - lim)
    assert not task.is_satisfied(cfg)
    cfg.update(np.zeros(3))
    assert task.is_satisfied(cfg)


def test_joint_limit_is_respected_by_the_solve_and_given_limits_override(arm):
    cfg = configured(arm, np.zeros(3))
    limit = JointLimitTask(cfg, ["joint0", "joint1"], min_angle=-0.3, max_angle=[0.3, 0.5])
    reach = FrameTask(cfg, "end", ([0.2, 0.0, 0.05], [1, 0, 0, 0]), rotation_axis=None)
    pik_mj.solve(cfg, [[limit], [reach]], stop=40, revert_if_fail=False)
    assert -0.3 - 1e-5 <= cfg.q[0] <= 0.3 + 1e-5
    assert -0.3 - 1e-5 <= cfg.q[1] <= 0.5 + 1e-5
    assert cfg.q[0] == pytest.approx(0.3, abs=1e-4)  # the limit is active
    assert limit.is_satisfied(cfg)


# --------------------------------------------------------------------------- velocity


def test_joint_velocity_bounds_every_step(arm):
    cfg = configured(arm, np.zeros(3))
    vel = JointVelocityTask(cfg, ["joint0", "joint1", "joint2"], max_vel=[1.0, 2.0, 2.0])
    rows = vel.compute_rows(cfg)
    assert np.allclose(rows.d_upper, [0.05, 0.1, 0.1]) and np.allclose(rows.d_lower, -rows.d_upper)
    reach = FrameTask(cfg, "end", ([0.15, 0.0, 0.1], [1, 0, 0, 0]), rotation_axis=None)
    steps = []
    q_prev = [cfg.q.copy()]

    def record(info):
        steps.append(np.abs(info.configuration.q - q_prev[0]))
        q_prev[0] = info.configuration.q.copy()

    pik_mj.solve(cfg, [[vel], [reach]], stop=60, callback=record, correct=False)
    steps = np.array(steps)
    # bounds hold to OSQP's primal tolerance, eps_abs + eps_rel * |bound|
    tol = OSQP_DEFAULTS["eps_abs"] + OSQP_DEFAULTS["eps_rel"] * 0.1
    assert np.all(steps <= np.array([0.05, 0.1, 0.1]) + tol)
    assert steps[:, 0].max() >= 0.05 - 1e-4  # the bound was active
    assert reach.is_satisfied(cfg)


# --------------------------------------------------------------------------- coupling


def test_joint_coupling_fd_and_solve(humanoid):
    q = random_posture(humanoid, 2)
    cfg = configured(humanoid, q)
    task = JointCouplingTask(cfg, "right_hip_y", "left_hip_y", ratio=0.5, offset=0.1)
    e = task.compute_error(cfg)[0]
    assert e == pytest.approx(
        cfg.data.joint("left_hip_y").qpos[0] - (0.5 * cfg.data.joint("right_hip_y").qpos[0] + 0.1)
    )
    J_fd = fd_jacobian(humanoid, q, task.compute_error)
    cfg.update(q)
    assert np.max(np.abs(J_fd - task.compute_jacobian(cfg))) < TOL
    value = JointCouplingTask(cfg, -0.4, "right_knee")
    result = pik_mj.solve(
        cfg, [[JointLimitTask.all_limited(cfg)], [task, value]], stop=20, revert_if_fail=False
    )
    assert result.converged
    assert abs(task.compute_error(cfg)[0]) <= 1e-5
    assert cfg.data.joint("right_knee").qpos[0] == pytest.approx(-0.4, abs=1e-5)


class SiteHeight(EqualityTask):
    """A user task written against the base: the z of a site onto a height."""

    k = 1

    def __init__(self, site: str, height: float, limit: float | None = None):
        self.site, self.height, self.limit = site, height, limit
        self.weights = np.ones(1)
        self.name = f"height:{site}"

    def compute_error(self, configuration):
        return np.array([configuration.data.site(self.site).xpos[2] - self.height])

    def compute_jacobian(self, configuration):
        model, data = configuration.model, configuration.data
        jacp = np.zeros((3, model.nv))
        mujoco.mj_jacSite(model, data, jacp, None, model.site(self.site).id)
        return jacp[2:3]

    def clamp(self, e):
        return e.copy() if self.limit is None else np.clip(e, -self.limit, self.limit)

    def satisfied_by(self, e):
        return abs(e[0]) <= 1e-4


def test_a_user_equality_task_gets_rows_clamp_and_stop_test_from_the_base(arm):
    """Error and Jacobian in, everything else from EqualityTask: the rows are
    ``J x = -clamp(e)``, the Jacobian matches finite differences, the stop test
    reads the unclamped error, and the cascade solves it."""
    q = np.array([0.2, 0.4, -0.3])
    cfg = configured(arm, np.array([-0.1, 0.6, 0.2]))
    height = float(cfg.data.site("end").xpos[2])  # reachable: where another posture puts it
    cfg.update(q)
    task = SiteHeight("end", height=height, limit=0.01)
    e, J = task.error_and_jacobian(cfg)
    rows = task.compute_rows(cfg)
    np.testing.assert_array_equal(rows.A, J)
    assert rows.b[0] == pytest.approx(-np.clip(e[0], -0.01, 0.01))
    assert rows.n_in == 0 and list(rows.w_A) == [1.0]
    state = task.evaluate(cfg)
    assert state.error == pytest.approx(abs(e[0])) and state.satisfied is (abs(e[0]) <= 1e-4)
    J_fd = fd_jacobian(arm, q, task.compute_error)
    cfg.update(q)
    assert np.max(np.abs(J_fd - task.compute_jacobian(cfg))) < TOL
    result = pik_mj.solve(cfg, [[JointLimitTask.all_limited(cfg)], [task]], stop=60)
    assert result.converged
    assert abs(task.compute_error(cfg)[0]) <= 1e-4


# --------------------------------------------------------------------------- centroid

AXES = [True, "x", "y", "z", "xy", "yz", "zx"]


@pytest.mark.parametrize("axis", AXES)
@pytest.mark.parametrize(
    "frame", ["world", "rotation", "quaternion", "right_hand", "left_foot"], ids=str
)
def test_centroid_jacobian_fd_every_axis_and_frame(humanoid, axis, frame):
    q = random_posture(humanoid, 3)
    cfg = configured(humanoid, q)
    rot = mink.SO3.from_rpy_radians(0.3, -0.5, 1.1)
    option = {"rotation": rot.as_matrix(), "quaternion": rot.wxyz}.get(frame, frame)
    task = CentroidTask(cfg, [0.3, -0.2, 0.5], translation_axis=axis, frame=option)
    assert task.root_body_name == "torso"
    J_fd = fd_jacobian(humanoid, q, task.compute_error)
    cfg.update(q)
    J = task.compute_jacobian(cfg)
    assert J.shape == (3 - (0 if axis is True else len(axis)), humanoid.nv)
    assert np.max(np.abs(J_fd - J)) < TOL


@pytest.mark.parametrize("frame", ["world", "l3"])
def test_centroid_jacobian_fd_on_the_fixed_arm(arm, frame):
    q = np.array([0.4, -0.7, 1.1])
    cfg = configured(arm, q)
    task = CentroidTask(cfg, [0.0, 0.0, 0.1], translation_axis=True, frame=frame)
    assert task.root_body_name == "l1"
    J_fd = fd_jacobian(arm, q, task.compute_error)
    cfg.update(q)
    assert np.max(np.abs(J_fd - task.compute_jacobian(cfg))) < TOL


def test_centroid_counts_only_the_robot_in_a_scene():
    model = Robot.from_model("sample_humanoid", environment="room").model
    cfg = configured(model, model.qpos0.copy())
    task = CentroidTask(cfg, [0, 0, 0])
    root = task.root_body
    assert task.root_body_name == "pelvis"
    robot = [b for b in range(model.nbody) if model.body_rootid[b] == root]
    mass = model.body_mass[robot]
    brute = (mass[:, None] * cfg.data.xipos[robot]).sum(axis=0) / mass.sum()
    assert np.allclose(task.com(cfg), brute, atol=1e-12)
    assert mass.sum() == pytest.approx(58.5, rel=1e-6)
    # The world's subtree (kettle included) differs.
    assert np.linalg.norm(cfg.data.subtree_com[0] - brute) > 1e-3


def test_centroid_solve_matches_xy_leaves_z_free_and_clamps(arm):
    cfg = configured(arm, np.array([0.2, 0.3, -0.2]))
    c0 = CentroidTask(cfg, [0, 0, 0]).com(cfg)
    target = c0 + np.array([0.02, 0.0, -5.0])  # z is free (default axis "z")
    task = CentroidTask(cfg, target, p_limit=0.005)
    rows = task.compute_rows(cfg)
    assert rows.b.shape == (2,)
    assert np.linalg.norm(rows.b) == pytest.approx(0.005)  # clamped from 0.02
    result = pik_mj.solve(cfg, [[JointLimitTask.all_limited(cfg)], [task]], stop=50)
    assert result.converged
    c = task.com(cfg)
    assert np.linalg.norm(c[:2] - target[:2]) <= 1e-3
    assert abs(c[2] - target[2]) > 4.0


def test_centroid_offset_is_added(arm):
    cfg = configured(arm, np.zeros(3))
    offset = np.array([0.01, -0.02, 0.03])
    plain = CentroidTask(cfg, [0.1, 0.1, 0.1], translation_axis=True)
    shifted = CentroidTask(cfg, [0.1, 0.1, 0.1], translation_axis=True, com_offset=lambda c: offset)
    assert np.allclose(shifted.compute_error(cfg) - plain.compute_error(cfg), offset)
    assert "CentroidTask" in repr(shifted)


# ------------------------------------------------------------------------ virtual root


def test_virtual_root_reaches_a_target_the_fixed_arm_cannot(arm):
    target = np.array([0.5, 0.2, 0.1])

    def levels(cfg):
        reach = FrameTask(cfg, "end", (target, [1, 0, 0, 0]), rotation_axis=None)
        return [[JointLimitTask.all_limited(cfg)], [reach]]

    fixed = configured(arm, np.zeros(3))
    assert not pik_mj.solve(fixed, levels(fixed), stop=50).converged
    res = solve_with_virtual_root("three_dof_arm", None, levels, stop=50)
    assert res.solve.converged
    assert res.q.shape == (3,) and np.all(np.abs(res.q) <= arm.jnt_range[:, 1] + 1e-5)
    # Independent check: the fixed model at res.q, moved rigidly by the displacement.
    data = mujoco.MjData(arm)
    data.qpos[:] = res.q
    mujoco.mj_kinematics(arm, data)
    p = res.displacement.apply(data.site("end").xpos)
    assert np.linalg.norm(p - target) <= 1e-3
    # l1 sits at the origin of the fixed model, so the base pose is the displacement.
    assert np.allclose(res.base_pose.as_matrix(), res.displacement.as_matrix(), atol=1e-12)
    assert np.linalg.norm(res.base_pose.translation()) > 0.1


def test_virtual_root_wraps_a_jointed_top_body_and_maps_keyframes():
    xml = """
    <mujoco><worldbody>
      <body name="other" pos="1 0 0"><joint name="ofree" type="free"/>
        <geom size=".1"/></body>
      <body name="base" pos="0 0 0.5">
        <joint name="slide" type="slide" axis="1 0 0" range="-1 1"/>
        <geom size=".1" mass="1"/>
        <body name="l2" pos="0 0 .2"><joint name="h" axis="0 1 0"/>
          <geom size=".05" mass="0.2"/><site name="tip"/></body></body>
    </worldbody>
    <keyframe><key name="k" qpos="1 0 0 1 0 0 0 0.3 0.2"/></keyframe></mujoco>"""
    spec = mujoco.MjSpec.from_string(xml)
    fixed = spec.compile()
    model, info = with_virtual_root(spec, root_body="base")
    assert info.wrapped and model.nq == fixed.nq + 7
    q_fixed = fixed.key_qpos[0]
    assert np.allclose(info.to_fixed(model.key_qpos[0]), q_fixed)
    assert np.allclose(info.to_fixed(info.to_floating(q_fixed)), q_fixed)
    # Undisplaced: every body where the fixed model puts it.
    d_fixed, d_float = mujoco.MjData(fixed), mujoco.MjData(model)
    d_fixed.qpos[:], d_float.qpos[:] = q_fixed, info.to_floating(q_fixed)
    mujoco.mj_kinematics(fixed, d_fixed)
    mujoco.mj_kinematics(model, d_float)
    for body in ("other", "base", "l2"):
        assert np.allclose(d_fixed.body(body).xpos, d_float.body(body).xpos)
    # Moving the free joint moves the robot, not the other body.
    base = np.r_[0.1, 0.2, 0.3, np.cos(0.2), 0, 0, np.sin(0.2)]
    d_float.qpos[:] = info.to_floating(q_fixed, base)
    mujoco.mj_kinematics(model, d_float)
    X = info.displacement(d_float.qpos)
    assert np.allclose(d_float.site("tip").xpos, X.apply(d_fixed.site("tip").xpos))
    assert np.allclose(d_float.body("other").xpos, d_fixed.body("other").xpos)


# -------------------------------------------------------------------------- bad input


def test_bad_inputs_raise_clear_errors(arm, humanoid, ball_model):
    cfg = configured(arm, np.zeros(3))
    with pytest.raises(UnknownName, match="joint0"):
        JointLimitTask(cfg, "nope")
    with pytest.raises(InvalidInput, match="inverted"):
        JointLimitTask(cfg, "joint0", min_angle=0.5, max_angle=0.1)
    with pytest.raises(InvalidInput, match="NaN"):
        JointLimitTask(cfg, "joint0", min_angle=np.nan, max_angle=0.1)
    with pytest.raises(InvalidInput, match="one value per joint"):
        JointLimitTask(cfg, ["joint0", "joint1"], min_angle=[0, 0, 0], max_angle=1.0)
    with pytest.raises(InvalidInput, match="twice"):
        JointLimitTask(cfg, ["joint0", "joint0"])
    hcfg = configured(humanoid, humanoid.qpos0.copy())
    with pytest.raises(InvalidInput, match="free joint"):
        JointLimitTask(hcfg, "root")
    bcfg = configured(ball_model, ball_model.qpos0.copy())
    with pytest.raises(InvalidInput, match="cone"):
        JointLimitTask(bcfg, "ball", min_angle=-0.2, max_angle=0.5)
    with pytest.raises(InvalidInput, match="inverted"):
        JointVelocityTask(cfg, "joint0", max_vel=-1.0)
    with pytest.raises(InvalidInput, match="periodic_time"):
        JointVelocityTask(cfg, "joint0", max_vel=1.0, periodic_time=0.0)
    with pytest.raises(InvalidInput, match="degree of freedom"):
        JointVelocityTask(cfg, "joint0", max_vel=[1.0, 2.0])
    with pytest.raises(InvalidInput, match="both values"):
        JointCouplingTask(cfg, 0.1, 0.2)
    with pytest.raises(InvalidInput, match="ball"):
        JointCouplingTask(bcfg, "ball", 0.0)
    with pytest.raises(UnknownName, match="joint1"):
        JointCouplingTask(cfg, "joint0", "jointX")
    with pytest.raises(InvalidInput, match="finite"):
        JointCouplingTask(cfg, "joint0", "joint1", ratio=np.inf)
    with pytest.raises(InvalidInput, match="translation_axis"):
        CentroidTask(cfg, [0, 0, 0], translation_axis="w")
    with pytest.raises(InvalidInput, match="3 finite numbers"):
        CentroidTask(cfg, [0, 0, np.nan])
    with pytest.raises(InvalidInput, match="p_limit"):
        CentroidTask(cfg, [0, 0, 0], p_limit=-1.0)
    with pytest.raises(UnknownName, match="l1"):
        CentroidTask(cfg, [0, 0, 0], root_body="torso")
    with pytest.raises(InvalidInput, match="world body"):
        robot_root_body(arm, "world")
    with pytest.raises(InvalidInput, match="is not valid; use 'world', a frame name"):
        CentroidTask(cfg, [0, 0, 0], frame=np.ones((3, 3)))
    bad_offset = CentroidTask(cfg, [0, 0, 0], com_offset=lambda c: [1.0, 2.0])
    with pytest.raises(InvalidInput, match="com_offset"):
        bad_offset.compute_error(cfg)
    with pytest.raises(InvalidInput, match="already has a free joint"):
        with_virtual_root("dm_humanoid")
    with pytest.raises(InvalidInput, match="MjSpec"):
        with_virtual_root(arm)
    with pytest.raises(InvalidInput, match="already a joint"):
        with_virtual_root("three_dof_arm", joint_name="joint0")
    _, info = with_virtual_root("three_dof_arm")
    with pytest.raises(InvalidInput, match="nq"):
        info.to_floating(np.zeros(4))
