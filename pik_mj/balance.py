"""Static-balance geometry: support polygon, contact wrench limits, equilibrium, SCFR.

Everything here is pure numpy/scipy (LPs are solved with ``scipy.optimize.linprog``,
HiGHS). Seed 000, ``centroid-support-polygon-task`` and ``centroid-scfr-task``;
DESIGN.md §5.

Conventions:

* A planar region is a :class:`HalfPlanes` ``(A, b)`` meaning
  ``{c : A c + b >= 0}`` with unit-norm rows of ``A``, so ``A c + b`` is the signed
  distance [m] of ``c`` to each edge line (positive inside).
* Polygons are vertex arrays ``(m, 2)`` ordered counter-clockwise.
* The robot receives the contact wrench ``w_i = (f_i, n_i)`` [N, N·m], expressed in
  the world frame, the moment taken about the contact frame origin ``p_WC``.
* Static equilibrium about the world origin (``g`` = gravity vector [m/s²]):

  .. math::

      \\sum_i \\begin{bmatrix} f_i \\\\ n_i + p_i \\times f_i \\end{bmatrix}
      + \\begin{bmatrix} m g \\\\ c \\times m g \\end{bmatrix}
      + \\sum_k \\begin{bmatrix} f_k \\\\ \\tau_k + p_k \\times f_k \\end{bmatrix} = 0
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import linprog
from scipy.spatial import HalfspaceIntersection

from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.spatial import STANDARD_GRAVITY, rot_z, skew

GRAVITY = (0.0, 0.0, -STANDARD_GRAVITY)
"""Gravity vector [m/s²] (world frame, z up) of the functions here, which take no
model; pass ``model.opt.gravity`` when there is one."""

_ROTATION_TOL = 1e-6


# ----------------------------------------------------------------------------
# Input helpers
# ----------------------------------------------------------------------------


def _array(value: object, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    """Returns ``value`` as a finite float array of ``shape`` (None = any length)."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be a numeric array of shape {shape}") from exc
    if arr.ndim != len(shape) or any(
        s is not None and s != n for s, n in zip(shape, arr.shape, strict=True)
    ):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise InvalidInput(f"{name} must have shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInput(f"{name} must be finite (no NaN/inf), got {arr}")
    return arr


def _scalar(value: object, name: str, *, allow_inf: bool = False) -> float:
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be a real number, got {value!r}") from exc
    if math.isnan(x) or (not allow_inf and math.isinf(x)):
        raise InvalidInput(f"{name} must be finite, got {x}")
    return x


def _cross2(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """z-component of ``(a - o) x (b - o)`` (positive for a left turn)."""
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


# ----------------------------------------------------------------------------
# Planar polygons and half-planes
# ----------------------------------------------------------------------------


def _drop_flat_vertices(hull: np.ndarray, dist_tol: float) -> np.ndarray:
    """Drops vertices within ``dist_tol`` of a neighbour or of the neighbours' line."""
    v = [p for p in hull]
    changed = True
    while changed and len(v) >= 3:
        changed = False
        for i in range(len(v)):
            a, p, b = v[i - 1], v[i], v[(i + 1) % len(v)]
            ab = b - a
            lab = float(np.linalg.norm(ab))
            near = float(np.linalg.norm(p - a)) <= dist_tol
            flat = lab > 0.0 and _cross2(a, b, p) / lab >= -dist_tol
            if near or flat or lab == 0.0:
                del v[i]
                changed = True
                break
    return np.array(v)


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
    pts = _array(points, (None, 2), "points")
    if len(pts) == 0:
        raise InvalidInput("points is empty: need at least 3 non-collinear points")
    pts = np.unique(pts, axis=0)  # sorted lexicographically by (x, y)
    extent = float(np.max(np.ptp(pts, axis=0))) if len(pts) > 1 else 0.0
    dist_tol = 1e-9 * extent if tol is None else _scalar(tol, "tol")
    hull = pts
    if len(pts) >= 3:

        def chain(seq: np.ndarray) -> list[np.ndarray]:
            out: list[np.ndarray] = []
            for p in seq:
                while len(out) >= 2 and _cross2(out[-2], out[-1], p) <= 0.0:
                    out.pop()
                out.append(p)
            return out

        lower = chain(pts)
        upper = chain(pts[::-1])
        hull = _drop_flat_vertices(np.array(lower[:-1] + upper[:-1]), dist_tol)
    if len(hull) >= 3:
        return hull
    if not allow_degenerate:
        raise InvalidInput(
            f"degenerate point set: the {len(pts)} distinct point(s) are collinear or "
            f"coincident (within {dist_tol:.3g} m) and span no area; a convex hull "
            "needs at least 3 non-collinear points"
        )
    if extent <= dist_tol:
        return pts[:1]
    # Segment: the two extreme points along the principal direction.
    d = pts - pts.mean(axis=0)
    axis = np.linalg.svd(d, full_matrices=False)[2][0]
    s = d @ axis
    return pts[[int(np.argmin(s)), int(np.argmax(s))]]


def polygon_area(vertices: np.ndarray) -> float:
    """Signed area of a polygon (shoelace formula), positive when counter-clockwise.

    .. math::

        A = \\tfrac12 \\sum_i (x_i y_{i+1} - x_{i+1} y_i)

    Args:
        vertices: Polygon vertices ``(m, 2)`` [m].

    Returns:
        Area [m²].
    """
    v = _array(vertices, (None, 2), "vertices")
    if len(v) < 3:
        return 0.0
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


class HalfPlanes(NamedTuple):
    """Planar region ``{c : A c + b >= 0}``; rows of ``A`` have unit norm.

    Attributes:
        A: Inward unit normals ``(m, 2)``.
        b: Offsets ``(m,)`` [m]; ``A c + b`` is the signed distance to each edge line.
    """

    A: np.ndarray
    b: np.ndarray


def _check_halfplanes(hp: HalfPlanes) -> tuple[np.ndarray, np.ndarray]:
    A = _array(hp.A, (None, 2), "HalfPlanes.A")
    b = _array(hp.b, (len(A),), "HalfPlanes.b")
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
    v = _array(vertices_ccw, (None, 2), "vertices_ccw")
    if len(v) < 3:
        raise InvalidInput(f"a polygon needs at least 3 vertices, got {len(v)}")
    edges = np.roll(v, -1, axis=0) - v
    lengths = np.linalg.norm(edges, axis=1)
    scale = max(float(np.max(np.ptp(v, axis=0))), 1e-300)
    if np.any(lengths <= 1e-12 * scale):
        raise InvalidInput("vertices_ccw has repeated consecutive vertices")
    t = edges / lengths[:, None]
    turns = t[:, 0] * np.roll(t, -1, axis=0)[:, 1] - t[:, 1] * np.roll(t, -1, axis=0)[:, 0]
    if np.any(turns <= 0.0):
        raise InvalidInput(
            "vertices_ccw must be a strictly convex polygon in counter-clockwise "
            "order (use convex_hull_2d to obtain one)"
        )
    A = np.column_stack([-t[:, 1], t[:, 0]])
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
    p = _array(c, (2,), "c")
    return float(np.min(A @ p + b))


def shrink(hp: HalfPlanes, margin: float) -> HalfPlanes:
    """Moves every edge inward by ``margin`` [m] (outward if negative).

    .. math::

        b_i \\leftarrow b_i - \\text{margin}
    """
    A, b = _check_halfplanes(hp)
    m = _scalar(margin, "margin")
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


# ----------------------------------------------------------------------------
# Support polygon
# ----------------------------------------------------------------------------


def plane_basis(normal: np.ndarray) -> np.ndarray:
    """Right-handed basis ``R = [e1 e2 n]`` of the plane orthogonal to ``normal``.

    ``e1`` is the world x-axis projected onto the plane (the y-axis when x is
    within ~8° of ``normal``), ``e2 = n x e1``.

    Args:
        normal: Plane normal ``(3,)`` (any length > 0).

    Returns:
        Rotation ``(3, 3)`` with columns ``e1, e2, n``.
    """
    n = _array(normal, (3,), "normal")
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
        return self.R[:, :2].T @ _array(p_W, (3,), "p_W")

    def from_plane(self, uv: np.ndarray) -> np.ndarray:
        """World point on the region's plane with plane coordinates ``uv`` (2,)."""
        u = _array(uv, (2,), "uv")
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
    pts = np.concatenate([_array(p, (None, 3), f"polygons[{i}]") for i, p in enumerate(polys)])
    if len(pts) == 0:
        raise InvalidInput("polygons contain no points")
    R = plane_basis(normal)
    uv = pts @ R[:, :2]
    try:
        hull = convex_hull_2d(uv, allow_degenerate=allow_degenerate, tol=tol)
    except InvalidInput as exc:
        raise InvalidInput(
            f"degenerate support polygon: the contact points projected along the "
            f"normal {R[:, 2]} span no area ({exc})"
        ) from exc
    height = float(np.mean(pts @ R[:, 2]))
    v3 = hull @ R[:, :2].T + height * R[:, 2]
    area = len(hull) >= 3
    return SupportRegion(
        vertices_2d=hull,
        vertices_3d=v3,
        halfplanes=halfplanes_from_polygon(hull) if area else None,
        R=R,
        height=height,
        area=polygon_area(hull) if area else 0.0,
    )


# ----------------------------------------------------------------------------
# Contacts and their wrench limits
# ----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ContactConstraint:
    """A rectangular (or point) contact with Coulomb friction.

    Attributes:
        p_WC: Contact frame origin in the world ``(3,)`` [m] (rectangle centre).
        R_WC: Contact frame rotation ``(3, 3)``; its z-axis is the contact normal
            pointing INTO the robot (the direction the environment pushes).
        half_x: Half-size of the rectangle along the contact x-axis [m] (0: point).
        half_y: Half-size along the contact y-axis [m] (0: point).
        mu: Friction coefficient (>= 0).
        fz_min: Lower bound of the normal force [N] (>= 0).
        fz_max: Upper bound of the normal force [N] (> fz_min, may be inf).
        torsion: Bound the yaw moment by the exact rectangular-contact wrench cone
            (Caron et al. 2015). If False the moment about the normal is free.
        pyramid: ``"inscribed"`` (default, conservative): ``|fx|, |fy| <= mu fz/√2``,
            a pyramid inside the circular cone. ``"circumscribed"``:
            ``|fx|, |fy| <= mu fz``, which contains the cone (allows up to √2·mu
            along the diagonals).
    """

    p_WC: np.ndarray
    R_WC: np.ndarray
    half_x: float = 0.0
    half_y: float = 0.0
    mu: float = 0.5
    fz_min: float = 0.0
    fz_max: float = math.inf
    torsion: bool = True
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed"

    def __post_init__(self) -> None:
        p = _array(self.p_WC, (3,), "ContactConstraint.p_WC")
        R = _array(self.R_WC, (3, 3), "ContactConstraint.R_WC")
        err = float(np.max(np.abs(R.T @ R - np.eye(3))))
        if err > _ROTATION_TOL or np.linalg.det(R) < 0.0:
            raise InvalidInput(
                f"ContactConstraint.R_WC must be a rotation (orthonormal, det +1); "
                f"|R^T R - I| = {err:.2e}, det = {np.linalg.det(R):.3f}"
            )
        hx = _scalar(self.half_x, "ContactConstraint.half_x")
        hy = _scalar(self.half_y, "ContactConstraint.half_y")
        if hx < 0.0 or hy < 0.0:
            raise InvalidInput(f"half_x, half_y must be >= 0 [m], got {hx}, {hy}")
        mu = _scalar(self.mu, "ContactConstraint.mu")
        if mu < 0.0:
            raise InvalidInput(f"friction coefficient mu must be >= 0, got {mu}")
        lo = _scalar(self.fz_min, "ContactConstraint.fz_min")
        hi = _scalar(self.fz_max, "ContactConstraint.fz_max", allow_inf=True)
        if lo < 0.0:
            raise InvalidInput(f"fz_min must be >= 0 [N], got {lo}")
        if not hi > lo:
            raise InvalidInput(f"fz_max must be > fz_min = {lo} [N], got {hi}")
        if self.pyramid not in ("inscribed", "circumscribed"):
            raise InvalidInput(
                f"pyramid must be 'inscribed' or 'circumscribed', got {self.pyramid!r}"
            )
        for name, val in (
            ("p_WC", p),
            ("R_WC", R),
            ("half_x", hx),
            ("half_y", hy),
            ("mu", mu),
            ("fz_min", lo),
            ("fz_max", hi),
            ("torsion", bool(self.torsion)),
        ):
            if isinstance(val, np.ndarray):
                val.flags.writeable = False
            object.__setattr__(self, name, val)

    @property
    def mu_pyramid(self) -> float:
        """Pyramid coefficient: ``mu/√2`` (inscribed) or ``mu`` (circumscribed)."""
        return self.mu / math.sqrt(2.0) if self.pyramid == "inscribed" else self.mu

    def corners(self) -> np.ndarray:
        """World corners of the contact rectangle ``(4, 3)`` [m], ccw about z_C."""
        s = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], dtype=float)
        local = np.column_stack([s[:, 0] * self.half_x, s[:, 1] * self.half_y, np.zeros(4)])
        return self.p_WC + local @ self.R_WC.T

    def __repr__(self) -> str:
        return (
            f"ContactConstraint(p_WC={np.round(self.p_WC, 4).tolist()}, "
            f"normal={np.round(self.R_WC[:, 2], 4).tolist()}, half_x={self.half_x}, "
            f"half_y={self.half_y}, mu={self.mu}, fz=[{self.fz_min}, {self.fz_max}], "
            f"torsion={self.torsion}, pyramid={self.pyramid!r})"
        )


