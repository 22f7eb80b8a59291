"""Every scenario runs green, its recording read back (issue 6), and its
simulation checked (issue 5).

Every scenario runs once, with a 3 s hold of its final pose where it has one;
its recording is read back (``pik_mj.record.read_recording``) and
compared with what the run returned: the iterations logged are the solves'
iterations, the logged errors are the SolveResult's task errors, the logged CoM
is the robot's, the logged static checks are the StaticReports, and the logged
hold is the hold's report; ``rerun rrd verify`` accepts every file, also one
whose scenario raised mid-solve. ``pik-mj validate`` reproduces a run's hold
from its JSON and fails a pose whose CoM leans past the toes.
"""

from __future__ import annotations

import inspect
import itertools
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pik_mj.scenarios
import pytest
from tmp_scenarios import add_scenario

from pik_mj import Recorder, Robot, cli
from pik_mj.record import PATHS, EntityData, read_blueprint, read_recording, style
from pik_mj.scenario import ScenarioResult

HOLD = 3.0  # [s], as pik-mj run
#: Shorter variants of the walking scenarios (2 s of walking at 50 Hz, ~2 s to run).
SHORT = {
    "walk_forward": {"n_steps": 2, "dt": 0.02},
    "walk_go_pos": {"x": 0.2, "y": 0.05, "theta_deg": 20.0, "dt": 0.02},
}
KEYS = {"name", "passed", "converged", "iterations", "tasks", "timing", "figures", "messages"}
#: Scenarios whose final pose holds in physics (the others are reported, see the
#: hold figures in the JSON: external forces not applied in the hold, kettle not
#: carried by the hand, forearm sliding on the wall).
HOLDS = {"fullbody_reach", "cocktail_shaker"}
SCALAR = "Scalars:scalars"


