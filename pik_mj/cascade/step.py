"""One step of the priority cascade at one linearization point
(:func:`solve_cascade`), its regularization and its result."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pik_mj.cascade.linalg import chol_solve, regular_solve
from pik_mj.cascade.nullspace import FEASIBILITY_TOLERANCE, NullSpaceCascade, overshoot
from pik_mj.exceptions import InfeasibleHardConstraints, InvalidInput, QPFailure
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.hierarchy import HierarchicalProblem
from pik_mj.qp.make import as_backend
from pik_mj.qp.problem import LevelProblem, QPSolution
from pik_mj.tasks.task import TaskRows

DEFAULT_RELAXATION = 1e-5
"""τ [row units: m, rad], ten times the absolute tolerance of the default OSQP
settings. A lower level may move a higher level's row by at most
``τ + ε_prim``, with ``ε_prim = eps_abs + eps_rel·max(|A z|, |z|)`` OSQP's
primal feasibility tolerance."""


@dataclass(frozen=True)
class Regularization:
    """``regular``, ``regular-rel``, ``regular-max`` (prioritized-IK manual) for one level.

    ``λ = min(w + w_r · e, w_max)`` where ``e`` is the level's squared error.
    """

    w: float = 1e-6
    w_r: float = 5.0
    w_max: float = 0.1

    def weight(self, squared_error: float) -> float:
        return min(self.w + self.w_r * squared_error, self.w_max)


def per_level(value: float | Sequence[float], n_levels: int, name: str) -> list[float]:
    """The prioritized-IK manual's convention: a float is shared by every level, a
    list gives one per level."""
    if type(value) is float:  # the common case, without numpy calls
        values = [value] * n_levels
    else:
        try:
            if np.ndim(value) == 0:
                values = [float(value)] * n_levels  # type: ignore[arg-type]
            else:
                values = [float(v) for v in value]  # type: ignore[union-attr]
        except (TypeError, ValueError):
            raise InvalidInput(
                f"{name} must be a float or one float per solved level, got {value!r}"
            ) from None
        if isinstance(value, bool) or (
            np.ndim(value) > 0 and any(isinstance(v, bool) for v in value)  # type: ignore[union-attr]
        ):
            raise InvalidInput(f"{name} must be a float or one per solved level, got {value!r}")
        if len(values) != n_levels:
            raise InvalidInput(
                f"{name} has {len(values)} entries; give a float or one per solved level "
                f"({n_levels})"
            )
    if not all(math.isfinite(v) and v >= 0 for v in values):
        raise InvalidInput(f"{name} must be finite and >= 0, got {values}")
    return values


@dataclass
class CascadeStep:
    """Result of one cascade step.

    Attributes:
        x: The step of the last level, shape (nv,).
        level_x: ``x_k*`` for each solved level k = 1..K (empty for a
            hierarchical backend, which returns the last only).
        level_errors: Squared error ``e_k`` of each solved level at ``x = 0``.
        level_lambdas: Regularization ``λ_k`` used at each level (0 for a
            hierarchical backend: each level exact).
        problems: The QP of each level handed to the backend (levels solved in
            closed form have none; see :meth:`NullSpaceCascade.level_problem`),
            or the one :class:`HierarchicalProblem` (whose arrays the backend's
            next problem of the same shape rewrites: copy them to keep them).
        violations: Feasibility error ``v_k`` of each level's solution
            (largest constraint violation of its QP; 0 in closed form). A row
            ``a`` of level ``j`` ends within ``τ + ‖a‖₁ Σ_{k>=j} v_k`` of its
            value at ``x_j*``.
        closed_form: Number of levels solved in closed form.
    """

    x: np.ndarray
    level_x: list[np.ndarray]
    level_errors: list[float]
    level_lambdas: list[float]
    problems: list[LevelProblem | HierarchicalProblem] = field(default_factory=list)
    violations: list[float] = field(default_factory=list)
    closed_form: int = 0


def solve_cascade(
    hard: TaskRows,
    levels: Sequence[TaskRows],
    regularization: Sequence[Regularization],
    backend: QPBackend,
    relaxation: float = DEFAULT_RELAXATION,
    role: str = "step",
    closed_form: bool = True,
) -> CascadeStep:
    """Solve the cascade at one linearization point.

    Args:
        hard: Level-0 rows (hard constraints; assumed feasible, never solved alone).
        levels: Rows of levels 1..K, highest priority first.
        regularization: One :class:`Regularization` per level 1..K.
        backend: QP backend, or a hierarchical backend (``solve_hierarchy``).
        relaxation: ``τ`` [row units].
        role: Tag of the problems (``"step"`` or ``"correction"``) for backends
            that cache per problem.
        closed_form: Solve a level in closed form when no inequality is active
            (False: every level goes to the backend). A backend given as an
            object or a function (prioritized-IK manual: ``qp-solver``) always
            gets every level (:attr:`~pik_mj.qp.QPBackend.allows_closed_form`).

    Raises:
        InfeasibleHardConstraints: Level 1 is infeasible: only level 0's hard rows
            can make it so.
        QPFailure: Another level's QP failed; carries the level and the problem.
    """
    backend = as_backend(backend)
    errors = [rows.squared_error() for rows in levels]
    hierarchical = backend.solves_hierarchy
    closed_form = closed_form and backend.allows_closed_form
    if hierarchical:
        lambdas = [0.0] * len(levels)
    else:
        lambdas = [
            reg.weight(e) + rows.damping
            for rows, reg, e in zip(levels, regularization, errors, strict=True)
        ]
    if role == "correction" and closed_form and len(levels) == 1:
        x = _projection(hard, levels[0], lambdas[0])
        if x is not None:
            return CascadeStep(x, [x], errors, lambdas, [], [0.0], 1)
    if hierarchical:
        if role == "correction" and closed_form:
            # The projection back onto satisfied levels: exact in closed form
            # (λ = 0, like the hierarchical solve) unless an inequality is active.
            step = _exact(hard, levels, errors)
            if step is not None:
                return step
        return _solve_hierarchy(hard, levels, errors, backend)
    cascade = NullSpaceCascade(hard, backend, relaxation, role)
    level_x: list[np.ndarray] = []
    problems: list[LevelProblem | HierarchicalProblem] = []
    violations: list[float] = []
    n_exact = 0
    n_levels = len(levels)
    for k, rows in enumerate(levels):
        x_k, problem, violation = cascade.level(
            k + 1, rows, lambdas[k], k == n_levels - 1, closed_form
        )
        level_x.append(x_k)
        violations.append(violation)
        if problem is None:
            n_exact += 1
        else:
            problems.append(problem)
    return CascadeStep(level_x[-1].copy(), level_x, errors, lambdas, problems, violations, n_exact)


def _projection(hard: TaskRows, rows: TaskRows, lam: float) -> np.ndarray | None:
    """The correction's common case in closed form: one level of equality rows
    and only inequality rows above it (joint limits). With ``B = W^½ A``,
    ``r = W^½ b``:

    .. math::

        x = B^T (B B^T + \\lambda I)^{-1} r

    returned when it meets every hard row within :data:`FEASIBILITY_TOLERANCE`
    (then it is the level's optimum, as :meth:`NullSpaceCascade.candidate`
    finds it with ``P = I``), else None: other shapes, an active limit, and
    with ``λ = 0`` rows that are dependent (a Cholesky pivot below
    :data:`~pik_mj.cascade.linalg.CHOLESKY_PIVOT`), go to
    :class:`NullSpaceCascade` and the backend. The same products without the
    cascade's bookkeeping, for the correction the solve loop runs most
    iterations.
    """
    if hard.n_eq or rows.n_in or not rows.n_eq:
        return None
    sw = np.sqrt(rows.w_A)
    B = sw[:, None] * rows.A
    G = B @ B.T
    if lam > 0:
        G.flat[:: G.shape[0] + 1] += lam
    r = sw * rows.b
    y = regular_solve(G, r) if lam > 0 else chol_solve(G, r)
    if y is None:
        return None
    x = B.T @ y
    if not math.isfinite(float(x @ x)):
        return None
    if hard.n_in:
        if float(overshoot(hard.C @ x, hard.d_lower, hard.d_upper).max()) > FEASIBILITY_TOLERANCE:
            return None
    return x


def _exact(hard: TaskRows, levels: Sequence[TaskRows], errors: list[float]) -> CascadeStep | None:
    """Every level in closed form with ``λ_k = 0``, or None if an inequality is active."""
    cascade = NullSpaceCascade(hard, None, 0.0, "correction")
    level_x = []
    for k, rows in enumerate(levels):
        x_k, _, _ = cascade.level(k + 1, rows, 0.0, k == len(levels) - 1, True)
        if x_k is None:
            return None
        level_x.append(x_k)
    n = len(levels)
    return CascadeStep(level_x[-1].copy(), level_x, errors, [0.0] * n, [], [0.0] * n, n)


def _solve_hierarchy(
    hard: TaskRows, levels: Sequence[TaskRows], errors: list[float], backend: QPBackend
) -> CascadeStep:
    """Every level in one call of a hierarchical backend."""
    problem = backend.hierarchy_problem(hard, levels)
    solution: QPSolution = backend.solve_hierarchy(problem)
    if not solution.ok or solution.z is None:
        if solution.infeasible:
            raise InfeasibleHardConstraints(
                f"the hard rows of level 0 admit no step ({solution.status})"
            )
        raise QPFailure(problem.levels[-1] if problem.levels else 1, solution.status, problem)
    return CascadeStep(
        solution.z.copy(), [], errors, [0.0] * len(levels), [problem], [], closed_form=0
    )
