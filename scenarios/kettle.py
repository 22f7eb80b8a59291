"""The kettle in the room: look at it, grasp the handle, lift it 0.1 m (irteus manual, room73b2).

The robot stands at ``spot_counter_front`` (no walking: it is placed there) and
makes four solves, each a segment of one motion:

1. **look** at the kettle's handle (``:head :look-at``, the chain from the root:
   waist and neck), checked in the head camera's image: the handle projects
   near the image centre, not occluded by MuJoCo's ray cast;
2. **pre-grasp**: the right hand ``APPROACH`` in front of the handle, already in
   the grasp orientation (hand x along the vertical bar, rotation about the bar
   free — irteus's ``:rotation-axis :z`` is the bar's axis), keeping the kettle
   in view;
3. **approach**: the hand along the approach direction onto the handle
   (``:inverse-kinematics`` of the handle coordinates);
4. **lift** 0.1 m in the world (``:move-end-pos #f(0 0 100) :world
   :look-at-target t``): the hand target moves up 0.1 m keeping the grasp while
   the head keeps looking at the kettle, which moves with the hand.

The forearm lies along the approach direction and the handle is only 0.37 m
ahead of the shoulder, so the elbow folds past the abdomen: pre-grasp and
approach carry a collision avoidance (irteus's ``:collision-avoidance-link-pair``,
yellow zone ``YELLOW``, orange ``ORANGE``) of the arm, chest and pelvis against
the counter, the kettle and each other, in a level above the hand's target: the
pairs among the robot's own links keep the folding forearm out of the abdomen.
The approach leaves out the hand's own pairs with the kettle: the handle ends
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

from dataclasses import dataclass
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj import (
    CollisionAvoidanceTask,
    Recorder,
    Robot,
    Scene,
    Waypoints,
    WorldAvoidance,
    inverse_kinematics,
)
from pik_mj.ik import gaze_angle
from pik_mj.robot.camera import Camera, Visibility
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    ScenarioResult,
    Stage,
    com_margin,
    end_pose,
    largest_move,
    open_recorder,
    parser,
    report,
)
from pik_mj.sim.motion import Clearance
from pik_mj.solve import TrustRegion
from pik_mj.tasks.collision import GeomPair, collision_pairs, moving_pairs

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
GRASPED = WorldAvoidance(allowed=["kettle"])  # the world kept off, the grasped kettle excepted
FEET = ("rleg", "lleg")


def grasp_rotation(R_W_handle: np.ndarray) -> np.ndarray:
    """Hand orientation grasping the vertical bar: hand x along the bar (handle z),
    hand z (towards the elbow) against the approach direction (handle x)."""
    x = R_W_handle[:, 2]
    z = -R_W_handle[:, 0]
    return np.column_stack([x, np.cross(z, x), z])


@dataclass(frozen=True)
class Kettle:
    """The kettle on the counter, before the robot touches it.

    Attributes:
        p_handle: Handle position [m], world.
        R_handle: Handle orientation ``R_WH``: x the approach direction, z along the bar.
        p_center: The kettle's centre [m], world: where the head looks once it is held.
        X_body: Pose ``X_WO`` of the kettle's body.
        adr: Address of the kettle's free joint in ``qpos``.
        qpos: The free joint's 7 coordinates (position, quaternion).
    """

    p_handle: np.ndarray
    R_handle: np.ndarray
    p_center: np.ndarray
    X_body: mink.SE3
    adr: int
    qpos: np.ndarray

    @classmethod
    def on_counter(cls, robot: Robot) -> Kettle:
        """The kettle in the robot's world as it is now."""
        handle = robot.frame_pose("kettle_handle")
        adr = int(robot.model.joint("kettle_free").qposadr[0])
        return cls(
            p_handle=handle.translation(),
            R_handle=handle.rotation().as_matrix(),
            p_center=robot.frame_pose("kettle_center").translation(),
            X_body=robot.frame_pose("kettle", "body"),
            adr=adr,
            qpos=robot.configuration.q[adr : adr + 7].copy(),
        )

    @property
    def pre_grasp(self) -> np.ndarray:
        """The hand's pre-grasp position [m]: ``APPROACH`` back from the handle."""
        return self.p_handle - APPROACH * self.R_handle[:, 0]

    def center_with(self, robot: Robot, X_grasp: mink.SE3) -> np.ndarray:
        """The kettle's centre [m] as it moves with the hand that grasped it at ``X_grasp``."""
        return self.p_center + robot.frame_pose("rarm_end").translation() - X_grasp.translation()


