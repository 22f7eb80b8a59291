"""Backends around other solvers: any ``qpsolvers`` solver, and a user's own
solver given as a function or as an object (prioritized-IK manual:
``qp-solver``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.problem import LevelProblem, QPSolution


@dataclass
class QpsolversBackend(QPBackend):
    """Any dense solver known to ``qpsolvers``, one level at a time.

    Rows with ``l = u`` go to the solver as equalities, the others as
    ``A z <= u`` and ``-A z <= -l`` where finite.
    """

    allows_closed_form: ClassVar[bool] = True

    solver: str
    kwargs: dict[str, Any] = field(default_factory=dict)

    def solve(self, problem: LevelProblem) -> QPSolution:
        """One level's QP with ``qpsolvers.solve_qp``."""
        import qpsolvers  # (its solvers' imports take a while: only when used)

        A, l, u = problem.A, problem.l, problem.u
        eq = l == u
        upper = ~eq & np.isfinite(u)
        lower = ~eq & np.isfinite(l)
        G = np.vstack([A[upper], -A[lower]])
        h = np.concatenate([u[upper], -l[lower]])
        z = qpsolvers.solve_qp(
            problem.P,
            problem.q,
            G if G.size else None,
            h if h.size else None,
            A[eq] if eq.any() else None,
            l[eq] if eq.any() else None,
            solver=self.solver,
            **self.kwargs,
        )
        return QPSolution(z, "solved" if z is not None else "failed", z is not None)


def _name(fn: object) -> str:
    return getattr(fn, "__qualname__", None) or repr(fn)


@dataclass
class CallableBackend(QPBackend):
    """A user's solver as a function: ``fn(problem, **qp_args) -> z or None``
    (prioritized-IK manual: ``qp-solver``). It gets every level.

    A result of the wrong shape or with NaN/inf raises :class:`InvalidInput`
    naming the function; None is a failed solve.
    """

    fn: Callable[..., np.ndarray | None]
    kwargs: dict[str, Any] = field(default_factory=dict)

    def solve(self, problem: LevelProblem) -> QPSolution:
        """``fn``'s solution of one level, checked."""
        z = self.fn(problem, **self.kwargs)
        if z is None:
            return QPSolution(None, f"qp_solver {_name(self.fn)} returned None", False)
        name = _name(self.fn)
        try:
            z = np.asarray(z, dtype=float)
        except (TypeError, ValueError):
            raise InvalidInput(
                f"qp_solver {name} returned {type(z).__name__}; return z (n,) or None"
            ) from None
        n = problem.P.shape[0]
        if z.shape != (n,):
            raise InvalidInput(
                f"qp_solver {name} returned shape {z.shape} for a problem of {n} "
                f"variables (level {problem.level}); return z of shape ({n},) or None"
            )
        if not np.all(np.isfinite(z)):
            raise InvalidInput(
                f"qp_solver {name} returned NaN or inf (level {problem.level}); "
                "return finite z or None"
            )
        return QPSolution(z, f"qp_solver {name}", True)


@dataclass
class ObjectBackend(QPBackend):
    """A user's solver as an object with ``solve(problem) -> QPSolution``
    (prioritized-IK manual: ``qp-solver``), which declares no capability: it
    gets every level, one at a time, and keeps nothing the cascade resets.
    (A solver that declares capabilities subclasses :class:`QPBackend`.)

    Attributes:
        solver: The user's object.
    """

    solver: Any

    def solve(self, problem: LevelProblem) -> QPSolution:
        """``solver.solve(problem)``."""
        return self.solver.solve(problem)
