"""A hand on the wall: the SCFR of three contacts (prioritized-IK manual ``centroid-scfr-task``).

A wall is built before the robot (:func:`pik_mj.scenario.scenes.wall_scene`): its
face 0.75 L ahead of the shoulders, L the arm's length. The right palm is put flat
on the wall :data:`HAND_ABOVE_SHOULDER` arm lengths above the shoulder, straight
ahead of it (the palm's normal into the wall, the rotation about it free; the hand:
:class:`pik_mj.scenario.Hand`; an arm of fewer than :data:`FLAT_JOINTS` joints, which
cannot set the palm's normal besides its position, touches the wall at a point, the
hand's orientation free); the feet stay. The balance task of level 1 is the
static centroid feasible region of the three contacts (two soles on the floor, μ =
0.8; the palm on the wall, μ = 0.5), and a lower level asks the CoM to lean
:data:`LEAN` of the way from the toes to the wall — outside the feet's support
polygon, which only the wall contact makes statically possible. The pose is checked
independently by the static-equilibrium LP: contact wrenches within their friction
cones and CoP limits hold the robot. The iterates are played in physics: the wall
pushes on the hand (MuJoCo's contact forces, ``mj_contactForce``) only once the
palm reaches it, and at the end; where the hand has a touch sensor (a bumper) it
reads off until then and on at the end.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import mujoco
import numpy as np

from pik_mj import (
    CentroidTask,
    CollisionAvoidanceTask,
    Recorder,
    Robot,
    Scene,
    ScfrTask,
    SolveResult,
    Waypoints,
    WorldAvoidance,
    fullbody_inverse_kinematics,
)
from pik_mj.balance import ContactConstraint, contact_from_normal, foot_contact, static_equilibrium
from pik_mj.robot.ground import sole_polygons
from pik_mj.robot.sensors import SensorTrace
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    Hand,
    RobotOption,
    ScenarioResult,
    Stage,
    Stature,
    com_margin,
    open_recorder,
    parser,
    report,
    robot_in,
    run_options,
)
from pik_mj.scenario.scenes import wall_scene
from pik_mj.sim.clearance import min_distance
from pik_mj.solve import TrustRegion
from pik_mj.spatial import yaw_of
from pik_mj.tasks.collision import collision_pairs

NAME = "wall_contact"
ARM = "rarm"
OTHER_ARM = "larm"
FEET = ("rleg", "lleg")
ROBOT = RobotOption("sample_humanoid", (ARM, *FEET), floating_base=True)
HAND_ABOVE_SHOULDER = 0.1  # [arm lengths] the palm's centre above the shoulder
LEAN = 0.35  # the CoM's target past the toes: this fraction of the way to the wall
LEAN_MET = 0.5  # the lean is met within this share of its way past the toes
FLAT_JOINTS = 5  # an arm sets its hand's position and palm normal (5 numbers) with 5 joints
TOUCHING = 1e-3  # [m] hand-wall distance at which the palm is on the wall
# Solves that bring a hand touching at a point onto the wall (its orientation free, its
# geometry's reach towards the wall is known only after the solve): each moves the
# hand frame's target into the wall by the gap MuJoCo measures.
ONTO_WALL = 3
PALM_ONTO = "hand onto the wall"
LEAN_ONTO = "lean on the wall, onto it"
# The first trust radius of 1: the palm's solve then ends with the forearm clear of
# the wall by the lean's clearance, so that the lean's avoidance holds from its start.
STEPS = TrustRegion(radius=1.0)
# The wall is a planned contact (the palm on it); the lean keeps the arm and head off it.
PALM_ON_WALL = WorldAvoidance(allowed=["wall"])


@dataclass(frozen=True)
class Palm:
    """The flat of a hand: how far its face is from the hand frame and how large it is.

    Attributes:
        offset: Distance [m] from the hand frame to the palm's face along the palm's
            normal: the farthest the hand's geometry reaches along it.
        half_size: Half the palm's size [m] across the normal: the nearest its
            geometry ends from the hand frame along the two other axes, either way.
    """

    offset: float
    half_size: float

    @classmethod
    def of(cls, robot: Robot, hand: Hand) -> Palm:
        """The palm of ``hand`` from its collision geoms' bounding boxes (MuJoCo's
        ``geom_aabb``, in each geom's frame): the support of the geoms along a unit
        axis ``u`` of the hand frame, ``max_g (p_G - p_H)·u + c_G·u_G + |u_G|·h_G``."""
        m, d = robot.model, robot.data
        X_WH = hand.pose(robot)
        R_WH = X_WH.rotation().as_matrix()

        def reach(u: np.ndarray) -> float:
            out = 0.0
            for g in hand.geoms(m):
                u_G = d.geom_xmat[g].reshape(3, 3).T @ u
                centre, half = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
                p = (d.geom_xpos[g] - X_WH.translation()) @ u + centre @ u_G
                out = max(out, float(p + np.abs(u_G) @ half))
            return out

        k, sign = hand.palm
        across = [reach(s * R_WH[:, j]) for j in range(3) if j != k for s in (1.0, -1.0)]
        return cls(offset=reach(sign * R_WH[:, k]), half_size=min(across))


@dataclass(frozen=True)
class WallSupport:
    """Where the palm goes on the wall, and the contacts the robot then leans on.

    Attributes:
        hand: The hand that touches the wall.
        flat: Whether the palm is put flat on the wall (an arm of at least
            :data:`FLAT_JOINTS` joints); else the hand touches it at a point, its
            orientation free, the hand frame the radius of the hand's ball
            (:attr:`Hand.radius`) off the wall.
        p_palm: The palm's centre on the wall [m], above the shoulder.
        p_hand: The hand frame's target [m]: the palm's offset off the wall.
        R_hand: The hand's orientation: the palm's normal into the wall (matched
            when ``flat``).
        n_wall: Direction of the wall's push on the palm (the wall's normal).
        contacts: The soles (μ = 0.8) and the palm (μ = 0.5; a point unless
            ``flat``).
        toes: The toes' coordinate [m] along the robot's forward axis.
        lean: The CoM's target [m]: ``LEAN`` of the way from the toes to the wall,
            between the feet.
    """

    hand: Hand
    flat: bool
    p_palm: np.ndarray
    p_hand: np.ndarray
    R_hand: np.ndarray
    n_wall: np.ndarray
    contacts: list[ContactConstraint]
    toes: float
    lean: np.ndarray

    @classmethod
    def facing(cls, robot: Robot) -> WallSupport:
        """The support of ``robot`` standing before the wall."""
        stature = Stature.of(robot)
        hand = stature.hands[ARM]
        flat = len(robot.limb(ARM).joints) >= FLAT_JOINTS
        palm = Palm.of(robot, hand) if flat else Palm(offset=hand.radius, half_size=0.0)
        wall = robot.frame_pose("wall", "geom")
        n_wall = wall.rotation().as_matrix()[:, 0]  # the wall's x: out of its face
        face = wall.translation() + robot.model.geom("wall").size[0] * n_wall
        p_palm = stature.from_shoulder(ARM, [0.0, 0.0, HAND_ABOVE_SHOULDER])
        p_palm += ((face - p_palm) @ n_wall) * n_wall  # onto the wall's face
        R_hand = hand.rotation(grip=stature.direction([0.0, 1.0, 0.0]), palm=-n_wall)
        length, width = stature.sole
        yaw = yaw_of(stature.R_WR)
        centres = [sole_centre(stature, poly) for poly in sole_polygons(robot, FEET)]
        contacts = [foot_contact(p, yaw, length / 2, width / 2, mu=0.8) for p in centres]
        contacts.append(contact_from_normal(p_palm, n_wall, palm.half_size, palm.half_size, 0.5))
        toes = max(stature.to_robot(p)[0] for p in centres) + length / 2
        middle = stature.to_robot(0.5 * (centres[0] + centres[1]))
        ahead = stature.to_robot(face)[0]
        lean = stature.to_world([toes + LEAN * (ahead - toes), middle[1], 0.0])
        p_hand = p_palm + palm.offset * n_wall
        return cls(hand, flat, p_palm, p_hand, R_hand, n_wall, contacts, toes, lean)

    @property
    def rotation_axis(self) -> list[str] | None:
        """The hand target's ``rotation_axis``: the palm's normal matched, the rotation
        about it free (``flat``); else None: position only."""
        return [Hand.name(self.hand.palm)] if self.flat else None


def sole_centre(stature: Stature, polygon: np.ndarray) -> np.ndarray:
    """The centre [m] of a sole polygon's extent in the robot's frame, at its lowest
    point's height."""
    local = np.array([stature.to_robot(p) for p in polygon])
    centre = 0.5 * (local.min(axis=0) + local.max(axis=0))
    centre[2] = local[:, 2].min()
    return stature.to_world(centre)


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
    """Build the wall before the robot, put the palm on it, lean, play and hold.
    ``robot``: the robot already built from ``model`` and ``description`` (alone),
    else None: built here."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=ROBOT.limbs)
    robot = robot_in(robot, wall_scene(Stature.of(robot)), NAME)
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    support = WallSupport.facing(robot)
    path = Waypoints(robot, "hand to the wall")
    # First the palm to the wall, the CoM over the feet (a lean before the hand is
    # there would fall into the wall), then the lean with the wall's support.
    palm_to_wall(stage, support, path)
    support, _ = onto_wall(
        stage, support, lambda s, label: palm_to_wall(stage, s, path, label), PALM_ONTO
    )
    scfr_task, lean = lean_on_wall(stage, support, path)
    support, again = onto_wall(
        stage, support, lambda s, label: lean_on_wall(stage, s, path, label), LEAN_ONTO
    )
    if again is not None:
        scfr_task, lean = again
    trace = play(stage, support.hand, path, speed) if speed else None
    # The final pose in physics; the palm on the wall is an intended contact.
    stage.hold_final_pose(hold)
    result = stage.result
    result.main = list(result.solves)[-1]
    result.figures = figures(robot, support, scfr_task, lean)
    check(result)
    if trace is not None:
        check_contact(result, trace)
    return result


def wall_avoidance(robot: Robot, hand: Hand) -> list[CollisionAvoidanceTask]:
    """The robot but its hand kept off the wall: both arms and the head 2 cm off it (a
    forearm dragged along the wall sticks to it and pulls the robot off its reference;
    the other arm, held by its servos, sags towards the wall as the robot leans), the
    other bodies 1 cm (the hips come near the wall as the robot leans)."""
    m, d = robot.model, robot.data
    upper = [b for b in robot.bodies(ARM) if b != hand.body]
    upper += robot.bodies(OTHER_ARM) if OTHER_ARM in robot.limbs else []
    upper += robot.bodies("head") if "head" in robot.limbs else []
    rest = [b for b in robot.bodies() if b not in upper and b != hand.body]
    return [
        CollisionAvoidanceTask(
            robot.configuration, collision_pairs(m, d, upper, ["wall"]), yellow=0.06, orange=0.02
        ),
        CollisionAvoidanceTask(
            robot.configuration,
            collision_pairs(m, d, rest, ["wall"]),
            yellow=0.03,
            orange=0.01,
            name="body off the wall",
        ),
    ]


def hand_off_wall(robot: Robot, support: WallSupport) -> list[CollisionAvoidanceTask]:
    """A hand touching at a point (not ``flat``) onto the wall, not through it: its
    geoms' pairs with the wall kept at a distance >= 0 (orange 0), the steps slowed
    within the yellow distance, so that the path played reaches the wall without
    passing into it. None for a flat palm (its orientation set, its face onto the wall)."""
    if support.flat:
        return []
    m = robot.model
    pairs = [(m.geom(g).name, "wall") for g in support.hand.geoms(m) if m.geom(g).name]
    return [
        CollisionAvoidanceTask(
            robot.configuration,
            pairs,
            yellow=0.06,
            orange=0.0,
            check=False,
            name="hand onto the wall",
        )
    ]


def body_avoidance(robot: Robot) -> CollisionAvoidanceTask:
    """The arm kept off the body: the pairs between the arm's bodies, the root body,
    the torso's and the head's, and the legs' first links (pairs within 1 cm at the
    start dropped)."""
    links = [*robot.bodies(ARM), robot.root_body]
    links += [b for limb in ("torso", "head") if limb in robot.limbs for b in robot.bodies(limb)]
    links += [robot.limb(leg).root_body for leg in FEET]
    pairs = collision_pairs(robot.model, robot.data, list(dict.fromkeys(links)), touching=0.01)
    return CollisionAvoidanceTask(
        robot.configuration, pairs, yellow=0.06, orange=0.01, name="arm off the body"
    )


def palm_to_wall(
    stage: Stage, support: WallSupport, path: Waypoints, label: str = "hand to the wall"
) -> SolveResult:
    """The right palm flat on the wall, rotation about its normal free; the arm kept
    off the body, a hand touching at a point kept from passing into the wall
    (:func:`hand_off_wall`)."""
    return stage.solve(
        fullbody_inverse_kinematics,
        label,
        [(support.p_hand, support.R_hand)],
        path=path,
        total=100,
        limbs=[ARM],
        move_targets=[support.hand.frame],
        rotation_axis=support.rotation_axis,
        collision_avoidance=[body_avoidance(stage.robot), *hand_off_wall(stage.robot, support)],
        avoid_world=PALM_ON_WALL,
        stop=100,
        trust_region=STEPS,
    )


def lean_on_wall(
    stage: Stage, support: WallSupport, path: Waypoints, label: str = "lean on the wall"
) -> tuple[ScfrTask, SolveResult]:
    """The palm kept on the wall, every joint free, the CoM in the SCFR of the three
    contacts (level 1) and leaning past the toes (a lower level, met within
    :data:`LEAN_MET` of its way past the toes); the rest of the robot kept off the wall
    (:func:`wall_avoidance`) and the arm off the body (:func:`body_avoidance`). Returns
    the SCFR task and the solve's result."""
    robot, hand = stage.robot, support.hand
    scfr_task = ScfrTask(
        robot.configuration, support.contacts, root_body=robot.root_body, margin=0.01
    )
    past_toes = Stature.of(robot).to_robot(support.lean)[0] - support.toes
    lean_task = CentroidTask(
        robot.configuration,
        support.lean,
        root_body=robot.root_body,
        centroid_thre=LEAN_MET * past_toes,
    )
    res = stage.solve(
        fullbody_inverse_kinematics,
        label,
        [(support.p_hand, support.R_hand)],
        path=path,
        total=100,
        start=False,
        limbs=[ARM],
        joints="all",  # the other arm too: held, it swings into the wall as the robot leans
        move_targets=[hand.frame],
        rotation_axis=support.rotation_axis,
        balance=[scfr_task],
        collision_avoidance=[*wall_avoidance(robot, hand), body_avoidance(robot)],
        avoid_world=PALM_ON_WALL,
        extra_levels=[[lean_task]],
        stop=100,
        trust_region=STEPS,
    )
    return scfr_task, res


