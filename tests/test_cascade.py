"""The cascade against independent references on random hierarchies.

* Equality-only stacks: closed-form null-space projection (no QP at all).
* Stacks with inequalities and hard rows: sequential dense QPs solved by DAQP
  (a dual active-set solver) with the higher levels' achieved values kept
  *exactly* (dependent rows removed by SVD), slacks explicit.

Every check runs twice: with the closed form for levels whose inequalities are
inactive (the default), and with every level handed to OSQP. The hierarchical
backend (``"daqp-hqp"``, each level exact, ``λ → 0``) is checked against the
recursive pseudo-inverse (equality stacks) and against the sequential
reference extrapolated to ``λ = 0`` (mixed stacks).
"""

from __future__ import annotations

import numpy as np
import pytest
import qpsolvers

from pik_mj import InfeasibleHardConstraints, QPFailure, TaskRows
from pik_mj.cascade import (
    CHOLESKY_PIVOT,
    DEFAULT_RELAXATION,
    NullSpaceCascade,
    Regularization,
    solve_cascade,
)
from pik_mj.cascade.linalg import chol_solve, cholesky, psd_solve
from pik_mj.cascade.step import _projection
from pik_mj.qp import (
    DAQPBackend,
    HierarchicalBackend,
    HierarchicalProblem,
    OSQPBackend,
    QPSolution,
    QpsolversBackend,
    make_backend,
)

NV = 8
# eps_prim_inf well below τ (1e-9): see OSQP_DEFAULTS.
TIGHT_SETTINGS = {"eps_abs": 1e-9, "eps_rel": 1e-9, "eps_prim_inf": 1e-12, "max_iter": 100000}


def tight() -> OSQPBackend:
    """A fresh OSQP backend at tight tolerances (fresh: a shared one would
    warm-start each test from the one before)."""
    return OSQPBackend(dict(TIGHT_SETTINGS))


def random_rows(rng, n_eq, n_in, rank=None, nv=NV) -> TaskRows:
    rank = n_eq if rank is None else rank
    A = rng.normal(size=(n_eq, rank)) @ rng.normal(size=(rank, nv)) if n_eq else np.zeros((0, nv))
    b = rng.normal(size=n_eq)
    w = rng.uniform(0.5, 2.0, size=n_eq)
    C = rng.normal(size=(n_in, nv))
    centre = rng.normal(size=n_in)
    width = rng.uniform(0.0, 0.5, size=n_in)
    rows = TaskRows.equality(A, b, w) if n_eq else TaskRows.empty(nv)
    if n_in:
        rows = TaskRows.stack(
            [
                rows,
                TaskRows.inequality(C, centre - width, centre + width, rng.uniform(0.5, 2, n_in)),
            ],
            nv,
        )
    return rows


def level_objective(rows: TaskRows, lam: float, x: np.ndarray) -> float:
    """Level cost minimized over slacks: ``e_k(x) + λ‖x‖²``."""
    return rows.squared_error(x) + lam * float(x @ x)


def lam_of(rows: TaskRows, reg: Regularization) -> float:
    e = rows.squared_error()
    return min(reg.w + reg.w_r * e, reg.w_max) + rows.damping


def nullspace_reference(levels, regs):
    """Equality-only cascade in closed form.

    Level k: ``min ‖W½(A_k x - b_k)‖² + λ‖x‖²`` over ``x = x_{k-1} + N z`` with
    ``N`` a basis of the null space of every higher level's rows.
    """
    x = np.zeros(NV)
    N = np.eye(NV)
    out = []
    for rows, reg in zip(levels, regs, strict=True):
        lam = lam_of(rows, reg)
        sw = np.sqrt(rows.w_A)[:, None]
        An, r = sw * rows.A @ N, sw[:, 0] * (rows.b - rows.A @ x)
        H = An.T @ An + lam * N.T @ N
        g = An.T @ r - lam * N.T @ x
        z = np.linalg.solve(H, g)
        x = x + N @ z
        out.append((x.copy(), lam))
        keep = rows.w_A > 0
        stacked_null = rows.A[keep] @ N
        if stacked_null.size:
            _, s, Vt = np.linalg.svd(stacked_null)
            rank = int(np.sum(s > 1e-10 * max(1.0, s[0])))
            N = N @ Vt[rank:].T
    return out


def daqp_reference(hard, levels, regs):
    """Sequential dense QPs, higher levels kept exactly, solved by DAQP."""
    eq_rows: list[np.ndarray] = [hard.A]
    eq_vals: list[np.ndarray] = [hard.b]
    in_rows = [hard.C]
    in_lo, in_hi = [hard.d_lower], [hard.d_upper]
    out = []
    for rows, reg in zip(levels, regs, strict=True):
        lam = lam_of(rows, reg)
        s = rows.n_in
        n = NV + s
        P = np.zeros((n, n))
        P[:NV, :NV] = 2 * (rows.A.T @ (rows.w_A[:, None] * rows.A) + lam * np.eye(NV))
        P[NV:, NV:] = 2 * np.diag(rows.w_C)
        q = np.zeros(n)
        q[:NV] = -2 * rows.A.T @ (rows.w_A * rows.b)
        # Exact equalities: an orthonormal basis of their row space.
        E = np.vstack(eq_rows)
        e = np.concatenate(eq_vals)
        A_eq = b_eq = None
        if E.shape[0]:
            U, sv, Vt = np.linalg.svd(E, full_matrices=False)
            r = int(np.sum(sv > 1e-9 * max(1.0, sv[0])))
            A_eq = np.hstack([Vt[:r], np.zeros((r, s))])
            b_eq = (U[:, :r].T @ e) / sv[:r]
        Cs = np.vstack(in_rows)
        lo, hi = np.concatenate(in_lo), np.concatenate(in_hi)
        G = [
            np.hstack([Cs, np.zeros((Cs.shape[0], s))]),
            -np.hstack([Cs, np.zeros((Cs.shape[0], s))]),
        ]
        h = [hi, -lo]
        G += [np.hstack([rows.C, np.eye(s)]), -np.hstack([rows.C, np.eye(s)])]
        h += [rows.d_upper, -rows.d_lower]
        G, h = np.vstack(G), np.concatenate(h)
        finite = np.isfinite(h)
        z = qpsolvers.solve_qp(
            P,
            q,
            G[finite],
            h[finite],
            A_eq,
            b_eq,
            solver="daqp",
            primal_tol=1e-12,
            dual_tol=1e-12,
        )
        assert z is not None, "reference QP failed"
        x = z[:NV]
        out.append((x.copy(), lam))
        keep = rows.w_A > 0
        eq_rows.append(rows.A[keep])
        eq_vals.append(rows.A[keep] @ x)
        cx = rows.C @ x
        in_rows.append(rows.C)
        in_lo.append(np.minimum(rows.d_lower, cx))
        in_hi.append(np.maximum(rows.d_upper, cx))
    return out


