"""Per-iteration callbacks composed as a list, and the Progress display."""

from __future__ import annotations

import io

import numpy as np
import pytest

from pik_mj import InvalidInput, Progress, Robot, inverse_kinematics, solve
from pik_mj.tasks.frame import FrameTask

TIP_DOWN = np.array([0.0, 0.0, 1.0, 0.0])


def arm() -> Robot:
    robot = Robot.from_model("three_dof_arm")
    robot.set_angle_vector(np.deg2rad([30.0, 30.0, 30.0]))
    return robot


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_callbacks_run_in_order_with_the_same_info():
    robot = arm()
    calls: list = []

    def first(info) -> None:
        calls.append(("first", info.iteration, info.configuration.q.copy()))

    def second(info) -> None:
        calls.append(("second", info.iteration, info.configuration.q.copy()))

    result = inverse_kinematics(robot, ([0.15, 0.0, 0.0], TIP_DOWN), callback=[first, second])
    assert result.converged and result.iterations >= 2
    assert [c[0] for c in calls] == ["first", "second"] * result.iterations
    assert [c[1] for c in calls[::2]] == list(range(1, result.iterations + 1))
    for a, b in zip(calls[::2], calls[1::2], strict=True):
        np.testing.assert_array_equal(a[2], b[2])
    np.testing.assert_array_equal(calls[-1][2], result.q)


def test_a_non_callable_is_refused_before_the_first_iteration():
    robot = arm()
    q0 = robot.configuration.q.copy()
    calls: list = []
    with pytest.raises(InvalidInput, match=r"callback\[1\]"):
        inverse_kinematics(robot, ([0.15, 0.0, 0.0], TIP_DOWN), callback=[calls.append, "progress"])
    assert calls == []
    np.testing.assert_array_equal(robot.configuration.q, q0)
    task = FrameTask(robot.configuration, "end", ([0.15, 0.0, 0.0], TIP_DOWN))
    with pytest.raises(InvalidInput, match="callable"):
        solve(robot.configuration, [[], [task]], callback=42)


def test_progress_plain_lines_and_terminal_bar():
    robot = arm()
    target = ([0.15, 0.0, 0.0], TIP_DOWN)
    plain, tty = io.StringIO(), Terminal()
    a, b = Progress("reach", total=50, stream=plain), Progress("reach", total=50, stream=tty)
    result = inverse_kinematics(robot, target, callback=[a, b])
    a.finish(result)
    b.finish(result)
    n = result.iterations
    lines = plain.getvalue().splitlines()
    # a pipe: one plain line per iteration, then the outcome
    assert len(lines) == n + 1 and "\r" not in plain.getvalue()
    assert lines[0].startswith("reach [") and f"iteration {n}/50" in lines[n - 1]
    assert lines[-1] == f"reach: {n} iterations, converged"
    # a terminal: the bar redrawn in place, one line in the end
    out = tty.getvalue()
    assert out.count("\r") == n + 1 and out.count("\n") == 1
    bar = out.split("\r")[n]  # the last bar drawn
    assert bar.count("#") == round(30 * n / 50) and f"{n}/50" in bar
    assert out.endswith(f"reach: {n} iterations, converged\x1b[K\n")
    assert a.iterations == n and a.elapsed == pytest.approx(sum(result.iteration_times))
    quiet = Progress("reach", stream=None)
    quiet.finish(result)  # writes nothing, raises nothing
    with pytest.raises(InvalidInput, match="total"):
        Progress("reach", total=0)
