"""`pip install .` (not editable) ships everything `pik-mj` needs: from an empty
directory, `pik-mj list` names every scenario and `pik-mj run NAME` passes for
each, importing pik_mj, its scenarios and its MJCF models from the install."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pik_mj.scenarios
import pytest

SOURCE = Path(__file__).resolve().parents[1]
HOLD = ["--hold", "0.3", "--speed", "0"]
#: Quicker runs of every scenario (shorter holds and walks, the full-body
#: scenarios' motions not played): the point is that each one runs from the
#: install; tests/test_run_recording.py plays them and checks the figures.
FAST = {
    "cocktail_shaker": ["--steps", "4", *HOLD],
    "walk_forward": ["--steps", "1", "--dt", "0.05"],
    "walk_go_pos": ["--x", "0.1", "--y", "0.0", "--theta", "10", "--dt", "0.05"],
}

#: `pik-mj list`, then `pik-mj run NAME` for every name listed, in one interpreter
#: (pik_mj.cli.main is what the console script calls).
DRIVER = """
import contextlib, io, json, sys
import pik_mj, pik_mj.cli, pik_mj.mjcf, pik_mj.scenarios
fast = json.loads(sys.argv[1])
with contextlib.redirect_stdout(io.StringIO()) as listed:
    listed_code = pik_mj.cli.main(["list"])
names = [line.split()[0] for line in listed.getvalue().splitlines()]
codes = {name: pik_mj.cli.main(["run", name, "--quiet", *fast[name]]) for name in names}
print(json.dumps({
    "listed": [listed_code, names],
    "codes": codes,
    "files": [pik_mj.__file__, pik_mj.scenarios.__file__, pik_mj.mjcf.__file__],
}))
"""


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """pik_mj built from a copy of the source tree and installed (not editable)
    into a directory of its own."""
    tmp = tmp_path_factory.mktemp("install")
    src = tmp / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "build", ".*", "out")
    for name in ("pik_mj", "scenarios", "models"):
        shutil.copytree(SOURCE / name, src / name, ignore=ignore)
    for name in ("pyproject.toml", "setup.py", "README.md"):
        shutil.copy2(SOURCE / name, src / name)
    site = tmp / "site"
    subprocess.run(
        [
            *(sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-compile"),
            *("--no-build-isolation", "--no-index", "--target", str(site), str(src)),
        ],
        check=True,
        capture_output=True,
        timeout=300,
    )
    return site


def _installed(site: Path, cwd: Path, *command: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(site)}
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.process
def test_list_and_run_every_scenario_from_a_non_editable_install(installed, tmp_path):
    cwd = tmp_path / "empty"
    cwd.mkdir()
    names = pik_mj.scenarios.SCENARIOS
    fast = {name: FAST.get(name, HOLD if name != "three_dof_reach" else []) for name in names}
    done = _installed(installed, cwd, sys.executable, "-c", DRIVER, json.dumps(fast))
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(done.stdout.splitlines()[-1])
    # imported from the install, not from the source tree
    for file in report["files"]:
        assert Path(file).resolve().is_relative_to(installed.resolve()), file
    assert report["listed"] == [0, names]
    assert report["codes"] == dict.fromkeys(names, 0), done.stdout[-3000:]
    for name in names:  # `pik-mj run NAME` records into out/NAME.rrd by default
        assert (cwd / "out" / f"{name}.rrd").stat().st_size > 10_000, name
    assert sorted(p.name for p in cwd.iterdir()) == ["out"]  # nothing else written
    # the console script pip wrote for [project.scripts] calls the same main
    script = (installed / "bin" / "pik-mj").read_text()
    assert "from pik_mj.cli import main" in script