def check_never_worsened(step, levels, tau):
    """Rows of level j at the final x stay within the documented bound of their
    value at x_j*: ``τ + ‖a‖₁ Σ_{k>=j} v_k`` (v_k: level k's feasibility error)."""
    worst = 0.0
    for j, rows in enumerate(levels[:-1]):
        slack_sum = sum(step.violations[j:])
        keep = rows.w_A > 0
        xj, x = step.level_x[j], step.x
        A = rows.A[keep]
        dev_eq = np.abs(A @ (x - xj)) - (tau + np.abs(A).sum(axis=1) * slack_sum)
        cxj, cx = rows.C @ xj, rows.C @ x
        bound = tau + np.abs(rows.C).sum(axis=1) * slack_sum
        below = np.minimum(rows.d_lower, cxj) - cx - bound
        above = cx - np.maximum(rows.d_upper, cxj) - bound
        worst = max(worst, float(np.max(np.concatenate([dev_eq, below, above]), initial=-1.0)))
    assert worst <= 1e-12, worst


def assert_same_optimum(ours: float, ref: float, level: int):
    assert abs(ours - ref) <= 1e-6 * max(1.0, abs(ref)), (level, ours, ref)


@pytest.mark.parametrize("closed_form", [True, False])
@pytest.mark.parametrize("seed", range(12))
def test_equality_stacks_match_nullspace_projection(seed, closed_form):
    rng = np.random.default_rng(seed)
    n_levels = rng.integers(3, 5)
    # Rank-deficient and conflicting: level sizes add up to more than NV.
    levels = [
        random_rows(rng, int(rng.integers(2, 5)), 0, rank=int(rng.integers(1, 3)))
        for _ in range(n_levels)
    ]
    regs = [Regularization(1e-6, 1.0, 0.1)] * n_levels
    step = solve_cascade(
        TaskRows.empty(NV), levels, regs, tight(), relaxation=1e-9, closed_form=closed_form
    )
    assert step.closed_form == (n_levels if closed_form else 0)
    reference = nullspace_reference(levels, regs)
    for k, (rows, (x_ref, lam)) in enumerate(zip(levels, reference, strict=True)):
        assert step.level_lambdas[k] == pytest.approx(lam, rel=1e-12)
        assert_same_optimum(
            level_objective(rows, lam, step.level_x[k]),
            level_objective(rows, lam, x_ref),
            k,
        )
        # Each level's task error itself, not just the regularized objective.
        assert abs(rows.squared_error(step.level_x[k]) - rows.squared_error(x_ref)) <= 1e-6
    check_never_worsened(step, levels, 1e-9)


def mixed_stack(seed: int) -> tuple[TaskRows, list[TaskRows], list[Regularization]]:
    """A joint-limit-like hard box (often active) and 3-4 levels mixing rank-deficient
    equalities with inequalities."""
    rng = np.random.default_rng(100 + seed)
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    n_levels = int(rng.integers(3, 5))
    levels = [
        random_rows(
            rng,
            int(rng.integers(0, 4)),
            int(rng.integers(1, 4)),
            rank=int(rng.integers(1, 3)),
        )
        for _ in range(n_levels)
    ]
    return hard, levels, [Regularization(1e-4, 1.0, 0.1)] * n_levels


@pytest.mark.parametrize("closed_form", [True, False])
@pytest.mark.parametrize("seed", range(12))
def test_mixed_stacks_match_sequential_dense_qps(seed, closed_form):
    hard, levels, regs = mixed_stack(seed)
    step = solve_cascade(hard, levels, regs, tight(), relaxation=1e-9, closed_form=closed_form)
    reference = daqp_reference(hard, levels, regs)
    for k, (rows, (x_ref, lam)) in enumerate(zip(levels, reference, strict=True)):
        assert_same_optimum(
            level_objective(rows, lam, step.level_x[k]),
            level_objective(rows, lam, x_ref),
            k,
        )
    assert np.all(np.abs(step.x) <= 0.4 + 1e-7)  # hard rows hold
    check_never_worsened(step, levels, 1e-9)


@pytest.mark.parametrize("closed_form", [True, False])
@pytest.mark.parametrize("seed", range(8))
def test_default_settings_keep_higher_levels_within_documented_relaxation(seed, closed_form):
    """With the default OSQP settings, a lower level moves a higher level's rows by
    at most τ + ε_prim (eps_abs + eps_rel·scale)."""
    rng = np.random.default_rng(200 + seed)
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    levels = [random_rows(rng, 3, 2, rank=2) for _ in range(4)]
    regs = [Regularization()] * 4
    step = solve_cascade(
        hard, levels, regs, OSQPBackend(), DEFAULT_RELAXATION, closed_form=closed_form
    )
    check_never_worsened(step, levels, DEFAULT_RELAXATION)
    # The bound is tight to the solver: feasibility errors stay near eps_abs.
    assert max(step.violations) <= 1e-4


def test_regularization_formula():
    reg = Regularization(w=1e-3, w_r=2.0, w_max=0.5)
    assert reg.weight(0.1) == pytest.approx(1e-3 + 0.2)
    assert reg.weight(10.0) == 0.5


def test_a_user_backend_gets_every_level():
    """A backend given as an object or function (seed qp-solver) solves every
    level, even those the closed form would have taken."""
    seen = []

    def qp(problem):
        seen.append(problem.level)
        return DAQPBackend().solve(problem).z

    levels = [
        TaskRows.equality(np.eye(NV)[:3], np.ones(3)),
        TaskRows.equality(np.eye(NV), np.zeros(NV)),
    ]
    regs = [Regularization(1e-9, 0.0, 1.0)] * 2
    step = solve_cascade(TaskRows.empty(NV), levels, regs, make_backend(qp))
    assert seen == [1, 2] and step.closed_form == 0
    np.testing.assert_allclose(step.x[:3], np.ones(3), atol=1e-6)


