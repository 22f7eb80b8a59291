"""Bad input to the solver side (solve, qp, tasks), table-driven.

Each case builds a call on a fresh dm_control humanoid configuration and
asserts the exception type, a message naming the cause, and that the
configuration is exactly where it started. Then: inputs that must be
accepted, and Ctrl-C (a real SIGINT, 20 times) during solve loops.
"""

from __future__ import annotations

import os
import signal
import threading
import warnings

import cases
import mink
import numpy as np
import pytest

import pik_mj
from pik_mj.inputs import RANGE_TOLERANCE
from pik_mj.qp import QPSolution
from pik_mj.solve import TrustRegion
from pik_mj.solve.evaluation import RowStack
from pik_mj.tasks import MinkLimit
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.task import Task, TaskRows

MODEL = cases.dm_humanoid()
OTHER = cases.cmu_humanoid()


class Setup:
    """A configuration at the stance and the reach stack with a near target."""

    def __init__(self):
        self.cfg = mink.Configuration(MODEL)
        self.cfg.update(cases.stance(MODEL))
        near = cases.unreachable_hand_target(self.cfg, 0.05)
        self.stack = cases.reach_stack(self.cfg, near)
        self.q0 = self.cfg.q.copy()

    def solve(self, **options):
        return pik_mj.solve(self.cfg, self.stack.levels, **options)


def _with_q(s: Setup, index: int, value: float):
    q = s.cfg.q.copy()
    q[index] = value
    s.cfg.data.qpos[:] = q  # what a user writing the state directly does
    s.q0 = s.cfg.q.copy()
    return s.solve()


def _zero_free_quaternion(s: Setup):
    s.cfg.data.qpos[3:7] = 0.0
    s.q0 = s.cfg.q.copy()
    return s.solve()


def _nan_from_callback(s: Setup):
    def poison(info):
        info.configuration.data.qpos[10] = np.nan

    return s.solve(callback=poison)


def _inverted_range(s: Setup):
    model = cases.dm_humanoid()  # a fresh copy, edited below as a user could
    j = model.joint("right_elbow").id
    model.jnt_range[j] = model.jnt_range[j][::-1].copy()
    cfg = mink.Configuration(model)
    cfg.update(cases.stance(model))
    s.cfg, s.q0 = cfg, cfg.q.copy()
    stack = cases.reach_stack(cfg, cases.unreachable_hand_target(cfg, 0.05))
    return pik_mj.solve(cfg, stack.levels)


def _contradictory_hard_rows(s: Setup, qp_solver: str):
    e0 = np.eye(MODEL.nv)[6:7]
    hard = [
        pik_mj.LinearTask(C=e0, d_lower=0.5, d_upper=1.0, name="up"),
        pik_mj.LinearTask(C=e0, d_lower=-1.0, d_upper=-0.5, name="down"),
    ]
    return pik_mj.solve(s.cfg, [hard, *s.stack.levels[1:]], qp_solver=qp_solver)


def _posture_of_another_model(s: Setup):
    posture = mink.PostureTask(OTHER, cost=1.0)
    posture.set_target(OTHER.qpos0)
    return pik_mj.solve(s.cfg, [*s.stack.levels[:3], [pik_mj.MinkTask(posture, check=False)]])


def _qp_function(result):
    def qp(problem):
        return result(problem)

    return qp


def _nan_rows(s: Setup):
    bad = pik_mj.LinearTask(
        A=lambda c: np.full((1, MODEL.nv), np.nan), b=np.zeros(1), name="nan_rows"
    )
    return pik_mj.solve(s.cfg, [*s.stack.levels, [bad]])


