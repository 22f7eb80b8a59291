r"""The physics scene of a robot's world: :class:`Scene` (DESIGN.md §5).

A :class:`Scene` is made from a :class:`pik_mj.Robot` (:meth:`Scene.from_robot`):
its spec is a copy of the robot's world (``robot.spec``) plus a floor plane when
the world has none, an environment (only for a robot that has none of its own),
a position servo on every robot hinge/slide joint, contact parameters and grasp
welds. The robot's configuration ``q`` (``robot.configuration.q``, the robot
model's ``nq``) is a prefix of the scene's ``qpos``: :meth:`Scene.set_pose`
writes it as it is, no joint is mapped by name, and IK and physics share one
world frame (targets read from the scene are IK targets).

Modelling choices (documented here once):

* **Servos** (:mod:`pik_mj.sim.servos`): a position servo
  ``τ = kp (q_ref - q) - kv q̇`` on every robot hinge/slide joint: the robot's
  own position actuator where it has one (its gains, its control set to the
  target), else a MuJoCo position actuator the scene adds, with gains from the
  robot's joint-space inertia (``kp = ω² M_jj``, ``kv = 2 ζ ω M_jj``). The
  robot's other actuators (motors) stay at zero control, which exerts nothing.
  :meth:`Scene.hold` adds the static feed-forward of
  :func:`pik_mj.sim.hold.holding_torques`, so the pose starts in equilibrium
  instead of sagging by ``τ_gravity / kp``. The integrator is ``implicitfast``,
  which treats ``kv`` implicitly.
* **Contact pairs**: the robot's explicit ``<contact><pair>``\ s are kept (they
  come with its spec), with the scene's contact parameters.
* **Friction**: elliptic cones with ``impratio = 10`` (MuJoCo's advice against
  the slow creep of soft contacts under a sustained tangential load). The
  equilibrium LP uses an inscribed pyramid, so it is the more conservative of
  the two.
* **Contact parameters** (:class:`ContactParams`) are written on the robot's
  geoms and on the environment's static geoms: MuJoCo combines friction by
  taking the maximum, so both sides must carry ``μ``.
* **Contact stiffness** (:data:`DEFAULT_CONTACT`): ``solref = (0.005, 1)``, a
  hard sole on a hard floor, instead of MuJoCo's soft default ``(0.02, 1)``. A
  hold starts from rest with no contact force: the robot first sinks into the
  floor until the contacts carry it, and while they build up the centre of
  pressure is where the soles sink, not under the CoM. MuJoCo's contact spring
  scales as ``1 / timeconst²``: at ``reset_pose`` a sole corner sinks 0.6 mm
  with 0.02 s and 0.06 mm with 0.005 s (measured). Tipping over an edge at
  distance ``r`` from the CoM at height ``h`` only needs the energy of raising
  the CoM by ``r² / 2h`` (0.35 mm for r = 2 cm, h = 0.57 m), which the soft
  settling transient supplied in crouched reaches with a 2 cm margin (the robot
  rolled over the sole edge); the hard contact settles ten times shallower.
  0.005 s is 2.5 time steps, above MuJoCo's floor of two (checked).
* **Touching geoms**: MuJoCo reports a contact only for ``dist < margin``; feet
  placed exactly on the floor have ``dist = 0``. :meth:`Scene.static_check`
  therefore runs collision detection on a copy of the model whose robot geoms
  have ``geom_margin = contact_tolerance`` and keeps contacts with
  ``dist <= contact_tolerance``. The physics model keeps the original margins
  (a margin there would make the contacts push at a distance).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import balance, inputs
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.frames import Frame
from pik_mj.robot.ground import foot_geoms
from pik_mj.robot.world import EnvironmentLike, add_floor, attach_environment, has_plane
from pik_mj.sim.guard import StateGuard
from pik_mj.sim.servos import (
    DEFAULT_BANDWIDTH,
    DEFAULT_DAMPING_RATIO,
    position_actuators,
    position_feedback,
    rest_controls,
    servo_gains,
)
from pik_mj.sim.static import ContactInfo, StaticChecks, StaticReport
from pik_mj.sim.static import static_check as _static_check
from pik_mj.spatial import matrix_to_quat, quat_to_matrix

if TYPE_CHECKING:
    from pik_mj.robot import Robot
    from pik_mj.sim.hold import HoldCriteria, HoldReport
    from pik_mj.sim.motion import MotionReport, PhysicsState, Waypoints

__all__ = ["DEFAULT_CONTACT", "ContactParams", "Grasp", "Scene"]

_ANGLE_JOINTS = (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)

External = tuple[str, ArrayLike, ArrayLike]
"""``(frame, force (3,) [N], moment (3,) [N·m])``: a wrench acting on the robot, the
force at the frame's origin (a site or body of the scene), world frame."""


