"""The physics hold of a pose: :func:`hold` (:meth:`pik_mj.sim.Scene.hold`).

The state is reset, the pose written at rest with the servo targets at it and
the static torques that hold it (:func:`holding_torques`); the stepping loop
(:func:`pik_mj.sim.tracking.track`, the one a motion uses) measures against that
constant reference (:class:`HeldPose`). The thresholds are one
:class:`~pik_mj.sim.criteria.HoldCriteria`, each callback gets a
:class:`~pik_mj.sim.tracking.HoldSample`, the outcome is a :class:`HoldReport`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks, call_stride
from pik_mj.sim.balancing import SERVOS_ALONE, balance_feedback, stance
from pik_mj.sim.criteria import HoldCriteria, check_options
from pik_mj.sim.falls import Fall
from pik_mj.sim.measures import HoldSample, Tracked
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.stability import diagnose
from pik_mj.sim.static import finite_or_none
from pik_mj.sim.torques import drive_shortfalls, holding_torques
from pik_mj.sim.tracking import MARGIN_EVERY, RECORD_EVERY, track, track_many

__all__ = ["HeldPose", "HoldCriteria", "HoldReport", "HoldSample", "hold", "hold_many"]


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
            :meth:`~pik_mj.sim.Scene.static_check` (``-inf`` if contact was lost). At the start
            it is the static margin: the physics alone reports a contact only once
            a geom penetrates, so a pose placed on the floor would start with an
            arbitrary subset of its sole corners (often one foot's).
        fell: The robot fell (:mod:`pik_mj.sim.falls`: its trunk tilted, its root
            drifted off its footprint or sank below ``fall_ratio`` of its start height).
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
        fall: The first sign of the fall, with its figure and time (None: no fall).
        tilt: Largest tilt of the trunk (root body) from its start [rad].
        balance_feedback: The balance feedback's figures (:mod:`pik_mj.sim.balancing`:
            on or off, the ankle servos' and the tipping stiffness); None for a
            robot that does not stand on two driven ankles.
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
    fall: Fall | None = None
    tilt: float = 0.0
    balance_feedback: dict[str, Any] | None = None

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
            "fall": None if self.fall is None else self.fall.to_dict(),
            "tilt": self.tilt,
            "balance_feedback": self.balance_feedback,
        }


class HeldPose:
    """The constant reference of a hold: the pose ``q`` at rest, the servo
    targets at it, and the static torques ``tau`` as the servos' feed-forward.

    Args:
        scene: The scene.
        q: Robot configuration.
        tau: Generalized forces (:func:`holding_torques`) the servos add to their
            feedback (:class:`~pik_mj.sim.servos.ServoLaw`: through their
            controls, within what the drives deliver), or None.
    """

    moving = False
    waypoint: int | None = None
    load = 1.0

    def __init__(self, scene: Physics, q: ArrayLike, tau: np.ndarray | None):
        self.scene = scene
        self.q = np.asarray(q, dtype=float)
        self.tau = tau
        self.data: mujoco.MjData | None = None  # begin()'s
        self._servos = scene.servo_law

    def begin(self, data: mujoco.MjData | None = None) -> None:
        """Reset the state (environment at ``qpos0``), write the pose with zero
        velocity, the servo targets at it with the static torques; the pose's
        kinematics in ``data`` (default: a new data of the scene's model)."""
        scene = self.scene
        m, d = scene.model, scene.data
        self.data = mujoco.MjData(m) if data is None else data
        mujoco.mj_resetData(m, d)
        scene.set_pose(self.q)
        if self.tau is not None:
            servos = self._servos
            nv = scene.robot.model.nv
            d.ctrl[servos.ids] = servos.controls(self.q, np.zeros(nv), self.tau[:nv])
            held = servos.ids[m.actuator_actnum[servos.ids] > 0]
            d.act[m.actuator_actadr[held]] = d.ctrl[held]  # activations at rest too
            mujoco.mj_forward(m, d)
        self.data.qpos[:] = d.qpos
        mujoco.mj_kinematics(m, self.data)
        self._ctrl = d.ctrl.copy()
        self._rows = np.empty((0, len(self._ctrl)))

    def update(self, t: float) -> None:
        """Nothing moves."""

    def updates(self, times: np.ndarray) -> Iterator[None]:
        """Nothing moves, at each of ``times``."""
        for _ in times:
            yield

    def controls(self, t: np.ndarray) -> np.ndarray:
        """The controls written at the start, in every step (read-only rows)."""
        if len(self._rows) != len(t):
            self._rows = np.tile(self._ctrl, (len(t), 1))
            self._rows.flags.writeable = False
        return self._rows

    def loads(self, t: np.ndarray) -> np.ndarray:
        """The external wrenches as given."""
        return np.ones(len(t))


def hold(
    scene: Physics,
    q: ArrayLike,
    duration: float = 3.0,
    *,
    criteria: HoldCriteria | None = None,
    external: Sequence[External] = (),
    callback: Callback | Sequence[Callback] | None = None,
    every: int | None = None,
    record_every: int = RECORD_EVERY,
    margin_every: int = MARGIN_EVERY,
    feedforward: bool = True,
    balance: bool = True,
) -> HoldReport:
    """Hold ``q`` with the scene's servos and step the physics for ``duration``.

    The state is reset (environment at ``qpos0``), the pose written with zero
    velocity and the servo targets set to it (:class:`HeldPose`);
    :func:`~pik_mj.sim.tracking.track` steps the physics. With the reference
    constant, the drift is the root body's displacement from its start, the
    slip each foot geom's horizontal displacement since it touched down.
    Verdict (:class:`HoldCriteria`): drift < ``max_drift``, foot slip <
    ``max_slip``, no fall (:mod:`pik_mj.sim.falls`: trunk tilt, root drift off
    the footprint, root height below ``fall_ratio`` of its start), no
    contact of a robot geom outside ``allowed`` with the environment and
    (unless ``allow_self_contact``) no self-contact.

    Args:
        scene: The scene (its :class:`~pik_mj.sim.physics.Physics`).
        q: Robot configuration (``robot.model.nq``).
        duration: Simulated time [s].
        criteria: Pass/fail thresholds (default :class:`HoldCriteria`).
        external: Wrenches acting on the robot during the hold, as
            ``(frame, force (3,) [N], moment (3,) [N·m])`` with the force applied
            at the frame's origin (a site or body name of the scene), written
            to ``xfrc_applied`` of the frame's body every step.
        callback: A callable or a list, each called with a :class:`HoldSample`
            at the start and every ``every`` steps (the checks sample as
            without callbacks: :mod:`pik_mj.sim.tracking`).
        every: Steps between callback calls (>= 1); None: what the callbacks
            ask (:func:`pik_mj.callbacks.call_stride`: a recorder's logger its
            own rate, any other callback every step).
        record_every: Steps between the checks' samples
            (the physics runs in C between them); 1: every step.
        margin_every: Steps between evaluations of the CoM margin (a convex hull
            of the ground contacts).
        feedforward: Add :func:`holding_torques` on the servo joints (PD
            with gravity compensation): the hold then starts in equilibrium
            rather than sagging onto its servos' error, an overshoot that can
            tip a pose with a small margin. Nothing is added when the pose has
            no equilibrium. When a joint needs more than its drive gives
            (:func:`drive_shortfalls`), the pose is not stepped: the report
            fails, naming the joint, its torque and the drive's bound.
        balance: Turn the stance ankles' servo targets against the trunk's
            inclination where the robot cannot stand on its ankle servos alone
            (:mod:`pik_mj.sim.balancing`); False: the servos alone.

    Returns:
        A :class:`HoldReport`.

    Raises:
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    callbacks = as_callbacks(callback)
    every = call_stride(callbacks, every)
    criteria = check_options(
        criteria, duration, every=every, record_every=record_every, margin_every=margin_every
    )
    external = inputs.wrenches(external, "external")
    q = scene.qpos_of(q)[: scene.robot_nq]
    allowed = scene.allowed(criteria.allowed)
    tau = holding_torques(scene, q, external, data=scene.workspace()) if feedforward else None
    short = [] if tau is None else drive_shortfalls(scene, q, tau)
    if short:
        why = "the servos cannot hold this pose: " + "; ".join(s.describe() for s in short)
        return _not_held(scene, q, duration, criteria, allowed, why)
    figures = stance(scene, q)
    feedback = balance_feedback(scene, q, figures) if balance else None
    run = track(
        scene,
        HeldPose(scene, q, tau),
        duration,
        criteria=criteria,
        allowed=allowed,
        external=external,
        callbacks=callbacks,
        every=every,
        record_every=record_every,
        margin_every=margin_every,
        feedback=feedback,
    )
    balanced = None if figures is None else figures.to_dict(feedback is not None)
    return _held(scene, run, criteria, allowed, duration, balanced)


def _held(
    scene: Physics,
    run: Tracked,
    criteria: HoldCriteria,
    allowed: list[str],
    duration: float,
    balance: dict[str, Any] | None,
) -> HoldReport:
    """The report of a hold that ran (``run``) with the ``balance`` feedback's
    figures, its failures diagnosed (:func:`pik_mj.sim.stability.diagnose`)."""
    why = diagnose(scene, run, criteria)
    if balance and balance["on"]:
        why = [w + SERVOS_ALONE for w in why]
    failures = run.failures(criteria) + why
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
        thresholds={**criteria.thresholds(), **run.limits.thresholds()},
        duration=float(duration),
        simulated=run.end_time,
        steps=run.steps,
        timestep=float(scene.model.opt.timestep),
        root_height=run.root_height,
        wall_time=run.wall_time,
        fall=run.fall,
        tilt=run.tilt,
        balance_feedback=balance,
    )


def hold_many(
    scene: Physics,
    qs: Sequence[ArrayLike],
    duration: float = 3.0,
    *,
    criteria: HoldCriteria | None = None,
    nthread: int | None = None,
    record_every: int = RECORD_EVERY,
    margin_every: int = MARGIN_EVERY,
    feedforward: bool = True,
    balance: bool = True,
) -> list[HoldReport]:
    """:func:`hold` of each configuration of ``qs``, stepped together: each chunk
    of steps is one ``mujoco.rollout`` of every hold still going, on ``nthread``
    threads with one ``MjData`` each (:func:`pik_mj.sim.tracking.track_many`);
    a hold that falls stops early. The verdicts and figures are
    :func:`hold`'s (up to the solver's warm start at each chunk: below 1e-9 m).
    No external wrenches or callbacks (use :func:`hold` for those).

    Args:
        scene: The scene.
        qs: Robot configurations.
        duration: Simulated time [s] of each hold.
        criteria: Pass/fail thresholds (default :class:`HoldCriteria`).
        nthread: Rollout threads (default: one per CPU of this process, at most
            one per configuration; 0: the calling thread).
        record_every, margin_every, feedforward, balance: As :func:`hold`.

    Returns:
        One :class:`HoldReport` per configuration, in order.

    Raises:
        InvalidInput: A configuration that is not the robot's, bad options.
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    criteria = check_options(
        criteria, duration, record_every=record_every, margin_every=margin_every
    )
    allowed = scene.allowed(criteria.allowed)
    reports: list[HoldReport | None] = [None] * len(qs)
    held: list[tuple[int, HeldPose]] = []
    stances = []
    for i, q in enumerate(qs):
        q = scene.qpos_of(q)[: scene.robot_nq]
        tau = holding_torques(scene, q, data=scene.workspace()) if feedforward else None
        short = [] if tau is None else drive_shortfalls(scene, q, tau)
        if short:
            why = "the servos cannot hold this pose: " + "; ".join(s.describe() for s in short)
            reports[i] = _not_held(scene, q, duration, criteria, allowed, why)
        else:
            held.append((i, HeldPose(scene, q, tau)))
            stances.append(stance(scene, q))
    feedback = [
        balance_feedback(scene, r.q, f) if balance else None
        for (_, r), f in zip(held, stances, strict=True)
    ]
    if nthread is None:
        nthread = min(len(held), len(os.sched_getaffinity(0)))
    runs = track_many(
        scene, [r for _, r in held], duration, criteria=criteria, allowed=allowed,
        nthread=nthread if nthread > 1 else 0, record_every=record_every,
        margin_every=margin_every, feedback=feedback,
    )  # fmt: skip
    for (i, _), run, f, fb in zip(held, runs, stances, feedback, strict=True):
        balanced = None if f is None else f.to_dict(fb is not None)
        reports[i] = _held(scene, run, criteria, allowed, duration, balanced)
    return [r for r in reports if r is not None]


def _not_held(
    scene: Physics,
    q: np.ndarray,
    duration: float,
    criteria: HoldCriteria,
    allowed: list[str],
    why: str,
) -> HoldReport:
    """The report of a hold that was not stepped: ``why``."""
    h = scene.root_height(scene.kinematics(q))
    return HoldReport(
        passed=False,
        failures=[why],
        drift=0.0,
        drift_horizontal=0.0,
        drift_vertical=0.0,
        final_displacement=np.zeros(3),
        slip=0.0,
        slip_per_geom={},
        min_margin=-math.inf,
        fell=False,
        unexpected_contacts=[],
        allowed=list(allowed),
        thresholds=criteria.thresholds(),
        duration=float(duration),
        simulated=0.0,
        steps=0,
        timestep=float(scene.model.opt.timestep),
        root_height=(h, h),
        wall_time=0.0,
    )
