"""The :class:`Recorder`: logs pik_mj data to an explicit rerun recording stream.

What it writes, and why it is shaped so:

* Model geometry is logged once, static, one entity per primitive kind with one
  instance per geom (:mod:`pik_mj.record.geometry`); the bodies' frames are one
  entity with one instance per body. rerun's cost per file (building chunks,
  the RRD footer) grows with the number of entities, not with their size.
* Per-iteration data (body poses, frames, points, scalars) is buffered densely,
  one buffer per set of entities logged together, and sent as one chunk per
  entity (:mod:`pik_mj.record.columns`). The geoms' poses are computed then, for
  all rows at once, from the buffered body poses.
* Everything else (polygons, contacts, text) is logged directly.

Every entity path is built by :class:`~pik_mj.record.paths.EntityPaths`
(:data:`~pik_mj.record.paths.PATHS`); quaternions are MuJoCo's (w, x, y, z)
everywhere in pik_mj and are converted to rerun's (x, y, z, w) only in
:mod:`pik_mj.record.columns`.

Typical use::

    with Recorder.to_file("run.rrd") as rec:
        rec.log_model_geometry(model, robot_root_body="torso")
        for k in range(n_iter):
            rec.log_body_poses(data, timeline="iteration", time=k)
            rec.log_com(data.subtree_com[1], target=p_WC_target)
            rec.log_task_errors({(1, "com"): e_com, (2, "posture"): e_post})
    # leaving the block sends the blueprint and closes the file

The per-iteration loggers of a solve and of a physics hold are
:meth:`Recorder.solve_logger` and :meth:`Recorder.hold_logger`
(:mod:`pik_mj.record.loggers`).
"""

from __future__ import annotations

import dataclasses
import math
import time
import uuid
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import rerun as rr
import rerun.blueprint as rrb

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.record import geometry, style
from pik_mj.record.blueprint import Framing, blueprint, blueprint_for, send_blueprint_for
from pik_mj.record.columns import (
    ARROW,
    BODY_FRAME,
    INSTANCE_POSES,
    POINT,
    SCALAR,
    TRANSFORM,
    Block,
    Outbox,
    RowKind,
    pose_batches_of,
)
from pik_mj.record.geometry import BodyFrames, InstancePoses
from pik_mj.record.loggers import HoldLogger, MotionLogger, SolveLogger, log_walk
from pik_mj.record.paths import PATHS, TIMELINES, EntityPaths

__all__ = ["Recorder"]

_TEXT_LEVELS = ("TRACE", "DEBUG", "INFO", "WARN", "ERROR", "CRITICAL")


