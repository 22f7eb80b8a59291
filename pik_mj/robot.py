"""The robot data layer: irteus' cascaded-link / robot-model on a MuJoCo model.

A :class:`Robot` is built from its model with :meth:`Robot.from_model` (a model
name, an MJCF path or an :class:`mujoco.MjSpec`, optionally placed in an
environment) and OWNS its kinematic world: ``robot.spec`` (the robot, or the
robot with the environment attached into it, so the robot's ``qpos`` is a prefix
of every model built from it), ``robot.model``, ``robot.configuration`` (a
:class:`mink.Configuration` holding its state) and ``robot.source`` (a
:class:`RobotSource`: what rebuilds it). It knows which top-level body is the
robot (its *root body*, :func:`robot_root_body`), the robot's joints and limbs,
and gives irteus-style accessors: ``angle_vector``, ``link_list``,
end-effector frames, mass, centroid and centroid Jacobian. MuJoCo computes all
kinematics.

A floating-base robot's start pose stands on the floor z = 0: its lowest sole
(or foot) collision geom touches the plane (dm_control's humanoids start 0.2 m
up; they are lowered), so the IK's world and the physics' world are the same.

Limbs are found by name:

* models following the pik_mj naming (``models/sample_humanoid.xml``): every
  joint named ``{limb}_...`` belongs to limb ``rarm``, ``larm``, ``rleg``,
  ``lleg``, ``torso`` or ``head``; its end frame is the site ``{limb}_end``;
* dm_control's ``humanoid.xml`` and ``humanoid_CMU.xml`` and the 3-DoF arm:
  the explicit tables below.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.models import model_path

FRAME_TYPES = ("site", "body", "geom")
LIMB_NAMES = ("rarm", "larm", "rleg", "lleg", "torso", "head")
RESET_KEYFRAME = "reset_pose"
GROUND_TOLERANCE = 1e-6
"""[m] A floating-base robot whose soles are farther than this from the floor
(above or below) at its start pose is moved onto it by :meth:`Robot.from_model`."""

_FRAME_OBJ = {
    "site": mujoco.mjtObj.mjOBJ_SITE,
    "body": mujoco.mjtObj.mjOBJ_BODY,
    "geom": mujoco.mjtObj.mjOBJ_GEOM,
}
_FRAME_COUNT = {"site": "nsite", "body": "nbody", "geom": "ngeom"}
_ANGLE_JOINTS = (
    int(mujoco.mjtJoint.mjJNT_HINGE),
    int(mujoco.mjtJoint.mjJNT_SLIDE),
)


@dataclass(frozen=True)
class Limb:
    """A kinematic chain of the robot (irteus ``:rarm``, ``:lleg``, ...).

    Attributes:
        name: Limb name, e.g. ``"rarm"``.
        joints: Joint names from the limb's root towards its end.
        end_frame: Name of the end-effector frame (irteus ``:end-coords``).
        end_frame_type: ``"site"`` or ``"body"``.
        root_body: The limb's first link: the body moved by ``joints[0]``
            (irteus ``:root-link``).
    """

    name: str
    joints: tuple[str, ...]
    end_frame: str
    end_frame_type: str
    root_body: str


# (limb, joints, end frame, end frame type) of models without pik_mj naming.
_LimbRow = tuple[str, tuple[str, ...], str, str]


def _sides(row: _LimbRow, left: str, right: str) -> list[_LimbRow]:
    """The right-side and left-side copies of a row written with ``{s}``."""
    limb, joints, end, kind = row
    return [
        (limb.format(s=s), tuple(j.format(s=n) for j in joints), end.format(s=n), kind)
        for s, n in (("r", right), ("l", left))
    ]


DM_HUMANOID_LIMBS: tuple[_LimbRow, ...] = (
    ("torso", ("abdomen_z", "abdomen_y", "abdomen_x"), "pelvis", "body"),
    *_sides(
        (
            "{s}leg",
            (
                "{s}_hip_x",
                "{s}_hip_z",
                "{s}_hip_y",
                "{s}_knee",
                "{s}_ankle_y",
                "{s}_ankle_x",
            ),
            "{s}_foot",
            "body",
        ),
        "left",
        "right",
    ),
    *_sides(
        (
            "{s}arm",
            ("{s}_shoulder1", "{s}_shoulder2", "{s}_elbow"),
            "{s}_hand",
            "site",
        ),
        "left",
        "right",
    ),
)
"""dm_control ``suite/humanoid.xml``: the head has no joint, so no head limb."""

DM_HUMANOID_CMU_LIMBS: tuple[_LimbRow, ...] = (
    (
        "torso",
        tuple(f"{b}r{a}" for b in ("lowerback", "upperback", "thorax") for a in "zyx"),
        "thorax",
        "body",
    ),
    (
        "head",
        tuple(f"{b}r{a}" for b in ("lowerneck", "upperneck", "head") for a in "zyx"),
        "head",
        "body",
    ),
    *_sides(
        (
            "{s}leg",
            tuple(
                "{s}" + j
                for j in (
                    "femurrz",
                    "femurry",
                    "femurrx",
                    "tibiarx",
                    "footrz",
                    "footrx",
                )
            ),
            "{s}foot",
            "body",
        ),
        "l",
        "r",
    ),
    *_sides(
        (
            "{s}arm",
            tuple(
                "{s}" + j
                for j in (
                    "claviclerz",
                    "claviclery",
                    "humerusrz",
                    "humerusry",
                    "humerusrx",
                    "radiusrx",
                    "wristry",
                    "handrz",
                    "handrx",
                )
            ),
            "{s}hand",
            "body",
        ),
        "l",
        "r",
    ),
)
"""dm_control ``suite/humanoid_CMU.xml`` (toes, fingers and thumbs left out)."""

THREE_DOF_ARM_LIMBS: tuple[_LimbRow, ...] = (
    ("arm", ("joint0", "joint1", "joint2"), "end", "site"),
)
"""``models/three_dof_arm.xml`` (seed 001's ``3dof-robot``)."""

_LIMB_TABLES = (DM_HUMANOID_LIMBS, DM_HUMANOID_CMU_LIMBS, THREE_DOF_ARM_LIMBS)


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, i: int) -> str:
    return mujoco.mj_id2name(model, obj, i) or ""


