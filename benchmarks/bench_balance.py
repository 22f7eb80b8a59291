"""Do full-body reaches that keep the CoM in the support polygon stand in physics?

Sample humanoid from ``reset_pose``; ``--n`` random right-hand (``rarm_end``) position
targets, seeded, in a box ahead of and beside the pelvis ``p_WP``:

.. math::

    x - p_{WP,x} \\in [0.2, 0.7], \\quad y - p_{WP,y} \\in [-0.5, 0.2], \\quad
    z \\in [0.2, 1.3] \\ \\text{(height above the floor)} \\quad [m]

Two stacks (:func:`pik_mj.ik.fullbody_inverse_kinematics`, root bounds and
posture as its defaults, ``stop=100``, no revert: the final pose is what is held),
identical but for the CoM task:

* **balanced**: level 1 = both feet fixed + CoM inside the soles' support polygon
  shrunk by 2 cm (:class:`pik_mj.tasks.support_polygon.SupportPolygonTask`,
  ``margin=0.02``) + collision avoidance; level 2 = the hand (position only).
* **unbalanced**: level 1 = both feet fixed + collision avoidance; level 2 = the hand.

Collision avoidance (:class:`pik_mj.tasks.collision.CollisionAvoidanceTask`,
yellow zone 10 cm, orange zone 1 cm, in level 1 so above the hand) watches every
pair of the robot's bodies and every body against the floor, less adjacent bodies
and pairs touching in ``reset_pose`` (the soles on the floor)
(:func:`pik_mj.tasks.collision.collision_pairs`). The IK robot is the sample
humanoid standing on a floor plane (``Robot.from_model(..., environment=
floor_environment())``, no degrees of freedom added), so that the floor is a geom
it can keep clear of.

Every final pose is held for ``--duration`` s in the robot's
:class:`pik_mj.sim.Scene` (``Scene.from_robot``: default servos and contacts). A
case passes with the hold's own verdict: base drift < 1 cm, foot slip < 2 mm, no
fall, no unexpected contact (a robot geom other than the soles touching the
floor, or a self-contact). Failures are counted per cause; "balance pass" ignores
unexpected contacts. Timings are wall-clock per case (IK solve, hold).

Run: ``python benchmarks/bench_balance.py [--n 100] [--seed 0]``
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np

from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.robot import Robot
from pik_mj.robot.ground import sole_polygons
from pik_mj.scenario import com_margin
from pik_mj.sim import HoldReport, Scene, floor_environment
from pik_mj.tasks.collision import CollisionAvoidanceTask, GeomPair, collision_pairs
from pik_mj.tasks.support_polygon import SupportPolygonTask

MODEL = "sample_humanoid"
HAND = "rarm"
MARGIN = 0.02  # [m] CoM kept this far inside the support polygon
X_RANGE = (0.2, 0.7)  # [m] ahead of the pelvis
Y_RANGE = (-0.5, 0.2)  # [m] beside the pelvis (right hand: mostly to the right)
Z_RANGE = (0.2, 1.3)  # [m] above the floor
MAX_DRIFT, MAX_SLIP = 0.01, 0.002  # [m] the hold's pass thresholds
YELLOW, ORANGE = 0.1, 0.01  # [m] collision avoidance: watched below, kept above
FLOOR = "floor"  # the floor plane of floor_environment()
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
VARIANTS = ("balanced", "unbalanced")


@dataclass
class Case:
    """One solved and held target."""

    target: np.ndarray
    converged: bool
    iterations: int
    hand_error: float  # [m]
    margin: float  # [m] static CoM margin to the soles' polygon at the final pose
    ik_time: float  # [s]
    hold: HoldReport

    clearance: float  # [m] smallest distance of a watched collision pair at the final pose

    @property
    def unexpected(self) -> bool:
        return bool(self.hold.unexpected_contacts)

    @property
    def balance_ok(self) -> bool:
        h = self.hold
        return h.drift < MAX_DRIFT and h.slip < MAX_SLIP and not h.fell


def sample_targets(p_WP: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``n`` hand targets (n, 3) [m] in the box of the module docstring."""
    rng = np.random.default_rng(seed)
    lo = np.array([p_WP[0] + X_RANGE[0], p_WP[1] + Y_RANGE[0], Z_RANGE[0]])
    hi = np.array([p_WP[0] + X_RANGE[1], p_WP[1] + Y_RANGE[1], Z_RANGE[1]])
    return rng.uniform(lo, hi, size=(n, 3))


