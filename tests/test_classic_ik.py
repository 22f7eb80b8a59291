"""irteus' classic IK (SR-inverse, Chan–Dubey weights, null space) and the look-at task.

References: the push-through identity and SVD bounds for the SR-inverse,
finite differences of H(θ) and of the gaze error, forward kinematics read back
from MuJoCo, and pik_mj's cascade on the same targets.
"""

from __future__ import annotations

import mink
import numpy as np
import pytest
from fd import fd_jacobian

from pik_mj import FrameTask, solve
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.ik.classic import (
    classic_inverse_kinematics,
    joint_limit_gradient,
    joint_limit_weights,
    manipulability,
    sr_damping,
    sr_inverse,
)
from pik_mj.robot import Robot
from pik_mj.robot.loading import load_model
from pik_mj.tasks.look_at import LookAtTask


def _arm():
    model = load_model("three_dof_arm")
    return model, mink.Configuration(model)


def _arm_targets(conf, n, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = conf.model.jnt_range[:, 0], conf.model.jnt_range[:, 1]
    out = []
    for _ in range(n):
        conf.update(rng.uniform(lo, hi))
        out.append(conf.get_transform_frame_to_world("end", "site"))
    return out


def _planar_task(conf, target, **kw):
    return FrameTask(conf, "end", target, translation_axis="y", rotation_axis="zx", **kw)


# --------------------------------------------------------------------- algebra


def test_sr_inverse_identities():
    rng = np.random.default_rng(1)
    J = rng.normal(size=(3, 5))
    winv = rng.uniform(0.2, 1.0, size=5)
    k = 0.05
    # Push-through: W⁻¹Jᵀ(JW⁻¹Jᵀ + kI)⁻¹ = (JᵀJ + kW)⁻¹Jᵀ.
    W = np.diag(1.0 / winv)
    np.testing.assert_allclose(
        sr_inverse(J, k, winv), np.linalg.solve(J.T @ J + k * W, J.T), atol=1e-12
    )
    # k = 0, W = I: the Moore–Penrose inverse.
    np.testing.assert_allclose(sr_inverse(J, 0.0), np.linalg.pinv(J), atol=1e-12)
    # Manipulability = product of the singular values.
    assert manipulability(J) == pytest.approx(np.prod(np.linalg.svd(J, compute_uv=False)))
    # Near a singularity the SR gain stays below 1/(2√k); the pseudo-inverse explodes.
    U, _, Vt = np.linalg.svd(rng.normal(size=(3, 3)))
    J_sing = U @ np.diag([1.0, 0.5, 1e-6]) @ Vt
    k = sr_damping(manipulability(J_sing))
    assert k == pytest.approx(0.001 * (1 - manipulability(J_sing) / 0.1) ** 2)
    assert np.linalg.norm(sr_inverse(J_sing, k), 2) <= 1.0 / (2.0 * np.sqrt(k)) + 1e-9
    assert np.linalg.norm(sr_inverse(J_sing, 0.0), 2) > 1e5
    assert sr_damping(0.2) == 0.0


def test_joint_limit_gradient_matches_finite_differences():
    lo, hi = np.array([-1.0, -2.0, 0.0]), np.array([1.0, 0.5, 2.5])

    def H(q):
        return np.sum((hi - lo) ** 2 / (4 * (hi - q) * (q - lo)))

    q = np.array([0.3, -1.5, 2.2])
    fd = np.array([(H(q + 1e-7 * e) - H(q - 1e-7 * e)) / 2e-7 for e in np.eye(3)])
    np.testing.assert_allclose(joint_limit_gradient(q, lo, hi), fd, rtol=1e-5)
    # Unlimited joints have no gradient; weights grow only while |∂H| grows.
    g = joint_limit_gradient(np.array([5.0]), np.array([-np.inf]), np.array([np.inf]))
    assert g[0] == 0.0
    w = joint_limit_weights(np.array([2.0, -3.0]), np.array([1.0, -4.0]), gain=1.0)
    np.testing.assert_allclose(w, [3.0, 1.0])


# --------------------------------------------------------------------- solver


def test_classic_converges_on_reachable_arm_targets_and_matches_cascade():
    model, conf = _arm()
    targets = _arm_targets(conf, 20)
    site = model.site("end").id
    ok_classic = ok_pik = 0
    for target in targets:
        conf.update(np.array([0.3, 0.3, 0.3]))
        res = classic_inverse_kinematics(conf, [_planar_task(conf, target)], stop=50)
        if res.converged:
            ok_classic += 1
            # Independent check: MuJoCo's forward kinematics of the returned q.
            data = conf.data
            assert np.linalg.norm(data.site_xpos[site] - target.translation()) <= 1e-3
            assert np.all(conf.q >= model.jnt_range[:, 0] - 1e-12)
            assert np.all(conf.q <= model.jnt_range[:, 1] + 1e-12)
            assert len(res.iteration_times) == res.iterations
        else:
            assert res.reverted and np.allclose(conf.q, 0.3)
        conf.update(np.array([0.3, 0.3, 0.3]))
        levels = [[mink.ConfigurationLimit(model)], [_planar_task(conf, target)]]
        ok_pik += solve(conf, levels, stop=50).converged
    print(f"classic {ok_classic}/20, pik_mj.solve {ok_pik}/20")
    assert ok_classic >= 16 and ok_pik >= 16


def test_weights_slow_a_joint_approaching_its_limit():
    """One row (z of the tip), three joints: W⁻¹ shifts motion away from joint0 near its limit."""
    _, conf = _arm()
    q0 = np.array([1.6, 0.0, 0.0])  # joint0 0.145 rad from its upper limit, arm horizontal
    conf.update(q0)
    p = conf.get_transform_frame_to_world("end", "site").translation()
    target = mink.SE3.from_translation(p + np.array([0.0, 0.0, -0.03]))  # down: joint0 +
    moves = {}
    for gain in (0.0, 1.0):
        conf.update(q0)
        task = FrameTask(
            conf,
            "end",
            target,
            translation_axis="xy",
            rotation_axis=None,
            translation_frame="world",
        )
        classic_inverse_kinematics(
            conf,
            [task],
            stop=1,
            avoid_weight_gain=gain,
            avoid_nspace_gain=0.0,
            revert_if_fail=False,
        )
        moves[gain] = conf.q - q0
    # The weighted step moves joint0 (towards its limit) less.
    assert moves[1.0][0] > 0 and moves[0.0][0] > 0
    assert moves[1.0][0] < 0.5 * moves[0.0][0]


def test_null_space_term_moves_joints_towards_range_middle():
    model, conf = _arm()
    lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)

    def V(q):  # z = −g W⁻¹ ∇V: the potential the seed's null-space term descends
        return np.sum(half * np.abs((q - mid) / half) ** 3 / 3.0)

    q0 = np.array([1.4, -1.3, 1.2])
    conf.update(q0)
    target = conf.get_transform_frame_to_world("end", "site")
    finals = {}
    # k = 0 (pseudo-inverse): I − J#J is an exact projector. With the SR damping
    # k > 0 the null-space term leaks into the task (J(I − J#J)z = k(JW⁻¹Jᵀ+kI)⁻¹Jz).
    values: list[float] = []
    for gain in (0.0, 0.5):
        conf.update(q0)
        values.clear()
        values.append(V(q0))
        task = FrameTask(conf, "end", target, translation_axis="y", rotation_axis=None)
        res = classic_inverse_kinematics(
            conf,
            [task],
            stop=40,
            min_loop=40,
            avoid_nspace_gain=gain,
            method="pseudo-inverse",
            callback=lambda info: values.append(V(info.configuration.q)),
        )
        assert res.converged and res.iterations == 40
        finals[gain] = conf.q.copy()
    assert np.allclose(finals[0.0], q0, atol=1e-9)  # nothing to do, nothing done
    # Projected descent: V falls every iteration while the task stays solved.
    assert np.all(np.diff(values) < 1e-12) and values[-1] < values[0] - 0.1
    assert np.max(np.abs(finals[0.5] - q0)) > 0.1


