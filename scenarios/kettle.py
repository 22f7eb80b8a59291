"""The kettle on a counter: look at it, grasp the handle, lift it (irteus manual, room73b2).

The scene is made for the robot (:mod:`pik_mj.scenario.scenes`): a counter before it
and a kettle on it, scaled by the right arm's length L over 0.61 m (its 1 kg by the
cube), whose handle's vertical bar is where the right hand holds a vertical bar 0.6 L
ahead of its shoulder (found by a solve on the robot:
:func:`~pik_mj.scenario.scenes.holding_reach`). The hand is the arm's end frame, or
the hand's geometry past it (:class:`pik_mj.scenario.Hand`); the grip axis is the
hand's axis a bar held in the fist runs along. The robot stands where it is (no
walking) and makes up to four solves, each a segment of one motion:

1. **look** at the kettle's handle (``:head :look-at``, the chain from the root:
   waist and neck), where the robot has a head; with a head camera, checked in its
   image: the handle projects near the image centre, not occluded by MuJoCo's ray
   cast;
2. **pre-grasp**: the hand beside the handle, on the arm's side, its ball clear of
   the bar by the orange distance, already in the grasp orientation: the grip axis
   along the vertical bar, rotation about the bar free (irteus's ``:rotation-axis
   :z`` is the bar's axis), keeping the kettle in view;
3. **approach**: the hand sideways onto the handle (``:inverse-kinematics`` of the
   handle coordinates);
4. **lift** ``LIFT`` (scaled) in the world (``:move-end-pos #f(0 0 100) :world
   :look-at-target t``): the hand's position moves up keeping the bar vertical (the
   rotation about the bar free: an arm of 4 joints cannot keep all six), the head
   looking at the kettle, which moves with the hand.

Every solve is a full-body one (feet fixed, the CoM over them): a short arm leans
its body in. Pre-grasp and approach carry a collision avoidance (irteus's
``:collision-avoidance-link-pair``, yellow zone ``YELLOW``, orange ``ORANGE``) of the
arm and the trunk against the counter, the kettle and each other, in a level above
the hand's target; the approach leaves out the pairs of the hand and its wrist with
the kettle and of the arm with the handle: the handle ends inside the hand.

The iterates are played in physics (``scene.play``), in three scenes, each part
continuing from the state the one before ended in: look and pre-grasp in the scene
as it is; the approach with the contacts of the hand and its wrist with the kettle
excluded (``Scene.from_robot(robot, exclude=[(hand, "kettle"), (wrist,
"kettle")])``: open fingers pass around the bar a hand's box would end around); the
lift in the scene with the grasp (a weld of the kettle to the hand, switched on at
the part's start: the closed fingers around the bar), the kettle's weight in the hand
and on the balance, its contact with the counter planned at the lift's start.
Reported: the motion section and the smallest distance of the arm to the counter
along the motion, in the reference and in physics.

The kettle is an object: the IK moves only the robot; after the lift the kettle's
free joint is set to its grasp-time pose relative to the hand carried to the lifted
hand, ``X_WO = X_WH(lift) X_WH(grasp)^-1 X_WO(0)``, and the physics hold holds it in
the hand (the grasp scene): its weight loads the arm and the balance.
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
    fullbody_inverse_kinematics,
    inverse_kinematics,
)
from pik_mj.ik import gaze_angle
from pik_mj.robot.camera import Camera, Visibility
from pik_mj.robot.ground import collision_geoms
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    Hand,
    RobotOption,
    ScenarioResult,
    Stage,
    Stature,
    com_margin,
    end_pose,
    largest_move,
    open_recorder,
    parser,
    report,
    robot_in,
    run_options,
)
from pik_mj.scenario.scenes import KettleLayout, kettle_scene
from pik_mj.sim.motion import Clearance
from pik_mj.solve import TrustRegion
from pik_mj.tasks.collision import GeomPair, collision_pairs, moving_pairs

NAME = "kettle"
ARM = "rarm"
FEET = ("rleg", "lleg")
ROBOT = RobotOption("sample_humanoid", (ARM, *FEET), floating_base=True, uses="a head camera")
LIFT = 0.1  # [m] at the kettle's scale 1
CENTRED = 0.05  # the handle within this fraction of the image width of its centre
BAR = 0.012  # [m] radius of the handle's bar at the kettle's scale 1
HANDLE = ("kettle_handle", "kettle_handle_upper", "kettle_handle_lower")  # its geoms
YELLOW = 0.1  # [m] pairs nearer than this are constrained
ORANGE = 0.03  # [m] the distance kept
GAIN = 0.2  # velocity-damper gain: a slow approach keeps the linearized rows from overshooting
STEPS = TrustRegion(radius=0.02, max_radius=0.04)  # short steps: a dense path to play
GRASPED = WorldAvoidance(allowed=["kettle"])  # the world kept off, the grasped kettle excepted


@dataclass(frozen=True)
class Kettle:
    """The kettle on the counter, before the robot touches it.

    Attributes:
        p_handle: Handle position [m], world.
        R_handle: Handle orientation ``R_WH``: x from the robot to the kettle, z along the bar.
        p_center: The kettle's centre [m], world: where the head looks once it is held.
        X_body: Pose ``X_WO`` of the kettle's body.
        adr: Address of the kettle's free joint in ``qpos``.
        qpos: The free joint's 7 coordinates (position, quaternion).
        scale: The kettle's size over its size at scale 1.
        inward: The approach direction: horizontal, from the grasping arm's side
            towards the robot's middle plane.
    """

    p_handle: np.ndarray
    R_handle: np.ndarray
    p_center: np.ndarray
    X_body: mink.SE3
    adr: int
    qpos: np.ndarray
    scale: float
    inward: np.ndarray

    @classmethod
    def on_counter(cls, robot: Robot, scale: float, inward: np.ndarray) -> Kettle:
        """The kettle in the robot's world as it is now, approached along ``inward``."""
        handle = robot.frame_pose("kettle_handle")
        adr = int(robot.model.joint("kettle_free").qposadr[0])
        return cls(
            p_handle=handle.translation(),
            R_handle=handle.rotation().as_matrix(),
            p_center=robot.frame_pose("kettle_center").translation(),
            X_body=robot.frame_pose("kettle", "body"),
            adr=adr,
            qpos=robot.configuration.q[adr : adr + 7].copy(),
            scale=scale,
            inward=np.asarray(inward, dtype=float),
        )

    @property
    def lift(self) -> float:
        """The lift [m]: :data:`LIFT` times the kettle's scale."""
        return LIFT * self.scale

    def back_off(self, hand: Hand) -> float:
        """How far [m] the hand waits beside the handle: its ball (``hand.radius``)
        clear of the bar (radius ``BAR``, scaled) by the orange distance."""
        return hand.radius + BAR * self.scale + ORANGE

    def pre_grasp(self, hand: Hand) -> np.ndarray:
        """The hand's pre-grasp position [m]: :meth:`back_off` beside the handle, on
        the arm's side."""
        return self.p_handle - self.back_off(hand) * self.inward

    def center_with(self, robot: Robot, hand: Hand, X_grasp: mink.SE3) -> np.ndarray:
        """The kettle's centre [m] as it moves with the hand that grasped it at ``X_grasp``."""
        return self.p_center + hand.pose(robot).translation() - X_grasp.translation()


