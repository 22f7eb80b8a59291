"""How close to MuJoCo's own speed do a hold and a motion playback run?

For each robot (``sample_humanoid``, dm_control's ``dm_humanoid``, Unitree G1
through ``MENAGERIE_ROOT``; a robot that is not on the machine is skipped,
saying so), built as a user builds it (``Robot.from_model``,
``Scene.from_robot``), in one process and from the same states:

* **hold**: ``scene.hold(q0, 3 s)`` of the standing pose, against the raw
  physics of the same simulated time: ``mujoco.mj_step(m, d, n)`` from the
  same start state (``scene.set_pose(q0)``), one C call;
* **playback**: ``scene.play(path)`` of a reach path (the right shoulder
  pitched 0.8 rad forward and the elbow 0.6 rad in 6 iterates, the rest of the
  robot as it stands), against ``mj_step`` for the motion's simulated time
  from its first pose; its torque plan (the inverse dynamics at the knots,
  :func:`pik_mj.sim.effort.plan_torques`) is timed on its own;
* the same two with ``record_every=1`` (every step sampled: the per-step path)
  and their figures beside the sampled ones;
* **batch** (the first robot): ``--batch`` holds of the standing pose one by
  one (``scene.hold``) and together (``scene.hold_many`` on 1 and 2 threads),
  against ``--batch`` times the raw ``mj_step``; the verdicts and drifts of the
  batch checked equal to the single holds'.

Each time is the median of ``--repeats`` runs, the runs of the compared pair
alternating (a change of the machine's load hits both). Ratios are wall time
over the raw ``mj_step`` time.

Run: ``MENAGERIE_ROOT=... python benchmarks/bench_physics.py [--repeats 5] [--batch 8]``
"""

from __future__ import annotations

import argparse
import os
import time

import mujoco
import numpy as np

from pik_mj import Robot, Scene
from pik_mj.robot.loading import menagerie_available, menagerie_models
from pik_mj.sim import Waypoints
from pik_mj.sim.motion import MotionReference, velocity_limits
from pik_mj.sim.path import Waypoint

ROBOTS = ("sample_humanoid", "dm_humanoid", "unitree_g1")
HOLD = 3.0  # [s]


def _raw(scene: Scene, q: np.ndarray, steps: int) -> float:
    """Wall time [s] of ``mj_step(m, d, steps)`` from ``q`` at rest."""
    scene.set_pose(q)
    t = time.perf_counter()
    mujoco.mj_step(scene.model, scene.data, steps)
    return time.perf_counter() - t


def _path(robot: Robot) -> Waypoints:
    """The right arm reaching forward: 6 iterates from the standing pose."""
    q0 = robot.configuration.q.copy()
    arm = robot.limb("rarm").joints
    path = Waypoints(q0, "reach")
    for k in range(1, 7):
        q = q0.copy()
        for name, amount in zip(arm[:1] + arm[-1:], (-0.8, -0.6), strict=True):
            j = robot.model.joint(name)
            lo, hi = robot.model.jnt_range[j.id] if robot.model.jnt_limited[j.id] else (-9, 9)
            q[j.qposadr[0]] = np.clip(q0[j.qposadr[0]] + amount * k / 6, lo, hi)
        path.items.append(Waypoint(q, "reach", k))
    return path


