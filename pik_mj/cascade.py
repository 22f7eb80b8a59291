"""One step of the priority cascade: one QP per level (seed 000,
``prioritized-inverse-kinematics``).

Level ``k >= 1`` solves, over ``x = Δq`` (length ``nv``) and slacks ``ω_k`` for its
own inequality rows:

.. math::

    \\min_{x, \\omega_k}\\; \\sum (A_k x - b_k)^T W_A (A_k x - b_k)
        + \\omega_k^T W_C \\omega_k + \\lambda_k \\|x\\|^2

subject to

* level 0's rows, hard: ``A_0 x = b_0``, ``d_l0 <= C_0 x <= d_u0``;
* every level ``j < k`` kept at what it achieved at its own solution ``x_j*``:
  ``|A_j x - A_j x_j*| <= τ`` and
  ``min(d_lj, C_j x_j*) - τ <= C_j x <= max(d_uj, C_j x_j*) + τ``;
* ``d_lk <= C_k x + ω_k <= d_uk``;

with ``λ_k = min(w + w_r e_k, w_max) + μ_k``, ``e_k`` the level's squared error at
``x = 0`` and ``μ_k`` the tasks' own Levenberg–Marquardt damping.

``τ`` (:data:`DEFAULT_RELAXATION`) absorbs the inexactness of a first-order
solver, so that a lower level can never be made infeasible by the rounding of a
higher one; it is also the bound by which a lower level may move a higher
level's rows. Kept rows are further widened by the feasibility error ``v_k``
of every later level's solution times the row's 1-norm, since each ``x_k*`` met
the hard rows only to within ``v_k``: a row ``a`` of level ``j`` ends within
``τ + ‖a‖₁ Σ_{k>=j} v_k`` of what level ``j`` achieved (the bound the tests check).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from .exceptions import InfeasibleHardConstraints, InvalidInput, QPFailure
from .qp import LevelProblem, QPBackend, QPSolution
from .tasks.task import TaskRows

DEFAULT_RELAXATION = 1e-5
"""τ [row units: m, rad], ten times the absolute tolerance of the default OSQP
settings. A lower level may move a higher level's row by at most
``τ + ε_prim``, with ``ε_prim = eps_abs + eps_rel·max(|A z|, |z|)`` OSQP's
primal feasibility tolerance."""


@dataclass(frozen=True)
class Regularization:
    """Seed ``regular``, ``regular-rel``, ``regular-max`` for one level.

    ``λ = min(w + w_r · e, w_max)`` where ``e`` is the level's squared error.
    """

    w: float = 1e-6
    w_r: float = 5.0
    w_max: float = 0.1

    def weight(self, squared_error: float) -> float:
        return min(self.w + self.w_r * squared_error, self.w_max)


def per_level(value: float | Sequence[float], n_levels: int, name: str) -> list[float]:
    """Seed convention: a float is shared by every level, a list gives one per level."""
    if np.ndim(value) == 0:
        values = [float(value)] * n_levels  # type: ignore[arg-type]
    else:
        values = [float(v) for v in value]  # type: ignore[union-attr]
        if len(values) != n_levels:
            raise InvalidInput(
                f"{name} has {len(values)} entries; give a float or one per solved "
                f"level ({n_levels})"
            )
    if not all(np.isfinite(v) and v >= 0 for v in values):
        raise InvalidInput(f"{name} must be finite and >= 0, got {values}")
    return values


@dataclass
class CascadeStep:
    """Result of one cascade step.

    Attributes:
        x: The step of the last level, shape (nv,).
        level_x: ``x_k*`` for each solved level k = 1..K.
        level_errors: Squared error ``e_k`` of each solved level at ``x = 0``.
        level_lambdas: Regularization ``λ_k`` used at each level.
        problems: The QP of each level (for inspection and tests).
        violations: Feasibility error ``v_k`` of each level's solution
            (largest constraint violation of its QP). A row ``a`` of level
            ``j`` ends within ``τ + ‖a‖₁ Σ_{k>=j} v_k`` of its value at ``x_j*``.
    """

    x: np.ndarray
    level_x: list[np.ndarray]
    level_errors: list[float]
    level_lambdas: list[float]
    problems: list[LevelProblem]
    violations: list[float]


def _bounds_kept(rows: TaskRows, x_star: np.ndarray, tau: float, violation: float) -> tuple:
    """Rows of a higher level and the bounds that hold what it achieved.

    Each row is widened by ``τ + v Σ_i |M_ri|``: ``v`` is how far ``x_star``
    itself violates its level's constraints (the solver's feasibility error), so
    keeping the row exactly could conflict with hard rows that ``x_star`` only
    met to within ``v``.
    """
    keep = rows.w_A > 0  # zero-weight rows carry no objective: nothing to keep
    M = np.vstack([rows.A[keep], rows.C])
    mx = M @ x_star
    n_eq = int(keep.sum())
    widen = tau + violation * np.abs(M).sum(axis=1)
    lo = np.concatenate([mx[:n_eq], np.minimum(rows.d_lower, mx[n_eq:])]) - widen
    hi = np.concatenate([mx[:n_eq], np.maximum(rows.d_upper, mx[n_eq:])]) + widen
    return M, lo, hi


def build_level_problem(
    level: int,
    rows: TaskRows,
    constraint_rows: tuple[np.ndarray, np.ndarray, np.ndarray],
    lam: float,
    role: str = "step",
) -> LevelProblem:
    """Assemble the QP of one level from its rows and the rows it must keep.

    Args:
        level: Priority level k >= 1.
        rows: The level's own rows.
        constraint_rows: ``(M, lo, hi)``: hard and kept rows ``lo <= M x <= hi``.
        lam: Regularization ``λ_k`` on ``‖x‖²``.
    """
    nv = rows.A.shape[1]
    s = rows.n_in
    n = nv + s
    M, lo, hi = constraint_rows
    WA = rows.A * rows.w_A[:, None]
    if s == 0:  # equality rows only: no slack block
        P = rows.A.T @ WA
        P.flat[:: n + 1] += lam
        return LevelProblem(level, P, -(WA.T @ rows.b), M, lo, hi, nv, role)
    P = np.zeros((n, n))
    P[:nv, :nv] = rows.A.T @ WA
    P.flat[: nv * (n + 1) : n + 1] += lam
    P.flat[nv * (n + 1) :: n + 1] = rows.w_C
    q = np.zeros(n)
    q[:nv] = -(WA.T @ rows.b)
    A = np.zeros((M.shape[0] + s, n))
    A[: M.shape[0], :nv] = M
    A[M.shape[0] :, :nv] = rows.C
    A[M.shape[0] :, nv:] = np.eye(s)
    l = np.concatenate([lo, rows.d_lower])
    u = np.concatenate([hi, rows.d_upper])
    return LevelProblem(level, P, q, A, l, u, nv, role)


def unconstrained_optimum(problem: LevelProblem) -> QPSolution | None:
    """The exact optimum of ``problem`` when no constraint is active, else None.

    ``P`` is positive definite (``λ > 0`` on ``x``, slack weights ``> 0``), so
    ``z = -P⁻¹ q`` (MuJoCo's dense Cholesky, ``mju_cholFactor``/``mju_cholSolve``)
    is the unique minimizer of the objective; when it also
    satisfies ``l <= A z <= u`` it is the QP's optimum (the active set is
    empty). This is the common case of level 1, whose only constraints are
    the hard rows (joint limits far from the step): one 27×27 solve instead of
    an ADMM run.
    """
    n = problem.P.shape[0]
    L = np.array(problem.P, dtype=float)  # factorized in place: P = L Lᵀ
    if mujoco.mju_cholFactor(L, 0.0) < n:  # not positive definite
        return None
    z = np.empty(n)
    mujoco.mju_cholSolve(z, L, -problem.q)
    Az = problem.A @ z
    if not (np.all(np.isfinite(z)) and np.all(problem.l <= Az) and np.all(Az <= problem.u)):
        return None
    return QPSolution(z, "unconstrained optimum (no active constraint)", True)


def solve_cascade(
    hard: TaskRows,
    levels: Sequence[TaskRows],
    regularization: Sequence[Regularization],
    backend: QPBackend,
    relaxation: float = DEFAULT_RELAXATION,
    role: str = "step",
) -> CascadeStep:
    """Solve the cascade at one linearization point.

    Args:
        hard: Level-0 rows (hard constraints; assumed feasible, never solved alone).
        levels: Rows of levels 1..K, highest priority first.
        regularization: One :class:`Regularization` per level 1..K.
        backend: QP backend.
        relaxation: ``τ`` [row units].
        role: Tag of the problems (``"step"`` or ``"correction"``) for backends
            that cache per problem.

    Raises:
        InfeasibleHardConstraints: Level 1 is infeasible: only level 0's hard rows
            can make it so.
        QPFailure: Another level's QP failed; carries the level and the problem.
    """
    nv = hard.A.shape[1]
    M = np.vstack([hard.A, hard.C])
    lo = np.concatenate([hard.b, hard.d_lower])
    hi = np.concatenate([hard.b, hard.d_upper])
    n_hard = M.shape[0]
    level_x: list[np.ndarray] = []
    errors: list[float] = []
    lambdas: list[float] = []
    problems: list[LevelProblem] = []
    violations: list[float] = []
    x = np.zeros(nv)
    n_levels = len(levels)
    for k, (rows, reg) in enumerate(zip(levels, regularization, strict=True), start=1):
        e_k = rows.squared_error()
        lam = reg.weight(e_k) + rows.damping
        problem = build_level_problem(k, rows, (M, lo, hi), lam, role)
        solution = None
        if M.shape[0] == n_hard:  # no kept rows yet: the free optimum may be feasible
            solution = unconstrained_optimum(problem)
        exact = solution is not None  # feasible by the check: no violation
        if solution is None:
            solution = backend.solve(problem)
        if not solution.ok or solution.z is None:
            if k == 1 and "infeasible" in solution.status.lower():
                raise InfeasibleHardConstraints(
                    f"the hard rows of level 0 admit no step (level 1 QP status: {solution.status})"
                )
            raise QPFailure(k, solution.status, problem)
        x = solution.z[:nv]
        level_x.append(x)
        errors.append(e_k)
        lambdas.append(lam)
        problems.append(problem)
        # x met every constraint only to within v: rows kept from higher levels
        # must tolerate that much too, or hard rows and kept rows could conflict.
        violation = 0.0 if exact else problem.max_violation(solution.z)
        violations.append(violation)
        if k == n_levels:  # nothing below to keep these rows for
            break
        if violation > 0 and M.shape[0] > n_hard:
            widen = violation * np.abs(M[n_hard:]).sum(axis=1)
            lo, hi = lo.copy(), hi.copy()  # earlier problems hold the old bounds
            lo[n_hard:] -= widen
            hi[n_hard:] += widen
        M_k, lo_k, hi_k = _bounds_kept(rows, x, relaxation, violation)
        M = np.vstack([M, M_k])
        lo = np.concatenate([lo, lo_k])
        hi = np.concatenate([hi, hi_k])
    return CascadeStep(x.copy(), level_x, errors, lambdas, problems, violations)
