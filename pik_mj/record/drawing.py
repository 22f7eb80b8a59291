"""What a recording draws of a MuJoCo model, and what its 3D views frame.

:func:`draw_model` turns a model into the static data of a recording (every
visible geom, one entity per primitive kind, :mod:`pik_mj.record.geometry`) and
the body frames whose logged poses move the robot's and the scene's moving
geoms; :func:`draw_reference` draws a robot a second time, translucent (a
motion's reference pose). :class:`Extent` keeps the box the robot swept on each
timeline, which the blueprint's cameras frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
import rerun as rr

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.record import geometry, style
from pik_mj.record.blueprint import Framing
from pik_mj.record.columns import pose_batches_of
from pik_mj.record.geometry import BodyFrames, InstancePoses, Measures
from pik_mj.record.paths import EntityPaths

__all__ = ["Drawing", "Extent", "body_poses", "draw_model", "draw_reference", "robot_masks"]


@dataclass
class Drawing:
    """What a recording draws of a model.

    Attributes:
        static: ``(entity path, archetypes)`` to log once, static, in order.
        frames: The body frames whose poses are logged, by ``(path,)``: each
            moves the geoms it carries (:class:`~pik_mj.record.geometry.BodyFrames`).
        skipped: Geoms of a type rerun cannot draw.
    """

    static: list[tuple[str, tuple[Any, ...]]] = field(default_factory=list)
    frames: dict[tuple[str, ...], BodyFrames] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)


def robot_masks(
    model: mujoco.MjModel, robot_root_body: str | None
) -> tuple[np.ndarray, np.ndarray]:
    """Which bodies are the robot's and which move, (nbody,) masks each.

    The robot is the subtree of ``robot_root_body`` (every body but the world
    body when None); bodies move when they are the robot's, not welded to the
    world, or mocap bodies.

    Raises:
        UnknownName: No body ``robot_root_body``.
        InvalidInput: ``robot_root_body`` is the world body.
    """
    if robot_root_body is None:
        robot = np.ones(model.nbody, dtype=bool)
        robot[0] = False
        return robot, robot.copy()
    root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot_root_body)
    if root < 0:
        raise UnknownName("body", robot_root_body, geometry.unique_names(model, "body"))
    if root == 0:
        raise InvalidInput("robot_root_body cannot be the world body")
    robot = geometry.subtree(model, root)
    moving = (np.asarray(model.body_weldid) != 0) | (np.asarray(model.body_mocapid) >= 0)
    moving |= robot
    moving[0] = False
    return robot, moving


def draw_model(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    paths: EntityPaths,
    *,
    robot: np.ndarray,
    moving: np.ndarray,
    groups: set[int],
    plane_half_size: float,
) -> Drawing:
    """The drawing of ``model``: the world's axes, every visible geom of
    ``groups`` (the ones welded to the world at their poses in ``data``), the
    body markers and the frames of the ``moving`` bodies, robot and scene
    apart (:func:`robot_masks`), and a warning for the geoms not drawn."""
    body_names = geometry.unique_names(model, "body")
    drawing = Drawing(static=[(paths.world, (rr.ViewCoordinates.RIGHT_HAND_Z_UP,))])
    found, drawing.skipped = geometry.geom_groups(
        model,
        geometry.unique_names(model, "geom"),
        robot=robot,
        moving=moving,
        groups=groups,
        plane_half_size=plane_half_size,
        entity_path=paths.geoms,
    )
    welded = [g for g in found if not g.moving]
    ids = np.concatenate([g.ids for g in welded]) if welded else np.zeros(0, dtype=int)
    bodies = np.unique(model.geom_bodyid[ids])
    X_WB = np.hstack([data.xpos[bodies], data.xquat[bodies]])[None]  # their poses now
    for group, poses in zip(welded, InstancePoses(model, welded, bodies)(X_WB), strict=True):
        drawing.static.append((group.path, (group.shape, pose_batches_of(group, poses[0]))))
    for is_robot in (True, False):
        ids = np.flatnonzero(moving & (robot if is_robot else ~robot))
        if len(ids):
            path = paths.bodies(robot=is_robot)
            drawing.static.append((path, (geometry.body_markers([body_names[b] for b in ids]),)))
            carried = [g for g in found if g.moving and g.robot == is_robot]
            drawing.static += [(group.path, (group.shape,)) for group in carried]
            instances = InstancePoses(model, carried, ids)
            drawing.frames[(path,)] = BodyFrames(path, ids, carried, instances)
    if drawing.skipped:
        warning = f"geoms of unsupported type not drawn: {drawing.skipped}"
        drawing.static.append((paths.events, (rr.TextLog(warning, level="WARN"),)))
    return drawing


def draw_reference(model: mujoco.MjModel, robot_root_body: str, paths: EntityPaths) -> Drawing:
    """The robot of ``model`` (the subtree of ``robot_root_body``) drawn a
    second time at :attr:`EntityPaths.reference`, translucent
    (:data:`~pik_mj.record.style.REFERENCE`): one body-frames entity carrying
    its geoms."""
    root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot_root_body)
    robot = geometry.subtree(model, root)
    base = paths.reference
    groups, _ = geometry.geom_groups(
        model,
        geometry.unique_names(model, "geom"),
        robot=robot,
        moving=robot,
        groups={0, 1, 2},
        plane_half_size=1.0,
        entity_path=lambda kind, robot, moving: f"{base}/{kind}",
        color=style.REFERENCE,
        only=robot,
    )
    ids = np.flatnonzero(robot)
    path = f"{base}/bodies"
    # the body frames are drawn as the robot's are (an Ellipsoids3D needs its sizes)
    body_names = geometry.unique_names(model, "body")
    drawing = Drawing(static=[(path, (geometry.body_markers([body_names[b] for b in ids]),))])
    drawing.static += [(group.path, (group.shape,)) for group in groups]
    drawing.frames[(path,)] = BodyFrames(path, ids, groups, InstancePoses(model, groups, ids))
    return drawing


def body_poses(frames: BodyFrames, data: mujoco.MjData) -> np.ndarray:
    """The poses ``X_WB`` (n, 7) ``[p, q_wxyz]`` of the bodies of ``frames`` in
    ``data`` (MuJoCo's ``xpos``, ``xquat``)."""
    poses = np.empty((len(frames.ids), 7))
    poses[:, :3] = data.xpos[frames.ids]
    poses[:, 3:] = data.xquat[frames.ids]
    return poses


class Extent:
    """The box of the robot's body positions seen on each timeline, and the
    robot's heading when it was first seen there: what each timeline's 3D view
    frames (:class:`~pik_mj.record.blueprint.Framing`)."""

    def __init__(self) -> None:
        # timeline -> (low, high) corners [m], heading [rad]
        self._seen: dict[str, tuple[np.ndarray, np.ndarray, float]] = {}

    def grow(self, timeline: str, poses: np.ndarray) -> None:
        """Grow the box of ``timeline`` by the robot's body poses (n, 7)
        ``[p, q_wxyz]``, the root first."""
        p = poses[:, :3]
        seen = self._seen.get(timeline)
        if seen is None:
            w, x, y, z = poses[0, 3:]  # the root's x axis, on the ground plane
            heading = math.atan2(2 * (x * y + w * z), 1 - 2 * (y * y + z * z))
            self._seen[timeline] = (p.min(axis=0), p.max(axis=0), heading)
        else:
            low, high, heading = seen
            self._seen[timeline] = (
                np.minimum(low, p.min(axis=0)),
                np.maximum(high, p.max(axis=0)),
                heading,
            )

    def framing(self, measures: Measures | None) -> dict[str, Framing]:
        """What each timeline's 3D view frames: the box seen on it, with the
        robot's height and ground from ``measures`` (height 1 m and no ground
        without)."""
        height, ground = (1.0, None) if measures is None else (measures.height, measures.ground_z)
        return {
            timeline: Framing(low, high, heading, height, ground)
            for timeline, (low, high, heading) in self._seen.items()
        }
