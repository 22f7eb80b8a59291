"""Planar polygons and half-planes: convex hulls, areas, the half-plane form
of a convex polygon and back, signed distances, inward offsets.

A planar region is a :class:`HalfPlanes` ``(A, b)`` meaning
``{c : A c + b >= 0}`` with unit-norm rows of ``A``, so ``A c + b`` is the
signed distance [m] of ``c`` to each edge line (positive inside). Polygons are
vertex arrays ``(m, 2)`` ordered counter-clockwise.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import HalfspaceIntersection

from pik_mj.balance.values import finite_array, real
from pik_mj.exceptions import InvalidInput

Point = tuple[float, float]


def _cross2(o: Point, a: Point, b: Point) -> float:
    """z-component of ``(a - o) x (b - o)`` (positive for a left turn)."""
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _chain(points: list[Point]) -> list[Point]:
    """One chain of Andrew's monotone chain: the points (sorted) kept while each
    turn is strictly to the left."""
    out: list[Point] = []
    for p in points:
        while len(out) >= 2 and _cross2(out[-2], out[-1], p) <= 0.0:
            out.pop()
        out.append(p)
    return out


def _drop_flat_vertices(hull: list[Point], dist_tol: float) -> list[Point]:
    """Drops vertices within ``dist_tol`` of a neighbour or of the neighbours' line."""
    v = list(hull)
    changed = True
    while changed and len(v) >= 3:
        changed = False
        for i in range(len(v)):
            a, p, b = v[i - 1], v[i], v[(i + 1) % len(v)]
            lab = math.hypot(b[0] - a[0], b[1] - a[1])
            near = math.hypot(p[0] - a[0], p[1] - a[1]) <= dist_tol
            flat = lab > 0.0 and _cross2(a, b, p) / lab >= -dist_tol
            if near or flat or lab == 0.0:
                del v[i]
                changed = True
                break
    return v


def convex_hull_2d(
    points: np.ndarray, *, allow_degenerate: bool = False, tol: float | None = None
) -> np.ndarray:
    """Convex hull of planar points (Andrew's monotone chain).

    Duplicate and collinear points are removed: after the hull is built, a vertex
    closer than ``tol`` to its predecessor, or within ``tol`` of the line through
    its two neighbours, is dropped (repeatedly). Dropping such a vertex moves the
    boundary by at most ``tol``.

    Args:
        points: Points ``(n, 2)`` [m].
        allow_degenerate: Return 1 or 2 points (a point or a segment) instead of
            raising when the points do not span an area.
        tol: Distance tolerance [m]; default ``1e-9`` times the extent of the points.

    Returns:
        Hull vertices ``(m, 2)``, counter-clockwise.

    Raises:
        InvalidInput: Wrong shape, non-finite values, or fewer than 3 non-collinear
            points (unless ``allow_degenerate``).
    """
    return _hull(finite_array(points, (None, 2), "points"), allow_degenerate, tol)


def _hull(pts: np.ndarray, allow_degenerate: bool, tol: float | None) -> np.ndarray:
    """:func:`convex_hull_2d` of finite points ``pts`` (n, 2)."""
    if len(pts) == 0:
        raise InvalidInput("points is empty: need at least 3 non-collinear points")
    # the distinct points sorted lexicographically by (x, y), as np.unique(pts, axis=0)
    distinct = sorted(set(map(tuple, pts.tolist())))
    pts = np.array(distinct, dtype=float).reshape(-1, 2)
    dist_tol = 1e-9 * _extent(pts) if tol is None else real(tol, "tol")
    hull = pts
    if len(pts) >= 3:  # on Python floats: a few points, many small steps
        lower, upper = _chain(distinct), _chain(distinct[::-1])
        hull = np.array(_drop_flat_vertices(lower[:-1] + upper[:-1], dist_tol)).reshape(-1, 2)
    if len(hull) >= 3:
        return hull
    if not allow_degenerate:
        raise InvalidInput(
            f"degenerate point set: the {len(pts)} distinct point(s) are collinear or "
            f"coincident (within {dist_tol:.3g} m) and span no area; a convex hull "
            "needs at least 3 non-collinear points"
        )
    if _extent(pts) <= dist_tol:
        return pts[:1]
    # Segment: the two extreme points along the principal direction.
    d = pts - pts.mean(axis=0)
    axis = np.linalg.svd(d, full_matrices=False)[2][0]
    s = d @ axis
    return pts[[int(np.argmin(s)), int(np.argmax(s))]]


def _extent(pts: np.ndarray) -> float:
    """The largest side [m] of the points' (n, 2) bounding box (0 for one point)."""
    return float(np.max(np.ptp(pts, axis=0))) if len(pts) > 1 else 0.0


