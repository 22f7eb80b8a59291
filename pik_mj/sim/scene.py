r"""The physics scene of a robot's world: :class:`Scene`.

A :class:`Scene` is made from a :class:`pik_mj.Robot` (:meth:`Scene.from_robot`):
its spec is a copy of the robot's world (``robot.spec``) plus a floor plane when
the world has none, an environment (only for a robot that has none of its own),
a position servo on every robot hinge/slide joint, contact parameters and grasp
welds (:mod:`pik_mj.sim.assembly`, :mod:`pik_mj.sim.grasp`). The robot's
configuration ``q`` (``robot.configuration.q``, the robot model's ``nq``) is a
prefix of the scene's ``qpos``: :meth:`Scene.set_pose` writes it as it is, no
joint is mapped by name, and IK and physics share one world frame (targets read
from the scene are IK targets). A scene is a :class:`pik_mj.sim.physics.Physics`
(contacts, wrenches, servo joints, stepping) and runs the static check
(:mod:`pik_mj.sim.static`), the hold (:mod:`pik_mj.sim.hold`) and the motion
playback (:mod:`pik_mj.sim.motion`) on itself.

Modelling choices (documented here once):

* **Servos** (:mod:`pik_mj.sim.servos`): a position servo
  ``τ = kp (q_ref - q) - kv q̇`` on every robot hinge/slide joint: the robot's
  own position actuator where it has one (its gains, its control set to the
  target), else a MuJoCo position actuator the scene adds, with gains from the
  robot's joint-space inertia (``kp = ω² M_jj``, ``kv = 2 ζ ω M_jj``). The
  robot's other actuators (motors) stay at zero control, which exerts nothing.
  :meth:`Scene.hold` adds the static feed-forward of
  :func:`pik_mj.sim.torques.holding_torques`, so the pose starts in equilibrium
  rather than sagging by ``τ_gravity / kp``. The integrator is ``implicitfast``,
  which treats ``kv`` implicitly.
* **Contact pairs**: the robot's explicit ``<contact><pair>``\ s are kept (they
  come with its spec), with the scene's contact parameters.
* **Friction**: elliptic cones with ``impratio = 10`` (MuJoCo's advice against
  the slow creep of soft contacts under a sustained tangential load). The
  equilibrium LP uses an inscribed pyramid, so it is the more conservative of
  the two.
* **Contact parameters** (:class:`~pik_mj.sim.assembly.ContactParams`) are
  written on the robot's geoms and on the environment's static geoms: MuJoCo
  combines friction by taking the maximum, so both sides must carry ``μ``.
* **Contact stiffness** (:data:`~pik_mj.sim.assembly.DEFAULT_CONTACT`):
  ``solref = (0.005, 1)``, a hard sole on a hard floor, rather than MuJoCo's
  soft default ``(0.02, 1)``. A hold starts from rest with no contact force: the
  robot first sinks into the floor until the contacts carry it, and while they
  build up the centre of pressure is where the soles sink, not under the CoM.
  Tipping over an edge at distance ``r`` from the CoM at height ``h`` only needs
  the energy of raising the CoM by ``r² / 2h`` (0.35 mm for r = 2 cm,
  h = 0.57 m), the order of a soft contact's settling depth. MuJoCo's contact
  spring scales as ``1 / timeconst²``: 0.005 s settles ``(0.02 / 0.005)² = 16``
  times shallower than 0.02 s. It is 2.5 time steps of 2 ms, above MuJoCo's
  stability floor of two (the scene refuses a shorter one).
* **Touching geoms**: MuJoCo reports a contact only for ``dist < margin``;
  :meth:`Scene.static_check` counts the geoms within ``contact_tolerance`` on a
  probe copy of the model (:mod:`pik_mj.sim.physics`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from numpy.typing import ArrayLike

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.robot import Robot
from pik_mj.robot.world import EnvironmentLike
from pik_mj.sim.assembly import (
    DEFAULT_CONTACT,
    ContactParams,
    add_excludes,
    add_servos,
    apply_contact,
    check_prefix,
    compile_spec,
    scene_spec,
    set_physics_options,
)
from pik_mj.sim.grasp import Grasp, GraspLike, add_grasp_welds, parse_grasps
from pik_mj.sim.hold import HoldCriteria, HoldReport, hold, hold_many
from pik_mj.sim.motion import DEFAULT_SPEED, MotionReport, PhysicsState, Waypoints, play
from pik_mj.sim.physics import External, Physics, subtree_mask
from pik_mj.sim.servos import DEFAULT_BANDWIDTH, DEFAULT_DAMPING_RATIO
from pik_mj.sim.static import StaticChecks, StaticReport, static_check
from pik_mj.sim.tracking import MARGIN_EVERY, RECORD_EVERY

__all__ = ["DEFAULT_CONTACT", "ContactParams", "External", "Grasp", "GraspLike", "Scene"]


def _check_robot(robot: Robot) -> None:
    """A :class:`pik_mj.Robot` that knows its world (has a spec)."""
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


class Scene(Physics):
    """The physics scene of a robot's world, with joint servos, for balance checks.

    Make one with :meth:`from_robot`. A scene is a
    :class:`~pik_mj.sim.physics.Physics`: its model and state, the robot's
    pose, contacts, servo joints (``servo_joints``), grasped objects
    (``grasps``, ``carried_mass``), allowed contacts (``allowed_contacts``,
    ``foot_geoms``) and stepping are documented there.

    Attributes:
        spec: The scene spec.
        servo_gains: ``{joint: (kp, kv)}`` of the servos, in joint space
            [N·m/rad, N·m·s/rad] (or [N/m, N·s/m] for slide joints).
        servo_actuators: ``{joint: actuator id}`` of the servos in ``model``.
        robot_servos: The joints whose servo is the robot's own position actuator
            (:func:`pik_mj.sim.servos.position_actuators`); the others have one
            the scene added (``<joint>_servo``).
        exclude: Body pairs whose contacts are excluded.
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
                ``impratio``). With the default elliptic friction cones, a ratio
                above 1 makes friction stiffer than the normal contact, against
                the slow creep of a loaded foot.
            noslip_iterations: MuJoCo's no-slip solver iterations (0: off): a
                no-slip pass removes the remaining creep, at the cost of a slower
                step.
            grasps: Objects held by robot frames: ``(frame, body)`` pairs, whose
                relative pose ``X_FO = X_WF⁻¹ X_WO`` is read at the robot's current
                configuration (carry the object with the hand first), or
                :class:`~pik_mj.sim.grasp.Grasp`\\ es / ``(frame, body, p_FO, R_FO)``. Each object's
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
        _check_robot(robot)
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
        spec = scene_spec(robot, environment)
        set_physics_options(spec, timestep, impratio, noslip_iterations)
        servos = add_servos(spec, robot, kp, kv, bandwidth, damping_ratio)
        model = compile_spec(spec)
        check_prefix(model, robot.model)
        robot_body = subtree_mask(model, robot.root_body_id)
        if contact is not None:
            apply_contact(spec, model, robot_body[model.geom_bodyid], contact)
        parsed = parse_grasps(model, robot_body, robot.configuration.q, grasps)
        add_grasp_welds(
            spec, model, robot_body, parsed, None if contact is None else contact.solref
        )
        self.exclude = add_excludes(spec, model, exclude)
        if contact is not None or parsed or self.exclude:
            model = compile_spec(spec)
        self.spec = spec
        self.robot_servos = servos.robot_servos
        self.servo_gains = servos.gains
        self.servo_actuators = servos.actuators
        super().__init__(
            robot,
            model,
            grasps=parsed,
            contact_tolerance=contact_tolerance,
            allowed_contacts=allowed_contacts,
        )

    @classmethod
    def from_robot(cls, robot: Robot, **options: Any) -> Scene:
        """The physics scene of ``robot``'s world: ``Scene(robot, **options)``
        (the options are :class:`Scene`'s).

        Raises:
            UnknownName: An option :class:`Scene` does not have (lists them).
        """
        inputs.options(options, cls.__init__, "Scene option", positional=("robot",))
        return cls(robot, **options)

    # ------------------------------------------------------------ static check
    def static_check(self, q: ArrayLike, **options: Any) -> StaticReport:
        """:func:`pik_mj.sim.static.static_check` of the robot configuration ``q``
        in this scene (options: ``mu``, ``external``, ``pyramid``,
        ``max_ground_slope``, ``scfr``).

        Raises:
            UnknownName: An option it does not have (lists them).
        """
        inputs.options(options, static_check, "static_check option", positional=("scene", "q"))
        return static_check(self, q, **options)

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
        self.external_wrenches(external)
        return StaticChecks(self, mu=mu, external=external, scfr=scfr)

    # -------------------------------------------------------------------- hold
    def hold(
        self,
        q: ArrayLike,
        duration: float = 3.0,
        *,
        criteria: HoldCriteria | None = None,
        external: Sequence[External] = (),
        callback: Any = None,
        every: int | None = None,
        record_every: int = RECORD_EVERY,
        margin_every: int = MARGIN_EVERY,
        feedforward: bool = True,
        balance: bool = True,
    ) -> HoldReport:
        """Hold ``q`` with the servos for ``duration`` [s] of physics
        (:func:`pik_mj.sim.hold.hold`)."""
        return hold(
            self,
            q,
            duration,
            criteria=criteria,
            external=external,
            callback=callback,
            every=every,
            record_every=record_every,
            margin_every=margin_every,
            feedforward=feedforward,
            balance=balance,
        )

    def hold_many(
        self,
        qs: Sequence[ArrayLike],
        duration: float = 3.0,
        *,
        criteria: HoldCriteria | None = None,
        nthread: int | None = None,
        **options: Any,
    ) -> list[HoldReport]:
        """Hold each configuration of ``qs`` for ``duration`` [s], all stepped
        together on ``nthread`` threads (:func:`pik_mj.sim.hold.hold_many`;
        options: ``record_every``, ``margin_every``, ``feedforward``, ``balance``)."""
        return hold_many(self, qs, duration, criteria=criteria, nthread=nthread, **options)

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
        ``every``, ``record_every``, ``margin_every``, ``feedforward``, ``balance``)."""
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
