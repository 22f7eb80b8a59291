"""Dual-arm cocktail shaker (irteus manual, a callable ``target-coords``).

The left hand first goes to the start, irteus's ``#f(400 0 0)`` mm from the waist
(position only, arm joints only); here ``START`` arm lengths ``L`` from the middle of
the shoulders, in the robot's frame (x forward, y left, z up; on the sample humanoid,
whose arm is 0.61 m long, the manual's 400 mm ahead of a waist 0.1 m below the
shoulders). Then, every step, the left hand follows ``(0.16 L sin t, 0.08 L cos t, 0)``
from the start (the manual's ``(100 sin t, 50 cos t, 0)`` mm) with its position along
the shaker axis free, orientation free; the right hand's target is a *function*
evaluated every iteration: the left hand's current pose moved ``SHAKER`` L along the
shaker axis, rotation about that axis free. The irteus example's shaker axis is the
hand's z; here it is the left hand's grip axis (:class:`pik_mj.scenario.Hand`: along a
bar held in the hand). A right arm of fewer than 5 joints (Unitree H1's and Booster
T1's have 4) holds the shaker's end by position alone: its grip is left free and its
misalignment reported, not checked. The shaker is at least as long as keeps the hands
``ORANGE`` apart (:meth:`Shaker.clearance`). Where the arms do not reach across the
middle by the shaker's length (Booster T1's arms barely reach the middle plane), the
start and the swing come from where the arms reach (:func:`placement`): both hands go
to the shaker at once, at a sampled pose where both reach it, and the shake swings
as far as the hands reach across. Every iteration is checked statically in
the robot's scene. The iterates are a motion by nature (a time-varying target):
they are played in physics (``scene.play``), the steps of the shake one
segment (travelled without stopping between steps); the final pose is held.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import mink
import numpy as np
from scipy.spatial import cKDTree

from pik_mj import (
    CollisionAvoidanceTask,
    Recorder,
    Robot,
    Scene,
    Waypoints,
    inverse_kinematics,
)
from pik_mj.robot.collisions import self_collision_pairs
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    Hand,
    RobotOption,
    ScenarioResult,
    Stage,
    Stature,
    count,
    open_recorder,
    parser,
    report,
    run_options,
)
from pik_mj.scenario.reach import sample_arm
from pik_mj.tasks.collision import GeomPair

NAME = "cocktail_shaker"
SHAKER = 0.16  # [arm lengths] between the hands along the shaker axis
START = (0.66, 0.0, -0.16)  # [arm lengths] the left hand's start from the shoulders
SWING = (0.16, 0.08)  # [arm lengths] the shake's half swings, forward and sideways
ARMS = ("larm", "rarm")  # the leader, the follower
SAMPLES = 20000  # configurations sampled per arm (:func:`placement`)
SEED = 0  # of the samples
REACH = 0.02  # [arm lengths] a sampled right hand this near the shaker's end reaches it


AXIS_JOINTS = 5
"""Right-arm joints that hold the shaker's end along the left hand's axis: 3 of
position and 2 of orientation (fewer: position alone)."""


def shaker_joints(robot: Robot) -> str | None:
    """Why ``robot``'s right arm cannot follow the shaker, or None: the right hand's
    target asks at least 3 coordinates of it (its position)."""
    n = len(robot.limb("rarm").joints) if "rarm" in robot.limbs else AXIS_JOINTS
    if n < 3:
        return f"its right arm has {n} joints; holding the shaker's end asks 3 (its position)"
    return None


ROBOT = RobotOption("sample_humanoid", ARMS, requires=shaker_joints)
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
YELLOW = 0.05  # [m] arm pairs nearer than this are constrained
ORANGE = 0.01  # [m] the distance kept between the arms


class Shaker:
    """The shaker held between the hands: the left hand leads, the right hand keeps
    ``SHAKER`` arm lengths along the left hand's grip axis.

    Attributes:
        left: The left hand.
        right: The right hand.
        length: The hands' distance along the axis [m].
        holds_axis: The right arm has the joints to hold its grip along the axis
            (:data:`AXIS_JOINTS`); else its orientation is free.
    """

    def __init__(self, stature: Stature, robot: Robot) -> None:
        self.left, self.right = (stature.hands[a] for a in ARMS)
        self.length = max(SHAKER * stature.arm_lengths["larm"], self.clearance(robot))
        self.holds_axis = len(robot.limb("rarm").joints) >= AXIS_JOINTS

    def clearance(self, robot: Robot) -> float:
        """The hands' distance along the shaker axis [m] that keeps them ``ORANGE``
        apart: how far each hand's geoms reach along the axis from its frame (the
        corners of their bounding boxes, MuJoCo's ``geom_aabb``, at the start pose),
        summed, plus ``ORANGE``."""
        m, d = robot.model, robot.data
        signs = np.array(list(itertools.product((-1, 1), repeat=3)))
        reach = 0.0
        for hand in (self.left, self.right):
            X_WH = hand.pose(robot)
            a = hand.axis(X_WH, hand.grip)
            corners = [
                d.geom_xpos[g]
                + (m.geom_aabb[g][:3] + signs * m.geom_aabb[g][3:]) @ d.geom_xmat[g].reshape(3, 3).T
                for g in hand.geoms(m)
            ]
            reach += float(np.max(np.abs((np.vstack(corners) - X_WH.translation()) @ a)))
        return reach + ORANGE

    @property
    def axis(self) -> str:
        """The shaker axis' name in the hand frames (``"x"``, ``"y"``, ``"z"``)."""
        return Hand.name(self.left.grip)

    def right_target(self, robot: Robot) -> mink.SE3:
        """The right hand's target, evaluated every iteration: the left hand's pose
        moved ``length`` along the shaker axis (irteus: ``(send (larm end-coords copy)
        :translate 100 :local)``)."""
        step = self.length * Hand.vector(self.left.grip)
        return self.left.pose(robot) @ mink.SE3.from_translation(step)


