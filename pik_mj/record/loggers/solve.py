"""The logger of a solve: a ``pik_mj.solve`` callback that records it iteration
by iteration.

A solve is recorded by passing :meth:`Recorder.solve_logger
<pik_mj.record.recorder.Recorder.solve_logger>` among its callbacks::

    checks = scene.static_checker()
    log = recorder.solve_logger("reach", checks=checks, start=robot)
    result = robot.fullbody_inverse_kinematics(..., callback=[checks, log])
    log.finish(result)

The ``iteration`` timeline counts iterations over all solves of a recording:
a solve's start pose is at the count when it starts, its iterations follow,
its final pose one tick after its last iteration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from pik_mj.balance import halfplanes_from_polygon, inset_vertices
from pik_mj.exceptions import InvalidInput
from pik_mj.record import style
from pik_mj.record.loggers.surface import RecorderSurface
from pik_mj.sim import StaticReport
from pik_mj.solve import IterationInfo, SolveResult
from pik_mj.tasks.com import CentroidTask, robot_root_body
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.scfr import ScfrTask

__all__ = ["SolveLogger", "margin_outline"]


def margin_outline(vertices: np.ndarray, d: float) -> np.ndarray:
    """The convex polygon ``vertices`` (m, 3) (horizontal, counter-clockwise)
    with every edge moved inward by ``d`` [m] (:func:`pik_mj.balance.inset_vertices`);
    (0, 3) when it vanishes. With the CoM margin as ``d`` it is the iso-margin
    outline through the CoM's projection.
    """
    try:
        xy = inset_vertices(halfplanes_from_polygon(vertices[:, :2]), d)
    except InvalidInput:  # near-degenerate hull
        return np.zeros((0, 3))
    return np.column_stack([xy, np.full(len(xy), float(np.mean(vertices[:, 2])))])


_BALANCE_SERIES = (
    ("margin", style.MARGIN, "CoM margin [m]"),
    ("contacts", style.CONTACT, "contacts"),
    ("feasible", style.FEASIBLE, "equilibrium (1 = yes)"),
)
"""The static check's series: name under ``balance/``, colour, legend label
(the contact count and the equilibrium flag share a plot, so they get colours
apart rather than rerun's colours hashed from their paths, which can coincide)."""


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).ravel())
    return q


def _mjdata(source: Any) -> mujoco.MjData:
    """The ``MjData`` of ``source``: an ``MjData``, or anything with ``.data``
    (a :class:`pik_mj.Robot`, a ``mink.Configuration``)."""
    data = source if isinstance(source, mujoco.MjData) else getattr(source, "data", None)
    if not isinstance(data, mujoco.MjData):
        raise InvalidInput(
            "start must be an MjData or have an MjData .data (a Robot, a mink.Configuration), "
            f"got {type(source).__name__}"
        )
    return data


def _top_level_body(model: mujoco.MjModel) -> str | None:
    """Name of the robot's top-level body (:func:`~pik_mj.tasks.com.robot_root_body`),
    or None (every body the robot's) when it cannot be told."""
    try:
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, robot_root_body(model))
    except InvalidInput:
        return None


@dataclass
class _Plan:
    """The tasks of one solve's stack that are logged (made once per stack)."""

    levels: list[list[Any]]  # the stack it was made for (compared by identity)
    centroid: CentroidTask | None  # the first one: its target is the CoM target
    frames: list[FrameTask]
    current_paths: tuple[str, ...]  # of each frame task's current frame
    scfr: list[ScfrTask]


