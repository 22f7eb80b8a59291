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
  :func:`pik_mj.sim.effort.plan_torques`) is timed on its own (the median of
  ``--repeats`` plans);
* the same two with ``record_every=1`` (every step sampled: the per-step path)
  and their figures beside the sampled ones;
* **solved reach**: the playback of a motion as a solve makes it, the iterates
  of ``bench_robots``' first hand target (seed 0, with the balance and the
  collision avoidance), its plan and its own physics, against ``mj_step`` of
  its steps from its first pose;
* **recorded** (the first robot, ``--recorded``): the 3 s hold with a
  recorder's ``hold_logger()`` writing to a file, called at the logger's own
  rate (its ``call_every``) and, beside a callback that declares no rate, at
  every step (the slow path), against the hold unrecorded (CPU time; the
  same logged samples either way);
* **batch** (the first robot): ``--batch`` holds of the standing pose one by
  one (``scene.hold``) and together (``scene.hold_many`` on 1 and 2 threads),
  against ``--batch`` times the raw ``mj_step``; the verdicts and drifts of the
  batch checked equal to the single holds'.

Each time is the median of ``--repeats`` runs, the runs of the compared pair
alternating (a change of the machine's load hits both). Ratios are time over
the raw ``mj_step`` time, by two clocks: the CPU time of this process (what a
busy shared machine does not distort: the rollout steps in the calling thread)
and the wall time; ``play - plan`` is the playback without its plan, ``plan /
raw`` the plan over the raw ``mj_step`` of the motion, ``physics / raw`` the
motion's own physics (the controls of its every step, computed beforehand,
stepped from its start in one rollout, no checks) over the raw ``mj_step`` of
the standing pose: what a moving robot's contacts cost MuJoCo, not the checks.
The batch's times are wall times (``hold_many`` runs on threads).

Run: ``MENAGERIE_ROOT=... python benchmarks/bench_physics.py [--repeats 5] [--batch 8]
[--recorded]``
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np
from bench_robots import Setup

from pik_mj import Robot, Scene
from pik_mj.record import Recorder
from pik_mj.robot.loading import menagerie_available, menagerie_models
from pik_mj.sim import Waypoints
from pik_mj.sim.motion import DEFAULT_SPEED, MotionReference, velocity_limits
from pik_mj.sim.path import Waypoint
from pik_mj.sim.stepping import Stepper
from pik_mj.sim.tracking import RECORD_EVERY

ROBOTS = ("sample_humanoid", "dm_humanoid", "unitree_g1")
HOLD = 3.0  # [s]


def _clock() -> np.ndarray:
    """Wall and CPU (this process) time [s]."""
    return np.array([time.perf_counter(), time.process_time()])


def _raw(scene: Scene, q: np.ndarray, steps: int) -> np.ndarray:
    """Wall and CPU time [s] of ``mj_step(m, d, steps)`` from ``q`` at rest."""
    scene.set_pose(q)
    t = _clock()
    mujoco.mj_step(scene.model, scene.data, steps)
    return _clock() - t


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


def _solved_path(name: str) -> Waypoints:
    """A solved reach: the iterates of ``bench_robots``' first hand target (seed 0)
    reached from the standing pose with the balance and collision avoidance."""
    setup = Setup(name)
    (target,) = setup.targets(1, 0)
    path = Waypoints(setup.robot, "reach")
    path.finish(setup.solve(target, True, "osqp", path))
    return path


def motion_physics(scene: Scene, path: Waypoints, steps: int) -> np.ndarray:
    """Wall and CPU time [s] of the motion's own physics: the controls of its
    ``steps`` steps (its reference's, computed beforehand) stepped from its start
    in one rollout, no checks."""
    lower, upper = velocity_limits(scene, None, path.velocity_bounds)
    reference = MotionReference(scene, path, lower, upper, speed=DEFAULT_SPEED)
    reference.begin()
    controls = reference.controls(np.arange(steps) * scene.model.opt.timestep)
    stepper = Stepper(scene.model)
    t = _clock()
    stepper.step(scene.data, controls)
    out = _clock() - t
    stepper.close()
    return out


