"""Models shipped with pik_mj, dm_control's humanoids, and scene composition.

Names accepted by :func:`model_path`, :func:`load_spec` and :func:`load_model`:

* ``three_dof_arm``   — the 3-DoF robot of the irteus manual (``models/``).
* ``sample_humanoid`` — a 30-joint humanoid with a free base (``models/``).
* ``room``            — an environment: floor, counter, kettle, wall (``models/``).
* ``dm_humanoid``     — dm_control ``suite/humanoid.xml`` (27 DoF), read from the
  installed dm_control package.
* ``dm_humanoid_cmu`` — dm_control ``suite/humanoid_CMU.xml`` (62 DoF), idem.
* a MuJoCo Menagerie robot (``unitree_g1``, ``booster_t1``, ...; see
  :func:`menagerie_models`), through the ``mujoco-menagerie`` package: its default
  robot model (the robot alone, not its scene), or an entry point named after a
  colon (``unitree_g1:g1_with_hands``). The package reads the robot from
  ``MENAGERIE_ROOT`` (a Menagerie checkout) when that is set, else from its own
  cache, downloading it there on first use.

Any other argument is taken as a path to an MJCF file.
"""

from __future__ import annotations

import difflib
import math
import os
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, PikError, UnknownName

MODELS_DIR = Path(__file__).resolve().parents[1] / "models"

_SHIPPED = {
    "three_dof_arm": "three_dof_arm.xml",
    "sample_humanoid": "sample_humanoid.xml",
    "room": "room.xml",
}
_DM_CONTROL = {
    "dm_humanoid": "humanoid.xml",
    "dm_humanoid_cmu": "humanoid_CMU.xml",
}

# Warnings MuJoCo prints while attaching a robot with an empty name prefix. Both
# are expected here: names are kept on purpose, and the environment's <option>
# wins over the robot's ("Attach conflict ... policy is 'warning'").
_EXPECTED_ATTACH_WARNINGS = ("empty prefix", "Attach conflict")


def available_models() -> list[str]:
    """Names that :func:`model_path` resolves without a file path."""
    return [*_SHIPPED, *_DM_CONTROL]


def menagerie_models(category: str | None = None) -> list[str]:
    """Names of the MuJoCo Menagerie robots (no I/O), e.g. ``category="humanoid"``."""
    import mujoco_menagerie  # Imported lazily: only Menagerie names need it.

    return [r.name for r in mujoco_menagerie.robots(category)]


def menagerie_available(name: str) -> bool:
    """Whether the Menagerie robot ``name`` (``robot[:entry]``) is on this machine.

    True when it is under ``MENAGERIE_ROOT`` or in the package's cache, i.e. when
    :func:`model_path` needs no download.
    """
    import mujoco_menagerie

    robot = name.partition(":")[0]
    if robot not in mujoco_menagerie.names():
        return False
    cache = mujoco_menagerie.Cache()
    if cache.root is not None:
        return (cache.root / robot).is_dir()
    return cache.is_cached(mujoco_menagerie.get(robot))


def _menagerie_path(name: str) -> Path | None:
    """The MJCF file of the Menagerie robot ``robot[:entry]``, or None for other names.

    Raises:
        UnknownName: The robot has no such entry point (lists its entry points).
        InvalidInput: The robot is neither under ``MENAGERIE_ROOT`` nor cached,
            and downloading it failed (e.g. no network).
    """
    import mujoco_menagerie

    robot_name, _, entry = name.partition(":")
    if robot_name not in mujoco_menagerie.names():
        return None
    robot = mujoco_menagerie.get(robot_name)
    entry = entry or robot.default_model
    if entry not in robot.entry_names:
        raise UnknownName(f"{robot_name} entry point", entry, robot.entry_names)
    cache = mujoco_menagerie.Cache()
    try:
        return Path(robot.xml(entry, cache)).resolve()
    except mujoco_menagerie.MenagerieError as err:
        where = (
            f"MENAGERIE_ROOT={str(cache.root)!r} has no folder {robot_name!r}"
            if cache.root is not None
            else f"it is not in the mujoco-menagerie cache {str(cache.dir)!r} and "
            "downloading it failed"
        )
        raise InvalidInput(
            f"MuJoCo Menagerie robot {robot_name!r} is not available: {where} ({err}). "
            "Set MENAGERIE_ROOT to a folder holding Menagerie robot folders, or load it "
            f"once where there is network (python -m mujoco_menagerie prefetch {robot_name}), "
            "or give an MJCF path"
        ) from err


