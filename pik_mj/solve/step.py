"""One iteration of the solve loop: the cascade's step at the current point,
its correction (a Newton projection back onto the levels kept before) and
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
from pik_mj.solve.trust_region import StepRule, met_tasks
from pik_mj.tasks.task import Task, TaskRows

MAX_CORRECTIONS = 3
"""Newton projections per trial step (each one re-solves the kept levels)."""


class Stepper:
    """The iterations of one solve: what every step needs (the tasks, the
    cascade's options, the step rule) and what the steps count.

    Args:
        configuration: The robot state, moved to each point evaluated.
        levels: The tasks, level 0 first.
        regularization: One :class:`Regularization` per solved level.
        backend: The QP backend.
        relaxation: ``τ`` [row units].
        correct: Correct the kept levels' drift (Newton projection).
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

    def iterate(self, here: Point, kept: int) -> tuple[Point, CascadeStep, float]:
        """One iteration from ``here`` (``kept`` leading solved levels kept,
        :meth:`~pik_mj.solve.evaluation.Point.satisfaction`): ``(there, step,
        α)``, the next point evaluated completely, the cascade's step ``x``
        and its length (``q ← q ⊕ α x``, then corrected). When no retry is
        accepted the iteration keeps its configuration (``there`` is
        ``here``, ``α = 0``).

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
            there, corrected = self.corrected(here, self.point(q).upto(kept), kept, alpha * x)
            if rule.accepts(here, there, kept, x, size, alpha, corrected):
                break
            alpha = rule.retry(alpha, size)  # rejected: retry shorter
            self.rejected += 1
        else:  # no acceptable step: the iteration keeps its configuration
            self.configuration.update(here.q)
            there, alpha = here, 0.0
        there.complete()
        return there, step, alpha

    def corrected(
        self, here: Point, there: Point, kept: int, step: np.ndarray
    ) -> tuple[Point, bool]:
        """``there`` (``here ⊕ step``) projected back onto what the step must
        keep, up to :data:`MAX_CORRECTIONS` Newton projections, until it
        holds within the rule's ``fix_above``; and whether it moved.

        What it keeps: the kept levels ``1..kept`` (with none, level 0's rows
        alone: a nonlinear hard equality such as a polynomial joint coupling),
        and, as one more level below them, the tasks of the level in progress
        that met their stop test at ``here``, each beyond what the level's
        linear model gives it (:func:`~pik_mj.solve.trust_region.met_tasks`).
        Each projection solves those rows at ``there`` alone (the cascade's
        ``"correction"`` role) and takes the whole step.
        """
        if not self.correct or kept >= self.n_solved:
            return there, False
        model = self.configuration.model
        progress = kept + 1
        met = met_tasks(here, progress, step)
        fix = self.rule.fix_above
        moved = False
        for _ in range(MAX_CORRECTIONS):
            beyond = met and _beyond(there.upto(progress).held(progress), met, fix)
            if not beyond and all(e <= fix for e in there.errors(kept)):
                break
            t0 = time.perf_counter()
            levels = there.rows[1 : kept + 1]
            regularization = self.regularization[:kept]
            if met:
                levels = [
                    *levels,
                    TaskRows.stack([there.task_rows[progress][i] for i, _, _ in met], model.nv),
                ]
                regularization = [*regularization, self.regularization[kept]]
            projection = solve_cascade(
                there.rows[0],
                levels or [TaskRows.empty(model.nv)],
                regularization or self.regularization[:1],
                self.backend,
                self.relaxation,
                "correction",
            )
            self.qp_time += time.perf_counter() - t0
            if not math.isfinite(float(np.abs(projection.x).max())):
                raise_non_finite_step(there, projection, max(len(levels), 1), "correction")
            self.corrections += 1
            q = there.q.copy()
            mujoco.mj_integratePos(model, q, projection.x, 1.0)
            there = self.point(q).upto(kept)
            moved = True
        return there, moved


def _beyond(held: list[float], met: list[tuple[int, float, float]], fix: float) -> bool:
    """Whether a task of ``met`` (``(index, held before, r(step))``, see
    :func:`~pik_mj.solve.trust_region.met_tasks`) holds an error in ``held``
    beyond ``max(fix, r(step))``."""
    return any(held[i] > max(fix, r) for i, _, r in met)


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