def _timed(call, raw, repeats: int) -> tuple[float, float, object]:
    """Median wall time of ``call()`` and of ``raw()``, alternating; the last result."""
    runs, raws, out = [], [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = call()
        runs.append(time.perf_counter() - t)
        raws.append(raw())
    return float(np.median(runs)), float(np.median(raws)), out


def run_robot(name: str, repeats: int) -> dict:
    robot = Robot.from_model(name)
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    dt = scene.model.opt.timestep
    n_hold = round(HOLD / dt)
    row: dict = {"robot": name, "nv": scene.model.nv}
    for label, every in (("hold", None), ("hold per step", 1)):
        options = {} if every is None else {"record_every": every}
        wall, raw, report = _timed(
            lambda o=options: scene.hold(q0, HOLD, **o),
            lambda: _raw(scene, q0, n_hold),
            repeats,
        )
        row[label] = {"wall": wall, "raw": raw, "ratio": wall / raw, "report": report}
    path = _path(robot)
    lower, upper = velocity_limits(scene)
    t = time.perf_counter()
    MotionReference(scene, path, lower, upper, speed=0.2)
    row["plan"] = time.perf_counter() - t
    for label, every in (("play", None), ("play per step", 1)):
        options = {} if every is None else {"record_every": every}
        first = scene.play(path, **options)
        wall, raw, report = _timed(
            lambda o=options: scene.play(path, **o),
            lambda n=first.steps: _raw(scene, path.q[0], n),
            repeats,
        )
        row[label] = {"wall": wall, "raw": raw, "ratio": wall / raw, "report": report}
    return row


def run_batch(name: str, n: int) -> dict:
    """``n`` holds of ``name``'s standing pose one by one and by ``hold_many``."""
    robot = Robot.from_model(name)
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    qs = [q0] * n
    t = time.perf_counter()
    single = [scene.hold(q, HOLD) for q in qs]
    out = {"robot": name, "n": n, "single": time.perf_counter() - t}
    out["raw"] = sum(_raw(scene, q0, round(HOLD / scene.model.opt.timestep)) for _ in qs)
    for threads in (1, 2):
        t = time.perf_counter()
        many = scene.hold_many(qs, HOLD, nthread=threads)
        out[f"many{threads}"] = time.perf_counter() - t
        out[f"same{threads}"] = all(
            a.passed == b.passed and abs(a.drift - b.drift) < 1e-9
            for a, b in zip(single, many, strict=True)
        )
    return out


def _available(name: str) -> bool:
    return name not in menagerie_models() or menagerie_available(name)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="*", default=list(ROBOTS))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--batch", type=int, default=8, help="holds of the batch (0: none)")
    args = parser.parse_args(argv)
    rows, skipped = [], []
    for name in args.robots:
        if _available(name):
            rows.append(run_robot(name, args.repeats))
        else:
            skipped.append(name)
    print(
        f"{'robot':16} {'nv':>3} {'hold [ms]':>10} {'mj_step':>8} {'ratio':>6} {'per step':>9} "
        f"{'play [ms]':>10} {'mj_step':>8} {'ratio':>6} {'per step':>9} {'plan [ms]':>10}"
    )
    for r in rows:
        h, hp, p, pp = r["hold"], r["hold per step"], r["play"], r["play per step"]
        print(
            f"{r['robot']:16} {r['nv']:>3} {1e3 * h['wall']:>10.1f} {1e3 * h['raw']:>8.1f} "
            f"{h['ratio']:>5.2f}x {hp['ratio']:>8.2f}x {1e3 * p['wall']:>10.1f} "
            f"{1e3 * p['raw']:>8.1f} {p['ratio']:>5.2f}x {pp['ratio']:>8.2f}x "
            f"{1e3 * r['plan']:>10.1f}"
        )
    print("\nfigures, sampled every 10 steps | every step:")
    for r in rows:
        for kind in ("hold", "play"):
            a, b = r[kind]["report"], r[f"{kind} per step"]["report"]
            print(
                f"  {r['robot']:16} {kind}: passed {a.passed} | {b.passed}; drift "
                f"{1e3 * a.drift:.3f} | {1e3 * b.drift:.3f} mm; slip {1e3 * a.slip:.3f} | "
                f"{1e3 * b.slip:.3f} mm; min margin {1e3 * a.min_margin:.2f} | "
                f"{1e3 * b.min_margin:.2f} mm; steps {a.steps} | {b.steps}"
            )
    batch = run_batch(rows[0]["robot"], args.batch) if rows and args.batch else None
    if batch:
        b = batch
        print(
            f"\nbatch of {b['n']} {HOLD:g} s holds ({b['robot']}): one by one {b['single']:.2f} s "
            f"({b['single'] / b['raw']:.2f}x raw mj_step {b['raw']:.2f} s); hold_many 1 thread "
            f"{b['many1']:.2f} s ({b['many1'] / b['raw']:.2f}x), 2 threads {b['many2']:.2f} s "
            f"({b['many2'] / b['raw']:.2f}x); verdicts and drifts equal to the single holds': "
            f"{b['same1'] and b['same2']}"
        )
    for name in skipped:
        print(f"{name:16} skipped: not under MENAGERIE_ROOT nor in the mujoco-menagerie cache")
    print(f"load average (1 min): {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    return {"rows": rows, "skipped": skipped, "batch": batch}


if __name__ == "__main__":
    main()
