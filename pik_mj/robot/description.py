"""A robot description: what a user writes when the kinematic tree is not enough.

A few lines of TOML (or the same keys in JSON) name the robot's limbs (by their
end frame, optionally their joints or first body), the keyframe to stand in,
the root body and the collision geoms of each sole. Everything left out is
found as usual (:func:`pik_mj.robot.limbs.find_limbs`, :func:`pik_mj.robot.keyframes.standing_pose`,
:func:`pik_mj.robot.ground.sole_polygons`)::

    # h1_description.toml
    model = "unitree_h1"              # a model name or an MJCF path (relative to this file)
    keyframe = "stand"                # a keyframe name, or an index for an unnamed one
    root_body = "pelvis"

    [limbs.rarm]
    end = "right_elbow_link"          # a site or body: the end frame
    [limbs.larm]
    end = "left_elbow_link"
    joints = ["left_shoulder_pitch", "left_shoulder_roll", "left_shoulder_yaw", "left_elbow"]

    [soles]
    rleg = ["right_sole"]             # collision geoms the right foot stands on

Pass the file to :meth:`pik_mj.Robot.from_model` (``description=PATH``) or to a
scenario (``pik-mj run fullbody_reach --description PATH``); :func:`load_description`
reads it, :func:`robot_limbs` gives the limbs.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.frames import Frame
from pik_mj.robot.keyframes import StandingPose, standing_pose
from pik_mj.robot.limbs import HUMANOID_LIMBS, Limb, find_limbs, limb_from_end
from pik_mj.robot.loading import looks_like_path, model_path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

_TOP_KEYS = ("model", "root_body", "keyframe", "limbs", "soles")
_LIMB_KEYS = ("end", "joints", "start")


@dataclass(frozen=True)
class LimbDescription:
    """One limb: its end frame, and optionally its joints or its first body.

    Attributes:
        end: Site or body name of the end frame.
        joints: Hinge/slide joint names, root first; empty: found from the tree.
        start: First body of the chain when ``joints`` is empty; None: below the
            nearest branching body above ``end``.
    """

    end: str
    joints: tuple[str, ...] = ()
    start: str | None = None


@dataclass(frozen=True)
class RobotDescription:
    """What a user states about a robot (module docstring); None / empty = find it.

    Attributes:
        model: Model name or MJCF path the description is for.
        root_body: The robot's top-level body.
        keyframe: Keyframe name, or index, to stand in.
        limbs: Limbs by name (``rarm``, ``larm``, ``rleg``, ``lleg``, ``torso``, ``head``).
        soles: Collision geom names of each leg's sole, by leg name.
    """

    model: str | None = None
    root_body: str | None = None
    keyframe: str | int | None = None
    limbs: Mapping[str, LimbDescription] = field(default_factory=dict)
    soles: Mapping[str, tuple[str, ...]] = field(default_factory=dict)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base_dir: str | os.PathLike[str] | None = None):
        """Read the keys of a description file (module docstring).

        Args:
            data: The parsed file.
            base_dir: Folder a relative MJCF path in ``model`` is relative to.

        Raises:
            InvalidInput: An unknown key or a value of the wrong type (the message
                names the key and the valid ones).
        """
        if not isinstance(data, Mapping):
            raise InvalidInput(f"a robot description is a table of keys, got {type(data).__name__}")
        _only(data, _TOP_KEYS, "robot description")
        model = _optional_str(data, "model")
        if model is not None and base_dir is not None and looks_like_path(model):
            model = str((Path(base_dir) / model).resolve())
        keyframe = data.get("keyframe")
        if keyframe is not None and (
            isinstance(keyframe, bool) or not isinstance(keyframe, (str, int))
        ):
            raise InvalidInput(f"keyframe must be a name or an index, got {keyframe!r}")
        limbs = {}
        for name, limb in _table(data, "limbs").items():
            where = f"limbs.{name}"
            if not isinstance(limb, Mapping):
                raise InvalidInput(f"{where} must be a table with an 'end' key, got {limb!r}")
            _only(limb, _LIMB_KEYS, where)
            end = _optional_str(limb, "end", where)
            if end is None:
                raise InvalidInput(f"{where} needs 'end': the site or body the limb ends at")
            limbs[str(name)] = LimbDescription(
                end, _names(limb.get("joints", ()), f"{where}.joints"), _optional_str(limb, "start")
            )
        soles = {str(k): _names(v, f"soles.{k}") for k, v in _table(data, "soles").items()}
        return cls(model, _optional_str(data, "root_body"), keyframe, limbs, soles)

    def to_dict(self) -> dict[str, Any]:
        """The keys of a description file (the inverse of :meth:`from_dict`)."""
        out: dict[str, Any] = {
            k: getattr(self, k)
            for k in ("model", "root_body", "keyframe")
            if getattr(self, k) is not None
        }
        if self.limbs:
            out["limbs"] = {
                n: {
                    "end": x.end,
                    **({"joints": list(x.joints)} if x.joints else {}),
                    **({"start": x.start} if x.start else {}),
                }
                for n, x in self.limbs.items()
            }
        if self.soles:
            out["soles"] = {n: list(g) for n, g in self.soles.items()}
        return out

    def model_for(self, model: str | os.PathLike[str] | mujoco.MjSpec | None) -> Any:
        """The model a robot of this description is built from: ``model``, else
        the description's ``model``.

        Raises:
            InvalidInput: Both are given and name different MJCF files (a
                description written for another robot); a model given as an
                ``MjSpec`` is not compared.
        """
        if model is None or self.model is None or isinstance(model, mujoco.MjSpec):
            return self.model if model is None else model
        if not _same_file(self.model, model):
            raise InvalidInput(
                f"the robot description is for model {self.model!r}, but the model given is "
                f"{str(model)!r}; give the description's model, or remove 'model' from the "
                "description to use it with any model"
            )
        return model

    def standing_pose(self, model: mujoco.MjModel) -> StandingPose:
        """:func:`pik_mj.robot.keyframes.standing_pose` with this description's keyframe."""
        return standing_pose(model, self.keyframe, root_body=self.root_body)