@dataclass(frozen=True)
class HeadView:
    """What the head sees of the handle after the look.

    Attributes:
        gaze: Angle [rad] between the gaze axis and the handle.
        camera: What the head camera sees of it: ``(pixel [px], depth [m], image
            width [px], offset from the image centre [px], visibility)``, or None
            without a head camera.
    """

    gaze: float
    camera: tuple[np.ndarray, float, int, float, Visibility] | None


@dataclass(frozen=True)
class Grasp:
    """The hand at the handle.

    Attributes:
        path: The approach's iterates (played in the scene without the hand's contacts).
        X_pre: The hand's pose after the pre-grasp.
        X_grasp: The hand's pose after the approach.
        gaze: Angle [rad] between the gaze axis and the kettle's centre then (None
            without a head).
    """

    path: Waypoints
    X_pre: mink.SE3
    X_grasp: mink.SE3
    gaze: float | None


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
    """Build the kettle's scene for the robot, then look, grasp, lift, play and hold.
    ``robot``: the robot already built from ``model`` and ``description`` (alone), else
    None to build it here."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=ROBOT.limbs)
    stature = Stature.of(robot)
    layout = KettleLayout.reached(robot, stature, ARM)
    robot = robot_in(robot, kettle_scene(stature, layout, ARM), NAME)
    hand = Stature.of(robot).hands[ARM]
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    inward = -stature.outward(ARM) * stature.R_WR[:, 1]
    kettle = Kettle.on_counter(robot, layout.scale, inward)
    feet0 = [end_pose(robot, foot) for foot in FEET]
    path = Waypoints(robot)
    view = look(stage, kettle, path) if "head" in robot.limbs else None
    pairs = avoidance_pairs(robot, hand)
    grasp = reach_handle(stage, kettle, hand, path, pairs)
    around = [(b, "kettle") for b in hand_bodies(robot, hand)]  # the hand around the handle
    held = Scene.from_robot(robot, grasps=[(hand.body, "kettle")], exclude=around)  # X_FO now
    lift_path, q_ik = lift(stage, kettle, hand, grasp.X_grasp)
    motion: dict[str, Any] = {}  # the motion's figures
    if speed:
        open_hand = Scene.from_robot(robot, exclude=around)
        first = "look, pre-grasp" if view is not None else "pre-grasp"
        parts = [
            (first, stage.scene, path),
            ("approach (open hand)", open_hand, grasp.path),
            ("lift (kettle in the hand)", held, lift_path),
        ]
        motion = play(stage, parts, speed, kettle, hand)
    # The final pose in physics, the kettle held in the hand by a weld.
    stage.hold_final_pose(hold, scene=held)
    result = stage.result
    result.main = "lift"
    result.figures = {
        **figures(robot, kettle, hand, view, grasp, feet0, q_ik, len(pairs)),
        **motion,
    }
    if view is None:
        result.messages.append("no head limb: no look, and the kettle is not kept in view")
    check(result, view, grasp_turn(hand, grasp.X_grasp, robot), kettle)
    return result


def look(stage: Stage, kettle: Kettle, path: Waypoints) -> HeadView:
    """Look at the handle with the chain from the root (waist and neck); what the head
    camera sees of it then, where the head has one (camera poses: ``mj_camlight``)."""
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
    head = set(robot.bodies("head"))
    cameras = [c for c in robot.cameras if robot.model.body(c.body_id).name in head]
    if not cameras:
        return HeadView(gaze, None)
    camera = cameras[0]
    mujoco.mj_camlight(robot.model, robot.data)
    pixel, depth = camera.project(robot.data, kettle.p_handle)
    centre = 0.5 * np.array([camera.intrinsics.width, camera.intrinsics.height])  # [px]
    seen = camera.visibility(robot.data, "kettle_handle")
    offset = float(np.linalg.norm(pixel - centre))
    return HeadView(gaze, (pixel, depth, camera.intrinsics.width, offset, seen))


def avoidance_pairs(robot: Robot, hand: Hand) -> list[GeomPair]:
    """The collision pairs of the arm and the trunk (the root body and the torso's
    links) against the counter, the kettle and each other, of those the arm's chain
    can move; pairs already within the orange distance at the start (neighbouring
    links of the shoulder and the wrist) are left to the joint limits."""
    trunk = [robot.root_body, *(robot.bodies("torso") if "torso" in robot.limbs else [])]
    links = list(dict.fromkeys([*robot.bodies(ARM), *trunk]))
    pairs = collision_pairs(robot.model, robot.data, links, ["counter", "kettle"], touching=ORANGE)
    return moving_pairs(robot.model, pairs, robot.joint_list(hand.frame, hand.frame_type))


def hand_bodies(robot: Robot, hand: Hand) -> list[str]:
    """The hand's body and the wrist it hangs from (its parent): what closes around
    the handle."""
    m = robot.model
    return [hand.body, m.body(int(m.body_parentid[m.body(hand.body).id])).name]


def avoid(robot: Robot, pairs: list[GeomPair]) -> CollisionAvoidanceTask:
    """Collision avoidance of ``pairs``: yellow zone ``YELLOW``, orange ``ORANGE``. It
    bounds the levels below it and is left out of the stop test: a pair of the
    robot's own links that starts inside the orange zone is kept at its start
    distance, to within the drift of one linearized step."""
    return CollisionAvoidanceTask(
        robot.configuration, pairs, yellow=YELLOW, orange=ORANGE, gain=GAIN, check=False
    )


def reach_handle(
    stage: Stage, kettle: Kettle, hand: Hand, path: Waypoints, pairs: list[GeomPair]
) -> Grasp:
    """The hand to the pre-grasp position, then onto the handle, in the grasp
    orientation, the kettle in view; the approach leaves out the hand's pairs with
    the kettle (the handle ends inside the hand)."""
    robot = stage.robot
    # the grip axis along the bar, the palm facing it from the arm's side
    R_grasp = hand.rotation(kettle.R_handle[:, 2], kettle.inward)
    m = robot.model
    hand_ids = {m.body(b).id for b in hand_bodies(robot, hand)}
    kettle_body = m.body("kettle").id
    handle = {m.geom(g).id for g in HANDLE}
    # the hand around the handle: its and its wrist's pairs with the kettle, the arm's
    # with the handle
    inside = [
        p
        for p in pairs
        if (
            {m.geom_bodyid[p.geom1], m.geom_bodyid[p.geom2]} & hand_ids
            and kettle_body in (m.geom_bodyid[p.geom1], m.geom_bodyid[p.geom2])
        )
        or {p.geom1, p.geom2} & handle
    ]
    head = "head" in robot.limbs
    options = dict(
        move_targets=[hand.frame],
        rotation_axis=[Hand.name(hand.grip)],
        look_at=kettle.p_center if head else None,
        stop=200,
        trust_region=STEPS,
    )
    stage.solve(
        fullbody_inverse_kinematics,
        "pre-grasp",
        [(kettle.pre_grasp(hand), R_grasp)],
        path=path,
        collision_avoidance=avoid(robot, pairs),
        **options,
    )
    X_pre = hand.pose(robot)
    approach = Waypoints(robot, "approach")
    stage.solve(
        fullbody_inverse_kinematics,
        "approach",
        [(kettle.p_handle, R_grasp)],
        path=approach,
        collision_avoidance=avoid(robot, [p for p in pairs if p not in inside]),
        avoid_world=GRASPED,
        **options,
    )
    gaze = gaze_angle(robot, kettle.p_center) if head else None
    return Grasp(approach, X_pre, hand.pose(robot), gaze)


def lift(
    stage: Stage, kettle: Kettle, hand: Hand, X_grasp: mink.SE3
) -> tuple[Waypoints, np.ndarray]:
    """The grasped hand lifted ``kettle.lift`` in the world, the bar kept vertical,
    the head looking at the kettle as it moves with the hand; then the kettle carried
    with the hand (:func:`carry`). Returns the lift's iterates and the
    kettle's coordinates the IK left (untouched)."""
    robot = stage.robot
    watch = stage.watch("lift", Waypoints(robot, "lift"))
    res = fullbody_inverse_kinematics(
        robot,
        [(kettle.p_handle + np.array([0.0, 0.0, kettle.lift]), X_grasp.rotation().wxyz)],
        move_targets=[hand.frame],
        rotation_axis=[Hand.name(hand.grip)],
        look_at=(lambda r: kettle.center_with(r, hand, X_grasp)) if "head" in robot.limbs else None,
        avoid_world=GRASPED,
        stop=100,
        trust_region=STEPS,
        callback=watch.callbacks,
    )
    q_ik = robot.configuration.q[kettle.adr : kettle.adr + 7].copy()
    carry(robot, kettle, hand, X_grasp)
    watch.keep(res)
    return watch.path, q_ik


