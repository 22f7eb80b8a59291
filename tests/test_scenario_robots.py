"""Every scenario but the walking ones on each humanoid: the project's sample humanoid and
Menagerie's Unitree G1, H1 and Booster T1 as shipped (skipped, saying why, where
``MENAGERIE_ROOT`` does not hold them).

A pair either runs (the scenario's solves, its static checks, its motion played in
physics at the command line's default speed on the Menagerie robots, and a 0.5 s
physics hold of its final pose: every check it makes passes; the sample humanoid's
motions are played in ``tests/test_motion_scenarios.py``, the 3 s holds in
``benchmarks/bench_robots.py --scenarios``) or is refused before any work by the
scenario's ``--model`` option (:class:`pik_mj.scenario.RobotOption`) in one line
naming what the robot lacks. A pair known to fail is an ``xfail`` with the reason
(strict: it fails the suite once it passes, so that the table is mended). The
motions and holds of Booster T1, whose ankle servos (2 × kp 75 N·m/rad) are softer
than its weight's tipping stiffness, run with the balance feedback
(:mod:`pik_mj.sim.balancing`) wherever ``k_ankle < m g h`` (its lean on the wall
lowers its CoM below that: the hold there runs without); the other robots' without."""

from __future__ import annotations

import pytest
from local_menagerie import requires_menagerie
from pik_mj.scenarios import SCENARIOS

from pik_mj import Recorder, cli
from pik_mj.cli import load_scenario
from pik_mj.robot.loading import menagerie_models
from pik_mj.scenario import DEFAULT_SPEED, RobotRefused

ROBOTS = ("sample_humanoid", "unitree_g1", "unitree_h1", "booster_t1")
MOVED = ("unitree_g1", "unitree_h1", "booster_t1")
"""The robots whose motions the matrix plays (at ``DEFAULT_SPEED``)."""
BALANCED = ("booster_t1",)
"""The robots that need the balance feedback: ankle servos softer than ``m g h``."""
MATRIX = [s for s in SCENARIOS if not s.startswith("walk_")]

FLOATING = r"has a floating base \(a free joint at its root '\w+'\); this scenario moves an arm"
REFUSED = {("three_dof_reach", r): FLOATING for r in ROBOTS}
"""The pairs refused, and the reason their refusal gives."""

FAILING: dict[tuple[str, str], str] = {}
"""The pairs that run and fail their checks, with why."""

MOTION_FAILING: dict[tuple[str, str], str] = {}
"""The pairs whose motion fails (``bench_robots.py --scenarios`` plays it), with why:
the matrix runs them without it."""

SLOW_FAILING: dict[tuple[str, str], str] = {}
"""Failing pairs too slow to run in the suite (``bench_robots.py --scenarios`` runs them)."""


def pairs() -> list:
    out = []
    for scenario in MATRIX:
        for robot in ROBOTS:
            reason = FAILING.get((scenario, robot))
            marks = [pytest.mark.xfail(reason=reason, strict=True)] if reason else []
            if (scenario, robot) in SLOW_FAILING:
                marks = [pytest.mark.xfail(reason=SLOW_FAILING[scenario, robot], run=False)]
            out.append(pytest.param(scenario, robot, marks=marks, id=f"{scenario}-{robot}"))
    return out


@pytest.mark.long
@pytest.mark.parametrize(("scenario", "robot"), pairs())
def test_scenario_on_robot(scenario, robot, tmp_path):
    if robot in menagerie_models():
        requires_menagerie(robot)
    module = load_scenario(scenario)
    refusal = REFUSED.get((scenario, robot))
    if refusal is not None:
        with pytest.raises(RobotRefused, match=refusal) as refused:
            module.ROBOT.check(robot, None)
        line = str(refused.value)
        assert line.startswith(f"argument --model: model {robot!r}") and "\n" not in line
        return
    model, built = module.ROBOT.check(robot, None)
    moved = robot in MOVED and (scenario, robot) not in MOTION_FAILING
    speed = DEFAULT_SPEED if moved else 0.0
    options = {"hold": 0.5, "speed": speed} if scenario != "three_dof_reach" else {}
    with Recorder.to_file(tmp_path / f"{scenario}-{robot}.rrd", scenario) as recorder:
        result = module.run(recorder, model=model, robot=built, quiet=True, **options)
    failed = [m for m in result.messages if m.startswith("[FAILED]")]
    assert result.passed, "\n".join(failed)
    if options:
        assert bool(result.motions) == moved
        feedback = [m.balance_feedback for m in result.motions.values()]
        feedback.append(result.balance["hold"]["balance_feedback"])
        # on exactly where the ankle servos are softer than m g h (a lean on the wall
        # can lower the CoM below it), and on for a balanced robot's first part
        assert all(
            f is not None and f["on"] == (f["ankle_stiffness"] < f["tipping_stiffness"])
            for f in feedback
        )
        assert feedback[0]["on"] == (robot in BALANCED)
    assert result.robot_state is None or result.robot_state["model"] == robot
    assert result.solves and all(r.iterations > 0 for r in result.solves.values())


def test_refusal_through_the_command_line_is_one_line_before_any_work(capsys, tmp_path):
    """``pik-mj run three_dof_reach --model unitree_h1``: H1 stands on a floating base,
    the scenario moves an arm bolted to the world; refused with exit status 2, one line
    on stderr, nothing written."""
    requires_menagerie("unitree_h1")
    out = tmp_path / "out.json"
    assert cli.main(["run", "three_dof_reach", "--model", "unitree_h1", "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].endswith(
        "error: argument --model: model 'unitree_h1' has a floating base (a free joint at its "
        "root 'pelvis'); this scenario moves an arm with a fixed base"
    )
    assert not out.exists()


def test_a_hand_touching_at_a_point_reaches_the_wall_without_passing_into_it(tmp_path):
    """T1's 4-joint arm puts its hand on the wall at a point: the palm's solve (trust
    radius 1) brought it 82 mm into the wall and back out before its hand was kept
    off it; every iterate of the path played now has the hand's geoms at most 2 mm
    (one linearized step) inside the wall, by MuJoCo's ``mj_geomDistance``."""
    requires_menagerie("booster_t1")
    wall = load_scenario("wall_contact")
    _, robot = wall.ROBOT.check("booster_t1", None)
    robot = wall.robot_in(robot, wall.wall_scene(wall.Stature.of(robot)), wall.NAME)
    with Recorder.to_file(tmp_path / "wall.rrd", wall.NAME) as recorder:
        stage = wall.Stage(wall.NAME, robot, recorder, scene=wall.Scene.from_robot(robot))
        support = wall.WallSupport.facing(robot)
        assert not support.flat
        path = wall.Waypoints(robot, "hand to the wall")
        assert wall.palm_to_wall(stage, support, path).converged
    gaps = []
    for item in path.items:
        robot.configuration.update(item.q)
        gaps.append(wall.hand_gap(robot, support.hand))
    assert len(gaps) > 3 and min(gaps) >= -2e-3, gaps
    assert gaps[-1] <= 0.05  # it did get to the wall
