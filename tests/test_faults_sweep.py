"""Faults of sweeps: nothing hung, nothing counted twice, nothing left half made.

Before: ``--address`` to a dead head retried for ever; two ``--resume`` at once both
exited 0 with every case twice; an unknown robot left ``sweep.json`` and ``rows/`` that
refused the corrected rerun; a corrupt part file was an ``ArrowInvalid`` traceback; a
full disk left ``.tmp-sweep.json`` and a directory refused as "not empty".

Most tests need no Ray: the dataset is written with real rows (:func:`make_row`) and
a sweep whose cases all have a row runs nothing. One module-scoped local Ray instance
(1 CPU) serves the two that run cases. The soak (200 cases killed and resumed, two
resumers at once) is ``benchmarks/bench_sweep_faults.py``.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import ray
from local_ray import local_ray

from pik_mj.exceptions import InvalidInput, OutputError, WriterBusy
from pik_mj.sweep import Grid, Sweep, read_rows, run_sweep
from pik_mj.sweep.dataset import RESULT_FIELDS, Dataset, make_row

pytestmark = pytest.mark.process  # locks, addresses, disks: not MuJoCo's version

SWEEP = Sweep(Grid({"x": [0.45, 0.6], "y": [-0.2], "z": [1.0]}), stacks=("balanced",), hold=0.2)
N = len(SWEEP)


def result(case_index: int) -> dict:
    """A worker's result columns (as a Worker returns them) for a case."""
    values = {
        "converged": True,
        "iterations": 10 + case_index,
        "hand_error": 1e-4,
        "level_errors": [0.0, 1e-6],
        "hand": [0.5, -0.2, 1.0],
        "com": [0.0, 0.0, 0.8],
        "static_feasible": True,
        "static_margin": 0.05,
        "motion_passed": True,
        "motion_failures": [],
        "motion_drift": 2e-3,
        "hold_passed": True,
        "hold_failures": [],
        "drift": 1e-3,
        "slip": 1e-4,
        "hold_min_margin": 0.04,
        "fell": False,
        "unexpected_contacts": [],
        "qpos": [0.0, 0.0, 0.9],
        "path": [[0.0, 0.0, 0.9]],
        "solve_time": 0.1,
        "static_time": 0.01,
        "motion_time": 0.3,
        "hold_time": 0.2,
    }
    assert set(values) == {f.name for f in RESULT_FIELDS}
    return values


def written(out: Path, sweep: Sweep = SWEEP, cases: range | None = None) -> Dataset:
    """``out`` holding ``sweep`` with a row for each of ``cases`` (default: all), one
    part per case; the writer's lock released."""
    data = Dataset.open(out, sweep)
    for case in sweep.cases():
        if cases is None or case.index in cases:
            data.write([make_row(case, result(case.index), "test:0")])
    data.close()
    return data


def sweep_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "pik_mj.sweep", *args]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def ray_one_cpu():
    """A local Ray instance of 1 CPU for the tests that run cases (run_sweep uses it)."""
    with local_ray(1, prefix="pkf") as tmp:
        yield tmp


# ---------------------------------------------------------------- bounded waiting
def test_an_address_where_nothing_listens_fails_at_once_naming_it(tmp_path):
    address = f"127.0.0.1:{free_port()}"
    t0 = time.monotonic()
    with pytest.raises(InvalidInput, match=f"no Ray cluster answers at '{address}'"):
        run_sweep(SWEEP, tmp_path / "s", address=address, connect_timeout=3.0, progress=False)
    assert time.monotonic() - t0 < 3.0
    assert not (tmp_path / "s").exists()  # refused before anything was written
    assert not ray.is_initialized()


def test_an_address_that_is_not_ray_is_given_up_within_the_timeout(tmp_path):
    """A port that accepts connections but never speaks Ray: ``ray.init`` would wait
    for ever; the command gives up after --connect-timeout with exit 2."""
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def accept() -> None:
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])
            except TimeoutError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        t0 = time.monotonic()
        run = subprocess.run(
            sweep_command(
                str(tmp_path / "s"),
                "--grid",
                "x=0.5",
                "y=-0.2",
                "z=1.0",
                "--stack",
                "balanced",
                "--address",
                f"127.0.0.1:{port}",
                "--connect-timeout",
                "3",
            ),
            capture_output=True,
            text=True,
            timeout=120,
        )
        elapsed = time.monotonic() - t0
    finally:
        stop.set()
        thread.join()
        server.close()
        for c in accepted:
            c.close()
    assert run.returncode == 2, run.stderr
    assert f"Ray cluster at '127.0.0.1:{port}'" in run.stderr
    assert "within 3 s" in run.stderr
    assert "Traceback" not in run.stderr
    assert elapsed < 60  # start-up of the interpreter and the robot check, plus 3 s
    assert not (tmp_path / "s").exists()


# ---------------------------------------------------------------- one writer
def holder(out: Path) -> subprocess.Popen:
    """Another process holding the sweep ``out`` open for writing, until its
    standard input closes (or it is killed)."""
    process = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from pik_mj.sweep.dataset import Dataset; "
            f"d = Dataset.open({str(out)!r}, resume=True); print('held', flush=True); "
            "sys.stdin.read()",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout.readline().strip() == "held"
    return process