def carry(robot: Robot, kettle: Kettle, hand: Hand, X_grasp: mink.SE3) -> None:
    """Set the kettle's free joint to its grasp-time pose in the hand, carried to the
    hand now: ``X_WO = X_WH X_WH(grasp)^-1 X_WO(0)``."""
    X_carried = hand.pose(robot) @ X_grasp.inverse() @ kettle.X_body
    q = robot.configuration.q.copy()
    q[kettle.adr : kettle.adr + 7] = np.r_[X_carried.translation(), X_carried.rotation().wxyz]
    robot.configuration.update(q)


def play(
    stage: Stage,
    parts: list[tuple[str, Scene, Waypoints]],
    speed: float,
    kettle: Kettle,
    hand: Hand,
) -> dict[str, Any]:
    """The motion in physics, part by part (``(label, scene, iterates)``), each from
    the state the last one ended in, with the head camera's view (where the robot has
    one and MuJoCo renders). Returns its figures: the arm's smallest distance to the
    counter, the kettle's moves before the grasp and in the lift."""
    model = stage.scene.model
    bodies = [model.body(b).id for b in stage.robot.bodies(ARM)]
    arm = collision_geoms(model, bodies).tolist()
    clearance = Clearance(model, arm, ["counter"])
    kettle_xyz = [kettle.qpos[:3]]  # at the start, after each part
    head = set(stage.robot.bodies("head")) if "head" in stage.robot.limbs else set()
    cameras = [
        Camera(model, c.name) for c in stage.robot.cameras if model.body(c.body_id).name in head
    ]
    log = stage.recorder.motion_logger(cameras=cameras[:1])
    part = None
    for label, scene, path in parts:
        part = stage.play(
            label, path, speed=speed, scene=scene, start=part, log=log, callback=[clearance]
        )
        kettle_xyz.append(part.final_state.qpos[kettle.adr : kettle.adr + 3].copy())
    return {
        "min_distance_arm_counter_reference_m": clearance.reference,
        "min_distance_arm_counter_physics_m": clearance.physics,
        "kettle_moved_before_the_grasp_physics_m": float(
            np.linalg.norm(kettle_xyz[2] - kettle_xyz[0])
        ),
        "kettle_lift_physics_m": kettle_xyz[3] - kettle_xyz[2],
    }