def test_failed_level_carries_level_and_problem():
    class Failing:
        def solve(self, problem):

            return QPSolution(None, "max iterations", False)

    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))] * 2
    # the hard row x_0 <= 0 is active, so level 1 needs the backend
    hard = TaskRows.inequality(np.eye(NV)[:1], -np.inf, 0.0)
    with pytest.raises(QPFailure) as info:
        solve_cascade(hard, levels, [Regularization()] * 2, Failing())
    assert info.value.level == 1
    assert info.value.problem.P.shape == (NV, NV)


class Counting(OSQPBackend):
    """Tight OSQP that records the level of every problem it gets."""

    def __init__(self):
        super().__init__(dict(TIGHT_SETTINGS))
        self.levels = []

    def solve(self, problem):
        self.levels.append(problem.level)
        return super().solve(problem)


def test_levels_without_active_constraint_are_solved_in_closed_form():
    """Levels whose inequalities stay inactive never reach the backend, and the
    closed form is the exact optimum (DAQP's active set on the same problem);
    an active hard row is held at its bound, still without the backend, with
    the optimum of the level's QP."""

    rng = np.random.default_rng(3)
    A1 = rng.normal(size=(3, NV))
    levels = [
        TaskRows.equality(A1, 0.01 * rng.normal(size=3)),
        TaskRows.equality(np.eye(NV), np.zeros(NV), 0.1),
    ]
    regs = [Regularization()] * 2
    loose = TaskRows.inequality(np.eye(NV), -1.0, 1.0)  # |x_i| <= 1: inactive
    backend = Counting()
    step = solve_cascade(loose, levels, regs, backend)
    assert backend.levels == [] and step.closed_form == 2
    for k in range(2):  # each level's QP (rows above kept), solved exactly by DAQP
        exact = solve_cascade(
            loose, levels[: k + 1], regs[: k + 1], DAQPBackend(), closed_form=False
        )
        np.testing.assert_allclose(step.level_x[k], exact.level_x[k], atol=1e-10)
    assert step.violations == [0.0, 0.0]

    x_free = step.level_x[0]
    i = int(np.argmax(np.abs(x_free)))
    bound = 0.5 * abs(x_free[i])
    tight = TaskRows.inequality(np.eye(NV)[i : i + 1], -bound, bound)
    backend = Counting()
    step = solve_cascade(tight, levels, regs, backend)
    assert backend.levels == [] and step.violations == [0.0, 0.0]
    assert abs(step.level_x[0][i]) == pytest.approx(bound, abs=1e-12)  # held at its bound
    assert abs(step.x[i]) <= bound + 1e-12
    reference = daqp_reference(tight, levels, regs)
    for k in range(2):
        np.testing.assert_allclose(step.level_x[k], reference[k][0], atol=1e-9)


def limited_stack(seed: int):
    """Equality levels (3 to 5 rows each, some rank-deficient) and a hard box
    that cuts 1 to 3 coordinates of the unconstrained first level's step to
    70 % of their value, the others far away."""
    rng = np.random.default_rng(300 + seed)
    levels = [
        random_rows(rng, int(rng.integers(3, 6)), 0, rank=int(rng.integers(2, 4)))
        for _ in range(int(rng.integers(2, 4)))
    ]
    regs = [Regularization(1e-4, 1.0, 0.1)] * len(levels)
    free = solve_cascade(TaskRows.empty(NV), levels, regs, tight())
    cut = rng.choice(NV, size=int(rng.integers(1, 4)), replace=False)
    bound = np.full(NV, 10.0)
    bound[cut] = 0.7 * np.abs(free.level_x[0][cut])
    return TaskRows.inequality(np.eye(NV), -bound, bound), levels, regs, bound


@pytest.mark.parametrize("seed", range(16))
def test_active_limits_are_held_exactly_without_the_backend(seed):
    """Levels whose unconstrained optimum crosses 1 to 3 hard limits: the
    active-set closed form gives DAQP's optimum of the same QPs (higher levels
    kept exactly) without calling the backend, and meets the limits exactly."""
    hard, levels, regs, bound = limited_stack(seed)
    backend = Counting()
    step = solve_cascade(hard, levels, regs, backend, relaxation=1e-9)
    assert backend.levels == [] and step.closed_form == len(levels)
    reference = daqp_reference(hard, levels, regs)
    active = 0
    for x_k, (x_ref, _) in zip(step.level_x, reference, strict=True):
        np.testing.assert_allclose(x_k, x_ref, atol=1e-9)
        assert np.all(np.abs(x_k) <= bound + 1e-12)
        active = max(active, int(np.sum(np.abs(x_ref) >= bound - 1e-9)))
    assert 1 <= active <= 3
    check_never_worsened(step, levels, 1e-9)


def test_a_held_row_whose_multiplier_has_the_wrong_sign_is_released():
    """min ‖x − (2, 0.5, 0…)‖² with x_0 <= 1 and x_0 − x_1 <= 1: the
    unconstrained optimum violates both rows; holding both gives x_1 = 0 with
    a negative multiplier on the second, so that face is refused and the row
    released: the optimum (1, 0.5, 0…) has only x_0 <= 1 active."""
    target = np.zeros(NV)
    target[:2] = 2.0, 0.5
    levels = [TaskRows.equality(np.eye(NV), target)]
    regs = [Regularization(1e-6, 0.0, 1.0)]
    C = np.zeros((2, NV))
    C[0, 0], C[1, :2] = 1.0, (1.0, -1.0)
    hard = TaskRows.inequality(C, -np.inf, 1.0)
    cascade = NullSpaceCascade(hard, Counting(), 0.0, "step")
    lam = lam_of(levels[0], regs[0])
    free = cascade.candidate(levels[0], lam)
    assert np.all(C @ free > 1.0 + 1e-3)  # both rows violated at first
    x, problem, violation = cascade.level(1, levels[0], lam, True, True)
    assert problem is None and violation == 0.0 and cascade.held == 1
    assert cascade.backend.levels == []
    ((x_ref, _),) = daqp_reference(hard, levels, regs)
    np.testing.assert_allclose(x, x_ref, atol=1e-12)
    assert x[0] == pytest.approx(1.0, abs=1e-15)
    assert x[1] == pytest.approx(0.5 / (1 + 1e-6), rel=1e-12)