def _vec(
    value: npt.ArrayLike, shape: tuple[int, ...], what: str, path: str | None = None
) -> np.ndarray:
    """``value`` as a finite float array of ``shape`` (-1 = any length), or raise.

    The error names ``what`` and, if given, the entity ``path`` (formatted only
    on failure: this check runs several times per logged iteration).
    """
    a = np.asarray(value, dtype=float)
    if a.shape != shape and (
        a.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, a.shape, strict=True))
    ):
        want = "(" + ", ".join("n" if s == -1 else str(s) for s in shape) + ")"
        raise InvalidInput(f"{_what(what, path)} must have shape {want}, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise InvalidInput(f"{_what(what, path)} must be finite, got {a.tolist()}")
    return a


#: The style of the CoM's point (:meth:`Recorder.log_point`).
_COM_STYLE = (style.COM_RADIUS, style.COM, None)


def _what(what: str, path: str | None) -> str:
    return what if path is None else f"{what} {path!r}"


def _check_flush_every(flush_every: int) -> None:
    if isinstance(flush_every, bool) or not isinstance(flush_every, (int, np.integer)):
        raise InvalidInput(f"flush_every must be an integer >= 1, got {flush_every!r}")
    if flush_every < 1:
        raise InvalidInput(f"flush_every must be an integer >= 1, got {flush_every}")


class Recorder:
    """Logs pik_mj data to an explicit rerun recording stream.

    Per-iteration data (body poses, frames, points, scalars) and static data
    (geometry) are buffered; every buffer is sent, in one call, when one
    entity holds ``flush_every`` rows, when ``flush_interval`` has passed since
    the last send (a live viewer then follows the run), and on :meth:`flush` /
    :meth:`send_buffered` / :meth:`close` / leaving the ``with`` block (also when
    the block raised). ``flush_every=1`` logs each row at once (~60 us per
    entity per row instead of ~1 us buffered).

    Time is set with :meth:`set_time` (or by :meth:`log_body_poses`); set it
    through the Recorder, not on the stream, so buffered rows carry it.

    :meth:`close` sends one blueprint laid out for everything that was logged
    (:func:`pik_mj.record.blueprint.blueprint_for`), then closes the stream.

    Args:
        stream: The recording stream to log to, passed explicitly (the
            Recorder never logs to rerun's global stream on its own), e.g. the
            one ``rr.script_setup`` returns (``--save``, ``--connect``,
            ``--spawn``, ``--serve``).
        flush_every: Rows buffered per entity before they are sent (>= 1).
        flush_interval: Longest time [s] rows stay buffered, or None (sent by
            count and on :meth:`flush` only, the default of :meth:`to_file`).
        owns_stream: Whether :meth:`close` disconnects ``stream`` (finalizing its
            file sinks). A stream you pass in is only flushed by default.
        paths: Entity-path table.

    Attributes:
        robot_root_body: Name of the robot's root body given to
            :meth:`log_model_geometry` (None: every body is the robot's).
    """

    def __init__(
        self,
        stream: rr.RecordingStream,
        *,
        flush_every: int = 256,
        flush_interval: float | None = 0.2,
        owns_stream: bool = False,
        paths: EntityPaths = PATHS,
    ):
        if not isinstance(stream, rr.RecordingStream):
            raise InvalidInput(
                f"stream must be a rerun.RecordingStream, got {type(stream).__name__}"
            )
        _check_flush_every(flush_every)
        if flush_interval is not None and not (
            math.isfinite(flush_interval) and flush_interval > 0
        ):
            raise InvalidInput(f"flush_interval must be > 0 [s] or None, got {flush_interval}")
        self.stream = stream
        self.paths = paths
        self.flush_every = int(flush_every)
        self.flush_interval = flush_interval
        self._next_send = -math.inf
        self.owns_stream = owns_stream
        self.closed = False
        # Current time: timeline -> value, and its kind (fixed once used).
        self._time: dict[str, float] = {}
        self._kinds: dict[str, str] = dict(TIMELINES)
        self._time_key: tuple[tuple[str, ...], tuple[str, ...]] = ((), ())
        self._time_vals: tuple[float, ...] = ()
        self._stream_time_dirty = False
        # (entity paths, timelines, style) -> their buffered rows
        self._blocks: dict[tuple[Any, ...], Block] = {}
        self._outbox = Outbox()
        # (task keys, solve label) -> (their error paths, then the log10 ones;
        # which are solved)
        self._error_paths: dict[tuple[Any, ...], tuple[tuple[str, ...], Any]] = {}
        # level -> (solve, task) -> its series' colour (style.SERIES, in order)
        self._series_colors: dict[int, dict[tuple[str | None, str], tuple[int, int, int]]] = {}
        # What was logged: entity path -> timelines of its rows (the blueprint's input)
        self._logged: dict[str, set[str]] = {}
        # Solves: the last tick of the iteration timeline, and the fixed targets
        # logged (path -> the target object, or the value of the CoM target)
        self._tick = 0
        self._logged_targets: dict[str, object] = {}
        # Filled by log_model_geometry.
        self._model: mujoco.MjModel | None = None
        self.robot_root_body: str | None = None
        self.measures: geometry.Measures | None = None
        # What the camera of each timeline frames: timeline -> (low, high) corners
        # of the robot's body positions [m], and the robot's heading [rad]
        self._extent: dict[str, tuple[np.ndarray, np.ndarray, float]] = {}
        # The last pose of each task's target (task -> (p, q_wxyz)), shown again
        # when a hold starts
        self._targets: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._frames: dict[tuple[str, ...], BodyFrames] = {}  # by (path,)
        self.skipped_geoms: list[str] = []
        # Physics runs on sim_time: the latest time logged, and the offset that
        # puts a run which restarts its clock (a hold after a motion) after it
        self._sim_end = 0.0
        self._sim_offset = 0.0
        self._reference_model: mujoco.MjModel | None = None

    @classmethod
    def to_file(
        cls,
        path: str | Path,
        application_id: str = "pik_mj",
        *,
        recording_id: str | None = None,
        flush_every: int = 256,
    ) -> Recorder:
        """A Recorder on a new stream that saves to the ``.rrd`` file ``path``.

        The Recorder owns the stream: :meth:`close` (or leaving the ``with`` block)
        flushes and disconnects it, which writes the file's footer.
        """
        _check_flush_every(flush_every)
        path = inputs.output_path(path, "recording")  # a file path that can be written
        if not path.parent.is_dir():
            raise InvalidInput(f"directory of the recording {str(path)!r} does not exist")
        stream = rr.RecordingStream(application_id, recording_id=recording_id or uuid.uuid4().hex)
        stream.save(path)
        return cls(stream, flush_every=flush_every, flush_interval=None, owns_stream=True)

    @property
    def model(self) -> mujoco.MjModel | None:
        """The model whose geometry was logged last (:meth:`log_model_geometry`)."""
        return self._model

    # -- loggers ----------------------------------------------------------------

    def solve_logger(self, label: str, checks: Any = None, *, start: Any = None) -> SolveLogger:
        """A callback for ``pik_mj.solve(..., callback=...)`` that logs solve
        ``label`` iteration by iteration; call its ``finish(result)`` after the
        solve. See :class:`~pik_mj.record.loggers.SolveLogger`.

        Args:
            label: Name of the solve (text log).
            checks: The scene's per-iteration static checker (an object with a
                ``.reports`` list), placed BEFORE this logger in the callbacks:
                its last report is logged each iteration.
            start: The robot (or its ``mink.Configuration`` / ``MjData``) in
                the start pose, logged at the solve's first tick.
        """
        return SolveLogger(self, label, checks, start=start)

    def hold_logger(self, every: int = 10) -> HoldLogger:
        """A callback for ``scene.hold(..., callback=...)`` that logs every
        ``every``-th sample on ``sim_time``. See
        :class:`~pik_mj.record.loggers.HoldLogger`."""
        return HoldLogger(self, every)

    def motion_logger(
        self,
        every: int = 10,
        *,
        reference: bool = True,
        sensors: bool = True,
        cameras: Sequence[Any] = (),
        image_every: float | None = 0.5,
    ) -> MotionLogger:
        """A callback for ``scene.play(..., callback=...)`` that logs every
        ``every``-th sample on ``sim_time``: the physical robot, the IK
        reference beside it (``reference``), the tracking series, the sensors
        (``sensors``), the ``cameras`` (:class:`pik_mj.robot.camera.Camera`) as
        pinholes with an image every ``image_every`` seconds where MuJoCo can
        render; its ``finish(report)`` logs the waypoints' times. See
        :class:`~pik_mj.record.loggers.MotionLogger`."""
        return MotionLogger(
            self,
            every,
            reference=reference,
            sensors=sensors,
            cameras=cameras,
            image_every=image_every,
        )

    def _begin_solve(self) -> int:
        """Start a solve at the current tick of ``iteration`` (a hold's
        ``sim_time`` no longer stamps rows); returns the tick."""
        self.disable_timeline("sim_time")
        self.set_time("iteration", self._tick)
        return self._tick

    def _next_tick(self) -> int:
        """The next tick of the ``iteration`` timeline (counted over all solves)."""
        self._tick += 1
        return self._tick

    def _begin_sim(self, model: mujoco.MjModel, data: mujoco.MjData, time: float) -> None:
        """Start a physics run (a hold, a motion) whose physics clock reads
        ``time``: rows are on ``sim_time`` only, a run that restarts its clock
        is placed after what was logged on it (:meth:`sim_clock`); the geometry
        of the scene's ``model`` is logged when it is not the model logged; the
        last targets of the solves are shown again."""
        self.disable_timeline("iteration")
        if self._sim_offset + time < self._sim_end - 1e-9:
            self._sim_offset = self._sim_end - time
        if model is not self._model:
            self.log_model_geometry(model, data, robot_root_body=self.robot_root_body)
        self.set_time("sim_time", self.sim_clock(time))
        # the solves' current task frames do not follow the physics
        self.hide_frames(
            [
                p
                for p in self._logged
                if p.startswith(f"{self.paths.tasks}/") and p.endswith("/current")
            ]
        )
        for label, (p, q) in self._targets.items():
            self.log_target(label, p, q)
        com_target = self._logged_targets.get(self.paths.com_target)
        if isinstance(com_target, np.ndarray):
            self.log_com_target(com_target)

    def sim_clock(self, time: float) -> float:
        """The ``sim_time`` [s] at which a physics run logs its clock's ``time``:
        ``time`` plus the offset that puts a run which restarted its clock
        after the runs logged before it (a hold after a motion)."""
        t = self._sim_offset + float(time)
        self._sim_end = max(self._sim_end, t)
        return t

    def log_reference_geometry(self, model: mujoco.MjModel) -> None:
        """Log the robot's geoms of ``model`` a second time, static, at
        :attr:`EntityPaths.reference`, translucent (:data:`style.REFERENCE`):
        the reference pose of a motion, posed by :meth:`log_reference_poses`.
        Call it after the model's own geometry (:meth:`log_model_geometry`)."""
        self._check_open()
        if self._model is None or self.robot_root_body is None:
            raise PikError("log the model's geometry (with its robot_root_body) first")
        root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, self.robot_root_body)
        robot = geometry.subtree(model, root)
        base = self.paths.reference
        names = geometry.unique_names(model, "geom")
        groups, _ = geometry.geom_groups(
            model,
            names,
            robot=robot,
            moving=robot,
            groups={0, 1, 2},
            plane_half_size=1.0,
            entity_path=lambda kind, robot, moving: f"{base}/{kind}",
            color=style.REFERENCE,
            only=robot,
        )
        ids = np.flatnonzero(robot)
        path = f"{base}/bodies"
        # the body frames are drawn as the robot's are (an Ellipsoids3D needs its sizes)
        body_names = geometry.unique_names(model, "body")
        self._log_static(path, geometry.body_markers([body_names[b] for b in ids]))
        for group in groups:
            self._log_static(group.path, group.shape)
        self._frames[(path,)] = BodyFrames(path, ids, groups, InstancePoses(model, groups, ids))
        self._reference_model = model

    def log_reference_poses(self, data: mujoco.MjData) -> None:
        """Log the body poses of the reference robot (``data``: its kinematics)
        at the current time; its geoms follow (:meth:`log_reference_geometry`)."""
        frames = self._frames.get((f"{self.paths.reference}/bodies",))
        if frames is None:
            raise PikError("call log_reference_geometry(model) before log_reference_poses")
        poses = np.empty((len(frames.ids), 7))
        poses[:, :3] = data.xpos[frames.ids]
        poses[:, 3:] = data.xquat[frames.ids]
        self._append((frames.path,), poses, BODY_FRAME)
        if self.flush_every == 1:
            for group, instances in frames.geometry(poses[None]):
                self._append((group.path,), instances[0], INSTANCE_POSES[group.archetype])

    def log_camera(self, camera: Any, data: mujoco.MjData, image: np.ndarray | None = None) -> str:
        """Log ``camera`` (:class:`pik_mj.robot.camera.Camera`) as a pinhole at its pose
        in ``data`` (kinematics and ``mj_camlight`` current) at the current
        time, with ``image`` (RGB uint8) if given (:func:`pik_mj.robot.camera.log_camera`).
        Returns the pinhole's path."""
        from pik_mj.robot.camera import log_camera

        self._check_open()
        self._sync_stream_time()
        path = self.paths.camera(camera.name)
        for p in (path, f"{path}/image"):
            self._logged.setdefault(p, set()).update(self._time)
        return log_camera(self.stream, camera, data, path=path, image=image)

    def hide_frames(self, paths: Iterable[str]) -> None:
        """Draw no axes for the frames ``paths`` from the current time on (a
        frame without a pose at the current time is drawn at the origin)."""
        for path in paths:
            self._log(path, rr.TransformAxes3D(axis_length=0.0))

    def log_walk(self, pattern: Any, report: Any) -> None:
        """Log a walking pattern and its playback in physics on ``sim_time``:
        footsteps, ZMPs (reference, inverse dynamics, measured), CoM, support
        polygon, margins. See :func:`~pik_mj.record.loggers.log_walk`."""
        log_walk(self, pattern, report)

    def log_target(self, task: str, p: npt.ArrayLike, quat_wxyz: npt.ArrayLike) -> None:
        """Log the target of ``task``: its frame (``world/tasks/<task>/target``,
        position [m], MuJoCo quaternion) and, on the same entity (one chunk), a
        marker labelled with the task's name at the frame's origin."""
        path = self.paths.task_target(task)
        self.log_frame(path, p, quat_wxyz)
        self.log_point(
            path, np.zeros(3), radius=style.TARGET_RADIUS, color=style.TARGET, label=str(task)
        )
        self._targets[str(task)] = (np.array(p, dtype=float), np.array(quat_wxyz, dtype=float))

    # -- lifetime ---------------------------------------------------------------

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc is not None and not self.closed:
            try:
                self.log_text(f"run raised {type(exc).__name__}: {exc}", level="ERROR")
            finally:
                self.close()
            return
        self.close()

    def flush(self) -> None:
        """Send every buffered row and wait until the stream has written them."""
        self._send_buffers()
        self.stream.flush()

    def send_buffered(self) -> None:
        """Send every buffered row without waiting: the stream encodes and writes
        them on its own threads while the caller goes on (e.g. builds the
        blueprint before :meth:`close`)."""
        self._check_open()
        self._send_buffers()
        self.stream.flush(timeout_sec=0.0)  # start the pipeline, do not wait

    def close(self, *, blueprint: bool = True) -> None:
        """Send the buffered rows and (with ``blueprint``) one blueprint laid out
        for everything logged; disconnect the stream if this Recorder owns it
        (which flushes it and finalizes its file), else flush it. The stream is
        closed also when sending fails. Idempotent."""
        if self.closed:
            return
        try:
            self._send_buffers()
            # the stream writes the rows on its threads while the blueprint is built
            self.stream.flush(timeout_sec=0.0)
            if blueprint:
                send_blueprint_for(self.stream, self._logged, self.paths, framing=self._framing())
            if not self.owns_stream:
                self.stream.flush()
        finally:
            self.closed = True
            if self.owns_stream:
                self.stream.disconnect()

    def logged(self) -> dict[str, set[str]]:
        """Every entity path logged so far (static data left out) -> the
        timelines its rows carry."""
        return {path: set(timelines) for path, timelines in self._logged.items()}

    def blueprint(self) -> rrb.Blueprint:
        """The blueprint of what was logged so far (what :meth:`close` sends):
        :func:`~pik_mj.record.blueprint.blueprint_for`, each 3D view framed on
        the robot's body positions seen on its timeline."""
        return blueprint_for(self._logged, self.paths, framing=self._framing())

    def _framing(self) -> dict[str, Framing]:
        """What each timeline's 3D view frames: the robot's body positions seen on it."""
        m = self.measures
        height, ground = (1.0, None) if m is None else (m.height, m.ground_z)
        return {
            timeline: Framing(low, high, heading, height, ground)
            for timeline, (low, high, heading) in self._extent.items()
        }

    def _send_buffers(self) -> None:
        """Send every buffered row of every entity, and pending static data, in
        one call."""
        for block in self._blocks.values():
            block.drain(self._outbox, self._frames.get(block.paths))
        self._outbox.send(self.stream)
        if self.flush_interval is not None:
            self._next_send = time.monotonic() + self.flush_interval

    def _check_open(self) -> None:
        if self.closed:
            raise PikError("the Recorder is closed; create a new one to log more")

    # -- time -------------------------------------------------------------------

    def set_time(self, timeline: str, value: float, *, kind: str | None = None) -> None:
        """Set the current time of ``timeline`` for every following log call.

        Args:
            timeline: Timeline name: ``iteration`` (sequence) or ``sim_time``
                (duration, value in [s]), or any other with an explicit ``kind``.
            value: Iteration number, or time in [s].
            kind: ``"sequence"`` or ``"duration"``; fixed once a timeline is used.
        """
        if kind is None and isinstance(value, (int, float)) and self._time.get(timeline) == value:
            return  # the current time (checked when it was set)
        known = self._kinds.get(timeline)
        if kind is None:
            if known is None:
                raise UnknownName("timeline", timeline, self._kinds)
            kind = known
        elif kind not in ("sequence", "duration"):
            raise InvalidInput(f"timeline kind must be 'sequence' or 'duration', got {kind!r}")
        elif known is not None and known != kind:
            raise InvalidInput(f"timeline {timeline!r} is a {known} timeline, not {kind}")
        if kind == "sequence":
            if isinstance(value, float) and not value.is_integer():
                raise InvalidInput(f"{timeline} must be an integer, got {value}")
            value = int(value)
        else:
            value = float(value)
            if not math.isfinite(value):
                raise InvalidInput(f"{timeline} must be finite [s], got {value}")
        self._kinds[timeline] = kind
        if timeline not in self._time:
            self._time[timeline] = value
            names = tuple(sorted(self._time))
            self._time_key = (names, tuple(self._kinds[n] for n in names))
        self._time[timeline] = value
        self._time_vals = tuple(self._time[n] for n in self._time_key[0])
        self._stream_time_dirty = True

    def disable_timeline(self, timeline: str) -> None:
        """Stop stamping following rows with ``timeline`` (e.g. after the solve)."""
        if timeline in self._time:
            del self._time[timeline]
            names = tuple(sorted(self._time))
            self._time_key = (names, tuple(self._kinds[n] for n in names))
            self._time_vals = tuple(self._time[n] for n in names)
            self.stream.disable_timeline(timeline)

    def _sync_stream_time(self) -> None:
        """Mirror the current time onto the stream before a direct ``log``."""
        if self._stream_time_dirty:
            for name, value in self._time.items():
                if self._kinds[name] == "sequence":
                    self.stream.set_time(name, sequence=int(value))
                else:
                    self.stream.set_time(name, duration=float(value))
            self._stream_time_dirty = False

    def _log(self, path: str, *archetypes: Any, static: bool = False) -> None:
        self._check_open()
        if not static:
            self._sync_stream_time()
            self._logged.setdefault(path, set()).update(self._time)
        self.stream.log(path, *archetypes, static=static, strict=True)

    def _log_static(self, path: str, *archetypes: Any) -> None:
        """Static data of ``path``: sent with the buffered rows (at once when
        unbuffered, ``flush_every=1``)."""
        self._check_open()
        if self.flush_every == 1:
            self._log(path, *archetypes, static=True)
        else:
            self._outbox.add_static(path, *archetypes)

    def log_series_style(self, path: str, color: tuple[int, ...], name: str) -> None:
        """A plotted series' line colour (RGB) and legend name, static."""
        self._log_static(path, rr.SeriesLines(colors=[color], names=[name]))

    def _append(
        self,
        paths: tuple[str, ...],
        rows: np.ndarray,
        kind: RowKind,
        style: tuple[Any, ...] = (),
    ) -> None:
        """Buffer one row of each entity of ``paths`` (``rows``: entities x
        [instances x] ``kind.width``, checked by the caller) with ``style`` at the
        current time; log them at once if unbuffered."""
        self._check_open()
        rows = rows.reshape(len(paths), -1, kind.width)
        if self.flush_every == 1:
            for path, row in zip(paths, rows, strict=True):
                self._log(path, kind.archetype(row, style))
            return
        names, kinds = self._time_key
        if not names:
            raise PikError(
                f"no time is set for {paths[0]!r}; call set_time (e.g. "
                "set_time('iteration', k)) before logging per-iteration data"
            )
        key = (paths, names, style, rows.shape[1])
        block = self._blocks.get(key)
        if block is None:
            block = self._blocks[key] = Block(
                paths, kind, style, names, kinds, self.flush_every, rows.shape[1]
            )
            for path in paths:
                self._logged.setdefault(path, set()).update(names)
        if block.append(self._time_vals, rows) or (
            self.flush_interval is not None and time.monotonic() >= self._next_send
        ):
            self._send_buffers()

    # -- geometry -------------------------------------------------------------

    def log_model_geometry(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData | None = None,
        *,
        robot_root_body: str | None = None,
        geom_groups: Iterable[int] = (0, 1, 2),
        plane_half_size: float | None = None,
    ) -> None:
        """Log every visible geom of ``model`` once, static, grouped by kind.

        Bodies in the subtree of ``robot_root_body`` are the robot, the others
        scene; with no root given, every body but the world body is robot. The
        geoms of one primitive kind share an entity (:meth:`EntityPaths.geoms`),
        one instance per geom labelled with its name: the robot's, the scene's
        welded to the world (static poses, from ``data`` here), and the scene's on
        free, jointed or mocap bodies. The moving ones get their poses, and the
        body frames theirs (:meth:`EntityPaths.bodies`), from
        :meth:`log_body_poses`. See :mod:`pik_mj.record.geometry`.

        The robot's height, weight and ground (:func:`~pik_mj.record.geometry.measure`,
        :attr:`measures`) scale the camera of the blueprint and the contact force
        arrows (:meth:`log_contacts`), and place the CoM's ground projection
        (:meth:`log_com`). The height is the one of the first pose logged of the
        robot: logging the same robot in another scene (a hold's) keeps it.

        Args:
            model: The MuJoCo model.
            data: Source of the poses of welded scene bodies (must hold forward
                kinematics). Default: a fresh ``MjData`` with ``mj_kinematics``.
            robot_root_body: Name of the robot's root body, or None.
            geom_groups: Geom groups to show (MuJoCo shows 0-2 by default;
                dm_control puts collision geoms in group 3).
            plane_half_size: Half extent [m] drawn for infinite planes; default:
                the scene's extent plus half a metre, at least one metre.
        """
        self._check_open()
        groups = {int(g) for g in geom_groups}
        if not groups <= set(range(mujoco.mjNGROUP)):
            raise InvalidInput(
                f"geom_groups must be in 0..{mujoco.mjNGROUP - 1}, got {sorted(groups)}"
            )
        if plane_half_size is not None and not (
            math.isfinite(plane_half_size) and plane_half_size > 0
        ):
            raise InvalidInput(f"plane_half_size must be > 0 [m], got {plane_half_size}")
        body_names = geometry.unique_names(model, "body")
        if robot_root_body is None:
            robot = np.ones(model.nbody, dtype=bool)
            robot[0] = False
            moving = robot.copy()
        else:
            root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot_root_body)
            if root < 0:
                raise UnknownName("body", robot_root_body, body_names)
            if root == 0:
                raise InvalidInput("robot_root_body cannot be the world body")
            robot = geometry.subtree(model, root)
            moving = (np.asarray(model.body_weldid) != 0) | (np.asarray(model.body_mocapid) >= 0)
            moving |= robot
            moving[0] = False
        if data is None:
            data = mujoco.MjData(model)
            mujoco.mj_kinematics(model, data)
        elif data.xpos.shape != (model.nbody, 3):
            raise InvalidInput(
                f"data has {data.xpos.shape[0]} bodies, the logged model {model.nbody}"
            )

        # Send rows buffered for a previous model before replacing the table.
        self._send_buffers()
        measures = geometry.measure(model, data, robot)
        if self.measures is not None and robot_root_body == self.robot_root_body:
            # the same robot in another scene (a hold's): the scale of its
            # drawings stays that of its first pose logged
            measures = dataclasses.replace(measures, height=self.measures.height)
        self.measures = measures
        self.robot_root_body = robot_root_body
        if plane_half_size is None:
            plane_half_size = self.measures.floor_half_size

        self._log_static(self.paths.world, rr.ViewCoordinates.RIGHT_HAND_Z_UP)
        geom_names = geometry.unique_names(model, "geom")
        found, self.skipped_geoms = geometry.geom_groups(
            model,
            geom_names,
            robot=robot,
            moving=moving,
            groups=groups,
            plane_half_size=plane_half_size,
            entity_path=self.paths.geoms,
        )
        welded = [g for g in found if not g.moving]
        ids = np.concatenate([g.ids for g in welded]) if welded else np.zeros(0, dtype=int)
        bodies = np.unique(model.geom_bodyid[ids])
        X_WB = np.hstack([data.xpos[bodies], data.xquat[bodies]])[None]  # their poses now
        for group, poses in zip(welded, InstancePoses(model, welded, bodies)(X_WB), strict=True):
            self._log_static(group.path, group.shape, pose_batches_of(group, poses[0]))
        self._frames = {}
        for is_robot in (True, False):
            ids = np.flatnonzero(moving & (robot if is_robot else ~robot))
            if len(ids):
                path = self.paths.bodies(robot=is_robot)
                self._log_static(path, geometry.body_markers([body_names[b] for b in ids]))
                carried = [g for g in found if g.moving and g.robot == is_robot]
                for group in carried:
                    self._log_static(group.path, group.shape)
                instances = InstancePoses(model, carried, ids)
                self._frames[(path,)] = BodyFrames(path, ids, carried, instances)
        if self.skipped_geoms:
            self._log_static(
                self.paths.events,
                rr.TextLog(
                    f"geoms of unsupported type not drawn: {self.skipped_geoms}", level="WARN"
                ),
            )
        self._model = model

    def log_body_poses(
        self, data: mujoco.MjData, *, timeline: str = "iteration", time: float
    ) -> None:
        """Set ``timeline`` to ``time`` and log the poses of every moving body:
        the body frames ``X_WB`` and the instances of their geoms.

        Rows carry every timeline currently set (see :meth:`disable_timeline`).
        The body poses are MuJoCo's ``xpos``, ``xquat`` (run its kinematics
        first); the geoms' follow from them (:class:`InstancePoses`).
        """
        self._check_open()
        model = self._model
        if model is None:
            raise PikError("call log_model_geometry(model) before log_body_poses")
        if data.xpos.shape[0] != model.nbody or data.geom_xpos.shape[0] != model.ngeom:
            raise InvalidInput(
                f"data has {data.xpos.shape[0]} bodies, the logged model {model.nbody}"
            )
        self.set_time(timeline, time)
        rows = []
        for frames in self._frames.values():
            poses = np.empty((len(frames.ids), 7))
            poses[:, :3] = data.xpos[frames.ids]
            poses[:, 3:] = data.xquat[frames.ids]
            if not np.isfinite(poses).all():
                raise InvalidInput(f"body poses at {timeline}={time} are not finite")
            rows.append((frames, poses))
        self._track_extent(timeline, rows)
        # buffered, the geoms' poses follow from these rows when they are sent
        for frames, poses in rows:
            self._append((frames.path,), poses, BODY_FRAME)
            if self.flush_every == 1:
                for group, instances in frames.geometry(poses[None]):
                    self._append((group.path,), instances[0], INSTANCE_POSES[group.archetype])

    def _track_extent(self, timeline: str, rows: list[tuple[BodyFrames, np.ndarray]]) -> None:
        """Grow the box of the robot's body positions seen on ``timeline``."""
        robot = self.paths.bodies(robot=True)
        for frames, poses in rows:
            if frames.path != robot:
                continue
            p = poses[:, :3]
            seen = self._extent.get(timeline)
            if seen is None:
                w, x, y, z = poses[0, 3:]  # the root's x axis, on the ground plane
                heading = math.atan2(2 * (x * y + w * z), 1 - 2 * (y * y + z * z))
                self._extent[timeline] = (p.min(axis=0), p.max(axis=0), heading)
            else:
                low, high, heading = seen
                self._extent[timeline] = (
                    np.minimum(low, p.min(axis=0)),
                    np.maximum(high, p.max(axis=0)),
                    heading,
                )

    # -- per-iteration primitives ---------------------------------------------

    def log_point(
        self,
        path: str,
        p: npt.ArrayLike,
        *,
        radius: float = 0.02,
        color: Sequence[int] = (255, 200, 0),
        label: str | None = None,
    ) -> None:
        """Log one point ``p`` [m] at ``path`` with its ``radius`` [m], RGB(A)
        ``color`` and optional ``label`` (buffered)."""
        p = _vec(p, (3,), "point", path)
        r = float(radius)
        if not (math.isfinite(r) and r > 0):
            raise InvalidInput(f"radius of point {path!r} must be > 0 [m], got {radius}")
        style = (r, tuple(int(c) for c in color), None if label is None else str(label))
        self._append((path,), p.reshape(1, 3), POINT, style)

    def log_com(self, p_WC: npt.ArrayLike, target: npt.ArrayLike | None = None) -> None:
        """Log the centre of mass ``p_WC`` [m] and, if given, its target [m].

        For a floating-base robot its projection on the ground (``ground_z`` of
        :attr:`measures`, drawn :attr:`lift` above it) and the arrow down to it
        go to the same entity (an ``Arrows3D``: one chunk for both).
        """
        p = _vec(p_WC, (3,), "CoM", self.paths.com)
        self._append((self.paths.com,), p.reshape(1, 3), POINT, _COM_STYLE)
        ground = None if self.measures is None else self.measures.ground_z
        if ground is not None:
            foot = np.array([p[0], p[1], ground + self.lift])
            self._append(
                (self.paths.com,),
                np.concatenate([p, foot - p]).reshape(1, 6),
                ARROW,
                (style.COM_GROUND_RADIUS / 2, style.COM_GROUND),
            )
        if target is not None:
            self.log_com_target(target)

    def log_com_target(self, target: npt.ArrayLike) -> None:
        """Log the target [m] of the centre of mass (the last one is shown again
        when a hold starts)."""
        p = _vec(target, (3,), "CoM target", self.paths.com_target)
        self.log_point(
            self.paths.com_target, p, radius=style.COM_TARGET_RADIUS, color=style.COM_TARGET
        )
        self._logged_targets[self.paths.com_target] = p.copy()

    def log_polygon(
        self,
        vertices: npt.ArrayLike,
        margin_vertices: npt.ArrayLike | None = None,
        *,
        path: str | None = None,
        color: Sequence[int] = style.SUPPORT_POLYGON,
        lift: float | None = None,
    ) -> None:
        """Log a polygon outline (closed loop) and optionally its margin outline.

        Args:
            vertices: (m, 3) vertices in order around the polygon [m]; the loop
                is closed here. m = 0 clears the outline.
            margin_vertices: (k, 3) shrunk outline, logged at ``<path>/margin``.
            path: Entity path; default :attr:`EntityPaths.support_polygon`.
            color: RGB(A) of the outline.
            lift: Drawn this far [m] above ``vertices``, clear of the floor and
                the soles; default :attr:`lift`.
        """
        path = self.paths.support_polygon if path is None else path
        lift = self.lift if lift is None else float(lift)
        loops = [(path, vertices, color)]
        if margin_vertices is not None:
            loops.append((f"{path}/margin", margin_vertices, style.MARGIN))
        for p, verts, c in loops:
            v = _vec(verts, (-1, 3), "polygon vertices of", p) + np.array([0.0, 0.0, lift])
            strips = [np.vstack([v, v[:1]])] if len(v) else []
            self._log(p, rr.LineStrips3D(strips, colors=[tuple(c)], radii=[style.OUTLINE_RADIUS]))

    def log_contacts(
        self,
        points: npt.ArrayLike,
        forces: npt.ArrayLike,
        scale: float | None = None,
    ) -> None:
        """Log contact points [m] and forces [N] drawn as arrows of ``scale`` [m/N].

        .. math::
            \\text{arrow}_i = s \\, f_i

        The default :attr:`force_scale` draws the robot's weight as
        :data:`~pik_mj.record.style.FORCE_PER_WEIGHT` of its height.
        """
        p = _vec(points, (-1, 3), "contact points")
        f = _vec(forces, (len(p), 3), "contact forces")
        scale = self.force_scale if scale is None else scale
        if not (math.isfinite(scale) and scale > 0):
            raise InvalidInput(f"contact force scale must be > 0 [m/N], got {scale}")
        self._log(
            self.paths.contact_points,
            rr.Points3D(p, radii=[style.CONTACT_RADIUS], colors=[style.CONTACT]),
        )
        self._log(
            self.paths.contact_forces,
            rr.Arrows3D(origins=p, vectors=f * scale, colors=[style.CONTACT]),
        )

    @property
    def lift(self) -> float:
        """Height [m] above the ground of overlays on it (``measures.lift``:
        above the soles; :data:`~pik_mj.record.style.LIFT` before any geometry
        is logged)."""
        return style.LIFT if self.measures is None else self.measures.lift

    @property
    def force_scale(self) -> float:
        """Contact force arrows [m/N]: the robot's weight ``W`` drawn as
        :data:`~pik_mj.record.style.FORCE_PER_WEIGHT` of its height ``h``,
        ``s = F h / W`` (:data:`~pik_mj.record.style.DEFAULT_FORCE_SCALE` before
        any geometry is logged)."""
        m = self.measures
        if m is None or m.weight <= 0:
            return style.DEFAULT_FORCE_SCALE
        return style.FORCE_PER_WEIGHT * m.height / m.weight

    def log_frame(
        self,
        path: str,
        p: npt.ArrayLike,
        quat_wxyz: npt.ArrayLike,
        axis_length: float = style.FRAME_AXIS,
    ) -> None:
        """Log a frame ``X_WF`` (position [m], MuJoCo quaternion (w, x, y, z)).

        The pose is buffered with the axes' ``axis_length`` [m].
        """
        p = _vec(p, (3,), "frame position", path)
        q = _vec(quat_wxyz, (4,), "frame quaternion (w, x, y, z)", path)
        self.log_frames((path,), p.reshape(1, 3), q.reshape(1, 4), axis_length)

    def log_frames(
        self,
        paths: Sequence[str],
        positions: npt.ArrayLike,
        quats_wxyz: npt.ArrayLike,
        axis_length: float = style.FRAME_AXIS,
    ) -> None:
        """Log frames ``X_WF_i`` at ``paths[i]``: positions (n, 3) [m], MuJoCo
        quaternions (n, 4) (w, x, y, z), normalized here.

        The poses are buffered, each with the axes' ``axis_length`` [m]. Passing
        the same ``paths`` every iteration keeps them in one buffer.
        """
        paths = tuple(paths)
        n = len(paths)
        p = _vec(positions, (n, 3), "frame positions")
        q = _vec(quats_wxyz, (n, 4), "frame quaternions (w, x, y, z)")
        norms = np.sqrt(np.einsum("ij,ij->i", q, q))
        if (norms < 1e-9).any():
            raise InvalidInput(f"frame quaternion of {paths[int(np.argmin(norms))]!r} is zero")
        length = float(axis_length)
        if not (math.isfinite(length) and length > 0):
            raise InvalidInput(f"axis_length must be > 0 [m], got {axis_length}")
        poses = np.empty((n, 7))
        poses[:, :3] = p
        poses[:, 3:] = q / norms[:, None]
        self._append(paths, poses, TRANSFORM, (length,))

    def log_scalar(self, path: str, value: float) -> None:
        """Log one value of the scalar series at ``path`` (buffered)."""
        v = float(value)
        if not math.isfinite(v):
            raise InvalidInput(f"scalar {path!r} must be finite, got {value}")
        self._append((path,), np.array([[v]]), SCALAR)

    def log_task_errors(
        self, errors: Mapping[tuple[int, str], float], *, solve: str | None = None
    ) -> None:
        """Log each task's error at ``errors/level_<k>/<task>`` and, for the
        solved levels (k >= 1; level 0 holds the hard rows), its ``log10`` at
        ``errors_log10/level_<k>/<task>`` (errors below 1e-16 count as 1e-16):
        the plots' log scale.

        Args:
            errors: ``{(level, task_name): error}``; the error is whatever scalar
                the caller tracks (e.g. the squared error ``‖e‖²``). The same
                keys every iteration keep the series in one buffer.
            solve: The label of the solve these tasks belong to (what
                :meth:`solve_logger` passes): the series then go one level
                deeper, ``errors/level_<k>/<solve>/<task>``, and are named
                ``"<solve>: <task>"`` in the plots' legends, so that the solves
                of one recording (whose stacks may put the same task on
                different levels) keep apart.

        Each task's series (linear and log10) gets a colour of
        :data:`~pik_mj.record.style.SERIES`, the next one in its level's plot.
        """
        keys = tuple(errors)
        plan = self._error_paths.get((keys, solve))
        if plan is None:
            solved = np.array([level >= 1 for level, _ in keys], dtype=bool)
            named = [(level, name, False) for level, name in keys]
            named += [
                (level, name, True) for (level, name), s in zip(keys, solved, strict=True) if s
            ]
            paths = tuple(
                self.paths.task_error(level, name, log10=log10, solve=solve)
                for level, name, log10 in named
            )
            # the legends' names and colours, once per series: a task's linear
            # and log10 series alike, tasks of one level's plot apart
            for path, (level, name, _) in zip(paths, named, strict=True):
                colors = self._series_colors.setdefault(level, {})
                color = colors.setdefault(
                    (solve, name), style.SERIES[len(colors) % len(style.SERIES)]
                )
                label = name if solve is None else f"{solve}: {name}"
                self.log_series_style(path, color, label)
            plan = self._error_paths[(keys, solve)] = (paths, solved)
        paths, solved = plan
        values = np.fromiter(errors.values(), dtype=float, count=len(keys))
        if not np.isfinite(values).all():
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise InvalidInput(f"scalar {paths[bad]!r} must be finite, got {values[bad]}")
        rows = np.concatenate([values, np.log10(np.maximum(np.abs(values[solved]), 1e-16))])
        self._append(paths, rows.reshape(-1, 1), SCALAR)

    def log_text(self, message: str, level: str = "INFO") -> None:
        """Log ``message`` to the run's text log at the current time."""
        if level not in _TEXT_LEVELS:
            raise InvalidInput(f"text level must be one of {_TEXT_LEVELS}, got {level!r}")
        self._log(self.paths.events, rr.TextLog(str(message), level=level))

    def send_blueprint(
        self, levels: Iterable[int] | None = None, extra: Sequence[tuple[str, str]] = ()
    ) -> None:
        """Send a blueprint now (made active): the one of what was logged so far
        (:meth:`blueprint`), or the layout of ``levels`` and ``extra`` series
        (:func:`~pik_mj.record.blueprint.blueprint`). :meth:`close` sends the
        blueprint of everything logged after it."""
        self._check_open()
        if levels is None:
            send_blueprint_for(self.stream, self._logged, self.paths, framing=self._framing())
        else:
            self.stream.send_blueprint(blueprint(list(levels), self.paths, extra=extra))
