"""The solve loop of seed 000's ``prioritized-inverse-kinematics``.

Each iteration linearizes every task at the current configuration, solves the
cascade (:mod:`pik_mj.cascade`) and integrates the step
``q ← q ⊕ x`` (``configuration.integrate_inplace(x, 1.0)``). The loop ends after
``stop`` iterations, or — from iteration ``min_loop`` on — as soon as every task
with ``check`` is satisfied. ``revert_if_fail`` restores the initial
configuration when it ends unsatisfied; any exception restores it too.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import mink
import numpy as np

from .callbacks import Callback, as_callbacks
from .cascade import (
    DEFAULT_RELAXATION,
    CascadeStep,
    Regularization,
    per_level,
    solve_cascade,
)
from .exceptions import InvalidInput, QPFailure
from .qp import make_backend
from .tasks.mink_adapter import as_task
from .tasks.task import Task, TaskRows


@dataclass
class TaskReport:
    """A task's state: ``error`` is the norm of its error vector in its own units."""

    name: str
    level: int
    error: float
    satisfied: bool
    checked: bool


@dataclass
class IterationInfo:
    """What the per-iteration callback receives (after the step was applied).

    Attributes:
        iteration: 1-based iteration count.
        configuration: The configuration after the step.
        levels: The tasks, level 0 first.
        step: The cascade's step (None for solvers without one).
        elapsed: Wall time of the iteration [s].
        tasks: Every task's error and stop test at ``configuration``, as the
            loop evaluated them (read these rather than evaluating again).
    """

    iteration: int
    configuration: mink.Configuration
    levels: list[list[Task]]
    step: CascadeStep | None
    elapsed: float
    tasks: list[TaskReport] = field(default_factory=list)


@dataclass
class SolveResult:
    """Outcome of :func:`solve`.

    Attributes:
        converged: Every checked task satisfied at the end.
        iterations: Iterations run.
        reverted: The initial configuration was restored.
        tasks: Final state of each task.
        level_errors: Final squared error of each solved level (1..K).
        history: Squared error of each solved level at the start of each iteration.
        iteration_times: Wall time of each iteration [s].
        qp_times: Time spent in the QP backend in each iteration [s].
        failure: Message of a QP failure that ended the loop (with revert), or None.
        q: Final configuration (``nq``).
    """

    converged: bool
    iterations: int
    reverted: bool
    tasks: list[TaskReport]
    level_errors: list[float]
    history: list[list[float]] = field(default_factory=list)
    iteration_times: list[float] = field(default_factory=list)
    qp_times: list[float] = field(default_factory=list)
    failure: str | None = None
    q: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def median_iteration_ms(self) -> float:
        return 1e3 * float(np.median(self.iteration_times)) if self.iteration_times else 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "converged": self.converged,
            "iterations": self.iterations,
            "reverted": self.reverted,
            "failure": self.failure,
            "tasks": [vars(t) for t in self.tasks],
            "level_errors": self.level_errors,
            "timing": {
                "iteration_ms": [1e3 * t for t in self.iteration_times],
                "median_iteration_ms": self.median_iteration_ms,
                "qp_ms": [1e3 * t for t in self.qp_times],
            },
        }

    def summary(self) -> str:
        head = (
            f"{'converged' if self.converged else 'NOT converged'} after "
            f"{self.iterations} iterations ({self.median_iteration_ms:.2f} ms median)"
            + (", reverted" if self.reverted else "")
            + (f", failure: {self.failure}" if self.failure else "")
        )
        lines = [head]
        for t in self.tasks:
            mark = "ok " if t.satisfied else ("-- " if not t.checked else "NO ")
            lines.append(f"  [{mark}] level {t.level}  {t.name:<28} error {t.error:.3g}")
        return "\n".join(lines)


