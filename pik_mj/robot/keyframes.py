"""Which configuration a robot stands in: the keyframe choice.

Rule, first match wins:

1. the keyframe the caller (or a robot description) names — by name, or by
   index for unnamed keyframes (PAL Talos' standing keyframe has no name);
2. a keyframe named like a standing pose, in the order of
   :data:`STANDING_KEYFRAME_NAMES` (``stand`` before ``home`` before ...; case
   ignored): Menagerie's G1 ``stand``, Booster T1 ``home``, pik_mj's ``reset_pose``;
3. the model's first keyframe;
4. the zero pose ``qpos0`` (Unitree H1 and dm_control's humanoids have no keyframe).

The chosen pose is returned as it is written, with its gap to the floor
(:func:`pik_mj.robot.floor_contact.floor_gap`). :meth:`pik_mj.Robot.from_model` makes it a
pose standing on the floor: a zero pose whose soles are tilted gets its feet
turned flat (keyframe ``pik_mj_standing``; dm_control's humanoid), and the robot
is put down onto z = 0 (Robotis OP3's zero pose floats).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, NoCollisionGeometry, UnknownName
from pik_mj.frames import robot_root_body
from pik_mj.robot.floor_contact import floor_gap

STANDING_KEYFRAME_NAMES = (
    "stand",
    "standing",
    "stand_pose",
    "home",
    "reset_pose",
    "default",
    "default_pose",
    "neutral",
    "ready",
    "init",
    "initial",
)
"""Keyframe names taken for a standing pose, most preferred first."""


@dataclass(frozen=True)
class StandingPose:
    """A configuration to stand in and where it came from.

    Attributes:
        qpos: The configuration (nq,), a copy.
        keyframe: Keyframe name (``""`` for an unnamed one), or None for ``qpos0``.
        index: Keyframe index, or None for ``qpos0``.
        rule: Why it was chosen (``"named by the caller"``, ``"standing name"``,
            ``"first keyframe"``, ``"zero pose"``).
        floor_gap: Height of the robot's lowest collision geom above ``z = 0`` [m]
            in this configuration (positive: floating); NaN for a robot without
            collision geoms.
    """

    qpos: np.ndarray
    keyframe: str | None
    index: int | None
    rule: str
    floor_gap: float

    def describe(self) -> str:
        """One line for reports: ``keyframe 'stand' (standing name), 2.0 mm into the floor``."""
        if self.index is None:
            what = "the zero pose qpos0"
        else:
            what = f"keyframe {self.keyframe!r}" if self.keyframe else f"keyframe #{self.index}"
        gap_mm = 1e3 * self.floor_gap
        if not np.isfinite(gap_mm):
            return f"{what} ({self.rule}), no collision geometry"
        where = f"{gap_mm:.1f} mm above" if gap_mm >= 0 else f"{-gap_mm:.1f} mm into"
        return f"{what} ({self.rule}), {where} the floor"


def keyframe_names(model: mujoco.MjModel) -> list[str]:
    """Each keyframe's name, ``#i`` for an unnamed one."""
    return [model.key(k).name or f"#{k}" for k in range(model.nkey)]


def _find_keyframe(model: mujoco.MjModel, keyframe: str | int) -> int:
    if isinstance(keyframe, (int, np.integer)) and not isinstance(keyframe, bool):
        if not 0 <= keyframe < model.nkey:
            raise InvalidInput(
                f"keyframe index {keyframe} is out of range: the model has {model.nkey} "
                f"keyframes {keyframe_names(model)}"
            )
        return int(keyframe)
    if not isinstance(keyframe, str):
        raise InvalidInput(
            f"keyframe must be a keyframe name (a string) or an index, got {keyframe!r}"
        )
    names = keyframe_names(model)
    if keyframe in names:
        return names.index(keyframe)
    raise UnknownName("keyframe", keyframe, names)


def choose_keyframe(
    model: mujoco.MjModel, keyframe: str | int | None = None
) -> tuple[int | None, str]:
    """``(index, rule)`` of the keyframe to stand in (rule in the module docstring):
    the keyframe index, or None for ``qpos0``, and why it was chosen.

    Raises:
        UnknownName: ``keyframe`` is not a keyframe of the model (lists them).
        InvalidInput: A bad index.
    """
    if keyframe is not None:
        return _find_keyframe(model, keyframe), "named by the caller"
    lowered = [model.key(k).name.lower() for k in range(model.nkey)]
    standing = [n for n in STANDING_KEYFRAME_NAMES if n in lowered]
    if standing:
        return lowered.index(standing[0]), "standing name"
    if model.nkey:
        return 0, "first keyframe"
    return None, "zero pose"


def standing_pose(
    model: mujoco.MjModel,
    keyframe: str | int | None = None,
    *,
    root_body: int | str | None = None,
) -> StandingPose:
    """The configuration the robot stands in (rule in the module docstring).

    Args:
        model: The robot's model.
        keyframe: A keyframe name (``"#2"`` or ``2`` for an unnamed one) that
            overrides the rule.
        root_body: The robot's top-level body for the floor gap; default
            :func:`pik_mj.frames.robot_root_body`.

    Raises:
        UnknownName: ``keyframe`` is not a keyframe of the model (lists them).
        InvalidInput: A bad index.
    """
    index, rule = choose_keyframe(model, keyframe)
    qpos = (model.qpos0 if index is None else model.key_qpos[index]).copy()
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    try:
        gap = floor_gap(model, data, robot_root_body(model, root_body))
    except NoCollisionGeometry:
        gap = math.nan
    return StandingPose(
        qpos=qpos,
        keyframe=None if index is None else model.key(index).name,
        index=index,
        rule=rule,
        floor_gap=gap,
    )
