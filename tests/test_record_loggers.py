"""The solve and hold loggers of pik_mj.record, with real solves and real physics.

Two full-body solves of the sample humanoid are recorded through
``Recorder.solve_logger`` (the second with the scene's per-iteration static
check) and read back: the logged errors are the solve loop's TaskReports, the
logged CoM is the robot's at every iteration, the ``iteration`` timeline counts
over both solves (start pose, iterations, final pose), the logged static
checks are the StaticReports. A hold logger is fed samples of MuJoCo stepping
the robot on a floor. The blueprint sent at close covers both solves' levels,
the balance series and the hold.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pytest
import rerun as rr

from pik_mj.exceptions import InvalidInput
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.record import PATHS, Recorder, read_recording
from pik_mj.record.loggers import margin_outline
from pik_mj.robot import Robot
from pik_mj.sim import Scene

SCALAR = "Scalars:scalars"
POINTS = "Points3D:positions"
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def _verify(path: Path) -> subprocess.CompletedProcess[str]:
    rerun = Path(sys.executable).parent / "rerun"
    return subprocess.run(
        [str(rerun), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60
    )


class Capture:
    """Keeps what each iteration reported, independently of the logger."""

    def __init__(self, robot: Robot):
        self.robot = robot
        self.errors: list[dict[tuple[int, str], float]] = []
        self.com: list[np.ndarray] = []

    def __call__(self, info) -> None:
        self.errors.append({(r.level, r.name): r.error for r in info.tasks})
        self.com.append(self.robot.com())


def _reach(robot: Robot, offset, callback):
    target = robot.root_pose()[0] + np.asarray(offset)
    return fullbody_inverse_kinematics(
        robot, [(target, IDENTITY)], limbs=["larm"], rotation_axis=[None], callback=callback
    )


def _chain(*callbacks):
    def call(info) -> None:
        for c in callbacks:
            c(info)

    return call


@dataclass
class Sample:
    """A hold sample (the fields ``scene.hold`` passes its callback)."""

    time: float
    model: mujoco.MjModel
    data: mujoco.MjData
    com: np.ndarray
    support_polygon: np.ndarray
    margin: float
    drift: float
    slip: float
    contact_points: np.ndarray
    contact_forces: np.ndarray


def _physics_samples(scene: Scene, q: np.ndarray, n: int):
    """``n`` samples of the robot standing in ``q`` on the scene's floor, one
    every 5 physics steps: contact forces on the robot from ``mj_contactForce``."""
    m, d = scene.model, scene.data
    scene.set_pose(q)
    root = m.body(scene.root_body).id
    robot_geom = np.asarray(m.body_rootid)[m.geom_bodyid] == root
    p0 = d.xpos[root].copy()
    f6 = np.zeros(6)
    for _ in range(n):
        for _ in range(5):
            mujoco.mj_step(m, d)
        points, forces = [], []
        for i in range(d.ncon):
            c = d.contact[i]
            if robot_geom[c.geom1] == robot_geom[c.geom2]:
                continue
            mujoco.mj_contactForce(m, d, i, f6)
            f_W = np.asarray(c.frame).reshape(3, 3).T @ f6[:3]
            points.append(c.pos.copy())
            forces.append(f_W if robot_geom[c.geom2] else -f_W)
        points = np.array(points).reshape(-1, 3)
        yield Sample(
            time=float(d.time),
            model=m,
            data=d,
            com=d.subtree_com[root].copy(),
            support_polygon=points[:3] if len(points) >= 3 else np.zeros((0, 3)),
            margin=0.01 * d.time,
            drift=float(np.linalg.norm(d.xpos[root] - p0)),
            slip=0.001 * d.time,
            contact_points=points,
            contact_forces=np.array(forces).reshape(-1, 3),
        )


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Two recorded solves and a recorded hold in one file, and what they returned."""
    path = tmp_path_factory.mktemp("loggers") / "two_solves.rrd"
    robot = Robot.load("sample_humanoid")
    scene = Scene("sample_humanoid")
    out = {"path": path, "robot": robot}
    with Recorder.to_file(path, "test_loggers") as rec:
        rec.log_model_geometry(robot.model, robot_root_body=robot.root_body)
        out["com0"] = robot.com()
        first = Capture(robot)
        log = rec.solve_logger("reach", start=robot)
        out["first"] = log.finish(_reach(robot, [0.4, 0.1, -0.6], _chain(first, log)))
        out["first_capture"], out["com1"] = first, robot.com()
        checks = scene.iteration_callback()
        second = Capture(robot)
        log = rec.solve_logger("reach again", checks=checks)
        out["second"] = log.finish(_reach(robot, [0.3, 0.3, -0.3], _chain(checks, second, log)))
        out["second_capture"], out["checks"], out["com2"] = second, checks, robot.com()
        hold = rec.hold_logger(every=4)
        out["samples"] = []
        for s in _physics_samples(scene, out["second"].q, 30):
            out["samples"].append((s.time, s.drift, s.com, s.contact_forces[:, 2].sum()))
            hold(s)
        hold.finish()
        out["logged"] = rec.logged()
    out["rec"] = read_recording(path)
    return out


