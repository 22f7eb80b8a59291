"""Every level keeps its priority on every iterate (docs/priority.md).

The stack: joint limits hard; both feet (level 1); the CoM pinned over its
start, or kept inside the feet's support polygon (level 2, ``check=False``:
not part of the stop test); the right hand 2 m out of reach (level 3);
posture (level 4). Watched on every iterate through the solve's callback:

* the feet within the drift bound (1e-4 m and rad) of their start;
* the CoM inside the support polygon (signed distance ≥ −bound), and, when
  pinned, within the bound of its start;
* the hand at the end: at the reachable minimum, the smallest hand error
  with the feet and the balance level held exactly, found independently by
  SciPy's SLSQP on the same MuJoCo kinematics (analytic Jacobians). Ending
  above it means the hand stalled; ending below it means a level above gave
  way.

Then: ``check`` changes no iterate; a task met with a small violation never
gets worse; feet that share level 1 with an unmet CoM target stay put (the
first iterate of ``fullbody_reach`` on Booster T1 lifted both soles 2.5 mm).
"""

from __future__ import annotations

import functools

import mink
import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie
from pik_mj.scenarios import fullbody_reach
from scipy.optimize import minimize

import pik_mj
from pik_mj.balance import convex_hull_2d
from pik_mj.robot.loading import load_model
from pik_mj.solve import TrustRegion
from pik_mj.spatial import skew
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.support_polygon import SupportPolygonTask

BOUND = TrustRegion().drift  # [m, rad]
FEET = ("rleg_end", "lleg_end")
HAND = "rarm_end"
# Sole rectangle of sample_humanoid (0.22 m x 0.12 m) in the sole site's frame.
SOLE = np.array([[0.11, 0.06, 0.0], [-0.11, 0.06, 0.0], [-0.11, -0.06, 0.0], [0.11, -0.06, 0.0]])
BACKENDS = ["osqp", "daqp-hqp"]
HAND_TOLERANCE = 2e-3  # [m, rad] above the reachable minimum after 50 iterations


@pytest.fixture(scope="module")
def model():
    return load_model("sample_humanoid")


def _start(model) -> mink.Configuration:
    cfg = mink.Configuration(model)
    cfg.update(model.key_qpos[0])
    return cfg


def _hand(cfg) -> mink.FrameTask:
    """The right hand's pose moved 2 m along world +x (out of reach)."""
    hand = mink.FrameTask(HAND, "site", position_cost=1.0, orientation_cost=1.0)
    now = cfg.get_transform_frame_to_world(HAND, "site")
    hand.set_target(mink.SE3.from_translation(np.array([2.0, 0.0, 0.0])) @ now)
    return hand


def _feet(cfg, kind: str) -> list:
    if kind == "pik":
        return [FrameTask(cfg, f, cfg.get_transform_frame_to_world(f, "site")) for f in FEET]
    feet = [mink.FrameTask(f, "site", position_cost=1.0, orientation_cost=1.0) for f in FEET]
    for f in feet:
        f.set_target_from_configuration(cfg)
    return feet


def _stack(cfg, feet_kind: str, balance_kind: str, check: bool = False, margin: float = 0.0):
    """``(levels, feet, polygon, balance, hand)``: feet › balance › hand › posture."""
    model = cfg.model
    feet = _feet(cfg, feet_kind)
    polygon = SupportPolygonTask(cfg, [(f, SOLE) for f in FEET], margin=margin, check=check)
    if balance_kind == "com":
        balance = CentroidTask(cfg, cfg.data.subtree_com[1].copy(), check=check)
    else:
        balance = polygon
    hand = _hand(cfg)
    posture = mink.PostureTask(model, cost=1e-2)
    posture.set_target_from_configuration(cfg)
    levels = [
        [mink.ConfigurationLimit(model)],
        feet,
        [balance],
        [hand],
        [pik_mj.MinkTask(posture, check=False)],
    ]
    return levels, feet, polygon, balance, hand


