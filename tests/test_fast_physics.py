"""Physics stepped in C, checks on the recorded trajectory (issue 40): the chunked
rollout is the per-step physics, the sampled figures match the per-step ones,
many holds stepped together give each single hold's figures and stop a fall
early, and a sweep's rows carry the pose they were validated with."""

from __future__ import annotations

import numpy as np
import pytest

from pik_mj import Robot, Scene
from pik_mj.cli import main as pik_mj
from pik_mj.sim.tracking import RECORD_EVERY
from pik_mj.sweep import Grid, Sweep, Worker
from pik_mj.sweep.dataset import Dataset, make_row
from pik_mj.sweep.replay import FIGURES, replay
from pik_mj.sweep.spec import Case


@pytest.fixture(scope="module")
def humanoid() -> tuple[Robot, Scene]:
    robot = Robot.from_model("sample_humanoid")
    return robot, Scene.from_robot(robot)


def _poses(robot: Robot) -> list[np.ndarray]:
    """Three standing poses (the right arm raised by 0.3, 0.8, 1.3 rad) and one
    that leans forward on its ankles past its toes (it falls)."""
    q0 = robot.configuration.q.copy()
    model = robot.model
    out = []
    for lift in (0.3, 0.8, 1.3):
        q = q0.copy()
        q[model.joint("rarm_shoulder_p").qposadr[0]] -= lift
        out.append(q)
    q = q0.copy()
    for ankle in ("rleg_ankle_p", "lleg_ankle_p"):
        q[model.joint(ankle).qposadr[0]] += 0.5
    out.append(q)
    return out


def test_the_chunked_physics_is_the_per_step_physics(humanoid):
    """A hold stepped by the rollout in chunks of a hundred and more steps ends in
    the very state of the same hold stepped one step per call (the controls and
    warm start carried over): sampling changes which states the checks see, not
    the physics; the figures seen every step and every ``RECORD_EVERY``-th
    differ by less than 0.1 mm, the margins (every ``MARGIN_EVERY``-th step in
    both) are equal."""
    robot, scene = humanoid
    q = _poses(robot)[2]
    fast = scene.hold(q, 1.0)
    end = scene.data.qpos.copy()
    slow = scene.hold(q, 1.0, record_every=1)
    np.testing.assert_array_equal(scene.data.qpos, end)
    assert fast.steps == slow.steps == 500
    assert fast.passed == slow.passed and fast.failures == slow.failures
    assert fast.drift <= slow.drift + 1e-12 and slow.drift - fast.drift < 1e-4
    assert abs(fast.slip - slow.slip) < 1e-4 and fast.min_margin == pytest.approx(slow.min_margin)


def test_a_sampled_motion_and_fall_agree_with_the_per_step_checks(humanoid):
    """The arm raised in physics (a motion) and the leaning pose's fall, checked
    every ``RECORD_EVERY``-th step and every step: the same verdicts and
    failures, the drift and the tracking error within 0.1 mm (rad), the margins
    equal; the fall of the same kind within a row's time of the per-step one,
    failing the same criteria."""
    robot, scene = humanoid
    poses = _poses(robot)
    path = np.array(poses[:3])
    fast, slow = scene.play(path), scene.play(path, record_every=1)
    assert fast.passed == slow.passed and fast.failures == slow.failures
    assert fast.steps == slow.steps and fast.drift <= slow.drift + 1e-12
    assert slow.drift - fast.drift < 1e-4 and abs(fast.slip - slow.slip) < 1e-4
    assert slow.tracking_error - fast.tracking_error < 1e-4
    assert fast.min_margin == pytest.approx(slow.min_margin, abs=1e-12)
    fast, slow = scene.hold(poses[3], 2.0), scene.hold(poses[3], 2.0, record_every=1)
    assert fast.fell and slow.fell and fast.fall.kind == slow.fall.kind
    # the runs stop at the check after the fall: their figures past it differ
    assert [f.split()[0] for f in fast.failures] == [f.split()[0] for f in slow.failures]
    assert 0 <= fast.fall.time - slow.fall.time <= RECORD_EVERY * scene.model.opt.timestep + 1e-9


