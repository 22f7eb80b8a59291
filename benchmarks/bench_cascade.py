"""Time to solution: the priority cascade against mink's single weighted QP.

Stack, on dm_control's humanoid (27 DoF) and CMU humanoid (62 DoF), floating
base: joint limits hard; both feet (pose) at level 1; the right hand (pose) at
level 2; posture at level 3. mink gets the same tasks in one QP
(``mink.solve_ik``) with the same limits, the feet at cost 10 (``--feet-cost``),
hand 1, posture 1e-2.

Five solvers in the same run, on the same FK-reachable hand targets, every one
starting from the same stance and stopping when both feet and the hand are
within 1 mm / 1 degree (at most 50 iterations):

* ``pik osqp``: ``pik_mj.solve`` with the default backend (one OSQP QP per level);
* ``pik daqp-hqp``: ``pik_mj.solve(qp_solver="daqp-hqp")`` (the whole
  hierarchy in one DAQP call);
* ``hqp no bound``: ``daqp-hqp`` without the bound on the feet's drift
  (``correct=False``, ``TrustRegion(drift=1.0)``): what the guarantee costs;
* ``mink osqp`` and ``mink daqp``: ``mink.solve_ik`` + ``integrate_inplace`` +
  the same stop test, per iteration.

Time to solution is the wall time of the whole loop (the solve call, or mink's
loop with its stop test), tasks built beforehand for both. Each figure is the
median over targets in one round; the table shows the median over ``--rounds``
rounds, and each ratio is the median of the ratios measured within a round
(their range over the rounds is printed too).

Also measured, in a separate untimed pass: how far each solver moves the feet
on the way, the largest distance of a foot from its start position over every
iterate of every target (:func:`path_drift`); and the worst foot drift over 50
iterations when the hand target is 2 m out of reach, with pik_mj's FrameTasks
and with raw ``mink.FrameTask``s in the cascade.

And a stack where a level is not part of the stop test (:func:`unchecked_level`):
the CoM pinned over its start at level 2 with ``check=False``, between the
feet and the hand 2 m out of reach, 50 iterations per solver: time per
iteration (mink: the same tasks, the CoM at the feet's cost, one QP) and the
worst foot and CoM drift over the iterates.

Run: ``python benchmarks/bench_cascade.py [--targets 20] [--rounds 5]``
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import cases
import mink
import numpy as np
from qpsolvers.warnings import SparseConversionWarning

import pik_mj
from pik_mj.solve import TrustRegion
from pik_mj.tasks.com import CentroidTask

THRE, RTHRE = 1e-3, np.deg2rad(1.0)
STOP = 50
UNBOUNDED = {"correct": False, "trust_region": TrustRegion(drift=1.0)}
"""``hqp no bound``'s options: no correction, and a trust region that accepts
any drift of the levels above (1 m or 1 rad) but still adapts the step."""
PIK_RUNS = {
    "pik osqp": ("osqp", None),
    "pik daqp-hqp": ("daqp-hqp", None),
    "hqp no bound": ("daqp-hqp", UNBOUNDED),
}
"""The cascade's solvers: backend and more options of ``pik_mj.solve``."""
MINK_RUNS = {"mink osqp": "osqp", "mink daqp": "daqp"}
"""mink's solvers: the ``qpsolvers`` name handed to ``mink.solve_ik``."""
PIK_SOLVERS = tuple(PIK_RUNS)
SOLVERS = (*PIK_RUNS, *MINK_RUNS)
MODELS = {"dm_control humanoid (27 DoF)": cases.DM, "CMU humanoid (62 DoF)": cases.CMU}


@dataclass
class Run:
    """One solve: converged, iterations, wall time [s]."""

    converged: bool
    iterations: int
    seconds: float
    evaluations: list[int] | None = None  # per level (pik only)
    corrections: int = 0


def satisfied(task, cfg) -> bool:
    e = task.compute_error(cfg)
    return bool(np.linalg.norm(e[:3]) <= THRE and np.linalg.norm(e[3:]) <= RTHRE)


def run_cascade(
    model, target, qp_solver="osqp", stop=STOP, callback=None, options: dict | None = None
) -> Run:
    """``pik_mj.solve`` on the reference stack (``options``: more of its keywords)."""
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    stack = cases.reach_stack(cfg, target)
    t0 = time.perf_counter()
    result = pik_mj.solve(
        cfg,
        stack.levels,
        stop=stop,
        revert_if_fail=False,
        callback=callback,
        qp_solver=qp_solver,
        **(options or {}),
    )
    seconds = time.perf_counter() - t0
    return Run(result.converged, result.iterations, seconds, result.evaluations, result.corrections)