def test_errors_are_the_task_reports_over_both_solves(recorded):
    rec, res1, res2 = recorded["rec"], recorded["first"], recorded["second"]
    n1, n2 = res1.iterations, res2.iterations
    assert res1.converged and res2.converged and n1 > 3 and n2 > 3
    # solve 1: start pose 0, iterations 1..n1, final pose n1 + 1 = start of solve 2
    ticks = {1: list(range(1, n1 + 1)), 2: list(range(n1 + 2, n1 + 2 + n2))}
    for solve, capture in ((1, recorded["first_capture"]), (2, recorded["second_capture"])):
        for key in capture.errors[0]:
            times, values = rec[PATHS.task_error(*key)].series(SCALAR, "iteration")
            mine = [(t, v[0]) for t, v in zip(times, values, strict=True) if t in ticks[solve]]
            assert [t for t, _ in mine] == ticks[solve]
            assert [v for _, v in mine] == [e[key] for e in capture.errors]
    final = {(t.level, t.name): t.error for t in res2.tasks}
    last = {k: rec[PATHS.task_error(*k)].series(SCALAR, "iteration")[1][-1][0] for k in final}
    assert last == final


def test_com_is_the_robots_at_every_tick(recorded):
    rec, n1 = recorded["rec"], recorded["first"].iterations
    times, values = rec[PATHS.com].series(POINTS, "iteration")
    com = dict(zip(times.tolist(), np.array([v[0] for v in values]), strict=True))
    n2 = recorded["second"].iterations
    # start pose, iterations, final pose (= start of the next solve), iterations, final
    assert sorted(com) == list(range(0, n1 + n2 + 3))
    expected = {0: recorded["com0"], n1 + 1: recorded["com1"], n1 + n2 + 2: recorded["com2"]}
    expected |= {k + 1: c for k, c in enumerate(recorded["first_capture"].com)}
    expected |= {n1 + 2 + k: c for k, c in enumerate(recorded["second_capture"].com)}
    for t, c in expected.items():
        np.testing.assert_allclose(com[t], c, atol=1e-6)  # float32 positions
    # the robot moved: the logged CoM is not one point
    assert np.ptp(np.array(list(com.values())), axis=0).max() > 0.01


def test_targets_show_from_the_start_and_frames_follow(recorded):
    rec, robot = recorded["rec"], recorded["robot"]
    name = "target:larm_end"
    times, targets = rec[PATHS.task_target(name)].series("Transform3D:translation", "iteration")
    assert times[0] == 0  # shown at the start pose, before the first iteration
    n1 = recorded["first"].iterations
    # fixed targets are logged when they change: once per solve
    assert times.tolist() == [0, n1 + 1]
    times, current = rec[PATHS.task_current(name)].series("Transform3D:translation", "iteration")
    assert len(times) == n1 + recorded["second"].iterations
    # at convergence the hand is on the target (thre 1 mm)
    assert np.linalg.norm(np.subtract(current[n1 - 1][0], targets[0][0])) < 1e-3
    end = robot.frame_pose("larm_end", "site").translation()
    np.testing.assert_allclose(current[-1][0], end, atol=1e-5)


