"""Reach past an obstacle, with and without collision avoidance (irteus manual: yellow/orange zone).

The right hand of the standing humanoid (its frame: :class:`pik_mj.scenario.Hand`)
reaches a point in front of its chest, ``TARGET_FROM_HAND`` arm lengths from where the
hand is at the start, in the robot's frame (x forward, y left, z up;
:class:`pik_mj.scenario.Stature`); a box
(:func:`pik_mj.scenario.scenes.obstacle_scene`, sized from the arm's length) hangs
across the way between the hand at its side and the target. The
same full-body IK (feet fixed, CoM over the feet, the hand target) is solved
twice from the same start: with a :class:`pik_mj.CollisionAvoidanceTask` of the
arm's links against the box in level 1 (above the target: irteus's
``:collision-avoidance-link-pair``, yellow zone ``YELLOW``, orange ``ORANGE``;
a second task keeps the arm off the body), and without it. Both solves' iterates
are played in physics. Reported for both:
the smallest arm–box distance (MuJoCo's ``mj_geomDistance``, negative when
penetrating) over the IK iterates, over the reference the servos track
between them, and over the physical motion. With avoidance the iterates keep
at least the orange distance and the physics never touches the box; without
it the iterates pass through the box and the physical arm hits it (or, on a
robot whose drives cannot track that reach, the report says so, naming the
joint).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pik_mj import (
    CollisionAvoidanceTask,
    Recorder,
    Robot,
    Scene,
    Waypoints,
    fullbody_inverse_kinematics,
)
from pik_mj.robot.camera import Camera
from pik_mj.robot.collisions import self_collision_pairs
from pik_mj.robot.ground import collision_geoms
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    Hand,
    RobotOption,
    ScenarioResult,
    Stage,
    Stature,
    open_recorder,
    parser,
    report,
    robot_in,
    run_options,
)
from pik_mj.scenario.scenes import obstacle_scene
from pik_mj.sim.motion import Clearance, min_distance
from pik_mj.solve import TrustRegion
from pik_mj.tasks.collision import collision_pairs

NAME = "obstacle_reach"
TARGET_FROM_HAND = (0.51, 0.066, 0.5)  # [arm lengths] the right hand's target from its start
HAND = "rarm"
ROBOT = RobotOption(
    "sample_humanoid", (HAND, "rleg", "lleg"), floating_base=True, uses="a head camera"
)
CAMERA = "head_camera"  # the robot's view in the recording, where it has this camera
YELLOW = 0.1  # [m] pairs nearer than this are constrained
ORANGE = 0.02  # [m] the distance kept
SELF_YELLOW = 0.05  # [m] the arm's pairs with the body nearer than this are constrained
SELF_ORANGE = 0.01  # [m] the distance kept between the arm and the body
GAIN = 0.2  # velocity-damper gain: a slow approach keeps the linearized rows from overshooting
STEPS = TrustRegion(radius=0.02, max_radius=0.04)  # short steps: a dense path to play


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
    """Build the box in the arm's way, reach without and with avoidance, play and
    hold. ``robot``: the robot already built from ``model`` and ``description``
    (alone), else None to build it here."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=ROBOT.limbs)
    stature = Stature.of(robot)
    hand = stature.hands[HAND]
    p_hand = hand.pose(robot).translation()
    target = p_hand + stature.arm_lengths[HAND] * stature.direction(TARGET_FROM_HAND)
    robot = robot_in(robot, obstacle_scene(stature, HAND, p_hand, target), NAME)
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    q0 = robot.configuration.q.copy()
    figures: dict[str, Any] = {}
    for label, tasks in (("without avoidance", []), ("with avoidance", avoidance(robot))):
        robot.configuration.update(q0)
        figures |= reach(stage, label, tasks, hand, target, speed)
    # The final pose with avoidance (the robot's now) held in physics.
    stage.hold_final_pose(hold)
    result = stage.result
    result.main = "with avoidance"
    result.figures = figures
    check(result)
    return result


def avoidance(robot: Robot) -> list[CollisionAvoidanceTask]:
    """The arm's avoidance: each of its links keeps ``ORANGE`` from the box (yellow
    zone ``YELLOW``), and the robot's own pairs the arm's joints move keep
    ``SELF_ORANGE`` (yellow zone ``SELF_YELLOW``; pairs that near at the start are
    left alone): the arm kept off the body, where the servos would push it out
    again."""
    model = robot.model
    dofs = [int(model.joint(j).dofadr[0]) for j in robot.limb(HAND).joints]
    box = collision_pairs(model, robot.data, robot.bodies(HAND), ["obstacle"])
    own = self_collision_pairs(robot, dofs, touching=SELF_ORANGE)
    return [
        CollisionAvoidanceTask(robot.configuration, box, yellow=YELLOW, orange=ORANGE, gain=GAIN),
        CollisionAvoidanceTask(
            robot.configuration, own, yellow=SELF_YELLOW, orange=SELF_ORANGE, gain=GAIN
        ),
    ]


