"""What keeping the robot clear of its world costs: full-body reaches in the room,
with the default world avoidance and without it, one row per robot.

Robots: the project's ``sample_humanoid`` and MuJoCo Menagerie's Unitree G1, H1
and Booster T1 (through ``MENAGERIE_ROOT``; a robot that is not on the machine
is skipped, saying so), each placed in the room at ``spot_counter_front``
(``Robot.from_model(name, environment="room", at="spot_counter_front")``).
Targets: the README's first example (the right hand 15 cm short of the kettle
handle, orientation free) and ``--n - 1`` more drawn uniformly within 8 cm of it
(seeded). Each target is solved twice from the standing pose, back to back (both
see the same machine load) by :func:`pik_mj.ik.fullbody_inverse_kinematics` with
its defaults: with the world avoidance (``avoid_world=True``: the pairs of a robot
geom and a world geom MuJoCo collides, :mod:`pik_mj.ik.world`) and without it
(``avoid_world=False``).

Columns: world pairs watched; the wall-clock ms per iteration (median over targets of
each solve's median) with and without, and their ratio; the time of one
evaluation of the avoidance task at the start pose (bounding-volume test of
every pair, ``mj_geomDistance`` of the near ones, their rows) [ms]; IK converged
% with and without; the smallest robot–world distance over every iterate
(``mj_geomDistance`` of the watched pairs; negative: through the world) with and
without [mm], the minimum over targets.

The peer: mink's own avoidance (``mink.CollisionAvoidanceLimit`` on the same
pairs, the same clearance, reach and gain, beside ``ConfigurationLimit``) in
``mink.solve_ik``'s single weighted QP: the right hand's position at cost 1, both
feet's poses at cost 10, posture 1e-2, ``integrate_inplace`` per iteration, at
most 50 iterations, stopping with the hand within 1 mm (or where OSQP finds no
step: ``mink.NoSolutionFound``, not converged). Columns: its wall-clock ms per
iteration and pik_mj's ratio to it (with avoidance), its smallest robot–world
distance [mm], converged %, and how far it moved a foot [mm] (the largest
distance of a foot from its start over every iterate; pik_mj keeps the feet
within 1e-4 m).

Run: ``MENAGERIE_ROOT=... OPENBLAS_NUM_THREADS=1 python benchmarks/bench_avoidance.py [--n 10]``
"""

from __future__ import annotations

import argparse
import time
import warnings

import mink
import mujoco
import numpy as np
from qpsolvers.warnings import SparseConversionWarning

from pik_mj import Robot
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.ik.arguments import root_dofs
from pik_mj.ik.world import WorldAvoidance, world_avoidance
from pik_mj.robot.loading import menagerie_available
from pik_mj.robot.stack import moving_dofs

ROBOTS = ("sample_humanoid", "unitree_g1", "unitree_h1", "booster_t1")
SPREAD = 0.08  # [m] targets within this of the README's
STOP = 50  # iterations, pik_mj's default
SHORT = np.array([0.15, 0.0, 0.0])  # [m] the README's target: this short of the handle


def targets(robot: Robot, n: int, seed: int) -> list[np.ndarray]:
    """The README's target and ``n - 1`` drawn within :data:`SPREAD` of it [m]."""
    base = robot.frame_pose("kettle_handle").translation() - SHORT
    rng = np.random.default_rng(seed)
    return [base] + [base + rng.uniform(-SPREAD, SPREAD, 3) for _ in range(n - 1)]


def solve(robot: Robot, target: np.ndarray, avoid: bool, pairs) -> tuple[bool, float, float]:
    """One reach from the start: ``(converged, median ms per iteration, smallest
    distance of ``pairs`` over the iterates [m])``; the start restored."""
    m, q0 = robot.model, robot.configuration.q.copy()

    def nearest() -> float:
        return min(mujoco.mj_geomDistance(m, robot.data, a, b, 1.0, None) for a, b in pairs)

    seen = [nearest()]
    result = fullbody_inverse_kinematics(
        robot,
        [(target, [1.0, 0.0, 0.0, 0.0])],
        limbs=[robot.limb("rarm").name],
        rotation_axis=[None],
        avoid_world=avoid,
        revert_if_fail=False,
        callback=lambda _info: seen.append(nearest()),
    )
    robot.configuration.update(q0)
    return result.converged, 1e3 * float(np.median(result.iteration_times)), min(seen)


