"""MuJoCo geoms and bodies as rerun primitives, grouped: one entity per primitive kind.

Every visible geom is one instance of a multi-instance rerun primitive
(``Boxes3D``, ``Capsules3D``, ``Cylinders3D``, ``Ellipsoids3D``), or one instance
of a mesh drawn once per geom that uses it (``Mesh3D`` placed by
``InstancePoses3D``). The geoms of one kind that belong to the robot share an
entity, those of the scene that are welded to the world another (its poses are
static), and those of moving scene bodies a third. A recording then holds a
handful of geometry entities instead of one per geom and one per body: rerun's
cost per file (building the chunks, the RRD footer) grows with the number of
entities.

Sizes follow MuJoCo's ``geom_size`` conventions; each instance's pose is its
primitive frame in the world,

.. math::
    X_{WP} = X_{WB} \\, X_{BG} \\, X_{GP}, \\qquad
    p_{WP} = p_{WB} + R_{WB} (p_{BG} + R_{BG} \\, o_{GP}), \\qquad
    q_{WP} = q_{WB} \\otimes q_{BG},

with ``X_WB`` MuJoCo's body pose (``xpos``, ``xquat``), ``X_BG`` the geom's
(``geom_pos``, ``geom_quat``) and ``o_GP`` the primitive's origin in the geom
frame: rerun capsules run from their origin along +z (``o = (0, 0, -h)``),
plane slabs lie below the plane (``o = (0, 0, -t)``), other primitives are
centred (``o = 0``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import rerun as rr

from pik_mj.record import style
from pik_mj.record.paths import path_part

__all__ = [
    "BODY_MARKER_RADIUS",
    "BodyFrames",
    "GeomGroup",
    "InstancePoses",
    "Measures",
    "body_markers",
    "geom_groups",
    "geom_rgba",
    "hfield_mesh",
    "measure",
    "right_mul_matrix",
    "subtree",
    "unique_names",
    "vertex_normals",
]

_DEFAULT_GEOM_RGBA = np.array([0.5, 0.5, 0.5, 1.0])
#: Half thickness [m] of the slab drawn for a plane.
PLANE_THICKNESS = 1e-3


def rgba8(rgba: npt.ArrayLike) -> np.ndarray:
    """RGBA in [0, 1] -> uint8 [0, 255]."""
    return np.clip(np.round(np.asarray(rgba, dtype=float) * 255.0), 0, 255).astype(np.uint8)


def geom_rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    """Colour MuJoCo renders geom ``g`` with.

    The geom's own ``rgba`` wins when it differs from MuJoCo's default
    (0.5, 0.5, 0.5, 1); otherwise the material's ``rgba`` is used, if any.
    """
    rgba = np.asarray(model.geom_rgba[g], dtype=float)
    mat = int(model.geom_matid[g])
    if mat >= 0 and np.allclose(rgba, _DEFAULT_GEOM_RGBA, atol=1e-6):
        return np.asarray(model.mat_rgba[mat], dtype=float)
    return rgba


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals of a triangle mesh (unit length, or zero)."""
    v0, v1, v2 = (vertices[faces[:, i]] for i in range(3))
    n_face = np.cross(v1 - v0, v2 - v0)
    normals = np.zeros_like(vertices)
    for i in range(3):
        np.add.at(normals, faces[:, i], n_face)
    norm = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, norm, out=np.zeros_like(normals), where=norm > 0)


def hfield_mesh(model: mujoco.MjModel, h: int) -> tuple[np.ndarray, np.ndarray]:
    """Top surface of height field ``h`` as (vertices (n, 3), triangles (m, 3)).

    .. math::
        x_c = -s_x + 2 s_x c / (n_{col} - 1),\\quad
        y_r = -s_y + 2 s_y r / (n_{row} - 1),\\quad
        z_{rc} = s_z \\, d_{r n_{col} + c}
    """
    nrow, ncol = int(model.hfield_nrow[h]), int(model.hfield_ncol[h])
    sx, sy, sz, _ = (float(s) for s in model.hfield_size[h])
    adr = int(model.hfield_adr[h])
    z = np.asarray(model.hfield_data[adr : adr + nrow * ncol]).reshape(nrow, ncol)
    yy, xx = np.meshgrid(np.linspace(-sy, sy, nrow), np.linspace(-sx, sx, ncol), indexing="ij")
    vertices = np.column_stack([xx.ravel(), yy.ravel(), sz * z.ravel()])
    r, c = np.meshgrid(np.arange(nrow - 1), np.arange(ncol - 1), indexing="ij")
    i00 = (r * ncol + c).ravel()
    i01, i10 = i00 + 1, i00 + ncol
    i11 = i10 + 1
    faces = np.concatenate([np.column_stack([i00, i01, i11]), np.column_stack([i00, i11, i10])])
    return vertices, faces.astype(np.uint32)


