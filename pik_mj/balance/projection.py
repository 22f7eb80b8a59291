"""The static centroid feasible region (SCFR): the CoM positions whose weight
contact wrenches within their limits can balance, by recursive projection
(prioritized-IK manual: ``centroid-scfr-task``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import OptimizeResult, linprog

from pik_mj.balance.contacts import ContactConstraint
from pik_mj.balance.equilibrium import (
    GRAVITY,
    ExternalWrench,
    checked_contacts,
    external_total,
    gravity_vector,
    wrench_lp,
)
from pik_mj.balance.polygon import (
    HalfPlanes,
    convex_hull_2d,
    halfplanes_from_polygon,
    polygon_area,
    signed_distance,
)
from pik_mj.balance.values import finite_array, real
from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.spatial import skew


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
            finite_array(p, (2,), "c")
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
    cs = checked_contacts(contacts)
    m = real(mass, "mass")
    if m <= 0.0:
        raise InvalidInput(f"mass must be > 0 [kg], got {m}")
    g = gravity_vector(gravity)
    if not np.linalg.norm(g) > 0.0:
        raise InvalidInput("gravity must be a non-zero vector")
    cz = real(com_z, "com_z")
    tol = real(tol, "tol")
    if tol <= 0.0:
        raise InvalidInput(f"tol must be > 0 [m], got {tol}")
    if int(max_iter) < 4:
        raise InvalidInput(f"max_iter must be >= 4, got {max_iter}")
    box = [(None, None), (None, None)]
    if bounds is not None:
        bx = finite_array(bounds, (4,), "bounds")
        if not (bx[0] < bx[1] and bx[2] < bx[3]):
            raise InvalidInput(f"bounds must be (x_min, x_max, y_min, y_max), got {bx}")
        box = [(bx[0], bx[1]), (bx[2], bx[3])]

    lp = _SupportLP(cs, m, g, cz, external, box)
    angles = np.arange(4) * (np.pi / 2)
    dirs = [np.array([math.cos(t), math.sin(t)]) for t in angles]
    pts: list[np.ndarray] = []
    for a in dirs:
        p = lp.support(a)
        if p is None:
            empty = HalfPlanes(np.zeros((0, 2)), np.zeros(0))
            return Region(np.zeros((0, 2)), empty, 0.0, empty=True, n_lp=lp.count)
        pts.append(p)
    eps_exact = 1e-3 * tol
    gap = _refine(lp, pts, dirs, tol, eps_exact, max_iter)
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
        gap=gap,
        n_lp=lp.count,
    )


class _SupportLP:
    """The SCFR's support function: for a direction ``a``, the point of the
    region farthest along it, ``argmax aᵀ (c_x, c_y)`` over the polytope of
    :func:`scfr` (an LP, HiGHS), or None when the polytope is empty.

    With vertical or any gravity ``g``, the moment of gravity
    ``m c × g = -m [g]× c`` is linear in ``(c_x, c_y)`` at the CoM height ``c_z``.

    Attributes:
        count: LPs solved so far.
    """

    def __init__(
        self,
        contacts: list[ContactConstraint],
        m: float,
        g: np.ndarray,
        cz: float,
        external: Sequence[ExternalWrench],
        box: list[tuple[float | None, float | None]],
    ) -> None:
        lp = wrench_lp(contacts)
        nv = 2 + 6 * lp.n
        # Moment of gravity: m c x g = -m [g]x c, linear in (cx, cy).
        Sg = skew(g)
        self.A_eq = np.zeros((6, nv))
        self.A_eq[3:, :2] = -m * Sg[:, :2]
        self.A_eq[:, 2:] = lp.G
        w_fixed = np.concatenate([m * g, -m * Sg @ np.array([0.0, 0.0, cz])])
        self.b_eq = -(w_fixed + external_total(external))
        self.A_ub = np.zeros((len(lp.d), nv))
        self.A_ub[:, 2:] = -lp.C
        self.b_ub = lp.d
        self.bounds = box + [(None, None)] * (6 * lp.n)
        self.nv = nv
        self.count = 0

    def _lp(self, objective: np.ndarray) -> OptimizeResult:
        """``min objectiveᵀ z`` over the polytope."""
        return linprog(
            objective,
            A_ub=self.A_ub,
            b_ub=self.b_ub,
            A_eq=self.A_eq,
            b_eq=self.b_eq,
            bounds=self.bounds,
            method="highs",
        )

    def support(self, a: np.ndarray) -> np.ndarray | None:
        """The region's point ``(c_x, c_y)`` [m] farthest along ``a``, or None
        when no CoM position can be balanced.

        Raises:
            InvalidInput: The region is unbounded along ``a``.
            PikError: The LP failed.
        """
        obj = np.zeros(self.nv)
        obj[:2] = -a
        res = self._lp(obj)
        self.count += 1
        if res.status == 0:
            return res.x[:2].copy()
        if res.status == 2:
            return None
        if res.status == 3:
            # HiGHS may say "unbounded" for "infeasible or unbounded": check.
            if self._lp(np.zeros(self.nv)).status == 2:
                return None
            raise InvalidInput(
                f"the SCFR is unbounded in direction {np.round(a, 4).tolist()}: the "
                "contacts can balance the CoM arbitrarily far away (e.g. opposing "
                "contacts with fz_max=inf); give finite fz_max or pass bounds="
            )
        raise PikError(f"SCFR LP failed (status {res.status}): {res.message}")


def _refine(
    lp: _SupportLP,
    pts: list[np.ndarray],
    dirs: list[np.ndarray],
    tol: float,
    eps_exact: float,
    max_iter: int,
) -> float:
    """Refine the inner polygon ``pts`` (support points, each the maximizer
    along ``dirs``; both grown in place) until the outer triangle over every
    edge is lower than ``tol`` [m] or the edge is exact (a support point along
    its normal adds less than ``eps_exact``); returns the largest gap left.

    Raises:
        PikError: ``max_iter`` LPs did not reach ``tol``.
    """
    final = [False] * len(pts)

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
        if lp.count >= max_iter:
            raise PikError(
                f"SCFR did not reach tol={tol} m within max_iter={max_iter} LPs "
                f"(largest gap {gap:.3g} m)"
            )
        p = lp.support(normal)  # gap >= tol > 0, so normal is set
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
    return max(gp for gp, _ in gaps)