def test_the_dual_active_set_releases_rows_on_the_way():
    """3-D problems, 4 general rows: the rows the unconstrained optimum
    violates are not the active set, and Goldfarb–Idnani's dual method
    releases a held row on its way (a partial step) before the face it finds
    is certified; the optimum is DAQP's."""
    for seed in (14, 115, 156):  # found among 400 draws: each releases a row
        rng = np.random.default_rng(seed)
        C = rng.normal(size=(4, NV))
        C[:, 3:] = 0.0
        target = np.zeros(NV)
        target[:3] = 3 * rng.normal(size=3)
        levels = [TaskRows.equality(np.eye(NV), target)]
        regs = [Regularization(1e-6, 0.0, 1.0)]
        hard = TaskRows.inequality(C, -1.0, 1.0)
        backend = Counting()
        cascade = NullSpaceCascade(hard, backend, 0.0, "step")
        x, problem, _ = cascade.level(1, levels[0], lam_of(levels[0], regs[0]), True, True)
        assert problem is None and backend.levels == []
        assert cascade.held == 1 and cascade.released >= 1
        ((x_ref, _),) = daqp_reference(hard, levels, regs)
        np.testing.assert_allclose(x, x_ref, atol=1e-8)
        assert np.all(np.abs(C @ x) <= 1.0 + 1e-12)


def test_dependent_limits_are_held_once():
    """Two limits on the same coordinate, both crossed: holding both is
    singular, the dual method holds one (the other is then met exactly)."""
    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))]
    hard = TaskRows.inequality(np.vstack([np.eye(NV)[:1]] * 2), -np.inf, 0.5)
    backend = Counting()
    cascade = NullSpaceCascade(hard, backend, 0.0, "step")
    x, problem, _ = cascade.level(1, levels[0], lam_of(levels[0], Regularization()), True, True)
    assert problem is None and backend.levels == [] and cascade.held == 1
    assert x[0] == pytest.approx(0.5, abs=1e-15)
    ((x_ref, _),) = daqp_reference(hard, levels, [Regularization()])
    np.testing.assert_allclose(x, x_ref, atol=1e-9)


@pytest.mark.parametrize("case", ["dependent limits with λ = 0", "own rows need slacks"])
def test_levels_the_active_set_cannot_certify_go_to_the_backend(case):
    """Two crossed limits on the same coordinate at λ = 0 (holding both is
    singular, and the dual method needs the Hessian's inverse), or a level
    whose own inequality row cannot be met: the active set gives up and the
    backend solves the level, as before."""
    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))]
    reg = Regularization()
    if case == "dependent limits with λ = 0":
        hard = TaskRows.inequality(np.vstack([np.eye(NV)[:1]] * 2), -np.inf, 0.5)
        reg = Regularization(0.0, 0.0, 0.0)
    else:  # x_0 <= 0.5 hard, and the level's own x_0 + x_1 >= 3 (slack needed)
        hard = TaskRows.inequality(np.eye(NV)[:1], -np.inf, 0.5)
        own = TaskRows.inequality(np.eye(NV)[:1] + np.eye(NV)[1:2], 3.0, np.inf)
        levels = [TaskRows.stack([levels[0], own], NV)]
    backend = Counting()
    cascade = NullSpaceCascade(hard, backend, 1e-9, "step")
    x, problem, _ = cascade.level(1, levels[0], lam_of(levels[0], reg), True, True)
    assert backend.levels == [1] and problem is not None and cascade.held == 0
    assert x[0] <= 0.5 + 1e-7
    ((x_ref, _),) = daqp_reference(hard, levels, [reg])
    np.testing.assert_allclose(x, x_ref, atol=1e-6)


def test_a_crossed_limit_fixed_by_hard_equalities_goes_to_the_backend():
    """a x = 0.7 (hard equality) against a x <= 0.5 (hard limit): the limit
    lies in the kept equality rows' span, so holding it is refused (it is not
    a face), and the backend names the hard rows infeasible."""
    A = np.zeros((1, NV))
    A[0, :3] = 0.36, 0.48, 0.8
    hard = TaskRows.stack([TaskRows.equality(A, [0.7]), TaskRows.inequality(A, -np.inf, 0.5)], NV)
    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))]
    backend = Counting()
    with pytest.raises(InfeasibleHardConstraints):
        solve_cascade(hard, levels, [Regularization()], backend)
    assert backend.levels == [1]


def captured_cmu_cascades(monkeypatch, n_targets=3):
    """Solves on the CMU humanoid's reach stack (joint limits hard, feet, hand,
    posture) for a few reachable targets: each cascade the solve loop runs
    and its re-solve with every level handed to OSQP at 1e-9 (made at once:
    the loop may rewrite its rows later), and (converged, iterations, q) of
    each solve."""
    import importlib

    import cases
    import mink

    import pik_mj

    solve_module = importlib.import_module("pik_mj.solve.step")
    model = cases.cmu_humanoid()
    targets = cases.reachable_hand_targets(model, n_targets, seed=1)
    seen = []
    original = solve_module.solve_cascade

    def recording(*args, **kwargs):
        step = original(*args, **kwargs)
        # (hard, levels, regularization, backend, relaxation, role): a tight backend
        reference = original(*args[:3], tight(), *args[4:], closed_form=False, **kwargs)
        seen.append((step, reference))
        return step

    monkeypatch.setattr(solve_module, "solve_cascade", recording)
    finals = []
    for target in targets:
        cfg = mink.Configuration(model)
        cfg.update(cases.stance(model))
        stack = cases.reach_stack(cfg, target)
        result = pik_mj.solve(cfg, stack.levels, stop=50, revert_if_fail=False)
        finals.append((result.converged, result.iterations, cfg.q.copy()))
    monkeypatch.undo()
    return seen, finals


