"""The :class:`Recorder`: logs pik_mj data to an explicit rerun recording stream.

What it writes, and why it is shaped so:

* Model geometry is logged once, static, one entity per primitive kind with one
  instance per geom (:mod:`pik_mj.record.drawing`); the bodies' frames are one
  entity with one instance per body. rerun's cost per file (building chunks,
  the RRD footer) grows with the number of entities, not with their size.
* Per-iteration data (body poses, frames, points, scalars) is buffered densely
  and sent as one chunk per entity (:mod:`pik_mj.record.stream`); the geoms'
  poses are computed then, for all rows at once, from the buffered body poses.
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

The loggers of a solve, a physics hold, a motion and a walk
(:meth:`Recorder.solve_logger`, :meth:`~Recorder.hold_logger`,
:meth:`~Recorder.motion_logger`, :meth:`~Recorder.walk_logger`) are callbacks
built on the Recorder's public methods (:mod:`pik_mj.record.loggers`).
"""

from __future__ import annotations

import dataclasses
import math
import uuid
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import rerun as rr

from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.record import geometry, style
from pik_mj.record.canvas import Canvas
from pik_mj.record.columns import ARROW, BODY_FRAME, INSTANCE_POSES, POINT, SCALAR
from pik_mj.record.drawing import (
    Drawing,
    body_poses,
    draw_model,
    draw_reference,
    robot_masks,
)
from pik_mj.record.geometry import BodyFrames
from pik_mj.record.loggers import HoldLogger, MotionLogger, SolveLogger, WalkLogger, log_walk
from pik_mj.record.paths import PATHS, EntityPaths
from pik_mj.record.sinks import SavedFiles
from pik_mj.record.stream import check_flush_every, finite_array
from pik_mj.robot.camera import Camera, log_camera
from pik_mj.walking.playback import PlaybackReport
from pik_mj.walking.wholebody import WalkPattern

__all__ = ["Recorder"]

_TEXT_LEVELS = ("TRACE", "DEBUG", "INFO", "WARN", "ERROR", "CRITICAL")

#: The style of the CoM's point (:meth:`Recorder.log_point`).
_COM_STYLE = (style.COM_RADIUS, style.COM, None)


