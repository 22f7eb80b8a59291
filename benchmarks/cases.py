"""Reproducible problem sets shared by the tests and the benchmarks.

The reference whole-body stack on dm_control's humanoid (27 DoF, floating base):

* level 0: joint limits (hard),
* level 1: both feet, full pose, at their current poses,
* level 2: the right hand, full pose,
* level 3: posture towards the start configuration (not checked).

:func:`reachable_hand_targets` makes targets the stack can reach: a random
posture is projected onto "feet where they are" by the cascade itself, and the
hand's pose there is the target.
"""

from __future__ import annotations

from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from pik_mj.models import load_model
from pik_mj.solve import solve
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.mink_adapter import MinkTask

FEET = ("left_foot", "right_foot")
HAND = "right_hand"
POSTURE_COST = 1e-2  # [cost]/[rad]


@dataclass
class ReachStack:
    """The reference stack and the tasks in it, for inspection."""

    configuration: mink.Configuration
    feet: list[FrameTask]
    hand: FrameTask
    posture: mink.PostureTask
    levels: list[list[object]]


STANCE = {
    "right_hip_y": -0.3,
    "left_hip_y": -0.3,
    "right_knee": -0.6,
    "left_knee": -0.6,
    "right_ankle_y": -0.3,
    "left_ankle_y": -0.3,
}  # [rad] knees bent: dm_control's qpos0 has straight legs, a singular posture


def dm_humanoid() -> mujoco.MjModel:
    return load_model("dm_humanoid")


def stance(model: mujoco.MjModel) -> np.ndarray:
    """``qpos0`` of dm_control's humanoid with the knees bent (:data:`STANCE`)."""
    q = model.qpos0.copy()
    for name, angle in STANCE.items():
        q[model.joint(name).qposadr[0]] = angle
    return q


def reach_stack(configuration: mink.Configuration, hand_target: mink.SE3) -> ReachStack:
    """Feet (level 1) before the hand (level 2) before posture (level 3)."""
    model = configuration.model
    feet = [
        FrameTask(
            configuration,
            f,
            configuration.get_transform_frame_to_world(f, "body"),
            move_target_type="body",
        )
        for f in FEET
    ]
    hand = FrameTask(configuration, HAND, hand_target, move_target_type="body")
    posture = mink.PostureTask(model, cost=POSTURE_COST)
    posture.set_target_from_configuration(configuration)
    levels: list[list[object]] = [
        [mink.ConfigurationLimit(model)],
        list(feet),
        [hand],
        [MinkTask(posture, check=False)],
    ]
    return ReachStack(configuration, feet, hand, posture, levels)


def mink_reach_tasks(configuration: mink.Configuration, hand_target: mink.SE3) -> list:
    """The same tasks for mink's single weighted QP (costs 1 on feet and hand)."""
    feet = [mink.FrameTask(f, "body", position_cost=1.0, orientation_cost=1.0) for f in FEET]
    for task in feet:
        task.set_target_from_configuration(configuration)
    hand = mink.FrameTask(HAND, "body", position_cost=1.0, orientation_cost=1.0)
    hand.set_target(hand_target)
    posture = mink.PostureTask(configuration.model, cost=POSTURE_COST)
    posture.set_target_from_configuration(configuration)
    return [*feet, hand, posture]


def reachable_hand_targets(
    model: mujoco.MjModel, n: int, seed: int = 0, sigma: float = 0.4
) -> list[mink.SE3]:
    """``n`` right-hand poses reachable with both feet kept where they are in :func:`stance`.

    Each comes from a random posture (joints ``stance + N(0, σ²)`` clipped to their
    ranges shrunk by 5% at each end) made consistent with the fixed feet by
    solving feet (level 1) before
    that posture (level 2); postures whose projection does not converge are
    redrawn.
    """
    rng = np.random.default_rng(seed)
    cfg = mink.Configuration(model)
    q0 = stance(model)
    # Postures strictly inside the ranges (5% margin): a target that needs a
    # joint exactly at its limit is reachable only asymptotically.
    lo, hi = model.jnt_range[1:, 0], model.jnt_range[1:, 1]
    lo, hi = lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo)
    targets: list[mink.SE3] = []
    while len(targets) < n:
        cfg.update(q0)
        feet = [
            FrameTask(cfg, f, cfg.get_transform_frame_to_world(f, "body"), move_target_type="body")
            for f in FEET
        ]
        q_random = q0.copy()
        q_random[7:] = np.clip(q0[7:] + rng.normal(0.0, sigma, model.nq - 7), lo, hi)
        posture = mink.PostureTask(model, cost=1.0)
        posture.set_target(q_random)
        result = solve(
            cfg,
            [[mink.ConfigurationLimit(model)], feet, [MinkTask(posture, check=False)]],
            stop=60,
            min_loop=20,
            revert_if_fail=False,
        )
        if all(t.satisfied for t in result.tasks if t.checked):
            targets.append(cfg.get_transform_frame_to_world(HAND, "body"))
    return targets


def unreachable_hand_target(configuration: mink.Configuration, distance: float = 2.0) -> mink.SE3:
    """The hand's current pose moved ``distance`` [m] forward (+x, world)."""
    current = configuration.get_transform_frame_to_world(HAND, "body")
    return mink.SE3.from_translation(np.array([distance, 0.0, 0.0])) @ current