def foot_contact(
    p_W: np.ndarray,
    yaw: float,
    half_x: float,
    half_y: float,
    mu: float,
    fz_max: float = math.inf,
    *,
    fz_min: float = 0.0,
    torsion: bool = True,
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed",
) -> ContactConstraint:
    """A sole on horizontal ground: normal +z, rectangle yawed by ``yaw`` [rad].

    Args:
        p_W: Sole centre ``(3,)`` [m].
        yaw: Rotation about world z [rad].
        half_x: Half length [m].
        half_y: Half width [m].
        mu: Friction coefficient.
        fz_max: Normal force bound [N].
        fz_min: Minimum normal force [N].
        torsion: See :class:`ContactConstraint`.
        pyramid: See :class:`ContactConstraint`.
    """
    return ContactConstraint(
        p_WC=p_W,
        R_WC=rot_z(_scalar(yaw, "yaw")),
        half_x=half_x,
        half_y=half_y,
        mu=mu,
        fz_min=fz_min,
        fz_max=fz_max,
        torsion=torsion,
        pyramid=pyramid,
    )


def contact_from_normal(
    p_W: np.ndarray,
    normal: np.ndarray,
    half_x: float = 0.0,
    half_y: float = 0.0,
    mu: float = 0.5,
    fz_max: float = math.inf,
    *,
    fz_min: float = 0.0,
    torsion: bool = True,
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed",
) -> ContactConstraint:
    """A contact whose normal (into the robot) is ``normal``.

    The contact x-axis is the world x-axis projected on the contact plane (world y
    when x is nearly parallel to the normal), as in :func:`plane_basis`.

    Args:
        p_W: Contact centre ``(3,)`` [m].
        normal: Direction the environment pushes the robot ``(3,)``.
        half_x: Half-size along the contact x-axis [m].
        half_y: Half-size along the contact y-axis [m].
        mu: Friction coefficient.
        fz_max: Normal force bound [N].
        fz_min: Minimum normal force [N].
        torsion: See :class:`ContactConstraint`.
        pyramid: See :class:`ContactConstraint`.
    """
    return ContactConstraint(
        p_WC=p_W,
        R_WC=plane_basis(normal),
        half_x=half_x,
        half_y=half_y,
        mu=mu,
        fz_min=fz_min,
        fz_max=fz_max,
        torsion=torsion,
        pyramid=pyramid,
    )


