"""FrameTask (seed move-target-task): Jacobian against finite differences for every
axis selection and error frame, fixed and moving targets, floating and fixed base."""

from __future__ import annotations

import itertools

import mink
import mujoco
import numpy as np
import pytest
from fd import fd_jacobian

from pik_mj import FrameTask, InvalidInput
from pik_mj.robot.loading import load_model
from pik_mj.tasks.frame import constrained_axes, ljacinv
from pik_mj.tasks.twist import twist_distances

TRANSLATION_AXES = [True, "x", "y", "z", "xy", "yz", "zx", None]
ROTATION_AXES = [True, "x", "y", "z", None]


@pytest.fixture(scope="module")
def humanoid_cfg():
    model = load_model("dm_humanoid")
    cfg = mink.Configuration(model)
    rng = np.random.default_rng(0)
    q = cfg.q.copy()
    quat = rng.normal(size=4)  # (seeded: SO3.sample_uniform draws from numpy's global state)
    q[3:7] = quat / np.linalg.norm(quat)
    q[7:] += rng.normal(0, 0.3, model.nq - 7)
    cfg.update(q)
    return cfg


FRAMES = ["local", "world", np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])]


@pytest.mark.parametrize("frame", range(len(FRAMES)))
@pytest.mark.parametrize("relative", [False, True])
@pytest.mark.parametrize("error_type", [None, "split"])
def test_jacobian_matches_finite_differences_all_options(humanoid_cfg, frame, relative, error_type):
    """Every axis selection and frame, fixed and robot-frame targets; the
    default error (the twist for the whole local pose) and the split one."""
    cfg = humanoid_cfg
    target = (
        "left_hand"
        if relative
        else mink.SE3.from_rotation_and_translation(
            mink.SO3.from_rpy_radians(0.3, -0.2, 1.0), np.array([0.4, -0.3, 1.1])
        )
    )
    worst = 0.0
    for t_axis, r_axis in itertools.product(TRANSLATION_AXES, ROTATION_AXES):
        if t_axis is None and r_axis is None:
            continue
        task = FrameTask(
            cfg,
            "right_hand",
            target,
            translation_axis=t_axis,
            rotation_axis=r_axis,
            translation_frame=FRAMES[frame],
            rotation_frame=FRAMES[frame],
            error_type=error_type,
        )
        J = task.compute_jacobian(cfg)
        assert J.shape == (
            len(constrained_axes(t_axis, "t")) + len(constrained_axes(r_axis, "r")),
            27,
        )
        worst = max(
            worst,
            float(
                np.abs(
                    J - fd_jacobian(cfg.model, cfg.q, task.compute_error, configuration=cfg)
                ).max()
            ),
        )
    assert worst < 1e-6, worst


def test_jacobian_on_fixed_base_arm():
    model = load_model("three_dof_arm")
    cfg = mink.Configuration(model)
    cfg.update(np.array([0.3, -0.5, 0.8]))
    task = FrameTask(cfg, "end", (np.array([0.1, 0.0, 0.1]), np.array([1.0, 0, 0, 0])))
    np.testing.assert_allclose(
        task.compute_jacobian(cfg),
        fd_jacobian(cfg.model, cfg.q, task.compute_error, configuration=cfg),
        atol=1e-6,
    )


def test_rows_are_clamped_to_p_limit_and_r_limit(humanoid_cfg):
    cfg = humanoid_cfg
    far = mink.SE3.from_rotation_and_translation(
        mink.SO3.from_x_radians(2.5), np.array([3.0, 0, 0])
    )
    task = FrameTask(cfg, "right_hand", far, p_limit=0.05, r_limit=0.2)
    rows = task.compute_rows(cfg)
    assert np.linalg.norm(rows.b[:3]) == pytest.approx(0.05)
    assert np.linalg.norm(rows.b[3:]) == pytest.approx(0.2)
    # The stop test uses the unclamped error.
    assert np.linalg.norm(task.compute_error(cfg)[:3]) > 1.0 and not task.is_satisfied(cfg)


