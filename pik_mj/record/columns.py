"""rerun 0.41's chunk API, in one place: rows buffered densely and sent as chunks.

Per-iteration rows (body poses, frames, points, scalars) are buffered densely
in blocks (:class:`Block`), one per set of entities logged together. At a flush each
entity's rows become one chunk (``rerun.chunk.Chunk.from_columns``) and one
``rr.send_chunks`` sends them all (:class:`Outbox`). A :class:`RowKind` says how
rows of one archetype become columns: Arrow arrays of the types of rerun's
component batches, built directly from the stacked rows (the same columns as
``<Archetype>.columns(...)``, without building and checking every field of the
archetype per call) and sliced per entity without copies (pyarrow). A style (a
point's radius and colour, a frame's axis length) goes with each row, in the
chunk of its data: its column is made once per style and sliced.

Nothing else in pik_mj touches ``rerun.chunk`` or pyarrow for writing: a new
rerun version changes this module (and :mod:`pik_mj.record.reader`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa
import rerun as rr
from rerun.chunk import Chunk

from pik_mj.record.geometry import BodyFrames, GeomGroup

__all__ = [
    "ARROW",
    "BODY_FRAME",
    "INSTANCE_POSES",
    "POINT",
    "SCALAR",
    "TRANSFORM",
    "Block",
    "Outbox",
    "RowKind",
    "pose_batches_of",
    "xyzw",
]


def xyzw(q_wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo (w, x, y, z) -> rerun (x, y, z, w), along the last axis."""
    return q_wxyz[..., [1, 2, 3, 0]]


