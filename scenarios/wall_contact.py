"""A hand on the wall: multi-contact balance with the SCFR (seed 000 ``centroid-scfr-task``).

The robot stands at ``spot_wall`` facing the wall (0.45 m ahead). Its right palm
is put flat on the wall at shoulder height; the feet stay. The balance task of
level 1 is the static centroid feasible region of the three contacts (two soles
on the floor, μ = 0.8; the palm on the wall, μ = 0.5), and a lower level asks
the CoM to lean 0.1 m past the toes towards the wall — outside the feet's support
polygon, which only the wall contact makes statically possible. The pose is
checked independently by the static-equilibrium LP: contact wrenches within
their friction cones and CoP limits hold the robot.
"""

from __future__ import annotations

import sys

import numpy as np

from pik_mj import (
    CentroidTask,
    HoldCriteria,
    Progress,
    Recorder,
    Robot,
    Scene,
    ScfrTask,
    fullbody_inverse_kinematics,
)
from pik_mj.balance import contact_from_normal, foot_contact, static_equilibrium
from pik_mj.ground import sole_size
from pik_mj.scenario import DEFAULT_HOLD, ScenarioResult, com_margin, open_recorder, parser, report
from pik_mj.spatial import yaw_of

NAME = "wall_contact"
PALM = (0.045, 0.06)  # [m] half sizes of the palm (hand box x, z)
PALM_OFFSET = 0.02  # [m] from the hand site to the palm face (hand box half thickness)
LEAN = 0.1  # [m] CoM target past the toes


def run(recorder: Recorder, *, hold: float = DEFAULT_HOLD, quiet: bool = True) -> ScenarioResult:
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
    log = recorder.solve_logger("hand on the wall", checks=checks, start=robot)
    progress = Progress("hand on the wall", total=100, stream=None if quiet else sys.stderr)
    res = fullbody_inverse_kinematics(
        robot,
        [(p_site, R_hand)],
        limbs=["rarm"],
        rotation_axis=["y"],
        balance=[scfr_task],
        extra_levels=[[lean_task]],
        stop=100,
        callback=[checks, log, progress],
    )
    result.add_solve("hand on the wall", res, checks, finish=[log, progress])

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
    result.main = "hand on the wall"
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
    result.check("converged", res.converged, f"{res.iterations} iterations")
    result.check(
        "palm on the wall (1 mm, 1°)",
        f["hand_error_m"] <= 1e-3 and f["palm_normal_misalignment_rad"] <= np.deg2rad(1),
    )
    result.check("CoM inside the SCFR (margin 1 cm)", f["com_scfr_margin_m"] >= 0.01 - 1e-3)
    result.check("CoM outside the feet's support polygon", f["com_support_polygon_margin_m"] < 0)
    result.check("static equilibrium LP: feasible with the wall", bool(eq.feasible))
    result.check("static equilibrium LP: infeasible on the feet alone", not eq_feet.feasible)
    return result


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, hold=args.hold, quiet=args.quiet)
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