def test_irteus_axis_convention_names_free_axes():
    np.testing.assert_array_equal(constrained_axes("z", "t"), [0, 1])
    np.testing.assert_array_equal(constrained_axes("xy", "t"), [2])
    np.testing.assert_array_equal(constrained_axes(True, "t"), [0, 1, 2])
    assert constrained_axes(None, "t").size == 0
    with pytest.raises(InvalidInput, match="translation_axis"):
        FrameTask(
            mink.Configuration(load_model("three_dof_arm")),
            "end",
            mink.SE3.identity(),
            translation_axis="w",
        )


def test_ljacinv_closed_form_matches_mink_and_is_finite_at_zero():
    rng = np.random.default_rng(1)
    for e in rng.normal(0, 1, (50, 3)):
        np.testing.assert_allclose(ljacinv(e), mink.SO3.ljacinv(e), atol=1e-12)
    np.testing.assert_allclose(ljacinv(np.zeros(3)), np.eye(3))


def test_per_axis_thresholds(humanoid_cfg):
    cfg = humanoid_cfg
    pose = cfg.get_transform_frame_to_world("right_hand", "body")
    offset = mink.SE3.from_translation(np.array([0.0, 0.0, 0.002])) @ pose
    loose_z = FrameTask(
        cfg, "right_hand", offset, translation_frame="world", thre=np.array([1e-3, 1e-3, 5e-3])
    )
    tight = FrameTask(cfg, "right_hand", offset, translation_frame="world", thre=1e-3)
    assert loose_z.is_satisfied(cfg) and not tight.is_satisfied(cfg)


def default_case_targets(cfg, frame_type):
    """``(name, here, near, cases)``: a body, site or geom of the humanoid, its
    pose, a pose within 1 mm / 1 degree of it, and ``(target, limits)`` cases:
    a far fixed pose, clamped and not, the same as a callable, and the near one."""
    model = cfg.model
    name = {"body": "right_hand", "site": model.site(0).name, "geom": model.geom(5).name}[
        frame_type
    ]
    pose = mink.SE3.from_rotation_and_translation(
        mink.SO3.from_rpy_radians(0.3, -0.2, 1.9), np.array([0.4, -0.3, 1.1])
    )
    here = cfg.get_transform_frame_to_world(name, frame_type)
    # within 1 mm / 1 degree; not much closer: mink's closed-form ljacinv loses
    # digits at small angles (1.5e-11 off at 1e-3 rad, 6e-14 at 0.015)
    near = here @ mink.SE3.from_rotation_and_translation(
        mink.SO3.from_x_radians(0.015), np.array([2e-4, 0.0, -3e-4])
    )
    cases = [
        (pose, {}),
        (pose, {"p_limit": 0.05, "r_limit": 0.2}),
        (lambda c: pose, {}),
        (near, {}),
    ]
    return name, here, near, cases


def clamped_rows_b(e, limits):
    """``-e`` with its translation and rotation clamped to ``p_limit``/``r_limit``."""
    b = -e.copy()
    for part, limit in ((b[:3], limits.get("p_limit")), (b[3:], limits.get("r_limit"))):
        if limit is not None and np.linalg.norm(part) > limit:
            part *= limit / np.linalg.norm(part)
    return b


