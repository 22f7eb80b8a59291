"""The :class:`Canvas`: what a recording draws with, over one rerun stream.

The generic half of :class:`~pik_mj.record.recorder.Recorder`: the stream's
lifetime and timelines, points, frames, polygons, contacts, scalar series and
text, and the blueprint sent when the stream closes. Everything goes through one
:class:`~pik_mj.record.stream.BufferedStream` (:attr:`Canvas.rows`). What it
draws on the ground is lifted and scaled by the robot's :attr:`~Canvas.measures`
(set when the robot's geometry is logged), and each timeline's 3D view frames
the box the robot swept on it (:attr:`~Canvas.extent`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from types import TracebackType
from typing import Any, Self

import numpy as np
import numpy.typing as npt
import rerun as rr
import rerun.blueprint as rrb

from pik_mj.exceptions import InvalidInput, OutputError
from pik_mj.record import geometry, style
from pik_mj.record.blueprint import Framing, blueprint, blueprint_for, send_blueprint_for
from pik_mj.record.columns import POINT, SCALAR, TRANSFORM
from pik_mj.record.drawing import Extent
from pik_mj.record.paths import PATHS, EntityPaths
from pik_mj.record.sinks import SavedFiles
from pik_mj.record.stream import BufferedStream, finite_array

__all__ = ["Canvas"]

_TEXT_LEVELS = ("TRACE", "DEBUG", "INFO", "WARN", "ERROR", "CRITICAL")


class Canvas:
    """Draws on one rerun recording stream: points, frames, polygons, contacts,
    scalar series and text at the current time of its timelines; closing it
    sends the blueprint of what was drawn. See
    :class:`~pik_mj.record.recorder.Recorder` (its arguments).

    Attributes:
        paths: Entity-path table.
        owns_stream: Whether :meth:`close` disconnects the stream.
        measures: The robot's height, weight and ground
            (:func:`~pik_mj.record.geometry.measure`), once its geometry is
            logged; None before.
        extent: The box of the robot's body positions seen on each timeline
            (what its 3D view frames).
        files: The ``.rrd`` files the stream saves to, held by this writer and
            checked whole when it closes (None: not known, not checked).
    """

    def __init__(
        self,
        stream: rr.RecordingStream,
        *,
        flush_every: int,
        flush_interval: float | None,
        owns_stream: bool,
        paths: EntityPaths = PATHS,
        files: SavedFiles | None = None,
    ) -> None:
        self._rows = BufferedStream(stream, flush_every, flush_interval)
        self.paths = paths
        self.owns_stream = owns_stream
        self.files = files
        self.measures: geometry.Measures | None = None
        self.extent = Extent()

    @property
    def rows(self) -> BufferedStream:
        """The buffered stream everything is logged through (rows of any
        :class:`~pik_mj.record.columns.RowKind`, static data, direct logs)."""
        return self._rows

    @property
    def stream(self) -> rr.RecordingStream:
        """The rerun recording stream logged to."""
        return self._rows.stream

    @property
    def flush_every(self) -> int:
        """Rows buffered per entity before they are sent."""
        return self._rows.flush_every

    @property
    def flush_interval(self) -> float | None:
        """Longest time [s] rows stay buffered, or None."""
        return self._rows.flush_interval

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` ran (logging then raises)."""
        return self._rows.closed

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
        p = finite_array(p, (3,), "point", path)
        r = float(radius)
        if not (math.isfinite(r) and r > 0):
            raise InvalidInput(f"radius of point {path!r} must be > 0 [m], got {radius}")
        style = (r, tuple(int(c) for c in color), None if label is None else str(label))
        self._rows.append((path,), p.reshape(1, 3), POINT, style)

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
            v = finite_array(verts, (-1, 3), "polygon vertices of", p) + np.array([0.0, 0.0, lift])
            strips = [np.vstack([v, v[:1]])] if len(v) else []
            self._rows.log(
                p, rr.LineStrips3D(strips, colors=[tuple(c)], radii=[style.OUTLINE_RADIUS])
            )

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
        p = finite_array(points, (-1, 3), "contact points")
        f = finite_array(forces, (len(p), 3), "contact forces")
        scale = self.force_scale if scale is None else scale
        if not (math.isfinite(scale) and scale > 0):
            raise InvalidInput(f"contact force scale must be > 0 [m/N], got {scale}")
        self._rows.log(
            self.paths.contact_points,
            rr.Points3D(p, radii=[style.CONTACT_RADIUS], colors=[style.CONTACT]),
        )
        self._rows.log(
            self.paths.contact_forces,
            rr.Arrows3D(origins=p, vectors=f * scale, colors=[style.CONTACT]),
        )

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
        p = finite_array(p, (3,), "frame position", path)
        q = finite_array(quat_wxyz, (4,), "frame quaternion (w, x, y, z)", path)
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
        p = finite_array(positions, (n, 3), "frame positions")
        q = finite_array(quats_wxyz, (n, 4), "frame quaternions (w, x, y, z)")
        norms = np.sqrt(np.einsum("ij,ij->i", q, q))
        if (norms < 1e-9).any():
            raise InvalidInput(f"frame quaternion of {paths[int(np.argmin(norms))]!r} is zero")
        length = float(axis_length)
        if not (math.isfinite(length) and length > 0):
            raise InvalidInput(f"axis_length must be > 0 [m], got {axis_length}")
        poses = np.empty((n, 7))
        poses[:, :3] = p
        poses[:, 3:] = q / norms[:, None]
        self._rows.append(paths, poses, TRANSFORM, (length,))

    def hide_frames(self, paths: Iterable[str]) -> None:
        """Draw no axes for the frames ``paths`` from the current time on (a
        frame without a pose at the current time is drawn at the origin)."""
        for path in paths:
            self._rows.log(path, rr.TransformAxes3D(axis_length=0.0))

    def log_scalar(self, path: str, value: float) -> None:
        """Log one value of the scalar series at ``path`` (buffered)."""
        v = float(value)
        if not math.isfinite(v):
            raise InvalidInput(f"scalar {path!r} must be finite, got {value}")
        self._rows.append((path,), np.array([[v]]), SCALAR)

    def log_series_style(self, path: str, color: tuple[int, ...], name: str) -> None:
        """A plotted series' line colour (RGB) and legend name, static."""
        self._rows.log_static(path, rr.SeriesLines(colors=[color], names=[name]))

    def log_static(self, path: str, *archetypes: Any) -> None:
        """Log ``archetypes`` (rerun archetypes) at ``path`` once, static: sent
        with the buffered rows."""
        self._rows.log_static(path, *archetypes)

    def log_text(self, message: str, level: str = "INFO") -> None:
        """Log ``message`` to the run's text log at the current time."""
        if level not in _TEXT_LEVELS:
            raise InvalidInput(f"text level must be one of {_TEXT_LEVELS}, got {level!r}")
        self._rows.log(self.paths.events, rr.TextLog(str(message), level=level))

    def set_time(self, timeline: str, value: float, *, kind: str | None = None) -> None:
        """Set the current time of ``timeline`` for every following log call.

        Args:
            timeline: Timeline name: ``iteration`` (sequence) or ``sim_time``
                (duration, value in [s]), or any other with an explicit ``kind``.
            value: Iteration number, or time in [s].
            kind: ``"sequence"`` or ``"duration"``; fixed once a timeline is used.
        """
        self._rows.set_time(timeline, value, kind=kind)

    def disable_timeline(self, timeline: str) -> None:
        """Stop stamping following rows with ``timeline`` (e.g. after the solve)."""
        self._rows.disable_timeline(timeline)

    def __enter__(self) -> Self:
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
        """Send every buffered row and wait until the stream has written them.

        Raises:
            OutputError: The stream's sink failed (a file on a full disk).
        """
        self._rows.send()
        self._flush()

    def _flush(self, timeout: float | None = None) -> None:
        """The stream's flush (``timeout`` [s]; None: until written), its sink's
        failure (rerun's file writer gone: only logged by rerun) raised."""
        try:
            if timeout is None:
                self.stream.flush()
            else:
                self.stream.flush(timeout_sec=timeout)
        except RuntimeError as exc:
            raise OutputError(self._sink_failure(str(exc))) from None

    def _sink_failure(self, reason: str) -> str:
        files = [repr(str(p)) for p in self.files.paths] if self.files is not None else []
        where = f"the recording {', '.join(files)}" if files else "the recording's sink"
        return f"{where} could not be written: {reason}; it is incomplete"

    def send_buffered(self) -> None:
        """Send every buffered row without waiting: the stream encodes and writes
        them on its own threads while the caller goes on (e.g. builds the
        blueprint before :meth:`close`)."""
        self._rows.check_open()
        self._rows.send()
        self._flush(timeout=0.0)  # start the pipeline, do not wait

    def close(self, *, blueprint: bool = True) -> None:
        """Send the buffered rows and (with ``blueprint``) one blueprint laid out
        for everything logged; disconnect the stream if it is owned (``owns_stream``)
        (which flushes it and finalizes its file), else flush it. The stream is
        closed also when sending fails. Idempotent.

        Raises:
            OutputError: The sink failed, or a file of :attr:`files` is not whole
                once closed (a full disk: rerun only logs it); the file is named.
        """
        if self.closed:
            return
        failure = None
        try:
            self._rows.send()
            # the stream writes the rows on its threads while the blueprint is built
            self._flush(timeout=0.0)
            if blueprint:
                send_blueprint_for(
                    self.stream, self._rows.logged_paths(), self.paths, framing=self._framing()
                )
            if not self.owns_stream:
                self._flush()
        except OutputError as exc:
            failure = exc
        finally:
            self._rows.mark_closed()
            if self.owns_stream:
                self.stream.disconnect()
            problems = [] if self.files is None else self.files.finish()
        if problems:
            raise OutputError("; ".join(problems)) from failure
        if failure is not None:
            raise failure

    def logged(self) -> dict[str, set[str]]:
        """Every entity path logged so far (static data left out) -> the
        timelines its rows carry."""
        return self._rows.logged()

    def blueprint(self) -> rrb.Blueprint:
        """The blueprint of what was logged so far (what :meth:`close` sends):
        :func:`~pik_mj.record.blueprint.blueprint_for`, each 3D view framed on
        the robot's body positions seen on its timeline."""
        return blueprint_for(self._rows.logged_paths(), self.paths, framing=self._framing())

    def send_blueprint(
        self, levels: Iterable[int] | None = None, extra: Sequence[tuple[str, str]] = ()
    ) -> None:
        """Send a blueprint now (made active): the one of what was logged so far
        (:meth:`blueprint`), or the layout of ``levels`` and ``extra`` series
        (:func:`~pik_mj.record.blueprint.blueprint`). :meth:`close` sends the
        blueprint of everything logged after it."""
        self._rows.check_open()
        if levels is None:
            send_blueprint_for(
                self.stream, self._rows.logged_paths(), self.paths, framing=self._framing()
            )
        else:
            self.stream.send_blueprint(blueprint(list(levels), self.paths, extra=extra))

    def _framing(self) -> dict[str, Framing]:
        """What each timeline's 3D view frames: the robot's body positions seen on it."""
        return self.extent.framing(self.measures)
