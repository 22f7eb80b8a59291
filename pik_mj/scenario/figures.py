"""Measures the scenarios report: where a limb's end is, how far frames moved or turned
between two poses, the CoM's margin in the support polygon of the soles."""

from __future__ import annotations

from collections.abc import Sequence

import mink
import numpy as np

from pik_mj.balance import support_polygon
from pik_mj.robot import Robot
from pik_mj.robot.ground import sole_polygons


def end_pose(robot: Robot, limb: str) -> mink.SE3:
    """Pose ``X_WE`` of the end frame of ``limb`` (its site or body) in the world."""
    end = robot.limb(limb)
    return robot.frame_pose(end.end_frame, end.end_frame_type)


def largest_move(before: Sequence[mink.SE3], after: Sequence[mink.SE3]) -> float:
    """The largest distance [m] between the positions of ``before[i]`` and ``after[i]``."""
    return max(
        float(np.linalg.norm(a.translation() - b.translation()))
        for a, b in zip(before, after, strict=True)
    )


def largest_turn(before: Sequence[mink.SE3], after: Sequence[mink.SE3]) -> float:
    """The largest rotation angle [rad] between the orientations of ``before[i]`` and
    ``after[i]``: ``max_i ||log(R_i^T R'_i)||``."""
    return max(
        float(np.linalg.norm((a.rotation().inverse() @ b.rotation()).log()))
        for a, b in zip(before, after, strict=True)
    )


def com_margin(robot: Robot, point: np.ndarray | None = None) -> float:
    """Signed distance [m] of the CoM's (or ``point``'s) ground projection to the edges
    of the support polygon of both soles (:func:`pik_mj.robot.ground.sole_polygons`),
    positive inside."""
    region = support_polygon(sole_polygons(robot))
    return float(region.signed_distance(robot.com() if point is None else np.asarray(point)))
