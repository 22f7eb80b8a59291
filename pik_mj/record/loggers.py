"""Per-iteration loggers: callbacks that record a solve or a physics hold.

A solve is recorded by passing :meth:`Recorder.solve_logger
<pik_mj.record.recorder.Recorder.solve_logger>` among its callbacks, a
physics hold by passing :meth:`Recorder.hold_logger
<pik_mj.record.recorder.Recorder.hold_logger>` to ``scene.hold``::

    checks = scene.static_checker()
    log = recorder.solve_logger("reach", checks=checks, start=robot)
    result = robot.fullbody_inverse_kinematics(..., callback=[checks, log])
    log.finish(result)
    report = scene.hold(result.q, callback=recorder.hold_logger())

The ``iteration`` timeline counts iterations over all solves of a recording:
a solve's start pose is at the count when it starts, its iterations follow,
its final pose one tick after its last iteration. A hold is on ``sim_time``
[s].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import mujoco
import numpy as np
import rerun as rr

from pik_mj.balance import halfplanes_from_polygon, inset_vertices
from pik_mj.exceptions import InvalidInput, RenderingUnavailable
from pik_mj.record import style
from pik_mj.tasks.com import CentroidTask, robot_root_body
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.scfr import ScfrTask

if TYPE_CHECKING:
    from pik_mj.record.recorder import Recorder
    from pik_mj.solve import IterationInfo, SolveResult

__all__ = [
    "HoldLogger",
    "HoldSample",
    "MotionLogger",
    "SolveLogger",
    "log_sensors",
    "log_walk",
    "margin_outline",
]


class HoldSample(Protocol):
    """What a physics hold passes its callback (duck-typed).

    Attributes:
        time: Simulated time [s].
        model: The scene's ``MjModel``.
        data: The physics state now (``MjData``).
        com: Robot CoM (3,) [m].
        support_polygon: Support polygon of the ground contacts (m, 3) [m].
        margin: CoM margin to the support polygon [m] (``-inf`` without contact).
        drift: Largest root displacement so far [m].
        slip: Largest foot slip so far [m].
        contact_points: Contact points on the robot (n, 3) [m].
        contact_forces: Contact forces on the robot (n, 3) [N].
    """

    time: float
    model: Any
    data: Any
    com: np.ndarray
    support_polygon: np.ndarray
    margin: float
    drift: float
    slip: float
    contact_points: np.ndarray
    contact_forces: np.ndarray


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
    frames: list[tuple[FrameTask, str, str]]  # (task, target path, current path)
    current_paths: tuple[str, ...]
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
        self, recorder: Recorder, label: str, checks: Any = None, *, start: Any = None
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
        self._start = recorder._begin_solve()
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
        rec.set_time("iteration", rec._next_tick())
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
        rec.set_time("iteration", rec._next_tick())
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
        frames = [
            (t, paths.task_target(t.name), paths.task_current(t.name))
            for t in tasks
            if isinstance(t, FrameTask)
        ]
        plan = self._plan = _Plan(
            levels=levels,
            centroid=centroids[0] if centroids else None,
            frames=frames,
            current_paths=tuple(current for _, _, current in frames),
            scfr=[t for t in tasks if isinstance(t, ScfrTask)],
        )
        return plan

    def _log_targets(self, plan: _Plan, cfg: Any) -> None:
        """Each frame task's target frame and a labelled marker at it, and the
        CoM target, each when it changed (the viewer holds the latest value; a
        fixed frame target is compared by identity, callable and robot-frame
        targets move)."""
        rec = self.recorder
        logged = rec._logged_targets
        for task, target_path, _ in plan.frames:
            fixed = task.target_pose
            if fixed is None or logged.get(target_path) is not fixed:
                p_T, R_T = task.target_pose_now(cfg)
                rec.log_target(task.name, p_T, _quat_wxyz(R_T))
                logged[target_path] = fixed
        if plan.centroid is not None:
            target = np.asarray(plan.centroid.target_now(cfg), dtype=float)
            last = logged.get(rec.paths.com_target)
            if not (isinstance(last, np.ndarray) and bool((last == target).all())):
                rec.log_com_target(target)

    def _log_frames(self, plan: _Plan, data: mujoco.MjData) -> None:
        """The current frame of each frame task, in one call (one buffer)."""
        if plan.frames:
            n = len(plan.frames)
            p, q = np.empty((n, 3)), np.empty((n, 4))
            for i, (task, _, _) in enumerate(plan.frames):
                p[i] = task.move_target.position(data)
                mujoco.mju_mat2Quat(q[i], task.move_target.rotation(data).reshape(9))
            self.recorder.log_frames(plan.current_paths, p, q)

    def _log_pose(self, data: mujoco.MjData) -> None:
        """Body poses and the robot's CoM at the current count."""
        rec = self.recorder
        rec.log_body_poses(data, timeline="iteration", time=rec._time["iteration"])
        rec.log_com(data.subtree_com[self._root_id(rec.model)])

    def _root_id(self, model: Any) -> int:
        """The robot's root body in ``model``: the recording's
        ``robot_root_body``, or the world when every body is the robot's."""
        if self._root is None or self._root[0] is not model:
            name = self.recorder.robot_root_body
            self._root = (model, 0 if name is None else robot_root_body(model, name))
        return self._root[1]

    def _log_static(self, report: Any) -> None:
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
            self._feasible = report.feasible


