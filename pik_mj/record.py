"""Rerun recording of solves and simulations: one place for entity paths and logging.

A :class:`Recorder` wraps an explicit :class:`rerun.RecordingStream` (never the
global one). What it writes, and why it is shaped so:

* Model geometry is logged once, static, one entity per primitive kind with one
  instance per geom (:mod:`pik_mj.record_geometry`); the bodies' frames are one
  entity with one instance per body. rerun's cost per file (building chunks,
  the RRD footer) grows with the number of entities, not with their size.
* Per-iteration data (body poses, frames, points, scalars) is buffered densely,
  one buffer per set of entities logged together. At a flush, each entity's
  rows become one chunk (``rerun.chunk.Chunk.from_columns``) and one
  ``rr.send_chunks`` sends them all. The geoms' poses are computed then, for all
  rows at once, from the buffered body poses. A style (a point's radius and
  colour, a frame's axis length) goes with each row, in the chunk of its data.
* Everything else (polygons, contacts, text) is logged directly.

Every entity path is built by :class:`EntityPaths` (module constant
:data:`PATHS`); quaternions are MuJoCo's (w, x, y, z) everywhere in pik_mj and are
converted to rerun's (x, y, z, w) only inside this module (:func:`_xyzw`).

Typical use::

    with Recorder.to_file("run.rrd") as rec:
        rec.log_model_geometry(model, robot_root_body="torso")
        rec.send_blueprint(levels=[1, 2])
        for k in range(n_iter):
            rec.log_body_poses(data, timeline="iteration", time=k)
            rec.log_com(data.subtree_com[1], target=p_WC_target)
            rec.log_task_errors({(1, "com"): e_com, (2, "posture"): e_post})
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb
from rerun.chunk import Chunk

from pik_mj import inputs, record_geometry
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.record_geometry import GeomGroup, InstancePoses

__all__ = [
    "PATHS",
    "TIMELINES",
    "EntityData",
    "EntityPaths",
    "Recorder",
    "blueprint",
    "read_recording",
]

#: Kind of every timeline pik_mj uses: ``iteration`` counts IK solver iterations,
#: ``sim_time`` is physics time in [s]. Other timelines need an explicit ``kind``.
TIMELINES: dict[str, str] = {"iteration": "sequence", "sim_time": "duration"}

_TEXT_LEVELS = ("TRACE", "DEBUG", "INFO", "WARN", "ERROR", "CRITICAL")


def _part(name: str) -> str:
    """Escape one entity-path part (MJCF names may hold '/', spaces, ...)."""
    return rr.escape_entity_path_part(name)


@dataclass(frozen=True)
class EntityPaths:
    """Every rerun entity path pik_mj writes. Names are escaped path parts.

    Attributes:
        world: Root of the 3D scene (z up).
        robot: Parent of the robot's geometry (``world/robot/<kind>``) and body
            frames (``world/robot/bodies``).
        scene: Parent of the environment's geometry: ``world/scene/<kind>``
            (welded to the world), ``world/scene/moving/<kind>`` and
            ``world/scene/moving/bodies`` (free or mocap bodies).
        com: Centre of mass ``p_WC`` [m].
        com_target: Target of the centre of mass [m].
        support_polygon: Support polygon outline (child ``margin``: shrunk outline).
        scfr: Static centroid feasible region outline.
        zmp: Zero-moment point [m].
        contact_points: Contact points [m].
        contact_forces: Contact forces drawn as arrows (scaled, [m/N]).
        tasks: Parent of task frames: ``world/tasks/<task>/target|current``.
        errors: Parent of task error series: ``errors/level_<k>/<task>``.
        events: Text log of the run.
        hold: Parent of physics-hold metrics: ``hold/<metric>`` (e.g. ``hold/drift``).
        balance: Parent of per-iteration balance metrics of the simulated static
            check: ``balance/<metric>`` (e.g. ``balance/margin``).
    """

    world: str = "world"
    robot: str = "world/robot"
    scene: str = "world/scene"
    com: str = "world/com"
    com_target: str = "world/com_target"
    support_polygon: str = "world/support_polygon"
    scfr: str = "world/scfr"
    zmp: str = "world/zmp"
    contact_points: str = "world/contacts/points"
    contact_forces: str = "world/contacts/forces"
    tasks: str = "world/tasks"
    errors: str = "errors"
    events: str = "log/events"
    hold: str = "hold"
    balance: str = "balance"

    def geoms(self, kind: str, *, robot: bool = True, moving: bool = True) -> str:
        """Path of the geoms of one primitive ``kind`` (``boxes``, ``capsules``,
        ``cylinders``, ``ellipsoids``, ``meshes/<mesh>``, ``hfields/<hfield>``)
        of the robot, of the scene welded to the world, or of moving scene bodies."""
        if robot:
            return f"{self.robot}/{kind}"
        return f"{self.scene}/moving/{kind}" if moving else f"{self.scene}/{kind}"

    def bodies(self, *, robot: bool = True) -> str:
        """Path of the body frames ``X_WB`` of the robot or of the moving scene
        bodies (one instance per body, labelled with its MJCF name)."""
        return f"{self.robot}/bodies" if robot else f"{self.scene}/moving/bodies"

    def task_target(self, task: str) -> str:
        """Path of a task's target frame."""
        return f"{self.tasks}/{_part(task)}/target"

    def task_current(self, task: str) -> str:
        """Path of a task's current frame."""
        return f"{self.tasks}/{_part(task)}/current"

    def level_errors(self, level: int) -> str:
        """Parent path of the error series of priority level ``level``."""
        return f"{self.errors}/level_{int(level)}"

    def task_error(self, level: int, task: str) -> str:
        """Path of the scalar error series of ``task`` on priority level ``level``."""
        return f"{self.level_errors(level)}/{_part(task)}"

    def hold_metric(self, name: str) -> str:
        """Path of a physics-hold metric series, e.g. ``hold/drift``."""
        return f"{self.hold}/{_part(name)}"

    def balance_metric(self, name: str) -> str:
        """Path of a per-iteration balance metric series, e.g. ``balance/margin``."""
        return f"{self.balance}/{_part(name)}"


