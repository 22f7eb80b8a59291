"""What a :class:`~pik_mj.sim.Scene` adds to its robot's world spec: the environment
and a floor, the physics options, a servo on every robot hinge/slide joint
(:func:`add_servos`), the contact parameters (:class:`ContactParams`,
:func:`apply_contact`) and contact exclusions (:func:`add_excludes`). The
modelling choices are explained in :mod:`pik_mj.sim.scene`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.world import EnvironmentLike, add_floor, attach_environment, has_plane
from pik_mj.sim.drives import motor_torque_range
from pik_mj.sim.servos import position_actuators, servo_gains

__all__ = [
    "DEFAULT_CONTACT",
    "ContactParams",
    "Servos",
    "add_excludes",
    "add_servos",
    "apply_contact",
    "check_prefix",
    "compile_spec",
    "scene_spec",
    "set_physics_options",
]


@dataclass(frozen=True)
class ContactParams:
    """Contact parameters written on robot geoms and static environment geoms.

    Attributes:
        friction: Sliding friction coefficient μ [-].
        torsional: Torsional friction [m] (used with condim >= 4).
        rolling: Rolling friction [m] (used with condim 6).
        condim: Contact dimension (1, 3, 4 or 6). 3: point contact with friction.
        solref: ``(timeconst [s], dampratio)``; MuJoCo's default (0.02, 1) here,
            :data:`DEFAULT_CONTACT` (the :class:`~pik_mj.sim.Scene` default) uses 0.005 s.
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
"""Contacts of :class:`~pik_mj.sim.Scene`: friction 1, a hard contact (``timeconst``
5 ms; see :mod:`pik_mj.sim.scene`), MuJoCo's impedance."""