def wrench_constraints(contact: ContactConstraint) -> tuple[np.ndarray, np.ndarray]:
    """Linear limits ``C w + d >= 0`` on the world contact wrench ``w = (f, n)``.

    In the contact frame, ``w_C = (f_x, f_y, f_z, n_x, n_y, n_z)`` (moment about
    ``p_WC``), with ``X = half_x``, ``Y = half_y``, ``μ'`` the pyramid coefficient
    (:attr:`ContactConstraint.mu_pyramid`):

    .. math::

        f_{z,min} \\le f_z \\le f_{z,max}, \\quad
        |f_x| \\le \\mu' f_z, \\quad |f_y| \\le \\mu' f_z, \\quad
        |n_x| \\le Y f_z, \\quad |n_y| \\le X f_z,

    and, with ``torsion`` (Caron, Pham, Nakamura 2015, the exact wrench cone of
    four corner forces inside the pyramid),

    .. math::

        -\\mu'(X+Y) f_z + |Y f_x - \\mu' n_x| + |X f_y - \\mu' n_y| \\le n_z
        \\le \\mu'(X+Y) f_z - |Y f_x + \\mu' n_x| - |X f_y + \\mu' n_y|

    (each ``|a| + |b| <= e`` expands to 4 rows). The rows are rotated to the world:
    ``C = C_C \\operatorname{diag}(R_{WC}^T, R_{WC}^T)``.

    Args:
        contact: The contact.

    Returns:
        ``C`` ``(r, 6)`` and ``d`` ``(r,)`` [N].
    """
    if not isinstance(contact, ContactConstraint):
        raise InvalidInput(f"expected a ContactConstraint, got {type(contact).__name__}")
    X, Y, mu = contact.half_x, contact.half_y, contact.mu_pyramid
    rows: list[list[float]] = []
    d: list[float] = []

    def row(fx=0.0, fy=0.0, fz=0.0, nx=0.0, ny=0.0, nz=0.0, const=0.0) -> None:
        rows.append([fx, fy, fz, nx, ny, nz])
        d.append(const)

    row(fz=1.0, const=-contact.fz_min)
    if math.isfinite(contact.fz_max):
        row(fz=-1.0, const=contact.fz_max)
    for s in (1.0, -1.0):
        row(fx=s, fz=mu)
        row(fy=s, fz=mu)
        row(nx=s, fz=Y)
        row(ny=s, fz=X)
    if contact.torsion:
        for s1 in (1.0, -1.0):
            for s2 in (1.0, -1.0):
                # n_z - tau_min >= 0
                row(
                    nz=1.0,
                    fz=mu * (X + Y),
                    fx=-s1 * Y,
                    nx=s1 * mu,
                    fy=-s2 * X,
                    ny=s2 * mu,
                )
                # tau_max - n_z >= 0
                row(
                    nz=-1.0,
                    fz=mu * (X + Y),
                    fx=-s1 * Y,
                    nx=-s1 * mu,
                    fy=-s2 * X,
                    ny=-s2 * mu,
                )
    C_C = np.array(rows)
    R = contact.R_WC
    C = np.hstack([C_C[:, :3] @ R.T, C_C[:, 3:] @ R.T])
    return C, np.array(d)


