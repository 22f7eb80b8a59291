"""The robot: a :class:`~pik_mj.robot.robot_model.RobotModel` built from its model
and standing in its world.

A :class:`Robot` is built with :meth:`Robot.from_model` (a model name, an MJCF path
or an :class:`mujoco.MjSpec`, optionally placed in an environment) and OWNS its
kinematic world: ``robot.spec`` (the robot, or the robot with the environment
attached into it, so the robot's ``qpos`` is a prefix of every model built from
it), ``robot.model``, ``robot.configuration`` (a :class:`mink.Configuration`
holding its state) and ``robot.source`` (a :class:`RobotSource`: what rebuilds it).

Any MJCF is taken as it is shipped: the start pose is a keyframe chosen by
:func:`pik_mj.robot.keyframes.choose_keyframe`; a floating-base robot's start pose
stands on the floor z = 0, its lowest collision geom touching the plane
(dm_control's humanoids start above it, Robotis OP3's zero pose floats: they are
lowered), so the IK's world and the physics' world are the same; a zero pose whose
soles are tilted gets them turned flat (:mod:`pik_mj.robot.stance`). The limbs are
found from the kinematic tree (:func:`pik_mj.robot.limbs.find_limbs`), and what
the tree does not tell is written in a robot description
(:mod:`pik_mj.robot.description`). The spec steps are :mod:`pik_mj.robot.assembly`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from pik_mj.exceptions import LimbsNotFound
from pik_mj.frames import robot_root_body
from pik_mj.robot.assembly import (
    as_description,
    compile_spec,
    environment_of,
    robot_source,
    robot_spec,
    world_of,
)
from pik_mj.robot.description import RobotDescription
from pik_mj.robot.limbs import Limb
from pik_mj.robot.robot_model import RobotModel
from pik_mj.robot.source import ModelLike, RobotSource
from pik_mj.robot.stance import flat_stance
from pik_mj.robot.world import placement

__all__ = ["Limb", "LimbsNotFound", "Robot", "RobotSource", "robot_root_body"]

STANDING_KEYFRAME = "pik_mj_standing"
"""Name of the keyframe :meth:`Robot.from_model` adds for a robot without any
whose zero pose does not stand flat on its soles (dm_control's humanoid)."""
GROUND_TOLERANCE = 1e-6
"""[m] A floating-base robot whose lowest collision geom is farther than this from
the floor (above or below) at its start pose is moved onto it by
:meth:`Robot.from_model`."""


class Robot(RobotModel):
    """A robot in a MuJoCo model, with its state in a :class:`mink.Configuration`.

    Build one with :meth:`Robot.from_model` (it then owns its world: ``spec``,
    ``source``). ``Robot(model)`` wraps a compiled model as it is (no source: no
    :class:`pik_mj.sim.Scene` can be made from it). Arguments, attributes and
    accessors: :class:`~pik_mj.robot.robot_model.RobotModel`.

    Attributes:
        spec: The robot's world as an :class:`mujoco.MjSpec` (never modified; a
            scene copies it), or None for ``Robot(model)``.
        source: The :class:`RobotSource` that rebuilds it, or None.
        placement: ``(x, y, z, yaw)`` [m, rad] where the robot's model frame was
            put (``at``), or None.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        root_body: str | None = None,
        limbs: Mapping[str, Limb] | None = None,
        keyframe: str | int | None = None,
        description: RobotDescription | None = None,
    ):
        super().__init__(
            model, root_body=root_body, limbs=limbs, keyframe=keyframe, description=description
        )
        self.spec: mujoco.MjSpec | None = None
        self.source: RobotSource | None = None
        self.placement: tuple[float, float, float, float] | None = None
        self._own_nq: int | None = None

    @property
    def own_nq(self) -> int:
        """Length of the robot's own part of ``q``: its MJCF's joints (the robot's,
        and those of other top-level bodies its MJCF has) come first, the
        environment's (e.g. the room's kettle) after them."""
        return super().own_nq if self._own_nq is None else self._own_nq

    @classmethod
    def from_model(
        cls,
        model: ModelLike | None = None,
        *,
        environment: ModelLike | None = None,
        at: str | Sequence[float] | None = None,
        keyframe: str | int | None = None,
        root_body: str | None = None,
        limbs: Mapping[str, Limb] | None = None,
        description: str | os.PathLike[str] | RobotDescription | None = None,
        required_limbs: Sequence[str] = (),
    ) -> Robot:
        """The robot of ``model``, standing in its world, its MJCF as it is shipped.

        Its start pose is a keyframe (:func:`pik_mj.robot.keyframes.choose_keyframe`:
        the one named, else one named like a standing pose, else the first, else
        ``qpos0``), its limbs are found from the kinematic tree in that pose
        (:func:`pik_mj.robot.limbs.find_limbs`), and what the tree does not tell can be
        described (``description``, :mod:`pik_mj.robot.description`). Elements the
        MJCF leaves unnamed get names (:func:`pik_mj.robot.world.name_unnamed`).

        The robot's spec is the host of its world: the robot's top-level body is
        placed at ``at`` (:func:`pik_mj.robot.world.place_root`), and the
        environment is attached into the spec
        (:func:`pik_mj.robot.world.attach_environment`), so the robot's
        ``qpos`` is a prefix of the world's and the robot and the environment's
        objects (e.g. the room's ``kettle_handle`` site) share one world frame. A
        floating-base robot is first moved along z so that its lowest collision
        geom touches z = 0 at its start pose
        (:func:`pik_mj.robot.floor_contact.floor_gap`, when it is farther than
        :data:`GROUND_TOLERANCE`: Robotis OP3's zero pose floats), in its qpos0 and
        its keyframes. A floating-base robot without keyframe whose zero pose has
        tilted soles gets the keyframe :data:`STANDING_KEYFRAME`, its soles turned
        flat (:func:`pik_mj.robot.stance.flat_stance`).

        Args:
            model: Model name (:func:`pik_mj.robot.loading.available_models`, a MuJoCo
                Menagerie robot such as ``"unitree_g1"``), MJCF path, or an
                :class:`mujoco.MjSpec` (copied; its source cannot be written to
                JSON). None: the description's ``model``.
            environment: Environment name, path or spec, or None (the robot alone).
            at: A site of the environment (its position and heading), or
                ``(x, y, yaw)`` / ``(x, y, z, yaw)`` [m, rad]: where the robot's model
                frame goes.
            keyframe: Keyframe of the start pose, by name or index (default: the
                description's, else the rule above).
            root_body: The robot's top-level body (default: the description's,
                else :func:`pik_mj.frames.robot_root_body`).
            limbs: Explicit limb table (default: the description's limbs, the
                others found from the tree).
            description: A robot description file (``.toml``/``.json``) or a
                :class:`~pik_mj.robot.description.RobotDescription`.
            required_limbs: Limb names the caller needs: when one is neither
                described nor found, :class:`~pik_mj.robot.limbs.LimbsNotFound` says so
                here, before any work (what was found, how to describe it).

        Raises:
            UnknownName: Unknown model name, site, keyframe, body, or a described
                frame or joint.
            InvalidInput: A model that does not load or compile, a bad placement
                or description.
            LimbsNotFound: A limb of ``required_limbs`` is not there.
        """
        described = as_description(description)
        if described is not None:
            model = described.model_for(model)
        spec = robot_spec(model, environment)
        alone = compile_spec(spec, f"model {spec.modelname!r}")
        robot = cls(
            alone, root_body=root_body, limbs=limbs, keyframe=keyframe, description=described
        )
        flat = flat_stance(robot) if robot.keyframe is None else None
        if flat is not None:  # the zero pose with its soles made flat: a keyframe
            spec.add_key(name=STANDING_KEYFRAME, qpos=flat.tolist())
            alone = spec.compile()
            robot = cls(
                alone,
                root_body=root_body,
                limbs=limbs,
                keyframe=STANDING_KEYFRAME,
                description=described,
            )
            robot.keyframe_rule = "zero pose, soles made flat"
        robot.require_limbs(required_limbs)
        env_spec, env_model = environment_of(environment)
        p_WR, yaw = (np.zeros(3), 0.0) if at is None else placement(at, env_model)
        dz = -robot.floor_gap() if robot.has_floating_base else 0.0
        if not abs(dz) > GROUND_TOLERANCE:  # within tolerance, or NaN: no collision geom
            dz = 0.0
        world, spec = world_of(
            spec,
            alone,
            robot.root_body_id,
            p_WR,
            yaw,
            placed=at is not None,
            dz=dz,
            environment=env_spec,
        )
        out = cls(
            world,
            root_body=robot.root_body,
            limbs=robot.limbs,
            keyframe=robot.keyframe,
            description=described,
        )
        out.keyframe_rule = robot.keyframe_rule
        out.spec = spec
        out._own_nq = int(alone.nq)
        out.source = robot_source(model, environment, at, keyframe, root_body, description)
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
            description=source.description,
        )
