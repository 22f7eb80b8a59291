"""The support polygon of a walk: the soles carrying the robot at a tick, each its
:class:`~pik_mj.robot.ground.Sole` polygon (from MuJoCo's contacts) at its planned
or measured pose, and the signed distance of a ZMP to their convex hull.

A sole with outline :math:`o_i` (its polygon in the sole frame, k × 2) at
position :math:`p` and heading :math:`\\psi` covers

.. math::

    P = \\{p_{xy} + R(\\psi)\\, o_i\\}, \\qquad
    m(z) = \\min_j \\big(a_j^T z + b_j\\big)

with :math:`a_j^T z + b_j \\ge 0` the edges of the convex hull of the polygons of
the supporting soles (positive inside, :func:`pik_mj.balance.signed_distance`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pik_mj.balance import convex_hull_2d, halfplanes_from_polygon, signed_distance
from pik_mj.exceptions import InvalidInput
from pik_mj.walking.gait import DOUBLE_SUPPORT, GaitPlan

__all__ = ["outline_at", "support_margin", "zmp_margin"]


def outline_at(p_W: np.ndarray, yaw: float, outline: np.ndarray) -> np.ndarray:
    """A sole polygon (k, 2) [m] in the world: ``outline`` (k, 2) [m], given in
    the sole frame, placed at ``p_W`` (its xy) with heading ``yaw`` [rad]."""
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s], [s, c]])
    return np.asarray(p_W, dtype=float)[:2] + np.asarray(outline, dtype=float) @ R.T


def zmp_margin(zmp: np.ndarray, polygons: Sequence[np.ndarray]) -> float:
    """Signed distance [m] of ``zmp`` (2,) to the convex hull of ``polygons``
    (each (k, 2) [m]), positive inside."""
    hull = convex_hull_2d(np.vstack(polygons))
    return float(signed_distance(halfplanes_from_polygon(hull), np.asarray(zmp, dtype=float)))


def support_margin(
    plan: GaitPlan, zmp: np.ndarray, outlines: Mapping[str, np.ndarray]
) -> np.ndarray:
    """Signed distance of the ZMP to the planned support polygon at every tick [m].

    The support polygon of tick k is the hull of the soles in contact per the
    plan's support label (both in double support), at their planned poses.

    Args:
        plan: The gait plan.
        zmp: ZMP per tick (K, 2) [m].
        outlines: Each leg's sole polygon in its sole frame (k, 2) [m]
            (:attr:`pik_mj.robot.ground.Sole.outline`).

    Returns:
        (K,) signed distances [m], positive inside.
    """
    zmp = np.asarray(zmp, dtype=float)
    if zmp.shape != (len(plan.t), 2):
        raise InvalidInput(f"zmp must have shape ({len(plan.t)}, 2), got {zmp.shape}")
    limbs = plan.params.all_limbs
    missing = [lb for lb in limbs if lb not in outlines]
    if missing:
        raise InvalidInput(f"no sole outline for legs {missing}; got {list(outlines)}")
    out = np.empty(len(plan.t))
    for k, label in enumerate(plan.support):
        feet = limbs if label == DOUBLE_SUPPORT else (label,)
        polygons = [
            outline_at(plan.feet_p[lb][k], plan.feet_yaw[lb][k], outlines[lb]) for lb in feet
        ]
        out[k] = zmp_margin(zmp[k], polygons)
    return out
