"""Overhead of per-iteration rerun recording on the full-body reach solve.

The solve is ``scenarios/fullbody_reach.py``'s (sample humanoid, waist 10°, both
feet fixed, centroid x-y over the feet, left hand to the seed's (0.4, 0.1, -0.6) m
from the pelvis, position only, ``stop=100``). It is timed without a callback and
recorded as a scenario script records it: a :class:`pik_mj.record.Recorder` on a
temporary ``.rrd`` with the robot's geometry, the solve's
:meth:`~pik_mj.record.Recorder.solve_logger` as callback (every body's pose
and, from them, every geom's; the CoM and its target; every task's error from
the solve loop's own evaluation; each frame task's current and target frame),
its ``finish`` (final pose, outcome) and :meth:`~pik_mj.record.Recorder.close`
(the blueprint, the end of the file).
The per-iteration static check and the physics hold are simulation, not
recording, and are off here.

Times are medians over ``--reps`` repetitions (alternating order, after one
warm-up each):

* ``plain``: the solve alone;
* ``recorded``: the solve with the callback, plus ``finish`` and the close (the
  buffered rows are sent there);
* ``setup``: opening the file, logging the model geometry and the start pose
  (once per run).

.. math::

    \\text{overhead} = t_{recorded} / t_{plain} - 1

Also printed: the median of the paired ratios ``t_recorded,i / t_plain,i - 1`` of
the two runs of each repetition (they run back to back, so it is less sensitive
to the machine's load drifting during the benchmark), the same ratio in CPU time
of the process (all threads, rerun's included: less sensitive to other
processes competing for the cores), and the time spent inside the callback and
in ``finish`` + ``close``.

Run: ``python benchmarks/bench_record.py [--reps 20]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.record import Recorder
from pik_mj.robot import Robot
from pik_mj.solve import IterationInfo, SolveResult

MODEL = "sample_humanoid"
HAND = "larm"
HAND_OFFSET = np.array([0.4, 0.1, -0.6])  # [m] from the pelvis (seed #f(400 100 -600) mm)
FEET = ("rleg", "lleg")
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def start(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Reset the robot to the scenario's start; returns (hand target, CoM target) [m]."""
    robot.reset_pose()
    robot.set_angle_vector([np.deg2rad(10.0)], ["torso_waist_p"])
    feet = [robot.frame_pose(robot.limb(x).end_frame, robot.limb(x).end_frame_type) for x in FEET]
    p_mid = 0.5 * (feet[0].translation() + feet[1].translation())
    return robot.root_pose()[0] + HAND_OFFSET, p_mid


def solve(robot: Robot, target: np.ndarray, p_mid: np.ndarray, callback=None) -> SolveResult:
    return fullbody_inverse_kinematics(
        robot,
        [(target, IDENTITY)],
        limbs=[HAND],
        rotation_axis=[None],
        target_centroid_pos=p_mid,
        centroid_axes="z",
        stop=100,
        callback=callback,
    )


def time_plain(robot: Robot) -> tuple[float, float, SolveResult]:
    """Returns (wall, CPU) times of the solve [s], result."""
    target, p_mid = start(robot)
    t0, c0 = time.perf_counter(), time.process_time()
    result = solve(robot, target, p_mid)
    return time.perf_counter() - t0, time.process_time() - c0, result