def hand_gap(robot: Robot, hand: Hand) -> float:
    """The hand's distance [m] to the wall (MuJoCo's ``mj_geomDistance`` over its
    collision geoms) in the robot's configuration."""
    m = robot.model
    return min_distance(m, robot.data, hand.geoms(m), [m.geom("wall").id], 0.1)


def onto_wall(
    stage: Stage, support: WallSupport, solve: Callable[[WallSupport, str], Any], label: str
) -> tuple[WallSupport, Any]:
    """A hand touching at a point (not ``flat``) brought onto the wall: while its
    geometry ends more than ``TOUCHING / 2`` off it (at most :data:`ONTO_WALL`
    times), the hand frame's target moves into the wall by that gap and
    ``solve(support, label)`` solves again from there. Returns the support with its
    last target and the last solve's return (None: none was needed)."""
    out = None
    for _ in range(ONTO_WALL):
        gap = hand_gap(stage.robot, support.hand)
        if support.flat or gap <= TOUCHING / 2:
            break
        support = replace(support, p_hand=support.p_hand - gap * support.n_wall)
        out = solve(support, label)
    return support, out


class WallTouch:
    """The hand on the wall along a motion: a callback of
    :meth:`pik_mj.sim.Scene.play`.

    Attributes:
        bumpers: The robot's touch sensors' readings (:class:`SensorTrace`).
        gap: The hand's distance to the wall per sample [m] (MuJoCo's
            ``mj_geomDistance``; negative: penetrating).
        force: The wall's push on the hand per sample [N]: the sum of the normal
            forces of the contacts between the hand's geoms and the wall
            (``mj_contactForce``).
    """

    def __init__(self, stage: Stage, hand: Hand):
        model = stage.scene.model
        self.bumpers = SensorTrace(stage.robot.sensors())
        self.geoms = hand.geoms(model)
        self.wall = model.geom("wall").id
        self.gap: list[float] = []
        self.force: list[float] = []

    def __call__(self, sample: Any) -> None:
        self.bumpers(sample)
        m, d = sample.model, sample.data
        self.gap.append(min_distance(m, d, self.geoms, [self.wall], 0.1))
        ncon = int(d.ncon)
        geom = d.contact.geom[:ncon]
        ours = np.isin(geom, self.geoms).any(axis=1) & (geom == self.wall).any(axis=1)
        f6, total = np.zeros(6), 0.0
        for i in np.flatnonzero(ours):
            mujoco.mj_contactForce(m, d, int(i), f6)
            total += f6[0]  # the normal force, in the contact's frame
        self.force.append(total)


