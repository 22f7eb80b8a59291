"""The kettle in the room: look at it, grasp the handle, lift it 0.1 m (seed 001, room73b2).

The robot stands at ``spot_counter_front`` (no walking: it is placed there) and
makes four solves, each a segment of one motion:

1. **look** at the kettle's handle (``:head :look-at``, the chain from the root:
   waist and neck), checked in the head camera's image: the handle projects
   near the image centre, not occluded by MuJoCo's ray cast;
2. **pre-grasp**: the right hand ``APPROACH`` in front of the handle, already in
   the grasp orientation (hand x along the vertical bar, rotation about the bar
   free — the seed's ``:rotation-axis :z`` is the bar's axis), keeping the kettle
   in view;
3. **approach**: the hand along the approach direction onto the handle
   (``:inverse-kinematics`` of the handle coordinates);
4. **lift** 0.1 m in the world (``:move-end-pos #f(0 0 100) :world
   :look-at-target t``): the hand target moves up 0.1 m keeping the grasp while
   the head keeps looking at the kettle, which moves with the hand.

The forearm lies along the approach direction and the handle is only 0.37 m
ahead of the shoulder, so the elbow folds past the abdomen: reach and approach
carry a collision avoidance (seed ``:collision-avoidance-link-pair``, yellow
zone ``YELLOW``, orange ``ORANGE``) of the arm, chest and pelvis against the
counter, the kettle and each other, in a level above the hand's target
(with the counter and the kettle alone, the forearm passed 69 mm into the
abdomen, and the physical arm, stopped there, ended on the counter). The
approach leaves out the hand's own pairs with the kettle: the handle ends
inside the hand.

The iterates are played in physics (``scene.play``), in three scenes, each part
continuing from the state the one before ended in: look and pre-grasp in the
room as it is; the approach with the hand's contacts with the kettle excluded
(``Scene.from_robot(robot, exclude=[("rarm_hand", "kettle")])``: the sample
humanoid's hand is a box without fingers and the bar ends inside it, where
open fingers would pass around it); the lift in the scene with the grasp (a
weld, ``grasps=[("rarm_end", "kettle")]``, switched on at the part's start:
the closed fingers), the kettle's 1 kg in the hand and on the balance, its
contact with the counter planned at the lift's start. Reported: the motion
section and the smallest distance of the hand and forearm to the counter along
the motion, in the reference and in physics.

The kettle is an object: the IK moves only the robot; after the lift the
kettle's free joint is set to its grasp-time pose relative to the hand carried
to the lifted hand, ``X_WO = X_WH(lift) X_WH(grasp)^-1 X_WO(0)``, and the
physics hold holds it in the hand (the grasp scene): its weight loads the arm
and the balance.
"""

from __future__ import annotations

import sys

import mujoco
import numpy as np

from pik_mj import (
    CollisionAvoidanceTask,
    HoldCriteria,
    Progress,
    Recorder,
    Robot,
    Scene,
    Waypoints,
    inverse_kinematics,
)
from pik_mj.ik import gaze_angle
from pik_mj.robot.camera import Camera
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    ScenarioResult,
    com_margin,
    open_recorder,
    parser,
    report,
)
from pik_mj.sim.motion import Clearance
from pik_mj.solve import SolveResult, TrustRegion
from pik_mj.tasks.collision import collision_pairs, moving_pairs

NAME = "kettle"
LIFT = 0.1  # [m]
CENTRED = 0.05  # the handle within this fraction of the image width of its centre
APPROACH = 0.1  # [m] pre-grasp: the hand this far back (the hand box's tip 38 mm off the bar)
LINKS = ("rarm_upper", "rarm_lower", "rarm_hand", "torso_chest", "pelvis")  # avoidance links
OBSTACLES = ("counter", "kettle")
YELLOW = 0.1  # [m] pairs nearer than this are constrained
ORANGE = 0.03  # [m] the distance kept
GAIN = 0.2  # velocity-damper gain: a slow approach keeps the linearized rows from overshooting
STEPS = TrustRegion(radius=0.02, max_radius=0.04)  # short steps: a dense path to play
HAND, FOREARM = "rarm_hand", "rarm_lower"