def right_mul_matrix(b: np.ndarray) -> np.ndarray:
    """(n, 4, 4) matrices ``M(b)`` with ``a ⊗ b = M(b) a`` for quaternions
    (w, x, y, z) ``b`` (n, 4): the Hamilton product by ``b`` on the right.

    .. math::
        M(b) = \\begin{pmatrix} b_w & -b_x & -b_y & -b_z \\\\ b_x & b_w & b_z & -b_y \\\\
               b_y & -b_z & b_w & b_x \\\\ b_z & b_y & -b_x & b_w \\end{pmatrix}
    """
    w, x, y, z = (b[:, i] for i in range(4))
    return np.stack(
        [
            np.stack([w, -x, -y, -z], axis=1),
            np.stack([x, w, z, -y], axis=1),
            np.stack([y, -z, w, x], axis=1),
            np.stack([z, y, -x, w], axis=1),
        ],
        axis=1,
    )


@dataclass
class GeomGroup:
    """Geoms drawn by one rerun entity, one instance each.

    Attributes:
        path: Entity path.
        archetype: The rerun primitive (``rr.Boxes3D``, ..., ``rr.Mesh3D``).
        ids: MuJoCo geom ids, in instance order.
        names: Geom names (instance labels).
        offset: (k, 3) primitive origin ``o_GP`` in each geom frame [m].
        shape: The static archetype: sizes, colours, labels (mesh data for meshes).
        robot: Whether the geoms are the robot's.
        moving: Whether the instances move (robot and free scene bodies).
    """

    path: str
    archetype: Any
    ids: np.ndarray
    names: list[str]
    offset: np.ndarray
    shape: Any
    robot: bool
    moving: bool


class InstancePoses:
    """World poses of the instances of some geom groups, from their bodies'.

    The bodies' poses come as rows of ``[p_WB, q_WB (w, x, y, z)]`` of the
    bodies ``bodies`` (the body frames a recording logs), so that the poses of
    many rows are computed at once. With the constants ``c_B = p_BG + R_BG o_GP``
    and ``M(q_BG)`` (see :func:`right_mul_matrix`),

    .. math::
        p_{WP} = p_{WB} + q_{WB} \\, c_B \\, q_{WB}^{*}, \\qquad
        q_{WP} = M(q_{BG}) \\, q_{WB}.
    """

    def __init__(self, model: mujoco.MjModel, groups: Sequence[GeomGroup], bodies: np.ndarray):
        ids = np.concatenate([g.ids for g in groups]) if groups else np.zeros(0, dtype=int)
        offset = np.concatenate([g.offset for g in groups]) if groups else np.zeros((0, 3))
        column = {int(b): j for j, b in enumerate(bodies)}
        self._columns = np.array([column[int(b)] for b in model.geom_bodyid[ids]], dtype=int)
        q_BG = np.asarray(model.geom_quat)[ids]
        R_BG = np.empty((len(ids), 9))
        for i, q in enumerate(q_BG):
            mujoco.mju_quat2Mat(R_BG[i], q)
        p_BG = np.asarray(model.geom_pos)[ids]
        self._c_B = p_BG + np.einsum("kij,kj->ki", R_BG.reshape(-1, 3, 3), offset)
        self._M = right_mul_matrix(q_BG)
        ends = np.cumsum([len(g.ids) for g in groups], dtype=int)
        self._slices = [slice(e - len(g.ids), e) for g, e in zip(groups, ends, strict=True)]

    def __call__(self, frames: np.ndarray) -> list[np.ndarray]:
        """Per group, (n, k, 7) poses ``[p_WP, q_WP (w, x, y, z)]`` [m] from the
        body poses ``frames`` (n, bodies, 7)."""
        X = frames[:, self._columns]
        p, q = X[..., :3], X[..., 3:]
        w, u = q[..., :1], q[..., 1:]
        # rotate c_B by the unit quaternion (w, u): c + w t + u x t, t = 2 u x c
        t = 2.0 * np.cross(u, self._c_B)
        poses = np.empty(X.shape)
        poses[..., :3] = p + self._c_B + w * t + np.cross(u, t)
        poses[..., 3:] = np.einsum("kij,nkj->nki", self._M, q)
        return [poses[:, s] for s in self._slices]


