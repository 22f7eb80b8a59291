"""Full-body reaches on each humanoid, as it is shipped: one row per robot.

Robots: Unitree G1, H1, Booster T1 (MuJoCo Menagerie, through ``MENAGERIE_ROOT``
or the ``mujoco-menagerie`` cache; a robot that is not on the machine is
skipped, saying so), the project's ``sample_humanoid`` and dm_control's
``dm_humanoid``. Each is built with nothing written by hand:
``Robot.from_model(name)`` (standing keyframe, limbs found from the tree, put
down on the floor) and ``Scene.from_robot(robot)`` (its own position actuators
as servos, the other joints' servo gains from its inertia). Then ``--n`` random
right-hand (``rarm`` end frame) targets, seeded:

* **reachable by construction**: from the standing pose, the right arm's joints
  are drawn ``q_i ~ N(q_i0, σ²)`` clipped to their ranges shrunk by 5 % at each
  end (the rest of the robot as it stands); the draw is kept when the CoM stays
  ``MARGIN`` inside the soles' support polygon, no watched pair comes nearer
  than the avoidance allows and nothing but the feet comes within 1 cm of the
  floor. The hand's pose there is the target, position and orientation (1 mm
  and 1°; Unitree H1's and Booster T1's arms have 4 joints, but with the legs
  and the floating base they reach these poses too): a solution exists, so the
  converged figure measures the solver, not the sampling;
* :func:`pik_mj.ik.fullbody_inverse_kinematics` (root bounds, posture as its
  defaults, ``stop=100``): level 1 = both feet fixed + the CoM inside the
  soles' support polygon (collision geometry, :func:`pik_mj.robot.ground.sole_polygons`)
  shrunk by ``MARGIN`` (:class:`~pik_mj.tasks.support_polygon.SupportPolygonTask`)
  + self-collision avoidance (:class:`~pik_mj.tasks.collision.CollisionAvoidanceTask`,
  yellow zone 10 cm, orange zone 1 cm, every pair of the robot's bodies less
  adjacent ones, pairs touching in the standing pose and pairs whose distance
  the hand's and legs' joints cannot change); level 2 = the hand;
* the same stack without the avoidance task, same target, back to back (both
  see the same machine load);
* the solve's iterates (with avoidance) played in physics from the standing pose
  (:meth:`pik_mj.sim.Scene.play`, ``--speed`` of the joint velocity limits, default
  0.2; the motion's default criteria: root drift from the reference < 2 cm, foot
  slip < 2 mm, no fall, no unexpected contact);
* the final pose (with avoidance) held 3 s in the robot's scene
  (:meth:`pik_mj.sim.Scene.hold`, default :class:`~pik_mj.sim.HoldCriteria`:
  base drift < 1 cm, foot slip < 2 mm, no fall, only the feet touching).

Columns: degrees of freedom (``nv``), watched collision pairs, IK converged %,
median over targets of the CPU ms per iteration with avoidance and without it,
their ratio, IK converged % without avoidance, motion pass % (of all targets),
hold pass % (of all targets) and the largest base drift of the passing holds.
``--qp-solver daqp`` runs every level on DAQP instead of OSQP.

Walk column (``--walk-steps``, default 6; 0: none): the robot walking
``--walk-steps`` strides forward and a go-pos to (0.5 m, 0.2 m, 30°) in physics,
as ``benchmarks/bench_walking.py`` does (:func:`bench_walking.walk_column`): per
walk the verdict (pass, FAIL or refused), the footsteps, the least ZMP margin to
the support polygon [mm] of the pattern's inverse dynamics / measured in physics
(the feet's force sensors where the robot has them, else MuJoCo's contact
forces), and the final error of the mid-feet point to the plan [mm]; a refusal's
or failure's reason on the line below.

``--scenarios``: instead, every scenario but the walking ones on each robot, as
``pik-mj run S --model R`` runs it (its default ``--hold`` 3 s and ``--speed`` 0.2):
passed, failed (the checks that failed) or refused before any work (the one line
its ``--model`` option says).

Run: ``MENAGERIE_ROOT=... OPENBLAS_NUM_THREADS=1 python benchmarks/bench_robots.py [--n 50]``
``[--scenarios]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pik_mj.scenarios
from bench_walking import cell, notes, walk_column

from pik_mj import HoldCriteria, Recorder, Robot, Scene, Waypoints
from pik_mj.balance import support_polygon
from pik_mj.cli import load_scenario
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.robot.ground import foot_geoms, geom_heights, sole_polygons, subtree_bodies
from pik_mj.robot.loading import menagerie_available, menagerie_models
from pik_mj.scenario import DEFAULT_HOLD, DEFAULT_SPEED, RobotRefused, ScenarioResult
from pik_mj.tasks.collision import CollisionAvoidanceTask, collision_pairs, moving_pairs
from pik_mj.tasks.support_polygon import SupportPolygonTask

ROBOTS = ("unitree_g1", "unitree_h1", "booster_t1", "sample_humanoid", "dm_humanoid")
HAND = "rarm"
MARGIN = 0.02  # [m] CoM kept this far inside the support polygon
YELLOW, ORANGE = 0.1, 0.01  # [m] collision avoidance: watched below, kept above
SIGMA = 0.5  # [rad] spread of the random arm joints about the standing pose
CLEARANCE = 0.01  # [m] a target pose keeps all but the feet this far above the floor
HOLD = DEFAULT_HOLD  # [s]
SPEED = DEFAULT_SPEED  # the motion's fraction of the joint velocity limits


@dataclass
class Row:
    """One robot's figures."""

    robot: str
    nv: int
    pairs: int
    converged: float  # fraction of targets, with avoidance
    ms_per_iteration: float  # median, with avoidance [ms]
    ms_per_iteration_without: float  # median, same targets without avoidance [ms]
    converged_without: float
    motion_pass: float  # fraction of targets whose iterates played in physics passed
    hold_pass: float  # fraction of targets whose final pose held
    max_drift: float  # [m] largest base drift of the passing holds
    failures: list[str] = field(default_factory=list)
    walk: dict | None = None  # bench_walking.walk_column: {"forward": ..., "go_pos": ...}

    @property
    def ratio(self) -> float:
        return self.ms_per_iteration / self.ms_per_iteration_without


