"""Simulation-coupled static balance: a robot in a MuJoCo scene (DESIGN.md §5).

A :class:`Scene` is the robot composed with a floor and an environment
(:func:`pik_mj.models.compose_scene`), with a position servo on every robot
hinge/slide joint. It answers two questions about a robot configuration ``q``
(the ``qpos`` of the robot-only model, e.g. ``mink.Configuration.q``):

* :meth:`Scene.static_check` — kinematics only (``mj_forward``, no stepping):
  which robot geoms touch what (MuJoCo's collision detection), the support
  polygon of the ground contacts, the CoM margin to it, and whether contact
  forces inside linearized friction cones at the actual contact points can
  balance gravity and external wrenches (an LP, :func:`pik_mj.balance.
  static_equilibrium`).
* :meth:`Scene.hold` — physics: the pose is held by the servos for a few
  seconds; base drift, foot slip, CoM margin, unexpected contacts and falling
  give a pass/fail verdict.

Modelling choices (documented here once):

* **Servos**: MuJoCo position actuators ``τ = kp (q_ref - q) - kv q̇`` on every
  robot hinge/slide joint; :meth:`Scene.hold` adds the static feed-forward of
  :meth:`Scene.holding_torques` (``feedforward=True``), so the pose starts in
  equilibrium instead of sagging by ``τ_gravity / kp``. The robot's own
  actuators are kept with zero control. The integrator is ``implicitfast``,
  which treats ``kv`` implicitly.
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
import os
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Literal

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import balance
from pik_mj.exceptions import InvalidInput, SimulationUnstable, UnknownName
from pik_mj.frames import Frame
from pik_mj.models import compose_scene, load_spec
from pik_mj.tasks.frame import skew

__all__ = [
    "DEFAULT_CONTACT",
    "ContactInfo",
    "ContactParams",
    "Grasp",
    "HoldReport",
    "Scene",
    "StaticCheckLog",
    "StaticReport",
    "add_box",
    "add_wall",
    "floor_environment",
    "validate_pose",
]

EnvironmentLike = str | os.PathLike[str] | mujoco.MjSpec | None
RobotLike = str | os.PathLike[str] | mujoco.MjSpec

#: Warnings after which the simulation state is garbage (as dm_control's
#: ``check_invalid_state``), plus full contact / constraint buffers.
UNSTABLE_WARNINGS: tuple[mujoco.mjtWarning, ...] = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADCTRL,
    mujoco.mjtWarning.mjWARN_CONTACTFULL,
    mujoco.mjtWarning.mjWARN_CNSTRFULL,
)

_ANGLE_JOINTS = (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)


# ----------------------------------------------------------------------------
# Environment helpers
# ----------------------------------------------------------------------------


def floor_environment(name: str = "floor") -> mujoco.MjSpec:
    """An environment spec holding only a floor plane ``floor`` at z = 0 and a light.

    Add boxes and walls with :func:`add_box` / :func:`add_wall`, then pass it to
    :class:`Scene` as ``environment``.
    """
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.compiler.degree = False
    spec.worldbody.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[20.0, 20.0, 0.1],
        rgba=[0.5, 0.5, 0.5, 1.0],
    )
    spec.worldbody.add_light(name="sun", pos=[0, 0, 4], dir=[0, 0, -1])
    return spec


def _vec(value: ArrayLike, n: int, what: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{what} must be {n} numbers, got {value!r}") from exc
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise InvalidInput(f"{what} must be {n} finite numbers, got {value!r}")
    return v


def add_box(
    spec: mujoco.MjSpec,
    name: str,
    pos: ArrayLike,
    size: ArrayLike,
    *,
    quat: ArrayLike = (1.0, 0.0, 0.0, 0.0),
    rgba: ArrayLike = (0.8, 0.8, 0.75, 1.0),
) -> mujoco.MjsGeom:
    """Add a static box geom to the world of ``spec`` (modified in place).

    Args:
        spec: Environment spec.
        name: Geom name (must be new).
        pos: Centre ``p_WB`` (3,) [m].
        size: Half sizes (3,) [m], all > 0.
        quat: Orientation (w, x, y, z).
        rgba: Colour.

    Returns:
        The new geom.
    """
    p = _vec(pos, 3, "pos")
    s = _vec(size, 3, "size")
    q = _vec(quat, 4, "quat")
    if np.any(s <= 0):
        raise InvalidInput(f"box half sizes must be > 0 [m], got {s}")
    if np.linalg.norm(q) < 1e-9:
        raise InvalidInput(f"quat {q} has zero norm")
    if any(g.name == name for g in spec.geoms):
        raise InvalidInput(f"the environment already has a geom named {name!r}")
    return spec.worldbody.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=p.tolist(),
        size=s.tolist(),
        quat=(q / np.linalg.norm(q)).tolist(),
        rgba=list(_vec(rgba, 4, "rgba")),
    )


def add_wall(
    spec: mujoco.MjSpec,
    point: ArrayLike,
    normal: ArrayLike,
    *,
    name: str = "wall",
    width: float = 2.0,
    height: float = 2.0,
    thickness: float = 0.1,
) -> mujoco.MjsGeom:
    """Add a vertical wall whose face passes through ``point`` facing ``normal``.

    The wall is a box standing on z = 0, ``height`` tall, ``width`` wide centred
    on ``point`` horizontally; its face plane is ``{p : n·(p - point) = 0}`` and
    the box lies behind it (``n·(p - point) <= 0``).

    Args:
        spec: Environment spec (modified in place).
        point: A point of the face (3,) [m].
        normal: Horizontal outward normal of the face (3,) (towards the robot).
        name: Geom name.
        width: Width [m].
        height: Height [m].
        thickness: Thickness [m].
    """
    p = _vec(point, 3, "point")
    n = _vec(normal, 3, "normal")
    if abs(n[2]) > 1e-9 or np.linalg.norm(n[:2]) < 1e-9:
        raise InvalidInput(f"a wall normal must be horizontal and non-zero, got {n}")
    n = n / np.linalg.norm(n)
    for label, v in (("width", width), ("height", height), ("thickness", thickness)):
        if not (math.isfinite(v) and v > 0):
            raise InvalidInput(f"wall {label} must be > 0 [m], got {v}")
    yaw = math.atan2(n[1], n[0])  # box x-axis along the normal
    centre = np.array([p[0], p[1], 0.0]) - 0.5 * thickness * n
    centre[2] = 0.5 * height
    return add_box(
        spec,
        name,
        centre,
        (0.5 * thickness, 0.5 * width, 0.5 * height),
        quat=(math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)),
    )


# ----------------------------------------------------------------------------
# Reports
# ----------------------------------------------------------------------------


def _finite_or_none(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


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
        if self.condim not in (1, 3, 4, 6):
            raise InvalidInput(f"condim must be 1, 3, 4 or 6, got {self.condim}")
        for label, v in (
            ("friction", self.friction),
            ("torsional", self.torsional),
            ("rolling", self.rolling),
        ):
            if not (math.isfinite(v) and v >= 0):
                raise InvalidInput(f"{label} must be finite and >= 0, got {v}")
        if len(self.solref) != 2 or len(self.solimp) != 5:
            raise InvalidInput("solref needs 2 numbers and solimp 5")


DEFAULT_CONTACT = ContactParams(solref=(0.005, 1.0))
"""Contacts of :class:`Scene`: friction 1, a hard contact (``timeconst`` 5 ms; see
the module docstring), MuJoCo's impedance."""