def normalize_levels(levels: Sequence[Sequence[object]], dt: float) -> list[list[Task]]:
    """Coerce and validate the user's levels (level 0 hard, then priorities)."""
    if isinstance(levels, (str, bytes)) or not isinstance(levels, Sequence):
        raise InvalidInput("levels must be a list of lists of tasks: [[hard...], [level1...], ...]")
    if len(levels) < 2:
        raise InvalidInput(
            f"levels has {len(levels)} entries; give level 0 (hard rows, may be empty) "
            "and at least one level to solve"
        )
    out: list[list[Task]] = []
    for k, level in enumerate(levels):
        if not isinstance(level, Sequence) or isinstance(level, (str, bytes)):
            raise InvalidInput(f"level {k} must be a list of tasks, got {type(level).__name__}")
        if k > 0 and len(level) == 0:
            raise InvalidInput(f"level {k} is empty; every level after level 0 needs a task")
        out.append([as_task(t, dt) for t in level])
    return out


def evaluate_levels(
    configuration: mink.Configuration, levels: list[list[Task]]
) -> tuple[list[TaskRows], list[TaskReport]]:
    """Every task's rows (stacked per level) and report at ``configuration``.

    One :meth:`Task.evaluate` per task: the rows of the next cascade step and
    the stop test of the one just taken come from the same evaluation.
    """
    nv = configuration.model.nv
    stacked: list[TaskRows] = []
    reports: list[TaskReport] = []
    for k, level in enumerate(levels):
        rows = []
        for task in level:
            state = task.evaluate(configuration)
            state.rows.validate(nv, task.name)
            rows.append(state.rows)
            reports.append(TaskReport(task.name, k, state.error, state.satisfied, task.check))
        stacked.append(TaskRows.stack(rows, nv))
    return stacked, reports


def revert_unless_converged(
    configuration: mink.Configuration, q0: np.ndarray, converged: bool, revert_if_fail: bool
) -> bool:
    """Put ``configuration`` back to ``q0`` when the solve did not converge and
    ``revert_if_fail`` is set; returns whether it was reverted."""
    reverted = not converged and revert_if_fail
    if reverted:
        configuration.update(q0)
    return reverted


def _satisfaction(reports: list[TaskReport], n_levels: int) -> tuple[bool, int]:
    """``(all checked tasks satisfied, number of leading solved levels satisfied)``.

    A level counts towards the prefix when it has a checked task and all its
    checked tasks hold; level 0 (hard) does not count.
    """
    per_level: list[list[bool]] = [[] for _ in range(n_levels)]
    for r in reports:
        if r.checked:
            per_level[r.level].append(r.satisfied)
    everything = all(all(s) for s in per_level)
    prefix = 0
    for s in per_level[1:]:
        if not s or not all(s):
            break
        prefix += 1
    return everything, prefix