def play(stage: Stage, hand: Hand, path: Waypoints, speed: float) -> WallTouch:
    """The iterates as a motion in physics; the hand's touch on the wall."""
    touch = WallTouch(stage, hand)
    stage.play("hand on the wall, lean", path, speed=speed, callback=[touch])
    return touch


def figures(
    robot: Robot, support: WallSupport, scfr_task: ScfrTask, lean: SolveResult
) -> dict[str, Any]:
    """The measures of the final pose: the palm on the wall, the CoM in the SCFR and
    past the toes, the static equilibrium with and without the wall."""
    com = robot.com()
    region = scfr_task.region(robot.configuration)
    g = robot.model.opt.gravity
    eq = static_equilibrium(support.contacts, robot.mass, com, gravity=g)
    eq_feet = static_equilibrium(support.contacts[:2], robot.mass, com, gravity=g)
    hand = support.hand.pose(robot)
    palm = support.hand.axis(hand, support.hand.palm)
    n_wall = support.n_wall
    return {
        "palm_target_m": support.p_palm,
        "palm_flat": support.flat,
        "hand_error_m": float(np.linalg.norm(hand.translation() - support.p_hand)),
        "hand_wall_gap_m": hand_gap(robot, support.hand),
        "palm_normal_misalignment_rad": float(np.arccos(np.clip(palm @ -n_wall, -1, 1))),
        "com_m": com,
        "com_scfr_margin_m": float(region.signed_distance(com[:2])),
        "com_support_polygon_margin_m": com_margin(robot),
        "com_past_toes_m": float(Stature.of(robot).to_robot(com)[0] - support.toes),
        "equilibrium_with_wall": eq.feasible,
        "equilibrium_feet_only": eq_feet.feasible,
        "wall_normal_force_N": None if eq.wrenches is None else float(eq.wrenches[2, :3] @ n_wall),
        "scfr_regions_computed": scfr_task.region_computations,
        "median_iteration_ms": lean.median_iteration_ms,
    }