class HoldLogger:
    """Logs a physics hold on ``sim_time`` (a ``scene.hold`` callback).

    Made by :meth:`Recorder.hold_logger`. Every ``every``-th call (the first
    one included) logs, from the :class:`HoldSample`: the body poses, the CoM,
    the support polygon, the contact points and forces on the robot, and the
    series ``hold/drift``, ``hold/slip``, ``hold/margin`` [m] and
    ``hold/contact_force_z`` (total vertical contact force [N]). The first call
    stops stamping rows with ``iteration`` and, when the sample's model is not
    the one logged, logs its geometry (the scene's floor, held objects).
    :meth:`finish` logs the last sample if it was skipped, and the verdict.
    """

    def __init__(self, recorder: Recorder, every: int = 10) -> None:
        if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
            raise InvalidInput(f"every must be an integer >= 1, got {every!r}")
        self.recorder = recorder
        self.every = int(every)
        self.calls = 0
        self._skipped: Any = None

    def __call__(self, sample: HoldSample) -> None:
        if self._starts(sample):
            self._begin(sample)
        n, self.calls = self.calls, self.calls + 1
        if n % self.every:
            self._skipped = sample
            return
        self._skipped = None
        self._log(sample)

    def _starts(self, sample: HoldSample) -> bool:
        """The first sample starts the hold."""
        return self.calls == 0

    def _begin(self, sample: HoldSample) -> None:
        self.recorder._begin_sim(sample.model, sample.data, float(sample.time))
        self.recorder.log_text("physics hold starts")

    def _metric(self, name: str) -> str:
        return self.recorder.paths.hold_metric(name)

    def _log(self, sample: HoldSample) -> None:
        rec = self.recorder
        rec.log_body_poses(sample.data, timeline="sim_time", time=rec.sim_clock(sample.time))
        rec.log_com(sample.com)
        if len(sample.support_polygon) >= 3:
            rec.log_polygon(sample.support_polygon)
        forces = np.asarray(sample.contact_forces, dtype=float).reshape(-1, 3)
        rec.log_contacts(sample.contact_points, forces)
        rec.log_scalar(self._metric("drift"), sample.drift)
        rec.log_scalar(self._metric("slip"), sample.slip)
        if math.isfinite(sample.margin):
            rec.log_scalar(self._metric("margin"), sample.margin)
        rec.log_scalar(self._metric("contact_force_z"), float(forces[:, 2].sum()))

    def finish(self, report: Any = None) -> Any:
        """Log the last sample if it was skipped and, given the hold's report
        (``.passed``, ``.failures``), its verdict; returns ``report``."""
        if self._skipped is not None:
            self._log(self._skipped)
            self._skipped = None
        if report is not None:
            failures: Sequence[str] = getattr(report, "failures", ())
            self.recorder.log_text(
                "physics hold: "
                + ("passed" if report.passed else "FAILED")
                + (f" ({'; '.join(failures)})" if failures else ""),
                level="INFO" if report.passed else "ERROR",
            )
        return report


