"""The pik-mj command line: list, run, JSON summary, rerun recording, exit codes."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pik_mj.scenarios
import pytest
from tmp_scenarios import add_scenario

from pik_mj import cli
from pik_mj.record import PATHS, read_recording


def test_list_names_every_scenario(capsys):
    assert cli.main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    names = pik_mj.scenarios.SCENARIOS
    assert [line.split()[0] for line in lines] == names
    reach = lines[names.index("fullbody_reach")]
    assert "[default; --model: a left arm, two legs, a floating base]" in reach
    assert "Fullbody IK" in reach
    # the description is the first line of the scenario's docstring
    kettle = lines[names.index("kettle")]
    doc = cli.load_scenario("kettle").__doc__.strip().splitlines()[0]
    assert kettle.split(None, 1)[1].startswith(doc + "  [--model: a right arm, two legs")


def test_run_writes_json_and_recording(tmp_path, capsys):
    rrd, js = tmp_path / "r.rrd", tmp_path / "sub" / "r.json"
    code = cli.main(["run", "three_dof_reach", "--save", str(rrd), "--json", str(js)])
    captured = capsys.readouterr()
    assert code == 0
    assert "three_dof_reach: PASSED" in captured.out and str(rrd) in captured.out
    assert "iteration" in captured.err  # progress on stderr
    d = json.loads(js.read_text())
    for key in ("converged", "iterations", "tasks", "timing", "figures", "balance", "solves"):
        assert key in d
    # The 3-DoF arm has no floating base: no simulation, no hold, no pose to validate.
    assert d["balance"] is None and d["simulation"] is None and d["robot"] is None
    assert d["converged"] is False and d["passed"] is True  # main solve: the seed's failing case
    assert {"name", "level", "error", "satisfied"} <= set(d["tasks"][0])
    rec = read_recording(rrd)
    assert any(p.startswith("world/robot/") for p in rec)
    assert "l4" in rec[PATHS.bodies()].static["Ellipsoids3D:labels"]
    times, _ = rec[PATHS.bodies()].series("Ellipsoids3D:centers", "iteration")
    assert len(times) >= sum(s["iterations"] for s in d["solves"].values())
    assert any(p.startswith("errors/level_1/") for p in rec)
    assert "world/com" in rec


def test_run_default_is_fullbody_reach_into_out_dir(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "--quiet"]) == 0
    rrd = Path("out") / "fullbody_reach.rrd"
    assert (tmp_path / rrd).is_file()
    out = capsys.readouterr().out
    assert "fullbody_reach: PASSED" in out
    # solved, validated in simulation (every iteration and a 3 s hold), recorded
    assert re.search(r"simulation, every iteration: (\d+)/\1 iterations in static equilibrium", out)
    assert "[ok] simulation: final pose in static equilibrium and held 3 s in physics" in out
    assert out.rstrip().splitlines()[-1].startswith(f"recording: {rrd}")
    assert out.count(f"recording: {rrd}") == 1


def test_run_with_model_option(tmp_path):
    js = tmp_path / "d.json"
    code = cli.main(
        [
            *("run", "fullbody_reach", "--model", "dm_humanoid", "--headless"),
            *("--json", str(js), "--quiet", "--hold", "0"),
        ]
    )
    assert code == 0
    d = json.loads(js.read_text())
    assert d["figures"]["model"] == "dm_humanoid"
    assert d["balance"] is None  # --hold 0
    assert d["robot"]["model"] == "dm_humanoid" and d["robot"]["environment"] is None
    # dm_control's humanoid starts 0.2145 m above the floor; its world stands it on
    # z = 0 (the IK and the scene share it): the hand target is 0.5 m below its root
    assert d["figures"]["hand_target_m"][2] == pytest.approx(1.5 - 0.2145 - 0.5, abs=1e-3)
    assert d["simulation"]["iterations_checked"] == d["timing"]["total_iterations"]


def test_the_robot_the_parser_checked_is_the_one_the_run_moves(tmp_path, monkeypatch):
    """``--model`` is checked by building the robot; the scenario moves that
    robot instead of building a second one."""
    from pik_mj.scenarios import fullbody_reach

    from pik_mj.robot import Robot

    built = []
    from_model = Robot.from_model.__func__

    def counting(cls, *args, **kwargs):
        robot = from_model(cls, *args, **kwargs)
        built.append(robot)
        return robot

    monkeypatch.setattr(Robot, "from_model", classmethod(counting))
    js = tmp_path / "d.json"
    argv = ["--model", "dm_humanoid", "--headless", "--quiet", "--hold", "0", "--speed", "0"]
    assert fullbody_reach.main([*argv, "--json", str(js)]) == 0
    assert len(built) == 1
    assert json.loads(js.read_text())["robot"]["model"] == "dm_humanoid"
    # a parser without --model keeps no robot
    from pik_mj.scenario import parser

    assert parser("A scenario.", hold=False).parse_args([]).robot is None


FAILING = '''
    """A scenario whose check fails."""
    from pik_mj.scenario import ScenarioResult, open_recorder, parser, report


    def run(recorder):
        result = ScenarioResult("always_fails")
        result.check("impossible", False)
        return result


    def main(argv=None):
        args = parser(__doc__, hold=False).parse_args(argv)
        with open_recorder(args, "always_fails") as recorder:
            result = run(recorder)
        return report(result, args)
'''

WAITING = '''
    """A scenario waiting for a module."""
    import pik_mj.not_written_yet
'''


def test_exit_codes_for_failing_and_bad_runs(tmp_path, monkeypatch, capsys):
    add_scenario(monkeypatch, tmp_path, "always_fails", FAILING)
    add_scenario(monkeypatch, tmp_path, "waits", WAITING)
    assert cli.main(["run", "always_fails", "--headless", "--quiet"]) == 1
    assert "[FAILED] impossible" in capsys.readouterr().out
    assert cli.main(["list"]) == 0
    listed = capsys.readouterr().out
    lines = listed.splitlines()
    assert lines[-2].split(None, 1) == ["always_fails", "A scenario whose check fails."]
    assert lines[-1].split() == ["waits", "[waiting", "for", "pik_mj.not_written_yet]"]
    assert cli.main(["run", "waits"]) == 2
    assert "waiting for pik_mj.not_written_yet" in capsys.readouterr().err
    assert cli.main(["run", "no_such_scenario"]) == 2
    assert "Valid scenario names" in capsys.readouterr().err
    # options the scenario's main does not take, and bad values: argparse's usage error
    assert cli.main(["run", "three_dof_reach", "--hold", "1", "--headless"]) == 2
    assert "--hold" in capsys.readouterr().err
    assert cli.main(["run", "kettle", "--hold", "-1", "--headless"]) == 2
    assert "--hold" in capsys.readouterr().err
    assert cli.main(["validate", str(tmp_path / "missing.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    (tmp_path / "arm.json").write_text(json.dumps({"name": "three_dof_reach", "robot": None}))
    assert cli.main(["validate", str(tmp_path / "arm.json")]) == 2
    assert "holds no pose" in capsys.readouterr().err
    assert cli.main(["frobnicate"]) == 2
    assert "invalid choice: 'frobnicate'" in capsys.readouterr().err