def grasp_turn(hand: Hand, X_grasp: mink.SE3, robot: Robot) -> float:
    """Angle [rad] between the hand's grip axis at the grasp and now."""
    bar = [hand.axis(X, hand.grip) for X in (X_grasp, hand.pose(robot))]
    return float(np.arccos(np.clip(bar[0] @ bar[1], -1, 1)))


def figures(
    robot: Robot,
    kettle: Kettle,
    hand: Hand,
    view: HeadView | None,
    grasp: Grasp,
    feet0: list[mink.SE3],
    q_ik: np.ndarray,
    pairs: int,
) -> dict[str, Any]:
    """The measures of the final pose: the hand at the handle and lifted, the gaze,
    the handle in the head camera, the feet and the kettle."""
    X_grasp, X_lift = grasp.X_grasp, hand.pose(robot)
    X_kettle = robot.frame_pose("kettle", "body")
    X_in_hand = [X.inverse() @ Y for X, Y in ((X_grasp, kettle.X_body), (X_lift, X_kettle))]
    out: dict[str, Any] = {
        "model": str(robot.source.model),
        "kettle_scale": kettle.scale,
        "handle_m": kettle.p_handle,
        "pre_grasp_error_m": float(
            np.linalg.norm(grasp.X_pre.translation() - kettle.pre_grasp(hand))
        ),
        "pre_grasp_back_off_m": kettle.back_off(hand),
        "grasp_error_m": float(np.linalg.norm(X_grasp.translation() - kettle.p_handle)),
        "hand_grip_axis_vs_handle_bar_rad": float(
            np.arccos(np.clip(hand.axis(X_grasp, hand.grip) @ kettle.R_handle[:, 2], -1, 1))
        ),
        "lift_m": X_lift.translation() - X_grasp.translation(),
        "lift_rotation_change_rad": float(
            np.linalg.norm((X_grasp.rotation().inverse() @ X_lift.rotation()).log())
        ),
        "feet_moved_m": largest_move(feet0, [end_pose(robot, foot) for foot in FEET]),
        "kettle_qpos_changed_by_ik": float(np.abs(q_ik - kettle.qpos).max()),
        "kettle_lift_m": X_kettle.translation() - kettle.X_body.translation(),
        "kettle_tilt_rad": float(
            np.arccos(np.clip(X_kettle.rotation().as_matrix()[2, 2], -1.0, 1.0))
        ),
        "kettle_in_hand_change_m": float(
            np.linalg.norm(X_in_hand[1].translation() - X_in_hand[0].translation())
        ),
        "com_margin_m": com_margin(robot),
        "avoidance_pairs": pairs,
    }
    if view is not None:
        out["gaze_angle_after_look_deg"] = np.rad2deg(view.gaze)
        out["gaze_angle_after_grasp_deg"] = np.rad2deg(grasp.gaze)
        out["gaze_angle_after_lift_deg"] = np.rad2deg(
            gaze_angle(robot, kettle.center_with(robot, hand, X_grasp))
        )
    if view is not None and view.camera is not None:
        pixel, depth, width, offset, seen = view.camera
        out["handle_pixel_after_look_px"] = pixel
        out["handle_offset_from_image_centre_px"] = offset
        out["image_width_px"] = width
        out["handle_depth_m"] = depth
        out["handle_visible_after_look"] = seen.visible
    return out


