"""Ctrl-C is always obeyed: ``KeyboardInterrupt`` propagates out of a recorded
solve and a hold with the robot's configuration restored and the recording
closed and valid; a real SIGINT stops a recorded ``pik-mj run`` (exit 130, no
traceback) and leaves a recording that ``rerun rrd verify`` accepts.

The solver side (OSQP catching SIGINT during a solve, the 20 SIGINTs during a
solve loop) is tested with the solver (tests of ``pik_mj.solve``).
"""

from __future__ import annotations

import random
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from tmp_scenarios import add_scenario

from pik_mj import Recorder, Robot, Scene, cli, fullbody_inverse_kinematics
from pik_mj.record import read_recording

ROUNDS = 20
PARALLEL = 4  # runs at a time: the interpreter's start (~2 s of imports) dominates
EXIT_TIMEOUT = 60.0  # [s] a run that does not end this long after SIGINT hangs


def rerun_command() -> list[str]:
    """The rerun CLI of this interpreter's environment (beside ``sys.executable``,
    else ``python -m rerun``): never looked up on PATH."""
    exe = Path(sys.executable).parent / "rerun"
    return [str(exe)] if exe.is_file() else [sys.executable, "-m", "rerun"]


def verify(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*rerun_command(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60
    )


class _Stop:
    """A callback raising KeyboardInterrupt at call ``at`` (what Ctrl-C does)."""

    def __init__(self, at: int):
        self.at = at
        self.calls = 0

    def __call__(self, _info: object) -> None:
        self.calls += 1
        if self.calls == self.at:
            raise KeyboardInterrupt


def test_interrupted_recorded_solve_restores_the_robot_and_closes_the_recording(tmp_path):
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    rrd = tmp_path / "solve.rrd"
    stop = _Stop(at=3)
    p_root, _ = robot.root_pose()
    target = (p_root + np.array([0.4, 0.1, -0.6]), np.array([1.0, 0.0, 0.0, 0.0]))
    with pytest.raises(KeyboardInterrupt):
        with Recorder.to_file(rrd, application_id="interrupted") as recorder:
            recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
            checks = scene.static_checker()
            fullbody_inverse_kinematics(
                robot,
                [target],
                limbs=["larm"],
                rotation_axis=[None],
                stop=100,
                callback=[checks, recorder.solve_logger("reach", checks=checks), stop],
            )
    assert stop.calls == 3  # it stopped at once
    assert np.array_equal(robot.configuration.q, q0)  # restored
    assert verify(rrd).returncode == 0, verify(rrd).stderr
    # the iterations before the interrupt are in the file
    rec = read_recording(rrd)
    assert len(checks.reports) == 3
    assert any(p.startswith("errors/level_") for p in rec)


def test_interrupted_hold_propagates_and_leaves_the_robot_alone():
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    stop = _Stop(at=4)
    with pytest.raises(KeyboardInterrupt):
        scene.hold(q0, 3.0, callback=stop)
    assert stop.calls == 4
    assert np.array_equal(robot.configuration.q, q0)
    # the scene is usable again after the interrupt
    assert scene.hold(q0, 0.1).passed


INTERRUPTED = '''
    """Interrupted mid-solve (Ctrl-C from a callback)."""
    import numpy as np
    from pik_mj import Robot, inverse_kinematics
    from pik_mj.scenario import ScenarioResult, open_recorder, parser, report


    def stop(info):
        if info.iteration == 2:
            raise KeyboardInterrupt


    def run(recorder):
        robot = Robot.from_model("three_dof_arm")
        recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
        log = recorder.solve_logger("reach")
        inverse_kinematics(robot, [(np.array([0.5, 0.5, 0.5]), np.array([1.0, 0, 0, 0]))],
                           rotation_axis=None, callback=[log, stop])
        return ScenarioResult("interrupted")


    def main(argv=None):
        args = parser(__doc__, hold=False).parse_args(argv)
        with open_recorder(args, "interrupted") as recorder:
            result = run(recorder)
        return report(result, args)
'''


def test_cli_returns_130_and_keeps_the_recording_when_interrupted(tmp_path, monkeypatch, capsys):
    add_scenario(monkeypatch, tmp_path, "interrupted", INTERRUPTED)
    rrd = tmp_path / "out" / "interrupted.rrd"
    assert cli.main(["run", "interrupted", "--save", str(rrd), "--quiet"]) == 130
    captured = capsys.readouterr()
    assert "pik-mj: interrupted" in captured.err and "Traceback" not in captured.err
    assert f"recording (up to the interrupt): {rrd}" in captured.out
    assert verify(rrd).returncode == 0, verify(rrd).stderr


MANGLED = '''
    """A real SIGINT whose KeyboardInterrupt a native call turns into another
    error (as a Cython buffer check in daqp did: "Buffer dtype mismatch")."""
    import signal
    from pik_mj.scenario import ScenarioResult, open_recorder, parser, report


    def run(recorder):
        recorder.log_text("before the interrupt")
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            raise ValueError("Buffer dtype mismatch, expected 'int' but got Python object")
        return ScenarioResult("mangled")


    def main(argv=None):
        args = parser(__doc__, hold=False).parse_args(argv)
        with open_recorder(args, "mangled") as recorder:
            result = run(recorder)
        return report(result, args)
'''


def test_an_interrupt_a_native_library_turns_into_another_error_still_exits_130(
    tmp_path, monkeypatch, capsys, ctrl_c
):
    """Ctrl-C is Ctrl-C even when it surfaces as another exception; an error
    without a SIGINT is still an error (exit 1, its traceback)."""
    add_scenario(monkeypatch, tmp_path, "mangled", MANGLED)
    rrd = tmp_path / "out" / "mangled.rrd"
    assert cli.main(["run", "mangled", "--save", str(rrd), "--quiet"]) == 130
    captured = capsys.readouterr()
    assert "pik-mj: interrupted" in captured.err and "Traceback" not in captured.err
    assert f"recording (up to the interrupt): {rrd}" in captured.out
    assert verify(rrd).returncode == 0, verify(rrd).stderr
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
    add_scenario(
        monkeypatch,
        tmp_path,
        "plain_error",
        MANGLED.replace("signal.raise_signal(signal.SIGINT)", "raise KeyboardInterrupt")
        .replace("except KeyboardInterrupt", "except KeyboardInterrupt as exc")
        .replace('"mangled"', '"plain_error"'),
    )
    assert cli.main(["run", "plain_error", "--save", str(tmp_path / "e.rrd"), "--quiet"]) == 1
    assert "Traceback" in capsys.readouterr().err


#: Where each SIGINT is aimed: after what the run printed, then a random delay [s].
PHASES = {
    "set-up": (None, 0.3),  # the recording started: robot, scene, geometry
    "solve": ("iteration 1/", 0.15),  # the IK's progress lines (~20 iterations)
    "hold": ("iterations, converged", 0.5),  # the solve ended: the motion, the hold in physics
}


def _size(path: Path) -> int:
    """Bytes in ``path``, 0 while it does not exist (the CLI's check of ``--save``
    writes and removes a probe file at that path, so it can vanish between calls)."""
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0


def _interrupt_one_run(i: int, phase: str, seed: int, tmp_path: Path) -> dict:
    """``pik-mj run fullbody_reach --save`` in a subprocess, SIGINT a random delay
    after it reached ``phase`` (its recording started, then what its stderr says)."""
    rrd = tmp_path / f"run{i}.rrd"
    mark, max_delay = PHASES[phase]
    delay = random.Random(seed).uniform(0.0, max_delay)
    proc = subprocess.Popen(
        [sys.executable, "-m", "pik_mj.cli", "run", "fullbody_reach", "--save", str(rrd)],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    err: list[str] = []
    out: list[str] = []
    readers = [
        threading.Thread(target=lambda: err.extend(proc.stderr), daemon=True),
        threading.Thread(target=lambda: out.extend(proc.stdout), daemon=True),
    ]
    for reader in readers:
        reader.start()
    try:
        deadline = time.monotonic() + 120.0
        while not (
            _size(rrd) > 0  # rerun's header: not the option check's probe
            and (mark is None or any(mark in line for line in err))
        ):
            assert proc.poll() is None, f"run {i} ended before {phase}: {''.join(err)}"
            assert time.monotonic() < deadline, f"run {i} never reached {phase}"
            time.sleep(0.005)
        time.sleep(delay)
        running = proc.poll() is None
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=EXIT_TIMEOUT)
        latency = time.monotonic() - sent
        for reader in readers:
            reader.join(timeout=EXIT_TIMEOUT)
    except BaseException:
        proc.kill()
        proc.wait()
        raise
    return {
        "i": i,
        "phase": phase,
        "delay": delay,
        "running": running,
        "code": proc.returncode,
        "latency": latency,
        "stdout": "".join(out),
        "stderr": "".join(err),
        "verify": verify(rrd),
    }


@pytest.mark.process
def test_sigint_stops_every_recorded_run_and_leaves_a_valid_recording(tmp_path):
    phases = [list(PHASES)[i % len(PHASES)] for i in range(ROUNDS)]
    with ThreadPoolExecutor(max_workers=PARALLEL) as pool:
        runs = list(
            pool.map(lambda i: _interrupt_one_run(i, phases[i], 2024 + i, tmp_path), range(ROUNDS))
        )
    for r in runs:
        detail = (
            f"run {r['i']} (exit {r['code']}, SIGINT {r['delay']:.2f} s into the {r['phase']}): "
        )
        detail += r["stderr"][-2000:]
        assert r["running"], f"{detail}\nthe run had already ended: shorten PHASES' delays"
        assert r["code"] == 130, detail  # stopped by the interrupt, not finished
        assert "pik-mj: interrupted" in r["stderr"], detail
        assert "Traceback" not in r["stderr"], detail
        assert r["verify"].returncode == 0, f"{detail}\n{r['verify'].stderr}"
    latencies = [r["latency"] for r in runs]
    landed = [
        "hold"
        if PHASES["hold"][0] in r["stderr"]
        else "solve"
        if "iteration " in r["stderr"]
        else "set-up"
        for r in runs
    ]
    print(
        f"{ROUNDS} SIGINTs (landed in: {', '.join(f'{landed.count(p)} {p}' for p in PHASES)}): "
        f"all stopped (exit 130), all recordings verified; from SIGINT to exit: median "
        f"{np.median(latencies):.2f} s, max {max(latencies):.2f} s"
    )
