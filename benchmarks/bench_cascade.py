"""The priority cascade against mink's single weighted QP, in one run.

Stack (dm_control's humanoid, 27 DoF, floating base): joint limits hard; both
feet (pose) at level 1; the right hand (pose) at level 2; posture at level 3.
mink gets the same tasks in one QP (``mink.solve_ik``, solver "osqp") with the
same limits.

Prints, side by side:
* reachable targets (forward kinematics of random feet-consistent postures):
  success rate to 1 mm / 1 degree within 50 iterations, median iterations;
* an unreachable hand target 2 m away: the worst foot drift over 50 iterations;
* the median time of one iteration and the ratio cascade / mink.

Run: ``python benchmarks/bench_cascade.py [--targets 100]``
"""

from __future__ import annotations

import argparse
import time

import cases
import mink
import numpy as np

import pik_mj

THRE, RTHRE = 1e-3, np.deg2rad(1.0)


def satisfied(task, cfg) -> bool:
    e = task.compute_error(cfg)
    return bool(np.linalg.norm(e[:3]) <= THRE and np.linalg.norm(e[3:]) <= RTHRE)


def run_cascade(model, target, stop=50, callback=None, qp_solver="osqp"):
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    stack = cases.reach_stack(cfg, target)
    result = pik_mj.solve(
        cfg, stack.levels, stop=stop, revert_if_fail=False, callback=callback, qp_solver=qp_solver
    )
    return result, stack, cfg


def run_mink(model, target, stop=50, callback=None):
    """mink's loop with the same stop test as the cascade."""
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    stack = cases.reach_stack(cfg, target)  # only for its error functions
    tasks = cases.mink_reach_tasks(cfg, target)
    limits = [mink.ConfigurationLimit(model)]
    times = []
    converged = False
    iterations = 0
    for iterations in range(1, stop + 1):  # noqa: B007 - used after the loop
        t0 = time.perf_counter()
        v = mink.solve_ik(cfg, tasks, 1.0, "osqp", limits=limits)
        cfg.integrate_inplace(v, 1.0)
        times.append(time.perf_counter() - t0)
        if callback is not None:
            callback(cfg)
        if all(satisfied(t, cfg) for t in [*stack.feet, stack.hand]):
            converged = True
            break
    return converged, iterations, times, stack


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", type=int, default=100)
    args = parser.parse_args(argv)
    model = cases.dm_humanoid()
    targets = cases.reachable_hand_targets(model, args.targets, seed=0)

    c_ok, c_its, c_times = 0, [], []
    m_ok, m_its, m_times = 0, [], []
    d_times: list[float] = []
    for target in targets:
        result, _, _ = run_cascade(model, target)
        c_ok += result.converged
        c_its.append(result.iterations)
        c_times += result.iteration_times
        d_times += run_cascade(model, target, qp_solver="daqp")[0].iteration_times
        ok, its, times, _ = run_mink(model, target)
        m_ok += ok
        m_its.append(its)
        m_times += times

    far = cases.unreachable_hand_target(mink.Configuration(model), 2.0)
    # Both runs start from the stance, so one stack's feet tasks measure both drifts.
    stance_cfg = mink.Configuration(model)
    stance_cfg.update(cases.stance(model))
    feet = cases.reach_stack(stance_cfg, far).feet

    def foot_drift(cfg: mink.Configuration) -> float:
        return max(np.linalg.norm(f.compute_error(cfg)[:3]) for f in feet)

    c_drift: list[float] = []
    run_cascade(model, far, callback=lambda info: c_drift.append(foot_drift(info.configuration)))
    m_drift: list[float] = []
    run_mink(model, far, callback=lambda cfg: m_drift.append(foot_drift(cfg)))

    c_ms, m_ms = 1e3 * np.median(c_times), 1e3 * np.median(m_times)
    d_ms = 1e3 * np.median(d_times)
    figures = {
        "targets": len(targets),
        "cascade_success": c_ok / len(targets),
        "mink_success": m_ok / len(targets),
        "cascade_median_iterations": float(np.median(c_its)),
        "mink_median_iterations": float(np.median(m_its)),
        "cascade_max_foot_drift_m": max(c_drift),
        "mink_max_foot_drift_m": max(m_drift),
        "cascade_ms_per_iteration": c_ms,
        "mink_ms_per_iteration": m_ms,
        "ratio": c_ms / m_ms,
        "cascade_daqp_ms_per_iteration": d_ms,
        "ratio_daqp": d_ms / m_ms,
    }
    print(f"dm_control humanoid, {len(targets)} reachable targets, 1 mm / 1 deg, stop 50")
    print(f"{'':34}{'cascade':>12}{'mink':>12}{'ratio':>8}")
    print(f"{'success rate':34}{figures['cascade_success']:>12.0%}{figures['mink_success']:>12.0%}")
    print(
        f"{'median iterations':34}{figures['cascade_median_iterations']:>12.1f}"
        f"{figures['mink_median_iterations']:>12.1f}"
    )
    print(
        f"{'max foot drift, hand 2 m away [m]':34}{figures['cascade_max_foot_drift_m']:>12.1e}"
        f"{figures['mink_max_foot_drift_m']:>12.1e}"
    )
    print(f"{'median time per iteration [ms]':34}{c_ms:>12.3f}{m_ms:>12.3f}{c_ms / m_ms:>8.2f}")
    print(f"{'  cascade with qp_solver=daqp':34}{d_ms:>12.3f}{m_ms:>12.3f}{d_ms / m_ms:>8.2f}")
    return figures


if __name__ == "__main__":
    main()