# ----------------------------------------------------------------------------
# Static equilibrium
# ----------------------------------------------------------------------------


class ExternalWrench(NamedTuple):
    """A wrench applied to the robot by something other than the contacts.

    Attributes:
        p_W: Application point ``(3,)`` [m] (world).
        force: Force ``(3,)`` [N] (world).
        moment: Additional pure moment ``(3,)`` [N·m] (world).
    """

    p_W: ArrayLike
    force: ArrayLike
    moment: ArrayLike = (0.0, 0.0, 0.0)


class EquilibriumResult(NamedTuple):
    """Result of :func:`static_equilibrium`.

    Attributes:
        feasible: Balancing contact wrenches exist.
        wrenches: One wrench per contact ``(n, 6)`` = ``(f, n)`` [N, N·m] (world,
            about ``p_WC``), or None if infeasible.
        message: Solver message.
    """

    feasible: bool
    wrenches: np.ndarray | None
    message: str


def _check_contacts(contacts: Sequence[ContactConstraint]) -> list[ContactConstraint]:
    cs = list(contacts)
    if not cs:
        raise InvalidInput("contacts is empty: give at least one ContactConstraint")
    for i, c in enumerate(cs):
        if not isinstance(c, ContactConstraint):
            raise InvalidInput(f"contacts[{i}] must be a ContactConstraint, got {type(c).__name__}")
    return cs


