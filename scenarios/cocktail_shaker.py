"""Dual-arm cocktail shaker (seed 001, a callable ``target-coords``).

The left hand first goes to the seed's ``#f(400 0 0)`` mm (position only, arm
joints only). Then, every step, the left hand follows
``(400 + 100 sin t, 50 cos t, 0)`` mm from the waist with its position along
the shaker axis free, orientation free; the right hand's target is a *function*
evaluated every iteration: the left hand's current pose moved 0.1 m along the
shaker axis, rotation about that axis free. The seed's shaker axis is the
hand's z; on the sample humanoid the grasp axis (across the palm) is the
hand's x, so x is the axis named here. Every iteration is checked statically in
the robot's scene. The iterates are a motion by nature (a time-varying target):
they are played in physics (``scene.play``), the steps of the shake one
segment (travelled without stopping between steps); the final pose is held.
"""

from __future__ import annotations

import sys

import mink
import numpy as np

from pik_mj import (
    CollisionAvoidanceTask,
    HoldCriteria,
    Progress,
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


def run(
    recorder: Recorder,
    *,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
    steps: int = 32,
) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    err = None if quiet else sys.stderr
    waist = robot.root_pose()[0] + np.array([0.0, 0.0, 0.3])  # [m] shaker height: chest

    def left_hand() -> mink.SE3:
        return robot.frame_pose("larm_end")

    def right_target() -> mink.SE3:  # seed: (send (larm end-coords copy) :translate 100 local)
        return left_hand() @ mink.SE3.from_translation(np.array([SHAKER, 0.0, 0.0]))

    path = Waypoints(robot, "left hand to start")

    def solve(label: str, segment: str, *targets, **options) -> None:
        """``inverse_kinematics`` with the static checks, the logger, the progress
        and the path (its iterates in the motion's ``segment``)."""
        checks = scene.static_checker()
        log = recorder.solve_logger(label, checks=checks, start=robot)
        progress = Progress(label, total=50, stream=err)
        res = inverse_kinematics(
            robot, *targets, callback=[checks, log, progress, path.segment(segment)], **options
        )
        result.add_solve(label, res, checks, finish=[log, progress, path])

    solve(
        "left hand to start",
        "left hand to start",
        (waist + np.array([0.4, 0.0, 0.0]), IDENTITY),
        limbs="larm",
        rotation_axis=None,
    )
    # The arms keep ORANGE apart (the hands, holding the shaker together, excepted):
    # the right hand's first move to the shaker passes the left hand.
    arms = [f"{side}arm_{link}" for side in "rl" for link in ("upper", "lower", "hand")]
    pairs = [
        p
        for p in collision_pairs(robot.model, robot.data, arms)
        if {p.name1, p.name2} != {"rarm_hand", "larm_hand"}
    ]
    avoid = CollisionAvoidanceTask(robot.configuration, pairs, yellow=YELLOW, orange=ORANGE)
    rel_errors, left_errors = [], []
    for k in range(steps):
        t = 0.1 * (k + 1)
        p_left = waist + np.array([0.4 + 0.1 * np.sin(t), 0.05 * np.cos(t), 0.0])
        solve(
            f"shake {k:02d}",
            "shake",  # one segment: the shake does not stop between steps
            [(p_left, IDENTITY), right_target],
            limbs=["larm", "rarm"],
            translation_axis=["x", True],
            rotation_axis=[None, "x"],
            collision_avoidance=avoid,
        )
        X_RL = right_target().inverse() @ robot.frame_pose("rarm_end")
        rel_rot = X_RL.rotation().as_matrix()
        # position error, and the shaker axis (x) of both hands aligned
        rel_errors.append(
            (
                float(np.linalg.norm(X_RL.translation())),
                float(np.arccos(np.clip(rel_rot[0, 0], -1, 1))),
            )
        )
        R_WL = left_hand().rotation().as_matrix()
        left_errors.append(
            float(np.linalg.norm((R_WL.T @ (left_hand().translation() - p_left))[1:]))
        )

    # The iterates as a motion in physics.
    if speed:
        log = recorder.motion_logger()
        motion = scene.play(path, speed=speed, callback=[log])
        result.add_motion("left hand to start, shake", motion, finish=[log])

    # The final pose in physics; the contacts the solves made are intended.
    q = robot.configuration.q.copy()
    static = scene.static_check(q)
    criteria = HoldCriteria(allowed=[*scene.allowed_contacts, *static.touching_geoms])
    held = scene.hold(q, hold, criteria=criteria, callback=recorder.hold_logger()) if hold else None
    result.add_balance(scene, static, held, criteria)

    solves = result.solves
    shakes = [r for k, r in solves.items() if k.startswith("shake")]
    result.main = list(solves)[-1]
    result.figures = {
        "steps": steps,
        "converged_steps": sum(r.converged for r in shakes),
        "iterations_per_step_max": max(r.iterations for r in shakes),
        "right_hand_position_error_max_m": max(e[0] for e in rel_errors),
        "shaker_axis_misalignment_max_rad": max(e[1] for e in rel_errors),
        "left_hand_error_yz_max_m": max(left_errors),
        "median_iteration_ms": float(
            np.median([t for r in shakes for t in r.iteration_times]) * 1e3
        ),
    }
    f = result.figures
    result.check("start pose reached", solves["left hand to start"].converged)
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
    return result


def main(argv: list[str] | None = None) -> int:
    p = parser(__doc__)
    p.add_argument("--steps", type=count, default=32, help="shaking steps")
    args = p.parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, speed=args.speed, quiet=args.quiet, steps=args.steps)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
