"""Where collision geometry meets the floor: lowest points of geoms, a body's gap
to the floor, the contact polygon of one foot and its normal.

The floor is the plane ``z = 0`` of the world (gravity along ``-z``). Only
*collision* geoms count (``contype`` or ``conaffinity`` non-zero, or named by a
``<contact><pair>``): visual meshes (``contype = conaffinity = 0``) never touch
anything in MuJoCo, so they never widen a sole.

The lowest point of a geom is its support point in the direction ``-z``. With
``c`` the geom's centre, ``R = [r_1 r_2 r_3]`` its orientation (``geom_xpos``,
``geom_xmat``) and ``s`` its size, its height is

.. math::

    h_{sphere} = c_z - s_1, \\qquad
    h_{box} = c_z - \\sum_i |R_{3i}|\\, s_i, \\qquad
    h_{ellipsoid} = c_z - \\sqrt{\\textstyle\\sum_i (R_{3i} s_i)^2}

    h_{capsule} = c_z - |R_{33}|\\, s_2 - s_1, \\qquad
    h_{cylinder} = c_z - |R_{33}|\\, s_2 - s_1 \\sqrt{1 - R_{33}^2}

and for a mesh the lowest of its vertices (MuJoCo collides a mesh's convex
hull, whose lowest point is a vertex). The parts of a geom *at* its lowest
height (within a tolerance) are what a floor under it touches: a box's bottom
face or edge or corner, a sphere's lowest point, both end caps' lowest points of
a capsule lying flat, the bottom disc (as a polygon) of a cylinder standing
upright or the bottom line of one lying flat, a mesh's lowest vertices.

What MuJoCo itself makes of a floor under some geoms is :func:`floor_contacts`:
its collision detection (``mj_collision``) between copies of the geoms and a
plane at their lowest point. A mesh touches that plane at the few points MuJoCo's
plane–convex collision picks (at most 4), not at every vertex of its bottom
face: these points, not the vertices, carry the load in the physics.
"""

from __future__ import annotations

import copy
import hashlib
from collections import OrderedDict
from collections.abc import Sequence

import mujoco
import numpy as np

from pik_mj.balance import convex_hull_2d
from pik_mj.exceptions import InvalidInput, NoCollisionGeometry, UnknownName
from pik_mj.frames import names_of

DEFAULT_TOLERANCE = 3e-3
"""Height difference [m] under which two points count as equally low (at rest on
a floor, MuJoCo's soft contacts touch both)."""

CYLINDER_RIM_POINTS = 16
"""Vertices of the polygon standing for the bottom disc of an upright cylinder."""

MIN_SOLE_POINTS = 3
"""Points of a contact polygon with an area: a foot touching at fewer stands on a point
or a line."""

_G = mujoco.mjtGeom

_PROBE_FLOOR = "floor_contacts_plane"


def _in_pairs(model: mujoco.MjModel) -> np.ndarray:
    """Mask (ngeom,) of the geoms named by an explicit ``<contact><pair>``."""
    mask = np.zeros(model.ngeom, dtype=bool)
    mask[model.pair_geom1] = True
    mask[model.pair_geom2] = True
    return mask


def is_collision_geom(model: mujoco.MjModel, geom: int) -> bool:
    """Whether MuJoCo can make contacts with ``geom``: contype or conaffinity
    non-zero, or named by an explicit ``<contact><pair>`` (Menagerie's MJX models
    disable every contact but their pairs)."""
    return bool(model.geom_contype[geom] or model.geom_conaffinity[geom]) or bool(
        _in_pairs(model)[geom]
    )


def subtree_bodies(model: mujoco.MjModel, body: int) -> np.ndarray:
    """Ids of ``body`` and of every body below it."""
    ids = [body]
    for b in range(body + 1, model.nbody):  # MuJoCo numbers children after parents
        if model.body_parentid[b] in ids:
            ids.append(b)
    return np.array(ids, dtype=int)


def collision_geoms(model: mujoco.MjModel, bodies: Sequence[int] | np.ndarray) -> np.ndarray:
    """Ids of the collision geoms attached to ``bodies`` (planes and height fields excluded)."""
    on = np.isin(model.geom_bodyid, np.asarray(bodies, dtype=int))
    collide = (model.geom_contype != 0) | (model.geom_conaffinity != 0) | _in_pairs(model)
    solid = ~np.isin(model.geom_type, [_G.mjGEOM_PLANE, _G.mjGEOM_HFIELD])
    return np.flatnonzero(on & collide & solid)