def test_a_second_writer_is_refused_with_the_holders_pid_and_host(tmp_path):
    out = tmp_path / "s"
    written(out, cases=range(1))
    other = holder(out)
    try:
        with pytest.raises(WriterBusy, match=rf"pid {other.pid} on host {socket.gethostname()}"):
            run_sweep(None, out, resume=True, progress=False)
        run = subprocess.run(
            sweep_command(str(out), "--resume", "--quiet"), capture_output=True, text=True
        )
        assert run.returncode == 2
        assert f"is being written by pid {other.pid}" in run.stderr
    finally:
        other.stdin.close()
        other.wait(timeout=30)
    # the holder gone (its lock with it), the sweep can be resumed
    Dataset.open(out, resume=True).close()


def test_a_killed_holder_leaves_no_lock_behind(tmp_path):
    out = tmp_path / "s"
    written(out, cases=range(1))
    other = holder(out)
    with pytest.raises(WriterBusy):
        Dataset.open(out, resume=True)
    other.kill()
    other.wait()
    other.stdin.close()
    Dataset.open(out, resume=True).close()


# ---------------------------------------------------------------- rows keyed by case
def test_a_case_with_two_rows_is_counted_once(tmp_path):
    """What two concurrent resumers left before: every part written twice."""
    out = tmp_path / "s"
    data = written(out)
    for part in data.parts():
        shutil.copy(part, part.with_name(part.stem + "-copy.parquet"))
    assert len(data.parts()) == 2 * N
    rows = read_rows(out).to_pylist()
    assert [r["case"] for r in rows] == list(range(N))
    again = run_sweep(None, out, resume=True, progress=False)  # nothing left: no Ray
    assert (again.ran, again.resumed, len(again.table)) == (0, N, N)


def test_a_row_of_a_case_that_ran_wins_over_one_that_raised(tmp_path):
    out = tmp_path / "s"
    data = written(out)
    case = SWEEP.cases()[1]
    data.write([make_row(case, None, "test:1", "RuntimeError: boom")])
    rows = read_rows(out).to_pylist()
    assert [r["case"] for r in rows] == list(range(N))
    assert rows[1]["verdict"] == "validated" and rows[1]["error"] is None


# ---------------------------------------------------------------- corrupt parts
def test_a_corrupt_part_is_named_and_set_aside_with_repair(tmp_path, ray_one_cpu):
    out = tmp_path / "s"
    data = written(out)
    bad = data.parts()[1]
    bad.write_bytes(bad.read_bytes()[:40])  # truncated
    with pytest.raises(InvalidInput, match=rf"{bad.name}: .*--repair"):
        run_sweep(None, out, resume=True, progress=False)
    with pytest.raises(InvalidInput, match=bad.name):
        read_rows(out)
    run = subprocess.run(sweep_command(str(out), "--resume"), capture_output=True, text=True)
    assert run.returncode == 2 and bad.name in run.stderr and "Traceback" not in run.stderr
    report = run_sweep(None, out, resume=True, repair=True, progress=False)
    assert (out / "corrupt" / bad.name).is_file() and not bad.exists()
    assert (report.ran, report.resumed) == (1, N - 1)  # its case ran again
    assert [r["case"] for r in read_rows(out).to_pylist()] == list(range(N))


# ---------------------------------------------------------------- failed starts
def test_a_sweep_refused_at_start_leaves_nothing_and_the_rerun_works(tmp_path, ray_one_cpu):
    """Before: an unknown robot left sweep.json and rows/, and both the corrected
    rerun and --resume were refused."""
    out = tmp_path / "deep" / "s"
    wrong = Sweep(Grid({"x": [0.5], "y": [-0.2], "z": [1.0]}), robots=("unitree_g2",), hold=0.2)
    with pytest.raises(InvalidInput, match="unitree_g2"):
        run_sweep(wrong, out, progress=False)
    assert not (tmp_path / "deep").exists()
    right = Sweep(Grid({"x": [0.5], "y": [-0.2], "z": [1.0]}), stacks=("balanced",), hold=0.2)
    report = run_sweep(right, out, progress=False)
    assert report.ran == 1 and len(read_rows(out)) == 1


# ---------------------------------------------------------------- full disk
def fill(disk: Path, leave: int) -> None:
    """Fill ``disk`` until about ``leave`` bytes are free."""
    free = os.statvfs(disk).f_bavail * os.statvfs(disk).f_frsize
    with open(disk / "filler", "wb") as f:
        f.write(b"\0" * max(0, free - leave))


def test_a_sweep_onto_a_full_disk_fails_naming_the_file_and_leaves_nothing(small_disk):
    fill(small_disk, 0)
    out = small_disk / "s"
    with pytest.raises(OutputError, match=r"sweep .*sweep.json' could not be written: No space"):
        run_sweep(SWEEP, out, progress=False)
    assert not out.exists()  # no .tmp-sweep.json, no directory refused as "not empty"
    (small_disk / "filler").unlink()
    written(out)  # the same directory, once there is room
    assert len(read_rows(out)) == N


def test_a_batch_that_does_not_fit_is_named_and_the_rows_before_are_kept(small_disk):
    out = small_disk / "s"
    data = Dataset.open(out, SWEEP)
    first = SWEEP.cases()[0]
    data.write([make_row(first, result(0), "test:0")])
    fill(small_disk, 0)
    second = SWEEP.cases()[1]
    with pytest.raises(
        OutputError, match=r"rows of cases \[1\] '.*part-.*' could not be written: No space"
    ):
        data.write([make_row(second, result(1), "test:0")])
    assert list(data.rows.glob(".tmp-*")) == []
    assert [r["case"] for r in data.table().to_pylist()] == [0]
    data.close()