# (id, call, exception, message pattern)
CASES = [
    ("stop=True", lambda s: s.solve(stop=True), pik_mj.InvalidInput, r"stop must be an integer"),
    ("stop=0", lambda s: s.solve(stop=0), pik_mj.InvalidInput, r"stop must be an integer >= 1"),
    ("stop=2.5", lambda s: s.solve(stop=2.5), pik_mj.InvalidInput, r"stop .*got 2\.5"),
    ("stop='50'", lambda s: s.solve(stop="50"), pik_mj.InvalidInput, r"stop .*'50'"),
    ("min_loop=-1", lambda s: s.solve(min_loop=-1), pik_mj.InvalidInput, r"min_loop"),
    (
        "min_loop>stop",
        lambda s: s.solve(stop=5, min_loop=6),
        pik_mj.InvalidInput,
        r"min_loop \(6\) must not exceed stop \(5\)",
    ),
    (
        "revert_if_fail='yes'",
        lambda s: s.solve(revert_if_fail="yes"),
        pik_mj.InvalidInput,
        r"revert_if_fail must be True or False",
    ),
    (
        "correct=1",
        lambda s: s.solve(correct=1),
        pik_mj.InvalidInput,
        r"correct must be True or False",
    ),
    ("dt=0", lambda s: s.solve(dt=0.0), pik_mj.InvalidInput, r"dt must be a finite number > 0"),
    ("dt=nan", lambda s: s.solve(dt=np.nan), pik_mj.InvalidInput, r"dt must be a finite number"),
    ("relaxation=nan", lambda s: s.solve(relaxation=np.nan), pik_mj.InvalidInput, r"relaxation"),
    (
        "relaxation='small'",
        lambda s: s.solve(relaxation="small"),
        pik_mj.InvalidInput,
        r"relaxation .*'small'",
    ),
    (
        "regular=-1",
        lambda s: s.solve(regular=-1.0),
        pik_mj.InvalidInput,
        r"regular must be finite and >= 0",
    ),
    (
        "regular=nan",
        lambda s: s.solve(regular=np.nan),
        pik_mj.InvalidInput,
        r"regular must be finite",
    ),
    (
        "regular list too short",
        lambda s: s.solve(regular=[1e-6, 1e-6]),
        pik_mj.InvalidInput,
        r"regular has 2 entries; .*one per solved level \(3\)",
    ),
    (
        "regular_rel='x'",
        lambda s: s.solve(regular_rel="x"),
        pik_mj.InvalidInput,
        r"regular_rel must be a float",
    ),
    ("regular_max=True", lambda s: s.solve(regular_max=True), pik_mj.InvalidInput, r"regular_max"),
    (
        "callback=5",
        lambda s: s.solve(callback=5),
        pik_mj.InvalidInput,
        r"callback must be a callable .*got 5",
    ),
    (
        "callback list with 5",
        lambda s: s.solve(callback=[print, 5]),
        pik_mj.InvalidInput,
        r"callback\[1\] must be callable",
    ),
    (
        "trust_region=5",
        lambda s: s.solve(trust_region=5),
        pik_mj.InvalidInput,
        r"trust_region must be a TrustRegion or None",
    ),
    (
        "TrustRegion(drift=-1)",
        lambda s: s.solve(trust_region=TrustRegion(drift=-1.0)),
        pik_mj.InvalidInput,
        r"TrustRegion.drift must be a positive",
    ),
    (
        "TrustRegion(shrink=2)",
        lambda s: s.solve(trust_region=TrustRegion(shrink=2.0)),
        pik_mj.InvalidInput,
        r"TrustRegion.shrink must be in \(0, 1\)",
    ),
    (
        "TrustRegion(radius>max)",
        lambda s: s.solve(trust_region=TrustRegion(radius=5.0, max_radius=1.0)),
        pik_mj.InvalidInput,
        r"min_radius <= radius <= max_radius",
    ),
    (
        "qp_solver='nope'",
        lambda s: s.solve(qp_solver="nope"),
        pik_mj.InvalidInput,
        r"unknown qp_solver 'nope'; valid: .*'daqp-hqp'.*'osqp'",
    ),
    (
        "qp_solver=5",
        lambda s: s.solve(qp_solver=5),
        pik_mj.InvalidInput,
        r"qp_solver must be a name",
    ),
    (
        "qp_args='fast'",
        lambda s: s.solve(qp_args="fast"),
        pik_mj.InvalidInput,
        r"qp_args must be a dict",
    ),
    (
        "qp_args unknown key",
        lambda s: s.solve(qp_args={"epsabs": 1e-3}),
        pik_mj.InvalidInput,
        r"unknown OSQP settings \['epsabs'\]; valid: .*'eps_abs'",
    ),
    (
        "qp_args eps_abs=-1",
        lambda s: s.solve(qp_args={"eps_abs": -1}),
        pik_mj.InvalidInput,
        r"rejected by OSQP: .*eps_abs must be nonnegative",
    ),
    (
        "qp_args max_iter=0",
        lambda s: s.solve(qp_args={"max_iter": 0}),
        pik_mj.InvalidInput,
        r"rejected by OSQP: .*max_iter",
    ),
    (
        "daqp qp_args unknown",
        lambda s: s.solve(qp_solver="daqp", qp_args={"tol": 1}),
        pik_mj.InvalidInput,
        r"unknown DAQP settings \['tol'\]; valid: .*'primal_tol'",
    ),
    (
        "daqp qp_args negative",
        lambda s: s.solve(qp_solver="daqp-hqp", qp_args={"primal_tol": -1.0}),
        pik_mj.InvalidInput,
        r"qp_args\['primal_tol'\] must be a finite number >= 0",
    ),
    (
        "daqp-hqp with regular",
        lambda s: s.solve(qp_solver="daqp-hqp", regular=1e-3),
        pik_mj.InvalidInput,
        r"\['regular'\] do not apply to qp_solver='daqp-hqp'",
    ),
    (
        "daqp-hqp with relaxation",
        lambda s: s.solve(qp_solver="daqp-hqp", relaxation=1e-4),
        pik_mj.InvalidInput,
        r"\['relaxation'\] do not apply",
    ),
    (
        "qp function wrong shape",
        lambda s: s.solve(qp_solver=_qp_function(lambda p: np.zeros(3))),
        pik_mj.InvalidInput,
        r"qp_solver .*qp returned shape \(3,\) for a problem of \d+ variables",
    ),
    (
        "qp function NaN",
        lambda s: s.solve(qp_solver=_qp_function(lambda p: np.full(p.P.shape[0], np.nan))),
        pik_mj.InvalidInput,
        r"returned NaN or inf",
    ),
    (
        "qp function str",
        lambda s: s.solve(qp_solver=_qp_function(lambda p: "x")),
        pik_mj.InvalidInput,
        r"returned str",
    ),
    (
        "solve(model)",
        lambda s: pik_mj.solve(MODEL, s.stack.levels),
        pik_mj.InvalidInput,
        r"configuration must be a mink.Configuration, got MjModel; "
        r"build one with mink.Configuration\(model\)",
    ),
    (
        "solve(data)",
        lambda s: pik_mj.solve(s.cfg.data, s.stack.levels),
        pik_mj.InvalidInput,
        r"got MjData",
    ),
    (
        "NaN in q",
        lambda s: _with_q(s, 12, np.nan),
        pik_mj.InvalidInput,
        r"configuration.q\[12\] \(joint '\w+'\) is NaN",
    ),
    (
        "inf in q",
        lambda s: _with_q(s, 12, np.inf),
        pik_mj.InvalidInput,
        r"configuration.q\[12\] .* is inf",
    ),
    (
        "hinge at 1e200",
        lambda s: _with_q(s, 12, 1e200),
        pik_mj.InvalidInput,
        r"is 1e\+200; every entry must be finite with \|q\| <= 1e\+06",
    ),
    (
        "zero free quaternion",
        _zero_free_quaternion,
        pik_mj.InvalidInput,
        r"joint 'root': its quaternion in configuration.q is zero",
    ),
    (
        "callback writes NaN",
        _nan_from_callback,
        pik_mj.InvalidInput,
        r"after a callback: configuration.q\[10\] .* is NaN",
    ),
    (
        "inverted joint range",
        _inverted_range,
        pik_mj.InvalidInput,
        r"joint 'right_elbow' has an inverted range",
    ),
    (
        "posture of another model",
        _posture_of_another_model,
        pik_mj.InvalidInput,
        r"target configuration has 63 entries but this model has nq = 28; "
        r"was it made for another model",
    ),
    ("NaN rows of a task", _nan_rows, pik_mj.InvalidInput, r"task nan_rows: A contains NaN"),
    (
        "levels not a list",
        lambda s: pik_mj.solve(s.cfg, "feet"),
        pik_mj.InvalidInput,
        r"levels must be a list of lists",
    ),
    (
        "levels too short",
        lambda s: pik_mj.solve(s.cfg, [[]]),
        pik_mj.InvalidInput,
        r"at least one level to solve",
    ),
    (
        "empty level",
        lambda s: pik_mj.solve(s.cfg, [[], []]),
        pik_mj.InvalidInput,
        r"level 1 is empty",
    ),
    (
        "a number in a level",
        lambda s: pik_mj.solve(s.cfg, [[], [42]]),
        pik_mj.InvalidInput,
        r"a level holds int; valid entries are",
    ),
    (
        "infeasible level 0, osqp",
        lambda s: _contradictory_hard_rows(s, "osqp"),
        pik_mj.InfeasibleHardConstraints,
        r"hard rows of level 0 admit no step \(OSQP: primal infeasible",
    ),
    (
        "infeasible level 0, daqp",
        lambda s: _contradictory_hard_rows(s, "daqp"),
        pik_mj.InfeasibleHardConstraints,
        r"level 0 admit no step \(DAQP exitflag -1: primal infeasible\)",
    ),
    (
        "infeasible level 0, daqp-hqp",
        lambda s: _contradictory_hard_rows(s, "daqp-hqp"),
        pik_mj.InfeasibleHardConstraints,
        r"level 0 admit no step \(DAQP",
    ),
    (
        "FrameTask thre=nan",
        lambda s: FrameTask(s.cfg, "right_hand", mink.SE3.identity(), thre=np.nan),
        pik_mj.InvalidInput,
        r"thre must be a finite number >= 0 or 3 of them \[m\], got nan",
    ),
    (
        "FrameTask thre='1mm'",
        lambda s: FrameTask(s.cfg, "right_hand", mink.SE3.identity(), thre="1mm"),
        pik_mj.InvalidInput,
        r"thre must be .*got '1mm'",
    ),
    (
        "FrameTask rthre=-1",
        lambda s: FrameTask(s.cfg, "right_hand", mink.SE3.identity(), rthre=-1.0),
        pik_mj.InvalidInput,
        r"rthre must be .*\[rad\]",
    ),
    (
        "FrameTask w_trans=1e300",
        lambda s: FrameTask(s.cfg, "right_hand", mink.SE3.identity(), w_trans=1e300),
        pik_mj.InvalidInput,
        r"w_trans must be finite, >= 0 and <= 1e\+12",
    ),
    (
        "FrameTask w_rot=nan",
        lambda s: FrameTask(s.cfg, "right_hand", mink.SE3.identity(), w_rot=np.nan),
        pik_mj.InvalidInput,
        r"w_rot must be finite",
    ),
    (
        "FrameTask p_limit=-1",
        lambda s: FrameTask(s.cfg, "right_hand", mink.SE3.identity(), p_limit=-1.0),
        pik_mj.InvalidInput,
        r"p_limit must be None or a positive finite number",
    ),
    (
        "FrameTask r_limit='big'",
        lambda s: FrameTask(s.cfg, "right_hand", mink.SE3.identity(), r_limit="big"),
        pik_mj.InvalidInput,
        r"r_limit must be None or a positive",
    ),
    (
        "FrameTask zero quaternion frame",
        lambda s: FrameTask(
            s.cfg, "right_hand", mink.SE3.identity(), translation_frame=[0, 0, 0, 0]
        ),
        pik_mj.InvalidInput,
        r"translation_frame: the quaternion .* has zero length",
    ),
    (
        "FrameTask zero quaternion target",
        lambda s: FrameTask(s.cfg, "right_hand", (np.zeros(3), np.zeros(4))),
        pik_mj.InvalidInput,
        r"orientation must be a wxyz quaternion",
    ),
    (
        "FrameTask unknown frame",
        lambda s: FrameTask(s.cfg, "nope", mink.SE3.identity()),
        pik_mj.UnknownName,
        r"'nope' does not exist. Valid .*'right_hand'",
    ),
    (
        "CentroidTask zero quaternion frame",
        lambda s: CentroidTask(s.cfg, [0, 0, 0], frame=[0, 0, 0, 0]),
        pik_mj.InvalidInput,
        r"frame: the quaternion .* has zero length",
    ),
    (
        "CentroidTask centroid_thre=nan",
        lambda s: CentroidTask(s.cfg, [0, 0, 0], centroid_thre=np.nan),
        pik_mj.InvalidInput,
        r"centroid_thre must be a finite number",
    ),
    (
        "CentroidTask target NaN",
        lambda s: CentroidTask(s.cfg, [np.nan, 0, 0]),
        pik_mj.InvalidInput,
        r"target must be 3 finite numbers",
    ),
]