def _timed(call, raw, repeats: int) -> dict:
    """Median wall and CPU times of ``call()`` and of ``raw()``, alternating, their
    ratios, and the last result."""
    runs, raws, out = [], [], None
    for _ in range(repeats):
        t = _clock()
        out = call()
        runs.append(_clock() - t)
        raws.append(raw())
    (wall, cpu), (raw_wall, raw_cpu) = np.median(runs, axis=0), np.median(raws, axis=0)
    return {
        "wall": wall, "raw": raw_wall, "ratio": wall / raw_wall,
        "cpu": cpu, "raw cpu": raw_cpu, "cpu ratio": cpu / raw_cpu, "report": out,
    }  # fmt: skip


def run_robot(name: str, repeats: int) -> dict:
    robot = Robot.from_model(name)
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    dt = scene.model.opt.timestep
    n_hold = round(HOLD / dt)
    row: dict = {"robot": name, "nv": scene.model.nv}
    for label, every in (("hold", None), ("hold per step", 1)):
        options = {} if every is None else {"record_every": every}
        row[label] = _timed(
            lambda o=options: scene.hold(q0, HOLD, **o),
            lambda: _raw(scene, q0, n_hold),
            repeats,
        )
    row.update(_motion(scene, _path(robot), repeats, per_step=True))
    row["solved"] = _motion(scene, _solved_path(name), repeats, per_step=False)
    return row


def _motion(scene: Scene, path: Waypoints, repeats: int, per_step: bool) -> dict:
    """``path`` played (``"play"``; with ``per_step`` also every step checked,
    ``"play per step"``), its plan and its own physics timed, each beside the
    raw ``mj_step`` of the same steps from its first pose."""
    lower, upper = velocity_limits(scene, None, path.velocity_bounds)
    plans = []
    for _ in range(repeats):
        t = _clock()
        MotionReference(scene, path, lower, upper, speed=DEFAULT_SPEED)
        plans.append(_clock() - t)
    out: dict = {}
    out["plan"], out["plan cpu"] = np.median(plans, axis=0)
    for label, every in (("play", None), ("play per step", 1))[: 2 if per_step else 1]:
        options = {} if every is None else {"record_every": every}
        first = scene.play(path, **options)
        out[label] = _timed(
            lambda o=options: scene.play(path, **o),
            lambda n=first.steps: _raw(scene, path.q[0], n),
            repeats,
        )
    steps = out["play"]["report"].steps
    physics, raws = [], []
    for _ in range(repeats):  # alternating with the raw run, as _timed does
        physics.append(motion_physics(scene, path, steps))
        raws.append(_raw(scene, path.q[0], steps))
    out["physics"], out["physics cpu"] = np.median(physics, axis=0) / np.median(raws, axis=0)
    return out


def run_recorded(name: str, repeats: int) -> dict:
    """CPU time [s] of a recorded hold at the logger's rate and at every step,
    and of the hold unrecorded (medians of ``repeats``)."""
    robot = Robot.from_model(name)
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    out: dict = {"robot": name}
    with tempfile.TemporaryDirectory() as folder:
        for label, extra in (("sampled", []), ("every step", [lambda sample: None])):
            times = []
            for k in range(repeats):
                with Recorder.to_file(Path(folder) / f"{k}.rrd", "bench") as rec:
                    rec.log_model_geometry(robot.model, robot_root_body=robot.root_body)
                    log = rec.hold_logger()
                    t = time.process_time()
                    log.finish(scene.hold(q0, HOLD, callback=[log, *extra]))
                    times.append(time.process_time() - t)
                out["calls " + label] = log.calls
            out[label] = float(np.median(times))
    t = time.process_time()
    for _ in range(repeats):
        scene.hold(q0, HOLD)
    out["unrecorded"] = (time.process_time() - t) / repeats
    return out


def run_batch(name: str, n: int) -> dict:
    """``n`` holds of ``name``'s standing pose one by one and by ``hold_many``."""
    robot = Robot.from_model(name)
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    qs = [q0] * n
    t = time.perf_counter()
    single = [scene.hold(q, HOLD) for q in qs]
    out = {"robot": name, "n": n, "single": time.perf_counter() - t}
    out["raw"] = sum(_raw(scene, q0, round(HOLD / scene.model.opt.timestep))[0] for _ in qs)
    for threads in (1, 2):
        t = time.perf_counter()
        many = scene.hold_many(qs, HOLD, nthread=threads)
        out[f"many{threads}"] = time.perf_counter() - t
        out[f"same{threads}"] = all(
            a.passed == b.passed and abs(a.drift - b.drift) < 1e-9
            for a, b in zip(single, many, strict=True)
        )
    return out


