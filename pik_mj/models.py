"""Models shipped with pik_mj and dm_control's humanoids: names to MJCF files.

Names accepted by :func:`model_path`, :func:`load_spec` and :func:`load_model`:

* ``three_dof_arm``   — the 3-DoF robot of the irteus manual (``models/``).
* ``sample_humanoid`` — a 30-joint humanoid with a free base (``models/``).
* ``room``            — an environment: floor, counter, kettle, wall (``models/``).
* ``dm_humanoid``     — dm_control ``suite/humanoid.xml`` (27 DoF), read from the
  installed dm_control package.
* ``dm_humanoid_cmu`` — dm_control ``suite/humanoid_CMU.xml`` (62 DoF), idem.

Any other argument is taken as a path to an MJCF file. A robot placed in an
environment is composed by :meth:`pik_mj.Robot.from_model`
(:mod:`pik_mj.sim.environment`).
"""

from __future__ import annotations

import os
from pathlib import Path

import mujoco

from pik_mj.exceptions import InvalidInput, UnknownName


def _models_dir() -> Path:
    import pik_mj.mjcf  # the top-level models/, installed as package data

    return Path(pik_mj.mjcf.__file__).resolve().parent


MODELS_DIR = _models_dir()
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


def available_models() -> list[str]:
    """Names that :func:`model_path` resolves without a file path."""
    return [*_SHIPPED, *_DM_CONTROL]


def _dm_control_suite_dir() -> Path:
    import dm_control  # Imported lazily: only the dm_humanoid models need it.

    return Path(os.path.dirname(dm_control.__file__)) / "suite"


def _looks_like_path(name: str) -> bool:
    return name.endswith(".xml") or os.sep in name or "/" in name


def model_path(name_or_path: str | os.PathLike[str]) -> Path:
    """Resolve a model name or an MJCF path to an existing file.

    Args:
        name_or_path: One of :func:`available_models` or a path to an MJCF file.

    Returns:
        Absolute path of the MJCF file.

    Raises:
        UnknownName: ``name_or_path`` is neither a known name nor path-like.
        InvalidInput: ``name_or_path`` is a path that does not exist.
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
    raise UnknownName("model", str(name_or_path), available_models())


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