class Setup:
    """A robot as it is shipped, its scene, its soles and watched collision pairs."""

    def __init__(self, name: str):
        self.name = name
        self.robot = Robot.from_model(name, required_limbs=(HAND, "rleg", "lleg"))
        self.scene = Scene.from_robot(self.robot)
        self.q0 = self.robot.configuration.q.copy()
        self.soles = sole_polygons(self.robot)
        self.region = support_polygon(self.soles)
        m = self.robot.model
        root = self.robot.root_body_id
        bodies = [
            m.body(b).name
            for b in range(1, m.nbody)
            if m.body_geomnum[b] > 0 and m.body_rootid[b] == root
        ]
        # the pairs whose distance the solve can change: the hand's and the legs'
        # joints move (the other joints are frozen by fullbody_inverse_kinematics)
        moving = [j for limb in (HAND, "rleg", "lleg") for j in self.robot.limb(limb).joints]
        self.pairs = moving_pairs(m, collision_pairs(m, self.robot.data, bodies), moving)
        self.arm = self.robot.limb(HAND)
        self.feet = set(foot_geoms(self.robot))
        self.bodies = subtree_bodies(m, root)

    def _avoidance(self) -> CollisionAvoidanceTask:
        return CollisionAvoidanceTask(
            self.robot.configuration, self.pairs, yellow=YELLOW, orange=ORANGE
        )

    def targets(self, n: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """``n`` hand poses ``(p_WH, quat_WH)`` reachable by construction (module docstring)."""
        robot, rng = self.robot, np.random.default_rng(seed)
        lo, hi = robot.joint_limits(self.arm.joints)
        lo, hi = np.where(np.isfinite(lo), lo, -np.pi), np.where(np.isfinite(hi), hi, np.pi)
        lo, hi = lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo)
        q_arm0 = robot.angle_vector(self.arm.joints)
        robot.configuration.update(self.q0)
        avoid = self._avoidance()  # its bounds: the standing pose's
        out = []
        while len(out) < n:
            robot.configuration.update(self.q0)
            robot.set_angle_vector(
                np.clip(q_arm0 + rng.normal(0.0, SIGMA, len(q_arm0)), lo, hi), self.arm.joints
            )
            if (
                self.region.signed_distance(robot.com()) < MARGIN
                or not avoid.is_satisfied(robot.configuration)
                or self._floor_clearance() < CLEARANCE
            ):
                continue
            X = robot.frame_pose(self.arm.end_frame, self.arm.end_frame_type)
            out.append((X.translation(), X.rotation().wxyz))
        robot.configuration.update(self.q0)
        return out

    def _floor_clearance(self) -> float:
        """Height [m] of the lowest collision geom that is not a foot's."""
        heights = geom_heights(self.robot.model, self.robot.data, self.bodies)
        return min((h for g, h in heights.items() if g not in self.feet), default=np.inf)

    def solve(self, target, avoidance: bool, qp_solver: str = "osqp", path=None):
        """Reach ``target`` from the standing pose, its iterates into ``path``."""
        robot = self.robot
        robot.configuration.update(self.q0)
        support = SupportPolygonTask(
            robot.configuration, self.soles, root_body=robot.root_body, margin=MARGIN
        )
        return fullbody_inverse_kinematics(
            robot,
            [target],
            limbs=[HAND],
            balance=[support],
            collision_avoidance=[self._avoidance()] if avoidance else [],
            stop=100,
            revert_if_fail=False,
            qp_solver=qp_solver,
            callback=[] if path is None else [path],
        )


