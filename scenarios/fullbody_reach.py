"""Fullbody IK with the centroid over the feet (irteus manual ``:fullbody-inverse-kinematics``).

Both feet stay where they are, the centroid's x-y goes to the midpoint of the feet
(z free, irteus ``:cog-translation-axis :z``), and the left hand reaches the irteus
example's ``#f(400 100 -600)`` mm from the waist, position only (``:rotation-axis
nil``); the floating base moves within the example's root-link bounds. The example
first bends the waist by 10° (done where the robot has ``torso_waist_p``).
dm_control's humanoid has its root at the chest, not the waist, and cannot crouch
as deep within the root bounds: its hand target is (0.3, 0.1, -0.5) m from its root.
Any other robot (``--model unitree_g1``, an MJCF path; ``--description FILE``
when its limbs are not found from its tree) reaches with its left hand
(0.6, 0.2, 0.4) L from where the hand is at the start, L the arm's length
(shoulder to hand). Every iteration is checked statically in the robot's scene;
the iterates are played in physics as a motion, and the final pose is held in
physics.
"""

from __future__ import annotations

from typing import Any

import mink
import numpy as np

from pik_mj import (
    Recorder,
    Robot,
    Scene,
    SolveResult,
    Waypoints,
    fullbody_inverse_kinematics,
)
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    RobotOption,
    ScenarioResult,
    Stage,
    com_margin,
    end_pose,
    largest_move,
    largest_turn,
    open_recorder,
    parser,
    report,
    run_options,
)

NAME = "fullbody_reach"
HAND_OFFSETS = {  # [m] left-hand target from the root body, per model
    "sample_humanoid": (0.4, 0.1, -0.6),  # irteus's #f(400 100 -600) mm
    "dm_humanoid_cmu": (0.4, 0.1, -0.6),
    "dm_humanoid": (0.3, 0.1, -0.5),
}
OTHER_MODELS = (0.6, 0.2, 0.4)  # [arm lengths] from the hand's start, other robots
FEET = ("rleg", "lleg")
HAND = "larm"
ROBOT = RobotOption("sample_humanoid", (*FEET, HAND), floating_base=True)


def run(
    recorder: Recorder,
    *,
    model: str | None = "sample_humanoid",
    description: str | None = None,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
    robot: Robot | None = None,
) -> ScenarioResult:
    """Solve, validate and record the reach. ``robot``: the robot already built
    from ``model`` and ``description`` (the one
    :class:`pik_mj.scenario.ScenarioParser` built to check them), else None to
    build it here."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=[*FEET, HAND])
    # irteus: (send *robot* :torso :waist-p :joint-angle 10)
    if "torso_waist_p" in robot.joint_names:
        robot.set_angle_vector([np.deg2rad(10.0)], ["torso_waist_p"])
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    feet0 = [end_pose(robot, x) for x in FEET]
    p_mid = 0.5 * (feet0[0].translation() + feet0[1].translation())
    p_root, _ = robot.root_pose()
    target = hand_target(robot, model)
    path = Waypoints(robot)
    res = stage.solve(
        fullbody_inverse_kinematics,
        "reach",
        [(target, np.array([1.0, 0.0, 0.0, 0.0]))],
        path=path,
        total=100,
        limbs=[HAND],
        rotation_axis=[None],
        target_centroid_pos=p_mid,
        centroid_axes="z",
        stop=100,
    )
    if speed:
        stage.play("reach", path, speed=speed)
    # The final pose in physics; the contacts the solve made are intended.
    stage.hold_final_pose(hold)
    result = stage.result
    result.main = "reach"
    result.figures = figures(robot, target, feet0, p_root, res)
    check(result)
    return result


def hand_target(robot: Robot, model: str | None) -> np.ndarray:
    """The left hand's target [m]: :data:`HAND_OFFSETS` from the root for the models
    it names, else :data:`OTHER_MODELS` arm lengths from the hand's start."""
    if str(model) in HAND_OFFSETS:
        return robot.root_pose()[0] + np.array(HAND_OFFSETS[str(model)])
    p_hand = end_pose(robot, HAND).translation()
    shoulder = robot.frame_pose(robot.limb(HAND).root_body, "body").translation()
    return p_hand + np.linalg.norm(p_hand - shoulder) * np.array(OTHER_MODELS)


def figures(
    robot: Robot,
    target: np.ndarray,
    feet0: list[mink.SE3],
    p_root: np.ndarray,
    res: SolveResult,
) -> dict[str, Any]:
    """The measures of the final pose: the hand, the feet, the CoM, the root; the
    solve's median iteration time."""
    p_mid = 0.5 * (feet0[0].translation() + feet0[1].translation())
    feet1 = [end_pose(robot, x) for x in FEET]
    com = robot.com()
    return {
        "model": str(robot.source.model),
        "hand_target_m": target,
        "hand_error_m": float(np.linalg.norm(end_pose(robot, HAND).translation() - target)),
        "feet_moved_m": largest_move(feet0, feet1),
        "feet_turned_rad": largest_turn(feet0, feet1),
        "com_m": com,
        "com_xy_error_m": float(np.linalg.norm(com[:2] - p_mid[:2])),
        "com_margin_m": com_margin(robot),
        "root_displacement_m": robot.root_pose()[0] - p_root,
        "median_iteration_ms": res.median_iteration_ms,
    }


def check(result: ScenarioResult) -> None:
    """The scenario's checks on its solve and figures."""
    f = result.figures
    res = result.solves["reach"]
    result.check("converged", res.converged, f"{res.iterations} iterations")
    result.check("hand on target (1 mm)", f["hand_error_m"] <= 1e-3, f"{f['hand_error_m']:.2e} m")
    result.check(
        "feet did not move (0.1 mm, 1 mrad)",
        f["feet_moved_m"] <= 1e-4 and f["feet_turned_rad"] <= 1e-3,
    )
    result.check("CoM xy over the feet midpoint (1 mm)", f["com_xy_error_m"] <= 1e-3)
    result.check(
        "CoM inside the support polygon", f["com_margin_m"] > 0, f"margin {f['com_margin_m']:.3f} m"
    )


def main(argv: list[str] | None = None) -> int:
    p = parser(__doc__, robot=ROBOT, description=True)
    args = p.parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, **run_options(args))
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