def check(result: ScenarioResult, view: HeadView | None, grasp_turn: float, kettle: Kettle) -> None:
    """The scenario's checks on its figures; ``view``: what the head saw after the
    look (None: no head), ``grasp_turn``: angle [rad] of the hand's grip axis from the
    grasp to now."""
    f = result.figures
    d, lift = f["lift_m"], kettle.lift
    for label in result.solves:
        result.check(f"{label} converged", result.solves[label].converged)
    result.check(
        f"pre-grasp: the hand {f['pre_grasp_back_off_m']:.3g} m before the handle (1 mm)",
        f["pre_grasp_error_m"] <= 1e-3,
    )
    result.check("hand at the handle (1 mm)", f["grasp_error_m"] <= 1e-3)
    result.check(
        "hand's grip axis along the bar (1°)",
        f["hand_grip_axis_vs_handle_bar_rad"] <= np.deg2rad(1.0),
    )
    result.check(
        f"lifted {lift:.3g} m straight up (1 mm)",
        abs(d[2] - lift) <= 1e-3 and np.linalg.norm(d[:2]) <= 1e-3,
        f"{d}",
    )
    result.check("grasp kept while lifting (grip axis within 1°)", grasp_turn <= np.deg2rad(1.0))
    if view is not None:
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
        "feet did not move (0.1 mm) and kettle untouched by the IK",
        f["feet_moved_m"] <= 1e-4 and f["kettle_qpos_changed_by_ik"] <= 1e-5,
    )
    result.check(
        f"kettle carried with the hand (pose in the hand kept, 1 µm), lifted {lift:.3g} m "
        "(2 mm) and upright (1°)",
        f["kettle_in_hand_change_m"] <= 1e-6
        and abs(f["kettle_lift_m"][2] - lift) <= 2e-3
        and f["kettle_tilt_rad"] <= np.deg2rad(1.0),
        f"{f['kettle_lift_m']}",
    )
    result.check("CoM over the feet", f["com_margin_m"] > 0, f"margin {f['com_margin_m']:.3f} m")
    if "image_width_px" in f:
        offset = f["handle_offset_from_image_centre_px"] / f["image_width_px"]
        result.check(
            f"head camera after the look: the handle within {CENTRED:.0%} of the image "
            "width of its centre, not occluded",
            offset <= CENTRED and f["handle_visible_after_look"],
            f"{offset:.1%} of the width",
        )
    if "kettle_lift_physics_m" in f:
        check_motion(result, kettle)


def check_motion(result: ScenarioResult, kettle: Kettle) -> None:
    """The motion's checks: the arm clear of the counter, the kettle still until the
    grasp and lifted by the physical hand."""
    f = result.figures
    reference = f["min_distance_arm_counter_reference_m"]
    physics = f["min_distance_arm_counter_physics_m"]
    result.check(
        "motion: the arm clear of the counter (reference: the orange distance "
        f"{ORANGE * 1e3:g} mm; physics: > 0)",
        reference >= ORANGE - 1e-3 and physics > 0,
        f"reference {reference * 1e3:.1f} mm, physics {physics * 1e3:.1f} mm",
    )
    lifted, moved = f["kettle_lift_physics_m"], f["kettle_moved_before_the_grasp_physics_m"]
    result.check(
        "motion: the kettle stays on the counter until the grasp (1 mm), then the "
        f"physical hand lifts it {kettle.lift:.3g} m (1 cm)",
        moved <= 1e-3 and abs(lifted[2] - kettle.lift) <= 1e-2,
        f"moved {moved * 1e3:.2f} mm before; lifted {lifted}",
    )


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__, robot=ROBOT, description=True).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, **run_options(args))
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
