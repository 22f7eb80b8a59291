"""What of a robot touches the ground: the collision geoms its feet stand on, their
sole polygons and size, read from its limbs and its robot description.

The geometry under these (lowest points of geoms, a body's gap to the floor,
one foot's contact polygon and its normal) is :mod:`pik_mj.robot.floor_contact`;
its names are given here too (``ground.floor_gap``, ``ground.sole_polygon``, ...),
so one module answers "what touches the ground" for a reader and a caller.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.robot.floor_contact import (
    CYLINDER_RIM_POINTS,
    DEFAULT_TOLERANCE,
    FLAT_TOLERANCE,
    MIN_SOLE_POINTS,
    bottom_points,
    collision_geoms,
    floor_gap,
    geom_heights,
    geom_id,
    is_collision_geom,
    lowest_height,
    sole_normal,
    sole_polygon,
    subtree_bodies,
    touching_geoms,
)
from pik_mj.robot.robot_model import RobotModel

__all__ = [
    "CYLINDER_RIM_POINTS",
    "DEFAULT_TOLERANCE",
    "FLAT_TOLERANCE",
    "MIN_SOLE_POINTS",
    "bottom_points",
    "collision_geoms",
    "floor_gap",
    "foot_geoms",
    "geom_heights",
    "geom_id",
    "is_collision_geom",
    "lowest_height",
    "sole_normal",
    "sole_polygon",
    "sole_polygons",
    "sole_size",
    "subtree_bodies",
    "touching_geoms",
]


def foot_geoms(
    robot: RobotModel,
    legs: Sequence[str] = ("rleg", "lleg"),
    *,
    soles: Mapping[str, Sequence[int | str]] | None = None,
) -> list[int]:
    """The collision geoms the robot stands on (:meth:`~pik_mj.robot.RobotModel.foot_geoms`):
    per leg, the geoms of ``soles`` (default: the robot description's ``[soles]``),
    else every collision geom of the leg's foot.

    Legs the robot does not have are skipped (a fixed-base arm stands on nothing).
    """
    return robot.foot_geoms(legs, soles=soles)


def sole_polygons(
    robot: RobotModel,
    legs: Sequence[str] = ("rleg", "lleg"),
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    soles: Mapping[str, Sequence[int | str]] | None = None,
) -> list[np.ndarray]:
    """Sole polygons of the robot's feet in the world [m], one ``(k, 3)`` array per leg.

    Per leg, :func:`sole_polygon` of the body of the leg's end frame (visual
    geoms and parts above the sole ignored), or of the leg's geoms in ``soles``
    (default: the robot description's ``[soles]``).

    Raises:
        UnknownName: A leg the robot does not have, or an unknown sole geom.
        InvalidInput: A foot without collision geoms, or touching at fewer than 3
            points (no area to stand on).
    """
    soles = robot.described_soles if soles is None else soles
    polys = []
    for leg in legs:
        limb = robot.limb(leg)
        body = Frame.find(robot.model, limb.end_frame, limb.end_frame_type).body_id
        poly = sole_polygon(robot.model, robot.data, body, tolerance, geoms=soles.get(leg))
        if len(poly) < MIN_SOLE_POINTS:
            raise InvalidInput(
                f"the foot of limb {leg!r} (body {robot.model.body(body).name!r}) touches "
                f"a floor at {len(poly)} point(s) within {tolerance} m of its lowest point: "
                "no area to stand on (is the foot tilted in this pose?)"
            )
        polys.append(poly)
    return polys


def sole_size(robot: RobotModel, legs: Sequence[str] = ("rleg", "lleg")) -> tuple[float, float]:
    """Length and width [m] of the soles: the extent of :func:`sole_polygons`
    along the x and y axes of each leg's end frame (the sole frame, at the sole's
    centre), the same for every leg (what walking plans footsteps with).

    Raises:
        InvalidInput: A sole not centred on its end frame, or legs whose soles
            differ (by more than 1 mm).
    """
    sizes = []
    for leg, pts in zip(legs, sole_polygons(robot, legs), strict=True):
        limb = robot.limb(leg)
        X = robot.frame_pose(limb.end_frame, limb.end_frame_type)
        local = (pts - X.translation()) @ X.rotation().as_matrix()
        lo, hi = local[:, :2].min(axis=0), local[:, :2].max(axis=0)
        if np.any(np.abs(lo + hi) > 1e-3):
            raise InvalidInput(
                f"the sole of {leg!r} is not centred on its end frame "
                f"{limb.end_frame!r} (x, y extents {lo} .. {hi} m)"
            )
        sizes.append(hi - lo)
    if np.ptp(np.array(sizes), axis=0).max() > 1e-3:
        raise InvalidInput(f"the soles of {list(legs)} differ in size: {np.array(sizes)} m")
    length, width = np.mean(sizes, axis=0)
    return float(length), float(width)
