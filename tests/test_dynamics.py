"""Statics and inverse dynamics against independent formulations.

Independent references: MuJoCo forward dynamics (``mj_forward`` with the
computed torques and the wrenches applied through ``xfrc_applied``),
``mj_rne``, hand-written planar statics of the 3-DoF arm, explicit moment
balances, and the cart-table ZMP of a rigidly translated body.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from pik_mj import dynamics as dy
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.loading import load_model, load_spec

G = 9.81
SOLES = [dy.SoleContact("rleg_end", 0.11, 0.06), dy.SoleContact("lleg_end", 0.11, 0.06)]


def _humanoid_pose() -> Robot:
    """An asymmetric standing pose: both soles flat on z = 0, arms and waist moved."""
    robot = Robot.from_model("sample_humanoid")
    robot.reset_pose()
    robot.set_angle_vector(
        [-0.9, -0.5, 0.3, -0.8, 0.2, 0.3, 0.1, 1.5],
        [f"rarm_{j}" for j in ("shoulder_p", "shoulder_r", "shoulder_y", "elbow_p")]
        + ["torso_waist_p", "torso_waist_y", "head_neck_y", "larm_shoulder_r"],
    )
    return robot


def _xfrc(model, data, body: int, point: np.ndarray, w: np.ndarray) -> np.ndarray:
    """A wrench (f, n about ``point``) as MuJoCo's xfrc_applied (about the body CoM)."""
    f, n = w[:3], w[3:]
    return np.concatenate([f, n + np.cross(point - data.xipos[body], f)])


def _forward_qacc(model, q, qvel, qfrc, xfrc: dict[int, np.ndarray]) -> np.ndarray:
    data = mujoco.MjData(model)
    data.qpos[:] = q
    data.qvel[:] = qvel
    data.qfrc_applied[:] = qfrc
    for b, w in xfrc.items():
        data.xfrc_applied[b] += w
    mujoco.mj_forward(model, data)
    return data.qacc.copy()


def test_static_torques_match_rne_and_forward_dynamics():
    robot = _humanoid_pose()
    model, q = robot.model, robot.configuration.q.copy()
    data = mujoco.MjData(model)
    st = dy.static_torques(model, data, q, SOLES)

    # Independent g(q): mj_rne with zero velocity, bias only.
    ref = mujoco.MjData(model)
    ref.qpos[:] = q
    mujoco.mj_forward(model, ref)
    g = np.zeros(model.nv)
    mujoco.mj_rne(model, ref, 0, g)
    np.testing.assert_allclose(st.gravity, g, atol=1e-9)

    # Independent contact Jacobians from mj_jacSite.
    J_c = []
    for name in ("rleg_end", "lleg_end"):
        jp, jr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacSite(model, ref, jp, jr, model.site(name).id)
        J_c.append(np.vstack([jp, jr]))
    J_c = np.vstack(J_c)
    f = st.wrenches.reshape(-1)
    np.testing.assert_allclose(st.tau, g - J_c.T @ f, atol=1e-9)
    # Root rows balance, joint rows are what the motors hold.
    assert np.max(np.abs(st.tau[:6])) < 1e-6
    assert np.max(np.abs(st.tau[6:])) > 1.0
    # Total vertical force carries the weight; each CoP inside its sole.
    assert st.wrenches[:, 2].sum() == pytest.approx(robot.mass * G, rel=1e-9)
    for contact, cop in zip(SOLES, st.cops, strict=True):
        site = model.site(contact.frame).id
        local = ref.site_xmat[site].reshape(3, 3).T @ (cop - ref.site_xpos[site])
        assert abs(local[0]) <= contact.half_x + 1e-9
        assert abs(local[1]) <= contact.half_y + 1e-9
    # The asymmetric pose loads the feet unequally (the split is not trivial).
    assert abs(st.wrenches[0, 2] - st.wrenches[1, 2]) > 1.0

    # Forward dynamics with these torques and contact wrenches: the pose holds.
    xfrc = {}
    for i, name in enumerate(("rleg_end", "lleg_end")):
        b = int(model.site_bodyid[model.site(name).id])
        xfrc[b] = _xfrc(model, ref, b, ref.site_xpos[model.site(name).id], st.wrenches[i])
    qacc = _forward_qacc(model, q, np.zeros(model.nv), st.tau, xfrc)
    assert np.max(np.abs(qacc)) < 1e-6


def test_joint_torques_dynamic_with_external_wrench_forward_check():
    """τ from mj_inverse − Jᵀw, fed to mj_forward with w in xfrc_applied, gives qacc back."""
    robot = _humanoid_pose()
    model, q = robot.model, robot.configuration.q.copy()
    rng = np.random.default_rng(3)
    qvel, qacc = rng.normal(size=model.nv), rng.normal(size=model.nv)
    w = np.array([12.0, -5.0, 30.0, 1.5, -2.0, 0.7])
    data = mujoco.MjData(model)
    tau = dy.joint_torques(model, data, q, qvel, qacc, [("rarm_end", w[:3], w[3:])])
    site = model.site("rarm_end").id
    b = int(model.site_bodyid[site])
    xfrc = {b: _xfrc(model, data, b, data.site_xpos[site], w)}
    back = _forward_qacc(model, q, qvel, tau, xfrc)
    np.testing.assert_allclose(back, qacc, atol=1e-7)