def _dm_control_suite_dir() -> Path:
    import dm_control  # Imported lazily: only the dm_humanoid models need it.

    return Path(os.path.dirname(dm_control.__file__)) / "suite"


def _looks_like_path(name: str) -> bool:
    return name.endswith(".xml") or os.sep in name or "/" in name


def model_path(name_or_path: str | os.PathLike[str]) -> Path:
    """Resolve a model name or an MJCF path to an existing file.

    Args:
        name_or_path: One of :func:`available_models`, a Menagerie robot name
            (``robot`` or ``robot:entry``, see :func:`menagerie_models`) or a path
            to an MJCF file.

    Returns:
        Absolute path of the MJCF file.

    Raises:
        UnknownName: ``name_or_path`` is neither a known name nor path-like, or
            names a Menagerie entry point the robot does not have.
        InvalidInput: ``name_or_path`` is a path that does not exist, or a
            Menagerie robot that is not on this machine and cannot be downloaded.
    """
    if isinstance(name_or_path, str) and name_or_path in _SHIPPED:
        return MODELS_DIR / _SHIPPED[name_or_path]
    if isinstance(name_or_path, str) and name_or_path in _DM_CONTROL:
        return _dm_control_suite_dir() / _DM_CONTROL[name_or_path]
    if isinstance(name_or_path, os.PathLike) or _looks_like_path(str(name_or_path)):
        path = Path(name_or_path).expanduser().resolve()
        if not path.is_file():
            raise InvalidInput(
                f"model file {str(path)!r} does not exist. Give an existing MJCF path "
                f"or one of the model names {available_models()}"
            )
        return path
    path = _menagerie_path(str(name_or_path))
    if path is not None:
        return path
    near = difflib.get_close_matches(str(name_or_path), menagerie_models(), n=3)
    err = UnknownName("model", str(name_or_path), [*available_models(), *near])
    err.args = (
        f"{err.args[0]}, or any MuJoCo Menagerie robot (pik_mj.models.menagerie_models()), "
        "or an MJCF path",
    )
    raise err


def load_spec(name_or_path: str | os.PathLike[str]) -> mujoco.MjSpec:
    """Parse a model into an editable :class:`mujoco.MjSpec`.

    Includes (e.g. dm_control's ``./common/*.xml``) are resolved relative to the
    file, so dm_control's models load from the installed package unchanged.
    """
    path = model_path(name_or_path)
    try:
        return mujoco.MjSpec.from_file(str(path))
    except ValueError as err:
        raise InvalidInput(f"cannot parse MJCF file {str(path)!r}: {err}") from err


def load_model(name_or_path: str | os.PathLike[str]) -> mujoco.MjModel:
    """Load and compile a model (see :func:`model_path` for the accepted names)."""
    path = model_path(name_or_path)
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as err:
        raise InvalidInput(f"cannot load MJCF file {str(path)!r}: {err}") from err


@contextmanager
def _mujoco_warnings_as_python() -> Iterator[None]:
    """Route MuJoCo's C warnings to Python, dropping the expected attach ones.

    Without a handler MuJoCo prints them and appends them to ``MUJOCO_LOG.TXT``
    in the working directory.
    """
    previous = mujoco.get_mju_user_warning()

    def handler(message: str) -> None:
        if not any(s in message for s in _EXPECTED_ATTACH_WARNINGS):
            warnings.warn(f"MuJoCo: {message}", RuntimeWarning, stacklevel=2)

    mujoco.set_mju_user_warning(handler)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


def _as_spec(model: str | os.PathLike[str] | mujoco.MjSpec) -> mujoco.MjSpec:
    """A private copy of ``model`` (a spec is copied, never modified)."""
    if isinstance(model, mujoco.MjSpec):
        return model.copy()
    return load_spec(model)


