"""What of a robot touches the ground: the collision geoms its feet stand on, and
each leg's :class:`Sole` (its frame, polygon and size) from the contacts MuJoCo
makes with a floor in the robot's start pose.

**A sole from the contacts.** In the start pose (:meth:`RobotModel.start_q`), the
foot's collision geoms (the robot description's ``[soles]``, else every collision
geom of the foot: :meth:`RobotModel.foot_geoms`) are put on a floor through their
lowest point and MuJoCo's collision detection gives the contact points
(:func:`floor_contacts`): a box touches at its 4 bottom corners, a sphere at
one point, a mesh at the few points MuJoCo picks (not at every vertex of its
bottom face). The sole polygon is the convex hull of these points, and the sole
frame S is

.. math::

    p_{WS} = \\frac{1}{A} \\int_{polygon} p \\, dA, \\qquad
    z_S = e_z, \\qquad x_S = \\pm u_1

with :math:`u_1` the eigenvector of the largest eigenvalue of the polygon's
second moment of area :math:`\\int (p - p_{WS})(p - p_{WS})^T dA` (the foot's long
axis), signed to point along the root body's heading; a polygon whose two
moments are within :data:`ISOTROPIC_RATIO` (a disc, a square) takes the root
body's heading. S is fixed to the foot body (``X_BS``): the sole's polygon
``outline`` (in S), its length and width go with the foot wherever it moves, and
walking plans its footsteps in S. No site is needed.

The geometry under these (lowest points of geoms, a body's gap to the floor,
one foot's contact polygon and its normal) is :mod:`pik_mj.robot.floor_contact`;
its names are given here too (``ground.floor_gap``, ``ground.sole_polygon``, ...),
so one module answers "what touches the ground" for a reader and a caller.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.balance import convex_hull_2d, polygon_area
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.robot.floor_contact import (
    CYLINDER_RIM_POINTS,
    DEFAULT_TOLERANCE,
    FLAT_TOLERANCE,
    MIN_SOLE_POINTS,
    bottom_points,
    collision_geoms,
    floor_contacts,
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
from pik_mj.robot.robot import Robot
from pik_mj.robot.robot_model import RobotModel

__all__ = [
    "CYLINDER_RIM_POINTS",
    "DEFAULT_TOLERANCE",
    "FLAT_TOLERANCE",
    "ISOTROPIC_RATIO",
    "MIN_SOLE_POINTS",
    "Sole",
    "bottom_points",
    "collision_geoms",
    "floor_contacts",
    "floor_gap",
    "foot_geoms",
    "geom_heights",
    "geom_id",
    "is_collision_geom",
    "lowest_height",
    "robot_soles",
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


ISOTROPIC_RATIO = 1.1
"""Ratio of a sole polygon's principal second moments of area below which it has no
long axis: its frame takes the root body's heading (module docstring)."""