def test_cmu_reach_cascades_match_every_level_solved_by_tight_osqp(monkeypatch):
    """On the CMU humanoid (62 DoF) the active set takes levels with active
    joint limits; each captured cascade, re-solved with every level handed to
    OSQP at 1e-9, gives the same level errors and the same step, and a solve
    with the active set disabled (every such level to OSQP, as before)
    converges as fast to the same configurations.

    (An upper level's own ``x_k`` is compared through its error only: near the
    target its damping ``λ_k`` is ~1e-5, so its objective is that flat along
    the lower levels' directions, and OSQP's 1e-9 leaves ``x_k`` 1e-5 apart
    there; the next level fixes those directions, and the steps agree.)"""
    held = []
    original = NullSpaceCascade.active_set

    def counting(self, *args):
        x = original(self, *args)
        held.append(x is not None)
        return x

    monkeypatch.setattr(NullSpaceCascade, "active_set", counting)
    seen, finals = captured_cmu_cascades(monkeypatch)
    assert sum(held) >= 5 and all(held), held  # the path is exercised, never gave up
    for step, reference in seen:
        np.testing.assert_allclose(step.level_errors, reference.level_errors, rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(step.x, reference.x, atol=1e-6)
    monkeypatch.setattr(NullSpaceCascade, "active_set", lambda *args: None)
    _, before = captured_cmu_cascades(monkeypatch)
    for (ok, iterations, q), (ok_before, iterations_before, q_before) in zip(
        finals, before, strict=True
    ):
        assert ok and ok_before and iterations == iterations_before
        # the same pose to the accuracy of OSQP's default settings, which solve
        # those levels there (the posture level's optimum moves by ~1e-4 rad)
        np.testing.assert_allclose(q, q_before, atol=1e-3)


def test_tight_osqp_rarely_needs_the_fallback():
    """At 1e-9, OSQP itself solves the great majority of levels; DAQP only rescues
    the few degenerate ones where ADMM stalls (measured: about 1 level in 10)."""
    backend = OSQPBackend(dict(TIGHT_SETTINGS))
    levels_solved = 0
    for seed in range(12):
        hard, levels, regs = mixed_stack(seed)
        solve_cascade(hard, levels, regs, backend, 1e-9)
        levels_solved += len(levels)
    assert backend.fallbacks <= 0.2 * levels_solved, (backend.fallbacks, levels_solved)


def test_osqp_workspaces_serve_later_solves_with_the_result_of_a_fresh_setup():
    """Each level is set up once: later problems of the same solve update it,
    and a later solve (after ``start()``) reuses it when the pattern is the
    same, reset to the state setup() leaves, so that the result is bit for bit
    that of a fresh backend whatever came before."""
    rng = np.random.default_rng(3)
    backend = OSQPBackend()
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    stacks = [[random_rows(rng, 3, 2) for _ in range(3)] for _ in range(5)]
    regs = [Regularization()] * 3
    backend.start()
    first = [solve_cascade(hard, s, regs, backend, closed_form=False).x for s in stacks]
    assert backend.setups == 3
    backend.start()
    again = [solve_cascade(hard, s, regs, backend, closed_form=False).x for s in stacks[::-1]]
    assert backend.setups == 3  # reused across solves
    backend.start()
    np.testing.assert_array_equal(
        solve_cascade(hard, stacks[0], regs, backend, closed_form=False).x, first[0]
    )
    fresh = OSQPBackend()
    fresh.start()
    np.testing.assert_array_equal(
        solve_cascade(hard, stacks[-1], regs, fresh, closed_form=False).x, again[0]
    )
    # the same problem warm-started from others: the same up to OSQP's tolerance
    assert np.abs(again[-1] - first[0]).max() <= 1e-4

    # the correction's workspaces (no warm start) too: the same sequence of
    # problems gives what a fresh backend gives
    def corrections(b):
        b.start()
        return [solve_cascade(hard, s, regs, b, 1e-5, "correction", False).x for s in stacks]

    fixes = [corrections(backend) for _ in range(2)]
    assert backend.setups == 6
    np.testing.assert_array_equal(fixes[0], fixes[1])
    np.testing.assert_array_equal(fixes[1], corrections(OSQPBackend()))


def test_osqp_workspaces_of_a_grown_pattern_serve_later_solves():
    """A level whose pattern grows within a solve (a coincidental zero of the
    first problem fills in) is set up again, grown; a later solve of the same
    problems reuses both workspaces and gives the same result bit for bit."""
    rng = np.random.default_rng(5)
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    dense = [random_rows(rng, 3, 2) for _ in range(2)]
    sparse = [r._replace(A=np.where(np.abs(r.A) < 0.5, 0.0, r.A)) for r in dense]
    regs = [Regularization()] * 2

    def one_solve(backend):
        backend.start()
        return [solve_cascade(hard, s, regs, backend, closed_form=False).x for s in (sparse, dense)]

    backend = OSQPBackend()
    first = one_solve(backend)
    assert backend.setups == 4  # each level: its sparse pattern, then grown
    again = one_solve(backend)
    assert backend.setups == 4
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)


# -------------------------------------------------------- hierarchical backend


def pinv_reference(levels):
    """Equality-only cascade with ``λ → 0``: each level's least-squares step
    of least norm in the null space of the levels above (recursive
    pseudo-inverse), which is the lexicographic optimum of least norm."""
    x = np.zeros(NV)
    N = np.eye(NV)
    for rows in levels:
        sw = np.sqrt(rows.w_A)[:, None]
        An, r = sw * rows.A @ N, sw[:, 0] * (rows.b - rows.A @ x)
        x = x + N @ (np.linalg.pinv(An, rcond=1e-12) @ r)
        M = rows.A[rows.w_A > 0] @ N
        if M.size:
            _, s, Vt = np.linalg.svd(M)
            N = N @ Vt[int(np.sum(s > 1e-10 * max(1.0, s[0]))) :].T
    return x


HQP = HierarchicalBackend({"primal_tol": 1e-10})


@pytest.mark.parametrize("seed", range(12))
def test_hierarchical_backend_matches_recursive_pseudo_inverse(seed):
    rng = np.random.default_rng(seed)
    n_levels = rng.integers(3, 5)
    levels = [
        random_rows(rng, int(rng.integers(2, 5)), 0, rank=int(rng.integers(1, 3)))
        for _ in range(n_levels)
    ]
    step = solve_cascade(TaskRows.empty(NV), levels, [Regularization()] * n_levels, HQP)
    assert len(step.problems) == 1  # one DAQP call for the whole hierarchy
    np.testing.assert_allclose(step.x, pinv_reference(levels), atol=1e-6)