@dataclass
class _Instance:
    """One geom's part of a group."""

    g: int
    fields: dict[str, Any]  # per-instance archetype fields (sizes)
    offset: tuple[float, float, float]
    color: tuple[int, ...]


def _primitive(
    model: mujoco.MjModel, g: int, plane_half_size: float
) -> tuple[str, Any, dict[str, Any], tuple[float, float, float]] | None:
    """(entity name, archetype, per-instance fields, o_GP) of geom ``g``, or None
    for an unsupported type. Meshes and height fields name their asset."""
    t = int(model.geom_type[g])
    size = np.asarray(model.geom_size[g], dtype=float)
    G = mujoco.mjtGeom
    if t == G.mjGEOM_BOX:
        return "boxes", rr.Boxes3D, {"half_sizes": size}, (0.0, 0.0, 0.0)
    if t == G.mjGEOM_SPHERE:
        return "ellipsoids", rr.Ellipsoids3D, {"half_sizes": [size[0]] * 3}, (0.0, 0.0, 0.0)
    if t == G.mjGEOM_ELLIPSOID:
        return "ellipsoids", rr.Ellipsoids3D, {"half_sizes": size}, (0.0, 0.0, 0.0)
    if t == G.mjGEOM_CAPSULE:
        fields = {"lengths": 2.0 * size[1], "radii": size[0]}
        return "capsules", rr.Capsules3D, fields, (0.0, 0.0, -size[1])
    if t == G.mjGEOM_CYLINDER:
        fields = {"lengths": 2.0 * size[1], "radii": size[0]}
        return "cylinders", rr.Cylinders3D, fields, (0.0, 0.0, 0.0)
    if t == G.mjGEOM_PLANE:
        # MuJoCo planes are infinite when a size is 0; a thin slab whose top
        # face is the plane z = 0 of the geom frame
        hx = size[0] if size[0] > 0 else plane_half_size
        hy = size[1] if size[1] > 0 else plane_half_size
        fields = {"half_sizes": [hx, hy, PLANE_THICKNESS]}
        return "boxes", rr.Boxes3D, fields, (0.0, 0.0, -PLANE_THICKNESS)
    if t == G.mjGEOM_MESH:
        name = model.mesh(int(model.geom_dataid[g])).name or f"mesh_{model.geom_dataid[g]}"
        return f"meshes/{path_part(name)}", rr.Mesh3D, {}, (0.0, 0.0, 0.0)
    if t == G.mjGEOM_HFIELD:
        h = int(model.geom_dataid[g])
        name = model.hfield(h).name or f"hfield_{h}"
        return f"hfields/{path_part(name)}", rr.Mesh3D, {}, (0.0, 0.0, 0.0)
    return None


def _mesh_shape(model: mujoco.MjModel, g: int, color: np.ndarray) -> Any:
    """``Mesh3D`` of the mesh or height field of geom ``g`` in the geom frame."""
    if int(model.geom_type[g]) == mujoco.mjtGeom.mjGEOM_HFIELD:
        vertices, faces = hfield_mesh(model, int(model.geom_dataid[g]))
    else:
        m = int(model.geom_dataid[g])
        va, vn = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
        fa, fn = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
        vertices = np.asarray(model.mesh_vert[va : va + vn], dtype=np.float32)
        faces = np.asarray(model.mesh_face[fa : fa + fn], dtype=np.uint32)
    return rr.Mesh3D(
        vertex_positions=vertices,
        triangle_indices=faces,
        vertex_normals=vertex_normals(vertices, faces),
        albedo_factor=color,
    )


def _shape(
    archetype: Any, instances: Sequence[_Instance], names: list[str], fill_mode: str = "solid"
) -> Any:
    """The static archetype of a primitive group: stacked sizes, colours, labels."""
    fields: dict[str, Any] = {
        key: np.array([i.fields[key] for i in instances], dtype=float)
        for key in instances[0].fields
    }
    return archetype(
        **fields,
        colors=np.array([i.color for i in instances], dtype=np.uint8),
        labels=names,
        show_labels=False,
        fill_mode=fill_mode,
    )


