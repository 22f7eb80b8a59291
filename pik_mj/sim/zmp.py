r"""The zero-moment point a timed path needs, and the timing that keeps it inside
the support polygon (:func:`stretch_for_balance`).

Along the played path (:class:`~pik_mj.sim.blends.BlendedPath`) the robot's
floating base needs the generalized force ``Q`` (its free joint's rows of the
inverse dynamics) from the contacts; at a knot ``σ`` with rates ``(σ̇, σ̈)``

.. math::

    Q = Q_s + Q_a\, \ddot σ + Q_v\, \dot σ^2 + Q_d\, \dot σ

``Q_s`` at rest (gravity less the external wrenches and the grasped objects'
weights), ``Q_a = M q'``, ``Q_v = c(q, q') + M q''`` (the blends' curvature
included), ``Q_d = D q'`` the joints' damping: the knot's inverse dynamics
(:class:`~pik_mj.sim.knots.Knot`, evaluated once for this plan and the torque
plan, :mod:`pik_mj.sim.effort`). Its rows are the net contact
force ``F`` (world) and the moment ``R_B (Q_4, Q_5, Q_6)`` about the root body's
origin ``o``. In the frame of the ground contacts' support polygon (basis
``e_1, e_2, n``, the plane at height ``h``; :meth:`~pik_mj.sim.physics.Physics.support`)
the point of the plane about which that wrench has no tangential moment is
(:func:`pik_mj.dynamics.zmp_points`)

.. math::

    p_1 = o_1 - \frac{n_2 + (o_3 - h) F_1}{F_3}, \qquad
    p_2 = o_2 - \frac{(o_3 - h) F_2 - n_1}{F_3}

the zero-moment point (ZMP; at rest the CoM's projection). A segment is slowed
down (its duration stretched by ``c``: ``σ̇ / c``, ``σ̈ / c²``, bisection as for
the drives) until every knot's ZMP keeps at least :data:`ZMP_RESERVE` of its
rest margin ``d_s`` to the polygon's edges, ``d(p) ≥ ρ_z d_s``. The motion may
use the rest of the margin; the servos and the contacts' compliance need the
reserve. A knot whose rest ZMP is not inside (``d_s ≤ 0``: another contact,
a hand on a wall, carries the robot there, or it cannot stand at all, which
the static check and the hold report) is not the ZMP's to judge.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from pik_mj.balance import SupportRegion
from pik_mj.dynamics import zmp_points
from pik_mj.sim.blends import BlendedPath
from pik_mj.sim.knots import Knot, PathDynamics
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.timing import Timing

__all__ = [
    "GROUND_SLOPE",
    "MAX_STRETCH",
    "SAME_SUPPORT",
    "ZMP_RESERVE",
    "ZmpPlan",
    "knot_regions",
    "plan_zmp",
    "stretch_for_balance",
]

ZMP_RESERVE = 0.5
"""Share ``ρ_z`` of a knot's rest margin (the CoM's) its moving ZMP keeps."""

MAX_STRETCH = 10.0
"""Largest factor by which a segment is slowed down for its balance."""

GROUND_SLOPE = math.pi / 4
"""Largest angle [rad] of a contact normal to up for the contact to support."""

SAME_SUPPORT = 1e-4
"""Distance [m] within which a knot's contact points are those of the knot
before: its support polygon is reused."""

_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


@dataclass
class ZmpPlan:
    """The floating base's wrench at knots (module docstring).

    Attributes:
        sigma: Knot nominal times [s] (k,).
        parts: ``Q_s, Q_a, Q_v, Q_d`` (4, k, 6) in the support polygon's frame:
            force ``(F_1, F_2, F_3)`` [N], moment ``(n_1, n_2, n_3)`` [N·m] about ``o``.
        origin: ``(o_1, o_2, o_3 - h)`` (k, 3) [m] of each knot.
        edges: ``(A, b)`` per knot: the polygon's half-planes ``A p + b ≥ 0``.
        rest_margin: ``d_s`` (k,) [m].
    """

    sigma: np.ndarray
    parts: np.ndarray
    origin: np.ndarray
    edges: list[tuple[np.ndarray, np.ndarray]]
    rest_margin: np.ndarray
    _stacked: tuple[np.ndarray, np.ndarray] | None = field(default=None, init=False, repr=False)

    def points(self, rate: np.ndarray, accel: np.ndarray) -> np.ndarray:
        """The ZMPs (..., k, 2) [m] in the polygons' planes at ``(σ̇, σ̈)``
        (..., k) each."""
        s, a, v, d = self.parts
        Q = s + a * accel[..., None] + v * (rate**2)[..., None] + d * rate[..., None]
        return zmp_points(Q[..., :3], Q[..., 3:], self.origin)

    def margins(self, rate: np.ndarray, accel: np.ndarray) -> np.ndarray:
        """Signed distance (..., k) [m] of each knot's ZMP to its polygon's edges
        at ``(σ̇, σ̈)`` (..., k)."""
        p = self.points(rate, accel)
        if self._stacked is None:  # every knot's half-planes, padded with b = inf
            self._stacked = _padded(self.edges)
        A, b = self._stacked
        return np.min(A[..., 0] * p[..., None, 0] + A[..., 1] * p[..., None, 1] + b, axis=-1)

    def fits(self, rate: np.ndarray, accel: np.ndarray) -> np.ndarray:
        """Per knot: the ZMP keeps :data:`ZMP_RESERVE` of a positive rest margin
        (module docstring; True where the rest margin is not positive); rates
        (..., k), result (..., k)."""
        d_s = self.rest_margin
        return (d_s <= 0) | (self.margins(rate, accel) >= ZMP_RESERVE * d_s - 1e-9)


def _padded(edges: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The half-planes ``(A, b)`` of each knot stacked, (k, E, 2) and (k, E),
    padded with ``A = 0``, ``b = inf`` to the most edges ``E`` (the knots that
    share a polygon share its rows, padded once)."""
    E = max(len(b) for _, b in edges)
    rows: dict[tuple[int, int], int] = {}  # a polygon's row in the padded arrays
    polygons: list[tuple[np.ndarray, np.ndarray]] = []
    for A_k, b_k in edges:
        if (id(A_k), id(b_k)) not in rows:
            rows[id(A_k), id(b_k)] = len(polygons)
            polygons.append((A_k, b_k))
    A, b = np.zeros((len(polygons), E, 2)), np.full((len(polygons), E), np.inf)
    for k, (A_k, b_k) in enumerate(polygons):
        A[k, : len(b_k)], b[k, : len(b_k)] = A_k, b_k
    index = [rows[id(A_k), id(b_k)] for A_k, b_k in edges]
    return A[index], b[index]


