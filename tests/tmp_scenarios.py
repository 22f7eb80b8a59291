"""Scenario modules written by a test into a temporary directory and made part of
``pik_mj.scenarios`` for the test (the registry is the package itself)."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pik_mj.scenarios


def add_scenario(monkeypatch, tmp_path: Path, name: str, source: str) -> None:
    """Make ``pik_mj.scenarios.<name>`` the module ``source`` for this test."""
    folder = tmp_path / "extra_scenarios"
    folder.mkdir(exist_ok=True)
    (folder / f"{name}.py").write_text(textwrap.dedent(source))
    monkeypatch.setattr(pik_mj.scenarios, "__path__", [*pik_mj.scenarios.__path__, str(folder)])
    monkeypatch.setattr(pik_mj.scenarios, "SCENARIOS", [*pik_mj.scenarios.SCENARIOS, name])
    monkeypatch.delitem(sys.modules, f"pik_mj.scenarios.{name}", raising=False)