def _arm_statics_by_hand(q: np.ndarray, F: np.ndarray, gravity: bool) -> np.ndarray:
    """Torques of the planar 3-DoF arm (hinges about y) holding F at the tip."""
    # Joint anchors and link directions in the xz-plane; rotation about y by θ
    # turns the z axis into (sin θ, 0, cos θ).
    lengths = [0.1, 0.1, 0.02]
    masses = [0.1, 0.1, 0.02]
    p = np.array([0.0, 0.0, 0.02])
    joints, coms = [], []
    theta = 0.0
    for qi, L in zip(q, lengths, strict=True):
        theta += qi
        u = np.array([math.sin(theta), 0.0, math.cos(theta)])
        joints.append(p.copy())
        coms.append(p + 0.5 * L * u)
        p = p + L * u
    tip = p
    tau = np.zeros(3)
    for i, p_i in enumerate(joints):
        # Torque the motor must give = minus the moment of the loads about the axis.
        moment = np.cross(tip - p_i, F)
        if gravity:
            for k in range(i, 3):
                moment += np.cross(coms[k] - p_i, np.array([0.0, 0.0, -masses[k] * G]))
        tau[i] = -moment[1]
    return tau


@pytest.mark.parametrize("gravity", [False, True])
def test_three_dof_arm_external_force_vs_hand_statics(gravity):
    model = load_model("three_dof_arm")
    if not gravity:
        model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    F = np.array([3.0, 0.0, -7.0])
    for q in ([0.3, -0.6, 0.9], [-1.2, 0.4, 0.2], [0.0, 0.0, 0.0]):
        q = np.array(q)
        tau = dy.joint_torques(model, data, q, external=[("end", F, np.zeros(3))])
        np.testing.assert_allclose(tau, _arm_statics_by_hand(q, F, gravity), atol=1e-9)


def test_force_from_joint_torque_recovers_tip_force():
    model = load_model("three_dof_arm")
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    q = np.array([0.3, -0.6, 0.9])
    F_ext = np.array([3.0, 0.0, -7.0])  # acting on the robot
    tau = dy.joint_torques(model, data, q, external=[("end", F_ext, np.zeros(3))])
    jp, jr = np.zeros((3, 3)), np.zeros((3, 3))
    mujoco.mj_jacSite(model, data, jp, jr, model.site("end").id)
    w = dy.force_from_joint_torque(np.vstack([jp, jr]), tau)
    # The tip pushes the environment with −F_ext.
    np.testing.assert_allclose(w, np.concatenate([-F_ext, np.zeros(3)]), atol=1e-9)
    # Redundant case (6x7 humanoid arm): (J Jᵀ)⁻¹ J τ returns the exact wrench.
    robot = _humanoid_pose()
    arm = robot.limb("rarm")
    dofs = [robot.model.jnt_dofadr[robot.model.joint(j).id] for j in arm.joints]
    jp, jr = np.zeros((3, robot.model.nv)), np.zeros((3, robot.model.nv))
    mujoco.mj_jacSite(robot.model, robot.data, jp, jr, robot.model.site("rarm_end").id)
    J = np.vstack([jp, jr])[:, dofs]
    w_true = np.array([4.0, -2.0, 9.0, 0.3, -0.1, 0.2])
    np.testing.assert_allclose(dy.force_from_joint_torque(J, J.T @ w_true), w_true, atol=1e-9)
    with pytest.raises(InvalidInput):
        dy.force_from_joint_torque(J[:3], J.T @ w_true)


def _moment_balance_residual(mass, com, forces, moments, points, s) -> np.ndarray:
    """Horizontal moment about s of gravity, the externals and the ground reaction."""
    # The ground reaction −(m g + Σ f) acts at s: no moment about s, so the rest
    # must have none either (the reaction's own horizontal moment is zero at the ZMP).
    gvec = np.array([0.0, 0.0, -mass * G])
    moment = np.cross(com - s, gvec)
    for f, n, p in zip(forces, moments, points, strict=True):
        moment += np.cross(p - s, f) + n
    return moment[:2]


