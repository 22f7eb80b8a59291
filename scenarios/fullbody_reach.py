"""Fullbody IK with the centroid over the feet (seed 001 ``fullbody-inverse-kinematics``).

Both feet stay where they are, the centroid's x-y goes to the midpoint of the feet
(z free, irteus ``:cog-translation-axis :z``), and the left hand reaches the seed's
``#f(400 100 -600)`` mm from the waist, position only (``:rotation-axis nil``);
the floating base moves within the seed's root-link bounds. The seed first bends
the waist by 10° (done where the robot has ``torso_waist_p``). dm_control's
humanoid has its root at the chest, not the waist, and cannot crouch as deep
within the root bounds: its hand target is (0.3, 0.1, -0.5) m from its root.
Any other robot (``--model unitree_g1``, an MJCF path; ``--description FILE``
when its limbs are not found from its tree) reaches with its left hand
(0.6, 0.2, 0.4) L from where the hand is at the start, L the arm's length
(shoulder to hand). Every iteration is checked statically in the robot's scene;
the iterates are played in physics as a motion, and the final pose is held in
physics.
"""

from __future__ import annotations

import sys

import numpy as np

from pik_mj import (
    HoldCriteria,
    Progress,
    Recorder,
    Robot,
    Scene,
    Waypoints,
    fullbody_inverse_kinematics,
)
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    ScenarioResult,
    com_margin,
    open_recorder,
    parser,
    report,
)

NAME = "fullbody_reach"
HAND_OFFSETS = {  # [m] left-hand target from the root body, per model
    "sample_humanoid": (0.4, 0.1, -0.6),  # the seed's #f(400 100 -600) mm
    "dm_humanoid_cmu": (0.4, 0.1, -0.6),
    "dm_humanoid": (0.3, 0.1, -0.5),
}
OTHER_MODELS = (0.6, 0.2, 0.4)  # [arm lengths] from the hand's start, other robots
FEET = ("rleg", "lleg")
HAND = "larm"


def foot_poses(robot: Robot) -> list:
    return [robot.frame_pose(robot.limb(x).end_frame, robot.limb(x).end_frame_type) for x in FEET]


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
    result = ScenarioResult(NAME)
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=[*FEET, HAND])
    if "torso_waist_p" in robot.joint_names:  # seed: (send *robot* :torso :waist-p :joint-angle 10)
        robot.set_angle_vector([np.deg2rad(10.0)], ["torso_waist_p"])
    scene = Scene.from_robot(robot)
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    feet0 = foot_poses(robot)
    p_mid = 0.5 * (feet0[0].translation() + feet0[1].translation())
    p_root, _ = robot.root_pose()
    arm = robot.limb(HAND)
    if str(model) in HAND_OFFSETS:
        target = p_root + np.array(HAND_OFFSETS[str(model)])
    else:
        p_hand = robot.frame_pose(arm.end_frame, arm.end_frame_type).translation()
        length = np.linalg.norm(p_hand - robot.frame_pose(arm.root_body, "body").translation())
        target = p_hand + length * np.array(OTHER_MODELS)

    checks = scene.static_checker()
    log = recorder.solve_logger("reach", checks=checks, start=robot)
    progress = Progress("reach", total=100, stream=None if quiet else sys.stderr)
    path = Waypoints(robot)
    res = fullbody_inverse_kinematics(
        robot,
        [(target, np.array([1.0, 0.0, 0.0, 0.0]))],
        limbs=[HAND],
        rotation_axis=[None],
        target_centroid_pos=p_mid,
        centroid_axes="z",
        stop=100,
        callback=[checks, log, progress, path.segment("reach")],
    )
    result.add_solve("reach", res, checks, finish=[log, progress, path])

    # The iterates as a motion in physics.
    if speed:
        log = recorder.motion_logger()
        result.add_motion("reach", scene.play(path, speed=speed, callback=log), finish=[log])

    # The final pose in physics; the contacts the solve made are intended.
    q = robot.configuration.q.copy()
    static = scene.static_check(q)
    criteria = HoldCriteria(allowed=[*scene.allowed_contacts, *static.touching_geoms])
    held = scene.hold(q, hold, criteria=criteria, callback=recorder.hold_logger()) if hold else None
    result.add_balance(scene, static, held, criteria)

    feet1 = foot_poses(robot)
    hand = robot.frame_pose(arm.end_frame, arm.end_frame_type)
    com = robot.com()
    result.main = "reach"
    result.figures = {
        "model": str(robot.source.model),
        "hand_target_m": target,
        "hand_error_m": float(np.linalg.norm(hand.translation() - target)),
        "feet_moved_m": max(
            float(np.linalg.norm(a.translation() - b.translation()))
            for a, b in zip(feet0, feet1, strict=True)
        ),
        "feet_turned_rad": max(
            float(np.linalg.norm((a.rotation().inverse() @ b.rotation()).log()))
            for a, b in zip(feet0, feet1, strict=True)
        ),
        "com_m": com,
        "com_xy_error_m": float(np.linalg.norm(com[:2] - p_mid[:2])),
        "com_margin_m": com_margin(robot),
        "root_displacement_m": robot.root_pose()[0] - p_root,
        "median_iteration_ms": res.median_iteration_ms,
    }
    f = result.figures
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
    return result


def main(argv: list[str] | None = None) -> int:
    p = parser(
        __doc__,
        model="sample_humanoid",
        limbs=(*FEET, HAND),
        floating_base=True,
        description=True,
    )
    args = p.parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(
            recorder,
            model=args.model,
            description=args.description,
            robot=args.robot,
            hold=args.hold,
            speed=args.speed,
            quiet=args.quiet,
        )
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
