"""The kettle in the room: look at it, grasp the handle, lift it 0.1 m (seed 001, room73b2).

The robot stands at ``spot_counter_front`` (no walking: it is placed there), looks
at the kettle's handle (``:head :look-at``; checked in the head camera's image:
the handle projects near the image centre, not occluded by MuJoCo's ray cast),
keeps the kettle in view while it reaches the handle with the right hand
(``:inverse-kinematics`` of the handle coordinates with the chain from the root,
rotation about the handle bar free — the seed's ``:rotation-axis :z`` is the
bar's axis, here the hand's x), and lifts it 0.1 m in the world
(``:move-end-pos #f(0 0 100) :world :look-at-target t``): the hand target moves
up 0.1 m keeping the grasp while the head keeps looking at the kettle, which
moves with the hand. The kettle is an object: the IK moves only the robot; after
the lift the kettle's free joint is set to its grasp-time pose relative to the
hand carried to the lifted hand, ``X_WO = X_WH(lift) X_WH(grasp)^-1 X_WO(0)``,
and the physics hold holds it in the hand (a weld: ``Scene.from_robot(robot,
grasps=[("rarm_end", "kettle")])``): its weight loads the arm and the balance.
"""

from __future__ import annotations

import sys

import mujoco
import numpy as np

from pik_mj import HoldCriteria, Progress, Recorder, Robot, Scene, inverse_kinematics
from pik_mj.camera import Camera
from pik_mj.ik import gaze_angle
from pik_mj.scenario import DEFAULT_HOLD, ScenarioResult, com_margin, open_recorder, parser, report

NAME = "kettle"
LIFT = 0.1  # [m]
CENTRED = 0.05  # the handle within this fraction of the image width of its centre


def grasp_rotation(R_W_handle: np.ndarray) -> np.ndarray:
    """Hand orientation grasping the vertical bar: hand x along the bar (handle z),
    hand z (towards the elbow) against the approach direction (handle x)."""
    x = R_W_handle[:, 2]
    z = -R_W_handle[:, 0]
    return np.column_stack([x, np.cross(z, x), z])


def run(recorder: Recorder, *, hold: float = DEFAULT_HOLD, quiet: bool = True) -> ScenarioResult:
    result = ScenarioResult(NAME)
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    scene = Scene.from_robot(robot)
    recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    err = None if quiet else sys.stderr
    handle = robot.frame_pose("kettle_handle")
    p_handle = handle.translation()
    p_kettle = robot.frame_pose("kettle_center").translation()
    R_grasp = grasp_rotation(handle.rotation().as_matrix())
    feet0 = [robot.frame_pose(f).translation() for f in ("rleg_end", "lleg_end")]
    kettle_adr = int(robot.model.joint("kettle_free").qposadr[0])
    kettle_q = robot.configuration.q[kettle_adr : kettle_adr + 7].copy()
    X_kettle0 = robot.frame_pose("kettle", "body")

    checks = scene.static_checker()
    log, progress = (
        recorder.solve_logger("look", checks=checks, start=robot),
        Progress("look", stream=err),
    )
    look = inverse_kinematics(
        robot, [], look_at=p_handle, joints="chain", callback=[checks, log, progress]
    )
    result.add_solve("look", look, checks, finish=[log, progress])
    gaze_look = gaze_angle(robot, p_handle)
    # The handle in the head camera's image (camera poses: mj_camlight).
    camera = Camera(robot.model, "head_camera")
    mujoco.mj_camlight(robot.model, robot.data)
    pixel, depth = camera.project(robot.data, p_handle)
    centre = 0.5 * np.array([camera.intrinsics.width, camera.intrinsics.height])  # [px]
    seen = camera.visibility(robot.data, "kettle_handle")

    checks = scene.static_checker()
    log, progress = (
        recorder.solve_logger("grasp", checks=checks, start=robot),
        Progress("grasp", stream=err),
    )
    grasp = inverse_kinematics(
        robot,
        (p_handle, R_grasp),
        move_targets="rarm_end",
        rotation_axis="x",
        look_at=p_kettle,
        stop=100,
        callback=[checks, log, progress],
    )
    result.add_solve("grasp", grasp, checks, finish=[log, progress])
    X_grasp = robot.frame_pose("rarm_end")
    gaze_grasp = gaze_angle(robot, p_kettle)

    def kettle_now(r) -> np.ndarray:  # the kettle moves with the hand
        return p_kettle + r.frame_pose("rarm_end").translation() - X_grasp.translation()

    checks = scene.static_checker()
    log, progress = (
        recorder.solve_logger("lift", checks=checks, start=robot),
        Progress("lift", stream=err),
    )
    lift = inverse_kinematics(
        robot,
        # the grasped hand's whole pose, lifted: the kettle hangs from it
        (p_handle + np.array([0.0, 0.0, LIFT]), X_grasp.rotation().wxyz),
        move_targets="rarm_end",
        rotation_axis=True,
        look_at=kettle_now,
        stop=100,
        callback=[checks, log, progress],
    )
    # The IK left the kettle alone; now it is carried with the hand.
    q_ik_kettle = robot.configuration.q[kettle_adr : kettle_adr + 7].copy()
    X_carried = robot.frame_pose("rarm_end") @ X_grasp.inverse() @ X_kettle0
    q = robot.configuration.q.copy()
    q[kettle_adr : kettle_adr + 7] = np.r_[X_carried.translation(), X_carried.rotation().wxyz]
    robot.configuration.update(q)
    result.add_solve("lift", lift, checks, finish=[log, progress])

    # The final pose in physics, the kettle held in the hand by a weld.
    scene = Scene.from_robot(robot, grasps=[("rarm_end", "kettle")])
    static = scene.static_check(q)
    criteria = HoldCriteria(allowed=[*scene.allowed_contacts, *static.touching_geoms])
    held = scene.hold(q, hold, criteria=criteria, callback=recorder.hold_logger()) if hold else None
    result.add_balance(scene, static, held, criteria)

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
        "grasp_error_m": float(np.linalg.norm(X_grasp.translation() - p_handle)),
        "hand_bar_axis_vs_handle_bar_rad": float(
            np.arccos(np.clip(bar_W[0] @ handle.rotation().as_matrix()[:, 2], -1, 1))
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
    }
    f = result.figures
    for label in ("look", "grasp", "lift"):
        result.check(f"{label} converged", result.solves[label].converged)
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
    return result


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