def solve(
    configuration: mink.Configuration,
    levels: Sequence[Sequence[object]],
    *,
    stop: int = 50,
    min_loop: int = 0,
    revert_if_fail: bool = True,
    regular: float | Sequence[float] = 1e-6,
    regular_rel: float | Sequence[float] = 5.0,
    regular_max: float | Sequence[float] = 0.1,
    relaxation: float = DEFAULT_RELAXATION,
    dt: float = 1.0,
    qp_solver: object = "osqp",
    qp_args: dict[str, Any] | None = None,
    correct: bool = True,
    callback: Callback | Sequence[Callback] | None = None,
) -> SolveResult:
    """Prioritized inverse kinematics: iterate the cascade until the tasks hold.

    Args:
        configuration: The robot state; updated in place.
        levels: ``[[level-0 tasks], [level-1 tasks], ...]``. Level 0 holds hard rows
            (e.g. ``mink.ConfigurationLimit``), assumed feasible and never solved on
            its own; each later level is one QP. Entries are pik_mj tasks,
            ``mink.Task``s (equality rows) or ``mink.Limit``s (inequality rows).
        stop: Maximum iterations (seed ``stop``).
        min_loop: Iterations before the satisfaction test may end the loop.
        revert_if_fail: Restore the initial configuration if the loop ends with a
            checked task unsatisfied, or when a level's QP fails.
        regular: ``w`` of ``λ_k = min(w + w_r e_k, w_max)``; float or one per level.
        regular_rel: ``w_r``; float or one per level.
        regular_max: ``w_max``; float or one per level.
        relaxation: ``τ`` by which a lower level may move a higher level's rows.
        dt: Time step given to ``mink.Limit``s [s].
        qp_solver: ``"osqp"`` (default), a ``qpsolvers`` name, a backend object or
            a function (seed ``qp-solver``). Passing the same
            :class:`~pik_mj.qp.OSQPBackend` to successive solves (e.g. one per tick
            of a motion) reuses its OSQP workspaces: no ``setup()`` after the first.
        qp_args: Solver settings (seed ``qp-args``).
        correct: After each step, re-linearize and re-solve the leading levels
            that were satisfied before it (a Newton projection), so that the
            second-order drift a step causes in tasks already achieved (feet
            fixed while a hand reaches) is removed within the same iteration.
        callback: A callable, or a list of callables called in order, after
            every iteration with an :class:`IterationInfo`.

    Returns:
        A :class:`SolveResult`.

    Raises:
        InvalidInput: Bad levels, options, or task rows (NaN, wrong shapes,
            inverted bounds). The configuration is restored.
        InfeasibleHardConstraints: Level 0 admits no step. The configuration is
            restored.
        QPFailure: A level's QP failed and ``revert_if_fail`` is False.
    """
    if not isinstance(stop, int) or stop < 1:
        raise InvalidInput(f"stop must be a positive integer, got {stop!r}")
    if not isinstance(min_loop, int) or min_loop < 0:
        raise InvalidInput(f"min_loop must be a non-negative integer, got {min_loop!r}")
    if not (np.isfinite(relaxation) and relaxation >= 0):
        raise InvalidInput(f"relaxation must be finite and >= 0, got {relaxation}")
    callbacks = as_callbacks(callback)
    task_levels = normalize_levels(levels, dt)
    n_solved = len(task_levels) - 1
    regs = [
        Regularization(w, wr, wm)
        for w, wr, wm in zip(
            per_level(regular, n_solved, "regular"),
            per_level(regular_rel, n_solved, "regular_rel"),
            per_level(regular_max, n_solved, "regular_max"),
            strict=True,
        )
    ]
    backend = make_backend(qp_solver, qp_args)
    q0 = configuration.q.copy()
    history: list[list[float]] = []
    times: list[float] = []
    qp_times: list[float] = []
    failure: str | None = None
    converged = False
    iteration = 0
    try:
        rows, reports = evaluate_levels(configuration, task_levels)
        _, prefix = _satisfaction(reports, len(task_levels))
        while iteration < stop:
            t0 = time.perf_counter()
            try:
                step = solve_cascade(rows[0], rows[1:], regs, backend, relaxation)
                qp_time = time.perf_counter() - t0
                configuration.integrate_inplace(step.x, 1.0)
                if correct and 0 < prefix < n_solved:
                    kept, _ = evaluate_levels(configuration, task_levels[: prefix + 1])
                    t2 = time.perf_counter()
                    fix = solve_cascade(
                        kept[0], kept[1:], regs[:prefix], backend, relaxation, "correction"
                    )
                    qp_time += time.perf_counter() - t2
                    configuration.integrate_inplace(fix.x, 1.0)
            except QPFailure as exc:
                if not revert_if_fail:
                    raise
                failure = str(exc)
                # the step may have moved the robot since the last evaluation
                rows, reports = evaluate_levels(configuration, task_levels)
                break
            iteration += 1
            history.append(step.level_errors)
            # the stop test's evaluation is also the next iteration's linearization
            rows, reports = evaluate_levels(configuration, task_levels)
            everything, prefix = _satisfaction(reports, len(task_levels))
            converged = iteration >= min_loop and everything
            qp_times.append(qp_time)
            times.append(time.perf_counter() - t0)
            if callbacks:
                info = IterationInfo(
                    iteration, configuration, task_levels, step, times[-1], reports
                )
                for call in callbacks:
                    call(info)
            if converged:
                break
    except BaseException:
        configuration.update(q0)
        raise
    level_errors = [r.squared_error() for r in rows[1:]]
    reverted = revert_unless_converged(configuration, q0, converged, revert_if_fail)
    return SolveResult(
        converged=converged,
        iterations=iteration,
        reverted=reverted,
        tasks=reports,
        level_errors=level_errors,
        history=history,
        iteration_times=times,
        qp_times=qp_times,
        failure=failure,
        q=configuration.q.copy(),
    )
