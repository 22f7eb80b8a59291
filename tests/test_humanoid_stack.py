"""The reference whole-body stack on dm_control's humanoid (issue: the cascade).

Feet (pose) at level 1, a hand (pose) at level 2, posture at level 3, joint
limits hard.
"""

from __future__ import annotations

import cases
import mink
import numpy as np
import pytest

import pik_mj
from pik_mj.solve import CORRECT_ABOVE, TaskReport, TrustRegion
from pik_mj.solve.evaluation import Point
from pik_mj.solve.trust_region import predicted_decrease
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.mink_adapter import as_task
from pik_mj.tasks.task import TaskRows, TaskState


@pytest.fixture(scope="module")
def model():
    return cases.dm_humanoid()


@pytest.fixture(scope="module")
def targets(model):
    return cases.reachable_hand_targets(model, 100, seed=0)


def test_reachable_targets_all_converge_within_50_iterations(model, targets):
    cfg = mink.Configuration(model)
    iterations = []
    for target in targets:
        cfg.update(cases.stance(model))
        stack = cases.reach_stack(cfg, target)
        result = pik_mj.solve(cfg, stack.levels, stop=50)
        assert result.converged, result.summary()
        # 1 mm / 1 degree on every foot and on the hand.
        for task in [*stack.feet, stack.hand]:
            e = task.compute_error(cfg)
            assert np.linalg.norm(e[:3]) <= 1e-3 and np.linalg.norm(e[3:]) <= np.deg2rad(1)
        iterations.append(result.iterations)
    assert len(iterations) == 100
    assert np.median(iterations) <= 20


def test_unreachable_hand_keeps_feet_fixed_every_iteration(model):
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    target = cases.unreachable_hand_target(cfg, 2.0)
    stack = cases.reach_stack(cfg, target)
    start = np.linalg.norm(stack.hand.compute_error(cfg)[:3])
    worst_p, worst_r = [], []

    def watch(info):
        for foot in stack.feet:
            e = foot.compute_error(info.configuration)
            worst_p.append(np.linalg.norm(e[:3]))
            worst_r.append(np.linalg.norm(e[3:]))

    result = pik_mj.solve(cfg, stack.levels, stop=50, revert_if_fail=False, callback=watch)
    assert not result.converged and result.iterations == 50
    assert max(worst_p) <= 1e-4 and max(worst_r) <= 1e-3
    end = np.linalg.norm(stack.hand.compute_error(cfg)[:3])
    assert end < start - 0.5  # the hand got as close as it could: over half a metre closer


def test_revert_if_fail_restores_configuration(model):
    cfg = mink.Configuration(model)
    q0 = cfg.q.copy()
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg))
    result = pik_mj.solve(cfg, stack.levels, stop=5, revert_if_fail=True)
    assert result.reverted and not result.converged
    np.testing.assert_array_equal(cfg.q, q0)
    # The report still says how far it got before reverting.
    hand = next(t for t in result.tasks if t.level == 2)
    assert not hand.satisfied and hand.error > 0.5  # the target is 2 m away


def test_min_loop_runs_at_least_that_many_iterations(model):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cfg.get_transform_frame_to_world(cases.HAND, "body"))
    result = pik_mj.solve(cfg, stack.levels, min_loop=4)
    assert result.converged and result.iterations == 4
    result = pik_mj.solve(cfg, stack.levels)
    assert result.converged and result.iterations == 1


def test_per_level_regularization_lists(model):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.2))
    result = pik_mj.solve(cfg, stack.levels, regular=[1e-6, 1e-5, 1e-4], regular_max=[0.1] * 3)
    assert result.converged
    with pytest.raises(pik_mj.InvalidInput, match="one per solved level"):
        pik_mj.solve(cfg, stack.levels, regular=[1e-6, 1e-5])


def test_result_summary_and_dict(model):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.1))
    result = pik_mj.solve(cfg, stack.levels)
    d = result.to_dict()
    assert d["converged"] and d["iterations"] == result.iterations
    assert [t["level"] for t in d["tasks"]] == [0, 1, 1, 2, 3]
    assert len(d["timing"]["iteration_ms"]) == result.iterations
    assert d["evaluations"] == result.evaluations and len(d["evaluations"]) == 4
    assert "converged after" in result.summary()


# -- bad input: clear errors, configuration untouched ----------------------------------