def _foot_error(foot, cfg) -> float:
    return float(np.linalg.norm(foot.compute_error(cfg)))


def _right_jacobian(phi: np.ndarray) -> np.ndarray:
    """``J_r`` of SO(3): ``exp(φ + δ) ≈ exp(φ) exp(J_r(φ) δ)``."""
    theta = float(np.linalg.norm(phi))
    K = skew(phi)
    if theta < 1e-8:
        return np.eye(3) - 0.5 * K
    return (
        np.eye(3)
        - (1.0 - np.cos(theta)) / theta**2 * K
        + (theta - np.sin(theta)) / theta**3 * K @ K
    )


@functools.cache
def reachable_minimum(balance_kind: str) -> float:
    """The smallest hand error ‖e‖ [m, rad] with both feet where they are and
    the CoM pinned (``"com"``) or inside the start's support polygon
    (``"polygon"``), joint limits as bounds: SLSQP over ``v`` with
    ``q = q0 ⊕ v`` (``mj_integratePos``), from the start pose. The Jacobians
    are MuJoCo's and mink's times ``d(q0 ⊕ v)/dv`` (``J_r`` on the free
    joint's rotation, the identity elsewhere)."""
    model = load_model("sample_humanoid")
    cfg = _start(model)
    q0 = cfg.q.copy()
    feet, hand = _feet(cfg, "mink"), _hand(cfg)
    c0 = cfg.data.subtree_com[1][:2].copy()
    corners = [cfg.data.site(f).xpos + SOLE @ cfg.data.site(f).xmat.reshape(3, 3).T for f in FEET]
    hull = convex_hull_2d(np.vstack(corners)[:, :2])
    edges = np.roll(hull, -1, axis=0) - hull
    inward = np.stack([-edges[:, 1], edges[:, 0]], axis=1)
    inward /= np.linalg.norm(inward, axis=1)[:, None]
    offset = -(inward * hull).sum(axis=1)  # distance inside edge i: inward_i · c + offset_i
    free = model.jnt_dofadr[0]  # the floating base (its rotation: dofs free+3..free+6)
    cache: dict = {}

    def at(v: np.ndarray) -> dict:
        if cache.get("v") is None or not np.array_equal(cache["v"], v):
            q = q0.copy()
            mujoco.mj_integratePos(model, q, v, 1.0)
            cfg.update(q)
            D = np.eye(model.nv)
            D[free + 3 : free + 6, free + 3 : free + 6] = _right_jacobian(v[free + 3 : free + 6])
            J_com = np.zeros((3, model.nv))
            mujoco.mj_jacSubtreeCom(model, cfg.data, J_com, 1)
            cache.update(
                v=v.copy(),
                e=hand.compute_error(cfg),
                J_e=hand.compute_jacobian(cfg) @ D,
                f=np.concatenate([t.compute_error(cfg) for t in feet]),
                J_f=np.vstack([t.compute_jacobian(cfg) for t in feet]) @ D,
                c=cfg.data.subtree_com[1][:2].copy(),
                J_c=J_com[:2] @ D,
            )
        return cache

    constraints = [{"type": "eq", "fun": lambda v: at(v)["f"], "jac": lambda v: at(v)["J_f"]}]
    if balance_kind == "com":
        constraints.append(
            {"type": "eq", "fun": lambda v: at(v)["c"] - c0, "jac": lambda v: at(v)["J_c"]}
        )
    else:
        constraints.append(
            {
                "type": "ineq",
                "fun": lambda v: inward @ at(v)["c"] + offset,
                "jac": lambda v: inward @ at(v)["J_c"],
            }
        )
    hinges = model.jnt_qposadr[1:]
    bounds = [(None, None)] * 6 + list(
        zip(model.jnt_range[1:, 0] - q0[hinges], model.jnt_range[1:, 1] - q0[hinges], strict=True)
    )
    result = minimize(
        lambda v: float(at(v)["e"] @ at(v)["e"]),
        np.zeros(model.nv),
        jac=lambda v: 2.0 * at(v)["J_e"].T @ at(v)["e"],
        bounds=bounds,
        constraints=constraints,
        method="SLSQP",
        options={"maxiter": 300, "ftol": 1e-12},
    )
    assert result.success, result.message
    found = at(result.x)
    assert np.abs(found["f"]).max() <= 1e-9  # the feet held
    return float(np.linalg.norm(found["e"]))


