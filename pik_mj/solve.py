"""The solve loop of seed 000's ``prioritized-inverse-kinematics``.

Each iteration linearizes every task at the current configuration, solves the
cascade (:mod:`pik_mj.cascade`) for a step ``x`` and integrates
``q ← q ⊕ α x`` (``mj_integratePos``). The loop ends after ``stop`` iterations,
or — from iteration ``min_loop`` on — as soon as every task with ``check`` is
satisfied. ``revert_if_fail`` restores the initial configuration when it ends
unsatisfied; any exception (and Ctrl-C) restores it too.

The step length ``α ∈ (0, 1]`` comes from a trust region on ``‖x‖_∞``
(:class:`TrustRegion`): a step is accepted when no level satisfied before it,
and no hard row, ends more than ``drift`` (1e-4 in the task's units) worse
than it was, after the correction below; otherwise it is retried shorter.
This bounds the step of *every* task (mink's tasks and user tasks included)
so that a lower level never moves a higher one through linearization error.

The correction (``correct=True``): when a step made the satisfied levels
drift, their rows at the new configuration are solved again alone (a Newton
projection back onto them) within the same iteration.

Inputs are validated here, where they enter (configuration, options, every
task's rows at the start: only their shapes for tasks whose rows are valid by
construction, :attr:`~pik_mj.tasks.task.Task.finite_rows`); afterwards each
iteration checks only that the stacked rows are finite (except for levels of
such tasks) and that the step is.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.cascade import DEFAULT_RELAXATION, CascadeStep, Regularization, per_level, solve_cascade
from pik_mj.checks import check_configuration, normalize_levels
from pik_mj.exceptions import InvalidInput, QPFailure
from pik_mj.qp import make_backend
from pik_mj.tasks.task import Task, TaskRows, frozen

MAX_CORRECTIONS = 3
"""Newton projections per trial step (each one re-solves the satisfied levels)."""

CORRECT_ABOVE = 0.9
"""A satisfied task is corrected when its error exceeds this fraction of the
trust region's ``drift``. Each step's QP already drives it back (its rows are
in every step), so a drift within the bound needs no projection of its own:
0.9 instead of 0.5 saves 5-9 % of the corrections on the reference reaching
stacks, and accepted errors stay within ``drift``."""


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


@dataclass(frozen=True)
class TrustRegion:
    """The step rule: a trust region on ``‖Δq‖_∞`` with an acceptance test.

    Each iteration takes ``α x`` with ``α = min(1, radius / ‖x‖_∞)``. If the
    levels satisfied before the step drifted, the correction (``correct``)
    projects back onto them, up to :data:`MAX_CORRECTIONS` times, until each
    of their checked tasks is within :data:`CORRECT_ABOVE` ``· drift``. The
    step is accepted when every checked task of those levels and of level 0
    (the hard rows, whose linearization a long step can overshoot) has an
    error of at most
    ``max(its error before, drift)``: a lower level never moves a higher one
    by more than ``drift`` through linearization error. A rejected step is
    retried ``shrink`` times as long (at most ``retries`` times; then the
    iteration keeps its configuration).

    The radius then adapts to the first unsatisfied level's error norm ``e``,
    with ``ρ`` its decrease over the decrease its rows predicted: ``ρ > 3/4``
    lets it grow to ``2 α ‖x‖_∞`` (up to ``max_radius``); ``ρ < 1/4`` shrinks
    it to ``shrink · α ‖x‖_∞`` (not below ``min_radius``), but only when the
    step needed a correction or made ``e`` grow: a callable target's motion is
    not in its task's Jacobian, and a task reporting a clamped error shows no
    change, so a small ``ρ`` alone is no verdict.

    Attributes:
        radius: Initial radius [rad or m, per coordinate of Δq]. 0.5: on the
            reference reaching stacks (two sets of 10 targets), 1.0 needed
            15-22 % more iterations on the 62-DoF CMU humanoid with
            ``daqp-hqp`` (3-4 % with OSQP), and 0-7 % fewer on dm_control's
            27-DoF humanoid.
        max_radius: Largest radius [rad or m].
        min_radius: Smallest radius kept for the next iterations [rad or m]
            (a rejected step is retried shorter than it, within its iteration).
        drift: Error a satisfied task may reach [its units: m, rad, ...].
        shrink: Factor of a rejected or poorly predicted step's length.
        retries: Rejections per iteration before it gives up.
    """

    radius: float = 0.5
    max_radius: float = 4.0
    min_radius: float = 0.01
    drift: float = 1e-4
    shrink: float = 0.25
    retries: int = 6

    def __post_init__(self) -> None:
        for name in ("radius", "max_radius", "min_radius", "drift"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.number)) and np.isfinite(v) and v > 0):
                raise InvalidInput(
                    f"TrustRegion.{name} must be a positive finite number, got {v!r}"
                )
        if not 0 < self.shrink < 1:
            raise InvalidInput(f"TrustRegion.shrink must be in (0, 1), got {self.shrink!r}")
        if not self.min_radius <= self.radius <= self.max_radius:
            raise InvalidInput(
                f"TrustRegion radii must satisfy min_radius <= radius <= max_radius, got "
                f"{self.min_radius}, {self.radius}, {self.max_radius}"
            )
        inputs.integer(self.retries, "TrustRegion.retries", low=0)


# -- evaluation ----------------------------------------------------------------------


class _Stack:
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
    stack: _Stack | None = None,
    validate: bool = True,
    nv: int | None = None,
) -> tuple[TaskRows, list[TaskReport]]:
    """The rows of level ``k`` (stacked) and a report per task at ``configuration``
    (``nv``: the model's, if the caller has it at hand).

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
    return stacked, reports


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


def revert_unless_converged(
    configuration: mink.Configuration, q0: np.ndarray, converged: bool, revert_if_fail: bool
) -> bool:
    """Put ``configuration`` back to ``q0`` when the solve did not converge and
    ``revert_if_fail`` is set; returns whether it was reverted."""
    reverted = not converged and revert_if_fail
    if reverted:
        configuration.update(q0)
    return reverted


class _Point:
    """The tasks at one configuration ``q``, evaluated level by level on demand
    (a trial step is judged on the levels satisfied before it first, and the
    rest is evaluated only when it is accepted).

    Levels must be evaluated while ``configuration`` is at ``q`` (the loop
    moves it only to the next point).
    """

    def __init__(
        self, q: np.ndarray, configuration: mink.Configuration, levels, stacks, counts: list[int]
    ):
        configuration.update(q)
        self.q, self.configuration, self.levels, self.stacks = q, configuration, levels, stacks
        self.counts = counts  # evaluations of each level, shared by the solve's points
        self.nv = configuration.model.nv
        n = len(levels)
        self.rows: list[TaskRows] = [None] * n  # type: ignore[list-item]
        self.level_reports: list[list[TaskReport]] = [None] * n  # type: ignore[list-item]
        self.done = 0

    def upto(self, k: int, validate: bool = False) -> _Point:
        """Evaluate levels ``0..k`` (those not done yet)."""
        for j in range(self.done, min(k, len(self.levels) - 1) + 1):
            self.rows[j], self.level_reports[j] = evaluate_level(
                self.configuration, j, self.levels[j], self.stacks[j], validate, self.nv
            )
            self.counts[j] += 1
        self.done = max(self.done, min(k, len(self.levels) - 1) + 1)
        return self

    def complete(self, validate: bool = False) -> _Point:
        return self.upto(len(self.levels) - 1, validate)

    @property
    def reports(self) -> list[TaskReport]:
        return [r for level in self.level_reports[: self.done] for r in level]

    def errors(self, k: int) -> list[float]:
        """Error of each checked task of levels ``0..k`` (level 0: the hard rows'
        violations); unchecked tasks carry no promise to keep. (A few floats:
        Python lists, no numpy calls.)"""
        return [r.error for level in self.level_reports[: k + 1] for r in level if r.checked]

    def level_error(self, k: int) -> float:
        """Norm of the errors of level ``k``'s checked tasks."""
        return math.sqrt(sum(r.error * r.error for r in self.level_reports[k] if r.checked))

    def satisfaction(self) -> tuple[bool, int]:
        """``(every checked task satisfied, number of leading solved levels
        satisfied)`` over the levels evaluated so far.

        A level counts towards the prefix when it has a checked task and all its
        checked tasks hold; level 0 (hard) does not count.
        """
        everything, prefix, leading = True, 0, True
        for k, level in enumerate(self.level_reports[: self.done]):
            checked = [r.satisfied for r in level if r.checked]
            holds = all(checked)
            everything = everything and holds
            if k and leading:
                leading = holds and bool(checked)
                prefix += leading
        return everything, prefix


def _predicted_decrease(rows: TaskRows, x: np.ndarray) -> float:
    """What the rows' linear model predicts a step ``x`` takes off the level's
    unweighted error norm, its clamp included: ``‖r(0)‖ − ‖r(x)‖`` with
    ``r(x) = [A x − b; dist(C x, [d_l, d_u])]``."""
    b = rows.b
    r_eq = rows.A @ x - b
    now, then = float(b @ b), float(r_eq @ r_eq)
    if rows.n_in:
        viol = rows.bound_distance()
        now += float(viol @ viol)
        viol = rows.bound_distance(rows.C @ x)
        then += float(viol @ viol)
    return math.sqrt(now) - math.sqrt(then)


def _sq(errors: list[float]) -> float:
    """Sum of squares."""
    return sum(e * e for e in errors)


def _kept(before: list[float], after: list[float], drift: float) -> bool:
    """Every task of the satisfied levels within ``max(its error before, drift)``."""
    return all(a <= max(b, drift) for a, b in zip(after, before, strict=True))


# -- the loop ------------------------------------------------------------------------


def solve(
    configuration: mink.Configuration,
    levels: Sequence[Sequence[object]],
    *,
    stop: int = 50,
    min_loop: int = 0,
    revert_if_fail: bool = True,
    regular: float | Sequence[float] | None = None,
    regular_rel: float | Sequence[float] | None = None,
    regular_max: float | Sequence[float] | None = None,
    relaxation: float | None = None,
    dt: float = 1.0,
    qp_solver: object = "osqp",
    qp_args: dict[str, Any] | None = None,
    correct: bool = True,
    trust_region: TrustRegion | None = TrustRegion(),
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
        min_loop: Iterations before the satisfaction test may end the loop
            (``<= stop``).
        revert_if_fail: Restore the initial configuration if the loop ends with a
            checked task unsatisfied, or when a level's QP fails.
        regular: ``w`` of ``λ_k = min(w + w_r e_k, w_max)`` (default 1e-6);
            float or one per level.
        regular_rel: ``w_r`` (default 5, the seed's: Levenberg–Marquardt damping
            that grows with the error; without it an unreachable target at a
            singular, stretched pose makes the steps oscillate).
        regular_max: ``w_max`` (default 0.1).
        relaxation: ``τ`` by which a lower level may move a higher level's rows
            (default :data:`~pik_mj.cascade.DEFAULT_RELAXATION`).
        dt: Time step given to ``mink.Limit``s [s].
        qp_solver: ``"osqp"`` (default), ``"daqp"``, ``"daqp-hqp"`` (the whole
            hierarchy in one DAQP call, every level exact: ``regular*`` and
            ``relaxation`` do not apply and are refused), another ``qpsolvers``
            name, a backend object or a function (seed ``qp-solver``). Named
            backends keep their workspaces across solves.
        qp_args: Solver settings (seed ``qp-args``), checked against the solver's
            list of settings.
        correct: When a step makes the satisfied levels drift (beyond
            :data:`CORRECT_ABOVE` times the trust region's ``drift``), re-solve
            them alone at the new configuration
            and apply that projection (up to :data:`MAX_CORRECTIONS` times)
            within the same iteration.
        trust_region: The step rule (:class:`TrustRegion`); None takes the full
            step every iteration (the seed's loop).
        callback: One callable or a list of callables, each called in order with
            the same :class:`IterationInfo` after every iteration.

    Returns:
        A :class:`SolveResult`.

    Raises:
        InvalidInput: Bad configuration, levels, options, or task rows (NaN,
            wrong shapes, inverted bounds), each named. The configuration is
            restored.
        InfeasibleHardConstraints: Level 0 admits no step. The configuration is
            restored.
        QPFailure: A level's QP failed and ``revert_if_fail`` is False.
        KeyboardInterrupt: Ctrl-C; the configuration is restored.

    Warns:
        RuntimeWarning: The start configuration is outside joint ranges.
    """
    check_configuration(configuration)
    stop = inputs.integer(stop, "stop", low=1)
    min_loop = inputs.integer(min_loop, "min_loop", low=0)
    if min_loop > stop:
        raise InvalidInput(f"min_loop ({min_loop}) must not exceed stop ({stop})")
    revert_if_fail = inputs.flag(revert_if_fail, "revert_if_fail")
    correct = inputs.flag(correct, "correct")
    dt = inputs.real(dt, "dt", unit="s", low=0.0, low_open=True)
    if trust_region is not None and not isinstance(trust_region, TrustRegion):
        raise InvalidInput(f"trust_region must be a TrustRegion or None, got {trust_region!r}")
    callbacks = as_callbacks(callback)
    task_levels = normalize_levels(levels, dt)
    n_solved = len(task_levels) - 1
    backend = make_backend(qp_solver, qp_args)
    options = {"regular": regular, "regular_rel": regular_rel, "regular_max": regular_max}
    if backend.solves_hierarchy:
        given = [k for k, v in {**options, "relaxation": relaxation}.items() if v is not None]
        if given:
            raise InvalidInput(
                f"{given} do not apply to qp_solver={qp_solver!r}, which solves every level "
                "exactly (λ_k → 0, τ = 0); use qp_solver='osqp' to set them"
            )
    defaults = {"regular": 1e-6, "regular_rel": 5.0, "regular_max": 0.1}
    values = [per_level(defaults[k] if v is None else v, n_solved, k) for k, v in options.items()]
    regs = [Regularization(w, wr, wm) for w, wr, wm in zip(*values, strict=True)]
    tau = (
        DEFAULT_RELAXATION if relaxation is None else inputs.real(relaxation, "relaxation", low=0.0)
    )

    backend.start()  # a shared backend's workspaces start cold: repeatable solves
    model = configuration.model
    q0 = configuration.q.copy()
    stacks = [_Stack(level) for level in task_levels]
    counts = [0] * len(task_levels)
    n_corrections = n_rejected = 0
    history: list[list[float]] = []
    times: list[float] = []
    qp_times: list[float] = []
    lengths: list[float] = []
    failure: str | None = None
    converged = False
    iteration = 0
    radius = trust_region.radius if trust_region is not None else math.inf
    drift = trust_region.drift if trust_region is not None else math.inf
    retries = trust_region.retries if trust_region is not None else 0
    # corrections bring satisfied levels back within the drift bound, with a margin
    fix_above = CORRECT_ABOVE * drift if trust_region is not None else 1e-5

    def point(q: np.ndarray) -> _Point:
        return _Point(q, configuration, task_levels, stacks, counts)

    try:
        # every task's rows validated once, where they enter
        here = point(configuration.q.copy()).complete(validate=True)
        everything, prefix = here.satisfaction()
        while iteration < stop:
            t0 = time.perf_counter()
            qp_time = 0.0
            try:
                step = solve_cascade(here.rows[0], here.rows[1:], regs, backend, tau)
                qp_time += time.perf_counter() - t0
                x = step.x
                size = float(np.abs(x).max())  # (nv >= 1)
                if not math.isfinite(size):
                    _raise_non_finite_step(here, step, n_solved, "step")
                alpha = 1.0 if size <= radius else radius / size
                before = here.errors(prefix)
                progress_level = prefix + 1 if prefix < n_solved else 0
                for _ in range(retries + 1):
                    q = here.q.copy()
                    mujoco.mj_integratePos(model, q, x, alpha)
                    there = point(q).upto(prefix)
                    corrected = False
                    if correct and prefix < n_solved:
                        # Newton projection back onto the levels satisfied before
                        # (with none yet, onto level 0's rows alone: a nonlinear
                        # hard equality such as a polynomial joint coupling)
                        for _ in range(MAX_CORRECTIONS):
                            if all(e <= fix_above for e in there.errors(prefix)):
                                break
                            t2 = time.perf_counter()
                            kept = there.rows[1 : prefix + 1] or [TaskRows.empty(model.nv)]
                            fix = solve_cascade(
                                there.rows[0],
                                kept,
                                regs[: max(prefix, 1)],
                                backend,
                                tau,
                                "correction",
                            )
                            qp_time += time.perf_counter() - t2
                            if not math.isfinite(float(np.abs(fix.x).max())):
                                _raise_non_finite_step(there, fix, max(prefix, 1), "correction")
                            n_corrections += 1
                            q = q.copy()
                            mujoco.mj_integratePos(model, q, fix.x, 1.0)
                            there = point(q).upto(prefix)
                            corrected = True
                    if trust_region is None:
                        break
                    after = there.errors(prefix)
                    kept = _kept(before, after, drift)
                    ratio = 1.0
                    # levels above improved (the correction repaired them): a
                    # lexicographic gain whatever it cost the progress level
                    repaired = _sq(after) < _sq(before) - fix_above**2
                    if kept and progress_level and not repaired:
                        there.upto(progress_level)
                        e0 = here.level_error(progress_level)
                        e1 = there.level_error(progress_level)
                        rows_k = here.rows[progress_level]
                        predicted = _predicted_decrease(rows_k, alpha * x)
                        # Judged only when the step needed a correction: then a
                        # poor ratio means a step too long for the curvature of
                        # the satisfied levels (the correction undid the gain).
                        # Otherwise the task's own model decides (a callable
                        # target's motion is not in its Jacobian; an error that
                        # did not change is a saturated clamp).
                        if predicted > 1e-12 and abs(e1 - e0) > 1e-9 * e0:
                            ratio = (e0 - e1) / predicted
                            if ratio < 0.25 and not (corrected or e1 > e0):
                                ratio = 0.5  # no verdict: keep the radius
                    if kept:
                        if ratio < 0.25:  # the linear model overpromised: shorter steps
                            radius = max(
                                trust_region.min_radius, trust_region.shrink * alpha * size
                            )
                        elif ratio > 0.75:
                            radius = min(trust_region.max_radius, max(radius, 2.0 * alpha * size))
                        break
                    alpha *= trust_region.shrink  # rejected: retry shorter
                    n_rejected += 1
                    radius = max(trust_region.min_radius, alpha * size)
                else:  # no acceptable step: the iteration keeps its configuration
                    configuration.update(here.q)
                    there, alpha = here, 0.0
                there.complete()
            except QPFailure as exc:
                if not revert_if_fail:
                    raise
                failure = str(exc)
                # the step may have moved the robot since the last evaluation
                here = point(configuration.q.copy()).complete()
                break
            here = there
            everything, prefix = here.satisfaction()
            iteration += 1
            history.append(step.level_errors)
            lengths.append(alpha)
            converged = iteration >= min_loop and everything
            qp_times.append(qp_time)
            times.append(time.perf_counter() - t0)
            if callbacks:
                info = IterationInfo(
                    iteration, configuration, task_levels, step, times[-1], here.reports
                )
                for c in callbacks:
                    c(info)
                if not np.array_equal(configuration.q, here.q):
                    # a callback moved the robot: check and re-linearize there
                    _check_after_callback(configuration)
                    here = point(configuration.q.copy()).complete(validate=True)
                    everything, prefix = here.satisfaction()
                    converged = iteration >= min_loop and everything
            if converged:
                break
    except BaseException:
        configuration.update(q0)
        raise
    level_errors = [r.squared_error() for r in here.rows[1:]]
    reverted = revert_unless_converged(configuration, q0, converged, revert_if_fail)
    return SolveResult(
        converged=converged,
        iterations=iteration,
        reverted=reverted,
        tasks=here.reports,
        level_errors=level_errors,
        history=history,
        iteration_times=times,
        qp_times=qp_times,
        failure=failure,
        q=configuration.q.copy(),
        step_lengths=lengths,
        evaluations=counts,
        corrections=n_corrections,
        rejected=n_rejected,
    )


def _raise_non_finite_step(here: _Point, step: CascadeStep, level: int, what: str) -> None:
    """Name what made a cascade ``what`` (its last level ``level``) NaN or
    inf: a task's rows at ``here`` (every level evaluated there validated,
    task by task), else the solver."""
    for tasks in here.levels[: here.done]:
        for task in tasks:
            task.evaluate(here.configuration).rows.validate(here.nv, task.name)
    problem = step.problems[-1] if step.problems else None
    raise QPFailure(level, f"the {what} is not finite", problem)


def _check_after_callback(configuration: mink.Configuration) -> None:
    try:
        check_configuration(configuration)
    except InvalidInput as exc:
        raise InvalidInput(f"after a callback: {exc}") from None