def geom_groups(
    model: mujoco.MjModel,
    geom_names: Sequence[str],
    *,
    robot: np.ndarray,
    moving: np.ndarray,
    groups: set[int],
    plane_half_size: float,
    entity_path: Any,
    color: Sequence[int] | None = None,
    only: np.ndarray | None = None,
) -> tuple[list[GeomGroup], list[str]]:
    """Group the visible geoms of ``model`` by owner, motion and primitive kind.

    Args:
        model: The MuJoCo model.
        geom_names: A unique name per geom (instance labels).
        robot: Per-body mask of the robot's bodies.
        moving: Per-body mask of the bodies that move in the recording.
        groups: MuJoCo geom groups to draw.
        plane_half_size: Half extent [m] drawn for infinite planes.
        entity_path: ``(kind, robot, moving) -> path`` (:meth:`EntityPaths.geoms`).
        color: One RGBA for every geom, drawn translucent with its primitives'
            major wireframe (a second robot: a motion's reference pose), or None
            (each geom's own colour, solid).
        only: Per-body mask of the bodies whose geoms are grouped (None: all).

    Returns:
        The groups, and the names of geoms of unsupported types.
    """
    members: dict[tuple[str, bool, bool, tuple[int, ...]], tuple[Any, list[_Instance]]] = {}
    skipped: list[str] = []
    for g in range(model.ngeom):
        b = int(model.geom_bodyid[g])
        if int(model.geom_group[g]) not in groups or (only is not None and not only[b]):
            continue
        prim = _primitive(model, g, plane_half_size)
        if prim is None:
            skipped.append(geom_names[g])
            continue
        kind, archetype, fields, offset = prim
        own = rgba8(geom_rgba(model, g)) if color is None else color
        rgba = tuple(int(c) for c in own)
        # a mesh's colour is the entity's (albedo), not per instance
        key = (kind, bool(robot[b]), bool(moving[b]), rgba if archetype is rr.Mesh3D else ())
        members.setdefault(key, (archetype, []))[1].append(_Instance(g, fields, offset, rgba))
    out: list[GeomGroup] = []
    taken: dict[str, int] = {}
    for (kind, is_robot, is_moving, _), (archetype, instances) in members.items():
        path = entity_path(kind, robot=is_robot, moving=is_moving)
        taken[path] = taken.get(path, 0) + 1
        if taken[path] > 1:  # one mesh in several colours
            path = f"{path}_{taken[path]}"
        names = [geom_names[i.g] for i in instances]
        if archetype is rr.Mesh3D:
            shape = _mesh_shape(model, instances[0].g, np.array(instances[0].color, np.uint8))
        else:
            fill = "solid" if color is None else "TransparentFillMajorWireframe"
            shape = _shape(archetype, instances, names, fill)
        out.append(
            GeomGroup(
                path=path,
                archetype=archetype,
                ids=np.array([i.g for i in instances], dtype=int),
                names=names,
                offset=np.array([i.offset for i in instances], dtype=float),
                shape=shape,
                robot=is_robot,
                moving=is_moving,
            )
        )
    return out, skipped


# ---------------------------------------------------------------------------
# Bodies


def subtree(model: mujoco.MjModel, root: int) -> np.ndarray:
    """Boolean mask of the bodies in the kinematic subtree of ``root``."""
    inside = np.zeros(model.nbody, dtype=bool)
    inside[root] = True
    for b in range(root + 1, model.nbody):  # parents have smaller ids
        inside[b] = inside[model.body_parentid[b]]
    return inside


def unique_names(model: mujoco.MjModel, kind: str) -> list[str]:
    """The MJCF names of ``model``'s bodies or geoms (``kind``: ``"body"``,
    ``"geom"``), with ``<kind>_<id>`` for unnamed ones, made unique."""
    accessor = getattr(model, kind)
    count = model.nbody if kind == "body" else model.ngeom
    out: list[str] = []
    seen: set[str] = set()
    for i in range(count):
        name = accessor(i).name
        n = name or f"{kind}_{i}"
        if n in seen:
            n = f"{n}_{i}"
        seen.add(n)
        out.append(n)
    return out


#: Radius [m] of the marker drawn at each body frame.
BODY_MARKER_RADIUS = 0.01


def body_markers(names: Sequence[str]) -> Any:
    """Small wireframe spheres labelled with the body names (their poses are
    logged per row)."""
    return rr.Ellipsoids3D(
        half_sizes=np.full((len(names), 3), BODY_MARKER_RADIUS),
        colors=[(230, 230, 230)],
        labels=list(names),
        show_labels=False,
    )


