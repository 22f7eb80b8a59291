"""Reading recordings back: ``{entity path: EntityData}`` from an ``.rrd`` file.

Uses ``rerun.chunk.RrdReader`` (rerun 0.41) and the chunks' Arrow record batches.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader

from pik_mj.exceptions import InvalidInput, UnknownName

__all__ = [
    "BlueprintLayout",
    "EntityData",
    "ViewLayout",
    "check_complete",
    "read_blueprint",
    "read_recording",
    "verify",
]

RRD_MAGIC = b"RRF2"
"""The first bytes of an ``.rrd`` file (rerun 0.41)."""
RRD_END = b"RRF2FOOT"
"""What the last 12 bytes of a complete ``.rrd`` start with: the footer's end
marker (then its 4-byte version), written when the stream is closed."""


def check_complete(path: str | Path, what: str = "recording") -> Path:
    """``path`` as a complete ``.rrd`` file: it exists, starts as an ``.rrd`` and
    ends with rerun's footer (written last, when the recording is closed: a file cut
    short by a full disk, a kill or a writer still at work has none). Reads 24 bytes.

    Raises:
        InvalidInput: No such file, not an ``.rrd`` (e.g. a text file), or
            truncated; the message says which.
    """
    p = Path(path)
    if not p.is_file():
        raise InvalidInput(f"{what} {str(p)!r} does not exist")
    size = p.stat().st_size
    with open(p, "rb") as f:
        head = f.read(len(RRD_MAGIC))
        f.seek(max(0, size - 12))
        tail = f.read(12)
    if head != RRD_MAGIC:
        raise InvalidInput(
            f"{what} {str(p)!r} is not a rerun recording (.rrd): it does not start with "
            f"{RRD_MAGIC!r}"
        )
    if not tail.startswith(RRD_END):
        raise InvalidInput(
            f"{what} {str(p)!r} is truncated: it lacks the footer rerun writes when a "
            f"recording is closed ({size} bytes; cut short by a full disk or a kill, or "
            "still being written)"
        )
    return p


def verify(path: str | Path, what: str = "recording") -> Path:
    """:func:`check_complete`, and rerun reads the footer's manifest of the file's
    chunks (``rerun.chunk.RrdReader``; about 0.1 s for 20 MB).

    Raises:
        InvalidInput: As :func:`check_complete`, or rerun cannot read the manifest.
    """
    p = check_complete(path, what)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # rerun warns where a footer is missing
            if not RrdReader(p).recordings():
                raise InvalidInput(f"{what} {str(p)!r} holds no recording")
    except (RuntimeError, Warning) as exc:
        raise InvalidInput(f"{what} {str(p)!r} cannot be read by rerun: {exc}") from None
    return p


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

    Raises:
        InvalidInput: No such file, not an ``.rrd``, truncated
            (:func:`check_complete`), or damaged.
    """
    path = check_complete(path)
    try:
        return _read(path, blueprint)
    except RuntimeError as exc:  # rerun's decoder: a damaged file
        raise InvalidInput(f"recording {str(path)!r} cannot be read by rerun: {exc}") from None


def _read(path: Path, blueprint: bool) -> dict[str, EntityData]:
    """:func:`read_recording` of a checked file."""
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
    newest = -1
    for chunk in reader.stream(store=store).to_chunks():
        batch = chunk.to_record_batch()
        for i, f in enumerate(batch.schema):
            if pa.types.is_timestamp(f.type) and len(batch.column(i)):
                newest = max(newest, int(max(batch.column(i).cast(pa.int64()).to_pylist())))
    return newest


