"""How fast does a sweep run on 1 and 2 Ray workers, where does a case spend its time,
and does checking the physics every ``RECORD_EVERY``-th step change a verdict?

The same sweep (default: the ``pik-mj sweep`` default, 100 random right-hand
targets of the sample humanoid in the box x ∈ [0.2, 0.7], y ∈ [-0.5, 0.2],
z ∈ [0.2, 1.3] m × the stacks ``balanced`` and ``unbalanced`` = 200 cases: the
solve, its static check, its iterates played in physics, a 3 s hold) is run with
each ``--workers`` count on one local Ray instance of
``--num-cpus`` CPUs, each run into a fresh dataset; ``--rounds`` repeats the
runs, alternating their order, so that a change of the machine's load hits both
counts alike. Ray's workers run at niceness 0 here (Ray's default, 15, makes
them yield to every other process of a shared machine).

Per run: wall time of the cases (Ray start-up and actor creation apart), cases
per second, speedup over the 1-worker run of the same round, the CPU share each
worker had (its processes' CPU time over the wall time, ``s = Σ t_cpu / (k
T_wall)``: 1 on an idle machine), the share of the wall time the workers spent
in cases (``busy``; the rest is dispatch, Parquet writes and Ray) and the load
average before and after. On a shared machine the speedup cannot exceed
``2 s_2 / s_1``; on Linux with ``sched_autogroup_enabled`` (printed) the kernel
shares the CPU between sessions, not processes, so the sweep's workers, all in
the caller's session, share one session's part of a busy machine however many
they are. The speedup "with a free core per worker" is ``k`` times the run's
cases per CPU-second over the 1-worker run's (a projection from the measured
CPU times, not a measurement). Per case, from the rows: the mean wall time of
the solve, the static check, the motion and the hold, their shares, the mean
CPU time, and the Ray overhead per case,

.. math::

    t_{overhead} = \\frac{k \\, T_{wall} - \\sum_i t_{case,i}}{n}, \\qquad
    t_{case} = t_{solve} + t_{static} + t_{motion} + t_{hold}

for ``k`` workers and ``n`` cases. The runs' rows must be equal but for the
times and the worker names (checked). With ``--per-step`` the sweep runs once
more on the largest worker count with the motions' and holds' checks sampled
every step (:class:`PerStepWorker`, the slow path), and every case whose
verdict differs from the sampled run's is listed with its figures.

With ``--floor N`` the first ``N`` cases run again in this process, one by one,
and each case's CPU time is split: the solve, the static check, the motion's
plan (:class:`~pik_mj.sim.motion.MotionReference`: the torque and ZMP plans),
its playback (``scene.play``, the plan included) and the hold, each beside
the raw physics of the same steps from the same pose (``mujoco.mj_step(m, d,
n)``, one C call), and the motion's own physics (its controls stepped in one
rollout, no checks: what its moving contacts cost MuJoCo beyond the raw run's
standing robot). The floor of a case, the solve plus the raw physics of its
motion and hold, bounds the cases per CPU-second whatever the checks cost
(``--workers 0``: the floor alone, no sweep).

Run: ``python benchmarks/bench_sweep.py [--n 100] [--workers 1 2] [--rounds 1] [--hold 3]
[--per-step] [--floor 20]``
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np
import ray
from bench_physics import motion_physics

from pik_mj.sim import Waypoints
from pik_mj.sim.motion import MotionReference, velocity_limits
from pik_mj.sim.path import Waypoint
from pik_mj.sweep import Sweep, Uniform, Worker, run_sweep
from pik_mj.sweep.cli import DEFAULT_BOX
from pik_mj.sweep.dataset import comparable
from pik_mj.sweep.views import summary_table

PARTS = ("solve_time", "static_time", "motion_time", "hold_time")


class PerStepWorker(Worker):
    """The sweep's worker with the checks sampled every physics step."""

    record_every = 1


ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])


def run(sweep: Sweep, workers: int, out: Path, worker_class: type = Worker) -> dict:
    """One sweep on ``workers`` workers; its figures."""
    load_before = os.getloadavg()
    report = run_sweep(sweep, out, workers=workers, progress=False, worker_class=worker_class)
    load_after = os.getloadavg()
    rows = report.table.to_pylist()
    busy = {k: np.array([r[k] for r in rows if r[k] is not None]) for k in PARTS}
    total = sum(v.sum() for v in busy.values())
    cpu = sum(r["cpu_time"] for r in rows if r["cpu_time"] is not None)
    return {
        "workers": workers,
        "cases": report.ran,
        "wall_s": report.wall_time,
        "startup_s": report.startup_time,
        "cases_per_s": report.ran / report.wall_time,
        "cpu_share": cpu / (workers * report.wall_time),
        "cases_per_cpu_s": report.ran / cpu,
        "mean_s": {k: float(v.mean()) for k, v in busy.items()},
        "mean_cpu_s": cpu / report.ran,
        "share": {k: float(v.sum() / total) for k, v in busy.items()},
        "overhead_s": (workers * report.wall_time - total) / report.ran,
        "busy": total / (workers * report.wall_time),
        "errors": report.errors,
        "load": (load_before[0], load_after[0]),
        "rows": rows,
        "table": report.table,
    }


