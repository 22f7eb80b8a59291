"""A recorder's physics loggers are called at their own rate, not every step
(:data:`pik_mj.callbacks.CALL_EVERY`): the recording read back has a row every
``every`` steps, the figures of the run are those of the run without a
logger, and a callback that needs every step still gets every step."""

from __future__ import annotations

import numpy as np

from pik_mj.callbacks import call_stride
from pik_mj.record import PATHS, Recorder, read_recording
from pik_mj.robot import Robot
from pik_mj.sim import Scene

SCALAR = "Scalars:scalars"


def test_a_hold_logger_is_called_at_its_rate_and_its_rows_read_back(tmp_path):
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    q = robot.configuration.q.copy()
    duration, every = 0.5, 25
    n_steps = round(duration / scene.model.opt.timestep)
    plain = scene.hold(q, duration)
    with Recorder.to_file(tmp_path / "hold.rrd", "test") as rec:
        rec.log_model_geometry(robot.model, robot_root_body=robot.root_body)
        log = rec.hold_logger(every=every)
        steps: list[int] = []

        def spy(sample) -> None:  # beside the logger, it declares the same rate
            steps.append(sample.step)

        spy.call_every = every
        report = log.finish(scene.hold(q, duration, callback=[log, spy]))
    # called at the start and every 25 steps: 21 calls, not 251
    assert steps == list(range(0, n_steps + 1, every))
    assert log.calls == len(steps) == n_steps // every + 1
    assert report.passed and report.drift == plain.drift and report.slip == plain.slip
    data = read_recording(tmp_path / "hold.rrd")
    t, drift = data[PATHS.hold_metric("drift")].series(SCALAR, "sim_time")
    dt = scene.model.opt.timestep
    np.testing.assert_allclose(np.diff(t), every * dt, atol=1e-9)
    assert len(t) == len(steps)
    assert drift[-1][0] == report.drift  # the last row is the run's end


def test_a_callback_that_does_not_say_gets_every_step(tmp_path):
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    with Recorder.to_file(tmp_path / "slow.rrd", "test") as rec:
        log = rec.hold_logger(every=10)
        seen: list[int] = []
        q = robot.configuration.q.copy()
        scene.hold(q, 0.1, callback=[log, lambda s: seen.append(s.step)])
    assert seen == list(range(51))  # the slow path: a call per step
    assert log.calls == 51
    t, _ = read_recording(tmp_path / "slow.rrd")[PATHS.hold_metric("drift")].series(
        SCALAR, "sim_time"
    )
    np.testing.assert_allclose(t, np.arange(0, 51, 10) * scene.model.opt.timestep, atol=1e-9)
    assert call_stride([log]) == 10 and call_stride([log, print]) == 1
    assert call_stride([log], every=4) == 4 and call_stride([]) == 1