def _rename_clashing_assets(scene: mujoco.MjSpec, robot: mujoco.MjSpec) -> None:
    """Rename the robot's assets whose names the scene already uses.

    dm_control's humanoids define a texture and a material ``grid`` like the room;
    the robot's copies become ``<robot model name>_grid`` and every reference
    (materials' textures, geoms', sites' and defaults' materials, meshes, height
    fields) follows.
    """
    prefix = f"{robot.modelname or 'robot'}_"
    renamed: dict[str, dict[str, str]] = {}
    for kind, ours, theirs in (
        ("texture", robot.textures, scene.textures),
        ("material", robot.materials, scene.materials),
        ("mesh", robot.meshes, scene.meshes),
        ("hfield", robot.hfields, scene.hfields),
    ):
        taken = {a.name for a in theirs}
        renamed[kind] = {}
        for asset in ours:
            if asset.name and asset.name in taken:
                renamed[kind][asset.name] = prefix + asset.name
                asset.name = prefix + asset.name
    tex, mat = renamed["texture"], renamed["material"]
    mesh, hfield = renamed["mesh"], renamed["hfield"]
    if not any(renamed.values()):
        return
    for material in robot.materials:
        material.textures = [tex.get(t, t) for t in material.textures]
    for geom in robot.geoms:
        geom.material = mat.get(geom.material, geom.material)
        geom.meshname = mesh.get(geom.meshname, geom.meshname)
        geom.hfieldname = hfield.get(geom.hfieldname, geom.hfieldname)
    for site in robot.sites:
        site.material = mat.get(site.material, site.material)
    for tendon in robot.tendons:
        tendon.material = mat.get(tendon.material, tendon.material)
    for default in _defaults(robot):
        default.geom.material = mat.get(default.geom.material, default.geom.material)
        default.geom.meshname = mesh.get(default.geom.meshname, default.geom.meshname)
        default.site.material = mat.get(default.site.material, default.site.material)


def _defaults(spec: mujoco.MjSpec) -> list[mujoco.MjsDefault]:
    """Every default class of ``spec``, the main one included."""
    out = [spec.default]
    names = {spec.default.name}
    # MjSpec has no list of defaults; classes are named by the classname of the
    # elements that use them.
    for element in [*spec.geoms, *spec.joints, *spec.sites]:
        default = element.classname
        if default is not None and default.name not in names:
            names.add(default.name)
            out.append(default)
    return out


def _yaw_quat(yaw: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation by ``yaw`` [rad] about world z."""
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def _plain_floor_spec(robot: mujoco.MjSpec) -> mujoco.MjSpec:
    """An environment with only a floor plane ``floor``; the robot's <option>."""
    scene = mujoco.MjSpec()
    scene.modelname = "floor"
    scene.compiler.degree = False
    for field in dir(robot.option):
        if not field.startswith("_"):
            setattr(scene.option, field, getattr(robot.option, field))
    scene.worldbody.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[20.0, 20.0, 0.1],
        rgba=[0.5, 0.5, 0.5, 1.0],
        contype=1,
        conaffinity=1,
    )
    scene.worldbody.add_light(name="sun", pos=[0, 0, 4], dir=[0, 0, -1])
    return scene


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) or "" for i in range(count)]


def compose_scene(
    robot: str | os.PathLike[str] | mujoco.MjSpec,
    environment: str | os.PathLike[str] | mujoco.MjSpec | None = "room",
    *,
    robot_pos: Sequence[float] = (0.0, 0.0, 0.0),
    robot_yaw: float = 0.0,
) -> mujoco.MjSpec:
    """One spec holding the environment's world with the robot attached to it.

    The robot's single top-level body (with its free joint, if any) is attached
    to a frame of the world at ``robot_pos`` rotated by ``robot_yaw`` about z:
    a robot point ``p_RP`` lands at

    .. math::

        p_{WP} = p_{WR} + R_z(\\psi)\\, p_{RP}

    with ``p_WR = robot_pos`` [m] and ``ψ = robot_yaw`` [rad]. Names are kept
    unchanged (empty attach prefix); only the robot's textures/materials/meshes
    whose names the environment already uses are renamed to
    ``<robot model name>_<name>``. The environment's <option>, <visual>,
    <statistic> and <compiler> settings win; with ``environment=None`` the scene
    is a plain floor plane named ``floor`` with the robot's <option>. The robot's
    actuators, sensors, contact exclusions and keyframes come along; the
    keyframes' free-joint poses are moved by the same transform, and their
    environment entries hold the environment's ``qpos0``.

    Args:
        robot: Model name, MJCF path or spec of the robot (a spec is copied).
        environment: Model name, MJCF path or spec of the environment, or None.
        robot_pos: Translation of the robot's model frame in the world [m].
        robot_yaw: Rotation of the robot's model frame about world z [rad].

    Returns:
        The composed spec (compile it with ``spec.compile()``).

    Raises:
        InvalidInput: Bad pose, a robot without exactly one top-level body, or a
            composition that does not compile (e.g. clashing element names).
    """
    p_WR = np.asarray(robot_pos, dtype=float)
    if p_WR.shape != (3,) or not np.all(np.isfinite(p_WR)):
        raise InvalidInput(f"robot_pos must be 3 finite numbers [m], got {robot_pos!r}")
    if not math.isfinite(float(robot_yaw)):
        raise InvalidInput(f"robot_yaw must be a finite angle [rad], got {robot_yaw!r}")
    quat_WR = _yaw_quat(float(robot_yaw))

    robot_spec = _as_spec(robot)
    robot_model = robot_spec.compile()
    top = list(robot_spec.worldbody.bodies)
    if len(top) != 1:
        raise InvalidInput(
            f"the robot must have exactly one top-level body, "
            f"{robot_spec.modelname!r} has {[b.name for b in top]}"
        )
    scene = _plain_floor_spec(robot_spec) if environment is None else _as_spec(environment)

    # The robot's main default class would otherwise come out unnamed, and the
    # scene could not be written back to XML.
    robot_spec.default.name = f"{robot_spec.modelname or 'robot'}_main"
    _rename_clashing_assets(scene, robot_spec)
    frame = scene.worldbody.add_frame(pos=p_WR.tolist(), quat=quat_WR.tolist())
    with _mujoco_warnings_as_python():
        try:
            frame.attach_body(top[0], "", "")
        except ValueError as err:
            raise InvalidInput(f"cannot attach the robot to the scene: {err}") from err
        # A copy forgets the attachment, so compiling it later does not repeat
        # the empty-prefix warning.
        scene = scene.copy()
    try:
        model = scene.compile()
    except ValueError as err:
        raise InvalidInput(f"the composed scene does not compile: {err}") from err

    _move_keyframe_roots(scene, model, robot_model, p_WR, quat_WR)
    model = scene.compile()
    _check_names_kept(model, robot_model)
    return scene