def hull_region(
    points: np.ndarray, *, allow_degenerate: bool = False, tol: float | None = None
) -> tuple[np.ndarray, HalfPlanes | None, float]:
    """The convex hull of planar points (:func:`convex_hull_2d`) and, when it
    spans an area (3 vertices or more), its :func:`halfplanes_from_polygon`
    and :func:`polygon_area` (else None and 0), the hull checked once.

    Args:
        points: Points ``(n, 2)`` [m].
        allow_degenerate, tol: As :func:`convex_hull_2d`.

    Returns:
        ``(vertices (m, 2) counter-clockwise, half-planes or None, area [m²])``.

    Raises:
        InvalidInput: As :func:`convex_hull_2d` and :func:`halfplanes_from_polygon`.
    """
    hull = _hull(finite_array(points, (None, 2), "points"), allow_degenerate, tol)
    if len(hull) < 3:
        return hull, None, 0.0
    return hull, _halfplanes(hull), _area(hull)


def _next(a: np.ndarray) -> np.ndarray:
    """The rows of ``a`` each replaced by the next one, the last by the first
    (``np.roll(a, -1, axis=0)``)."""
    return np.concatenate([a[1:], a[:1]])


def polygon_area(vertices: np.ndarray) -> float:
    """Signed area of a polygon (shoelace formula), positive when counter-clockwise.

    .. math::

        A = \\tfrac12 \\sum_i (x_i y_{i+1} - x_{i+1} y_i)

    Args:
        vertices: Polygon vertices ``(m, 2)`` [m].

    Returns:
        Area [m²].
    """
    return _area(finite_array(vertices, (None, 2), "vertices"))


def _area(v: np.ndarray) -> float:
    """:func:`polygon_area` of finite vertices ``v`` (m, 2)."""
    if len(v) < 3:
        return 0.0
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, _next(y)) - np.dot(_next(x), y))


class HalfPlanes(NamedTuple):
    """Planar region ``{c : A c + b >= 0}``; rows of ``A`` have unit norm.

    Attributes:
        A: Inward unit normals ``(m, 2)``.
        b: Offsets ``(m,)`` [m]; ``A c + b`` is the signed distance to each edge line.
    """

    A: np.ndarray
    b: np.ndarray


def _check_halfplanes(hp: HalfPlanes) -> tuple[np.ndarray, np.ndarray]:
    A = finite_array(hp.A, (None, 2), "HalfPlanes.A")
    b = finite_array(hp.b, (len(A),), "HalfPlanes.b")
    if len(A) == 0:
        raise InvalidInput("HalfPlanes has no rows (an empty region description)")
    norms = np.linalg.norm(A, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-9):
        raise InvalidInput(f"HalfPlanes.A rows must have unit norm, got norms {norms}")
    return A, b


def halfplanes_from_polygon(vertices_ccw: np.ndarray) -> HalfPlanes:
    """Half-plane form of a convex counter-clockwise polygon.

    For the edge ``v_i -> v_{i+1}`` with unit direction ``t_i``, the inward normal is
    ``a_i = (-t_y, t_x)`` (left of the edge) and

    .. math::

        d_i(c) = a_i^T (c - v_i) = a_i^T c + b_i, \\qquad b_i = -a_i^T v_i

    Args:
        vertices_ccw: Convex polygon ``(m, 2)`` [m], counter-clockwise, m >= 3.

    Returns:
        :class:`HalfPlanes` with one row per edge.

    Raises:
        InvalidInput: Fewer than 3 vertices, clockwise or non-convex order,
            repeated vertices.
    """
    return _halfplanes(finite_array(vertices_ccw, (None, 2), "vertices_ccw"))


def _halfplanes(v: np.ndarray) -> HalfPlanes:
    """:func:`halfplanes_from_polygon` of finite vertices ``v`` (m, 2)."""
    if len(v) < 3:
        raise InvalidInput(f"a polygon needs at least 3 vertices, got {len(v)}")
    # on Python floats, as numpy's elementwise steps: a few vertices
    points = v.tolist()
    scale = max(max(max(c) - min(c) for c in zip(*points, strict=True)), 1e-300)
    t = []
    for (x0, y0), (x1, y1) in zip(points, points[1:] + points[:1], strict=True):
        ex, ey = x1 - x0, y1 - y0
        length = math.sqrt(ex * ex + ey * ey)  # as np.linalg.norm(edges, axis=1)
        if length <= 1e-12 * scale:
            raise InvalidInput("vertices_ccw has repeated consecutive vertices")
        t.append((ex / length, ey / length))
    if any(a[0] * b[1] - a[1] * b[0] <= 0.0 for a, b in zip(t, t[1:] + t[:1], strict=True)):
        raise InvalidInput(
            "vertices_ccw must be a strictly convex polygon in counter-clockwise "
            "order (use convex_hull_2d to obtain one)"
        )
    A = np.array([(-ty, tx) for tx, ty in t])
    b = -np.einsum("ij,ij->i", A, v)
    return HalfPlanes(A, b)


