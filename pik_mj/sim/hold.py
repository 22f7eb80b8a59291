"""The physics hold of a pose (DESIGN.md §5), and the stepping loop it shares
with a motion (:mod:`pik_mj.sim.motion`).

:func:`track` is the one loop that steps a scene's physics while its servos
track a reference, measuring against that reference: root drift, foot slip,
CoM margin to the support polygon of the actual contacts, unexpected contacts,
falling, joint and task-frame tracking errors. A hold is the constant
reference (:class:`HeldPose`); a motion is a reference that moves along the
iterates of a solve (:class:`pik_mj.sim.motion.MotionReference`).

:meth:`pik_mj.sim.Scene.hold` runs :func:`hold`. Its pass/fail thresholds are one
:class:`HoldCriteria`; every ``every`` steps each callback gets a
:class:`HoldSample` (e.g. a recorder's ``hold_logger()``); the outcome is a
:class:`HoldReport`. The steps go through the scene's state guard
(:meth:`pik_mj.sim.Scene.step`), so an unstable simulation raises.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.dynamics import contact_wrenches
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.sim.static import finite_or_none, point_contacts

if TYPE_CHECKING:
    from pik_mj.sim.scene import External, Scene

__all__ = [
    "HeldPose",
    "HoldCriteria",
    "HoldReport",
    "HoldSample",
    "Reference",
    "Tracked",
    "hold",
    "holding_torques",
    "track",
]


@dataclass(frozen=True)
class HoldCriteria:
    """What a physics hold must show to pass.

    Attributes:
        max_drift: Largest root-body displacement [m] (drift < max_drift).
        max_slip: Largest horizontal slip [m] of a foot geom while in contact.
        fall_ratio: The robot fell when its root height drops below this ratio of
            its start [-].
        allowed: Robot geoms allowed to touch the environment (default: the
            scene's ``allowed_contacts``, its soles); repeated names count once.
        feet: Geoms whose slip is the verdict's foot slip (default: the allowed
            geoms among the scene's ``foot_geoms``, else all allowed geoms). A
            hand on a wall or a handle still appears in ``slip_per_geom``.
        allow_self_contact: Do not count robot self-contacts as unexpected.
        stop_on_fall: End the simulation as soon as the robot fell.
        max_ground_slope: Largest angle [rad] between a contact normal and up for
            the contact to count in the support polygon.
    """

    max_drift: float = 0.01
    max_slip: float = 0.002
    fall_ratio: float = 0.8
    allowed: Sequence[str] | None = None
    feet: Sequence[str] | None = None
    allow_self_contact: bool = False
    stop_on_fall: bool = True
    max_ground_slope: float = math.pi / 4

    def __post_init__(self) -> None:
        for label in ("max_drift", "max_slip"):
            inputs.real(getattr(self, label), label, unit="m", low=0, low_open=True)
        inputs.real(self.fall_ratio, "fall_ratio", low=0, high=1, low_open=True, high_open=True)
        inputs.real(self.max_ground_slope, "max_ground_slope", unit="rad", low=0, high=math.pi / 2)
        inputs.flag(self.allow_self_contact, "allow_self_contact")
        inputs.flag(self.stop_on_fall, "stop_on_fall")
        for label, names in (("allowed", self.allowed), ("feet", self.feet)):
            if names is not None:
                names = inputs.names(names, f"{label} (robot geoms)")
                object.__setattr__(self, label, tuple(dict.fromkeys(names)))

    def thresholds(self) -> dict[str, float]:
        return {
            "max_drift": self.max_drift,
            "max_slip": self.max_slip,
            "fall_ratio": self.fall_ratio,
        }


@dataclass(eq=False)
class HoldSample:
    """The physics state a hold callback receives (valid during the call).

    Attributes:
        time: Simulated time [s].
        step: Physics steps taken.
        model: The physics model.
        data: The physics state now (do not modify).
        com: CoM ``p_WG`` (3,) [m] of the robot and its grasped objects.
        drift: Largest root displacement so far [m].
        slip: Largest foot slip so far [m].
        support_polygon: Support polygon of the touching ground contacts (m, 3) [m]
            (computed on first access).
        margin: CoM margin to it [m] (``-inf`` without ground contact).
        contact_points: Active contact points with the environment (n, 3) [m].
        contact_forces: MuJoCo's contact forces on the robot there (n, 3) [N].
        reference: Kinematics of the reference pose now (a motion's; None in a
            hold, whose reference is its start).
        waypoint: Index of the last waypoint the reference passed (a motion's),
            or None.
        tracking_error: Largest servo joint error ``|q - q_ref|`` now [rad or m].
        frame_errors: Distance [m] of each tracked task frame to its reference
            position, by frame name (computed on first access; empty in a hold).
    """

    time: float
    step: int
    model: mujoco.MjModel
    data: mujoco.MjData
    com: np.ndarray
    drift: float
    slip: float
    _scene: Scene = field(repr=False)
    reference: mujoco.MjData | None = field(default=None, repr=False)
    waypoint: int | None = None
    tracking_error: float = 0.0
    _frames: Sequence[Frame] = field(default=(), repr=False)
    _max_slope: float = field(default=math.pi / 4, repr=False)
    _support: tuple[np.ndarray, float] | None = field(default=None, repr=False)

    def _region(self) -> tuple[np.ndarray, float]:
        if self._support is None:
            contacts = self._scene.touching(self.data.qpos)
            region, margin = self._scene.support(contacts, self.com, self._max_slope)
            polygon = np.zeros((0, 3)) if region is None else region.vertices_3d
            self._support = (polygon, margin)
        return self._support

    @property
    def support_polygon(self) -> np.ndarray:
        return self._region()[0]

    @property
    def margin(self) -> float:
        return self._region()[1]

    @functools.cached_property
    def _contact_forces(self) -> tuple[np.ndarray, np.ndarray]:
        return self._scene.contact_forces(self.data)

    @property
    def contact_points(self) -> np.ndarray:
        return self._contact_forces[0]

    @property
    def contact_forces(self) -> np.ndarray:
        return self._contact_forces[1]

    @functools.cached_property
    def frame_errors(self) -> dict[str, float]:
        if self.reference is None:
            return {}
        return {
            f.name: float(np.linalg.norm(f.position(self.data) - f.position(self.reference)))
            for f in self._frames
        }


@dataclass
class HoldReport:
    """Result of :meth:`pik_mj.sim.Scene.hold`.

    Attributes:
        passed: Every criterion holds (see ``failures``).
        failures: One line per failed criterion.
        drift: Largest displacement of the root body from its start [m].
        drift_horizontal: Largest horizontal displacement of the root body [m].
        drift_vertical: Largest vertical displacement of the root body [m].
        final_displacement: Root body displacement at the end (3,) [m].
        slip: Largest horizontal displacement of a foot geom while it stayed in
            contact with the environment [m].
        slip_per_geom: Slip of each allowed geom that touched the environment.
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
            "min_margin": finite_or_none(self.min_margin),
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


def _external_wrench(scene: Scene, frame: str, force: ArrayLike, moment: ArrayLike):
    """A function ``apply(data, scale)`` writing ``scale (force at the frame
    origin, moment)`` to ``xfrc_applied`` of the frame's body: torque about the
    body CoM ``n + (p_WF - p_WCoM) × f``."""
    f = np.asarray(force, dtype=float)  # checked by inputs.wrenches
    n = np.asarray(moment, dtype=float)
    target = Frame.find(scene.model, frame)
    body = target.body_id

    def apply(d: mujoco.MjData, scale: float = 1.0) -> None:
        lever = target.position(d) - d.xipos[body]
        d.xfrc_applied[body, :3] = scale * f
        d.xfrc_applied[body, 3:] = scale * (n + np.cross(lever, f))

    return apply


def holding_torques(
    scene: Scene, q: ArrayLike, external: Sequence[External] = ()
) -> np.ndarray | None:
    r"""Generalized forces that hold ``q`` still against gravity, the contact
    forces and the external wrenches:

    .. math::

        \tau = g(q) - \tau_{passive}(q) - \sum_i J_{p}(p_i)^T f_i - \sum_e J_e^T w_e
           - \sum_o J_{p,F_o}(c_o)^T m_o g

    ``g`` comes from ``qfrc_bias`` at zero velocity, ``τ_passive`` from
    ``qfrc_passive`` (joint springs: dm_control's humanoid has them); ``f_i`` are the
    least-norm forces inside the friction pyramids that balance the robot at
    the actual contacts ``p_i`` (:func:`pik_mj.dynamics.contact_wrenches`; the
    equilibrium LP's own forces are any feasible point, often on a cone's
    edge, which would push the feet to slip). The rows on the servo joints
    are the static feed-forward of a PD hold with gravity compensation; the
    free-joint rows are ~0. A grasped object's weight ``m_o g`` acts at its
    CoM ``c_o`` on the grasping frame's body (the weld carries it in the
    physics); the contact forces balance the robot and its objects.

    Returns:
        ``(nv,)`` [N, N·m], or None when the pose has no static equilibrium.
    """
    m, d = scene.model, scene.data
    scene.set_pose(q)
    wrenches = scene._wrenches(d, external)
    report = scene.static_check(q, external=external)
    if not report.feasible or report.forces is None:
        return None
    weight = (scene.mass + scene.carried_mass) * np.asarray(m.opt.gravity, dtype=float)
    total = -np.concatenate([weight, np.cross(report.com, weight)])
    for w in wrenches:
        F, M = np.asarray(w.force, float), np.asarray(w.moment, float)
        total -= np.concatenate([F, np.cross(np.asarray(w.p_W, float), F) + M])
    env = report.environment_contacts
    solved = contact_wrenches(point_contacts(env, report.mu), total)
    if solved is None:
        return None
    scene.set_pose(q)
    tau = d.qfrc_bias - d.qfrc_passive  # gravity, less the joints' springs
    jacp = np.zeros((3, m.nv))
    for c, f in zip(env, solved[:, :3], strict=True):
        mujoco.mj_jac(
            m, d, jacp, None, c.position, int(m.geom_bodyid[scene._geom_id[c.robot_geom]])
        )
        tau -= jacp.T @ f
    for frame, b in zip(scene._grasp_frames, scene._grasp_bodies, strict=True):
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


# ---------------------------------------------------------------------------
# The stepping loop of a hold and a motion


class Reference(Protocol):
    """What :func:`track` steps the physics along.

    Attributes:
        moving: False for a constant reference (nothing to update per step).
        data: Kinematics of the reference pose now (an ``MjData`` of the scene's
            model: body, site and geom poses).
        waypoint: Index of the last waypoint passed, or None.
        load: Scale of the external wrenches now [-] (1: as given).
    """

    moving: bool
    data: mujoco.MjData
    waypoint: int | None
    load: float

    def begin(self) -> None:
        """Put the physics at the reference's start and write its controls."""

    def update(self, t: float) -> None:
        """Move the reference to time ``t`` [s] from its start: its kinematics
        (:attr:`data`) and the controls it writes into the physics state."""


class HeldPose:
    """The constant reference of a hold: the pose ``q`` at rest, the servo
    targets at it, and the static torques ``tau`` on the servo joints.

    Args:
        scene: The scene.
        q: Robot configuration.
        tau: Generalized forces (:func:`holding_torques`) written to
            ``qfrc_applied`` of the servo joints, or None.
    """

    moving = False
    waypoint: int | None = None
    load = 1.0

    def __init__(self, scene: Scene, q: ArrayLike, tau: np.ndarray | None):
        self.scene = scene
        self.q = np.asarray(q, dtype=float)
        self.tau = tau
        self.data = mujoco.MjData(scene.model)

    def begin(self) -> None:
        """Reset the state (environment at ``qpos0``), write the pose with zero
        velocity, the servo targets at it and the static torques."""
        scene = self.scene
        m, d = scene.model, scene.data
        mujoco.mj_resetData(m, d)
        scene.set_pose(self.q)
        if self.tau is not None:  # less what the actuators exert at rest (0 for servos and motors)
            dofs = scene._servo_dofs
            d.qfrc_applied[dofs] = self.tau[dofs] - d.qfrc_actuator[dofs]
        self.data.qpos[:] = d.qpos
        mujoco.mj_kinematics(m, self.data)

    def update(self, t: float) -> None:
        """Nothing moves."""


@dataclass
class Tracked:
    """What :func:`track` measured (see :class:`HoldReport` for the metrics).

    Attributes:
        drift: Largest root-body distance to its reference position [m].
        drift_horizontal: Its largest horizontal part [m].
        drift_vertical: Its largest vertical part [m].
        final_displacement: Root body minus its reference position at the end (3,) [m].
        slip_per_geom: Largest slip of each allowed geom that touched [m].
        foot_slip: Largest slip of a foot geom [m].
        min_margin: Smallest CoM margin to the support polygon [m].
        fell: The root dropped below ``fall_ratio`` of its reference height.
        unexpected: ``(robot geom, other geom) -> first time [s]``.
        steps: Physics steps taken.
        simulated: Simulated time [s].
        end_time: Physics time at the end [s].
        root_height: Root height at the start and at the end [m].
        tracking_error: Largest servo joint error ``|q - q_ref|`` [rad or m].
        tracking_joint: The joint where it was reached (None without servos).
        frame_errors: Largest distance of each tracked frame to its reference [m].
        series: ``time`` [s], ``margin`` [m], ``tracking_error`` and ``waypoint``
            every ``margin_every`` steps.
        wall_time: Wall-clock time [s].
    """

    drift: float
    drift_horizontal: float
    drift_vertical: float
    final_displacement: np.ndarray
    slip_per_geom: dict[str, float]
    foot_slip: float
    min_margin: float
    fell: bool
    unexpected: dict[tuple[str, str], float]
    steps: int
    simulated: float
    end_time: float
    root_height: tuple[float, float]
    tracking_error: float
    tracking_joint: str | None
    frame_errors: dict[str, float]
    series: dict[str, np.ndarray]
    wall_time: float

    def failures(self, criteria: HoldCriteria, drift: str = "base drift") -> list[str]:
        """One line per failed criterion of ``criteria``; ``drift`` names the drift."""
        out = []
        if self.drift >= criteria.max_drift:
            out.append(f"{drift} {self.drift * 1e3:.1f} mm >= {criteria.max_drift * 1e3:.1f} mm")
        if self.foot_slip >= criteria.max_slip:
            out.append(
                f"foot slip {self.foot_slip * 1e3:.2f} mm >= {criteria.max_slip * 1e3:.2f} mm"
            )
        if self.fell:
            out.append(f"fell: root height below {criteria.fall_ratio:.0%} of its reference")
        if self.unexpected:
            pairs = ", ".join(f"{a}-{b}" for a, b in self.unexpected)
            out.append(f"unexpected contacts: {pairs}")
        return out


def foot_geoms(scene: Scene, allowed: Sequence[str], criteria: HoldCriteria) -> set[str]:
    """The geoms whose slip is the verdict's (:attr:`HoldCriteria.feet`)."""
    feet = criteria.feet
    if feet is None:
        feet = [n for n in allowed if n in scene.foot_geoms] or list(allowed)
    return set(scene._allowed(feet))


def track(
    scene: Scene,
    reference: Reference,
    duration: float,
    *,
    criteria: HoldCriteria,
    allowed: Sequence[str],
    planned_pairs: set[frozenset[str]] | frozenset[frozenset[str]] = frozenset(),
    external: Sequence[External] = (),
    callbacks: Sequence[Callback] = (),
    every: int = 1,
    margin_every: int = 5,
    frames: Sequence[Frame] = (),
) -> Tracked:
    """Step the physics for ``duration`` [s] while the servos track ``reference``.

    ``reference.begin()`` sets the start state; before each step the external
    wrenches are written (scaled by ``reference.load``), after it a moving
    reference is updated to the new time (its kinematics, and the controls of
    the next step). With ``p_B`` the
    root body position, ``p_g`` each allowed geom's centre and ``ref`` the
    reference's value at the same time:

    .. math::

        \\text{drift} = \\max_t \\|p_B(t) - p_B^{ref}(t)\\|, \\qquad
        \\text{slip} = \\max_{g,t} \\|(\\Delta_g(t) - \\Delta_g(t_g))_{xy}\\|,
        \\quad \\Delta_g = p_g - p_g^{ref}

    where ``t_g`` is when geom ``g`` last came into contact (for a hold the
    reference is constant: the displacement since the start, and since touch-down).
    A contact is unexpected unless its robot geom is in ``allowed`` (touching
    the environment anywhere), or the pair ``{robot geom, other geom}`` is in
    ``planned_pairs`` (environment or self contact), or it is a self-contact
    and ``criteria.allow_self_contact``; the robot fell when its root height drops below
    ``fall_ratio`` times the reference's. The CoM margin (a convex hull, ~0.5
    ms) and the frames' errors are evaluated every ``margin_every`` steps,
    callbacks get a :class:`HoldSample` every ``every`` steps.

    Raises:
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    allowed_ids = {scene.model.geom(n).id for n in allowed}
    foot_names = foot_geoms(scene, allowed, criteria)
    wrenches = [_external_wrench(scene, *w) for w in external]

    def apply_wrenches(d: mujoco.MjData) -> None:
        for apply in wrenches:
            apply(d, reference.load)

    m, d = scene.model, scene.data
    root = scene.robot.root_body_id
    reference.begin()
    t_start = float(d.time)
    t_wall = time.perf_counter()
    n_steps = max(1, round(duration / m.opt.timestep))
    up = scene.up()
    h0 = float(d.xpos[root] @ up)
    drift = drift_h = drift_v = 0.0
    min_margin = math.inf
    slip: dict[str, float] = {}
    anchor: dict[int, np.ndarray] = {}  # geom id -> horizontal offset at touch-down
    unexpected: dict[tuple[str, str], float] = {}
    fell = False
    P_h = np.eye(3) - np.outer(up, up)
    qadr = np.array([m.joint(j).qposadr[0] for j in scene.servo_joints], dtype=int)
    tracking, tracking_at = 0.0, -1
    frame_errors = {f.name: 0.0 for f in frames}
    series: dict[str, list[float]] = {
        "time": [],
        "margin": [],
        "tracking_error": [],
        "waypoint": [],
    }
    steps = 0
    for k in range(n_steps + 1):
        if k > 0:
            scene._guard.step(1, before_step=apply_wrenches if wrenches else None)
            steps += 1
            if reference.moving:
                reference.update(float(d.time) - t_start)
        ref = reference.data
        touching = set()
        for c in scene._contacts(m, d, 0.0):
            pair = frozenset((c.robot_geom, c.other_geom))
            if c.self_contact:
                if not criteria.allow_self_contact and pair not in planned_pairs:
                    unexpected.setdefault((c.robot_geom, c.other_geom), float(d.time))
                continue
            g = scene._geom_id[c.robot_geom]
            if g in allowed_ids or pair in planned_pairs:
                touching.add(g)
            else:
                unexpected.setdefault((c.robot_geom, c.other_geom), float(d.time))
        for g in list(anchor):
            if g not in touching:
                del anchor[g]
        for g in touching:
            p = P_h @ (d.geom_xpos[g] - ref.geom_xpos[g])
            a = anchor.setdefault(g, p)
            name = scene._geom_names[g]
            slip[name] = max(slip.get(name, 0.0), float(np.linalg.norm(p - a)))
        dp = d.xpos[root] - ref.xpos[root]
        drift = max(drift, float(np.linalg.norm(dp)))
        drift_h = max(drift_h, float(np.linalg.norm(P_h @ dp)))
        drift_v = max(drift_v, abs(float(dp @ up)))
        if len(qadr):
            errors = np.abs(d.qpos[qadr] - ref.qpos[qadr])
            worst = int(np.argmax(errors))
            error = float(errors[worst])
            if error > tracking:
                tracking, tracking_at = error, worst
        else:
            error = 0.0
        com = scene.com()
        support = None
        if k % margin_every == 0:
            region, margin = scene.support(scene.touching(d.qpos), com, criteria.max_ground_slope)
            support = (np.zeros((0, 3)) if region is None else region.vertices_3d, margin)
            min_margin = min(min_margin, margin)
            for f in frames:
                e = float(np.linalg.norm(f.position(d) - f.position(ref)))
                frame_errors[f.name] = max(frame_errors[f.name], e)
            series["time"].append(float(d.time))
            series["margin"].append(margin)
            series["tracking_error"].append(error)
            series["waypoint"].append(-1 if reference.waypoint is None else reference.waypoint)
        if callbacks and k % every == 0:
            sample = HoldSample(
                time=float(d.time),
                step=steps,
                model=m,
                data=d,
                com=com,
                drift=drift,
                slip=max(slip.values(), default=0.0),
                _scene=scene,
                reference=ref if reference.moving else None,
                waypoint=reference.waypoint,
                tracking_error=error,
                _frames=frames,
                _max_slope=criteria.max_ground_slope,
                _support=support,
            )
            for call in callbacks:
                call(sample)
        if float(d.xpos[root] @ up) < criteria.fall_ratio * float(ref.xpos[root] @ up):
            fell = True
            if criteria.stop_on_fall:
                break
    final = d.xpos[root] - reference.data.xpos[root]
    return Tracked(
        drift=drift,
        drift_horizontal=drift_h,
        drift_vertical=drift_v,
        final_displacement=final.copy(),
        slip_per_geom=slip,
        foot_slip=max((v for n, v in slip.items() if n in foot_names), default=0.0),
        min_margin=min_margin,
        fell=fell,
        unexpected=unexpected,
        steps=steps,
        simulated=float(d.time) - t_start,
        end_time=float(d.time),
        root_height=(h0, float(d.xpos[root] @ up)),
        tracking_error=tracking,
        tracking_joint=scene.servo_joints[tracking_at] if tracking_at >= 0 else None,
        frame_errors=frame_errors,
        series={k: np.asarray(v) for k, v in series.items()},
        wall_time=time.perf_counter() - t_wall,
    )


def check_options(criteria: HoldCriteria | None, duration: float, **counts: int) -> HoldCriteria:
    """``criteria`` (default :class:`HoldCriteria`) after checking it, a duration
    > 0 [s] and positive integer ``counts`` (``every=...``)."""
    criteria = HoldCriteria() if criteria is None else criteria
    if not isinstance(criteria, HoldCriteria):
        raise InvalidInput(f"criteria must be a HoldCriteria, got {type(criteria).__name__}")
    inputs.real(duration, "duration", unit="s", low=0, low_open=True)
    for label, v in counts.items():
        inputs.integer(v, label, low=1)
    return criteria


def hold(
    scene: Scene,
    q: ArrayLike,
    duration: float = 3.0,
    *,
    criteria: HoldCriteria | None = None,
    external: Sequence[External] = (),
    callback: Callback | Sequence[Callback] | None = None,
    every: int = 1,
    margin_every: int = 5,
    feedforward: bool = True,
) -> HoldReport:
    """Hold ``q`` with the scene's servos and step the physics for ``duration``.

    The state is reset (environment at ``qpos0``), the pose written with zero
    velocity and the servo targets set to it (:class:`HeldPose`); :func:`track`
    steps the physics. With the reference constant, the drift is the root
    body's displacement from its start, the slip each foot geom's horizontal
    displacement since it touched down. Verdict (:class:`HoldCriteria`): drift
    < ``max_drift``, foot slip < ``max_slip``, no fall (root height >=
    ``fall_ratio`` of its start), no contact of a robot geom outside ``allowed``
    with the environment and (unless ``allow_self_contact``) no self-contact.

    Args:
        scene: The scene.
        q: Robot configuration (``robot.model.nq``).
        duration: Simulated time [s].
        criteria: Pass/fail thresholds (default :class:`HoldCriteria`).
        external: Wrenches acting on the robot during the hold, as
            ``(frame, force (3,) [N], moment (3,) [N·m])`` with the force applied
            at the frame's origin (a site or body name of the scene), written
            to ``xfrc_applied`` of the frame's body every step.
        callback: A callable or a list, each called with a :class:`HoldSample`
            at the start and every ``every`` steps.
        every: Steps between callback calls (>= 1).
        margin_every: Steps between evaluations of the CoM margin (a convex hull
            each, ~0.5 ms).
        feedforward: Add :func:`holding_torques` on the servo joints (PD
            with gravity compensation): the hold then starts in equilibrium
            instead of sagging onto its servos' error, which with the default
            gains (damping ratio ~0.1) overshoots by 1-2 cm and can tip a pose
            with a small margin. Nothing is added when the pose has no equilibrium.

    Returns:
        A :class:`HoldReport`.

    Raises:
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    criteria = check_options(criteria, duration, every=every, margin_every=margin_every)
    external = inputs.wrenches(external, "external")
    q = scene._qpos(q)[: scene.robot_nq]
    callbacks = as_callbacks(callback)
    allowed = (
        scene.allowed_contacts if criteria.allowed is None else scene._allowed(criteria.allowed)
    )
    tau = holding_torques(scene, q, external) if feedforward else None
    run = track(
        scene,
        HeldPose(scene, q, tau),
        duration,
        criteria=criteria,
        allowed=allowed,
        external=external,
        callbacks=callbacks,
        every=every,
        margin_every=margin_every,
    )
    failures = run.failures(criteria)
    return HoldReport(
        passed=not failures,
        failures=failures,
        drift=run.drift,
        drift_horizontal=run.drift_horizontal,
        drift_vertical=run.drift_vertical,
        final_displacement=run.final_displacement,
        slip=run.foot_slip,
        slip_per_geom=run.slip_per_geom,
        min_margin=run.min_margin,
        fell=run.fell,
        unexpected_contacts=[(a, b, t) for (a, b), t in run.unexpected.items()],
        allowed=list(allowed),
        thresholds=criteria.thresholds(),
        duration=float(duration),
        simulated=run.end_time,
        steps=run.steps,
        timestep=float(scene.model.opt.timestep),
        root_height=run.root_height,
        wall_time=run.wall_time,
    )