def _table(rows: list[dict], clock: str, wall: bool) -> None:
    """The times [ms] and ratios of ``rows`` by one clock."""
    time_of, ratio, plan = ("wall", "ratio", "plan") if wall else ("cpu", "cpu ratio", "plan cpu")
    physics = "physics" if wall else "physics cpu"
    raw = "raw" if wall else "raw cpu"
    print(f"\n{clock}:")
    print(
        f"{'robot':16} {'nv':>3} {'hold [ms]':>10} {'mj_step':>8} {'ratio':>6} {'per step':>9} "
        f"{'play [ms]':>10} {'mj_step':>8} {'ratio':>6} {'per step':>9} {'plan [ms]':>10} "
        f"{'play - plan':>12} {'plan / raw':>11} {'physics / raw':>14}"
    )
    for r in rows:
        h, hp, p, pp = r["hold"], r["hold per step"], r["play"], r["play per step"]
        print(
            f"{r['robot']:16} {r['nv']:>3} {1e3 * h[time_of]:>10.1f} {1e3 * h[raw]:>8.1f} "
            f"{h[ratio]:>5.2f}x {hp[ratio]:>8.2f}x {1e3 * p[time_of]:>10.1f} "
            f"{1e3 * p[raw]:>8.1f} {p[ratio]:>5.2f}x {pp[ratio]:>8.2f}x "
            f"{1e3 * r[plan]:>10.1f} {(p[time_of] - r[plan]) / p[raw]:>11.2f}x "
            f"{r[plan] / p[raw]:>10.2f}x {r[physics]:>13.2f}x"
        )


def _solved_table(rows: list[dict]) -> None:
    """The solved reaches' playback against raw ``mj_step`` (CPU time)."""
    print("\nsolved reach (bench_robots' first target, seed 0), CPU time of this process:")
    print(
        f"{'robot':16} {'steps':>6} {'play [ms]':>10} {'mj_step':>8} {'ratio':>6} "
        f"{'plan [ms]':>10} {'play - plan':>12} {'plan / raw':>11} {'physics / raw':>14} passed"
    )
    for r in rows:
        s = r["solved"]
        p = s["play"]
        print(
            f"{r['robot']:16} {p['report'].steps:>6} {1e3 * p['cpu']:>10.1f} "
            f"{1e3 * p['raw cpu']:>8.1f} {p['cpu ratio']:>5.2f}x {1e3 * s['plan cpu']:>10.1f} "
            f"{(p['cpu'] - s['plan cpu']) / p['raw cpu']:>11.2f}x "
            f"{s['plan cpu'] / p['raw cpu']:>10.2f}x {s['physics cpu']:>13.2f}x "
            f"{p['report'].passed}"
        )


def _available(name: str) -> bool:
    return name not in menagerie_models() or menagerie_available(name)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="*", default=list(ROBOTS))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--batch", type=int, default=8, help="holds of the batch (0: none)")
    parser.add_argument("--recorded", action="store_true", help="time a recorded hold")
    args = parser.parse_args(argv)
    rows, skipped = [], []
    for name in args.robots:
        if _available(name):
            rows.append(run_robot(name, args.repeats))
        else:
            skipped.append(name)
    for clock, wall in (("CPU time of this process", False), ("wall time", True)):
        _table(rows, clock, wall)
    _solved_table(rows)
    print(f"\nfigures, sampled every {RECORD_EVERY} steps | every step:")
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
    recorded = run_recorded(rows[0]["robot"], args.repeats) if rows and args.recorded else None
    if recorded:
        r = recorded
        print(
            f"\nrecorded {HOLD:g} s hold ({r['robot']}, CPU): at the logger's rate "
            f"{r['sampled']:.3f} s ({r['calls sampled']} calls), at every step "
            f"{r['every step']:.3f} s ({r['calls every step']} calls); unrecorded "
            f"{r['unrecorded']:.3f} s"
        )
    for name in skipped:
        print(f"{name:16} skipped: not under MENAGERIE_ROOT nor in the mujoco-menagerie cache")
    print(f"load average (1 min): {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    return {"rows": rows, "skipped": skipped, "batch": batch, "recorded": recorded}


if __name__ == "__main__":
    main()
