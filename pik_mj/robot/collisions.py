"""The geom pairs a robot can collide in: with itself, and with its world.

Both lists start from the pairs MuJoCo collides
(:func:`pik_mj.tasks.collision_pairs.collidable_pairs`: ``<contact><pair>``,
``<exclude>``, contype/conaffinity, parent–child filtering), so a robot whose
self-collision is declared only as explicit pairs is watched as MuJoCo collides
it. The robot's geoms are those on its subtree (:attr:`RobotModel.root_body_id`);
every other geom of its model (the floor, the room's counter, a kettle) is its
world. From those pairs, a solve watches the ones that

* are apart at the start (farther than ``touching``): a foot standing on the
  floor, a hand holding a handle are contacts the robot already makes;
* are not a planned contact (``allowed``: a name, geom or body, on either side
  lets every pair with its geoms touch; two names let the pairs between them
  touch, e.g. ``("rarm_hand", "wall")``);
* can change their distance through the degrees of freedom the solve moves
  (:func:`pik_mj.tasks.collision_pairs.moved_by`; a floating base moves every
  robot–world pair).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.robot.floor_contact import subtree_bodies
from pik_mj.robot.robot_model import RobotModel
from pik_mj.tasks.collision_pairs import (
    GeomPair,
    apart,
    body_geoms,
    collidable_pairs,
    geom_pairs,
    geoms_named,
    moved_by,
)

Allowed = Sequence[str | tuple[str, str]]
"""Planned contacts: names (geom or body) and pairs of names."""


def robot_geoms(robot: RobotModel) -> np.ndarray:
    """Ids of the geoms on the robot's bodies (its root body's subtree)."""
    return body_geoms(robot.model, subtree_bodies(robot.model, robot.root_body_id))


def self_collision_pairs(
    robot: RobotModel, dofs: Iterable[int] | None = None, *, touching: float = 0.0
) -> list[GeomPair]:
    """The pairs of the robot's own geoms MuJoCo collides, apart (farther than
    ``touching`` [m]) at the current pose, and moved by ``dofs`` (tangent-space
    indices; default every degree of freedom)."""
    return _watched(robot, collidable_pairs(robot.model, robot_geoms(robot)), dofs, touching)


def world_collision_pairs(
    robot: RobotModel,
    dofs: Iterable[int] | None = None,
    *,
    allowed: Allowed = (),
    touching: float = 0.0,
) -> list[GeomPair]:
    """The pairs of a robot geom and a world geom MuJoCo collides (module docstring),
    robot geom first: apart (farther than ``touching`` [m]) at the current pose,
    not ``allowed``, and moved by ``dofs`` (tangent-space indices; default every
    degree of freedom).

    Raises:
        InvalidInput: A malformed ``allowed``.
        UnknownName: A name in ``allowed`` that is neither geom nor body.
    """
    model = robot.model
    own = robot_geoms(robot)
    world = np.setdiff1d(np.arange(model.ngeom), own)
    pairs = collidable_pairs(model, own, world)
    pairs = np.where(np.isin(pairs[:, :1], own), pairs, pairs[:, ::-1])  # robot geom first
    return _watched(robot, pairs[~_allowed_mask(robot, pairs, allowed)], dofs, touching)


def _allowed_mask(robot: RobotModel, pairs: np.ndarray, allowed: Allowed) -> np.ndarray:
    """(k,) mask: the pairs ``allowed`` lets touch (module docstring)."""
    if isinstance(allowed, str):
        raise InvalidInput(f"allowed contacts must be a list of names or pairs, got {allowed!r}")
    mask = np.zeros(len(pairs), dtype=bool)
    for entry in allowed:
        if isinstance(entry, str):
            mask |= np.isin(pairs, geoms_named(robot.model, [entry], "allowed")).any(axis=1)
        elif isinstance(entry, (tuple, list)) and len(entry) == 2:
            a = geoms_named(robot.model, [entry[0]], "allowed")
            b = geoms_named(robot.model, [entry[1]], "allowed")
            in_a, in_b = np.isin(pairs, a), np.isin(pairs, b)
            mask |= (in_a[:, 0] & in_b[:, 1]) | (in_a[:, 1] & in_b[:, 0])
        else:
            raise InvalidInput(
                f"an allowed contact is a geom or body name, or a pair of them; got {entry!r}"
            )
    return mask


def _watched(
    robot: RobotModel, pairs: np.ndarray, dofs: Iterable[int] | None, touching: float
) -> list[GeomPair]:
    """``pairs`` apart at the current pose and moved by ``dofs``, as :class:`GeomPair` s."""
    model = robot.model
    if dofs is not None:
        pairs = pairs[moved_by(model, pairs, dofs)]
    return geom_pairs(model, pairs[apart(model, robot.data, pairs, touching)])