def _mesh_vertices(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> np.ndarray:
    """World positions (n, 3) [m] of a mesh geom's vertices."""
    mesh = int(model.geom_dataid[geom])
    start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
    v_G = np.asarray(model.mesh_vert[start : start + count], dtype=float)
    return data.geom_xpos[geom] + v_G @ data.geom_xmat[geom].reshape(3, 3).T


def lowest_height(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> float:
    """Height ``z`` [m] of the lowest point of ``geom`` (formulas in the module docstring).

    Raises:
        InvalidInput: A plane, height field or SDF geom (no lowest point).
    """
    c = data.geom_xpos[geom]
    R = data.geom_xmat[geom].reshape(3, 3)
    s = model.geom_size[geom]
    kind = int(model.geom_type[geom])
    if kind == _G.mjGEOM_SPHERE:
        return float(c[2] - s[0])
    if kind == _G.mjGEOM_BOX:
        return float(c[2] - np.abs(R[2]) @ s)
    if kind == _G.mjGEOM_ELLIPSOID:
        return float(c[2] - np.linalg.norm(R[2] * s))
    if kind == _G.mjGEOM_CAPSULE:
        return float(c[2] - abs(R[2, 2]) * s[1] - s[0])
    if kind == _G.mjGEOM_CYLINDER:
        return float(c[2] - abs(R[2, 2]) * s[1] - s[0] * np.sqrt(max(1.0 - R[2, 2] ** 2, 0.0)))
    if kind == _G.mjGEOM_MESH:
        return float(_mesh_vertices(model, data, geom)[:, 2].min())
    raise InvalidInput(
        f"geom {geom} is a {_G(kind).name}: only spheres, capsules, cylinders, boxes, "
        "ellipsoids and meshes have a lowest point"
    )


def bottom_points(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    geom: int,
    tolerance: float = DEFAULT_TOLERANCE,
) -> np.ndarray:
    """Points (k, 3) [m] of ``geom`` within ``tolerance`` of its lowest height.

    What a floor under the geom touches (module docstring): their convex hull is
    the geom's contact patch on a floor at its lowest height.
    """
    c = data.geom_xpos[geom]
    R = data.geom_xmat[geom].reshape(3, 3)
    s = model.geom_size[geom]
    kind = int(model.geom_type[geom])
    down = np.array([0.0, 0.0, -1.0])
    if kind == _G.mjGEOM_SPHERE:
        return (c + s[0] * down)[None]
    if kind == _G.mjGEOM_ELLIPSOID:
        # support point of {R diag(s) u : |u| = 1} in the direction -z
        d_G = s * (R.T @ down)
        return (c + R @ (s * d_G / np.linalg.norm(d_G)))[None]
    if kind == _G.mjGEOM_BOX:
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        pts = c + (signs * s) @ R.T
    elif kind == _G.mjGEOM_MESH:
        pts = _mesh_vertices(model, data, geom)
    elif kind in (_G.mjGEOM_CAPSULE, _G.mjGEOM_CYLINDER):
        axis = R[:, 2]
        ends = c + np.outer([-s[1], s[1]], axis)
        if kind == _G.mjGEOM_CAPSULE:
            pts = ends + s[0] * down
        else:
            radial = down - (down @ axis) * axis  # towards the floor, across the axis
            n = float(np.linalg.norm(radial))
            if n > 1e-9:
                pts = ends + s[0] * radial / n
            else:  # upright: the bottom disc, as a polygon on its rim
                angle = np.linspace(0.0, 2.0 * np.pi, CYLINDER_RIM_POINTS, endpoint=False)
                rim = s[0] * (np.outer(np.cos(angle), R[:, 0]) + np.outer(np.sin(angle), R[:, 1]))
                pts = np.vstack([ends[0] + rim, ends[1] + rim])
    else:
        lowest_height(model, data, geom)  # raises with the geom's type
        raise AssertionError("unreachable")
    return pts[pts[:, 2] <= pts[:, 2].min() + tolerance]


def floor_gap(model: mujoco.MjModel, data: mujoco.MjData, root_body: int | str) -> float:
    """Height [m] of the lowest collision geom of the robot above the floor ``z = 0``.

    Positive when the robot floats (Robotis OP3's zero pose), negative when
    it sinks into the floor. Lowering a free-floating root by this much puts the
    robot down on the floor.

    Args:
        model: The model.
        data: Its pose (``geom_xpos``/``geom_xmat`` current, e.g. after ``mj_kinematics``).
        root_body: The robot's top-level body (name or id): its subtree is the robot.

    Raises:
        InvalidInput: The robot has no collision geom.
    """
    heights = geom_heights(model, data, subtree_bodies(model, _body_id(model, root_body)))
    return float(min(heights.values()))


def geom_heights(
    model: mujoco.MjModel, data: mujoco.MjData, bodies: Sequence[int] | np.ndarray
) -> dict[int, float]:
    """Lowest height [m] of each collision geom of ``bodies``, by geom id.

    Raises:
        InvalidInput: The bodies carry no collision geom.
    """
    geoms = collision_geoms(model, bodies)
    if geoms.size == 0:
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(b)) for b in bodies]
        raise NoCollisionGeometry(
            f"bodies {names} have no collision geom (contype or conaffinity non-zero): "
            "nothing of them can touch the floor"
        )
    return {int(g): lowest_height(model, data, int(g)) for g in geoms}


