"""The scenarios' scenes, built for the robot that plays them (MjSpec): a counter with a
kettle on it, a wall, a box in the arm's way; each placed and sized from the robot's
:class:`~pik_mj.scenario.stature.Stature` (its frame, shoulders, arm length), on a floor
(:func:`pik_mj.robot.world.floor_environment`).

Each builder returns the environment's spec; :func:`scene_file` writes it as MJCF (its
path names the scene and its contents), so that the robot built in it has a source
JSON can hold and ``pik-mj validate`` rebuilds its world.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.robot import Robot
from pik_mj.robot.world import add_box, add_wall, floor_environment
from pik_mj.scenario.robot_option import model_label
from pik_mj.scenario.stature import Hand, Stature
from pik_mj.spatial import yaw_of, yaw_quat
from pik_mj.tasks.frame import FrameTask

KETTLE_ARM = 0.61
"""[m] The arm length the kettle is sized for: a robot whose arm is ``L`` long gets the
kettle scaled by ``L / KETTLE_ARM`` (its mass by the cube)."""

KETTLE_MASS = 1.0
"""[kg] The kettle's mass at scale 1."""

HANDLE_FROM_SHOULDER = (0.6, 0.0, -0.47)
"""Where the kettle's handle (the middle of its bar) goes from the grasping arm's
shoulder, in arm lengths, in the robot's frame (x forward, y left, z up): exactly that
far ahead, and as near the rest as the hand reaches holding it (:func:`holding_reach`)."""

WALL_FROM_SHOULDER = 0.75
"""The wall's face ahead of the shoulders [arm lengths]."""


def scene_dir() -> Path:
    """Where :func:`scene_file` writes: ``$PIK_MJ_SCENES``, else
    ``$XDG_CACHE_HOME/pik_mj/scenes`` (``~/.cache/pik_mj/scenes``)."""
    if os.environ.get("PIK_MJ_SCENES"):
        return Path(os.environ["PIK_MJ_SCENES"])
    cache = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(cache) / "pik_mj" / "scenes"


def scene_file(spec: mujoco.MjSpec, name: str) -> Path:
    """Write ``spec`` as MJCF to ``scene_dir()/<name>-<digest>.xml`` (the digest of its
    text: the same scene is the same file) and return the path."""
    text = spec.to_xml()
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    folder = scene_dir()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}-{digest}.xml"
    if not path.is_file():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return path


# ----------------------------------------------------------------------------- kettle
@dataclass(frozen=True)
class KettleLayout:
    """Where the counter and the kettle stand for a robot.

    Attributes:
        p_handle: The handle bar's middle [m], world.
        yaw: Heading [rad] of the approach direction (the robot's forward).
        scale: The kettle's size over its size at scale 1 [-].
        counter_top: Height [m] of the counter's top (the kettle's bottom).
    """

    p_handle: np.ndarray
    yaw: float
    scale: float
    counter_top: float

    @classmethod
    def reached(cls, robot: Robot, stature: Stature, arm: str) -> KettleLayout:
        """The handle where ``arm``'s hand holds a vertical bar 0.6 L ahead of its
        shoulder (:func:`holding_reach`), the kettle scaled by the arm's length over
        :data:`KETTLE_ARM`, its bottom on the counter."""
        scale = stature.arm_lengths[arm] / KETTLE_ARM
        p_handle = holding_reach(robot, stature, arm)
        return cls(
            p_handle=p_handle,
            yaw=yaw_of(stature.R_WR),
            scale=scale,
            counter_top=float(p_handle[2] - 0.1 * scale),
        )