@dataclass(frozen=True)
class ContactParams:
    """Contact parameters written on robot geoms and static environment geoms.

    Attributes:
        friction: Sliding friction coefficient μ [-].
        torsional: Torsional friction [m] (used with condim >= 4).
        rolling: Rolling friction [m] (used with condim 6).
        condim: Contact dimension (1, 3, 4 or 6). 3: point contact with friction.
        solref: ``(timeconst [s], dampratio)``; MuJoCo's default (0.02, 1) here,
            :data:`DEFAULT_CONTACT` (the :class:`Scene` default) uses 0.005 s.
        solimp: MuJoCo's default impedance ``(0.9, 0.95, 0.001, 0.5, 2)``.
    """

    friction: float = 1.0
    torsional: float = 0.005
    rolling: float = 0.0001
    condim: int = 3
    solref: tuple[float, float] = (0.02, 1.0)
    solimp: tuple[float, float, float, float, float] = (0.9, 0.95, 0.001, 0.5, 2.0)

    def __post_init__(self) -> None:
        if isinstance(self.condim, bool) or self.condim not in (1, 3, 4, 6):
            raise InvalidInput(f"condim must be 1, 3, 4 or 6, got {self.condim!r}")
        inputs.real(self.friction, "friction", low=0)
        inputs.real(self.torsional, "torsional", unit="m", low=0)
        inputs.real(self.rolling, "rolling", unit="m", low=0)
        inputs.vector(self.solref, 2, "solref (timeconst [s], dampratio)")
        inputs.vector(self.solimp, 5, "solimp")


DEFAULT_CONTACT = ContactParams(solref=(0.005, 1.0))
"""Contacts of :class:`Scene`: friction 1, a hard contact (``timeconst`` 5 ms; see
the module docstring), MuJoCo's impedance."""


@dataclass(frozen=True)
class Grasp:
    r"""An object held rigidly by a robot frame (a hand).

    The object O is a top-level body with a free joint that is not the robot
    (e.g. the room's ``kettle``). In a :class:`Scene` with this grasp its pose
    follows the robot: for every robot configuration ``q``

    .. math::

        X_{WO}(q) = X_{WF}(q)\, X_{FO}, \qquad
        p_{WO} = p_{WF} + R_{WF}\, p_{FO}, \quad R_{WO} = R_{WF} R_{FO}

    and in the physics a MuJoCo weld equality between the frame's body and O
    keeps that relative pose (MuJoCo computes the constraint force, so the
    object's weight loads the arm and the balance). The object belongs to the
    system: its mass counts in the CoM and the equilibrium of
    :meth:`Scene.static_check`, its contacts with the environment are the
    system's, its contacts with the robot self-contacts; contacts between the
    frame's body and O (the grip) are excluded.

    Attributes:
        frame: Robot site or body name F (e.g. ``"rarm_end"``).
        body: Object body name O.
        p_FO: Position of O's body frame in F (3,) [m].
        R_FO: Orientation of O's body frame in F (3, 3) [-].
    """

    frame: str
    body: str
    p_FO: np.ndarray
    R_FO: np.ndarray

    def __post_init__(self) -> None:
        p = np.asarray(self.p_FO, dtype=float).reshape(-1)
        R = np.asarray(self.R_FO, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InvalidInput(f"grasp of {self.body!r}: p_FO must be 3 finite numbers [m]")
        if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-6):
            raise InvalidInput(f"grasp of {self.body!r}: R_FO must be a 3x3 rotation matrix")
        object.__setattr__(self, "p_FO", p)
        object.__setattr__(self, "R_FO", R)

    def to_dict(self) -> dict[str, Any]:
        """``{"frame", "body", "p_FO" [m], "R_FO"}``, JSON-ready."""
        return {
            "frame": self.frame,
            "body": self.body,
            "p_FO": self.p_FO.tolist(),
            "R_FO": self.R_FO.tolist(),
        }


GraspLike = Grasp | tuple[str, str] | tuple[str, str, ArrayLike, ArrayLike]


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) or "" for i in range(count)]


def _compile(spec: mujoco.MjSpec) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as err:
        raise InvalidInput(f"the scene does not compile: {err}") from err


