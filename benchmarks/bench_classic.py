"""irteus' classic IK vs pik_mj's cascade vs mink.solve_ik, on 3-DoF arm and
full-body targets.

Arm: targets are reachable by construction: the end pose of a random
configuration inside the joint ranges (x, z and the pitch about y: the arm is
planar). Full body: dm_control's humanoid with both feet and the right hand as
targets (``benchmarks/cases.py``; the classic solver stacks all three in one
SR-inverse, the cascade puts the feet above the hand, mink weighs them in one
QP). Every solver starts from the same configuration and stops at ``--stop``
iterations or when every target is within 1 mm and 1 degree.

    python benchmarks/bench_classic.py --n 100 --seed 0
"""

from __future__ import annotations

import argparse
import json
import time

import cases
import mink
import numpy as np

from pik_mj import FrameTask, solve
from pik_mj.ik.classic import classic_inverse_kinematics
from pik_mj.robot.loading import load_model

THRE, RTHRE = 1e-3, np.deg2rad(1.0)


def _arm_task(conf: mink.Configuration, target: mink.SE3) -> FrameTask:
    # The arm moves in the xz-plane: match x, z (y free) and the rotation about y.
    return FrameTask(
        conf, "end", target, translation_axis="y", rotation_axis="zx", thre=THRE, rthre=RTHRE
    )


def seed_clamped(tasks: list[FrameTask]) -> list[FrameTask]:
    """The seed's per-iteration step limits (0.1 m, 0.5 rad) on ``tasks``: the
    classic SR-inverse has no trust region and relies on them."""
    for task in tasks:
        task.p_limit, task.r_limit = 0.1, 0.5
    return tasks


def _run_classic(conf, target, stop):
    r = classic_inverse_kinematics(conf, seed_clamped([_arm_task(conf, target)]), stop=stop)
    return r.converged, r.iterations, float(np.sum(r.iteration_times))


def _run_pik(conf, target, stop):
    levels = [[mink.ConfigurationLimit(conf.model)], [_arm_task(conf, target)]]
    r = solve(conf, levels, stop=stop)
    return r.converged, r.iterations, float(np.sum(r.iteration_times))


def _run_mink(conf, target, stop):
    task = mink.FrameTask("end", "site", position_cost=1.0, orientation_cost=1.0)
    task.set_target(target)
    limits = [mink.ConfigurationLimit(conf.model)]
    t0 = time.perf_counter()
    for it in range(1, stop + 1):
        v = mink.solve_ik(conf, [task], 1.0, "daqp", damping=1e-6, limits=limits)
        conf.integrate_inplace(v, 1.0)
        e = task.compute_error(conf)
        if np.linalg.norm(e[:3]) <= THRE and np.linalg.norm(e[3:]) <= RTHRE:
            return True, it, time.perf_counter() - t0
    return False, stop, time.perf_counter() - t0


SOLVERS = {
    "classic (SR-inverse)": _run_classic,
    "pik_mj.solve": _run_pik,
    "mink.solve_ik": _run_mink,
}


def compare(n: int = 100, seed: int = 0, stop: int = 50, q_start=(0.3, 0.3, 0.3)) -> dict:
    """Success rate, iterations and time per iteration of each solver on ``n`` targets."""
    model = load_model("three_dof_arm")
    conf = mink.Configuration(model)
    rng = np.random.default_rng(seed)
    lo, hi = model.jnt_range[:, 0], model.jnt_range[:, 1]
    targets = []
    for _ in range(n):
        conf.update(rng.uniform(lo, hi))
        targets.append(conf.get_transform_frame_to_world("end", "site"))
    q0 = np.array(q_start, dtype=float)
    out = {}
    for name, run in SOLVERS.items():
        runs = []
        for target in targets:
            conf.update(q0)
            runs.append(run(conf, target, stop))
        out[name] = _tally(runs)
    return out


def _tally(runs: list[tuple[bool, int, float]]) -> dict:
    """Success rate, mean iterations of the converged runs and time per iteration
    from ``(converged, iterations, seconds)`` per target."""
    ok = np.array([r[0] for r in runs])
    iters = np.array([r[1] for r in runs])
    secs = sum(r[2] for r in runs)
    return {
        "success_rate": float(ok.mean()),
        "mean_iterations_converged": float(iters[ok].mean()) if ok.any() else None,
        "ms_per_iteration": 1e3 * float(secs / max(iters.sum(), 1)),
    }


def _fullbody_satisfied(stack, conf) -> bool:
    return all(t.is_satisfied(conf) for t in [*stack.feet, stack.hand])


def _fullbody_classic(conf, stack, stop):
    r = classic_inverse_kinematics(conf, seed_clamped([*stack.feet, stack.hand]), stop=stop)
    return r.converged, r.iterations, float(np.sum(r.iteration_times))


def _fullbody_pik(conf, stack, stop):
    r = solve(conf, stack.levels, stop=stop)
    return r.converged, r.iterations, float(np.sum(r.iteration_times))


def _fullbody_mink(conf, stack, stop):
    p_WT, R_WT = stack.hand.target_pose_now(conf)
    target = mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(R_WT), p_WT)
    tasks = cases.mink_reach_tasks(conf, target)
    limits = [mink.ConfigurationLimit(conf.model)]
    t0 = time.perf_counter()
    for it in range(1, stop + 1):
        v = mink.solve_ik(conf, tasks, 1.0, "daqp", damping=1e-6, limits=limits)
        conf.integrate_inplace(v, 1.0)
        if _fullbody_satisfied(stack, conf):
            return True, it, time.perf_counter() - t0
    return False, stop, time.perf_counter() - t0


FULLBODY_SOLVERS = {
    "classic (SR-inverse)": _fullbody_classic,
    "pik_mj.solve": _fullbody_pik,
    "mink.solve_ik": _fullbody_mink,
}


def compare_fullbody(n: int = 100, seed: int = 0, stop: int = 50) -> dict:
    """The same figures on ``n`` reachable full-body targets (feet fixed, right hand)."""
    model = cases.dm_humanoid()
    conf = mink.Configuration(model)
    targets = cases.reachable_hand_targets(model, n, seed=seed)
    stance = cases.stance(model)
    out = {}
    for name, run in FULLBODY_SOLVERS.items():
        runs = []
        for target in targets:
            conf.update(stance)
            runs.append(run(conf, cases.reach_stack(conf, target), stop))
        out[name] = _tally(runs)
    return out


def _print(title: str, result: dict) -> None:
    print(title)
    for name, r in result.items():
        iters = r["mean_iterations_converged"]
        print(
            f"  {name:<22} success {100 * r['success_rate']:5.1f} %   "
            f"iterations {iters if iters is None else f'{iters:5.1f}'}   "
            f"{r['ms_per_iteration']:.3f} ms/iteration"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--stop", type=int, default=50)
    parser.add_argument("--start", type=float, nargs=3, default=(0.3, 0.3, 0.3))
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args()
    result = {
        "arm": compare(args.n, args.seed, args.stop, args.start),
        "fullbody": compare_fullbody(args.n, args.seed, args.stop),
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    _print(
        f"{args.n} reachable 3-DoF arm targets, start q = {list(args.start)}, stop = {args.stop}",
        result["arm"],
    )
    _print(
        f"{args.n} reachable full-body targets (dm_control humanoid: feet + right hand), "
        f"stop = {args.stop}",
        result["fullbody"],
    )


if __name__ == "__main__":
    main()
