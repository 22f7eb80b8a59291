"""Sweeps on Ray: cases and seeds, rows, a raising worker, kill and resume, views.

The reference sweep runs on the local Ray instance run_sweep starts and stops;
a second instance (2 CPUs) then serves the module's other in-process sweeps; the
kill test runs the sweep command in a subprocess with its own instance. Each
instance lives in its own temporary directory, and the tests check that none of
its processes is left once it is shut down (or its driver killed).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import ray  # the test extra installs it
from local_ray import local_ray

from pik_mj import cli
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.record import read_recording
from pik_mj.sweep import Grid, Sweep, Uniform, Worker, read_rows, run_sweep
from pik_mj.sweep.dataset import UNREPEATABLE, comparable
from pik_mj.sweep.spec import point_seed
from pik_mj.sweep.views import COLORS, summary_table, write_views

# 2 x 2 targets of the right hand beside and ahead of the pelvis, both stacks:
# the low ones (z = 0.6 m) tip the unbalanced stack over, the rest stands.
GRID = {"x": [0.45, 0.6], "y": [-0.2], "z": [0.6, 1.0]}
SWEEP = Sweep(Grid(GRID), hold=0.3, seed=7)
N = len(SWEEP)
GRID_ARGS = ["--grid", "x=0.45,0.6", "y=-0.2", "z=0.6,1.0", "--hold", "0.3", "--seed", "7"]
RAISE, DIE = 2, 5  # cases on which RaisingWorker raises, and its process exits


# Ray's workers cannot import this test module: send its classes by value.
ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])


class RaisingWorker(Worker):
    """The real worker, but case RAISE raises and case DIE kills the process."""

    def run(self, case):
        if case.index == RAISE:
            raise RuntimeError(f"boom on case {case.index}")
        if case.index == DIE:
            os._exit(3)
        return super().run(case)


def ray_processes(tag: str) -> list[int]:
    """Processes (but this one) whose command line holds ``tag`` (a Ray temp dir)."""
    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit() or int(proc.name) == os.getpid():
            continue
        try:
            if tag.encode() in (proc / "cmdline").read_bytes():
                found.append(int(proc.name))
        except OSError:
            continue
    return found


def wait_gone(tag: str, timeout: float = 15.0) -> list[int]:
    """Wait until no process of the Ray instance ``tag`` is left; those left."""
    deadline = time.monotonic() + timeout
    while (left := ray_processes(tag)) and time.monotonic() < deadline:
        time.sleep(0.2)
    return left


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """SWEEP run uninterrupted on 2 workers, on the local Ray instance run_sweep
    starts (in its own temporary directory) and stops."""
    assert not ray.is_initialized()
    out = tmp_path_factory.mktemp("reference") / "sweep"
    ray_tmp = tempfile.mkdtemp(prefix="pkr")  # short: Ray's socket paths live below it
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RAY_TMPDIR", ray_tmp)
        report = run_sweep(SWEEP, out, workers=2, num_cpus=2, batch_size=1, progress=False)
    assert not ray.is_initialized()
    assert wait_gone(ray_tmp) == []  # run_sweep shut its instance down
    return report


@pytest.fixture(scope="module")
def ray_session(reference):
    """A local Ray instance of 2 CPUs for the module's later sweeps (run_sweep uses
    it and leaves it running); none of its processes outlive it."""
    with local_ray(2) as tmp:
        yield tmp
    assert wait_gone(tmp) == []


def test_cases_cross_points_stacks_robots_and_seed_points_alone():
    axes = {"x": [0.3, 0.45, 0.6], "y": [-0.2], "z": [0.6, 1.0]}
    grid = Sweep(Grid(axes), robots=("sample_humanoid", "dm_humanoid"), seed=3)
    cases = grid.cases()
    assert len(cases) == len(grid) == 2 * 2 * 6
    assert [c.index for c in cases] == list(range(24))
    # robot, then stack, then point (last grid axis fastest)
    c = cases[6 + 4]  # sample_humanoid, unbalanced, point 4
    assert (c.robot, c.stack, c.point) == ("sample_humanoid", "unbalanced", 4)
    assert c.params == {"x": 0.6, "y": -0.2, "z": 0.6}
    assert cases[12].robot == "dm_humanoid" and cases[12].params == cases[0].params
    # a random point comes from (sweep seed, point index) alone, shared by the stacks
    box = {"x": (0.2, 0.7), "y": (-0.5, 0.2), "z": (0.2, 1.3)}
    rand = Sweep(Uniform(box, 50), seed=11)
    rc = rand.cases()
    for c in rc[:50]:
        assert c.seed == point_seed(11, c.point)
        rng = np.random.default_rng(c.seed)
        assert c.params == {k: rng.uniform(lo, hi) for k, (lo, hi) in box.items()}
        assert rc[50 + c.point].params == c.params and rc[50 + c.point].stack == "unbalanced"
    pts = np.array([[c.params[k] for k in "xyz"] for c in rc[:50]])
    assert (pts >= [0.2, -0.5, 0.2]).all() and (pts <= [0.7, 0.2, 1.3]).all()
    assert len({tuple(p) for p in pts}) == 50
    other = Sweep(Uniform(box, 50), seed=12).cases()
    assert all(a.params != b.params for a, b in zip(rc[:50], other[:50], strict=True))
    assert Sweep.from_dict(rand.to_dict()) == rand and Sweep.from_dict(grid.to_dict()) == grid


def test_bad_sweeps_say_what_is_valid(tmp_path):
    with pytest.raises(InvalidInput, match=r"unknown sweep parameter 'w'.*x \(hand target"):
        Grid({"w": [1.0], "x": [0.3], "y": [0.0], "z": [1.0]})
    with pytest.raises(InvalidInput, match=r"must set \['z'\]"):
        Sweep(Grid({"x": [0.3], "y": [0.0]}))
    with pytest.raises(UnknownName, match=r"stack 'tiptoe' does not exist.*'balanced'"):
        Sweep(Grid(GRID), stacks=("tiptoe",))
    with pytest.raises(InvalidInput, match="inverted"):
        Uniform({"x": (0.7, 0.2), "y": (0, 0), "z": (1, 1)}, 5)
    with pytest.raises(InvalidInput, match="finite"):
        Grid({"x": [float("nan")], "y": [0.0], "z": [1.0]})
    with pytest.raises(InvalidInput, match=r"grid value of 'x' must be a finite number \[m\]"):
        Grid({"x": ["0.3"], "y": [0.0], "z": [1.0]})  # a string is not a number
    with pytest.raises(InvalidInput, match=r"a Grid needs a mapping name -> values"):
        Grid([("x", [0.3])])
    with pytest.raises(InvalidInput, match=r"range of 'x' must be \(low, high\) \[m\]"):
        Uniform({"x": "0:1", "y": (0, 0), "z": (1, 1)}, 5)
    with pytest.raises(InvalidInput, match=r"n must be an integer >= 1, got 2.5"):
        Uniform({"x": (0, 1), "y": (0, 0), "z": (1, 1)}, 2.5)
    with pytest.raises(InvalidInput, match=r"robots must be a list of names, got 'sample_"):
        Sweep(Grid(GRID), robots="sample_humanoid")
    with pytest.raises(InvalidInput, match=r"seed must be an integer >= 0, got -1"):
        Sweep(Grid(GRID), seed=-1)
    with pytest.raises(InvalidInput, match=r"hold must be a finite number > 0 \[s\], got 0"):
        Sweep(Grid(GRID), hold=0)
    # run_sweep's own arguments are refused before the directory is made
    with pytest.raises(InvalidInput, match=r"sweep must be a pik_mj.sweep.Sweep"):
        run_sweep(GRID, tmp_path / "never")
    with pytest.raises(InvalidInput, match=r"workers=3 but num_cpus=2"):
        run_sweep(SWEEP, tmp_path / "never", workers=3, num_cpus=2)
    with pytest.raises(InvalidInput, match=r"batch_size must be an integer >= 1, got 0"):
        run_sweep(SWEEP, tmp_path / "never", batch_size=0)
    assert not (tmp_path / "never").exists()


def test_sweep_rows_are_the_cases_solved_checked_and_held(reference):
    table = reference.table
    rows = table.to_pylist()
    assert [r["case"] for r in rows] == list(range(N))
    assert reference.ran == N and reference.resumed == 0 and reference.errors == 0
    for r, c in zip(rows, SWEEP.cases(), strict=True):
        assert (r["robot"], r["stack"], r["point"], r["seed"]) == (
            c.robot,
            c.stack,
            c.point,
            c.seed,
        )
        assert [r[k] for k in "xyz"] == [c.params[k] for k in "xyz"]
        # the hand column is where the hand ended; its distance to the target is hand_error
        target = np.array([r["x"], r["y"], r["z"]])
        assert np.linalg.norm(np.array(r["hand"]) - target) == pytest.approx(r["hand_error"])
        if r["converged"]:
            assert r["hand_error"] < 1e-3  # the IK's own threshold
        assert r["solve_time"] > 0 and r["static_time"] > 0 and r["hold_time"] > 0
        assert r["motion_time"] > 0
    # without the CoM task the two low forward reaches tip over; with it every reach
    # stands, the far low one through its motion too (timed for its ZMP, pik_mj.sim.zmp)
    fails = [
        (r["verdict"], r["stack"], r["x"], r["z"]) for r in rows if r["verdict"] != "validated"
    ]
    assert fails == [
        ("fails", "unbalanced", 0.45, 0.6),
        ("fails", "unbalanced", 0.6, 0.6),
    ]
    for r in rows:  # a row carries the pose it was validated with: the last iterate
        assert np.allclose(r["path"][-1], r["qpos"], atol=1e-12)
    for r in rows:  # the static check agrees with the hold
        assert r["static_feasible"] == (r["static_margin"] > 0) == r["hold_passed"]
        if r["stack"] == "balanced":  # the CoM task's 2 cm margin, seen by the scene
            assert r["static_margin"] > 0.02 - 1e-3
    # both actors ran cases
    assert len({r["worker"] for r in rows}) == 2
    # a case rerun here, outside Ray, in a fresh worker gives the same row
    worker = Worker("sample_humanoid", hold=SWEEP.hold)
    for i in (3, 6):  # one per stack
        again = worker.run(SWEEP.cases()[i])
        for k, v in again.items():
            if k not in UNREPEATABLE:
                assert v == rows[i][k], k


def test_margin_is_a_task_parameter_of_the_balanced_stack(reference):
    """The CoM margin of the balanced stack, swept as a parameter, reaches the scene."""
    worker = Worker("sample_humanoid", hold=SWEEP.hold)
    case = SWEEP.cases()[2]  # balanced, x = 0.6 m, z = 0.6 m: the CoM at the 2 cm margin
    default = reference.table.to_pylist()[2]
    assert default["static_margin"] == pytest.approx(0.02, abs=1e-3)
    wide = worker.run(replace(case, params={**case.params, "margin": 0.05}))
    assert wide["static_margin"] == pytest.approx(0.05, abs=1e-3)
    assert wide["converged"] and wide["hold_passed"]


def test_a_case_that_raises_is_a_row_and_the_others_complete(ray_session, tmp_path, reference):
    report = run_sweep(
        SWEEP, tmp_path / "s", workers=2, batch_size=1, worker_class=RaisingWorker, progress=False
    )
    rows = report.table.to_pylist()
    assert [r["case"] for r in rows] == list(range(N))
    assert report.errors == 2
    raised, died = rows[RAISE], rows[DIE]
    assert raised["verdict"] == "error" and raised["error"] == "RuntimeError: boom on case 2"
    assert "raise RuntimeError" in raised["traceback"]
    assert raised["converged"] is None and raised["hold_passed"] is None
    assert raised["x"] == SWEEP.cases()[RAISE].params["x"]  # the identity is kept
    assert died["verdict"] == "error" and "worker process died" in died["error"]
    others = [r for r in rows if r["case"] not in (RAISE, DIE)]
    ref = [r for r in reference.table.to_pylist() if r["case"] not in (RAISE, DIE)]
    assert comparable(others) == comparable(ref)


def sweep_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "pik_mj.sweep", *args]


@pytest.mark.process
def test_killed_sweep_resumes_to_the_uninterrupted_rows(ray_session, tmp_path, reference):
    out = tmp_path / "sweep"
    ray_tmp = tempfile.mkdtemp(prefix="pkk")
    env = dict(os.environ, RAY_TMPDIR=ray_tmp)
    args = [str(out), *GRID_ARGS, "--workers", "2", "--batch-size", "1", "--quiet"]
    driver = subprocess.Popen(sweep_command(*args, "--no-views"), env=env)
    parts = out / "rows"
    try:
        deadline = time.monotonic() + 120
        while driver.poll() is None and time.monotonic() < deadline:
            if parts.is_dir() and len(list(parts.glob("part-*.parquet"))) >= 3:
                break
            time.sleep(0.02)
        assert driver.poll() is None, "the sweep ended before it could be killed"
        driver.send_signal(signal.SIGKILL)
    finally:
        driver.kill()
        driver.wait()
    assert wait_gone(ray_tmp) == []  # Ray's processes share the driver's fate
    kept = read_rows(out).to_pylist()
    assert 3 <= len(kept) < N  # a batch file is whole or absent
    assert comparable(kept) == comparable(
        r for r in reference.table.to_pylist() if r["case"] in {k["case"] for k in kept}
    )

    done = run_sweep(None, out, resume=True, workers=2, batch_size=1, progress=False)
    assert (done.ran, done.resumed) == (N - len(kept), len(kept))
    rows = read_rows(out).to_pylist()
    assert [r["case"] for r in rows] == list(range(N))  # every case exactly once
    assert comparable(rows) == comparable(reference.table.to_pylist())


def test_views_show_every_case_by_verdict(reference, tmp_path):
    table = reference.table
    png, rrd = tmp_path / "map.png", tmp_path / "map.rrd"
    assert write_views(table, SWEEP, png=png, rrd=rrd) == [png, rrd]
    rec = read_recording(rrd)
    rows = table.to_pylist()
    for stack in SWEEP.stacks:
        for verdict, color in COLORS.items():
            mine = [
                [r["x"], r["y"], r["z"]]
                for r in rows
                if (r["stack"], r["verdict"]) == (stack, verdict)
            ]
            path = f"world/sweep/{stack}/{verdict}"
            if not mine:
                assert path not in rec
                continue
            got = rec[path].static
            np.testing.assert_allclose(np.array(got["Points3D:positions"]), mine)
            packed = (color[0] << 24) | (color[1] << 16) | (color[2] << 8) | 255
            assert got["Points3D:colors"] == [packed] * len(mine)
    assert any(p.startswith("world/robot/") for p in rec)  # the robot is drawn
    from matplotlib.image import imread

    image = imread(png)
    assert image.shape[0] > 400 and image.shape[1] > 600
    # green cells (validated) fill part of the picture
    green = np.all(np.abs(image[:, :, :3] - np.array(COLORS["validated"]) / 255) < 0.02, axis=2)
    assert green.sum() > 2000
    table_text = summary_table(table)
    assert "sample_humanoid  balanced" in table_text
    line = next(x for x in table_text.splitlines() if "unbalanced" in x)
    assert line.split()[2:7] == ["4", "2", "(50%)", "0", "2"]  # cases, validated, held, fails
    line = next(x for x in table_text.splitlines() if " balanced" in x)
    assert line.split()[2:7] == ["4", "4", "(100%)", "0", "0"]


def test_usage_errors(ray_session, tmp_path, reference, capsys):
    with pytest.raises(InvalidInput, match="already holds a sweep"):
        run_sweep(SWEEP, reference.path, progress=False)
    other = Sweep(Grid(GRID), hold=0.5)
    with pytest.raises(InvalidInput, match="holds another sweep"):
        run_sweep(other, reference.path, resume=True, progress=False)
    with pytest.raises(InvalidInput, match="workers=3 but the Ray cluster has 2 CPUs"):
        run_sweep(SWEEP, tmp_path / "w", workers=3, progress=False)
    # a robot that cannot be built stops the sweep with the reason
    with pytest.raises(InvalidInput, match=r"limb 'rhand' does not exist.*'rarm'"):
        run_sweep(replace(SWEEP, hand="rhand"), tmp_path / "h", workers=1, progress=False)
    # a finished sweep resumed runs nothing (and needs no Ray)
    again = run_sweep(None, reference.path, resume=True, progress=False)
    assert again.ran == 0 and again.resumed == N and len(again.table) == N
    # `pik-mj sweep` is registered; bad options exit 2 with the reason
    assert cli.main(["sweep", str(tmp_path / "c"), "--grid", "x=0.1:0.5", "y=0", "z=1"]) == 2
    assert "A:B:N needs a whole count" in capsys.readouterr().err