def compile_spec(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """``spec.compile()``.

    Raises:
        InvalidInput: The scene does not compile (MuJoCo's message).
    """
    try:
        return spec.compile()
    except ValueError as err:
        raise InvalidInput(f"the scene does not compile: {err}") from err


def scene_spec(robot: Robot, environment: EnvironmentLike | None = None) -> mujoco.MjSpec:
    """A copy of the robot's world spec, ``environment`` attached into it, and a
    floor plane when the world has none.

    Raises:
        InvalidInput: An environment for a robot that stands in one already.
    """
    spec = robot.spec.copy()
    if environment is not None:
        if robot.source is not None and robot.source.environment is not None:
            raise InvalidInput(
                f"the robot already stands in environment {robot.source.environment!r}; "
                "a Scene adds an environment only to a robot without one"
            )
        spec = attach_environment(spec, environment)
    if not has_plane(robot.model if environment is None else compile_spec(spec)):
        add_floor(spec)
    return spec


def set_physics_options(
    spec: mujoco.MjSpec, timestep: float, impratio: float, noslip_iterations: int
) -> None:
    """Time step [s], the ``implicitfast`` integrator (the servos' damping is
    implicit), elliptic friction cones with ``impratio``, no-slip iterations."""
    spec.option.timestep = float(timestep)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = float(impratio)
    spec.option.noslip_iterations = noslip_iterations


@dataclass(frozen=True)
class Servos:
    """The position servos on the robot's hinge/slide joints.

    Attributes:
        joints: The servo joints, in joint order.
        robot_servos: Those driven by the robot's own position actuator.
        gains: ``{joint: (kp, kv)}`` in joint space [N·m/rad, N·m·s/rad] (or
            [N/m, N·s/m] for slide joints).
        actuators: ``{joint: actuator id}`` in the scene's model.
    """

    joints: list[str]
    robot_servos: list[str]
    gains: dict[str, tuple[float, float]]
    actuators: dict[str, int]


def add_servos(
    spec: mujoco.MjSpec,
    robot: Robot,
    kp: float | Mapping[str, float] | None,
    kv: float | Mapping[str, float] | None,
    bandwidth: float,
    damping_ratio: float,
) -> Servos:
    """A servo on every robot hinge/slide joint (ids shared with the robot's model:
    its joints and actuators come first): the robot's own position actuator
    (:func:`pik_mj.sim.servos.position_actuators`, its gains) where it has one,
    else a ``<joint>_servo`` position actuator added to ``spec`` with the given
    gains or :func:`pik_mj.sim.servos.servo_gains`, no control range (whatever
    the MJCF's default actuator class says) and the torque range of the robot's
    motors on that joint as its force range
    (:func:`pik_mj.sim.drives.motor_torque_range`). Keyframes that set ``ctrl``
    get the added servos' targets at their own pose.

    Raises:
        InvalidInput: A gain that is not a number > 0 (``kv`` >= 0), or one
            given for a joint driven by the robot's own actuator.
        UnknownName: A joint of a ``kp``/``kv`` mapping without a servo.
    """
    rm = robot.model
    servo_ids = [int(j) for j in robot.angle_joint_ids]
    joints = [rm.joint(j).name for j in servo_ids]
    own = position_actuators(rm, servo_ids)
    robot_servos = [rm.joint(j).name for j in servo_ids if j in own]
    added = [j for j in servo_ids if j not in own]
    n_old = len(spec.actuators)
    gains = {rm.joint(j).name: (kp_j, kv_j) for j, (_, kp_j, kv_j) in own.items()}
    derived = servo_gains(rm, robot.start_q(), added, bandwidth, damping_ratio)
    gains.update(_added_gains([rm.joint(j).name for j in added], robot_servos, kp, kv, derived))
    for j in added:
        joint = rm.joint(j).name
        act = spec.add_actuator(
            name=f"{joint}_servo", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT
        )
        act.set_to_position(kp=gains[joint][0], kv=gains[joint][1])
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE  # not the defaults' range
        act.gear = [1.0, 0, 0, 0, 0, 0]
        motor = motor_torque_range(rm, j)
        act.forcelimited = (
            mujoco.mjtLimited.mjLIMITED_FALSE
            if motor is None
            else mujoco.mjtLimited.mjLIMITED_TRUE  # the drive is the robot's motor
        )
        if motor is not None:
            act.forcerange = motor
    actuators = {rm.joint(j).name: a for j, (a, _, _) in own.items()}
    actuators.update({rm.joint(j).name: n_old + i for i, j in enumerate(added)})
    _extend_keyframe_ctrl(spec, n_old, [rm.joint(j).name for j in added])
    return Servos(joints, robot_servos, gains, {j: actuators[j] for j in joints})


def _added_gains(
    names: Sequence[str],
    robot_servos: Sequence[str],
    kp: float | Mapping[str, float] | None,
    kv: float | Mapping[str, float] | None,
    derived: tuple[np.ndarray, np.ndarray],
) -> dict[str, tuple[float, float]]:
    """``{joint: (kp, kv)}`` of the servos added on the joints ``names``: the
    given gains, else the ``derived`` ones."""
    for value in (kp, kv):
        if isinstance(value, Mapping):
            for joint in value:
                if joint in robot_servos:
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


def _extend_keyframe_ctrl(spec: mujoco.MjSpec, n_old: int, added: Sequence[str]) -> None:
    """Keyframes that set ``ctrl`` get the targets of the ``added`` servos (after
    the ``n_old`` actuators of the robot) at their own pose."""
    if not any(len(key.ctrl) for key in spec.keys):
        return
    model = compile_spec(spec)  # servos not counted in key_ctrl yet: compile first
    for k in range(model.nkey):
        key = spec.keys[k]
        if len(key.ctrl) == 0:
            continue
        qpos = model.key_qpos[k]
        targets = [qpos[model.jnt_qposadr[model.joint(j).id]] for j in added]
        key.ctrl = list(key.ctrl)[:n_old] + [float(t) for t in targets]


def check_prefix(model: mujoco.MjModel, robot_model: mujoco.MjModel) -> None:
    """The robot's joints come first in ``model``, at the same addresses.

    Raises:
        PikError: They do not: the robot's configuration would not be a prefix
            of the scene's ``qpos``.
    """
    rm = robot_model
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


def apply_contact(
    spec: mujoco.MjSpec, model: mujoco.MjModel, robot_geom: np.ndarray, contact: ContactParams
) -> None:
    """``contact`` written on the robot's geoms (mask ``robot_geom`` (ngeom,)) and
    the environment's static geoms (MuJoCo combines friction by taking the
    maximum, so both sides carry ``μ``), and on the explicit contact pairs with
    a robot geom (a pair's parameters override its geoms')."""
    static = np.asarray(model.body_weldid)[model.geom_bodyid] == 0
    targets = robot_geom | static
    for geom in spec.geoms:
        if not targets[geom.id]:  # geom.id: its index in the compiled model
            continue
        geom.friction = [contact.friction, contact.torsional, contact.rolling]
        geom.condim = contact.condim
        geom.solref = list(contact.solref)
        geom.solimp = list(contact.solimp)
    names = {model.geom(g).name for g in np.flatnonzero(targets)}
    for pair in spec.pairs:
        if pair.geomname1 in names or pair.geomname2 in names:
            mu = [contact.friction, contact.friction, contact.torsional]
            pair.friction = [*mu, contact.rolling, contact.rolling]
            pair.condim = contact.condim
            pair.solref = list(contact.solref)
            pair.solimp = list(contact.solimp)


def add_excludes(
    spec: mujoco.MjSpec, model: mujoco.MjModel, exclude: Sequence[tuple[str, str]]
) -> list[tuple[str, str]]:
    """A contact exclusion per body pair of ``exclude`` (MJCF ``<contact><exclude>``).

    Raises:
        InvalidInput: Not a list of ``(body1, body2)`` pairs.
        UnknownName: A body that does not exist.
    """
    if isinstance(exclude, (str, bytes)) or not isinstance(exclude, Sequence):
        raise InvalidInput(f"exclude must be a list of (body1, body2) pairs, got {exclude!r}")
    bodies = [model.body(b).name for b in range(model.nbody)]
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