def holding_reach(robot: Robot, stature: Stature, arm: str) -> np.ndarray:
    """Where [m] ``arm``'s hand holds a vertical bar :data:`HANDLE_FROM_SHOULDER` ahead
    of its shoulder, found on the robot itself: a full-body solve from its start pose
    (feet fixed, the CoM over them) with, at level 2, the hand that far ahead (along
    the robot's forward axis) and its grip axis vertical, and at level 3 (best
    effort) the hand at :data:`HANDLE_FROM_SHOULDER` (its height and its side
    offset): an arm that cannot hold the bar there holds it as near as it can. The
    robot is left at its start pose.

    Raises:
        InvalidInput: The hand cannot hold the bar that far ahead.
    """
    hand = stature.hands[arm]
    p_goal = stature.from_shoulder(arm, HANDLE_FROM_SHOULDER)
    R_goal = hand.rotation([0.0, 0.0, 1.0], stature.R_WR[:, 0])
    q0 = robot.configuration.q.copy()
    ahead = FrameTask(
        robot.configuration,
        hand.frame,
        (p_goal, R_goal),
        move_target_type=hand.frame_type,
        translation_axis="yz",  # only the forward axis of the robot's frame
        translation_frame=stature.R_WR,
        rotation_axis=Hand.name(hand.grip),
        name="bar held ahead",
    )
    near = FrameTask(
        robot.configuration,
        hand.frame,
        (p_goal, R_goal),
        move_target_type=hand.frame_type,
        rotation_axis=None,
        check=False,
        name="bar held at the goal",
    )
    try:
        result = fullbody_inverse_kinematics(
            robot,
            [],
            joints="all",
            extra_levels=[[ahead], [near]],
            stop=100,
            revert_if_fail=False,
        )
        p_hand = hand.pose(robot).translation()
    finally:
        robot.configuration.update(q0)
    if not result.converged:
        raise InvalidInput(
            f"the {arm} hand of {robot_label(robot)!r} cannot hold a vertical bar "
            f"{HANDLE_FROM_SHOULDER[0]:g} arm lengths ahead of its shoulder"
        )
    return p_hand


def kettle_scene(stature: Stature, layout: KettleLayout, arm: str) -> mujoco.MjSpec:
    """A floor, a counter and a kettle on it whose handle faces ``arm``
    (``layout``): the counter's front 7 cm (scaled) before the handle, one arm length
    deep, two wide, centred on the robot's middle plane.

    The kettle (body ``kettle``, free joint ``kettle_free``) has a pot, a lid, a
    spout and a handle (geoms ``kettle_*``); site ``kettle_handle`` is the middle
    of the handle's vertical bar, x along the approach direction, z up; site
    ``kettle_center`` the pot's centre.
    """
    spec = floor_environment("kettle_scene")
    L = stature.arm_lengths[arm]
    forward = stature.R_WR[:, 0]
    front = stature.to_robot(layout.p_handle)[0] - 0.07 * layout.scale  # counter front [m]
    centre = stature.to_world([front + 0.5 * L, 0.0, 0.0])
    centre[2] = 0.5 * layout.counter_top
    add_box(
        spec,
        "counter",
        centre,
        (0.5 * L, L, 0.5 * layout.counter_top),
        quat=yaw_quat(layout.yaw),
        rgba=(0.6, 0.42, 0.25, 1.0),
    )
    origin = layout.p_handle + 0.13 * layout.scale * forward
    origin[2] = layout.counter_top
    add_kettle(spec, origin, layout.yaw, layout.scale)
    return spec


def add_kettle(spec: mujoco.MjSpec, origin: np.ndarray, yaw: float, scale: float) -> None:
    """Add the kettle (:func:`kettle_scene`) to ``spec``: its bottom's centre at
    ``origin`` [m], its handle towards ``-x`` turned by ``yaw`` [rad], its sizes times
    ``scale`` and its mass (:data:`KETTLE_MASS`) times ``scale``³."""
    s, m = scale, KETTLE_MASS * scale**3
    body = spec.worldbody.add_body(name="kettle", pos=origin.tolist(), quat=yaw_quat(yaw).tolist())
    body.add_freejoint(name="kettle_free")
    steel, black = [0.7, 0.72, 0.75, 1.0], [0.1, 0.1, 0.1, 1.0]
    cylinder, capsule = mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE
    geoms = [  # name, type, size, pos or fromto, mass fraction, colour
        ("kettle_pot", cylinder, [0.08, 0.08], [0, 0, 0.08], 0.74, steel),
        ("kettle_lid", cylinder, [0.05, 0.01], [0, 0, 0.17], 0.05, black),
        ("kettle_spout", capsule, [0.012], [0.07, 0, 0.06, 0.14, 0, 0.14], 0.05, steel),
        ("kettle_handle_upper", capsule, [0.01], [-0.075, 0, 0.15, -0.13, 0, 0.15], 0.03, black),
        ("kettle_handle_lower", capsule, [0.01], [-0.075, 0, 0.05, -0.13, 0, 0.05], 0.03, black),
        ("kettle_handle", capsule, [0.012], [-0.13, 0, 0.05, -0.13, 0, 0.15], 0.1, black),
    ]
    for name, kind, size, where, fraction, rgba in geoms:
        geom = body.add_geom(
            name=name,
            type=kind,
            size=[s * x for x in size] + [0.0] * (3 - len(size)),
            mass=fraction * m,
            rgba=rgba,
            friction=[1.0, 0.005, 0.0001],
        )
        if len(where) == 6:
            geom.fromto = [s * x for x in where]
        else:
            geom.pos = [s * x for x in where]
    body.add_site(name="kettle_handle", pos=[-0.13 * s, 0, 0.1 * s], size=[0.02 * s, 0, 0])
    body.add_site(name="kettle_center", pos=[0, 0, 0.08 * s], size=[0.02 * s, 0, 0])


