"""The solve loop (prioritized-IK manual: ``prioritized-inverse-kinematics``).

Each iteration linearizes every task at the current configuration, solves the
cascade (:mod:`pik_mj.cascade`) for a step ``x`` and integrates
``q ← q ⊕ α x`` (``mj_integratePos``). The loop ends after ``stop`` iterations,
or — from iteration ``min_loop`` on — as soon as every task with ``check`` is
satisfied. ``revert_if_fail`` restores the initial configuration when it ends
unsatisfied; any exception (and Ctrl-C) restores it too.

The step length ``α ∈ (0, 1]`` comes from a trust region on ``‖x‖_∞``
(:class:`TrustRegion`). A step is accepted when, after the correction below,
no task of level 0 or of a kept level (every task met, checked or not, and so
every level above) ends worse than ``max(its error before, drift)``
(``drift`` 1e-4 in the task's units, m or rad), and no task of the level in
progress that was met ends worse than that or than the level's linear model
gives it; otherwise it is retried shorter. ``check`` decides convergence
only: a level's priority does not depend on it. This bounds the step of
*every* task (mink's tasks and user tasks included) so that a lower level
never moves a higher one through linearization error (docs/priority.md).

The correction (``correct=True``): when a step made the kept levels, or the
met tasks of the level in progress, drift, their rows at the new
configuration are solved again alone (a Newton projection back onto them)
within the same iteration.

Inputs are validated where they enter (configuration, options, every task's
rows at the start: only their shapes for tasks whose rows are valid by
construction, :attr:`~pik_mj.tasks.task.Task.finite_rows`); afterwards each
iteration checks only that the stacked rows are finite (except for levels of
such tasks) and that the step is.

Modules: :mod:`~pik_mj.solve.loop` (:func:`solve`), :mod:`~pik_mj.solve.step`
(one iteration: trial step and correction), :mod:`~pik_mj.solve.trust_region`
(the step rule), :mod:`~pik_mj.solve.evaluation` (the tasks' rows at a
configuration), :mod:`~pik_mj.solve.results` (what a solve reports).
"""

from pik_mj.solve.evaluation import evaluate_level, evaluate_levels
from pik_mj.solve.loop import revert_unless_converged, solve
from pik_mj.solve.results import IterationInfo, SolveResult, TaskReport
from pik_mj.solve.step import MAX_CORRECTIONS
from pik_mj.solve.trust_region import CORRECT_ABOVE, TrustRegion

__all__ = [
    "CORRECT_ABOVE",
    "MAX_CORRECTIONS",
    "IterationInfo",
    "SolveResult",
    "TaskReport",
    "TrustRegion",
    "evaluate_level",
    "evaluate_levels",
    "revert_unless_converged",
    "solve",
]
