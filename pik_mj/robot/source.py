"""What builds a robot's world, as data: :class:`RobotSource`, the arguments of
:meth:`pik_mj.robot.Robot.from_model` (model, environment, placement, keyframe,
root body, description), written to and read from JSON so that a run's robot
can be built again (``pik-mj validate``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import mujoco

from pik_mj.exceptions import InvalidInput
from pik_mj.robot.description import RobotDescription
from pik_mj.robot.loading import model_path

__all__ = ["ModelLike", "RobotSource", "source_description", "source_name"]

ModelLike = str | os.PathLike[str] | mujoco.MjSpec


@dataclass(frozen=True)
class RobotSource:
    """What builds a robot's world: :meth:`Robot.from_model`'s arguments.

    Attributes:
        model: Model name (``"sample_humanoid"``), absolute MJCF path, or an
            :class:`mujoco.MjSpec`.
        environment: Environment name, path or spec, or None.
        at: Placement: a site of the environment, ``(x, y, yaw)`` or
            ``(x, y, z, yaw)`` [m, rad], or None.
        keyframe: The start pose's keyframe (name or index), or None
            (:func:`pik_mj.robot.keyframes.choose_keyframe`).
        root_body: The robot's top-level body, or None (:func:`pik_mj.frames.robot_root_body`).
        description: The robot description file (absolute path) or a
            :class:`~pik_mj.robot.description.RobotDescription`, or None.
    """

    model: ModelLike
    environment: ModelLike | None = None
    at: str | tuple[float, ...] | None = None
    keyframe: str | int | None = None
    root_body: str | None = None
    description: str | RobotDescription | None = None

    @property
    def serializable(self) -> bool:
        """Whether the source is names and paths only (no spec), so JSON can hold it."""
        return not any(isinstance(x, mujoco.MjSpec) for x in (self.model, self.environment))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready ``{"model", "environment", "at", "keyframe", "root_body",
        "description"}`` (a description given as an object is written as its keys).

        Raises:
            InvalidInput: The model or the environment was given as an MjSpec.
        """
        if not self.serializable:
            which = "model" if isinstance(self.model, mujoco.MjSpec) else "environment"
            raise InvalidInput(
                f"this robot's {which} was given as an MjSpec, which JSON cannot hold: "
                "build the robot from a model name or an MJCF path (e.g. save the spec "
                "with spec.to_xml() and pass the file) to write its source"
            )
        return {
            "model": str(self.model),
            "environment": None if self.environment is None else str(self.environment),
            "at": self.at if self.at is None or isinstance(self.at, str) else list(self.at),
            "keyframe": self.keyframe,
            "root_body": self.root_body,
            "description": (
                self.description.to_dict()
                if isinstance(self.description, RobotDescription)
                else self.description
            ),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RobotSource:
        """The source written by :meth:`to_dict` (extra keys are ignored).

        Raises:
            InvalidInput: No ``model``, or entries of the wrong type.
        """
        if not isinstance(data, Mapping) or not isinstance(data.get("model"), str):
            raise InvalidInput(
                f'a robot source needs "model" (a name or an MJCF path), got {data!r}'
            )
        values = {f.name: data.get(f.name) for f in fields(cls)}
        for key in ("environment", "root_body"):
            if values[key] is not None and not isinstance(values[key], str):
                raise InvalidInput(f"robot source {key!r} must be a string or null")
        key = values["keyframe"]
        if key is not None and (isinstance(key, bool) or not isinstance(key, (str, int))):
            raise InvalidInput(f"robot source 'keyframe' must be a name, an index or null: {key!r}")
        if isinstance(values["description"], Mapping):
            values["description"] = RobotDescription.from_dict(values["description"])
        elif values["description"] is not None and not isinstance(values["description"], str):
            raise InvalidInput("robot source 'description' must be a path, a table or null")
        at = values["at"]
        if at is not None and not isinstance(at, str):
            if not isinstance(at, (list, tuple)) or not all(
                isinstance(x, (int, float)) for x in at
            ):
                raise InvalidInput(f'robot source "at" must be a site name or numbers, got {at!r}')
            values["at"] = tuple(float(x) for x in at)
        return cls(**values)


def source_description(
    description: str | os.PathLike[str] | RobotDescription | None,
) -> str | RobotDescription | None:
    """A description file's absolute path (found from anywhere), or the object."""
    if isinstance(description, (str, os.PathLike)):
        return os.path.abspath(os.fspath(description))
    return description


def source_name(model: ModelLike) -> ModelLike:
    """A model name as given; a path made absolute (it is then found from anywhere)."""
    if isinstance(model, mujoco.MjSpec):
        return model
    name = os.fspath(model)
    if isinstance(model, os.PathLike) or name.endswith(".xml") or "/" in name or os.sep in name:
        return str(model_path(name))
    return name