def _external_total(external: Sequence[ExternalWrench]) -> np.ndarray:
    """Sum of the external wrenches about the world origin ``(6,)``."""
    total = np.zeros(6)
    for i, e in enumerate(external):
        if not isinstance(e, ExternalWrench):
            raise InvalidInput(f"external[{i}] must be an ExternalWrench, got {type(e).__name__}")
        p = _array(e.p_W, (3,), f"external[{i}].p_W")
        f = _array(e.force, (3,), f"external[{i}].force")
        m = _array(e.moment, (3,), f"external[{i}].moment")
        total += np.concatenate([f, m + np.cross(p, f)])
    return total


@dataclass
class _WrenchLP:
    """Shared rows: ``G w = h`` (equilibrium) and ``C w + d >= 0`` (limits)."""

    G: np.ndarray  # (6, 6n) maps contact wrenches to the total wrench at the origin
    C: np.ndarray  # (r, 6n) block diagonal
    d: np.ndarray  # (r,)
    n: int


def _wrench_lp(contacts: list[ContactConstraint]) -> _WrenchLP:
    n = len(contacts)
    G = np.zeros((6, 6 * n))
    blocks = [wrench_constraints(c) for c in contacts]
    C = np.zeros((sum(len(b[1]) for b in blocks), 6 * n))
    r = 0
    for i, (c, (Ci, _)) in enumerate(zip(contacts, blocks, strict=True)):
        G[:3, 6 * i : 6 * i + 3] = np.eye(3)
        G[3:, 6 * i : 6 * i + 3] = skew(c.p_WC)
        G[3:, 6 * i + 3 : 6 * i + 6] = np.eye(3)
        C[r : r + len(Ci), 6 * i : 6 * i + 6] = Ci
        r += len(Ci)
    return _WrenchLP(G=G, C=C, d=np.concatenate([b[1] for b in blocks]), n=n)


