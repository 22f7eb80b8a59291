"""Fullbody IK with forces on both hands: the static balance point between the feet
(irteus manual, ``:centroid-offset-func`` with ``:calc-static-balance-point``).

Both hands receive the irteus example's force (-20, 0, 0) N and moment (10, 0, 0)
N·m; the feet stay, the hands go to ``#f(400 ∓300 0)`` mm from the waist
(position only), and the *static balance point* — where the ground reaction
balances gravity and the hand wrenches — is brought over the midpoint of the
feet instead of the centroid. The check is independent of the formula used in
the solve: the total moment of gravity and the hand wrenches about the feet
midpoint has no horizontal component (a pure vertical ground force there
balances). The iterates are played in physics as a motion and the final pose
is held, both with the same hand wrenches applied.
"""

from __future__ import annotations

from typing import Any

import mink
import numpy as np

from pik_mj import (
    CollisionAvoidanceTask,
    Recorder,
    Robot,
    Scene,
    SolveResult,
    Waypoints,
    fullbody_inverse_kinematics,
)
from pik_mj.ik import static_balance_point
from pik_mj.scenario import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
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
    run_options,
)
from pik_mj.solve import TrustRegion
from pik_mj.tasks.collision import collision_pairs

NAME = "fullbody_external_force"
FORCE = np.array([-20.0, 0.0, 0.0])  # [N] on each hand (sample_humanoid, 58.5 kg)
MOMENT = np.array([10.0, 0.0, 0.0])  # [N·m] on each hand (sample_humanoid, arm 0.61 m)
LEAN = 0.1  # other robots: the pulls ask the CoM this many sole lengths forward
TWIST = 0.8  # other robots: the moment is the pull times this many arm lengths
HANDS = ("rarm", "larm")
FEET = ("rleg", "lleg")
ROBOT = RobotOption("sample_humanoid", (*HANDS, *FEET), floating_base=True)
IRTEUS_TARGETS = ((0.4, -0.3, 0.0), (0.4, 0.3, 0.0))  # [m] from the root (sample_humanoid)
OTHER_MODELS = (0.6, 0.0, 0.4)  # [hand-to-shoulder distances] from each hand's start, robot's frame
Wrench = tuple[str, np.ndarray, np.ndarray]  # (frame, force [N], moment [N·m])


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
    """Solve, validate and record the reach under the hand wrenches. ``robot``: the
    robot already built from ``model`` and ``description``, else None to build it."""
    if robot is None:
        robot = Robot.from_model(model, description=description, required_limbs=ROBOT.limbs)
    stage = Stage(NAME, robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    feet0 = [end_pose(robot, x) for x in FEET]
    p_mid = 0.5 * (feet0[0].translation() + feet0[1].translation())
    targets = hand_targets(robot, model)
    forces = hand_wrenches(robot, model, targets)
    path = Waypoints(robot)
    res = reach(stage, targets, forces, p_mid, path)
    if speed:
        # The hands take up their wrenches as they reach, at half the speed: under the
        # 40 N of pulls the servos let the root lag behind its reference in proportion
        # to the speed.
        stage.play("reach with forces", path, speed=speed / 2, external=forces, external_ramp=True)
    # The final pose in physics, with the hand wrenches it was solved for.
    stage.hold_final_pose(hold, external=forces)
    result = stage.result
    result.main = "reach with forces"
    result.figures = figures(robot, forces, targets, feet0, res)
    check(result, robot, res)
    return result


def hand_targets(robot: Robot, model: str | None) -> list[np.ndarray]:
    """The hands' targets [m]: the irteus example's ``#f(400 ∓300 0)`` mm from the
    root on ``sample_humanoid``, else :data:`OTHER_MODELS` from each hand's start, in
    the robot's frame, in units of the hand's distance to its shoulder."""
    if str(model) == "sample_humanoid":
        p_root = robot.root_pose()[0]
        return [p_root + np.array(offset) for offset in IRTEUS_TARGETS]
    stature = Stature.of(robot)
    targets = []
    for h in HANDS:
        p_hand = end_pose(robot, h).translation()
        reach = float(np.linalg.norm(p_hand - stature.shoulders[h]))
        targets.append(p_hand + reach * stature.direction(OTHER_MODELS))
    return targets


def hand_wrenches(robot: Robot, model: str | None, targets: list[np.ndarray]) -> list[Wrench]:
    """Each hand's wrench: the irteus example's on ``sample_humanoid``; else a pull
    ``F`` back, the same on both hands, that asks the CoM to lean ``LEAN`` sole lengths
    ``l`` forward, ``F = LEAN l M g / sum_h z_h`` [N] (``z_h`` a target's height above
    the soles), and a moment about the robot's x of ``TWIST`` arm lengths times it
    [N·m]."""
    if str(model) == "sample_humanoid":
        return [(robot.limb(h).end_frame, FORCE, MOMENT) for h in HANDS]
    stature = Stature.of(robot)
    assert stature.sole is not None  # the robot has both legs (ROBOT)
    weight = robot.mass * float(np.linalg.norm(robot.model.opt.gravity))  # [N]
    heights = sum(float(p[2] - stature.p_WR[2]) for p in targets)
    pull = LEAN * stature.sole[0] * weight / heights
    return [
        (
            robot.limb(h).end_frame,
            stature.direction([-pull, 0.0, 0.0]),
            stature.direction([TWIST * stature.arm_lengths[h] * pull, 0.0, 0.0]),
        )
        for h in HANDS
    ]


def avoided_links(robot: Robot) -> list[str]:
    """The arms' bodies, the root body, the torso's and each leg's first link: the
    links the arms keep off."""
    links = [b for h in HANDS for b in robot.bodies(h)] + [robot.root_body]
    if "torso" in robot.limbs:
        links += robot.bodies("torso")
    links += [robot.limb(leg).root_body for leg in FEET]
    return list(dict.fromkeys(links))


def reach(
    stage: Stage,
    targets: list[np.ndarray],
    forces: list[Wrench],
    p_mid: np.ndarray,
    path: Waypoints,
) -> SolveResult:
    """The hands to ``targets`` (position only) under ``forces``, the feet kept, the
    static balance point over the feet midpoint ``p_mid`` (its x-y); the arms keep off
    the body (irteus: the arms' ``:collision-avoidance-link-pair``), which the
    plain solution's first step swings the right forearm into."""
    robot = stage.robot
    pairs = collision_pairs(robot.model, robot.data, avoided_links(robot), touching=0.01)
    avoid = CollisionAvoidanceTask(robot.configuration, pairs, yellow=0.1, orange=0.01)
    return stage.solve(
        fullbody_inverse_kinematics,
        "reach with forces",
        [(p, np.array([1.0, 0.0, 0.0, 0.0])) for p in targets],
        path=path,
        total=100,
        limbs=list(HANDS),
        rotation_axis=None,
        external_forces=forces,
        collision_avoidance=avoid,
        target_centroid_pos=p_mid,
        centroid_axes="z",
        stop=100,
        # short steps: a long first step lifts a foot off the floor (level 1 is not
        # yet satisfied, so the trust region does not keep the feet)
        trust_region=TrustRegion(radius=0.05, max_radius=0.1),
    )


def figures(
    robot: Robot,
    forces: list[Wrench],
    targets: list[np.ndarray],
    feet0: list[mink.SE3],
    res: SolveResult,
) -> dict[str, Any]:
    """The measures of the final pose: the balance point and, independently, the
    moment about the feet midpoint (3D cross products) where a pure vertical ground
    force must balance gravity and the hand wrenches; the hands, the feet, the CoM."""
    p_mid = 0.5 * (feet0[0].translation() + feet0[1].translation())
    p = static_balance_point(robot, forces, height=p_mid[2])
    moment = np.cross(robot.com() - p_mid, robot.mass * robot.model.opt.gravity)
    hands = [end_pose(robot, h).translation() for h in HANDS]
    for p_hand, (_, force, torque) in zip(hands, forces, strict=True):
        moment += np.cross(p_hand - p_mid, force) + torque
    com = robot.com()
    R_WR = Stature.of(robot).R_WR
    weight = robot.mass * float(np.linalg.norm(robot.model.opt.gravity))  # [N]
    # the forward lean the pulls alone ask for: sum_h -(F_h · x) (z_h - z_mid) / (M g)
    lean = sum(
        -(f @ R_WR[:, 0]) * (p_hand[2] - p_mid[2])
        for p_hand, (_, f, _) in zip(hands, forces, strict=True)
    )
    return {
        "balance_point_m": p,
        "balance_point_xy_error_m": float(np.linalg.norm(p[:2] - p_mid[:2])),
        "horizontal_moment_about_feet_midpoint_Nm": moment[:2],
        "com_m": com,
        "com_shift_from_feet_midpoint_m": com[:2] - p_mid[:2],
        "com_forward_of_feet_midpoint_m": float((com - p_mid) @ R_WR[:, 0]),
        "lean_of_the_pulls_m": float(lean / weight),
        "balance_point_margin_m": com_margin(robot, p),
        "hand_errors_m": [
            float(np.linalg.norm(end_pose(robot, h).translation() - t))
            for h, t in zip(HANDS, targets, strict=True)
        ],
        "feet_moved_m": largest_move(feet0, [end_pose(robot, x) for x in FEET]),
        "median_iteration_ms": res.median_iteration_ms,
    }


def check(result: ScenarioResult, robot: Robot, res: SolveResult) -> None:
    """The scenario's checks on its solve and figures."""
    f = result.figures
    moment = f["horizontal_moment_about_feet_midpoint_Nm"]
    weight = robot.mass * float(np.linalg.norm(robot.model.opt.gravity))  # [N]
    result.check("converged", res.converged, f"{res.iterations} iterations")
    result.check("hands on target (1 mm)", max(f["hand_errors_m"]) <= 1e-3)
    result.check("feet did not move (0.1 mm)", f["feet_moved_m"] <= 1e-4)
    result.check(
        "balance point over the feet midpoint (1 mm)", f["balance_point_xy_error_m"] <= 1e-3
    )
    result.check(
        "no horizontal moment about the feet midpoint (M g · 1 mm)",
        float(np.abs(moment).max()) <= weight * 1e-3,
        f"{moment}",
    )
    result.check("balance point inside the support polygon", f["balance_point_margin_m"] > 0)
    result.check(
        "CoM leans into the pull (forward of the feet midpoint by more than half of "
        "sum_h |F_h| z_h / (M g), the lean the pulls alone ask for)",
        f["com_forward_of_feet_midpoint_m"] > 0.5 * f["lean_of_the_pulls_m"] > 0,
        f"{f['com_forward_of_feet_midpoint_m'] * 1e3:.1f} mm, pulls "
        f"{f['lean_of_the_pulls_m'] * 1e3:.1f} mm",
    )


def main(argv: list[str] | None = None) -> int:
    args = parser(__doc__, robot=ROBOT, description=True).parse_args(argv)
    with open_recorder(args, NAME) as recorder:
        result = run(recorder, **run_options(args))
    return report(result, args)


if __name__ == "__main__":
    raise SystemExit(main())
