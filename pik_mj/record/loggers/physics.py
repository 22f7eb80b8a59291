"""The loggers of physics runs on ``sim_time`` [s]: a hold (a ``scene.hold``
callback) and a motion (a ``scene.play`` callback), and the robot's sensors.

    report = scene.hold(result.q, callback=recorder.hold_logger())
    log = recorder.motion_logger(cameras=robot.cameras)
    log.finish(scene.play(path, callback=log))

A physics run restarts nothing on the recording: it is placed after the runs
logged before it (:meth:`Recorder.sim_clock <pik_mj.record.recorder.Recorder.sim_clock>`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, RenderingUnavailable
from pik_mj.record.loggers.surface import RecorderSurface
from pik_mj.robot.camera import Camera, CameraRenderer
from pik_mj.robot.sensors import RobotSensors
from pik_mj.sim import HoldReport, HoldSample, MotionReport

__all__ = ["HoldLogger", "MotionLogger", "check_every", "log_sensors"]


def check_every(every: int) -> int:
    """``every`` (steps between logged samples) as an int, or raise
    :class:`~pik_mj.exceptions.InvalidInput` unless it is an integer >= 1."""
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise InvalidInput(f"every must be an integer >= 1, got {every!r}")
    return int(every)


class HoldLogger:
    """Logs a physics hold on ``sim_time`` (a ``scene.hold`` callback).

    Made by :meth:`Recorder.hold_logger`. It logs the run sampled at every
    ``every``-th step (the viewer's rate), and says so to the simulation: its
    :data:`~pik_mj.callbacks.CALL_EVERY` is ``every``, so a hold or a motion
    given no ``every`` calls it at those steps only and steps in C between
    them (with a callback that needs every step beside it, every step is a
    call, the slow path, and the logger still logs every ``every``-th step).
    The sample of a step (the first one, step 0, included) logs, from the
    :class:`~pik_mj.sim.HoldSample`: the body poses, the CoM,
    the support polygon, the contact points and forces on the robot, and the
    series ``hold/drift``, ``hold/slip``, ``hold/margin`` [m] and
    ``hold/contact_force_z`` (total vertical contact force [N]). The first call
    stops stamping rows with ``iteration`` and, when the sample's model is not
    the one logged, logs its geometry (the scene's floor, held objects).
    :meth:`finish` logs the last sample if it was skipped, and the verdict.
    """

    def __init__(self, recorder: RecorderSurface, every: int = 10) -> None:
        self.every = check_every(every)
        self.call_every = self.every  # CALL_EVERY: the steps apart it needs its calls
        self.recorder = recorder
        self.calls = 0
        self._skipped: HoldSample | None = None

    def __call__(self, sample: HoldSample) -> None:
        if self._starts(sample):
            self._begin(sample)
        self.calls += 1
        if sample.step % self.every:
            self._skipped = sample
            return
        self._skipped = None
        self._log(sample)

    def _starts(self, sample: HoldSample) -> bool:
        """The first sample starts the hold."""
        return self.calls == 0

    def _begin(self, sample: HoldSample) -> None:
        self.recorder.begin_sim(sample.model, sample.data, float(sample.time))
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

    def finish(self, report: HoldReport | None = None) -> HoldReport | None:
        """Log the last sample if it was skipped and, given the hold's report
        (``.passed``, ``.failures``), its verdict; returns ``report``."""
        if self._skipped is not None:
            self._log(self._skipped)
            self._skipped = None
        if report is not None:
            failures: Sequence[str] = report.failures
            self.recorder.log_text(
                "physics hold: "
                + ("passed" if report.passed else "FAILED")
                + (f" ({'; '.join(failures)})" if failures else ""),
                level="INFO" if report.passed else "ERROR",
            )
        return report


def log_sensors(
    recorder: RecorderSurface,
    sensors: RobotSensors,
    model: mujoco.MjModel,
    data: mujoco.MjData,
) -> None:
    """Log the readings of :class:`pik_mj.robot.sensors.RobotSensors` in ``data`` at
    the current time (MuJoCo's ``sensordata``: computed in the last
    ``mj_step``/``mj_forward``):

    * each force sensor's contact force ``|f|`` [N] (the wrench the environment
      applies behind it, its distal part's weight compensated:
      :meth:`~pik_mj.robot.sensors.ForceSensor.contact_wrench`) at
      ``sensors/force/<site>``;
    * each bumper's touch force [N] at ``sensors/touch/<site>`` and its state
      (1 = on, the irteus manual's reading) at ``sensors/bumper/<site>``;
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

    Made by :meth:`Recorder.motion_logger`. Every ``every``-th step (called
    then only, as a :class:`HoldLogger`) it logs what a :class:`HoldLogger`
    logs (body poses, CoM, support polygon, contacts), and:

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
        recorder: RecorderSurface,
        every: int = 10,
        *,
        reference: bool = True,
        sensors: bool = True,
        cameras: Sequence[Camera] = (),
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
        self._model: mujoco.MjModel | None = None
        self._sensors: RobotSensors | None = None
        self._renderer: CameraRenderer | None = None
        self._no_rendering: str | None = None
        self._next_image = -math.inf
        self._waypoints = 0  # waypoints of the parts finished so far

    def _starts(self, sample: HoldSample) -> bool:
        """A sample of another model than the last starts a run (a new scene)."""
        return sample.model is not self._model

    def _begin(self, sample: HoldSample) -> None:
        rec = self.recorder
        rec.begin_sim(sample.model, sample.data, float(sample.time))
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

    def _render(self, sample: HoldSample, camera: Camera) -> np.ndarray | None:
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

    def finish(self, report: MotionReport | None = None) -> MotionReport | None:
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