def _move_keyframe_roots(
    scene: mujoco.MjSpec,
    model: mujoco.MjModel,
    robot_model: mujoco.MjModel,
    p_WR: np.ndarray,
    quat_WR: np.ndarray,
) -> None:
    """Apply the attach transform to the robot's free joints in its keyframes.

    MuJoCo 3.17 copies the robot's keyframes verbatim, so a keyframe pose
    ``(p, q)`` of a free joint becomes ``(p_WR + R_WR p, q_WR ⊗ q)``. A keyframe
    whose pose MuJoCo already moved is left alone.
    """
    free = [
        j for j in range(robot_model.njnt) if robot_model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    ]
    R_WR = np.empty(9)
    mujoco.mju_quat2Mat(R_WR, quat_WR)
    R_WR = R_WR.reshape(3, 3)
    for k in range(robot_model.nkey):
        key_name = mujoco.mj_id2name(robot_model, mujoco.mjtObj.mjOBJ_KEY, k)
        k_scene = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, key_name or "")
        if k_scene < 0:
            continue
        qpos = model.key_qpos[k_scene].copy()
        for j in free:
            name = mujoco.mj_id2name(robot_model, mujoco.mjtObj.mjOBJ_JOINT, j)
            a_robot = robot_model.jnt_qposadr[j]
            a_scene = model.jnt_qposadr[model.joint(name).id]
            original = robot_model.key_qpos[k, a_robot : a_robot + 7]
            if not np.allclose(qpos[a_scene : a_scene + 7], original, atol=1e-12):
                continue
            quat = np.empty(4)
            mujoco.mju_mulQuat(quat, quat_WR, original[3:])
            qpos[a_scene : a_scene + 3] = p_WR + R_WR @ original[:3]
            qpos[a_scene + 3 : a_scene + 7] = quat
        key = scene.key(key_name)
        key.qpos = qpos.tolist()
        key.qvel = model.key_qvel[k_scene].tolist()
        key.act = model.key_act[k_scene].tolist()
        key.ctrl = model.key_ctrl[k_scene].tolist()
        key.mpos = model.key_mpos[k_scene].tolist()
        key.mquat = model.key_mquat[k_scene].tolist()


def _check_names_kept(model: mujoco.MjModel, robot_model: mujoco.MjModel) -> None:
    """Every robot joint, site and body name exists in the composed model."""
    for obj, attr in (
        (mujoco.mjtObj.mjOBJ_JOINT, "njnt"),
        (mujoco.mjtObj.mjOBJ_SITE, "nsite"),
        (mujoco.mjtObj.mjOBJ_BODY, "nbody"),
    ):
        kept = set(_names(model, obj, getattr(model, attr)))
        robot_names = _names(robot_model, obj, getattr(robot_model, attr))
        missing = [n for n in robot_names if n and n not in kept]
        if missing:
            raise PikError(f"composed scene lost robot {obj.name} names {missing}")