# -------------------------------------------------------------------------------- wall
def wall_scene(stature: Stature) -> mujoco.MjSpec:
    """A floor and a wall (geom ``wall``) facing the robot, its face
    :data:`WALL_FROM_SHOULDER` arm lengths ahead of the shoulders, as wide as twice
    and as high as 1.5 times the shoulders' height."""
    spec = floor_environment("wall_scene")
    L = float(np.mean(list(stature.arm_lengths.values())))
    shoulders = np.mean([stature.to_robot(p) for p in stature.shoulders.values()], axis=0)
    face = stature.to_world([shoulders[0] + WALL_FROM_SHOULDER * L, 0.0, 0.0])
    add_wall(
        spec,
        face,
        -stature.R_WR[:, 0],
        width=2.0 * shoulders[2],
        height=1.5 * shoulders[2],
        thickness=0.1,
    )
    return spec


# --------------------------------------------------------------------------- obstacle
OBSTACLE_FROM_MIDDLE = (0.0, 0.15, 0.0)
"""Where the obstacle's centre is from the middle of the hand's straight way to its
target, in arm lengths, in the robot's frame with y outwards (away from the body's
middle plane, on the arm's side): off that way, so that the way round it is its inner
side, between the box and the body, not a saddle."""


def obstacle_scene(
    stature: Stature, arm: str, p_hand: np.ndarray, p_target: np.ndarray
) -> mujoco.MjSpec:
    """A floor and a box (geom ``obstacle``) across the way of ``arm``'s hand from
    ``p_hand`` to ``p_target`` [m]: centred :data:`OBSTACLE_FROM_MIDDLE` arm lengths
    from the middle of that segment (outwards: the way inside it, along the body, is
    the short one), thin along the robot's forward axis (0.1 L), 0.34 L wide and
    0.17 L high, ``L`` the arm's length."""
    spec = floor_environment("obstacle_scene")
    L = stature.arm_lengths[arm]
    middle = 0.5 * (np.asarray(p_hand) + np.asarray(p_target))
    x, y, z = OBSTACLE_FROM_MIDDLE
    add_box(
        spec,
        "obstacle",
        middle + L * stature.direction((x, stature.outward(arm) * y, z)),
        (0.05 * L, 0.17 * L, 0.085 * L),
        quat=yaw_quat(yaw_of(stature.R_WR)),
        rgba=(0.9, 0.5, 0.2, 1.0),
    )
    return spec


def robot_in(robot: Robot, environment: mujoco.MjSpec, name: str) -> Robot:
    """``robot`` built again in ``environment``, written by :func:`scene_file` as
    ``<name>-<robot>`` (the robot: :func:`robot_label`), at its start pose: its source
    then names the scene's file (``pik-mj validate`` rebuilds the world).

    Raises:
        InvalidInput: A robot without a source (``Robot(model)``), or one already in
            an environment.
    """
    if robot.source is None or robot.source.environment is not None:
        raise InvalidInput(
            "a scenario builds its scene around a robot made by Robot.from_model without "
            f"an environment; this one has source {robot.source!r}"
        )
    path = scene_file(environment, f"{name}-{robot_label(robot)}")
    return Robot.from_source(replace(robot.source, environment=str(path)))


def robot_label(robot: Robot) -> str:
    """A short name of ``robot``'s model for file names
    (:func:`~pik_mj.scenario.robot_option.model_label`; a model given as a spec: its
    model name)."""
    model = None if robot.source is None else robot.source.model
    if isinstance(model, mujoco.MjSpec) or model is None:
        return robot.model.names.split(b"\0", 1)[0].decode() or "robot"
    return model_label(model)
