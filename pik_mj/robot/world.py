"""Worlds for a robot: environment specs, attaching one into a robot's spec, and
placing the robot in it.

An environment is any MJCF (a model name such as ``"room"``, a path) or an
:class:`mujoco.MjSpec` — e.g. :func:`floor_environment` with :func:`add_box` /
:func:`add_wall`. :func:`attach_environment` attaches it INTO the robot's spec
(the robot's spec is the host), so the robot's joints, bodies and ``qpos`` come
first and every model built from it has the robot's configuration as a prefix
of its ``qpos``: nothing is ever mapped by name. :func:`place_root` moves the
robot's top-level body by a planar placement ``(p_WR, ψ)`` before that:

.. math::

    p_{WB} = p_{WR} + R_z(\\psi)\\, p_{RB}, \\qquad q_{WB} = q_z(\\psi) \\otimes q_{RB}

(a fixed base: the body's ``pos``/``quat``; a floating base: the same, which is
its free joint's ``qpos0``, and the free joint's pose in every keyframe).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.inputs import Q_LIMIT
from pik_mj.mujoco_warnings import mujoco_warnings
from pik_mj.robot.loading import load_spec
from pik_mj.spatial import quat_mul, rot_z, yaw_of, yaw_quat

__all__ = [
    "EnvironmentLike",
    "add_box",
    "add_floor",
    "add_wall",
    "attach_environment",
    "floor_environment",
    "has_plane",
    "name_unnamed",
    "place_root",
    "placement",
]

EnvironmentLike = str | os.PathLike[str] | mujoco.MjSpec

FLOOR = "floor"
"""Name of the floor plane :func:`floor_environment` and :func:`add_floor` add."""

#: What MuJoCo says while pik_mj attaches an environment with an empty name
#: prefix: expected (names are kept on purpose; the host's <option> wins).
ATTACH_WARNINGS = ("empty prefix", "Attach conflict")


# ----------------------------------------------------------------------------
# Environment builders
# ----------------------------------------------------------------------------


def _add_floor_geom(body: mujoco.MjsBody) -> None:
    body.add_geom(
        name=FLOOR,
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[20.0, 20.0, 0.1],
        rgba=[0.5, 0.5, 0.5, 1.0],
    )


def floor_environment(name: str = "floor") -> mujoco.MjSpec:
    """An environment spec holding only a floor plane ``floor`` at z = 0 and a light.

    Add boxes and walls with :func:`add_box` / :func:`add_wall`, then pass it as
    ``environment`` to :meth:`pik_mj.Robot.from_model` or
    :meth:`pik_mj.sim.Scene.from_robot`.
    """
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.compiler.degree = False
    _add_floor_geom(spec.worldbody)
    spec.worldbody.add_light(name="sun", pos=[0, 0, 4], dir=[0, 0, -1])
    return spec


def has_plane(model: mujoco.MjModel) -> bool:
    """Whether ``model`` has a plane geom (a floor)."""
    return bool(np.any(model.geom_type == int(mujoco.mjtGeom.mjGEOM_PLANE)))


def add_floor(spec: mujoco.MjSpec) -> None:
    """Add the floor plane ``floor`` at z = 0 to the world of ``spec`` (in place)."""
    _add_floor_geom(spec.worldbody)


def _vec(value: ArrayLike, n: int, what: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{what} must be {n} numbers, got {value!r}") from exc
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise InvalidInput(f"{what} must be {n} finite numbers, got {value!r}")
    return v


def add_box(
    spec: mujoco.MjSpec,
    name: str,
    pos: ArrayLike,
    size: ArrayLike,
    *,
    quat: ArrayLike = (1.0, 0.0, 0.0, 0.0),
    rgba: ArrayLike = (0.8, 0.8, 0.75, 1.0),
) -> mujoco.MjsGeom:
    """Add a static box geom to the world of ``spec`` (modified in place).

    Args:
        spec: Environment spec.
        name: Geom name (must be new).
        pos: Centre ``p_WB`` (3,) [m].
        size: Half sizes (3,) [m], all > 0.
        quat: Orientation (w, x, y, z).
        rgba: Colour.

    Returns:
        The new geom.
    """
    p = _vec(pos, 3, "pos")
    s = _vec(size, 3, "size")
    q = _vec(quat, 4, "quat")
    if np.any(s <= 0):
        raise InvalidInput(f"box half sizes must be > 0 [m], got {s}")
    if np.linalg.norm(q) < 1e-9:
        raise InvalidInput(f"quat {q} has zero norm")
    if any(g.name == name for g in spec.geoms):
        raise InvalidInput(f"the environment already has a geom named {name!r}")
    return spec.worldbody.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=p.tolist(),
        size=s.tolist(),
        quat=(q / np.linalg.norm(q)).tolist(),
        rgba=list(_vec(rgba, 4, "rgba")),
    )


def add_wall(
    spec: mujoco.MjSpec,
    point: ArrayLike,
    normal: ArrayLike,
    *,
    name: str = "wall",
    width: float = 2.0,
    height: float = 2.0,
    thickness: float = 0.1,
) -> mujoco.MjsGeom:
    """Add a vertical wall whose face passes through ``point`` facing ``normal``.

    The wall is a box standing on z = 0, ``height`` tall, ``width`` wide centred
    on ``point`` horizontally; its face plane is ``{p : n·(p - point) = 0}`` and
    the box lies behind it (``n·(p - point) <= 0``).

    Args:
        spec: Environment spec (modified in place).
        point: A point of the face (3,) [m].
        normal: Horizontal outward normal of the face (3,) (towards the robot).
        name: Geom name.
        width: Width [m].
        height: Height [m].
        thickness: Thickness [m].
    """
    p = _vec(point, 3, "point")
    n = _vec(normal, 3, "normal")
    if abs(n[2]) > 1e-9 or np.linalg.norm(n[:2]) < 1e-9:
        raise InvalidInput(f"a wall normal must be horizontal and non-zero, got {n}")
    n = n / np.linalg.norm(n)
    for label, v in (("width", width), ("height", height), ("thickness", thickness)):
        if not (math.isfinite(v) and v > 0):
            raise InvalidInput(f"wall {label} must be > 0 [m], got {v}")
    yaw = math.atan2(n[1], n[0])  # box x-axis along the normal
    centre = np.array([p[0], p[1], 0.0]) - 0.5 * thickness * n
    centre[2] = 0.5 * height
    return add_box(
        spec,
        name,
        centre,
        (0.5 * thickness, 0.5 * width, 0.5 * height),
        quat=yaw_quat(yaw),
    )


# ----------------------------------------------------------------------------
# Names for what an MJCF leaves unnamed


def name_unnamed(spec: mujoco.MjSpec) -> None:
    """Name every unnamed body, joint and geom of ``spec`` (in place).

    Menagerie robots ship tens of unnamed geoms (meshes, foot spheres) and often
    an unnamed free joint; contacts, allowed contacts and limbs are named. The
    ``k``-th joint or geom of body ``B`` (counting all of that body's joints, or
    geoms, from 0 in MJCF order) becomes ``B_joint{k}`` / ``B_geom{k}``; an
    unnamed body ``body{i}`` (``i`` its index). A name already taken gets
    ``_`` appended until it is free. Named elements are never renamed, and the
    same spec always gives the same names.
    """
    taken = {b.name for b in spec.bodies}
    for i, body in enumerate(spec.bodies):
        if not body.name:
            body.name = _free_name(f"body{i}", taken)
    for kind, elements in (("joint", spec.joints), ("geom", spec.geoms)):
        taken = {e.name for e in elements}
        count: dict[str, int] = {}
        for element in elements:
            body = element.parent.name
            k = count.get(body, 0)
            count[body] = k + 1
            if not element.name:
                element.name = _free_name(f"{body}_{kind}{k}", taken)


def _free_name(name: str, taken: set[str]) -> str:
    while name in taken:
        name += "_"
    taken.add(name)
    return name


# ----------------------------------------------------------------------------
# Attaching an environment into a robot's spec
# ----------------------------------------------------------------------------


def as_spec(model: EnvironmentLike) -> mujoco.MjSpec:
    """A private copy of ``model`` (a spec is copied, never modified)."""
    if isinstance(model, mujoco.MjSpec):
        return model.copy()
    return load_spec(model)


def _defaults(spec: mujoco.MjSpec) -> list[mujoco.MjsDefault]:
    """Every default class of ``spec`` that its elements use, the main one included."""
    out = [spec.default]
    names = {spec.default.name}
    # MjSpec has no list of defaults; classes are named by the elements using them.
    for element in [*spec.geoms, *spec.joints, *spec.sites]:
        default = element.classname
        if default is not None and default.name not in names:
            names.add(default.name)
            out.append(default)
    return out


def _rename_clashing_assets(host: mujoco.MjSpec, guest: mujoco.MjSpec) -> None:
    """Rename the guest's assets whose names the host already uses.

    The room and dm_control's humanoids both define a texture and a material
    ``grid``: the guest's copies become ``<guest model name>_grid`` and every
    reference in the guest (materials' textures, geoms', sites', tendons' and
    defaults' materials, meshes, height fields) follows.
    """
    prefix = f"{guest.modelname or 'environment'}_"
    renamed: dict[str, dict[str, str]] = {}
    for kind, ours, theirs in (
        ("texture", guest.textures, host.textures),
        ("material", guest.materials, host.materials),
        ("mesh", guest.meshes, host.meshes),
        ("hfield", guest.hfields, host.hfields),
    ):
        taken = {a.name for a in theirs}
        renamed[kind] = {}
        for asset in ours:
            if asset.name and asset.name in taken:
                renamed[kind][asset.name] = prefix + asset.name
                asset.name = prefix + asset.name
    if not any(renamed.values()):
        return
    tex, mat = renamed["texture"], renamed["material"]
    mesh, hfield = renamed["mesh"], renamed["hfield"]
    for material in guest.materials:
        material.textures = [tex.get(t, t) for t in material.textures]
    for geom in guest.geoms:
        geom.material = mat.get(geom.material, geom.material)
        geom.meshname = mesh.get(geom.meshname, geom.meshname)
        geom.hfieldname = hfield.get(geom.hfieldname, geom.hfieldname)
    for site in guest.sites:
        site.material = mat.get(site.material, site.material)
    for tendon in guest.tendons:
        tendon.material = mat.get(tendon.material, tendon.material)
    for default in _defaults(guest):
        default.geom.material = mat.get(default.geom.material, default.geom.material)
        default.geom.meshname = mesh.get(default.geom.meshname, default.geom.meshname)
        default.site.material = mat.get(default.site.material, default.site.material)


def attach_environment(host: mujoco.MjSpec, environment: EnvironmentLike) -> mujoco.MjSpec:
    """The host spec (a robot's world) with ``environment`` attached into it.

    The environment's world (its bodies, world geoms, sites, lights) is attached
    at the world origin with an empty name prefix, after everything the host
    has, so the host's joints keep their ``qpos`` addresses and names are kept.
    The environment brings its own ground: the host's world planes (e.g.
    dm_control's humanoids ship a floor) are left out. Environment assets whose
    names the host uses are renamed ``<environment model name>_<name>``. The
    host's ``<option>`` and ``<compiler>`` win. Keyframes of the host get the
    environment's ``qpos0`` for its joints. Unnamed elements get names
    (:func:`name_unnamed`).

    Args:
        host: The robot's spec (not modified).
        environment: Model name, MJCF path or spec (copied).

    Returns:
        A new spec (it forgets the attachment: compiling it does not warn again).

    Raises:
        InvalidInput: The composition does not compile (e.g. element names the
            host already uses).
    """
    out = host.copy()
    env = as_spec(environment)
    for geom in list(out.worldbody.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_PLANE:
            out.delete(geom)
    _rename_clashing_assets(out, env)
    # The environment's main default class would otherwise come out unnamed, and
    # the composed spec could not be written back to XML.
    env.default.name = f"{env.modelname or 'environment'}_main"
    with mujoco_warnings(expected=ATTACH_WARNINGS):
        try:
            out.attach(env, frame=out.worldbody.add_frame(), prefix="")
            out = out.copy()
            name_unnamed(out)
            out.compile()
        except ValueError as err:
            raise InvalidInput(
                f"cannot attach environment {env.modelname!r} into {host.modelname!r}: {err}"
            ) from err
    return out


# ----------------------------------------------------------------------------
# Placing the robot
# ----------------------------------------------------------------------------


def placement(
    at: str | Sequence[float], environment: mujoco.MjModel | None
) -> tuple[np.ndarray, float]:
    """``(p_WR (3,) [m], ψ [rad])`` of a placement.

    Args:
        at: A site of the environment (its position and its heading ``ψ =
            atan2(R_10, R_00)``), or ``(x, y, ψ)``, or ``(x, y, z, ψ)`` [m, rad].
        environment: The compiled environment (for a site name).

    Raises:
        UnknownName: No such site.
        InvalidInput: Bad numbers, or a site name without an environment.
    """
    if isinstance(at, str):
        if environment is None:
            raise InvalidInput(
                f"at={at!r} names a site of an environment, but no environment is given; "
                "pass environment=... or at=(x, y, yaw)"
            )
        k = mujoco.mj_name2id(environment, mujoco.mjtObj.mjOBJ_SITE, at)
        if k < 0:
            sites = [environment.site(i).name for i in range(environment.nsite)]
            raise UnknownName("site of the environment", at, sites)
        data = mujoco.MjData(environment)
        mujoco.mj_kinematics(environment, data)
        return data.site_xpos[k].copy(), yaw_of(data.site_xmat[k].reshape(3, 3))
    try:
        v = np.asarray(at, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(
            f"at must be a site name, (x, y, yaw) or (x, y, z, yaw): {at!r}"
        ) from exc
    if v.shape not in ((3,), (4,)) or not np.all(np.isfinite(v)) or np.any(np.abs(v) > Q_LIMIT):
        raise InvalidInput(
            f"at must be a site name, or 3 or 4 finite numbers (x, y[, z], yaw) [m, rad] "
            f"within ±{Q_LIMIT:g}, got {at!r}"
        )
    p = np.array([v[0], v[1], v[2] if len(v) == 4 else 0.0])
    return p, float(v[-1])


def place_root(
    spec: mujoco.MjSpec,
    model: mujoco.MjModel,
    root: int,
    p_WR: ArrayLike,
    yaw: float,
) -> None:
    """Move the top-level body ``root`` of ``spec`` by ``(p_WR, ψ)`` (in place).

    ``model`` is ``spec`` compiled (it gives the body's pose and its free joint's
    ``qpos`` address). The body's ``pos``/``quat`` become ``p_WR + R_z(ψ) p`` and
    ``q_z(ψ) ⊗ q``; with a free joint its pose in every keyframe moves the same way.
    """
    p_WR = np.asarray(p_WR, dtype=float)
    R, q_z = rot_z(yaw), yaw_quat(yaw)
    body = spec.body(model.body(root).name)
    body.pos = (p_WR + R @ model.body_pos[root]).tolist()
    body.quat = quat_mul(q_z, model.body_quat[root]).tolist()
    body.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
    j = int(model.body_jntadr[root])
    if j < 0 or model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE:
        return
    a = int(model.jnt_qposadr[j])
    for k in range(model.nkey):
        key = spec.key(model.key(k).name)
        if len(key.qpos) == 0:
            continue  # qpos0: follows the body
        qpos = np.array(key.qpos, dtype=float)
        qpos[a : a + 3] = p_WR + R @ qpos[a : a + 3]
        qpos[a + 3 : a + 7] = quat_mul(q_z, qpos[a + 3 : a + 7])
        key.qpos = qpos.tolist()
