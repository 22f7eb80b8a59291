"""Motion playback of a solve: the iterates stepped in physics (:func:`play`,
:meth:`pik_mj.sim.Scene.play`).

:func:`play` turns a path (:class:`~pik_mj.sim.path.Waypoints`, a solve's
iterates) into a time-parameterized reference
(:class:`~pik_mj.sim.reference.MotionReference`: its timing and the servos'
targets) that the scene's servos track while the physics steps, in the same
loop as a hold (:func:`pik_mj.sim.tracking.track`: a hold is the constant
reference), and reports what happened (:class:`MotionReport`). After the path
the last pose is held for ``settle`` seconds.

**Contacts.** The planned contacts are the scene's ``allowed_contacts`` (the
soles, with anything) and the geom pairs of the static checks along the path:
a robot geom and the environment or robot geom it touches at a waypoint
(within the scene's ``contact_tolerance``,
:meth:`~pik_mj.sim.physics.Physics.touching`, and penetrating by less than
it), with each other only. Any other contact in the physics is unexpected; a
path that passes a limb through the body or an obstacle between two waypoints
shows up there.

**A sequence of scenes.** A grasp changes the physics (a weld): play the part
before it in the scene without the grasp, and the part after it in the scene
with it, continuing from the first part's final state
(``held.play(lift_path, start=reach_motion)``): the weld switches on at the
boundary. A hand without fingers, whose box ends around the handle, approaches
it in a scene with the hand's contacts with the object excluded
(``Scene.from_robot(robot, exclude=[(hand body, object body)])``: the open
fingers), the part before in the scene as it is (the kettle scenario).

The path, the reference and the clearance callback are in their own modules
and importable from here too (:class:`Waypoints`, :class:`MotionReference`,
:func:`velocity_limits`, :class:`Clearance`, :func:`min_distance`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks, call_stride
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.sim.balancing import SERVOS_ALONE, balance_feedback, stance
from pik_mj.sim.clearance import Clearance, min_distance
from pik_mj.sim.criteria import HoldCriteria, check_options
from pik_mj.sim.falls import Fall
from pik_mj.sim.path import Waypoint, Waypoints
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.reference import (
    IRTEUS_MAX_VELOCITY,
    SEED_MAX_VELOCITY,
    MotionReference,
    PhysicsState,
    velocity_limits,
)
from pik_mj.sim.stability import diagnose
from pik_mj.sim.static import finite_or_none
from pik_mj.sim.tracking import MARGIN_EVERY, RECORD_EVERY, track

__all__ = [
    "DEFAULT_SETTLE",
    "DEFAULT_SPEED",
    "IRTEUS_MAX_VELOCITY",
    "MOTION_CRITERIA",
    "SEED_MAX_VELOCITY",
    "Clearance",
    "MotionReference",
    "MotionReport",
    "PhysicsState",
    "Waypoint",
    "Waypoints",
    "min_distance",
    "planned_contacts",
    "play",
    "velocity_limits",
]

DEFAULT_SPEED = 0.2
"""Fraction of the joint velocity limits a motion moves at: 1 rad/s for a hinge,
0.32 m/s for a floating base. The servos let the root lag behind a moving
reference by more the faster it moves; a fifth of the limits keeps a leaning
robot within the 2 cm drift of :data:`MOTION_CRITERIA`."""

DEFAULT_SETTLE = 0.3
"""Time [s] the last pose is held after the path."""

MOTION_CRITERIA = HoldCriteria(max_drift=0.02)
"""Default pass/fail thresholds of a motion: the root within 2 cm of its
reference (a moving robot lags its reference by its servos' tracking error),
foot slip below 2 mm, no fall, no unexpected contact."""


@dataclass
class MotionReport:
    """What happened when a path was played in physics (:func:`play`).

    Attributes:
        passed: Every criterion holds (see ``failures``).
        failures: One line per failed criterion.
        duration: Time of the path [s] (then the last pose is held ``settle``).
        settle: Time the last pose was held [s].
        simulated: Simulated time [s] (shorter if the robot fell).
        speed: Fraction of the joint velocity limits.
        waypoint_times: Time [s] of each waypoint on the physics clock (the
            ``sim_time`` of a recording: the start state's time plus the
            waypoint's time from the start).
        segments: Segment label of each waypoint.
        tracking_error: Largest servo joint error ``|q - q_ref|`` [rad or m].
        tracking_joint: Joint where it was reached.
        frame_errors: Largest distance [m] of each task frame (the solves'
            frame tasks' move targets) to its reference position.
        drift: Largest distance of the root body to its reference position [m].
        min_margin: Smallest CoM margin [m] to the support polygon of the actual
            ground contacts (``-inf`` if contact was lost).
        slip: Largest foot slip relative to the reference [m].
        slip_per_geom: Slip of each planned contact geom [m].
        fell: The robot fell (:mod:`pik_mj.sim.falls`: its trunk tilted, its root
            drifted off its footprint or sank, measured against the reference).
        planned_contacts: Robot geoms allowed to touch the environment
            anywhere (the scene's ``allowed_contacts``, the criteria's ``allowed``).
        planned_pairs: ``(robot geom, other geom)`` touching at a waypoint
            (:func:`planned_contacts`): allowed with each other only.
        unexpected_contacts: ``(robot geom, other geom, first time [s])``.
        thresholds: The pass/fail thresholds used.
        steps: Physics steps taken.
        timestep: Physics time step [s].
        final_state: The physics state at the end (``start`` of a next part).
        series: ``time`` [s], ``margin`` [m], ``tracking_error`` and
            ``waypoint`` every ``margin_every`` steps.
        wall_time: Wall-clock time [s] of the physics.
        fall: The first sign of the fall, with its figure and time (None: no fall).
        tilt: Largest tilt of the trunk (root body) from its reference [rad].
        balance_feedback: The balance feedback's figures (:mod:`pik_mj.sim.balancing`:
            on or off, the ankle servos' and the tipping stiffness); None for a
            robot that does not stand on two driven ankles.
    """

    passed: bool
    failures: list[str]
    duration: float
    settle: float
    simulated: float
    speed: float
    waypoint_times: np.ndarray
    segments: list[str]
    tracking_error: float
    tracking_joint: str | None
    frame_errors: dict[str, float]
    drift: float
    min_margin: float
    slip: float
    slip_per_geom: dict[str, float]
    fell: bool
    planned_contacts: list[str]
    planned_pairs: list[tuple[str, str]]
    unexpected_contacts: list[tuple[str, str, float]]
    thresholds: dict[str, float]
    steps: int
    timestep: float
    final_state: PhysicsState = field(repr=False)
    series: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    wall_time: float = 0.0
    fall: Fall | None = None
    tilt: float = 0.0
    balance_feedback: dict[str, Any] | None = None

    @property
    def max_frame_error(self) -> float:
        """Largest task-frame error [m] (0 without frames)."""
        return max(self.frame_errors.values(), default=0.0)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``min_com_margin`` None when contact was lost)."""
        frame = max(self.frame_errors, key=self.frame_errors.__getitem__, default=None)
        spans: dict[str, list[float]] = {}
        for label, t in zip(self.segments, self.waypoint_times, strict=True):
            spans.setdefault(label, [float(t), float(t)])[1] = float(t)
        return {
            "passed": self.passed,
            "failures": list(self.failures),
            "duration": self.duration,
            "settle": self.settle,
            "simulated": self.simulated,
            "speed": self.speed,
            "waypoints": len(self.waypoint_times),
            "segments": spans,
            "max_tracking_error": {
                "joints_rad": self.tracking_error,
                "joint": self.tracking_joint,
                "frames_m": self.max_frame_error,
                "frame": frame,
            },
            "frame_errors_m": dict(self.frame_errors),
            "max_drift": self.drift,
            "min_com_margin": finite_or_none(self.min_margin),
            "max_slip": self.slip,
            "slip_per_geom": dict(self.slip_per_geom),
            "contacts": {
                "planned": list(self.planned_contacts),
                "planned_pairs": [list(p) for p in self.planned_pairs],
                "unexpected": [list(c) for c in self.unexpected_contacts],
            },
            "fell": self.fell,
            "fall": None if self.fall is None else self.fall.to_dict(),
            "max_tilt_rad": self.tilt,
            "balance_feedback": self.balance_feedback,
            "thresholds": dict(self.thresholds),
            "steps": self.steps,
            "timestep": self.timestep,
            "wall_time": self.wall_time,
        }

    def summary(self) -> str:
        """One line: the verdict and the figures."""
        margin = (
            f"{self.min_margin * 1e3:.1f} mm"
            if math.isfinite(self.min_margin)
            else "none (no ground contact)"
        )
        return (
            f"motion: {'PASSED' if self.passed else 'FAILED'} — {self.duration:.2f} s "
            f"(+{self.settle:g} s settle), {len(self.waypoint_times)} waypoints; tracking "
            f"error {self.tracking_error:.3f} rad, frames {self.max_frame_error * 1e3:.1f} mm; "
            f"drift {self.drift * 1e3:.1f} mm, slip {self.slip * 1e3:.2f} mm, min CoM margin "
            f"{margin}; tilt {math.degrees(self.tilt):.1f}°, "
            f"{'FELL' if self.fell else 'no fall'}, "
            f"{len(self.unexpected_contacts)} unexpected contacts"
            + (
                "; balance feedback on"
                if self.balance_feedback and self.balance_feedback["on"]
                else ""
            )
            + (f"; {'; '.join(self.failures)}" if self.failures else "")
        )


def planned_contacts(scene: Physics, path: Waypoints) -> list[tuple[str, str]]:
    """The geom pairs ``(robot geom, other geom)`` touching at any waypoint (with
    the environment or self-contacts): the static checks' contacts
    (:meth:`~pik_mj.sim.physics.Physics.touching`), within the scene's
    ``contact_tolerance`` of touching. A pair that penetrates deeper than the
    tolerance at a waypoint collides there: it is not planned. A planned pair
    is planned with its partner only: a hand meant to touch a handle that
    sweeps through the counter makes an unexpected contact."""
    names = scene.geom_names
    probes = [scene.probe_contacts(scene.qpos_of(w.q)) for w in path.items]
    # MuJoCo's contact arrays of every waypoint, stacked in order and read at once
    geom, dist, exclude = (np.concatenate(x) for x in list(zip(*probes, strict=True))[:3])
    keep, robot, other, _ = scene.robot_contact_rows(geom, dist, exclude)
    keep &= dist >= -scene.contact_tolerance
    pairs = zip(robot[keep].tolist(), other[keep].tolist(), strict=True)
    return list(dict.fromkeys((names[r], names[o]) for r, o in pairs))


def _as_waypoints(path: Waypoints | ArrayLike, nq: int) -> Waypoints:
    """``path`` as :class:`Waypoints` (configurations (N, nq) become one segment
    ``"path"``), its configurations checked to be ``nq`` long."""
    if not isinstance(path, Waypoints):
        q = np.asarray(path, dtype=float)
        if q.ndim != 2 or len(q) < 1:
            raise InvalidInput(f"path must be Waypoints or configurations (N, nq), got {q.shape}")
        path = Waypoints(q[0], "path")
        path.items += [Waypoint(x.copy(), "path", i) for i, x in enumerate(q[1:], 1)]
    if path.items[0].q.shape != (nq,):
        raise InvalidInput(
            f"the path's configurations have {path.items[0].q.size} entries, the scene's robot {nq}"
        )
    return path


def _not_played(
    scene: Physics,
    path: Waypoints,
    reference: MotionReference,
    speed: float,
    settle: float,
    t0: float,
    why: str,
) -> MotionReport:
    """The report of a path that was not played: ``why``."""
    return MotionReport(
        passed=False,
        failures=[why],
        duration=reference.duration,
        settle=settle,
        simulated=0.0,
        speed=speed,
        waypoint_times=t0 + reference.times,
        segments=[w.segment for w in path.items],
        tracking_error=0.0,
        tracking_joint=None,
        frame_errors={},
        drift=0.0,
        min_margin=-math.inf,
        slip=0.0,
        slip_per_geom={},
        fell=False,
        planned_contacts=[],
        planned_pairs=[],
        unexpected_contacts=[],
        thresholds={},
        steps=0,
        timestep=float(scene.model.opt.timestep),
        final_state=PhysicsState.of(scene.data),
    )


def _check_planned(scene: Physics, planned: Sequence[tuple[str, str]]) -> None:
    """Each planned contact is a pair (robot geom, geom of the scene).

    Raises:
        InvalidInput: Not a pair.
        UnknownName: Its first geom is not the robot's.
        KeyError: Its second geom does not exist (MuJoCo's lookup).
    """
    for pair in planned:
        if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
            raise InvalidInput(f"planned contacts are (robot geom, other geom) pairs, got {pair!r}")
        scene.check_robot_geoms([pair[0]])
        scene.model.geom(pair[1])


def play(
    scene: Physics,
    path: Waypoints | ArrayLike,
    *,
    speed: float = DEFAULT_SPEED,
    max_velocity: float | Mapping[str, float] | None = None,
    settle: float = DEFAULT_SETTLE,
    criteria: HoldCriteria | None = None,
    external: Sequence[External] = (),
    external_ramp: bool = False,
    callback: Callback | Sequence[Callback] | None = None,
    every: int | None = None,
    record_every: int = RECORD_EVERY,
    margin_every: int = MARGIN_EVERY,
    feedforward: bool = True,
    start: MotionReport | PhysicsState | None = None,
    planned: Sequence[tuple[str, str]] = (),
    balance: bool = True,
) -> MotionReport:
    """Play ``path`` in the scene's physics (module docstring and
    :mod:`pik_mj.sim.reference`).

    Args:
        scene: The scene (its robot's configurations are the path's; its
            :class:`~pik_mj.sim.physics.Physics`).
        path: :class:`Waypoints`, or configurations (N, nq).
        speed: Fraction of the joint velocity limits, in (0, 1].
        max_velocity: Velocity limit [rad/s or m/s] of every robot joint, or by
            joint name (default: a joint velocity task of the solves, else the
            irteus joints' defaults, :func:`velocity_limits`).
        settle: Time [s] the last pose is held after the path (>= 0).
        criteria: Pass/fail thresholds (default :data:`MOTION_CRITERIA`; drift and slip
            measured against the reference; its ``allowed`` geoms are planned).
        external: Wrenches ``(frame, force, moment)`` acting during the motion.
        external_ramp: Let the wrenches grow with the path's progress (0 at the
            first waypoint, their value at the last): a load taken up while
            reaching, for a path solved with the full load.
        callback: A callable or a list, called with a
            :class:`~pik_mj.sim.measures.HoldSample` every ``every`` steps (its
            ``reference`` and ``waypoint`` are set; the checks sample as
            without callbacks: :mod:`pik_mj.sim.tracking`).
        every: Steps between callback calls; None: what the callbacks ask
            (:func:`pik_mj.callbacks.call_stride`).
        record_every: Steps between the checks' samples; 1:
            every step.
        margin_every: Steps between evaluations of the CoM margin.
        feedforward: Plan the torques the path needs: the servos' feed-forward
            and a timing slowed down where the drives need it
            (:func:`pik_mj.sim.effort.plan_torques`); False: the velocity
            limits alone, no feed-forward.
        start: A motion (or its state) to continue from, e.g. the part before a
            grasp in the scene without the grasp; None: from rest at the first
            waypoint.
        planned: More planned contacts ``(robot geom, other geom)``, e.g. a hand
            closing on a handle it overlaps at the grasp (a pair penetrating
            at a waypoint is not planned by itself).
        balance: Turn the stance ankles' servo targets against the trunk's
            inclination where the robot cannot stand on its ankle servos alone
            (:mod:`pik_mj.sim.balancing`, decided at the first waypoint);
            False: the servos alone.

    Returns:
        A :class:`MotionReport`.

    Raises:
        InvalidInput: Bad options, configurations of another robot, a start
            state of another model.
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    path = _as_waypoints(path, scene.robot_nq)
    path.check_finite(scene.model)
    if not (isinstance(speed, (int, float)) and 0.0 < speed <= 1.0):
        raise InvalidInput(f"speed must be in (0, 1] (a fraction of the limits), got {speed!r}")
    if not (math.isfinite(settle) and settle >= 0):
        raise InvalidInput(f"settle must be >= 0 [s], got {settle}")
    external = inputs.wrenches(external, "external")
    state = start.final_state if isinstance(start, MotionReport) else start
    if state is not None and not isinstance(state, PhysicsState):
        raise InvalidInput(f"start must be a MotionReport or PhysicsState, got {type(start)}")
    lower, upper = velocity_limits(scene, max_velocity, path.velocity_bounds)
    t_wall = time.perf_counter()
    reference = MotionReference(
        scene, path, lower, upper, speed=float(speed), external=external,
        external_ramp=external_ramp, feedforward=feedforward, start=state,
    )  # fmt: skip
    duration = max(reference.duration + settle, scene.model.opt.timestep)
    every = call_stride(as_callbacks(callback), every)
    criteria = check_options(
        MOTION_CRITERIA if criteria is None else criteria,
        duration,
        every=every,
        record_every=record_every,
        margin_every=margin_every,
    )
    _check_planned(scene, planned)
    pairs = list(dict.fromkeys([*planned_contacts(scene, path), *map(tuple, planned)]))
    allowed = list(dict.fromkeys([*scene.allowed_contacts, *scene.allowed(criteria.allowed)]))
    frames = [Frame.find(scene.model, name, kind) for name, kind in path.frames.items()]
    t0 = 0.0 if state is None else state.time
    if reference.shortfalls:
        why = "the servos cannot track this path: " + "; ".join(
            f.describe() for f in reference.shortfalls
        )
        return _not_played(scene, path, reference, float(speed), float(settle), t0, why)
    figures = stance(scene, path.items[0].q)
    feedback = balance_feedback(scene, path.items[0].q, figures) if balance else None
    run = track(
        scene, reference, duration, criteria=criteria, allowed=allowed,
        planned_pairs={frozenset(p) for p in pairs}, external=external,
        callbacks=as_callbacks(callback), every=every, record_every=record_every,
        margin_every=margin_every, frames=frames, feedback=feedback,
    )  # fmt: skip
    failures = run.failures(criteria, drift="root drift from the reference")
    failures += [w + (SERVOS_ALONE if feedback else "") for w in diagnose(scene, run, criteria)]
    return MotionReport(
        passed=not failures,
        failures=failures,
        duration=reference.duration,
        settle=float(settle),
        simulated=run.simulated,
        speed=float(speed),
        waypoint_times=t0 + reference.times,
        segments=[w.segment for w in path.items],
        tracking_error=run.tracking_error,
        tracking_joint=run.tracking_joint,
        frame_errors=run.frame_errors,
        drift=run.drift,
        min_margin=run.min_margin,
        slip=run.foot_slip,
        slip_per_geom=run.slip_per_geom,
        fell=run.fell,
        planned_contacts=allowed,
        planned_pairs=pairs,
        unexpected_contacts=[(a, b, t) for (a, b), t in run.unexpected.items()],
        thresholds={**criteria.thresholds(), **run.limits.thresholds()},
        steps=run.steps,
        timestep=float(scene.model.opt.timestep),
        final_state=PhysicsState.of(scene.data),
        series=run.series,
        wall_time=time.perf_counter() - t_wall,
        fall=run.fall,
        tilt=run.tilt,
        balance_feedback=None if figures is None else figures.to_dict(feedback is not None),
    )