@pytest.mark.parametrize("frame_type", ["body", "site", "geom"])
def test_split_rows_match_the_module_formulas_written_with_mink(humanoid_cfg, frame_type):
    """The split error of the whole pose in the move target's frame is computed
    on Python floats and MuJoCo's Jacobian of the target point; here the module
    formulas with mink's SO(3) (log, ljacinv) and MuJoCo's frame Jacobian: the
    rows, error norm and stop test agree to rounding, for a fixed and a
    callable target, clamped and not, and a target reached within tolerance."""
    cfg = humanoid_cfg
    model, data = cfg.model, cfg.data
    name, _, near, cases = default_case_targets(cfg, frame_type)
    for target, limits in cases:
        task = FrameTask(
            cfg, name, target, move_target_type=frame_type, error_type="split", **limits
        )
        state = task.evaluate(cfg)
        p, R = {
            "body": (data.xpos, data.xmat),
            "site": (data.site_xpos, data.site_xmat),
            "geom": (data.geom_xpos, data.geom_xmat),
        }[frame_type]
        p_WM, R_WM = p[task.move_target.id], R[task.move_target.id].reshape(3, 3)
        goal = target(cfg) if callable(target) else target
        e_tW = p_WM - goal.translation()
        e_rW = (mink.SO3.from_matrix(R_WM) @ goal.rotation().inverse()).log()
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        {"body": mujoco.mj_jacBody, "site": mujoco.mj_jacSite, "geom": mujoco.mj_jacGeom}[
            frame_type
        ](model, data, jacp, jacr, task.move_target.id)
        skew = np.array(
            [[0.0, -e_tW[2], e_tW[1]], [e_tW[2], 0.0, -e_tW[0]], [-e_tW[1], e_tW[0], 0.0]]
        )
        J = np.vstack(
            [R_WM.T @ (jacp + skew @ jacr), R_WM.T @ mink.SO3.ljacinv(-e_rW) @ jacr]
            if np.linalg.norm(e_rW) > 0
            else [R_WM.T @ (jacp + skew @ jacr), R_WM.T @ jacr]
        )
        e = np.concatenate([R_WM.T @ e_tW, R_WM.T @ e_rW])
        b = clamped_rows_b(e, limits)
        np.testing.assert_allclose(state.rows.A, J, rtol=0, atol=1e-12)
        np.testing.assert_allclose(state.rows.b, b, rtol=0, atol=1e-14)
        assert state.error == pytest.approx(np.linalg.norm(e), rel=1e-13)
        satisfied = np.linalg.norm(e[:3]) <= 1e-3 and np.linalg.norm(e[3:]) <= np.deg2rad(1)
        assert state.satisfied == satisfied
        assert satisfied == (target is near)
        np.testing.assert_allclose(task.compute_error(cfg), e, rtol=0, atol=1e-14)


@pytest.mark.parametrize("frame_type", ["body", "site", "geom"])
def test_twist_rows_are_mink_frame_tasks_and_the_stop_test_reads_the_split_error(
    humanoid_cfg, frame_type
):
    """The default rows of a whole pose are mink's ``FrameTask`` rows with the
    sign of ``log(T_WT⁻¹ T_WM)`` (mink's error is ``log(T_WM⁻¹ T_WT)``); the
    error norm and the stop test are the split error's (the distance between
    the origins, the rotation angle), for a fixed and a callable target,
    clamped and not, and a target reached within tolerance."""
    cfg = humanoid_cfg
    name, here, near, cases = default_case_targets(cfg, frame_type)
    pose = cases[0][0]
    for target, limits in cases:
        task = FrameTask(cfg, name, target, move_target_type=frame_type, **limits)
        assert task.error_type == "twist"
        goal = target(cfg) if callable(target) else target
        reference = mink.FrameTask(name, frame_type, position_cost=1.0, orientation_cost=1.0)
        reference.set_target(goal)
        e, J = -reference.compute_error(cfg), -reference.compute_jacobian(cfg)
        state = task.evaluate(cfg)
        b = clamped_rows_b(e, limits)
        # (the task hands mink its target as a matrix: rounding of the quaternion)
        np.testing.assert_allclose(state.rows.A, J, rtol=0, atol=1e-12)
        np.testing.assert_allclose(state.rows.b, b, rtol=0, atol=1e-12)
        np.testing.assert_allclose(task.compute_error(cfg), e, rtol=0, atol=1e-12)
        # the twist's rotation is the split's; its translation is not the distance
        split = FrameTask(cfg, name, target, move_target_type=frame_type, error_type="split")
        e_split = split.compute_error(cfg)
        np.testing.assert_allclose(task.pose_error(cfg), e_split, rtol=0, atol=1e-14)
        np.testing.assert_allclose(e[3:], e_split[3:], rtol=0, atol=1e-14)
        distance = np.linalg.norm(goal.translation() - here.translation())
        assert np.linalg.norm(e_split[:3]) == pytest.approx(distance, rel=1e-12)
        if target is pose:
            assert abs(np.linalg.norm(e[:3]) - distance) > 1e-2
        assert state.error == pytest.approx(np.linalg.norm(e_split), rel=1e-12)
        n_t, n_r = np.linalg.norm(e_split[:3]), np.linalg.norm(e_split[3:])
        satisfied = n_t <= 1e-3 and n_r <= np.deg2rad(1)
        assert state.satisfied == satisfied == task.is_satisfied(cfg) == (target is near)