def test_static_checks_are_the_reports(recorded):
    rec, reports = recorded["rec"], recorded["checks"].reports
    n1, n2 = recorded["first"].iterations, recorded["second"].iterations
    assert len(reports) == n2
    times, feasible = rec[PATHS.balance_metric("feasible")].series(SCALAR, "iteration")
    assert times.tolist() == list(range(n1 + 2, n1 + 2 + n2))
    assert [v[0] for v in feasible] == [float(r.feasible) for r in reports]
    _, margins = rec[PATHS.balance_metric("margin")].series(SCALAR, "iteration")
    assert [v[0] for v in margins] == [r.margin for r in reports]
    _, contacts = rec[PATHS.balance_metric("contacts")].series(SCALAR, "iteration")
    assert [v[0] for v in contacts] == [len(r.environment_contacts) for r in reports]
    # the last polygon and margin outline are the last report's
    last = reports[-1]
    times, strips = rec[PATHS.support_polygon].series("LineStrips3D:strips", "iteration")
    loop = np.array(strips[-1][0])
    np.testing.assert_allclose(loop[:-1], last.support_polygon, atol=1e-6)
    np.testing.assert_allclose(loop[-1], loop[0])
    _, outline = rec[f"{PATHS.support_polygon}/margin"].series("LineStrips3D:strips", "iteration")
    np.testing.assert_allclose(
        np.array(outline[-1][0])[:-1], margin_outline(last.support_polygon, last.margin), atol=1e-6
    )
    _, forces = rec[PATHS.contact_forces].series("Arrows3D:vectors", "iteration")
    np.testing.assert_allclose(np.array(forces[-1]), 1e-3 * last.forces, atol=1e-6)


def test_margin_outline_is_at_the_margin_from_every_edge():
    square = np.array([[0, 0, 0.1], [1, 0, 0.1], [1, 1, 0.1], [0, 1, 0.1]], dtype=float)
    inner = margin_outline(square, 0.2)
    np.testing.assert_allclose(
        inner, [[0.2, 0.2, 0.1], [0.8, 0.2, 0.1], [0.8, 0.8, 0.1], [0.2, 0.8, 0.1]]
    )
    assert margin_outline(square, 0.6).shape == (0, 3)  # shrunk past its centre


def test_events_tell_the_outcome(recorded):
    texts = [b[0] for _, b in recorded["rec"][PATHS.events].temporal["TextLog:text"]]
    n1, n2 = recorded["first"].iterations, recorded["second"].iterations
    assert "solve 'reach' starts" in texts
    assert f"solve 'reach': converged after {n1} iterations" in texts
    assert f"solve 'reach again': converged after {n2} iterations" in texts
    assert "physics hold starts" in texts


def test_hold_is_on_sim_time_every_nth_sample(recorded):
    rec, samples = recorded["rec"], recorded["samples"]
    kept = samples[::4] + ([samples[-1]] if (len(samples) - 1) % 4 else [])
    times, drift = rec[PATHS.hold_metric("drift")].series(SCALAR, "sim_time")
    np.testing.assert_allclose(times, [s[0] for s in kept], atol=1e-9)
    assert [v[0] for v in drift] == [s[1] for s in kept]
    assert max(s[1] for s in kept) > 0  # the physics moved the robot
    _, fz = rec[PATHS.hold_metric("contact_force_z")].series(SCALAR, "sim_time")
    assert [v[0] for v in fz] == pytest.approx([s[3] for s in kept])
    # the robot stands: the floor carries about its weight
    weight = -recorded["robot"].model.opt.gravity[2] * recorded["robot"].mass
    assert fz[-1][0] == pytest.approx(weight, rel=0.2)
    # hold rows are not on the iteration timeline; the body poses are on sim_time
    assert all("iteration" not in t for t, _ in rec[PATHS.hold_metric("drift")].temporal[SCALAR])
    pose_t, _ = rec[PATHS.bodies()].series("Ellipsoids3D:centers", "sim_time")
    np.testing.assert_allclose(pose_t, [s[0] for s in kept], atol=1e-9)
    _, com = rec[PATHS.com].series(POINTS, "sim_time")
    np.testing.assert_allclose(com[-1][0], kept[-1][2], atol=1e-6)
    # the scene's floor was logged with the scene's model
    assert "floor" in rec[PATHS.geoms("boxes", robot=False, moving=False)].static["Boxes3D:labels"]


