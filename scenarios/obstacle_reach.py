"""Reach past an obstacle, with and without collision avoidance (irteus manual: yellow/orange zone).

The right hand of the standing humanoid reaches a point in front of its chest;
a box (``models/obstacle.xml``) hangs across the way between the hand at its
side and the target. The
same full-body IK (feet fixed, CoM over the feet, the hand target) is solved
twice from the same start: with a :class:`pik_mj.CollisionAvoidanceTask` of the
arm's links against the box in level 1 (above the target: irteus's
``:collision-avoidance-link-pair``, yellow zone ``YELLOW``, orange ``ORANGE``),
and without it. Both solves' iterates are played in physics. Reported for both:
the smallest arm–box distance (MuJoCo's ``mj_geomDistance``, negative when
penetrating) over the IK iterates, over the reference the servos track
between them, and over the physical motion. With avoidance the iterates keep
at least the orange distance and the physics never touches the box; without
it the iterates pass through the box and the physical arm hits it.
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
from pik_mj.robot.loading import MODELS_DIR
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    ScenarioResult,
    Stage,
    open_recorder,
    parser,
    report,
)
from pik_mj.sim.motion import Clearance, min_distance
from pik_mj.solve import TrustRegion
from pik_mj.tasks.collision import collision_pairs

NAME = "obstacle_reach"
TARGET = np.array([0.38, -0.25, 0.95])  # [m] right-hand target, world (robot at the origin)
ARM = ("rarm_upper", "rarm_lower", "rarm_hand")
YELLOW = 0.1  # [m] pairs nearer than this are constrained
ORANGE = 0.02  # [m] the distance kept
GAIN = 0.2  # velocity-damper gain: a slow approach keeps the linearized rows from overshooting
STEPS = TrustRegion(radius=0.02, max_radius=0.04)  # short steps: a dense path to play


def run(
    recorder: Recorder,
    *,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
) -> ScenarioResult:
    robot = Robot.from_model("sample_humanoid", environment=MODELS_DIR / "obstacle.xml")
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    q0 = robot.configuration.q.copy()
    pairs = collision_pairs(robot.model, robot.data, list(ARM), ["obstacle"])
    avoid = CollisionAvoidanceTask(
        robot.configuration, pairs, yellow=YELLOW, orange=ORANGE, gain=GAIN
    )
    figures: dict[str, Any] = {}
    for label, tasks in (("without avoidance", []), ("with avoidance", [avoid])):
        robot.configuration.update(q0)
        figures |= reach(stage, label, tasks, speed)
    # The final pose with avoidance (the robot's now) held in physics.
    stage.hold_final_pose(hold)
    result = stage.result
    result.main = "with avoidance"
    result.figures = figures
    check(result)
    return result


def reach(
    stage: Stage, label: str, avoid: list[CollisionAvoidanceTask], speed: float
) -> dict[str, Any]:
    """The full-body reach from the start pose, with ``avoid`` tasks in level 1, its
    iterates played in physics (kept in the result with avoidance). Returns its
    figures: the arm's smallest distance to the box over the iterates, the reference
    and the physics, the hand's error, the motion."""
    robot, model = stage.robot, stage.scene.model
    box = model.geom("obstacle").id
    arm = [g for g in range(model.ngeom) if model.body(model.geom_bodyid[g]).name in ARM]
    path = Waypoints(robot, label)
    stage.solve(
        fullbody_inverse_kinematics,
        label,
        [(TARGET, np.array([1.0, 0.0, 0.0, 0.0]))],
        path=path,
        total=100,
        limbs=["rarm"],
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
        f"hand_error_{key}_m": float(
            np.linalg.norm(robot.frame_pose("rarm_end").translation() - TARGET)
        ),
    }
    if speed:
        clearance = Clearance(model, arm, [box])
        # the robot's view, where MuJoCo renders
        log = stage.recorder.motion_logger(cameras=[Camera(model, "head_camera")])
        motion = stage.scene.play(path, speed=speed, callback=[log, clearance])
        log.finish(motion)
        figures[f"min_distance_reference_{key}_m"] = clearance.reference
        figures[f"min_distance_physics_{key}_m"] = clearance.physics
        figures[f"motion_{key}"] = motion.summary()
        if avoid:
            stage.result.add_motion(label, motion)
        else:
            figures["unexpected_contacts_without"] = motion.unexpected_contacts
    return figures


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
        result.check(
            "without avoidance: the physical arm hits the box (an unexpected contact)",
            any("obstacle" in c[1] for c in f["unexpected_contacts_without"]),
            f"min distance {f['min_distance_physics_without_m'] * 1e3:.1f} mm",
        )


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, speed=args.speed, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