def log_sensors(recorder: Recorder, sensors: Any, model: Any, data: Any) -> None:
    """Log the readings of :class:`pik_mj.robot.sensors.RobotSensors` in ``data`` at
    the current time (MuJoCo's ``sensordata``: computed in the last
    ``mj_step``/``mj_forward``):

    * each force sensor's contact force ``|f|`` [N] (the wrench the environment
      applies behind it, its distal part's weight compensated:
      :meth:`~pik_mj.robot.sensors.ForceSensor.contact_wrench`) at
      ``sensors/force/<site>``;
    * each bumper's touch force [N] at ``sensors/touch/<site>`` and its state
      (1 = on, the seed's reading) at ``sensors/bumper/<site>``;
    * each IMU's ``a − g`` [m/s²] and angular velocity [rad/s] in its frame at
      ``sensors/imu_acceleration/<site>_x|y|z`` and
      ``sensors/imu_angular_velocity/<site>_x|y|z``.
    """
    paths = recorder.paths
    for s in sensors.force_sensors:
        if s.force is not None:
            f = s.contact_wrench(model, data).force
            recorder.log_scalar(paths.sensor_series("force", s.name), float(np.linalg.norm(f)))
    for b in sensors.bumpers:
        recorder.log_scalar(paths.sensor_series("touch", b.name), b.force(data))
        recorder.log_scalar(paths.sensor_series("bumper", b.name), float(b.is_on(data)))
    for imu in sensors.imu_sensors:
        reading = imu.read(data)
        for group, value in (
            ("imu_acceleration", reading.acceleration),
            ("imu_angular_velocity", reading.angular_velocity),
        ):
            if value is not None:
                for axis, v in zip("xyz", value, strict=True):
                    recorder.log_scalar(paths.sensor_series(group, f"{imu.name}_{axis}"), v)


