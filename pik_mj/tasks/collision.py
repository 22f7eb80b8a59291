"""Collision avoidance as inequality rows (irteus ``:collision-avoidance``, Sugiura et al.).

For each pair of geoms ``(a, b)`` MuJoCo gives the signed distance ``d`` and the
witness points ``p_a``, ``p_b`` (``mj_geomDistance``, its ``fromto`` segment).
With the unit normal ``n`` pointing from ``b`` to ``a`` (flipped when the geoms
penetrate), the distance changes to first order as

.. math::

    \\dot d = n^T \\big(J_p(p_a) - J_p(p_b)\\big)\\, \\dot q

(``J_p`` of a point fixed to the geom's body, ``mj_jac``). The seed's two zones:

* yellow zone ``d_y`` (seed ``avoid-collision-distance``, 200 mm): a pair
  farther apart contributes nothing (its row is inactive: unbounded);
* orange zone ``d_o`` (seed: 0.1 ``d_y``): the minimum distance kept.

Inside the yellow zone a pair's row is the velocity damper of Faverjon &
Tournassoud (the step may close at most a fraction ``γ`` of the gap to the
orange zone):

.. math::

    n^T (J_a - J_b)\\, x \\;\\ge\\; -\\gamma\\, (d - d_o)

so ``d + Δd ≥ d_o + (1 - γ)(d - d_o)``; ``γ = 1`` is the plain linearization
``d + Δd ≥ d_o``, and a pair already inside the orange zone is pushed out.
Where the task stands in the priority list decides what wins: above the
hand's target it avoids even against the target (the seed's orange zone);
below it, avoidance uses only what the target leaves free (the seed's null
space term). Pair lists are built like the seed's
``collision-avoidance-link-pair-from-link-list``: see :func:`collision_pairs`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import mink
import mujoco
import numpy as np

from ..exceptions import InvalidInput, UnknownName
from ..frames import names_of
from .task import Task, TaskRows

DEFAULT_YELLOW = 0.2
"""Seed ``avoid-collision-distance`` [m] (200 mm)."""


class GeomPair(NamedTuple):
    """Two geoms whose distance is watched (ids and names)."""

    geom1: int
    geom2: int
    name1: str
    name2: str


def _geom_name(model: mujoco.MjModel, g: int) -> str:
    return model.geom(g).name or f"geom#{g}"


def _geom_id(model: mujoco.MjModel, name: str) -> int:
    if not isinstance(name, str):
        raise InvalidInput(f"geom name must be a string, got {type(name).__name__}")
    g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
    if g < 0:
        raise UnknownName("geom", name, names_of(model, "geom"))
    return int(g)


def _collidable(model: mujoco.MjModel, g: int) -> bool:
    return bool(model.geom_contype[g] or model.geom_conaffinity[g])


def _body_geoms(model: mujoco.MjModel, body: int) -> list[int]:
    start, count = int(model.body_geomadr[body]), int(model.body_geomnum[body])
    return [g for g in range(start, start + count) if start >= 0 and _collidable(model, g)]


def _excluded(model: mujoco.MjModel, b1: int, b2: int) -> bool:
    """Adjacent (parent–child) bodies, the same body, or an MJCF ``<exclude>``."""
    if b1 == b2 or model.body_parentid[b1] == b2 or model.body_parentid[b2] == b1:
        return True
    lo, hi = min(b1, b2), max(b1, b2)
    return bool(np.any(model.exclude_signature == ((lo + 1) << 16) + hi + 1))


def collision_pairs(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    links: Sequence[str],
    obstacles: Sequence[str] = (),
    *,
    touching: float = 0.0,
) -> list[GeomPair]:
    """Geom pairs to watch, built like the seed's link-pair list.

    1. every pair of collidable geoms of two different ``links`` (self collision),
       and every link geom against every ``obstacles`` geom;
    2. minus pairs of adjacent bodies (parent–child), pairs MJCF ``<exclude>``s;
    3. minus pairs already touching at the reference pose in ``data``
       (distance ``<= touching`` [m]): "links that always intersect".

    Args:
        model: The model (robot or scene).
        data: Reference pose (kinematics current).
        links: Robot body names (irteus links).
        obstacles: Environment geom or body names (a body stands for its geoms).
        touching: Distance [m] at or below which a pair counts as touching.

    Returns:
        The pairs, self pairs first.
    """
    if isinstance(links, str) or isinstance(obstacles, str):
        raise InvalidInput("links and obstacles must be lists of names, not a string")
    bodies = []
    for name in links:
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if b < 0:
            raise UnknownName("body", name, names_of(model, "body"))
        bodies.append(int(b))
    obstacle_geoms: list[int] = []
    for name in obstacles:
        g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if g >= 0:
            obstacle_geoms.append(int(g))
            continue
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if b < 0:
            valid = names_of(model, "geom") + names_of(model, "body")
            raise UnknownName("geom or body", name, valid)
        obstacle_geoms.extend(_body_geoms(model, int(b)))
    candidates: list[tuple[int, int]] = []
    for i, b1 in enumerate(bodies):
        for b2 in bodies[i + 1 :]:
            if _excluded(model, b1, b2):
                continue
            candidates += [
                (g1, g2) for g1 in _body_geoms(model, b1) for g2 in _body_geoms(model, b2)
            ]
    link_geoms = [g for b in bodies for g in _body_geoms(model, b)]
    candidates += [
        (g1, g2)
        for g1 in link_geoms
        for g2 in obstacle_geoms
        if g1 != g2 and not _excluded(model, model.geom_bodyid[g1], model.geom_bodyid[g2])
    ]
    pairs = []
    for g1, g2 in candidates:
        if mujoco.mj_geomDistance(model, data, g1, g2, touching + 1e-9, None) > touching:
            pairs.append(GeomPair(g1, g2, _geom_name(model, g1), _geom_name(model, g2)))
    return pairs


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
    fromto = np.zeros(6)
    d = float(mujoco.mj_geomDistance(model, data, pair.geom1, pair.geom2, distmax, fromto))
    if d >= distmax:
        return PairDistance(d, fromto[:3], fromto[3:], np.zeros(3))
    p_a, p_b = fromto[:3].copy(), fromto[3:].copy()
    delta = p_a - p_b
    norm = float(np.linalg.norm(delta))
    if norm < 1e-9:
        delta = data.geom_xpos[pair.geom1] - data.geom_xpos[pair.geom2]
        norm = float(np.linalg.norm(delta))
        sign = 1.0
    else:
        sign = 1.0 if d >= 0 else -1.0  # penetrating: fromto runs the other way
    normal = sign * delta / norm if norm > 0 else np.zeros(3)
    return PairDistance(d, p_a, p_b, normal)


def _point_jacobian(
    model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray, body: int
) -> np.ndarray:
    jacp = np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, None, point, body)
    return jacp


class CollisionAvoidanceTask(Task):
    """Keep geom pairs apart (seed yellow/orange zones), as inequality rows.

    Args:
        configuration: Robot configuration (for name lookup).
        pairs: Geom pairs: ``(name1, name2)`` tuples or :class:`GeomPair`s
            (see :func:`collision_pairs` / :meth:`from_links`).
        yellow: Yellow zone ``d_y`` [m]: pairs farther apart are ignored.
        orange: Orange zone ``d_o`` [m], the minimum distance (default ``0.1 d_y``).
        gain: Velocity-damper gain ``γ`` in (0, 1].
        weight: Slack weight of the rows [cost/m²].
        check: Whether the solve loop's stop test looks at this task
            (satisfied when every pair is at least ``orange`` apart).
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
            g1, g2 = _geom_id(model, p[0]), _geom_id(model, p[1])
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
        self.yellow, self.orange = float(yellow), float(orange)
        self.gain, self.weight = float(gain), float(weight)
        self.check = check
        self.name = name

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

    def distances(self, configuration: mink.Configuration, distmax: float = 10.0) -> np.ndarray:
        """Signed distance of every pair [m] (capped at ``distmax``)."""
        m, d = configuration.model, configuration.data
        return np.array([pair_distance(m, d, p, distmax).distance for p in self.pairs])

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        m, data = configuration.model, configuration.data
        # One row per pair, always (a fixed sparsity pattern for the QP backend).
        # Outside the yellow zone a row is inactive: 0·x >= -d_y holds for every x.
        C = np.zeros((len(self.pairs), m.nv))
        lower = np.full(len(self.pairs), -self.yellow)
        for i, pair in enumerate(self.pairs):
            pd = pair_distance(m, data, pair, self.yellow)
            if pd.distance >= self.yellow:
                continue
            J_a = _point_jacobian(m, data, pd.p_a, int(m.geom_bodyid[pair.geom1]))
            J_b = _point_jacobian(m, data, pd.p_b, int(m.geom_bodyid[pair.geom2]))
            C[i] = pd.normal @ (J_a - J_b)
            lower[i] = -self.gain * (pd.distance - self.orange)
        return TaskRows.inequality(C, lower, np.inf, self.weight)

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """How far each pair is inside the orange zone [m] (0 when clear)."""
        return np.maximum(self.orange - self.distances(configuration, self.yellow), 0.0)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return bool(np.all(self.compute_error(configuration) <= 1e-6))

    def __repr__(self) -> str:
        return (
            f"CollisionAvoidanceTask(name={self.name!r}, pairs={len(self.pairs)}, "
            f"yellow={self.yellow}, orange={self.orange}, gain={self.gain})"
        )