@dataclass
class BodyFrames:
    """The frames of the moving bodies of the robot (or of the scene), and the
    geometry they carry: its instance poses follow from the body poses."""

    path: str
    ids: np.ndarray  # body ids, one instance each
    groups: list[GeomGroup]  # the moving geom groups on these bodies
    instances: InstancePoses

    def geometry(self, frames: np.ndarray) -> list[tuple[GeomGroup, np.ndarray]]:
        """Each group with its (rows, k, 7) poses, from body poses (rows, bodies, 7)."""
        return list(zip(self.groups, self.instances(frames), strict=True))


# ---------------------------------------------------------------------------
# Sizes the layout and the overlays are scaled by


@dataclass(frozen=True)
class Measures:
    """What a recording's camera, floor and force arrows are scaled by.

    Attributes:
        height: Vertical extent of the robot's geoms [m] (bounding spheres).
        ground_z: Height of the ground under a floating-base robot [m]: the
            highest plane of the scene at or below its lowest point, else that
            lowest point; None for a robot fixed to the world.
        weight: The robot's weight ``m |g|`` [N].
        floor_half_size: Half extent [m] drawn for an infinite plane: the scene's
            other geoms plus half a metre, at least one metre.
        lift: Height [m] above the ground at which overlays on the ground
            (support polygon, ZMP, the CoM's projection) are drawn: just above
            the top of the geoms the robot stands on (its soles), which would
            hide them, else :data:`~pik_mj.record.style.LIFT`.
    """

    height: float
    ground_z: float | None
    weight: float
    floor_half_size: float
    lift: float = style.LIFT


def _aabb(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """World axis-aligned boxes of the geoms: (low (n, 3), high (n, 3)) [m], from
    MuJoCo's geom-frame boxes ``geom_aabb`` (centre ``c``, half sizes ``h``):
    centre ``p + R c``, half sizes ``|R| h``."""
    box = np.asarray(model.geom_aabb).reshape(-1, 6)
    R = np.asarray(data.geom_xmat).reshape(-1, 3, 3)
    centre = np.asarray(data.geom_xpos) + np.einsum("nij,nj->ni", R, box[:, :3])
    half = np.einsum("nij,nj->ni", np.abs(R), box[:, 3:])
    return centre - half, centre + half


def measure(model: mujoco.MjModel, data: mujoco.MjData, robot: np.ndarray) -> Measures:
    """:class:`Measures` of the robot (per-body mask ``robot``) in ``data``'s pose.

    .. math::
        h = \\max_g z^{hi}_g - \\min_g z^{lo}_g, \\qquad W = |g| \\sum_{b \\in robot} m_b

    over the world bounding boxes ``[lo, hi]`` of the robot's geoms ``g``.
    """
    body = np.asarray(model.geom_bodyid)
    plane = np.asarray(model.geom_type) == mujoco.mjtGeom.mjGEOM_PLANE
    mine = robot[body] & ~plane
    lo, hi = _aabb(model, data)
    if mine.any():
        low, high = float(lo[mine, 2].min()), float(hi[mine, 2].max())
    else:  # a robot without geoms: its bodies
        zb = np.asarray(data.xpos)[robot, 2]
        low, high = (float(zb.min()), float(zb.max())) if len(zb) else (0.0, 0.0)
    weight = float(np.linalg.norm(model.opt.gravity) * np.asarray(model.body_mass)[robot].sum())
    ground = None
    free = int(mujoco.mjtJoint.mjJNT_FREE)
    floating = any(
        model.body_jntnum[b] > 0 and model.jnt_type[model.body_jntadr[b]] == free
        for b in np.unique(np.asarray(model.body_rootid)[robot])
    )
    lift = style.LIFT
    if floating:
        floors = np.asarray(data.geom_xpos)[plane & ~robot[body], 2]
        below = floors[floors <= low + 0.02]
        ground = float(below.max()) if len(below) else low
        feet = mine & (lo[:, 2] <= ground + 0.01)  # the geoms it stands on
        if feet.any():
            lift = max(lift, float(hi[feet, 2].max()) - ground + 0.005)
    solid = ~plane
    reach = np.maximum(np.abs(lo[solid, :2]), np.abs(hi[solid, :2])).max(axis=1)
    floor = max(1.0, float(reach.max()) + 0.5) if len(reach) else 1.0
    return Measures(max(high - low, 1e-3), ground, weight, floor, lift)