class FloorWorker(Worker):
    """The sweep's worker keeping each case's final pose and iterates (no checks)."""

    def check(self, q: np.ndarray, path: np.ndarray) -> dict:
        self.q, self.path = q.copy(), np.asarray(path, dtype=float)
        return {}


def floor(sweep: Sweep, n: int, hold: float) -> dict:
    """Mean CPU times [s] of the first ``n`` cases' parts, run here one by one,
    and the raw ``mj_step`` of their motions' and holds' steps (module docstring)."""
    worker = FloorWorker("sample_humanoid", hold=hold)
    scene, clock = worker.scene, time.process_time
    parts = []
    for case in sweep.cases()[:n]:
        t0 = clock()
        worker.run(case)
        solve = clock() - t0
        q, path = worker.q, worker.path
        t0 = clock()
        scene.static_check(q)
        static = clock() - t0
        waypoints = Waypoints(path[0], "path")
        waypoints.items += [Waypoint(x, "path", i) for i, x in enumerate(path[1:], 1)]
        lower, upper = velocity_limits(scene, None, waypoints.velocity_bounds)
        t0 = clock()
        MotionReference(scene, waypoints, lower, upper, speed=0.2)
        plan = clock() - t0
        t0 = clock()
        motion = scene.play(path)
        play = clock() - t0
        physics = motion_physics(scene, waypoints, motion.steps)[1]
        t0 = clock()
        held = scene.hold(q, hold, criteria=worker.criteria)
        hold_cpu = clock() - t0
        raws = []
        for start, steps in ((path[0], motion.steps), (q, held.steps)):
            scene.set_pose(start)
            t0 = clock()
            mujoco.mj_step(scene.model, scene.data, steps)
            raws.append(clock() - t0)
        parts.append(
            (solve, static, plan, play, hold_cpu, *raws, physics, motion.steps, held.steps)
        )
    keys = (
        "solve", "static", "plan", "play", "hold", "raw play", "raw hold", "physics", "steps",
        "held",
    )  # fmt: skip
    mean = dict(zip(keys, np.mean(parts, axis=0).tolist(), strict=True))
    case = mean["solve"] + mean["static"] + mean["play"] + mean["hold"]
    bound = mean["solve"] + mean["raw play"] + mean["raw hold"]
    print(
        f"\nthe first {n} cases one by one in this process (mean CPU time [s]; load "
        f"{os.getloadavg()[0]:.2f}):\n"
        f"  solve {mean['solve']:.3f}, static {mean['static']:.3f}, motion {mean['play']:.3f} "
        f"(plan {mean['plan']:.3f}; raw mj_step {mean['raw play']:.3f} for "
        f"{mean['steps']:.0f} steps: {mean['play'] / mean['raw play']:.2f}x, without the plan "
        f"{(mean['play'] - mean['plan']) / mean['raw play']:.2f}x; its own physics in one "
        f"rollout {mean['physics'] / mean['raw play']:.2f}x), hold {mean['hold']:.3f} "
        f"(raw {mean['raw hold']:.3f}: {mean['hold'] / mean['raw hold']:.2f}x)\n"
        f"  a case {case:.3f} s: {1 / case:.2f} cases per CPU-second; the floor (solve + raw "
        f"physics) {bound:.3f} s: at most {1 / bound:.2f} cases per CPU-second"
    )
    return {**mean, "case": case, "floor": bound}