def touching_geoms(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    root_body: int | str,
    tolerance: float = DEFAULT_TOLERANCE,
) -> list[int]:
    """Collision geoms of the robot within ``tolerance`` [m] of its lowest point:
    those touching a floor put under the robot."""
    heights = geom_heights(model, data, subtree_bodies(model, _body_id(model, root_body)))
    lowest = min(heights.values())
    return [g for g, h in heights.items() if h <= lowest + tolerance]


def sole_polygon(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    foot: int | str,
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    geoms: Sequence[int | str] | None = None,
) -> np.ndarray:
    """Contact polygon of one foot on a floor under it, world frame (k, 3) [m].

    The foot is ``foot`` and the bodies below it (toes), or only the collision
    geoms ``geoms`` when given. Of these geoms, those within ``tolerance`` of the
    foot's lowest point take part, each with its parts at that height
    (:func:`bottom_points`); the polygon is the convex hull of these points in the
    horizontal plane, counter-clockwise seen from above, at their mean height. A
    foot touching at one point or along a line gives 1 or 2 points.

    Raises:
        InvalidInput: The foot has no collision geom, or a geom of ``geoms`` is not
            a collision geom.
        UnknownName: A geom name that does not exist.
    """
    if geoms is None:
        heights = geom_heights(model, data, subtree_bodies(model, _body_id(model, foot)))
    else:
        heights = {}
        for g in geoms:
            gid = geom_id(model, g)
            if not is_collision_geom(model, gid):
                raise InvalidInput(
                    f"sole geom {g!r} is not a collision geom (contype = conaffinity = 0)"
                )
            heights[gid] = lowest_height(model, data, gid)
        if not heights:
            raise InvalidInput("give at least one sole geom")
    lowest = min(heights.values())
    pts = np.vstack(
        [
            p
            for g, h in heights.items()
            if h <= lowest + tolerance
            for p in bottom_points(model, data, g, tolerance)
            if p[2] <= lowest + tolerance
        ]
    )
    hull = convex_hull_2d(pts[:, :2], allow_degenerate=True, tol=1e-6)
    return np.column_stack([hull, np.full(len(hull), pts[:, 2].mean())])


FLAT_TOLERANCE = 0.01
"""Height [m] above a foot's lowest point within which :func:`sole_normal` takes
its geoms' bottom points as the sole (a foot tilted by 1° over 20 cm: 3.5 mm)."""


def sole_normal(
    model: mujoco.MjModel, data: mujoco.MjData, geoms: Sequence[int]
) -> np.ndarray | None:
    """Upward unit normal (3,) of the sole formed by the collision ``geoms`` of a
    foot: the plane fitted (least squares, ``np.linalg.svd``) to their bottom
    points within :data:`FLAT_TOLERANCE` of the lowest (:func:`bottom_points`),
    or None when these span no area (a point or a line: a ball or a blade).

    ``[0, 0, 1]`` for a foot standing flat; a foot whose sole is tilted by ``θ``
    gives a normal ``θ`` away from up.
    """
    if len(geoms) == 0:
        return None
    lowest = min(lowest_height(model, data, int(g)) for g in geoms)
    pts = np.vstack([bottom_points(model, data, int(g), FLAT_TOLERANCE) for g in geoms])
    pts = pts[pts[:, 2] <= lowest + FLAT_TOLERANCE]
    centred = pts - pts.mean(axis=0)
    if len(pts) < MIN_SOLE_POINTS:
        return None
    _, sv, vt = np.linalg.svd(centred)
    if sv[1] < 1e-6 * max(sv[0], 1e-12) or sv[1] < 1e-6:  # collinear: no plane
        return None
    n = vt[2]
    return n if n[2] >= 0 else -n