#: The one entity-path table of pik_mj.
PATHS = EntityPaths()


def _xyzw(q_wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo (w, x, y, z) -> rerun (x, y, z, w), along the last axis."""
    return q_wxyz[..., [1, 2, 3, 0]]


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


def _what(what: str, path: str | None) -> str:
    return what if path is None else f"{what} {path!r}"


# ---------------------------------------------------------------------------
# Model geometry


def _subtree(model: mujoco.MjModel, root: int) -> np.ndarray:
    """Boolean mask of the bodies in the kinematic subtree of ``root``."""
    inside = np.zeros(model.nbody, dtype=bool)
    inside[root] = True
    for b in range(root + 1, model.nbody):  # parents have smaller ids
        inside[b] = inside[model.body_parentid[b]]
    return inside


def _unique_names(kind: str, names: Sequence[str]) -> list[str]:
    """MJCF names with ``<kind>_<id>`` for unnamed ones, made unique."""
    out: list[str] = []
    seen: set[str] = set()
    for i, name in enumerate(names):
        n = name or f"{kind}_{i}"
        if n in seen:
            n = f"{n}_{i}"
        seen.add(n)
        out.append(n)
    return out


#: Per-instance pose components of each primitive: (translation, rotation).
_INSTANCE_POSE_FIELDS: dict[Any, tuple[Any, Any]] = {
    rr.Boxes3D: (rr.Boxes3D.descriptor_centers(), rr.Boxes3D.descriptor_quaternions()),
    rr.Capsules3D: (
        rr.Capsules3D.descriptor_translations(),
        rr.Capsules3D.descriptor_quaternions(),
    ),
    rr.Cylinders3D: (rr.Cylinders3D.descriptor_centers(), rr.Cylinders3D.descriptor_quaternions()),
    rr.Ellipsoids3D: (
        rr.Ellipsoids3D.descriptor_centers(),
        rr.Ellipsoids3D.descriptor_quaternions(),
    ),
    # a mesh is drawn once per instance pose
    rr.Mesh3D: (
        rr.InstancePoses3D.descriptor_translations(),
        rr.InstancePoses3D.descriptor_quaternions(),
    ),
}

#: Radius [m] of the marker drawn at each body frame.
BODY_MARKER_RADIUS = 0.01


def _body_markers(names: Sequence[str]) -> Any:
    """Small wireframe spheres labelled with the body names (their poses are
    logged per row)."""
    return rr.Ellipsoids3D(
        half_sizes=np.full((len(names), 3), BODY_MARKER_RADIUS),
        colors=[(230, 230, 230)],
        labels=list(names),
        show_labels=False,
    )


# ---------------------------------------------------------------------------
# Buffered rows


def _time_columns(
    names: tuple[str, ...], kinds: tuple[str, ...], times: np.ndarray
) -> list[rr.TimeColumn]:
    """TimeColumns for ``times`` (rows x timelines)."""
    cols = []
    for j, (name, kind) in enumerate(zip(names, kinds, strict=True)):
        if kind == "sequence":
            cols.append(rr.TimeColumn(name, sequence=times[:, j].astype(np.int64)))
        else:
            cols.append(rr.TimeColumn(name, duration=times[:, j].astype(float)))
    return cols


@dataclass(frozen=True)
class _RowKind:
    """How rows of one archetype are sent: stacked in columns, or one by one.

    A row of one entity is one or more instances of ``width`` floats (a scalar,
    a point, a pose; the instances of a multi-instance primitive). Its
    style (radius and colour of a point, axis length of a frame; ``()`` for
    none) goes with every row, in the same chunk: a static style would cost a
    chunk of its own per entity.
    """

    width: int
    # (instances, width) stacked, instances per row -> data columns
    columns: Callable[[np.ndarray, np.ndarray], list[Any]]
    style_columns: Callable[[tuple[Any, ...], int], list[Any]]  # (style, rows) -> columns
    archetype: Callable[[np.ndarray, tuple[Any, ...]], Any]  # (instances, width) row -> ``log``


def _no_style(style: tuple[Any, ...], n: int) -> list[Any]:
    return []


# Columns are built from the component batches directly: the same components
# as ``<Archetype>.columns(...)``, at half its cost (which builds and checks
# every field of the archetype per call).


def _one_per_row(batch: Any, descriptor: Any, n: int) -> Any:
    """Column of ``n`` rows holding one value of ``batch`` each."""
    return batch.described(descriptor).partition([1] * n)


def _pose_batches(v: np.ndarray, translation: Any, quaternion: Any) -> list[Any]:
    """Translation and rotation batches of poses ``v`` (n, 7) [p, q_wxyz],
    described as ``translation`` / ``quaternion`` (ComponentDescriptors)."""
    return [
        rr.components.Translation3DBatch(v[:, :3]).described(translation),
        rr.components.RotationQuatBatch(_xyzw(v[:, 3:])).described(quaternion),
    ]


def _pose_kind(translation: Any, quaternion: Any, *, axes: bool = False) -> _RowKind:
    """Rows of poses [p, q_wxyz] sent as the components ``translation`` and
    ``quaternion`` (a Transform3D, or the per-instance poses of a primitive);
    with ``axes``, a style ``(axis_length,)`` draws the frame's axes."""
    style_columns = _axes_style_columns if axes else _no_style
    return _RowKind(
        width=7,
        columns=lambda v, lengths: [
            b.partition(lengths) for b in _pose_batches(v, translation, quaternion)
        ],
        style_columns=style_columns,
        archetype=lambda v, style: (
            _pose_batches(v, translation, quaternion)
            + [c.component_batch for c in style_columns(style, 1)]
        ),
    )


def _point_style_columns(style: tuple[Any, ...], n: int) -> list[Any]:
    """Radius [m], colour and optional label of a point, ``n`` rows."""
    radius, color, label = style
    cols = [
        _one_per_row(
            rr.components.RadiusBatch(np.full(n, radius, np.float32)),
            rr.Points3D.descriptor_radii(),
            n,
        ),
        _one_per_row(rr.components.ColorBatch([color] * n), rr.Points3D.descriptor_colors(), n),
    ]
    if label is not None:
        cols.append(
            _one_per_row(rr.components.TextBatch([label] * n), rr.Points3D.descriptor_labels(), n)
        )
    return cols


def _axes_style_columns(style: tuple[Any, ...], n: int) -> list[Any]:
    """Axis length [m] of a frame, ``n`` rows (no style: a body pose, no axes)."""
    if not style:
        return []
    return [
        _one_per_row(
            rr.components.AxisLengthBatch(np.full(n, style[0], np.float32)),
            rr.TransformAxes3D.descriptor_axis_length(),
            n,
        )
    ]


def _point_archetype(v: np.ndarray, style: tuple[Any, ...]) -> Any:
    radius, color, label = style
    return rr.Points3D.from_fields(
        positions=v,
        radii=[radius],
        colors=[color],
        labels=None if label is None else [label],
    )


_SCALAR = _RowKind(
    width=1,
    columns=lambda v, lengths: [
        rr.components.ScalarBatch(v[:, 0])
        .described(rr.Scalars.descriptor_scalars())
        .partition(lengths)
    ],
    style_columns=_no_style,
    archetype=lambda v, style: rr.Scalars(v[:, 0]),
)
_POINT = _RowKind(
    width=3,
    columns=lambda v, lengths: [
        rr.components.Position3DBatch(v)
        .described(rr.Points3D.descriptor_positions())
        .partition(lengths)
    ],
    style_columns=_point_style_columns,
    archetype=_point_archetype,
)
#: A frame: Transform3D, with its axes' length as style (none for no axes).
_TRANSFORM = _pose_kind(
    rr.Transform3D.descriptor_translation(), rr.Transform3D.descriptor_quaternion(), axes=True
)
#: The per-instance poses of each primitive.
_INSTANCE_POSES = {a: _pose_kind(*fields) for a, fields in _INSTANCE_POSE_FIELDS.items()}
#: Body frames: the poses of their markers.
_BODY_FRAME = _INSTANCE_POSES[rr.Ellipsoids3D]


def _pose_batches_of(group: GeomGroup, poses: np.ndarray) -> list[Any]:
    """The per-instance poses (n, 7) [p, q_wxyz] of ``group``'s primitive, as
    component batches."""
    return _pose_batches(poses, *_INSTANCE_POSE_FIELDS[group.archetype])


class _Outbox:
    """Buffered rows of many entities, sent with one ``rr.send_chunks``.

    Rows of one kind (all poses, all scalars, ...) that share their time stamps
    are serialized together by rerun's component batches and sliced per entity
    (zero-copy); each entity's slices become one chunk
    (:meth:`rerun.chunk.Chunk.from_columns`, ~20 us an entity, about half of
    ``Chunk.from_record_batch`` on one batch of all entities and a third of one
    ``send_columns`` per entity).
    """

    def __init__(self) -> None:
        # (timelines, their kinds, time stamps) ->
        #     (times, kind -> [(paths, rows, style)]),
        # rows: (entities x time stamps x instances x width), entity-major
        self._groups: dict[
            tuple[Any, ...],
            tuple[np.ndarray, dict[_RowKind, list[tuple[tuple[str, ...], np.ndarray, Any]]]],
        ] = {}
        # (path, component) -> (descriptor, one-row list array): static data,
        # a later value of the same component replaces the earlier one
        self._static: dict[tuple[str, str], tuple[Any, pa.Array]] = {}

    def add_static(self, path: str, *archetypes: Any) -> None:
        """Queue ``archetypes`` (or lists of described component batches) as
        static data of ``path``."""
        for archetype in archetypes:
            batches = (
                archetype.as_component_batches()
                if hasattr(archetype, "as_component_batches")
                else archetype
            )
            for batch in batches:
                d, values = batch.component_descriptor(), batch.as_arrow_array()
                offsets = pa.array([0, len(values)], pa.int32())
                self._static[(path, d.component)] = (d, pa.ListArray.from_arrays(offsets, values))

    def add(
        self,
        paths: tuple[str, ...],
        names: tuple[str, ...],
        kinds: tuple[str, ...],
        times: np.ndarray,
        kind: _RowKind,
        rows: np.ndarray,
        style: tuple[Any, ...] = (),
    ) -> None:
        """Queue the rows of the entities ``paths`` at ``times`` (time stamps x
        timelines, values of the timelines ``names``); ``rows`` is (entities x
        time stamps x instances x ``kind.width``), ``style`` goes with each row."""
        key = (names, kinds, times.tobytes())
        group = self._groups.get(key)
        if group is None:
            group = self._groups[key] = (times, {})
        group[1].setdefault(kind, []).append((paths, rows, style))

    def send(self, stream: rr.RecordingStream) -> None:
        """Send every queued row (one chunk per entity and time stamps, one per
        entity of static data) and empty the box."""
        static: dict[str, list[_ListColumn]] = {}
        for (path, _), (d, array) in self._static.items():
            static.setdefault(path, []).append(_ListColumn(d, array))
        self._static.clear()
        chunks = [Chunk.from_columns(path, [], cols) for path, cols in static.items()]
        for (names, kinds, _), (times, by_kind) in self._groups.items():
            n = len(times)
            columns: dict[str, list[_ListColumn]] = {}
            for kind, entries in by_kind.items():
                paths = [p for entry_paths, _, _ in entries for p in entry_paths]
                stacked = np.concatenate([r.reshape(-1, kind.width) for _, r, _ in entries])
                lengths = np.concatenate(
                    [np.full(r.shape[0] * r.shape[1], r.shape[2]) for _, r, _ in entries]
                )
                for col in kind.columns(stacked, lengths):
                    d, array = col.component_descriptor(), col.as_arrow_array()
                    for i, path in enumerate(paths):
                        columns.setdefault(path, []).append(_ListColumn(d, array.slice(i * n, n)))
                for entry_paths, _, style in entries:
                    # the same style column (n equal rows) for each entity
                    for col in kind.style_columns(style, n):
                        styled = _ListColumn(col.component_descriptor(), col.as_arrow_array())
                        for path in entry_paths:
                            columns.setdefault(path, []).append(styled)
            index = _time_columns(names, kinds, times)
            chunks += [Chunk.from_columns(path, index, cols) for path, cols in columns.items()]
        self._groups.clear()
        if chunks:
            rr.send_chunks(chunks, recording=stream)


@dataclass(frozen=True)
class _ListColumn:
    """A component column already in Arrow form (one list entry per row), with
    the interface of ``rr.ComponentColumn`` that ``Chunk.from_columns`` reads."""

    descriptor: Any  # rr.ComponentDescriptor
    array: pa.Array

    def component_descriptor(self) -> Any:
        return self.descriptor

    def as_arrow_array(self) -> pa.Array:
        return self.array


@dataclass
class _Block:
    """Buffered rows of a fixed tuple of entities of one kind on one set of
    timelines, stored densely: ``values[row, entity]`` is one entity's row
    (instances x width)."""

    paths: tuple[str, ...]
    kind: _RowKind
    style: tuple[Any, ...]
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    capacity: int
    instances: int
    times: list[tuple[float, ...]] = field(default_factory=list)
    values: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        shape = (self.capacity, len(self.paths), self.instances, self.kind.width)
        self.values = np.empty(shape)

    def append(self, time: tuple[float, ...], rows: np.ndarray) -> bool:
        """Buffer ``rows`` (entities x instances x width) at ``time``; True when full."""
        self.values[len(self.times)] = rows
        self.times.append(time)
        return len(self.times) >= self.capacity

    def buffered(self) -> tuple[np.ndarray, np.ndarray]:
        """(times (rows x timelines), values (rows x entities x instances x width))."""
        n = len(self.times)
        return np.asarray(self.times, dtype=float).reshape(n, -1), self.values[:n]

    def drain(self, outbox: _Outbox, frames: _BodyFrames | None = None) -> None:
        """Move the buffered rows to ``outbox``; if these are the body poses of
        ``frames``, the poses of the geoms they carry too (all rows at once)."""
        if not self.times:
            return
        times, values = self.buffered()
        outbox.add(
            self.paths,
            self.names,
            self.kinds,
            times,
            self.kind,
            values.transpose(1, 0, 2, 3),
            self.style,
        )
        if frames is not None:
            for group, poses in frames.geometry(values[:, 0]):
                kind = _INSTANCE_POSES[group.archetype]
                outbox.add((group.path,), self.names, self.kinds, times, kind, poses[None])
        self.times.clear()


@dataclass
class _BodyFrames:
    """The frames of the moving bodies of the robot (or of the scene), and the
    geometry they carry: its instance poses follow from the body poses."""

    path: str
    ids: np.ndarray  # body ids, one instance each
    groups: list[GeomGroup]  # the moving geom groups on these bodies
    instances: InstancePoses

    def geometry(self, frames: np.ndarray) -> list[tuple[GeomGroup, np.ndarray]]:
        """Each group with its (rows, k, 7) poses, from body poses (rows, bodies, 7)."""
        return list(zip(self.groups, self.instances(frames), strict=True))


# ---------------------------------------------------------------------------
# Recorder


def _check_flush_every(flush_every: int) -> None:
    if isinstance(flush_every, bool) or not isinstance(flush_every, (int, np.integer)):
        raise InvalidInput(f"flush_every must be an integer >= 1, got {flush_every!r}")
    if flush_every < 1:
        raise InvalidInput(f"flush_every must be an integer >= 1, got {flush_every}")


class Recorder:
    """Logs pik_mj data to an explicit rerun recording stream.

    Per-iteration data (body poses, frames, points, scalars) and static data
    (geometry) are buffered; every buffer is sent, in one call, when one
    entity holds ``flush_every`` rows, and on :meth:`flush` /
    :meth:`send_buffered` / :meth:`close` / leaving the ``with`` block (also when
    the block raised). ``flush_every=1`` logs each row at once (for a live
    viewer; ~60 us per entity per row instead of ~1 us buffered).

    Time is set with :meth:`set_time` (or by :meth:`log_body_poses`); set it
    through the Recorder, not on the stream, so buffered rows carry it.

    Args:
        stream: The recording stream to log to (never the global one).
        flush_every: Rows buffered per entity before they are sent (>= 1).
        owns_stream: Whether :meth:`close` disconnects ``stream`` (finalizing its
            file sinks). A stream you pass in is only flushed by default.
        paths: Entity-path table.
    """

    def __init__(
        self,
        stream: rr.RecordingStream,
        *,
        flush_every: int = 256,
        owns_stream: bool = False,
        paths: EntityPaths = PATHS,
    ):
        if not isinstance(stream, rr.RecordingStream):
            raise InvalidInput(
                f"stream must be a rerun.RecordingStream, got {type(stream).__name__}"
            )
        _check_flush_every(flush_every)
        self.stream = stream
        self.paths = paths
        self.flush_every = int(flush_every)
        self.owns_stream = owns_stream
        self.closed = False
        # Current time: timeline -> value, and its kind (fixed once used).
        self._time: dict[str, float] = {}
        self._kinds: dict[str, str] = dict(TIMELINES)
        self._time_key: tuple[tuple[str, ...], tuple[str, ...]] = ((), ())
        self._time_vals: tuple[float, ...] = ()
        self._stream_time_dirty = False
        # (entity paths, timelines, style) -> their buffered rows
        self._blocks: dict[tuple[Any, ...], _Block] = {}
        self._outbox = _Outbox()
        self._error_paths: dict[tuple[tuple[int, str], ...], tuple[str, ...]] = {}
        # Filled by log_model_geometry.
        self._model: mujoco.MjModel | None = None
        self._frames: dict[tuple[str, ...], _BodyFrames] = {}  # by (path,)
        self.skipped_geoms: list[str] = []

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
        return cls(stream, flush_every=flush_every, owns_stream=True)

    # -- lifetime ---------------------------------------------------------------

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
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

    def close(self) -> None:
        """Send the buffered rows; disconnect the stream if this Recorder owns it
        (which flushes it and finalizes its file), else flush it. Idempotent."""
        if self.closed:
            return
        try:
            self._send_buffers()
            if not self.owns_stream:
                self.stream.flush()
        finally:
            self.closed = True
            if self.owns_stream:
                self.stream.disconnect()

    def _send_buffers(self) -> None:
        """Send every buffered row of every entity, and pending static data, in
        one call."""
        for block in self._blocks.values():
            block.drain(self._outbox, self._frames.get(block.paths))
        self._outbox.send(self.stream)

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
        self.stream.log(path, *archetypes, static=static, strict=True)

    def _log_static(self, path: str, *archetypes: Any) -> None:
        """Static data of ``path``: sent with the buffered rows (at once when
        unbuffered, ``flush_every=1``)."""
        self._check_open()
        if self.flush_every == 1:
            self._log(path, *archetypes, static=True)
        else:
            self._outbox.add_static(path, *archetypes)

    def _append(
        self,
        paths: tuple[str, ...],
        rows: np.ndarray,
        kind: _RowKind,
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
            block = self._blocks[key] = _Block(
                paths, kind, style, names, kinds, self.flush_every, rows.shape[1]
            )
        if block.append(self._time_vals, rows):
            self._send_buffers()

    # -- geometry -------------------------------------------------------------

    def log_model_geometry(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData | None = None,
        *,
        robot_root_body: str | None = None,
        geom_groups: Iterable[int] = (0, 1, 2),
        plane_half_size: float = 5.0,
    ) -> None:
        """Log every visible geom of ``model`` once, static, grouped by kind.

        Bodies in the subtree of ``robot_root_body`` are the robot, the others
        scene; with no root given, every body but the world body is robot. The
        geoms of one primitive kind share an entity (:meth:`EntityPaths.geoms`),
        one instance per geom labelled with its name: the robot's, the scene's
        welded to the world (static poses, from ``data`` here), and the scene's on
        free, jointed or mocap bodies. The moving ones get their poses, and the
        body frames theirs (:meth:`EntityPaths.bodies`), from
        :meth:`log_body_poses`. See :mod:`pik_mj.record_geometry`.

        Args:
            model: The MuJoCo model.
            data: Source of the poses of welded scene bodies (must hold forward
                kinematics). Default: a fresh ``MjData`` with ``mj_kinematics``.
            robot_root_body: Name of the robot's root body, or None.
            geom_groups: Geom groups to show (MuJoCo shows 0-2 by default;
                dm_control puts collision geoms in group 3).
            plane_half_size: Half extent [m] drawn for infinite planes.
        """
        self._check_open()
        groups = {int(g) for g in geom_groups}
        if not groups <= set(range(mujoco.mjNGROUP)):
            raise InvalidInput(
                f"geom_groups must be in 0..{mujoco.mjNGROUP - 1}, got {sorted(groups)}"
            )
        if not (math.isfinite(plane_half_size) and plane_half_size > 0):
            raise InvalidInput(f"plane_half_size must be > 0 [m], got {plane_half_size}")
        body_names = _unique_names("body", [model.body(b).name for b in range(model.nbody)])
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
            robot = _subtree(model, root)
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

        self._log_static(self.paths.world, rr.ViewCoordinates.RIGHT_HAND_Z_UP)
        geom_names = _unique_names("geom", [model.geom(g).name for g in range(model.ngeom)])
        found, self.skipped_geoms = record_geometry.geom_groups(
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
            self._log_static(group.path, group.shape, _pose_batches_of(group, poses[0]))
        self._frames = {}
        for is_robot in (True, False):
            ids = np.flatnonzero(moving & (robot if is_robot else ~robot))
            if len(ids):
                path = self.paths.bodies(robot=is_robot)
                self._log_static(path, _body_markers([body_names[b] for b in ids]))
                carried = [g for g in found if g.moving and g.robot == is_robot]
                for group in carried:
                    self._log_static(group.path, group.shape)
                instances = InstancePoses(model, carried, ids)
                self._frames[(path,)] = _BodyFrames(path, ids, carried, instances)
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
        # buffered, the geoms' poses follow from these rows when they are sent
        for frames, poses in rows:
            self._append((frames.path,), poses, _BODY_FRAME)
            if self.flush_every == 1:
                for group, instances in frames.geometry(poses[None]):
                    self._append((group.path,), instances[0], _INSTANCE_POSES[group.archetype])

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
        self._append((path,), p.reshape(1, 3), _POINT, style)

    def log_com(self, p_WC: npt.ArrayLike, target: npt.ArrayLike | None = None) -> None:
        """Log the centre of mass ``p_WC`` [m] and, if given, its target [m]."""
        self.log_point(self.paths.com, p_WC, radius=0.03, color=(230, 40, 40))
        if target is not None:
            self.log_point(self.paths.com_target, target, radius=0.025, color=(40, 200, 40))

    def log_polygon(
        self,
        vertices: npt.ArrayLike,
        margin_vertices: npt.ArrayLike | None = None,
        *,
        path: str | None = None,
        color: Sequence[int] = (40, 120, 255),
    ) -> None:
        """Log a polygon outline (closed loop) and optionally its margin outline.

        Args:
            vertices: (m, 3) vertices in order around the polygon [m]; the loop
                is closed here. m = 0 clears the outline.
            margin_vertices: (k, 3) shrunk outline, logged at ``<path>/margin``.
            path: Entity path; default :attr:`EntityPaths.support_polygon`.
            color: RGB(A) of the outline.
        """
        path = self.paths.support_polygon if path is None else path
        loops = [(path, vertices, color)]
        if margin_vertices is not None:
            loops.append((f"{path}/margin", margin_vertices, (255, 140, 0)))
        for p, verts, c in loops:
            v = _vec(verts, (-1, 3), "polygon vertices of", p)
            strips = [np.vstack([v, v[:1]])] if len(v) else []
            self._log(p, rr.LineStrips3D(strips, colors=[tuple(c)], radii=[0.005]))

    def log_contacts(
        self,
        points: npt.ArrayLike,
        forces: npt.ArrayLike,
        scale: float = 1e-3,
    ) -> None:
        """Log contact points [m] and forces [N] drawn as arrows of ``scale`` [m/N].

        .. math::
            \\text{arrow}_i = s \\, f_i
        """
        p = _vec(points, (-1, 3), "contact points")
        f = _vec(forces, (len(p), 3), "contact forces")
        if not (math.isfinite(scale) and scale > 0):
            raise InvalidInput(f"contact force scale must be > 0 [m/N], got {scale}")
        self._log(
            self.paths.contact_points,
            rr.Points3D(p, radii=[0.01], colors=[(255, 0, 255)]),
        )
        self._log(
            self.paths.contact_forces,
            rr.Arrows3D(origins=p, vectors=f * scale, colors=[(255, 0, 255)]),
        )

    def log_frame(
        self,
        path: str,
        p: npt.ArrayLike,
        quat_wxyz: npt.ArrayLike,
        axis_length: float = 0.1,
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
        axis_length: float = 0.1,
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
        self._append(paths, poses, _TRANSFORM, (length,))

    def log_scalar(self, path: str, value: float) -> None:
        """Log one value of the scalar series at ``path`` (buffered)."""
        v = float(value)
        if not math.isfinite(v):
            raise InvalidInput(f"scalar {path!r} must be finite, got {value}")
        self._append((path,), np.array([[v]]), _SCALAR)

    def log_task_errors(self, errors: Mapping[tuple[int, str], float]) -> None:
        """Log each task's error at ``errors/level_<k>/<task>``.

        Args:
            errors: ``{(level, task_name): error}``; the error is whatever scalar
                the caller tracks (e.g. the squared error ``‖e‖²``). The same
                keys every iteration keep the series in one buffer.
        """
        keys = tuple(errors)
        paths = self._error_paths.get(keys)
        if paths is None:
            paths = self._error_paths[keys] = tuple(
                self.paths.task_error(level, name) for level, name in keys
            )
        values = np.fromiter(errors.values(), dtype=float, count=len(keys))
        if not np.isfinite(values).all():
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise InvalidInput(f"scalar {paths[bad]!r} must be finite, got {values[bad]}")
        self._append(paths, values.reshape(-1, 1), _SCALAR)

    def log_text(self, message: str, level: str = "INFO") -> None:
        """Log ``message`` to the run's text log at the current time."""
        if level not in _TEXT_LEVELS:
            raise InvalidInput(f"text level must be one of {_TEXT_LEVELS}, got {level!r}")
        self._log(self.paths.events, rr.TextLog(str(message), level=level))

    def send_blueprint(self, levels: Iterable[int], extra: Sequence[tuple[str, str]] = ()) -> None:
        """Send :func:`blueprint` of ``levels`` (and ``extra`` series) with the stream
        (made active)."""
        self._check_open()
        self.stream.send_blueprint(blueprint(list(levels), self.paths, extra=extra))


def blueprint(
    levels: Sequence[int],
    paths: EntityPaths = PATHS,
    *,
    extra: Sequence[tuple[str, str]] = (),
) -> rrb.Blueprint:
    """Viewer layout: the 3D ``world`` view beside one time series per level.

    Args:
        levels: Priority levels whose error series get a view.
        paths: Entity-path table.
        extra: More time-series views ``(origin, name)`` below the level views
            (e.g. ``(paths.balance, "balance")``).
    """
    view3d = rrb.Spatial3DView(origin=paths.world, name="world")
    series = [
        rrb.TimeSeriesView(origin=paths.level_errors(k), name=f"level {int(k)} errors")
        for k in levels
    ] + [rrb.TimeSeriesView(origin=origin, name=name) for origin, name in extra]
    if not series:
        return rrb.Blueprint(view3d)
    return rrb.Blueprint(rrb.Horizontal(view3d, rrb.Vertical(*series), column_shares=[2, 1]))


# ---------------------------------------------------------------------------
# Reading recordings back


@dataclass
class EntityData:
    """What a recording holds for one entity.

    Attributes:
        static: Component (e.g. ``"Boxes3D:half_sizes"``) -> its last static batch.
        temporal: Component -> rows ``(times, batch)``, ``times`` a dict timeline ->
            value (sequence: int; duration: seconds; timestamp: ns).
    """

    static: dict[str, list[Any]] = field(default_factory=dict)
    temporal: dict[str, list[tuple[dict[str, float], list[Any]]]] = field(default_factory=dict)

    def series(self, component: str, timeline: str) -> tuple[np.ndarray, list[Any]]:
        """(times, batches) of ``component`` on ``timeline``, sorted by time."""
        if component not in self.temporal:
            raise UnknownName("component", component, self.temporal)
        rows = [(t[timeline], v) for t, v in self.temporal[component] if timeline in t]
        rows.sort(key=lambda r: r[0])
        return np.array([r[0] for r in rows]), [r[1] for r in rows]


def read_recording(path: str | Path, *, blueprint: bool = False) -> dict[str, EntityData]:
    """Load the first recording of an ``.rrd`` file into ``{entity_path: data}``.

    Entity paths are as logged (no leading ``/``). Uses ``rerun.chunk.RrdReader``.

    Args:
        path: The ``.rrd`` file.
        blueprint: Read the file's active blueprint (the last one sent) instead of
            its recording.
    """
    import pyarrow as pa
    from rerun.chunk import RrdReader

    path = Path(path)
    if not path.is_file():
        raise InvalidInput(f"recording {str(path)!r} does not exist")
    reader = RrdReader(path)
    store = None
    if blueprint:
        stores = reader.blueprints()
        if not stores:
            raise InvalidInput(f"recording {str(path)!r} holds no blueprint")
        # each send_blueprint makes a store with a random id, listed in no set
        # order: the viewer shows the last one sent, so take the newest
        store = max(stores, key=lambda st: _newest_timestamp(reader, st))
    out: dict[str, EntityData] = {}
    for chunk in reader.stream(store=store).to_chunks():
        entity = out.setdefault(chunk.entity_path.lstrip("/"), EntityData())
        batch = chunk.to_record_batch()
        index: dict[str, list[float]] = {}
        data_cols: dict[str, list[Any]] = {}
        for i, f in enumerate(batch.schema):
            kind = (f.metadata or {}).get(b"rerun:kind", b"").decode()
            col = batch.column(i)
            if kind == "index":
                if pa.types.is_duration(f.type):
                    ns = col.cast(pa.int64()).to_numpy(zero_copy_only=False)
                    index[f.name] = (ns * 1e-9).tolist()
                elif pa.types.is_timestamp(f.type):
                    index[f.name] = col.cast(pa.int64()).to_pylist()
                else:
                    index[f.name] = col.to_pylist()
            elif kind == "data":
                data_cols[f.name] = col.to_pylist()
        for name, values in data_cols.items():
            if chunk.is_static:
                for v in values:
                    if v is not None:
                        entity.static[name] = v
                continue
            rows = entity.temporal.setdefault(name, [])
            for r, v in enumerate(values):
                if v is not None:
                    rows.append(({tl: index[tl][r] for tl in index}, v))
    return out


def _newest_timestamp(reader: Any, store: Any) -> int:
    """Latest timestamp index (ns) over ``store``'s chunks; blueprints are stamped
    with the time they were sent."""
    import pyarrow as pa

    newest = -1
    for chunk in reader.stream(store=store).to_chunks():
        batch = chunk.to_record_batch()
        for i, f in enumerate(batch.schema):
            if pa.types.is_timestamp(f.type) and len(batch.column(i)):
                newest = max(newest, int(max(batch.column(i).cast(pa.int64()).to_pylist())))
    return newest
