"""Fullbody IK with forces on both hands: the static balance point between the feet
(seed 001, ``:centroid-offset-func`` with ``:calc-static-balance-point``).

Both hands receive the seed's force (-20, 0, 0) N and moment (10, 0, 0) N·m; the
feet stay, the hands go to the seed's ``#f(400 ∓300 0)`` mm from the waist
(position only), and the *static balance point* — where the ground reaction
balances gravity and the hand wrenches — is brought over the midpoint of the
feet instead of the centroid. The check is independent of the formula used in
the solve: the total moment of gravity and the hand wrenches about the feet
midpoint has no horizontal component (a pure vertical ground force there
balances). The iterates are played in physics as a motion and the final pose
is held, both with the same hand wrenches applied.
"""

from __future__ import annotations

import sys

import numpy as np

from pik_mj import (
    CollisionAvoidanceTask,
    HoldCriteria,
    Progress,
    Recorder,
    Robot,
    Scene,
    Waypoints,
    fullbody_inverse_kinematics,
)
from pik_mj.ik import static_balance_point
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    ScenarioResult,
    com_margin,
    open_recorder,
    parser,
    report,
)
from pik_mj.solve import TrustRegion
from pik_mj.tasks.collision import collision_pairs

NAME = "fullbody_external_force"
FORCE = np.array([-20.0, 0.0, 0.0])  # [N] on each hand
MOMENT = np.array([10.0, 0.0, 0.0])  # [N·m] on each hand
HANDS = ("rarm", "larm")
FEET = ("rleg", "lleg")


def frame_of(robot: Robot, limb: str):
    return robot.frame_pose(robot.limb(limb).end_frame, robot.limb(limb).end_frame_type)


def run(
    recorder: Recorder,
    *,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    feet0 = [frame_of(robot, x) for x in FEET]
    p_mid = 0.5 * (feet0[0].translation() + feet0[1].translation())
    p_root, _ = robot.root_pose()
    targets = [p_root + np.array([0.4, -0.3, 0.0]), p_root + np.array([0.4, 0.3, 0.0])]
    forces = [(robot.limb(h).end_frame, FORCE, MOMENT) for h in HANDS]

    # The arms keep off the body (seed: collision-avoidance links of the arms):
    # the plain solution's first step swings the right forearm into the pelvis.
    arms = [f"{arm}_{link}" for arm in HANDS for link in ("upper", "lower", "hand")]
    pairs = collision_pairs(
        robot.model, robot.data, [*arms, "pelvis", "torso_chest", "rleg_thigh", "lleg_thigh"]
    )
    avoid = CollisionAvoidanceTask(robot.configuration, pairs, yellow=0.1, orange=0.01)
    checks = scene.static_checker()
    log = recorder.solve_logger("reach with forces", checks=checks, start=robot)
    progress = Progress("reach with forces", total=100, stream=None if quiet else sys.stderr)
    path = Waypoints(robot)
    res = fullbody_inverse_kinematics(
        robot,
        [(p, np.array([1.0, 0.0, 0.0, 0.0])) for p in targets],
        limbs=list(HANDS),
        rotation_axis=None,
        external_forces=forces,
        collision_avoidance=avoid,
        target_centroid_pos=p_mid,
        centroid_axes="z",
        stop=100,
        # short steps: the first long step lifts a foot off the floor (level 1 is
        # not yet satisfied, so the trust region does not keep the feet), which
        # the motion in physics shows as slip and a lean
        trust_region=TrustRegion(radius=0.05, max_radius=0.1),
        callback=[checks, log, progress, path.segment("reach with forces")],
    )
    result.add_solve("reach with forces", res, checks, finish=[log, progress, path])

    # The iterates as a motion in physics: the hands take up their wrenches as they reach.
    if speed:
        log = recorder.motion_logger()
        # at half the speed: under the 40 N of pulls the servos let the root lag
        # 24.6 mm behind its reference at 0.2 of the joint limits, 10.7 mm at 0.1
        motion = scene.play(
            path, speed=speed / 2, external=forces, external_ramp=True, callback=log
        )
        result.add_motion("reach with forces", motion, finish=[log])

    # The final pose in physics, with the hand wrenches it was solved for.
    q = robot.configuration.q.copy()
    static = scene.static_check(q, external=forces)
    criteria = HoldCriteria(allowed=[*scene.allowed_contacts, *static.touching_geoms])
    log = recorder.hold_logger()
    held = scene.hold(q, hold, criteria=criteria, external=forces, callback=log) if hold else None
    result.add_balance(scene, static, held, criteria, external=forces)

    # Independent check: moments about the feet midpoint (3D cross products), where
    # a pure vertical ground force must balance gravity and the hand wrenches.
    p = static_balance_point(robot, forces, height=p_mid[2])
    g = robot.mass * robot.model.opt.gravity
    moment = np.cross(robot.com() - p_mid, g)
    for h in HANDS:
        moment += np.cross(frame_of(robot, h).translation() - p_mid, FORCE) + MOMENT
    feet1 = [frame_of(robot, x) for x in FEET]
    com = robot.com()
    hand_errors = [
        float(np.linalg.norm(frame_of(robot, h).translation() - t))
        for h, t in zip(HANDS, targets, strict=True)
    ]
    result.main = "reach with forces"
    result.figures = {
        "balance_point_m": p,
        "balance_point_xy_error_m": float(np.linalg.norm(p[:2] - p_mid[:2])),
        "horizontal_moment_about_feet_midpoint_Nm": moment[:2],
        "com_m": com,
        "com_shift_from_feet_midpoint_m": com[:2] - p_mid[:2],
        "balance_point_margin_m": com_margin(robot, p),
        "hand_errors_m": hand_errors,
        "feet_moved_m": max(
            float(np.linalg.norm(a.translation() - b.translation()))
            for a, b in zip(feet0, feet1, strict=True)
        ),
        "median_iteration_ms": res.median_iteration_ms,
    }
    f = result.figures
    weight = robot.mass * float(np.linalg.norm(robot.model.opt.gravity))  # [N]
    result.check("converged", res.converged, f"{res.iterations} iterations")
    result.check("hands on target (1 mm)", max(hand_errors) <= 1e-3)
    result.check("feet did not move (0.1 mm)", f["feet_moved_m"] <= 1e-4)
    result.check(
        "balance point over the feet midpoint (1 mm)", f["balance_point_xy_error_m"] <= 1e-3
    )
    result.check(
        "no horizontal moment about the feet midpoint (M g · 1 mm)",
        float(np.abs(moment[:2]).max()) <= weight * 1e-3,
        f"{moment[:2]}",
    )
    result.check("balance point inside the support polygon", f["balance_point_margin_m"] > 0)
    result.check(
        "CoM leans into the pull (x forward of the feet midpoint by > 2 cm)",
        f["com_shift_from_feet_midpoint_m"][0] > 0.02,
    )
    return result


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, speed=args.speed, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
