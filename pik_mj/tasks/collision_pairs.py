"""Which geom pairs MuJoCo collides, and the pairs a collision avoidance watches.

:func:`collidable_pairs` answers, from the model alone, which geom pairs
``mj_collision`` tests (and so which can ever be in ``data.contact``):

* nothing when the model disables contacts (``<flag contact="disable">`` or
  ``constraint="disable"``: ``mjDSBL_CONTACT``, ``mjDSBL_CONSTRAINT``);
* every explicit pair (``<contact><pair>``): tested whatever the geoms'
  ``contype``/``conaffinity``, ``<exclude>`` and parent–child filtering;
* every other pair of geoms ``g1``, ``g2`` on bodies ``b1``, ``b2`` whose weld
  bodies ``w = body_weldid[b]`` (the body, or its nearest ancestor with a joint;
  the world ``0`` for a body welded to it) differ, and

  - not parent and child, unless ``<flag filterparent="disable">``
    (``mjDSBL_FILTERPARENT``): ``w1 ≠ 0``, ``w2 ≠ 0`` and ``w1`` is the weld body
    of ``w2``'s parent, or the other way round (the world is never filtered);
  - the body pair is not an ``<exclude>`` (``exclude_signature``,
    ``(min(b1, b2) << 16) + max(b1, b2)``);
  - the bitmask test
    ``(contype_1 & conaffinity_2) ≠ 0  or  (contype_2 & conaffinity_1) ≠ 0``;

* of the geom types, MuJoCo has a collision function (never plane–plane,
  plane–height field, height field–height field).

A user ``mjcb_contactfilter`` (a global callback replacing the bitmask test) is
not seen. Tested against ``mj_collision`` itself: with every margin made large,
the pairs in ``data.contact`` are exactly these.

:func:`collision_pairs` builds the list an avoidance watches (irteus'
``collision-avoidance-link-pair-from-link-list``) from it; :func:`moving_pairs`
keeps the pairs whose distance the solved joints can change.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import NamedTuple

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.frames import names_of
from pik_mj.tasks.joint_limit import find_joint

_GEOM = mujoco.mjtObj.mjOBJ_GEOM
_BODY = mujoco.mjtObj.mjOBJ_BODY
_PLANE, _HFIELD = int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD)
_NO_COLLIDER = frozenset(frozenset(pair) for pair in ((_PLANE,), (_HFIELD,), (_PLANE, _HFIELD)))
"""Geom type pairs (as sets) MuJoCo has no collision function for."""


class GeomPair(NamedTuple):
    """Two geoms whose distance is watched (ids and names)."""

    geom1: int
    geom2: int
    name1: str
    name2: str


def geom_label(model: mujoco.MjModel, g: int) -> str:
    """The geom's MJCF name, or ``geom#<id>`` for an unnamed one."""
    return model.geom(g).name or f"geom#{g}"


def find_geom(model: mujoco.MjModel, name: str) -> int:
    """Id of the geom called ``name``.

    Raises:
        InvalidInput: ``name`` is not a string.
        UnknownName: No such geom (the message lists the valid names).
    """
    if not isinstance(name, str):
        raise InvalidInput(f"geom name must be a string, got {type(name).__name__}")
    g = mujoco.mj_name2id(model, _GEOM, name)
    if g < 0:
        raise UnknownName("geom", name, names_of(model, "geom"))
    return int(g)


def body_geoms(model: mujoco.MjModel, bodies: Iterable[int]) -> np.ndarray:
    """Ids (sorted) of every geom on ``bodies`` (body ids)."""
    wanted = np.zeros(model.nbody, dtype=bool)
    wanted[np.asarray(list(bodies), dtype=int)] = True
    return np.flatnonzero(wanted[model.geom_bodyid])


def geoms_named(model: mujoco.MjModel, names: Sequence[str], what: str) -> np.ndarray:
    """Geom ids of ``names``, each a geom or a body (standing for all its geoms).

    Raises:
        InvalidInput: ``names`` is a string or holds a non-string.
        UnknownName: A name that is neither a geom nor a body (valid names listed).
    """
    if isinstance(names, str):
        raise InvalidInput(f"{what} must be a list of names, not a string")
    out: list[int] = []
    for name in names:
        if not isinstance(name, str):
            raise InvalidInput(f"{what}: names must be strings, got {name!r}")
        g = mujoco.mj_name2id(model, _GEOM, name)
        if g >= 0:
            out.append(int(g))
            continue
        b = mujoco.mj_name2id(model, _BODY, name)
        if b < 0:
            valid = names_of(model, "geom") + names_of(model, "body")
            raise UnknownName(f"{what} geom or body", name, valid)
        out.extend(body_geoms(model, [b]).tolist())
    return np.array(sorted(set(out)), dtype=int)


