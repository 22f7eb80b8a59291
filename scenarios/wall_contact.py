"""A hand on the wall: multi-contact balance with the SCFR (seed 000 ``centroid-scfr-task``).

The robot stands at ``spot_wall`` facing the wall (0.45 m ahead). Its right palm
is put flat on the wall at shoulder height; the feet stay. The balance task of
level 1 is the static centroid feasible region of the three contacts (two soles
on the floor, μ = 0.8; the palm on the wall, μ = 0.5), and a lower level asks
the CoM to lean 0.1 m past the toes towards the wall — outside the feet's support
polygon, which only the wall contact makes statically possible. The pose is
checked independently by the static-equilibrium LP: contact wrenches within
their friction cones and CoP limits hold the robot. The iterates are played in
physics: the hand's bumper (a touch sensor on a site around the hand) is off
until the palm reaches the wall, and on once it is there.
"""

from __future__ import annotations

import sys

import mujoco
import numpy as np

from pik_mj import (
    CentroidTask,
    CollisionAvoidanceTask,
    HoldCriteria,
    Progress,
    Recorder,
    Robot,
    Scene,
    ScfrTask,
    Waypoints,
    fullbody_inverse_kinematics,
)
from pik_mj.balance import contact_from_normal, foot_contact, static_equilibrium
from pik_mj.robot.ground import sole_size
from pik_mj.robot.sensors import SensorTrace
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
from pik_mj.spatial import yaw_of
from pik_mj.tasks.collision import collision_pairs

NAME = "wall_contact"
PALM = (0.045, 0.06)  # [m] half sizes of the palm (hand box x, z)
PALM_OFFSET = 0.02  # [m] from the hand site to the palm face (hand box half thickness)
LEAN = 0.1  # [m] CoM target past the toes
BUMPER = "rarm_bumper"  # touch sensor site around the right hand
TOUCHING = 1e-3  # [m] hand-wall distance at which the palm is on the wall
# The step rule the palm-then-lean path was tuned with (a first radius of 0.5
# ends the palm's solve with the forearm nearer the wall than the lean's
# clearance, which then never holds: the lean reverts).
STEPS = TrustRegion(radius=1.0)