def test_unknown_frame_lists_valid_names(model):
    cfg = mink.Configuration(model)
    with pytest.raises(pik_mj.UnknownName, match="right_hand") as info:
        FrameTask(cfg, "nope", mink.SE3.identity(), move_target_type="body")
    assert "nope" in str(info.value)


@pytest.mark.parametrize(
    "target",
    [
        np.zeros(3),
        (np.zeros(2), np.array([1.0, 0, 0, 0])),
        "not-a-frame",
        (np.zeros(3), np.zeros(4)),
    ],
)
def test_wrong_target_shapes(model, target):
    cfg = mink.Configuration(model)
    with pytest.raises((pik_mj.InvalidInput, pik_mj.UnknownName)):
        FrameTask(cfg, cases.HAND, target)


def test_nan_target_is_rejected_and_configuration_restored(model):
    cfg = mink.Configuration(model)
    q0 = cfg.q.copy()
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.2))
    stack.hand.set_target(lambda c: (np.array([np.nan, 0, 1]), np.array([1.0, 0, 0, 0])))
    with pytest.raises(pik_mj.InvalidInput, match="finite"):
        pik_mj.solve(cfg, stack.levels)
    np.testing.assert_array_equal(cfg.q, q0)


def test_nan_weight_is_rejected(model):
    cfg = mink.Configuration(model)
    with pytest.raises(pik_mj.InvalidInput, match="w_trans"):
        FrameTask(cfg, cases.HAND, mink.SE3.identity(), w_trans=np.nan)


def test_nan_in_mink_task_rows_restores_configuration(model):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.2))
    q_before = cfg.q.copy()
    stack.posture.target_q = np.full(model.nq, np.nan)
    with pytest.raises(pik_mj.InvalidInput, match="PostureTask"):
        pik_mj.solve(cfg, stack.levels)
    np.testing.assert_array_equal(cfg.q, q_before)


class _FrozenRows(pik_mj.Task):
    """Equality rows ``A x = b`` with a read-only ``A``; ``A`` is replaced by a
    new read-only matrix holding a NaN after ``n_good`` evaluations."""

    name = "frozen"

    def __init__(self, nv: int, n_good: int):
        self.nv, self.n_good, self.calls = nv, n_good, 0
        self.A = np.eye(nv)[:3].copy()
        self.A.flags.writeable = False

    def compute_rows(self, configuration):
        self.calls += 1
        if self.calls > self.n_good:
            A = np.eye(self.nv)[:3].copy()
            A[1, 2] = np.nan
            A.flags.writeable = False
            self.A = A
        return pik_mj.TaskRows.equality(self.A, np.full(3, 1e-3))

    def evaluate(self, configuration):
        return TaskState(self.compute_rows(configuration), 1e-3, False)


def test_a_new_read_only_matrix_with_nan_is_caught_mid_solve(model):
    """The loop sums a read-only matrix once (a posture's constant Jacobian is
    handed back as the same object); a new object is summed again: a NaN in it
    after three evaluations ends the solve with the task named, the
    configuration restored. A check keyed on anything but the object would
    miss it."""
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.5))
    frozen = _FrozenRows(model.nv, n_good=3)
    q_before = cfg.q.copy()
    with pytest.raises(pik_mj.InvalidInput, match="frozen"):
        pik_mj.solve(cfg, [*stack.levels[:3], [frozen]], stop=20)
    assert frozen.calls == 4
    np.testing.assert_array_equal(cfg.q, q_before)


@pytest.mark.parametrize(
    ("levels", "match"),
    [
        ([], "at least one level"),
        ([[]], "at least one level"),
        ([[], []], "level 1 is empty"),
        ([[], [42]], "valid entries"),
        ("feet", "list of lists"),
    ],
)
def test_malformed_levels(model, levels, match):
    cfg = mink.Configuration(model)
    with pytest.raises(pik_mj.InvalidInput, match=match):
        pik_mj.solve(cfg, levels)


@pytest.mark.parametrize(
    ("option", "value"), [("stop", 0), ("min_loop", -1), ("relaxation", np.nan)]
)
def test_bad_options(model, option, value):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.1))
    with pytest.raises(pik_mj.InvalidInput, match=option):
        pik_mj.solve(cfg, stack.levels, **{option: value})


def test_inverted_hard_limits(model):
    cfg = mink.Configuration(model)
    q0 = cfg.q.copy()
    nv = model.nv
    inverted = pik_mj.LinearTask(C=np.eye(nv)[:1], d_lower=1.0, d_upper=-1.0, name="inverted")
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.1))
    with pytest.raises(pik_mj.InvalidInput, match="inverted bounds"):
        pik_mj.solve(cfg, [[inverted], *stack.levels[1:]])
    np.testing.assert_array_equal(cfg.q, q0)