@dataclass(frozen=True)
class ContactInfo:
    """A contact between a robot geom and another geom.

    Attributes:
        robot_geom: Name of the robot's geom.
        other_geom: Name of the other geom (environment, or robot if ``self_contact``).
        other_body: Name of the other geom's body.
        position: Contact point ``p_WC`` (3,) [m] (MuJoCo: midway between surfaces).
        normal: Unit normal (3,) pointing INTO the robot geom (the direction the
            other geom pushes it).
        dist: Signed distance between the surfaces [m] (< 0: penetration).
        friction: MuJoCo's sliding friction coefficient of the pair.
        self_contact: Both geoms belong to the robot.
    """

    robot_geom: str
    other_geom: str
    other_body: str
    position: np.ndarray
    normal: np.ndarray
    dist: float
    friction: float
    self_contact: bool

    def to_dict(self) -> dict[str, Any]:
        return {
            "robot_geom": self.robot_geom,
            "other_geom": self.other_geom,
            "other_body": self.other_body,
            "position": self.position.tolist(),
            "normal": self.normal.tolist(),
            "dist": self.dist,
            "friction": self.friction,
            "self_contact": self.self_contact,
        }


@dataclass(frozen=True)
class Grasp:
    r"""An environment object held rigidly by a robot frame (a hand).

    The object O is a top-level body of the environment with a free joint (e.g.
    the room's ``kettle``). In a :class:`Scene` with this grasp its pose follows
    the robot: for every robot configuration ``q``

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


@dataclass
class StaticReport:
    """Result of :meth:`Scene.static_check` for one configuration.

    Attributes:
        contacts: Every robot contact (environment and self) within the tolerance.
        support_polygon: Vertices (m, 3) [m] of the support polygon (convex hull
            of the ground contacts projected along gravity, counter-clockwise),
            at the mean contact height; ``(0, 3)`` without ground contacts, 1 or 2
            rows when they span no area.
        com: Centre of mass ``p_WG`` (3,) [m] of the robot and its grasped objects.
        margin: Signed distance [m] of the CoM's projection to the support polygon,
            positive inside; for a degenerate polygon (a point or a segment) minus
            the distance to it; ``-inf`` without ground contacts.
        feasible: Contact forces inside the friction cones at the environment
            contacts balance gravity and the external wrenches.
        message: Equilibrium LP message (or why it was not solved).
        forces: Contact forces (n_env, 3) [N] found by the LP (world frame, on the
            robot), one per environment contact in ``contacts`` order, or None.
        mu: Friction coefficient used in the LP (None: each contact's own).
        scfr_margin: Signed distance [m] of the CoM to the static centroid
            feasible region of the actual contacts, when requested.
        q: The robot configuration checked.
    """

    contacts: list[ContactInfo]
    support_polygon: np.ndarray
    com: np.ndarray
    margin: float
    feasible: bool
    message: str
    forces: np.ndarray | None
    mu: float | None
    scfr_margin: float | None
    q: np.ndarray

    @property
    def environment_contacts(self) -> list[ContactInfo]:
        """Contacts with the environment (self contacts left out)."""
        return [c for c in self.contacts if not c.self_contact]

    @property
    def touching_geoms(self) -> list[str]:
        """Sorted names of robot geoms touching the environment."""
        return sorted({c.robot_geom for c in self.environment_contacts})

    @property
    def self_contacts(self) -> list[tuple[str, str]]:
        """Pairs of robot geoms touching each other."""
        return sorted({(c.robot_geom, c.other_geom) for c in self.contacts if c.self_contact})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (non-finite margins become None)."""
        return {
            "feasible": self.feasible,
            "margin": _finite_or_none(self.margin),
            "scfr_margin": _finite_or_none(self.scfr_margin),
            "com": self.com.tolist(),
            "support_polygon": self.support_polygon.tolist(),
            "touching_geoms": self.touching_geoms,
            "self_contacts": [list(p) for p in self.self_contacts],
            "contacts": [c.to_dict() for c in self.contacts],
            "forces": None if self.forces is None else self.forces.tolist(),
            "mu": self.mu,
            "message": self.message,
        }


@dataclass
class HoldReport:
    """Result of :meth:`Scene.hold`.

    Attributes:
        passed: Every criterion holds (see ``failures``).
        failures: One line per failed criterion.
        drift: Largest displacement of the root body from its start [m].
        drift_horizontal: Largest horizontal displacement of the root body [m].
        drift_vertical: Largest vertical displacement of the root body [m].
        final_displacement: Root body displacement at the end (3,) [m].
        slip: Largest horizontal displacement of an allowed contact geom while it
            stayed in contact with the environment [m].
        slip_per_geom: ``slip`` for each allowed geom that touched the environment.
        min_margin: Smallest CoM margin to the support polygon over the hold [m],
            the polygon of the ground contacts within ``contact_tolerance`` as in
            :meth:`Scene.static_check` (``-inf`` if contact was lost). At the start
            it is the static margin: the physics alone reports a contact only once
            a geom penetrates, so a pose placed on the floor would start with an
            arbitrary subset of its sole corners (often one foot's).
        fell: The root body dropped below ``fall_ratio`` times its initial height.
        unexpected_contacts: ``(robot_geom, other_geom, first_time [s])`` for
            contacts of robot geoms that are not allowed, and robot self-contacts.
        allowed: Robot geoms allowed to touch the environment.
        thresholds: The pass/fail thresholds used.
        duration: Requested duration [s].
        simulated: Simulated time [s] (shorter if the run stopped on a fall).
        steps: Physics steps taken.
        timestep: Physics time step [s].
        root_height: Root body height at the start and at the end [m].
        wall_time: Wall-clock time of the hold [s].
    """

    passed: bool
    failures: list[str]
    drift: float
    drift_horizontal: float
    drift_vertical: float
    final_displacement: np.ndarray
    slip: float
    slip_per_geom: dict[str, float]
    min_margin: float
    fell: bool
    unexpected_contacts: list[tuple[str, str, float]]
    allowed: list[str]
    thresholds: dict[str, float]
    duration: float
    simulated: float
    steps: int
    timestep: float
    root_height: tuple[float, float]
    wall_time: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (non-finite margins become None)."""
        return {
            "passed": self.passed,
            "failures": list(self.failures),
            "drift": self.drift,
            "drift_horizontal": self.drift_horizontal,
            "drift_vertical": self.drift_vertical,
            "final_displacement": self.final_displacement.tolist(),
            "slip": self.slip,
            "slip_per_geom": dict(self.slip_per_geom),
            "min_margin": _finite_or_none(self.min_margin),
            "fell": self.fell,
            "unexpected_contacts": [list(c) for c in self.unexpected_contacts],
            "allowed": list(self.allowed),
            "thresholds": dict(self.thresholds),
            "duration": self.duration,
            "simulated": self.simulated,
            "steps": self.steps,
            "timestep": self.timestep,
            "root_height": list(self.root_height),
            "wall_time": self.wall_time,
        }


# ----------------------------------------------------------------------------
# Geometry helpers
# ----------------------------------------------------------------------------


def _support(points: np.ndarray, R: np.ndarray, com: np.ndarray) -> tuple[np.ndarray, float]:
    """Support polygon (world vertices) of ``points`` and the CoM margin.

    ``R = [e1 e2 up]`` (:func:`pik_mj.balance.plane_basis`): the points and the CoM
    are projected on ``(e1, e2)``.

    A degenerate set (a point or a segment) gives those 1-2 points and minus the
    distance of the projected CoM to them.
    """
    if len(points) == 0:
        return np.zeros((0, 3)), -math.inf
    uv = points @ R[:, :2]
    height = float(np.mean(points @ R[:, 2]))
    c = R[:, :2].T @ com
    extent = float(np.max(np.ptp(uv, axis=0))) if len(uv) > 1 else 0.0
    hull = balance.convex_hull_2d(uv, allow_degenerate=True, tol=max(1e-9, 1e-6 * extent))
    if len(hull) >= 3:
        margin = balance.signed_distance(balance.halfplanes_from_polygon(hull), c)
    elif len(hull) == 2:
        a, b = hull
        t = float(np.clip((c - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        margin = -float(np.linalg.norm(c - (a + t * (b - a))))
    else:
        margin = -float(np.linalg.norm(c - hull[0]))
    return hull @ R[:, :2].T + height * R[:, 2], margin


@contextmanager
def _collect_mujoco_warnings(messages: list[str]) -> Iterator[None]:
    """Route MuJoCo's C warnings into ``messages`` (not stderr / MUJOCO_LOG.TXT)."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) or "" for i in range(count)]


# ----------------------------------------------------------------------------
# Scene
# ----------------------------------------------------------------------------


def _least_norm_forces(
    report: StaticReport,
    mass: float,
    gravity: np.ndarray,
    external: Sequence[balance.ExternalWrench],
) -> np.ndarray | None:
    r"""Least-norm contact forces inside the friction pyramids that balance
    gravity at the CoM and ``external`` (a QP, DAQP); None if there are none.

    .. math::

        \min \sum_i \|f_i\|^2 \;\text{s.t.}\; \sum_i [f_i; p_i \times f_i]
        = -\Big[m g + \sum F_e;\; c \times m g + \sum (p_e \times F_e + M_e)\Big],
        \quad |t_{k,i} \cdot f_i| \le \tfrac{\mu}{\sqrt 2}\, n_i \cdot f_i
    """
    import qpsolvers

    contacts = report.environment_contacts
    n = len(contacts)
    A = np.zeros((6, 3 * n))
    G = np.zeros((5 * n, 3 * n))
    for i, c in enumerate(contacts):
        cols = slice(3 * i, 3 * i + 3)
        A[:3, cols] = np.eye(3)
        A[3:, cols] = skew(c.position)
        t1, t2, normal = balance.plane_basis(c.normal).T
        mu = (report.mu if report.mu is not None else c.friction) / np.sqrt(2.0)
        G[5 * i : 5 * i + 5, cols] = [
            -normal,
            t1 - mu * normal,
            -t1 - mu * normal,
            t2 - mu * normal,
            -t2 - mu * normal,
        ]
    weight = mass * np.asarray(gravity, dtype=float)
    b = -np.concatenate([weight, np.cross(report.com, weight)])
    for w in external:
        F, M = np.asarray(w.force, float), np.asarray(w.moment, float)
        b -= np.concatenate([F, np.cross(np.asarray(w.p_W, float), F) + M])
    # Forces in units of the weight keep the QP O(1).
    scale = float(np.linalg.norm(weight)) or 1.0
    f = qpsolvers.solve_qp(
        np.eye(3 * n), np.zeros(3 * n), G, np.zeros(5 * n), A, b / scale, solver="daqp"
    )
    return None if f is None else scale * f.reshape(n, 3)


class Scene:
    """A robot on a floor in an environment, with joint servos, for balance checks.

    Args:
        robot: Robot model name, MJCF path or spec (copied).
        environment: ``"room"``, another model name/path, a spec (e.g. from
            :func:`floor_environment` + :func:`add_wall`), or None for a floor only.
        robot_pos: Where the robot model's origin is placed in the world [m].
        robot_yaw: Rotation of the robot model about world z [rad].
        timestep: Physics time step [s].
        kp: Servo stiffness [N·m/rad] (or [N/m] for slide joints); a float, or a
            mapping joint name -> kp (missing joints get ``default_kp``).
        kv: Servo damping [N·m·s/rad]; float or mapping as ``kp``.
        contact: Contact parameters for the robot and the static environment, or
            None to keep the models' own. A positive ``solref`` time constant
            must be at least two time steps (MuJoCo's stability floor).
        contact_tolerance: Distance [m] within which :meth:`static_check` counts
            two geoms as touching.
        allowed_contacts: Robot geoms allowed to touch the environment in
            :meth:`hold`; default: geoms whose name contains ``sole``, else the
            geoms of bodies whose name contains ``foot``.
        default_kp: kp for joints missing from a ``kp`` mapping.
        default_kv: kv for joints missing from a ``kv`` mapping.
        impratio: Ratio of frictional to normal constraint impedance (MuJoCo
            ``impratio``). With the default elliptic friction cones, 10 keeps the
            soft-contact creep of a loaded foot below ~0.2 mm/s (1: ~3 mm/s).
        noslip_iterations: MuJoCo's no-slip solver iterations (0: off); 5 removes
            the remaining creep at ~30% more time per step.
        grasps: Objects held by robot frames (:class:`Grasp`, or tuples
            ``(frame, body, p_FO, R_FO)``): each object's pose follows the robot
            and a weld equality (``solref`` of ``contact``, else MuJoCo's) holds
            it in the physics.

    Attributes:
        spec: The composed scene spec.
        model: The physics model.
        data: The physics state.
        robot_model: The robot-only model (defines the layout of ``q_robot``).
        root_body: Name of the robot's top-level body.
        mass: Robot mass [kg].
        grasps: The :class:`Grasp` list.
        carried_mass: Mass of the grasped objects [kg].
    """

    def __init__(
        self,
        robot: RobotLike = "sample_humanoid",
        environment: EnvironmentLike = None,
        *,
        robot_pos: ArrayLike = (0.0, 0.0, 0.0),
        robot_yaw: float = 0.0,
        timestep: float = 0.002,
        kp: float | Mapping[str, float] = 3000.0,
        kv: float | Mapping[str, float] = 60.0,
        contact: ContactParams | None = DEFAULT_CONTACT,
        contact_tolerance: float = 2e-3,
        allowed_contacts: Sequence[str] | None = None,
        default_kp: float = 3000.0,
        default_kv: float = 60.0,
        impratio: float = 10.0,
        noslip_iterations: int = 0,
        grasps: Sequence[Grasp | tuple[str, str, ArrayLike, ArrayLike]] = (),
    ):
        if not (math.isfinite(impratio) and impratio >= 1):
            raise InvalidInput(f"impratio must be >= 1, got {impratio}")
        if not (math.isfinite(timestep) and timestep > 0):
            raise InvalidInput(f"timestep must be > 0 [s], got {timestep}")
        if not (math.isfinite(contact_tolerance) and contact_tolerance >= 0):
            raise InvalidInput(f"contact_tolerance must be >= 0 [m], got {contact_tolerance}")
        if contact is not None and 0 < contact.solref[0] < 2 * timestep:
            raise InvalidInput(
                f"contact solref time constant {contact.solref[0]} s is below two time "
                f"steps ({2 * timestep} s): MuJoCo's contacts become unstable; raise it "
                f"or lower the time step"
            )
        robot_spec = robot.copy() if isinstance(robot, mujoco.MjSpec) else load_spec(robot)
        self.robot_model = robot_spec.compile()
        self.robot_pos = _vec(robot_pos, 3, "robot_pos")
        self.robot_yaw = float(robot_yaw)
        spec = compose_scene(
            robot_spec, environment, robot_pos=self.robot_pos, robot_yaw=self.robot_yaw
        )
        spec.option.timestep = float(timestep)
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = float(impratio)
        if not (isinstance(noslip_iterations, int) and noslip_iterations >= 0):
            raise InvalidInput(
                f"noslip_iterations must be an integer >= 0, got {noslip_iterations}"
            )
        spec.option.noslip_iterations = noslip_iterations
        self.contact_tolerance = float(contact_tolerance)

        # compose_scene checked that the robot has exactly one top-level body.
        rm = self.robot_model
        top = next(b for b in range(1, rm.nbody) if rm.body_parentid[b] == 0)
        self.root_body = rm.body(top).name
        robot_joints = [
            (self.robot_model.joint(j).name, int(self.robot_model.jnt_type[j]))
            for j in range(self.robot_model.njnt)
        ]
        self.servo_joints = [n for n, t in robot_joints if t in _ANGLE_JOINTS]
        n_old_actuators = len(spec.actuators)
        gains = self._gains(kp, kv, default_kp, default_kv)
        for joint in self.servo_joints:
            act = spec.add_actuator(
                name=f"{joint}_servo", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT
            )
            act.set_to_position(kp=gains[joint][0], kv=gains[joint][1])
        self._extend_keyframe_ctrl(spec, n_old_actuators)
        self.spec = spec
        try:
            model = spec.compile()
        except ValueError as err:
            raise InvalidInput(f"the scene does not compile: {err}") from err

        root_id = model.body(self.root_body).id
        self._robot_body = np.asarray(model.body_rootid) == root_id
        self._robot_geom = self._robot_body[model.geom_bodyid]
        if contact is not None:
            self._apply_contact(spec, model, contact)
        self.grasps = [g if isinstance(g, Grasp) else Grasp(*g) for g in grasps]
        self._add_grasps(spec, model, contact)
        if contact is not None or self.grasps:
            try:
                model = spec.compile()
            except ValueError as err:
                raise InvalidInput(f"the scene does not compile: {err}") from err
        self.model = model
        self.data = mujoco.MjData(model)
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
        self._servo_ids = np.arange(n_old_actuators, model.nu)
        self._build_pose_map()
        # Collision-only copy whose robot geoms carry the contact tolerance.
        self._probe_model = copy.copy(model)
        self._probe_model.geom_margin[self._robot_geom] = self.contact_tolerance
        self._probe_data = mujoco.MjData(self._probe_model)
        self._geom_names = _names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom)
        self._body_names = _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody)
        self._geom_id = {n: g for g, n in enumerate(self._geom_names) if n}
        self.allowed_contacts = self._allowed(allowed_contacts)

    # ------------------------------------------------------------ construction
    def _gains(
        self,
        kp: float | Mapping[str, float],
        kv: float | Mapping[str, float],
        default_kp: float,
        default_kv: float,
    ) -> dict[str, tuple[float, float]]:
        out = {}
        for value in (kp, kv):
            if isinstance(value, Mapping):
                unknown = set(value) - set(self.servo_joints)
                if unknown:
                    raise UnknownName("joint", sorted(unknown)[0], self.servo_joints)
        for joint in self.servo_joints:
            p = kp.get(joint, default_kp) if isinstance(kp, Mapping) else kp
            v = kv.get(joint, default_kv) if isinstance(kv, Mapping) else kv
            if not (math.isfinite(p) and p > 0 and math.isfinite(v) and v >= 0):
                raise InvalidInput(
                    f"servo gains of joint {joint!r} must be kp > 0, kv >= 0, got {p}, {v}"
                )
            out[joint] = (float(p), float(v))
        return out

    def _extend_keyframe_ctrl(self, spec: mujoco.MjSpec, n_old: int) -> None:
        """Keyframes that set ``ctrl`` get the servo targets of their own pose."""
        model = spec.compile()  # servos not counted in key_ctrl yet: compile first
        for k in range(model.nkey):
            key = spec.key(model.key(k).name)
            if len(key.ctrl) == 0:
                continue
            qpos = model.key_qpos[k]
            targets = [qpos[model.jnt_qposadr[model.joint(j).id]] for j in self.servo_joints]
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

    def _add_grasps(
        self, spec: mujoco.MjSpec, model: mujoco.MjModel, contact: ContactParams | None
    ) -> None:
        """A weld ``(frame's body B, object O)`` with ``relpose = X_BO = X_BF X_FO``
        and a contact exclusion of ``(B, O)`` per grasp (names checked)."""
        frames = [
            n
            for kind in ("site", "body")
            for n in _names(
                model,
                getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}"),
                model.nsite if kind == "site" else model.nbody,
            )
            if n
            and self._robot_body[
                model.site_bodyid[model.site(n).id] if kind == "site" else model.body(n).id
            ]
        ]
        objects = [
            model.body(b).name
            for b in range(1, model.nbody)
            if model.body_parentid[b] == 0
            and not self._robot_body[b]
            and model.body_jntnum[b] == 1
            and model.jnt_type[model.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE
        ]
        seen: set[str] = set()
        for g in self.grasps:
            if g.frame not in frames:
                raise UnknownName("robot frame (site or body)", g.frame, frames)
            if g.body not in objects:
                raise UnknownName("free environment body", g.body, objects)
            if g.body in seen:
                raise InvalidInput(f"body {g.body!r} is grasped twice")
            seen.add(g.body)
            frame = Frame.find(model, g.frame)
            body = frame.body_id
            if frame.frame_type == "site":
                p_BF = np.array(model.site_pos[frame.id])
                R_BF = np.zeros(9)
                mujoco.mju_quat2Mat(R_BF, model.site_quat[frame.id])
                R_BF = R_BF.reshape(3, 3)
            else:
                p_BF, R_BF = np.zeros(3), np.eye(3)
            p_BO = p_BF + R_BF @ g.p_FO
            quat_BO = np.empty(4)
            mujoco.mju_mat2Quat(quat_BO, np.ascontiguousarray(R_BF @ g.R_FO).ravel())
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

    def _build_pose_map(self) -> None:
        rm, m = self.robot_model, self.model
        src, dst = [], []
        self._free: list[tuple[int, int]] = []
        for j in range(rm.njnt):
            name = rm.joint(j).name
            a = int(rm.jnt_qposadr[j])
            b = int(m.jnt_qposadr[m.joint(name).id])
            kind = rm.jnt_type[j]
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                self._free.append((a, b))
            else:
                n = 4 if kind == mujoco.mjtJoint.mjJNT_BALL else 1
                src.extend(range(a, a + n))
                dst.extend(range(b, b + n))
        self._src, self._dst = np.array(src, dtype=int), np.array(dst, dtype=int)
        servo_adr = [m.jnt_qposadr[m.joint(j).id] for j in self.servo_joints]
        self._servo_qadr = np.array(servo_adr, dtype=int)
        self._servo_dofs = np.array(
            [m.jnt_dofadr[m.joint(j).id] for j in self.servo_joints], dtype=int
        )
        c, s = math.cos(self.robot_yaw), math.sin(self.robot_yaw)
        self._R_WR = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        self._quat_WR = np.array([math.cos(self.robot_yaw / 2), 0, 0, math.sin(self.robot_yaw / 2)])

    def _allowed(self, allowed: Sequence[str] | None) -> list[str]:
        robot_geoms = [n for g, n in enumerate(self._geom_names) if self._robot_geom[g] and n]
        if allowed is None:
            sole = [n for n in robot_geoms if "sole" in n]
            if sole:
                return sole
            return [
                self._geom_names[g]
                for g in np.flatnonzero(self._robot_geom)
                if "foot" in self._body_names[self.model.geom_bodyid[g]] and self._geom_names[g]
            ]
        if isinstance(allowed, str):
            raise InvalidInput(f"allowed contacts must be a list of geom names, got {allowed!r}")
        for name in allowed:
            if name not in robot_geoms:
                raise UnknownName("robot geom", name, robot_geoms)
        return list(allowed)

    # -------------------------------------------------------------------- pose
    @property
    def robot_nq(self) -> int:
        """Length of a robot configuration (``robot_model.nq``)."""
        return int(self.robot_model.nq)

    def scene_qpos(self, q_robot: ArrayLike, base: np.ndarray | None = None) -> np.ndarray:
        """The scene's ``qpos`` holding the robot configuration ``q_robot``.

        Joints are mapped by name; a free joint's pose ``(p, quat)`` in the robot
        model's world becomes ``(p_WR + R_WR p, quat_WR ⊗ quat)`` in the scene.
        Environment entries come from ``base`` (default: the model's ``qpos0``),
        except grasped objects, placed at ``X_WF(q) X_FO`` (:class:`Grasp`).

        Raises:
            InvalidInput: Wrong length or non-finite values.
        """
        q = np.asarray(q_robot, dtype=float)
        if q.shape != (self.robot_nq,):
            raise InvalidInput(
                f"q_robot must be the robot model's qpos of shape ({self.robot_nq},), "
                f"got shape {q.shape} (scene nq is {self.model.nq})"
            )
        if not np.all(np.isfinite(q)):
            raise InvalidInput(f"q_robot holds NaN or inf: {q}")
        out = (self.model.qpos0 if base is None else base).copy()
        out[self._dst] = q[self._src]
        for a, b in self._free:
            out[b : b + 3] = self.robot_pos + self._R_WR @ q[a : a + 3]
            quat = np.empty(4)
            mujoco.mju_mulQuat(
                quat, self._quat_WR, q[a + 3 : a + 7] / np.linalg.norm(q[a + 3 : a + 7])
            )
            out[b + 3 : b + 7] = quat
        if self.grasps:
            d = self._kin_data
            d.qpos[:] = out
            mujoco.mj_kinematics(self.model, d)
            for g, frame, adr in zip(
                self.grasps, self._grasp_frames, self._grasp_qadr, strict=True
            ):
                R_WF = frame.rotation(d)
                out[adr : adr + 3] = frame.position(d) + R_WF @ g.p_FO
                quat = np.empty(4)
                mujoco.mju_mat2Quat(quat, np.ascontiguousarray(R_WF @ g.R_FO).ravel())
                out[adr + 3 : adr + 7] = quat
        return out

    def set_pose(self, q_robot: ArrayLike) -> None:
        """Write ``q_robot`` into the physics state: zero velocity, servo targets
        at the pose, ``mj_forward``. Environment joints keep their state."""
        self.data.qpos[:] = self.scene_qpos(q_robot, base=self.data.qpos)
        self.data.qvel[:] = 0.0
        self.data.ctrl[:] = 0.0
        self.data.ctrl[self._servo_ids] = self.data.qpos[self._servo_qadr]
        mujoco.mj_forward(self.model, self.data)

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

    def _touching(self, qpos: np.ndarray) -> list[ContactInfo]:
        """Robot contacts within ``contact_tolerance`` at the scene state ``qpos``
        (collision detection on the probe model, as :meth:`static_check`)."""
        m, d = self._probe_model, self._probe_data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        return self._contacts(m, d, self.contact_tolerance)

    def _up(self) -> np.ndarray:
        g = np.asarray(self.model.opt.gravity, dtype=float)
        n = float(np.linalg.norm(g))
        return -g / n if n > 0 else np.array([0.0, 0.0, 1.0])

    def _ground_points(self, contacts: list[ContactInfo], max_slope: float) -> np.ndarray:
        up = self._up()
        cos_max = math.cos(max_slope)
        pts = [c.position for c in contacts if not c.self_contact and c.normal @ up >= cos_max]
        return np.array(pts).reshape(-1, 3)

    # ------------------------------------------------------------ static check
    def static_check(
        self,
        q_robot: ArrayLike,
        *,
        mu: float | None = None,
        external: Sequence[balance.ExternalWrench] = (),
        pyramid: Literal["inscribed", "circumscribed"] = "inscribed",
        max_ground_slope: float = math.pi / 4,
        scfr: bool = False,
    ) -> StaticReport:
        """Contacts, support polygon, CoM margin and static equilibrium of a pose.

        Collision detection runs on a copy of the model whose robot geoms have
        ``margin = contact_tolerance``; contacts with ``dist <= contact_tolerance``
        count. Each environment contact ``i`` is a point contact at ``p_i`` with
        normal ``n_i`` into the robot; the LP (HiGHS) asks for forces ``f_i``

        .. math::

            \\sum_i f_i + m g + \\sum_k f_k = 0, \\quad
            \\sum_i p_i \\times f_i + c \\times m g + \\sum_k (\\tau_k + p_k \\times f_k) = 0,

            f_i \\cdot n_i \\ge 0, \\quad |f_i \\cdot t_{i,j}| \\le \\mu' f_i \\cdot n_i

        (``μ' = μ/√2`` for the inscribed pyramid). The support polygon is the
        convex hull of the contacts whose normal is within ``max_ground_slope``
        of up, projected along gravity; ``margin = min_j (a_j^T c + b_j)`` [m].

        Args:
            q_robot: Robot configuration (``robot_model.nq``).
            mu: Friction coefficient for the LP; None uses each contact's MuJoCo
                friction.
            external: External wrenches on the robot.
            pyramid: Friction pyramid (see :class:`pik_mj.balance.ContactConstraint`).
            max_ground_slope: Largest angle [rad] between a contact normal and up
                for the contact to count in the support polygon.
            scfr: Also compute the margin to the static centroid feasible region
                of the actual contacts (:func:`pik_mj.balance.scfr`, ~20-60 LPs).

        Returns:
            A :class:`StaticReport`.
        """
        if mu is not None and not (math.isfinite(mu) and mu >= 0):
            raise InvalidInput(f"mu must be finite and >= 0, got {mu}")
        m, d = self._probe_model, self._probe_data
        d.qpos[:] = self.scene_qpos(q_robot)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        contacts = self._contacts(m, d, self.contact_tolerance)
        com = self.com(d)
        polygon, margin = _support(
            self._ground_points(contacts, max_ground_slope), balance.plane_basis(self._up()), com
        )
        env = [c for c in contacts if not c.self_contact]
        gravity = np.asarray(m.opt.gravity, dtype=float)
        forces = None
        scfr_margin = None
        if not env:
            feasible, message = False, "no contact with the environment"
        else:
            cons = [
                balance.contact_from_normal(
                    c.position, c.normal, mu=c.friction if mu is None else mu, pyramid=pyramid
                )
                for c in env
            ]
            result = balance.static_equilibrium(
                cons, self.mass + self.carried_mass, com, external, gravity
            )
            feasible, message = result.feasible, result.message
            if result.wrenches is not None:
                forces = result.wrenches[:, :3].copy()
            if scfr:
                scfr_margin = self._scfr_margin(cons, com, external, gravity)
        return StaticReport(
            contacts=contacts,
            support_polygon=polygon,
            com=com,
            margin=margin,
            feasible=feasible,
            message=message,
            forces=forces,
            mu=mu,
            scfr_margin=scfr_margin,
            q=np.array(q_robot, dtype=float),
        )

    def _scfr_margin(
        self,
        cons: list[balance.ContactConstraint],
        com: np.ndarray,
        external: Sequence[balance.ExternalWrench],
        gravity: np.ndarray,
    ) -> float:
        pts = np.array([c.p_WC for c in cons])
        lo, hi = pts[:, :2].min(axis=0) - 2.0, pts[:, :2].max(axis=0) + 2.0
        try:
            region = balance.scfr(
                cons,
                self.mass + self.carried_mass,
                external,
                gravity,
                com_z=float(com[2]),
                bounds=(lo[0], hi[0], lo[1], hi[1]),
            )
        except InvalidInput:  # degenerate region (a segment or a point)
            return -math.inf
        return region.signed_distance(com[:2])

    def iteration_callback(
        self,
        *,
        mu: float | None = None,
        external: Sequence[balance.ExternalWrench] = (),
        scfr: bool = False,
        recorder: Any = None,
        then: Callable[[Any], None] | None = None,
    ) -> StaticCheckLog:
        """A callback for :func:`pik_mj.solve` that runs :meth:`static_check` on
        every iteration's configuration and keeps the reports.

        Args:
            mu: See :meth:`static_check`.
            external: See :meth:`static_check`.
            scfr: See :meth:`static_check`.
            recorder: Optional :class:`pik_mj.record.Recorder`: the support polygon,
                CoM and contact forces are logged on the ``iteration`` timeline.
            then: Another callback called afterwards with the same argument.

        Returns:
            A :class:`StaticCheckLog` (``.reports``: one :class:`StaticReport` per
            iteration).
        """
        return StaticCheckLog(
            self, mu=mu, external=external, scfr=scfr, recorder=recorder, then=then
        )

    # -------------------------------------------------------------- stepping
    def _offender(self, warning: mujoco.mjtWarning, index: int) -> str:
        """Name of what a MuJoCo warning's ``lastinfo`` index points at."""
        m = self.model
        try:
            if warning == mujoco.mjtWarning.mjWARN_BADQPOS:
                j = int(np.searchsorted(m.jnt_qposadr, index, side="right") - 1)
                return f"qpos[{index}] (joint {m.joint(j).name!r})"
            if warning in (mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC):
                return f"dof {index} (joint {m.joint(int(m.dof_jntid[index])).name!r})"
            if warning == mujoco.mjtWarning.mjWARN_BADCTRL:
                return f"actuator {index} ({m.actuator(index).name!r})"
        except (IndexError, KeyError):
            pass
        return f"index {index}"

    def _check_state(self, before: np.ndarray, t: float, messages: list[str]) -> None:
        d = self.data
        numbers = self._warning_counts()
        fired = [w for w, b, a in zip(UNSTABLE_WARNINGS, before, numbers, strict=True) if a > b]
        if fired or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
            what = [
                f"{w.name} at {self._offender(w, int(d.warning[int(w)].lastinfo))}" for w in fired
            ]
            detail = f"; MuJoCo says: {' | '.join(messages)}" if messages else ""
            raise SimulationUnstable(
                f"simulation unstable in the step from t = {t:.4f} s: "
                f"{', '.join(what) or 'non-finite qpos/qvel'}{detail}"
            )

    def _warning_counts(self) -> np.ndarray:
        return np.array([self.data.warning[int(w)].number for w in UNSTABLE_WARNINGS])

    def step(self, n: int = 1) -> None:
        """Advance the physics ``n`` steps, checking the state after each.

        Like dm_control's ``check_invalid_state``: MuJoCo's warning counters
        (``mjWARN_BADQACC``, ``BADQVEL``, ``BADQPOS``, ``BADCTRL``, full contact or
        constraint buffers) are compared before and after each step, and a NaN
        or inf in ``qpos``/``qvel`` is caught.

        Raises:
            SimulationUnstable: A warning fired or the state is not finite.
        """
        if not isinstance(n, int) or n < 0:
            raise InvalidInput(f"n must be a non-negative integer, got {n!r}")
        messages: list[str] = []
        with _collect_mujoco_warnings(messages):
            for _ in range(n):
                before, t = self._warning_counts(), float(self.data.time)
                mujoco.mj_step(self.model, self.data)
                self._check_state(before, t, messages)

    # -------------------------------------------------------------------- hold
    def holding_torques(
        self, q_robot: ArrayLike, external: Sequence[tuple[str, ArrayLike, ArrayLike]] = ()
    ) -> np.ndarray | None:
        r"""Generalized forces that hold ``q_robot`` still against gravity, the
        contact forces and the external wrenches:

        .. math::

            \tau = g(q) - \sum_i J_{p}(p_i)^T f_i - \sum_e J_e^T w_e
               - \sum_o J_{p,F_o}(c_o)^T m_o g

        ``g`` comes from ``qfrc_bias`` at zero velocity; ``f_i`` are the
        least-norm forces inside the friction pyramids that balance the robot at
        the actual contacts ``p_i`` (the equilibrium LP's own forces are any
        feasible point, often on a cone's edge, which would push the feet to
        slip). The rows on the servo joints are the static feed-forward of a PD
        hold with gravity compensation; the free-joint rows are ~0. A grasped
        object's weight ``m_o g`` acts at its CoM ``c_o`` on the grasping frame's
        body (the weld carries it in the physics); the contact forces balance the
        robot and its objects.

        Returns:
            ``(nv,)`` [N, N·m], or None when the pose has no static equilibrium.
        """
        m, d = self.model, self.data
        self.set_pose(q_robot)
        wrenches = [
            balance.ExternalWrench(Frame.find(m, f).position(d), F, M) for f, F, M in external
        ]
        report = self.static_check(q_robot, external=wrenches)
        if not report.feasible or report.forces is None:
            return None
        forces = _least_norm_forces(report, self.mass + self.carried_mass, m.opt.gravity, wrenches)
        if forces is None:
            return None
        self.set_pose(q_robot)
        tau = d.qfrc_bias.copy()
        jacp = np.zeros((3, m.nv))
        for c, f in zip(report.environment_contacts, forces, strict=True):
            mujoco.mj_jac(
                m, d, jacp, None, c.position, int(m.geom_bodyid[self._geom_id[c.robot_geom]])
            )
            tau -= jacp.T @ f
        for frame, b in zip(self._grasp_frames, self._grasp_bodies, strict=True):
            # the weight of a grasped object hangs on the frame's body at its CoM
            mujoco.mj_jac(m, d, jacp, None, d.subtree_com[b], frame.body_id)
            tau -= jacp.T @ (m.body_subtreemass[b] * np.asarray(m.opt.gravity))
        qfrc = np.zeros(m.nv)
        for (frame, F, M), w in zip(external, wrenches, strict=True):
            body = Frame.find(m, frame).body_id
            mujoco.mj_applyFT(
                m,
                d,
                np.asarray(F, float),
                np.asarray(M, float),
                np.asarray(w.p_W, float),
                body,
                qfrc,
            )
        return tau - qfrc

    def _external_wrench(self, frame: str, force: ArrayLike, moment: ArrayLike):
        """A function writing ``(force at the frame origin, moment)`` to
        ``xfrc_applied`` of the frame's body: torque about the body CoM
        ``n + (p_WF - p_WCoM) × f``."""
        f = np.asarray(force, dtype=float).reshape(-1)
        n = np.asarray(moment, dtype=float).reshape(-1)
        if f.shape != (3,) or n.shape != (3,) or not np.all(np.isfinite(np.r_[f, n])):
            raise InvalidInput(
                f"external wrench at {frame!r}: force and moment must be 3 finite numbers"
            )
        target = Frame.find(self.model, frame)
        body = target.body_id

        def apply(d: mujoco.MjData) -> None:
            lever = target.position(d) - d.xipos[body]
            d.xfrc_applied[body, :3] = f
            d.xfrc_applied[body, 3:] = n + np.cross(lever, f)

        return apply

    def hold(
        self,
        q_robot: ArrayLike,
        duration: float = 3.0,
        *,
        recorder: Any = None,
        record_every: int = 10,
        margin_every: int = 5,
        allowed: Sequence[str] | None = None,
        max_drift: float = 0.01,
        max_slip: float = 0.002,
        fall_ratio: float = 0.8,
        allow_self_contact: bool = False,
        stop_on_fall: bool = True,
        max_ground_slope: float = math.pi / 4,
        feet: Sequence[str] | None = None,
        external: Sequence[tuple[str, ArrayLike, ArrayLike]] = (),
        feedforward: bool = True,
    ) -> HoldReport:
        """Hold ``q_robot`` with the servos and step the physics for ``duration``.

        The state is reset (environment at ``qpos0``), the pose written with zero
        velocity and the servo targets set to it. Per step, with ``p_B`` the root
        body position and ``p_g`` each allowed geom's centre:

        .. math::

            \\text{drift} = \\max_t \\|p_B(t) - p_B(0)\\|, \\qquad
            \\text{slip} = \\max_{g,t} \\|(p_g(t) - p_g(t_g))_{xy}\\|

        where ``t_g`` is when geom ``g`` last came into contact. Verdict: drift <
        ``max_drift``, foot slip (``slip`` over the ``feet`` geoms) < ``max_slip``,
        no fall (root height >= ``fall_ratio``
        of its start), no contact of a robot geom outside ``allowed`` with the
        environment and (unless ``allow_self_contact``) no self-contact.

        Args:
            q_robot: Robot configuration (``robot_model.nq``).
            duration: Simulated time [s].
            recorder: Optional :class:`pik_mj.record.Recorder`: model geometry, body
                poses, CoM, support polygon and ``hold/*`` metrics on ``sim_time``.
            record_every: Log every this many steps.
            margin_every: Evaluate the CoM margin every this many steps (a convex
                hull per evaluation, ~0.5 ms).
            allowed: Robot geoms allowed to touch the environment (default: the
                scene's ``allowed_contacts``).
            max_drift: Drift threshold [m].
            max_slip: Slip threshold [m].
            fall_ratio: Fall threshold on the root height [-].
            allow_self_contact: Do not count robot self-contacts as unexpected.
            stop_on_fall: End the simulation as soon as the robot fell.
            max_ground_slope: See :meth:`static_check`.
            feet: Geoms whose slip is the verdict's foot slip (default: the allowed
                geoms named ``*sole*`` or ``*foot*``, else all allowed geoms). A
                hand on a wall or a handle still appears in ``slip_per_geom``.
            external: Wrenches acting on the robot during the hold, as
                ``(frame, force (3,) [N], moment (3,) [N·m])`` with the force applied
                at the frame's origin (a site or body name of the scene), written
                to ``xfrc_applied`` of the frame's body every step.
            feedforward: Add :meth:`holding_torques` on the servo joints (PD with
                gravity compensation): the hold then starts in equilibrium instead
                of sagging onto its servos' error, which with the default gains
                (damping ratio ~0.1) overshoots by 1-2 cm and can tip a pose with
                a small margin. Nothing is added when the pose has no equilibrium.

        Returns:
            A :class:`HoldReport`.

        Raises:
            SimulationUnstable: MuJoCo reported an invalid state.
        """
        if not (math.isfinite(duration) and duration > 0):
            raise InvalidInput(f"duration must be > 0 [s], got {duration}")
        if not isinstance(record_every, int) or record_every < 1:
            raise InvalidInput(f"record_every must be a positive integer, got {record_every!r}")
        if not isinstance(margin_every, int) or margin_every < 1:
            raise InvalidInput(f"margin_every must be a positive integer, got {margin_every!r}")
        allowed_names = self.allowed_contacts if allowed is None else self._allowed(allowed)
        allowed_ids = {self.model.geom(n).id for n in allowed_names}
        if feet is None:
            feet = [n for n in allowed_names if "sole" in n or "foot" in n] or list(allowed_names)
        foot_names = set(self._allowed(feet))
        wrenches = [self._external_wrench(*w) for w in external]
        m, d = self.model, self.data
        tau = self.holding_torques(q_robot, external) if feedforward else None
        mujoco.mj_resetData(m, d)
        self.set_pose(q_robot)
        if tau is not None:
            d.qfrc_applied[self._servo_dofs] = tau[self._servo_dofs]
        t_wall = time.perf_counter()
        n_steps = max(1, round(duration / m.opt.timestep))
        up = self._up()
        p0 = d.xpos[self._root_id].copy()
        h0 = float(p0 @ up)
        drift = drift_h = drift_v = 0.0
        min_margin = math.inf
        slip: dict[str, float] = {}
        anchor: dict[int, np.ndarray] = {}  # geom id -> horizontal position at touch-down
        unexpected: dict[tuple[str, str], float] = {}
        fell = False
        P_h = np.eye(3) - np.outer(up, up)
        R_up = balance.plane_basis(up)
        if recorder is not None:
            recorder.log_model_geometry(m, d, robot_root_body=self.root_body)
        messages: list[str] = []
        steps = 0
        with _collect_mujoco_warnings(messages):
            for k in range(n_steps + 1):
                if k > 0:
                    before, t = self._warning_counts(), float(d.time)
                    for apply in wrenches:
                        apply(d)
                    mujoco.mj_step(m, d)
                    self._check_state(before, t, messages)
                    steps += 1
                contacts = self._contacts(m, d, 0.0)
                touching = set()
                for c in contacts:
                    if c.self_contact:
                        if not allow_self_contact:
                            unexpected.setdefault((c.robot_geom, c.other_geom), float(d.time))
                        continue
                    g = self._geom_id[c.robot_geom]
                    if g in allowed_ids:
                        touching.add(g)
                    else:
                        unexpected.setdefault((c.robot_geom, c.other_geom), float(d.time))
                for g in list(anchor):
                    if g not in touching:
                        del anchor[g]
                for g in touching:
                    p = P_h @ d.geom_xpos[g]
                    a = anchor.setdefault(g, p)
                    name = self._geom_names[g]
                    slip[name] = max(slip.get(name, 0.0), float(np.linalg.norm(p - a)))
                dp = d.xpos[self._root_id] - p0
                drift = max(drift, float(np.linalg.norm(dp)))
                drift_h = max(drift_h, float(np.linalg.norm(P_h @ dp)))
                drift_v = max(drift_v, abs(float(dp @ up)))
                com = self.com()
                log = recorder is not None and k % record_every == 0
                if k % margin_every == 0 or log:
                    touching = self._touching(d.qpos)
                    ground = self._ground_points(touching, max_ground_slope)
                    polygon, margin = _support(ground, R_up, com)
                    min_margin = min(min_margin, margin)
                if log:
                    self._record_hold(
                        recorder, d, com, polygon, drift, max(slip.values(), default=0.0), margin
                    )
                if float(d.xpos[self._root_id] @ up) < fall_ratio * h0:
                    fell = True
                    if stop_on_fall:
                        break
        final = d.xpos[self._root_id] - p0
        max_slip_seen = max((v for n, v in slip.items() if n in foot_names), default=0.0)
        failures = []
        if drift >= max_drift:
            failures.append(f"base drift {drift * 1e3:.1f} mm >= {max_drift * 1e3:.1f} mm")
        if max_slip_seen >= max_slip:
            failures.append(f"foot slip {max_slip_seen * 1e3:.2f} mm >= {max_slip * 1e3:.2f} mm")
        if fell:
            failures.append(f"fell: root height below {fall_ratio:.0%} of its start")
        if unexpected:
            pairs = ", ".join(f"{a}-{b}" for a, b in unexpected)
            failures.append(f"unexpected contacts: {pairs}")
        return HoldReport(
            passed=not failures,
            failures=failures,
            drift=drift,
            drift_horizontal=drift_h,
            drift_vertical=drift_v,
            final_displacement=final.copy(),
            slip=max_slip_seen,
            slip_per_geom=slip,
            min_margin=min_margin,
            fell=fell,
            unexpected_contacts=[(a, b, t) for (a, b), t in unexpected.items()],
            allowed=list(allowed_names),
            thresholds={"max_drift": max_drift, "max_slip": max_slip, "fall_ratio": fall_ratio},
            duration=float(duration),
            simulated=float(d.time),
            steps=steps,
            timestep=float(m.opt.timestep),
            root_height=(h0, float(d.xpos[self._root_id] @ up)),
            wall_time=time.perf_counter() - t_wall,
        )

    def _record_hold(
        self,
        recorder: Any,
        d: mujoco.MjData,
        com: np.ndarray,
        polygon: np.ndarray,
        drift: float,
        slip: float,
        margin: float,
    ) -> None:
        recorder.log_body_poses(d, timeline="sim_time", time=float(d.time))
        recorder.log_com(com)
        if len(polygon) >= 3:
            recorder.log_polygon(polygon)
        paths = recorder.paths
        recorder.log_scalar(paths.hold_metric("drift"), drift)
        recorder.log_scalar(paths.hold_metric("slip"), slip)
        if math.isfinite(margin):
            recorder.log_scalar(paths.hold_metric("margin"), margin)

    def __repr__(self) -> str:
        return (
            f"Scene(root_body={self.root_body!r}, nq={self.model.nq}, "
            f"servos={len(self.servo_joints)}, timestep={self.model.opt.timestep}, "
            f"mass={self.mass:.2f} kg, allowed_contacts={self.allowed_contacts}"
            + (f", grasps={[(g.frame, g.body) for g in self.grasps]}" if self.grasps else "")
            + ")"
        )


@dataclass
class StaticCheckLog:
    """Per-iteration static checks for :func:`pik_mj.solve` (``callback=``).

    Attributes:
        scene: The scene checked against.
        reports: One :class:`StaticReport` per solver iteration, in order.
    """

    scene: Scene
    mu: float | None = None
    external: Sequence[balance.ExternalWrench] = ()
    scfr: bool = False
    recorder: Any = None
    then: Callable[[Any], None] | None = None
    reports: list[StaticReport] = field(default_factory=list)

    def __call__(self, info: Any) -> None:
        report = self.scene.static_check(
            info.configuration.q, mu=self.mu, external=self.external, scfr=self.scfr
        )
        self.reports.append(report)
        if self.recorder is not None:
            self.recorder.set_time("iteration", int(info.iteration))
            if len(report.support_polygon) >= 3:
                self.recorder.log_polygon(report.support_polygon)
            if report.forces is not None:
                env = report.environment_contacts
                self.recorder.log_contacts([c.position for c in env], report.forces)
        if self.then is not None:
            self.then(info)

    def to_dicts(self) -> list[dict[str, Any]]:
        """``to_dict()`` of every report."""
        return [r.to_dict() for r in self.reports]


# ----------------------------------------------------------------------------
# Convenience for the CLI
# ----------------------------------------------------------------------------


def validate_pose(
    robot: RobotLike,
    q: ArrayLike | str | None = None,
    environment: EnvironmentLike = None,
    duration: float = 3.0,
    *,
    mu: float | None = None,
    robot_pos: ArrayLike = (0.0, 0.0, 0.0),
    robot_yaw: float = 0.0,
    allowed: Sequence[str] | None = None,
    grasps: Sequence[Grasp | tuple[str, str, ArrayLike, ArrayLike]] = (),
    recorder: Any = None,
) -> dict[str, Any]:
    """Static check and physics hold of one pose (for ``pik-mj validate``).

    Args:
        robot: Robot model name, MJCF path or spec.
        q: Robot configuration (``nq`` of the robot model), the name of one of the
            robot's keyframes, or None for ``reset_pose`` (``qpos0`` if absent).
        environment: See :class:`Scene`.
        duration: Hold duration [s].
        mu: Friction coefficient of the equilibrium LP (None: MuJoCo's).
        robot_pos: See :class:`Scene`.
        robot_yaw: See :class:`Scene`.
        allowed: Robot geoms allowed to touch the environment.
        grasps: Objects held by robot frames (see :class:`Scene`).
        recorder: Optional recorder for the hold.

    Returns:
        ``{"robot", "environment", "static": StaticReport.to_dict(),
        "hold": HoldReport.to_dict(), "passed": feasible and hold passed}``.
    """
    scene = Scene(
        robot,
        environment,
        robot_pos=robot_pos,
        robot_yaw=robot_yaw,
        allowed_contacts=allowed,
        grasps=grasps,
    )
    rm = scene.robot_model
    if q is None or isinstance(q, str):
        key = "reset_pose" if q is None else q
        k = mujoco.mj_name2id(rm, mujoco.mjtObj.mjOBJ_KEY, key)
        if k < 0:
            if q is not None:
                raise UnknownName("keyframe", key, _names(rm, mujoco.mjtObj.mjOBJ_KEY, rm.nkey))
            q_robot = rm.qpos0.copy()
        else:
            q_robot = rm.key_qpos[k].copy()
    else:
        q_robot = np.asarray(q, dtype=float)
    static = scene.static_check(q_robot, mu=mu)
    hold = scene.hold(q_robot, duration, recorder=recorder)

    def label(x: object) -> str | None:
        if isinstance(x, mujoco.MjSpec):
            return x.modelname or "spec"
        return None if x is None else str(x)

    return {
        "robot": label(robot),
        "environment": label(environment),
        "static": static.to_dict(),
        "hold": hold.to_dict(),
        "passed": bool(static.feasible and hold.passed),
    }
