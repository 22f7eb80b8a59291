"""FrameTask (seed move-target-task): Jacobian against finite differences for every
axis selection and error frame, fixed and moving targets, floating and fixed base."""

from __future__ import annotations

import itertools

import mink
import numpy as np
import pytest
from fd import fd_jacobian

from pik_mj import FrameTask, InvalidInput
from pik_mj.models import load_model
from pik_mj.tasks.frame import constrained_axes, ljacinv

TRANSLATION_AXES = [True, "x", "y", "z", "xy", "yz", "zx", None]
ROTATION_AXES = [True, "x", "y", "z", None]


@pytest.fixture(scope="module")
def humanoid_cfg():
    model = load_model("dm_humanoid")
    cfg = mink.Configuration(model)
    rng = np.random.default_rng(0)
    q = cfg.q.copy()
    q[3:7] = mink.SO3.sample_uniform().wxyz
    q[7:] += rng.normal(0, 0.3, model.nq - 7)
    cfg.update(q)
    return cfg


FRAMES = ["local", "world", np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])]


@pytest.mark.parametrize("frame", range(len(FRAMES)))
@pytest.mark.parametrize("relative", [False, True])
def test_jacobian_matches_finite_differences_all_options(humanoid_cfg, frame, relative):
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