def run(
    recorder: Recorder,
    *,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_wall")
    scene = Scene.from_robot(robot)
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    wall = robot.frame_pose("wall", "geom")
    y_wall = wall.translation()[1] - robot.model.geom("wall").size[1]  # wall face [m]
    n_wall = np.array([0.0, -1.0, 0.0])  # the wall pushes the robot back
    shoulder = robot.frame_pose("rarm_upper", "body").translation()
    p_palm = np.array([shoulder[0], y_wall, shoulder[2] - 0.05])
    # Hand frame: y (palm normal) into the wall, z (towards the elbow) down.
    R_hand = np.column_stack([np.cross([0.0, 1.0, 0.0], [0.0, 0.0, -1.0]), [0, 1, 0], [0, 0, -1]])
    p_site = p_palm + PALM_OFFSET * n_wall
    feet = [robot.frame_pose(f) for f in ("rleg_end", "lleg_end")]
    yaw = yaw_of(feet[0].rotation().as_matrix())
    sole = 0.5 * np.array(sole_size(robot))  # [m] half length and width
    contacts = [foot_contact(f.translation(), yaw, *sole, mu=0.8) for f in feet]
    contacts.append(contact_from_normal(p_palm, n_wall, *PALM, mu=0.5))
    toes = max(f.translation()[1] for f in feet) + sole[0]  # the sites are the sole centres
    lean = np.array([0.5 * (feet[0].translation()[0] + feet[1].translation()[0]), toes + LEAN, 0.0])

    scfr_task = ScfrTask(robot.configuration, contacts, root_body=robot.root_body, margin=0.01)
    lean_task = CentroidTask(robot.configuration, lean, root_body=robot.root_body, check=False)
    checks = scene.static_checker()
    log = recorder.solve_logger("hand to the wall", checks=checks, start=robot)
    progress = Progress("hand to the wall", total=100, stream=None if quiet else sys.stderr)
    path = Waypoints(robot, "hand to the wall")
    # First the palm to the wall, the CoM over the feet (a lean before the hand
    # is there would fall into the wall), then the lean with the wall's support.
    reach = fullbody_inverse_kinematics(
        robot,
        [(p_site, R_hand)],
        limbs=["rarm"],
        rotation_axis=["y"],
        stop=100,
        trust_region=STEPS,
        callback=[checks, log, progress, path],
    )
    result.add_solve("hand to the wall", reach, checks, finish=[log, progress, path])
    checks = scene.static_checker()
    log = recorder.solve_logger("lean on the wall", checks=checks)
    progress = Progress("lean on the wall", total=100, stream=None if quiet else sys.stderr)
    # The arm and head keep 2 cm off the wall while the body leans (the forearm
    # dragged along the wall sticks to it and pulls the robot off its reference).
    forearm = collision_pairs(
        robot.model, robot.data, ["rarm_lower", "rarm_upper", "head_link"], ["wall"]
    )
    avoid = CollisionAvoidanceTask(robot.configuration, forearm, yellow=0.06, orange=0.02)
    res = fullbody_inverse_kinematics(
        robot,
        [(p_site, R_hand)],
        limbs=["rarm"],
        rotation_axis=["y"],
        balance=[scfr_task],
        collision_avoidance=avoid,
        extra_levels=[[lean_task]],
        stop=100,
        min_loop=15,  # the lean is not checked (it stops where the SCFR keeps it)
        trust_region=STEPS,
        callback=[checks, log, progress, path.segment("lean on the wall")],
    )
    result.add_solve("lean on the wall", res, checks, finish=[log, progress, path])

    # The iterates as a motion in physics, with the hand's bumper and its distance to the wall.
    bumpers = SensorTrace(robot.sensors())
    hand, wall_geom = scene.model.geom("rarm_hand").id, scene.model.geom("wall").id
    gap: list[float] = []

    def hand_to_wall(sample) -> None:
        gap.append(mujoco.mj_geomDistance(sample.model, sample.data, hand, wall_geom, 0.1, None))

    if speed:
        log = recorder.motion_logger()
        motion = scene.play(path, speed=speed, callback=[log, bumpers, hand_to_wall])
        result.add_motion("hand on the wall, lean", motion, finish=[log])

    # The final pose in physics; the palm on the wall is an intended contact.
    q = robot.configuration.q.copy()
    static = scene.static_check(q)
    criteria = HoldCriteria(allowed=[*scene.allowed_contacts, *static.touching_geoms])
    held = scene.hold(q, hold, criteria=criteria, callback=recorder.hold_logger()) if hold else None
    result.add_balance(scene, static, held, criteria)

    com = robot.com()
    region = scfr_task.region(robot.configuration)
    eq = static_equilibrium(contacts, robot.mass, com, gravity=robot.model.opt.gravity)
    eq_feet = static_equilibrium(contacts[:2], robot.mass, com, gravity=robot.model.opt.gravity)
    hand = robot.frame_pose("rarm_end")
    result.main = "lean on the wall"
    result.figures = {
        "palm_target_m": p_palm,
        "hand_error_m": float(np.linalg.norm(hand.translation() - p_site)),
        "palm_normal_misalignment_rad": float(
            np.arccos(np.clip(hand.rotation().as_matrix()[:, 1] @ -n_wall, -1, 1))
        ),
        "com_m": com,
        "com_scfr_margin_m": float(region.signed_distance(com[:2])),
        "com_support_polygon_margin_m": com_margin(robot),
        "com_past_toes_m": float(com[1] - toes),
        "equilibrium_with_wall": eq.feasible,
        "equilibrium_feet_only": eq_feet.feasible,
        "wall_normal_force_N": None if eq.wrenches is None else float(eq.wrenches[2, :3] @ n_wall),
        "scfr_regions_computed": scfr_task.region_computations,
        "median_iteration_ms": res.median_iteration_ms,
    }
    f = result.figures
    result.check("hand to the wall: converged", reach.converged, f"{reach.iterations} iterations")
    result.check("lean on the wall: converged", res.converged, f"{res.iterations} iterations")
    result.check(
        "palm on the wall (1 mm, 1°)",
        f["hand_error_m"] <= 1e-3 and f["palm_normal_misalignment_rad"] <= np.deg2rad(1),
    )
    result.check("CoM inside the SCFR (margin 1 cm)", f["com_scfr_margin_m"] >= 0.01 - 1e-3)
    result.check("CoM outside the feet's support polygon", f["com_support_polygon_margin_m"] < 0)
    result.check("static equilibrium LP: feasible with the wall", bool(eq.feasible))
    result.check("static equilibrium LP: infeasible on the feet alone", not eq_feet.feasible)
    if speed:
        on, t = np.array(bumpers.on[BUMPER]), np.array(bumpers.time)
        away = np.array(gap) > TOUCHING
        reached = np.flatnonzero(~away)
        f["bumper_first_on_s"] = bumpers.first_on(BUMPER)
        f["hand_reaches_wall_s"] = float(t[reached[0]]) if reached.size else None
        f["bumper_on_while_away_from_wall"] = int(np.count_nonzero(on & away))
        f["bumper_samples_away_from_wall"] = int(np.count_nonzero(away))
        f["bumper_force_end_N"] = bumpers.force[BUMPER][-1]
        result.check(
            f"bumper {BUMPER} off while the hand is away from the wall (> {TOUCHING * 1e3:g} mm)",
            away.any() and not (on & away).any(),
            f"{f['bumper_on_while_away_from_wall']} of {f['bumper_samples_away_from_wall']} "
            "samples on",
        )
        result.check(
            f"bumper {BUMPER} on with the palm on the wall at the end",
            bool(on[-1]) and not away[-1],
            f"{f['bumper_force_end_N']:.1f} N, first on at {f['bumper_first_on_s']} s",
        )
    return result


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, speed=args.speed, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