@dataclass(frozen=True)
class HeadView:
    """What the head sees of the handle after the look.

    Attributes:
        gaze: Angle [rad] between the gaze axis and the handle.
        pixel: The handle's projection in the head camera's image [px].
        depth: Its depth in front of the camera [m].
        width: The image's width [px].
        offset: Distance [px] of the pixel from the image centre.
        seen: Whether MuJoCo's ray cast reaches it.
    """

    gaze: float
    pixel: np.ndarray
    depth: float
    width: int
    offset: float
    seen: Visibility


@dataclass(frozen=True)
class Grasp:
    """The hand at the handle.

    Attributes:
        path: The approach's iterates (played in the scene without the hand's contacts).
        X_pre: The hand's pose after the pre-grasp.
        X_grasp: The hand's pose after the approach.
        gaze: Angle [rad] between the gaze axis and the kettle's centre then.
    """

    path: Waypoints
    X_pre: mink.SE3
    X_grasp: mink.SE3
    gaze: float


def run(
    recorder: Recorder,
    *,
    hold: float = DEFAULT_HOLD,
    speed: float = DEFAULT_SPEED,
    quiet: bool = True,
) -> ScenarioResult:
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    kettle = Kettle.on_counter(robot)
    feet0 = [end_pose(robot, foot) for foot in FEET]
    path = Waypoints(robot, "look")
    view = look(stage, kettle, path)
    pairs = avoidance_pairs(robot)
    grasp = reach_handle(stage, kettle, path, pairs)
    held = Scene.from_robot(robot, grasps=[("rarm_end", "kettle")])  # X_FO read now
    lift_path, q_ik = lift(stage, kettle, grasp.X_grasp)
    motion: dict[str, Any] = {}  # the motion's figures
    if speed:
        open_hand = Scene.from_robot(robot, exclude=[(HAND, "kettle")])
        parts = [
            ("look, pre-grasp", stage.scene, path),
            ("approach (open hand)", open_hand, grasp.path),
            ("lift (kettle in the hand)", held, lift_path),
        ]
        motion = play(stage, parts, speed, kettle)
    # The final pose in physics, the kettle held in the hand by a weld.
    stage.hold_final_pose(hold, scene=held)
    result = stage.result
    result.main = "lift"
    result.figures = {**figures(robot, kettle, view, grasp, feet0, q_ik, len(pairs)), **motion}
    check(result, view.seen, grasp_turn(grasp.X_grasp, robot))
    return result


def look(stage: Stage, kettle: Kettle, path: Waypoints) -> HeadView:
    """Look at the handle with the chain from the root (waist and neck); what the head
    camera sees of it then (camera poses: ``mj_camlight``)."""
    robot = stage.robot
    stage.solve(
        inverse_kinematics,
        "look",
        [],
        path=path,
        look_at=kettle.p_handle,
        joints="chain",
        trust_region=STEPS,
    )
    gaze = gaze_angle(robot, kettle.p_handle)
    camera = robot.camera("head_camera")
    mujoco.mj_camlight(robot.model, robot.data)
    pixel, depth = camera.project(robot.data, kettle.p_handle)
    centre = 0.5 * np.array([camera.intrinsics.width, camera.intrinsics.height])  # [px]
    seen = camera.visibility(robot.data, "kettle_handle")
    offset = float(np.linalg.norm(pixel - centre))
    return HeadView(gaze, pixel, depth, camera.intrinsics.width, offset, seen)


def avoidance_pairs(robot: Robot) -> list[GeomPair]:
    """The collision pairs of the arm, chest and pelvis against the counter, the
    kettle and each other, of those the arm's chain can move."""
    pairs = collision_pairs(robot.model, robot.data, list(LINKS), list(OBSTACLES))
    return moving_pairs(robot.model, pairs, robot.joint_list("rarm_end", "site"))


