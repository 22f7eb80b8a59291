"""Walking on each humanoid, as it is shipped: one row per robot.

Robots: Unitree G1, H1, Booster T1 (MuJoCo Menagerie, through ``MENAGERIE_ROOT``
or the ``mujoco-menagerie`` cache; a robot that is not on the machine is
skipped, saying so), the project's ``sample_humanoid``, dm_control's
``dm_humanoid``. Each is built with nothing written by hand
(``Robot.from_model(name)``), its soles from MuJoCo's floor contacts and its gait
derived from its legs, soles and mass (:func:`pik_mj.walking.robot_gait.robot_gait`),
then two walks, each a pattern by preview control and whole-body IK played in
the robot's scene (:func:`pik_mj.walking.walk.walk`):

* **forward**: ``--steps`` strides straight ahead and a closing step;
* **go-pos**: to (0.5 m, 0.2 m, 30°) (:meth:`~pik_mj.walking.robot_gait.RobotGait.go_pos`).

Columns per walk: the verdict (``pass``: no fall, the ZMP of the inverse
dynamics inside the support polygon at every tick, the feet ending within 5 cm
of the plan; ``FAIL``; ``refused`` with the reason when the robot cannot walk
this way), the footsteps, the least margin of the ZMP of the pattern's inverse
dynamics and of the ZMP measured in physics (the feet's force sensors where the
robot has them, else MuJoCo's contact forces) to the support polygon [mm], the
final error of the mid-feet point and of the root to the plan [mm], and the wall
time of pattern and playback [s]. :func:`walk_column` is the walk column of
``bench_robots.py``.

Run: ``MENAGERIE_ROOT=... OPENBLAS_NUM_THREADS=1 python benchmarks/bench_walking.py``
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import numpy as np

from pik_mj import Robot
from pik_mj.exceptions import PikError
from pik_mj.robot.ground import robot_soles
from pik_mj.robot.loading import menagerie_available, menagerie_models
from pik_mj.walking.gait import DOUBLE_SUPPORT
from pik_mj.walking.robot_gait import DEFAULT_DT, robot_gait
from pik_mj.walking.support import zmp_margin
from pik_mj.walking.walk import walk
from pik_mj.walking.wholebody import WalkPattern, feet_from_robot

ROBOTS = ("unitree_g1", "unitree_h1", "booster_t1", "sample_humanoid", "dm_humanoid")
GO_POS = (0.5, 0.2, math.radians(30.0))  # [m, m, rad]


def walk_figures(name: str, kind: str, steps: int = 6, dt: float = DEFAULT_DT) -> dict[str, Any]:
    """One walk of robot ``name``: ``kind`` ``"forward"`` (``steps`` strides) or
    ``"go_pos"`` (to :data:`GO_POS`); its verdict and figures (module docstring)."""
    t0 = time.perf_counter()
    robot = Robot.from_model(name, required_limbs=("rleg", "lleg"))
    soles = robot_soles(robot)
    try:
        gait = robot_gait(robot, soles, dt=dt)
    except PikError as exc:
        return {"verdict": "refused", "reason": str(exc), "steps": 0}
    feet = feet_from_robot(robot, soles)
    if kind == "forward":
        footsteps = gait.straight_steps(steps, feet)
    else:
        footsteps = gait.go_pos(*GO_POS, feet)
    done = walk(robot, footsteps, gait, soles=soles)
    f, report = done.figures, done.report
    sensed = f.get("sim_zmp_force_sensors_margin_min_m")
    return {
        "verdict": "pass" if done.passed else "FAIL",
        "steps": len(footsteps),
        "zmp_margin_id": f["zmp_margin_computed_min_m"],
        "zmp_margin_sim": sensed if sensed is not None else f["sim_zmp_contacts_margin_min_m"],
        "zmp_sim_source": "force sensors" if sensed is not None else "contacts",
        "final_error": report.final_midfeet_error,
        "root_error": report.final_root_error,
        "yaw_error": report.final_yaw_error,
        "fall": None if report.fall is None else report.fall.describe(),
        "gains": report.params.get("gains"),
        "gait": gait.to_dict(),
        "wall": time.perf_counter() - t0,
        "failed": [label for label, ok, _ in done.checks if not ok],
        **(rolled_soles(done.pattern) if gait.rolling_soles else {}),
    }


def rolled_soles(pattern: WalkPattern) -> dict[str, float]:
    """A rolling-sole pattern's soles as they are: the largest sole roll [rad], the
    largest height spread of a sole polygon's corners [m], the largest root roll
    [rad], and the least margin [m] of the ZMP of its inverse dynamics to the
    soles' polygons rolled as in the pattern, projected on the floor."""
    corners = {lb: np.c_[s.outline, np.zeros(len(s.outline))] for lb, s in pattern.soles.items()}
    lift, roll, margins = 0.0, 0.0, []
    for lb, R in pattern.feet_R.items():
        roll = max(roll, float(np.max(np.abs(np.arctan2(R[:, 2, 1], R[:, 2, 2])))))
        heights = np.einsum("kij,nj->kni", R, corners[lb])[..., 2]
        lift = max(lift, float(np.max(np.ptp(heights, axis=1))))
    for k, label in enumerate(pattern.support):
        legs = pattern.plan.params.all_limbs if label == DOUBLE_SUPPORT else (label,)
        polygons = [
            pattern.feet_p[lb][k][:2] + (corners[lb] @ pattern.feet_R[lb][k].T)[:, :2]
            for lb in legs
        ]
        margins.append(zmp_margin(pattern.zmp_computed[k], polygons))
    w, x, y, z = pattern.q[:, 3:7].T
    root = np.abs(np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)))
    return {
        "sole_roll_max": roll,
        "sole_lift_max": lift,
        "root_roll_max": float(root.max()),
        "zmp_margin_id_rolled": float(min(margins)),
    }