def time_recorded(
    robot: Robot, path: Path, cpu: list[float] | None = None
) -> tuple[float, float, float, float, SolveResult]:
    """Returns (setup, solve + finish/close, in the callback, finish/close) times [s],
    result; appends the CPU time of the solve + finish/close (all threads) to ``cpu``."""
    target, p_mid = start(robot)
    t0 = time.perf_counter()
    rec = Recorder.to_file(path, "bench_record")
    rec.log_model_geometry(robot.model, robot_root_body=robot.root_body)
    rec.flush()  # the geometry on disk before the solve, as a scenario does
    callback = rec.solve_logger("reach", start=robot)
    spent: list[float] = []

    def timed(info: IterationInfo) -> None:
        t = time.perf_counter()
        callback(info)
        spent.append(time.perf_counter() - t)

    t1, c1 = time.perf_counter(), time.process_time()
    result = solve(robot, target, p_mid, timed)
    t2 = time.perf_counter()
    callback.finish(result)
    rec.close()
    t3, c3 = time.perf_counter(), time.process_time()
    if cpu is not None:
        cpu.append(c3 - c1)
    return t1 - t0, t3 - t1, sum(spent), t3 - t2, result


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=20, help="repetitions (median)")
    args = parser.parse_args(argv)
    if args.reps < 1:
        parser.error("--reps must be >= 1")

    robot = Robot.from_model(MODEL)
    plain, recorded, setup, in_callback, closing = [], [], [], [], []
    cpu_plain, cpu_recorded = [], []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench_record.rrd"
        _, _, ref = time_plain(robot)  # warm-up
        time_recorded(robot, path)
        for i in range(args.reps):
            order = (0, 1) if i % 2 == 0 else (1, 0)
            for which in order:
                if which == 0:
                    t, c, result = time_plain(robot)
                    plain.append(t)
                    cpu_plain.append(c)
                else:
                    s, t, cb, close, result = time_recorded(robot, path, cpu_recorded)
                    setup.append(s)
                    recorded.append(t)
                    in_callback.append(cb)
                    closing.append(close)
                if result.iterations != ref.iterations or result.converged != ref.converged:
                    raise RuntimeError(
                        f"the solve is not repeatable: {result.iterations} vs {ref.iterations}"
                        " iterations"
                    )
        rrd_bytes = path.stat().st_size

    t_plain, t_rec, t_setup, t_cb, t_close = (
        float(np.median(x)) for x in (plain, recorded, setup, in_callback, closing)
    )
    figures = {
        "reps": args.reps,
        "iterations": ref.iterations,
        "converged": ref.converged,
        "plain_s": t_plain,
        "recorded_s": t_rec,
        "setup_s": t_setup,
        "callback_s": t_cb,
        "close_s": t_close,
        "overhead": t_rec / t_plain - 1.0,
        "overhead_paired": float(np.median(np.array(recorded) / np.array(plain) - 1.0)),
        "overhead_in_callback": t_cb / t_plain,
        "overhead_with_setup": (t_rec + t_setup) / t_plain - 1.0,
        "overhead_cpu_paired": float(np.median(np.array(cpu_recorded) / np.array(cpu_plain) - 1.0)),
        "rrd_bytes": rrd_bytes,
    }
    print(
        f"{MODEL} full-body reach: {ref.iterations} iterations "
        f"({'converged' if ref.converged else 'NOT converged'}), median of {args.reps}"
    )
    print(f"{'solve, unrecorded [ms]':40}{1e3 * t_plain:>10.2f}")
    print(f"{'solve, recorded + finish/close [ms]':40}{1e3 * t_rec:>10.2f}")
    print(f"{'recording overhead':40}{figures['overhead']:>10.1%}   (target <= 30%)")
    print(f"{'  median of the paired ratios':40}{figures['overhead_paired']:>10.1%}")
    print(f"{'  in CPU time (all threads), paired':40}{figures['overhead_cpu_paired']:>10.1%}")
    print(f"{'  of which in the callback [ms]':40}{1e3 * t_cb:>10.2f}")
    print(f"{'  of which finish + close [ms]':40}{1e3 * t_close:>10.2f}")
    print(f"{'overhead of the callback alone':40}{figures['overhead_in_callback']:>10.1%}")
    print(f"{'file + model geometry, once [ms]':40}{1e3 * t_setup:>10.2f}")
    print(f"{'overhead including that':40}{figures['overhead_with_setup']:>10.1%}")
    print(f"{'.rrd size [kB]':40}{rrd_bytes / 1e3:>10.1f}")
    return figures


if __name__ == "__main__":
    main()