@pytest.mark.parametrize(
    ("call", "exception", "pattern"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_bad_input_is_named_and_leaves_the_configuration_alone(call, exception, pattern):
    s = Setup()
    with pytest.raises(exception, match=pattern):
        call(s)
    np.testing.assert_array_equal(s.cfg.q, s.q0)


def test_at_least_sixty_cases():
    assert len(CASES) >= 60


# ----------------------------------------------------------------- accepted


def test_numpy_scalars_are_accepted():
    s = Setup()
    result = s.solve(
        stop=np.int64(50), min_loop=np.int32(2), dt=np.float32(1.0), correct=np.bool_(True)
    )
    assert result.converged and result.iterations >= 2


def test_a_target_a_million_metres_away_does_not_fail_the_qp():
    """Clamped or not, any distance gives a solvable QP: the hand stretches
    towards it and the solve ends unconverged, without QPFailure."""
    s = Setup()
    s.stack.hand.set_target(cases.unreachable_hand_target(s.cfg, 1e6))
    result = s.solve(stop=20, revert_if_fail=False)
    assert not result.converged and result.failure is None and result.iterations == 20
    assert np.all(np.isfinite(s.cfg.q))


def test_start_outside_the_joint_ranges_warns_naming_the_joint_and_pulls_it_in():
    s = Setup()
    j = MODEL.joint("right_elbow")
    q = s.cfg.q.copy()
    q[j.qposadr[0]] = MODEL.jnt_range[j.id][1] + 0.3  # 0.3 rad beyond the upper limit
    s.cfg.update(q)
    with pytest.warns(RuntimeWarning, match=r"outside the joint ranges: right_elbow"):
        result = s.solve(stop=50, revert_if_fail=False)
    assert result.converged
    assert s.cfg.q[j.qposadr[0]] <= MODEL.jnt_range[j.id][1] + 1e-6


def test_a_start_past_a_range_by_the_solvers_rounding_is_not_warned():
    """A solve that starts where another ended (a joint at its limit, past it
    by the QP's accuracy) runs without a warning; 10x that tolerance warns."""
    s = Setup()
    j = MODEL.joint("right_elbow")
    for over, warned in ((0.5 * RANGE_TOLERANCE, False), (10 * RANGE_TOLERANCE, True)):
        q = s.cfg.q.copy()
        q[j.qposadr[0]] = MODEL.jnt_range[j.id][1] + over
        s.cfg.update(q)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            s.solve(stop=2, revert_if_fail=False)
        ranges = [w for w in caught if "outside the joint ranges" in str(w.message)]
        assert bool(ranges) == warned, (over, [str(w.message) for w in caught])


# ----------------------------------------------------------------- Ctrl-C


@pytest.mark.parametrize("qp_solver", ["osqp", "daqp-hqp"])
def test_ctrl_c_always_stops_the_solve_and_restores_the_configuration(qp_solver, ctrl_c):
    """A real SIGINT at a random moment of a long solve (hand 2 m out of reach,
    joint limits active: OSQP, which catches SIGINT itself, is called), 10
    times per backend: each one raises KeyboardInterrupt and the configuration
    is back at its start."""
    rng = np.random.default_rng(0)
    stopped = 0
    for _ in range(10):
        s = Setup()
        s.stack.hand.set_target(cases.unreachable_hand_target(s.cfg, 2.0))
        timer = threading.Timer(rng.uniform(0.005, 0.05), os.kill, (os.getpid(), signal.SIGINT))
        try:
            with pytest.raises(KeyboardInterrupt):
                timer.start()  # inside: under load the timer may fire before the solve
                s.solve(stop=2000, revert_if_fail=False, qp_solver=qp_solver)
        finally:
            timer.cancel()
            timer.join()
        np.testing.assert_array_equal(s.cfg.q, s.q0)
        stopped += 1
    assert stopped == 10


def test_rows_turning_nan_after_the_start_are_named():
    """Rows that pass the check at the start and turn NaN at a later
    configuration: the level's per-evaluation check names the task."""
    s = Setup()
    calls = []

    def rows_A(configuration):
        calls.append(1)
        A = np.zeros((1, MODEL.nv))
        A[0, 6] = 1.0 if len(calls) == 1 else np.nan
        return A

    late = pik_mj.LinearTask(A=rows_A, b=np.zeros(1), name="late_nan", check=False)
    with pytest.raises(pik_mj.InvalidInput, match=r"task late_nan: A contains NaN"):
        pik_mj.solve(s.cfg, [*s.stack.levels, [late]])
    assert len(calls) >= 2
    np.testing.assert_array_equal(s.cfg.q, s.q0)


class _NaNBackend:
    """A backend object (no closed forms: it gets every level) whose solution is NaN."""

    def solve(self, problem):
        return QPSolution(np.full(problem.P.shape[0], np.nan), "nan", True)


def test_a_backend_returning_nan_ends_the_solve_as_a_qp_failure():
    s = Setup()
    result = s.solve(qp_solver=_NaNBackend())
    assert result.reverted and not result.converged
    assert result.failure == "QP of priority level 3 failed: the step is not finite"
    np.testing.assert_array_equal(s.cfg.q, s.q0)
    with pytest.raises(pik_mj.QPFailure, match=r"the step is not finite"):
        s.solve(qp_solver=_NaNBackend(), revert_if_fail=False)
    np.testing.assert_array_equal(s.cfg.q, s.q0)


def test_only_levels_of_tasks_finite_by_construction_skip_the_finite_check():
    s = Setup()
    feet, hand = s.stack.levels[1], s.stack.levels[2]
    box = MinkLimit(mink.ConfigurationLimit(MODEL))
    velocity = MinkLimit(mink.VelocityLimit(MODEL, {"right_elbow": 1.0}))
    linear = pik_mj.LinearTask(A=np.eye(MODEL.nv)[6:7], b=np.zeros(1))
    assert RowStack(feet).finite and RowStack(hand).finite and RowStack([box]).finite
    assert not RowStack([box, velocity]).finite
    assert not RowStack([*feet, linear]).finite
    assert not RowStack([]).finite


class _DeclaredFinite(Task):
    """A task that declares :attr:`Task.finite_rows` and breaks the promise:
    its fixed rows have the wrong width, or NaN."""

    finite_rows = True

    def __init__(self, rows: TaskRows, name: str):
        self.rows, self.name, self.check = rows, name, False

    def compute_rows(self, configuration):
        return self.rows


def test_tasks_finite_by_construction_still_have_their_shapes_checked_and_a_nan_named():
    """At the start a ``finite_rows`` task's rows are checked for shape only;
    a broken promise of finite values still ends in an error naming the task,
    through the non-finite step, with the configuration restored."""
    s = Setup()
    wide = _DeclaredFinite(TaskRows.equality(np.ones((1, MODEL.nv + 1)), [0.0]), "too_wide")
    with pytest.raises(pik_mj.InvalidInput, match=r"task too_wide: row shapes do not agree"):
        pik_mj.solve(s.cfg, [*s.stack.levels, [wide]])
    np.testing.assert_array_equal(s.cfg.q, s.q0)
    A = np.zeros((1, MODEL.nv))
    A[0, 6] = np.nan
    for qp_solver in ("osqp", "daqp-hqp"):
        nan = _DeclaredFinite(TaskRows.equality(A, [0.0]), "nan_rows")
        with pytest.raises(pik_mj.InvalidInput, match=r"task nan_rows: A contains NaN"):
            pik_mj.solve(s.cfg, [*s.stack.levels, [nan]], qp_solver=qp_solver)
        np.testing.assert_array_equal(s.cfg.q, s.q0)
