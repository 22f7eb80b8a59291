"""The physics hold of a pose: :func:`hold` (:meth:`pik_mj.sim.Scene.hold`).

The state is reset, the pose written at rest with the servo targets at it and
the static torques that hold it (:func:`holding_torques`); the stepping loop
(:func:`pik_mj.sim.tracking.track`, the one a motion uses) measures against that
constant reference (:class:`HeldPose`). The thresholds are one
:class:`~pik_mj.sim.tracking.HoldCriteria`, each callback gets a
:class:`~pik_mj.sim.tracking.HoldSample`, the outcome is a :class:`HoldReport`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.dynamics import contact_wrenches
from pik_mj.frames import Frame
from pik_mj.sim.criteria import HoldCriteria, check_options
from pik_mj.sim.falls import Fall
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.static import finite_or_none, point_contacts, static_check
from pik_mj.sim.tracking import HoldSample, track

__all__ = [
    "HeldPose",
    "HoldCriteria",
    "HoldReport",
    "HoldSample",
    "hold",
    "holding_torques",
]


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
        }


def holding_torques(
    scene: Physics, q: ArrayLike, external: Sequence[External] = ()
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
    wrenches = scene.external_wrenches(external, d)
    report = static_check(scene, q, external=external)
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
            m, d, jacp, None, c.position, int(m.geom_bodyid[scene.geom_ids[c.robot_geom]])
        )
        tau -= jacp.T @ f
    for frame, b in scene.held_objects:
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

    def __init__(self, scene: Physics, q: ArrayLike, tau: np.ndarray | None):
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
            dofs = scene.servo_dofs
            d.qfrc_applied[dofs] = self.tau[dofs] - d.qfrc_actuator[dofs]
        self.data.qpos[:] = d.qpos
        mujoco.mj_kinematics(m, self.data)

    def update(self, t: float) -> None:
        """Nothing moves."""


def hold(
    scene: Physics,
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
            at the start and every ``every`` steps.
        every: Steps between callback calls (>= 1).
        margin_every: Steps between evaluations of the CoM margin (a convex hull
            each).
        feedforward: Add :func:`holding_torques` on the servo joints (PD
            with gravity compensation): the hold then starts in equilibrium
            rather than sagging onto its servos' error, an overshoot that can
            tip a pose with a small margin. Nothing is added when the pose has
            no equilibrium.

    Returns:
        A :class:`HoldReport`.

    Raises:
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    criteria = check_options(criteria, duration, every=every, margin_every=margin_every)
    external = inputs.wrenches(external, "external")
    q = scene.qpos_of(q)[: scene.robot_nq]
    callbacks = as_callbacks(callback)
    allowed = scene.allowed(criteria.allowed)
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
        thresholds={**criteria.thresholds(), **run.limits.thresholds()},
        duration=float(duration),
        simulated=run.end_time,
        steps=run.steps,
        timestep=float(scene.model.opt.timestep),
        root_height=run.root_height,
        wall_time=run.wall_time,
        fall=run.fall,
        tilt=run.tilt,
    )
