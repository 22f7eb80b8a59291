"""The stepping loop of a hold and a motion: :func:`track` steps a scene's physics
while its servos track a reference, measuring against that reference.

The measures are root drift, foot slip, the CoM margin to the support polygon of
the actual contacts, unexpected contacts, falling, joint and task-frame tracking
errors. A hold is the constant reference (:class:`pik_mj.sim.hold.HeldPose`); a
motion is a reference that moves along the iterates of a solve
(:class:`pik_mj.sim.reference.MotionReference`). The pass/fail thresholds are
one :class:`HoldCriteria`; every ``every`` steps each callback gets a
:class:`HoldSample` (e.g. a recorder's ``hold_logger()``). The steps go
through the scene's state guard (:meth:`pik_mj.sim.physics.Physics.step`), so
an unstable simulation raises.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj.callbacks import Callback
from pik_mj.frames import Frame
from pik_mj.sim.criteria import HoldCriteria, slip_verdict_geoms
from pik_mj.sim.falls import Fall, FallLimits, fall_measures, first_fall
from pik_mj.sim.physics import External, Physics

__all__ = ["HoldSample", "Reference", "Tracked", "describe_contacts", "track"]


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
    _scene: Physics = field(repr=False)
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


@dataclass
class Tracked:
    """What :func:`track` measured (see :class:`pik_mj.sim.hold.HoldReport` for
    the metrics).

    Attributes:
        drift: Largest root-body distance to its reference position [m].
        drift_horizontal: Its largest horizontal part [m].
        drift_vertical: Its largest vertical part [m].
        final_displacement: Root body minus its reference position at the end (3,) [m].
        slip_per_geom: Largest slip of each allowed geom that touched [m].
        foot_slip: Largest slip of a foot geom [m].
        min_margin: Smallest CoM margin to the support polygon [m].
        fell: The robot fell (:mod:`pik_mj.sim.falls`).
        fall: The first sign of the fall (None: no fall).
        tilt: Largest trunk tilt from the reference [rad].
        limits: The fall thresholds used.
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
    fall: Fall | None
    tilt: float
    limits: FallLimits
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
        if self.fall is not None:
            out.append(self.fall.describe())
        if self.unexpected:
            out.append(describe_contacts(self.unexpected))
        return out


def describe_contacts(unexpected: dict[tuple[str, str], float]) -> str:
    """``unexpected contacts: a-b at 0.512 s, ...``: each pair with the time it began."""
    pairs = ", ".join(f"{a}-{b} at {t:.3f} s" for (a, b), t in unexpected.items())
    return f"unexpected contacts: {pairs}"


def _external_wrench(
    scene: Physics, frame: str, force: ArrayLike, moment: ArrayLike
) -> Callable[[mujoco.MjData, float], None]:
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


