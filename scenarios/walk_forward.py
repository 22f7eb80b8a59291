"""Walk forward: 4 steps of 0.12 m by preview control + whole-body IK, played in physics.

The irteus manual's ``:calc-walk-pattern-from-footstep-list``, its first walking
example on the sample humanoid: footsteps straight ahead (left first), preview control of
the cart-table model for the CoM, one whole-body IK per tick (feet, CoM and
upright pelvis, posture), then two checks of the pattern: the ZMP of its
inverse dynamics stays inside the support polygon at every tick, and played
with joint servos on a floor in MuJoCo it walks without falling and ends where
planned.
"""

from __future__ import annotations

from pik_mj import Recorder, Robot, Scene
from pik_mj.scenario import ScenarioResult, count, open_recorder, parser, positive, report
from pik_mj.walking import GaitParameters, straight_steps
from pik_mj.walking.playback import WALK_CONTACT, evaluate_walk, play_walk_pattern, walk_motion
from pik_mj.walking.wholebody import calc_walk_pattern, feet_from_robot

NAME = "walk_forward"


def run(
    recorder: Recorder,
    *,
    quiet: bool = True,
    n_steps: int = 4,
    stride: float = 0.12,  # [m]
    dt: float = 0.01,  # [s]
) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("sample_humanoid")
    params = GaitParameters(dt=dt, step_time=1.0, step_height=0.05, double_support_ratio=0.2)
    steps = straight_steps(n_steps, stride, feet_from_robot(robot), first_limb="lleg")
    pattern = calc_walk_pattern(robot, steps, params)
    if not quiet:
        print(pattern)
    scene = Scene.from_robot(robot, contact=WALK_CONTACT)
    log = recorder.walk_logger()
    walk = log.finish(play_walk_pattern(pattern, scene, callback=log))
    result.robot = robot
    result.figures, checks = evaluate_walk(pattern, walk)
    result.walk = walk_motion(pattern, walk)
    for label, ok, detail in checks:
        result.check(label, ok, detail)
    return result


def main(argv: list[str] | None = None) -> int:
    p = parser(__doc__, hold=False)
    p.add_argument("--steps", type=count, default=4, help="number of steps")
    p.add_argument("--dt", type=positive, default=0.01, help="pattern tick [s]")
    args = p.parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, quiet=args.quiet, n_steps=args.steps, dt=args.dt)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