def load_description(path: str | os.PathLike[str]) -> RobotDescription:
    """Read a robot description from a ``.toml`` or ``.json`` file.

    Raises:
        InvalidInput: The file is missing, not TOML/JSON, or holds bad keys.
    """
    p = Path(path).expanduser()
    if not p.is_file():
        raise InvalidInput(f"robot description {str(p)!r} does not exist")
    text = p.read_text(encoding="utf-8")
    try:
        if p.suffix.lower() == ".json":
            data = json.loads(text)
        elif p.suffix.lower() == ".toml":
            data = tomllib.loads(text)
        else:
            raise InvalidInput(
                f"robot description {str(p)!r}: use a .toml or .json file, got {p.suffix!r}"
            )
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as err:
        raise InvalidInput(f"robot description {str(p)!r} cannot be parsed: {err}") from err
    return RobotDescription.from_dict(data, base_dir=p.resolve().parent)


def robot_limbs(
    model: mujoco.MjModel,
    description: RobotDescription | None = None,
    qpos: np.ndarray | None = None,
    *,
    root_body: int | str | None = None,
    required: Sequence[str] = HUMANOID_LIMBS,
) -> dict[str, Limb]:
    """The robot's limbs: the described ones, the others found from the tree.

    Args:
        model: The robot's model.
        description: What the user described (None: find everything).
        qpos: Standing configuration for the search; default the description's
            (or the rule's) standing pose.
        root_body: The robot's top-level body (name or id); default the
            description's, else :func:`pik_mj.frames.robot_root_body`.
        required: Limb names that must be there in the end (the others are
            found if they can be).

    Raises:
        LimbsNotFound: A required limb is neither described nor found.
        UnknownName: A described end frame, first body or joint does not exist.
    """
    description = description or RobotDescription()
    described = {
        name: limb_from_end(model, name, x.end, joints=x.joints, start=x.start)
        for name, x in description.limbs.items()
    }
    if root_body is None:
        root_body = description.root_body
    if qpos is None:
        qpos = standing_pose(model, description.keyframe, root_body=root_body).qpos
    for name, x in description.limbs.items():
        _check_chain(model, f"limbs.{name}", x, described[name])
    still = [n for n in required if n not in described]
    found = find_limbs(model, qpos, root_body=root_body, required=still)
    return {**found, **described}


def _same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two model names or paths resolve to one MJCF file (by name when
    one does not resolve)."""
    if str(a) == str(b):
        return True
    try:
        return model_path(a) == model_path(b)
    except PikError:
        return False


def _check_chain(model: mujoco.MjModel, where: str, described: LimbDescription, limb: Limb) -> None:
    """Each described joint moves the limb's end frame: its body is the end
    frame's body or above it.

    Raises:
        InvalidInput: A joint off that chain (e.g. a left elbow in ``rarm``);
            the joints on the chain are listed.
    """
    if not described.joints:
        return
    end_body = Frame.find(model, limb.end_frame, limb.end_frame_type).body_id
    chain = []
    body = end_body
    while body > 0:
        chain.append(body)
        body = int(model.body_parentid[body])
    on_chain = [
        model.joint(j).name
        for j in range(model.njnt)
        if int(model.jnt_bodyid[j]) in chain
        and int(model.jnt_type[j]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
    ]
    for joint in described.joints:
        if joint not in on_chain:
            body_name = model.body(int(model.joint(joint).bodyid[0])).name
            raise InvalidInput(
                f"{where}.joints: joint {joint!r} (on body {body_name!r}) does not move the "
                f"end frame {described.end!r}: it is not on the chain above it. The hinge and "
                f"slide joints on that chain: {on_chain}"
            )


def _only(table: Mapping[str, Any], valid: Sequence[str], where: str) -> None:
    unknown = [k for k in table if k not in valid]
    if unknown:
        raise InvalidInput(f"{where}: unknown keys {unknown}; valid keys are {list(valid)}")


def _optional_str(table: Mapping[str, Any], key: str, where: str = "") -> str | None:
    value = table.get(key)
    if value is not None and not isinstance(value, str):
        raise InvalidInput(f"{where + '.' if where else ''}{key} must be a string, got {value!r}")
    return value


def _table(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise InvalidInput(f"{key} must be a table, got {value!r}")
    return value


def _names(value: Any, where: str) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise InvalidInput(f"{where} must be a list of names, got {value!r}")
    if not all(isinstance(v, str) for v in value):
        raise InvalidInput(f"{where} must hold names (strings), got {list(value)!r}")
    return tuple(value)