def grasp_rotation(R_W_handle: np.ndarray) -> np.ndarray:
    """Hand orientation grasping the vertical bar: hand x along the bar (handle z),
    hand z (towards the elbow) against the approach direction (handle x)."""
    x = R_W_handle[:, 2]
    z = -R_W_handle[:, 0]
    return np.column_stack([x, np.cross(z, x), z])


def run(
    recorder: Recorder,
    *,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    scene = Scene.from_robot(robot)
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    err = None if quiet else sys.stderr
    handle = robot.frame_pose("kettle_handle")
    p_handle = handle.translation()
    R_W_handle = handle.rotation().as_matrix()
    p_kettle = robot.frame_pose("kettle_center").translation()
    R_grasp = grasp_rotation(R_W_handle)
    feet0 = [robot.frame_pose(f).translation() for f in ("rleg_end", "lleg_end")]
    kettle_adr = int(robot.model.joint("kettle_free").qposadr[0])
    kettle_q = robot.configuration.q[kettle_adr : kettle_adr + 7].copy()
    X_kettle0 = robot.frame_pose("kettle", "body")
    path = Waypoints(robot, "look")

    def solve(label: str, path: Waypoints, targets, **options) -> SolveResult:
        """``inverse_kinematics`` in short steps with the static checks, the
        logger, the progress and the path (segment ``label``)."""
        checks = scene.static_checker()
        log = recorder.solve_logger(label, checks=checks, start=robot)
        progress = Progress(label, stream=err)
        res = inverse_kinematics(
            robot,
            targets,
            trust_region=STEPS,
            callback=[checks, log, progress, path.segment(label)],
            **options,
        )
        result.add_solve(label, res, checks, finish=[log, progress, path])
        return res

    solve("look", path, [], look_at=p_handle, joints="chain")
    gaze_look = gaze_angle(robot, p_handle)
    # The handle in the head camera's image (camera poses: mj_camlight).
    camera = robot.camera("head_camera")
    mujoco.mj_camlight(robot.model, robot.data)
    pixel, depth = camera.project(robot.data, p_handle)
    centre = 0.5 * np.array([camera.intrinsics.width, camera.intrinsics.height])  # [px]
    seen = camera.visibility(robot.data, "kettle_handle")

    # Collision avoidance of the arm, chest and pelvis against the counter, the
    # kettle and each other, for the pairs the arm's chain can move.
    pairs = collision_pairs(robot.model, robot.data, list(LINKS), list(OBSTACLES))
    pairs = moving_pairs(robot.model, pairs, robot.joint_list("rarm_end", "site"))
    kettle_geoms = {
        robot.model.geom(g).name
        for g in range(robot.model.ngeom)
        if robot.model.geom_bodyid[g] == robot.model.body("kettle").id
    }
    hand_kettle = [
        p for p in pairs if {p.name1, p.name2} & kettle_geoms and HAND in (p.name1, p.name2)
    ]
    approach_pairs = [p for p in pairs if p not in hand_kettle]

    def avoid(pairs) -> CollisionAvoidanceTask:
        return CollisionAvoidanceTask(
            robot.configuration, pairs, yellow=YELLOW, orange=ORANGE, gain=GAIN
        )

    p_pre = p_handle - APPROACH * R_W_handle[:, 0]
    grasp_options = dict(move_targets="rarm_end", rotation_axis="x", look_at=p_kettle, stop=200)
    solve("pre-grasp", path, (p_pre, R_grasp), collision_avoidance=avoid(pairs), **grasp_options)
    X_pre = robot.frame_pose("rarm_end")
    approach = Waypoints(robot, "approach")
    solve(
        "approach",
        approach,
        (p_handle, R_grasp),
        collision_avoidance=avoid(approach_pairs),
        **grasp_options,
    )
    X_grasp = robot.frame_pose("rarm_end")
    gaze_grasp = gaze_angle(robot, p_kettle)
    held = Scene.from_robot(robot, grasps=[("rarm_end", "kettle")])  # X_FO read now

    def kettle_now(r) -> np.ndarray:  # the kettle moves with the hand
        return p_kettle + r.frame_pose("rarm_end").translation() - X_grasp.translation()

    checks = scene.static_checker()
    log, progress = (
        recorder.solve_logger("lift", checks=checks, start=robot),
        Progress("lift", stream=err),
    )
    lift_path = Waypoints(robot, "lift")
    lift = inverse_kinematics(
        robot,
        # the grasped hand's whole pose, lifted: the kettle hangs from it
        (p_handle + np.array([0.0, 0.0, LIFT]), X_grasp.rotation().wxyz),
        move_targets="rarm_end",
        rotation_axis=True,
        look_at=kettle_now,
        stop=100,
        trust_region=STEPS,
        callback=[checks, log, progress, lift_path],
    )
    # The IK left the kettle alone; now it is carried with the hand.
    q_ik_kettle = robot.configuration.q[kettle_adr : kettle_adr + 7].copy()
    X_carried = robot.frame_pose("rarm_end") @ X_grasp.inverse() @ X_kettle0
    q = robot.configuration.q.copy()
    q[kettle_adr : kettle_adr + 7] = np.r_[X_carried.translation(), X_carried.rotation().wxyz]
    robot.configuration.update(q)
    result.add_solve("lift", lift, checks, finish=[log, progress, lift_path])

    # The motion in physics: reach in the room, approach with the open hand,
    # lift with the kettle welded in the hand, each part from the last one's state.
    clearance = Clearance(scene.model, [HAND, FOREARM], ["counter"])
    kettle_xyz: list[np.ndarray] = [kettle_q[:3]]  # physics: at the start, after each part
    if speed:
        open_hand = Scene.from_robot(robot, exclude=[(HAND, "kettle")])
        head = Camera(scene.model, "head_camera")
        log = recorder.motion_logger(cameras=[head])  # the robot's view, where MuJoCo renders
        part = None
        for label, in_scene, part_path in (
            ("look, pre-grasp", scene, path),
            ("approach (open hand)", open_hand, approach),
            ("lift (kettle in the hand)", held, lift_path),
        ):
            part = in_scene.play(part_path, speed=speed, start=part, callback=[log, clearance])
            result.add_motion(label, part, finish=[log])
            kettle_xyz.append(part.final_state.qpos[kettle_adr : kettle_adr + 3].copy())

    # The final pose in physics, the kettle held in the hand by a weld.
    static = held.static_check(q)
    criteria = HoldCriteria(allowed=[*held.allowed_contacts, *static.touching_geoms])
    hold_report = (
        held.hold(q, hold, criteria=criteria, callback=recorder.hold_logger()) if hold else None
    )
    result.add_balance(held, static, hold_report, criteria)

    X_lift = robot.frame_pose("rarm_end")
    d = X_lift.translation() - X_grasp.translation()
    R_rel = X_grasp.rotation().inverse() @ X_lift.rotation()
    bar_W = [X.rotation().as_matrix()[:, 0] for X in (X_grasp, X_lift)]
    feet1 = [robot.frame_pose(f).translation() for f in ("rleg_end", "lleg_end")]
    X_kettle1 = robot.frame_pose("kettle", "body")
    X_hand_kettle = [X.inverse() @ Y for X, Y in ((X_grasp, X_kettle0), (X_lift, X_kettle1))]
    result.main = "lift"
    result.figures = {
        "handle_m": p_handle,
        "pre_grasp_error_m": float(np.linalg.norm(X_pre.translation() - p_pre)),
        "grasp_error_m": float(np.linalg.norm(X_grasp.translation() - p_handle)),
        "hand_bar_axis_vs_handle_bar_rad": float(
            np.arccos(np.clip(bar_W[0] @ R_W_handle[:, 2], -1, 1))
        ),
        "lift_m": d,
        "lift_rotation_change_rad": float(np.linalg.norm(R_rel.log())),
        "gaze_angle_after_look_deg": np.rad2deg(gaze_look),
        "gaze_angle_after_grasp_deg": np.rad2deg(gaze_grasp),
        "gaze_angle_after_lift_deg": np.rad2deg(gaze_angle(robot, kettle_now(robot))),
        "handle_pixel_after_look_px": pixel,
        "handle_offset_from_image_centre_px": float(np.linalg.norm(pixel - centre)),
        "image_width_px": camera.intrinsics.width,
        "handle_depth_m": depth,
        "handle_visible_after_look": seen.visible,
        "feet_moved_m": max(
            float(np.linalg.norm(a - b)) for a, b in zip(feet0, feet1, strict=True)
        ),
        "kettle_qpos_changed_by_ik": float(np.abs(q_ik_kettle - kettle_q).max()),
        "kettle_lift_m": X_kettle1.translation() - X_kettle0.translation(),
        "kettle_in_hand_change_m": float(
            np.linalg.norm(X_hand_kettle[1].translation() - X_hand_kettle[0].translation())
        ),
        "com_margin_m": com_margin(robot),
        "avoidance_pairs": len(pairs),
    }
    f = result.figures
    if speed:
        f["min_distance_hand_forearm_counter_reference_m"] = clearance.reference
        f["min_distance_hand_forearm_counter_physics_m"] = clearance.physics
        f["kettle_moved_before_the_grasp_physics_m"] = float(
            np.linalg.norm(kettle_xyz[2] - kettle_xyz[0])
        )
        f["kettle_lift_physics_m"] = kettle_xyz[3] - kettle_xyz[2]
    for label in ("look", "pre-grasp", "approach", "lift"):
        result.check(f"{label} converged", result.solves[label].converged)
    result.check(
        f"pre-grasp: the hand {APPROACH:g} m before the handle (1 mm)",
        f["pre_grasp_error_m"] <= 1e-3,
    )
    result.check("hand at the handle (1 mm)", f["grasp_error_m"] <= 1e-3)
    result.check(
        "hand's grasp axis along the bar (1°)",
        f["hand_bar_axis_vs_handle_bar_rad"] <= np.deg2rad(1.0),
    )
    result.check(
        "lifted 0.1 m straight up (1 mm)",
        abs(d[2] - LIFT) <= 1e-3 and np.linalg.norm(d[:2]) <= 1e-3,
        f"{d}",
    )
    result.check(
        "grasp kept while lifting (bar axis within 1°)",
        float(np.arccos(np.clip(bar_W[0] @ bar_W[1], -1, 1))) <= np.deg2rad(1.0),
    )
    result.check(
        "looking at the handle (2°) after look, at the kettle after grasp and lift",
        max(
            f["gaze_angle_after_look_deg"],
            f["gaze_angle_after_grasp_deg"],
            f["gaze_angle_after_lift_deg"],
        )
        <= 2.0,
    )
    result.check(
        "feet (frozen legs and root: within the QP tolerance, 10 µm) "
        "and kettle untouched by the IK",
        f["feet_moved_m"] <= 1e-5 and f["kettle_qpos_changed_by_ik"] <= 1e-5,
    )
    k = f["kettle_lift_m"]
    result.check(
        "kettle carried with the hand (pose in the hand kept, 1 µm) and lifted 0.1 m (2 mm)",
        f["kettle_in_hand_change_m"] <= 1e-6
        and abs(k[2] - LIFT) <= 2e-3
        and np.linalg.norm(k[:2]) <= 2e-3,
        f"{k}",
    )
    result.check("CoM over the feet", f["com_margin_m"] > 0, f"margin {f['com_margin_m']:.3f} m")
    offset = f["handle_offset_from_image_centre_px"] / f["image_width_px"]
    result.check(
        f"head camera after the look: the handle within {CENTRED:.0%} of the image width "
        "of its centre, not occluded",
        offset <= CENTRED and seen.visible,
        f"{offset:.1%} of the width; "
        + ("visible" if seen.visible else f"occluded by {seen.occluder}"),
    )
    if speed:
        result.check(
            "motion: the hand and forearm clear of the counter (reference: the orange "
            f"distance {ORANGE * 1e3:g} mm; physics: > 0)",
            f["min_distance_hand_forearm_counter_reference_m"] >= ORANGE - 1e-3
            and f["min_distance_hand_forearm_counter_physics_m"] > 0,
            f"reference {f['min_distance_hand_forearm_counter_reference_m'] * 1e3:.1f} mm, "
            f"physics {f['min_distance_hand_forearm_counter_physics_m'] * 1e3:.1f} mm",
        )
        lifted = f["kettle_lift_physics_m"]
        result.check(
            "motion: the kettle stays on the counter until the grasp (1 mm), then the "
            f"physical hand lifts it {LIFT:g} m (1 cm)",
            f["kettle_moved_before_the_grasp_physics_m"] <= 1e-3
            and abs(lifted[2] - LIFT) <= 1e-2
            and np.linalg.norm(lifted[:2]) <= 1e-2,
            f"moved {f['kettle_moved_before_the_grasp_physics_m'] * 1e3:.2f} mm before; "
            f"lifted {lifted}",
        )
    return result


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, speed=args.speed, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