def load_robot() -> Robot:
    """The sample humanoid on a floor plane named ``floor`` (robot ``q`` unchanged)."""
    return Robot.from_model(MODEL, environment=floor_environment())


def avoidance_pairs(robot: Robot) -> list[GeomPair]:
    """Every pair of robot bodies and every body against the floor, less adjacent
    bodies and pairs touching in ``reset_pose``."""
    robot.reset_pose()
    m = robot.model
    bodies = [m.body(b).name for b in range(1, m.nbody) if m.body_geomnum[b] > 0]
    return collision_pairs(m, robot.data, bodies, [FLOOR])


def solve_case(
    robot: Robot,
    target: np.ndarray,
    balanced: bool,
    margin: float = MARGIN,
    pairs: list[GeomPair] | None = None,
) -> tuple:
    """Reach ``target`` from ``reset_pose``; returns (result, IK wall time [s],
    the collision task)."""
    if pairs is None:
        pairs = avoidance_pairs(robot)
    robot.reset_pose()
    avoid = CollisionAvoidanceTask(robot.configuration, pairs, yellow=YELLOW, orange=ORANGE)
    balance = []
    if balanced:
        balance = [
            SupportPolygonTask(
                robot.configuration,
                sole_polygons(robot),
                root_body=robot.root_body,
                margin=margin,
            )
        ]
    t0 = time.perf_counter()
    result = fullbody_inverse_kinematics(
        robot,
        [(target, IDENTITY)],
        limbs=[HAND],
        rotation_axis=[None],  # position only
        balance=balance,
        collision_avoidance=[avoid],
        stop=100,
        revert_if_fail=False,
    )
    return result, time.perf_counter() - t0, avoid


def run_case(
    robot: Robot,
    scene: Scene,
    target: np.ndarray,
    balanced: bool,
    duration: float,
    margin: float = MARGIN,
    pairs: list[GeomPair] | None = None,
) -> Case:
    result, ik_time, avoid = solve_case(robot, target, balanced, margin, pairs)
    limb = robot.limb(HAND)
    p_hand = robot.frame_pose(limb.end_frame, limb.end_frame_type).translation()
    hold = scene.hold(robot.configuration.q.copy(), duration)
    return Case(
        target=target,
        converged=result.converged,
        iterations=result.iterations,
        hand_error=float(np.linalg.norm(p_hand - target)),
        margin=com_margin(robot),
        ik_time=ik_time,
        hold=hold,
        clearance=float(avoid.distances(robot.configuration, YELLOW).min()),
    )


def summarize(cases: list[Case]) -> dict:
    n = len(cases)
    ik_t = np.array([c.ik_time for c in cases])
    hold_t = np.array([c.hold.wall_time for c in cases])
    passed = [c for c in cases if c.hold.passed]
    nan = float("nan")
    return {
        "pass": sum(c.hold.passed for c in cases) / n,
        "balance_pass": sum(c.balance_ok for c in cases) / n,
        "fell": sum(c.hold.fell for c in cases) / n,
        "drift_fail": sum(c.hold.drift >= MAX_DRIFT for c in cases) / n,
        "drift_fail_standing": sum(c.hold.drift >= MAX_DRIFT and not c.hold.fell for c in cases)
        / n,
        "drift_fail_transient": sum(
            c.hold.drift >= MAX_DRIFT and np.linalg.norm(c.hold.final_displacement) < MAX_DRIFT
            for c in cases
        )
        / n,
        "slip_fail": sum(c.hold.slip >= MAX_SLIP for c in cases) / n,
        "unexpected_contact": sum(c.unexpected for c in cases) / n,
        "ik_converged": sum(c.converged for c in cases) / n,
        "min_static_margin_m": float(min(c.margin for c in cases)),
        "min_hold_margin_pass_m": float(min((c.hold.min_margin for c in passed), default=nan)),
        "min_clearance_m": float(min(c.clearance for c in cases)),
        "median_drift_m": float(np.median([c.hold.drift for c in cases])),
        "max_drift_pass_m": float(max((c.hold.drift for c in passed), default=nan)),
        "median_ik_s": float(np.median(ik_t)),
        "max_ik_s": float(np.max(ik_t)),
        "median_hold_s": float(np.median(hold_t)),
        "max_hold_s": float(np.max(hold_t)),
    }