def test_holds_stepped_together_are_the_single_holds(humanoid):
    """``hold_many`` on two threads: the verdicts, drift, slip, margin and fall of
    each single hold (its chunks start without the solver's warm start: equal to
    1e-9); the leaning pose falls and its run stops early, in both."""
    robot, scene = humanoid
    poses = _poses(robot)
    single = [scene.hold(q, 2.0) for q in poses]
    many = scene.hold_many(poses, 2.0, nthread=2)
    assert [h.passed for h in many] == [h.passed for h in single] == [True, True, True, False]
    for a, b in zip(single, many, strict=True):
        assert a.failures == b.failures and a.steps == b.steps
        for name in ("drift", "slip", "min_margin", "tilt"):
            assert getattr(b, name) == pytest.approx(getattr(a, name), abs=1e-9), name
    fell = many[-1]
    assert fell.fell and single[-1].fell and fell.fall.kind == single[-1].fall.kind
    assert fell.fall.time == pytest.approx(single[-1].fall.time)
    assert fell.steps < 1000 and fell.simulated < 2.0  # stopped early


SWEEP = Sweep(
    Grid({"x": [0.3, 0.4, 0.5, 0.6, 0.7], "y": [-0.2], "z": [0.6, 1.1]}), hold=0.5, seed=3
)


def test_twenty_rows_replay_from_their_pose_to_the_same_verdicts(tmp_path):
    """Twenty cases solved, checked, played and held; their rows written to a
    sweep dataset; each row replayed from its ``qpos`` and ``path`` alone (no
    solve; the holds stepped together) gives the stored verdict and figures,
    and ``pik-mj validate OUT#CASE`` says so."""
    cases: list[Case] = list(SWEEP.cases())
    assert len(cases) == 20
    worker = Worker("sample_humanoid", hold=SWEEP.hold)
    rows = [make_row(c, worker.run(c), "here") for c in cases]
    out = tmp_path / "sweep"
    data = Dataset.open(out, SWEEP)
    data.write(rows)
    stored = data.table().to_pylist()
    data.close()
    assert all(len(r["qpos"]) == worker.robot.model.nq for r in stored)
    assert all(np.allclose(r["path"][-1], r["qpos"]) for r in stored)  # the last iterate
    again = replay(out)
    assert [r["case"] for r in again] == list(range(20))
    verdicts = {r["replayed"]["verdict"] for r in again}
    assert len(verdicts) > 1  # the grid reaches and misses: not all alike
    for r in again:
        a, b = r["stored"], r["replayed"]
        assert b["verdict"] == a["verdict"], r["case"]
        for k in FIGURES:
            assert b[k] == pytest.approx(a[k], abs=1e-9), (r["case"], k)
    validated = next(r["case"] for r in again if r["stored"]["verdict"] == "validated")
    assert pik_mj(["validate", f"{out}#{validated}"]) == 0


def test_a_callback_sees_the_run_s_figures_so_far(humanoid):
    """The drift and slip a per-step callback gets grow row by row to the report's
    figures over the whole record (computed at once): equal at the last step."""
    robot, scene = humanoid
    q = _poses(robot)[3]  # leaning: it drifts and its feet slip
    seen = []
    report = scene.hold(q, 0.4, callback=lambda s: seen.append((s.drift, s.slip)), every=1)
    assert len(seen) == report.steps + 1  # the start and every step
    drifts = [d for d, _ in seen]
    assert drifts == sorted(drifts) and drifts[-1] > 1e-3
    assert drifts[-1] == pytest.approx(report.drift, abs=1e-12)
    assert seen[-1][1] == pytest.approx(max(report.slip_per_geom.values()), abs=1e-12)
    quiet = scene.hold(q, 0.4)  # no callback: the record's rows at the same steps
    for name in ("drift", "slip", "min_margin", "tilt", "steps"):
        assert getattr(quiet, name) == getattr(report, name), name
