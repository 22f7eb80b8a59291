"""The steps of :meth:`pik_mj.robot.Robot.from_model` that work on specs: the
robot's own spec from its arguments, the environment's, and the world both make
once the robot is placed and put down.

The robot's spec is the host of its world: the robot's top-level body is placed
(:func:`pik_mj.robot.world.place_root`) and the environment attached into it
(:func:`pik_mj.robot.world.attach_environment`), so the robot's ``qpos`` is a
prefix of the world's and the robot and the environment's objects share one
world frame.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.robot.description import RobotDescription, load_description
from pik_mj.robot.loading import check_finite
from pik_mj.robot.source import ModelLike, RobotSource, source_description, source_name
from pik_mj.robot.world import as_spec, attach_environment, name_unnamed, place_root


def as_description(
    description: str | os.PathLike[str] | RobotDescription | None,
) -> RobotDescription | None:
    """The robot description of ``description`` (a ``.toml``/``.json`` file, read),
    or the object itself, or None.

    Raises:
        InvalidInput: Neither a path nor a :class:`RobotDescription`, or a bad file.
    """
    if description is None or isinstance(description, RobotDescription):
        return description
    if isinstance(description, (str, os.PathLike)):
        return load_description(description)
    raise InvalidInput(
        "description must be a robot description file (.toml or .json) or a "
        f"RobotDescription, got {type(description).__name__}"
    )


def robot_spec(model: ModelLike | None, environment: ModelLike | None) -> mujoco.MjSpec:
    """A private copy of the robot's spec, its unnamed elements named
    (:func:`pik_mj.robot.world.name_unnamed`), once both arguments are checked.

    Raises:
        InvalidInput: ``model`` or ``environment`` is not a name, path or spec
            (``environment`` may be None).
        UnknownName: Unknown model name.
    """
    for what, value in (("model", model), ("environment", environment)):
        if not isinstance(value, (str, os.PathLike, mujoco.MjSpec)) and (
            value is not None or what == "model"
        ):
            raise InvalidInput(
                f"{what} must be a model name, an MJCF path or a mujoco.MjSpec, got {value!r}"
                + (" (or a description whose 'model' names it)" if what == "model" else "")
            )
    spec = as_spec(model)
    name_unnamed(spec)
    return spec


def compile_spec(spec: mujoco.MjSpec, what: str) -> mujoco.MjModel:
    """``spec`` compiled.

    Raises:
        InvalidInput: It does not compile, or compiles with a NaN or infinite
            number (:func:`pik_mj.robot.loading.check_finite`); ``what`` names it.
    """
    try:
        model = spec.compile()
    except ValueError as err:
        raise InvalidInput(f"{what} does not compile: {err}") from err
    check_finite(model, what)
    return model


def environment_of(
    environment: ModelLike | None,
) -> tuple[mujoco.MjSpec | None, mujoco.MjModel | None]:
    """The environment's private spec and its compiled copy, or ``(None, None)``.

    Raises:
        InvalidInput: The environment does not compile.
    """
    if environment is None:
        return None, None
    spec = as_spec(environment)
    return spec, compile_spec(spec.copy(), f"environment {spec.modelname!r}")


def world_of(
    spec: mujoco.MjSpec,
    alone: mujoco.MjModel,
    root_body_id: int,
    p_WR: np.ndarray,
    yaw: float,
    *,
    placed: bool,
    dz: float,
    environment: mujoco.MjSpec | None,
) -> tuple[mujoco.MjModel, mujoco.MjSpec]:
    """The robot's world: ``spec`` (compiled: ``alone``) with its top-level body moved
    by ``(p_WR + (0, 0, dz), yaw)`` when ``placed`` or ``dz != 0``, and the
    ``environment`` attached into it; ``(alone, spec)`` when there is nothing to do.

    Args:
        spec: The robot's spec (edited in place when placed).
        alone: ``spec`` compiled.
        root_body_id: The robot's top-level body.
        p_WR: Where the robot's model frame goes (3,) [m].
        yaw: Its heading [rad].
        placed: Whether a placement was asked for.
        dz: Height change [m] putting a floating robot down onto the floor.
        environment: The environment's spec, or None.

    Raises:
        InvalidInput: The world does not compile.
    """
    if not (placed or dz != 0.0 or environment is not None):
        return alone, spec
    if placed or dz != 0.0:
        place_root(spec, alone, root_body_id, p_WR + np.array([0.0, 0.0, dz]), yaw)
    if environment is not None:
        spec = attach_environment(spec, environment)
    return compile_spec(spec, "the robot's world"), spec


def robot_source(
    model: ModelLike,
    environment: ModelLike | None,
    at: str | Sequence[float] | None,
    keyframe: str | int | None,
    root_body: str | None,
    description: str | os.PathLike[str] | RobotDescription | None,
) -> RobotSource:
    """The :class:`RobotSource` of :meth:`~pik_mj.robot.Robot.from_model`'s arguments
    (paths made absolute, a placement as a tuple of floats)."""
    return RobotSource(
        source_name(model),
        None if environment is None else source_name(environment),
        at if at is None or isinstance(at, str) else tuple(float(x) for x in at),
        keyframe,
        root_body,
        source_description(description),
    )