@pytest.mark.parametrize("qp_solver", BACKENDS)
@pytest.mark.parametrize("feet_kind", ["mink", "pik"])
@pytest.mark.parametrize("balance_kind", ["com", "polygon"])
def test_an_unchecked_balance_level_holds_on_every_iterate(
    model, qp_solver, feet_kind, balance_kind
):
    """Feet within 1e-4, the CoM inside the polygon (and, pinned, within 1e-4
    of its start) on every iterate, the hand at its reachable minimum at the
    end. Before the fix the unchecked level was unprotected: the CoM left the
    polygon by up to 0.6 m (``daqp-hqp``) and ``daqp-hqp``'s hand ended
    further than it started."""
    cfg = _start(model)
    levels, feet, polygon, balance, hand = _stack(cfg, feet_kind, balance_kind)
    start = float(np.linalg.norm(hand.compute_error(cfg)))
    feet_errors, margins, com_errors = [], [], []

    def watch(info):
        c = info.configuration
        feet_errors.append(max(_foot_error(f, c) for f in feet))
        margins.append(polygon.signed_distance(c))
        com_errors.append(float(np.linalg.norm(balance.compute_error(c))))

    result = pik_mj.solve(
        cfg, levels, stop=50, revert_if_fail=False, qp_solver=qp_solver, callback=watch
    )
    assert result.iterations == len(feet_errors) == 50
    assert max(feet_errors) <= BOUND
    assert min(margins) >= -BOUND
    assert max(com_errors) <= BOUND
    end = float(np.linalg.norm(hand.compute_error(cfg)))
    reference = reachable_minimum(balance_kind)
    assert start - end > 0.7  # from 2 m to about 1.1-1.2 m
    assert reference - 5e-4 <= end <= reference + HAND_TOLERANCE, (end, reference)


@pytest.mark.parametrize("qp_solver", BACKENDS)
def test_check_changes_no_iterate(model, qp_solver):
    """``check`` decides convergence only: with the hand out of reach (never
    converged) the iterates are the same, bit for bit, whether the polygon
    level is checked or not."""
    paths = []
    for check in (True, False):
        cfg = _start(model)
        levels, *_ = _stack(cfg, "mink", "polygon", check=check)
        path: list[np.ndarray] = []
        pik_mj.solve(
            cfg,
            levels,
            stop=20,
            revert_if_fail=False,
            qp_solver=qp_solver,
            callback=lambda info, p=path: p.append(info.configuration.q.copy()),
        )
        paths.append(np.array(path))
    np.testing.assert_array_equal(paths[0], paths[1])


@pytest.mark.parametrize("qp_solver", BACKENDS)
def test_a_level_met_with_a_small_violation_never_gets_worse(model, qp_solver):
    """The polygon shrunk so that the start's CoM is 0.5 mm outside it: within
    its stop test (``centroid_thre`` 1 mm), so the level is kept, and its
    violation stays at most 0.5 mm on every iterate (never worse than when it
    was met), while the hand pulls the CoM towards it."""
    cfg = _start(model)
    probe = SupportPolygonTask(cfg, [(f, SOLE) for f in FEET])
    inside = probe.signed_distance(cfg)
    levels, _, polygon, _, _ = _stack(cfg, "mink", "polygon", margin=inside + 5e-4)
    violation = [float(polygon.compute_error(cfg).max())]
    assert violation[0] == pytest.approx(5e-4, abs=1e-12)

    def watch(info):
        violation.append(float(polygon.compute_error(info.configuration).max()))

    pik_mj.solve(cfg, levels, stop=30, revert_if_fail=False, qp_solver=qp_solver, callback=watch)
    assert max(violation) <= 5e-4 + 1e-12
    assert min(violation) < 1e-4  # the level's own step took the violation off


