"""A hand on the wall: the SCFR of three contacts (prioritized-IK manual ``centroid-scfr-task``).

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

from dataclasses import dataclass
from typing import Any

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
from pik_mj.robot.ground import sole_size
from pik_mj.robot.sensors import SensorTrace
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    RobotOption,
    ScenarioResult,
    Stage,
    Stature,
    com_margin,
    end_pose,
    open_recorder,
    parser,
    report,
)
from pik_mj.sim.motion import min_distance
from pik_mj.solve import TrustRegion
from pik_mj.spatial import yaw_of
from pik_mj.tasks.collision import collision_pairs

NAME = "wall_contact"
PALM = (0.045, 0.06)  # [m] half sizes of the palm (hand box x, z)
PALM_OFFSET = 0.02  # [m] from the hand site to the palm face (hand box half thickness)
LEAN = 0.1  # [m] CoM target past the toes
ARM = "rarm"
TOUCHING = 1e-3  # [m] hand-wall distance at which the palm is on the wall
# The first trust radius of 1: the palm's solve then ends with the forearm clear of
# the wall by the lean's clearance, so that the lean's avoidance holds from its start.
STEPS = TrustRegion(radius=1.0)
FEET = ("rleg", "lleg")


def hand_bumper(robot: Robot) -> str | None:
    """Why ``robot`` cannot tell its palm on the wall, or None: the scenario reads a
    touch sensor on the right hand."""
    if not robot.sensors(ARM).bumpers:
        return "its right hand has no touch sensor, which tells the palm on the wall"
    return None


ROBOT = RobotOption("sample_humanoid", (ARM, *FEET), floating_base=True, requires=hand_bumper)
# The wall is a planned contact (the palm on it); the lean keeps the arm and head off it.
PALM_ON_WALL = WorldAvoidance(allowed=["wall"])


@dataclass(frozen=True)
class WallSupport:
    """Where the palm goes on the wall, and the contacts the robot then leans on.

    Attributes:
        p_palm: The palm's centre on the wall [m], below the shoulder.
        p_site: The hand site's target [m]: ``PALM_OFFSET`` off the wall.
        R_hand: The hand's orientation: y (palm normal) into the wall, z (towards
            the elbow) down.
        n_wall: Direction of the wall's push on the palm (the wall's normal).
        contacts: The soles (μ = 0.8) and the palm (μ = 0.5).
        toes: The toes' y [m] (the wall is ahead along y).
        lean: The CoM's target [m]: ``LEAN`` past the toes, between the feet in x.
    """

    p_palm: np.ndarray
    p_site: np.ndarray
    R_hand: np.ndarray
    n_wall: np.ndarray
    contacts: list[ContactConstraint]
    toes: float
    lean: np.ndarray

    @classmethod
    def facing(cls, robot: Robot) -> WallSupport:
        """The support of ``robot`` standing before the wall."""
        wall = robot.frame_pose("wall", "geom")
        y_wall = wall.translation()[1] - robot.model.geom("wall").size[1]  # wall face [m]
        n_wall = np.array([0.0, -1.0, 0.0])  # the wall pushes the robot back
        shoulder = robot.frame_pose(robot.limb(ARM).root_body, "body").translation()
        p_palm = np.array([shoulder[0], y_wall, shoulder[2] - 0.05])
        R_hand = np.column_stack(
            [np.cross([0.0, 1.0, 0.0], [0.0, 0.0, -1.0]), [0, 1, 0], [0, 0, -1]]
        )
        feet = [end_pose(robot, f) for f in FEET]
        yaw = yaw_of(feet[0].rotation().as_matrix())
        sole = 0.5 * np.array(sole_size(robot))  # [m] half length and width
        contacts = [foot_contact(f.translation(), yaw, *sole, mu=0.8) for f in feet]
        contacts.append(contact_from_normal(p_palm, n_wall, *PALM, mu=0.5))
        toes = max(f.translation()[1] for f in feet) + sole[0]  # the sites: the sole centres
        x_mid = 0.5 * (feet[0].translation()[0] + feet[1].translation()[0])
        lean = np.array([x_mid, toes + LEAN, 0.0])
        return cls(p_palm, p_palm + PALM_OFFSET * n_wall, R_hand, n_wall, contacts, toes, lean)


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
    """Put the palm on the wall, lean, play and hold. ``robot``: the robot already
    built from ``model`` and ``description`` (alone), else None: built here."""
    if robot is not None:
        model, description = robot.source.model, robot.source.description
    robot = Robot.from_model(
        model,
        description=description,
        environment="room",
        at="spot_wall",
        required_limbs=ROBOT.limbs,
    )
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    support = WallSupport.facing(robot)
    path = Waypoints(robot, "hand to the wall")
    # First the palm to the wall, the CoM over the feet (a lean before the hand is
    # there would fall into the wall), then the lean with the wall's support.
    palm_to_wall(stage, support, path)
    scfr_task, lean = lean_on_wall(stage, support, path)
    trace = play(stage, path, speed) if speed else None
    # The final pose in physics; the palm on the wall is an intended contact.
    stage.hold_final_pose(hold)
    result = stage.result
    result.main = "lean on the wall"
    result.figures = figures(robot, support, scfr_task, lean)
    check(result)
    if trace is not None:
        check_bumper(result, *trace)
    return result


def palm_to_wall(stage: Stage, support: WallSupport, path: Waypoints) -> SolveResult:
    """The right palm flat on the wall, rotation about its normal free."""
    return stage.solve(
        fullbody_inverse_kinematics,
        "hand to the wall",
        [(support.p_site, support.R_hand)],
        path=path,
        total=100,
        limbs=[ARM],
        rotation_axis=["y"],
        avoid_world=PALM_ON_WALL,
        stop=100,
        trust_region=STEPS,
    )


def lean_on_wall(
    stage: Stage, support: WallSupport, path: Waypoints
) -> tuple[ScfrTask, SolveResult]:
    """The palm kept on the wall, the CoM in the SCFR of the three contacts (level 1)
    and leaning past the toes (a lower level); the arm and head keep 2 cm off the
    wall (a forearm dragged along the wall sticks to it and pulls the robot off its
    reference). Returns the SCFR task and the solve's result."""
    robot = stage.robot
    scfr_task = ScfrTask(
        robot.configuration, support.contacts, root_body=robot.root_body, margin=0.01
    )
    lean_task = CentroidTask(
        robot.configuration, support.lean, root_body=robot.root_body, check=False
    )
    hand = Stature.of(robot).hands[ARM]
    links = [b for b in robot.bodies(ARM) if b != hand.body]
    links += robot.bodies("head") if "head" in robot.limbs else []
    arm = collision_pairs(robot.model, robot.data, links, ["wall"])
    avoid = CollisionAvoidanceTask(robot.configuration, arm, yellow=0.06, orange=0.02)
    res = stage.solve(
        fullbody_inverse_kinematics,
        "lean on the wall",
        [(support.p_site, support.R_hand)],
        path=path,
        total=100,
        start=False,
        limbs=[ARM],
        rotation_axis=["y"],
        balance=[scfr_task],
        collision_avoidance=avoid,
        avoid_world=PALM_ON_WALL,
        extra_levels=[[lean_task]],
        stop=100,
        min_loop=15,  # the lean is not checked (it stops where the SCFR keeps it)
        trust_region=STEPS,
    )
    return scfr_task, res