ROWS = (
    ("hold pass (drift, slip, fall, contacts)", "pass", "%"),
    ("balance pass (drift, slip, fall)", "balance_pass", "%"),
    ("  fell", "fell", "%"),
    ("  base drift >= 1 cm", "drift_fail", "%"),
    ("  ... of which did not fall", "drift_fail_standing", "%"),
    ("  ... back within 1 cm at the end", "drift_fail_transient", "%"),
    ("  foot slip >= 2 mm", "slip_fail", "%"),
    ("  unexpected contact", "unexpected_contact", "%"),
    ("IK converged (1 mm)", "ik_converged", "%"),
    ("min static CoM margin [m]", "min_static_margin_m", "f"),
    ("min CoM margin in passing holds [m]", "min_hold_margin_pass_m", "f"),
    ("min collision-pair clearance [m]", "min_clearance_m", "f"),
    ("median base drift [m]", "median_drift_m", "f"),
    ("max base drift in passing holds [m]", "max_drift_pass_m", "f"),
    ("median IK time [s]", "median_ik_s", "f"),
    ("max IK time [s]", "max_ik_s", "f"),
    ("median hold time [s]", "median_hold_s", "f"),
    ("max hold time [s]", "max_hold_s", "f"),
)


def _cell(value: float, fmt: str) -> str:
    return f"{value:>13.0%}" if fmt == "%" else f"{value:>13.4f}"


def print_failures(label: str, cases: list[Case]) -> None:
    failed = [(i, c) for i, c in enumerate(cases) if not c.hold.passed]
    if not failed:
        return
    print(f"\nfailed cases, {label}:")
    print(
        f"{'#':>4} {'target [m]':>22} {'conv':>5} {'hand err':>9} {'margin':>8} "
        f"{'drift':>8} {'slip':>8} {'min marg':>9} {'clear':>7}  why"
    )
    for i, c in failed:
        h = c.hold
        why = "; ".join(h.failures)
        print(
            f"{i:>4} {np.array2string(c.target, precision=2):>22} {c.converged!s:>5} "
            f"{c.hand_error:>9.4f} {c.margin:>8.4f} {h.drift:>8.4f} {h.slip:>8.4f} "
            f"{h.min_margin:>9.4f} {c.clearance:>7.4f}  {why}"
        )


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="number of targets")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=3.0, help="hold duration [s]")
    parser.add_argument(
        "--margin", type=float, default=MARGIN, help="support-polygon margin [m] (diagnosis)"
    )
    parser.add_argument("--kp", type=float, default=None, help="servo kp (default: Scene's)")
    parser.add_argument("--kv", type=float, default=None, help="servo kv (default: Scene's)")
    parser.add_argument("--quiet", action="store_true", help="no per-case failure listing")
    args = parser.parse_args(argv)
    if args.n < 1:
        parser.error("--n must be >= 1")

    robot = load_robot()
    pairs = avoidance_pairs(robot)
    p_WP, _ = robot.root_pose()
    targets = sample_targets(p_WP, args.n, args.seed)
    gains = {k: v for k, v in (("kp", args.kp), ("kv", args.kv)) if v is not None}
    scene = Scene.from_robot(robot, **gains)
    cases = {
        v: [
            run_case(robot, scene, t, v == "balanced", args.duration, args.margin, pairs)
            for t in targets
        ]
        for v in VARIANTS
    }
    figures = {v: summarize(cases[v]) for v in VARIANTS}
    figures["targets"] = args.n
    figures["margin_m"] = args.margin

    print(
        f"{MODEL}: {args.n} right-hand targets (seed {args.seed}), feet fixed, "
        f"hold {args.duration:g} s; balanced = CoM in support polygon, margin {args.margin} m"
    )
    if gains:
        print(f"servo gains changed for diagnosis: {gains}")
    print(f"{'':42}{'balanced':>13}{'unbalanced':>13}")
    for label, key, fmt in ROWS:
        print(f"{label:42}" + "".join(_cell(figures[v][key], fmt) for v in VARIANTS))
    if not args.quiet:
        for v in VARIANTS:
            print_failures(v, cases[v])
    return figures


if __name__ == "__main__":
    main()