def knot_regions(scene: Physics, knots: Sequence[Knot]) -> list[SupportRegion | None]:
    """The support region of each knot: the polygon of its ground contacts
    (:meth:`~pik_mj.sim.physics.Physics.support_region`, as
    :meth:`~pik_mj.sim.physics.Physics.support`; None without them), formed
    again only where the knot's contact points are not within
    :data:`SAME_SUPPORT` of those of the knot whose region was formed last (as
    many points, each coordinate within). The knots with as many points in a
    row are compared with that knot together."""
    regions: list[SupportRegion | None] = []
    seen, region = np.zeros((0, 3)), None  # the points of the region formed last
    points = [knot.contacts.points for knot in knots]
    start = 0
    while start < len(knots):  # the run of knots with as many points as knot start
        stop = start + 1
        while stop < len(knots) and len(points[stop]) == len(points[start]):
            stop += 1
        run, i = np.array(points[start:stop]), 0  # (stop - start, n, 3)
        while i < len(run):
            if run[i].shape == seen.shape:  # the region kept up to the first knot off seen
                off = np.abs(run[i:] - seen).max(axis=(1, 2), initial=0) > SAME_SUPPORT
                kept = int(np.argmax(off)) if off.any() else len(run) - i
                regions += [region] * kept
                i += kept
                if i == len(run):
                    break
            contacts = knots[start + i].contacts
            ground = scene.on_ground(contacts.normals, contacts.self_contact, GROUND_SLOPE)
            region, seen = scene.support_region(contacts.points[ground]), contacts.points
            regions.append(region)
            i += 1
        start = stop
    return regions