class Scene:
    """The physics scene of a robot's world, with joint servos, for balance checks.

    Make one with :meth:`from_robot`.

    Attributes:
        robot: The :class:`pik_mj.Robot` it was made from.
        spec: The scene spec.
        model: The physics model.
        data: The physics state.
        root_body: Name of the robot's top-level body.
        mass: Robot mass [kg].
        servo_joints: Joints with a position servo (the robot's hinge/slide joints).
        servo_gains: ``{joint: (kp, kv)}`` of the servos, in joint space
            [N·m/rad, N·m·s/rad] (or [N/m, N·s/m] for slide joints).
        servo_actuators: ``{joint: actuator id}`` of the servos in :attr:`model`.
        robot_servos: The joints whose servo is the robot's own position actuator
            (:func:`pik_mj.sim.servos.position_actuators`); the others have one
            the scene added (``<joint>_servo``).
        allowed_contacts: Robot geoms allowed to touch the environment in a hold
            by default.
        foot_geoms: The robot's foot geoms (:func:`pik_mj.robot.ground.foot_geoms`): a
            hold's foot slip is theirs.
        contact_tolerance: Distance [m] within which :meth:`static_check` counts
            two geoms as touching.
        grasps: The :class:`Grasp` list.
        exclude: Body pairs whose contacts are excluded.
        carried_mass: Mass of the grasped objects [kg].
    """

    def __init__(
        self,
        robot: Robot,
        *,
        environment: EnvironmentLike | None = None,
        timestep: float = 0.002,
        kp: float | Mapping[str, float] | None = None,
        kv: float | Mapping[str, float] | None = None,
        bandwidth: float = DEFAULT_BANDWIDTH,
        damping_ratio: float = DEFAULT_DAMPING_RATIO,
        contact: ContactParams | None = DEFAULT_CONTACT,
        contact_tolerance: float = 2e-3,
        allowed_contacts: Sequence[str] | None = None,
        impratio: float = 10.0,
        noslip_iterations: int = 0,
        grasps: Sequence[GraspLike] = (),
        exclude: Sequence[tuple[str, str]] = (),
    ):
        """The physics scene of ``robot``'s world.

        Args:
            robot: A robot made by :meth:`pik_mj.Robot.from_model` (it has a spec).
            environment: Model name, MJCF path or spec (e.g. from
                :func:`floor_environment` + :func:`add_wall`) attached into the
                world, for a robot placed in none (``Robot.from_model(...,
                environment=...)`` places it in one).
            timestep: Physics time step [s].
            kp: Stiffness [N·m/rad] (or [N/m] for slide joints) of the servos the
                scene adds: a float, or a mapping joint name -> kp; None (and
                joints missing from a mapping): ``ω² M_jj``
                (:func:`pik_mj.sim.servos.servo_gains`). A joint driven by the
                robot's own position actuator keeps that actuator's gains.
            kv: Damping [N·m·s/rad] of the servos the scene adds, as ``kp``;
                None: ``2 ζ ω M_jj``.
            bandwidth: ``ω`` [rad/s] of the derived gains.
            damping_ratio: ``ζ`` [-] of the derived gains.
            contact: Contact parameters for the robot and the static environment,
                or None to keep the models' own. A positive ``solref`` time constant
                must be at least two time steps (MuJoCo's stability floor).
            contact_tolerance: Distance [m] within which :meth:`static_check`
                counts two geoms as touching.
            allowed_contacts: Robot geoms allowed to touch the environment in
                :meth:`hold`; default: the robot's feet
                (:func:`pik_mj.robot.ground.foot_geoms`).
            impratio: Ratio of frictional to normal constraint impedance (MuJoCo
                ``impratio``). With the default elliptic friction cones, 10 keeps
                the soft-contact creep of a loaded foot below ~0.2 mm/s (1: ~3 mm/s).
            noslip_iterations: MuJoCo's no-slip solver iterations (0: off); 5
                removes the remaining creep at ~30% more time per step.
            grasps: Objects held by robot frames: ``(frame, body)`` pairs, whose
                relative pose ``X_FO = X_WF⁻¹ X_WO`` is read at the robot's current
                configuration (carry the object with the hand first), or
                :class:`Grasp`\\ s / ``(frame, body, p_FO, R_FO)``. Each object's
                pose then follows the robot and a weld equality (``solref`` of
                ``contact``, else MuJoCo's) holds it in the physics.
            exclude: Body pairs ``(body1, body2)`` that never touch (MJCF
                ``<contact><exclude>``), e.g. a hand without fingers and the
                object it is about to grasp: the open fingers pass around the
                handle, which ends inside the hand's box.

        Raises:
            InvalidInput: A robot without a source (``Robot(model)``), an
                environment for a robot that has one, bad options, or a scene
                that does not compile.
            UnknownName: Unknown joint in ``kp``/``kv``, geoms in
                ``allowed_contacts``, frames or bodies in ``grasps``, bodies in
                ``exclude``.
        """

        from pik_mj.robot import Robot

        if not isinstance(robot, Robot):
            raise InvalidInput(
                f"Scene.from_robot takes a pik_mj.Robot, got {type(robot).__name__}; "
                "make one with Robot.from_model(name, path or MjSpec)"
            )
        if robot.spec is None:
            raise InvalidInput(
                "this Robot was made from a compiled MjModel and does not know its world; "
                "make it with Robot.from_model(name, path or MjSpec) to build its Scene"
            )
        impratio = inputs.real(impratio, "impratio", low=1)
        timestep = inputs.real(timestep, "timestep", unit="s", low=0, low_open=True)
        contact_tolerance = inputs.real(contact_tolerance, "contact_tolerance", unit="m", low=0)
        if contact is not None and not isinstance(contact, ContactParams):
            raise InvalidInput(f"contact must be a ContactParams or None, got {contact!r}")
        if isinstance(grasps, (str, bytes)) or not isinstance(grasps, Sequence):
            raise InvalidInput(f"grasps must be a list of grasps, got {grasps!r}")
        if contact is not None and 0 < contact.solref[0] < 2 * timestep:
            raise InvalidInput(
                f"contact solref time constant {contact.solref[0]} s is below two time "
                f"steps ({2 * timestep} s): MuJoCo's contacts become unstable; raise it "
                f"or lower the time step"
            )
        noslip_iterations = inputs.integer(noslip_iterations, "noslip_iterations", low=0)
        bandwidth = inputs.real(bandwidth, "bandwidth", unit="rad/s", low=0, low_open=True)
        damping_ratio = inputs.real(damping_ratio, "damping_ratio", low=0)
        self.robot = robot
        rm = robot.model
        spec = robot.spec.copy()
        if environment is not None:
            if robot.source is not None and robot.source.environment is not None:
                raise InvalidInput(
                    f"the robot already stands in environment {robot.source.environment!r}; "
                    "a Scene adds an environment only to a robot without one"
                )
            spec = attach_environment(spec, environment)
        if not has_plane(rm if environment is None else _compile(spec)):
            add_floor(spec)
        spec.option.timestep = float(timestep)
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = float(impratio)
        spec.option.noslip_iterations = noslip_iterations
        self.contact_tolerance = float(contact_tolerance)

        # A servo on every robot hinge/slide joint (ids shared with the robot's
        # model: its joints and actuators come first): the robot's own position
        # actuator where it has one, else one the scene adds.
        servo_ids = [int(j) for j in robot.angle_joint_ids]
        self.servo_joints = [rm.joint(j).name for j in servo_ids]
        own = position_actuators(rm, servo_ids)
        self.robot_servos = [rm.joint(j).name for j in servo_ids if j in own]
        added = [j for j in servo_ids if j not in own]
        n_old_actuators = len(spec.actuators)
        self.servo_gains = {rm.joint(j).name: (kp_j, kv_j) for j, (_, kp_j, kv_j) in own.items()}
        self.servo_gains.update(
            self._gains(
                added,
                kp,
                kv,
                servo_gains(rm, robot.start_q(), added, bandwidth, damping_ratio),
            )
        )
        for j in added:
            joint = rm.joint(j).name
            act = spec.add_actuator(
                name=f"{joint}_servo", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT
            )
            act.set_to_position(kp=self.servo_gains[joint][0], kv=self.servo_gains[joint][1])
        self.servo_actuators = {rm.joint(j).name: a for j, (a, _, _) in own.items()}
        self.servo_actuators.update(
            {rm.joint(j).name: n_old_actuators + i for i, j in enumerate(added)}
        )
        self.servo_actuators = {j: self.servo_actuators[j] for j in self.servo_joints}
        self._extend_keyframe_ctrl(spec, n_old_actuators)
        model = _compile(spec)
        self._check_prefix(model)

        self.root_body = robot.root_body
        root_id = robot.root_body_id
        self._robot_body = np.asarray(model.body_rootid) == root_id
        self._robot_geom = self._robot_body[model.geom_bodyid]
        if contact is not None:
            self._apply_contact(spec, model, contact)
        self.grasps = self._parse_grasps(model, grasps)
        self._add_grasps(spec, model, contact)
        self.exclude = self._add_excludes(spec, model, exclude)
        if contact is not None or self.grasps or self.exclude:
            model = _compile(spec)
        self.spec = spec
        self.model = model
        self.data = mujoco.MjData(model)
        self._guard = StateGuard(model, self.data)
        self._root_id = root_id
        self.mass = float(model.body_subtreemass[root_id])
        # Grasped objects are part of the system: CoM, contacts, equilibrium.
        self._grasp_frames = [Frame.find(model, g.frame) for g in self.grasps]
        self._grasp_bodies = np.array([model.body(g.body).id for g in self.grasps], dtype=int)
        self._grasp_qadr = [
            int(model.jnt_qposadr[model.body_jntadr[b]]) for b in self._grasp_bodies
        ]
        self.carried_mass = float(model.body_subtreemass[self._grasp_bodies].sum())
        self._system_body = self._robot_body.copy()
        for b in self._grasp_bodies:
            self._system_body |= np.asarray(model.body_rootid) == b
        self._robot_geom = self._system_body[model.geom_bodyid]
        self._kin_data = mujoco.MjData(model)
        self._position_actuators = np.flatnonzero(position_feedback(model))
        self._servo_dofs = np.array(rm.jnt_dofadr[servo_ids], dtype=int)
        # Collision-only copy whose robot geoms carry the contact tolerance.
        self._probe_model = copy.copy(model)
        self._probe_model.geom_margin[self._robot_geom] = self.contact_tolerance
        robot_pairs = self._robot_geom[model.pair_geom1] | self._robot_geom[model.pair_geom2]
        self._probe_model.pair_margin[robot_pairs] = self.contact_tolerance
        self._probe_data = mujoco.MjData(self._probe_model)
        self._geom_names = _names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom)
        self._body_names = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
        self._geom_id = {n: g for g, n in enumerate(self._geom_names) if n}
        rm = robot.model
        self.foot_geoms = [rm.geom(g).name for g in foot_geoms(robot)]
        self.allowed_contacts = self._allowed(allowed_contacts)

    @classmethod
    def from_robot(cls, robot: Robot, **options: Any) -> Scene:
        """The physics scene of ``robot``'s world: ``Scene(robot, **options)``
        (the options are :class:`Scene`'s).

        Raises:
            UnknownName: An option :class:`Scene` does not have (lists them).
        """
        inputs.options(options, cls.__init__, "Scene option", positional=("robot",))
        return cls(robot, **options)

    # ------------------------------------------------------------ construction
    def _check_prefix(self, model: mujoco.MjModel) -> None:
        """The robot's joints come first in the scene, at the same addresses."""
        rm = self.robot.model
        same = (
            model.nq >= rm.nq
            and model.njnt >= rm.njnt
            and np.array_equal(model.jnt_type[: rm.njnt], rm.jnt_type)
            and np.array_equal(model.jnt_qposadr[: rm.njnt], rm.jnt_qposadr)
            and np.array_equal(model.jnt_dofadr[: rm.njnt], rm.jnt_dofadr)
        )
        if not same:
            raise PikError(
                "the scene's joints do not start with the robot's: its configuration "
                "would not be a prefix of the scene's qpos"
            )

    def _gains(
        self,
        joints: Sequence[int],
        kp: float | Mapping[str, float] | None,
        kv: float | Mapping[str, float] | None,
        derived: tuple[np.ndarray, np.ndarray],
    ) -> dict[str, tuple[float, float]]:
        """``{joint: (kp, kv)}`` of the servos the scene adds on ``joints``: the
        given gains, else the ``derived`` ones."""
        names = [self.robot.model.joint(j).name for j in joints]
        for value in (kp, kv):
            if isinstance(value, Mapping):
                for joint in value:
                    if joint in self.robot_servos:
                        raise InvalidInput(
                            f"joint {joint!r} is driven by the robot's own position actuator: "
                            "its gains are the actuator's (set them in the MJCF)"
                        )
                    if joint not in names:
                        raise UnknownName("joint", joint, names)
        out = {}
        for joint, p0, v0 in zip(names, *derived, strict=True):
            p = kp.get(joint, p0) if isinstance(kp, Mapping) else (p0 if kp is None else kp)
            v = kv.get(joint, v0) if isinstance(kv, Mapping) else (v0 if kv is None else kv)
            out[joint] = (
                inputs.real(p, f"kp of joint {joint!r}", unit="N·m/rad", low=0, low_open=True),
                inputs.real(v, f"kv of joint {joint!r}", unit="N·m·s/rad", low=0),
            )
        return out

    def _extend_keyframe_ctrl(self, spec: mujoco.MjSpec, n_old: int) -> None:
        """Keyframes that set ``ctrl`` get the servo targets of their own pose."""
        if not any(len(key.ctrl) for key in spec.keys):
            return
        model = _compile(spec)  # servos not counted in key_ctrl yet: compile first
        for k in range(model.nkey):
            key = spec.keys[k]
            if len(key.ctrl) == 0:
                continue
            qpos = model.key_qpos[k]
            added = [j for j in self.servo_joints if j not in self.robot_servos]
            targets = [qpos[model.jnt_qposadr[model.joint(j).id]] for j in added]
            key.ctrl = list(key.ctrl)[:n_old] + [float(t) for t in targets]

    def _apply_contact(
        self, spec: mujoco.MjSpec, model: mujoco.MjModel, contact: ContactParams
    ) -> None:
        static = np.asarray(model.body_weldid)[model.geom_bodyid] == 0
        targets = self._robot_geom | static
        for geom in spec.geoms:
            if not targets[geom.id]:  # geom.id: its index in the compiled model
                continue
            geom.friction = [contact.friction, contact.torsional, contact.rolling]
            geom.condim = contact.condim
            geom.solref = list(contact.solref)
            geom.solimp = list(contact.solimp)
        # Explicit <contact><pair>s carry their own parameters, which override
        # the geoms' (MuJoCo): those with a robot geom get the same ones.
        names = {model.geom(g).name for g in np.flatnonzero(targets)}
        for pair in spec.pairs:
            if pair.geomname1 in names or pair.geomname2 in names:
                mu = [contact.friction, contact.friction, contact.torsional]
                pair.friction = [*mu, contact.rolling, contact.rolling]
                pair.condim = contact.condim
                pair.solref = list(contact.solref)
                pair.solimp = list(contact.solimp)

    def _parse_grasps(self, model: mujoco.MjModel, grasps: Sequence[GraspLike]) -> list[Grasp]:
        """:class:`Grasp`\\ s; for ``(frame, body)`` pairs X_FO is read in this model
        at the robot's current configuration (environment at ``qpos0``)."""
        out: list[Grasp] = []
        d = None
        for g in grasps:
            if isinstance(g, Grasp):
                out.append(g)
                continue
            if not isinstance(g, (tuple, list)) or len(g) not in (2, 4):
                raise InvalidInput(
                    f"a grasp is (frame, body), (frame, body, p_FO, R_FO) or a Grasp, got {g!r}"
                )
            if len(g) == 4:
                out.append(Grasp(*g))
                continue
            frame, body = g
            if d is None:
                d = mujoco.MjData(model)
                d.qpos[: self.robot.model.nq] = self.robot.configuration.q
                mujoco.mj_kinematics(model, d)
            self._check_grasp_names(model, frame, body)
            F = Frame.find(model, frame)
            b = model.body(body).id
            R_WF = F.rotation(d)
            R_WO = d.xmat[b].reshape(3, 3)
            p_FO = R_WF.T @ (d.xpos[b] - F.position(d))
            out.append(Grasp(frame, body, p_FO, R_WF.T @ R_WO))
        return out

    def _grasp_candidates(self, model: mujoco.MjModel) -> tuple[list[str], list[str]]:
        """Robot frames (sites and bodies) and free top-level bodies of the environment."""
        sites = [
            n
            for i, n in enumerate(_names(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite))
            if n and self._robot_body[model.site_bodyid[i]]
        ]
        bodies = [
            n
            for i, n in enumerate(_names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody))
            if n and self._robot_body[i]
        ]
        objects = [
            model.body(b).name
            for b in range(1, model.nbody)
            if model.body_parentid[b] == 0
            and not self._robot_body[b]
            and model.body_jntnum[b] == 1
            and model.jnt_type[model.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE
        ]
        return sites + bodies, objects

    def _check_grasp_names(self, model: mujoco.MjModel, frame: str, body: str) -> None:
        frames, objects = self._grasp_candidates(model)
        if frame not in frames:
            raise UnknownName("robot frame (site or body)", frame, frames)
        if body not in objects:
            raise UnknownName("free environment body", body, objects)

    def _add_grasps(
        self, spec: mujoco.MjSpec, model: mujoco.MjModel, contact: ContactParams | None
    ) -> None:
        """A weld ``(frame's body B, object O)`` with ``relpose = X_BO = X_BF X_FO``
        and a contact exclusion of ``(B, O)`` per grasp (names checked)."""
        seen: set[str] = set()
        for g in self.grasps:
            self._check_grasp_names(model, g.frame, g.body)
            if g.body in seen:
                raise InvalidInput(f"body {g.body!r} is grasped twice")
            seen.add(g.body)
            frame = Frame.find(model, g.frame)
            body = frame.body_id
            if frame.frame_type == "site":
                p_BF = np.array(model.site_pos[frame.id])
                R_BF = quat_to_matrix(model.site_quat[frame.id])
            else:
                p_BF, R_BF = np.zeros(3), np.eye(3)
            p_BO = p_BF + R_BF @ g.p_FO
            quat_BO = matrix_to_quat(R_BF @ g.R_FO)
            weld = spec.add_equality(
                name=f"grasp_{g.body}",
                type=mujoco.mjtEq.mjEQ_WELD,
                objtype=mujoco.mjtObj.mjOBJ_BODY,
                name1=model.body(body).name,
                name2=g.body,
            )
            # data: anchor (3) in O, relpose X_BO (3 + 4), torque scale.
            weld.data = np.r_[np.zeros(3), p_BO, quat_BO, 1.0, np.zeros(len(weld.data) - 11)]
            if contact is not None:
                weld.solref = list(contact.solref)
            spec.add_exclude(bodyname1=model.body(body).name, bodyname2=g.body)

    @staticmethod
    def _add_excludes(
        spec: mujoco.MjSpec, model: mujoco.MjModel, exclude: Sequence[tuple[str, str]]
    ) -> list[tuple[str, str]]:
        """A contact exclusion per body pair of ``exclude`` (names checked)."""
        if isinstance(exclude, (str, bytes)) or not isinstance(exclude, Sequence):
            raise InvalidInput(f"exclude must be a list of (body1, body2) pairs, got {exclude!r}")
        bodies = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
        out = []
        for pair in exclude:
            if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
                raise InvalidInput(f"exclude takes (body1, body2) pairs, got {pair!r}")
            for name in pair:
                if name not in bodies:
                    raise UnknownName("body", name, [b for b in bodies if b])
            spec.add_exclude(bodyname1=pair[0], bodyname2=pair[1])
            out.append((str(pair[0]), str(pair[1])))
        return out

    def _allowed(self, allowed: Sequence[str] | None) -> list[str]:
        robot_geoms = [n for g, n in enumerate(self._geom_names) if self._robot_geom[g] and n]
        if allowed is None:
            return list(self.foot_geoms)
        allowed = inputs.names(allowed, "allowed contacts (robot geoms)")
        for name in allowed:
            if name not in robot_geoms:
                raise UnknownName("robot geom", name, robot_geoms)
        return list(allowed)

    # -------------------------------------------------------------------- pose
    @property
    def robot_nq(self) -> int:
        """Length of a robot configuration (the robot model's ``nq``)."""
        return int(self.robot.model.nq)

    def _qpos(self, q: ArrayLike, base: np.ndarray | None = None) -> np.ndarray:
        """The scene's ``qpos``: ``q`` in its first ``robot_nq`` entries, the rest
        from ``base`` (default ``qpos0``), grasped objects at ``X_WF(q) X_FO``."""
        q = inputs.configuration(self.robot.model, q, "q (the robot's configuration)")
        out = (self.model.qpos0 if base is None else base).copy()
        out[: self.robot_nq] = q
        if self.grasps:
            d = self._kin_data
            d.qpos[:] = out
            mujoco.mj_kinematics(self.model, d)
            for g, frame, adr in zip(
                self.grasps, self._grasp_frames, self._grasp_qadr, strict=True
            ):
                R_WF = frame.rotation(d)
                out[adr : adr + 3] = frame.position(d) + R_WF @ g.p_FO
                out[adr + 3 : adr + 7] = matrix_to_quat(R_WF @ g.R_FO)
        return out

    def kinematics(self, q: ArrayLike, data: mujoco.MjData | None = None) -> mujoco.MjData:
        """MuJoCo's kinematics of the scene at the robot configuration ``q``
        (the environment at ``qpos0``, grasped objects in their frames): the
        poses of bodies, geoms and sites (``mj_kinematics``) and the subtree
        centres of mass (``mj_comPos``), in ``data`` (default: a new
        ``MjData`` of :attr:`model`, the physics state untouched). For
        distances along a path (``mj_geomDistance``), camera views, the CoM
        (:meth:`com`).

        Raises:
            InvalidInput: ``q`` is not a finite configuration of the robot, or
                ``data`` is not of :attr:`model`.
        """
        if data is None:
            data = mujoco.MjData(self.model)
        elif not isinstance(data, mujoco.MjData) or data.qpos.shape != (self.model.nq,):
            raise InvalidInput("data must be an MjData of the scene's model (scene.model)")
        data.qpos[:] = self._qpos(q)
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        return data

    def set_pose(self, q: ArrayLike) -> None:
        """Write the robot configuration ``q`` into the physics state: zero
        velocity, ``mj_forward``, and every actuator's control at rest there: the
        servos' (the scene's and the robot's own position actuators') targets at
        the pose (:func:`pik_mj.sim.servos.rest_controls`; their activations
        too), zero for the others (motors). The other joints keep their state
        (grasped objects follow their frames)."""
        m, d = self.model, self.data
        d.qpos[:] = self._qpos(q, base=d.qpos)
        d.qvel[:] = 0.0
        d.ctrl[:] = 0.0
        d.act[:] = 0.0
        mujoco.mj_fwdPosition(m, d)
        servos = self._position_actuators
        d.ctrl[servos] = rest_controls(m, d, servos)
        for a in servos[m.actuator_actnum[servos] > 0]:
            d.act[m.actuator_actadr[a]] = d.ctrl[a]
        mujoco.mj_forward(m, d)

    def com(self, data: mujoco.MjData | None = None) -> np.ndarray:
        r"""Centre of mass ``p_WG`` (3,) [m] of the robot and its grasped objects
        in ``data`` (default: physics):

        .. math::

            p_{WG} = \frac{m_r c_r + \sum_o m_o c_o}{m_r + \sum_o m_o}
        """
        d = self.data if data is None else data
        if not self.grasps:
            return d.subtree_com[self._root_id].copy()
        c = self.mass * d.subtree_com[self._root_id]
        for b in self._grasp_bodies:
            c = c + self.model.body_subtreemass[b] * d.subtree_com[b]
        return c / (self.mass + self.carried_mass)

    # ---------------------------------------------------------------- contacts
    def _contacts(
        self, model: mujoco.MjModel, data: mujoco.MjData, max_dist: float
    ) -> list[ContactInfo]:
        """Robot contacts of ``data`` with ``dist <= max_dist``."""
        out: list[ContactInfo] = []
        for i in range(data.ncon):
            c = data.contact[i]
            if c.dist > max_dist or c.exclude not in (0, 1):
                continue
            g1, g2 = int(c.geom1), int(c.geom2)
            r1, r2 = bool(self._robot_geom[g1]), bool(self._robot_geom[g2])
            if not (r1 or r2):
                continue
            # MuJoCo's normal frame[0:3] points from geom1 to geom2: it pushes geom2.
            n = np.array(c.frame[:3])
            robot, other = (g2, g1) if r2 else (g1, g2)
            if not r2:
                n = -n
            out.append(
                ContactInfo(
                    robot_geom=self._geom_names[robot],
                    other_geom=self._geom_names[other],
                    other_body=self._body_names[model.geom_bodyid[other]],
                    position=np.array(c.pos),
                    normal=n,
                    dist=float(c.dist),
                    friction=float(c.friction[0]),
                    self_contact=r1 and r2,
                )
            )
        return out

    def touching(self, qpos: np.ndarray) -> list[ContactInfo]:
        """Robot contacts within ``contact_tolerance`` at the scene state ``qpos``
        (collision detection on the probe model, as :meth:`static_check`)."""
        m, d = self._probe_model, self._probe_data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        return self._contacts(m, d, self.contact_tolerance)

    def contact_forces(self, data: mujoco.MjData | None = None) -> tuple[np.ndarray, np.ndarray]:
        r"""Points ``p_WC`` (n, 3) [m] and forces (n, 3) [N] on the robot (and its
        grasped objects) of the active contacts with the environment in ``data``
        (default: physics), from MuJoCo's ``mj_contactForce``.

        MuJoCo's contact frame has its normal (first row of ``frame``) from geom1
        to geom2 and gives the force of geom1 on geom2 in that frame:

        .. math::
            f_W = R_{WC} f_C, \quad R_{WC} = \text{frame}^T, \qquad
            f_{robot} = \pm f_W \;(+ \text{ if the robot geom is geom2})
        """
        d = self.data if data is None else data
        points, forces = [], []
        f6 = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            r1, r2 = bool(self._robot_geom[c.geom1]), bool(self._robot_geom[c.geom2])
            if r1 == r2 or c.efc_address < 0:  # not robot-environment, or inactive
                continue
            mujoco.mj_contactForce(self.model, d, i, f6)
            f_W = np.asarray(c.frame).reshape(3, 3).T @ f6[:3]
            points.append(np.array(c.pos))
            forces.append(f_W if r2 else -f_W)
        return np.array(points).reshape(-1, 3), np.array(forces).reshape(-1, 3)

    def up(self) -> np.ndarray:
        """Unit vector against gravity (z without gravity)."""
        g = np.asarray(self.model.opt.gravity, dtype=float)
        n = float(np.linalg.norm(g))
        return -g / n if n > 0 else np.array([0.0, 0.0, 1.0])

    def support(
        self, contacts: list[ContactInfo], com: np.ndarray, max_slope: float
    ) -> tuple[balance.SupportRegion | None, float]:
        """Support region of the ground contacts (normal within ``max_slope`` [rad]
        of up, projected along gravity) and the signed distance of ``com`` to it
        [m] (``(None, -inf)`` without ground contacts)."""
        up = self.up()
        cos_max = math.cos(max_slope)
        pts = [c.position for c in contacts if not c.self_contact and c.normal @ up >= cos_max]
        if not pts:
            return None, -math.inf
        uv = np.array(pts) @ balance.plane_basis(up)[:, :2]
        extent = float(np.max(np.ptp(uv, axis=0))) if len(uv) > 1 else 0.0
        region = balance.support_polygon(
            [np.array(pts)], up, allow_degenerate=True, tol=max(1e-9, 1e-6 * extent)
        )
        return region, region.signed_distance(com)

    def _wrenches(self, data: mujoco.MjData, external: Sequence[External]) -> list:
        """``external`` as :class:`pik_mj.balance.ExternalWrench`\\ es at the frames'
        positions in ``data``."""
        return [
            balance.ExternalWrench(Frame.find(self.model, frame).position(data), F, M)
            for frame, F, M in inputs.wrenches(external, "external")
        ]

    # ------------------------------------------------------------ static check
    def static_check(self, q: ArrayLike, **options: Any) -> StaticReport:
        """:func:`pik_mj.sim.static.static_check` of the robot configuration ``q``
        in this scene (options: ``mu``, ``external``, ``pyramid``,
        ``max_ground_slope``, ``scfr``).

        Raises:
            UnknownName: An option it does not have (lists them).
        """
        inputs.options(options, _static_check, "static_check option", positional=("scene", "q"))
        return _static_check(self, q, **options)

    def static_checker(
        self,
        *,
        mu: float | None = None,
        external: Sequence[External] = (),
        scfr: bool = False,
    ) -> StaticChecks:
        """A callback for :func:`pik_mj.solve` that runs :meth:`static_check` on
        every iteration's configuration and keeps the reports (``.reports``).

        Raises:
            InvalidInput: A bad ``mu`` or ``external`` (checked now, not at the
                first iteration).
        """
        if mu is not None:
            inputs.real(mu, "mu", low=0)
        self._wrenches(self.data, external)
        return StaticChecks(self, mu=mu, external=external, scfr=scfr)

    # -------------------------------------------------------------- stepping
    def step(self, n: int = 1) -> None:
        """Advance the physics ``n`` steps through the state guard
        (:class:`pik_mj.sim.guard.StateGuard`).

        Raises:
            SimulationUnstable: A warning fired or the state is not finite.
        """
        self._guard.step(n)

    # -------------------------------------------------------------------- hold
    def hold(
        self,
        q: ArrayLike,
        duration: float = 3.0,
        *,
        criteria: HoldCriteria | None = None,
        external: Sequence[External] = (),
        callback: Any = None,
        every: int = 1,
        margin_every: int = 5,
        feedforward: bool = True,
    ) -> HoldReport:
        """Hold ``q`` with the servos for ``duration`` [s] of physics
        (:func:`pik_mj.sim.hold.hold`)."""
        from pik_mj.sim.hold import hold

        return hold(
            self,
            q,
            duration,
            criteria=criteria,
            external=external,
            callback=callback,
            every=every,
            margin_every=margin_every,
            feedforward=feedforward,
        )

    # ------------------------------------------------------------------- play
    def play(
        self,
        path: Waypoints | ArrayLike,
        *,
        speed: float | None = None,
        start: MotionReport | PhysicsState | None = None,
        **options: Any,
    ) -> MotionReport:
        """Play ``path`` (a solve's iterates, :class:`pik_mj.sim.Waypoints`) in
        physics, the servos tracking it (:func:`pik_mj.sim.motion.play`; options:
        ``max_velocity``, ``settle``, ``criteria``, ``external``, ``callback``,
        ``every``, ``margin_every``, ``feedforward``)."""
        from pik_mj.sim.motion import DEFAULT_SPEED, play

        return play(
            self, path, speed=DEFAULT_SPEED if speed is None else speed, start=start, **options
        )

    def __repr__(self) -> str:
        return (
            f"Scene(root_body={self.root_body!r}, nq={self.model.nq}, "
            f"servos={len(self.servo_joints)}, timestep={self.model.opt.timestep}, "
            f"mass={self.mass:.2f} kg, allowed_contacts={self.allowed_contacts}"
            + (f", grasps={[(g.frame, g.body) for g in self.grasps]}" if self.grasps else "")
            + (f", exclude={self.exclude}" if self.exclude else "")
            + ")"
        )
