"""The cascade against independent references on random hierarchies.

* Equality-only stacks: closed-form null-space projection (no QP at all).
* Stacks with inequalities and hard rows: sequential dense QPs solved by DAQP
  (a dual active-set solver) with the higher levels' achieved values kept
  *exactly* (dependent rows removed by SVD), slacks explicit.
"""

from __future__ import annotations

import numpy as np
import pytest
import qpsolvers

from pik_mj import InfeasibleHardConstraints, QPFailure, TaskRows
from pik_mj.cascade import DEFAULT_RELAXATION, Regularization, solve_cascade
from pik_mj.qp import OSQPBackend, QpsolversBackend

NV = 8
# eps_prim_inf well below τ (1e-9): see OSQP_DEFAULTS.
TIGHT = OSQPBackend({"eps_abs": 1e-9, "eps_rel": 1e-9, "eps_prim_inf": 1e-12, "max_iter": 100000})


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


@pytest.mark.parametrize("seed", range(12))
def test_equality_stacks_match_nullspace_projection(seed):
    rng = np.random.default_rng(seed)
    n_levels = rng.integers(3, 5)
    # Rank-deficient and conflicting: level sizes add up to more than NV.
    levels = [
        random_rows(rng, int(rng.integers(2, 5)), 0, rank=int(rng.integers(1, 3)))
        for _ in range(n_levels)
    ]
    regs = [Regularization(1e-6, 1.0, 0.1)] * n_levels
    step = solve_cascade(TaskRows.empty(NV), levels, regs, TIGHT, relaxation=1e-9)
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


@pytest.mark.parametrize("seed", range(12))
def test_mixed_stacks_match_sequential_dense_qps(seed):
    hard, levels, regs = mixed_stack(seed)
    step = solve_cascade(hard, levels, regs, TIGHT, relaxation=1e-9)
    reference = daqp_reference(hard, levels, regs)
    for k, (rows, (x_ref, lam)) in enumerate(zip(levels, reference, strict=True)):
        assert_same_optimum(
            level_objective(rows, lam, step.level_x[k]),
            level_objective(rows, lam, x_ref),
            k,
        )
    assert np.all(np.abs(step.x) <= 0.4 + 1e-7)  # hard rows hold
    check_never_worsened(step, levels, 1e-9)


@pytest.mark.parametrize("seed", range(8))
def test_default_settings_keep_higher_levels_within_documented_relaxation(seed):
    """With the default OSQP settings, a lower level moves a higher level's rows by
    at most τ + ε_prim (eps_abs + eps_rel·scale)."""
    rng = np.random.default_rng(200 + seed)
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    levels = [random_rows(rng, 3, 2, rank=2) for _ in range(4)]
    regs = [Regularization()] * 4
    step = solve_cascade(hard, levels, regs, OSQPBackend(), DEFAULT_RELAXATION)
    check_never_worsened(step, levels, DEFAULT_RELAXATION)
    # The bound is tight to the solver: feasibility errors stay near eps_abs.
    assert max(step.violations) <= 1e-4


def test_other_backend_agrees_with_osqp():
    rng = np.random.default_rng(7)
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    levels = [random_rows(rng, 3, 2, rank=2) for _ in range(3)]
    regs = [Regularization(1e-4, 1.0, 0.1)] * 3
    a = solve_cascade(hard, levels, regs, TIGHT, relaxation=1e-9)
    b = solve_cascade(hard, levels, regs, QpsolversBackend("daqp"), relaxation=1e-9)
    for k, rows in enumerate(levels):
        lam = a.level_lambdas[k]
        assert_same_optimum(
            level_objective(rows, lam, a.level_x[k]),
            level_objective(rows, lam, b.level_x[k]),
            k,
        )


def test_regularization_formula():
    reg = Regularization(w=1e-3, w_r=2.0, w_max=0.5)
    assert reg.weight(0.1) == pytest.approx(1e-3 + 0.2)
    assert reg.weight(10.0) == 0.5


def test_infeasible_hard_rows_raise():
    hard = TaskRows.stack(
        [
            TaskRows.inequality(np.eye(NV)[:1], 1.0, 2.0),
            TaskRows.inequality(np.eye(NV)[:1], -2.0, -1.0),
        ],
        NV,
    )
    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))]
    with pytest.raises(InfeasibleHardConstraints, match="level 0"):
        solve_cascade(hard, levels, [Regularization()], OSQPBackend())


def test_failed_level_carries_level_and_problem():
    class Failing:
        def solve(self, problem):
            from pik_mj.qp import QPSolution

            return QPSolution(None, "max iterations", False)

    levels = [TaskRows.equality(np.eye(NV), np.ones(NV))] * 2
    # the hard row x_0 <= 0 is active, so level 1 needs the backend
    hard = TaskRows.inequality(np.eye(NV)[:1], -np.inf, 0.0)
    with pytest.raises(QPFailure) as info:
        solve_cascade(hard, levels, [Regularization()] * 2, Failing())
    assert info.value.level == 1
    assert info.value.problem.P.shape == (NV, NV)


def test_level_without_active_constraint_is_solved_in_closed_form():
    """Level 1 with inactive hard rows never reaches the backend, and its closed
    form ``-P⁻¹q`` is the backend's optimum; an active hard row sends it there."""

    class Counting:
        def __init__(self):
            self.levels, self.inner = [], OSQPBackend(dict(TIGHT.settings))

        def solve(self, problem):
            self.levels.append(problem.level)
            return self.inner.solve(problem)

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
    assert backend.levels == [2]
    reference = QpsolversBackend("daqp").solve(step.problems[0])  # exact active set
    np.testing.assert_allclose(step.level_x[0], reference.z[:NV], atol=1e-10)
    assert step.violations[0] == 0.0

    x_free = step.level_x[0]
    i = int(np.argmax(np.abs(x_free)))
    bound = 0.5 * abs(x_free[i])
    tight = TaskRows.inequality(np.eye(NV)[i : i + 1], -bound, bound)
    backend = Counting()
    step = solve_cascade(tight, levels, regs, backend)
    assert backend.levels == [1, 2]
    assert abs(step.level_x[0][i]) <= bound + 1e-6


def test_tight_osqp_rarely_needs_the_fallback():
    """At 1e-9, OSQP itself solves the great majority of levels; DAQP only rescues
    the few degenerate ones where ADMM stalls (measured: about 1 level in 10)."""
    backend = OSQPBackend(dict(TIGHT.settings))
    levels_solved = 0
    for seed in range(12):
        hard, levels, regs = mixed_stack(seed)
        solve_cascade(hard, levels, regs, backend, 1e-9)
        levels_solved += len(levels)
    assert backend.fallbacks <= 0.2 * levels_solved, (backend.fallbacks, levels_solved)


def test_osqp_backend_sets_up_once_per_level_and_updates_after():
    rng = np.random.default_rng(3)
    backend = OSQPBackend()
    hard = TaskRows.inequality(np.eye(NV), -0.4, 0.4)
    for _ in range(5):
        levels = [random_rows(rng, 3, 2) for _ in range(3)]
        solve_cascade(hard, levels, [Regularization()] * 3, backend)
    assert backend.setups == 3
