"""One sweep case on pik_mj's API: solve, static check, motion, physics hold → one result.

This is the only module of :mod:`pik_mj.sweep` that calls the robot, IK and
simulation API; the rest (cases, Ray driver, dataset, views) sees a
:class:`Worker` and the plain dict its :meth:`Worker.run` returns.

The robot is :meth:`pik_mj.Robot.from_model` of the case's model standing on a
floor plane (``environment=floor_environment()``: the world frame is the
floor's, z up, the robot's model frame at the origin; no degrees of freedom
added), so that the floor is a geom the IK keeps clear of. Its physics scene is
:meth:`pik_mj.sim.Scene.from_robot` of that robot (default servos, contacts and
allowed contacts: the soles).

A case reaches the hand target ``p = (x, y, z)`` [m] (world frame) from the
robot's start pose (``reset_pose``) with
:func:`pik_mj.ik.fullbody_inverse_kinematics` (feet fixed, hand position only,
``stop=100``, no revert: the final pose is what is held). Level 1 holds the
feet, collision avoidance (every pair of robot bodies and every body against
the floor, less adjacent pairs and pairs touching at the start; yellow zone
10 cm, orange zone 1 cm) and, in the ``balanced`` stack, the CoM inside the
soles' support polygon shrunk by ``margin``; level 2 the hand. The final pose is
checked statically (:meth:`pik_mj.sim.Scene.static_check`), the iterates are
played in physics as a motion (:meth:`pik_mj.sim.Scene.play`, its default speed
and criteria) and the final pose is held (:meth:`pik_mj.sim.Scene.hold`,
default :class:`pik_mj.sim.HoldCriteria`). The result carries the final
configuration (``qpos``) and the iterates (``path``): :func:`replay` checks a
row again from them alone.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.robot import Robot
from pik_mj.robot.ground import sole_polygons
from pik_mj.robot.world import FLOOR
from pik_mj.sim import (
    HoldCriteria,
    HoldReport,
    MotionReport,
    Scene,
    StaticReport,
    Waypoints,
    floor_environment,
)
from pik_mj.sim.tracking import RECORD_EVERY
from pik_mj.tasks.collision import CollisionAvoidanceTask, collision_pairs
from pik_mj.tasks.support_polygon import SupportPolygonTask

DEFAULT_HAND = "rarm"
DEFAULT_MARGIN = 0.02  # [m] CoM kept this far inside the support polygon (balanced)
STOP = 100  # IK iterations at most
YELLOW, ORANGE = 0.1, 0.01  # [m] collision avoidance: watched below, kept above
FEET = ("rleg", "lleg")
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])

PARAMETERS = {
    "x": "hand target x [m], world frame",
    "y": "hand target y [m], world frame",
    "z": "hand target z [m], world frame (height above the floor)",
    "margin": f"CoM margin inside the support polygon [m] (balanced stack; {DEFAULT_MARGIN})",
}
"""Task parameters a sweep may vary, with their meaning."""

REQUIRED = ("x", "y", "z")

STACKS = {
    "balanced": "feet fixed + CoM inside the soles' polygon + collision avoidance; hand",
    "unbalanced": "feet fixed + collision avoidance; hand",
}
"""Stacks a sweep may use, with their levels."""


def standing_robot(model: str, hand: str = DEFAULT_HAND) -> Robot:
    """The robot of a sweep: ``model`` standing on a floor plane, in its start pose.

    Raises:
        UnknownName: Unknown model, or no limb ``hand`` / ``rleg`` / ``lleg``.
        InvalidInput: A model that does not load, or no floating base.
    """
    robot = Robot.from_model(model, environment=floor_environment())
    if not robot.has_floating_base:
        raise InvalidInput(
            f"model {model!r} has no floating base (a free joint at its root "
            f"{robot.root_body!r}): a sweep's robot stands on its feet"
        )
    for limb in (hand, *FEET):
        robot.limb(limb)
    return robot


class Worker:
    """Solves, checks and holds cases of one robot; built once, reused across cases.

    Args:
        robot: Robot model name or MJCF path.
        hand: Limb sent to the target.
        hold: Physics hold duration [s].

    Attributes:
        record_every: Steps between the samples of the motion's and the hold's
            checks (:mod:`pik_mj.sim.tracking`; 1: every step).
    """

    record_every = RECORD_EVERY

    def __init__(self, robot: str, *, hand: str = DEFAULT_HAND, hold: float = 3.0):
        self.robot = standing_robot(robot, hand)
        self.limb = self.robot.limb(hand)
        self.hold_duration = float(hold)
        self.scene = Scene.from_robot(self.robot)
        self.criteria = HoldCriteria()
        self.robot.reset_pose()
        m = self.robot.model
        bodies = [m.body(b).name for b in range(1, m.nbody) if m.body_geomnum[b] > 0]
        self.pairs = collision_pairs(m, self.robot.data, bodies, [FLOOR])
        self.soles = sole_polygons(self.robot, FEET)

    def run(self, case: Any) -> dict[str, Any]:
        """Solve, check and hold ``case`` (a :class:`pik_mj.sweep.spec.Case`).

        Returns:
            The result columns of :data:`pik_mj.sweep.dataset.RESULT_FIELDS`.
        """
        robot, params = self.robot, case.params
        target = np.array([params["x"], params["y"], params["z"]], dtype=float)
        robot.reset_pose()
        config = robot.configuration
        avoid = CollisionAvoidanceTask(config, self.pairs, yellow=YELLOW, orange=ORANGE)
        balance = []
        if case.stack == "balanced":
            margin = float(params.get("margin", DEFAULT_MARGIN))
            balance = [
                SupportPolygonTask(config, self.soles, root_body=robot.root_body, margin=margin)
            ]
        path = Waypoints(robot, "reach")
        t0 = time.perf_counter()
        result = fullbody_inverse_kinematics(
            robot,
            [(target, IDENTITY)],
            limbs=[self.limb.name],
            rotation_axis=[None],  # position only
            fix_feet=FEET,
            balance=balance,
            collision_avoidance=[avoid],
            stop=STOP,
            revert_if_fail=False,
            callback=[path],
        )
        t1 = time.perf_counter()
        q = config.q.copy()
        p_hand = robot.frame_pose(self.limb.end_frame, self.limb.end_frame_type).translation()
        checked = self.check(q, path.q)
        return {
            "converged": bool(result.converged),
            "iterations": int(result.iterations),
            "hand_error": float(np.linalg.norm(p_hand - target)),
            "level_errors": [float(e) for e in result.level_errors],
            "hand": [float(v) for v in p_hand],
            **checked,
            "solve_time": t1 - t0,
        }

    def check(self, q: np.ndarray, path: np.ndarray) -> dict[str, Any]:
        """The checks of a case's final configuration ``q`` and iterates ``path``
        (N, nq): the static check, the motion and the hold; their columns of
        :data:`pik_mj.sweep.dataset.RESULT_FIELDS` (with ``qpos`` and ``path``)."""
        t0 = time.perf_counter()
        static = self.scene.static_check(q)
        t1 = time.perf_counter()
        every = {"record_every": self.record_every}
        motion = self.scene.play(np.asarray(path, dtype=float), **every)
        t2 = time.perf_counter()
        hold = self.scene.hold(q, self.hold_duration, criteria=self.criteria, **every)
        t3 = time.perf_counter()
        return {
            **_static_columns(static),
            **_motion_columns(motion),
            **_hold_columns(hold),
            "qpos": [float(v) for v in q],
            "path": [[float(v) for v in x] for x in path],
            "static_time": t1 - t0,
            "motion_time": t2 - t1,
            "hold_time": t3 - t2,
        }

    def check_many(self, qs: list[np.ndarray], paths: list[np.ndarray]) -> list[dict[str, Any]]:
        """:meth:`check` of many cases, their holds stepped together
        (:meth:`pik_mj.sim.Scene.hold_many`: ``mujoco.rollout``'s threads)."""
        out = []
        for q, path in zip(qs, paths, strict=True):
            static = self.scene.static_check(q)
            every = {"record_every": self.record_every}
            motion = self.scene.play(np.asarray(path, dtype=float), **every)
            out.append({**_static_columns(static), **_motion_columns(motion)})
        holds = self.scene.hold_many(
            qs, self.hold_duration, criteria=self.criteria, record_every=self.record_every
        )
        for row, hold in zip(out, holds, strict=True):
            row.update(_hold_columns(hold))
        return out


def _static_columns(static: StaticReport) -> dict[str, Any]:
    return {
        "com": [float(v) for v in static.com],
        "static_feasible": bool(static.feasible),
        "static_margin": float(static.margin),
    }


def _motion_columns(motion: MotionReport) -> dict[str, Any]:
    return {
        "motion_passed": bool(motion.passed),
        "motion_failures": list(motion.failures),
        "motion_drift": float(motion.drift),
    }


def _hold_columns(hold: HoldReport) -> dict[str, Any]:
    return {
        "hold_passed": bool(hold.passed),
        "hold_failures": list(hold.failures),
        "drift": float(hold.drift),
        "slip": float(hold.slip),
        "hold_min_margin": float(hold.min_margin),
        "fell": bool(hold.fell),
        "unexpected_contacts": [f"{a}-{b}" for a, b, _ in hold.unexpected_contacts],
    }