def test_infeasible_hard_level_raises_and_restores(model):
    cfg = mink.Configuration(model)
    q0 = cfg.q.copy()
    e0 = np.eye(model.nv)[:1]
    contradictory = [
        pik_mj.LinearTask(C=e0, d_lower=0.5, d_upper=1.0, name="up"),
        pik_mj.LinearTask(C=e0, d_lower=-1.0, d_upper=-0.5, name="down"),
    ]
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.1))
    with pytest.raises(pik_mj.InfeasibleHardConstraints, match="level 0"):
        pik_mj.solve(cfg, [contradictory, *stack.levels[1:]])
    np.testing.assert_array_equal(cfg.q, q0)


def test_unknown_qp_solver(model):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.1))
    with pytest.raises(pik_mj.InvalidInput, match="valid"):
        pik_mj.solve(cfg, stack.levels, qp_solver="nope")


def test_daqp_backend_solves_the_stack(model):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.15))
    result = pik_mj.solve(cfg, stack.levels, qp_solver="daqp")
    assert result.converged


# -- step rule, backends, callbacks ------------------------------------------------------


@pytest.mark.parametrize("qp_solver", ["osqp", "daqp-hqp"])
def test_satisfied_feet_are_corrected_only_beyond_0_9_drift(model, qp_solver):
    """A step that leaves the satisfied feet more than CORRECT_ABOVE · drift
    (9e-5) off is projected back; one within it is left to the next step's QP,
    which holds their rows. With the hand 2 m out of reach, the feet's error
    (the norm of each foot's error, m and rad) stays within 9e-5 at every
    iteration, and some iterations end above half the drift (those were
    corrected under the former threshold, drift / 2)."""
    drift = TrustRegion().drift
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 2.0))
    feet: list[float] = []

    def watch(info):
        feet.append(max(t.error for t in info.tasks if t.level == 1))

    result = pik_mj.solve(
        cfg, stack.levels, stop=50, revert_if_fail=False, qp_solver=qp_solver, callback=watch
    )
    assert result.iterations == 50 and result.corrections >= 1
    assert max(feet) <= CORRECT_ABOVE * drift
    assert max(feet) > 0.5 * drift


@pytest.mark.parametrize("humanoid", [cases.DM, cases.CMU], ids=["dm", "cmu"])
def test_raw_mink_frame_tasks_keep_the_feet_within_1e4_every_iteration(humanoid):
    """mink.FrameTasks have no step limit of their own: the trust region bounds
    every step, so with the hand 2 m out of reach the feet (level 1) stay within
    1e-4 m (and 1e-4 rad) of their pose at every iteration."""
    model = pik_mj.robot.loading.load_model(humanoid.model)
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    feet = [
        mink.FrameTask(f, "body", position_cost=1.0, orientation_cost=1.0) for f in humanoid.feet
    ]
    for f in feet:
        f.set_target_from_configuration(cfg)
    hand = mink.FrameTask(humanoid.hand, "body", position_cost=1.0, orientation_cost=1.0)
    start = cfg.get_transform_frame_to_world(humanoid.hand, "body")
    hand.set_target(cases.unreachable_hand_target(cfg, 2.0))
    posture = mink.PostureTask(model, cost=cases.POSTURE_COST)
    posture.set_target_from_configuration(cfg)
    levels = [
        [mink.ConfigurationLimit(model)],
        feet,
        [hand],
        [pik_mj.MinkTask(posture, check=False)],
    ]
    worst_p, worst_r = [], []

    def watch(info):
        for f in feet:
            e = f.compute_error(info.configuration)
            worst_p.append(np.linalg.norm(e[:3]))
            worst_r.append(np.linalg.norm(e[3:]))

    result = pik_mj.solve(cfg, levels, stop=30, revert_if_fail=False, callback=watch)
    assert result.iterations == 30 and len(worst_p) == 2 * 30
    assert max(worst_p) <= 1e-4 and max(worst_r) <= 1e-4
    moved = np.linalg.norm(
        cfg.get_transform_frame_to_world(humanoid.hand, "body").translation() - start.translation()
    )
    assert moved > 0.2  # the hand did reach out


