"""The pik-mj command line: list, run, JSON summary, rerun recording, exit codes."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from pik_mj import cli
from pik_mj.record import PATHS, read_recording
from pik_mj.scenarios import REGISTRY, Scenario, ScenarioResult


def test_list_names_every_scenario(capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    for name in REGISTRY:
        assert name in out
    assert "default" in out.splitlines()[list(REGISTRY).index("fullbody_reach")]


def test_run_writes_json_and_recording(tmp_path, capsys):
    rrd, js = tmp_path / "r.rrd", tmp_path / "sub" / "r.json"
    code = cli.main(["run", "three_dof_reach", "--out", str(rrd), "--json", str(js)])
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
    code = cli.main(
        [
            "run",
            "fullbody_reach",
            "--model",
            "dm_humanoid",
            "--no-record",
            "--json",
            str(tmp_path / "d.json"),
            "--quiet",
            "--hold",
            "0",
        ]
    )
    assert code == 0
    d = json.loads((tmp_path / "d.json").read_text())
    assert d["figures"]["model"] == "dm_humanoid"
    assert d["balance"] is None  # --hold 0
    # dm_control's humanoid starts 0.2145 m above its floor: the scene lowers it.
    assert d["robot"]["model"] == "dm_humanoid"
    assert d["robot"]["robot_pos"][2] == pytest.approx(-0.2145, abs=1e-3)
    assert d["simulation"]["iterations_checked"] == d["timing"]["total_iterations"]


def test_exit_codes_for_failing_and_bad_runs(tmp_path, monkeypatch, capsys):
    def failing(out, *, progress=False):
        result = ScenarioResult("always_fails")
        result.check("impossible", False)
        return result

    monkeypatch.setitem(REGISTRY, "always_fails", Scenario("always_fails", "test", fn=failing))
    assert cli.main(["run", "always_fails", "--no-record", "--quiet"]) == 1
    assert "[FAILED] impossible" in capsys.readouterr().out
    assert cli.main(["run", "no_such_scenario"]) == 2
    assert "Valid scenario names" in capsys.readouterr().err
    assert cli.main(["run", "kettle", "--model", "dm_humanoid", "--no-record"]) == 2
    assert cli.main(["run", "kettle", "--hold", "-1", "--no-record"]) == 2
    assert "--hold" in capsys.readouterr().err
    assert cli.main(["validate", str(tmp_path / "missing.json")]) == 2
    assert "does not exist" in capsys.readouterr().err
    (tmp_path / "arm.json").write_text(json.dumps({"name": "three_dof_reach", "robot": None}))
    assert cli.main(["validate", str(tmp_path / "arm.json")]) == 2
    assert "holds no pose" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["frobnicate"])


def test_console_script_lists_scenarios():
    exe = shutil.which("pik-mj") or "/work/venv/bin/pik-mj"
    out = subprocess.run([exe, "list"], capture_output=True, text=True, timeout=60, check=True)
    assert "fullbody_external_force" in out.stdout