#: Per-instance pose components of each primitive: (translation, rotation).
INSTANCE_POSE_FIELDS: dict[Any, tuple[Any, Any]] = {
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


def time_columns(
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
class RowKind:
    """How rows of one archetype are sent: stacked in columns, or one by one.

    A row of one entity is one or more instances of ``width`` floats (a scalar,
    a point, a pose; the instances of a multi-instance primitive). Its
    style (radius and colour of a point, axis length of a frame; ``()`` for
    none) goes with every row, in the same chunk: a static style would cost a
    chunk of its own per entity.
    """

    width: int
    # (descriptor, stacked rows (instances, width) -> the component's Arrow values)
    fields: tuple[tuple[Any, Callable[[np.ndarray], pa.Array]], ...]
    style_batches: Callable[[tuple[Any, ...]], list[Any]]  # style -> one-value batches
    archetype: Callable[[np.ndarray, tuple[Any, ...]], Any]  # (instances, width) row -> ``log``

    def columns(self, v: np.ndarray, offsets: pa.Array) -> list[tuple[Any, pa.Array]]:
        """(descriptor, list column) of each component of the stacked rows ``v``
        (instances, width), row ``i`` holding instances ``offsets[i]:offsets[i+1]``."""
        return [(d, pa.ListArray.from_arrays(offsets, values(v))) for d, values in self.fields]


# Columns are built as Arrow arrays directly, of the Arrow types of rerun's
# component batches (the same columns as ``<Archetype>.columns(...)``, which
# builds and checks every field of the archetype per call).


def _arrow_type(batch: Any, zero: np.ndarray) -> pa.DataType:
    """The Arrow type of rerun's component batch class ``batch``."""
    return batch(zero).as_arrow_array().type


_VEC3 = _arrow_type(rr.components.Position3DBatch, np.zeros((1, 3)))
_QUAT = _arrow_type(rr.components.RotationQuatBatch, np.zeros((1, 4)))
_SCALAR = _arrow_type(rr.components.ScalarBatch, np.zeros(1))
if {
    _arrow_type(rr.components.Translation3DBatch, np.zeros((1, 3))),
    _arrow_type(rr.components.Vector3DBatch, np.zeros((1, 3))),
} != {_VEC3}:  # pragma: no cover - a rerun version that types them apart
    raise ImportError("pik_mj.record.columns: rerun's 3D vector components differ in type")


def _f32(v: np.ndarray, type_: pa.DataType) -> pa.Array:
    """Rows ``v`` (n, k) as a fixed-size list array of float32 of ``type_``."""
    flat = np.ascontiguousarray(v, dtype=np.float32).reshape(-1)
    return pa.FixedSizeListArray.from_arrays(pa.array(flat), type=type_)


def _pose_batches(v: np.ndarray, translation: Any, quaternion: Any) -> list[Any]:
    """Translation and rotation batches of poses ``v`` (n, 7) [p, q_wxyz],
    described as ``translation`` / ``quaternion`` (ComponentDescriptors)."""
    return [
        rr.components.Translation3DBatch(v[:, :3]).described(translation),
        rr.components.RotationQuatBatch(xyzw(v[:, 3:])).described(quaternion),
    ]


def _pose_kind(translation: Any, quaternion: Any, *, axes: bool = False) -> RowKind:
    """Rows of poses [p, q_wxyz] sent as the components ``translation`` and
    ``quaternion`` (a Transform3D, or the per-instance poses of a primitive);
    with ``axes``, a style ``(axis_length,)`` draws the frame's axes."""
    style_batches = _axes_style if axes else _no_style
    return RowKind(
        width=7,
        fields=(
            (translation, lambda v: _f32(v[:, :3], _VEC3)),
            (quaternion, lambda v: _f32(xyzw(v[:, 3:]), _QUAT)),
        ),
        style_batches=style_batches,
        archetype=lambda v, style: _pose_batches(v, translation, quaternion) + style_batches(style),
    )


def _no_style(style: tuple[Any, ...]) -> list[Any]:
    return []


def _point_style(style: tuple[Any, ...]) -> list[Any]:
    """Radius [m], colour and optional label of a point."""
    radius, color, label = style
    batches = [
        rr.components.RadiusBatch(np.full(1, radius, np.float32)).described(
            rr.Points3D.descriptor_radii()
        ),
        rr.components.ColorBatch([color]).described(rr.Points3D.descriptor_colors()),
    ]
    if label is not None:
        batches.append(rr.components.TextBatch([label]).described(rr.Points3D.descriptor_labels()))
    return batches


def _axes_style(style: tuple[Any, ...]) -> list[Any]:
    """Axis length [m] of a frame (no style: a body pose, no axes)."""
    if not style:
        return []
    return [
        rr.components.AxisLengthBatch(np.full(1, style[0], np.float32)).described(
            rr.TransformAxes3D.descriptor_axis_length()
        )
    ]


def _arrow_style(style: tuple[Any, ...]) -> list[Any]:
    """Radius [m] and colour of an arrow."""
    radius, color = style
    return [
        rr.components.RadiusBatch(np.full(1, radius, np.float32)).described(
            rr.Arrows3D.descriptor_radii()
        ),
        rr.components.ColorBatch([color]).described(rr.Arrows3D.descriptor_colors()),
    ]


def _point_archetype(v: np.ndarray, style: tuple[Any, ...]) -> Any:
    radius, color, label = style
    return rr.Points3D.from_fields(
        positions=v,
        radii=[radius],
        colors=[color],
        labels=None if label is None else [label],
    )


SCALAR = RowKind(
    width=1,
    fields=((rr.Scalars.descriptor_scalars(), lambda v: pa.array(v[:, 0], type=_SCALAR)),),
    style_batches=_no_style,
    archetype=lambda v, style: rr.Scalars(v[:, 0]),
)
POINT = RowKind(
    width=3,
    fields=((rr.Points3D.descriptor_positions(), lambda v: _f32(v, _VEC3)),),
    style_batches=_point_style,
    archetype=_point_archetype,
)
#: An arrow: [origin, vector] [m], with its radius and colour as style.
ARROW = RowKind(
    width=6,
    fields=(
        (rr.Arrows3D.descriptor_origins(), lambda v: _f32(v[:, :3], _VEC3)),
        (rr.Arrows3D.descriptor_vectors(), lambda v: _f32(v[:, 3:], _VEC3)),
    ),
    style_batches=_arrow_style,
    archetype=lambda v, style: rr.Arrows3D(
        origins=v[:, :3], vectors=v[:, 3:], radii=[style[0]], colors=[style[1]]
    ),
)
#: A frame: Transform3D, with its axes' length as style (none for no axes).
TRANSFORM = _pose_kind(
    rr.Transform3D.descriptor_translation(), rr.Transform3D.descriptor_quaternion(), axes=True
)
#: The per-instance poses of each primitive.
INSTANCE_POSES = {a: _pose_kind(*fields) for a, fields in INSTANCE_POSE_FIELDS.items()}
#: Body frames: the poses of their markers.
BODY_FRAME = INSTANCE_POSES[rr.Ellipsoids3D]

#: (id of the kind, style) -> its style's columns: (descriptor, list array of
#: rows each holding the style's value), sliced to the rows sent
_STYLES: dict[tuple[int, tuple[Any, ...]], list[tuple[Any, pa.Array]]] = {}


def _style_columns(kind: RowKind, style: tuple[Any, ...], n: int) -> list[_ListColumn]:
    """The columns of ``n`` rows each holding ``style``'s components, made once
    per kind and style (styles are few: a handful of colours and sizes) for
    as many rows as sent so far, and sliced (zero-copy)."""
    if not style:
        return []
    key = (id(kind), style)
    cached = _STYLES.get(key)
    if cached is None or (cached and len(cached[0][1]) < n):
        if len(_STYLES) > 4096:  # styles made of data (labels): do not grow forever
            _STYLES.clear()
        rows = max(n, 64 if cached is None else 2 * len(cached[0][1]))
        offsets = pa.array(np.arange(rows + 1, dtype=np.int32))
        first = pa.array(np.zeros(rows, dtype=np.int32))
        cached = _STYLES[key] = [
            (
                b.component_descriptor(),
                pa.ListArray.from_arrays(offsets, b.as_arrow_array().take(first)),
            )
            for b in kind.style_batches(style)
        ]
    return [_ListColumn(d, column.slice(0, n)) for d, column in cached]


def pose_batches_of(group: GeomGroup, poses: np.ndarray) -> list[Any]:
    """The per-instance poses (n, 7) [p, q_wxyz] of ``group``'s primitive, as
    component batches."""
    return _pose_batches(poses, *INSTANCE_POSE_FIELDS[group.archetype])


class Outbox:
    """Buffered rows of many entities, sent with one ``rr.send_chunks``.

    Rows of one kind (all poses, all scalars, ...) that share their time stamps
    become one Arrow array per component (:meth:`RowKind.columns`), sliced per
    entity (zero-copy); each entity's slices become one chunk
    (:meth:`rerun.chunk.Chunk.from_columns`), and all chunks go in one call.
    """

    def __init__(self) -> None:
        # (timelines, their kinds, time stamps) ->
        #     (times, kind -> [(paths, rows, style)]),
        # rows: (entities x time stamps x instances x width), entity-major
        self._groups: dict[
            tuple[Any, ...],
            tuple[np.ndarray, dict[RowKind, list[tuple[tuple[str, ...], np.ndarray, Any]]]],
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
        kind: RowKind,
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
            styles: dict[tuple[int, Any], list[_ListColumn]] = {}  # n rows of each style
            for kind, entries in by_kind.items():
                paths = [p for entry_paths, _, _ in entries for p in entry_paths]
                stacked = np.concatenate([r.reshape(-1, kind.width) for _, r, _ in entries])
                lengths = np.concatenate(
                    [np.full(r.shape[0] * r.shape[1], r.shape[2]) for _, r, _ in entries]
                )
                offsets = pa.array(np.concatenate([[0], np.cumsum(lengths)]), pa.int32())
                for d, array in kind.columns(stacked, offsets):
                    for i, path in enumerate(paths):
                        columns.setdefault(path, []).append(_ListColumn(d, array.slice(i * n, n)))
                for entry_paths, _, style in entries:
                    # the same style column (n equal rows) for each entity
                    styled = styles.get((id(kind), style))
                    if styled is None:
                        styled = styles[(id(kind), style)] = _style_columns(kind, style, n)
                    for path in entry_paths:
                        columns.setdefault(path, []).extend(styled)
            index = time_columns(names, kinds, times)
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
class Block:
    """Buffered rows of a fixed tuple of entities of one kind on one set of
    timelines, stored densely: ``values[row, entity]`` is one entity's row
    (instances x width)."""

    paths: tuple[str, ...]
    kind: RowKind
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

    def drain(self, outbox: Outbox, frames: BodyFrames | None = None) -> None:
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
                kind = INSTANCE_POSES[group.archetype]
                outbox.add((group.path,), self.names, self.kinds, times, kind, poses[None])
        self.times.clear()