def polygon_from_halfplanes(hp: HalfPlanes) -> np.ndarray:
    """Vertices of a bounded region given by half-planes.

    An interior point is found as the Chebyshev centre (an LP), then
    ``scipy.spatial.HalfspaceIntersection`` gives the vertices.

    Args:
        hp: Region ``{c : A c + b >= 0}``.

    Returns:
        Vertices ``(m, 2)`` counter-clockwise.

    Raises:
        InvalidInput: The region is empty, has no interior, or is unbounded.
    """
    A, b = _check_halfplanes(hp)
    # Chebyshev centre: max r  s.t.  A c + b >= r, 0 <= r <= 1e6  (unit-norm rows).
    res = linprog(
        c=[0.0, 0.0, -1.0],
        A_ub=np.column_stack([-A, np.ones(len(A))]),
        b_ub=b,
        bounds=[(None, None), (None, None), (None, 1e6)],
        method="highs",
    )
    if res.status == 2:
        raise InvalidInput("the half-planes have an empty intersection")
    if res.status != 0:
        raise InvalidInput(f"Chebyshev-centre LP failed: {res.message}")
    r = float(res.x[2])
    if r >= 1e6 * (1 - 1e-9):
        raise InvalidInput("the half-plane region is unbounded (no polygon)")
    if r < -1e-12:
        raise InvalidInput(
            f"the half-planes have an empty intersection (violated by >= {-r:.3g} m)"
        )
    if r <= 1e-12:
        raise InvalidInput("the half-plane region has no interior (zero area)")
    center = res.x[:2]
    try:
        hs = HalfspaceIntersection(np.column_stack([-A, -b]), center)
    except Exception as exc:  # qhull errors (QhullError) are not exported stably.
        raise InvalidInput(f"half-plane intersection failed: {exc}") from exc
    pts = hs.intersections
    if not np.all(np.isfinite(pts)):
        raise InvalidInput("the half-plane region is unbounded (no polygon)")
    return convex_hull_2d(pts)


def signed_distance(hp: HalfPlanes, c: np.ndarray) -> float:
    """Smallest signed distance of ``c`` to the edge lines [m], positive inside.

    .. math::

        s(c) = \\min_i (A_i c + b_i)

    Inside a convex polygon this is the exact distance to the boundary. Outside,
    ``-s(c)`` is the largest violation, a lower bound on the Euclidean distance (exact
    where the nearest boundary point is inside an edge, not at a vertex).

    Args:
        hp: Region.
        c: Point ``(2,)`` [m].

    Returns:
        Signed distance [m].
    """
    A, b = _check_halfplanes(hp)
    p = finite_array(c, (2,), "c")
    return float(np.min(A @ p + b))


def shrink(hp: HalfPlanes, margin: float) -> HalfPlanes:
    """Moves every edge inward by ``margin`` [m] (outward if negative).

    .. math::

        b_i \\leftarrow b_i - \\text{margin}
    """
    A, b = _check_halfplanes(hp)
    m = real(margin, "margin")
    return HalfPlanes(A.copy(), b - m)


def inset_vertices(hp: HalfPlanes, d: float) -> np.ndarray:
    """Vertices ``(k, 2)`` [m] of the convex polygon ``hp`` (edges in
    counter-clockwise order) with every edge moved inward by ``d`` [m]: the
    iso-margin outline, where the margin is ``d``. ``(0, 2)`` when it vanishes
    (shrunk past a vertex) or is near-degenerate.

    Vertex ``i`` is where the moved edges ``i-1`` and ``i`` meet:
    ``a_{i-1}^T v + b_{i-1} - d = 0 = a_i^T v + b_i - d``.
    """
    try:
        A, b = shrink(hp, d)
    except InvalidInput:  # near-degenerate hull
        return np.zeros((0, 2))
    out = []
    for i in range(len(A)):
        M = np.array([A[i - 1], A[i]])
        if abs(np.linalg.det(M)) < 1e-12:
            return np.zeros((0, 2))
        out.append(np.linalg.solve(M, -np.array([b[i - 1], b[i]])))
    uv = np.array(out)
    if np.any(uv @ A.T + b < -1e-9):  # shrunk past a vertex: not the true offset
        return np.zeros((0, 2))
    return uv