def run(
    recorder: Recorder,
    *,
    model: str | None = "sample_humanoid",
    description: str | None = None,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
    steps: int = 32,
    robot: Robot | None = None,
) -> ScenarioResult:
    """The left hand to the start, ``steps`` steps of the shake, played and held.
    ``robot``: the robot already built from ``model`` and ``description``, else None
    to build it here."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=ROBOT.limbs)
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    stature = Stature.of(robot)
    shaker = Shaker(stature, robot)
    shoulders = np.mean([stature.shoulders[a] for a in ARMS], axis=0)
    L = stature.arm_lengths["larm"]
    start = shoulders + L * stature.direction(START)
    path = Waypoints(robot, "left hand to start")
    avoid = arms_apart(robot, shaker)
    place = placement(robot, stature, shaker, start, shoulders)
    start = place.start
    to_start(stage, path, avoid, shaker, place)
    swing = [
        place.scale * L * stature.direction([SWING[0], 0.0, 0.0]),
        place.scale * L * stature.direction([0.0, SWING[1], 0.0]),
    ]
    errors = [shake(stage, path, avoid, shaker, start, swing, k) for k in range(steps)]
    if speed:
        stage.play("left hand to start, shake", path, speed=speed)
    # The final pose in physics; the contacts the solves made are intended.
    stage.hold_final_pose(hold)
    result = stage.result
    result.main = list(result.solves)[-1]
    result.figures = figures(result, steps, errors)
    result.figures["right_grip_held_along_the_axis"] = shaker.holds_axis
    result.figures["shaker_length_m"] = shaker.length
    result.figures["hands_reach_across_middle_m"] = place.across
    result.figures["swing_scale"] = place.scale
    check(result, steps)
    return result


@dataclass(frozen=True)
class Placement:
    """Where the shake starts and how far it swings (:func:`placement`).

    Attributes:
        start: The left hand's start [m], world.
        scale: The share of ``SWING`` the shake swings.
        manual: The start is the manual's (the left hand goes there alone); else
            both hands go to the shaker at once.
        across: How far [m] the hands reach across the middle plane (the lesser of
            the two arms').
    """

    start: np.ndarray
    scale: float
    manual: bool
    across: float


def placement(
    robot: Robot, stature: Stature, shaker: Shaker, start: np.ndarray, middle: np.ndarray
) -> Placement:
    """The shake's start and swing, from where the arms reach (each arm's hand frame
    at ``SAMPLES`` configurations drawn within its joint ranges,
    :func:`pik_mj.scenario.reach.sample_arm`).

    The manual's start ``start`` lies on the middle plane between the shoulders
    (``middle`` [m], their midpoint): the hands hold the shaker there if each reaches
    across that plane by the shaker's length, ``a = min(-min_l y, max_r y) >= length``
    (``y`` the hands' sampled offsets [m] along the robot's left). Else the shake
    swings ``a / length`` of ``SWING`` (none where a hand does not reach the plane)
    and starts at the sampled left-hand position nearest ``start`` whose shaker end
    (``length`` along its grip axis) is within ``REACH`` arm lengths of a sampled
    right-hand position (the nearest end, if none is).
    """
    rng = np.random.default_rng(SEED)
    left, right = (sample_arm(robot, h, SAMPLES, rng) for h in (shaker.left, shaker.right))
    y = stature.direction([0.0, 1.0, 0.0])
    across = float(min(-np.min((left.p - middle) @ y), np.max((right.p - middle) @ y)))
    if across >= shaker.length:
        return Placement(start, 1.0, True, across)
    ends = left.p + shaker.length * left.R @ Hand.vector(shaker.left.grip)
    gap, _ = cKDTree(right.p).query(ends)
    near = np.flatnonzero(gap <= REACH * stature.arm_lengths["larm"])
    if near.size == 0:
        near = np.array([int(np.argmin(gap))])
    k = near[np.argmin(np.linalg.norm(left.p[near] - start, axis=1))]
    return Placement(left.p[k], float(np.clip(across / shaker.length, 0.0, 1.0)), False, across)


def to_start(
    stage: Stage, path: Waypoints, avoid: CollisionAvoidanceTask, shaker: Shaker, place: Placement
) -> None:
    """The solve to the shake's start: at the manual's start the left hand alone (its
    position, its arm's joints); at a start from the arms' reach (:func:`placement`)
    both hands at once, the right one on :meth:`Shaker.right_target`."""
    if place.manual:
        targets: Any = (place.start, IDENTITY)
        aim: dict[str, Any] = {"limbs": "larm", "move_targets": shaker.left.frame}
        aim["rotation_axis"] = None
    else:
        targets = [(place.start, IDENTITY), shaker.right_target]
        aim = {"limbs": list(ARMS), "move_targets": [shaker.left.frame, shaker.right.frame]}
        aim["rotation_axis"] = [None, shaker.axis if shaker.holds_axis else None]
    stage.solve(
        inverse_kinematics,
        "left hand to start",
        targets,
        path=path,
        total=50,
        collision_avoidance=avoid,
        **aim,
    )


def arms_apart(robot: Robot, shaker: Shaker) -> CollisionAvoidanceTask:
    """The arms keep ``ORANGE`` from each other and from the body (every pair of the
    robot's own geoms the arms' joints move): the right hand's first move to the
    shaker passes the left hand, and a hand brought to the middle does not press its
    shoulder into the torso. Not watched: the hands' bodies, holding the shaker
    together, and pairs of one arm's own links (a wrist bending next to its forearm
    is the arm's own business)."""
    m = robot.model
    side = {b: a for a in ARMS for b in robot.bodies(a)}
    dofs = [int(m.joint(j).dofadr[0]) for a in ARMS for j in robot.limb(a).joints]
    hands = {shaker.left.body, shaker.right.body}

    def watched(p: GeomPair) -> bool:
        bodies = {m.body(m.geom_bodyid[g]).name for g in (p.geom1, p.geom2)}
        arms = {side.get(b) for b in bodies}
        return bodies != hands and not (len(arms) == 1 and None not in arms)

    pairs = [p for p in self_collision_pairs(robot, dofs) if watched(p)]
    return CollisionAvoidanceTask(robot.configuration, pairs, yellow=YELLOW, orange=ORANGE)


def shake(
    stage: Stage,
    path: Waypoints,
    avoid: CollisionAvoidanceTask,
    shaker: Shaker,
    start: np.ndarray,
    swing: list[np.ndarray],
    k: int,
) -> tuple[float, float, float]:
    """Shaking step ``k``: the left hand along its path ``start + sin t swing_0 +
    cos t swing_1``, its position along the shaker axis free, the right hand on
    :meth:`Shaker.right_target`. Returns the right hand's distance to its target [m],
    the angle [rad] between the hands' shaker axes, and the left hand's distance [m]
    to its path across the free axis."""
    robot = stage.robot
    t = 0.1 * (k + 1)
    p_left = start + np.sin(t) * swing[0] + np.cos(t) * swing[1]
    stage.solve(
        inverse_kinematics,
        f"shake {k:02d}",
        [(p_left, IDENTITY), shaker.right_target],
        path=path,
        segment="shake",  # one segment: the shake does not stop between steps
        total=50,
        limbs=list(ARMS),
        move_targets=[shaker.left.frame, shaker.right.frame],
        translation_axis=[shaker.axis, True],
        rotation_axis=[None, shaker.axis if shaker.holds_axis else None],
        collision_avoidance=avoid,
    )
    X_RL = shaker.right_target(robot).inverse() @ shaker.right.pose(robot)
    X_WL = shaker.left.pose(robot)
    R_WL = X_WL.rotation().as_matrix()
    a = Hand.vector(shaker.left.grip)
    across = np.eye(3) - np.outer(a, a)  # the left hand frame's components off the axis
    return (
        float(np.linalg.norm(X_RL.translation())),
        float(np.arccos(np.clip(a @ X_RL.rotation().as_matrix() @ a, -1, 1))),
        float(np.linalg.norm(across @ (R_WL.T @ (X_WL.translation() - p_left)))),
    )


def figures(
    result: ScenarioResult, steps: int, errors: list[tuple[float, float, float]]
) -> dict[str, Any]:
    """The shake's measures: its steps, their iterations, the hands' largest errors."""
    shakes = [r for k, r in result.solves.items() if k.startswith("shake")]
    return {
        "steps": steps,
        "converged_steps": sum(r.converged for r in shakes),
        "iterations_per_step_max": max(r.iterations for r in shakes),
        "right_hand_position_error_max_m": max(e[0] for e in errors),
        "shaker_axis_misalignment_max_rad": max(e[1] for e in errors),
        "left_hand_error_yz_max_m": max(e[2] for e in errors),
        "median_iteration_ms": float(
            np.median([t for r in shakes for t in r.iteration_times]) * 1e3
        ),
    }


def check(result: ScenarioResult, steps: int) -> None:
    """The scenario's checks on its solves and figures."""
    f = result.figures
    result.check("start pose reached", result.solves["left hand to start"].converged)
    result.check("every step converged", f["converged_steps"] == steps)
    result.check(
        "right hand on the shaker, along the left hand's axis (1 mm)",
        f["right_hand_position_error_max_m"] <= 1e-3,
    )
    if f["right_grip_held_along_the_axis"]:
        result.check(
            "hands' shaker axes aligned (1°)",
            f["shaker_axis_misalignment_max_rad"] <= np.deg2rad(1.0),
        )
    result.check(
        "left hand on its path across the free axis (1 mm)", f["left_hand_error_yz_max_m"] <= 1e-3
    )


def main(argv: list[str] | None = None) -> int:
    p = parser(__doc__, robot=ROBOT, description=True)
    p.add_argument("--steps", type=count, default=32, help="shaking steps")
    args = p.parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, **run_options(args), steps=args.steps)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
