"""Collision avoidance as inequality rows (irteus manual: ``:collision-avoidance``;
Sugiura et al.).

For each pair of geoms ``(a, b)`` MuJoCo gives the signed distance ``d`` and the
witness points ``p_a``, ``p_b`` (``mj_geomDistance``, its ``fromto`` segment).
With the unit normal ``n`` pointing from ``b`` to ``a`` (flipped when the geoms
penetrate), the distance changes to first order as

.. math::

    \\dot d = n^T \\big(J_p(p_a) - J_p(p_b)\\big)\\, \\dot q

(``J_p`` of a point fixed to the geom's body, ``mj_jac``). The irteus manual's
two zones:

* yellow zone ``d_y`` (``avoid-collision-distance``, 200 mm): a pair
  farther apart contributes nothing (no row);
* orange zone ``d_o`` (0.1 ``d_y``): the minimum distance kept.

Inside the yellow zone a pair's row is the velocity damper of Faverjon &
Tournassoud (the step may close at most a fraction ``γ`` of the gap to the
orange zone):

.. math::

    n^T (J_a - J_b)\\, x \\;\\ge\\; -\\gamma\\, (d - d_o)

so ``d + Δd ≥ d_o + (1 - γ)(d - d_o)``; ``γ = 1`` is the plain linearization
``d + Δd ≥ d_o``, and a pair already inside the orange zone is pushed out.
Where the task stands in the priority list decides what wins: above the
hand's target it avoids even against the target (irteus' orange zone);
below it, avoidance uses only what the target leaves free (irteus' null
space term). Pair lists are built like irteus'
``collision-avoidance-link-pair-from-link-list`` from the pairs MuJoCo collides:
see :mod:`pik_mj.tasks.collision_pairs`.

A pair already closer than ``d_o`` when the task is made (standing, Unitree
H1's torso and right shoulder link are 3.5 mm apart, G1's elbow and wrist pitch
links 9.5 mm) keeps that start distance ``d_0`` as its own bound,
``d_o,i = min(d_o, d_0)``: it may not come closer, and the task can be satisfied
(pushing it out to ``d_o`` could fight the feet and never converge).

One witness point per pair is not enough where two flat faces meet (a hand's
box over a counter's edge): a step that turns the hand about the witness
point brings another corner nearer, and the next step's witness is that
corner, the step after the first one again. So the task remembers, per pair and
geom, the last :data:`RECALL` witness points (fixed to the geom's body) and,
while the pair is apart, keeps each of them off the separating plane through
the other witness point:

.. math::

    n^T \\big(J_p(x) - J_p(p_b)\\big)\\, \\dot q \\;\\ge\\; -\\gamma\\, (n^T (x - p_b) - d_o)

for a remembered ``x`` on ``a`` (and the same with the roles swapped for a
point on ``b``). For convex geoms ``p_a`` is ``a``'s support point along
``-n``, so ``n^T (x - p_b) ≥ d``: a remembered point never asks more than the
witness row does now.

Each iteration measures only the pairs that can be in the yellow zone: a pair
whose geoms' bounding spheres (``geom_rbound`` about ``geom_xpos``) or
world-aligned boxes (MuJoCo's ``geom_aabb`` carried by ``geom_xmat``) are
``d_y`` or more apart cannot be nearer than ``d_y``, so ``mj_geomDistance``
runs only for the others, once per iteration (rows, error and stop test share
it), and only the pairs that have come inside the yellow zone give rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.spatial import cross_rows
from pik_mj.tasks.collision_pairs import (
    GeomPair,
    collision_pairs,
    find_geom,
    moving_pairs,
)
from pik_mj.tasks.task import Task, TaskRows, TaskState

__all__ = [
    "DEFAULT_CHECK_MARGIN",
    "DEFAULT_YELLOW",
    "RECALL",
    "CollisionAvoidanceTask",
    "GeomPair",
    "PairDistance",
    "collision_pairs",
    "moving_pairs",
    "pair_distance",
]

DEFAULT_YELLOW = 0.2
"""``avoid-collision-distance`` [m] (irteus manual; 200 mm)."""

RECALL = 2
"""Witness points remembered per pair and geom (module docstring)."""

SAME_POINT = 1e-3
"""Remembered points nearer than this [m] to the current witness point give no row."""

DEFAULT_CHECK_MARGIN = 1e-4
"""How far [m] a pair may be inside its bound and the task still hold (the stop
test's tolerance, prioritized-IK manual: ``check-margin``). A row is the distance
to first order at one witness point; where two faces meet, a step that turns one
about that point brings a corner nearer to second order. Within the margin the
task still holds, so the solve loop keeps it on every later step as it keeps any
satisfied level (a step may not make it worse)."""


class PairDistance(NamedTuple):
    """Distance of one pair: ``d`` [m], witness points ``p_a``, ``p_b`` and normal ``n``."""

    distance: float
    p_a: np.ndarray
    p_b: np.ndarray
    normal: np.ndarray


def pair_distance(
    model: mujoco.MjModel, data: mujoco.MjData, pair: GeomPair, distmax: float
) -> PairDistance:
    """Signed distance and witness points (``mj_geomDistance``), normal from b to a.

    Beyond ``distmax`` MuJoCo returns ``distmax`` and no points; then the normal
    is zero. At exact contact (``p_a = p_b``) the normal falls back to the
    direction between the geom centres.
    """
    fromto = np.empty(6)
    d = float(mujoco.mj_geomDistance(model, data, pair.geom1, pair.geom2, distmax, fromto))
    if d >= distmax:
        return PairDistance(d, fromto[:3], fromto[3:], np.zeros(3))
    centres = data.geom_xpos[pair.geom1] - data.geom_xpos[pair.geom2]
    normal = _normals(np.array([d]), fromto[None], centres[None])[0]
    return PairDistance(d, fromto[:3], fromto[3:], normal)


def _normals(distance: np.ndarray, fromto: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Unit normals (k, 3) from b to a of pairs at ``distance`` (k,) with
    ``mj_geomDistance``'s witness segments ``fromto`` (k, 6): along ``p_a − p_b``,
    reversed for a penetrating pair (``fromto`` runs the other way); along the
    geom centres' difference ``centres`` (k, 3) at exact contact; zero when that
    is zero too."""
    delta = fromto[:, :3] - fromto[:, 3:]
    norm = np.linalg.norm(delta, axis=1)
    sign = np.where(distance >= 0, 1.0, -1.0)
    touching = norm < 1e-9
    if touching.any():
        delta[touching], sign[touching] = centres[touching], 1.0
        norm = np.linalg.norm(delta, axis=1)
    scale = np.divide(sign, norm, out=np.zeros_like(norm), where=norm > 0)
    return scale[:, None] * delta


class _Measured(NamedTuple):
    """The pairs nearer than the distance asked for: indices (k,), distances (k,)
    [m] and ``mj_geomDistance`` witness segments (k, 6) [m]."""

    index: np.ndarray
    distance: np.ndarray
    fromto: np.ndarray


class CollisionAvoidanceTask(Task):
    """Keep geom pairs apart (irteus' yellow/orange zones), as inequality rows.

    Args:
        configuration: Robot configuration: names, and the start distances.
        pairs: Geom pairs: ``(name1, name2)`` tuples or :class:`GeomPair`s
            (see :func:`collision_pairs` / :meth:`from_links`).
        yellow: Yellow zone ``d_y`` [m]: pairs farther apart are ignored.
        orange: Orange zone ``d_o`` [m], the minimum distance (default ``0.1 d_y``);
            a pair nearer than that in ``configuration`` keeps its distance there
            instead (:meth:`keep_start_distances`).
        gain: Velocity-damper gain ``γ`` in (0, 1].
        weight: Slack weight of the rows [cost/m²].
        check: Whether the solve loop's stop test looks at this task
            (satisfied when every pair is within ``check_margin`` of its bound).
        check_margin: Tolerance [m] of the stop test (:data:`DEFAULT_CHECK_MARGIN`).
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        pairs: Sequence[tuple[str, str] | GeomPair],
        *,
        yellow: float = DEFAULT_YELLOW,
        orange: float | None = None,
        gain: float = 0.5,
        weight: float = 1e3,
        check: bool = True,
        check_margin: float = DEFAULT_CHECK_MARGIN,
        name: str = "collision",
    ):
        model = configuration.model
        self.model = model
        if isinstance(pairs, (str, bytes)) or not isinstance(pairs, Sequence):
            raise InvalidInput("pairs must be a list of (geom1, geom2) name tuples")
        self.pairs: list[GeomPair] = []
        for i, p in enumerate(pairs):
            if isinstance(p, GeomPair):
                self.pairs.append(p)
                continue
            if not isinstance(p, (tuple, list)) or len(p) != 2:
                raise InvalidInput(f"pairs[{i}] must be (geom1, geom2), got {p!r}")
            g1, g2 = find_geom(model, p[0]), find_geom(model, p[1])
            if g1 == g2:
                raise InvalidInput(f"pairs[{i}] pairs geom {p[0]!r} with itself")
            self.pairs.append(GeomPair(g1, g2, p[0], p[1]))
        orange = 0.1 * yellow if orange is None else orange
        if not (np.isfinite(yellow) and np.isfinite(orange) and 0.0 <= orange < yellow):
            raise InvalidInput(
                f"zones must satisfy 0 <= orange < yellow [m], got orange={orange}, yellow={yellow}"
            )
        if not (0.0 < gain <= 1.0):
            raise InvalidInput(f"gain must be in (0, 1], got {gain}")
        if not (np.isfinite(weight) and weight > 0):
            raise InvalidInput(f"weight must be > 0, got {weight}")
        if not (np.isfinite(check_margin) and check_margin >= 0):
            raise InvalidInput(f"check_margin must be finite and >= 0 [m], got {check_margin}")
        self.check_margin = float(check_margin)
        self.yellow, self.orange = float(yellow), float(orange)
        self.gain, self.weight = float(gain), float(weight)
        self.check = check
        self.name = name
        self._g1 = np.array([p.geom1 for p in self.pairs], dtype=int)
        self._g2 = np.array([p.geom2 for p in self.pairs], dtype=int)
        self._g1_list, self._g2_list = self._g1.tolist(), self._g2.tolist()
        self._geoms = np.concatenate([self._g1, self._g2])
        types = model.geom_type
        self._plane1 = types[self._g1] == int(mujoco.mjtGeom.mjGEOM_PLANE)
        self._plane2 = types[self._g2] == int(mujoco.mjtGeom.mjGEOM_PLANE)
        hfield = int(mujoco.mjtGeom.mjGEOM_HFIELD)
        self._unbounded = (types[self._g1] == hfield) | (types[self._g2] == hfield)
        self.keep_start_distances(configuration)

    def keep_start_distances(self, configuration: mink.Configuration) -> None:
        """Bound each pair by ``min(d_o, d_0)``, ``d_0`` its distance at ``configuration``.

        The constructor calls it with the configuration it is given (the start of
        the solve); call it again to start from another configuration (it also
        forgets which pairs have rows).
        """
        self.bounds = np.minimum(self.orange, self.distances(configuration, self.yellow))
        self.row_pairs = np.zeros(0, dtype=int)
        self._recalled = np.full((len(self.pairs), 2, RECALL, 3), np.nan)
        self._pending: tuple[np.ndarray, tuple] | None = None

    @classmethod
    def from_links(
        cls,
        configuration: mink.Configuration,
        links: Sequence[str],
        obstacles: Sequence[str] = (),
        **kwargs,
    ) -> CollisionAvoidanceTask:
        """Pairs from :func:`collision_pairs` at the configuration's current pose."""
        pairs = collision_pairs(configuration.model, configuration.data, links, obstacles)
        if not pairs:
            raise InvalidInput(
                f"links {list(links)} and obstacles {list(obstacles)} give no pair to watch"
            )
        return cls(configuration, pairs, **kwargs)

    def near_pairs(self, data: mujoco.MjData, distmax: float) -> np.ndarray:
        """Indices of the pairs that may be nearer than ``distmax`` [m].

        The distance of two geoms is at least the gap of their bounding spheres
        and at least the gap of their world-aligned bounding boxes:

        .. math::

            d \\ge \\|c_1 - c_2\\| - r_1 - r_2, \\qquad
            d \\ge \\big\\|\\max(0,\\ |a_1 - a_2| - (h_1 + h_2))\\big\\|

        with ``c`` the geom centres, ``r`` MuJoCo's bounding radii, ``a`` and
        ``h = |R| h_G`` the centres and half sizes of the geoms' boxes in the
        world. A plane (infinite for MuJoCo's collisions) bounds the distance of
        the other geom by its centre's height over the plane, as MuJoCo's own
        bounding-sphere filter does,

        .. math::

            d \\ge n_p^T (c - p) - r

        (``n_p`` the plane's normal, its ``z`` axis, ``p`` its centre). A height
        field has no bound: its pairs are always measured.
        """
        m = self.model
        g1, g2, both = self._g1, self._g2, self._geoms  # both: g1's, then g2's
        c = data.geom_xpos[both]
        R = data.geom_xmat[both].reshape(-1, 3, 3)
        rbound, aabb = m.geom_rbound[both], m.geom_aabb[both]
        n = len(g1)
        c1, c2, R1, R2 = c[:n], c[n:], R[:n], R[n:]
        lower = np.linalg.norm(c1 - c2, axis=1) - rbound[:n] - rbound[n:]
        a = c + np.einsum("nij,nj->ni", R, aabb[:, :3])
        h = np.einsum("nij,nj->ni", np.abs(R), aabb[:, 3:])
        box_gap = np.linalg.norm(np.maximum(np.abs(a[:n] - a[n:]) - h[:n] - h[n:], 0.0), axis=1)
        bound = np.maximum(lower, box_gap)
        for on, plane, other, R_plane in ((self._plane1, g1, g2, R1), (self._plane2, g2, g1, R2)):
            if on.any():
                height = np.einsum(
                    "ni,ni->n",
                    R_plane[on, :, 2],
                    data.geom_xpos[other[on]] - data.geom_xpos[plane[on]],
                )
                bound[on] = height - m.geom_rbound[other[on]]
        return np.flatnonzero(self._unbounded | (bound < distmax))

    def _measure(
        self, configuration: mink.Configuration, distmax: float
    ) -> tuple[np.ndarray, _Measured]:
        """Distance of every pair capped at ``distmax`` [m], and the measured pairs."""
        m, data = configuration.model, configuration.data
        d = np.full(len(self.pairs), float(distmax))
        near = self.near_pairs(data, distmax)
        fromto = np.empty((len(near), 6))
        g1, g2, distance = self._g1_list, self._g2_list, mujoco.mj_geomDistance
        for k, i in enumerate(near.tolist()):
            d[i] = distance(m, data, g1[i], g2[i], distmax, fromto[k])
        inside = d[near] < distmax
        index = near[inside]
        return d, _Measured(index, d[index], fromto[inside])

    def distances(self, configuration: mink.Configuration, distmax: float = 10.0) -> np.ndarray:
        """Signed distance of every pair [m] (capped at ``distmax``)."""
        return self._measure(configuration, distmax)[0]

    def _rows(self, configuration: mink.Configuration, measured: _Measured) -> TaskRows:
        """One row per pair that has been inside the yellow zone since the start
        (:attr:`row_pairs`, in pair order); a row is inactive (``0 x >= -d_y``)
        while its pair is outside the zone. Then ``2 RECALL`` rows per such pair
        for its remembered witness points (:meth:`_recalled_rows`), inactive
        where there is none.

        Pairs never in the zone give no row: a row per pair would put hundreds
        of inactive rows and slacks into every level's QP (579 pairs on G1). A
        pair keeps its row once it had one, so that the QP's shape changes only
        when a new pair comes near (each change costs the QP solver a new setup).
        """
        m, data = configuration.model, configuration.data
        index = measured.index
        self.row_pairs = np.union1d(self.row_pairs, index)
        n = len(self.row_pairs)  # the witness rows, then 2 RECALL rows per pair
        size = (1 + 2 * RECALL) * n
        C_all, lower_all = np.zeros((size, m.nv)), np.full(size, -self.yellow)
        C, lower = C_all[:n], lower_all[:n]
        if len(index):
            g1, g2 = self._g1[index], self._g2[index]
            b1, b2 = m.geom_bodyid[g1], m.geom_bodyid[g2]
            centres = data.geom_xpos[g1] - data.geom_xpos[g2]
            normal = _normals(measured.distance, measured.fromto, centres)
            J = np.empty((len(index), 2, 3, m.nv))
            for k in range(len(index)):
                mujoco.mj_jac(m, data, J[k, 0], None, measured.fromto[k, :3], b1[k])
                mujoco.mj_jac(m, data, J[k, 1], None, measured.fromto[k, 3:], b2[k])
            rows = np.searchsorted(self.row_pairs, index)
            C[rows] = np.einsum("ki,kiv->kv", normal, J[:, 0] - J[:, 1])
            lower[rows] = -self.gain * (measured.distance - self.bounds[index])
            self._remember(configuration, measured, b1, b2)
            self._recalled_rows(configuration, measured, rows, normal, J, C_all[n:], lower_all[n:])
        return TaskRows.inequality(C_all, lower_all, np.inf, self.weight)

    def _recalled_rows(
        self,
        configuration: mink.Configuration,
        measured: _Measured,
        rows: np.ndarray,
        normal: np.ndarray,
        J: np.ndarray,
        C: np.ndarray,
        lower: np.ndarray,
    ) -> None:
        """Write the rows of the remembered witness points of the measured pairs
        that are apart (module docstring) into ``C`` and ``lower`` (inactive rows,
        ``0 x >= -d_y``, as given): row ``(2 r + s) RECALL + j`` for point ``j`` on
        side ``s`` of the pair whose witness row is ``r``; rows of pairs not
        measured, of missing points and of points at the current witness stay
        inactive."""
        m, data = configuration.model, configuration.data
        apart = np.flatnonzero(measured.distance >= 0.0)  # penetrating: the witness row pushes
        pairs = measured.index[apart]
        # both sides at once: [k, s] is side s (0: geom 1, 1: geom 2) of pair k
        bodies = m.geom_bodyid[np.stack([self._g1[pairs], self._g2[pairs]], axis=1)]
        points = self._recalled[pairs]  # (k, 2, RECALL, 3) in the bodies' frames
        R = data.xmat[bodies].reshape(-1, 2, 3, 3)
        world = data.xpos[bodies][:, :, None, :] + np.einsum("ksij,ksrj->ksri", R, points)
        ends = measured.fromto[apart].reshape(-1, 2, 3)  # [k, s]: side s's witness point
        far = np.linalg.norm(world - ends[:, :, None, :], axis=3) >= SAME_POINT  # nan: False
        k, side, j = np.nonzero(far)
        if not len(k):
            return
        n = (1.0 - 2.0 * side)[:, None] * normal[apart[k]]  # n points from b to a
        x = world[k, side, j]
        point_bodies = bodies[k, side]
        # J_p(x) = J_p(x_B) - [x - x_B]_x J_r(B), so
        # n^T J_p(x) = n^T J_p(x_B) + ((x - x_B) x n)^T J_r(B)  (mj_jacBody at x_B)
        slot = {body: u for u, body in enumerate(dict.fromkeys(point_bodies.tolist()))}
        body_of = np.array([slot[body] for body in point_bodies.tolist()])
        jacp, jacr = np.empty((2, len(slot), 3, m.nv))
        for body, u in slot.items():  # each body's Jacobian once
            mujoco.mj_jacBody(m, data, jacp[u], jacr[u], body)
        arm = cross_rows(x - data.xpos[point_bodies], n)
        row = (2 * rows[apart[k]] + side) * RECALL + j
        C[row] = np.einsum("pi,piv->pv", n, jacp[body_of] - J[apart[k], 1 - side]) + np.einsum(
            "pi,piv->pv", arm, jacr[body_of]
        )
        gap = np.einsum("pi,pi->p", n, x - ends[k, 1 - side])
        lower[row] = -self.gain * (gap - self.bounds[pairs[k]])

    def _remember(
        self,
        configuration: mink.Configuration,
        measured: _Measured,
        b1: np.ndarray,
        b2: np.ndarray,
    ) -> None:
        """Keep the witness points of apart pairs, in their bodies' frames, the
        newest first, :data:`RECALL` distinct ones per geom. A configuration's
        points are kept once another configuration is measured, so that rows
        asked twice at one configuration are the same."""
        data = configuration.data
        pending, self._pending = self._pending, None
        if pending is not None and not np.array_equal(pending[0], configuration.q):
            pairs, sides, local = pending[1]
            kept = self._recalled[pairs, sides]  # (k, RECALL, 3)
            seen = np.linalg.norm(kept - local[:, None, :], axis=2) < SAME_POINT  # nan: False
            new = ~seen.any(axis=1)
            pairs, sides = pairs[new], sides[new]
            self._recalled[pairs, sides, 1:] = kept[new, :-1]
            self._recalled[pairs, sides, 0] = local[new]
        elif pending is not None:
            self._pending = pending
            return
        apart = measured.distance >= 0.0
        pairs = measured.index[apart]
        bodies = np.concatenate([b1[apart], b2[apart]])  # side 0's points, then side 1's
        fromto = measured.fromto[apart]
        p = np.concatenate([fromto[:, :3], fromto[:, 3:]]) - data.xpos[bodies]
        local = np.einsum("kji,kj->ki", data.xmat[bodies].reshape(-1, 3, 3), p)  # Rᵀ (p − x_body)
        sides = np.repeat([0, 1], len(pairs))
        points = (np.concatenate([pairs, pairs]), sides, local)
        self._pending = (configuration.q.copy(), points)

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        return self._rows(configuration, self._measure(configuration, self.yellow)[1])

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """How far each pair is inside its bound ``min(d_o, d_0)`` [m] (0 when clear)."""
        return np.maximum(self.bounds - self.distances(configuration, self.yellow), 0.0)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return bool(np.all(self.compute_error(configuration) <= self.check_margin))

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, error and stop test from one measurement of the pairs."""
        d, measured = self._measure(configuration, self.yellow)
        error = np.maximum(self.bounds - d, 0.0)
        return TaskState(
            self._rows(configuration, measured),
            float(np.linalg.norm(error)),
            bool(np.all(error <= self.check_margin)),
        )

    def __repr__(self) -> str:
        return (
            f"CollisionAvoidanceTask(name={self.name!r}, pairs={len(self.pairs)}, "
            f"yellow={self.yellow}, orange={self.orange}, gain={self.gain})"
        )