def _id(model: mujoco.MjModel, obj: mujoco.mjtObj, name: str) -> int:
    return mujoco.mj_name2id(model, obj, name)


def robot_root_body(
    model: mujoco.MjModel, root_body: str | None = None, *, limb_bodies: Sequence[int] = ()
) -> int:
    """Id of the robot's top-level body: the one choice every part of pik_mj makes.

    Args:
        model: The model (a robot alone, or with an environment).
        root_body: A body name (any body but the world; its subtree is the
            robot). None picks among the top-level bodies (children of the
            world): the one holding ``limb_bodies`` if they share one; else those
            with a free joint if any, then the one with the most degrees of
            freedom in its subtree.
        limb_bodies: Ids of bodies known to be the robot's (e.g. its limbs').

    Raises:
        UnknownName: No body ``root_body``.
        InvalidInput: ``root_body`` is the world, or the default is ambiguous.
    """
    top = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
    names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in top]
    if root_body is not None:
        if not isinstance(root_body, str):
            raise InvalidInput(f"root_body must be a body name, got {type(root_body).__name__}")
        b = _id(model, mujoco.mjtObj.mjOBJ_BODY, root_body)
        if b < 0:
            all_names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(model.nbody)]
            raise UnknownName("body", root_body, all_names)
        if b == 0:
            raise InvalidInput(
                f"root_body {root_body!r} is the world body, whose subtree holds the "
                f"environment too; give the robot's top-level body, one of {names}"
            )
        return int(b)
    if not top:
        raise InvalidInput("the model has no body besides the world")
    roots = {int(model.body_rootid[b]) for b in limb_bodies}
    if len(roots) == 1:
        return roots.pop()
    free = int(mujoco.mjtJoint.mjJNT_FREE)
    floating = [
        b for b in top if model.body_jntnum[b] > 0 and model.jnt_type[model.body_jntadr[b]] == free
    ]
    candidates = floating or top
    dofs = [int(model.body_dofnum[model.body_rootid == b].sum()) for b in candidates]
    best = max(dofs)
    if dofs.count(best) > 1:
        raise InvalidInput(
            f"cannot tell which top-level body is the robot among {names}; pass root_body"
        )
    return int(candidates[dofs.index(best)])