def test_without_the_trust_region_raw_mink_tasks_move_the_feet(model):
    """The same stack with the seed's plain loop (full steps): the feet drift
    by centimetres, which is what the step rule prevents."""
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    feet = [mink.FrameTask(f, "body", position_cost=1.0, orientation_cost=1.0) for f in cases.FEET]
    for f in feet:
        f.set_target_from_configuration(cfg)
    hand = mink.FrameTask(cases.HAND, "body", position_cost=1.0, orientation_cost=1.0)
    hand.set_target(cases.unreachable_hand_target(cfg, 2.0))
    drift = []
    pik_mj.solve(
        cfg,
        [[mink.ConfigurationLimit(model)], feet, [hand]],
        stop=5,
        revert_if_fail=False,
        trust_region=None,
        correct=False,
        callback=lambda info: drift.append(
            max(np.linalg.norm(f.compute_error(info.configuration)[:3]) for f in feet)
        ),
    )
    assert max(drift) > 1e-2


@pytest.mark.parametrize("qp_solver", ["osqp", "daqp", "daqp-hqp"])
def test_every_backend_reaches_the_reachable_targets(model, targets, qp_solver):
    cfg = mink.Configuration(model)
    for target in targets[:10]:
        cfg.update(cases.stance(model))
        stack = cases.reach_stack(cfg, target)
        result = pik_mj.solve(cfg, stack.levels, stop=50, qp_solver=qp_solver)
        assert result.converged, (qp_solver, result.summary())
        for task in stack.feet:
            assert np.linalg.norm(task.compute_error(cfg)[:3]) <= 1e-4


def test_hierarchical_and_osqp_cascades_reach_the_same_pose_to_the_tolerance(model, targets):
    """Both backends solve the same hierarchy (the OSQP cascade damped by λ_k,
    DAQP's exact): feet and hand agree within the stop tolerances."""
    poses = {}
    for qp_solver in ("osqp", "daqp-hqp"):
        cfg = mink.Configuration(model)
        cfg.update(cases.stance(model))
        stack = cases.reach_stack(cfg, targets[0])
        assert pik_mj.solve(cfg, stack.levels, qp_solver=qp_solver).converged
        poses[qp_solver] = [
            cfg.get_transform_frame_to_world(b, "body").translation()
            for b in (*cases.FEET, cases.HAND)
        ]
    for a, b in zip(poses["osqp"], poses["daqp-hqp"], strict=True):
        assert np.linalg.norm(a - b) <= 2e-3


def test_solves_are_repeatable_with_the_shared_backend(model, targets):
    qs = []
    for _ in range(3):
        cfg = mink.Configuration(model)
        cfg.update(cases.stance(model))
        stack = cases.reach_stack(cfg, targets[3])
        pik_mj.solve(cfg, stack.levels)
        qs.append(cfg.q.copy())
    np.testing.assert_array_equal(qs[0], qs[1])
    np.testing.assert_array_equal(qs[0], qs[2])


def test_a_list_of_callbacks_is_called_in_order_with_the_same_info(model):
    cfg = mink.Configuration(model)
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.2))
    seen = []
    result = pik_mj.solve(
        cfg,
        stack.levels,
        callback=[
            lambda info: seen.append(("a", info.iteration, id(info))),
            lambda info: seen.append(("b", info.iteration, id(info))),
        ],
    )
    assert [s[:2] for s in seen] == [(n, i) for i in range(1, result.iterations + 1) for n in "ab"]
    assert all(seen[2 * k][2] == seen[2 * k + 1][2] for k in range(result.iterations))


def test_a_callback_that_moves_the_robot_is_followed(model):
    """The loop re-linearizes where a callback left the configuration."""
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.2))
    nudged = []

    def nudge(info):
        if info.iteration == 1:
            q = info.configuration.q.copy()
            q[10] += 0.05
            info.configuration.update(q)
            nudged.append(q[10])

    result = pik_mj.solve(cfg, stack.levels, callback=nudge)
    assert result.converged and nudged
    assert all(t.satisfied for t in result.tasks if t.checked)


class _Recorded(pik_mj.Task):
    """A task of the stack, unchanged, that notes every configuration it is
    evaluated at (the loop's only entry into a task is ``evaluate``)."""

    def __init__(self, inner):
        self.inner = as_task(inner)
        self.name, self.check = self.inner.name, self.inner.check
        self.seen: list[bytes] = []

    def compute_rows(self, configuration):
        return self.inner.compute_rows(configuration)

    def evaluate(self, configuration):
        self.seen.append(configuration.q.tobytes())
        return self.inner.evaluate(configuration)