def run_mink(
    model, target, solver="osqp", feet_cost=10.0, stop=STOP, callback: Callable | None = None
) -> Run:
    """mink's loop with the same stop test as the cascade (mink's own errors)."""
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    tasks = cases.mink_reach_tasks(cfg, target, feet_cost=feet_cost)
    checked = tasks[:3]  # feet and hand
    limits = [mink.ConfigurationLimit(model)]
    # mink hands qpsolvers dense matrices, and qpsolvers calls OSQP's solve()
    # without raise_error: both warn on every call
    warnings.filterwarnings("ignore", category=SparseConversionWarning)
    warnings.filterwarnings("ignore", "The default value of raise_error", PendingDeprecationWarning)
    converged, iterations = False, 0
    t0 = time.perf_counter()
    for iterations in range(1, stop + 1):  # noqa: B007 - used after the loop
        v = mink.solve_ik(cfg, tasks, 1.0, solver, limits=limits)
        cfg.integrate_inplace(v, 1.0)
        if callback is not None:
            callback(cfg)
        if all(satisfied(t, cfg) for t in checked):
            converged = True
            break
    return Run(converged, iterations, time.perf_counter() - t0)


def one_round(model, targets, feet_cost: float) -> dict[str, list[Run]]:
    runs: dict[str, list[Run]] = {s: [] for s in SOLVERS}
    for target in targets:
        for s, (qp_solver, options) in PIK_RUNS.items():
            runs[s].append(run_cascade(model, target, qp_solver, options=options))
        for s, solver in MINK_RUNS.items():
            runs[s].append(run_mink(model, target, solver, feet_cost))
    return runs


def path_drift(model, targets, feet_cost: float) -> dict[str, float]:
    """Per solver, the largest distance [m] of a foot from its start position
    over every iterate of every target (untimed: the callbacks read poses)."""
    feet = [model.body(f).id for f in cases.humanoid_of(model).feet]
    start = mink.Configuration(model)
    start.update(cases.stance(model))
    p0 = start.data.xpos[feet].copy()
    worst = {s: 0.0 for s in SOLVERS}

    def watcher(solver: str) -> Callable:
        def watch(cfg: mink.Configuration) -> None:
            moved = float(np.linalg.norm(cfg.data.xpos[feet] - p0, axis=1).max())
            worst[solver] = max(worst[solver], moved)

        return watch

    for target in targets:
        for s, (qp_solver, options) in PIK_RUNS.items():
            watch = watcher(s)
            run_cascade(
                model,
                target,
                qp_solver,
                callback=lambda i, w=watch: w(i.configuration),
                options=options,
            )
        for s, solver in MINK_RUNS.items():
            run_mink(model, target, solver, feet_cost, callback=watcher(s))
    return worst


def foot_drift(model, raw_mink: bool) -> float:
    """Worst foot position error [m] over 50 iterations, hand 2 m out of reach."""
    h = cases.humanoid_of(model)
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    far = cases.unreachable_hand_target(cfg, 2.0)
    stack = cases.reach_stack(cfg, far)
    levels = stack.levels
    if raw_mink:
        feet = [mink.FrameTask(f, "body", position_cost=1.0, orientation_cost=1.0) for f in h.feet]
        for f in feet:
            f.set_target_from_configuration(cfg)
        hand = mink.FrameTask(h.hand, "body", position_cost=1.0, orientation_cost=1.0)
        hand.set_target(far)
        levels = [levels[0], feet, [hand], levels[3]]
    drift: list[float] = []

    def watch(info):
        drift.append(max(np.linalg.norm(f.pose_error(info.configuration)[:3]) for f in stack.feet))

    pik_mj.solve(cfg, levels, stop=STOP, revert_if_fail=False, callback=watch)
    return max(drift)