@pytest.mark.parametrize("qp_solver", BACKENDS)
def test_feet_beside_an_unmet_com_target_stay_put(model, qp_solver):
    """Feet and a CoM target 4 cm forward share level 1 (the full-body IK's
    stack): the feet, met at the start, stay within 1e-4 m on every iterate
    while the level moves the CoM (before the fix the first iterate moved
    them by 0.8-3 mm), and the CoM reaches its target."""
    cfg = _start(model)
    feet = _feet(cfg, "mink")
    target = cfg.data.subtree_com[1].copy() + np.array([0.04, 0.0, 0.0])
    com = CentroidTask(cfg, target)
    posture = mink.PostureTask(model, cost=1e-2)
    posture.set_target_from_configuration(cfg)
    levels = [
        [mink.ConfigurationLimit(model)],
        [*feet, com],
        [pik_mj.MinkTask(posture, check=False)],
    ]
    drift: list[float] = []
    result = pik_mj.solve(
        cfg,
        levels,
        stop=30,
        qp_solver=qp_solver,
        callback=lambda info: drift.append(max(_foot_error(f, info.configuration) for f in feet)),
    )
    assert result.converged, result.summary()
    assert max(drift) <= BOUND
    assert np.linalg.norm(com.compute_error(cfg)) <= 1e-3


def test_booster_t1_fullbody_reach_keeps_the_feet_on_every_iterate():
    """``pik-mj run fullbody_reach --model booster_t1``: the feet (level 1,
    beside the CoM, which starts 4 cm off the feet's midpoint) within 1e-4 m
    of their start on every iterate (both soles rose 2.5 mm at the first)."""
    requires_menagerie("booster_t1")
    robot = pik_mj.Robot.from_model(
        "booster_t1", required_limbs=[*fullbody_reach.FEET, fullbody_reach.HAND]
    )
    limbs = [robot.limb(leg) for leg in fullbody_reach.FEET]
    start = [robot.frame_pose(limb.end_frame, limb.end_frame_type) for limb in limbs]
    p_mid = 0.5 * (start[0].translation() + start[1].translation())
    moved: list[float] = []

    def watch(info):
        now = [robot.frame_pose(limb.end_frame, limb.end_frame_type) for limb in limbs]
        moved.append(
            max(np.linalg.norm((s.inverse() @ n).log()) for s, n in zip(start, now, strict=True))
        )

    result = pik_mj.fullbody_inverse_kinematics(
        robot,
        [(fullbody_reach.hand_target(robot, "booster_t1"), np.array([1.0, 0.0, 0.0, 0.0]))],
        limbs=[fullbody_reach.HAND],
        rotation_axis=[None],
        target_centroid_pos=p_mid,
        centroid_axes="z",
        stop=100,
        callback=watch,
    )
    assert result.converged, result.summary()
    assert len(moved) == result.iterations
    assert max(moved) <= BOUND