@pytest.mark.parametrize("qp_solver", ["osqp", "daqp-hqp"])
def test_no_task_is_evaluated_twice_at_one_configuration(model, targets, qp_solver):
    """The evaluation that accepts a step is the next iteration's
    linearization: every task sees each configuration once; the levels below
    the satisfied feet are evaluated only at accepted configurations (once per
    iteration, plus the start); the hard rows and the feet once per trial step
    and once per correction (the counts the result reports)."""
    cfg = mink.Configuration(model)
    for target in targets[:4]:
        cfg.update(cases.stance(model))
        stack = cases.reach_stack(cfg, target)
        levels = [[_Recorded(t) for t in level] for level in stack.levels]
        result = pik_mj.solve(cfg, levels, qp_solver=qp_solver)
        assert result.converged and result.iterations >= 2, result.summary()
        for k, level in enumerate(levels):
            for task in level:
                assert len(task.seen) == len(set(task.seen)), (k, task.name)
                assert len(task.seen) == result.evaluations[k], (k, task.name)
        n = result.iterations
        assert result.evaluations[2] == result.evaluations[3] == n + 1
        gave_up = result.step_lengths.count(0.0)
        trials = n - gave_up + result.rejected
        assert result.evaluations[0] == result.evaluations[1] == 1 + trials + result.corrections
        assert result.corrections >= 1  # the feet drift beyond 0.9 drift on a 0.5 rad step


def test_predicted_decrease_is_the_drop_of_the_rows_residual_norm():
    """``‖r(0)‖ − ‖r(x)‖`` with ``r(x) = [A x − b; dist(C x, [d_l, d_u])]``,
    against the distance to the box written with ``np.clip``."""
    rng = np.random.default_rng(3)
    nv = 7
    lo = np.array([-np.inf, -0.2, 0.1, -1.0])
    hi = np.array([0.3, np.inf, 0.5, -0.4])
    rows = TaskRows(
        rng.normal(size=(5, nv)),
        rng.normal(size=5),
        np.ones(5),
        rng.normal(size=(4, nv)),
        lo,
        hi,
        np.ones(4),
    )

    def residual(x):
        cx = rows.C @ x
        return np.linalg.norm(np.concatenate([rows.A @ x - rows.b, cx - np.clip(cx, lo, hi)]))

    for _ in range(20):
        x = rng.normal(size=nv)
        assert predicted_decrease(rows, x) == pytest.approx(
            residual(np.zeros(nv)) - residual(x), abs=1e-12
        )
    equality_only = rows._replace(C=np.zeros((0, nv)), d_lower=lo[:0], d_upper=hi[:0])
    x = rng.normal(size=nv)
    expected = np.linalg.norm(rows.b) - np.linalg.norm(rows.A @ x - rows.b)
    assert predicted_decrease(equality_only, x) == pytest.approx(expected, abs=1e-12)


class _Reports:
    """What :meth:`Point.satisfaction` reads: the reports of the evaluated levels."""

    def __init__(self, levels):
        self.level_reports = [
            [TaskReport(f"t{k}{i}", k, 0.0, ok, checked) for i, (ok, checked) in enumerate(level)]
            for k, level in enumerate(levels)
        ]
        self.done = len(levels)


@pytest.mark.parametrize(
    "levels, expected",
    [
        ([[(True, True)], [(True, True)], [(True, True)]], (True, 2)),
        # level 0 (the hard rows) is never part of the prefix, but of "everything"
        ([[(False, True)], [(True, True)], [(False, True)]], (False, 1)),
        # an unmet unchecked task ends the kept levels, and does not stop convergence
        ([[], [(True, True)], [(False, False)], [(True, True)]], (True, 1)),
        ([[], [(True, True), (False, False)], [(True, True)]], (True, 0)),
        ([[], [(True, True), (False, True)], [(True, True)]], (False, 0)),
        # a met unchecked task keeps its level like a checked one (check: convergence only)
        ([[], [(True, True), (True, False)], [(True, True), (False, True)]], (False, 1)),
        ([[], [(True, True)], [(True, False)], [(False, True)]], (False, 2)),
        ([[], [(True, False)], [(True, False)]], (True, 2)),
    ],
)
def test_satisfaction_counts_the_leading_kept_levels(levels, expected):
    assert Point.satisfaction(_Reports(levels)) == expected