def _gravity(gravity: object) -> np.ndarray:
    return _array(gravity, (3,), "gravity")


def static_equilibrium(
    contacts: Sequence[ContactConstraint],
    mass: float,
    com: np.ndarray,
    external: Sequence[ExternalWrench] = (),
    gravity: np.ndarray = GRAVITY,
) -> EquilibriumResult:
    """Whether contact wrenches within their limits balance gravity and ``external``.

    Solves the LP feasibility problem (HiGHS)

    .. math::

        \\text{find } w \\;\\text{s.t.}\\; G w + \\begin{bmatrix} m g \\\\
        c \\times m g\\end{bmatrix} + w_{ext} = 0, \\quad C w + d \\ge 0

    Args:
        contacts: The contacts.
        mass: Total mass [kg] (> 0).
        com: Centre of mass ``(3,)`` [m].
        external: External wrenches.
        gravity: Gravity vector ``(3,)`` [m/s²].

    Returns:
        :class:`EquilibriumResult`.
    """
    cs = _check_contacts(contacts)
    m = _scalar(mass, "mass")
    if m <= 0.0:
        raise InvalidInput(f"mass must be > 0 [kg], got {m}")
    c = _array(com, (3,), "com")
    g = _gravity(gravity)
    lp = _wrench_lp(cs)
    w_gravity = np.concatenate([m * g, np.cross(c, m * g)])
    h = -(w_gravity + _external_total(external))
    # Wrenches in units of the weight m|g| keep the LP O(1); HiGHS can otherwise
    # end "unknown" (status 4) on nearly-infeasible poses. The default method
    # is tried first, then dual simplex, then interior point.
    scale = m * float(np.linalg.norm(g)) or 1.0
    for method in ("highs", "highs-ds", "highs-ipm"):
        res = linprog(
            c=np.zeros(6 * lp.n),
            A_ub=-lp.C,
            b_ub=lp.d / scale,
            A_eq=lp.G,
            b_eq=h / scale,
            bounds=(None, None),
            method=method,
        )
        if res.status == 0:
            return EquilibriumResult(True, scale * res.x.reshape(lp.n, 6), res.message)
        if res.status == 2:
            return EquilibriumResult(False, None, res.message)
    raise PikError(f"static-equilibrium LP failed (status {res.status}): {res.message}")


