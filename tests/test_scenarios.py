"""Every seed example runs green through the scenario registry."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.scenarios import REGISTRY, Scenario, ScenarioResult, run_scenario

KEYS = {"name", "passed", "converged", "iterations", "tasks", "timing", "figures", "messages"}


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_scenario_passes(name):
    result = run_scenario(name)
    assert result.passed, result.summary()
    d = result.to_dict()
    assert KEYS <= set(d)
    json.dumps(d, allow_nan=False)  # JSON-ready
    assert d["timing"]["iteration_ms"] and all(t > 0 for t in d["timing"]["iteration_ms"])
    for task in d["tasks"]:
        assert {"name", "level", "error", "satisfied"} <= set(task)
    assert all(m.startswith("[ok]") for m in result.messages)


def test_fullbody_reach_on_dm_humanoid():
    result = run_scenario("fullbody_reach", model="dm_humanoid")
    assert result.passed, result.summary()
    f = result.figures
    assert f["model"] == "dm_humanoid"
    assert f["feet_moved_m"] <= 1e-4 and f["com_xy_error_m"] <= 1e-3 and f["com_margin_m"] > 0


def test_three_dof_boundary_matches_the_joint_limit_geometry():
    f = run_scenario("three_dof_reach").figures
    # tip down at height 0 needs the elbow bend 2 acos(x / 0.2) <= 100°
    x_min = 0.2 * np.cos(np.deg2rad(50.0))
    assert f["x_min_analytic_m"] == pytest.approx(x_min)
    assert min(f["reached_x_m"]) >= x_min - 2e-3 and max(f["failed_x_m"]) <= x_min + 2e-3
    assert np.allclose(f["failing_case_angles_deg"], 30.0)


def test_registry_errors_and_waiting_scenarios(monkeypatch):
    with pytest.raises(UnknownName, match="fullbody_reach"):
        run_scenario("nope")
    with pytest.raises(InvalidInput, match="takes no model"):
        run_scenario("kettle", model="dm_humanoid")
    waiting = Scenario(
        "waits",
        "needs a module",
        fn=lambda out, **k: ScenarioResult("waits"),
        requires=("pik_mj.not_written_yet",),
    )
    monkeypatch.setitem(REGISTRY, "waits", waiting)
    assert waiting.missing() == ["pik_mj.not_written_yet"]
    with pytest.raises(PikError, match="waiting"):
        run_scenario("waits")
    assert REGISTRY["wall_contact"].missing() == []  # pik_mj.tasks.scfr exists


def test_failed_check_fails_the_scenario():
    r = ScenarioResult("x")
    assert r.check("fine", True) and r.passed
    assert not r.check("broken", False, "detail")
    assert not r.passed and r.messages[-1] == "[FAILED] broken: detail"
    assert r.to_dict()["passed"] is False
