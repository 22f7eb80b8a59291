"""What the cascade asks of a QP backend: the contract and its declared capabilities.

A backend solves one level's :class:`~pik_mj.qp.problem.LevelProblem`. What
else it can do is declared on it, with the defaults of :class:`QPBackend`, and
the cascade and the solve loop read those declarations (they never probe an
object for methods):

* :attr:`QPBackend.solves_hierarchy`: it solves the whole hierarchy in one call
  (:meth:`QPBackend.solve_hierarchy`) instead of one level at a time;
* :attr:`QPBackend.allows_closed_form`: the cascade may solve a level in closed
  form instead of calling it (the level's exact optimum, which this backend
  would return to within its tolerance); a user's solver gets every level;
* :meth:`QPBackend.start`: a new solve begins; a backend that keeps state
  between problems (workspaces, warm starts) resets it here.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

from pik_mj.qp.hierarchy import HierarchicalProblem
from pik_mj.qp.problem import LevelProblem, QPSolution
from pik_mj.tasks.task import TaskRows


class QPBackend:
    """Base of the cascade's QP backends: :meth:`solve` one level, and the
    capabilities the cascade reads, declared with their defaults (one level
    at a time, every level handed over, nothing kept between solves).

    Attributes:
        solves_hierarchy: Solves a whole hierarchy in one call
            (:meth:`solve_hierarchy`); the cascade then hands it every level at
            once, each solved exactly (no ``λ_k``, no ``τ``).
        allows_closed_form: The cascade may solve a level in closed form (its
            exact optimum when no inequality is active, see
            :mod:`pik_mj.cascade`) instead of calling this backend.
    """

    solves_hierarchy: ClassVar[bool] = False
    allows_closed_form: ClassVar[bool] = False

    def start(self) -> None:
        """A new solve begins: the state kept from earlier problems (workspaces,
        warm starts) is reset, so that the solve's result does not depend on
        the solves before it. The default keeps no state."""

    def solve(self, problem: LevelProblem) -> QPSolution:
        """Solve one level's QP."""
        raise NotImplementedError(f"{type(self).__name__} does not solve a level's QP")

    def hierarchy_problem(self, hard: TaskRows, levels: Sequence[TaskRows]) -> HierarchicalProblem:
        """The :class:`HierarchicalProblem` of a cascade's rows, for
        :meth:`solve_hierarchy` (a backend may build it with caches it keeps)."""
        return HierarchicalProblem.from_rows(hard, list(levels))

    def solve_hierarchy(self, problem: HierarchicalProblem) -> QPSolution:
        """Solve every level of ``problem`` in one call (when
        :attr:`solves_hierarchy`)."""
        raise NotImplementedError(f"{type(self).__name__} does not solve a whole hierarchy")
