"""Walk to a pose: go_pos(0.5 m, 0.15 m, 45°) footsteps, the pattern played in physics.

The irteus manual's ``:go-pos-params->footstep-list``: footsteps from the sample humanoid's
feet to a goal 0.5 m ahead, 0.15 m left and turned 45° left (the left leg
leads, at most 0.15 m / 30° per step), the walking pattern by preview control
and whole-body IK per tick, then the same checks as ``walk_forward``: ZMP of the
inverse dynamics inside the support polygon at every tick; in physics no fall
and the feet end where planned.
"""

from __future__ import annotations

import numpy as np

from pik_mj import Recorder, Robot, Scene
from pik_mj.scenario import ScenarioResult, finite, open_recorder, parser, positive, report
from pik_mj.walking import GaitParameters, go_pos
from pik_mj.walking.playback import WALK_CONTACT, evaluate_walk, play_walk_pattern, walk_motion
from pik_mj.walking.wholebody import calc_walk_pattern, feet_from_robot

NAME = "walk_go_pos"


def run(
    recorder: Recorder,
    *,
    quiet: bool = True,
    x: float = 0.5,  # [m]
    y: float = 0.15,  # [m]
    theta_deg: float = 45.0,  # [deg]
    dt: float = 0.01,  # [s]
) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("sample_humanoid")
    params = GaitParameters(dt=dt, step_time=1.0, step_height=0.05, double_support_ratio=0.2)
    steps = go_pos(x, y, np.deg2rad(theta_deg), feet_from_robot(robot))
    pattern = calc_walk_pattern(robot, steps, params)
    if not quiet:
        print(pattern)
    scene = Scene.from_robot(robot, contact=WALK_CONTACT)
    log = recorder.walk_logger()
    walk = log.finish(play_walk_pattern(pattern, scene, callback=log))
    result.robot = robot
    result.figures, checks = evaluate_walk(pattern, walk)
    result.walk = walk_motion(pattern, walk)
    result.figures["sim_final_yaw_error_deg"] = float(np.rad2deg(walk.final_yaw_error))
    for label, ok, detail in checks:
        result.check(label, ok, detail)
    result.check(
        "physics playback: final heading within 5 deg of the plan",
        walk.final_yaw_error <= np.deg2rad(5.0),
        f"{np.rad2deg(walk.final_yaw_error):.2f} deg",
    )
    return result


def main(argv: list[str] | None = None) -> int:
    p = parser(__doc__, hold=False)
    p.add_argument("--x", type=finite, default=0.5, help="goal ahead [m]")
    p.add_argument("--y", type=finite, default=0.15, help="goal to the left [m]")
    p.add_argument("--theta", type=finite, default=45.0, help="goal heading change [deg]")
    p.add_argument("--dt", type=positive, default=0.01, help="pattern tick [s]")
    args = p.parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(
            recorder, quiet=args.quiet, x=args.x, y=args.y, theta_deg=args.theta, dt=args.dt
        )
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
