"""The solve loop (prioritized-IK manual: ``prioritized-inverse-kinematics``):
options checked where they enter, then iterations until the tasks hold."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import mink
import numpy as np

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.cascade.step import DEFAULT_RELAXATION, Regularization, per_level
from pik_mj.checks import normalize_levels
from pik_mj.exceptions import InvalidInput, QPFailure
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.make import make_backend
from pik_mj.solve.evaluation import Point
from pik_mj.solve.results import IterationInfo, SolveResult
from pik_mj.solve.step import Stepper
from pik_mj.solve.trust_region import DEFAULT_TRUST_REGION, StepRule, TrustRegion

REGULARIZATION_DEFAULTS = {"regular": 1e-6, "regular_rel": 5.0, "regular_max": 0.1}
"""``w``, ``w_r``, ``w_max`` of :class:`~pik_mj.cascade.Regularization` when not given."""


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
    trust_region: TrustRegion | None = DEFAULT_TRUST_REGION,
    callback: Callback | Sequence[Callback] | None = None,
) -> SolveResult:
    """Prioritized inverse kinematics: iterate the cascade until the tasks hold.

    Args:
        configuration: The robot state; updated in place.
        levels: ``[[level-0 tasks], [level-1 tasks], ...]``. Level 0 holds hard rows
            (e.g. ``mink.ConfigurationLimit``), assumed feasible and never solved on
            its own; each later level is one QP. Entries are pik_mj tasks,
            ``mink.Task`` objects (equality rows) or ``mink.Limit`` objects (inequality rows).
        stop: Maximum iterations (prioritized-IK manual: ``stop``).
        min_loop: Iterations before the satisfaction test may end the loop
            (``<= stop``).
        revert_if_fail: Restore the initial configuration if the loop ends with a
            checked task unsatisfied, or when a level's QP fails.
        regular: ``w`` of ``λ_k = min(w + w_r e_k, w_max)`` (default 1e-6);
            float or one per level.
        regular_rel: ``w_r`` (default 5, the prioritized-IK manual's:
            Levenberg–Marquardt damping that grows with the error; without it
            an unreachable target at a singular, stretched pose makes the steps
            oscillate).
        regular_max: ``w_max`` (default 0.1).
        relaxation: ``τ`` by which a lower level may move a higher level's rows
            (default :data:`~pik_mj.cascade.DEFAULT_RELAXATION`).
        dt: Time step given to ``mink.Limit`` objects [s].
        qp_solver: ``"osqp"`` (default), ``"daqp"``, ``"daqp-hqp"`` (the whole
            hierarchy in one DAQP call, every level exact: ``regular*`` and
            ``relaxation`` do not apply and are refused), another ``qpsolvers``
            name, a backend object or a function (prioritized-IK manual:
            ``qp-solver``). Named backends keep their workspaces across solves.
        qp_args: Solver settings (``qp-args``), checked against the solver's
            list of settings.
        correct: When a step makes the kept levels (every task met, checked
            or not) or the met tasks of the level in progress drift (beyond
            :data:`~pik_mj.solve.trust_region.CORRECT_ABOVE` times the trust
            region's ``drift``), re-solve them alone at the new configuration
            and apply that projection (up to
            :data:`~pik_mj.solve.step.MAX_CORRECTIONS` times) within the same
            iteration.
        trust_region: The step rule (:class:`TrustRegion`), which keeps every
            level's priority on every iterate within its ``drift``
            (docs/priority.md); None takes the full step every iteration (the
            prioritized-IK manual's loop, no bound).
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
    inputs.mink_configuration(configuration)
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
    backend = make_backend(qp_solver, qp_args)
    options = {"regular": regular, "regular_rel": regular_rel, "regular_max": regular_max}
    regularization = _regularization(backend, qp_solver, options, relaxation, len(task_levels) - 1)
    tau = (
        DEFAULT_RELAXATION if relaxation is None else inputs.real(relaxation, "relaxation", low=0.0)
    )
    backend.start()  # a shared backend's workspaces start cold: repeatable solves
    stepper = Stepper(
        configuration, task_levels, regularization, backend, tau, correct, StepRule(trust_region)
    )
    q0 = configuration.q.copy()
    record = _Record()
    try:
        here = _iterate(stepper, record, stop, min_loop, revert_if_fail, callbacks)
    except BaseException:
        configuration.update(q0)
        raise
    level_errors = [r.squared_error() for r in here.rows[1:]]
    reverted = revert_unless_converged(configuration, q0, record.converged, revert_if_fail)
    return SolveResult(
        converged=record.converged,
        iterations=record.iterations,
        reverted=reverted,
        tasks=here.reports,
        level_errors=level_errors,
        history=record.history,
        iteration_times=record.times,
        qp_times=record.qp_times,
        failure=record.failure,
        q=configuration.q.copy(),
        step_lengths=record.lengths,
        evaluations=stepper.counts,
        corrections=stepper.corrections,
        rejected=stepper.rejected,
    )


def _regularization(
    backend: QPBackend,
    qp_solver: object,
    options: dict[str, float | Sequence[float] | None],
    relaxation: float | None,
    n_solved: int,
) -> list[Regularization]:
    """One :class:`Regularization` per solved level from the ``regular*``
    options (their defaults where None), refused for a backend that solves
    every level exactly."""
    if backend.solves_hierarchy:
        given = [k for k, v in {**options, "relaxation": relaxation}.items() if v is not None]
        if given:
            raise InvalidInput(
                f"{given} do not apply to qp_solver={qp_solver!r}, which solves every level "
                "exactly (λ_k → 0, τ = 0); use qp_solver='osqp' to set them"
            )
    values = [
        per_level(REGULARIZATION_DEFAULTS[k] if v is None else v, n_solved, k)
        for k, v in options.items()
    ]
    return [Regularization(w, wr, wm) for w, wr, wm in zip(*values, strict=True)]


@dataclass
class _Record:
    """What the loop keeps of its iterations (see :class:`SolveResult`)."""

    iterations: int = 0
    converged: bool = False
    failure: str | None = None
    history: list[list[float]] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    qp_times: list[float] = field(default_factory=list)
    lengths: list[float] = field(default_factory=list)


def _iterate(
    stepper: Stepper,
    record: _Record,
    stop: int,
    min_loop: int,
    revert_if_fail: bool,
    callbacks: list[Callback],
) -> Point:
    """Iterations until every checked task holds (from ``min_loop`` on), ``stop``
    of them, or a QP failure with ``revert_if_fail``; returns the last point,
    evaluated completely."""
    configuration = stepper.configuration
    # every task's rows validated once, where they enter
    here = stepper.point(configuration.q.copy()).complete(validate=True)
    everything, kept = here.satisfaction()
    while record.iterations < stop:
        t0 = time.perf_counter()
        try:
            here, step, alpha = stepper.iterate(here, kept)
        except QPFailure as exc:
            if not revert_if_fail:
                raise
            record.failure = str(exc)
            # the step may have moved the robot since the last evaluation
            return stepper.point(configuration.q.copy()).complete()
        everything, kept = here.satisfaction()
        record.iterations += 1
        record.history.append(step.level_errors)
        record.lengths.append(alpha)
        record.converged = record.iterations >= min_loop and everything
        record.qp_times.append(stepper.qp_time)
        record.times.append(time.perf_counter() - t0)
        if callbacks:
            elapsed = record.times[-1]
            info = IterationInfo(
                record.iterations, configuration, stepper.levels, step, elapsed, here.reports
            )
            for c in callbacks:
                c(info)
            if not np.array_equal(configuration.q, here.q):
                # a callback moved the robot: check and re-linearize there
                _check_after_callback(configuration)
                here = stepper.point(configuration.q.copy()).complete(validate=True)
                everything, kept = here.satisfaction()
                record.converged = record.iterations >= min_loop and everything
        if record.converged:
            break
    return here


def revert_unless_converged(
    configuration: mink.Configuration, q0: np.ndarray, converged: bool, revert_if_fail: bool
) -> bool:
    """Put ``configuration`` back to ``q0`` when the solve did not converge and
    ``revert_if_fail`` is set; returns whether it was reverted."""
    reverted = not converged and revert_if_fail
    if reverted:
        configuration.update(q0)
    return reverted


def _check_after_callback(configuration: mink.Configuration) -> None:
    try:
        inputs.mink_configuration(configuration)
    except InvalidInput as exc:
        raise InvalidInput(f"after a callback: {exc}") from None