def play(stage: Stage, path: Waypoints, speed: float) -> tuple[SensorTrace, list[float]]:
    """The iterates as a motion in physics; the hand's bumper and the hand's distance
    to the wall [m] at every sample."""
    bumpers = SensorTrace(stage.robot.sensors())
    model = stage.scene.model
    hand = Stature.of(stage.robot).hands[ARM]
    geoms = hand.geoms(model)
    wall = model.geom("wall").id
    gap: list[float] = []

    def hand_to_wall(sample: Any) -> None:
        gap.append(min_distance(sample.model, sample.data, geoms, [wall], 0.1))

    stage.play("hand on the wall, lean", path, speed=speed, callback=[bumpers, hand_to_wall])
    return bumpers, gap


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
    hand = end_pose(robot, ARM)
    n_wall = support.n_wall
    return {
        "palm_target_m": support.p_palm,
        "hand_error_m": float(np.linalg.norm(hand.translation() - support.p_site)),
        "palm_normal_misalignment_rad": float(
            np.arccos(np.clip(hand.rotation().as_matrix()[:, 1] @ -n_wall, -1, 1))
        ),
        "com_m": com,
        "com_scfr_margin_m": float(region.signed_distance(com[:2])),
        "com_support_polygon_margin_m": com_margin(robot),
        "com_past_toes_m": float(com[1] - support.toes),
        "equilibrium_with_wall": eq.feasible,
        "equilibrium_feet_only": eq_feet.feasible,
        "wall_normal_force_N": None if eq.wrenches is None else float(eq.wrenches[2, :3] @ n_wall),
        "scfr_regions_computed": scfr_task.region_computations,
        "median_iteration_ms": lean.median_iteration_ms,
    }


def check(result: ScenarioResult) -> None:
    """The scenario's checks on its solves and figures."""
    f = result.figures
    for label in ("hand to the wall", "lean on the wall"):
        res = result.solves[label]
        result.check(f"{label}: converged", res.converged, f"{res.iterations} iterations")
    result.check(
        "palm on the wall (1 mm, 1°)",
        f["hand_error_m"] <= 1e-3 and f["palm_normal_misalignment_rad"] <= np.deg2rad(1),
    )
    result.check("CoM inside the SCFR (margin 1 cm)", f["com_scfr_margin_m"] >= 0.01 - 1e-3)
    result.check("CoM outside the feet's support polygon", f["com_support_polygon_margin_m"] < 0)
    result.check("static equilibrium LP: feasible with the wall", bool(f["equilibrium_with_wall"]))
    result.check(
        "static equilibrium LP: infeasible on the feet alone", not f["equilibrium_feet_only"]
    )


def check_bumper(result: ScenarioResult, bumpers: SensorTrace, gap: list[float]) -> None:
    """The bumper's figures and checks: off while the hand is away from the wall, on
    with the palm on it at the end."""
    f = result.figures
    bumper = result.robot.sensors(ARM).bumpers[0].name
    on, t = np.array(bumpers.on[bumper]), np.array(bumpers.time)
    away = np.array(gap) > TOUCHING
    reached = np.flatnonzero(~away)
    f["bumper_first_on_s"] = bumpers.first_on(bumper)
    f["hand_reaches_wall_s"] = float(t[reached[0]]) if reached.size else None
    f["bumper_on_while_away_from_wall"] = int(np.count_nonzero(on & away))
    f["bumper_samples_away_from_wall"] = int(np.count_nonzero(away))
    f["bumper_force_end_N"] = bumpers.force[bumper][-1]
    result.check(
        f"bumper {bumper} off while the hand is away from the wall (> {TOUCHING * 1e3:g} mm)",
        away.any() and not (on & away).any(),
        f"{f['bumper_on_while_away_from_wall']} of {f['bumper_samples_away_from_wall']} samples on",
    )
    result.check(
        f"bumper {bumper} on with the palm on the wall at the end",
        bool(on[-1]) and not away[-1],
        f"{f['bumper_force_end_N']:.1f} N, first on at {f['bumper_first_on_s']} s",
    )


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__, robot=ROBOT, description=True).parse_args(argv)
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
