"""3-DoF arm: reach sweep; the manual's failing case reverts; an unreachable one stretches.

The irteus manual's ``3dof-robot``: the tip pointing down (rpy (0 pi 0)) is sent
along ``x = 100 + 80 sin(i / 100)`` mm, z = 0; with the joints' ±100° limits a
pose with the tip down at height 0 needs the elbow bend ``j2 = 2 acos(x / 0.2)``,
so targets with ``x < 0.2 cos 50° = 0.1286 m`` fail (the manual's failure
printout is at x = 39.98 mm) and, with ``revert_if_fail``, leave the angles as
they were. Then the manual's ``(300 0 0)`` with ``:rotation-axis nil
:revert-if-fail nil``: out of reach, the arm ends stretched towards it. A
fixed-base arm: nothing to balance, no physics hold.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pik_mj import Recorder, Robot, SolveResult, inverse_kinematics
from pik_mj.scenario import (
    RobotOption,
    ScenarioResult,
    Stage,
    end_pose,
    open_recorder,
    parser,
    report,
    run_options,
)

NAME = "three_dof_reach"
LINK = 0.1  # [m] l2 and l3
TIP_DOWN = np.array([0.0, 0.0, 1.0, 0.0])  # (w, x, y, z): rotation by pi about y
START = np.deg2rad([30.0, 30.0, 30.0])  # [rad]
FAR = np.array([0.3, 0.0, 0.0])  # [m] the out-of-reach target
ROBOT = RobotOption("three_dof_arm", ("arm",), fixed_base=True)


def run(
    recorder: Recorder,
    *,
    model: str | None = "three_dof_arm",
    description: str | None = None,
    quiet: bool = True,
    samples: int = 16,
    robot: Robot | None = None,
) -> ScenarioResult:
    """The sweep, the manual's failing case and the out-of-reach target. ``robot``:
    the arm already built from ``model`` and ``description``, else None: built here."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=ROBOT.limbs)
    stage = Stage(NAME, robot, recorder, quiet=quiet)
    robot.set_angle_vector(START)
    reached, failed, reverted_exactly = sweep(stage, samples)
    # The manual's printout case, alone: the angles must be unchanged.
    robot.set_angle_vector(START)
    before = robot.angle_vector()
    fail = solve(stage, "seed failing case", [0.039982, 0.0, 0.0])
    failing_unchanged = np.array_equal(robot.angle_vector(), before)
    # (300 0 0), rotation free, no revert: stretched towards the target.
    far = solve(stage, "out of reach", FAR, rotation_axis=None, revert_if_fail=False)
    result = stage.result
    result.main = "seed failing case"
    result.robot = robot
    result.figures = figures(robot, reached, failed, before)
    check(result, fail, far, reverted_exactly, failing_unchanged)
    return result


def solve(stage: Stage, label: str, p: Any, **options: Any) -> SolveResult:
    """The tip to ``p`` [m] pointing down, with the logger and the progress."""
    return stage.solve(inverse_kinematics, label, (p, TIP_DOWN), total=50, **options)


def sweep(stage: Stage, samples: int) -> tuple[list[float], list[float], bool]:
    """The tip along ``x = 0.1 + 0.08 sin(i / 100)`` m, ``samples`` targets from where
    the last one ended. Returns the targets' x [m] reached and failed, and whether
    every failed one left the angles exactly as they were (reverted)."""
    robot = stage.robot
    reached, failed, reverted_exactly = [], [], True
    for i in np.linspace(0, 400, samples, endpoint=False):
        x = 0.1 + 0.08 * np.sin(i / 100.0)
        before = robot.angle_vector()
        res = solve(stage, f"sweep x={x:.4f}", [x, 0.0, 0.0])
        (reached if res.converged else failed).append(float(x))
        if not res.converged:
            reverted_exactly &= bool(res.reverted) and np.array_equal(robot.angle_vector(), before)
    return reached, failed, reverted_exactly


def figures(
    robot: Robot, reached: list[float], failed: list[float], before: np.ndarray
) -> dict[str, Any]:
    """The sweep's outcome against the elbow's limit, the failing case's angles
    (``before``), and how near the stretched arm came to the far target, against the
    straight arm's reach (0.22 m from joint0 at z = 0.02)."""
    gap = float(np.linalg.norm(end_pose(robot, "arm").translation() - FAR))
    return {
        "x_min_analytic_m": 2 * LINK * np.cos(np.deg2rad(50.0)),  # elbow at its 100° limit
        "reached_x_m": reached,
        "failed_x_m": failed,
        "failing_case_angles_deg": np.rad2deg(before),
        "out_of_reach_gap_m": gap,
        "out_of_reach_gap_analytic_m": np.linalg.norm(FAR - [0, 0, 0.02]) - 0.22,
        "out_of_reach_angles_deg": np.rad2deg(robot.angle_vector()),
    }


def check(
    result: ScenarioResult,
    fail: SolveResult,
    far: SolveResult,
    reverted_exactly: bool,
    failing_unchanged: bool,
) -> None:
    """The scenario's checks: reach iff the elbow's limit allows, the failed sweep
    targets reverted exactly, the failing case not converged with its angles
    unchanged, the stretch towards the far target."""
    f = result.figures
    x_min, reached, failed = f["x_min_analytic_m"], f["reached_x_m"], f["failed_x_m"]
    gap, expected_gap = f["out_of_reach_gap_m"], f["out_of_reach_gap_analytic_m"]
    result.check(
        "reach iff x >= x_min (2 mm band excluded)",
        all(x >= x_min - 2e-3 for x in reached) and all(x <= x_min + 2e-3 for x in failed),
        f"x_min = {x_min:.4f} m, {len(reached)} reached, {len(failed)} failed",
    )
    result.check("sweep has both outcomes", bool(reached) and bool(failed))
    result.check("failed sweep targets reverted exactly", reverted_exactly)
    result.check(
        "seed failing case: not converged, reverted, angles unchanged",
        not fail.converged and fail.reverted and failing_unchanged,
    )
    result.check(
        "out of reach: stretched towards the target",
        not far.converged and not far.reverted and abs(gap - expected_gap) < 2e-3,
        f"gap {gap:.4f} m vs {expected_gap:.4f} m",
    )


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__, hold=False, robot=ROBOT, description=True).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, **run_options(args))
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
