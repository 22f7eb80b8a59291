"""The contact wrench distribution in closed form where no limit is active, the
QP where one is (:func:`pik_mj.dynamics.contact_wrenches`), and the torque
plan built on it (:func:`pik_mj.sim.effort.plan_torques`) against independent
references: the QP itself, ``holding_torques`` pose by pose, and the mass
matrix."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
import qpsolvers
from test_drives import _arm_out, _robot

from pik_mj import Robot, Scene, balance, fullbody_inverse_kinematics
from pik_mj import dynamics as dy
from pik_mj.dynamics import distribution
from pik_mj.exceptions import InvalidInput
from pik_mj.sim import effort, knots, zmp
from pik_mj.sim.motion import MotionReference, velocity_limits
from pik_mj.sim.path import Waypoint, Waypoints
from pik_mj.sim.static import point_contacts
from pik_mj.sim.torques import (
    ContactSupport,
    holding_torques,
    root_free_dofs,
    root_wrench_maps,
)

WEIGHT = 500.0  # [N]


def _qp_calls(monkeypatch) -> list[int]:
    """Counts the calls to the QP solver (the real one, called through)."""
    calls: list[int] = []
    solve = distribution.daqp.solve

    def counted(*args, **kwargs):
        calls.append(1)
        return solve(*args, **kwargs)

    monkeypatch.setattr(distribution.daqp, "solve", counted)
    return calls


@pytest.mark.parametrize("kind", ["points", "soles"])
def test_the_qp_is_qpsolvers_daqp_problem(kind):
    """The distribution's QP (DAQP called directly) gives qpsolvers'
    ``solve_qp(W, 0, G, h, A, b, solver="daqp")`` bit for bit, in units of
    ``|f|``, feasible or not (None)."""
    rng = np.random.default_rng(5)
    found = 0
    for trial in range(20):
        d = dy.ContactDistribution(_contacts(rng, kind))
        f = np.array([*rng.normal(0, 0.3 if trial % 2 else 1.2, 2) * WEIGHT, WEIGHT])
        total = np.concatenate([f, np.cross([*rng.normal(0, 0.2, 2), 0.9], f)])
        scale = float(np.linalg.norm(total[:3]))
        ref = qpsolvers.solve_qp(
            np.diag(d.weights), np.zeros(d.n), G=d.G, h=d.h / scale, A=d.A, b=total / scale,
            solver="daqp",
        )  # fmt: skip
        got = d.solve(total, solver="qp")
        assert (got is None) == (ref is None)
        if ref is not None:
            found += 1
            x = np.concatenate([got[i, :k] for i, (_, k) in enumerate(d.cols)])
            assert np.array_equal(x, scale * ref)
    assert 0 < found < 20  # feasible and infeasible totals


def _contacts(rng: np.random.Generator, kind: str) -> list[balance.ContactConstraint]:
    """Four point contacts of a foot pair on z = 0, or two flat soles."""
    if kind == "points":
        corners = [(0.1, 0.15), (-0.1, 0.15), (0.1, -0.15), (-0.1, -0.15)]
        return [
            balance.contact_from_normal(
                np.array([x, y, 0.0]) + rng.normal(0, 0.01, 3) * [1, 1, 0], np.array([0, 0, 1.0])
            )
            for x, y in corners
        ]
    return [
        balance.contact_from_normal(np.array([0.0, y, 0.0]), np.array([0, 0, 1.0]), 0.1, 0.05)
        for y in (0.1, -0.1)
    ]


@pytest.mark.parametrize("kind", ["points", "soles"])
def test_the_closed_form_is_the_qp_s_solution_where_no_limit_is_active(kind, monkeypatch):
    """Random totals: a weight over the support with small pushes (every limit
    inactive) are solved without the QP, and equal its solution within 1e-9 of
    the weight; a push beyond friction or a CoP outside the feet goes to the QP
    (the closed form's forces would leave a pyramid) and gives the QP's forces."""
    rng = np.random.default_rng(3)
    calls = _qp_calls(monkeypatch)
    inside = 0
    for trial in range(40):
        contacts = _contacts(rng, kind)
        f = np.array([*rng.normal(0, 0.05 if trial % 2 else 0.6, 2) * WEIGHT, WEIGHT])
        c = np.array([*rng.normal(0, 0.03 if trial % 2 else 0.2, 2), 0.9])  # where f acts
        total = np.concatenate([f, np.cross(c, f)])
        before = len(calls)
        auto = dy.contact_wrenches(contacts, total)
        closed = len(calls) == before
        qp = dy.contact_wrenches(contacts, total, solver="qp")
        assert (auto is None) == (qp is None)
        if auto is None:
            continue
        np.testing.assert_allclose(auto, qp, rtol=0, atol=1e-9 * WEIGHT)
        inside += closed
        np.testing.assert_allclose(
            dy.wrench_map([k.p_WC for k in contacts]) @ auto[:, :3].reshape(-1)
            + np.concatenate([np.zeros(3), auto[:, 3:].sum(axis=0)]),
            total,
            atol=1e-9 * WEIGHT,
        )
    assert 10 <= inside < 40  # both branches were taken


def test_contacts_on_one_line_go_to_the_qp(monkeypatch):
    """Two point contacts cannot apply a moment about their line: the closed
    form misses the total, the QP says there is no equilibrium."""
    calls = _qp_calls(monkeypatch)
    pts = [np.array([0.0, y, 0.0]) for y in (0.1, -0.1)]
    contacts = [balance.contact_from_normal(p, np.array([0, 0, 1.0])) for p in pts]
    f = np.array([0, 0, WEIGHT])
    assert dy.contact_wrenches(contacts, np.concatenate([f, np.cross([0.05, 0, 1], f)])) is None
    assert calls
    with pytest.raises(InvalidInput, match="solver"):
        dy.contact_wrenches(contacts, np.zeros(6), solver="lp")
    with pytest.raises(InvalidInput, match="ContactConstraint"):
        dy.contact_wrenches(["foot"], np.zeros(6))


def _reach(robot: Robot) -> Waypoints:
    """The right arm forward in 4 iterates from the standing pose."""
    q0 = robot.configuration.q.copy()
    path = Waypoints(q0, "reach")
    j = robot.model.joint(robot.limb("rarm").joints[0])
    for k in range(1, 5):
        q = q0.copy()
        q[j.qposadr[0]] -= 0.2 * k
        path.items.append(Waypoint(q, "reach", k))
    return path


def test_the_plan_s_knots_match_holding_torques_and_the_mass_matrix():
    """At every knot of a reach's plan on the sample humanoid (the pose and
    ``q'`` rebuilt from the timing): ``τ_s`` equals gravity less the contact
    forces the QP finds, each through its point's Jacobian, and equals
    ``holding_torques`` of the knot's pose (1e-9 N·m); the inertia
    term equals ``P M q'`` with ``M q'`` from ``mj_mulM`` (1e-9); and every term's
    free-joint rows are carried by the contacts (below 1e-9)."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    path = _reach(robot)
    lower, upper = velocity_limits(scene)
    ref = MotionReference(scene, path, lower, upper, speed=0.2)
    plan, timing, rm = ref.torques, ref.timing, robot.model
    assert len(plan.sigma) >= 5 and not plan.shortfalls
    m, nv = scene.model, rm.nv
    data = mujoco.MjData(m)
    Mv, J = np.zeros(m.nv), np.zeros((3, m.nv))
    for k, sigma in enumerate(plan.sigma):
        (i,), (alpha,) = timing.piece(np.array([sigma]))
        q = ref.q[i].copy()
        v = np.zeros(m.nv)
        if i < len(ref.q) - 1:
            mujoco.mj_differentiatePos(rm, v[:nv], 1.0, ref.q[i], ref.q[i + 1])
            mujoco.mj_integratePos(rm, q, v[:nv].copy(), alpha)
            v[:nv] /= timing.steps[i]
        qpos = scene.qpos_of(q)
        held = dy.joint_torques(m, data, qpos)
        contacts = [c for c in scene.touching(qpos) if not c.self_contact]
        support = ContactSupport(scene, data, contacts)
        forces = dy.contact_wrenches(point_contacts(contacts), support.wrench(held), solver="qp")
        for c, f in zip(contacts, forces, strict=True):
            mujoco.mj_jac(m, data, J, None, c.position, m.geom(c.robot_geom).bodyid[0])
            held -= J.T @ f[:3]
        np.testing.assert_allclose(plan.rest[k], held[:nv], atol=1e-9)
        np.testing.assert_allclose(holding_torques(scene, q), held, atol=1e-9)
        mujoco.mj_mulM(m, data, Mv, v)
        np.testing.assert_allclose(plan.inertia[k], support.carry(Mv)[:nv], atol=1e-9)
        for term in (plan.rest, plan.inertia, plan.velocity, plan.damping):
            assert np.max(np.abs(term[k][:6])) < 1e-9


def _every_knot(monkeypatch) -> None:
    """The plan on every knot of the grid (no knot skipped: today's rule before
    the refinement)."""
    monkeypatch.setattr(effort, "KNOT_TOLERANCE", -1.0)


def _solved_reach(robot: Robot) -> Waypoints:
    """The iterates of a full-body reach, as a sweep's case plays them (steps
    that shrink and turn as the solve converges)."""
    robot.reset_pose()
    path = Waypoints(robot, "reach")
    target = (np.array([0.5, -0.1, 0.6]), np.array([1.0, 0, 0, 0]))  # low, in front
    fullbody_inverse_kinematics(
        robot, [target], limbs=["rarm"], rotation_axis=[None], fix_feet=("rleg", "lleg"),
        revert_if_fail=False, callback=[path],
    )  # fmt: skip
    robot.reset_pose()
    assert len(path.q) > 10
    return path


def test_fewer_knots_keep_the_plan_and_the_motion_s_figures(monkeypatch):
    """The reach of the sample humanoid, the iterates of a solved reach and the
    arm raised too fast for its 3 N·m shoulder (test_drives), planned on the
    refined knots and on every knot of the grid: the refined knots are a subset
    (the reaches' at most 2/3); between them the plan stays within 2
    KNOT_TOLERANCE of the largest rest torque of the full one at every grid
    knot; the stretch is within 2 %; played, the
    same verdict, drift within 0.5 mm, slip within 0.05 mm, tracking within
    10 %."""
    raised = _robot('actuatorfrcrange="-3 3"')
    cases = []
    for robot, speed in ((Robot.from_model("sample_humanoid"), 0.2), (raised, 1.0)):
        path = (
            _reach(robot)
            if robot is not raised
            else Waypoints(robot.configuration.q.copy(), "raise")
        )
        if robot is raised:
            path.items.append(Waypoint(_arm_out(robot), "raise", 1))
        cases.append((Scene.from_robot(robot), path, speed))
    cases.append((cases[0][0], _solved_reach(cases[0][0].robot), 0.2))
    runs, tolerance = {}, effort.KNOT_TOLERANCE
    for label in ("refined", "every"):
        if label == "every":
            _every_knot(monkeypatch)
        runs[label] = []
        for scene, path, speed in cases:
            lower, upper = velocity_limits(scene)
            ref = MotionReference(scene, path, lower, upper, speed=speed)
            runs[label].append((ref, scene.play(path, speed=speed)))
    for (ref, report), (full, full_report), (scene, _, _) in zip(
        runs["refined"], runs["every"], cases, strict=True
    ):
        plan, every = ref.torques, full.torques
        assert set(plan.sigma) <= set(every.sigma)
        if scene.robot is not raised:  # the fast raise is not linear between its knots
            assert len(plan.sigma) <= 2 / 3 * len(every.sigma)
        np.testing.assert_allclose(ref.timing.stretch, full.timing.stretch, rtol=0.02)
        _, rate, accel = full.timing.progress(full.timing.times_of(every.sigma))
        dofs = scene.servo_dofs
        scale = np.abs(every.rest[:, dofs]).max()
        gap = np.abs(plan.at(every.sigma, rate, accel) - every.at(every.sigma, rate, accel))
        assert gap[:, dofs].max() <= 2 * tolerance * scale
        assert report.passed == full_report.passed
        assert abs(report.drift - full_report.drift) < 5e-4
        assert abs(report.slip - full_report.slip) < 5e-5
        assert report.tracking_error == pytest.approx(full_report.tracking_error, rel=0.1)


def test_a_grasped_object_resting_on_a_surface_does_not_carry_the_robot():
    """The kettle grasped where it stands on the counter: its weight is on the hand
    (the weld carries it), and its contacts with the counter do not hold the robot up,
    so the holding torques are those of the same scene with the kettle-counter
    contacts excluded by MuJoCo (``exclude``), to 1e-9 N·m, while a least-norm share
    of the robot's weight on the counter would change the legs' torques by N·m."""
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    q = robot.configuration.q.copy()
    held = Scene.from_robot(robot, grasps=[("rarm_end", "kettle")])
    apart = Scene.from_robot(
        robot, grasps=[("rarm_end", "kettle")], exclude=[("kettle", "counter")]
    )
    touching = held.touching(held.qpos_of(q))
    assert any(c.other_body == "counter" for c in touching if c.robot_geom.startswith("kettle"))
    assert not any(c.other_body == "counter" for c in apart.touching(apart.qpos_of(q)))
    tau = holding_torques(held, q)
    np.testing.assert_allclose(tau, holding_torques(apart, q), atol=1e-9)
    # the feet carry the robot and the kettle: the free joint's rows are ~0
    root = robot.model.jnt_dofadr[robot.model.body_jntadr[robot.root_body_id]]
    np.testing.assert_allclose(tau[root : root + 6], 0.0, atol=1e-6)


def test_one_zmp_formula_gives_the_old_formulas_values():
    """``dynamics.zmp_points`` (vectorized) on random wrenches equals, within
    1e-12 m, the two formulas it replaced: the ZMP plan's about the root body's
    origin in the polygon's frame, and ``zmp_from_wrench``'s about the world
    origin on the plane ``z``."""
    rng = np.random.default_rng(3)
    F = rng.normal(0, 50, (200, 3)) + np.array([0.0, 0.0, 400.0])
    n, o = rng.normal(0, 20, (200, 3)), rng.normal(0, 0.5, (200, 3))
    old_plan = np.column_stack(
        [o[:, 0] - (n[:, 1] + o[:, 2] * F[:, 0]) / F[:, 2],
         o[:, 1] - (o[:, 2] * F[:, 1] - n[:, 0]) / F[:, 2]]
    )  # fmt: skip
    np.testing.assert_allclose(dy.zmp_points(F, n, o), old_plan, rtol=0, atol=1e-12)
    for f, m, z in zip(F[:20], n[:20], rng.normal(0, 0.2, 20), strict=True):
        old = np.array([(z * f[0] - m[1]) / f[2], (z * f[1] + m[0]) / f[2]])
        np.testing.assert_allclose(dy.zmp_from_wrench(f, m, z), old, rtol=0, atol=1e-12)
        np.testing.assert_allclose(dy.zmp_points(f, m, 0.0, z), old, rtol=0, atol=1e-12)


def test_both_plans_read_one_evaluation_per_knot():
    """The reach's torque plan and ZMP plan on one ``PathDynamics``: each knot
    is evaluated once (the torque plan's knots are among the ZMP plan's), the
    plans equal those made apart, and the ZMP plan's points at rates equal,
    within 1e-12 m, the plan's formula before on its own four ``mj_inverse`` at
    ``(q̇, q̈)`` = ``(0, 0)``, ``(0, q')``, ``(±q', q'')``."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    path = _reach(robot)
    lower, upper = velocity_limits(scene)
    ref = MotionReference(scene, path, lower, upper, speed=0.2)
    dv = np.array([np.zeros(robot.model.nv)] * (len(ref.q) - 1))
    for i, d in enumerate(dv):
        mujoco.mj_differentiatePos(robot.model, d, 1.0, ref.q[i], ref.q[i + 1])
    shared = knots.PathDynamics(scene, ref.path)
    torques = effort.plan_torques(scene, ref.q, dv, ref.timing, dynamics=shared)
    evaluated = shared.evaluations
    plan = zmp.plan_zmp(scene, ref.path, dynamics=shared)
    apart = zmp.plan_zmp(scene, ref.path)
    assert shared.evaluations == len(zmp_knots := knots.knot_times(ref.path))
    assert set(torques.sigma) <= set(zmp_knots) and evaluated < len(zmp_knots)
    np.testing.assert_array_equal(torques.rest, ref.torques.rest)
    np.testing.assert_array_equal(plan.parts, apart.parts)
    k = len(plan.sigma)
    rate, accel = np.full(k, 0.8), np.full(k, 1.5)
    points = plan.points(rate, accel)
    m, rm, data = scene.model, robot.model, mujoco.MjData(scene.model)
    root = m.body(robot.root_body).id
    for j in range(0, k, 4):
        q, d1, d2 = ref.path.at(plan.sigma[j])
        v, a, zero = np.zeros(m.nv), np.zeros(m.nv), np.zeros(m.nv)
        v[: rm.nv], a[: rm.nv] = d1, d2
        g, acc, plus, minus = dy.inverse_dynamics(
            m, data, scene.qpos_of(q), np.array([zero, zero, v, -v]), np.array([zero, v, a, a])
        )
        Q = (g, acc - g, 0.5 * (plus + minus) - g, 0.5 * (plus - minus))
        region = scene.support(scene.touching(scene.qpos_of(q)), np.zeros(3), zmp.GROUND_SLOPE)[0]
        R, R_B = region.R, data.xmat[root].reshape(3, 3)
        w = Q[0] + Q[1] * accel[j] + Q[2] * rate[j] ** 2 + Q[3] * rate[j]
        F, n = R.T @ w[:3], R.T @ (R_B @ w[3:6])
        o = R.T @ data.xpos[root] - [0, 0, region.height]
        old = [o[0] - (n[1] + o[2] * F[0]) / F[2], o[1] - (o[2] * F[1] - n[0]) / F[2]]
        np.testing.assert_allclose(points[j], old, rtol=0, atol=1e-12)


def test_knot_contacts_and_supports_equal_touching_s():
    """The knots' contacts read from the probe's arrays at once
    (:func:`pik_mj.sim.knots.robot_contacts`) are ``scene.touching``'s, contact by
    contact (geom, point, normal into the robot, friction, self-contact), and
    the supports built from them (``ContactSupport.of_points``, at the knot's
    kinematics) hold and carry every term exactly as ``ContactSupport`` built
    from those contacts at ``scene.kinematics`` of the knot's pose."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    lower, upper = velocity_limits(scene)
    ref = MotionReference(scene, _reach(robot), lower, upper, speed=0.5)
    dynamics = knots.PathDynamics(scene, ref.path)
    data = mujoco.MjData(scene.model)
    for knot in dynamics.many(dynamics.sigma[::3], support=True):
        found, touching = knot.contacts, scene.touching(knot.qpos)
        assert len(touching) >= 4
        assert [scene.geom_names[g] for g in found.geom] == [c.robot_geom for c in touching]
        for name, value in (("points", "position"), ("normals", "normal")):
            np.testing.assert_array_equal(
                getattr(found, name), [getattr(c, value) for c in touching]
            )
        np.testing.assert_array_equal(found.friction, [c.friction for c in touching])
        np.testing.assert_array_equal(found.self_contact, [c.self_contact for c in touching])
        scene.kinematics(knot.q, data)
        reference = ContactSupport(scene, data, touching)
        np.testing.assert_array_equal(knot.support.hold(knot.rest), reference.hold(knot.rest))
        for term in (knot.inertia, knot.velocity, knot.damping):
            np.testing.assert_array_equal(knot.support.carry(term), reference.carry(term))


def test_the_knots_root_wrench_maps_give_the_wrench_of_the_free_joint_rows():
    """Each knot's ``T J_B^{-T}`` (:func:`pik_mj.sim.torques.root_wrench_maps`,
    formed for all knots at once) maps the free joint's rows ``τ_root`` to a
    wrench ``(f, n about the origin)`` whose moment about the root body's origin,
    ``n - p_WB × f``, through ``J_Bᵀ`` (``mj_jacBody`` at the knot's pose) gives
    ``τ_root`` back; and it is the map one knot's own kinematics give."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    lower, upper = velocity_limits(scene)
    ref = MotionReference(scene, _reach(robot), lower, upper, speed=0.5)
    dynamics = knots.PathDynamics(scene, ref.path)
    m, data = scene.model, mujoco.MjData(scene.model)
    b, dofs = robot.root_body_id, root_free_dofs(scene)
    rng = np.random.default_rng(3)
    for knot in dynamics.many(dynamics.sigma[::4]):
        scene.kinematics(knot.q, data)
        J_B = np.zeros((6, m.nv))
        mujoco.mj_jacBody(m, data, J_B[:3], J_B[3:], b)
        alone = root_wrench_maps(J_B[None, :, dofs], data.xpos[b][None])[0]
        np.testing.assert_array_equal(knot.root_wrench, alone)
        tau = rng.normal(0.0, 100.0, 6)
        f, n = np.split(knot.root_wrench @ tau, 2)
        about_body = np.concatenate([f, n - np.cross(data.xpos[b], f)])
        np.testing.assert_allclose(J_B[:, dofs].T @ about_body, tau, rtol=0, atol=1e-9)


def test_knot_regions_are_the_knot_by_knot_rule_s(monkeypatch):
    """``zmp.knot_regions`` on knots whose contacts drift slowly (past
    ``SAME_SUPPORT`` only over several knots), jump, change in number, vanish
    and come back: the same region for each knot, and as many regions formed,
    as the rule knot by knot (a knot keeps the region of the knot whose region
    was formed last while as many points lie within ``SAME_SUPPORT``)."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    formed: list[int] = []
    support_region = scene.support_region

    def counted(points):
        formed.append(len(points))
        return support_region(points)

    monkeypatch.setattr(scene, "support_region", counted)
    square = np.array([[0, 0, 0], [0.2, 0, 0], [0.2, 0.1, 0], [0, 0.1, 0]], float)
    rng = np.random.default_rng(5)
    points, shift = [], np.zeros(3)
    for k in range(60):
        shift[:2] += 0.4 * zmp.SAME_SUPPORT * rng.normal(size=2)  # a slow drift
        if k in (20, 21, 40):
            shift[0] += 0.01  # a jump
        n = 3 if 30 <= k < 35 else 0 if 45 <= k < 48 else 4
        points.append((square + shift)[:n])
    knots_ = [
        SimpleNamespace(
            contacts=knots.KnotContacts(
                np.zeros(len(p), int), p, np.tile([0.0, 0.0, 1.0], (len(p), 1)),
                np.ones(len(p)), np.zeros(len(p), bool),
            )
        )
        for p in points
    ]  # fmt: skip
    found = zmp.knot_regions(scene, knots_)
    formed_found, formed[:] = list(formed), []
    expected, seen, region = [], np.zeros((0, 3)), None
    for p in points:  # the rule, knot by knot
        if p.shape != seen.shape or np.abs(p - seen).max(initial=0) > zmp.SAME_SUPPORT:
            region, seen = support_region(p) if len(p) else None, p
            formed.append(len(p))
        expected.append(region)
    assert [r is e for r, e in zip(found, expected, strict=True)] == [True] * len(points)
    assert formed_found == formed and 8 < len(formed) < 40


def test_inverse_dynamics_of_many_configurations_is_each_one_s():
    """``inverse_dynamics_many`` equals ``inverse_dynamics`` configuration by
    configuration and each pair ``(q̇, q̈)`` alone (a whole ``mj_inverse``; the
    second pair repeats the first's velocity: its velocity stage is skipped),
    bitwise; it calls ``each(i)`` with the kinematics of configuration ``i``
    (the bodies' poses of ``mj_kinematics`` there) and leaves the constraint
    solver as it found it."""
    robot = Robot.from_model("sample_humanoid")
    m = robot.model
    rng = np.random.default_rng(3)
    q = np.tile(robot.configuration.q, (3, 1))
    q[:, 7:] += rng.uniform(-0.2, 0.2, (3, m.nq - 7))
    qvel, qacc = rng.normal(size=(3, 4, m.nv)), rng.normal(size=(3, 4, m.nv))
    qvel[:, 1] = qvel[:, 0]
    data, check = mujoco.MjData(m), mujoco.MjData(m)
    seen = []

    def each(i: int) -> None:
        check.qpos[:] = q[i]
        mujoco.mj_kinematics(m, check)
        seen.append(np.array_equal(data.xpos, check.xpos) and np.array_equal(data.xmat, check.xmat))

    flags = m.opt.disableflags
    many = dy.inverse_dynamics_many(m, data, q, qvel, qacc, each)
    assert seen == [True, True, True] and m.opt.disableflags == flags
    for i in range(3):
        np.testing.assert_array_equal(many[i], dy.inverse_dynamics(m, data, q[i], qvel[i], qacc[i]))
        for j in range(4):
            alone = dy.inverse_dynamics(m, data, q[i], qvel[i, j : j + 1], qacc[i, j : j + 1])
            np.testing.assert_array_equal(many[i, j], alone[0])
    Ma = np.zeros(m.nv)  # data at q[2]: at equal velocities the difference is M Δq̈
    mujoco.mj_mulM(m, data, Ma, qacc[2, 1] - qacc[2, 0])
    tau = dy.inverse_dynamics(m, data, q[2], qvel[2, :1].repeat(2, 0), qacc[2, :2])
    np.testing.assert_allclose(tau[1] - tau[0], Ma, atol=1e-9)


def test_point_contacts_limits_are_their_friction_pyramids():
    """``ContactDistribution.of_points``: ``A x`` is the forces' total and moment
    about the origin (``Σ f_i``, ``Σ p_i × f_i``), and ``G x ≤ h`` holds exactly
    when each force is inside its inscribed pyramid (``|f·e_k| ≤ μ/√2 f·n`` in the
    plane basis of its normal), checked on 400 random forces away from the
    faces."""
    rng = np.random.default_rng(5)
    n = 5
    points = rng.normal(size=(n, 3))
    normals = np.array([[0, 0, 1.0], [0, 0, 1.0], *rng.normal(size=(3, 3))])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    mu = np.array([0.8, 0.8, 0.5, 1.0, 0.3])
    problem = distribution.ContactDistribution.of_points(points, normals, mu)
    bases = [balance.plane_basis(v) for v in normals]
    checked, verdicts = 0, set()
    for _ in range(400):
        f = rng.normal(size=(n, 3)) + 2.0 * normals  # inside or not, both often
        x = f.reshape(-1)
        local = np.array([R.T @ fi for R, fi in zip(bases, f, strict=True)])  # (e1, e2, n)
        slack = mu[:, None] / np.sqrt(2) * local[:, 2:] - np.abs(local[:, :2])
        if np.min(np.abs(slack)) < 1e-6:
            continue
        rows = problem.G @ x <= problem.h
        inside = [bool(np.all(rows[problem.G[:, 3 * i : 3 * i + 3].any(axis=1)])) for i in range(n)]
        assert inside == np.all(slack > 0, axis=1).tolist()
        verdicts.update(inside)
        total = np.concatenate([f.sum(axis=0), np.cross(points, f).sum(axis=0)])
        np.testing.assert_allclose(problem.A @ x, total, atol=1e-12)
        checked += 1
    assert checked > 300 and verdicts == {True, False}


def test_a_path_not_finite_is_refused_before_its_knots():
    """The knots' poses are not checked one by one: a waypoint holding NaN is
    refused when the reference is made, naming the waypoint and the joint."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    path = _reach(robot)
    j = robot.model.joint(robot.limb("rarm").joints[0])
    path.items[2].q[j.qposadr[0]] = np.nan
    lower, upper = velocity_limits(scene)
    with pytest.raises(InvalidInput, match=rf"waypoint 2 of 5 .*{j.name}"):
        MotionReference(scene, path, lower, upper, speed=0.2)
