"""CoM inside the support polygon (prioritized-IK manual: ``centroid-support-polygon-task``).

The support polygons' vertices — fixed world points, or points attached to robot
frames so that they move with the robot — and the CoM ``c`` are projected along
the up direction ``n`` onto plane coordinates ``⁰p = E p`` (``E`` = the first two
columns of :func:`pik_mj.balance.plane_basis`, transposed). Every iteration the
convex hull ``(⁰p_0, ⁰p_1, ...)`` (counter-clockwise about ``n``) is recomputed
and, per hull edge ``i`` (``u = ⁰p_{i+1} − ⁰p_i``, ``l = ‖u‖``,
``w = ⁰c − ⁰p_i``), the signed distance of the CoM, positive inside, is

.. math::

    d_i = \\frac{u_x w_y - u_y w_x}{l}

with the inequality row ``d_i + J_i x + ω ≥ margin``. ``J_i`` includes the
vertices' motion (the prioritized-IK manual's formula):

.. math::

    J_i = g_c\\, E J_{com} + g_i\\, E J_{v_i} + g_{i+1}\\, E J_{v_{i+1}}, \\quad
    g_c = \\tfrac1l (-u_y, u_x), \\quad
    g_{i+1} = \\tfrac1l (w_y, -w_x) - \\tfrac{d_i}{l^2} u^T, \\quad
    g_i = -g_c - g_{i+1}

where a vertex ``p = p_WF + R_WF p_F`` attached to frame ``F`` moves with
``J_v = J_{p,F} − [R_WF p_F]_× J_{ω,F}`` (``J_v = 0`` for a fixed point).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import mink
import numpy as np

from pik_mj.balance import SupportRegion, convex_hull_2d, plane_basis, support_polygon
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.spatial import skew
from pik_mj.tasks.com import com_jacobian, com_position, robot_root_body
from pik_mj.tasks.task import Task, TaskRows, TaskState

PolygonSpec = Any
"""``(k, 3)`` world points, or ``(frame_name, (k, 3) local points[, frame_type])``."""


def _points(value: Any, what: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{what} must be a (k, 3) array of points [m]") from None
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 1:
        raise InvalidInput(f"{what} must have shape (k, 3) with k >= 1, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInput(f"{what} contains NaN or inf")
    return arr


class SupportPolygonTask(Task):
    """Keep the CoM inside the (shrunk) convex hull of support polygons.

    Args:
        configuration: Robot configuration.
        polygons: A list; each entry is either world points ``(k, 3)`` [m]
            (fixed), or ``(frame_name, p_F)`` / ``(frame_name, p_F, frame_type)``
            with ``p_F`` ``(k, 3)`` [m] in that robot frame (moving with it).
        normal: Up direction ``n`` (3,); the polygon lives in the plane orthogonal
            to it.
        margin: ``margin`` [m] (prioritized-IK manual): the CoM is kept this
            far inside the hull.
        w: Slack weight (float > 0).
        centroid_thre: Stop test: ``min_i d_i >= margin − centroid_thre`` [m].
        root_body: The robot's top-level body (see
            :func:`pik_mj.tasks.com.robot_root_body`).
        check: Whether the solve loop's stop test looks at this task.
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        polygons: Sequence[PolygonSpec],
        *,
        normal: Sequence[float] = (0.0, 0.0, 1.0),
        margin: float = 0.0,
        w: float = 1.0,
        centroid_thre: float = 1e-3,
        root_body: str | None = None,
        check: bool = True,
        name: str | None = None,
    ):
        model = configuration.model
        self.root_body = robot_root_body(model, root_body)
        if isinstance(polygons, np.ndarray) or isinstance(polygons, (str, bytes)):
            raise InvalidInput("polygons must be a list of polygons (one (k, 3) array each)")
        polys = list(polygons)
        if not polys:
            raise InvalidInput("polygons is empty: give at least one support polygon")
        self.polygons: list[tuple[Frame | None, np.ndarray]] = []
        for i, p in enumerate(polys):
            if isinstance(p, tuple) and len(p) in (2, 3) and isinstance(p[0], str):
                frame = Frame.find(model, p[0], p[2] if len(p) == 3 else None)
                self.polygons.append((frame, _points(p[1], f"polygons[{i}] local points")))
            else:
                self.polygons.append((None, _points(p, f"polygons[{i}]")))
        self.R = plane_basis(np.asarray(normal, dtype=float))
        self.E = self.R[:, :2].T
        for label, v in (("margin", margin), ("centroid_thre", centroid_thre), ("w", w)):
            if not np.isfinite(v):
                raise InvalidInput(f"{label} must be finite, got {v}")
        if w <= 0:
            raise InvalidInput(f"w must be > 0, got {w}")
        if centroid_thre < 0:
            raise InvalidInput(f"centroid_thre must be >= 0 [m], got {centroid_thre}")
        self.margin, self.w, self.centroid_thre = float(margin), float(w), float(centroid_thre)
        self.check = check
        self.name = name or "support_polygon"
        self.hull(configuration)  # fails early on a degenerate set of points

    # -- geometry -----------------------------------------------------------
    def points(self, configuration: mink.Configuration) -> np.ndarray:
        """World positions of all polygon vertices, shape (n, 3) [m]."""
        data = configuration.data
        out = []
        for frame, pts in self.polygons:
            if frame is None:
                out.append(pts)
            else:
                out.append(frame.position(data) + pts @ frame.rotation(data).T)
        return np.vstack(out)

    def point_jacobians(self, configuration: mink.Configuration) -> np.ndarray:
        """World Jacobians of all vertices, shape (n, 3, nv) (zero for fixed points)."""
        data = configuration.data
        nv = configuration.model.nv
        out = []
        for frame, pts in self.polygons:
            if frame is None:
                out.append(np.zeros((len(pts), 3, nv)))
                continue
            J_p, J_w = frame.jacobians(data)
            R = frame.rotation(data)
            out.append(np.stack([J_p - skew(R @ p) @ J_w for p in pts]))
        return np.concatenate(out)

    def hull(self, configuration: mink.Configuration) -> np.ndarray:
        """Indices into :meth:`points` of the hull vertices, counter-clockwise about n."""
        return self._hull(self.points(configuration) @ self.E.T)

    def _hull(self, uv: np.ndarray) -> np.ndarray:
        """:meth:`hull` of the projected points ``uv`` (n, 2): each hull vertex's
        first index among them."""
        try:
            hull = convex_hull_2d(uv)
        except InvalidInput as exc:
            raise InvalidInput(
                f"{self.name}: the support points projected along the normal span no area ({exc})"
            ) from exc
        return np.argmin(np.sum((uv[None, :, :] - hull[:, None, :]) ** 2, axis=2), axis=1)

    def region(self, configuration: mink.Configuration) -> SupportRegion:
        """The support polygon as a :class:`pik_mj.balance.SupportRegion` (unshrunk)."""
        return support_polygon([self.points(configuration)], self.R[:, 2])

    def _distances(
        self, configuration: mink.Configuration, hull: np.ndarray | None, jacobian: bool
    ):
        uv = self.points(configuration) @ self.E.T
        if hull is None:
            hull = self._hull(uv)
        c = self.E @ com_position(configuration, self.root_body)
        if jacobian:
            J_c = self.E @ com_jacobian(configuration, self.root_body)
            J_P = np.einsum("ij,njk->nik", self.E, self.point_jacobians(configuration))
        m = hull.size
        d = np.zeros(m)
        J = np.zeros((m, configuration.model.nv))
        for k in range(m):
            i, j = hull[k], hull[(k + 1) % m]
            u = uv[j] - uv[i]
            w = c - uv[i]
            length = float(np.linalg.norm(u))
            d[k] = (u[0] * w[1] - u[1] * w[0]) / length
            if jacobian:
                g_c = np.array([-u[1], u[0]]) / length
                g_j = np.array([w[1], -w[0]]) / length - d[k] * u / length**2
                g_i = -g_c - g_j
                J[k] = g_c @ J_c + g_i @ J_P[i] + g_j @ J_P[j]
        return d, J

    def edge_distances(
        self, configuration: mink.Configuration, hull: np.ndarray | None = None
    ) -> np.ndarray:
        """Signed distances ``d_i`` [m] of the CoM to each hull edge (positive inside).

        Args:
            configuration: Robot configuration.
            hull: Vertex indices from :meth:`hull` to use instead of recomputing
                the hull (e.g. to differentiate with a fixed hull structure).
        """
        return self._distances(configuration, hull, jacobian=False)[0]

    def edge_jacobian(
        self, configuration: mink.Configuration, hull: np.ndarray | None = None
    ) -> np.ndarray:
        """``d d_i / d q``, shape (edges, nv)."""
        return self._distances(configuration, hull, jacobian=True)[1]

    def signed_distance(self, configuration: mink.Configuration) -> float:
        """``min_i d_i`` [m]: the CoM's distance to the (unshrunk) hull boundary."""
        return float(np.min(self.edge_distances(configuration)))

    # -- cascade contract ---------------------------------------------------
    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        d, J = self._distances(configuration, None, jacobian=True)
        return TaskRows.inequality(J, self.margin - d, np.inf, self.w)

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """Per-edge violation ``max(margin − d_i, 0)`` [m]."""
        return np.maximum(self.margin - self.edge_distances(configuration), 0.0)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return bool(np.max(self.compute_error(configuration)) <= self.centroid_thre)

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, error norm and stop test from one hull and one pass over its
        edges (the values of :meth:`compute_rows`, :meth:`compute_error` and
        :meth:`is_satisfied`)."""
        d, J = self._distances(configuration, None, jacobian=True)
        error = np.maximum(self.margin - d, 0.0)
        return TaskState(
            TaskRows.inequality(J, self.margin - d, np.inf, self.w),
            float(np.linalg.norm(error)),
            bool(np.max(error) <= self.centroid_thre),
        )

    def __repr__(self) -> str:
        kinds = [str(f) if f is not None else "fixed" for f, _ in self.polygons]
        return (
            f"SupportPolygonTask(name={self.name!r}, polygons={kinds}, "
            f"normal={np.round(self.R[:, 2], 4).tolist()}, margin={self.margin})"
        )
