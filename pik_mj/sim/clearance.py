"""Clearance along a motion: the smallest distance between two sets of geoms, in
the physics and in the reference the servos track (:class:`Clearance`, a
callback of :meth:`pik_mj.sim.Scene.play`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.frames import names_of

__all__ = ["Clearance", "min_distance"]


def _geom_ids(model: mujoco.MjModel, geoms: Sequence[str | int], what: str) -> list[int]:
    if isinstance(geoms, (str, bytes)) or not isinstance(geoms, Sequence) or not geoms:
        raise InvalidInput(f"{what} must be a non-empty list of geom names or ids, got {geoms!r}")
    out = []
    for g in geoms:
        if isinstance(g, str):
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g)
            if i < 0:
                raise UnknownName("geom", g, names_of(model, "geom"))
            out.append(int(i))
        elif isinstance(g, (int, np.integer)) and 0 <= g < model.ngeom:
            out.append(int(g))
        else:
            raise InvalidInput(f"{what}: {g!r} is not a geom of the model (0..{model.ngeom - 1})")
    return out


def min_distance(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    geoms: Sequence[int],
    obstacles: Sequence[int],
    distmax: float = 1.0,
) -> float:
    """Smallest signed distance [m] between any of ``geoms`` and any of
    ``obstacles`` (geom ids) in ``data``: MuJoCo's ``mj_geomDistance``, negative
    when they penetrate (the depth), ``distmax`` when all are farther."""
    return min(
        mujoco.mj_geomDistance(model, data, g, o, distmax, None) for g in geoms for o in obstacles
    )


class Clearance:
    """The smallest distance [m] between ``geoms`` and ``obstacles`` along a
    motion, in the physics (``physics``) and in the reference the servos track
    (``reference``): a callback of :meth:`pik_mj.sim.Scene.play` (one instance
    may follow several parts of a motion, in scenes of the same world).

    Args:
        model: The scene's model (geom names are looked up in it).
        geoms: Geom names or ids (e.g. an arm's).
        obstacles: Geom names or ids (e.g. a box, a counter).
        distmax: Distances beyond it read as ``distmax`` [m].

    Attributes:
        physics: Smallest distance in the physics [m] (``inf`` before a sample).
        reference: Smallest distance in the reference [m].
        physics_time: When the physics' smallest distance was reached [s].
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        geoms: Sequence[str | int],
        obstacles: Sequence[str | int],
        distmax: float = 1.0,
    ):
        self.geoms = _geom_ids(model, geoms, "geoms")
        self.obstacles = _geom_ids(model, obstacles, "obstacles")
        self.distmax = inputs.real(distmax, "distmax", unit="m", low=0, low_open=True)
        self.physics = self.reference = math.inf
        self.physics_time = math.nan

    def __call__(self, sample: Any) -> None:
        d = min_distance(sample.model, sample.data, self.geoms, self.obstacles, self.distmax)
        if d < self.physics:
            self.physics, self.physics_time = d, float(sample.time)
        if sample.reference is not None:
            d = min_distance(
                sample.model, sample.reference, self.geoms, self.obstacles, self.distmax
            )
            self.reference = min(self.reference, d)