@dataclass(frozen=True)
class Sole:
    """A leg's sole: a frame S fixed to the foot body, and its polygon in S.

    Attributes:
        leg: The leg (``"rleg"``, ``"lleg"``).
        body: The foot body S is fixed to (the body of the leg's end frame).
        geoms: The collision geoms that touched the floor.
        p_BS: Origin of S in the foot body's frame (3,) [m]: the polygon's centroid.
        R_BS: Rotation of S in the foot body's frame (3, 3): x forward, z up
            (normal to the floor) in the start pose.
        outline: The polygon's vertices in S's xy plane (k, 2) [m], counter-clockwise.
    """

    leg: str
    body: str
    geoms: tuple[str, ...]
    p_BS: np.ndarray
    R_BS: np.ndarray
    outline: np.ndarray

    @property
    def size(self) -> tuple[float, float]:
        """Length (along x_S) and width (along y_S) of the polygon [m]."""
        length, width = np.ptp(self.outline, axis=0)
        return float(length), float(width)

    def pose(self, model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """``(p_WS (3,) [m], R_WS (3, 3))`` in the pose of ``data``:
        ``p_WS = p_WB + R_WB p_BS``, ``R_WS = R_WB R_BS``."""
        b = model.body(self.body).id
        R_WB = data.xmat[b].reshape(3, 3)
        return data.xpos[b] + R_WB @ self.p_BS, R_WB @ self.R_BS

    def polygon(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """The polygon's vertices in the world (k, 3) [m] in the pose of ``data``."""
        p_WS, R_WS = self.pose(model, data)
        return p_WS + self.outline @ R_WS[:, :2].T

    def __repr__(self) -> str:
        length, width = self.size
        return (
            f"Sole({self.leg!r}, body={self.body!r}, {len(self.outline)} points, "
            f"{length:.3f} x {width:.3f} m, p_BS={np.round(self.p_BS, 4).tolist()})"
        )


def robot_soles(
    robot: RobotModel,
    legs: Sequence[str] = ("rleg", "lleg"),
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    soles: Mapping[str, Sequence[int | str]] | None = None,
) -> dict[str, Sole]:
    """Each leg's :class:`Sole` from MuJoCo's floor contacts in the robot's start
    pose (module docstring).

    Args:
        robot: The robot (its configuration is not changed).
        legs: The legs.
        tolerance: Distance [m] above the foot's lowest point up to which a geom
            touches the floor.
        soles: Sole geoms by leg (default: the robot description's ``[soles]``;
            a leg not named there: every collision geom of its foot).

    Raises:
        UnknownName: A leg the robot does not have, or an unknown sole geom.
        InvalidInput: A foot without collision geoms, or touching at fewer than 3
            points (no area to stand on).
    """
    model = robot.model
    spec = robot.spec if isinstance(robot, Robot) else None
    data = mujoco.MjData(model)
    data.qpos[:] = robot.start_q()
    mujoco.mj_kinematics(model, data)
    root = model.body(robot.root_body).id
    heading = data.xmat[root].reshape(3, 3)[:2, 0]
    out = {}
    for leg in legs:
        limb = robot.limb(leg)
        body = Frame.find(model, limb.end_frame, limb.end_frame_type).body_id
        geoms = robot.foot_geoms([leg], soles=soles)
        if not geoms:
            raise InvalidInput(f"the foot of limb {leg!r} has no collision geom to stand on")
        points, owners = floor_contacts(model, data, geoms, tolerance, spec=spec)
        hull = convex_hull_2d(points[:, :2], allow_degenerate=True, tol=1e-6) if len(points) else []
        if len(hull) < MIN_SOLE_POINTS:
            raise InvalidInput(
                f"the foot of limb {leg!r} (body {model.body(body).name!r}) touches a floor "
                f"at {len(hull)} point(s) within {tolerance} m of its lowest point in the "
                "start pose: no area to stand on (is the foot tilted in this pose?)"
            )
        p_WS, R_WS = _sole_frame(hull, float(points[0, 2]), heading)
        R_WB = data.xmat[body].reshape(3, 3)
        out[leg] = Sole(
            leg=leg,
            body=model.body(body).name,
            geoms=tuple(dict.fromkeys(model.geom(int(g)).name for g in owners)),
            p_BS=R_WB.T @ (p_WS - data.xpos[body]),
            R_BS=R_WB.T @ R_WS,
            outline=(hull - p_WS[:2]) @ R_WS[:2, :2],
        )
    return out


def _sole_frame(
    hull: np.ndarray, height: float, heading: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(p_WS, R_WS)`` of a sole polygon ``hull`` (k, 2) [m] (ccw) at ``height``
    [m]: its centroid and principal axes, x along ``heading`` (module docstring)."""
    x, y = hull[:, 0], hull[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    area = polygon_area(hull)
    c = np.array([((x + x1) * cross).sum(), ((y + y1) * cross).sum()]) / (6.0 * area)
    # second moments of area about the origin, then about the centroid
    Ixx = ((y * y + y * y1 + y1 * y1) * cross).sum() / 12.0
    Iyy = ((x * x + x * x1 + x1 * x1) * cross).sum() / 12.0
    Ixy = ((x * y1 + 2 * x * y + 2 * x1 * y1 + x1 * y) * cross).sum() / 24.0
    second = np.array([[Iyy, Ixy], [Ixy, Ixx]]) - area * np.outer(c, c)
    moments, axes = np.linalg.eigh(second)
    forward = heading / max(float(np.linalg.norm(heading)), 1e-12)
    u = forward if moments[1] < ISOTROPIC_RATIO * moments[0] else axes[:, 1]
    u = u if u @ forward >= 0.0 else -u
    R_WS = np.array([[u[0], -u[1], 0.0], [u[1], u[0], 0.0], [0.0, 0.0, 1.0]])
    return np.array([c[0], c[1], height]), R_WS


def sole_polygons(
    robot: RobotModel,
    legs: Sequence[str] = ("rleg", "lleg"),
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    soles: Mapping[str, Sequence[int | str]] | None = None,
) -> list[np.ndarray]:
    """Sole polygons of the robot's feet in the world [m], one ``(k, 3)`` array per
    leg, in the robot's current configuration: each leg's :class:`Sole`
    (:func:`robot_soles`, MuJoCo's floor contacts in the start pose) carried by its
    foot body.

    Raises:
        UnknownName: A leg the robot does not have, or an unknown sole geom.
        InvalidInput: A foot without collision geoms, or touching at fewer than 3
            points in the start pose (no area to stand on).
    """
    found = robot_soles(robot, legs, tolerance, soles=soles)
    return [found[leg].polygon(robot.model, robot.data) for leg in legs]


def sole_size(robot: RobotModel, legs: Sequence[str] = ("rleg", "lleg")) -> tuple[float, float]:
    """Length and width [m] of the robot's soles: the mean over ``legs`` of each
    :class:`Sole`'s extent along its x and y axes."""
    sizes = np.array([sole.size for sole in robot_soles(robot, legs).values()])
    length, width = sizes.mean(axis=0)
    return float(length), float(width)
