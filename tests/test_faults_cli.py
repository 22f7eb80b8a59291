"""Faults at the command line: outputs checked before work, bad sizes and files named,
a closed pipe ends quietly, every number of a pose file checked.

Before: ``pik-mj list | head -c 10`` was a ``BrokenPipeError`` traceback;
``validate --json /dev/full`` failed after the whole hold; ``screenshot --out DIR``
after 10 s of viewer; ``screenshot --size 0x0`` was a traceback; ``screenshot`` of a
truncated ``.rrd`` took 68 s to say "did not finish loading"; ``validate`` passed a
pose whose position was ``[NaN, 0, 0]``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest

from pik_mj import Recorder, cli
from pik_mj.robot.loading import load_model

PIK_MJ = [sys.executable, "-m", "pik_mj.cli"]


def pose_file(tmp_path, **extra) -> str:
    model = load_model("sample_humanoid")
    pose = {"model": "sample_humanoid", "q": model.key("reset_pose").qpos.tolist(), **extra}
    path = tmp_path / "pose.json"
    path.write_text(json.dumps(pose))
    return str(path)


def recording(tmp_path) -> str:
    rrd = tmp_path / "run.rrd"
    with Recorder.to_file(rrd) as recorder:
        recorder.set_time("iteration", 0)
        recorder.log_point("world/p", [0.0, 0.0, 1.0])
    return str(rrd)


def test_a_closed_pipe_ends_quietly():
    """``pik-mj list | head -c 0``: the reader is gone before the first byte, so the
    first write fails whatever the output's size (a pipe's buffer would otherwise take
    a short output whole and hide the closed reader)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        writer = subprocess.Popen([*PIK_MJ, "list"], stdout=write_end, stderr=subprocess.PIPE)
    finally:
        os.close(write_end)
    err = writer.stderr.read().decode()
    assert writer.wait(timeout=120) == 141  # as a process ended by SIGPIPE
    assert "Traceback" not in err and "BrokenPipeError" not in err and err == ""


@pytest.mark.parametrize(
    ("command", "option"),
    [
        (["validate", "{pose}", "--json"], "--json"),
        (["validate", "{pose}", "--save"], "--save"),
        (["run", "three_dof_reach", "--json"], "--json"),
        (["run", "three_dof_reach", "--save"], "--save"),
        (["screenshot", "{rrd}", "--out"], "--out"),
        (["sweep", "{out}", "--grid", "x=0.5", "y=0", "z=1", "--png"], "--png"),
    ],
)
@pytest.mark.parametrize("target", ["directory", "/dev/full"])
def test_every_command_checks_its_outputs_before_any_work(
    tmp_path, capsys, command, option, target
):
    """An output that cannot be written is a usage error before the work starts
    (no hold, no viewer, no solve): ``validate --json /dev/full`` used to fail after
    the whole hold, ``screenshot --out DIR`` after 10 s of viewer."""
    where = str(tmp_path) if target == "directory" else target
    fill = {"pose": pose_file(tmp_path), "rrd": recording(tmp_path), "out": str(tmp_path / "s")}
    argv = [a.format(**fill) for a in command] + [where]
    t0 = time.monotonic()
    assert cli.main(argv) == 2
    elapsed = time.monotonic() - t0
    err = capsys.readouterr().err
    assert repr(where) in err or where in err, err
    assert ("is a directory" in err) if target == "directory" else ("No space left" in err)
    assert "Traceback" not in err
    assert elapsed < 20.0  # checks only (a robot built at most), no hold, no viewer
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("size", ["0x0", "1600x0", "-5x10", "100000x900", "wide"])
def test_screenshot_size_is_validated(tmp_path, capsys, size):
    argv = ["screenshot", recording(tmp_path), "--out", str(tmp_path / "a.png"), f"--size={size}"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "WIDTHxHEIGHT in points, each 1..8192" in err and "Traceback" not in err


def test_screenshot_of_a_truncated_recording_is_named_before_the_viewer(tmp_path, capsys):
    whole = recording(tmp_path)
    cut = tmp_path / "cut.rrd"
    data = open(whole, "rb").read()
    cut.write_bytes(data[: len(data) - 100])
    t0 = time.monotonic()
    assert cli.main(["screenshot", str(cut), "--out", str(tmp_path / "a.png")]) == 2
    err = capsys.readouterr().err
    assert f"recording '{cut}' is truncated" in err
    assert "headless rerun viewer" not in err  # never started
    assert time.monotonic() - t0 < 5.0
    assert not (tmp_path / "a.png").exists()


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        ({"at": [float("nan"), 0.0, 0.0]}, "'at'[0] = nan"),
        ({"robot_pos": [float("nan"), 0, 0]}, "'robot_pos'[0] = nan"),
        (
            {"external": [["rarm_end", [0, 0, float("inf")], [0, 0, 0]]]},
            "'external'[0][1][2] = inf",
        ),
    ],
)
def test_validate_checks_every_number_of_the_pose_file(tmp_path, capsys, extra, named):
    path = pose_file(tmp_path, **extra)
    assert cli.main(["validate", path]) == 2
    err = capsys.readouterr().err
    assert named in err and "must be finite" in err


def test_validate_refuses_a_nan_in_q(tmp_path, capsys):
    model = load_model("sample_humanoid")
    q = model.key("reset_pose").qpos.tolist()
    q[10] = float("nan")
    path = tmp_path / "pose.json"
    path.write_text(json.dumps({"model": "sample_humanoid", "q": q}))
    assert cli.main(["validate", str(path)]) == 2
    joint = model.joint(int(sum(model.jnt_qposadr <= 10)) - 1).name
    assert f"joint '{joint}' holds NaN or inf" in capsys.readouterr().err