def run_robot(
    name: str,
    n: int,
    seed: int,
    qp_solver: str = "osqp",
    hold: float = HOLD,
    speed: float = SPEED,
) -> Row:
    """Each target solved with and without avoidance, one after the other, then
    the pose with avoidance held. Time per iteration is the process's CPU time of
    a solve over its iterations (steadier than wall time on a shared machine;
    run with one BLAS thread: ``OPENBLAS_NUM_THREADS=1``)."""
    setup = Setup(name)
    converged: dict[bool, list[bool]] = {True: [], False: []}
    per_iteration: dict[bool, list[float]] = {True: [], False: []}
    held, moved, drifts, failures = [], [], [], []
    for target in setup.targets(n, seed):
        for avoidance in (False, True):  # the avoidance solve last: its pose is held
            setup.robot.configuration.update(setup.q0)
            path = Waypoints(setup.robot, "reach") if avoidance else None
            t0 = time.process_time()
            result = setup.solve(target, avoidance, qp_solver, path)
            cpu = time.process_time() - t0
            converged[avoidance].append(result.converged)
            per_iteration[avoidance].append(cpu / max(result.iterations, 1))
        if speed > 0 and path is not None:
            path.finish(result)
            motion = setup.scene.play(path, speed=speed)
            moved.append(motion.passed)
            failures += [f"motion: {f}" for f in motion.failures]
        if hold > 0:
            report = setup.scene.hold(
                setup.robot.configuration.q.copy(), hold, criteria=HoldCriteria()
            )
            held.append(report.passed)
            if report.passed:
                drifts.append(report.drift)
            else:
                failures += report.failures
    return Row(
        robot=name,
        nv=setup.robot.model.nv,
        pairs=len(setup.pairs),
        converged=float(np.mean(converged[True])),
        ms_per_iteration=1e3 * float(np.median(per_iteration[True])),
        ms_per_iteration_without=1e3 * float(np.median(per_iteration[False])),
        converged_without=float(np.mean(converged[False])),
        motion_pass=float(np.mean(moved)) if moved else float("nan"),
        hold_pass=float(np.mean(held)) if held else float("nan"),
        max_drift=max(drifts, default=float("nan")),
        failures=failures,
    )


WALKING = ("walk_forward", "walk_go_pos")


def scenario_names() -> list[str]:
    """The scenarios of the matrix: every one but the walking ones."""
    return [name for name in pik_mj.scenarios.SCENARIOS if name not in WALKING]


def run_scenario(name: str, robot: str, hold: float, speed: float) -> tuple[str, str, float]:
    """Scenario ``name`` on ``robot``: ``("passed" | "failed" | "refused", detail,
    seconds)``; the detail: the failed checks, or the refusal's line."""
    module = load_scenario(name)
    t0 = time.perf_counter()
    try:
        model, built = module.ROBOT.check(robot, None)
    except RobotRefused as exc:
        return "refused", str(exc), time.perf_counter() - t0
    options = {"hold": hold, "speed": speed} if "speed" in module.run.__code__.co_varnames else {}
    with tempfile.TemporaryDirectory() as folder:
        with Recorder.to_file(Path(folder) / f"{name}.rrd", name) as recorder:
            result = module.run(recorder, model=model, robot=built, **options)
    return ("passed" if result.passed else "failed"), why_failed(result), time.perf_counter() - t0