def reach(
    stage: Stage,
    label: str,
    avoid: list[CollisionAvoidanceTask],
    hand: Hand,
    target: np.ndarray,
    speed: float,
) -> dict[str, Any]:
    """The full-body reach of ``hand`` (its frame, :class:`pik_mj.scenario.Hand`)
    from the start pose, with ``avoid`` tasks in level 1, its iterates played in
    physics (kept in the result with avoidance). Returns its figures: the arm's
    smallest distance to the box over the iterates, the reference and the physics,
    the hand's error, the motion."""
    robot, model = stage.robot, stage.scene.model
    box = model.geom("obstacle").id
    arm = collision_geoms(model, [model.body(b).id for b in robot.bodies(HAND)]).tolist()
    path = Waypoints(robot, label)
    stage.solve(
        fullbody_inverse_kinematics,
        label,
        [(target, np.array([1.0, 0.0, 0.0, 0.0]))],
        path=path,
        total=100,
        limbs=[HAND],
        move_targets=[hand.frame],
        rotation_axis=[None],
        collision_avoidance=avoid,
        avoid_world=False,  # the scenario's own avoidance task, or none
        trust_region=STEPS,
        stop=200,
    )
    iterates = min(min_distance(model, stage.scene.kinematics(w.q), arm, [box]) for w in path.items)
    key = "with" if avoid else "without"
    figures = {
        f"min_distance_iterates_{key}_m": iterates,
        f"hand_error_{key}_m": float(np.linalg.norm(hand.pose(robot).translation() - target)),
    }
    if speed:
        clearance = Clearance(model, arm, [box])
        # the robot's view, where MuJoCo renders
        cameras = [Camera(model, CAMERA)] if CAMERA in camera_names(model) else []
        log = stage.recorder.motion_logger(cameras=cameras)
        motion = stage.scene.play(path, speed=speed, callback=[log, clearance])
        log.finish(motion)
        figures[f"min_distance_reference_{key}_m"] = clearance.reference
        figures[f"min_distance_physics_{key}_m"] = clearance.physics
        figures[f"motion_{key}"] = motion.summary()
        if avoid:
            stage.result.add_motion(label, motion)
        else:
            figures["unexpected_contacts_without"] = motion.unexpected_contacts
            # a path the robot's drives cannot track is not played (the reason names the joint)
            figures["not_played_without"] = motion.failures[0] if motion.simulated == 0 else None
    return figures


def camera_names(model: Any) -> list[str]:
    """Names of ``model``'s cameras."""
    return [model.camera(i).name for i in range(model.ncam)]


def check(result: ScenarioResult) -> None:
    """The scenario's checks on its solves and figures."""
    f = result.figures
    result.check("with avoidance: converged", result.solves["with avoidance"].converged)
    result.check("without avoidance: converged", result.solves["without avoidance"].converged)
    result.check(
        f"with avoidance: the iterates keep the orange distance ({ORANGE * 1e3:g} mm) from the box",
        f["min_distance_iterates_with_m"] >= ORANGE - 1e-4,
        f"min {f['min_distance_iterates_with_m'] * 1e3:.1f} mm",
    )
    result.check(
        "without avoidance: the iterates pass through the box (distance < 0)",
        f["min_distance_iterates_without_m"] < 0,
        f"min {f['min_distance_iterates_without_m'] * 1e3:.1f} mm",
    )
    if "motion_with" in f:
        result.check(
            "with avoidance: the physical arm never touches the box",
            f["min_distance_physics_with_m"] > 0,
            f"min {f['min_distance_physics_with_m'] * 1e3:.1f} mm",
        )
        not_played = f["not_played_without"]
        result.check(
            "without avoidance: the physical arm hits the box (MuJoCo's distance < 0), "
            "or the robot's drives cannot play that reach",
            f["min_distance_physics_without_m"] < 0 or not_played is not None,
            not_played or f"min distance {f['min_distance_physics_without_m'] * 1e3:.1f} mm",
        )


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__, robot=ROBOT, description=True).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, **run_options(args))
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
