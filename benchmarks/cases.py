"""Reproducible problem sets shared by the tests and the benchmarks.

The reference whole-body stack on dm_control's humanoids (``dm_humanoid``,
27 DoF, and ``dm_humanoid_cmu``, 62 DoF; floating base):

* level 0: joint limits (hard),
* level 1: both feet, full pose, at their current poses,
* level 2: the right hand, full pose,
* level 3: posture towards the start configuration (not checked).

:func:`reachable_hand_targets` makes targets the stack can reach: a random
posture is projected onto "feet where they are" by the cascade itself, and the
hand's pose there is the target. The model is recognised by its body names
(:data:`HUMANOIDS`), so every function takes just the model or configuration.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mink
import mujoco
import numpy as np

from pik_mj.robot.loading import load_model
from pik_mj.solve import solve
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.mink_adapter import MinkTask

POSTURE_COST = 1e-2  # [cost]/[rad]


@dataclass(frozen=True)
class Humanoid:
    """A humanoid of the reference stack: its model name, feet, hand and stance.

    Attributes:
        model: Name for :func:`pik_mj.robot.loading.load_model`.
        feet: Body names of the feet (level 1).
        hand: Body name of the reaching hand (level 2).
        stance: Joint angles [rad] set over ``qpos0`` for the start pose.
    """

    model: str
    feet: tuple[str, str]
    hand: str
    stance: dict[str, float] = field(default_factory=dict)


DM = Humanoid(
    "dm_humanoid",
    ("left_foot", "right_foot"),
    "right_hand",
    {
        "right_hip_y": -0.3,
        "left_hip_y": -0.3,
        "right_knee": -0.6,
        "left_knee": -0.6,
        "right_ankle_y": -0.3,
        "left_ankle_y": -0.3,
    },  # knees bent: dm_control's qpos0 has straight legs, a singular posture
)
CMU = Humanoid(
    "dm_humanoid_cmu",
    ("lfoot", "rfoot"),
    "rhand",
    {
        "lfemurrx": -0.3,
        "rfemurrx": -0.3,
        "ltibiarx": 0.6,
        "rtibiarx": 0.6,
        "lfootrx": -0.3,
        "rfootrx": -0.3,
    },  # knees bent: qpos0 has them at 0, outside their range [1 deg, 170 deg]
)
HUMANOIDS = (DM, CMU)

FEET, HAND, STANCE = DM.feet, DM.hand, DM.stance  # dm_control's humanoid, the default


def humanoid_of(model: mujoco.MjModel) -> Humanoid:
    """The :class:`Humanoid` whose feet and hand bodies ``model`` has."""
    bodies = {model.body(b).name for b in range(model.nbody)}
    for h in HUMANOIDS:
        if bodies.issuperset((*h.feet, h.hand)):
            return h
    raise ValueError(f"not a humanoid of {[h.model for h in HUMANOIDS]}")


@dataclass
class ReachStack:
    """The reference stack and the tasks in it, for inspection."""

    configuration: mink.Configuration
    feet: list[FrameTask]
    hand: FrameTask
    posture: mink.PostureTask
    levels: list[list[object]]


def dm_humanoid() -> mujoco.MjModel:
    return load_model(DM.model)


def cmu_humanoid() -> mujoco.MjModel:
    return load_model(CMU.model)


def stance(model: mujoco.MjModel) -> np.ndarray:
    """``qpos0`` with the knees bent (the humanoid's :attr:`Humanoid.stance`)."""
    q = model.qpos0.copy()
    for name, angle in humanoid_of(model).stance.items():
        q[model.joint(name).qposadr[0]] = angle
    return q


def reach_stack(configuration: mink.Configuration, hand_target: mink.SE3) -> ReachStack:
    """Feet (level 1) before the hand (level 2) before posture (level 3)."""
    model = configuration.model
    h = humanoid_of(model)
    feet = [
        FrameTask(
            configuration,
            f,
            configuration.get_transform_frame_to_world(f, "body"),
            move_target_type="body",
        )
        for f in h.feet
    ]
    hand = FrameTask(configuration, h.hand, hand_target, move_target_type="body")
    posture = mink.PostureTask(model, cost=POSTURE_COST)
    posture.set_target_from_configuration(configuration)
    levels: list[list[object]] = [
        [mink.ConfigurationLimit(model)],
        list(feet),
        [hand],
        [MinkTask(posture, check=False)],
    ]
    return ReachStack(configuration, feet, hand, posture, levels)


def mink_reach_tasks(
    configuration: mink.Configuration, hand_target: mink.SE3, feet_cost: float = 1.0
) -> list:
    """The same tasks for mink's single weighted QP: feet at ``feet_cost``
    (position [cost]/[m], orientation [cost]/[rad]), hand at cost 1."""
    h = humanoid_of(configuration.model)
    feet = [
        mink.FrameTask(f, "body", position_cost=feet_cost, orientation_cost=feet_cost)
        for f in h.feet
    ]
    for task in feet:
        task.set_target_from_configuration(configuration)
    hand = mink.FrameTask(h.hand, "body", position_cost=1.0, orientation_cost=1.0)
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
    h = humanoid_of(model)
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
            for f in h.feet
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
            targets.append(cfg.get_transform_frame_to_world(h.hand, "body"))
    return targets


def unreachable_hand_target(configuration: mink.Configuration, distance: float = 2.0) -> mink.SE3:
    """The hand's current pose moved ``distance`` [m] along world +x."""
    hand = humanoid_of(configuration.model).hand
    current = configuration.get_transform_frame_to_world(hand, "body")
    return mink.SE3.from_translation(np.array([distance, 0.0, 0.0])) @ current