def test_twist_toward_a_robot_frame_is_minks_relative_frame_task(humanoid_cfg):
    """With another robot frame as the target (both move), the twist rows are
    mink's ``RelativeFrameTask`` rows toward the identity, same sign."""
    cfg = humanoid_cfg
    task = FrameTask(cfg, "right_hand", "left_hand", move_target_type="body", target_type="body")
    reference = mink.RelativeFrameTask("right_hand", "body", "left_hand", "body", 1.0, 1.0)
    reference.set_target(mink.SE3.identity())
    e, J = task.error_and_jacobian(cfg)
    np.testing.assert_allclose(e, reference.compute_error(cfg), rtol=0, atol=1e-14)
    np.testing.assert_allclose(J, reference.compute_jacobian(cfg), rtol=0, atol=1e-14)
    state = task.evaluate(cfg)
    split = FrameTask(cfg, "right_hand", "left_hand", error_type="split").compute_error(cfg)
    assert state.error == pytest.approx(np.linalg.norm(split), rel=1e-12)
    # a new target frame: the rows follow it
    task.set_target("head", "body")
    reference = mink.RelativeFrameTask("right_hand", "body", "head", "body", 1.0, 1.0)
    reference.set_target(mink.SE3.identity())
    np.testing.assert_allclose(task.compute_error(cfg), reference.compute_error(cfg), atol=1e-14)


def test_twist_distances_match_the_split_error_at_any_angle():
    """``twist_distances`` turns ``(ρ, φ)`` back into the distance between the
    origins and the angle, on both sides of its series (1e-2 rad) and near π."""
    rng = np.random.default_rng(3)
    for angle in (0.0, 1e-7, 3e-3, 9.9e-3, 1.01e-2, 0.4, 2.0, np.pi - 1e-6):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        p = rng.normal(size=3)
        T = mink.SE3.from_rotation_and_translation(mink.SO3.exp(angle * axis), p)
        twist = T.log()
        n_t, n_r = twist_distances(*twist.tolist())
        assert n_t == pytest.approx(np.linalg.norm(p), rel=1e-12)
        assert n_r == pytest.approx(angle, rel=1e-12, abs=1e-15)


def test_error_type_is_checked_and_defaults_to_split_where_the_twist_does_not_apply(
    humanoid_cfg,
):
    cfg = humanoid_cfg
    pose = (np.array([0.4, -0.3, 1.1]), np.array([1.0, 0.0, 0.0, 0.0]))
    assert FrameTask(cfg, "right_hand", pose).error_type == "twist"
    assert FrameTask(cfg, "right_hand", pose, translation_axis="z").error_type == "split"
    assert FrameTask(cfg, "right_hand", pose, rotation_frame="world").error_type == "split"
    assert FrameTask(cfg, "right_hand", pose, error_type="split").error_type == "split"
    with pytest.raises(InvalidInput, match=r"'screw' is not one of \('twist', 'split'\)"):
        FrameTask(cfg, "right_hand", pose, error_type="screw")
    with pytest.raises(InvalidInput, match="error_type='twist' matches the whole pose"):
        FrameTask(cfg, "right_hand", pose, rotation_axis="z", error_type="twist")
    with pytest.raises(InvalidInput, match="both frames 'local'"):
        FrameTask(cfg, "right_hand", pose, translation_frame="world", error_type="twist")