# ----------------------------------------------------------------------------
# Static centroid feasible region (SCFR)
# ----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Region:
    """Static centroid feasible region (CoM x-y positions that can be balanced).

    Attributes:
        vertices: Polygon ``(m, 2)`` [m] in world (x, y), counter-clockwise.
            Every vertex is an LP solution, so the polygon lies inside the true
            region (an inner approximation).
        halfplanes: Half-planes of ``vertices`` (distances in m).
        area: Area [m²].
        empty: No CoM position can be balanced. Then ``vertices`` is ``(0, 2)``,
            ``halfplanes`` has no rows, and :meth:`signed_distance` returns -inf.
            Callers building constraints from ``halfplanes`` must check this.
        gap: Upper bound [m] on how far the true region reaches outside
            ``vertices`` (the largest gap to the outer approximation).
        n_lp: Number of LPs solved.
    """

    vertices: np.ndarray
    halfplanes: HalfPlanes
    area: float
    empty: bool = False
    gap: float = 0.0
    n_lp: int = 0

    def signed_distance(self, c: np.ndarray) -> float:
        """Signed distance [m] of the CoM (x, y) — ``c`` is (2,) or (3,)."""
        p = np.asarray(c, dtype=float)
        if p.shape == (3,):
            p = p[:2]
        if self.empty:
            _array(p, (2,), "c")
            return -math.inf
        return signed_distance(self.halfplanes, p)

    def contains(self, c: np.ndarray, margin: float = 0.0) -> bool:
        """Whether ``c`` is inside by at least ``margin`` [m]."""
        return self.signed_distance(c) >= margin