class DriftWatch:
    """The worst foot displacement and CoM xy drift [m] from the stance over
    the iterates it is shown (:meth:`see`)."""

    def __init__(self, model) -> None:
        cfg = mink.Configuration(model)
        cfg.update(cases.stance(model))
        self.feet = [model.body(f).id for f in cases.humanoid_of(model).feet]
        self.p0 = cfg.data.xpos[self.feet].copy()
        self.c0 = cfg.data.subtree_com[1].copy()
        self.foot_m = self.com_m = 0.0

    def see(self, cfg: mink.Configuration) -> None:
        moved = np.linalg.norm(cfg.data.xpos[self.feet] - self.p0, axis=1).max()
        self.foot_m = max(self.foot_m, float(moved))
        com = np.linalg.norm(cfg.data.subtree_com[1][:2] - self.c0[:2])
        self.com_m = max(self.com_m, float(com))


def unchecked_pik(model, solver: str, watch: DriftWatch | None = None) -> float:
    """``pik_mj.solve`` on the reference stack with the CoM pinned at level 2
    (``check=False``), the hand 2 m out of reach, :data:`STOP` iterations;
    returns the wall time [s]."""
    qp_solver, options = PIK_RUNS[solver]
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 2.0))
    pinned = CentroidTask(cfg, cfg.data.subtree_com[1].copy(), check=False)
    levels = [*stack.levels[:2], [pinned], *stack.levels[2:]]
    callback = None if watch is None else (lambda info: watch.see(info.configuration))
    t0 = time.perf_counter()
    pik_mj.solve(
        cfg,
        levels,
        stop=STOP,
        revert_if_fail=False,
        qp_solver=qp_solver,
        callback=callback,
        **(options or {}),
    )
    return time.perf_counter() - t0


def unchecked_mink(model, solver: str, feet_cost: float, watch: DriftWatch | None = None) -> float:
    """mink's loop on the same tasks, the CoM's x and y at the feet's cost,
    :data:`STOP` iterations; returns the wall time [s]."""
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    tasks = cases.mink_reach_tasks(cfg, cases.unreachable_hand_target(cfg, 2.0), feet_cost)
    com = mink.ComTask(cost=np.array([feet_cost, feet_cost, 0.0]))
    com.set_target(cfg.data.subtree_com[1].copy())
    tasks.insert(2, com)
    limits = [mink.ConfigurationLimit(model)]
    t0 = time.perf_counter()
    for _ in range(STOP):
        v = mink.solve_ik(cfg, tasks, 1.0, MINK_RUNS[solver], limits=limits)
        cfg.integrate_inplace(v, 1.0)
        if watch is not None:
            watch.see(cfg)
    return time.perf_counter() - t0


def unchecked_level(model, feet_cost: float) -> dict[str, dict[str, float]]:
    """Per solver, with the CoM pinned at level 2 (``check=False``) and the
    hand 2 m out of reach: ms per iteration (timed without callbacks), the
    worst foot displacement and CoM xy drift [m] over the iterates (a second,
    watched run)."""
    out = {}
    for s in SOLVERS:
        watch = DriftWatch(model)
        if s in PIK_RUNS:
            seconds = unchecked_pik(model, s)
            unchecked_pik(model, s, watch)
        else:
            seconds = unchecked_mink(model, s, feet_cost)
            unchecked_mink(model, s, feet_cost, watch)
        out[s] = {
            "ms_per_iteration": 1e3 * seconds / STOP,
            "feet_m": watch.foot_m,
            "com_m": watch.com_m,
        }
    return out


def summarize(rounds: list[dict[str, list[Run]]]) -> dict[str, dict[str, float]]:
    """Medians over targets per round, then medians over rounds; paired ratios."""
    out: dict[str, dict[str, float]] = {}
    for s in SOLVERS:
        ms = [1e3 * np.median([r.seconds for r in rnd[s]]) for rnd in rounds]
        its = [np.median([r.iterations for r in rnd[s]]) for rnd in rounds]
        per_it = [
            1e3 * np.median([r.seconds / max(r.iterations, 1) for r in rnd[s]]) for rnd in rounds
        ]
        ok = [np.mean([r.converged for r in rnd[s]]) for rnd in rounds]
        out[s] = {
            "success": float(np.min(ok)),
            "iterations": float(np.median(its)),
            "ms_per_iteration": float(np.median(per_it)),
            "ms_to_solution": float(np.median(ms)),
            "ms_to_solution_runs": [float(m) for m in ms],
        }

    def ratios(a: str, b: str) -> list[float]:
        return [
            float(np.median([r.seconds for r in rnd[a]]) / np.median([r.seconds for r in rnd[b]]))
            for rnd in rounds
        ]

    pairs = {
        "pik osqp / mink osqp": ("pik osqp", "mink osqp"),
        "pik daqp-hqp / mink daqp": ("pik daqp-hqp", "mink daqp"),
        "hqp no bound / mink daqp": ("hqp no bound", "mink daqp"),
    }
    for s in PIK_SOLVERS:
        runs = [r for rnd in rounds for r in rnd[s]]
        its = sum(r.iterations for r in runs)
        out[s]["evaluations_per_iteration"] = [
            float(v) / its for v in np.sum([r.evaluations for r in runs], axis=0)
        ]
        out[s]["corrections_per_iteration"] = sum(r.corrections for r in runs) / its
    out["ratio_runs"] = {label: ratios(a, b) for label, (a, b) in pairs.items()}
    out["ratios"] = {label: float(np.median(r)) for label, r in out["ratio_runs"].items()}
    return out