def plan_zmp(
    scene: Physics,
    path: BlendedPath,
    external: Sequence[External] = (),
    ramp: bool = False,
    dynamics: PathDynamics | None = None,
) -> ZmpPlan | None:
    """The :class:`ZmpPlan` of ``path`` (``ramp``: the external wrenches grow
    with the path's progress ``σ / S``; ``dynamics``: the path's knots when
    evaluated already, shared with the torque plan), or None when the robot has
    no free joint. Knots without ground contacts (or whose support is a point or
    a segment, or carried with ``F_3 ≤ 0``) are left out; a knot whose contact
    points are within :data:`SAME_SUPPORT` of the knot before's keeps its polygon."""
    m, rm = scene.model, scene.robot.model
    free = np.flatnonzero(rm.jnt_type == _FREE).tolist()
    if not free:
        return None
    if dynamics is None:
        dynamics = PathDynamics(scene, path, external, ramp)
    dof = int(rm.jnt_dofadr[free[0]])
    body = m.body(rm.body(int(rm.jnt_bodyid[free[0]])).name).id
    knots, chosen, regions = dynamics.many(dynamics.sigma), [], []  # of knot_times(path)
    for knot, region in zip(knots, knot_regions(scene, knots), strict=True):
        if region is not None and region.halfplanes is not None:
            chosen.append(knot)
            regions.append(region)
    if not chosen:
        return None
    terms = np.array([(k.rest, k.inertia, k.velocity, k.curvature, k.damping) for k in chosen])
    rest, inertia, velocity, curvature, damping = np.transpose(
        terms[:, :, dof : dof + 6], (1, 0, 2)
    )
    # (k, 4, 6): the free joint's rows of Q_s, Q_a, Q_v + Q_c, Q_d
    Q = np.stack([rest, inertia, velocity + curvature, damping], axis=1)
    R = np.array([region.R for region in regions])  # (k, 3, 3)
    R_B = np.array([k.xmat[body] for k in chosen]).reshape(-1, 3, 3)
    force = Q[..., :3] @ R  # R^T F, row by row
    moment = (Q[..., 3:] @ np.transpose(R_B, (0, 2, 1))) @ R  # R^T R_B n
    height = np.array([[0.0, 0.0, region.height] for region in regions])
    origin = np.einsum("kj,kji->ki", np.array([k.xpos[body] for k in chosen]), R) - height
    sigmas = [k.sigma for k in chosen]
    edges = [(np.asarray(r.halfplanes.A), np.asarray(r.halfplanes.b)) for r in regions]
    kept = force[:, 0, 2] > 0
    plan = ZmpPlan(
        np.array(sigmas)[kept],
        np.transpose(np.concatenate([force, moment], axis=2)[kept], (1, 0, 2)),
        origin[kept],
        [e for e, k in zip(edges, kept, strict=True) if k],
        np.zeros(int(kept.sum())),
    )
    if not len(plan.sigma):
        return None
    zero = np.zeros(len(plan.sigma))
    plan.rest_margin = plan.margins(zero, zero)
    return plan


def stretch_for_balance(
    scene: Physics,
    path: BlendedPath,
    timing: Timing,
    external: Sequence[External] = (),
    ramp: bool = False,
    dynamics: PathDynamics | None = None,
) -> dict[int, float]:
    """Slow down each segment of ``timing`` whose knots' ZMP leaves the reserve
    (module docstring; ``timing.stretch`` is updated; ``dynamics``: as
    :func:`plan_zmp`). Returns the segments stretched, ``{segment index: c}``."""
    plan = plan_zmp(scene, path, external, ramp, dynamics)
    if plan is None:
        return {}
    return timing.stretch_until(plan.sigma, plan.fits, MAX_STRETCH)
