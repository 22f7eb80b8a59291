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
from pathlib import Path

import numpy as np
import pytest
import rerun as rr

from pik_mj.exceptions import InvalidInput
from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.record import PATHS, Recorder, read_blueprint, read_recording
from pik_mj.record.loggers import margin_outline
from pik_mj.record.style import FORCE_PER_WEIGHT
from pik_mj.robot import Robot
from pik_mj.sim import Scene
from pik_mj.walking import GaitParameters, straight_steps
from pik_mj.walking.playback import WALK_CONTACT, play_walk_pattern
from pik_mj.walking.wholebody import calc_walk_pattern, feet_from_robot

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


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Two recorded solves and a recorded hold in one file, and what they returned."""
    path = tmp_path_factory.mktemp("loggers") / "two_solves.rrd"
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    out = {"path": path, "robot": robot}
    with Recorder.to_file(path, "test_loggers") as rec:
        rec.log_model_geometry(robot.model, robot_root_body=robot.root_body)
        out["force_scale"], out["height"] = rec.force_scale, rec.measures.height
        out["lift"] = rec.lift
        out["com0"] = robot.com()
        first = Capture(robot)
        log = rec.solve_logger("reach", start=robot)
        out["first"] = log.finish(_reach(robot, [0.4, 0.1, -0.6], [first, log]))
        out["first_capture"], out["com1"] = first, robot.com()
        checks = scene.static_checker()
        second = Capture(robot)
        log = rec.solve_logger("reach again", checks=checks)
        out["second"] = log.finish(_reach(robot, [0.3, 0.3, -0.3], [checks, second, log]))
        out["second_capture"], out["checks"], out["com2"] = second, checks, robot.com()
        hold = rec.hold_logger(every=4)
        out["samples"] = []

        def sample(s) -> None:  # what the logger saw, while the sample is valid
            out["samples"].append((s.time, s.drift, s.com, s.contact_forces[:, 2].sum()))
            hold(s)

        scene.hold(out["second"].q, 0.3, callback=sample, every=5)
        hold.finish()
        out["logged"] = rec.logged()
        out["force_scale_end"] = rec.force_scale
    out["rec"] = read_recording(path)
    return out


def test_errors_are_the_task_reports_over_both_solves(recorded):
    rec, res1, res2 = recorded["rec"], recorded["first"], recorded["second"]
    n1, n2 = res1.iterations, res2.iterations
    assert res1.converged and res2.converged and n1 > 3 and n2 > 3
    # solve 1: start pose 0, iterations 1..n1, final pose n1 + 1 = start of solve 2
    ticks = {1: list(range(1, n1 + 1)), 2: list(range(n1 + 2, n1 + 2 + n2))}
    # each solve's series apart (its label in the path and the legend's name),
    # in a colour of its own in its level's plot (its log10 series alike)
    colors: dict[int, list] = {}
    for solve, label, capture in (
        (1, "reach", recorded["first_capture"]),
        (2, "reach again", recorded["second_capture"]),
    ):
        for key in capture.errors[0]:
            shown = []
            for log10 in (False, True) if key[0] else (False,):
                series = rec[PATHS.task_error(*key, log10=log10, solve=label)]
                assert series.static["SeriesLines:names"] == [f"{label}: {key[1]}"]
                shown.append(series.static["SeriesLines:colors"])
            assert all(c == shown[0] for c in shown)
            colors.setdefault(key[0], []).append(shown[0])
            times, values = rec[PATHS.task_error(*key, solve=label)].series(SCALAR, "iteration")
            assert times.tolist() == ticks[solve]
            assert [v[0] for v in values] == [e[key] for e in capture.errors]
    assert all(len({str(c) for c in level}) == len(level) for level in colors.values())
    assert max(len(level) for level in colors.values()) > 1
    final = {(t.level, t.name): t.error for t in res2.tasks}
    last = {
        k: rec[PATHS.task_error(*k, solve="reach again")].series(SCALAR, "iteration")[1][-1][0]
        for k in final
    }
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
    # from the start pose (given to the first solve) on; the second solve had none
    assert times[0] == 0 and len(times) == 1 + n1 + recorded["second"].iterations
    _, lengths = rec[PATHS.task_current(name)].series("TransformAxes3D:axis_length", "iteration")
    assert lengths[n1 + 1] == [0.0]  # hidden at the second solve's start count
    current = current[1:]
    # at convergence the hand is on the target (thre 1 mm)
    assert np.linalg.norm(np.subtract(current[n1 - 1][0], targets[0][0])) < 1e-3
    end = robot.frame_pose("larm_end", "site").translation()
    np.testing.assert_allclose(current[-1][0], end, atol=1e-5)
    # the labelled marker sits at the target frame's origin, on its entity; the CoM
    # target shows from the start too
    times, points = rec[PATHS.task_target(name)].series(POINTS, "iteration")
    assert times.tolist() == [0, n1 + 1] and points == [[[0.0, 0.0, 0.0]]] * 2
    _, labels = rec[PATHS.task_target(name)].series("Points3D:labels", "iteration")
    assert labels[0] == [name]
    times, _ = rec[PATHS.com_target].series(POINTS, "iteration")
    assert times[0] == 0
    # and they stay on screen during the hold (sim_time), at its first sample
    t0 = recorded["samples"][0][0]
    for path, component in (
        (PATHS.task_target(name), "Transform3D:translation"),
        (PATHS.com_target, POINTS),
    ):
        times, _ = rec[path].series(component, "sim_time")
        assert times.tolist() == pytest.approx([t0])


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
    # named, and the two series of one plot in colours apart
    styles = {
        name: (
            rec[PATHS.balance_metric(name)].static["SeriesLines:names"],
            str(rec[PATHS.balance_metric(name)].static["SeriesLines:colors"]),
        )
        for name in ("margin", "contacts", "feasible")
    }
    assert styles["contacts"][0] == ["contacts"]
    assert styles["feasible"][0] == ["equilibrium (1 = yes)"]
    assert styles["contacts"][1] != styles["feasible"][1]
    # the last polygon and margin outline are the last report's
    last = reports[-1]
    times, strips = rec[PATHS.support_polygon].series("LineStrips3D:strips", "iteration")
    loop = np.array(strips[-1][0])
    up = np.array([0.0, 0.0, recorded["lift"]])  # drawn above the soles
    assert recorded["lift"] > 0.07  # the sample humanoid's soles are 7 cm thick
    lifted = last.support_polygon + up
    np.testing.assert_allclose(loop[:-1], lifted, atol=1e-6)
    np.testing.assert_allclose(loop[-1], loop[0])
    _, outline = rec[f"{PATHS.support_polygon}/margin"].series("LineStrips3D:strips", "iteration")
    expected = margin_outline(last.support_polygon, last.margin) + up
    np.testing.assert_allclose(np.array(outline[-1][0])[:-1], expected, atol=1e-6)
    # forces drawn at the robot's scale: its weight as FORCE_PER_WEIGHT of its height
    _, forces = rec[PATHS.contact_forces].series("Arrows3D:vectors", "iteration")
    robot = recorded["robot"]
    weight = -robot.model.opt.gravity[2] * robot.mass
    assert recorded["force_scale"] == pytest.approx(FORCE_PER_WEIGHT * recorded["height"] / weight)
    np.testing.assert_allclose(
        np.array(forces[-1]), recorded["force_scale"] * last.forces, atol=1e-6
    )
    assert 1.2 < recorded["height"] < 1.8  # the sample humanoid, soles to head [m]
    assert recorded["force_scale_end"] == recorded["force_scale"]  # the hold's scene too


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
    # the solve's current task frames do not follow the physics: no axes in the hold
    current = rec[PATHS.task_current("target:larm_end")]
    times, lengths = current.series("TransformAxes3D:axis_length", "sim_time")
    assert times.tolist() == pytest.approx([samples[0][0]]) and lengths == [[0.0]]
    # the scene's floor was logged with the scene's model
    assert "floor" in rec[PATHS.geoms("boxes", robot=False, moving=False)].static["Boxes3D:labels"]


def test_blueprint_covers_every_solve_and_the_hold(recorded):
    levels = {t.level for r in (recorded["first"], recorded["second"]) for t in r.tasks} - {0}
    logged = recorded["logged"]
    parents = {p.rsplit("/", 2)[0] for p in logged}  # errors/level_<k>(/<solve>/<task>)
    assert {PATHS.level_errors(k) for k in levels} <= parents
    assert logged[PATHS.hold_metric("drift")] == {"sim_time"}
    assert logged[PATHS.balance_metric("margin")] == {"iteration"}
    bp = read_recording(recorded["path"], blueprint=True)
    origins = {
        e.temporal["ViewBlueprint:space_origin"][-1][1][0]
        for e in bp.values()
        if "ViewBlueprint:space_origin" in e.temporal
    }
    plots = {PATHS.level_errors(k, log10=True) for k in levels}
    assert plots | {PATHS.balance, PATHS.hold, PATHS.world, PATHS.events} == origins
    assert _verify(recorded["path"]).returncode == 0


def test_a_solve_recorded_on_its_own_stream(tmp_path):
    """The public hook: a user's own stream (here from rr.script_setup with
    --save), no geometry logged beforehand."""
    parser = argparse.ArgumentParser()
    rr.script_add_args(parser)
    args = parser.parse_args(["--save", str(tmp_path / "mine.rrd")])
    stream = rr.script_setup(args, "my_solve")
    robot = Robot.from_model("sample_humanoid")
    with Recorder(stream) as rec:
        log = rec.solve_logger("mine")
        result = log.finish(_reach(robot, [0.3, 0.2, -0.4], log))
    rr.script_teardown(args)
    stream.disconnect()  # what the end of the script's process does
    rr.set_global_data_recording(None)  # script_setup made it the global one
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


# ---------------------------------------------------------------------------
# The blueprint a person opens (issue 16)


def _robot_points(rec, timeline: str) -> np.ndarray:
    """Every logged body position of the robot on ``timeline`` (n, 3) [m]."""
    _, rows = rec[PATHS.bodies()].series("Ellipsoids3D:centers", timeline)
    return np.vstack([np.array(r) for r in rows])


def _check_framed(eye: dict, points: np.ndarray, height: float) -> None:
    """The camera looks at the robot from within a few robot heights."""
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    # it looks at the robot's middle ...
    assert np.linalg.norm(eye["look_target"][:2] - centre[:2]) < 0.25 * height
    assert points[:, 2].min() < eye["look_target"][2] < points[:, 2].max()
    # ... from within three robot heights, above the ground, never from inside it
    distance = np.linalg.norm(points - eye["position"], axis=1)
    assert 0.5 * height < distance.min() and distance.max() < 3.0 * height
    assert eye["position"][2] > 0


def _check_plots_have_data(rec, views, timeline: str) -> int:
    """Every plot shows some series with rows on ``timeline``."""
    plots = [v for v in views if v.kind == "TimeSeries"]
    for view in plots:
        shown = view.entities(rec)
        assert shown, f"plot {view.name!r} shows no logged entity"
        rows = [len(rec[e].series(SCALAR, timeline)[0]) for e in shown]
        assert max(rows) > 1, f"plot {view.name!r} has no data on {timeline}"
    return len(plots)


def test_blueprint_opens_on_the_solve(recorded):
    rec, layout = recorded["rec"], read_blueprint(recorded["path"])
    assert layout.timeline == "iteration"  # the time panel opens on the solve
    (solve, views), (hold, hold_views) = layout.tabs
    assert "iteration" in solve and "sim_time" in hold  # each tab names its timeline
    assert views[0].kind == "3D" and views[0].origin == PATHS.world
    _check_framed(views[0].eye, _robot_points(rec, "iteration"), recorded["height"])
    assert _check_plots_have_data(rec, views, "iteration") == 5  # 3 levels, 2 balance
    assert any(v.kind == "TextLog" and v.origin == PATHS.events for v in views)
    # error plots are log-scaled: they show log10 of the logged errors
    errors = [v for v in views if "error" in v.name]
    assert [v.origin for v in errors] == [PATHS.level_errors(k, log10=True) for k in (1, 2, 3)]
    key = (2, "target:larm_end")
    _, linear = rec[PATHS.task_error(*key, solve="reach")].series(SCALAR, "iteration")
    _, log10 = rec[PATHS.task_error(*key, log10=True, solve="reach")].series(SCALAR, "iteration")
    np.testing.assert_allclose([v[0] for v in log10], np.log10([v[0] for v in linear]))
    assert min(v[0] for v in log10) < -3  # converged below 1 mm: visible on this scale
    # plots grouped by unit: no plot mixes metres with counts or newtons
    names = {v.name: v.entities(rec) for v in views + hold_views if v.kind == "TimeSeries"}
    assert names["static check: CoM margin to the support polygon [m]"] == ["balance/margin"]
    assert names["hold: vertical contact force [N]"] == ["hold/contact_force_z"]
    _check_framed(hold_views[0].eye, _robot_points(rec, "sim_time"), recorded["height"])
    assert _check_plots_have_data(rec, hold_views, "sim_time") == 2


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    """A step of the sample humanoid (and the closing one), played in physics
    into a recording (coarse ticks: the whole-body IK per tick is the cost)."""
    path = tmp_path_factory.mktemp("walk") / "walk.rrd"
    robot = Robot.from_model("sample_humanoid")
    steps = straight_steps(1, 0.1, feet_from_robot(robot), first_limb="lleg")
    pattern = calc_walk_pattern(robot, steps, GaitParameters(dt=0.05, step_time=0.8))
    scene = Scene.from_robot(robot, contact=WALK_CONTACT)
    with Recorder.to_file(path, "test_walk") as rec:
        log = rec.walk_logger()
        report = log.finish(play_walk_pattern(pattern, scene, callback=log, settle_time=0.3))
        lift = rec.lift
    return {"path": path, "pattern": pattern, "report": report, "lift": lift, "robot": robot}


def test_walk_series_are_the_pattern_and_the_playback(walked):
    rec = read_recording(walked["path"])
    pattern, report = walked["pattern"], walked["report"]
    assert not report.fell
    for name, zmp in (
        ("zmp_reference", pattern.zmp_ref),
        ("zmp_inverse_dynamics", pattern.zmp_computed),
    ):
        for i, axis in enumerate("xy"):
            times, values = rec[PATHS.walk_series(axis, name)].series(SCALAR, "sim_time")
            np.testing.assert_allclose(times, pattern.t, atol=1e-9)
            assert [v[0] for v in values] == zmp[:, i].tolist()
    times, margin = rec[PATHS.walk_series("margin", "zmp_inverse_dynamics")].series(
        SCALAR, "sim_time"
    )
    assert [v[0] for v in margin] == pattern.support_margin("computed").tolist()
    seen = np.all(np.isfinite(report.zmp), axis=1)
    times, measured = rec[PATHS.walk_series("x", "zmp_measured")].series(SCALAR, "sim_time")
    np.testing.assert_allclose(times, report.t[seen], atol=1e-9)
    assert [v[0] for v in measured] == report.zmp[seen, 0].tolist()
    _, com = rec[PATHS.walk_series("y", "com")].series(SCALAR, "sim_time")
    assert [v[0] for v in com] == report.com[:, 1].tolist()
    # the footstep plan: the stance, then one outline per footstep
    strips = rec[PATHS.footsteps].static["LineStrips3D:strips"]
    assert len(strips) == len(pattern.plan.initial_feet) + len(pattern.plan.footsteps)


def _inside(polygon: np.ndarray, p: np.ndarray) -> float:
    """Signed distance of ``p`` (2,) to the convex counter-clockwise ``polygon``
    (m, 2): the smallest distance to an edge's line, positive inside."""
    d = []
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        t = (b - a) / np.linalg.norm(b - a)
        d.append(t[0] * (p[1] - a[1]) - t[1] * (p[0] - a[0]))
    return min(d)