class SolveLogger:
    """Logs one solve, iteration by iteration (a ``pik_mj.solve`` callback).

    Made by :meth:`Recorder.solve_logger`; the solve starts at the recording's
    current ``iteration`` count, where the start pose is logged when
    ``start`` is given. Each call (count + 1) logs, from the
    :class:`~pik_mj.solve.IterationInfo`:

    * the body poses, the robot's CoM and the target of the first
      :class:`~pik_mj.tasks.com.CentroidTask`;
    * each :class:`~pik_mj.tasks.frame.FrameTask`'s target (when it changes;
      the first ones also at the start count, so they show from the start) and
      current frame (``world/tasks/<task>/target|current``);
    * each task's error ``errors/level_<k>/<label>/<task>`` from ``info.tasks``
      (the solve loop's own evaluation: nothing is evaluated again), named
      ``"<label>: <task>"`` in the legends;
    * each :class:`~pik_mj.tasks.scfr.ScfrTask`'s region (``world/scfr``);
    * with ``checks`` (an object whose ``.reports`` list gets one static report
      per iteration, run before this logger): the last report's support
      polygon with the CoM's iso-margin outline (``<polygon>/margin``,
      :func:`margin_outline`), its contacts with the LP's forces,
      ``balance/margin`` [m], ``balance/feasible`` (1/0),
      ``balance/contacts``, and a text line when static equilibrium is lost or
      regained.

    :meth:`finish` logs the final pose one tick after the last iteration and
    the outcome in the text log.
    """

    def __init__(
        self, recorder: RecorderSurface, label: str, checks: Any = None, *, start: Any = None
    ) -> None:
        if checks is not None and not isinstance(getattr(checks, "reports", None), list):
            raise InvalidInput(
                f"checks must have a .reports list (a scene's static checker), got "
                f"{type(checks).__name__}"
            )
        self.recorder = recorder
        self.label = str(label)
        self.checks = checks
        self.iterations = 0
        self._data = None if start is None else _mjdata(start)
        if self._data is not None and recorder.model is None:  # its robot's geometry
            model = self._data.model
            recorder.log_model_geometry(model, robot_root_body=_top_level_body(model))
        self._configuration: Any = None
        self._plan: _Plan | None = None
        self._root: tuple[Any, int] | None = None  # (model, robot root body id)
        self._reports_seen = 0 if checks is None else len(checks.reports)
        self._feasible: bool | None = None
        self._start = self._tick = recorder.begin_solve()
        recorder.log_text(f"solve {self.label!r} starts")
        if self._data is not None:
            self._log_pose(self._data)

    # -- per iteration ----------------------------------------------------------

    def __call__(self, info: IterationInfo) -> None:
        rec = self.recorder
        cfg = info.configuration
        self._configuration = cfg
        if rec.model is None:  # a solve recorded on its own: its robot's geometry
            rec.log_model_geometry(cfg.model, robot_root_body=_top_level_body(cfg.model))
        plan = self._plan_of(info.levels)
        if self.iterations == 0:  # targets and frames shown from the start count
            rec.set_time("iteration", self._start)
            self._log_targets(plan, cfg)
            if self._data is not None:
                self._log_frames(plan, self._data)
            else:  # no start pose: no frame (rerun would draw one at the origin)
                rec.hide_frames(plan.current_paths)
        self.iterations += 1
        self._tick = rec.next_tick()
        self._log_targets(plan, cfg)
        data = cfg.data
        self._log_frames(plan, data)
        for task in plan.scfr:
            region = task.region(cfg)
            if not region.empty:
                z = float(np.mean([c.p_WC[2] for c in task.contacts_now(cfg)]))
                v = np.column_stack([region.vertices, np.full(len(region.vertices), z)])
                rec.log_polygon(v, path=rec.paths.scfr, color=style.SCFR)
        self._log_pose(data)
        rec.log_task_errors({(r.level, r.name): r.error for r in info.tasks}, solve=self.label)
        if self.checks is not None and len(self.checks.reports) > self._reports_seen:
            self._reports_seen = len(self.checks.reports)
            self._log_static(self.checks.reports[-1])

    def finish(self, result: SolveResult) -> SolveResult:
        """Log the solve's final pose one tick after its last iteration (its start
        pose when it reverted) and its outcome (level failure, revert) in the
        text log; returns ``result``."""
        rec = self.recorder
        self._tick = rec.next_tick()
        source = self._configuration if self._configuration is not None else self._data
        if source is not None:
            self._log_pose(source.data if hasattr(source, "data") else source)
        if result.failure:
            rec.log_text(f"solve {self.label!r}: level failure: {result.failure}", level="ERROR")
        rec.log_text(
            f"solve {self.label!r}: {'converged' if result.converged else 'not converged'}"
            f" after {result.iterations} iterations"
            + (", reverted to its start pose" if result.reverted else ""),
            level="INFO" if result.converged else "WARN",
        )
        return result

    # -- parts ------------------------------------------------------------------

    def _plan_of(self, levels: list[list[Any]]) -> _Plan:
        """What ``levels`` log each iteration (made once: the solve loop passes
        the same stack every iteration)."""
        plan = self._plan
        if plan is not None and plan.levels is levels:
            return plan
        paths = self.recorder.paths
        tasks = [task for level in levels for task in level]
        centroids = [t for t in tasks if isinstance(t, CentroidTask)]
        frames = [t for t in tasks if isinstance(t, FrameTask)]
        plan = self._plan = _Plan(
            levels=levels,
            centroid=centroids[0] if centroids else None,
            frames=frames,
            current_paths=tuple(paths.task_current(t.name) for t in frames),
            scfr=[t for t in tasks if isinstance(t, ScfrTask)],
        )
        return plan

    def _log_targets(self, plan: _Plan, cfg: Any) -> None:
        """Each frame task's target frame and a labelled marker at it, and the
        CoM target, each when it changed (the viewer holds the latest value; a
        fixed frame target is compared by identity, callable and robot-frame
        targets move)."""
        rec = self.recorder
        for task in plan.frames:
            fixed = task.target_pose
            if not rec.shows_target(task.name, fixed):
                p_T, R_T = task.target_pose_now(cfg)
                rec.log_target(task.name, p_T, _quat_wxyz(R_T), fixed=fixed)
        if plan.centroid is not None:
            target = np.asarray(plan.centroid.target_now(cfg), dtype=float)
            last = rec.com_target
            if last is None or not bool((last == target).all()):
                rec.log_com_target(target)

    def _log_frames(self, plan: _Plan, data: mujoco.MjData) -> None:
        """The current frame of each frame task, in one call (one buffer)."""
        if plan.frames:
            n = len(plan.frames)
            p, q = np.empty((n, 3)), np.empty((n, 4))
            for i, task in enumerate(plan.frames):
                p[i] = task.move_target.position(data)
                mujoco.mju_mat2Quat(q[i], task.move_target.rotation(data).reshape(9))
            self.recorder.log_frames(plan.current_paths, p, q)

    def _log_pose(self, data: mujoco.MjData) -> None:
        """Body poses and the robot's CoM at the current count."""
        rec = self.recorder
        rec.log_body_poses(data, timeline="iteration", time=self._tick)
        rec.log_com(data.subtree_com[self._root_id(rec.model)])

    def _root_id(self, model: Any) -> int:
        """The robot's root body in ``model``: the recording's
        ``robot_root_body``, or the world when every body is the robot's."""
        if self._root is None or self._root[0] is not model:
            name = self.recorder.robot_root_body
            self._root = (model, 0 if name is None else robot_root_body(model, name))
        return self._root[1]

    def _log_static(self, report: StaticReport) -> None:
        """A static report: polygon and margin outline, contacts and LP forces,
        ``balance/*`` and equilibrium changes."""
        rec = self.recorder
        poly = np.asarray(report.support_polygon, dtype=float).reshape(-1, 3)
        if len(poly) >= 3:
            shrunk = margin_outline(poly, report.margin) if report.margin > 0 else np.zeros((0, 3))
            rec.log_polygon(poly, shrunk)
        else:
            rec.log_polygon(np.zeros((0, 3)), np.zeros((0, 3)))
        env = report.environment_contacts
        forces = np.zeros((len(env), 3)) if report.forces is None else report.forces
        rec.log_contacts(np.array([c.position for c in env]).reshape(-1, 3), forces)
        paths = rec.paths
        if self._feasible is None:  # this solve's first report: the series' styles
            for name, color, label in _BALANCE_SERIES:
                rec.log_series_style(paths.balance_metric(name), color, label)
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
