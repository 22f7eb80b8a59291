"""Edges of ``pik-mj`` a new user meets first: a scenario's ``--help`` names the
command it belongs to and starts no run, runs on other robots keep their own
recordings, and a pose moved into a world without what it holds is refused
naming it (it said ``free environment body 'kettle' does not exist. Valid …: []``).
"""

from __future__ import annotations

import json
from pathlib import Path

import pik_mj
from pik_mj import cli


def test_scenario_help_is_usage_of_pik_mj_run_name(tmp_path, monkeypatch, capsys):
    """``pik-mj run kettle --help``: exit 0, ``usage: pik-mj run kettle``, no
    "running kettle" banner, and no recording started."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "kettle", "--help"]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("usage: pik-mj run kettle [-h]")
    assert "--hold HOLD" in out and "running" not in err
    assert list(tmp_path.iterdir()) == []


def test_usage_errors_name_the_scenario_command(capsys):
    assert cli.main(["run", "kettle", "--hold", "-1"]) == 2
    err = capsys.readouterr().err
    assert "usage: pik-mj run kettle" in err and "pik-mj run kettle: error: argument --hold" in err


def test_default_recording_is_per_model():
    """Without a recording option, a run saves out/NAME.rrd, and out/NAME-MODEL.rrd
    with --model (a name, or an MJCF path's stem): runs on other robots do not
    overwrite each other."""
    name = "fullbody_reach"
    assert cli.default_recording(name, []) == Path("out/fullbody_reach.rrd")
    assert cli.default_recording(name, ["--hold", "1"]) == Path("out/fullbody_reach.rrd")
    got = cli.default_recording(name, ["--model", "unitree_g1", "--hold", "0"])
    assert got == Path("out/fullbody_reach-unitree_g1.rrd")
    got = cli.default_recording(name, ["--model=/robots/h1/scene.xml"])
    assert got == Path("out/fullbody_reach-scene.rrd")


def test_validate_in_an_environment_without_the_held_body(tmp_path, capsys):
    """A kettle pose validated with ``--environment none``: exit 2, one line naming
    the kettle and the room it came from; before any physics."""
    robot = pik_mj.Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    pose = robot.source.to_dict()
    pose["q"] = [float(x) for x in robot.configuration.q]
    eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    pose["grasps"] = [{"frame": "rarm_end", "body": "kettle", "p_FO": [0, 0, 0], "R_FO": eye}]
    path = tmp_path / "pose.json"
    path.write_text(json.dumps(pose))
    assert cli.main(["validate", str(path), "--environment", "none"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "pik-mj: error: --environment none: the pose holds 'kettle' of environment 'room', "
        "which the floor alone does not have; give an environment with it, or leave "
        "--environment out"
    ]
