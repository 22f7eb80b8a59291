"""The step rule of the solve loop: a trust region on ``‖Δq‖_∞`` with an
acceptance test (:class:`TrustRegion`, the user's options), and the radius it
adapts over one solve (:class:`StepRule`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.solve.evaluation import Point
from pik_mj.tasks.task import TaskRows

CORRECT_ABOVE = 0.9
"""A task of a kept level is corrected when its error exceeds this fraction of
the trust region's ``drift``. Each step's QP already drives it back (its rows are
in every step), so a drift within the bound needs no projection of its own;
the margin below 1 keeps accepted errors within ``drift``."""

UNBOUNDED_CORRECTION = 1e-5
"""Without a trust region: the error [task units] above which a kept task is
corrected."""


@dataclass(frozen=True)
class TrustRegion:
    """The step rule: a trust region on ``‖Δq‖_∞`` with an acceptance test.

    Each iteration takes ``α x`` with ``α = min(1, radius / ‖x‖_∞)``. If the
    kept levels (the leading solved levels whose tasks all meet their stop
    test, checked or not: ``check`` decides convergence only) drifted, or the
    tasks of the level in progress that met theirs moved beyond what the
    level's linear model gives them, the correction (``correct``) projects
    back onto them, up to :data:`~pik_mj.solve.step.MAX_CORRECTIONS` times,
    until each is within :data:`CORRECT_ABOVE` ``· drift`` (or that model's
    residual). The step is accepted when every task of level 0 (the hard
    rows, whose linearization a long step can overshoot) and of the kept
    levels has an error of at most ``max(its error before, drift)``, and every
    met task of the level in progress at most ``max(its error before, drift,
    r)``, ``r`` its rows' residual after the step (:func:`met_tasks`): a
    lower level never moves a higher one by more than ``drift`` through
    linearization error (docs/priority.md). A rejected step is retried
    ``shrink`` times as long (at most ``retries`` times; then the iteration
    keeps its configuration).

    The radius then adapts to the error norm ``e`` of the level in progress,
    with ``ρ`` its decrease over the decrease its rows predicted: ``ρ > 3/4``
    lets it grow to ``2 α ‖x‖_∞`` (up to ``max_radius``); ``ρ < 1/4`` shrinks
    it to ``shrink · α ‖x‖_∞`` (not below ``min_radius``), but only when the
    step needed a correction or made ``e`` grow: a callable target's motion is
    not in its task's Jacobian, and a task reporting a clamped error shows no
    change, so a small ``ρ`` alone is no verdict.

    Attributes:
        radius: Initial radius [rad or m, per coordinate of Δq].
        max_radius: Largest radius [rad or m].
        min_radius: Smallest radius kept for the next iterations [rad or m]
            (a rejected step is retried shorter than it, within its iteration).
        drift: Error a kept task may reach [its units: m, rad, ...].
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


DEFAULT_TRUST_REGION = TrustRegion()
"""The step rule of :func:`pik_mj.solve.solve` when none is given."""


