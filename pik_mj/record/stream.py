"""Buffered logging to one rerun recording stream: the current time of each
timeline, rows buffered per set of entities and sent as chunks, static data,
and what was logged.

:class:`BufferedStream` is what :class:`~pik_mj.record.recorder.Recorder`
writes through. Per-iteration rows (body poses, frames, points, scalars) are
buffered densely, one :class:`~pik_mj.record.columns.Block` per set of entities
logged together, and sent as one chunk per entity
(:class:`~pik_mj.record.columns.Outbox`): rerun's cost per ``log`` call is paid
once per chunk rather than once per row. Everything else (polygons, contacts,
text) is logged directly, at the current time.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
import rerun as rr

from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.record.columns import Block, Outbox, RowKind
from pik_mj.record.geometry import BodyFrames
from pik_mj.record.paths import TIMELINES

__all__ = ["BufferedStream", "check_flush_every", "finite_array"]


def finite_array(
    value: npt.ArrayLike, shape: tuple[int, ...], what: str, path: str | None = None
) -> np.ndarray:
    """``value`` as a finite float array of ``shape`` (-1 = any length), or raise
    :class:`~pik_mj.exceptions.InvalidInput`.

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


def _what(what: str, path: str | None) -> str:
    return what if path is None else f"{what} {path!r}"


def check_flush_every(flush_every: int) -> None:
    """Raise :class:`~pik_mj.exceptions.InvalidInput` unless ``flush_every`` is
    an integer >= 1."""
    if isinstance(flush_every, bool) or not isinstance(flush_every, (int, np.integer)):
        raise InvalidInput(f"flush_every must be an integer >= 1, got {flush_every!r}")
    if flush_every < 1:
        raise InvalidInput(f"flush_every must be an integer >= 1, got {flush_every}")


class BufferedStream:
    """One rerun recording stream, written through buffers.

    Rows are buffered per set of entities logged together; every buffer is sent,
    in one call, when one entity holds ``flush_every`` rows, when
    ``flush_interval`` has passed since the last send, and on :meth:`send`.
    ``flush_every=1`` logs each row at once. Rows whose entity carries the
    geoms of a :class:`~pik_mj.record.geometry.BodyFrames` (body poses) send
    the geoms' poses with them, computed then for all rows at once.

    Args:
        stream: The rerun recording stream.
        flush_every: Rows buffered per entity before they are sent (>= 1).
        flush_interval: Longest time [s] rows stay buffered, or None (sent by
            count and on :meth:`send` only).

    Attributes:
        stream: The rerun recording stream.
        flush_every: Rows buffered per entity before they are sent.
        flush_interval: Longest time [s] rows stay buffered, or None.
        closed: Whether the stream was closed (:meth:`mark_closed`): logging
            then raises.
    """

    def __init__(
        self, stream: rr.RecordingStream, flush_every: int, flush_interval: float | None
    ) -> None:
        if not isinstance(stream, rr.RecordingStream):
            raise InvalidInput(
                f"stream must be a rerun.RecordingStream, got {type(stream).__name__}"
            )
        check_flush_every(flush_every)
        if flush_interval is not None and not (
            math.isfinite(flush_interval) and flush_interval > 0
        ):
            raise InvalidInput(f"flush_interval must be > 0 [s] or None, got {flush_interval}")
        self.stream = stream
        self.flush_every = int(flush_every)
        self.flush_interval = flush_interval
        self.closed = False
        self._next_send = -math.inf
        # Current time: timeline -> value, and its kind (fixed once used).
        self._time: dict[str, float] = {}
        self._kinds: dict[str, str] = dict(TIMELINES)
        self._time_key: tuple[tuple[str, ...], tuple[str, ...]] = ((), ())
        self._time_vals: tuple[float, ...] = ()
        self._stream_time_dirty = False
        # (entity paths, timelines, style, instances) -> their buffered rows
        self._blocks: dict[tuple[Any, ...], Block] = {}
        self._outbox = Outbox()
        # What was logged: entity path -> timelines of its rows
        self._logged: dict[str, set[str]] = {}
        # Entities whose rows are body poses: (path,) -> the frames carrying geoms
        self._carriers: dict[tuple[str, ...], BodyFrames] = {}

    # -- time -------------------------------------------------------------------

    def set_time(self, timeline: str, value: float, *, kind: str | None = None) -> None:
        """Set the current time of ``timeline`` for every following row.

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
        """Stop stamping following rows with ``timeline``."""
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

    # -- rows -------------------------------------------------------------------

    def check_open(self) -> None:
        """Raise :class:`~pik_mj.exceptions.PikError` if the stream was closed."""
        if self.closed:
            raise PikError("the Recorder is closed; create a new one to log more")

    def log(self, path: str, *archetypes: Any, static: bool = False) -> None:
        """Log ``archetypes`` at ``path`` now, at the current time (or static)."""
        self.check_open()
        if not static:
            self._sync_stream_time()
            self._logged.setdefault(path, set()).update(self._time)
        self.stream.log(path, *archetypes, static=static, strict=True)

    def log_static(self, path: str, *archetypes: Any) -> None:
        """Static data of ``path``: sent with the buffered rows (at once when
        unbuffered, ``flush_every=1``); a later value of a component replaces
        an earlier one."""
        self.check_open()
        if self.flush_every == 1:
            self.log(path, *archetypes, static=True)
        else:
            self._outbox.add_static(path, *archetypes)

    def note_logged(self, path: str) -> None:
        """Count ``path`` as logged on the current timelines (data written to
        the stream by other means)."""
        self._sync_stream_time()
        self._logged.setdefault(path, set()).update(self._time)

    def append(
        self,
        paths: tuple[str, ...],
        rows: np.ndarray,
        kind: RowKind,
        style: tuple[Any, ...] = (),
    ) -> None:
        """Buffer one row of each entity of ``paths`` (``rows``: entities x
        [instances x] ``kind.width``, checked by the caller) with ``style`` at the
        current time; log them at once if unbuffered."""
        self.check_open()
        rows = rows.reshape(len(paths), -1, kind.width)
        if self.flush_every == 1:
            for path, row in zip(paths, rows, strict=True):
                self.log(path, kind.archetype(row, style))
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
            self.send()

    def carry_geometry(self, frames: Mapping[tuple[str, ...], BodyFrames]) -> None:
        """The entities whose rows are body poses from now on, by ``(path,)``:
        the poses of the geoms their :class:`BodyFrames` carry are sent with
        them (:meth:`send` first the rows of a table being replaced)."""
        self._carriers = dict(frames)

    def send(self) -> None:
        """Send every buffered row of every entity, and pending static data, in
        one call, without waiting for the stream to write them."""
        for block in self._blocks.values():
            block.drain(self._outbox, self._carriers.get(block.paths))
        self._outbox.send(self.stream)
        if self.flush_interval is not None:
            self._next_send = time.monotonic() + self.flush_interval

    def logged(self) -> dict[str, set[str]]:
        """Every entity path logged so far (static data left out) -> the
        timelines its rows carry (a copy)."""
        return {path: set(timelines) for path, timelines in self._logged.items()}

    def logged_paths(self) -> Mapping[str, set[str]]:
        """What :meth:`logged` returns, without the copy (read only)."""
        return self._logged

    def mark_closed(self) -> None:
        """Refuse every later row (:meth:`check_open`)."""
        self.closed = True