def _element_id(model: mujoco.MjModel, kind: str, element: int | str) -> int:
    """Id of a ``"body"`` or ``"geom"`` given by name or id (checked)."""
    count = model.nbody if kind == "body" else model.ngeom
    if isinstance(element, str):
        obj = mujoco.mjtObj.mjOBJ_BODY if kind == "body" else mujoco.mjtObj.mjOBJ_GEOM
        i = mujoco.mj_name2id(model, obj, element)
        if i < 0:
            raise UnknownName(kind, element, names_of(model, kind))
        return int(i)
    i = int(element)
    if not 0 <= i < count:
        raise InvalidInput(f"{kind} id {i} is out of range [0, {count})")
    return i


def _body_id(model: mujoco.MjModel, body: int | str) -> int:
    return _element_id(model, "body", body)


def geom_id(model: mujoco.MjModel, geom: int | str) -> int:
    """Id of a geom given by name or id.

    Raises:
        UnknownName: No geom of that name (lists the model's geoms).
        InvalidInput: An id out of range.
    """
    return _element_id(model, "geom", geom)


def floor_contacts(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    geoms: Sequence[int],
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    spec: mujoco.MjSpec | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's contact points of the collision ``geoms`` with a floor put under
    them: the horizontal plane through their lowest point (:func:`lowest_height`).

    A probe world holds the plane and the geoms at their poses in ``data``: with
    ``spec`` (the MJCF ``model`` was compiled from), ``spec`` itself with the
    plane added (compiled once per spec), so every mesh is the same compiled hull
    as in ``model`` and MuJoCo picks the same vertices; without it, a copy of
    each geom (a mesh by its vertices in the world frame, whose hull MuJoCo
    recomputes: among equally low vertices of a flat mesh bottom it may pick
    others). The geoms get MuJoCo's contact ``margin`` ``tolerance`` and collide
    with the plane whatever their ``contype``; ``mj_fwdPosition`` runs MuJoCo's
    collision detection and the contacts with ``dist <= tolerance`` are kept,
    their points put on the plane.

    Args:
        model: The model.
        data: The pose (``qpos``, and ``geom_xpos``/``geom_xmat`` current).
        geoms: Collision geom ids of ``model``.
        tolerance: Distance [m] up to which a geom counts as touching the floor.
        spec: The spec ``model`` was compiled from (not modified), or None.

    Returns:
        ``(points (k, 3) [m], geoms (k,))``: each contact point on the plane and the
        geom (id in ``model``) it belongs to.

    Raises:
        InvalidInput: No geom, a geom without a lowest point (plane, height
            field, SDF), or a negative tolerance.
    """
    ids = [int(g) for g in geoms]
    if not ids:
        raise InvalidInput("floor_contacts needs at least one collision geom")
    if not np.isfinite(tolerance) or tolerance < 0.0:
        raise InvalidInput(f"tolerance must be finite and >= 0 [m], got {tolerance}")
    floor_z = min(lowest_height(model, data, g) for g in ids)
    probe = _spec_probe(spec, model, ids) if spec is not None else None
    if probe is None:
        probe = _copy_probe(model, data, ids)
        probe_of = {g: i + 1 for i, g in enumerate(ids)}  # the copies follow the plane
        qpos = probe.qpos0
    else:
        probe_of = {g: probe.geom(model.geom(g).name).id for g in ids}
        qpos = data.qpos
    probe = copy.copy(probe)  # this call's margins
    floor = probe.geom(_PROBE_FLOOR).id
    own = list(probe_of.values())
    probe.geom_margin[own] = tolerance
    probe.geom_contype[own] = probe.geom_conaffinity[own] = 1
    probe_data = mujoco.MjData(probe)
    probe_data.qpos[:] = qpos
    probe_data.mocap_pos[probe.body_mocapid[probe.geom_bodyid[floor]]] = [0.0, 0.0, floor_z]
    mujoco.mj_fwdPosition(probe, probe_data)  # kinematics, bounding volumes, collisions
    geom_of = {p: g for g, p in probe_of.items()}
    points, owners = [], []
    for c in probe_data.contact[: probe_data.ncon]:
        other = int(c.geom2 if c.geom1 == floor else c.geom1 if c.geom2 == floor else -1)
        if other in geom_of and c.dist <= tolerance:
            points.append([c.pos[0], c.pos[1], floor_z])
            owners.append(geom_of[other])
    return np.array(points, dtype=float).reshape(-1, 3), np.array(owners, dtype=int)


_SPEC_PROBES: OrderedDict[str, mujoco.MjModel] = OrderedDict()
"""Compiled probes by :func:`_probe_key`, the most recent last (copying a spec
with meshes takes a good part of a second: robots built alike share theirs)."""

_MAX_SPEC_PROBES = 32


def _probe_key(model: mujoco.MjModel, geoms: list[int]) -> str:
    """A digest of what a probe of ``geoms`` depends on: the kinematic tree and
    the geoms' names, shapes, poses and mesh vertices."""
    h = hashlib.sha1()
    for a in (
        model.body_parentid,
        model.body_pos,
        model.body_quat,
        model.jnt_type,
        model.jnt_qposadr,
        model.jnt_pos,
        model.jnt_axis,
    ):
        h.update(np.ascontiguousarray(a).tobytes())
    for g in sorted(geoms):
        h.update(model.geom(g).name.encode() + b"\0")
        for a in (model.geom_type, model.geom_size, model.geom_pos, model.geom_quat):
            h.update(np.ascontiguousarray(a[g]).tobytes())
        mesh = int(model.geom_dataid[g])
        if model.geom_type[g] == _G.mjGEOM_MESH and mesh >= 0:
            start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            h.update(np.ascontiguousarray(model.mesh_vert[start : start + count]).tobytes())
    return h.hexdigest()


def _spec_probe(
    spec: mujoco.MjSpec, model: mujoco.MjModel, geoms: list[int]
) -> mujoco.MjModel | None:
    """``spec`` with the probe's plane and without any geom but ``geoms`` (and
    without the meshes they do not use, materials and textures), compiled
    (cached by :func:`_probe_key`); None when a geom is unnamed or the probe does
    not have the joints of ``model``."""
    names = {model.geom(g).name for g in geoms}
    if "" in names:
        return None
    key = _probe_key(model, geoms)
    if key not in _SPEC_PROBES:
        world = spec.copy()
        for geom in list(world.geoms):
            if geom.name not in names:
                world.delete(geom)
        used = {geom.meshname for geom in world.geoms}
        for mesh in list(world.meshes):
            if mesh.name not in used:
                world.delete(mesh)
        for geom in world.geoms:
            geom.material = ""
        for asset in [*world.materials, *world.textures]:  # (skyboxes take long)
            world.delete(asset)
        world.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
        for body in world.bodies[1:]:  # no mass is left on them: any will do
            body.explicitinertial, body.mass, body.inertia = True, 1.0, [1.0, 1.0, 1.0]
        _add_floor(world)
        _SPEC_PROBES[key] = world.compile()
        while len(_SPEC_PROBES) > _MAX_SPEC_PROBES:
            _SPEC_PROBES.popitem(last=False)
    _SPEC_PROBES.move_to_end(key)
    probe = _SPEC_PROBES[key]
    return probe if probe.nq == model.nq else None


def _add_floor(spec: mujoco.MjSpec) -> None:
    """The probe's plane, on a mocap body (its height set per call)."""
    body = spec.worldbody.add_body(mocap=True)
    body.add_geom(name=_PROBE_FLOOR, type=_G.mjGEOM_PLANE, size=[0.0, 0.0, 1.0])


def _copy_probe(model: mujoco.MjModel, data: mujoco.MjData, geoms: list[int]) -> mujoco.MjModel:
    """The probe world of :func:`floor_contacts` without a spec: the plane and, on
    one free body (so that MuJoCo collides them with the static plane), a copy of
    each geom at its world pose; the model's collision flags."""
    spec = mujoco.MjSpec()
    spec.option.enableflags = int(model.opt.enableflags)
    spec.option.disableflags = int(model.opt.disableflags)
    spec.compiler.inertiafromgeom = False
    _add_floor(spec)
    body = spec.worldbody.add_body(mass=1.0, inertia=[1.0, 1.0, 1.0])
    body.add_freejoint()
    for i, g in enumerate(geoms):
        kind = int(model.geom_type[g])
        geom = body.add_geom(type=kind)
        if kind == _G.mjGEOM_MESH:
            mesh = spec.add_mesh(name=f"probe_mesh_{i}")
            mesh.uservert = _mesh_vertices(model, data, g).ravel().tolist()
            geom.meshname = mesh.name
            continue
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, data.geom_xmat[g])
        geom.size = model.geom_size[g].copy()
        geom.pos = data.geom_xpos[g].copy()
        geom.quat = quat
    return spec.compile()