def contacts_disabled(model: mujoco.MjModel) -> bool:
    """Whether the model's options switch collision detection off
    (``mjDSBL_CONTACT`` or ``mjDSBL_CONSTRAINT``)."""
    off = mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    return bool(model.opt.disableflags & off)


def _dynamic(model: mujoco.MjModel, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(a), len(b)) mask: MuJoCo's dynamic filters (module docstring) pass."""
    weld, parent = model.body_weldid, model.body_parentid
    b1, b2 = model.geom_bodyid[a][:, None], model.geom_bodyid[b][None, :]
    w1, w2 = weld[b1], weld[b2]
    keep = w1 != w2
    if not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        p1, p2 = weld[parent[w1]], weld[parent[w2]]
        keep &= ~((w1 != 0) & (w2 != 0) & ((w1 == p2) | (w2 == p1)))
    if model.nexclude:
        signature = (np.minimum(b1, b2).astype(np.int64) << 16) + np.maximum(b1, b2)
        keep &= ~np.isin(signature, model.exclude_signature)
    t1, a1 = model.geom_contype[a][:, None], model.geom_conaffinity[a][:, None]
    t2, a2 = model.geom_contype[b][None, :], model.geom_conaffinity[b][None, :]
    keep &= ((t1 & a2) != 0) | ((t2 & a1) != 0)
    return keep


def _has_collider(model: mujoco.MjModel, pairs: np.ndarray) -> np.ndarray:
    """(k,) mask: MuJoCo has a collision function for each pair's geom types."""
    kinds = model.geom_type[pairs]
    return np.array([frozenset(k) not in _NO_COLLIDER for k in kinds.tolist()], dtype=bool).reshape(
        len(pairs)
    )


def collidable_pairs(
    model: mujoco.MjModel,
    geoms: Iterable[int] | None = None,
    others: Iterable[int] | None = None,
) -> np.ndarray:
    """The geom pairs ``mj_collision`` tests (module docstring), ``(k, 2)`` ids with
    ``g1 < g2``, sorted.

    Args:
        model: The model.
        geoms: Geom ids; default every geom. Without ``others``: the pairs of two
            of these geoms.
        others: Geom ids: the pairs of one of ``geoms`` and one of these.

    Returns:
        The pairs, explicit ones included, each once.
    """
    a = np.arange(model.ngeom) if geoms is None else np.unique(np.asarray(list(geoms), dtype=int))
    b = a if others is None else np.unique(np.asarray(list(others), dtype=int))
    if contacts_disabled(model) or not len(a) or not len(b):
        return np.zeros((0, 2), dtype=int)
    mask = _dynamic(model, a, b)
    i, j = np.nonzero(mask)
    found = np.column_stack([a[i], b[j]])
    if model.npair:
        explicit = np.column_stack([model.pair_geom1, model.pair_geom2])
        in_a, in_b = np.isin(explicit, a), np.isin(explicit, b)
        chosen = (in_a[:, 0] & in_b[:, 1]) | (in_a[:, 1] & in_b[:, 0])
        found = np.vstack([found, explicit[chosen]])
    found = np.sort(found, axis=1)
    found = found[found[:, 0] != found[:, 1]]
    found = np.unique(found, axis=0) if len(found) else found.reshape(0, 2)
    return found[_has_collider(model, found)] if len(found) else found


def geom_pairs(model: mujoco.MjModel, pairs: np.ndarray) -> list[GeomPair]:
    """``(k, 2)`` geom ids as :class:`GeomPair` s (names: :func:`geom_label`)."""
    return [
        GeomPair(g1, g2, geom_label(model, g1), geom_label(model, g2)) for g1, g2 in pairs.tolist()
    ]


def apart(
    model: mujoco.MjModel, data: mujoco.MjData, pairs: np.ndarray, touching: float = 0.0
) -> np.ndarray:
    """(k,) mask: the pairs farther apart than ``touching`` [m] in ``data``
    (``mj_geomDistance``; kinematics current)."""
    cut = touching + 1e-9
    return np.array(
        [
            mujoco.mj_geomDistance(model, data, g1, g2, cut, None) > touching
            for g1, g2 in pairs.tolist()
        ],
        dtype=bool,
    ).reshape(len(pairs))


