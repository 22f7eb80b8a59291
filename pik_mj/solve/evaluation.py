"""The tasks' rows and stop tests at a configuration, level by level: what one
iteration of the solve loop linearizes and judges.

Inputs are validated where they enter: every task's rows at the start of a
solve (only their shapes for tasks whose rows are valid by construction,
:attr:`~pik_mj.tasks.task.Task.finite_rows`); afterwards each evaluation checks
only that the stacked rows are finite (except for levels of such tasks).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mink
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.solve.results import TaskReport
from pik_mj.tasks.task import Task, TaskRows, frozen


class RowStack:
    """One level's rows stacked into preallocated arrays, two sets in turn so
    that the rows at the accepted configuration survive a trial evaluation."""

    def __init__(self, level: Sequence[Task] = ()) -> None:
        # rows finite at every finite configuration (Task.finite_rows): not
        # summed at each evaluation
        self.finite = bool(level) and all(task.finite_rows for task in level)
        self.buffers: list[tuple[tuple, TaskRows] | None] = [None, None]
        self.slot = 0
        # read-only matrices found finite (a limit's constant C, a posture's
        # constant A), handed back as the same objects: not summed again
        self.checked_A: np.ndarray | None = None
        self.checked_C: np.ndarray | None = None

    def stack(self, rows: list[TaskRows], nv: int) -> TaskRows:
        """``rows`` stacked into one :class:`TaskRows` (a level of one task: its
        own rows), in the buffer not holding the previous stack."""
        if len(rows) == 1:
            return rows[0]
        if not rows:
            return TaskRows.empty(nv)
        self.slot ^= 1
        shape = tuple([(r.A.shape[0], r.C.shape[0]) for r in rows])
        held = self.buffers[self.slot]
        if held is None or held[0] != shape:
            m_eq = sum([m for m, _ in shape])
            m_in = sum([m for _, m in shape])
            empty = np.empty
            held = (
                shape,
                TaskRows(
                    empty((m_eq, nv)),
                    empty(m_eq),
                    empty(m_eq),
                    empty((m_in, nv)),
                    empty(m_in),
                    empty(m_in),
                    empty(m_in),
                ),
            )
            self.buffers[self.slot] = held
        out = held[1]
        i = j = 0
        damping = 0.0
        for r, (m_eq, m_in) in zip(rows, shape, strict=True):
            if m_eq:  # (an empty slice assignment still costs a numpy call)
                out.A[i : i + m_eq] = r.A
                out.b[i : i + m_eq] = r.b
                out.w_A[i : i + m_eq] = r.w_A
            if m_in:
                out.C[j : j + m_in] = r.C
                out.d_lower[j : j + m_in] = r.d_lower
                out.d_upper[j : j + m_in] = r.d_upper
                out.w_C[j : j + m_in] = r.w_C
            i, j = i + m_eq, j + m_in
            damping += r.damping
        return out if damping == out.damping else out._replace(damping=damping)


def evaluate_level(
    configuration: mink.Configuration,
    k: int,
    level: list[Task],
    stack: RowStack | None = None,
    validate: bool = True,
    nv: int | None = None,
) -> tuple[TaskRows, list[TaskReport]]:
    """The rows of level ``k`` (stacked) and a report per task at ``configuration``
    (``nv``: the model's, if the caller has it at hand); see
    :func:`evaluate_tasks`."""
    stacked, reports, _ = evaluate_tasks(configuration, k, level, stack, validate, nv)
    return stacked, reports


def evaluate_tasks(
    configuration: mink.Configuration,
    k: int,
    level: list[Task],
    stack: RowStack | None = None,
    validate: bool = True,
    nv: int | None = None,
) -> tuple[TaskRows, list[TaskReport], list[TaskRows]]:
    """The rows of level ``k`` (stacked), a report per task and each task's
    own rows at ``configuration`` (``nv``: the model's, if the caller has it
    at hand).

    One :meth:`Task.evaluate` per task: the rows of the next cascade step and
    the stop test of the one just taken come from the same evaluation. With
    ``validate`` every task's rows are checked (shapes, NaN, bounds; the
    shapes only for a task with :attr:`Task.finite_rows`); without,
    only the stacked arrays' finiteness is (not even that when ``stack`` holds
    a level whose tasks all have :attr:`Task.finite_rows`), and a failure is
    traced back to its task.
    """
    nv = configuration.model.nv if nv is None else nv
    rows = []
    reports = []
    for task in level:
        if validate:
            task.check_model(configuration)
        try:
            state = task.evaluate(configuration)
        except (TypeError, ValueError, IndexError) as exc:
            if not validate or isinstance(exc, InvalidInput):
                raise
            raise InvalidInput(_foreign_task(task, configuration, exc)) from exc
        if validate:  # (the values of finite_rows tasks' rows are valid by construction)
            rows_check = state.rows.check_shapes if task.finite_rows else state.rows.validate
            rows_check(nv, task.name)
        rows.append(state.rows)
        reports.append(TaskReport(task.name, k, state.error, state.satisfied, task.check))
    try:
        stacked = stack.stack(rows, nv) if stack is not None else TaskRows.stack(rows, nv)
    except ValueError:
        stacked = None
    if stack is None:
        finite = stacked is not None and _finite(stacked, nv)
    elif stack.finite and not validate:
        finite = stacked is not None
    else:
        finite = stacked is not None and _finite(stacked, nv, stack.checked_A, stack.checked_C)
    if not finite:
        for task, r in zip(level, rows, strict=True):
            r.validate(nv, task.name)
        raise InvalidInput(f"level {k}: rows are not finite")  # pragma: no cover
    if stack is not None:
        if stacked.A is not stack.checked_A and frozen(stacked.A):
            stack.checked_A = stacked.A
        if stacked.C is not stack.checked_C and frozen(stacked.C):
            stack.checked_C = stacked.C
    return stacked, reports, rows


def _foreign_task(task: Task, configuration: mink.Configuration, exc: Exception) -> str:
    """What to say about a task that cannot be evaluated on ``configuration``."""
    model = configuration.model
    target = getattr(getattr(task, "task", None), "target_q", None)
    if target is not None and np.shape(target) != (model.nq,):
        return (
            f"task {task.name}: its target configuration has {np.size(target)} entries but "
            f"this model has nq = {model.nq}; was it made for another model?"
        )
    return (
        f"task {task.name} cannot be evaluated on this configuration (nq = {model.nq}, "
        f"nv = {model.nv}): {type(exc).__name__}: {exc}; was it made for another model?"
    )


def evaluate_levels(
    configuration: mink.Configuration, levels: list[list[Task]], validate: bool = True
) -> tuple[list[TaskRows], list[TaskReport]]:
    """Every level's rows and every task's report at ``configuration`` (see
    :func:`evaluate_level`)."""
    stacked: list[TaskRows] = []
    reports: list[TaskReport] = []
    for k, level in enumerate(levels):
        rows, level_reports = evaluate_level(configuration, k, level, None, validate)
        stacked.append(rows)
        reports += level_reports
    return stacked, reports


def _finite(
    rows: TaskRows,
    nv: int,
    known_A: np.ndarray | None = None,
    known_C: np.ndarray | None = None,
) -> bool:
    """Cheap check of stacked rows: shapes agree with ``nv``; no NaN or inf in
    the matrices and targets, no NaN in the bounds (sums propagate them).
    ``known_A``, ``known_C``: read-only matrices already found finite (a
    posture's constant ``A``, a limit's constant ``C``, handed back as the same
    objects), not summed again."""
    A, C = rows.A, rows.C
    if A.shape[1:] != (nv,) or C.shape[1:] != (nv,):
        return False
    if A.shape[0]:
        total = rows.b.sum() if A is known_A else A.sum() + rows.b.sum()
        if not math.isfinite(total):
            return False
    if C.shape[0]:
        total = 0.0 if C is known_C else C.sum()
        return not (
            math.isnan(total)
            or math.isinf(total)
            or math.isnan(rows.d_lower.sum())
            or math.isnan(rows.d_upper.sum())
        )
    return True


class Point:
    """The tasks at one configuration ``q``, evaluated level by level on demand
    (a trial step is judged on the levels kept before it first, and the
    rest is evaluated only when it is accepted).

    Levels must be evaluated while ``configuration`` is at ``q`` (the loop
    moves it only to the next point).
    """

    def __init__(
        self,
        q: np.ndarray,
        configuration: mink.Configuration,
        levels: list[list[Task]],
        stacks: list[RowStack],
        counts: list[int],
    ):
        configuration.update(q)
        self.q, self.configuration, self.levels, self.stacks = q, configuration, levels, stacks
        self.counts = counts  # evaluations of each level, shared by the solve's points
        self.nv = configuration.model.nv
        n = len(levels)
        self.rows: list[TaskRows] = [None] * n  # type: ignore[list-item]
        self.level_reports: list[list[TaskReport]] = [None] * n  # type: ignore[list-item]
        self.task_rows: list[list[TaskRows]] = [None] * n  # type: ignore[list-item]
        self._held: list[list[float] | None] = [None] * n
        self.done = 0

    def upto(self, k: int, validate: bool = False) -> Point:
        """Evaluate levels ``0..k`` (those not done yet)."""
        for j in range(self.done, min(k, len(self.levels) - 1) + 1):
            self.rows[j], self.level_reports[j], self.task_rows[j] = evaluate_tasks(
                self.configuration, j, self.levels[j], self.stacks[j], validate, self.nv
            )
            self.counts[j] += 1
        self.done = max(self.done, min(k, len(self.levels) - 1) + 1)
        return self

    def complete(self, validate: bool = False) -> Point:
        """Evaluate every level (those not done yet)."""
        return self.upto(len(self.levels) - 1, validate)

    @property
    def reports(self) -> list[TaskReport]:
        """The reports of every task of the levels evaluated so far."""
        return [r for level in self.level_reports[: self.done] for r in level]

    def held(self, k: int) -> list[float]:
        """The error each task of level ``k`` holds: its rows' residual at
        ``x = 0`` over the rows it weights
        (:meth:`~pik_mj.tasks.task.TaskRows.residual_norm`), what the step
        rule bounds (a posture weighting a few joints holds those)."""
        held = self._held[k]
        if held is None:
            held = self._held[k] = [rows.residual_norm() for rows in self.task_rows[k]]
        return held

    def errors(self, k: int) -> list[float]:
        """:meth:`held` of each task of levels ``0..k`` (level 0: the hard
        rows' violations), checked or not: ``check`` decides convergence
        only, every task keeps its priority."""
        return [e for j in range(k + 1) for e in self.held(j)]

    def level_error(self, k: int) -> float:
        """Norm of the errors of level ``k``'s tasks."""
        return math.sqrt(sum(r.error * r.error for r in self.level_reports[k]))

    def satisfaction(self) -> tuple[bool, int]:
        """``(every checked task satisfied, number of leading solved levels kept)``
        over the levels evaluated so far.

        The first tells convergence (the stop test reads the checked tasks
        only, level 0's included). The second tells priority: a solved level
        is kept when every one of its tasks meets its stop test, checked or
        not, and so are the levels above it; the step rule holds the kept
        levels within its drift bound and corrects them (level 0, the hard
        rows, is always held and never counted).
        """
        everything, kept, leading = True, 0, True
        for k, level in enumerate(self.level_reports[: self.done]):
            everything = everything and all(r.satisfied for r in level if r.checked)
            if k and leading:
                leading = all(r.satisfied for r in level)
                kept += leading
        return everything, kept