def test_walk_shows_the_zmp_inside_the_support_polygon(walked):
    rec, pattern, lift = read_recording(walked["path"]), walked["pattern"], walked["lift"]
    poly_t, polygons = rec[PATHS.support_polygon].series("LineStrips3D:strips", "sim_time")
    assert 3 <= len(poly_t) < len(pattern.t) // 5  # logged when the support changes
    zmp_t, zmp = rec[f"{PATHS.zmp}/inverse_dynamics"].series(POINTS, "sim_time")
    _, margin = rec[PATHS.walk_series("margin", "zmp_inverse_dynamics")].series(SCALAR, "sim_time")
    single = np.flatnonzero(pattern.plan.support != "double")
    for k in (single[len(single) // 4], single[3 * len(single) // 4], 0):
        at = np.flatnonzero(poly_t <= zmp_t[k])[-1]
        loop = np.array(polygons[at][0])
        # drawn above the soles, the ZMP at the same height
        assert loop[:, 2] == pytest.approx(pattern.plan.ground_z + lift)
        assert zmp[k][0][2] == pytest.approx(pattern.plan.ground_z + lift)
        assert lift > 0.05  # above the sample humanoid's 7 cm soles
        d = _inside(loop[:-1, :2], np.array(zmp[k][0][:2]))
        assert d == pytest.approx(margin[k][0], abs=1e-5) and d > 0.01


def test_walk_blueprint_opens_on_the_walk(walked):
    rec, layout = read_recording(walked["path"]), read_blueprint(walked["path"])
    assert layout.timeline == "sim_time"
    ((name, views),) = layout.tabs
    assert name.startswith("walking")
    height = walked["robot"].model.stat.extent  # a robot height's order [m]
    assert views[0].kind == "3D"
    _check_framed(views[0].eye, _robot_points(rec, "sim_time"), max(height, 1.0))
    assert _check_plots_have_data(rec, views, "sim_time") == 3
    origins = {v.origin for v in views}
    assert {f"{PATHS.walk}/x", f"{PATHS.walk}/y", f"{PATHS.walk}/margin"} <= origins


@pytest.fixture(scope="session")
def renders() -> None:
    """Skip, saying why and what to install, where rerun's headless viewer cannot
    render (it needs Vulkan: a GPU, or Mesa's lavapipe); decided once."""
    from pik_mj.record import screenshot

    problem = screenshot.viewer_problem()
    if problem is not None:
        pytest.skip(f"rerun's headless viewer cannot render here: {problem}")


def test_viewer_problem_says_what_to_install_without_a_vulkan_driver(monkeypatch):
    """With the Vulkan driver hidden the viewer stops (exit 102), and the probe
    says so and names the packages that bring a driver; the answer is cached."""
    from pik_mj.record import screenshot

    monkeypatch.setenv("VK_ICD_FILENAMES", "/nonexistent/icd.json")
    monkeypatch.delenv("VK_DRIVER_FILES", raising=False)
    screenshot.viewer_problem.cache_clear()
    try:
        problem = screenshot.viewer_problem()
        assert screenshot.viewer_problem() is problem  # once per process
    finally:
        screenshot.viewer_problem.cache_clear()
    if problem is None:
        pytest.skip("the viewer rendered without Vulkan (a GPU's OpenGL driver)")
    assert "headless rerun viewer exited (102)" in problem
    assert "Failed to get render context" in problem
    assert "apt-get install mesa-vulkan-drivers libvulkan1" in problem
    assert screenshot.vulkan_hint() in problem


def test_screenshot_command_says_what_to_install(recorded, tmp_path, monkeypatch, capsys):
    """``pik-mj screenshot`` without a Vulkan driver: one error line saying why,
    with the packages to install (beside the line saying where the viewer
    listened), exit 2, no picture."""
    from pik_mj.cli import main

    monkeypatch.setenv("VK_ICD_FILENAMES", "/nonexistent/icd.json")
    out = tmp_path / "shot.png"
    code = main(["screenshot", str(recorded["path"]), "--out", str(out)])
    err = capsys.readouterr().err
    if code == 0:
        pytest.skip("the viewer rendered without Vulkan (a GPU's OpenGL driver)")
    assert code == 2 and not out.exists()
    assert "Failed to get render context" in err and "apt-get install mesa-vulkan-drivers" in err
    errors = [line for line in err.splitlines() if line.startswith("pik-mj: error:")]
    assert len(errors) == 1 and "apt-get install" in errors[0]


def test_screenshot_shows_the_zmp_inside_the_polygon(renders, walked, tmp_path):
    """rerun's headless viewer renders the walk's 3D view: the cyan support
    polygon and the ZMP markers inside it are on the picture."""
    from PIL import Image

    from pik_mj.record import screenshot, style

    pattern = walked["pattern"]
    # mid-way through the double support after the step: the ZMP between the
    # soles, where neither hides it
    double = pattern.plan.support == "double"
    starts = np.flatnonzero(double[1:] & ~double[:-1]) + 1
    ends = np.flatnonzero(~double[starts[0] :])[0] + starts[0]
    t = float(pattern.t[(starts[0] + ends) // 2])
    shot = screenshot.Shot(tmp_path / "walk.png", "sim_time", t, view="walking")
    (png,) = screenshot.screenshots(walked["path"], [shot], size=(800, 600))
    image = np.asarray(Image.open(png).convert("RGB")).astype(int)
    assert image.shape == (600, 800, 3)

    def pixels(color) -> np.ndarray:
        ys, xs = np.nonzero(np.abs(image - np.array(color)).sum(axis=2) < 60)
        return np.column_stack([xs, ys])

    polygon = pixels(style.SUPPORT_POLYGON)
    zmp = np.vstack(
        [pixels(c) for c in (style.ZMP, style.ZMP_REFERENCE, style.ZMP_INVERSE_DYNAMICS)]
    )
    assert len(polygon) > 50 and len(zmp) > 10  # both visible, not hidden by the soles
    centre = zmp.mean(axis=0)
    assert (polygon.min(axis=0) < centre).all() and (centre < polygon.max(axis=0)).all()


def test_screenshot_tabs_are_chosen_by_name(renders, recorded, walked):
    """``--tab`` switches a layout of several tabs, accepts the only tab of a
    layout of one (which has no tab container), and names the tabs there are
    when none matches."""
    from pik_mj.record import screenshot

    with screenshot.headless_viewer((800, 600)) as client:
        screenshot._open(client, recorded["path"])
        screenshot._arrange(client, "physics", None, panels=True)
        containers = screenshot._containers(client.get_blueprint(of="recording").blueprint)
        (tabs,) = [c for c in containers.values() if c.get("container_kind") == "Tabs"]
        assert containers[tabs["active_tab"]]["display_name"].startswith("physics hold")
        with pytest.raises(InvalidInput, match=r"no tab named 'walk'; there are \['physics hold"):
            screenshot._arrange(client, "walk", None, panels=True)

        screenshot._open(client, walked["path"])
        screenshot._arrange(client, "walking", None, panels=True)  # the only one
        only = r"no tab named 'solve'; there are \['walking \(timeline: sim_time\)'\]"
        with pytest.raises(InvalidInput, match=only):
            screenshot._arrange(client, "solve", None, panels=True)