@dataclass
class ViewLayout:
    """One view of a blueprint read back.

    Attributes:
        kind: rerun's view class (``"3D"``, ``"TimeSeries"``, ``"TextLog"``).
        name: Display name.
        origin: Space origin (an entity path).
        contents: Its query expressions (``"$origin/**"`` or entity paths; an
            exclusion starts with ``"- "``).
        timelines: Timelines of its visible time ranges.
        eye: ``{"position": (3,), "look_target": (3,)}`` of a 3D view's camera, or None.
    """

    kind: str
    name: str
    origin: str
    contents: list[str]
    timelines: list[str]
    eye: dict[str, np.ndarray] | None

    def entities(self, paths: Any) -> list[str]:
        """The entity paths among ``paths`` that the view shows: matched by an
        inclusion of its contents (``$origin/**``, ``<path>/**``, an exact path)
        and by no exclusion (``- <path>``, ``- <path>/**``)."""
        rules = [
            (not q.startswith("-"), q.replace("$origin", self.origin).lstrip("+- ").strip())
            for q in self.contents
        ]

        def matches(path: str, q: str) -> bool:
            return path == q or (q.endswith("/**") and (path == q[:-3] or path.startswith(q[:-2])))

        return [
            path
            for path in paths
            if any(keep and matches(path, q) for keep, q in rules)
            and not any(not keep and matches(path, q) for keep, q in rules)
        ]


@dataclass
class BlueprintLayout:
    """A recording's blueprint, read back (:func:`read_blueprint`).

    Attributes:
        timeline: The timeline the time panel opens on (None: rerun's choice).
        tabs: ``(name, views)`` of each tab, the active one first when the root
            is a tab container; else one entry, the root's views.
    """

    timeline: str | None
    tabs: list[tuple[str, list[ViewLayout]]]


def _last(entity: EntityData | None, component: str) -> Any:
    if entity is None or component not in entity.temporal:
        return None
    return entity.temporal[component][-1][1]


def read_blueprint(path: str | Path) -> BlueprintLayout:
    """The active blueprint of an ``.rrd`` file: its time panel's timeline and
    the views of each tab, in order.

    Raises:
        InvalidInput: No such file, or it holds no blueprint.
    """
    import uuid

    bp = read_recording(path, blueprint=True)
    panel = _last(bp.get("time_panel"), "TimePanelBlueprint:timeline")
    root = _last(bp.get("viewport"), "ViewportBlueprint:root_container")
    if root is None:
        raise InvalidInput(f"the blueprint of {str(path)!r} has no viewport")
    root_path = f"container/{uuid.UUID(bytes=bytes(root[0]))}"

    def view(key: str) -> ViewLayout:
        e = bp[key]
        eye = None
        if f"{key}/EyeControls3D" in bp:
            controls = bp[f"{key}/EyeControls3D"]
            eye = {
                name: np.array(_last(controls, f"EyeControls3D:{name}")[0], dtype=float)
                for name in ("position", "look_target")
            }
        ranges = _last(bp.get(f"{key}/VisibleTimeRanges"), "VisibleTimeRanges:ranges") or []
        return ViewLayout(
            kind=str(_last(e, "ViewBlueprint:class_identifier")[0]),
            name=str((_last(e, "ViewBlueprint:display_name") or [""])[0]),
            origin=str(_last(e, "ViewBlueprint:space_origin")[0]),
            contents=list(_last(bp.get(f"{key}/ViewContents"), "ViewContents:query") or []),
            timelines=[r["timeline"] for r in ranges],
            eye=eye,
        )

    def views(key: str) -> list[ViewLayout]:
        if key.startswith("view/"):
            return [view(key)]
        return [v for child in _last(bp[key], "ContainerBlueprint:contents") for v in views(child)]

    def name(key: str) -> str:
        return str((_last(bp[key], "ContainerBlueprint:display_name") or [key])[0])

    container = bp[root_path]
    kind = _last(container, "ContainerBlueprint:container_kind")
    if kind is not None and int(kind[0]) == 1:  # tabs
        children = list(_last(container, "ContainerBlueprint:contents"))
        active = _last(container, "ContainerBlueprint:active_tab")
        if active is not None and active[0] in children:
            children.remove(active[0])
            children.insert(0, active[0])
        tabs = [(name(child), views(child)) for child in children]
    else:
        tabs = [(name(root_path), views(root_path))]
    return BlueprintLayout(None if panel is None else str(panel[0]), tabs)