def test_blueprint_covers_every_solve_and_the_hold(recorded):
    levels = {t.level for r in (recorded["first"], recorded["second"]) for t in r.tasks} - {0}
    logged = recorded["logged"]
    assert {PATHS.level_errors(k) for k in levels} <= {p.rsplit("/", 1)[0] for p in logged}
    assert logged[PATHS.hold_metric("drift")] == {"sim_time"}
    assert logged[PATHS.balance_metric("margin")] == {"iteration"}
    bp = read_recording(recorded["path"], blueprint=True)
    origins = {
        e.temporal["ViewBlueprint:space_origin"][-1][1][0]
        for e in bp.values()
        if "ViewBlueprint:space_origin" in e.temporal
    }
    assert {PATHS.level_errors(k) for k in levels} | {PATHS.balance, PATHS.hold} <= origins
    assert _verify(recorded["path"]).returncode == 0


def test_a_solve_recorded_on_its_own_stream(tmp_path):
    """The public hook: a user's own stream (here from rr.script_setup with
    --save), no geometry logged beforehand."""
    parser = argparse.ArgumentParser()
    rr.script_add_args(parser)
    args = parser.parse_args(["--save", str(tmp_path / "mine.rrd")])
    stream = rr.script_setup(args, "my_solve")
    robot = Robot.load("sample_humanoid")
    with Recorder(stream) as rec:
        log = rec.solve_logger("mine")
        result = log.finish(_reach(robot, [0.3, 0.2, -0.4], log))
    rr.script_teardown(args)
    stream.disconnect()  # what the end of the script's process does
    assert rec.robot_root_body == robot.root_body  # found from the model
    data = read_recording(tmp_path / "mine.rrd")
    times, _ = data[PATHS.com].series(POINTS, "iteration")
    assert times.tolist() == list(range(1, result.iterations + 2))
    assert "pelvis" in data[PATHS.bodies()].static["Ellipsoids3D:labels"]


def _sent_before_close(tmp_path: Path, flush_interval: float | None) -> dict:
    """What a viewer connected to the stream has received after four rows,
    10 ms apart, before the Recorder is closed."""
    stream = rr.RecordingStream("live", recording_id="live")
    memory = stream.memory_recording()
    rec = Recorder(stream, flush_interval=flush_interval)
    for k in range(4):
        rec.set_time("iteration", k)
        time.sleep(0.01)
        rec.log_scalar("x", float(k))
    stream.flush()
    path = tmp_path / f"live_{flush_interval}.rrd"
    path.write_bytes(memory.drain_as_bytes())
    rec.close()
    memory.drain_as_bytes()
    return read_recording(path)


def test_rows_reach_a_live_viewer_before_close(tmp_path):
    """With a flush interval (the default of Recorder(stream)), buffered rows
    are sent while the run goes on; by count only, they wait for the close."""
    live = _sent_before_close(tmp_path, 0.005)
    assert live["x"].series(SCALAR, "iteration")[0].tolist() == [0, 1, 2, 3]
    assert "x" not in _sent_before_close(tmp_path, None)


def test_bad_logger_input():
    rec = Recorder(rr.RecordingStream("bad", recording_id="bad"))
    with pytest.raises(InvalidInput, match="every must be an integer >= 1"):
        rec.hold_logger(every=0)
    with pytest.raises(InvalidInput, match=r"checks must have a \.reports list"):
        rec.solve_logger("x", checks=object())
    with pytest.raises(InvalidInput, match="start must be an MjData"):
        rec.solve_logger("x", start=3)
    with pytest.raises(InvalidInput, match="flush_interval must be > 0"):
        Recorder(rec.stream, flush_interval=0.0)
    rec.close()