def avoid(robot: Robot, pairs: list[GeomPair]) -> CollisionAvoidanceTask:
    """Collision avoidance of ``pairs``: yellow zone ``YELLOW``, orange ``ORANGE``."""
    return CollisionAvoidanceTask(
        robot.configuration, pairs, yellow=YELLOW, orange=ORANGE, gain=GAIN
    )


def reach_handle(stage: Stage, kettle: Kettle, path: Waypoints, pairs: list[GeomPair]) -> Grasp:
    """The hand to the pre-grasp position, then onto the handle, in the grasp
    orientation, the kettle in view; the approach leaves out the hand's pairs with
    the kettle (the handle ends inside the hand)."""
    robot = stage.robot
    R_grasp = grasp_rotation(kettle.R_handle)
    kettle_geoms = {
        robot.model.geom(g).name
        for g in range(robot.model.ngeom)
        if robot.model.geom_bodyid[g] == robot.model.body("kettle").id
    }
    hand_kettle = [
        p for p in pairs if {p.name1, p.name2} & kettle_geoms and HAND in (p.name1, p.name2)
    ]
    options = dict(
        move_targets="rarm_end",
        rotation_axis="x",
        look_at=kettle.p_center,
        stop=200,
        trust_region=STEPS,
    )
    stage.solve(
        inverse_kinematics,
        "pre-grasp",
        (kettle.pre_grasp, R_grasp),
        path=path,
        collision_avoidance=avoid(robot, pairs),
        **options,
    )
    X_pre = robot.frame_pose("rarm_end")
    approach = Waypoints(robot, "approach")
    stage.solve(
        inverse_kinematics,
        "approach",
        (kettle.p_handle, R_grasp),
        path=approach,
        collision_avoidance=avoid(robot, [p for p in pairs if p not in hand_kettle]),
        avoid_world=GRASPED,
        **options,
    )
    X_grasp = robot.frame_pose("rarm_end")
    return Grasp(approach, X_pre, X_grasp, gaze_angle(robot, kettle.p_center))


def lift(stage: Stage, kettle: Kettle, X_grasp: mink.SE3) -> tuple[Waypoints, np.ndarray]:
    """The grasped hand's whole pose lifted ``LIFT`` in the world, the head looking at
    the kettle as it moves with the hand; then the kettle carried with the hand
    (:func:`carry`). Returns the lift's iterates and the kettle's coordinates the IK
    left (untouched)."""
    robot = stage.robot
    watch = stage.watch("lift", Waypoints(robot, "lift"))
    res = inverse_kinematics(
        robot,
        # the grasped hand's whole pose, lifted: the kettle hangs from it
        (kettle.p_handle + np.array([0.0, 0.0, LIFT]), X_grasp.rotation().wxyz),
        move_targets="rarm_end",
        rotation_axis=True,
        look_at=lambda r: kettle.center_with(r, X_grasp),
        avoid_world=GRASPED,
        stop=100,
        trust_region=STEPS,
        callback=watch.callbacks,
    )
    q_ik = robot.configuration.q[kettle.adr : kettle.adr + 7].copy()
    carry(robot, kettle, X_grasp)
    watch.keep(res)
    return watch.path, q_ik


def carry(robot: Robot, kettle: Kettle, X_grasp: mink.SE3) -> None:
    """Set the kettle's free joint to its grasp-time pose in the hand, carried to the
    hand now: ``X_WO = X_WH X_WH(grasp)^-1 X_WO(0)``."""
    X_carried = robot.frame_pose("rarm_end") @ X_grasp.inverse() @ kettle.X_body
    q = robot.configuration.q.copy()
    q[kettle.adr : kettle.adr + 7] = np.r_[X_carried.translation(), X_carried.rotation().wxyz]
    robot.configuration.update(q)