def why_failed(result: ScenarioResult) -> str:
    """The failed checks of ``result``, each by its label; a failed motion or hold
    with its failures (a fall, a drift, the servos' unstable mode, a drive's
    shortfall), each cut at 120 characters."""
    out = []
    for message in result.messages:
        if not message.startswith("[FAILED]"):
            continue
        text = message.removeprefix("[FAILED] ")
        label = text.split(":", 1)[0]
        motion = result.motions.get(label.removeprefix("motion ").strip("'"))
        hold = (result.balance or {}).get("hold") if label == "simulation" else None
        if motion is None and hold is None:
            out.append(text[:120])
            continue
        failures = motion.failures if motion is not None else hold.get("failures", [])
        out.append(label + "".join(f" [{f[:120]}]" for f in failures))
    return "; ".join(out)


def scenario_matrix(robots: list[str], hold: float, speed: float, quiet: bool) -> dict:
    """Every scenario of :func:`scenario_names` on each of ``robots`` (those here)."""
    rows: dict[str, dict[str, list]] = {}
    for name in scenario_names():
        rows[name] = {}
        for robot in robots:
            if not available(robot):
                continue
            outcome, detail, seconds = run_scenario(name, robot, hold, speed)
            rows[name][robot] = [outcome, detail, seconds]
            if not quiet:
                print(f"{name:24} {robot:16} {outcome:8} {seconds:6.1f} s  {detail}", flush=True)
    return rows


def available(name: str) -> bool:
    return name not in menagerie_models() or menagerie_available(name)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=50, help="hand targets per robot")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--robots", nargs="*", default=list(ROBOTS))
    parser.add_argument("--qp-solver", default="osqp", help="osqp (default) or daqp")
    parser.add_argument("--hold", type=float, default=HOLD, help="hold duration [s]; 0: none")
    parser.add_argument(
        "--speed", type=float, default=SPEED, help="motion speed (of velocity limits); 0: none"
    )
    parser.add_argument(
        "--walk-steps", type=int, default=6, help="strides of the walk column; 0: no walk"
    )
    parser.add_argument("--quiet", action="store_true")
    parser.add_argument(
        "--scenarios", action="store_true", help="the scenario x robot matrix instead"
    )
    args = parser.parse_args(argv)
    if args.scenarios:
        return {"scenarios": scenario_matrix(args.robots, args.hold, args.speed, args.quiet)}
    rows, skipped = [], []
    t0 = time.perf_counter()
    for name in args.robots:
        if not available(name):
            skipped.append(name)
            continue
        rows.append(run_robot(name, args.n, args.seed, args.qp_solver, args.hold, args.speed))
        if args.walk_steps > 0:
            rows[-1].walk = walk_column(name, args.walk_steps)
    if not args.quiet:
        print(
            f"{'robot':16} {'nv':>3} {'pairs':>5} {'IK conv':>7} {'ms/it':>6} "
            f"{'ms/it w/o':>9} {'ratio':>5} {'conv w/o':>8} {'motion':>6} {'hold pass':>9} "
            f"{'drift mm':>8}  {'walk forward':38}  {'walk go-pos':38}"
        )
        for r in rows:
            print(
                f"{r.robot:16} {r.nv:3d} {r.pairs:5d} "
                f"{100 * r.converged:6.0f}% {r.ms_per_iteration:6.2f} "
                f"{r.ms_per_iteration_without:9.2f} {r.ratio:5.2f} "
                f"{100 * r.converged_without:7.0f}% {100 * r.motion_pass:5.0f}% "
                f"{100 * r.hold_pass:8.0f}% "
                f"{1e3 * r.max_drift:8.2f}"
                + (
                    ""
                    if r.walk is None
                    else f"  {cell(r.walk['forward']):38}  {cell(r.walk['go_pos']):38}"
                )
            )
            for failure in sorted(set(r.failures)):
                print(f"{'':16}   failure: {failure}")
            for line in [] if r.walk is None else notes(r.walk):
                print(f"{'':16}   walk {line}")
        for name in skipped:
            print(f"{name:16} skipped: not under MENAGERIE_ROOT nor in the mujoco-menagerie cache")
        print(
            f"{args.n} targets per robot, seed {args.seed}, QP solver {args.qp_solver}, "
            f"motion at {args.speed} of the velocity limits, hold {args.hold} s, "
            f"walk {args.walk_steps} strides and go-pos (0.5 m, 0.2 m, 30 deg), walk ZMP "
            f"margins inverse dynamics/physics, {time.perf_counter() - t0:.0f} s"
        )
    return {
        "targets": args.n,
        "rows": {r.robot: {**r.__dict__, "ratio": r.ratio} for r in rows},
        "skipped": skipped,
    }


if __name__ == "__main__":
    main()