def test_bad_input():
    _, conf = _arm()
    target = conf.get_transform_frame_to_world("end", "site")
    with pytest.raises(InvalidInput, match="method"):
        classic_inverse_kinematics(conf, [("end", target)], method="jacobian-transpose")
    with pytest.raises(UnknownName, match="joint7"):
        classic_inverse_kinematics(conf, [("end", target)], joints=["joint7"])
    with pytest.raises(InvalidInput):
        classic_inverse_kinematics(conf, [])
    with pytest.raises(UnknownName):
        classic_inverse_kinematics(conf, [("tip", target)])


# --------------------------------------------------------------------- look-at


@pytest.mark.parametrize("target", [np.array([1.0, -0.6, 1.8]), "rarm_end"])
def test_look_at_jacobian_finite_differences(target):
    robot = Robot.from_model("sample_humanoid")
    robot.reset_pose()
    robot.set_angle_vector(
        [0.3, -0.2, -0.9, -0.4], ["head_neck_y", "head_neck_p", "rarm_shoulder_p", "rarm_elbow_p"]
    )
    conf = robot.configuration
    task = LookAtTask(conf, "head_end", target)
    J = task.compute_jacobian(conf)
    np.testing.assert_allclose(
        J, fd_jacobian(conf.model, conf.q, task.compute_error, configuration=conf), atol=2e-5
    )
    assert np.linalg.matrix_rank(J, tol=1e-6) == 2  # the gaze has two degrees of freedom