class StepRule:
    """The trust region over one solve: the current radius, the test of a
    trial step and the radius's adaptation (:class:`TrustRegion`); without one
    (None) every step is taken whole and accepted.

    Attributes:
        region: The options, or None.
        radius: Current radius [rad or m] (``inf`` without a trust region).
        drift: Error a kept task may reach [its units] (``inf`` without).
        retries: Rejections per iteration before it gives up.
        fix_above: Error above which a kept task is corrected
            (:data:`CORRECT_ABOVE` ``· drift``, or :data:`UNBOUNDED_CORRECTION`).
    """

    def __init__(self, region: TrustRegion | None) -> None:
        self.region = region
        self.radius = region.radius if region is not None else math.inf
        self.drift = region.drift if region is not None else math.inf
        self.retries = region.retries if region is not None else 0
        # corrections bring kept levels back within the drift bound, with a margin
        self.fix_above = CORRECT_ABOVE * self.drift if region is not None else UNBOUNDED_CORRECTION

    def length(self, size: float) -> float:
        """``α = min(1, radius / ‖x‖_∞)`` for a step of ``‖x‖_∞ = size``."""
        return 1.0 if size <= self.radius else self.radius / size

    def accepts(
        self,
        here: Point,
        there: Point,
        kept: int,
        step: np.ndarray,
        size: float,
        alpha: float,
        corrected: bool,
    ) -> bool:
        """Whether the trial point ``there`` (``here ⊕ α x``, corrected or not)
        is accepted, the radius adapted when it is (see :class:`TrustRegion`).

        Args:
            here: The point the step starts from.
            there: The trial point, its levels ``0..kept`` evaluated.
            kept: Number of leading solved levels kept at ``here``
                (:meth:`~pik_mj.solve.evaluation.Point.satisfaction`).
            step: The cascade's step ``x``.
            size: ``‖x‖_∞``.
            alpha: Its length ``α``.
            corrected: The correction moved ``there``.
        """
        region = self.region
        if region is None:
            return True
        before, after = here.errors(kept), there.errors(kept)
        if not _kept(before, after, self.drift):
            return False
        progress_level = kept + 1 if kept < len(here.levels) - 1 else 0
        if progress_level and not self.holds_met_tasks(here, there, progress_level, alpha * step):
            return False
        ratio = 1.0
        # levels above improved (the correction repaired them): a lexicographic
        # gain whatever it cost the progress level
        repaired = _sq(after) < _sq(before) - self.fix_above**2
        if progress_level and not repaired:
            ratio = _ratio(here, there, progress_level, alpha * step, corrected)
        if ratio < 0.25:  # the linear model overpromised: shorter steps
            self.radius = max(region.min_radius, region.shrink * alpha * size)
        elif ratio > 0.75:
            self.radius = min(region.max_radius, max(self.radius, 2.0 * alpha * size))
        return True

    def holds_met_tasks(self, here: Point, there: Point, k: int, step: np.ndarray) -> bool:
        """Whether the tasks of level ``k`` (the level in progress) that met
        their stop test at ``here`` end no worse than before, than ``drift``,
        or than the level's linear model gives them (:func:`met_tasks`):
        ``e(there) <= max(e(here), drift, r(step))``. A task sharing its level
        with an unmet one (feet beside a CoM target) keeps its pose through
        linearization error as a level above would, and still yields what the
        level's least squares trades off."""
        met = met_tasks(here, k, step)
        if met:
            held = there.upto(k).held(k)
            for i, before, predicted in met:
                if held[i] > max(before, self.drift, predicted):
                    return False
        return True

    def retry(self, alpha: float, size: float) -> float:
        """The length of a rejected step's retry, ``shrink`` times ``alpha``;
        the radius follows it (not below ``min_radius``)."""
        assert self.region is not None  # (without one every step is accepted)
        alpha *= self.region.shrink
        self.radius = max(self.region.min_radius, alpha * size)
        return alpha


def met_tasks(here: Point, k: int, step: np.ndarray) -> list[tuple[int, float, float]]:
    """The tasks of level ``k`` meeting their stop test at ``here``, as
    ``(index in the level, error held at here, r(step))``
    (:meth:`~pik_mj.solve.evaluation.Point.held`) with ``r`` the residual the
    task's rows leave after ``step``
    (:meth:`~pik_mj.tasks.task.TaskRows.residual_norm`): what the level's
    linear model gives it (about zero when the level's tasks agree; more when
    its least squares trades the task off against the others)."""
    if not k:
        return []
    rows, held = here.task_rows[k], here.held(k)
    return [
        (i, held[i], rows[i].residual_norm(step))
        for i, r in enumerate(here.level_reports[k])
        if r.satisfied
    ]


def _ratio(here: Point, there: Point, k: int, step: np.ndarray, corrected: bool) -> float:
    """``ρ``: the decrease of level ``k``'s error norm from ``here`` to ``there``
    over the decrease its rows predicted for ``step`` (1: no verdict).

    Judged only when the step needed a correction or made the error grow: then
    a poor ratio means a step too long for the curvature of the kept
    levels (the correction undid the gain). Otherwise the task's own model
    decides (a callable target's motion is not in its Jacobian; an error that
    did not change is a saturated clamp).
    """
    there.upto(k)
    e0, e1 = here.level_error(k), there.level_error(k)
    predicted = predicted_decrease(here.rows[k], step)
    if predicted > 1e-12 and abs(e1 - e0) > 1e-9 * e0:
        ratio = (e0 - e1) / predicted
        if ratio < 0.25 and not (corrected or e1 > e0):
            return 0.5  # no verdict: keep the radius
        return ratio
    return 1.0


def predicted_decrease(rows: TaskRows, x: np.ndarray) -> float:
    """What the rows' linear model predicts a step ``x`` takes off the level's
    unweighted error norm, its clamp included: ``‖r(0)‖ − ‖r(x)‖``
    (:meth:`~pik_mj.tasks.task.TaskRows.residual_norm`)."""
    return rows.residual_norm() - rows.residual_norm(x)


def _sq(errors: list[float]) -> float:
    """Sum of squares."""
    return sum(e * e for e in errors)


def _kept(before: list[float], after: list[float], drift: float) -> bool:
    """Every task of the kept levels within ``max(its error before, drift)``."""
    return all(a <= max(b, drift) for a, b in zip(after, before, strict=True))
