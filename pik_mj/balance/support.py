"""The support polygon: the convex hull of the contact polygons projected along
the up direction (prioritized-IK manual: ``centroid-support-polygon-task``)."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pik_mj.balance.polygon import HalfPlanes, hull_region, inset_vertices, signed_distance
from pik_mj.balance.values import finite_array
from pik_mj.exceptions import InvalidInput


def plane_basis(normal: np.ndarray) -> np.ndarray:
    """Right-handed basis ``R = [e1 e2 n]`` of the plane orthogonal to ``normal``.

    ``e1`` is the world x-axis projected onto the plane (the y-axis when x is
    within ~8° of ``normal``), ``e2 = n x e1``.

    Args:
        normal: Plane normal ``(3,)`` (any length > 0).

    Returns:
        Rotation ``(3, 3)`` with columns ``e1, e2, n``.
    """
    n = finite_array(normal, (3,), "normal")
    return _plane_basis(*n.tolist()).copy()


@functools.lru_cache(maxsize=64)
def _plane_basis(x: float, y: float, z: float) -> np.ndarray:
    """:func:`plane_basis` of the normal ``(x, y, z)``, kept by its value (most
    callers ask about the same up direction)."""
    n = np.array([x, y, z])
    norm = float(np.linalg.norm(n))
    if norm < 1e-12:
        raise InvalidInput(f"normal must be a non-zero vector, got {n}")
    n = n / norm
    e1 = np.array([1.0, 0.0, 0.0]) - n[0] * n
    if np.linalg.norm(e1) < 0.15:
        e1 = np.array([0.0, 1.0, 0.0]) - n[1] * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    return np.column_stack([e1, e2, n])


@dataclass(frozen=True, eq=False)
class SupportRegion:
    """Support polygon in the plane orthogonal to a normal.

    Attributes:
        vertices_2d: Hull vertices ``(m, 2)`` [m] in plane coordinates, ccw about n
            (1 or 2 rows for a degenerate region: a point or a segment).
        vertices_3d: The same vertices in the world ``(m, 3)`` [m], on the plane
            orthogonal to ``n`` at ``height`` (the mean height of the input points).
        halfplanes: Half-planes in plane coordinates (distances in m); None for a
            degenerate region.
        R: Basis ``(3, 3)``, columns ``e1, e2, n`` (world frame).
        height: ``n · p`` of the plane holding ``vertices_3d`` [m].
        area: Area [m²] (0 when degenerate).
    """

    vertices_2d: np.ndarray
    vertices_3d: np.ndarray
    halfplanes: HalfPlanes | None
    R: np.ndarray
    height: float
    area: float

    def to_plane(self, p_W: np.ndarray) -> np.ndarray:
        """Plane coordinates ``(e1·p, e2·p)`` of a world point ``p_W`` (3,) [m]."""
        return self.R[:, :2].T @ finite_array(p_W, (3,), "p_W")

    def from_plane(self, uv: np.ndarray) -> np.ndarray:
        """World point on the region's plane with plane coordinates ``uv`` (2,)."""
        u = finite_array(uv, (2,), "uv")
        return self.R @ np.array([u[0], u[1], self.height])

    def signed_distance(self, p_W: np.ndarray) -> float:
        """Signed distance [m] of the projection of ``p_W`` (3,), positive inside;
        for a degenerate region (a point or a segment) minus the distance to it."""
        c = self.to_plane(p_W)
        if self.halfplanes is not None:
            return signed_distance(self.halfplanes, c)
        if len(self.vertices_2d) == 2:
            a, b = self.vertices_2d
            t = float(np.clip((c - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
            return -float(np.linalg.norm(c - (a + t * (b - a))))
        return -float(np.linalg.norm(c - self.vertices_2d[0]))

    def shrunk(self, d: float) -> np.ndarray:
        """World vertices ``(k, 3)`` [m] of the polygon with every edge moved inward
        by ``d`` [m] (the iso-margin outline: where the margin is ``d``); ``(0, 3)``
        when it vanishes or the region is degenerate.

        (:func:`inset_vertices` in the polygon's plane).
        """
        if self.halfplanes is None:
            return np.zeros((0, 3))
        uv = inset_vertices(self.halfplanes, d)
        if len(uv) == 0:
            return np.zeros((0, 3))
        return uv @ self.R[:, :2].T + self.height * self.R[:, 2]


def support_polygon(
    polygons: Sequence[np.ndarray],
    normal: np.ndarray = (0.0, 0.0, 1.0),
    *,
    allow_degenerate: bool = False,
    tol: float | None = None,
) -> SupportRegion:
    """Convex hull of contact polygons projected along ``normal``.

    .. math::

        {}^0p = (e_1^T p,\\; e_2^T p), \\qquad
        \\mathcal{S} = \\operatorname{conv}\\{{}^0p_{ij}\\}

    Args:
        polygons: Contact polygons (or contact points), each ``(k_i, 3)`` world
            points [m].
        normal: Up direction ``(3,)``; the hull lives in the plane orthogonal to it.
        allow_degenerate: Return a region of 1 or 2 vertices (a point or a
            segment) instead of raising when the points span no area.
        tol: Distance [m] below which hull vertices merge (see
            :func:`convex_hull_2d`).

    Returns:
        :class:`SupportRegion`.

    Raises:
        InvalidInput: Empty list, wrong shapes, non-finite values, or (unless
            ``allow_degenerate``) projected points that span no area.
    """
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2:
        raise InvalidInput("polygons must be a list of (k, 3) arrays, not one array")
    polys = list(polygons)
    if not polys:
        raise InvalidInput("polygons is empty: give at least one contact polygon")
    pts = np.concatenate(
        [finite_array(p, (None, 3), f"polygons[{i}]") for i, p in enumerate(polys)]
    )
    if len(pts) == 0:
        raise InvalidInput("polygons contain no points")
    R = plane_basis(normal)
    uv = pts @ R[:, :2]
    try:
        hull, halfplanes, area = hull_region(uv, allow_degenerate=allow_degenerate, tol=tol)
    except InvalidInput as exc:
        raise InvalidInput(
            f"degenerate support polygon: the contact points projected along the "
            f"normal {R[:, 2]} span no area ({exc})"
        ) from exc
    height = float(np.mean(pts @ R[:, 2]))
    v3 = hull @ R[:, :2].T + height * R[:, 2]
    return SupportRegion(
        vertices_2d=hull, vertices_3d=v3, halfplanes=halfplanes, R=R, height=height, area=area
    )
