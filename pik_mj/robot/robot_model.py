"""A robot in a compiled MuJoCo model: irteus' cascaded-link / robot-model.

A :class:`RobotModel` knows which top-level body of its model is the robot (its
*root body*, :func:`pik_mj.frames.robot_root_body`), the robot's joints
(:class:`pik_mj.robot.joints.RobotJoints`), limbs, start pose, feet, sensors and
cameras, and gives irteus-style accessors: ``angle_vector``, ``link_list``,
end-effector frames, mass, centroid and centroid Jacobian. Its state is a
:class:`mink.Configuration`; MuJoCo computes all kinematics.

:class:`pik_mj.robot.Robot` is a :class:`RobotModel` built from a model name,
path or spec and standing in its world (:meth:`pik_mj.robot.Robot.from_model`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import mink
import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, LimbsNotFound, NoCollisionGeometry, UnknownName
from pik_mj.frames import Frame, robot_root_body
from pik_mj.robot.camera import Camera
from pik_mj.robot.description import RobotDescription, robot_limbs
from pik_mj.robot.floor_contact import collision_geoms, floor_gap, geom_id, subtree_bodies
from pik_mj.robot.joints import RobotJoints
from pik_mj.robot.keyframes import choose_keyframe
from pik_mj.robot.limbs import LIMB_NAMES, Limb, find_limbs
from pik_mj.robot.sensors import Bumper, ForceSensor, Imu, RobotSensors

FRAME_TYPES = ("site", "body", "geom")

_FRAME_OBJ = {
    "site": mujoco.mjtObj.mjOBJ_SITE,
    "body": mujoco.mjtObj.mjOBJ_BODY,
    "geom": mujoco.mjtObj.mjOBJ_GEOM,
}
_FRAME_COUNT = {"site": "nsite", "body": "nbody", "geom": "ngeom"}


def _name(model: mujoco.MjModel, obj: mujoco.mjtObj, i: int) -> str:
    return mujoco.mj_id2name(model, obj, i) or ""


def _id(model: mujoco.MjModel, obj: mujoco.mjtObj, name: str) -> int:
    return mujoco.mj_name2id(model, obj, name)


class RobotModel:
    """A robot in a compiled MuJoCo model, with its state in a :class:`mink.Configuration`.

    :meth:`pik_mj.robot.Robot.from_model` builds one standing in its world;
    ``Robot(model)`` wraps a compiled model as it is.

    Args:
        model: The compiled model (a robot alone or with an environment).
        root_body: Name of the robot's top-level body (default: the
            description's, else :func:`robot_root_body`).
        limbs: Explicit limb table ``{name: Limb}``; None: the description's
            limbs, the others found from the kinematic tree in the start pose
            (:func:`pik_mj.robot.description.robot_limbs`; none required).
        keyframe: Keyframe of the start pose (:meth:`reset_pose`), by name or
            index (default: the description's, else
            :func:`pik_mj.robot.keyframes.choose_keyframe`).
        description: What a robot description file states
            (:class:`~pik_mj.robot.description.RobotDescription`), or None.

    Attributes:
        model: The compiled model.
        configuration: The robot's state.
        keyframe: The start pose's keyframe (:meth:`reset_pose`): name, index of an
            unnamed one, or None for ``qpos0``.
        keyframe_rule: Why that keyframe (:func:`pik_mj.robot.keyframes.choose_keyframe`).
        description: The robot description, or None.
        limbs: ``{name: Limb}``, in the order of :data:`pik_mj.robot.limbs.LIMB_NAMES`.
        joint_names: The robot's hinge and slide joints (its angle vector), in model order.
        angle_joint_ids: Their joint ids in :attr:`model`.

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
        keyframe: str | int | None = None,
        description: RobotDescription | None = None,
    ):
        if not isinstance(model, mujoco.MjModel):
            raise InvalidInput(
                f"Robot(model) takes a compiled mujoco.MjModel, got {type(model).__name__}; "
                "use Robot.from_model(name, path or MjSpec)"
            )
        self.model = model
        self.configuration = mink.Configuration(model)
        self._sensors: RobotSensors | None = None
        self.description = description
        top_level = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
        if not top_level:
            raise InvalidInput("the model has no body besides the world")
        if limbs is not None and not (
            isinstance(limbs, Mapping) and all(isinstance(x, Limb) for x in limbs.values())
        ):
            raise InvalidInput(f"limbs must be a mapping of names to Limb, got {limbs!r}")
        if root_body is None and description is not None:
            root_body = description.root_body
        if root_body is not None and not isinstance(root_body, str):
            raise InvalidInput(f"root_body must be a body name, got {type(root_body).__name__}")
        self._root_id = robot_root_body(model, root_body)
        if self._root_id not in top_level:
            names = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in top_level]
            raise InvalidInput(
                f"root_body {root_body!r} is not a top-level body (a child of "
                f"the world). Top-level bodies: {names}"
            )
        self._joints = RobotJoints(model, self._root_id)
        self.angle_joint_ids = self._joints.angle_ids
        self.joint_names: list[str] = self._joints.names
        if keyframe is None and description is not None:
            keyframe = description.keyframe
        self._key_index, self.keyframe_rule = choose_keyframe(model, keyframe)
        self.reset_pose()
        if limbs is None:
            limbs = robot_limbs(
                model, description, self.configuration.q, root_body=self._root_id, required=()
            )
        else:
            for limb in limbs.values():
                self._check_limb(limb)
        order = [n for n in LIMB_NAMES if n in limbs] + [n for n in limbs if n not in LIMB_NAMES]
        self.limbs: dict[str, Limb] = {name: limbs[name] for name in order}

    @property
    def keyframe(self) -> str | int | None:
        """The start pose's keyframe (:meth:`reset_pose`): its name, its index when it
        has none, or None for ``qpos0``; chosen by
        :func:`pik_mj.robot.keyframes.choose_keyframe` (:attr:`keyframe_rule` says why)."""
        if self._key_index is None:
            return None
        return self.model.key(self._key_index).name or self._key_index

    # ------------------------------------------------------------------ limbs
    def _check_limb(self, limb: Limb) -> None:
        for joint in limb.joints:
            self._joints.angle_joint_id(joint)
        for frame, kind in (
            (limb.end_frame, limb.end_frame_type),
            (limb.root_body, "body"),
        ):
            if self.model.body_rootid[self._frame_body_id(frame, kind)] != self._root_id:
                raise InvalidInput(f"limb {limb.name!r}: {kind} {frame!r} is not on the robot")

    def _limb_search(self, names: Sequence[str]) -> LimbsNotFound | None:
        """Why the limbs ``names`` are missing: the error :func:`find_limbs` gives
        when asked for them in the start pose (what it saw and found), or None."""
        missing = [n for n in names if n not in self.limbs]
        if not missing:
            return None
        q = self.configuration.q.copy()
        self.reset_pose()
        try:
            find_limbs(self.model, self.configuration.q, root_body=self._root_id, required=missing)
        except LimbsNotFound as err:
            return LimbsNotFound(str(err.args[0]).split("\n")[0], self.limbs, err.details)
        finally:
            self.configuration.update(q)
        return LimbsNotFound(f"the robot has no limb {missing}", self.limbs, [])

    def require_limbs(self, names: Sequence[str]) -> None:
        """Raise :class:`~pik_mj.robot.limbs.LimbsNotFound` (what was found, how to
        describe the limbs) unless the robot has every limb in ``names``."""
        if isinstance(names, str):
            names = [names]
        error = self._limb_search(list(names))
        if error is not None:
            raise error

    def limb(self, name: str) -> Limb:
        """The limb called ``name`` (irteus ``(send robot :rarm)``).

        Raises:
            UnknownName: No limb ``name`` (lists the robot's limbs; for a name
                :func:`~pik_mj.robot.limbs.find_limbs` gives, such as ``larm``, how to
                describe it). :meth:`require_limbs` says what the search saw.
        """
        try:
            return self.limbs[name]
        except KeyError:
            err = UnknownName("limb", name, self.limbs)
            if name in LIMB_NAMES:
                err.args = (
                    f"{err.args[0]}; the robot's tree does not give it: name it in a robot "
                    "description (Robot.from_model(..., description=PATH))",
                )
            raise err from None

    # ------------------------------------------------------------------ feet
    def floor_gap(self) -> float:
        """Height [m] of the robot's lowest collision geom above the floor z = 0 in
        its current configuration (:func:`pik_mj.robot.floor_contact.floor_gap`; negative: it
        sinks in), NaN for a robot without collision geoms."""
        try:
            return floor_gap(self.model, self.data, self._root_id)
        except NoCollisionGeometry:
            return math.nan

    @property
    def described_soles(self) -> Mapping[str, Sequence[str]]:
        """The sole geoms of the robot description by leg (its ``[soles]``), or ``{}``."""
        return {} if self.description is None else self.description.soles

    def foot_geoms(
        self,
        legs: Sequence[str] = ("rleg", "lleg"),
        *,
        soles: Mapping[str, Sequence[int | str]] | None = None,
    ) -> list[int]:
        """The collision geoms the robot stands on, without repeats: per leg, the
        geoms of ``soles`` (default: :attr:`described_soles`), else every collision
        geom of the leg's foot (the body of its end frame and the bodies below it: toes).

        Legs the robot does not have are skipped (a fixed-base arm stands on nothing).

        Raises:
            UnknownName: A sole geom that does not exist.
        """
        soles = self.described_soles if soles is None else soles
        out: list[int] = []
        for leg in legs:
            if leg in soles:
                out += [geom_id(self.model, g) for g in soles[leg]]
            elif leg in self.limbs:
                limb = self.limbs[leg]
                body = Frame.find(self.model, limb.end_frame, limb.end_frame_type).body_id
                out += collision_geoms(self.model, subtree_bodies(self.model, body)).tolist()
        return list(dict.fromkeys(out))

    # ------------------------------------------------- sensors and cameras
    def bodies(self, limb: str | None = None) -> list[str]:
        """Names of the robot's bodies (the subtree of its root body), or of
        ``limb``'s: the subtree of its first link (a leg with its foot) without
        the other limbs that start inside it (a torso without the arms and head).

        Raises:
            UnknownName: No limb ``limb``.
        """
        if limb is None:
            ids = subtree_bodies(self.model, self._root_id)
        else:
            own = self.model.body(self.limb(limb).root_body).id
            ids = subtree_bodies(self.model, own)
            for other in self.limbs.values():
                start = self.model.body(other.root_body).id
                if start != own and start in ids:
                    ids = np.setdiff1d(ids, subtree_bodies(self.model, start))
        return [self.model.body(int(b)).name for b in np.sort(ids)]

    def sensors(self, limb: str | None = None) -> RobotSensors:
        """The MJCF sensors on the robot's bodies: force/torque sensors, IMUs
        and bumpers (:class:`pik_mj.robot.sensors.RobotSensors`; irteus manual: ``(send robot
        :force-sensors)``), or only those on ``limb``'s bodies (irteus manual: ``(send
        robot :rleg :force-sensors)``). An environment's sensors are not the
        robot's.

        Raises:
            UnknownName: No limb ``limb``.
        """
        if self._sensors is None:
            self._sensors = RobotSensors.from_model(self.model, bodies=self.bodies())
        if limb is None:
            return self._sensors
        return self._sensors.by_limb({limb: self.bodies(limb)})[limb]

    @property
    def force_sensors(self) -> tuple[ForceSensor, ...]:
        """The robot's 6-axis force/torque sensors (irteus manual: ``:force-sensors``)."""
        return self.sensors().force_sensors

    @property
    def imu_sensors(self) -> tuple[Imu, ...]:
        """The robot's IMUs (irteus manual: ``:imu-sensors``)."""
        return self.sensors().imu_sensors

    @property
    def bumpers(self) -> tuple[Bumper, ...]:
        """The robot's touch sensors read on/off (irteus manual: ``bumper-model``)."""
        return self.sensors().bumpers

    @property
    def cameras(self) -> tuple[Camera, ...]:
        """The perspective MJCF cameras on the robot's bodies, in model order
        (irteus manual: ``:cameras``), each with its MJCF resolution
        (:class:`pik_mj.robot.camera.Camera`)."""
        mine = set(subtree_bodies(self.model, self._root_id).tolist())
        perspective = int(mujoco.mjtProjection.mjPROJ_PERSPECTIVE)
        return tuple(
            Camera(self.model, self.model.camera(c).name)
            for c in range(self.model.ncam)
            if int(self.model.cam_bodyid[c]) in mine
            and int(self.model.cam_projection[c]) == perspective
        )

    def camera(self, name: str) -> Camera:
        """The robot's camera ``name`` (irteus manual: ``(send robot :camera name)``).

        Raises:
            UnknownName: Not one of :attr:`cameras` (lists them).
        """
        cameras = {c.name: c for c in self.cameras}
        if name not in cameras:
            raise UnknownName("camera of the robot", name, cameras)
        return cameras[name]

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
        return self._joints.qpos_end()

    @property
    def free_qposadr(self) -> int | None:
        """Index in ``q`` of the root body's free joint (7 entries: position, then
        quaternion w x y z), or None for a fixed base."""
        return self._joints.free_qposadr()

    @property
    def has_floating_base(self) -> bool:
        """Whether the root body's first joint is a free joint."""
        return self.free_qposadr is not None

    def angle_vector(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Joint positions [rad or m] (irteus ``:angle-vector``).

        Args:
            names: Hinge/slide joint names; all of :attr:`joint_names` if None.

        Returns:
            Array of shape (len(names),), a copy.
        """
        return self.data.qpos[self._joints.qpos_addresses(names)].copy()

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
        adr = self._joints.qpos_addresses(names)
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
        adr = self._joints.free_qposadr()
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

    def start_q(self) -> np.ndarray:
        """The start configuration (nq,): keyframe :attr:`keyframe`, or ``qpos0``; a copy."""
        k = self._key_index
        return (self.model.qpos0 if k is None else self.model.key_qpos[k]).copy()

    def reset_pose(self) -> None:
        """Go to the start pose: keyframe :attr:`keyframe`, or ``qpos0`` without one."""
        self.configuration.update(self.start_q())

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
            for i, j in enumerate(self.angle_joint_ids)
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
        return self._joints.limits(names)

    def __repr__(self) -> str:
        model_name = self.model.names[: self.model.names.index(b"\0")].decode()
        return (
            f"{type(self).__name__}(model={model_name!r}, root_body={self.root_body!r}, "
            f"floating_base={self.has_floating_base}, joints={len(self.joint_names)}, "
            f"nv={self.model.nv}, limbs={list(self.limbs)}, mass={self.mass:.3f} kg)"
        )
