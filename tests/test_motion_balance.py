"""The played path's blends (:class:`pik_mj.sim.blends.BlendedPath`) and the
timing that keeps the plan's ZMP inside the support polygon
(:mod:`pik_mj.sim.zmp`), against finite differences, MuJoCo's inverse
dynamics at the full acceleration, and physics on Unitree G1."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from pik_mj import Robot, Scene, Waypoints
from pik_mj.sim import zmp
from pik_mj.sim.blends import BlendedPath
from pik_mj.sim.motion import MotionReference, velocity_limits
from pik_mj.sim.path import Waypoint
from pik_mj.sim.timing import Timing

BENCH = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_robots.py"


def _zigzag(robot: Robot, n: int = 7, amplitude: float = 0.15) -> Waypoints:
    """The right arm's first joints zigzagging away from the standing pose (a
    path that turns at every waypoint), in two segments."""
    q0 = robot.configuration.q.copy()
    joints = robot.limb("rarm").joints[:2]
    adr = [robot.model.joint(j).qposadr[0] for j in joints]
    path = Waypoints(q0.copy(), "out")
    for i in range(1, n):
        q = q0.copy()
        q[adr[0]] -= amplitude * i
        q[adr[1]] += amplitude * (i % 2)
        path.items.append(Waypoint(q, "out" if i <= n // 2 else "back", i))
    return path


def _blended(robot: Robot, path: Waypoints) -> tuple[BlendedPath, Timing, np.ndarray]:
    m, q = robot.model, path.q
    dv = np.array([np.zeros(m.nv) for _ in range(len(q) - 1)])
    for i in range(len(q) - 1):
        mujoco.mj_differentiatePos(m, dv[i], 1.0, q[i], q[i + 1])
    steps = np.abs(dv).max(axis=1) / 1.0  # 1 rad/s
    timing = Timing(steps, [w.segment for w in path.items])
    return BlendedPath(m, q, dv, timing), timing, dv


def test_the_blends_turn_the_rate_continuously_and_pass_near_the_waypoints():
    """``q'`` and ``q''`` are the finite differences of ``q(σ)``; ``q'`` has no
    jump at the interior waypoints (where the straight path's rate turns); a
    blend passes ``3 b (v_w - v_{w-1}) / 16`` from its waypoint; the segment
    boundary is passed exactly; no joint's rate exceeds its rates on the two
    steps."""
    robot = Robot.from_model("sample_humanoid")
    path = _zigzag(robot)
    blended, timing, dv = _blended(robot, path)
    m, q = robot.model, path.q
    h = 1e-6
    for sigma in np.linspace(0.01, timing.nominal[-1] - 0.01, 37):
        qa, d1, d2 = blended.at(sigma)
        qb, d1b, _ = blended.at(sigma + h)
        fd = np.zeros(m.nv)
        mujoco.mj_differentiatePos(m, fd, h, qa, qb)
        assert np.allclose(fd, d1, atol=1e-4)
        assert np.allclose((d1b - d1) / h, d2, atol=1e-3 * (1 + np.abs(d2).max()))
    rates = dv / timing.steps[:, None]
    boundary = int(timing.last[0])
    for w in range(1, len(q) - 1):
        before = blended.at(timing.nominal[w] - 1e-9)[1]
        after = blended.at(timing.nominal[w] + 1e-9)[1]
        b = blended.half_width[w]
        gap = np.zeros(m.nv)
        mujoco.mj_differentiatePos(m, gap, 1.0, q[w], blended.at(timing.nominal[w])[0])
        if w == boundary:  # at rest there (the timing): the path turns at once
            assert b == 0.0 and np.abs(gap).max() < 1e-12
            continue
        assert np.allclose(before, after, atol=1e-6)  # no kink
        turn = rates[w] - rates[w - 1]
        assert np.abs(turn).max() > 0.1  # the straight path turns here
        assert b == pytest.approx(0.5 * min(timing.steps[w - 1], timing.steps[w]))
        assert np.allclose(gap, 3 * b * turn / 16, atol=1e-9)
        for s in np.linspace(timing.nominal[w] - b, timing.nominal[w] + b, 11):
            rate = blended.at(s)[1]
            assert np.all(np.abs(rate) <= np.maximum(abs(rates[w - 1]), abs(rates[w])) + 1e-9)


def _zmp_direct(scene: Scene, q, qvel, qacc, data: mujoco.MjData | None = None) -> np.ndarray:
    """The ZMP on z = 0 of the free joint's generalized force at the full
    ``(q, q̇, q̈)``: the moments of the root's wrench about a grid of floor points,
    the point where the horizontal moment vanishes (least squares). ``data``:
    the robot model's, reused."""
    m = scene.robot.model  # the robot alone: its free joint first, no contacts
    d = mujoco.MjData(m) if data is None else data
    d.qpos[:], d.qvel[:], d.qacc[:] = q, qvel, qacc
    saved = m.opt.disableflags
    m.opt.disableflags = saved | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    mujoco.mj_inverse(m, d)
    m.opt.disableflags = saved
    assert m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    root = m.jnt_bodyid[0]
    F = d.qfrc_inverse[:3]
    n_o = d.xmat[root].reshape(3, 3) @ d.qfrc_inverse[3:6]
    o = d.xpos[root]

    def moment(p):  # horizontal moment about the floor point p
        return (n_o + np.cross(o - np.array([p[0], p[1], 0.0]), F))[:2]

    base = moment((0.0, 0.0))
    J = np.column_stack([moment((1.0, 0.0)) - base, moment((0.0, 1.0)) - base])
    return np.linalg.solve(J, -base)


def test_the_plan_s_zmp_is_the_inverse_dynamics_one():
    """At every knot of a zigzag of the sample humanoid's arm the plan's ZMP at
    rates ``(σ̇, σ̈)`` is the one of MuJoCo's inverse dynamics at ``q̇ = q' σ̇``,
    ``q̈ = q' σ̈ + q'' σ̇²`` (found another way); at rest it is the CoM's
    projection. A knot fits while its ZMP keeps half its rest margin; one not
    balanced at rest always fits."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    path = _zigzag(robot)
    blended, _, _ = _blended(robot, path)
    plan = zmp.plan_zmp(scene, blended)
    k = len(plan.sigma)
    assert k > 20
    rng = np.random.default_rng(0)
    rate, accel = rng.uniform(0.2, 1.0, k), rng.uniform(-5.0, 5.0, k)
    points = plan.points(rate, accel)
    rest = plan.points(np.zeros(k), np.zeros(k))
    d = mujoco.MjData(scene.model)
    for j in range(0, k, 5):
        q, d1, d2 = blended.at(plan.sigma[j])
        R = scene.support(scene.touching(scene.qpos_of(q)), np.zeros(3), zmp.GROUND_SLOPE)[0].R
        direct = _zmp_direct(scene, q, d1 * rate[j], d1 * accel[j] + d2 * rate[j] ** 2)
        assert np.allclose(R[:2, :2] @ points[j], direct, atol=1e-6)
        d.qpos[:] = scene.qpos_of(q)
        mujoco.mj_kinematics(scene.model, d)
        mujoco.mj_comPos(scene.model, d)
        com = d.subtree_com[scene.model.body(robot.root_body).id]
        assert np.allclose(R[:2, :2] @ rest[j], com[:2], atol=1e-6)
    # the criterion: half the rest margin kept; knots not balanced at rest not judged
    zero = np.zeros(k)
    assert np.all(plan.rest_margin > 0) and np.all(plan.fits(zero, zero))
    fast = np.full(k, 40.0)
    margins = plan.margins(zero + 1.0, fast)
    expected = margins >= zmp.ZMP_RESERVE * plan.rest_margin - 1e-9
    assert not np.all(expected)
    np.testing.assert_array_equal(plan.fits(zero + 1.0, fast), expected)
    plan.rest_margin = -plan.rest_margin
    assert np.all(plan.fits(zero + 1.0, fast))


def _bench():
    spec = importlib.util.spec_from_file_location("_bench_robots", BENCH)
    module = importlib.util.module_from_spec(spec)
    sys.modules["_bench_robots"] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(not os.environ.get("MENAGERIE_ROOT"), reason="MENAGERIE_ROOT is not set")
def test_a_g1_reach_near_the_margin_stands_through_its_motion():
    """bench_robots' second G1 target (seed 0): the solve ends with the CoM at
    the 20 mm margin. Played straight between the iterates at the solve's pace
    its ZMP (finite differences of the reference, inverse dynamics) leaves the
    support polygon; with the blends and the balance stretch it keeps half
    the margin, and in physics the robot stays within the motion's criteria
    (root drift < 20 mm) with its CoM half the margin inside the polygon it
    stands on."""
    bench = _bench()
    setup = bench.Setup("unitree_g1")
    target = setup.targets(4, 0)[1]
    path = Waypoints(setup.robot, "reach")
    path.finish(setup.solve(target, True, "osqp", path))
    scene = setup.scene
    lower, upper = velocity_limits(scene, None, path.velocity_bounds)
    reference = MotionReference(scene, path, lower, upper, speed=bench.SPEED)
    assert reference.balance_stretch  # the ZMP needed a slower motion
    stretched = reference.timing.stretch.copy()
    reference.timing.stretch[:] = stretched / np.array(list(reference.balance_stretch.values()))
    assert _least_zmp_margin(scene, setup.region, reference) < 0.0  # unstretched: outside
    reference.timing.stretch[:] = stretched
    assert _least_zmp_margin(scene, setup.region, reference) > 0.45 * bench.MARGIN
    motion = scene.play(path, speed=bench.SPEED)
    assert motion.passed, motion.failures
    assert motion.drift < 0.02 and motion.min_margin > 0.5 * bench.MARGIN


def _least_zmp_margin(scene: Scene, region, reference: MotionReference) -> float:
    """The least margin [m] of the reference's ZMP (the played reference sampled
    every 5 ms, its rates by finite differences, MuJoCo's inverse dynamics)."""
    rm, dt = scene.robot.model, 0.005
    t = np.arange(0.0, reference.duration, dt)
    qs = []
    for _ in reference.updates(t):
        qs.append(reference.data.qpos[: rm.nq].copy())
    v = np.zeros((len(t), rm.nv))
    for k in range(len(t) - 1):
        mujoco.mj_differentiatePos(rm, v[k], dt, qs[k], qs[k + 1])
    margins, data = [], mujoco.MjData(rm)
    for k in range(1, len(t) - 1):
        qvel, qacc = 0.5 * (v[k] + v[k - 1]), (v[k] - v[k - 1]) / dt
        p = _zmp_direct(scene, qs[k], qvel, qacc, data)
        margins.append(region.signed_distance(np.array([p[0], p[1], 0.0])))
    return float(np.min(margins))


def test_stretch_until_is_the_plain_bisection():
    """Timing.stretch_until (several halvings per call of fits) gives the
    stretch of a plain 30-halving bisection called knot by knot, bit for bit,
    on three segments whose knots need different slowdowns (one none)."""
    rng = np.random.default_rng(4)
    labels = ["a", "a", "a", "b", "b", "c", "c"]
    for trial in range(5):
        timing = Timing(rng.uniform(0.2, 0.6, 6), labels)
        reference = Timing(timing.steps.copy(), labels)
        sigma = np.linspace(0.0, timing.nominal[-1], 31)
        need = rng.uniform(0.5, 3.0, (2, len(sigma)))
        need[:, sigma < timing.nominal[2]] = 0.1 * (trial % 2)  # segment a: fits at once

        def fits(rate, accel, need=need):
            return rate**2 * need[0] + np.abs(accel) * need[1] <= 1.0

        got = timing.stretch_until(sigma, fits, 10.0)
        t = reference.times_of(sigma)
        _, rate, accel = reference.progress(t)
        segment = reference.segment_of(t)
        expected = {}
        for k in np.unique(segment[~fits(rate, accel)]):
            mine = segment == k
            low, high = 1.0, 10.0
            for _ in range(30):
                c = 0.5 * (low + high)
                ok = fits(np.where(mine, rate / c, rate), np.where(mine, accel / c**2, accel))
                low, high = (low, c) if np.all(ok[mine]) else (c, high)
            reference.stretch[k] *= high
            expected[int(k)] = float(reference.stretch[k])
        assert got == expected and np.array_equal(timing.stretch, reference.stretch)
        assert len(got) >= 2 and max(got.values()) > 1.5
