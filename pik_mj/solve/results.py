"""What :func:`pik_mj.solve.solve` reports: each task's state, each iteration
(to the callbacks) and the outcome."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mink
import numpy as np

from pik_mj.cascade.step import CascadeStep
from pik_mj.tasks.task import Task


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
    """What the per-iteration callbacks receive (after the step was applied).

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
        step_lengths: ``α`` of each iteration's accepted step (1: the full step).
        evaluations: How many times each level (0..K) was evaluated (every
            task's rows and error at one configuration). Each configuration is
            evaluated once per level at most: the evaluation that accepts a
            step is the next iteration's linearization, so levels evaluated
            only at accepted configurations count ``iterations + 1``.
        corrections: Correction solves (Newton projections) over all iterations.
        rejected: Trial steps rejected by the trust region over all iterations.
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
    step_lengths: list[float] = field(default_factory=list)
    evaluations: list[int] = field(default_factory=list)
    corrections: int = 0
    rejected: int = 0

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
            "evaluations": list(self.evaluations),
            "corrections": self.corrections,
            "rejected": self.rejected,
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
