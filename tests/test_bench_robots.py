"""Smoke run of benchmarks/bench_robots.py on the project's own humanoid (the
Menagerie rows need the robots; they are skipped, and said so, without them)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_robots.py"


def _bench():
    spec = importlib.util.spec_from_file_location("_bench_robots", BENCH)
    module = importlib.util.module_from_spec(spec)
    sys.modules["_bench_robots"] = module  # dataclasses resolve annotations through it
    spec.loader.exec_module(module)
    return module


def test_bench_robots_small(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))  # no Menagerie robot here
    figures = _bench().main(
        [
            "--n",
            "1",
            "--hold",
            "1",
            "--walk-steps",
            "1",
            "--robots",
            "sample_humanoid",
            "unitree_g1",
        ]
    )
    out = capsys.readouterr().out
    assert figures["skipped"] == ["unitree_g1"] and "unitree_g1       skipped" in out
    row = figures["rows"]["sample_humanoid"]
    assert row["nv"] == 36
    assert 0 < row["pairs"] < 114  # the pairs the hand and legs can move, of 114
    # the target is reachable by construction; the pose reached holds in physics
    assert row["converged"] == 1.0 and row["converged_without"] == 1.0
    assert row["ms_per_iteration"] > 0 and row["ms_per_iteration_without"] > 0
    assert row["hold_pass"] == 1.0 and 0 < row["max_drift"] < 0.01
    assert "hold pass" in out
    # the walk column: 1 stride + the closing step, and the go-pos, in physics
    forward, go_pos = row["walk"]["forward"], row["walk"]["go_pos"]
    assert forward["verdict"] == "pass" and forward["steps"] == 2
    assert go_pos["verdict"] == "pass" and go_pos["steps"] >= 4
    for w in (forward, go_pos):
        assert w["zmp_sim_source"] == "force sensors"  # the sample humanoid has them
        assert w["zmp_margin_id"] > 0.01 and w["zmp_margin_sim"] > 0.0
        assert w["final_error"] < 0.05
    assert "walk forward" in out and "pass  2 st" in out
