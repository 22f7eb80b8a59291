"""TEMPORARY adapter (issue 13): the recording interface the top layer codes
against, on top of today's :class:`pik_mj.record.Recorder`.

Helper "rec" builds the real one in the ``pik_mj.record`` package
(``Recorder.solve_logger``, ``Recorder.hold_logger``, a ``close`` that sends the
blueprint). Until it is merged, this module gives the same three methods by
subclassing today's Recorder; the per-iteration logging moved here as one
block from the old ``ScenarioRecorder`` (``_log_tasks``, ``_log_static``,
``_plan``, ``_log_pose``) and from ``Scene.hold``'s recording. At the merge,
delete this module and import ``Recorder`` from ``pik_mj.record``.

Timelines: ``iteration`` counts iterations over every solve logged by one
recorder (each solve's iterations, then one tick for its final pose);
``sim_time`` is the hold's physics time [s].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import TracebackType
from typing import Any

import mujoco
import numpy as np

from pik_mj import record
from pik_mj.exceptions import InvalidInput
from pik_mj.spatial import matrix_to_quat
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.scfr import ScfrTask

__all__ = ["HoldLogger", "Recorder", "SolveLogger"]


class Recorder(record.Recorder):
    """:class:`pik_mj.record.Recorder` with the solve and hold loggers, and a
    :meth:`close` that sends the blueprint (one plot per level of every solve
    logged, the balance and hold series when they were logged)."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.iteration = 0  # ticks of the iteration timeline used so far
        self._robot_root: str | None = None
        self._n_levels = 0
        self._logged_balance = False
        self._logged_hold = False
        self._logged_targets: dict[str, object] = {}
        self._task_frame_paths: dict[str, tuple[str, str]] = {}

    def log_model_geometry(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData | None = None,
        *,
        robot_root_body: str | None = None,
        **kwargs: Any,
    ) -> None:
        self._robot_root = robot_root_body
        super().log_model_geometry(model, data, robot_root_body=robot_root_body, **kwargs)

    def _use_model(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Log ``model``'s geometry unless it is the one logged last."""
        if self._model is not model:
            self.log_model_geometry(model, data, robot_root_body=self._robot_root)

    def solve_logger(self, label: str, checks: Any = None) -> SolveLogger:
        """A :func:`pik_mj.solve` callback logging solve ``label`` (see :class:`SolveLogger`)."""
        return SolveLogger(self, label, checks)

    def hold_logger(self, every: int = 10) -> HoldLogger:
        """A hold callback logging every ``every``-th :class:`~pik_mj.sim.HoldSample`."""
        return HoldLogger(self, every)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc is not None and not self.closed:
            self.log_text(f"raised {type(exc).__name__}: {exc}", level="ERROR")
        self.close()

    def close(self) -> None:
        """Send the rows, then the blueprint, and close (idempotent)."""
        if self.closed:
            return
        try:
            self.send_buffered()  # rows first: the stream writes them meanwhile
            extra = [(self.paths.balance, "balance (simulation)")] if self._logged_balance else []
            if self._logged_hold:
                extra.append((self.paths.hold, "physics hold"))
            self.send_blueprint(range(1, self._n_levels), extra=extra)
        finally:
            super().close()


@dataclass
class _LogPlan:
    """The tasks of one solve's stack that a :class:`SolveLogger` logs."""

    levels: list[list[Any]]  # the stack it was made for (compared by identity)
    centroid: CentroidTask | None  # the first one: its target is the CoM target
    frames: list[tuple[FrameTask, str, str]]  # (task, target path, current path)
    current_paths: tuple[str, ...]
    scfr: list[ScfrTask]


class SolveLogger:
    """Logs one solve on the ``iteration`` timeline.

    Every iteration: the body poses, the CoM and the target of a
    :class:`~pik_mj.tasks.com.CentroidTask`, the target and current frame of every
    :class:`~pik_mj.tasks.frame.FrameTask` (``world/tasks/<task>/target|current``;
    a fixed target when it changes), each task's error at
    ``errors/level_<k>/<task>``, an SCFR task's region at ``world/scfr``, and, with
    ``checks`` (a :class:`pik_mj.sim.StaticChecks` called before this logger),
    its last report: the support polygon of the actual ground contacts with the
    CoM's iso-margin outline, the contact points with the LP's forces, and
    ``balance/margin`` [m], ``balance/feasible`` (1/0), ``balance/contacts``.
    :meth:`finish` logs the final pose one tick later and the outcome in the
    text log (a level failure, a revert).
    """

    def __init__(self, recorder: Recorder, label: str, checks: Any = None):
        self.recorder = recorder
        self.label = label
        self.checks = checks
        self._plan: _LogPlan | None = None
        self._feasible: bool | None = None
        self._configuration: Any = None
        recorder.set_time("iteration", recorder.iteration)
        recorder.log_text(f"solve {label!r} starts")

    def __call__(self, info: Any) -> None:
        rec = self.recorder
        self._configuration = info.configuration
        rec._use_model(info.configuration.model, info.configuration.data)
        rec.iteration += 1
        rec.set_time("iteration", rec.iteration)
        self._log_tasks(info)
        if self.checks is not None and self.checks.reports:
            self._log_static(self.checks.reports[-1])

    def finish(self, result: Any) -> None:
        """Log the final pose (the configuration now: after a revert, the start)
        one tick after the last iteration, and the outcome."""
        rec = self.recorder
        rec.iteration += 1
        rec.set_time("iteration", rec.iteration)
        if self._configuration is not None:
            data = self._configuration.data
            rec.log_body_poses(data, time=rec.iteration)
            rec.log_com(self._com(data))
        label = self.label
        if result.failure:
            rec.log_text(f"solve {label!r}: level failure: {result.failure}", level="ERROR")
        rec.log_text(
            f"solve {label!r}: {'converged' if result.converged else 'not converged'}"
            f" after {result.iterations} iterations"
            + (", reverted to its start pose" if result.reverted else ""),
            level="INFO" if result.converged else "WARN",
        )

    def _com(self, data: mujoco.MjData) -> np.ndarray:
        rec = self.recorder
        model = self._configuration.model
        root = 1 if rec._robot_root is None else model.body(rec._robot_root).id
        return data.subtree_com[root]

    def _frame_paths(self, task: str) -> tuple[str, str]:
        """Entity paths of a frame task's target and current frame (cached)."""
        cache = self.recorder._task_frame_paths
        paths = cache.get(task)
        if paths is None:
            p = self.recorder.paths
            paths = cache[task] = (p.task_target(task), p.task_current(task))
        return paths

    def _log_plan(self, levels: list[list[Any]]) -> _LogPlan:
        """What ``levels`` log each iteration (made once per solve: the solve
        loop passes the same stack every iteration)."""
        plan = self._plan
        if plan is not None and plan.levels is levels:
            return plan
        tasks = [task for level in levels for task in level]
        centroids = [t for t in tasks if isinstance(t, CentroidTask)]
        frames = [(t, *self._frame_paths(t.name)) for t in tasks if isinstance(t, FrameTask)]
        plan = self._plan = _LogPlan(
            levels=levels,
            centroid=centroids[0] if centroids else None,
            frames=frames,
            current_paths=tuple(current for _, _, current in frames),
            scfr=[t for t in tasks if isinstance(t, ScfrTask)],
        )
        return plan

    def _log_tasks(self, info: Any) -> None:
        """Body poses, CoM (+ target), task frames, task errors and SCFR regions."""
        rec = self.recorder
        cfg, data = info.configuration, info.configuration.data
        plan = self._log_plan(info.levels)
        com_target = None if plan.centroid is None else plan.centroid.target_now(cfg)
        targets = rec._logged_targets
        for task, target_path, _ in plan.frames:
            # a fixed target is logged when it changes: the viewer holds the
            # latest value (callable and robot-frame targets move)
            fixed = task.target_pose
            if fixed is None or targets.get(target_path) is not fixed:
                p_T, R_T = task.target_pose_now(cfg)
                rec.log_frame(target_path, p_T, matrix_to_quat(R_T))
                targets[target_path] = fixed
        if plan.frames:  # all current frames in one call (one buffer)
            rec.log_frames(
                plan.current_paths,
                [task.move_target.position(data) for task, _, _ in plan.frames],
                [matrix_to_quat(task.move_target.rotation(data)) for task, _, _ in plan.frames],
            )
        for task in plan.scfr:
            region = task.region(cfg)
            if not region.empty:
                z = float(np.mean([c.p_WC[2] for c in task.contacts_now(cfg)]))
                v = np.column_stack([region.vertices, np.full(len(region.vertices), z)])
                rec.log_polygon(v, path=rec.paths.scfr, color=(40, 200, 120))
        rec.log_body_poses(data, time=rec.iteration)
        if com_target is not None:  # logged when it changes, like fixed frame targets
            com_target = np.asarray(com_target, dtype=float)
            last = targets.get(rec.paths.com_target)
            if isinstance(last, np.ndarray) and np.array_equal(last, com_target):
                com_target = None
            else:
                targets[rec.paths.com_target] = com_target.copy()
        rec.log_com(self._com(data), target=com_target)
        # the solve loop's own evaluation at this configuration: no recomputation
        rec.log_task_errors({(r.level, r.name): r.error for r in info.tasks})
        rec._n_levels = max(rec._n_levels, len(info.levels))

    def _log_static(self, report: Any) -> None:
        """A :class:`pik_mj.sim.StaticReport`: polygon, contacts, balance series."""
        rec = self.recorder
        rec._logged_balance = True
        if len(report.support_polygon) >= 3:
            rec.log_polygon(report.support_polygon, report.margin_outline)
        else:
            rec.log_polygon(np.zeros((0, 3)), np.zeros((0, 3)))
        env = report.environment_contacts
        forces = np.zeros((len(env), 3)) if report.forces is None else report.forces
        rec.log_contacts(np.array([c.position for c in env]).reshape(-1, 3), forces)
        paths = rec.paths
        if math.isfinite(report.margin):
            rec.log_scalar(paths.balance_metric("margin"), report.margin)
        rec.log_scalar(paths.balance_metric("feasible"), float(report.feasible))
        rec.log_scalar(paths.balance_metric("contacts"), float(len(env)))
        if report.feasible != self._feasible:
            if self._feasible is not None or not report.feasible:
                rec.log_text(
                    f"{self.label}: static equilibrium "
                    + ("regained" if report.feasible else f"infeasible ({report.message})"),
                    level="INFO" if report.feasible else "WARN",
                )
            self._feasible = report.feasible


class HoldLogger:
    """Logs a physics hold on the ``sim_time`` timeline, every ``every``-th
    :class:`~pik_mj.sim.HoldSample`: body poses, CoM, support polygon, the contact
    points with MuJoCo's contact forces, and ``hold/drift``, ``hold/slip``,
    ``hold/margin``, ``hold/contact_force_z`` (their total vertical force [N])."""

    def __init__(self, recorder: Recorder, every: int = 10):
        if not isinstance(every, int) or every < 1:
            raise InvalidInput(f"every must be a positive integer, got {every!r}")
        self.recorder = recorder
        self.every = every
        self.calls = 0

    def __call__(self, sample: Any) -> None:
        k = self.calls
        self.calls += 1
        if k % self.every:
            return
        rec = self.recorder
        if k == 0:
            rec._logged_hold = True
            rec.disable_timeline("iteration")
            rec.set_time("sim_time", sample.time)
            rec.log_text("physics hold starts")
            rec._use_model(sample.model, sample.data)
        rec.log_body_poses(sample.data, timeline="sim_time", time=sample.time)
        rec.log_com(sample.com)
        if len(sample.support_polygon) >= 3:
            rec.log_polygon(sample.support_polygon)
        paths = rec.paths
        rec.log_scalar(paths.hold_metric("drift"), sample.drift)
        rec.log_scalar(paths.hold_metric("slip"), sample.slip)
        if math.isfinite(sample.margin):
            rec.log_scalar(paths.hold_metric("margin"), sample.margin)
        rec.log_contacts(sample.contact_points, sample.contact_forces)
        rec.log_scalar(
            paths.hold_metric("contact_force_z"), float(sample.contact_forces[:, 2].sum())
        )