def _autogroup() -> str:
    """Whether Linux shares the CPU between sessions (autogroup) rather than processes."""
    try:
        on = Path("/proc/sys/kernel/sched_autogroup_enabled").read_text().strip() == "1"
    except OSError:
        return "scheduler autogroup: unknown"
    return f"scheduler autogroup: {'on' if on else 'off'}"


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="random targets (x 2 stacks)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=1, help="repetitions, order alternating")
    parser.add_argument("--num-cpus", type=int, default=2, help="CPUs of the Ray instance")
    parser.add_argument("--hold", type=float, default=3.0, help="hold duration [s]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", help="directory for the datasets (default: a temporary one)")
    parser.add_argument(
        "--per-step", action="store_true", help="also run with every step checked and compare"
    )
    parser.add_argument("--floor", type=int, default=0, help="cases split here (0: none)")
    args = parser.parse_args(argv)
    sweep = Sweep(Uniform(DEFAULT_BOX, args.n), hold=args.hold, seed=args.seed)
    if args.workers == [0]:
        return {"floor": floor(sweep, args.floor, args.hold)}
    base = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_sweep_"))

    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    t0 = time.perf_counter()
    ray.init(
        address="local",
        num_cpus=args.num_cpus,
        include_dashboard=False,
        log_to_driver=False,
        logging_level=logging.ERROR,
        _system_config={"worker_niceness": 0},
    )
    ray_start = time.perf_counter() - t0
    runs = []
    try:
        for r in range(args.rounds):
            order = args.workers if r % 2 == 0 else args.workers[::-1]
            for k in order:
                runs.append({"round": r, **run(sweep, k, base / f"round{r}_workers{k}")})
        if args.per_step:
            k = max(args.workers)
            slow = run(sweep, k, base / "per_step", worker_class=PerStepWorker)
    finally:
        ray.shutdown()
    same = all(comparable(r["rows"]) == comparable(runs[0]["rows"]) for r in runs)
    first = {(r["round"], r["workers"]): r for r in runs}
    for r in runs:
        r["speedup"] = r["cases_per_s"] / first[(r["round"], args.workers[0])]["cases_per_s"]

    print(
        f"sweep: {len(sweep)} cases ({args.n} random right-hand targets x {sweep.stacks}), "
        f"hold {args.hold:g} s, sample_humanoid; Ray {ray.__version__}, local instance of "
        f"{args.num_cpus} CPUs (ray.init {ray_start:.1f} s); machine: {os.cpu_count()} cores"
    )
    print(f"datasets under {base}; {_autogroup()}")
    print(
        f"{'round':>5} {'workers':>7} {'wall [s]':>9} {'cases/s':>8} {'speedup':>8} "
        f"{'CPU share':>10} {'busy':>5} {'actors up [s]':>14} {'overhead/case [ms]':>19} "
        f"{'load avg (1 min) before -> after':>33}"
    )
    for r in runs:
        load = f"{r['load'][0]:.2f} -> {r['load'][1]:.2f}"
        print(
            f"{r['round']:>5} {r['workers']:>7} {r['wall_s']:>9.1f} {r['cases_per_s']:>8.2f} "
            f"{r['speedup']:>7.2f}x {r['cpu_share']:>10.0%} {r['busy']:>5.0%} "
            f"{r['startup_s']:>14.1f} {1e3 * r['overhead_s']:>19.1f} {load:>33}"
        )
    for k in args.workers[1:]:
        ups = [r["speedup"] for r in runs if r["workers"] == k]
        print(f"speedup of {k} workers: median {np.median(ups):.2f}x over {len(ups)} rounds")
        free = [
            k * r["cases_per_cpu_s"] / first[(r["round"], args.workers[0])]["cases_per_cpu_s"]
            for r in runs
            if r["workers"] == k
        ]
        print(
            f"  with a free core per worker (k x cases per CPU-second over the "
            f"{args.workers[0]}-worker run's): median {np.median(free):.2f}x"
        )
    print("\ncost of a case (mean wall time [s], share of the case's wall time; CPU time [s]):")
    print(
        f"{'round':>5} {'workers':>7} "
        + " ".join(f"{k.removesuffix('_time'):>16}" for k in PARTS)
        + f" {'CPU':>8}"
    )
    for r in runs:
        cells = [f"{r['mean_s'][k]:>8.3f} ({r['share'][k]:>4.0%})" for k in PARTS]
        print(
            f"{r['round']:>5} {r['workers']:>7} "
            + " ".join(f"{c:>16}" for c in cells)
            + f" {r['mean_cpu_s']:>8.3f}"
        )
    print(f"\nrows equal across runs (times and workers aside): {same}")
    print(summary_table(runs[-1]["table"]))
    result = {"runs": runs, "same_rows": same, "ray_init_s": ray_start}
    if args.per_step:
        result["per_step"] = _compare(runs[-1], slow)
    if args.floor:
        result["floor"] = floor(sweep, args.floor, args.hold)
    return result


def _compare(fast: dict, slow: dict) -> list[dict]:
    """Print and return the cases whose verdict differs between the sampled run
    and the per-step one, with their figures."""
    print(
        f"\nper-step run ({slow['workers']} workers): {slow['cases_per_s']:.2f} cases/s, "
        f"{slow['mean_cpu_s']:.3f} s CPU per case (sampled: {fast['mean_cpu_s']:.3f} s)"
    )
    keys = ("verdict", "motion_passed", "motion_drift", "hold_passed", "drift", "slip", "fell")
    diff = []
    for a, b in zip(fast["rows"], slow["rows"], strict=True):
        if a["verdict"] != b["verdict"]:
            diff.append({"case": a["case"], **{k: (a[k], b[k]) for k in keys}})
    print(f"verdicts that differ (sampled, per step): {len(diff)} of {len(fast['rows'])}")
    for d in diff:
        print("  " + ", ".join(f"{k} {v}" for k, v in d.items()))
    drift = [
        abs(a["drift"] - b["drift"])
        for a, b in zip(fast["rows"], slow["rows"], strict=True)
        if a["drift"] is not None and b["drift"] is not None
    ]
    if drift:
        print(f"largest hold drift difference: {1e3 * max(drift):.4f} mm")
    return diff


if __name__ == "__main__":
    main()