def play(
    stage: Stage, parts: list[tuple[str, Scene, Waypoints]], speed: float, kettle: Kettle
) -> dict[str, Any]:
    """The motion in physics, part by part (``(label, scene, iterates)``), each from
    the state the last one ended in, with the head camera's view (where MuJoCo
    renders). Returns its figures: the hand and forearm's smallest distance to the
    counter, the kettle's moves before the grasp and in the lift."""
    clearance = Clearance(stage.scene.model, [HAND, FOREARM], ["counter"])
    kettle_xyz = [kettle.qpos[:3]]  # at the start, after each part
    log = stage.recorder.motion_logger(cameras=[Camera(stage.scene.model, "head_camera")])
    part = None
    for label, scene, path in parts:
        part = stage.play(
            label, path, speed=speed, scene=scene, start=part, log=log, callback=[clearance]
        )
        kettle_xyz.append(part.final_state.qpos[kettle.adr : kettle.adr + 3].copy())
    return {
        "min_distance_hand_forearm_counter_reference_m": clearance.reference,
        "min_distance_hand_forearm_counter_physics_m": clearance.physics,
        "kettle_moved_before_the_grasp_physics_m": float(
            np.linalg.norm(kettle_xyz[2] - kettle_xyz[0])
        ),
        "kettle_lift_physics_m": kettle_xyz[3] - kettle_xyz[2],
    }


def grasp_turn(X_grasp: mink.SE3, robot: Robot) -> float:
    """Angle [rad] between the hand's grasp axis (x) at the grasp and now."""
    bar = [X.rotation().as_matrix()[:, 0] for X in (X_grasp, robot.frame_pose("rarm_end"))]
    return float(np.arccos(np.clip(bar[0] @ bar[1], -1, 1)))


def figures(
    robot: Robot,
    kettle: Kettle,
    view: HeadView,
    grasp: Grasp,
    feet0: list[mink.SE3],
    q_ik: np.ndarray,
    pairs: int,
) -> dict[str, Any]:
    """The measures of the final pose: the hand at the handle and lifted, the gaze,
    the handle in the head camera, the feet and the kettle."""
    X_grasp, X_lift = grasp.X_grasp, robot.frame_pose("rarm_end")
    X_kettle = robot.frame_pose("kettle", "body")
    X_in_hand = [X.inverse() @ Y for X, Y in ((X_grasp, kettle.X_body), (X_lift, X_kettle))]
    bar = X_grasp.rotation().as_matrix()[:, 0]
    return {
        "handle_m": kettle.p_handle,
        "pre_grasp_error_m": float(np.linalg.norm(grasp.X_pre.translation() - kettle.pre_grasp)),
        "grasp_error_m": float(np.linalg.norm(X_grasp.translation() - kettle.p_handle)),
        "hand_bar_axis_vs_handle_bar_rad": float(
            np.arccos(np.clip(bar @ kettle.R_handle[:, 2], -1, 1))
        ),
        "lift_m": X_lift.translation() - X_grasp.translation(),
        "lift_rotation_change_rad": float(
            np.linalg.norm((X_grasp.rotation().inverse() @ X_lift.rotation()).log())
        ),
        "gaze_angle_after_look_deg": np.rad2deg(view.gaze),
        "gaze_angle_after_grasp_deg": np.rad2deg(grasp.gaze),
        "gaze_angle_after_lift_deg": np.rad2deg(
            gaze_angle(robot, kettle.center_with(robot, X_grasp))
        ),
        "handle_pixel_after_look_px": view.pixel,
        "handle_offset_from_image_centre_px": view.offset,
        "image_width_px": view.width,
        "handle_depth_m": view.depth,
        "handle_visible_after_look": view.seen.visible,
        "feet_moved_m": largest_move(feet0, [end_pose(robot, foot) for foot in FEET]),
        "kettle_qpos_changed_by_ik": float(np.abs(q_ik - kettle.qpos).max()),
        "kettle_lift_m": X_kettle.translation() - kettle.X_body.translation(),
        "kettle_in_hand_change_m": float(
            np.linalg.norm(X_in_hand[1].translation() - X_in_hand[0].translation())
        ),
        "com_margin_m": com_margin(robot),
        "avoidance_pairs": pairs,
    }


def check(result: ScenarioResult, seen: Visibility, grasp_turn: float) -> None:
    """The scenario's checks on its figures; ``seen``: the handle's visibility after the
    look, ``grasp_turn``: angle [rad] of the hand's grasp axis from the grasp to now."""
    f = result.figures
    d = f["lift_m"]
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
        grasp_turn <= np.deg2rad(1.0),
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
    if "kettle_lift_physics_m" in f:
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


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, speed=args.speed, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