def check(result: ScenarioResult) -> None:
    """The scenario's checks on its solves and figures."""
    f = result.figures
    for label in ("hand to the wall", PALM_ONTO, "lean on the wall", LEAN_ONTO):
        if label not in result.solves:
            continue
        res = result.solves[label]
        result.check(f"{label}: converged", res.converged, f"{res.iterations} iterations")
    if f["palm_flat"]:
        result.check(
            "palm on the wall (1 mm, 1°)",
            f["hand_error_m"] <= 1e-3 and f["palm_normal_misalignment_rad"] <= np.deg2rad(1),
        )
    else:
        result.check(
            "hand on the wall (1 mm; a point: the arm sets no palm)", f["hand_error_m"] <= 1e-3
        )
    result.check("CoM inside the SCFR (margin 1 cm)", f["com_scfr_margin_m"] >= 0.01 - 1e-3)
    result.check("CoM outside the feet's support polygon", f["com_support_polygon_margin_m"] < 0)
    result.check("static equilibrium LP: feasible with the wall", bool(f["equilibrium_with_wall"]))
    result.check(
        "static equilibrium LP: infeasible on the feet alone", not f["equilibrium_feet_only"]
    )


def check_contact(result: ScenarioResult, touch: WallTouch) -> None:
    """The motion's figures and checks: the wall pushes on the hand (and the hand's
    bumper reads on) only once the palm is on it, and does at the end."""
    f = result.figures
    if not touch.gap:  # the motion was not played (its check says why)
        result.check("the wall pushes on the hand once it is on it", False, "motion not played")
        return
    t = np.array(touch.bumpers.time)
    away = np.array(touch.gap) > TOUCHING
    pushed = np.array(touch.force) > 0.0
    reached = np.flatnonzero(~away)
    f["hand_reaches_wall_s"] = float(t[reached[0]]) if reached.size else None
    f["wall_push_end_N"] = touch.force[-1]
    f["wall_push_while_away"] = int(np.count_nonzero(pushed & away))
    f["samples_away_from_wall"] = int(np.count_nonzero(away))
    result.check(
        f"the wall pushes on the hand only once it is on it (> {TOUCHING * 1e3:g} mm: none), "
        "and at the end (MuJoCo's contact forces)",
        bool(away.any()) and not (pushed & away).any() and bool(pushed[-1]),
        f"{f['wall_push_end_N']:.1f} N at the end, hand on the wall at "
        f"{f['hand_reaches_wall_s']} s",
    )
    for bumper in result.robot.sensors(ARM).bumpers:
        name = bumper.name
        on = np.array(touch.bumpers.on[name])
        f[f"{name}_first_on_s"] = touch.bumpers.first_on(name)
        f[f"{name}_force_end_N"] = touch.bumpers.force[name][-1]
        result.check(
            f"bumper {name} off while the hand is away from the wall, on at the end",
            bool(away.any()) and not (on & away).any() and bool(on[-1]) and not away[-1],
            f"{int(np.count_nonzero(on & away))} of {f['samples_away_from_wall']} samples on "
            f"while away; {f[f'{name}_force_end_N']:.1f} N at the end",
        )


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__, robot=ROBOT, description=True).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, **run_options(args))
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