def sole_geoms(model: mujoco.MjModel, bodies: np.ndarray) -> list[int]:
    """The robot's sole collision geoms: the named collision geoms of ``bodies``
    (a mask over ``model``'s bodies) whose name contains ``sole``; without any,
    those on bodies whose name contains ``foot``."""
    geoms = [
        g
        for g in range(model.ngeom)
        if bodies[model.geom_bodyid[g]]
        and (model.geom_contype[g] or model.geom_conaffinity[g])
        and _name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
    ]
    soles = [g for g in geoms if "sole" in _name(model, mujoco.mjtObj.mjOBJ_GEOM, g)]
    if soles:
        return soles
    return [
        g
        for g in geoms
        if "foot" in _name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g]))
    ]


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
        keyframe: The start pose's keyframe, or None (``reset_pose`` if the model
            has one, else ``qpos0``).
        root_body: The robot's top-level body, or None (:func:`robot_root_body`).
    """

    model: ModelLike
    environment: ModelLike | None = None
    at: str | tuple[float, ...] | None = None
    keyframe: str | None = None
    root_body: str | None = None

    @property
    def serializable(self) -> bool:
        """Whether the source is names and paths only (no spec), so JSON can hold it."""
        return not any(isinstance(x, mujoco.MjSpec) for x in (self.model, self.environment))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready ``{"model", "environment", "at", "keyframe", "root_body"}``.

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
        for key in ("environment", "keyframe", "root_body"):
            if values[key] is not None and not isinstance(values[key], str):
                raise InvalidInput(f"robot source {key!r} must be a string or null")
        at = values["at"]
        if at is not None and not isinstance(at, str):
            if not isinstance(at, (list, tuple)) or not all(
                isinstance(x, (int, float)) for x in at
            ):
                raise InvalidInput(f'robot source "at" must be a site name or numbers, got {at!r}')
            values["at"] = tuple(float(x) for x in at)
        return cls(**values)


def _source_name(model: ModelLike) -> ModelLike:
    """A model name as given; a path made absolute (it is then found from anywhere)."""
    if isinstance(model, mujoco.MjSpec):
        return model
    name = os.fspath(model)
    if isinstance(model, os.PathLike) or name.endswith(".xml") or "/" in name or os.sep in name:
        return str(model_path(name))
    return name


class Robot:
    """A robot in a MuJoCo model, with its state in a :class:`mink.Configuration`.

    Build one with :meth:`Robot.from_model` (it then owns its world: ``spec``,
    ``source``). ``Robot(model)`` wraps a compiled model as it is (no source: no
    :class:`pik_mj.sim.Scene` can be made from it).

    Args:
        model: The compiled model (a robot alone or with an environment).
        root_body: Name of the robot's top-level body. By default the top-level
            body holding the joints of the detected limbs, or, without limbs, as
            :func:`robot_root_body`.
        limbs: Explicit limb table ``{name: Limb}``; detected from names if None.
        keyframe: Keyframe of the start pose (:meth:`reset_pose`); default
            ``reset_pose`` if the model has one, else ``qpos0``.

    Attributes:
        model: The compiled model.
        configuration: The robot's state.
        spec: The robot's world as an :class:`mujoco.MjSpec` (never modified; a
            scene copies it), or None for ``Robot(model)``.
        source: The :class:`RobotSource` that rebuilds it, or None.
        placement: ``(x, y, z, yaw)`` [m, rad] where the robot's model frame was
            put (``at``), or None.
        keyframe: The start pose's keyframe (:meth:`reset_pose`), or None for ``qpos0``.

    Raises:
        UnknownName: ``root_body``, ``keyframe`` or a limb's joint/frame does not exist.
        InvalidInput: ``root_body`` is not a top-level body, or the robot's top
            level body cannot be chosen.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        root_body: str | None = None,
        limbs: Mapping[str, Limb] | None = None,
        keyframe: str | None = None,
    ):
        if not isinstance(model, mujoco.MjModel):
            raise InvalidInput(
                f"Robot(model) takes a compiled mujoco.MjModel, got {type(model).__name__}; "
                "use Robot.from_model(name, path or MjSpec)"
            )
        self.model = model
        self.configuration = mink.Configuration(model)
        self.spec: mujoco.MjSpec | None = None
        self.source: RobotSource | None = None
        self.placement: tuple[float, float, float, float] | None = None
        top_level = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
        if not top_level:
            raise InvalidInput("the model has no body besides the world")
        if limbs is not None and not (
            isinstance(limbs, Mapping) and all(isinstance(x, Limb) for x in limbs.values())
        ):
            raise InvalidInput(f"limbs must be a mapping of names to Limb, got {limbs!r}")
        if keyframe is not None and not isinstance(keyframe, str):
            raise InvalidInput(f"keyframe must be a keyframe name (a string), got {keyframe!r}")
        detected = self._detect_limbs() if limbs is None else dict(limbs)
        self._root_id = robot_root_body(
            model,
            root_body,
            limb_bodies=[
                b
                for b in (
                    _id(model, mujoco.mjtObj.mjOBJ_BODY, x.root_body) for x in detected.values()
                )
                if b >= 0
            ],
        )
        if self._root_id not in top_level:
            names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in top_level]
            raise InvalidInput(
                f"root_body {root_body!r} is not a top-level body (a child of "
                f"the world). Top-level bodies: {names}"
            )
        in_robot = model.body_rootid[model.jnt_bodyid] == self._root_id
        self._robot_joint_ids = np.flatnonzero(in_robot)
        angle = np.isin(model.jnt_type, _ANGLE_JOINTS)
        self._angle_joint_ids = np.flatnonzero(in_robot & angle)
        self.joint_names: list[str] = [
            _name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in self._angle_joint_ids
        ]
        self._joint_index = {n: i for i, n in enumerate(self.joint_names)}
        if limbs is not None:
            for limb in detected.values():
                self._check_limb(limb)
        self.limbs: dict[str, Limb] = {
            name: limb
            for name, limb in detected.items()
            if model.body_rootid[model.body(limb.root_body).id] == self._root_id
        }
        keys = [_name(model, mujoco.mjtObj.mjOBJ_KEY, k) for k in range(model.nkey)]
        if keyframe is not None and keyframe not in keys:
            raise UnknownName("keyframe", keyframe, keys)
        self.keyframe = (
            keyframe
            if keyframe is not None
            else (RESET_KEYFRAME if RESET_KEYFRAME in keys else None)
        )
        self.reset_pose()

    @classmethod
    def from_model(
        cls,
        model: ModelLike,
        *,
        environment: ModelLike | None = None,
        at: str | Sequence[float] | None = None,
        keyframe: str | None = None,
        root_body: str | None = None,
        limbs: Mapping[str, Limb] | None = None,
    ) -> Robot:
        """The robot of ``model``, standing in its world.

        The robot's spec is the host of its world: the robot's top-level body is
        placed at ``at`` (:func:`pik_mj.sim.environment.place_root`), and the
        environment is attached into the spec
        (:func:`pik_mj.sim.environment.attach_environment`), so the robot's
        ``qpos`` is a prefix of the world's and the robot and the environment's
        objects (e.g. the room's ``kettle_handle`` site) share one world frame. A
        floating-base robot is first moved along z so that its lowest sole geom
        (:func:`sole_geoms`) touches z = 0 at its start pose (when it is farther
        than :data:`GROUND_TOLERANCE`), in its qpos0 and its keyframes.

        Args:
            model: Model name (:func:`pik_mj.models.available_models`), MJCF path,
                or an :class:`mujoco.MjSpec` (copied; its source cannot be
                written to JSON).
            environment: Environment name, path or spec, or None (the robot alone).
            at: A site of the environment (its position and heading), or
                ``(x, y, yaw)`` / ``(x, y, z, yaw)`` [m, rad]: where the robot's model
                frame goes.
            keyframe: Keyframe of the start pose (default ``reset_pose`` if any).
            root_body: The robot's top-level body (default: see
                :func:`robot_root_body`).
            limbs: Explicit limb table (default: detected from names).

        Raises:
            UnknownName: Unknown model name, site, keyframe or body.
            InvalidInput: A model that does not load or compile, a bad placement.
        """
        from pik_mj.sim.environment import as_spec, attach_environment, place_root, placement

        for what, value in (("model", model), ("environment", environment)):
            if not isinstance(value, (str, os.PathLike, mujoco.MjSpec)) and (
                value is not None or what == "model"
            ):
                raise InvalidInput(
                    f"{what} must be a model name, an MJCF path or a mujoco.MjSpec, got {value!r}"
                )
        spec = as_spec(model)
        try:
            alone = spec.compile()
        except ValueError as err:
            raise InvalidInput(f"model {spec.modelname!r} does not compile: {err}") from err
        robot = cls(alone, root_body=root_body, limbs=limbs, keyframe=keyframe)
        env_spec = None if environment is None else as_spec(environment)
        env_model = None
        if env_spec is not None:
            try:
                env_model = env_spec.copy().compile()
            except ValueError as err:
                raise InvalidInput(
                    f"environment {env_spec.modelname!r} does not compile: {err}"
                ) from err
        p_WR, yaw = (np.zeros(3), 0.0) if at is None else placement(at, env_model)
        dz = -robot._ground_gap(spec) if robot.has_floating_base else 0.0
        if abs(dz) <= GROUND_TOLERANCE:
            dz = 0.0
        world = alone
        if at is not None or dz != 0.0 or env_spec is not None:
            if at is not None or dz != 0.0:
                place_root(spec, alone, robot.root_body_id, p_WR + np.array([0.0, 0.0, dz]), yaw)
            if env_spec is not None:
                spec = attach_environment(spec, env_spec)
            try:
                world = spec.compile()
            except ValueError as err:
                raise InvalidInput(f"the robot's world does not compile: {err}") from err
        out = cls(world, root_body=robot.root_body, limbs=limbs, keyframe=keyframe)
        out.spec = spec
        out.source = RobotSource(
            _source_name(model),
            None if environment is None else _source_name(environment),
            at if at is None or isinstance(at, str) else tuple(float(x) for x in at),
            keyframe,
            root_body,
        )
        if at is not None:
            out.placement = (float(p_WR[0]), float(p_WR[1]), float(p_WR[2]), float(yaw))
        return out

    @classmethod
    def from_source(cls, source: RobotSource | Mapping[str, Any]) -> Robot:
        """:meth:`from_model` of a :class:`RobotSource` (or its ``to_dict()``)."""
        if not isinstance(source, RobotSource):
            source = RobotSource.from_dict(source)
        return cls.from_model(
            source.model,
            environment=source.environment,
            at=source.at,
            keyframe=source.keyframe,
            root_body=source.root_body,
        )

    def _ground_gap(self, spec: mujoco.MjSpec) -> float:
        """Smallest distance [m] of the sole geoms to the plane z = 0 at the start
        pose (``mj_geomDistance``; negative: they sink into it); 0 without soles.

        ``spec`` is the robot's spec (``self.model`` compiled); a plane is added to
        a copy of it.
        """
        probe = spec.copy()
        probe.worldbody.add_geom(
            name="pik_mj_ground_probe", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.0, 1.0, 0.1]
        )
        m = probe.compile()
        soles = sole_geoms(m, np.asarray(m.body_rootid) == self._root_id)
        if not soles:
            return 0.0
        d = mujoco.MjData(m)
        d.qpos[:] = self.configuration.q
        mujoco.mj_kinematics(m, d)
        ground = m.geom("pik_mj_ground_probe").id
        return min(mujoco.mj_geomDistance(m, d, g, ground, 10.0, None) for g in soles)

    # ------------------------------------------------------------------ limbs
    def _detect_limbs(self) -> dict[str, Limb]:
        model = self.model
        joints = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
        limbs: dict[str, Limb] = {}
        for limb in LIMB_NAMES:
            own = tuple(
                n
                for j, n in enumerate(joints)
                if n.startswith(f"{limb}_") and int(model.jnt_type[j]) in _ANGLE_JOINTS
            )
            if not own:
                continue
            end = f"{limb}_end"
            if _id(model, mujoco.mjtObj.mjOBJ_SITE, end) >= 0:
                limbs[limb] = self._make_limb(limb, own, end, "site")
            else:  # e.g. the torso: its last link is the end frame.
                last = model.jnt_bodyid[model.joint(own[-1]).id]
                body = _name(model, mujoco.mjtObj.mjOBJ_BODY, last)
                limbs[limb] = self._make_limb(limb, own, body, "body")
        if limbs:
            return limbs
        names = set(joints)
        for table in _LIMB_TABLES:
            if all(
                set(row[1]) <= names and _id(model, _FRAME_OBJ[row[3]], row[2]) >= 0
                for row in table
            ):
                return {row[0]: self._make_limb(*row) for row in table}
        return {}

    def _make_limb(self, name: str, joints: tuple[str, ...], end: str, end_type: str) -> Limb:
        first = self.model.joint(joints[0]).id
        root = _name(self.model, mujoco.mjtObj.mjOBJ_BODY, self.model.jnt_bodyid[first])
        return Limb(name, tuple(joints), end, end_type, root)

    def _check_limb(self, limb: Limb) -> None:
        for joint in limb.joints:
            self._angle_joint_id(joint)
        for frame, kind in (
            (limb.end_frame, limb.end_frame_type),
            (limb.root_body, "body"),
        ):
            if self.model.body_rootid[self._frame_body_id(frame, kind)] != self._root_id:
                raise InvalidInput(f"limb {limb.name!r}: {kind} {frame!r} is not on the robot")

    def limb(self, name: str) -> Limb:
        """The limb called ``name`` (irteus ``(send robot :rarm)``)."""
        try:
            return self.limbs[name]
        except KeyError:
            raise UnknownName("limb", name, self.limbs) from None

    # ---------------------------------------------------------------- state
    @property
    def data(self) -> mujoco.MjData:
        """The configuration's :class:`mujoco.MjData` (kinematics kept current)."""
        return self.configuration.data

    @property
    def root_body(self) -> str:
        """Name of the robot's top-level body."""
        return _name(self.model, mujoco.mjtObj.mjOBJ_BODY, self._root_id)

    @property
    def root_body_id(self) -> int:
        """Id of the robot's top-level body."""
        return int(self._root_id)

    @property
    def own_nq(self) -> int:
        """Length of the robot's own part of ``q``: its joints come first, the
        environment's (e.g. the room's kettle) after them."""
        k = len(self._robot_joint_ids)
        return int(self.model.nq if k == self.model.njnt else self.model.jnt_qposadr[k])

    @property
    def has_floating_base(self) -> bool:
        """Whether the root body's first joint is a free joint."""
        return self._free_qposadr() is not None

    def _free_qposadr(self) -> int | None:
        j = self.model.body_jntadr[self._root_id]
        if j >= 0 and self.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            return int(self.model.jnt_qposadr[j])
        return None

    def _angle_joint_id(self, name: str) -> int:
        """Id of the robot's hinge or slide joint ``name``."""
        i = self._joint_index.get(name)
        if i is not None:
            return int(self._angle_joint_ids[i])
        j = _id(self.model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if j >= 0 and j in self._robot_joint_ids:
            kind = mujoco.mjtJoint(self.model.jnt_type[j]).name
            raise InvalidInput(
                f"joint {name!r} is a {kind} joint; angle vectors hold only hinge "
                "and slide joints (use set_root_pose for the free joint)"
            )
        raise UnknownName("joint", name, self.joint_names)

    def _qposadr(self, names: Sequence[str] | None) -> np.ndarray:
        if names is None:
            return self.model.jnt_qposadr[self._angle_joint_ids]
        names = inputs.names(names, "names (of joints)")
        return np.array([self.model.jnt_qposadr[self._angle_joint_id(n)] for n in names], dtype=int)

    def angle_vector(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Joint positions [rad or m] (irteus ``:angle-vector``).

        Args:
            names: Hinge/slide joint names; all of :attr:`joint_names` if None.

        Returns:
            Array of shape (len(names),), a copy.
        """
        return self.data.qpos[self._qposadr(names)].copy()

    def set_angle_vector(
        self, values: Sequence[float] | np.ndarray, names: Sequence[str] | None = None
    ) -> None:
        """Set joint positions [rad or m] and update the kinematics.

        Values are written as given (limits are not enforced; see
        :meth:`joint_limits`), within ``±``:data:`pik_mj.inputs.Q_LIMIT`.

        Args:
            values: One value per joint.
            names: Hinge/slide joint names; all of :attr:`joint_names` if None.

        Raises:
            InvalidInput: Not numbers, wrong length, non-finite values or beyond
                ``Q_LIMIT``, or a ball/free joint.
            UnknownName: A joint name the robot does not have.
        """
        adr = self._qposadr(names)
        v = inputs.vector(values, adr.size, f"angle vector (one value per joint, {adr.size})")
        far = np.flatnonzero(np.abs(v) > inputs.Q_LIMIT)
        if far.size:
            joint = (self.joint_names if names is None else list(names))[far[0]]
            raise InvalidInput(
                f"angle vector: joint {joint!r} at {v[far[0]]:g} is beyond "
                f"{inputs.Q_LIMIT:g} [rad or m]: an overflow or a units mistake"
            )
        q = self.configuration.q
        q[adr] = v
        self.configuration.update(q)

    def root_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Pose of the root body B in the world W.

        Returns:
            ``(p_WB, quat_WB)``: position (3,) [m] and quaternion (4,) (w, x, y, z).
        """
        b = self._root_id
        return self.data.xpos[b].copy(), self.data.xquat[b].copy()

    def set_root_pose(
        self, p_WB: Sequence[float] | np.ndarray, quat_WB: Sequence[float] | np.ndarray
    ) -> None:
        """Set the free joint of the root body (quaternion normalized).

        Args:
            p_WB: Position (3,) of the root body in the world [m].
            quat_WB: Orientation (4,) (w, x, y, z), any non-zero norm.

        Raises:
            InvalidInput: No floating base, wrong shapes, non-finite values or a
                zero quaternion.
        """
        adr = self._free_qposadr()
        if adr is None:
            raise InvalidInput(
                f"robot root body {self.root_body!r} has no free joint; its pose is fixed"
            )
        p = inputs.vector(p_WB, 3, "p_WB (the root position)", unit="m")
        if np.any(np.abs(p) > inputs.Q_LIMIT):
            raise InvalidInput(
                f"p_WB {p.tolist()} is beyond {inputs.Q_LIMIT:g} m: an overflow or a units mistake"
            )
        quat = inputs.quaternion(quat_WB, "quat_WB")
        q = self.configuration.q
        q[adr : adr + 3] = p
        q[adr + 3 : adr + 7] = quat
        self.configuration.update(q)

    def reset_pose(self) -> None:
        """Go to the start pose: keyframe :attr:`keyframe`, or ``qpos0`` without one."""
        k = -1 if self.keyframe is None else _id(self.model, mujoco.mjtObj.mjOBJ_KEY, self.keyframe)
        q = self.model.key_qpos[k] if k >= 0 else self.model.qpos0
        self.configuration.update(q.copy())

    # ------------------------------------------------------------- frames
    def _frame_body_id(self, name: str, frame_type: str) -> int:
        if not isinstance(name, str):
            raise InvalidInput(f"a frame name must be a string, got {name!r}")
        if frame_type not in _FRAME_OBJ:
            raise InvalidInput(f"frame_type {frame_type!r} is not one of {list(FRAME_TYPES)}")
        i = _id(self.model, _FRAME_OBJ[frame_type], name)
        if i < 0:
            n = getattr(self.model, _FRAME_COUNT[frame_type])
            valid = [_name(self.model, _FRAME_OBJ[frame_type], k) for k in range(n)]
            raise UnknownName(frame_type, name, [v for v in valid if v])
        if frame_type == "site":
            return int(self.model.site_bodyid[i])
        if frame_type == "geom":
            return int(self.model.geom_bodyid[i])
        return i

    def link_list(self, frame: str, frame_type: str = "site") -> list[str]:
        """Bodies from the robot's root body down to the body holding ``frame``.

        Like irteus ``(send robot :link-list (send end-coords :parent))``, but the
        root body is included even when it carries no joint (irteus omits a
        fixed root link: for the 3-DoF arm it gives ``(l2 l3 l4)``, this gives
        ``["l1", "l2", "l3", "l4"]``).

        Raises:
            UnknownName: No frame of that type and name.
            InvalidInput: The frame is not on the robot.
        """
        b = self._frame_body_id(frame, frame_type)
        if self.model.body_rootid[b] != self._root_id:
            raise InvalidInput(
                f"{frame_type} {frame!r} is not on the robot (root body {self.root_body!r})"
            )
        chain = []
        while b != 0:
            chain.append(_name(self.model, mujoco.mjtObj.mjOBJ_BODY, b))
            b = int(self.model.body_parentid[b])
        return chain[::-1]

    def joint_list(self, frame: str, frame_type: str = "site") -> list[str]:
        """Hinge/slide joints on the chain :meth:`link_list` ``(frame)``, root first."""
        bodies = {self.model.body(n).id for n in self.link_list(frame, frame_type)}
        return [
            self.joint_names[i]
            for i, j in enumerate(self._angle_joint_ids)
            if self.model.jnt_bodyid[j] in bodies
        ]

    def frame_pose(self, name: str, frame_type: str = "site") -> mink.SE3:
        """Pose ``X_WF`` of frame F (site, body or geom) in the world."""
        self._frame_body_id(name, frame_type)
        return self.configuration.get_transform_frame_to_world(name, frame_type)

    # ------------------------------------------------------------- mass, CoM
    @property
    def mass(self) -> float:
        """Total mass of the robot's bodies [kg]."""
        return float(self.model.body_subtreemass[self._root_id])

    def com(self) -> np.ndarray:
        """Centroid of the robot p_WG [m], shape (3,).

        .. math::

            p_{WG} = \\frac{1}{M} \\sum_{i \\in robot} m_i\\, p_{W i}
        """
        return self.data.subtree_com[self._root_id].copy()

    def com_jacobian(self) -> np.ndarray:
        """Centroid Jacobian J_com [m/rad or m/m], shape (3, nv).

        .. math::

            \\dot p_{WG} = J_{com}\\, v,
            \\qquad J_{com} = \\frac{1}{M} \\sum_{i \\in robot} m_i J_{p,i}

        with ``v`` MuJoCo's generalized velocity (the free joint's angular part in
        the body frame). Computed by ``mj_jacSubtreeCom`` for the root body.
        """
        J_com = np.zeros((3, self.model.nv))
        mujoco.mj_jacSubtreeCom(self.model, self.data, J_com, self._root_id)
        return J_com

    def joint_limits(self, names: Sequence[str] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper joint limits [rad or m]; ±inf where unlimited.

        Args:
            names: Hinge/slide joint names; all of :attr:`joint_names` if None.
        """
        if names is None:
            ids = self._angle_joint_ids
        else:
            names = inputs.names(names, "names (of joints)")
            ids = np.array([self._angle_joint_id(n) for n in names], dtype=int)
        limited = self.model.jnt_limited[ids].astype(bool)
        lower = np.where(limited, self.model.jnt_range[ids, 0], -np.inf)
        upper = np.where(limited, self.model.jnt_range[ids, 1], np.inf)
        return lower, upper

    def __repr__(self) -> str:
        model_name = self.model.names[: self.model.names.index(b"\0")].decode()
        return (
            f"Robot(model={model_name!r}, root_body={self.root_body!r}, "
            f"floating_base={self.has_floating_base}, joints={len(self.joint_names)}, "
            f"nv={self.model.nv}, limbs={list(self.limbs)}, mass={self.mass:.3f} kg)"
        )
