"""Dual-arm cocktail shaker (irteus manual, a callable ``target-coords``).

The left hand first goes to irteus's ``#f(400 0 0)`` mm (position only, arm
joints only). Then, every step, the left hand follows
``(400 + 100 sin t, 50 cos t, 0)`` mm from the waist with its position along
the shaker axis free, orientation free; the right hand's target is a *function*
evaluated every iteration: the left hand's current pose moved 0.1 m along the
shaker axis, rotation about that axis free. The irteus example's shaker axis is
the hand's z; on the sample humanoid the grasp axis (across the palm) is the
hand's x, so x is the axis named here. Every iteration is checked statically in
the robot's scene. The iterates are a motion by nature (a time-varying target):
they are played in physics (``scene.play``), the steps of the shake one
segment (travelled without stopping between steps); the final pose is held.
"""

from __future__ import annotations

from typing import Any

import mink
import numpy as np

from pik_mj import (
    CollisionAvoidanceTask,
    Recorder,
    Robot,
    Scene,
    Waypoints,
    inverse_kinematics,
)
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    ScenarioResult,
    Stage,
    count,
    open_recorder,
    parser,
    report,
)
from pik_mj.tasks.collision import collision_pairs

NAME = "cocktail_shaker"
SHAKER = 0.1  # [m] between the hands along the shaker axis
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
YELLOW = 0.05  # [m] arm pairs nearer than this are constrained
ORANGE = 0.01  # [m] the distance kept between the arms


def right_target(robot: Robot) -> mink.SE3:
    """The right hand's target, evaluated every iteration: the left hand's pose moved
    ``SHAKER`` along the shaker axis (irteus: ``(send (larm end-coords copy)
    :translate 100 :local)``)."""
    return robot.frame_pose("larm_end") @ mink.SE3.from_translation(np.array([SHAKER, 0.0, 0.0]))


def run(
    recorder: Recorder,
    *,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
    steps: int = 32,
) -> ScenarioResult:
    robot = Robot.from_model("sample_humanoid")
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    waist = robot.root_pose()[0] + np.array([0.0, 0.0, 0.3])  # [m] shaker height: chest
    path = Waypoints(robot, "left hand to start")
    stage.solve(
        inverse_kinematics,
        "left hand to start",
        (waist + np.array([0.4, 0.0, 0.0]), IDENTITY),
        path=path,
        total=50,
        limbs="larm",
        rotation_axis=None,
    )
    avoid = arms_apart(robot)
    errors = [shake(stage, path, avoid, waist, k) for k in range(steps)]
    if speed:
        stage.play("left hand to start, shake", path, speed=speed)
    # The final pose in physics; the contacts the solves made are intended.
    stage.hold_final_pose(hold)
    result = stage.result
    result.main = list(result.solves)[-1]
    result.figures = figures(result, steps, errors)
    check(result, steps)
    return result


def arms_apart(robot: Robot) -> CollisionAvoidanceTask:
    """The arms keep ``ORANGE`` apart (the hands, holding the shaker together,
    excepted): the right hand's first move to the shaker passes the left hand."""
    arms = [f"{side}arm_{link}" for side in "rl" for link in ("upper", "lower", "hand")]
    pairs = [
        p
        for p in collision_pairs(robot.model, robot.data, arms)
        if {p.name1, p.name2} != {"rarm_hand", "larm_hand"}
    ]
    return CollisionAvoidanceTask(robot.configuration, pairs, yellow=YELLOW, orange=ORANGE)


def shake(
    stage: Stage, path: Waypoints, avoid: CollisionAvoidanceTask, waist: np.ndarray, k: int
) -> tuple[float, float, float]:
    """Shaking step ``k``: the left hand along its path, its position along the shaker
    axis free, the right hand on :func:`right_target`. Returns the right hand's
    distance to its target [m], the angle [rad] between the hands' shaker axes, and
    the left hand's distance [m] to its path across the free axis."""
    robot = stage.robot
    t = 0.1 * (k + 1)
    p_left = waist + np.array([0.4 + 0.1 * np.sin(t), 0.05 * np.cos(t), 0.0])
    stage.solve(
        inverse_kinematics,
        f"shake {k:02d}",
        [(p_left, IDENTITY), right_target],
        path=path,
        segment="shake",  # one segment: the shake does not stop between steps
        total=50,
        limbs=["larm", "rarm"],
        translation_axis=["x", True],
        rotation_axis=[None, "x"],
        collision_avoidance=avoid,
    )
    X_RL = right_target(robot).inverse() @ robot.frame_pose("rarm_end")
    X_WL = robot.frame_pose("larm_end")
    R_WL = X_WL.rotation().as_matrix()
    return (
        float(np.linalg.norm(X_RL.translation())),
        float(np.arccos(np.clip(X_RL.rotation().as_matrix()[0, 0], -1, 1))),
        float(np.linalg.norm((R_WL.T @ (X_WL.translation() - p_left))[1:])),
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
        "right hand 0.1 m along the left hand's axis (1 mm)",
        f["right_hand_position_error_max_m"] <= 1e-3,
    )
    result.check(
        "hands' shaker axes aligned (1°)", f["shaker_axis_misalignment_max_rad"] <= np.deg2rad(1.0)
    )
    result.check(
        "left hand on its path across the free axis (1 mm)", f["left_hand_error_yz_max_m"] <= 1e-3
    )


def main(argv: list[str] | None = None) -> int:
    p = parser(__doc__)
    p.add_argument("--steps", type=count, default=32, help="shaking steps")
    args = p.parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, speed=args.speed, quiet=args.quiet, steps=args.steps)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
