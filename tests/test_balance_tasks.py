"""Support-polygon and SCFR tasks: Jacobians (moving vertices), regions, stacks.

* Row values ``d(q)`` (signed distances) against central finite differences
  along each tangent direction (``mj_integratePos``, eps 1e-6, tol 1e-6), with
  the hull structure / SCFR region frozen at the linearization point.
* Distances against :func:`pik_mj.balance.support_polygon` (independent hull).
* A humanoid stack in which the CoM must stay in the shrunk polygon at every
  iteration while a hand reaches far forward.
* SCFR of two flat feet = their hull; a hand on a wall lets the CoM lean further.
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np
import pytest
from fd import fd_jacobian

import pik_mj
from pik_mj.balance import ContactConstraint, contact_from_normal, foot_contact, support_polygon
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.robot.loading import load_model
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.joint_limit import JointLimitTask
from pik_mj.tasks.scfr import AttachedContact, ScfrTask
from pik_mj.tasks.support_polygon import SupportPolygonTask

EPS = 1e-6
TOL = 1e-6

# Sole rectangle of sample_humanoid (0.22 m x 0.12 m) in the sole site's frame.
SOLE = np.array([[0.11, 0.06, 0.0], [-0.11, 0.06, 0.0], [-0.11, -0.06, 0.0], [0.11, -0.06, 0.0]])
SOLE_CONTACT = ContactConstraint(np.zeros(3), np.eye(3), half_x=0.11, half_y=0.06, mu=10.0)


def random_posture(model: mujoco.MjModel, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = model.qpos0.copy()
    for j in range(model.njnt):
        a = model.jnt_qposadr[j]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            quat = np.r_[1.0, rng.normal(scale=0.15, size=3)]
            q[a : a + 3] += rng.normal(scale=0.1, size=3)
            q[a + 3 : a + 7] = quat / np.linalg.norm(quat)
        elif model.jnt_limited[j]:
            lo, hi = model.jnt_range[j]
            q[a] = 0.5 * (lo + hi) + 0.4 * (hi - lo) * rng.uniform(-1, 1)
    return q


@pytest.fixture(scope="module")
def humanoid():
    return load_model("dm_humanoid")


@pytest.fixture(scope="module")
def sample():
    return load_model("sample_humanoid")


def configured(model, q) -> mink.Configuration:
    cfg = mink.Configuration(model)
    cfg.update(q)
    return cfg


# ----------------------------------------------------------------- support polygon


@pytest.mark.parametrize("seed", [0, 1])
def test_support_polygon_jacobian_with_moving_vertices_fd(humanoid, seed):
    q = random_posture(humanoid, seed)
    cfg = configured(humanoid, q)
    rect = np.array([[0.1, 0.04, -0.03], [-0.08, 0.05, -0.03], [-0.08, -0.05, -0.03]])
    fixed = np.array([[0.6, 0.0, 0.0], [0.6, 0.1, 0.0]])  # a fixed (world) edge
    task = SupportPolygonTask(
        cfg, [("right_foot", rect), ("left_foot", rect, "body"), fixed], normal=(0.1, -0.2, 1.0)
    )
    hull = task.hull(cfg)
    moving = [i for i in hull if i < 6]
    assert len(moving) >= 2  # edges with moving vertices are tested
    # Vertex Jacobians on their own.
    JP_fd = fd_jacobian(humanoid, q, lambda c: task.points(c).ravel())
    cfg.update(q)
    assert np.max(np.abs(JP_fd - task.point_jacobians(cfg).reshape(-1, humanoid.nv))) < TOL
    # Signed distances with the hull structure frozen.
    J_fd = fd_jacobian(humanoid, q, lambda c: task.edge_distances(c, hull))
    cfg.update(q)
    rows = task.compute_rows(cfg)
    assert np.max(np.abs(J_fd - rows.C)) < TOL
    assert np.max(np.abs(J_fd - task.edge_jacobian(cfg, hull))) < TOL
    # Dropping the vertex motion would be wrong by much more than the tolerance.
    assert np.max(np.abs(JP_fd)) > 0.1


def test_support_polygon_distances_match_the_balance_module(sample):
    q = random_posture(sample, 4)
    cfg = configured(sample, q)
    task = SupportPolygonTask(cfg, [("rleg_end", SOLE), ("lleg_end", SOLE)], margin=0.02)
    feet = [
        cfg.data.site(s).xpos + SOLE @ cfg.data.site(s).xmat.reshape(3, 3).T
        for s in ("rleg_end", "lleg_end")
    ]
    region = support_polygon(feet)
    com = cfg.data.subtree_com[1]
    assert task.signed_distance(cfg) == pytest.approx(region.signed_distance(com), abs=1e-12)
    rows = task.compute_rows(cfg)
    assert np.allclose(rows.d_lower, 0.02 - task.edge_distances(cfg))
    assert len(rows.d_lower) == len(region.vertices_2d)
    inside = task.signed_distance(cfg) >= 0.02 - 1e-3
    assert task.is_satisfied(cfg) == inside


# ----------------------------------------------------------------------------- SCFR


def test_scfr_jacobian_fd_with_frozen_region(sample):
    q = random_posture(sample, 5)
    cfg = configured(sample, q)
    # Tilted feet with ample friction can hold the CoM anywhere: bound the region.
    task = ScfrTask(
        cfg,
        [("rleg_end", SOLE_CONTACT), AttachedContact("lleg_end", SOLE_CONTACT)],
        bounds=(-2.0, 2.0, -2.0, 2.0),
    )
    region = task.region(cfg)
    assert len(region.vertices) >= 4
    J_fd = fd_jacobian(sample, q, lambda c: task.distances(c, region))
    cfg.update(q)
    rows = task.compute_rows(cfg)
    assert np.max(np.abs(J_fd - rows.C)) < TOL
    assert np.allclose(rows.d_lower, -task.distances(cfg, region))


def test_scfr_of_two_flat_feet_is_their_support_hull(sample):
    cfg = configured(sample, sample.key_qpos[0].copy())
    sp = SupportPolygonTask(cfg, [("rleg_end", SOLE), ("lleg_end", SOLE)])
    scfr = ScfrTask(cfg, [("rleg_end", SOLE_CONTACT), ("lleg_end", SOLE_CONTACT)])
    hull = sp.region(cfg)
    region = scfr.region(cfg)
    # Hausdorff distance between the two convex polygons (vertices suffice).
    a = max(abs(hull.signed_distance(np.r_[v, 0.0])) for v in region.vertices)
    b = max(abs(region.signed_distance(v)) for v in hull.vertices_2d)
    assert max(a, b) <= 1e-3
    assert region.area == pytest.approx(hull.area, rel=1e-2)
    # Same CoM distance to the boundary.
    assert np.min(scfr.distances(cfg)) == pytest.approx(sp.signed_distance(cfg), abs=1e-3)


def test_scfr_region_is_cached_until_a_contact_moves(sample):
    q = sample.key_qpos[0].copy()
    cfg = configured(sample, q)
    task = ScfrTask(cfg, [("rleg_end", SOLE_CONTACT), ("lleg_end", SOLE_CONTACT)])
    task.compute_rows(cfg)
    q2 = q.copy()
    q2[2] += 1e-8  # pelvis up by 10 nm: under cache_tol
    cfg.update(q2)
    task.compute_rows(cfg)
    task.is_satisfied(cfg)
    assert task.region_computations == 1
    q2[0] += 0.05  # the whole robot 5 cm forward: recomputed, and the region follows
    cfg.update(q2)
    before = task._cache_region
    task.compute_rows(cfg)
    assert task.region_computations == 2
    moved = task.region(cfg).vertices.mean(0) - before.vertices.mean(0)
    assert np.allclose(moved, [0.05, 0.0])


def test_scfr_external_push_shifts_the_region_by_the_moment_balance(sample):
    cfg = configured(sample, sample.key_qpos[0].copy())
    feet = [("rleg_end", SOLE_CONTACT), ("lleg_end", SOLE_CONTACT)]
    force, height = 50.0, 1.0  # [N] forward push at 1 m
    pushed = ScfrTask(
        cfg,
        feet,
        external=lambda c: [pik_mj.balance.ExternalWrench([0, 0, height], [force, 0, 0])],
    )
    plain = ScfrTask(cfg, feet)
    g = -sample.opt.gravity[2]
    # m g c_x + h f_x must stay in m g [x_min, x_max]:  Δc_x = -h f_x / (m g).
    expected = -height * force / (plain.mass * g)
    shift = pushed.region(cfg).vertices.mean(0) - plain.region(cfg).vertices.mean(0)
    assert shift[0] == pytest.approx(expected, abs=1e-3)
    assert abs(shift[1]) <= 1e-3


def test_scfr_empty_region_raises(sample):
    cfg = configured(sample, sample.key_qpos[0].copy())
    # A ceiling contact only (pushes down): nothing holds the robot up.
    ceiling = contact_from_normal([0, 0, 2.0], [0, 0, -1.0], 0.1, 0.1, mu=0.5)
    task = ScfrTask(cfg, [ceiling], bounds=(-1, 1, -1, 1))
    with pytest.raises(PikError, match="empty"):
        task.compute_rows(cfg)


def test_evaluate_is_rows_error_and_stop_test_of_one_configuration(sample):
    """The balance tasks and the joint limits evaluate once per iteration: the
    rows, error norm and stop test of ``evaluate`` are bit for bit those of
    ``compute_rows``, ``compute_error`` and ``is_satisfied``, in postures inside
    and outside the margins and limits (an empty SCFR region: the same error)."""
    verdicts: dict[str, set[bool]] = {}
    for seed in range(6):
        q = random_posture(sample, seed)
        if seed % 2:  # beyond the joints' limits
            hinge = sample.jnt_type != mujoco.mjtJoint.mjJNT_FREE
            q[sample.jnt_qposadr[hinge]] += 2.0 * (seed - 3)
        cfg = configured(sample, q)
        margin = 0.3 * (seed % 3) - 0.1  # inside, beyond and far beyond the polygon's edges
        tasks = [
            SupportPolygonTask(cfg, [("rleg_end", SOLE), ("lleg_end", SOLE)], margin=margin),
            ScfrTask(
                cfg,
                [("rleg_end", SOLE_CONTACT), ("lleg_end", SOLE_CONTACT)],
                margin=margin,
                bounds=(-2.0, 2.0, -2.0, 2.0),
            ),
            JointLimitTask.all_limited(cfg),
        ]
        for task in tasks:
            try:
                rows, error = task.compute_rows(cfg), task.compute_error(cfg)
            except PikError:  # tilted feet no friction holds: the same error either way
                with pytest.raises(PikError, match="empty"):
                    task.evaluate(cfg)
                continue
            state = task.evaluate(cfg)
            for got, expected in zip(state.rows, rows, strict=True):
                np.testing.assert_array_equal(got, expected)
            assert state.error == float(np.linalg.norm(error))
            assert state.satisfied is task.is_satisfied(cfg)
            verdicts.setdefault(type(task).__name__, set()).add(state.satisfied)
    assert verdicts["SupportPolygonTask"] == {True, False}
    assert verdicts["JointLimitTask"] == {True, False}
    assert "ScfrTask" in verdicts


# --------------------------------------------------------------------------- stacks


def _feet(cfg):
    return [
        FrameTask(cfg, s, cfg.get_transform_frame_to_world(s, "site"))
        for s in ("rleg_end", "lleg_end")
    ]


def _posture(cfg, q0):
    posture = mink.PostureTask(cfg.model, cost=1e-2)
    posture.set_target(q0)
    return pik_mj.MinkTask(posture, check=False)


def _reach(sample, balance: str):
    """Feet + balance at level 1, the right hand 1.2 m in front of the chest at level 2."""
    q0 = sample.key_qpos[0].copy()
    cfg = configured(sample, q0)
    feet = _feet(cfg)
    sp = SupportPolygonTask(cfg, [("rleg_end", SOLE), ("lleg_end", SOLE)], margin=0.02)
    pinned = CentroidTask(cfg, cfg.data.subtree_com[1].copy())
    target = cfg.data.body("torso_chest").xpos + np.array([1.2, 0.0, 0.0])
    hand = FrameTask(cfg, "rarm_end", (target, [1, 0, 0, 0]), rotation_axis=None)
    extra = {"polygon": [sp], "pinned": [pinned], "none": []}[balance]
    levels = [[JointLimitTask.all_limited(cfg)], [*feet, *extra], [hand], [_posture(cfg, q0)]]
    margins, drift = [], []

    def record(info):
        margins.append(sp.signed_distance(info.configuration))
        drift.append(max(np.linalg.norm(f.compute_error(info.configuration)[:3]) for f in feet))

    result = pik_mj.solve(cfg, levels, stop=50, revert_if_fail=False, callback=record)
    reach = float(np.linalg.norm(hand.compute_error(cfg)))
    return result, reach, min(margins), max(drift)


def test_humanoid_reaching_keeps_the_com_in_the_shrunk_polygon_every_iteration(sample):
    result, reach, margin, drift = _reach(sample, "polygon")
    _, reach_pinned, _, _ = _reach(sample, "pinned")
    _, reach_free, margin_free, _ = _reach(sample, "none")
    print(
        f"\nhand distance: polygon {reach:.4f} m, CoM pinned {reach_pinned:.4f} m, "
        f"unconstrained {reach_free:.4f} m; min CoM margin {margin:.5f} m "
        f"(unconstrained {margin_free:.4f} m); max foot drift {drift:.2e} m; "
        f"{result.iterations} iterations"
    )
    assert result.iterations == 50
    assert margin >= 0.02 - 1e-4  # never left the polygon shrunk by 2 cm
    assert drift <= 1e-4
    # Leaning (CoM free inside the polygon) reaches further than a pinned CoM ...
    assert reach < reach_pinned - 0.05
    # ... and the polygon was what stopped it: without it the CoM leaves the feet.
    assert reach_free < reach - 0.05 and margin_free < -0.05


def test_hand_on_a_wall_lets_the_com_lean_further_than_the_support_polygon(sample):
    q0 = sample.key_qpos[0].copy()
    wall_point = np.array([0.55, -0.2, 1.0])
    wall = contact_from_normal(wall_point, [-1.0, 0.0, 0.0], mu=0.5, fz_max=150.0)
    results = {}
    for kind in ("scfr", "polygon"):
        cfg = configured(sample, q0)
        hand = FrameTask(cfg, "rarm_end", (wall_point, [1, 0, 0, 0]), rotation_axis=None)
        if kind == "scfr":
            # The lean pushes the CoM onto the region's boundary; 1 mm of margin
            # keeps the independent equilibrium LP below off that knife edge.
            balance = ScfrTask(
                cfg,
                [("rleg_end", SOLE_CONTACT), ("lleg_end", SOLE_CONTACT), wall],
                cache_tol=1e-4,
                margin=1e-3,
            )
        else:
            balance = SupportPolygonTask(cfg, [("rleg_end", SOLE), ("lleg_end", SOLE)])
        lean = CentroidTask(cfg, [0.6, -0.1, 0.0])
        levels = [
            [JointLimitTask.all_limited(cfg)],
            [*_feet(cfg), hand, balance],
            [lean],
            [_posture(cfg, q0)],
        ]
        pik_mj.solve(cfg, levels, stop=30, revert_if_fail=False)
        assert hand.is_satisfied(cfg) and balance.is_satisfied(cfg)
        results[kind] = cfg.data.subtree_com[1].copy()
        if kind == "scfr":
            # Independent check: the final CoM is statically balanced by the contacts.
            contacts = balance.contacts_now(cfg)
            eq = pik_mj.balance.static_equilibrium(contacts, balance.mass, results[kind])
            assert eq.feasible
            print(f"\nSCFR computations: {balance.region_computations}")
    print(f"CoM x: SCFR {results['scfr'][0]:.3f} m, support polygon {results['polygon'][0]:.3f} m")
    assert results["scfr"][0] > results["polygon"][0] + 0.1


# ------------------------------------------------------------------------- bad input


def test_bad_inputs_raise_clear_errors(sample):
    cfg = configured(sample, sample.key_qpos[0].copy())
    with pytest.raises(InvalidInput, match="empty"):
        SupportPolygonTask(cfg, [])
    with pytest.raises(InvalidInput, match=r"\(k, 3\)"):
        SupportPolygonTask(cfg, [np.zeros((4, 2))])
    with pytest.raises(InvalidInput, match="NaN"):
        SupportPolygonTask(cfg, [np.full((3, 3), np.nan)])
    with pytest.raises(UnknownName, match="rleg_end"):
        SupportPolygonTask(cfg, [("rfoot", SOLE)])
    with pytest.raises(InvalidInput, match="span no area"):
        SupportPolygonTask(cfg, [np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])])
    with pytest.raises(InvalidInput, match="w must be > 0"):
        SupportPolygonTask(cfg, [("rleg_end", SOLE)], w=0.0)
    with pytest.raises(InvalidInput, match="margin"):
        SupportPolygonTask(cfg, [("rleg_end", SOLE)], margin=np.nan)
    with pytest.raises(InvalidInput, match="non-zero"):
        SupportPolygonTask(cfg, [("rleg_end", SOLE)], normal=(0, 0, 0))
    with pytest.raises(InvalidInput, match="mu must be >= 0"):
        foot_contact([0, 0, 0], 0.0, 0.1, 0.05, mu=-0.5)
    with pytest.raises(InvalidInput, match="contacts is empty"):
        ScfrTask(cfg, [])
    with pytest.raises(InvalidInput, match="ContactConstraint"):
        ScfrTask(cfg, [np.zeros(3)])
    with pytest.raises(InvalidInput, match="ContactConstraint"):
        ScfrTask(cfg, [("rleg_end", "not a contact")])
    with pytest.raises(UnknownName, match="lleg_end"):
        ScfrTask(cfg, [("nowhere", SOLE_CONTACT)])
    with pytest.raises(InvalidInput, match="ExternalWrench"):
        ScfrTask(cfg, [SOLE_CONTACT], external=[(0, 0, 0)])
    with pytest.raises(InvalidInput, match="gravity"):
        ScfrTask(cfg, [SOLE_CONTACT], gravity=(0, 0, 0))
    with pytest.raises(InvalidInput, match="tol > 0"):
        ScfrTask(cfg, [SOLE_CONTACT], tol=0.0)
    assert "SupportPolygonTask" in repr(SupportPolygonTask(cfg, [("rleg_end", SOLE)]))
    assert "ScfrTask" in repr(ScfrTask(cfg, [SOLE_CONTACT]))