def walk_column(name: str, steps: int = 6, dt: float = DEFAULT_DT) -> dict[str, Any]:
    """The walk column of a robot: ``{"forward": ..., "go_pos": ...}`` of
    :func:`walk_figures` (a refused robot is refused once)."""
    forward = walk_figures(name, "forward", steps, dt)
    if forward["verdict"] == "refused":
        return {"forward": forward, "go_pos": forward}
    return {"forward": forward, "go_pos": walk_figures(name, "go_pos", steps, dt)}


def cell(w: dict[str, Any]) -> str:
    """One walk as table text: verdict, steps, ZMP margins, final error [mm]."""
    if w["verdict"] == "refused":
        return "refused"
    return (
        f"{w['verdict']:4} {w['steps']:2d} st {1e3 * w['zmp_margin_id']:5.1f}/"
        f"{1e3 * w['zmp_margin_sim']:5.1f} mm err {1e3 * w['final_error']:5.1f} mm"
    )


def notes(row: dict[str, Any]) -> list[str]:
    """Why a robot's walks were refused or failed, and how a rolling-sole walk's
    soles rolled, one line each."""
    forward = row["forward"]
    if forward["verdict"] == "refused":
        return [f"refused: {forward['reason']}"]
    lines = [
        f"{kind}: failed {w['failed']} {w['fall'] or ''}".rstrip()
        for kind, w in row.items()
        if w["verdict"] == "FAIL"
    ]
    for kind, w in row.items():
        if "sole_roll_max" in w:
            lines.append(
                f"{kind}: rolling soles, sole roll <= {math.degrees(w['sole_roll_max']):.2f} deg "
                f"(corners within {1e3 * w['sole_lift_max']:.2f} mm), root roll <= "
                f"{math.degrees(w['root_roll_max']):.1f} deg, ZMP margin on the rolled soles "
                f"{1e3 * w['zmp_margin_id_rolled']:.2f} mm"
            )
    return lines


def available(name: str) -> bool:
    return name not in menagerie_models() or menagerie_available(name)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", nargs="*", default=list(ROBOTS))
    parser.add_argument("--steps", type=int, default=6, help="strides of the forward walk")
    parser.add_argument("--dt", type=float, default=DEFAULT_DT, help="pattern tick [s]")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    rows, skipped = {}, []
    t0 = time.perf_counter()
    for name in args.robots:
        if not available(name):
            skipped.append(name)
            continue
        rows[name] = walk_column(name, args.steps, args.dt)
    if not args.quiet:
        print(f"{'robot':16} {'forward':44} {'go-pos':44}")
        for name, row in rows.items():
            print(f"{name:16} {cell(row['forward']):44} {cell(row['go_pos']):44}")
            for line in notes(row):
                print(f"{'':16}   {line}")
        for name in skipped:
            print(f"{name:16} skipped: not under MENAGERIE_ROOT nor in the mujoco-menagerie cache")
        wall = np.sum([w["wall"] for r in rows.values() for w in r.values() if "wall" in w])
        print(
            f"ZMP margins: least over the walk, of the inverse dynamics / measured in physics; "
            f"errors: mid-feet to the plan; {args.steps} strides forward, go-pos "
            f"{GO_POS[0]} m {GO_POS[1]} m {math.degrees(GO_POS[2]):.0f} deg; dt {args.dt} s; "
            f"walks {wall:.0f} s, all {time.perf_counter() - t0:.0f} s"
        )
    return {"rows": rows, "skipped": skipped}


if __name__ == "__main__":
    main()
