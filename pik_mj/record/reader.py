"""Reading recordings back: ``{entity path: EntityData}`` from an ``.rrd`` file.

Uses ``rerun.chunk.RrdReader`` (rerun 0.41) and the chunks' Arrow record batches.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader

from ..exceptions import InvalidInput, UnknownName

__all__ = ["EntityData", "read_recording"]


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
    newest = -1
    for chunk in reader.stream(store=store).to_chunks():
        batch = chunk.to_record_batch()
        for i, f in enumerate(batch.schema):
            if pa.types.is_timestamp(f.type) and len(batch.column(i)):
                newest = max(newest, int(max(batch.column(i).cast(pa.int64()).to_pylist())))
    return newest