def collision_pairs(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    links: Sequence[str],
    obstacles: Sequence[str] = (),
    *,
    touching: float = 0.0,
) -> list[GeomPair]:
    """Geom pairs to watch, built like irteus' link-pair list from the pairs MuJoCo
    collides (:func:`collidable_pairs`).

    1. every pair MuJoCo collides of two geoms on ``links`` (self collision), and
       of a geom on ``links`` and an ``obstacles`` geom;
    2. minus pairs already touching at the reference pose in ``data`` (distance
       ``<= touching`` [m]): "links that always intersect".

    Args:
        model: The model (robot or scene).
        data: Reference pose (kinematics current).
        links: Robot body names (irteus links).
        obstacles: Environment geom or body names (a body stands for its geoms).
        touching: Distance [m] at or below which a pair counts as touching.

    Returns:
        The pairs, self pairs first.

    Raises:
        InvalidInput: ``links`` or ``obstacles`` is a string.
        UnknownName: A link that is no body, an obstacle that is neither geom nor body.
    """
    if isinstance(links, str) or isinstance(obstacles, str):
        raise InvalidInput("links and obstacles must be lists of names, not a string")
    bodies = []
    for name in links:
        b = mujoco.mj_name2id(model, _BODY, name) if isinstance(name, str) else -1
        if b < 0:
            raise UnknownName("body", str(name), names_of(model, "body"))
        bodies.append(int(b))
    link_geoms = body_geoms(model, bodies)
    obstacle_geoms = geoms_named(model, obstacles, "obstacles")
    rank = np.zeros(model.ngeom, dtype=int)  # links, then obstacles, in the order given
    for i, name in enumerate(obstacles):
        rank[geoms_named(model, [name], "obstacles")] = len(bodies) + i
    for i, b in enumerate(bodies):
        rank[model.geom_bodyid == b] = i
    own = _ordered(collidable_pairs(model, link_geoms), rank)
    against = collidable_pairs(model, link_geoms, obstacle_geoms)
    against = _ordered(against[~np.all(np.isin(against, link_geoms), axis=1)], rank)
    pairs = np.vstack([own, against])
    return geom_pairs(model, pairs[apart(model, data, pairs, touching)])


def _ordered(pairs: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """``pairs`` each with the geom of lower ``rank`` first, sorted by the ranks."""
    flip = rank[pairs[:, 0]] > rank[pairs[:, 1]]
    pairs = np.where(flip[:, None], pairs[:, ::-1], pairs)
    order = np.lexsort((pairs[:, 1], pairs[:, 0], rank[pairs[:, 1]], rank[pairs[:, 0]]))
    return pairs[order]


def path_joints(model: mujoco.MjModel, body1: int, body2: int) -> set[int]:
    """Ids of the joints on the path between two bodies: up from each to their
    lowest common ancestor (a joint above it moves both alike)."""

    def chain(b: int) -> list[int]:
        out = [b]
        while out[-1] != 0:
            out.append(int(model.body_parentid[out[-1]]))
        return out

    c1, c2 = chain(body1), chain(body2)
    common = set(c1) & set(c2)
    return {
        j
        for b in c1 + c2
        if b not in common
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b])
    }


def moved_by(model: mujoco.MjModel, pairs: np.ndarray, dofs: Iterable[int]) -> np.ndarray:
    """(k,) mask: the pairs ``(k, 2)`` (geom ids) whose distance a motion of the
    degrees of freedom ``dofs`` (tangent-space indices) can change: a joint on the
    path between the two geoms' bodies (:func:`path_joints`) has one of them."""
    moving = set(model.dof_jntid[np.asarray(list(dofs), dtype=int)].tolist())
    body = model.geom_bodyid
    return np.array(
        [bool(path_joints(model, int(body[a]), int(body[b])) & moving) for a, b in pairs.tolist()],
        dtype=bool,
    ).reshape(len(pairs))


def moving_pairs(
    model: mujoco.MjModel, pairs: Sequence[GeomPair], joints: Sequence[str]
) -> list[GeomPair]:
    """The pairs whose distance the joints ``joints`` can change.

    Two bodies move relative to each other only through the joints on the path
    between them (:func:`path_joints`). A pair whose path holds no joint of
    ``joints`` keeps its distance whatever the solve does: its row could only be
    constant, and a solver given such rows (pinned by the hard rows that freeze
    the other joints) converges slowly.

    Args:
        model: The model.
        pairs: Candidate pairs (:func:`collision_pairs`).
        joints: Names of the joints the solve moves.

    Raises:
        UnknownName: A joint name the model does not have.
    """
    refs = [find_joint(model, j) for j in joints]
    dofs = [d for r in refs for d in r.dofs.tolist()]
    ids = np.array([(p.geom1, p.geom2) for p in pairs], dtype=int).reshape(-1, 2)
    keep = moved_by(model, ids, dofs)
    return [p for p, k in zip(pairs, keep.tolist(), strict=True) if k]