def nullspace_qp_reference(hard, levels, lam):
    """Sequential QPs over ``x = x_p + N z``, ``N`` a basis of the null space of
    every kept equality row (so no equality constraint reaches the solver):
    ``min e_k(x) + λ‖x‖²`` subject to the hard box and the kept inequality
    intervals, by DAQP on the ``(z, ω)`` problem. Returns each level's ``x``."""
    import daqp

    x_p, N = np.zeros(NV), np.eye(NV)
    C_kept, lo_kept, hi_kept = [hard.C], [hard.d_lower], [hard.d_upper]
    out = []
    for rows in levels:
        p, s = N.shape[1], rows.n_in
        AN = rows.A @ N
        H = np.zeros((p + s, p + s))
        H[:p, :p] = 2 * (AN.T @ (rows.w_A[:, None] * AN) + lam * N.T @ N)
        H[p:, p:] = 2 * np.diag(rows.w_C)
        f = np.zeros(p + s)
        f[:p] = 2 * (AN.T @ (rows.w_A * (rows.A @ x_p - rows.b)) + lam * N.T @ x_p)
        C = np.vstack(C_kept)
        G = np.vstack(
            [np.hstack([C @ N, np.zeros((C.shape[0], s))]), np.hstack([rows.C @ N, np.eye(s)])]
        )
        upper = np.concatenate([np.concatenate(hi_kept) - C @ x_p, rows.d_upper - rows.C @ x_p])
        lower = np.concatenate([np.concatenate(lo_kept) - C @ x_p, rows.d_lower - rows.C @ x_p])
        z, _, flag, _ = daqp.solve(
            H, f, np.ascontiguousarray(G), np.minimum(upper, 1e30), np.maximum(lower, -1e30)
        )
        assert flag in (1, 2), flag
        x = x_p + N @ z[:p]
        out.append(x)
        keep = rows.w_A > 0
        M = rows.A[keep] @ N
        if M.size:
            _, sv, Vt = np.linalg.svd(M)
            N = N @ Vt[int(np.sum(sv > 1e-10 * max(1.0, sv[0]))) :].T
        x_p = x
        cx = rows.C @ x
        C_kept.append(rows.C)
        lo_kept.append(np.minimum(rows.d_lower, cx))
        hi_kept.append(np.maximum(rows.d_upper, cx))
    return out


@pytest.mark.parametrize("seed", range(12))
def test_hierarchical_backend_matches_sequential_qps_extrapolated_to_exact_levels(seed):
    """A sequential reference at λ and 2λ, extrapolated to λ = 0
    (``2 e(λ) − e(2λ)``, exact to O(λ²)): each level's error agrees, and the
    hard box holds."""
    hard, levels, _ = mixed_stack(seed)
    lam = 1e-6
    ref1 = nullspace_qp_reference(hard, levels, lam)
    ref2 = nullspace_qp_reference(hard, levels, 2 * lam)
    step = solve_cascade(hard, levels, [Regularization()] * len(levels), HQP)
    for k, (rows, x1, x2) in enumerate(zip(levels, ref1, ref2, strict=True)):
        exact = 2 * rows.squared_error(x1) - rows.squared_error(x2)
        assert abs(rows.squared_error(step.x) - exact) <= 1e-7 * max(1.0, exact), k
    assert np.all(np.abs(step.x) <= 0.4 + 1e-9)


@pytest.mark.parametrize(
    ("backend", "w", "seed"),
    [(QpsolversBackend("daqp"), 1e-4, 7), (HQP, 1e-9, 11)],
    ids=["daqp per level", "daqp-hqp"],
)
def test_other_backends_agree_with_the_osqp_cascade(backend, w, seed):
    """The same random hierarchy on tight OSQP and on DAQP (level by level, or
    the whole hierarchy in one call at a regularization small enough for its
    exact levels): every level's error at the final step agrees."""
    rng = np.random.default_rng(seed)
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    levels = [random_rows(rng, 3, 2, rank=2) for _ in range(3)]
    regs = [Regularization(w, 0.0, 1.0)] * 3
    a = solve_cascade(hard, levels, regs, tight(), relaxation=1e-9, closed_form=False)
    b = solve_cascade(hard, levels, regs, backend, relaxation=1e-9, closed_form=False)
    for rows in levels:
        ea, eb = rows.squared_error(a.x), rows.squared_error(b.x)
        assert abs(ea - eb) <= 1e-6 * max(1.0, ea)


def test_hierarchical_layout_follows_hard_rows_refilled_in_place():
    """A stacked level 0 is a buffer the solve refills in place: the layout
    kept for its shape (which rows are bounds, their coefficients) follows its
    values. Row 0's coefficient doubles and row 1 becomes a bound; the problem
    equals the one built without a cache."""
    cache: dict = {}
    C = np.zeros((2, NV))
    C[0, 0], C[1, :2] = 1.0, [1.0, 1.0]
    hard = TaskRows.inequality(C, -1.0, 1.0)
    assert hard.C is C
    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))]
    HierarchicalProblem.from_rows(hard, levels, cache)
    C[0, 0], C[1] = 2.0, np.eye(NV)[1]
    cached = HierarchicalProblem.from_rows(hard, levels, cache)
    fresh = HierarchicalProblem.from_rows(hard, levels)
    for name in ("A", "bupper", "blower", "sense", "break_points"):
        np.testing.assert_array_equal(getattr(cached, name), getattr(fresh, name), name)
    assert fresh.bupper[0] == 0.5 and fresh.bupper[1] == 1.0
    # equal values in a new read-only object: the layout is kept, no rebuild
    frozen = C.copy()
    frozen.flags.writeable = False
    layout = next(iter(cache.values()))
    HierarchicalProblem.from_rows(TaskRows.inequality(frozen, -1.0, 1.0), levels, cache)
    assert next(iter(cache.values())) is layout and layout.C is frozen