class _Measures:
    """What :func:`track` accumulates step by step (see :func:`track` for the
    formulas and :class:`Tracked` for the fields)."""

    def __init__(
        self,
        scene: Physics,
        criteria: HoldCriteria,
        allowed: Sequence[str],
        planned_pairs: set[frozenset[str]] | frozenset[frozenset[str]],
        frames: Sequence[Frame],
        limits: FallLimits,
    ):
        m = scene.model
        self.scene = scene
        self.criteria = criteria
        self.allowed_ids = {m.geom(n).id for n in allowed}
        self.feet = slip_verdict_geoms(scene, allowed, criteria)
        self.planned_pairs = planned_pairs
        self.frames = frames
        self.root = scene.robot.root_body_id
        self.up = scene.up()
        self.P_h = np.eye(3) - np.outer(self.up, self.up)
        self.qadr = np.array([m.joint(j).qposadr[0] for j in scene.servo_joints], dtype=int)
        self.drift = self.drift_h = self.drift_v = 0.0
        self.min_margin = math.inf
        self.slip: dict[str, float] = {}
        self.anchor: dict[int, np.ndarray] = {}  # geom id -> horizontal offset at touch-down
        self.unexpected: dict[tuple[str, str], float] = {}
        self.limits = limits
        self.fall: Fall | None = None
        self.tilt = 0.0
        self.tracking, self.tracking_at = 0.0, -1
        self.frame_errors = {f.name: 0.0 for f in frames}
        self.series: dict[str, list[float]] = {
            "time": [],
            "margin": [],
            "tracking_error": [],
            "waypoint": [],
        }

    def height(self, d: mujoco.MjData) -> float:
        """Root height along up [m]."""
        return float(d.xpos[self.root] @ self.up)

    def contacts(self, d: mujoco.MjData, ref: mujoco.MjData) -> None:
        """Unexpected contacts now, and the slip of the touching geoms since touch-down."""
        scene, criteria, planned = self.scene, self.criteria, self.planned_pairs
        touching = set()
        for c in scene.contacts(d):
            pair = frozenset((c.robot_geom, c.other_geom))
            if c.self_contact:
                if not criteria.allow_self_contact and pair not in planned:
                    self.unexpected.setdefault((c.robot_geom, c.other_geom), float(d.time))
                continue
            g = scene.geom_ids[c.robot_geom]
            if g in self.allowed_ids or pair in planned:
                touching.add(g)
            else:
                self.unexpected.setdefault((c.robot_geom, c.other_geom), float(d.time))
        anchor, slip = self.anchor, self.slip
        for g in list(anchor):
            if g not in touching:
                del anchor[g]
        for g in touching:
            p = self.P_h @ (d.geom_xpos[g] - ref.geom_xpos[g])
            a = anchor.setdefault(g, p)
            name = scene.geom_names[g]
            slip[name] = max(slip.get(name, 0.0), float(np.linalg.norm(p - a)))

    def root_drift(self, d: mujoco.MjData, ref: mujoco.MjData) -> None:
        """The root's distance to its reference, and its horizontal and vertical parts."""
        dp = d.xpos[self.root] - ref.xpos[self.root]
        self.drift = max(self.drift, float(np.linalg.norm(dp)))
        self.drift_h = max(self.drift_h, float(np.linalg.norm(self.P_h @ dp)))
        self.drift_v = max(self.drift_v, abs(float(dp @ self.up)))

    def joint_error(self, d: mujoco.MjData, ref: mujoco.MjData) -> float:
        """Largest servo joint error ``|q - q_ref|`` now [rad or m] (0 without servos)."""
        if not len(self.qadr):
            return 0.0
        errors = np.abs(d.qpos[self.qadr] - ref.qpos[self.qadr])
        worst = int(np.argmax(errors))
        error = float(errors[worst])
        if error > self.tracking:
            self.tracking, self.tracking_at = error, worst
        return error

    def margin(
        self,
        d: mujoco.MjData,
        ref: mujoco.MjData,
        com: np.ndarray,
        error: float,
        waypoint: int | None,
    ) -> tuple[np.ndarray, float]:
        """The support polygon (m, 3) [m] of the touching ground contacts and the
        CoM margin to it [m] now; the frames' errors and one row of the series."""
        scene = self.scene
        region, margin = scene.support(scene.touching(d.qpos), com, self.criteria.max_ground_slope)
        self.min_margin = min(self.min_margin, margin)
        for f in self.frames:
            e = float(np.linalg.norm(f.position(d) - f.position(ref)))
            self.frame_errors[f.name] = max(self.frame_errors[f.name], e)
        self.series["time"].append(float(d.time))
        self.series["margin"].append(margin)
        self.series["tracking_error"].append(error)
        self.series["waypoint"].append(-1 if waypoint is None else waypoint)
        return (np.zeros((0, 3)) if region is None else region.vertices_3d, margin)

    def falling(self, d: mujoco.MjData, ref: mujoco.MjData) -> bool:
        """The robot has fallen now (:mod:`pik_mj.sim.falls`; the first fall is
        kept in :attr:`fall`, the largest tilt in :attr:`tilt`)."""
        root = self.root
        tilt, drift, height, ref_height = fall_measures(
            d.xpos[root], d.xmat[root], ref.xpos[root], ref.xmat[root], self.up
        )
        self.tilt = max(self.tilt, float(tilt[0]))
        fall = first_fall(np.array([d.time]), tilt, drift, height, ref_height, self.limits)
        if fall is not None and self.fall is None:
            self.fall = fall
        return fall is not None

    def tracked(
        self,
        d: mujoco.MjData,
        ref: mujoco.MjData,
        steps: int,
        t_start: float,
        h0: float,
        wall_time: float,
    ) -> Tracked:
        """The measures at the end of a run of ``steps`` steps from ``t_start`` [s]
        and root height ``h0`` [m] that took ``wall_time`` [s]."""
        slip, scene = self.slip, self.scene
        return Tracked(
            drift=self.drift,
            drift_horizontal=self.drift_h,
            drift_vertical=self.drift_v,
            final_displacement=(d.xpos[self.root] - ref.xpos[self.root]).copy(),
            slip_per_geom=slip,
            foot_slip=max((v for n, v in slip.items() if n in self.feet), default=0.0),
            min_margin=self.min_margin,
            fell=self.fall is not None,
            fall=self.fall,
            tilt=self.tilt,
            limits=self.limits,
            unexpected=self.unexpected,
            steps=steps,
            simulated=float(d.time) - t_start,
            end_time=float(d.time),
            root_height=(h0, self.height(d)),
            tracking_error=self.tracking,
            tracking_joint=scene.servo_joints[self.tracking_at] if self.tracking_at >= 0 else None,
            frame_errors=self.frame_errors,
            series={k: np.asarray(v) for k, v in self.series.items()},
            wall_time=wall_time,
        )


