"""Walk forward: 6 steps by preview control + whole-body IK, played in physics, on any humanoid.

The irteus manual's ``:calc-walk-pattern-from-footstep-list``, its first walking
example: footsteps straight ahead (left first) with a gait derived from the
robot (stride, step height and time, CoM height from its legs, soles and mass;
printed; ``--gait NAME=VALUE`` gives a value instead), preview control of the
cart-table model for the CoM, one whole-body IK per tick (soles and CoM, then
the rest), then two checks of the pattern: the ZMP of its inverse dynamics stays
inside the support polygon of the soles at every tick, and played with the
robot's joint servos (its own where they can carry it, within its torque limits)
on a floor in MuJoCo it walks without falling and ends where planned. Any robot
with two legs: ``--model unitree_g1``, an MJCF path, or ``--description FILE``.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from pik_mj import Recorder, Robot
from pik_mj.robot.ground import robot_soles
from pik_mj.scenario import (
    ScenarioResult,
    count,
    open_recorder,
    parser,
    positive,
    report,
    run_options,
)
from pik_mj.scenario.arguments import argument_type
from pik_mj.scenario.robot_option import model_label
from pik_mj.walking.gait import Footstep
from pik_mj.walking.playback import walk_motion
from pik_mj.walking.robot_gait import DEFAULT_DT, RobotGait, gait_value, robot_gait
from pik_mj.walking.walk import Walk, walk
from pik_mj.walking.wholebody import feet_from_robot

__all__ = ["LEGS", "NAME", "main", "run", "walk_command", "walk_parser", "walk_scenario"]

NAME = "walk_forward"
LEGS = ("rleg", "lleg")


def walk_scenario(
    name: str,
    recorder: Recorder,
    footsteps: Callable[[RobotGait, Mapping[str, Footstep]], Sequence[Footstep]],
    *,
    model: str | None,
    description: str | None = None,
    robot: Robot | None = None,
    dt: float = DEFAULT_DT,
    gait: dict[str, float] | None = None,
    quiet: bool = True,
) -> tuple[ScenarioResult, Walk]:
    """A walking scenario: the robot of ``model`` and ``description`` (``robot``: it
    already built, else None), the gait derived from it (``gait``: values given
    instead; printed unless ``quiet``), ``footsteps(gait, feet)`` from its feet,
    walked (:func:`pik_mj.walking.walk.walk`) into ``recorder``'s walk logger; the
    result with the walk's figures and checks."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=LEGS)
    label = model_label(model, description)
    soles = robot_soles(robot)
    chosen = robot_gait(robot, soles, dt=dt, **(gait or {}))
    if not quiet:
        print(f"{name} on {label}: {chosen}")
    steps = footsteps(chosen, feet_from_robot(robot, soles))
    log = recorder.walk_logger()
    done = walk(robot, steps, chosen, soles=soles, callback=log)
    log.finish(done.report)
    result = ScenarioResult(name)
    result.robot = robot
    result.figures = done.figures
    result.walk = walk_motion(done.pattern, done.report)
    for check, ok, detail in done.checks:
        result.check(check, ok, detail)
    return result, done


def walk_parser(doc: str) -> argparse.ArgumentParser:
    """The command line of a walking scenario: the scenario's options for a robot
    with two legs, ``--dt`` and ``--gait NAME=VALUE`` (repeatable)."""
    p = parser(
        doc,
        hold=False,
        model="sample_humanoid",
        limbs=LEGS,
        floating_base=True,
        description=True,
    )
    p.add_argument("--dt", type=positive, default=DEFAULT_DT, help="pattern tick [s]")
    p.add_argument(
        "--gait",
        type=argument_type(gait_value),
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a gait value instead of the derived one, e.g. stride=0.1 (repeatable)",
    )
    return p


def run(
    recorder: Recorder,
    *,
    model: str | None = "sample_humanoid",
    description: str | None = None,
    robot: Robot | None = None,
    quiet: bool = True,
    n_steps: int = 6,
    dt: float = DEFAULT_DT,  # [s]
    gait: dict[str, float] | None = None,
) -> ScenarioResult:
    """Walk ``n_steps`` forward; ``gait``: values given instead of derived."""
    result, _ = walk_scenario(
        NAME,
        recorder,
        lambda chosen, feet: chosen.straight_steps(n_steps, feet),
        model=model,
        description=description,
        robot=robot,
        dt=dt,
        gait=gait,
        quiet=quiet,
    )
    return result


def walk_command(
    name: str, run_walk: Callable[..., ScenarioResult], args: argparse.Namespace, **options: Any
) -> int:
    """Run a walking scenario's ``run_walk`` from its parsed command line
    (:func:`walk_parser`), with ``options`` (its own), into the recorder the command
    asks for; the exit status of its report."""
    label = model_label(args.model, args.description)
    with open_recorder(args, f"{name}_{label}") as recorder:
        result = run_walk(
            recorder, **run_options(args), dt=args.dt, gait=dict(args.gait), **options
        )
    return report(result, args)


def main(argv: list[str] | None = None) -> int:
    p = walk_parser(__doc__)
    p.add_argument("--steps", type=count, default=6, help="number of steps (default 6)")
    args = p.parse_args(argv)
    return walk_command(NAME, run, args, n_steps=args.steps)


if __name__ == "__main__":
    raise SystemExit(main())