def test_hierarchical_simple_bounds_intersect_every_single_entry_row():
    """Hard rows with one entry, ``c x_i ∈ [l, u]``, become DAQP's simple bounds
    on ``x_i``: for each column the intersection of its rows' intervals
    (``[l/c, u/c]``, swapped for ``c < 0``), within ±1e30, as a loop over the
    rows finds it; columns without such a row are free (±1e30), ``d`` is
    fixed at 0, and a row with several entries stays a general row. Rows of
    both signs and several per column, infinite and finite bounds; the same
    with a cached layout whose bounds change."""
    inf = np.inf
    single = [  # (column, c, l, u)
        (0, 2.0, -1.0, 3.0),
        (0, -0.5, -1.0, 0.25),
        (2, 1.0, -inf, 0.75),
        (2, -1.0, -inf, 0.25),
        (2, 4.0, -8.0, inf),
        (5, -3.0, -inf, inf),
        (6, 1.0, -inf, 0.5),
        (6, -1.0, -inf, 0.5),
    ]
    C = np.zeros((len(single) + 1, NV))
    for r, (i, c, _, _) in enumerate(single):
        C[r, i] = c
    C[-1, [1, 3]] = 1.0  # a general row
    levels = [TaskRows.equality(np.eye(NV), np.zeros(NV))]
    cache: dict = {}
    for scale in (1.0, 0.5):
        lo = np.array([scale * l for _, _, l, _ in single] + [-1.0])
        hi = np.array([scale * u for _, _, _, u in single] + [1.0])
        problem = HierarchicalProblem.from_rows(TaskRows.inequality(C, lo, hi), levels, cache)
        lower, upper = np.full(NV + 1, -1e30), np.full(NV + 1, 1e30)
        lower[NV] = upper[NV] = 0.0
        for r, (i, c, _, _) in enumerate(single):
            a, b = sorted((lo[r] / c, hi[r] / c))
            lower[i] = max(lower[i], a, -1e30)
            upper[i] = min(upper[i], b, 1e30)
        np.testing.assert_array_equal(problem.blower[: NV + 1], lower)
        np.testing.assert_array_equal(problem.bupper[: NV + 1], upper)
        assert problem.A.shape[0] == 1 + NV and problem.A[0, :NV].tolist() == C[-1].tolist()
        assert (problem.blower[NV + 1], problem.bupper[NV + 1]) == (-1.0, 1.0)
    assert (lower[0], upper[0]) == (-0.25, 0.75)  # (scale 0.5: [-0.25, 0.75] ∩ [-0.25, 1])
    assert (lower[2], upper[2]) == (-0.125, 0.375) and (lower[5], upper[5]) == (-1e30, 1e30)


def test_hierarchical_problem_buffers_are_rewritten_in_full():
    """A cached layout's arrays are written in place by every problem of its
    shape: problems of one shape with new values (random rows, a zero weight
    dropping a row, bounds and joint-limit-like box rows changed, a read-only
    posture-like matrix whose zero rows move) equal the ones built without a
    cache, entry for entry. A buffer entry left from the last problem (stale
    rows or bounds), or a zero-row mask kept for another matrix, fails this
    test. Leaving a read-only matrix's zero rows out does not change DAQP's
    solution (the same rows, writable, are all handed over)."""
    rng = np.random.default_rng(7)
    cache: dict = {}
    zero_rows: dict = {}
    box = np.vstack([np.eye(NV), -np.eye(NV)])
    box.flags.writeable = False
    general = rng.normal(size=(1, NV))
    C = np.vstack([box, general])
    C.flags.writeable = False
    for trial in range(4):
        hard = TaskRows(
            np.zeros((0, NV)),
            np.zeros(0),
            np.zeros(0),
            C,
            np.r_[np.full(2 * NV, -np.inf), -1.0],
            np.r_[rng.uniform(0.1, 1.0, 2 * NV), 1.0 + trial],
            np.ones(2 * NV + 1),
        )
        w = np.array([1.0, 0.0, 4.0]) if trial % 2 else np.array([0.0, 2.0, 1.0])
        posture = np.eye(NV)
        posture[:, [trial, trial + 1]] = 0.0  # two zero rows, a new pair each trial
        posture.flags.writeable = False
        target = rng.normal(size=NV)
        levels = [
            TaskRows.equality(rng.normal(size=(3, NV)), rng.normal(size=3), w),
            random_rows(rng, 2, 2, rank=2),
            TaskRows.equality(posture, target, 0.01),
        ]
        assert levels[2].A is posture
        cached = HierarchicalProblem.from_rows(hard, levels, cache, zero_rows)
        fresh = HierarchicalProblem.from_rows(hard, levels)
        # the general hard row, 2 of 3 rows (one of weight 0), 2 + 2 rows, NV - 2 of NV rows
        assert cached.A.shape == (1 + 2 + 4 + NV - 2, NV + 1)
        for name in ("A", "bupper", "blower", "sense", "break_points"):
            np.testing.assert_array_equal(getattr(cached, name), getattr(fresh, name), name)
        x = HQP.solve_hierarchy(cached).z
        np.testing.assert_array_equal(x, HQP.solve_hierarchy(fresh).z)
        writable = [*levels[:2], TaskRows.equality(posture.copy(), target, 0.01)]
        every_row = HierarchicalProblem.from_rows(hard, writable)
        assert every_row.A.shape[0] == cached.A.shape[0] + 2
        np.testing.assert_allclose(HQP.solve_hierarchy(every_row).z, x, atol=1e-12)
    assert len(cache) == 1  # one shape: the same buffers every time


def test_hierarchical_backend_weights_rows_within_a_level():
    """DAQP normalizes each soft row; the auxiliary column restores the level's
    weights: rows x0 = 1 (weight 1) and x0 = 0 (weight 100) give x0 = 1/101."""
    nv = 2
    level = TaskRows.equality(np.array([[1.0, 0.0], [1.0, 0.0]]), [1.0, 0.0], [1.0, 100.0])
    step = solve_cascade(TaskRows.empty(nv), [level], [Regularization()], HQP)
    np.testing.assert_allclose(step.x, [1.0 / 101.0, 0.0], atol=1e-9)


@pytest.mark.parametrize(
    "backend", [HQP, DAQPBackend(), OSQPBackend()], ids=["hqp", "daqp", "osqp"]
)
def test_every_backend_names_infeasible_hard_rows(backend):
    hard = TaskRows.stack(
        [
            TaskRows.inequality(np.eye(NV)[:1], 1.0, 2.0),
            TaskRows.inequality(np.eye(NV)[:1], -2.0, -1.0),
        ],
        NV,
    )
    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))]
    with pytest.raises(InfeasibleHardConstraints, match="level 0"):
        solve_cascade(hard, levels, [Regularization()], backend)