class MotionLogger(HoldLogger):
    """Logs a motion played in physics on ``sim_time`` (a ``scene.play`` callback).

    Made by :meth:`Recorder.motion_logger`. Every ``every``-th call logs what
    a :class:`HoldLogger` logs (body poses, CoM, support polygon, contacts),
    and:

    * the reference pose (the IK's iterates, interpolated) as a second,
      translucent robot at ``world/reference`` (``reference``);
    * ``motion/tracking_error`` [rad], ``motion/drift`` (root from its
      reference), ``motion/slip``, ``motion/margin`` and
      ``motion/frame_error/<frame>`` [m];
    * with ``sensors``, the robot's sensors (:func:`log_sensors`);
    * each of ``cameras`` (:class:`pik_mj.robot.camera.Camera` of the robot) as a
      pinhole at its pose, and every ``image_every`` seconds its image rendered
      by MuJoCo; where rendering is unavailable a text line says why, once.

    A sample from another model than the last one (the part of a motion after
    a grasp, played in the scene with the grasp) logs that scene's geometry.
    :meth:`finish` logs the last sample if it was skipped, each waypoint's
    index at its time (``motion/waypoint``: the iterates on ``sim_time``), the
    start of each segment (solve) and the verdict. A motion played in parts
    (one :meth:`finish` per part, each part from the last one's state) counts
    its waypoints on: the first of a part follows the last of the part before.
    """

    def __init__(
        self,
        recorder: Recorder,
        every: int = 10,
        *,
        reference: bool = True,
        sensors: bool = True,
        cameras: Sequence[Any] = (),
        image_every: float | None = 0.5,
    ) -> None:
        super().__init__(recorder, every)
        if image_every is not None and not (math.isfinite(image_every) and image_every > 0):
            raise InvalidInput(f"image_every must be > 0 [s] or None, got {image_every}")
        self.reference = bool(reference)
        self.sensors = bool(sensors)
        self.cameras = list(cameras)
        self.image_every = image_every
        self.images = 0
        self._model: Any = None
        self._sensors: Any = None
        self._renderer: Any = None
        self._no_rendering: str | None = None
        self._next_image = -math.inf
        self._waypoints = 0  # waypoints of the parts finished so far

    def _starts(self, sample: HoldSample) -> bool:
        """A sample of another model than the last starts a run (a new scene)."""
        return sample.model is not self._model

    def _begin(self, sample: HoldSample) -> None:
        from pik_mj.robot.sensors import RobotSensors

        rec = self.recorder
        rec._begin_sim(sample.model, sample.data, float(sample.time))
        model = sample.model
        if self.reference:
            rec.log_reference_geometry(model)
        root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, rec.robot_root_body or "")
        bodies = [
            model.body(b).name
            for b in range(1, model.nbody)
            if root < 0 or model.body_rootid[b] == root
        ]
        self._sensors = RobotSensors.from_model(model, bodies=bodies) if self.sensors else None
        self._close_renderer()
        rec.log_text("motion starts" if self._model is None else "motion goes on in a new scene")
        self._model = model

    def _metric(self, name: str) -> str:
        return self.recorder.paths.motion_metric(name)

    def _log(self, sample: HoldSample) -> None:
        super()._log(sample)
        rec = self.recorder
        rec.log_scalar(self._metric("tracking_error"), sample.tracking_error)
        for frame, error in sample.frame_errors.items():
            rec.log_scalar(rec.paths.frame_error(frame), error)
        if self.reference and sample.reference is not None:
            rec.log_reference_poses(sample.reference)
        if self._sensors is not None:
            log_sensors(rec, self._sensors, sample.model, sample.data)
        if self.cameras:
            self._log_cameras(sample)

    def _log_cameras(self, sample: HoldSample) -> None:
        rec = self.recorder
        render = self.image_every is not None and sample.time >= self._next_image
        if render:
            self._next_image = sample.time + float(self.image_every)
        for camera in self.cameras:
            image = self._render(sample, camera) if render else None
            rec.log_camera(camera, sample.data, image)

    def _render(self, sample: HoldSample, camera: Any) -> np.ndarray | None:
        from pik_mj.robot.camera import CameraRenderer

        if self._no_rendering is not None:
            return None
        k = camera.intrinsics
        try:
            if self._renderer is None:
                self._renderer = CameraRenderer(sample.model, k.width, k.height)
        except (RenderingUnavailable, InvalidInput) as err:
            self._no_rendering = str(err)
            self.recorder.log_text(
                f"camera images unavailable (the pinholes are logged): {err}", level="WARN"
            )
            return None
        self.images += 1
        return self._renderer.render(sample.data, camera)

    def _close_renderer(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def finish(self, report: Any = None) -> Any:
        """Log the last sample if it was skipped and, given the motion's report
        (:class:`pik_mj.sim.MotionReport`), each waypoint's index at its time,
        the start of each segment and the verdict; returns ``report``."""
        rec = self.recorder
        if self._skipped is not None:
            self._log(self._skipped)
            self._skipped = None
        self._close_renderer()
        if report is None:
            return report
        path = self._metric("waypoint")
        last = None
        first = self._waypoints
        for i, (t, label) in enumerate(
            zip(report.waypoint_times, report.segments, strict=True), start=first
        ):
            rec.set_time("sim_time", rec.sim_clock(t))
            rec.log_scalar(path, float(i))
            if label != last:
                rec.log_text(f"motion: waypoint {i} starts segment {label!r}")
                last = label
        self._waypoints = first + len(report.waypoint_times)
        rec.set_time("sim_time", rec.sim_clock(report.final_state.time))
        rec.log_text(
            "motion: "
            + ("passed" if report.passed else "FAILED")
            + (f" ({'; '.join(report.failures)})" if report.failures else ""),
            level="INFO" if report.passed else "ERROR",
        )
        return report


_BALANCE_SERIES = (
    ("margin", style.MARGIN, "CoM margin [m]"),
    ("contacts", style.CONTACT, "contacts"),
    ("feasible", style.FEASIBLE, "equilibrium (1 = yes)"),
)
"""The static check's series: name under ``balance/``, colour, legend label
(the contact count and the equilibrium flag share a plot, so they get colours
apart rather than rerun's hashed ones, which drew both purple)."""

#: The walking series: (plot group, name, colour, legend), the colours those of
#: the 3D overlays.
_WALK_SERIES = [
    (axis, name, color, f"{label} {axis} [m]")
    for axis in "xy"
    for name, color, label in (
        ("zmp_reference", style.ZMP_REFERENCE, "ZMP reference"),
        ("zmp_inverse_dynamics", style.ZMP_INVERSE_DYNAMICS, "ZMP of the inverse dynamics"),
        ("zmp_measured", style.ZMP, "ZMP measured in physics"),
        ("zmp_force_sensors", style.ZMP_FORCE_SENSORS, "ZMP from the feet's force sensors"),
        ("com", style.COM, "CoM"),
    )
] + [
    ("margin", "zmp_inverse_dynamics", style.ZMP_INVERSE_DYNAMICS, "ZMP of the inverse dynamics"),
    ("margin", "zmp_measured", style.ZMP, "ZMP measured in physics"),
    (
        "margin",
        "zmp_force_sensors",
        style.ZMP_FORCE_SENSORS,
        "ZMP from the force sensors, to the feet carrying it",
    ),
]


def log_walk(recorder: Recorder, pattern: Any, report: Any) -> None:
    """Log a walking pattern and its playback in physics on ``sim_time``.

    ``pattern`` is a :class:`~pik_mj.walking.wholebody.WalkPattern`, ``report``
    the :class:`~pik_mj.walking.playback.PlaybackReport` of playing it (its
    samples are at ``report.t``, the pattern's ticks ``pattern.t`` first). Logged:

    * the footstep plan, static: each sole's outline at its planned pose, the
      initial stance first (:attr:`EntityPaths.footsteps`);
    * per tick of the pattern: the ZMP reference and the ZMP of its inverse
      dynamics as points (``world/zmp/reference|inverse_dynamics``), the
      planned support polygon when it changes, the planned CoM (the CoM
      target), and the series ``walk/x|y/zmp_reference``,
      ``walk/x|y/zmp_inverse_dynamics``, ``walk/margin/zmp_inverse_dynamics``
      (signed distance to the support polygon, positive inside [m]);
    * per sample of the playback: the ZMP of the floor contact forces
      (``world/zmp``, series ``walk/x|y/zmp_measured`` and, during the
      pattern, ``walk/margin/zmp_measured``) and the CoM (``world/com`` with
      its ground projection, series ``walk/x|y/com``);
    * a line of text with the outcome.

    Ground overlays are drawn :attr:`Recorder.lift` above the plan's ground
    plane.
    """
    from pik_mj.balance import convex_hull_2d
    from pik_mj.walking.gait import DOUBLE_SUPPORT
    from pik_mj.walking.wholebody import sole_corners, support_margin

    rec, paths, plan = recorder, recorder.paths, pattern.plan
    z = float(plan.ground_z) + rec.lift
    limbs = plan.params.all_limbs
    steps = [*plan.initial_feet.values(), *plan.footsteps]
    outlines = [sole_corners(f.p_W, f.yaw, pattern.sole_size) for f in steps]
    rec._log_static(
        paths.footsteps,
        rr.LineStrips3D(
            [np.column_stack([np.vstack([c, c[:1]]), np.full(5, z)]) for c in outlines],
            colors=[style.FOOTSTEP],
            radii=[style.OUTLINE_RADIUS / 2],
        ),
    )
    for group, name, color, label in _WALK_SERIES:
        rec.log_series_style(paths.walk_series(group, name), color, label)
    K, N = len(pattern.t), len(report.t)
    measured = np.asarray(report.zmp, dtype=float)
    seen = np.all(np.isfinite(measured), axis=1)
    during = np.where(seen[:K, None], measured[:K], 0.0)
    if len(during) < K:  # the playback stopped early (a fall)
        during = np.vstack([during, np.zeros((K - len(during), 2))])
    margin_measured = support_margin(plan, during, pattern.sole_size)
    margin_id = support_margin(plan, pattern.zmp_computed, pattern.sole_size)
    sensed = np.asarray(getattr(report, "zmp_force_sensors", np.zeros((0, 2))), dtype=float)
    rec.disable_timeline("iteration")
    last_polygon: Any = None
    for k in range(N):
        rec.set_time("sim_time", float(report.t[k]))
        if k < K:
            support = limbs if plan.support[k] == DOUBLE_SUPPORT else (plan.support[k],)
            key = tuple((lb, *plan.feet_p[lb][k][:2], plan.feet_yaw[lb][k]) for lb in support)
            if key != last_polygon:
                corners = np.vstack(
                    [
                        sole_corners(plan.feet_p[lb][k], plan.feet_yaw[lb][k], pattern.sole_size)
                        for lb in support
                    ]
                )
                hull = convex_hull_2d(corners)
                rec.log_polygon(np.column_stack([hull, np.full(len(hull), z)]), lift=0.0)
                last_polygon = key
            for name, p_xy, color in (
                ("reference", pattern.zmp_ref[k], style.ZMP_REFERENCE),
                ("inverse_dynamics", pattern.zmp_computed[k], style.ZMP_INVERSE_DYNAMICS),
            ):
                rec.log_point(
                    f"{paths.zmp}/{name}",
                    [p_xy[0], p_xy[1], z],
                    radius=style.ZMP_RADIUS * 0.8,
                    color=color,
                )
                for axis, v in zip("xy", p_xy, strict=True):
                    rec.log_scalar(paths.walk_series(axis, f"zmp_{name}"), v)
            rec.log_scalar(paths.walk_series("margin", "zmp_inverse_dynamics"), margin_id[k])
            if seen[k]:
                rec.log_scalar(paths.walk_series("margin", "zmp_measured"), margin_measured[k])
            rec.log_com(report.com[k], target=pattern.com_ref[k])
        else:
            rec.log_com(report.com[k])
        for axis, v in zip("xy", report.com[k][:2], strict=True):
            rec.log_scalar(paths.walk_series(axis, "com"), v)
        if seen[k]:
            p = measured[k]
            rec.log_point(paths.zmp, [p[0], p[1], z], radius=style.ZMP_RADIUS, color=style.ZMP)
            for axis, v in zip("xy", p, strict=True):
                rec.log_scalar(paths.walk_series(axis, "zmp_measured"), v)
        if k < len(sensed) and np.all(np.isfinite(sensed[k])):
            p = sensed[k]
            rec.log_point(
                f"{paths.zmp}/force_sensors",
                [p[0], p[1], z],
                radius=style.ZMP_RADIUS * 0.6,
                color=style.ZMP_FORCE_SENSORS,
            )
            for axis, v in zip("xy", p, strict=True):
                rec.log_scalar(paths.walk_series(axis, "zmp_force_sensors"), v)
            rec.log_scalar(
                paths.walk_series("margin", "zmp_force_sensors"),
                float(report.zmp_force_sensors_margin[k]),
            )
    rec.log_text(
        f"walk: {len(plan.footsteps)} footsteps over {pattern.duration:.2f} s; ZMP of the "
        f"inverse dynamics at least {margin_id.min() * 1e3:.1f} mm inside the support polygon; "
        f"in physics: {'FELL' if report.fell else 'no fall'}, ends "
        f"{report.final_midfeet_error * 1e3:.1f} mm from the plan",
        level="WARN" if report.fell else "INFO",
    )
