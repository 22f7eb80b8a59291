"""Smoke runs of the benchmarks with tiny sizes, so that they keep working.

Each benchmark's ``main(argv)`` runs for real (IK, MuJoCo holds, rerun files) and
returns its figures; the checks are on what those figures must satisfy whatever
the machine's speed.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"


def _load(name: str):
    """Import ``benchmarks/<name>.py`` (not a package) under the name ``_bench_<name>``."""
    key = f"_bench_{name}"
    if key in sys.modules:
        return sys.modules[key]
    spec = importlib.util.spec_from_file_location(key, BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[key] = module  # dataclasses resolve annotations through sys.modules
    spec.loader.exec_module(module)
    return module


FRACTIONS = (
    "pass",
    "balance_pass",
    "fell",
    "drift_fail",
    "drift_fail_standing",
    "drift_fail_transient",
    "slip_fail",
    "unexpected_contact",
    "ik_converged",
)
TIMES = ("median_ik_s", "max_ik_s", "median_hold_s", "max_hold_s")


def test_bench_balance_small(capsys):
    bench = _load("bench_balance")
    n = 2
    figures = bench.main(["--n", str(n), "--duration", "0.5", "--quiet"])
    out = capsys.readouterr().out
    assert "balanced" in out and "unbalanced" in out
    assert figures["targets"] == n
    for variant in ("balanced", "unbalanced"):
        f = figures[variant]
        for key in FRACTIONS:
            assert 0.0 <= f[key] <= 1.0, (variant, key, f[key])
            # a fraction of n cases
            assert np.isclose(f[key] * n, round(f[key] * n)), (variant, key, f[key])
        for key in TIMES:
            assert f[key] > 0.0, (variant, key)
        assert f["max_ik_s"] >= f["median_ik_s"]
        assert f["max_hold_s"] >= f["median_hold_s"]
        # a passing hold passes the balance criteria too; failures are subsets
        assert f["pass"] <= f["balance_pass"]
        assert f["drift_fail_standing"] <= f["drift_fail"]
        assert f["drift_fail_transient"] <= f["drift_fail"]
        assert f["median_drift_m"] >= 0.0
    # the balanced stack keeps the CoM 2 cm inside the soles (level 1, 1 mm tolerance)
    assert figures["balanced"]["min_static_margin_m"] >= bench.MARGIN - 1e-3
    # both stacks keep every watched pair out of contact (orange zone 1 cm, level 1)
    for variant in ("balanced", "unbalanced"):
        assert figures[variant]["min_clearance_m"] > 0.5 * bench.ORANGE


def test_bench_balance_avoidance_pairs_cover_arm_body_and_floor():
    bench = _load("bench_balance")
    robot = bench.load_robot()
    pairs = {frozenset((p.name1, p.name2)) for p in bench.avoidance_pairs(robot)}
    # the contacts seen in holds before avoidance: forearm on the belly, hand on a
    # thigh, a hand on the floor
    for a, b in (
        ("rarm_lower", "torso_abdomen"),
        ("rarm_lower", "pelvis"),
        ("rarm_hand", "rleg_thigh"),
        ("larm_hand", "floor"),
    ):
        assert frozenset((a, b)) in pairs
    # soles stand on the floor in reset_pose: not watched; adjacent bodies neither
    assert frozenset(("rleg_sole", "floor")) not in pairs
    assert frozenset(("rarm_upper", "torso_chest")) not in pairs
    # the floor adds no degree of freedom: the same q as the robot-only model
    assert robot.model.nq == bench.Robot.from_model(bench.MODEL).model.nq


def test_bench_balance_targets_in_the_box():
    bench = _load("bench_balance")
    p_WP = np.array([0.1, -0.2, 0.8])
    t = bench.sample_targets(p_WP, 500, seed=3)
    assert t.shape == (500, 3)
    assert np.all(t[:, 0] >= p_WP[0] + 0.2) and np.all(t[:, 0] <= p_WP[0] + 0.7)
    assert np.all(t[:, 1] >= p_WP[1] - 0.5) and np.all(t[:, 1] <= p_WP[1] + 0.2)
    assert np.all(t[:, 2] >= 0.2) and np.all(t[:, 2] <= 1.3)
    np.testing.assert_array_equal(t, bench.sample_targets(p_WP, 500, seed=3))


def test_bench_record_small(capsys):
    bench = _load("bench_record")
    figures = bench.main(["--reps", "2"])
    assert "recording overhead" in capsys.readouterr().out
    assert figures["reps"] == 2
    assert figures["converged"] is True
    assert figures["iterations"] > 0
    for key in ("plain_s", "recorded_s", "setup_s", "callback_s", "close_s"):
        assert figures[key] > 0.0, key
    assert figures["callback_s"] + figures["close_s"] <= figures["recorded_s"]
    assert figures["overhead"] == pytest.approx(figures["recorded_s"] / figures["plain_s"] - 1)
    assert figures["rrd_bytes"] > 10_000  # geometry + per-iteration rows were written


def test_bench_record_rrd_holds_the_iterations(tmp_path):
    """The recorder logs one error row and one frame row per solver iteration."""
    from pik_mj.record import PATHS, read_recording
    from pik_mj.robot import Robot

    bench = _load("bench_record")
    robot = Robot.from_model(bench.MODEL)
    path = tmp_path / "r.rrd"
    _, _, _, _, result = bench.time_recorded(robot, path)
    data = read_recording(path)
    hand = robot.limb(bench.HAND).end_frame
    err = data[PATHS.task_error(2, f"target:{hand}", solve="reach")]
    (component,) = [c for c in err.temporal if "Scalar" in c]
    times, values = err.series(component, "iteration")
    np.testing.assert_array_equal(times, np.arange(1, result.iterations + 1))
    # last logged hand error equals the solve's final report for that task
    final = next(t for t in result.tasks if t.name == f"target:{hand}")
    assert np.ravel(values[-1])[0] == pytest.approx(np.linalg.norm(final.error), rel=1e-9)
    # as pik-mj run records it: every frame task's current frame, from the start
    # pose on, per iteration
    times, _ = data[PATHS.task_current(f"target:{hand}")].series(
        "Transform3D:translation", "iteration"
    )
    np.testing.assert_array_equal(times, np.arange(0, result.iterations + 1))


def test_bench_cascade_small(capsys):
    bench = _load("bench_cascade")
    name = "dm_control humanoid (27 DoF)"
    figures = bench.main(["--targets", "2", "--rounds", "1", "--models", name])
    assert "time to solution, pik osqp / mink osqp" in capsys.readouterr().out
    f = figures[name]
    for solver in bench.SOLVERS:
        assert 0.0 <= f[solver]["success"] <= 1.0 and f[solver]["ms_to_solution"] > 0.0
    assert f["pik osqp"]["success"] == f["pik daqp-hqp"]["success"] == 1.0
    assert all(r > 0 for r in f["ratios"].values())
    assert f["hqp no bound"]["corrections_per_iteration"] == 0.0
    # on the way to the targets, the feet stay within the step rule's 1e-4 m;
    # without the bound they move by centimetres, and so do mink's
    drift = f["path_drift_m"]
    assert drift["pik osqp"] <= 1e-4 and drift["pik daqp-hqp"] <= 1e-4
    assert drift["hqp no bound"] > 1e-2 and drift["mink daqp"] > 1e-2
    for solver in bench.PIK_SOLVERS:
        # levels below the feet once per accepted configuration; the hard rows
        # and the feet also at every trial step and correction
        e, c = f[solver]["evaluations_per_iteration"], f[solver]["corrections_per_iteration"]
        assert e[2] == e[3] > 1.0 and e[0] == e[1] >= e[2] + c - 1e-12
    # the step rule: the feet never move more than 1e-4 m, raw mink tasks included
    assert f["foot_drift_m"] <= 1e-4 and f["foot_drift_raw_mink_m"] <= 1e-4
    # a level left out of the stop test keeps its priority too: the CoM pinned
    # with check=False stays within 1e-4 m, with the feet; mink's moves
    unchecked = f["unchecked_level"]
    for solver in ("pik osqp", "pik daqp-hqp"):
        assert unchecked[solver]["feet_m"] <= 1e-4 and unchecked[solver]["com_m"] <= 1e-4
    assert unchecked["mink daqp"]["com_m"] > 1e-3
    assert all(u["ms_per_iteration"] > 0.0 for u in unchecked.values())
