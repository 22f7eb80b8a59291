"""Full-body reaches on each humanoid, as it is shipped: one row per robot.

Robots: Unitree G1, H1, Booster T1 (MuJoCo Menagerie, through ``MENAGERIE_ROOT``
or the ``mujoco-menagerie`` cache; a robot that is not on the machine is
skipped, saying so), the project's ``sample_humanoid`` and dm_control's
``dm_humanoid``. For each, with nothing written by hand:

* the standing pose by :func:`pik_mj.keyframes.standing_pose`, its limbs by
  :func:`pik_mj.limbs.find_limbs`, its soles by :func:`pik_mj.ground.sole_polygons`;
* ``--n`` random right-hand (``rarm`` end frame) position targets, seeded, in a
  box around the hand's start scaled by the standing height ``h`` of the root:

  .. math::

      \\Delta p \\in [0, 0.3h] \\times [-0.25h, 0.1h] \\times [-0.1h, 0.3h]

* :func:`pik_mj.ik.fullbody_inverse_kinematics` (root bounds, posture as its
  defaults, ``stop=100``): level 1 = both feet fixed + the CoM inside the soles'
  support polygon shrunk by ``MARGIN`` (:class:`~pik_mj.tasks.support_polygon.SupportPolygonTask`)
  + self-collision avoidance (:class:`~pik_mj.tasks.collision.CollisionAvoidanceTask`,
  yellow zone 10 cm, orange zone 1 cm, every pair of the robot's bodies less
  adjacent ones, pairs touching in the standing pose and pairs whose distance
  the hand's and legs' joints cannot change); level 2 = the hand.

Columns: degrees of freedom (``nv``), watched collision pairs, IK converged %,
median over targets of the CPU ms per iteration with avoidance and without it
(the same stack less the avoidance task, same targets), their ratio, and the hold pass % — **not yet
measured**: it needs the scene made from the robot (``Scene.from_robot``) and
the robot's own actuators as servos (issue 14's integration phase).

Each target is solved with and without avoidance back to back, so both see the
same machine load; ``--qp-solver daqp`` runs every level on DAQP instead of OSQP.

Run: ``MENAGERIE_ROOT=... OPENBLAS_NUM_THREADS=1 python benchmarks/bench_robots.py [--n 50]``
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np

from pik_mj.ground import sole_polygons
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.keyframes import standing_pose
from pik_mj.limbs import find_limbs
from pik_mj.models import load_model, menagerie_available, menagerie_models
from pik_mj.robot import Robot
from pik_mj.tasks.collision import CollisionAvoidanceTask, collision_pairs, moving_pairs
from pik_mj.tasks.support_polygon import SupportPolygonTask

ROBOTS = ("unitree_g1", "unitree_h1", "booster_t1", "sample_humanoid", "dm_humanoid")
HAND = "rarm"
MARGIN = 0.02  # [m] CoM kept this far inside the support polygon
YELLOW, ORANGE = 0.1, 0.01  # [m] collision avoidance: watched below, kept above
BOX = (np.array([0.0, -0.25, -0.1]), np.array([0.3, 0.1, 0.3]))  # × standing height
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
HOLD_PENDING = "n/a"  # the hold pass column, until Scene.from_robot and the servos land


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
    hold_pass: str = HOLD_PENDING

    @property
    def ratio(self) -> float:
        return self.ms_per_iteration / self.ms_per_iteration_without


class Setup:
    """A robot ready to solve: standing pose, limbs, soles, collision pairs."""

    def __init__(self, name: str):
        self.name = name
        model = load_model(name)
        pose = standing_pose(model)
        self.robot = Robot(model, limbs=find_limbs(model, pose.qpos))
        self.q0 = pose.qpos.copy()
        self.robot.configuration.update(self.q0)
        self.soles = sole_polygons(self.robot)
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
        limb = self.robot.limb(HAND)
        self.p_hand = self.robot.frame_pose(limb.end_frame, limb.end_frame_type).translation()
        self.height = float(self.robot.root_pose()[0][2] - min(p[:, 2].min() for p in self.soles))

    def targets(self, n: int, seed: int) -> np.ndarray:
        rng = np.random.default_rng(seed)
        return self.p_hand + self.height * rng.uniform(*BOX, size=(n, 3))

    def solve(self, target: np.ndarray, avoidance: bool, qp_solver: str = "osqp"):
        """Reach ``target`` from the standing pose; the result and the avoidance task."""
        robot = self.robot
        robot.configuration.update(self.q0)
        support = SupportPolygonTask(
            robot.configuration, self.soles, root_body=robot.root_body, margin=MARGIN
        )
        avoid = (
            [CollisionAvoidanceTask(robot.configuration, self.pairs, yellow=YELLOW, orange=ORANGE)]
            if avoidance
            else []
        )
        result = fullbody_inverse_kinematics(
            robot,
            [(target, IDENTITY)],
            limbs=[HAND],
            rotation_axis=[None],  # position only
            balance=[support],
            collision_avoidance=avoid,
            stop=100,
            revert_if_fail=False,
            qp_solver=qp_solver,
        )
        return result, avoid


def run_robot(name: str, n: int, seed: int, qp_solver: str = "osqp") -> Row:
    """Each target solved with and without avoidance, one after the other, so
    that both variants see the same machine load. Time per iteration is the
    process's CPU time of a solve over its iterations (steadier than wall time
    on a shared machine; run with one BLAS thread: ``OPENBLAS_NUM_THREADS=1``)."""
    setup = Setup(name)
    converged: dict[bool, list[bool]] = {True: [], False: []}
    per_iteration: dict[bool, list[float]] = {True: [], False: []}
    for target in setup.targets(n, seed):
        for avoidance in (True, False):
            t0 = time.process_time()
            result, _ = setup.solve(target, avoidance, qp_solver)
            cpu = time.process_time() - t0
            converged[avoidance].append(result.converged)
            per_iteration[avoidance].append(cpu / max(result.iterations, 1))
    return Row(
        robot=name,
        nv=setup.robot.model.nv,
        pairs=len(setup.pairs),
        converged=float(np.mean(converged[True])),
        ms_per_iteration=1e3 * float(np.median(per_iteration[True])),
        ms_per_iteration_without=1e3 * float(np.median(per_iteration[False])),
        converged_without=float(np.mean(converged[False])),
    )


def available(name: str) -> bool:
    return name not in menagerie_models() or menagerie_available(name)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=50, help="hand targets per robot")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--robots", nargs="*", default=list(ROBOTS))
    parser.add_argument("--qp-solver", default="osqp", help="osqp (default) or daqp")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    rows, skipped = [], []
    t0 = time.perf_counter()
    for name in args.robots:
        if not available(name):
            skipped.append(name)
            continue
        rows.append(run_robot(name, args.n, args.seed, args.qp_solver))
    if not args.quiet:
        print(
            f"{'robot':16} {'nv':>3} {'pairs':>5} {'IK conv':>7} {'ms/it':>6} "
            f"{'ms/it w/o':>9} {'ratio':>5} {'conv w/o':>8} {'hold pass':>9}"
        )
        for r in rows:
            print(
                f"{r.robot:16} {r.nv:3d} {r.pairs:5d} {100 * r.converged:6.0f}% "
                f"{r.ms_per_iteration:6.2f} {r.ms_per_iteration_without:9.2f} "
                f"{r.ratio:5.2f} {100 * r.converged_without:7.0f}% {r.hold_pass:>9}"
            )
        for name in skipped:
            print(f"{name:16} skipped: not under MENAGERIE_ROOT nor in the mujoco-menagerie cache")
        print(
            f"{args.n} targets per robot, seed {args.seed}, QP solver {args.qp_solver}, "
            f"{time.perf_counter() - t0:.0f} s"
        )
    return {
        "targets": args.n,
        "rows": {r.robot: {**r.__dict__, "ratio": r.ratio} for r in rows},
        "skipped": skipped,
    }


if __name__ == "__main__":
    main()