@pytest.mark.parametrize("qp_solver", BACKENDS)
def test_a_task_holds_what_it_weights(model, qp_solver):
    """A posture weighting only the left arm's joints (cost 0 elsewhere) at
    level 1 with the feet, not checked: its rows ask nothing of the other
    joints, so the right hand reaching below it moves them freely, while the
    left arm's joints stay within 1e-4 rad of their start on every iterate."""
    cfg = _start(model)
    left_arm = [
        model.jnt_dofadr[j] for j in range(model.njnt) if model.joint(j).name.startswith("larm")
    ]
    cost = np.zeros(model.nv)
    cost[left_arm] = 1.0
    keep = mink.PostureTask(model, cost=cost)
    keep.set_target_from_configuration(cfg)
    hand = _hand(cfg)
    levels = [
        [mink.ConfigurationLimit(model)],
        [*_feet(cfg, "mink"), pik_mj.MinkTask(keep, check=False)],
        [hand],
    ]
    q0 = cfg.q.copy()
    arm, moved = [], []

    def watch(info):
        dq = np.zeros(model.nv)
        mujoco.mj_differentiatePos(model, dq, 1.0, q0, info.configuration.q)
        arm.append(float(np.abs(dq[left_arm]).max()))
        moved.append(float(np.abs(dq).max()))

    pik_mj.solve(cfg, levels, stop=20, revert_if_fail=False, qp_solver=qp_solver, callback=watch)
    assert len(left_arm) >= 3 and max(arm) <= BOUND
    assert max(moved) > 0.3  # the rest of the body moved [rad or m]
    assert np.linalg.norm(hand.compute_error(cfg)) < 0.6  # from 2 m: the body leans


def test_a_mink_task_is_met_on_what_it_weights(model):
    """A ``mink.PostureTask`` weighting the left arm only: moving the right
    arm's joints by 0.3 rad leaves its error norm 0 and its stop test met;
    moving a left-arm joint by 2 mm [rad] makes the error 2e-3 and the stop
    test fail (threshold 1e-3)."""
    cfg = _start(model)
    left = [
        model.jnt_qposadr[j] for j in range(model.njnt) if model.joint(j).name.startswith("larm")
    ]
    right = [
        model.jnt_qposadr[j] for j in range(model.njnt) if model.joint(j).name.startswith("rarm")
    ]
    cost = np.zeros(model.nv)
    cost[
        [model.jnt_dofadr[j] for j in range(model.njnt) if model.joint(j).name.startswith("larm")]
    ] = 1
    posture = mink.PostureTask(model, cost=cost)
    posture.set_target_from_configuration(cfg)
    task = pik_mj.MinkTask(posture, check=False)
    q = cfg.q.copy()
    q[right] += 0.3
    cfg.update(q)
    state = task.evaluate(cfg)
    assert np.abs(task.compute_error(cfg)).max() == pytest.approx(0.3)  # mink's own error
    assert state.error == 0.0 and state.satisfied and task.is_satisfied(cfg)
    q[left[0]] += 2e-3
    cfg.update(q)
    state = task.evaluate(cfg)
    assert state.error == pytest.approx(2e-3) and not state.satisfied
    assert not task.is_satisfied(cfg)


def test_rows_residual_norm_counts_the_rows_that_constrain():
    """``‖[(A x − b)_{w > 0}; dist(C x, [d_l, d_u])]‖`` against the same
    written with a boolean mask and ``np.clip``."""
    rng = np.random.default_rng(7)
    nv = 6
    w = np.array([1.0, 0.0, 2.5, 0.0, 1e-3])
    lo = np.array([-np.inf, -0.1, 0.2])
    hi = np.array([0.4, np.inf, 0.3])
    rows = pik_mj.TaskRows(
        rng.normal(size=(5, nv)),
        rng.normal(size=5),
        w,
        rng.normal(size=(3, nv)),
        lo,
        hi,
        np.ones(3),
    )
    for x in (None, *rng.normal(size=(5, nv))):
        z = np.zeros(nv) if x is None else x
        r_eq = (rows.A @ z - rows.b)[w > 0]
        cx = rows.C @ z
        expected = np.linalg.norm(np.concatenate([r_eq, cx - np.clip(cx, lo, hi)]))
        assert rows.residual_norm(x) == pytest.approx(expected, abs=1e-12)
    assert rows._replace(w_A=np.ones(5)).residual_norm() > rows.residual_norm()