def print_table(name: str, n: int, rounds: int, s: dict) -> None:
    print(f"\n{name}: {n} reachable targets, 1 mm / 1 deg, stop {STOP}, {rounds} rounds")
    print(f"{'':26}" + "".join(f"{k:>14}" for k in SOLVERS))
    for key, label, fmt in (
        ("success", "success", "{:>14.0%}"),
        ("iterations", "median iterations", "{:>14.1f}"),
        ("ms_per_iteration", "ms per iteration", "{:>14.3f}"),
        ("ms_to_solution", "ms to solution", "{:>14.3f}"),
    ):
        print(f"{label:26}" + "".join(fmt.format(s[k][key]) for k in SOLVERS))
    drift = s["path_drift_m"]
    print(f"{'feet moved on the way [m]':26}" + "".join(f"{drift[k]:>14.1e}" for k in SOLVERS))
    for k in PIK_SOLVERS:
        evals = ", ".join(f"{v:.2f}" for v in s[k]["evaluations_per_iteration"])
        print(
            f"  {k}, per iteration: evaluations of levels 0..3 {evals}; "
            f"corrections {s[k]['corrections_per_iteration']:.2f}"
        )
    for label, value in s["ratios"].items():
        runs = s["ratio_runs"][label]
        print(
            f"  time to solution, {label}: {value:.2f} (rounds: {min(runs):.2f} to {max(runs):.2f})"
        )


def print_unchecked(u: dict[str, dict[str, float]]) -> None:
    print(f"  CoM pinned at level 2, check=False, hand 2 m out of reach, {STOP} iterations:")
    print(f"{'':26}" + "".join(f"{k:>14}" for k in SOLVERS))
    for key, label, fmt in (
        ("ms_per_iteration", "ms per iteration", "{:>14.3f}"),
        ("feet_m", "worst foot drift [m]", "{:>14.1e}"),
        ("com_m", "worst CoM drift [m]", "{:>14.1e}"),
    ):
        print(f"{label:26}" + "".join(fmt.format(u[k][key]) for k in SOLVERS))
    for a, b in (("pik osqp", "mink osqp"), ("pik daqp-hqp", "mink daqp")):
        ratio = u[a]["ms_per_iteration"] / u[b]["ms_per_iteration"]
        print(f"  time per iteration, {a} / {b}: {ratio:.2f}")


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--feet-cost", type=float, default=10.0)
    parser.add_argument("--models", nargs="*", default=list(MODELS), choices=list(MODELS))
    args = parser.parse_args(argv)
    figures: dict = {}
    for name in args.models:
        model = pik_mj.robot.loading.load_model(MODELS[name].model)
        targets = cases.reachable_hand_targets(model, args.targets, seed=0)
        one_round(model, targets[:2], args.feet_cost)  # warm-up: imports, caches
        rounds = [one_round(model, targets, args.feet_cost) for _ in range(args.rounds)]
        s = summarize(rounds)
        s["path_drift_m"] = path_drift(model, targets, args.feet_cost)
        s["foot_drift_m"] = foot_drift(model, raw_mink=False)
        s["foot_drift_raw_mink_m"] = foot_drift(model, raw_mink=True)
        print_table(name, len(targets), args.rounds, s)
        print(
            f"  worst foot drift, hand 2 m out of reach: {s['foot_drift_m']:.1e} m "
            f"(raw mink.FrameTasks in the cascade: {s['foot_drift_raw_mink_m']:.1e} m)"
        )
        s["unchecked_level"] = unchecked_level(model, args.feet_cost)
        print_unchecked(s["unchecked_level"])
        figures[name] = s
    return figures


if __name__ == "__main__":
    main()