def test_look_at_converges_to_a_point():
    robot = Robot.from_model("sample_humanoid")
    robot.reset_pose()
    conf = robot.configuration
    point = np.array([1.5, 0.8, 0.6])
    joints = ["head_neck_y", "head_neck_p", "torso_waist_y", "torso_waist_p"]
    dofs = [robot.model.jnt_dofadr[robot.model.joint(j).id] for j in joints]
    task = LookAtTask(conf, "head_end", point, rthre=np.deg2rad(0.5))
    assert task.angle(conf) > np.deg2rad(30)
    # Only the neck and the waist move (irteus: the head's link list).
    fixed = np.delete(np.eye(robot.model.nv), dofs, axis=0)
    from pik_mj import LinearTask

    hold = LinearTask(fixed, np.zeros(len(fixed)), name="others fixed")
    res = solve(conf, [[mink.ConfigurationLimit(robot.model), hold], [task]], stop=50)
    assert res.converged, res.summary()
    # Independent check: the site's x axis points at the point.
    site = robot.model.site("head_end").id
    x_axis = robot.data.site_xmat[site].reshape(3, 3)[:, 0]
    to_point = point - robot.data.site_xpos[site]
    cos = x_axis @ to_point / np.linalg.norm(to_point)
    assert cos >= np.cos(np.deg2rad(0.5))
    assert np.allclose(
        np.delete(conf.q[7:], np.array(dofs) - 6),
        np.delete(robot.model.key("reset_pose").qpos[7:], np.array(dofs) - 6),
        atol=1e-6,
    )
    with pytest.raises(InvalidInput):
        LookAtTask(conf, "head_end", point, axis=(0, 0, 0))
    with pytest.raises(UnknownName):
        LookAtTask(conf, "head_endd", point)


def test_interlocking_joints_move_together():
    _, conf = _arm()
    conf.update(np.array([0.3, 0.5, 0.5]))
    target = conf.get_transform_frame_to_world("end", "site")
    conf.update(np.array([0.0, 0.1, -0.2]))  # mismatched pair at the start
    task = FrameTask(conf, "end", target, translation_axis="y", rotation_axis=None)
    res = classic_inverse_kinematics(
        conf, [task], stop=100, interlocking_pairs=[("joint1", "joint2")]
    )
    assert res.converged
    assert conf.q[1] == pytest.approx(conf.q[2], abs=1e-4)
    with pytest.raises(UnknownName):
        classic_inverse_kinematics(conf, [task], interlocking_pairs=[("joint1", "joint9")])
