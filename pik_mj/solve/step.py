"""One iteration of the solve loop: the cascade's step at the current point,
its correction (a Newton projection back onto the levels satisfied before) and
the trust region's verdict, retried shorter when rejected."""

from __future__ import annotations

import math
import time

import mink
import mujoco
import numpy as np

from pik_mj.cascade.step import CascadeStep, Regularization, solve_cascade
from pik_mj.exceptions import QPFailure
from pik_mj.qp.backend import QPBackend
from pik_mj.solve.evaluation import Point, RowStack
from pik_mj.solve.trust_region import StepRule
from pik_mj.tasks.task import Task, TaskRows

MAX_CORRECTIONS = 3
"""Newton projections per trial step (each one re-solves the satisfied levels)."""


class Stepper:
    """The iterations of one solve: what every step needs (the tasks, the
    cascade's options, the step rule) and what the steps count.

    Args:
        configuration: The robot state, moved to each point evaluated.
        levels: The tasks, level 0 first.
        regularization: One :class:`Regularization` per solved level.
        backend: The QP backend.
        relaxation: ``τ`` [row units].
        correct: Correct the satisfied levels' drift (Newton projection).
        rule: The step rule (trust region).

    Attributes:
        counts: Evaluations of each level so far.
        corrections: Correction solves so far.
        rejected: Trial steps rejected by the trust region so far.
        qp_time: Time spent in the cascade during the last iteration [s].
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        levels: list[list[Task]],
        regularization: list[Regularization],
        backend: QPBackend,
        relaxation: float,
        correct: bool,
        rule: StepRule,
    ) -> None:
        self.configuration = configuration
        self.levels = levels
        self.regularization = regularization
        self.backend = backend
        self.relaxation = relaxation
        self.correct = correct
        self.rule = rule
        self.n_solved = len(levels) - 1
        self.stacks = [RowStack(level) for level in levels]
        self.counts = [0] * len(levels)
        self.corrections = 0
        self.rejected = 0
        self.qp_time = 0.0

    def point(self, q: np.ndarray) -> Point:
        """The tasks at ``q`` (the configuration moved there), evaluated on demand."""
        return Point(q, self.configuration, self.levels, self.stacks, self.counts)

    def iterate(self, here: Point, prefix: int) -> tuple[Point, CascadeStep, float]:
        """One iteration from ``here`` (``prefix`` leading solved levels
        satisfied): ``(there, step, α)``, the next point evaluated completely,
        the cascade's step ``x`` and its length (``q ← q ⊕ α x``, then
        corrected). When no retry is accepted the iteration keeps its
        configuration (``there`` is ``here``, ``α = 0``).

        Raises:
            QPFailure: A level's QP failed, or a step is not finite.
        """
        t0 = time.perf_counter()
        step = solve_cascade(
            here.rows[0], here.rows[1:], self.regularization, self.backend, self.relaxation
        )
        self.qp_time = time.perf_counter() - t0
        x = step.x
        size = float(np.abs(x).max())  # (nv >= 1)
        if not math.isfinite(size):
            raise_non_finite_step(here, step, self.n_solved, "step")
        rule = self.rule
        alpha = rule.length(size)
        for _ in range(rule.retries + 1):
            q = here.q.copy()
            mujoco.mj_integratePos(self.configuration.model, q, x, alpha)
            there, corrected = self.corrected(self.point(q).upto(prefix), prefix)
            if rule.accepts(here, there, prefix, x, size, alpha, corrected):
                break
            alpha = rule.retry(alpha, size)  # rejected: retry shorter
            self.rejected += 1
        else:  # no acceptable step: the iteration keeps its configuration
            self.configuration.update(here.q)
            there, alpha = here, 0.0
        there.complete()
        return there, step, alpha

    def corrected(self, there: Point, prefix: int) -> tuple[Point, bool]:
        """``there`` projected back onto the levels satisfied before the step
        (with none yet, onto level 0's rows alone: a nonlinear hard equality
        such as a polynomial joint coupling), up to :data:`MAX_CORRECTIONS`
        Newton projections, until their checked tasks are within the rule's
        ``fix_above``; and whether it moved.

        Each projection solves those levels' rows at ``there`` alone (the
        cascade's ``"correction"`` role) and takes the whole step.
        """
        if not self.correct or prefix >= self.n_solved:
            return there, False
        model = self.configuration.model
        moved = False
        for _ in range(MAX_CORRECTIONS):
            if all(e <= self.rule.fix_above for e in there.errors(prefix)):
                break
            t0 = time.perf_counter()
            kept = there.rows[1 : prefix + 1] or [TaskRows.empty(model.nv)]
            fix = solve_cascade(
                there.rows[0],
                kept,
                self.regularization[: max(prefix, 1)],
                self.backend,
                self.relaxation,
                "correction",
            )
            self.qp_time += time.perf_counter() - t0
            if not math.isfinite(float(np.abs(fix.x).max())):
                raise_non_finite_step(there, fix, max(prefix, 1), "correction")
            self.corrections += 1
            q = there.q.copy()
            mujoco.mj_integratePos(model, q, fix.x, 1.0)
            there = self.point(q).upto(prefix)
            moved = True
        return there, moved


def raise_non_finite_step(here: Point, step: CascadeStep, level: int, what: str) -> None:
    """Name what made a cascade ``what`` (its last level ``level``) NaN or
    inf: a task's rows at ``here`` (every level evaluated there validated,
    task by task), else the solver.

    Raises:
        InvalidInput: A task's rows are not finite.
        QPFailure: Otherwise.
    """
    for tasks in here.levels[: here.done]:
        for task in tasks:
            task.evaluate(here.configuration).rows.validate(here.nv, task.name)
    problem = step.problems[-1] if step.problems else None
    raise QPFailure(level, f"the {what} is not finite", problem)