def test_static_balance_point_moment_balance_and_inverse_dynamics():
    robot = _humanoid_pose()
    model, q = robot.model, robot.configuration.q.copy()
    com = robot.com()
    points = np.array([robot.data.site("rarm_end").xpos, robot.data.site("larm_end").xpos])
    forces = np.array([[-20.0, 5.0, -15.0], [8.0, -3.0, 10.0]])
    moments = np.array([[0.5, -1.0, 0.2], [0.0, 0.8, -0.3]])
    s = dy.static_balance_point(robot.mass, com, forces, moments, points, z=0.0)
    # Without externals: the CoM projection.
    s0 = dy.static_balance_point(robot.mass, com, np.zeros((0, 3)), (), np.zeros((0, 3)))
    np.testing.assert_allclose(s0, [com[0], com[1], 0.0], atol=1e-12)
    assert np.linalg.norm(s[:2] - s0[:2]) > 0.01  # the externals move it
    # Independent 1: the horizontal moment about s vanishes.
    res = _moment_balance_residual(robot.mass, com, forces, moments, points, s)
    np.testing.assert_allclose(res, 0.0, atol=1e-9)
    # Independent 2: MuJoCo's inverse dynamics of the floating base, wrenches at the hands.
    external = [
        ("rarm_end", forces[0], moments[0]),
        ("larm_end", forces[1], moments[1]),
    ]
    data = mujoco.MjData(model)
    zmp = dy.zmp_from_inverse_dynamics(model, data, q, external=external)
    np.testing.assert_allclose(zmp, s[:2], atol=1e-9)
    # Height matters: at z = 0.3 a horizontal force has a shorter lever.
    s_high = dy.static_balance_point(robot.mass, com, forces, moments, points, z=0.3)
    res = _moment_balance_residual(robot.mass, com, forces, moments, points, s_high)
    np.testing.assert_allclose(res, 0.0, atol=1e-9)
    with pytest.raises(PikError):
        dy.static_balance_point(1.0, com, [[0.0, 0.0, 20.0]], (), [[0.0, 0.0, 1.0]])


def test_zmp_static_and_translational_acceleration():
    robot = _humanoid_pose()
    model, q0 = robot.model, robot.configuration.q.copy()
    com = robot.com()
    data = mujoco.MjData(model)
    np.testing.assert_allclose(dy.zmp_from_inverse_dynamics(model, data, q0), com[:2], atol=1e-9)
    # Rigid translation with constant acceleration a: no angular momentum change,
    # so the cart-table relation is exact: s = c_xy − (c_z − z) a_xy / (g + a_z).
    a = np.array([0.8, -0.5, 0.3])
    dt, T = 0.01, 7
    qs = np.repeat(q0[None], T, axis=0)
    t = dt * np.arange(T)
    qs[:, :3] = q0[:3] + 0.5 * np.outer(t**2, a)
    zmps = dy.zmp_of_motion(model, qs, dt)
    assert zmps.shape == (T, 2)
    for k in range(T):
        c = com + qs[k, :3] - q0[:3]
        expected = c[:2] - c[2] * a[:2] / (G + a[2])
        np.testing.assert_allclose(zmps[k], expected, atol=1e-7)
    # Moving the plane: z = 0.1 shortens the lever.
    qacc = np.zeros(model.nv)
    qacc[:3] = a
    s = dy.zmp_from_inverse_dynamics(model, data, q0, 0.0, qacc, z=0.1)
    np.testing.assert_allclose(s, com[:2] - (com[2] - 0.1) * a[:2] / (G + a[2]), atol=1e-9)
    # Free fall: the ground cannot pull.
    qacc[:3] = [0.0, 0.0, -2 * G]
    with pytest.raises(PikError, match="ZMP is undefined"):
        dy.zmp_from_inverse_dynamics(model, data, q0, 0.0, qacc)


def test_torque_ratio_limits_sources():
    spec = load_spec("three_dof_arm")
    spec.joint("joint0").actfrcrange = [-4.0, 4.0]
    spec.joint("joint0").actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act = spec.add_actuator(name="m1", target="joint1", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.gear[0] = 2.0
    act.forcerange = [-1.5, 1.5]
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    model = spec.compile()
    np.testing.assert_allclose(dy.torque_limits(model), [4.0, 3.0, 100.0])
    np.testing.assert_allclose(dy.torque_ratio(model, [2.0, -3.0, 50.0]), [0.5, -1.0, 0.5])
    np.testing.assert_allclose(
        dy.torque_ratio(model, [2.0, -3.0, 50.0], {"joint2": 25.0}), [0.5, -1.0, 2.0]
    )
    with pytest.raises(UnknownName, match="joint2"):
        dy.torque_ratio(model, [0.0, 0.0, 0.0], {"joint9": 1.0})
    ratio = dy.torque_ratio(load_model("sample_humanoid"), np.ones(36))
    assert np.all(np.isnan(ratio[:6])) and np.allclose(ratio[6:], 0.01)


def test_static_torques_infeasible_and_bad_input():
    robot = _humanoid_pose()
    model, q = robot.model, robot.configuration.q.copy()
    data = mujoco.MjData(model)
    # A pull of 300 N forward at the hand cannot be held with μ = 0.5 soles.
    with pytest.raises(PikError, match="no contact wrenches"):
        dy.static_torques(model, data, q, SOLES, [("rarm_end", [300.0, 0, 0], [0, 0, 0])])
    with pytest.raises(UnknownName):
        dy.static_torques(model, data, q, [dy.SoleContact("nope", 0.1, 0.1)])
    with pytest.raises(InvalidInput):
        dy.joint_torques(model, data, q[:5])
    with pytest.raises(InvalidInput):
        dy.zmp_of_motion(model, q[None], 0.01)