def _verify(path: Path) -> subprocess.CompletedProcess:
    rerun = Path(sys.executable).parent / "rerun"
    return subprocess.run(
        [str(rerun), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60
    )


#: The components without which rerun's viewer cannot draw an archetype (it marks
#: the view with an error instead): rerun 0.41's required fields.
REQUIRED = {
    "Arrows3D": {"vectors"},
    "Boxes3D": {"half_sizes"},
    "Capsules3D": {"lengths", "radii"},
    "Ellipsoids3D": {"half_sizes"},
    "Image": {"buffer", "format"},
    "LineStrips3D": {"strips"},
    "Mesh3D": {"vertex_positions"},
    "Pinhole": {"image_from_camera"},
    "Points3D": {"positions"},
    "Scalars": {"scalars"},
    "TextLog": {"text"},
}


def _check_drawable(rec: dict[str, EntityData]) -> None:
    """Every archetype logged on an entity (static or over time) has the
    components the viewer needs to draw it."""
    missing = []
    for path, entity in rec.items():
        logged: dict[str, set[str]] = {}
        for component in [*entity.static, *entity.temporal]:
            archetype, _, name = component.partition(":")
            logged.setdefault(archetype, set()).add(name)
        for archetype, names in logged.items():
            lacking = REQUIRED.get(archetype, set()) - names
            if lacking:
                missing.append(f"{path}: {archetype} without {sorted(lacking)}")
    assert not missing, missing


def _check_pinholes(rrd: Path, rec: dict[str, EntityData]) -> None:
    """No 3D view shows a pinhole without a value on its tab's timeline (the
    viewer marks the view with an error: a camera logged on ``sim_time`` only
    is left out of the solve's view)."""
    bad = []
    for tab, views in read_blueprint(rrd).tabs:
        timeline = tab.partition("(timeline: ")[2].rstrip(")")
        for view in views:
            if view.kind != "3D" or not timeline:
                continue
            for path in view.entities(rec):
                rows = [
                    t
                    for c, r in rec[path].temporal.items()
                    if c.startswith("Pinhole:")
                    for t, _ in r
                ]
                if rows and not any(timeline in t for t in rows):
                    bad.append(f"{tab}: {path}")
    assert not bad, bad


def _at(entity: EntityData, component: str, timeline: str, t: float) -> list:
    """The batch of ``component`` the viewer shows at time ``t``: the last one
    logged at or before ``t`` (fixed targets are logged only when they change)."""
    times, values = entity.series(component, timeline)
    hits = [v for s, v in zip(times, values, strict=True) if s <= t]
    assert hits, f"nothing logged at or before {timeline} = {t}"
    return hits[-1]


def _ticks(result: ScenarioResult) -> tuple[list[int], dict[str, int], int]:
    """Iteration ticks of the solves, each solve's last tick, and the last tick.

    A solve starts at the current count (start pose), logs iterations at count+1..,
    and its final pose one tick after its last iteration.
    """
    ticks: list[int] = []
    last: dict[str, int] = {}
    t = 0
    for label, s in result.solves.items():
        ticks += range(t + 1, t + s.iterations + 1)
        last[label] = t + s.iterations
        t += s.iterations + 1
    return ticks, last, t


def _check_iterations(rec: dict[str, EntityData], result: ScenarioResult) -> None:
    ticks, last, end = _ticks(result)
    assert len(ticks) == sum(s.iterations for s in result.solves.values())
    logged: set[float] = set()
    for path, entity in rec.items():
        if path.startswith(f"{PATHS.errors}/") and SCALAR in entity.temporal:
            logged |= set(entity.series(SCALAR, "iteration")[0].tolist())
    assert sorted(logged) == ticks  # one error row per IK iteration, no more
    robot = result.robot
    assert robot is not None
    frames = rec[PATHS.bodies()]
    assert robot.root_body in frames.static["Ellipsoids3D:labels"]
    pose_times, _ = frames.series("Ellipsoids3D:centers", "iteration")
    assert set(pose_times.tolist()) == set(range(end + 1))  # + start and final poses
    # every task's last logged error is the SolveResult's error of that task
    for label, s in result.solves.items():
        if s.iterations == 0:
            continue
        keys = [(t.level, t.name) for t in s.tasks]
        for t in s.tasks:
            if keys.count((t.level, t.name)) > 1:
                continue
            entity = rec[PATHS.task_error(t.level, t.name, solve=label)]
            assert _at(entity, SCALAR, "iteration", last[label])[0] == pytest.approx(
                t.error, rel=1e-9, abs=1e-12
            )
    # the final pose logged is the robot's
    com = _at(rec[PATHS.com], "Points3D:positions", "iteration", end)[0]
    assert np.allclose(com, robot.com(), atol=1e-6)  # float32 in the recording
    # reverts and level failures are in the text log
    texts = [b[0] for _, b in rec[PATHS.events].temporal["TextLog:text"]]
    n_reverted = sum(s.reverted for s in result.solves.values())
    assert sum("reverted to its start pose" in x for x in texts) == n_reverted
    assert sum("level failure" in x for x in texts) == sum(
        bool(s.failure) for s in result.solves.values()
    )


def _check_simulation(rec: dict[str, EntityData], result: ScenarioResult) -> None:
    ticks, _, _ = _ticks(result)
    reports = [r for rs in result.static_reports.values() for r in rs]
    assert len(reports) == len(ticks)
    times, feasible = rec[PATHS.balance_metric("feasible")].series(SCALAR, "iteration")
    assert times.tolist() == ticks
    assert [bool(f[0]) for f in feasible] == [r.feasible for r in reports]
    _, margins = rec[PATHS.balance_metric("margin")].series(SCALAR, "iteration")
    assert np.allclose(
        [m[0] for m in margins], [r.margin for r in reports if np.isfinite(r.margin)]
    )
    final = reports[-1]
    strip = np.array(
        _at(rec[PATHS.support_polygon], "LineStrips3D:strips", "iteration", ticks[-1])[0]
    )
    # drawn above the floor and the soles
    assert np.allclose(strip[:-1, :2], final.support_polygon[:, :2], atol=1e-6)
    lift = strip[:, 2] - final.support_polygon[0, 2]
    assert np.allclose(lift, lift[0], atol=1e-6) and style.LIFT <= lift[0] < 0.2
    assert np.allclose(strip[-1], strip[0])  # closed outline
    if final.forces is not None:
        arrows = np.array(
            _at(rec[PATHS.contact_forces], "Arrows3D:vectors", "iteration", ticks[-1])
        )
        # one scale for all (the robot's weight drawn as a fraction of its height)
        scale = arrows[:, 2].sum() / final.forces[:, 2].sum()
        assert 5e-4 < scale < 5e-3
        assert np.allclose(arrows / scale, final.forces, atol=1e-2)  # float32
        # the LP's forces balance the weight (no external wrench in the check)
        mass = result.robot.mass
        assert final.forces.sum(axis=0) == pytest.approx([0, 0, mass * 9.81], abs=1e-3 * mass)

    # the hold, on sim_time, after the iterations
    bal = result.balance
    assert bal is not None and {"static", "hold", "passed", "robot"} <= set(bal)
    hold = bal["hold"]
    assert hold["duration"] == HOLD
    times, drift = rec[PATHS.hold_metric("drift")].series(SCALAR, "sim_time")
    # a motion played before the hold comes first on sim_time: the hold's clock
    # restarts at 0, the recording places it after the motion
    start = 0.0
    if result.motions:
        _, last = list(result.motions.items())[-1]
        start = times[0]
        assert start >= last.simulated - 1e-9
        m_t, _ = rec[PATHS.motion_metric("tracking_error")].series(SCALAR, "sim_time")
        assert m_t[0] == 0.0 and m_t[-1] <= start
    assert times[-1] - start == pytest.approx(hold["simulated"], abs=1e-9)
    assert drift[-1][0] == pytest.approx(hold["drift"], rel=1e-6)
    assert max(d[0] for d in drift) == pytest.approx(hold["drift"], rel=1e-6)
    # the hold does not write on the iteration timeline
    assert all("iteration" not in t for t, _ in rec[PATHS.hold_metric("drift")].temporal[SCALAR])
    pose_t, _ = rec[PATHS.bodies()].series("Ellipsoids3D:centers", "sim_time")
    assert pose_t[0] == 0.0 and pose_t[-1] == pytest.approx(start + hold["simulated"])
    fz = rec[PATHS.hold_metric("contact_force_z")].series(SCALAR, "sim_time")[1]
    if result.name in HOLDS:
        assert bal["passed"] and hold["drift"] < 0.01
        # MuJoCo's contact forces on a robot standing still carry its weight
        weight = result.robot.mass * 9.81
        assert fz[-1][0] == pytest.approx(weight, rel=0.02)
    hold_check = [m for m in result.messages if "held 3 s in physics" in m]
    assert hold_check == [
        m for m in hold_check if m.startswith("[ok]" if bal["passed"] else "[FAILED]")
    ]
    assert len(hold_check) == 1


def run_scenario(name: str, rrd: Path, **params) -> ScenarioResult:
    """Run scenario ``name``'s ``run`` into the recording ``rrd`` (quietly)."""
    module = cli.load_scenario(name)
    with Recorder.to_file(rrd, application_id=name) as recorder:
        result = module.run(recorder, **params)
    result.recording = str(rrd)
    return result


@pytest.mark.parametrize("name", pik_mj.scenarios.SCENARIOS)
def test_every_scenario_passes_and_writes_a_valid_recording(name, tmp_path):
    rrd = tmp_path / f"{name}.rrd"
    takes = inspect.signature(cli.load_scenario(name).run).parameters
    params = {**SHORT.get(name, {}), **({"hold": HOLD} if "hold" in takes else {})}
    result = run_scenario(name, rrd, **params)
    verified = _verify(rrd)
    assert verified.returncode == 0, verified.stderr
    rec = read_recording(rrd)
    _check_drawable(rec)
    _check_pinholes(rrd, rec)
    d = result.to_dict()
    json.dumps(d, allow_nan=False)  # JSON-ready
    assert KEYS <= set(d)
    if not result.solves:  # walking: the pattern is played in physics by the scenario
        assert result.passed, result.summary()
        assert d["motion"]["passed"] and not d["motion"]["fell"]
        times, _ = rec[PATHS.com].series("Points3D:positions", "sim_time")
        assert len(times) > 100
        return
    # every check of the scenario holds; the hold's check is the hold's verdict
    others = [m for m in result.messages if "held 3 s in physics" not in m]
    assert all(m.startswith("[ok]") for m in others), result.summary()
    assert d["timing"]["iteration_ms"] and all(t > 0 for t in d["timing"]["iteration_ms"])
    for task in d["tasks"]:
        assert {"name", "level", "error", "satisfied"} <= set(task)
    _check_iterations(rec, result)
    bp = read_recording(rrd, blueprint=True)
    origins = {
        e.temporal["ViewBlueprint:space_origin"][-1][1][0]: e.temporal[
            "ViewBlueprint:class_identifier"
        ][-1][1][0]
        for e in bp.values()
        if "ViewBlueprint:space_origin" in e.temporal
    }
    n_levels = max(len({t.level for t in s.tasks}) for s in result.solves.values())
    assert origins[PATHS.world] == "3D"
    assert all(
        origins[PATHS.level_errors(k, log10=True)] == "TimeSeries" for k in range(1, n_levels)
    )
    if result.robot.has_floating_base:
        assert origins[PATHS.balance] == "TimeSeries"
        _check_simulation(rec, result)
        # a static check in simulation on every iteration of every solve
        assert d["simulation"]["iterations_checked"] == d["timing"]["total_iterations"]
        for label, solve in result.solves.items():
            assert len(result.static_reports.get(label, [])) == solve.iterations
        # the scene's CoM is the robot's at the end (one world, one frame)
        last = [r for rs in result.static_reports.values() for r in rs][-1]
        if not list(result.solves.values())[-1].reverted:
            assert np.allclose(last.com, result.robot.com(), atol=1e-9)
        assert d["balance"]["hold"]["drift"] == pytest.approx(result.balance["hold"]["drift"])
        assert d["robot"]["q"] and d["robot"]["model"] == "sample_humanoid"
    else:
        assert result.balance is None and PATHS.balance_metric("margin") not in rec
        assert d["simulation"] is None and d["robot"] is None


def test_fullbody_reach_frames_in_the_recording(tmp_path):
    rrd = tmp_path / "r.rrd"
    result = run_scenario("fullbody_reach", rrd, hold=0.0)
    rec = read_recording(rrd)
    _, _, end = _ticks(result)
    last = end - 1
    target = _at(
        rec[PATHS.task_target("target:larm_end")], "Transform3D:translation", "iteration", last
    )
    current = _at(
        rec[PATHS.task_current("target:larm_end")], "Transform3D:translation", "iteration", last
    )
    assert np.allclose(target[0], result.figures["hand_target_m"], atol=1e-6)
    assert np.allclose(current[0], result.robot.frame_pose("larm_end").translation(), atol=1e-6)
    com_target = _at(rec[PATHS.com_target], "Points3D:positions", "iteration", last)[0]
    feet = [result.robot.frame_pose(f).translation() for f in ("rleg_end", "lleg_end")]
    assert np.allclose(com_target[:2], np.mean(feet, axis=0)[:2], atol=1e-6)
    # the iso-margin outline passes through the CoM's projection
    margin = _at(rec[f"{PATHS.support_polygon}/margin"], "LineStrips3D:strips", "iteration", last)
    loop = np.array(margin[0])[:, :2]
    c = result.robot.com()[:2]
    dist = min(
        np.linalg.norm(c - (a + np.clip((c - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1) * (b - a)))
        for a, b in itertools.pairwise(loop)
    )
    assert dist < 1e-5


BOOM = '''
    """Raises mid-solve."""
    import numpy as np

    from pik_mj import Robot, Scene, fullbody_inverse_kinematics
    from pik_mj.scenario import open_recorder, parser, report


    def run(recorder):
        robot = Robot.from_model("sample_humanoid")
        scene = Scene.from_robot(robot)
        recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
        target = robot.root_pose()[0] + np.array([0.4, 0.1, -0.6])
        checks = scene.static_checker()
        log = recorder.solve_logger("reach", checks=checks)

        def boom(info):
            if info.iteration == 3:
                raise RuntimeError("boom at iteration 3")

        fullbody_inverse_kinematics(
            robot,
            [(target, [1.0, 0.0, 0.0, 0.0])],
            limbs=["larm"],
            rotation_axis=[None],
            callback=[checks, log, boom],
        )


    def main(argv=None):
        args = parser(__doc__).parse_args(argv)
        with open_recorder(args, "boom") as recorder:
            result = run(recorder)
        return report(result, args)
'''


def test_recording_is_valid_when_the_scenario_raises(tmp_path, monkeypatch, capsys):
    add_scenario(monkeypatch, tmp_path, "boom", BOOM)
    rrd = tmp_path / "boom.rrd"
    assert cli.main(["run", "boom", "--save", str(rrd), "--quiet"]) == 1
    captured = capsys.readouterr()
    assert "RuntimeError: boom at iteration 3" in captured.err
    assert f"recording (up to the error): {rrd}" in captured.out
    verified = _verify(rrd)
    assert verified.returncode == 0, verified.stderr
    rec = read_recording(rrd)
    times, _ = rec[PATHS.task_error(2, "target:larm_end", solve="reach")].series(
        SCALAR, "iteration"
    )
    assert times.tolist() == [1, 2, 3]
    assert rec[PATHS.balance_metric("feasible")].series(SCALAR, "iteration")[0].tolist() == [
        1,
        2,
        3,
    ]
    events = rec[PATHS.events].temporal
    texts = [b[0] for _, b in events["TextLog:text"]]
    levels = [b[0] for _, b in events["TextLog:level"]]
    i = next(k for k, x in enumerate(texts) if "raised RuntimeError" in x)
    assert "boom at iteration 3" in texts[i] and levels[i] == "ERROR"
    assert PATHS.hold_metric("drift") not in rec  # no hold after a failure


def test_validate_reproduces_the_hold_of_a_run(tmp_path, capsys):
    js = tmp_path / "run.json"
    assert cli.main(["run", "--headless", "--json", str(js), "--quiet"]) == 0
    d = json.loads(js.read_text())
    assert d["name"] == "fullbody_reach" and d["balance"]["passed"]
    robot = d["robot"]
    assert (
        robot["model"] == "sample_humanoid"
        and len(robot["q"]) == Robot.from_model("sample_humanoid").model.nq
    )
    # the scene's contact polygon (MuJoCo contacts) and the IK's sole rectangles agree
    assert d["balance"]["static"]["margin"] == pytest.approx(d["figures"]["com_margin_m"], abs=1e-6)
    out = tmp_path / "validate.json"
    assert cli.main(["validate", str(js), "--json", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "PASSED" in stdout
    v = json.loads(out.read_text())
    assert v["passed"]
    # same scene, same pose, deterministic physics: the same hold
    for key in ("drift", "slip", "min_margin", "steps"):
        assert v["hold"][key] == pytest.approx(d["balance"]["hold"][key], abs=1e-12)
    # a bare {"model", "q"} file and --duration
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps({"model": robot["model"], "q": robot["q"]}))
    assert cli.main(["validate", str(bare), "--duration", "0.5", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["hold"]["simulated"] == pytest.approx(0.5)
    # the same pose in another world: the room around it (its floor at z = 0 too,
    # nothing else within reach), the kettle's joint appended at its start
    assert cli.main(["validate", str(js), "--environment", "room", "--json", str(out)]) == 0
    v = json.loads(out.read_text())
    assert v["robot"]["environment"] == "room" and v["passed"]
    assert v["hold"]["drift"] == pytest.approx(d["balance"]["hold"]["drift"], rel=1e-3)


def test_validate_fails_when_the_com_leans_past_the_toes(tmp_path, capsys):
    robot = Robot.from_model("sample_humanoid")
    robot.set_angle_vector(
        [1.0, -1.57, -1.57], ["torso_waist_p", "rarm_shoulder_p", "larm_shoulder_p"]
    )
    m, d = robot.model, robot.data
    toes = max(d.geom_xpos[m.geom(s).id][0] + m.geom(s).size[0] for s in ("rleg_sole", "lleg_sole"))
    com = robot.com()
    assert com[0] > toes and abs(com[1]) < 0.09  # past the front edge, between the feet
    pose = tmp_path / "lean.json"
    pose.write_text(json.dumps({"model": "sample_humanoid", "q": robot.configuration.q.tolist()}))
    out = tmp_path / "v.json"
    assert cli.main(["validate", str(pose), "--duration", "1.5", "--json", str(out)]) == 1
    assert "FAILED" in capsys.readouterr().out
    v = json.loads(out.read_text())
    assert not v["passed"] and not v["static"]["feasible"]
    assert v["static"]["margin"] == pytest.approx(toes - com[0], abs=1e-6)
    assert not v["hold"]["passed"] and v["hold"]["drift"] > 0.1