@pytest.mark.parametrize("rank", [12, 9, 1])
def test_null_space_projector_matches_pseudo_inverse(rank):
    """The kept rows' projector (Cholesky of the Gram matrix when its rows are
    independent, the eigendecomposition when not) against numpy's SVD
    pseudo-inverse: ``P = I - B⁺ B``, and a later level's ``G⁺ r`` likewise."""
    rng = np.random.default_rng(rank)
    nv = 62
    B = rng.normal(size=(12, rank)) @ rng.normal(size=(rank, nv))
    G = B @ B.T
    assert (cholesky(G) is None) == (rank < 12)
    cascade = NullSpaceCascade(TaskRows.empty(nv), None, 0.0, "step")
    cascade._keep(B)
    P = np.eye(nv) - np.linalg.pinv(B, rcond=1e-10) @ B
    np.testing.assert_allclose(cascade.P, P, atol=1e-12)
    # a second level's rows, projected onto that null space (rank-deficient
    # when the first level took some of their directions)
    B2 = np.vstack([rng.normal(size=(3, nv)), B[:2]]) @ cascade.P
    G2 = B2 @ B2.T
    r = rng.normal(size=5)
    np.testing.assert_allclose(
        psd_solve(G2, r), np.linalg.pinv(G2, rcond=1e-10, hermitian=True) @ r, atol=1e-9
    )


@pytest.mark.parametrize("backend", ["osqp", "daqp-hqp"])
def test_a_correction_of_one_equality_level_is_its_closed_form(backend):
    """The correction's common case (one level of equality rows under joint
    limits) is :func:`~pik_mj.cascade._projection`: the weighted rows' least
    norm solution for daqp-hqp (``λ = 0``; reference: numpy's pseudo-inverse)
    and the regularized one for OSQP (reference: the primal normal equations
    ``(Bᵀ B + λ I)⁻¹ Bᵀ r``, not the dual form the code uses), with no QP
    handed to the backend. An active limit, or dependent rows with ``λ = 0``,
    leave it to the cascade: the limit is then met, and the dependent rows get
    the pseudo-inverse."""
    rng = np.random.default_rng(11)
    rows = random_rows(rng, 4, 0)
    B = np.sqrt(rows.w_A)[:, None] * rows.A
    r = np.sqrt(rows.w_A) * rows.b
    loose = TaskRows.inequality(np.eye(NV), -1e3, 1e3)
    reg = Regularization()
    lam = 0.0 if backend == "daqp-hqp" else reg.weight(rows.squared_error())
    if lam:
        reference = np.linalg.solve(B.T @ B + lam * np.eye(NV), B.T @ r)
    else:
        reference = np.linalg.pinv(B) @ r
    fix = solve_cascade(loose, [rows], [reg], make_backend(backend), role="correction")
    np.testing.assert_allclose(fix.x, reference, rtol=0, atol=1e-12)
    assert fix.problems == [] and fix.closed_form == 1 and fix.level_lambdas == [lam]

    i = int(np.argmax(np.abs(reference)))
    bound = 0.5 * abs(reference[i])
    limited = TaskRows.inequality(np.eye(NV)[i : i + 1], -bound, bound)
    assert _projection(limited, rows, lam) is None
    fix = solve_cascade(limited, [rows], [reg], make_backend(backend), role="correction")
    assert abs(fix.x[i]) <= bound + 1e-6

    dependent = TaskRows.equality(np.vstack([rows.A, rows.A[:1]]), np.append(rows.b, rows.b[0]))
    assert _projection(loose, dependent, 0.0) is None
    if backend == "daqp-hqp":
        fix = solve_cascade(loose, [dependent], [reg], make_backend(backend), role="correction")
        np.testing.assert_allclose(fix.x, np.linalg.pinv(dependent.A) @ dependent.b, atol=1e-10)


def _numpy_pivot_test(G: np.ndarray) -> bool:
    """The pivot test on numpy's LAPACK factor: regular when every ``L_ii²``
    exceeds ``CHOLESKY_PIVOT`` times ``G``'s largest diagonal entry."""
    try:
        L = np.linalg.cholesky(G)
    except np.linalg.LinAlgError:
        return False
    return float(L.diagonal().min()) ** 2 > CHOLESKY_PIVOT * float(G.diagonal().max())


@pytest.mark.parametrize("n", [1, 6, 12, 56])
def test_mujoco_cholesky_matches_numpy_and_the_pivot_test(n):
    """``cholesky`` and ``chol_solve`` (MuJoCo's ``mju_cholFactor`` and
    ``mju_cholSolve``) against numpy's LAPACK ``cholesky`` and ``solve`` on
    regular Gram matrices, and None exactly where the pivot test on numpy's
    factor finds ``G`` singular or nearly so: dependent rows, a row scaled to
    1e-6, no rows, a negative definite ``G``."""
    rng = np.random.default_rng(n)
    nv = 62
    B = rng.normal(size=(n, nv))
    G = B @ B.T
    r = rng.normal(size=n)
    assert _numpy_pivot_test(G)
    L = cholesky(G)
    np.testing.assert_allclose(L, np.linalg.cholesky(G), rtol=1e-12, atol=1e-12)
    assert np.all(np.triu(L, 1) == 0.0)
    y = chol_solve(G, r)
    np.testing.assert_allclose(y, np.linalg.solve(G, r), rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(G, B @ B.T)  # G itself untouched
    if n > 1:
        dependent = np.vstack([B[:-1], B[0] + B[1]])
        tiny = np.vstack([B[:-1], 1e-6 * B[-1]])
        for singular in (dependent, tiny):
            S = singular @ singular.T
            assert not _numpy_pivot_test(S)
            assert cholesky(S) is None and chol_solve(S, r) is None
    for singular in (np.zeros((n, n)), -G):
        assert not _numpy_pivot_test(singular)
        assert cholesky(singular) is None and chol_solve(singular, r) is None
    assert chol_solve(np.zeros((0, 0)), np.zeros(0)) is None