class Recorder(Canvas):
    """Logs pik_mj data to an explicit rerun recording stream.

    Per-iteration data (body poses, frames, points, scalars) and static data
    (geometry) are buffered; every buffer is sent, in one call, when one
    entity holds ``flush_every`` rows, when ``flush_interval`` has passed since
    the last send (a live viewer then follows the run), and on :meth:`flush` /
    :meth:`send_buffered` / :meth:`close` / leaving the ``with`` block (also when
    the block raised). ``flush_every=1`` logs each row at once (a ``log`` call
    per entity and row: slower).

    Time is set with :meth:`set_time` (or by :meth:`log_body_poses`); set it
    through the Recorder, not on the stream, so buffered rows carry it.

    :meth:`close` sends one blueprint laid out for everything that was logged
    (:func:`pik_mj.record.blueprint.blueprint_for`), then closes the stream.

    Its drawing primitives, timelines and lifetime are the :class:`Canvas`'s
    (points, frames, polygons, contacts, series, text; :meth:`close`); here the
    model's geometry and body poses, the CoM, the solves' targets and errors,
    the runs (solves on ``iteration``, physics on ``sim_time``) and the loggers.

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
        files: The ``.rrd`` files ``stream`` saves to
            (:class:`~pik_mj.record.sinks.SavedFiles`, claimed by this writer):
            :meth:`close` (and :meth:`flush`) raise
            :class:`~pik_mj.exceptions.OutputError` naming a file that is not
            whole (a full disk, which rerun only logs).

    Attributes:
        paths: Entity-path table.
        owns_stream: Whether :meth:`close` disconnects the stream.
        robot_root_body: Name of the robot's root body given to
            :meth:`log_model_geometry` (None: every body is the robot's).
        measures: The robot's height, weight and ground
            (:func:`~pik_mj.record.geometry.measure`), once geometry is logged.
        skipped_geoms: Geoms of the last model logged that rerun cannot draw.
    """

    def __init__(
        self,
        stream: rr.RecordingStream,
        *,
        flush_every: int = 256,
        flush_interval: float | None = 0.2,
        owns_stream: bool = False,
        paths: EntityPaths = PATHS,
        files: SavedFiles | None = None,
    ) -> None:
        super().__init__(
            stream,
            flush_every=flush_every,
            flush_interval=flush_interval,
            owns_stream=owns_stream,
            paths=paths,
            files=files,
        )
        self._model: mujoco.MjModel | None = None
        self.robot_root_body: str | None = None
        self.skipped_geoms: list[str] = []
        self._frames: dict[tuple[str, ...], BodyFrames] = {}  # body frames, by (path,)
        # The solves: the last tick of the iteration timeline, the last pose of
        # each task's target (shown again when a physics run starts), the fixed
        # target object each shows, the CoM target [m]
        self._tick = 0
        self._targets: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._fixed_targets: dict[str, object] = {}
        self._com_target: np.ndarray | None = None
        # Physics runs on sim_time: the latest time logged, and the offset that
        # puts a run which restarts its clock (a hold after a motion) after it
        self._sim_end = 0.0
        self._sim_offset = 0.0
        # (task keys, solve label) -> (their error paths, then the log10 ones;
        # which are solved)
        self._error_paths: dict[tuple[Any, ...], tuple[tuple[str, ...], np.ndarray]] = {}
        # level -> (solve, task) -> its series' colour (style.SERIES, in order)
        self._series_colors: dict[int, dict[tuple[str | None, str], tuple[int, int, int]]] = {}

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
        flushes and disconnects it, which writes the file's footer, and checks
        the file whole. Until then no other writer may open ``path``.

        Raises:
            InvalidInput: ``path`` cannot be written, or its directory is missing.
            WriterBusy: Another Recorder (of this process or another) writes ``path``.
        """
        check_flush_every(flush_every)
        files = SavedFiles()
        path = files.claim(path)
        try:
            stream = rr.RecordingStream(
                application_id, recording_id=recording_id or uuid.uuid4().hex
            )
            stream.save(path)
        except BaseException:
            files.release()
            raise
        return cls(
            stream, flush_every=flush_every, flush_interval=None, owns_stream=True, files=files
        )

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
        ``every``-th step on ``sim_time``, called at those steps only (the
        physics runs in C between them). See
        :class:`~pik_mj.record.loggers.HoldLogger`."""
        return HoldLogger(self, every)

    def motion_logger(
        self,
        every: int = 10,
        *,
        reference: bool = True,
        sensors: bool = True,
        cameras: Sequence[Camera] = (),
        image_every: float | None = 0.5,
    ) -> MotionLogger:
        """A callback for ``scene.play(..., callback=...)`` that logs every
        ``every``-th step on ``sim_time`` (called at those steps only): the physical robot, the IK
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

    def walk_logger(self, every: int = 2) -> WalkLogger:
        """A callback for ``play_walk_pattern(..., callback=...)`` that logs the
        scene's geometry and, every ``every``-th pattern tick, the body poses on
        ``sim_time``; its ``finish(report)`` logs the walk's series
        (:meth:`log_walk`). See :class:`~pik_mj.record.loggers.WalkLogger`."""
        return WalkLogger(self, every)

    def log_walk(self, pattern: WalkPattern, report: PlaybackReport) -> None:
        """Log a walking pattern and its playback in physics on ``sim_time``:
        footsteps, ZMPs (reference, inverse dynamics, measured), CoM, support
        polygon, margins. See :func:`~pik_mj.record.loggers.log_walk`."""
        log_walk(self, pattern, report)

    # -- runs -------------------------------------------------------------------

    def begin_solve(self) -> int:
        """Start a solve at the current tick of ``iteration`` (a physics run's
        ``sim_time`` no longer stamps rows); returns the tick."""
        self.disable_timeline("sim_time")
        self.set_time("iteration", self._tick)
        return self._tick

    def next_tick(self) -> int:
        """Advance the ``iteration`` timeline (counted over all solves) by one
        tick and make it the current time; returns the tick."""
        self._tick += 1
        self.set_time("iteration", self._tick)
        return self._tick

    def begin_sim(self, model: mujoco.MjModel, data: mujoco.MjData, time: float) -> None:
        """Start a physics run (a hold, a motion) whose physics clock reads
        ``time``: rows are on ``sim_time`` only, a run that restarts its clock
        is placed after what was logged on it (:meth:`sim_clock`); the geometry
        of the scene's ``model`` is logged when it is not the model logged; the
        solves' current task frames are hidden and their last targets shown
        again."""
        self.disable_timeline("iteration")
        if self._sim_offset + time < self._sim_end - 1e-9:
            self._sim_offset = self._sim_end - time
        if model is not self._model:
            self.log_model_geometry(model, data, robot_root_body=self.robot_root_body)
        self.set_time("sim_time", self.sim_clock(time))
        tasks = f"{self.paths.tasks}/"
        self.hide_frames(
            [p for p in self.rows.logged_paths() if p.startswith(tasks) and p.endswith("/current")]
        )
        for label, (p, q) in self._targets.items():
            self._show_target(label, p, q)
        if self._com_target is not None:
            self.log_com_target(self._com_target)

    def sim_clock(self, time: float) -> float:
        """The ``sim_time`` [s] at which a physics run logs its clock's ``time``:
        ``time`` plus the offset that puts a run which restarted its clock
        after the runs logged before it (a hold after a motion)."""
        t = self._sim_offset + float(time)
        self._sim_end = max(self._sim_end, t)
        return t

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
        :meth:`log_body_poses`. See :mod:`pik_mj.record.drawing`.

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
        self.rows.check_open()
        groups = {int(g) for g in geom_groups}
        if not groups <= set(range(mujoco.mjNGROUP)):
            raise InvalidInput(
                f"geom_groups must be in 0..{mujoco.mjNGROUP - 1}, got {sorted(groups)}"
            )
        if plane_half_size is not None and not (
            math.isfinite(plane_half_size) and plane_half_size > 0
        ):
            raise InvalidInput(f"plane_half_size must be > 0 [m], got {plane_half_size}")
        robot, moving = robot_masks(model, robot_root_body)
        if data is None:
            data = mujoco.MjData(model)
            mujoco.mj_kinematics(model, data)
        elif data.xpos.shape != (model.nbody, 3):
            raise InvalidInput(
                f"data has {data.xpos.shape[0]} bodies, the logged model {model.nbody}"
            )
        self.rows.send()  # the rows buffered for a previous model, before its table goes
        measures = geometry.measure(model, data, robot)
        if self.measures is not None and robot_root_body == self.robot_root_body:
            # the same robot in another scene (a hold's): the scale of its
            # drawings stays that of its first pose logged
            measures = dataclasses.replace(measures, height=self.measures.height)
        self.measures = measures
        self.robot_root_body = robot_root_body
        if plane_half_size is None:
            plane_half_size = measures.floor_half_size
        drawing = draw_model(
            model,
            data,
            self.paths,
            robot=robot,
            moving=moving,
            groups=groups,
            plane_half_size=plane_half_size,
        )
        self.skipped_geoms = drawing.skipped
        self._frames = {}
        self._draw(drawing)
        self._model = model

    def _draw(self, drawing: Drawing) -> None:
        """Log the static data of ``drawing`` and pose its body frames from now on."""
        for path, archetypes in drawing.static:
            self.rows.log_static(path, *archetypes)
        self._frames.update(drawing.frames)
        self.rows.carry_geometry(self._frames)

    def log_body_poses(
        self, data: mujoco.MjData, *, timeline: str = "iteration", time: float
    ) -> None:
        """Set ``timeline`` to ``time`` and log the poses of every moving body:
        the body frames ``X_WB`` and the instances of their geoms.

        Rows carry every timeline currently set (see :meth:`disable_timeline`).
        The body poses are MuJoCo's ``xpos``, ``xquat`` (run its kinematics
        first); the geoms' follow from them.
        """
        self.rows.check_open()
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
            poses = body_poses(frames, data)
            if not np.isfinite(poses).all():
                raise InvalidInput(f"body poses at {timeline}={time} are not finite")
            rows.append((frames, poses))
        robot = self.paths.bodies(robot=True)
        for frames, poses in rows:
            if frames.path == robot:
                self.extent.grow(timeline, poses)
        for frames, poses in rows:
            self._append_poses(frames, poses)

    def _append_poses(self, frames: BodyFrames, poses: np.ndarray) -> None:
        """Buffer the body poses of ``frames``; the geoms' poses follow from them
        when they are sent (at once when unbuffered)."""
        rows = self.rows
        rows.append((frames.path,), poses, BODY_FRAME)
        if rows.flush_every == 1:
            for group, instances in frames.geometry(poses[None]):
                rows.append((group.path,), instances[0], INSTANCE_POSES[group.archetype])

    def log_reference_geometry(self, model: mujoco.MjModel) -> None:
        """Log the robot's geoms of ``model`` a second time, static, at
        :attr:`EntityPaths.reference`, translucent (:data:`style.REFERENCE`):
        the reference pose of a motion, posed by :meth:`log_reference_poses`.
        Call it after the model's own geometry (:meth:`log_model_geometry`)."""
        self.rows.check_open()
        if self._model is None or self.robot_root_body is None:
            raise PikError("log the model's geometry (with its robot_root_body) first")
        self._draw(draw_reference(model, self.robot_root_body, self.paths))

    def log_reference_poses(self, data: mujoco.MjData) -> None:
        """Log the body poses of the reference robot (``data``: its kinematics)
        at the current time; its geoms follow (:meth:`log_reference_geometry`)."""
        frames = self._frames.get((f"{self.paths.reference}/bodies",))
        if frames is None:
            raise PikError("call log_reference_geometry(model) before log_reference_poses")
        self._append_poses(frames, body_poses(frames, data))

    def log_camera(
        self, camera: Camera, data: mujoco.MjData, image: np.ndarray | None = None
    ) -> str:
        """Log ``camera`` (:class:`pik_mj.robot.camera.Camera`) as a pinhole at its pose
        in ``data`` (kinematics and ``mj_camlight`` current) at the current
        time, with ``image`` (RGB uint8) if given (:func:`pik_mj.robot.camera.log_camera`).
        Returns the pinhole's path."""
        self.rows.check_open()
        path = self.paths.camera(camera.name)
        for p in (path, f"{path}/image"):
            self.rows.note_logged(p)
        return log_camera(self.stream, camera, data, path=path, image=image)

    # -- CoM and targets --------------------------------------------------------

    def log_com(self, p_WC: npt.ArrayLike, target: npt.ArrayLike | None = None) -> None:
        """Log the centre of mass ``p_WC`` [m] and, if given, its target [m].

        For a floating-base robot its projection on the ground (``ground_z`` of
        :attr:`measures`, drawn :attr:`lift` above it) and the arrow down to it
        go to the same entity (an ``Arrows3D``: one chunk for both).
        """
        p = finite_array(p_WC, (3,), "CoM", self.paths.com)
        self.rows.append((self.paths.com,), p.reshape(1, 3), POINT, _COM_STYLE)
        ground = None if self.measures is None else self.measures.ground_z
        if ground is not None:
            foot = np.array([p[0], p[1], ground + self.lift])
            self.rows.append(
                (self.paths.com,),
                np.concatenate([p, foot - p]).reshape(1, 6),
                ARROW,
                (style.COM_GROUND_RADIUS / 2, style.COM_GROUND),
            )
        if target is not None:
            self.log_com_target(target)

    def log_com_target(self, target: npt.ArrayLike) -> None:
        """Log the target [m] of the centre of mass (the last one is shown again
        when a physics run starts, :meth:`begin_sim`)."""
        p = finite_array(target, (3,), "CoM target", self.paths.com_target)
        self.log_point(
            self.paths.com_target, p, radius=style.COM_TARGET_RADIUS, color=style.COM_TARGET
        )
        self._com_target = p.copy()

    @property
    def com_target(self) -> np.ndarray | None:
        """The CoM target logged last [m] (:meth:`log_com_target`), or None."""
        return self._com_target

    def log_target(
        self, task: str, p: npt.ArrayLike, quat_wxyz: npt.ArrayLike, *, fixed: object = None
    ) -> None:
        """Log the target of ``task``: its frame (``world/tasks/<task>/target``,
        position [m], MuJoCo quaternion) and, on the same entity (one chunk), a
        marker labelled with the task's name at the frame's origin. The last
        one is shown again when a physics run starts (:meth:`begin_sim`).

        Args:
            task: The task's name.
            p: Position of the target [m].
            quat_wxyz: Orientation of the target, MuJoCo quaternion.
            fixed: The task's fixed target object this pose is of (None: a
                target that moves); :meth:`shows_target` compares it.
        """
        self._show_target(task, p, quat_wxyz)
        self._targets[str(task)] = (np.array(p, dtype=float), np.array(quat_wxyz, dtype=float))
        self._fixed_targets[str(task)] = fixed

    def _show_target(self, task: str, p: npt.ArrayLike, quat_wxyz: npt.ArrayLike) -> None:
        path = self.paths.task_target(task)
        self.log_frame(path, p, quat_wxyz)
        self.log_point(
            path, np.zeros(3), radius=style.TARGET_RADIUS, color=style.TARGET, label=str(task)
        )

    def shows_target(self, task: str, fixed: object) -> bool:
        """Whether the target of ``task`` logged last is the fixed target object
        ``fixed`` (compared by identity; False for a target that moves)."""
        return fixed is not None and self._fixed_targets.get(str(task)) is fixed

    # -- task errors ------------------------------------------------------------

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
            plan = self._error_paths[(keys, solve)] = self._error_series(keys, solve)
        paths, solved = plan
        values = np.fromiter(errors.values(), dtype=float, count=len(keys))
        if not np.isfinite(values).all():
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise InvalidInput(f"scalar {paths[bad]!r} must be finite, got {values[bad]}")
        rows = np.concatenate([values, np.log10(np.maximum(np.abs(values[solved]), 1e-16))])
        self.rows.append(paths, rows.reshape(-1, 1), SCALAR)

    def _error_series(
        self, keys: tuple[tuple[int, str], ...], solve: str | None
    ) -> tuple[tuple[str, ...], np.ndarray]:
        """The error series of the tasks ``keys`` of ``solve``: their paths (the
        linear ones, then the log10 ones of the solved levels) and which keys
        are solved; their legends' names and colours are logged here, once: a
        task's linear and log10 series alike, the tasks of one level apart."""
        solved = np.array([level >= 1 for level, _ in keys], dtype=bool)
        named = [(level, name, False) for level, name in keys]
        named += [(level, name, True) for (level, name), s in zip(keys, solved, strict=True) if s]
        paths = tuple(
            self.paths.task_error(level, name, log10=log10, solve=solve)
            for level, name, log10 in named
        )
        for path, (level, name, _) in zip(paths, named, strict=True):
            colors = self._series_colors.setdefault(level, {})
            color = colors.setdefault((solve, name), style.SERIES[len(colors) % len(style.SERIES)])
            self.log_series_style(path, color, name if solve is None else f"{solve}: {name}")
        return paths, solved