def solve_mink(robot: Robot, target: np.ndarray, pairs) -> tuple[bool, float, float, float]:
    """The same reach in mink (module docstring): ``(converged, median ms per
    iteration, smallest distance of ``pairs`` [m], largest foot drift [m])``."""
    m = robot.model
    cfg = mink.Configuration(m)
    cfg.update(robot.configuration.q.copy())
    feet = [robot.limb(leg).end_frame for leg in ("rleg", "lleg")]
    kinds = [robot.limb(leg).end_frame_type for leg in ("rleg", "lleg")]
    tasks = [
        mink.FrameTask(f, k, position_cost=10.0, orientation_cost=10.0)
        for f, k in zip(feet, kinds, strict=True)
    ]
    for task in tasks:
        task.set_target_from_configuration(cfg)
    arm = robot.limb("rarm")
    hand = mink.FrameTask(
        arm.end_frame, arm.end_frame_type, position_cost=1.0, orientation_cost=0.0
    )
    hand.set_target(mink.SE3.from_translation(target))
    posture = mink.PostureTask(m, cost=1e-2)
    posture.set_target_from_configuration(cfg)
    avoidance = WorldAvoidance()
    limits = [
        mink.ConfigurationLimit(m),
        mink.CollisionAvoidanceLimit(
            m,
            [([a], [b]) for a, b in pairs],
            gain=avoidance.gain,
            minimum_distance_from_collisions=avoidance.clearance,
            collision_detection_distance=avoidance.reach,
        ),
    ]
    # mink hands qpsolvers dense matrices, and qpsolvers calls OSQP's solve()
    # without raise_error: both warn on every call
    warnings.filterwarnings("ignore", category=SparseConversionWarning)
    warnings.filterwarnings("ignore", "The default value of raise_error", PendingDeprecationWarning)
    start = [
        cfg.get_transform_frame_to_world(f, k).translation()
        for f, k in zip(feet, kinds, strict=True)
    ]
    seen, drift, times, converged = [], 0.0, [], False
    for _ in range(STOP):
        t = time.perf_counter()
        try:
            v = mink.solve_ik(cfg, [*tasks, hand, posture], 1.0, "osqp", limits=limits)
        except mink.NoSolutionFound:
            break  # OSQP gave up on a step: the run ends there, not converged
        cfg.integrate_inplace(v, 1.0)
        times.append(time.perf_counter() - t)
        seen.append(min(mujoco.mj_geomDistance(m, cfg.data, a, b, 1.0, None) for a, b in pairs))
        for f, k, p0 in zip(feet, kinds, start, strict=True):
            drift = max(
                drift,
                float(np.linalg.norm(cfg.get_transform_frame_to_world(f, k).translation() - p0)),
            )
        if np.linalg.norm(hand.compute_error(cfg)[:3]) < 1e-3:
            converged = True
            break
    if not times:
        return False, float("nan"), float("inf"), 0.0
    return converged, 1e3 * float(np.median(times)), min(seen), drift


def evaluation_ms(robot: Robot, repeats: int = 200) -> tuple[int, float]:
    """The world-avoidance task of a right-hand reach at the start pose: its pairs
    and the time of one :meth:`evaluate` [ms] (median of ``repeats``)."""
    dofs = moving_dofs(robot.model, robot.limb("rarm").joints, root_dofs(robot))
    task = world_avoidance(robot, True, dofs)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        task.evaluate(robot.configuration)
        times.append(time.perf_counter() - t)
    return len(task.pairs), 1e3 * float(np.median(times))


def row(name: str, n: int, seed: int) -> str:
    robot = Robot.from_model(name, environment="room", at="spot_counter_front")
    n_pairs, eval_ms = evaluation_ms(robot)
    dofs = moving_dofs(robot.model, robot.limb("rarm").joints, root_dofs(robot))
    pairs = [(p.geom1, p.geom2) for p in world_avoidance(robot, True, dofs).pairs]
    on, off, peer = [], [], []
    for target in targets(robot, n, seed):
        on.append(solve(robot, target, True, pairs))
        off.append(solve(robot, target, False, pairs))
        peer.append(solve_mink(robot, target, pairs))
    ms_on = float(np.median([r[1] for r in on]))
    ms_off = float(np.median([r[1] for r in off]))
    conv_on = 100.0 * np.mean([r[0] for r in on])
    conv_off = 100.0 * np.mean([r[0] for r in off])
    d_on, d_off = 1e3 * min(r[2] for r in on), 1e3 * min(r[2] for r in off)
    ms_mink = float(np.nanmedian([r[1] for r in peer]))
    mink_cells = (
        f"{ms_mink:.1f} | {ms_on / ms_mink:.2f} | {1e3 * min(r[2] for r in peer):.1f} | "
        f"{100.0 * np.mean([r[0] for r in peer]):.0f} | {1e3 * max(r[3] for r in peer):.1f} |"
    )
    return (
        f"| {name} | {n_pairs} | {ms_on:.1f} | {ms_off:.1f} | {ms_on / ms_off:.2f} | "
        f"{eval_ms:.3f} | {conv_on:.0f} | {conv_off:.0f} | {d_on:.1f} | {d_off:.1f} | " + mink_cells
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10, help="targets per robot")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--robots", nargs="*", default=list(ROBOTS))
    args = parser.parse_args()
    print(
        "| robot | world pairs | ms/iter with | ms/iter without | ratio | evaluate ms | "
        "converged % with | without | min distance mm with | without | "
        "mink ms/iter | ratio to mink | mink min distance mm | mink converged % | "
        "mink foot drift mm |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.robots:
        if name not in ("sample_humanoid",) and not menagerie_available(name):
            print(f"| {name} | skipped: not on this machine (set MENAGERIE_ROOT) |")
            continue
        print(row(name, args.n, args.seed), flush=True)


if __name__ == "__main__":
    main()