def track(
    scene: Physics,
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
    and ``criteria.allow_self_contact``; the robot fell when its trunk tilts, its
    root drifts or sinks past the thresholds of :mod:`pik_mj.sim.falls`
    (:meth:`HoldCriteria.fall_limits`, from the start state). The CoM margin (a convex hull) and the
    frames' errors are evaluated every ``margin_every`` steps, callbacks get a
    :class:`HoldSample` every ``every`` steps.

    Raises:
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    wrenches = [_external_wrench(scene, *w) for w in external]

    def apply_wrenches(d: mujoco.MjData) -> None:
        for apply in wrenches:
            apply(d, reference.load)

    before_step = apply_wrenches if wrenches else None
    d = scene.data
    reference.begin()
    limits = criteria.fall_limits(scene, scene.com_height(d), scene.root_height(d))
    measures = _Measures(scene, criteria, allowed, planned_pairs, frames, limits)
    t_start = float(d.time)
    t_wall = time.perf_counter()
    n_steps = max(1, round(duration / scene.model.opt.timestep))
    h0 = measures.height(d)
    steps = 0
    for k in range(n_steps + 1):
        if k > 0:
            scene.step(1, before_step=before_step)
            steps += 1
            if reference.moving:
                reference.update(float(d.time) - t_start)
        ref = reference.data
        measures.contacts(d, ref)
        measures.root_drift(d, ref)
        error = measures.joint_error(d, ref)
        com = scene.com()
        support = None
        if k % margin_every == 0:
            support = measures.margin(d, ref, com, error, reference.waypoint)
        if callbacks and k % every == 0:
            sample = HoldSample(
                time=float(d.time),
                step=steps,
                model=scene.model,
                data=d,
                com=com,
                drift=measures.drift,
                slip=max(measures.slip.values(), default=0.0),
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
        if measures.falling(d, ref) and criteria.stop_on_fall:
            break
    wall_time = time.perf_counter() - t_wall
    return measures.tracked(d, reference.data, steps, t_start, h0, wall_time)
