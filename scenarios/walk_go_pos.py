"""Walk to a pose: go_pos(0.5 m, 0.2 m, 30°) footsteps played in physics, on any humanoid.

The irteus manual's ``:go-pos-params->footstep-list``: footsteps from the robot's
feet to a goal 0.5 m ahead, 0.2 m left and turned 30° left, each step within the
reach of the gait derived from the robot (printed; ``--gait NAME=VALUE`` gives a
value instead), the walking pattern by preview control and whole-body IK per
tick, then the same checks as ``walk_forward``: ZMP of the inverse dynamics
inside the support polygon at every tick; in physics no fall, the feet end where
planned and turned as planned. Any robot with two legs: ``--model unitree_g1``,
an MJCF path, or ``--description FILE``.
"""

from __future__ import annotations

import numpy as np
from pik_mj.scenarios.walk_forward import walk_command, walk_parser, walk_scenario

from pik_mj import Recorder, Robot
from pik_mj.scenario import ScenarioResult, finite
from pik_mj.walking.robot_gait import DEFAULT_DT

NAME = "walk_go_pos"
HEADING_TOLERANCE = 5.0
"""[deg] Largest final heading error to the plan."""


def run(
    recorder: Recorder,
    *,
    model: str | None = "sample_humanoid",
    description: str | None = None,
    robot: Robot | None = None,
    quiet: bool = True,
    x: float = 0.5,  # [m]
    y: float = 0.2,  # [m]
    theta_deg: float = 30.0,  # [deg]
    dt: float = DEFAULT_DT,  # [s]
    gait: dict[str, float] | None = None,
) -> ScenarioResult:
    """Walk to ``(x, y, theta)`` from the start; ``gait``: values given instead of derived."""
    result, done = walk_scenario(
        NAME,
        recorder,
        lambda chosen, feet: chosen.go_pos(x, y, np.deg2rad(theta_deg), feet),
        model=model,
        description=description,
        robot=robot,
        dt=dt,
        gait=gait,
        quiet=quiet,
    )
    yaw_error = float(np.rad2deg(done.report.final_yaw_error))
    result.figures["sim_final_yaw_error_deg"] = yaw_error
    result.check(
        f"physics playback: final heading within {HEADING_TOLERANCE:.0f} deg of the plan",
        yaw_error <= HEADING_TOLERANCE,
        f"{yaw_error:.2f} deg",
    )
    return result


def main(argv: list[str] | None = None) -> int:
    p = walk_parser(__doc__)
    p.add_argument("--x", type=finite, default=0.5, help="goal ahead [m]")
    p.add_argument("--y", type=finite, default=0.2, help="goal to the left [m]")
    p.add_argument("--theta", type=finite, default=30.0, help="goal heading change [deg]")
    args = p.parse_args(argv)
    return walk_command(NAME, run, args, x=args.x, y=args.y, theta_deg=args.theta)


if __name__ == "__main__":
    raise SystemExit(main())
