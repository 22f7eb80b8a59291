"""Models shipped with pik_mj and dm_control's humanoids: names to MJCF files.

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

Any other argument is taken as a path to an MJCF file. A robot placed in an
environment is composed by :meth:`pik_mj.Robot.from_model`
(:mod:`pik_mj.robot.world`).
"""

from __future__ import annotations

import difflib
import functools
import importlib.resources
import os
from pathlib import Path

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName

MODELS_DIR = Path(str(importlib.resources.files("pik_mj.mjcf"))).resolve()
"""Where the shipped MJCF files are (the source tree's ``models/``, installed as
``pik_mj.mjcf``)."""

_SHIPPED = {
    "three_dof_arm": "three_dof_arm.xml",
    "sample_humanoid": "sample_humanoid.xml",
    "room": "room.xml",
}
_DM_CONTROL = {
    "dm_humanoid": "humanoid.xml",
    "dm_humanoid_cmu": "humanoid_CMU.xml",
}


_CATEGORIES = {
    "three_dof_arm": "arm",
    "sample_humanoid": "humanoid",
    "room": "scene",
    "dm_humanoid": "humanoid",
    "dm_humanoid_cmu": "humanoid",
}
"""The kind of each named model, in MuJoCo Menagerie's words (``room`` is a world)."""


def available_models(category: str | None = None) -> list[str]:
    """Names that :func:`model_path` resolves without a file path.

    Args:
        category: Only the models of this kind, in MuJoCo Menagerie's words:
            ``"humanoid"``, ``"arm"`` or ``"scene"`` (a world without a robot).
            None: every name.
    """
    names = [*_SHIPPED, *_DM_CONTROL]
    return [x for x in names if category is None or _CATEGORIES[x] == category]


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


def looks_like_path(name: str) -> bool:
    """Whether a model argument names a file (ends in ``.xml`` or holds a path separator)
    rather than a model name."""
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
    if isinstance(name_or_path, os.PathLike) or looks_like_path(str(name_or_path)):
        path = Path(name_or_path).expanduser().resolve()
        if path.is_dir():
            raise InvalidInput(
                f"model file {str(path)!r} is a directory. Give an MJCF file "
                f"or one of the model names {available_models()}"
            )
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
        f"{err.args[0]}, or any MuJoCo Menagerie robot (pik_mj.robot.loading.menagerie_models()), "
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
        raise InvalidInput(
            f"cannot parse MJCF file {str(path)!r}: {' '.join(str(err).split())}"
        ) from err


def load_model(name_or_path: str | os.PathLike[str]) -> mujoco.MjModel:
    """Load and compile a model (see :func:`model_path` for the accepted names).

    Raises:
        InvalidInput: The file does not parse or compile, or a number of the
            compiled model is NaN or infinite (:func:`check_finite`).
    """
    path = model_path(name_or_path)
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as err:
        raise InvalidInput(
            f"cannot load MJCF file {str(path)!r}: {' '.join(str(err).split())}"
        ) from err
    check_finite(model, f"MJCF file {str(path)!r}")
    return model


# The object type of a compiled array's rows, by the array's name prefix.
_ROW_OBJECTS = {
    "body": ("body", "nbody"),
    "jnt": ("joint", "njnt"),
    "geom": ("geom", "ngeom"),
    "site": ("site", "nsite"),
    "cam": ("camera", "ncam"),
    "light": ("light", "nlight"),
    "mesh": ("mesh", "nmesh"),
    "mat": ("material", "nmat"),
    "pair": ("pair", "npair"),
    "eq": ("equality", "neq"),
    "tendon": ("tendon", "ntendon"),
    "actuator": ("actuator", "nu"),
    "sensor": ("sensor", "nsensor"),
    "key": ("key", "nkey"),
}


@functools.cache
def _float_arrays() -> tuple[str, ...]:
    """Names of the float arrays of a compiled model (the same for every model)."""
    probe = mujoco.MjModel.from_xml_string("<mujoco/>")
    return tuple(
        a
        for a in dir(probe)
        if not a.startswith("_")
        and isinstance(getattr(probe, a), np.ndarray)
        and getattr(probe, a).dtype.kind == "f"
    )


def check_finite(model: mujoco.MjModel, what: str) -> None:
    """Raise unless every number of the compiled ``model`` is finite.

    MuJoCo compiles ``pos="nan 0 0"`` (it only warns); the NaN would surface
    later, far from its cause (a servo gain, a solve). The error names the
    element (``body 'b'``, ``joint 'j'``, ...) and its compiled field, the one
    an MJCF attribute sets first (``body_pos`` before the derived
    ``body_invweight0``).

    Raises:
        InvalidInput: A NaN or infinite value; ``what`` names the model.
    """
    bad = []
    for attr in _float_arrays():
        values = getattr(model, attr)
        if values.size and not np.isfinite(values).all():
            bad.append((attr.removeprefix(attr.partition("_")[0] + "_") not in _GIVEN, attr))
    if not bad:
        return
    attr = min(bad)[1]
    values = getattr(model, attr)
    row = int(np.argwhere(~np.isfinite(values))[0][0])
    kind, count = _ROW_OBJECTS.get(attr.partition("_")[0], (None, ""))
    where = f"{attr}[{row}]"
    if kind is not None and values.shape[0] == getattr(model, count):
        name = mujoco.mj_id2name(model, getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}"), row)
        label = repr(name) if name else f"#{row}"
        where = f"{kind} {label}: {attr} = {np.asarray(values[row]).tolist()}"
    raise InvalidInput(f"{what}: a number is not finite at {where}; give the element finite values")


# Compiled fields an MJCF attribute sets directly (named first in check_finite's error).
_GIVEN = frozenset(
    "pos quat size range axis mass inertia ipos iquat friction damping armature stiffness "
    "frictionloss margin gap gear ctrlrange forcerange fovy rgba qpos qvel ctrl".split()
)
