"""3-DoF arm: reach sweep; the seed's failing case reverts; an unreachable one stretches.

Seed 001 ``3dof-robot``: the tip pointing down (rpy (0 pi 0)) is sent along
``x = 100 + 80 sin(i / 100)`` mm, z = 0; with the joints' ±100° limits a pose
with the tip down at height 0 needs the elbow bend ``j2 = 2 acos(x / 0.2)``, so
targets with ``x < 0.2 cos 50° = 0.1286 m`` fail (the seed's failure printout is
at x = 39.98 mm) and, with ``revert_if_fail``, leave the angles as they were.
Then the seed's ``(300 0 0)`` with ``:rotation-axis nil :revert-if-fail nil``:
out of reach, the arm ends stretched towards it. A fixed-base arm: nothing to
balance, no physics hold.
"""

from __future__ import annotations

import sys

import numpy as np

from pik_mj import Progress, Recorder, Robot, inverse_kinematics
from pik_mj.scenario import ScenarioResult, open_recorder, parser, report

NAME = "three_dof_reach"
LINK = 0.1  # [m] l2 and l3
TIP_DOWN = np.array([0.0, 0.0, 1.0, 0.0])  # (w, x, y, z): rotation by pi about y


def run(recorder: Recorder, *, quiet: bool = True, samples: int = 16) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("three_dof_arm")
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    err = None if quiet else sys.stderr
    robot.set_angle_vector(np.deg2rad([30.0, 30.0, 30.0]))
    x_min = 2 * LINK * np.cos(np.deg2rad(50.0))  # elbow at its 100° limit

    def solve(label: str, target, **options):
        """``inverse_kinematics`` with the logger and the progress."""
        log, progress = (
            recorder.solve_logger(label, start=robot),
            Progress(label, total=50, stream=err),
        )
        res = inverse_kinematics(robot, target, callback=[log, progress], **options)
        return result.add_solve(label, res, finish=[log, progress])

    reached, failed, reverted_exactly = [], [], True
    for i in np.linspace(0, 400, samples, endpoint=False):
        x = 0.1 + 0.08 * np.sin(i / 100.0)
        before = robot.angle_vector()
        res = solve(f"sweep x={x:.4f}", ([x, 0.0, 0.0], TIP_DOWN))
        (reached if res.converged else failed).append(float(x))
        if not res.converged:
            reverted_exactly &= bool(res.reverted) and np.array_equal(robot.angle_vector(), before)

    # The seed's printout case, alone: the angles must be unchanged.
    robot.set_angle_vector(np.deg2rad([30.0, 30.0, 30.0]))
    before = robot.angle_vector()
    fail = solve("seed failing case", ([0.039982, 0.0, 0.0], TIP_DOWN))
    failing_unchanged = np.array_equal(robot.angle_vector(), before)

    # (300 0 0), rotation free, no revert: stretched towards the target.
    far = solve(
        "out of reach", ([0.3, 0.0, 0.0], TIP_DOWN), rotation_axis=None, revert_if_fail=False
    )

    tip = robot.frame_pose("end").translation()
    # Closest reachable point: straight arm (0.22 m from joint0 at z = 0.02) towards it.
    expected_gap = np.linalg.norm(np.array([0.3, 0.0, 0.0]) - [0, 0, 0.02]) - 0.22
    gap = float(np.linalg.norm(tip - [0.3, 0.0, 0.0]))
    result.main = "seed failing case"
    result.robot = robot
    result.figures = {
        "x_min_analytic_m": x_min,
        "reached_x_m": reached,
        "failed_x_m": failed,
        "failing_case_angles_deg": np.rad2deg(before),
        "out_of_reach_gap_m": gap,
        "out_of_reach_gap_analytic_m": expected_gap,
        "out_of_reach_angles_deg": np.rad2deg(robot.angle_vector()),
    }
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
    return result


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__, hold=False).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
