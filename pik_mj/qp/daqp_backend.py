"""DAQP backends: one level at a time, or the whole hierarchy in one call.

* :class:`DAQPBackend` (``qp_solver="daqp"``): DAQP's dual active-set method on
  each level's :class:`~pik_mj.qp.problem.LevelProblem`.
* :class:`HierarchicalBackend` (``qp_solver="daqp-hqp"``): the cascade as one
  DAQP hierarchical least-squares problem
  (:class:`~pik_mj.qp.hierarchy.HierarchicalProblem`,
  ``daqp.solve(..., break_points=...)``), every level exact.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import daqp
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.hierarchy import DAQP_INF, HierarchicalProblem
from pik_mj.qp.problem import LevelProblem, QPSolution
from pik_mj.tasks.task import TaskRows

DAQP_SETTINGS = (
    "primal_tol",
    "dual_tol",
    "zero_tol",
    "pivot_tol",
    "progress_tol",
    "cycle_tol",
    "iter_limit",
    "fval_bound",
    "eps_prox",
    "eta_prox",
    "rel_subopt",
    "abs_subopt",
    "sing_tol",
    "refactor_tol",
    "time_limit",
)
"""Every key ``qp_args`` may hold for DAQP (``"daqp"`` and ``"daqp-hqp"``)."""

_DAQP_EXIT = {
    1: "optimal",
    2: "optimal with soft constraints violated",
    3: "a level of the hierarchy could not be solved (kept the solution above it)",
    -1: "primal infeasible",
    -2: "cycling detected",
    -3: "unbounded",
    -4: "iteration limit reached",
    -5: "non-convex problem",
    -6: "overdetermined initial active set",
    -7: "time limit reached",
    -8: "unsupported problem",
}


def _daqp_status(exitflag: int) -> str:
    return f"DAQP exitflag {exitflag}: {_DAQP_EXIT.get(exitflag, 'unknown')}"


def _check_daqp_settings(settings: dict[str, Any]) -> dict[str, Any]:
    unknown = sorted(set(settings) - set(DAQP_SETTINGS))
    if unknown:
        raise InvalidInput(
            f"qp_args has unknown DAQP settings {unknown}; valid: {list(DAQP_SETTINGS)}"
        )
    for k, v in settings.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise InvalidInput(f"qp_args[{k!r}] must be a number, got {v!r}")
        if not (np.isfinite(v) and v >= 0) and k not in ("eps_prox", "eta_prox"):
            raise InvalidInput(f"qp_args[{k!r}] must be a finite number >= 0, got {v!r}")
    return dict(settings)


@dataclass
class DAQPBackend(QPBackend):
    """DAQP (dual active-set, exact) on one level at a time (``"daqp"``).

    ``l <= A z <= u`` goes to DAQP as is (rows with ``l = u`` are equalities).
    """

    allows_closed_form: ClassVar[bool] = True

    settings: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.settings = _check_daqp_settings(self.settings)

    def solve(self, problem: LevelProblem) -> QPSolution:
        """One level's QP, exactly."""
        A = np.ascontiguousarray(problem.A, dtype=float)
        u = np.minimum(problem.u, DAQP_INF)
        lo = np.maximum(problem.l, -DAQP_INF)
        sense = np.where(lo == u, 5, 0).astype(np.intc)
        P = np.ascontiguousarray(problem.P, dtype=float)
        z, _, exitflag, _ = daqp.solve(P, problem.q.astype(float), A, u, lo, sense, **self.settings)
        ok = exitflag in (1, 2)
        return QPSolution(np.array(z) if ok else None, _daqp_status(exitflag), ok, exitflag == -1)


@dataclass
class HierarchicalBackend(QPBackend):
    """The whole cascade in one DAQP call (``"daqp-hqp"``), see
    :class:`HierarchicalProblem`. Each level is solved exactly (no ``λ_k``, no
    ``τ``), so the per-level regularization options do not apply.

    Attributes:
        settings: DAQP settings (keys: :data:`DAQP_SETTINGS`).
        layouts: The layout of each stack shape and its arrays
            (:meth:`HierarchicalProblem.from_rows`'s ``cache``).
        zero_rows: The zero rows of each level's read-only ``A``
            (:meth:`HierarchicalProblem.from_rows`'s ``zero_rows``).
    """

    solves_hierarchy: ClassVar[bool] = True
    allows_closed_form: ClassVar[bool] = True

    settings: dict[str, Any] = field(default_factory=dict)
    layouts: dict = field(default_factory=dict, repr=False)
    zero_rows: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.settings = _check_daqp_settings(self.settings)

    def hierarchy_problem(self, hard: TaskRows, levels: Sequence[TaskRows]) -> HierarchicalProblem:
        """The problem of a cascade's rows, made with this backend's caches
        (its arrays are rewritten by the next problem of the same shape)."""
        return HierarchicalProblem.from_rows(hard, list(levels), self.layouts, self.zero_rows)

    def solve_hierarchy(self, problem: HierarchicalProblem) -> QPSolution:
        """Every level in one ``daqp.solve`` call; a failed level 0 is told
        apart (``infeasible``) by solving it alone."""
        z, _, exitflag, _ = daqp.solve(
            problem.H,
            np.zeros(problem.nv + 1),
            problem.A,
            problem.bupper,
            problem.blower,
            problem.sense,
            problem.break_points,
            **self.settings,
        )
        status = _daqp_status(exitflag)
        x = np.array(z[: problem.nv])
        tol = 1e-6 + 10 * float(self.settings.get("primal_tol", 1e-6))
        if exitflag in (1, 2) or (exitflag == 3 and problem.hard_violation(x) <= tol):
            return QPSolution(x, status, True)
        # Was level 0 itself infeasible? (DAQP reports a failed level as exitflag 3.)
        end = int(problem.break_points[0])
        n = problem.nv + 1
        _, _, alone, _ = daqp.solve(
            problem.H,
            np.zeros(n),
            np.ascontiguousarray(problem.A[: end - n]),
            problem.bupper[:end],
            problem.blower[:end],
            problem.sense[:end],
        )
        return QPSolution(None, status, False, infeasible=alone == -1)

    def solve(self, problem: LevelProblem) -> QPSolution:
        """One level alone (not used by the cascade, which hands this backend the
        whole hierarchy): DAQP's plain QP."""
        return DAQPBackend(self.settings).solve(problem)