def scfr(
    contacts: Sequence[ContactConstraint],
    mass: float,
    external: Sequence[ExternalWrench] = (),
    gravity: np.ndarray = GRAVITY,
    *,
    com_z: float = 0.0,
    tol: float = 1e-4,
    max_iter: int = 500,
    bounds: tuple[float, float, float, float] | None = None,
) -> Region:
    """Static centroid feasible region by recursive projection (Bretl & Lall 2008).

    The polytope of ``z = (c_x, c_y, w_1, ..., w_n)``

    .. math::

        G w + \\begin{bmatrix} m g \\\\ c \\times m g \\end{bmatrix} + w_{ext} = 0,
        \\qquad C w + d \\ge 0, \\qquad c = (c_x, c_y, c_z)

    is projected onto ``(c_x, c_y)``: for a direction ``a`` an LP maximizes
    ``a^T (c_x, c_y)``; the maximizers span an inner polygon, their supporting lines
    an outer polygon. The edge whose outer triangle is highest is refined along its
    outward normal until every gap is below ``tol`` (or the edge is exact).

    Args:
        contacts: The contacts.
        mass: Total mass [kg].
        external: External wrenches.
        gravity: Gravity ``(3,)`` [m/s²]. With vertical gravity the region does not
            depend on the CoM height; otherwise ``com_z`` is used.
        com_z: CoM height [m] (only matters for non-vertical gravity).
        tol: Accuracy [m]: the true region reaches at most ``tol`` beyond the
            returned polygon.
        max_iter: Maximum number of LPs.
        bounds: Optional box ``(x_min, x_max, y_min, y_max)`` [m] intersected with
            the region. Without it an unbounded region raises.

    Returns:
        :class:`Region` (``empty=True`` when no CoM position can be balanced).

    Raises:
        InvalidInput: Bad arguments; the region is unbounded (pass ``bounds``); or it
            is degenerate (a segment or a point, e.g. only point contacts in a row).
        PikError: An LP failed, or ``max_iter`` LPs did not reach ``tol``.
    """
    cs = _check_contacts(contacts)
    m = _scalar(mass, "mass")
    if m <= 0.0:
        raise InvalidInput(f"mass must be > 0 [kg], got {m}")
    g = _gravity(gravity)
    if not np.linalg.norm(g) > 0.0:
        raise InvalidInput("gravity must be a non-zero vector")
    cz = _scalar(com_z, "com_z")
    tol = _scalar(tol, "tol")
    if tol <= 0.0:
        raise InvalidInput(f"tol must be > 0 [m], got {tol}")
    if int(max_iter) < 4:
        raise InvalidInput(f"max_iter must be >= 4, got {max_iter}")
    box = [(None, None), (None, None)]
    if bounds is not None:
        bx = _array(bounds, (4,), "bounds")
        if not (bx[0] < bx[1] and bx[2] < bx[3]):
            raise InvalidInput(f"bounds must be (x_min, x_max, y_min, y_max), got {bx}")
        box = [(bx[0], bx[1]), (bx[2], bx[3])]

    lp = _wrench_lp(cs)
    nv = 2 + 6 * lp.n
    # Moment of gravity: m c x g = -m [g]x c, linear in (cx, cy).
    Sg = skew(g)
    A_eq = np.zeros((6, nv))
    A_eq[3:, :2] = -m * Sg[:, :2]
    A_eq[:, 2:] = lp.G
    w_fixed = np.concatenate([m * g, -m * Sg @ np.array([0.0, 0.0, cz])])
    b_eq = -(w_fixed + _external_total(external))
    A_ub = np.zeros((len(lp.d), nv))
    A_ub[:, 2:] = -lp.C
    var_bounds = box + [(None, None)] * (6 * lp.n)
    count = 0

    def support(a: np.ndarray) -> np.ndarray | None:
        nonlocal count
        obj = np.zeros(nv)
        obj[:2] = -a
        res = linprog(
            obj,
            A_ub=A_ub,
            b_ub=lp.d,
            A_eq=A_eq,
            b_eq=b_eq,
            bounds=var_bounds,
            method="highs",
        )
        count += 1
        if res.status == 0:
            return res.x[:2].copy()
        if res.status == 2:
            return None
        if res.status == 3:
            # HiGHS may say "unbounded" for "infeasible or unbounded": check.
            feas = linprog(
                np.zeros(nv),
                A_ub=A_ub,
                b_ub=lp.d,
                A_eq=A_eq,
                b_eq=b_eq,
                bounds=var_bounds,
                method="highs",
            )
            if feas.status == 2:
                return None
            raise InvalidInput(
                f"the SCFR is unbounded in direction {np.round(a, 4).tolist()}: the "
                "contacts can balance the CoM arbitrarily far away (e.g. opposing "
                "contacts with fz_max=inf); give finite fz_max or pass bounds="
            )
        raise PikError(f"SCFR LP failed (status {res.status}): {res.message}")

    angles = np.arange(4) * (np.pi / 2)
    dirs = [np.array([math.cos(t), math.sin(t)]) for t in angles]
    pts: list[np.ndarray] = []
    for a in dirs:
        p = support(a)
        if p is None:
            empty = HalfPlanes(np.zeros((0, 2)), np.zeros(0))
            return Region(np.zeros((0, 2)), empty, 0.0, empty=True, n_lp=count)
        pts.append(p)
    final = [False] * len(pts)
    eps_exact = 1e-3 * tol

    def edge_gap(k: int) -> tuple[float, np.ndarray | None]:
        """Height of the outer triangle over inner edge k, and its outward normal."""
        k1 = (k + 1) % len(pts)
        v0, v1 = pts[k], pts[k1]
        t = v1 - v0
        length = float(np.linalg.norm(t))
        if final[k] or length < eps_exact:
            return 0.0, None
        normal = np.array([t[1], -t[0]]) / length
        M = np.vstack([dirs[k], dirs[k1]])
        h = np.array([dirs[k] @ v0, dirs[k1] @ v1])
        if abs(np.linalg.det(M)) < 1e-12:
            return length, normal  # parallel supporting lines: unknown, refine
        q = np.linalg.solve(M, h)
        return max(0.0, float(normal @ (q - v0))), normal

    gaps = [edge_gap(k) for k in range(len(pts))]
    while True:
        k = max(range(len(gaps)), key=lambda i: gaps[i][0])
        gap, normal = gaps[k]
        if gap < tol:
            break
        if count >= max_iter:
            raise PikError(
                f"SCFR did not reach tol={tol} m within max_iter={max_iter} LPs "
                f"(largest gap {gap:.3g} m)"
            )
        p = support(normal)  # gap >= tol > 0, so normal is set
        if p is None:  # cannot happen after feasible LPs, but fail loudly.
            raise PikError("SCFR LP became infeasible during refinement")
        if normal @ p <= normal @ pts[k] + eps_exact:
            final[k] = True
            gaps[k] = (0.0, None)
            continue
        pts.insert(k + 1, p)
        dirs.insert(k + 1, normal)
        final.insert(k + 1, False)
        gaps.insert(k + 1, (0.0, None))
        gaps[k] = edge_gap(k)
        gaps[k + 1] = edge_gap(k + 1)

    try:
        hull = convex_hull_2d(np.array(pts), tol=eps_exact)
    except InvalidInput as exc:
        raise InvalidInput(
            "degenerate SCFR: the CoM positions these contacts can balance form a "
            f"segment or a point (zero area); support points {np.round(pts, 6)}"
        ) from exc
    return Region(
        vertices=hull,
        halfplanes=halfplanes_from_polygon(hull),
        area=polygon_area(hull),
        gap=max(gp for gp, _ in gaps),
        n_lp=count,
    )
