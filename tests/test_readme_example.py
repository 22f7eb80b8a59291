"""The README's first example, run as written: the reach converges, its iterates played
in physics pass, the final pose holds, and the recording it writes reads back."""

from __future__ import annotations

import re
from pathlib import Path

from pik_mj.record import PATHS, read_recording

README = Path(__file__).resolve().parent.parent / "README.md"


def first_python_example() -> str:
    """The first ```python block of the README."""
    return re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)


def test_readme_first_example_plays_its_motion_and_passes(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    code = first_python_example()
    assert "scene.play(path" in code and "scene.hold(" in code
    namespace: dict = {}
    exec(compile(code, str(README), "exec"), namespace)
    result, motion, hold = namespace["result"], namespace["motion"], namespace["hold"]
    assert result.converged and result.iterations > 1
    assert motion.passed, motion.failures
    assert motion.duration > 0.1 and not motion.fell and motion.unexpected_contacts == []
    assert motion.max_slip < 2e-3
    assert hold.passed, hold.failures
    assert "motion: PASSED" in capsys.readouterr().out
    # the recording it wrote: the solve's iterations, then the physics on its clock
    rec = read_recording(tmp_path / "reach.rrd")
    times, _ = rec[PATHS.bodies()].series("Ellipsoids3D:centers", "iteration")
    assert len(times) >= result.iterations
    sim = [
        t["sim_time"]
        for e in rec.values()
        for rows in e.temporal.values()
        for t, _ in rows
        if "sim_time" in t
    ]
    assert max(sim) >= motion.duration + 3.0 - 0.05  # the motion, then the 3 s hold
