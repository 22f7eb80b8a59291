"""A sweep's results on disk: a Parquet dataset written one batch file at a time.

Layout of a sweep directory::

    sweep.json                            the sweep definition (Sweep.to_dict)
    runs.jsonl                            one line per run: workers, cases, wall time
    rows/part-<first case>-<id>.parquet   one file per finished batch of cases

``rows/`` is the Parquet dataset (``pyarrow.dataset.dataset(OUT / "rows")``,
pandas, polars, DuckDB read it). A batch file is written under a hidden name
(``.tmp-…``, which dataset readers skip) and renamed into place (``os.replace``,
atomic), so a killed sweep leaves whole batch files only. Each row is
one case: its identity (``case``, ``robot``, ``stack``, ``point``, ``seed``, one
column per parameter), its :data:`RESULT_FIELDS` (null when the case raised),
``verdict``, ``error``, ``traceback``, ``worker`` (``host:pid``) and ``cpu_time``
(CPU time [s] of the worker process on the case: with the wall times, how much of
a core it had). :data:`UNREPEATABLE` lists the columns that differ between two
runs of one case.
"""

from __future__ import annotations

import json
import os
import uuid
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pyarrow as pa

from pik_mj.exceptions import InvalidInput
from pik_mj.sweep.spec import Case, Sweep

SWEEP_FILE = "sweep.json"
RUNS_FILE = "runs.jsonl"
ROWS_DIR = "rows"
PART_GLOB = "part-*.parquet"

_F64, _LIST_F64, _LIST_STR = pa.float64(), pa.list_(pa.float64()), pa.list_(pa.string())

RESULT_FIELDS = (
    pa.field("converged", pa.bool_()),  # every checked task satisfied at the end
    pa.field("iterations", pa.int32()),  # IK iterations run
    pa.field("hand_error", _F64),  # [m] hand end frame to target at the end
    pa.field("level_errors", _LIST_F64),  # final squared error of levels 1..K
    pa.field("hand", _LIST_F64),  # (3,) [m] hand end frame at the end
    pa.field("com", _LIST_F64),  # (3,) [m] CoM of the final pose
    pa.field("static_feasible", pa.bool_()),  # contact forces balance gravity
    pa.field("static_margin", _F64),  # [m] CoM margin to the contacts' polygon
    pa.field("motion_passed", pa.bool_()),  # the iterates played in physics: the verdict
    pa.field("motion_failures", _LIST_STR),  # one line per failed motion criterion
    pa.field("motion_drift", _F64),  # [m] largest root distance to the motion's reference
    pa.field("hold_passed", pa.bool_()),  # the hold's verdict
    pa.field("hold_failures", _LIST_STR),  # one line per failed hold criterion
    pa.field("drift", _F64),  # [m] largest root displacement in the hold
    pa.field("slip", _F64),  # [m] largest foot slip in the hold
    pa.field("hold_min_margin", _F64),  # [m] smallest CoM margin in the hold
    pa.field("fell", pa.bool_()),  # the hold fell: trunk tilt, root drift or height
    pa.field("unexpected_contacts", _LIST_STR),  # "robot_geom-other_geom"
    pa.field("qpos", _LIST_F64),  # the final configuration (the robot's nq)
    pa.field("path", pa.list_(_LIST_F64)),  # the iterates' configurations, first to last
    pa.field("solve_time", _F64),  # [s] wall time of the IK solve
    pa.field("static_time", _F64),  # [s] wall time of the static check
    pa.field("motion_time", _F64),  # [s] wall time of the motion playback
    pa.field("hold_time", _F64),  # [s] wall time of the physics hold
)
"""Columns a :class:`pik_mj.sweep.case.Worker` fills (its ``run`` returns them)."""

VERDICTS = {
    "validated": "reached, static check, motion and hold passed",
    "held": "reached, static check and hold passed, but the motion failed (a hold alone)",
    "fails": "reached, but the static check or the hold failed",
    "unreached": "IK did not converge",
    "error": "the case raised",
}
"""The ``verdict`` column's values, in the order the views list them."""

UNREPEATABLE = ("solve_time", "static_time", "motion_time", "hold_time", "worker", "cpu_time")
"""Columns that differ between two runs of the same case (times, process)."""


def schema(parameters: Sequence[str]) -> pa.Schema:
    """The row schema of a sweep over ``parameters``."""
    ident = [
        pa.field("case", pa.int64()),
        pa.field("robot", pa.string()),
        pa.field("stack", pa.string()),
        pa.field("point", pa.int64()),
        pa.field("seed", pa.int64()),
        *(pa.field(p, _F64) for p in parameters),
    ]
    tail = [
        pa.field("verdict", pa.string()),
        pa.field("error", pa.string()),
        pa.field("traceback", pa.string()),
        pa.field("worker", pa.string()),
        pa.field("cpu_time", _F64),
    ]
    return pa.schema([*ident, *RESULT_FIELDS, *tail])


def verdict(result: Mapping[str, Any] | None) -> str:
    """The :data:`VERDICTS` key of a case's result (None: the case raised)."""
    if result is None:
        return "error"
    if not result["converged"]:
        return "unreached"
    if not (result["static_feasible"] and result["hold_passed"]):
        return "fails"
    return "validated" if result["motion_passed"] else "held"


def make_row(
    case: Case,
    result: Mapping[str, Any] | None,
    worker: str,
    error: str | None = None,
    traceback: str | None = None,
    cpu_time: float | None = None,
) -> dict[str, Any]:
    """One row: the case's identity, its result (None: every result column null)."""
    row: dict[str, Any] = {
        "case": case.index,
        "robot": case.robot,
        "stack": case.stack,
        "point": case.point,
        "seed": case.seed,
        **case.params,
    }
    if result is not None:
        missing = [f.name for f in RESULT_FIELDS if f.name not in result]
        if missing:
            raise InvalidInput(f"the worker's result lacks the columns {missing}")
    for f in RESULT_FIELDS:
        row[f.name] = None if result is None else result[f.name]
    row.update(
        verdict=verdict(result), error=error, traceback=traceback, worker=worker, cpu_time=cpu_time
    )
    return row


class Dataset:
    """A sweep directory (see the module docstring).

    Args:
        path: The directory.
        sweep: The sweep it holds.
    """

    def __init__(self, path: str | os.PathLike[str], sweep: Sweep):
        self.path = Path(path)
        self.rows = self.path / ROWS_DIR
        self.sweep = sweep
        self.schema = schema(sweep.parameters)

    @classmethod
    def check(
        cls, path: str | os.PathLike[str], sweep: Sweep | None = None, *, resume: bool = False
    ) -> Sweep:
        """The sweep :meth:`open` would open in ``path``, checked without writing.

        Raises:
            InvalidInput: ``path`` holds a sweep and ``resume`` is False; it holds
                another sweep than ``sweep``; ``resume`` without a sweep there and
                none given; ``path`` is a file, a non-empty directory holding no
                sweep, or below a file.
        """
        p = Path(path)
        stored = cls.stored_sweep(p)
        if stored is not None:
            if not resume:
                raise InvalidInput(
                    f"{str(p)!r} already holds a sweep: resume it (--resume) or choose "
                    f"another directory"
                )
            if sweep is not None and sweep != stored:
                raise InvalidInput(
                    f"{str(p)!r} holds another sweep ({stored.to_dict()}) than the one "
                    f"given ({sweep.to_dict()})"
                )
            return stored
        if sweep is None:
            raise InvalidInput(f"{str(p)!r} holds no sweep to resume ({SWEEP_FILE} is missing)")
        if p.exists() and (not p.is_dir() or any(p.iterdir())):
            raise InvalidInput(f"{str(p)!r} exists and is not an empty directory")
        parent = p.absolute().parent
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise InvalidInput(f"{str(p)!r} cannot be made: {str(parent)!r} is a file")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise InvalidInput(f"{str(p)!r} cannot be made: {str(parent)!r} is not writable")
        return sweep

    @classmethod
    def open(
        cls, path: str | os.PathLike[str], sweep: Sweep | None = None, *, resume: bool = False
    ) -> Dataset:
        """Create the directory for ``sweep``, or (``resume``) reopen it.

        Raises:
            InvalidInput: As :meth:`check`.
        """
        p = Path(path)
        checked = cls.check(p, sweep, resume=resume)
        if cls.stored_sweep(p) is not None:
            for tmp in (p / ROWS_DIR).glob(".tmp-*"):  # a batch cut short by a kill
                tmp.unlink()
            return cls(p, checked)
        try:
            (p / ROWS_DIR).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InvalidInput(f"{str(p)!r} cannot be made: {exc.strerror or exc}") from None
        _write_atomic(p / SWEEP_FILE, json.dumps(checked.to_dict(), indent=2).encode())
        return cls(p, checked)

    @staticmethod
    def stored_sweep(path: str | os.PathLike[str]) -> Sweep | None:
        """The sweep stored in directory ``path``, or None."""
        f = Path(path) / SWEEP_FILE
        if not f.is_file():
            return None
        try:
            return Sweep.from_dict(json.loads(f.read_text()))
        except json.JSONDecodeError as exc:
            raise InvalidInput(f"{str(f)!r} is not JSON: {exc}") from None

    def parts(self) -> list[Path]:
        return sorted(self.rows.glob(PART_GLOB))

    def write(self, rows: Sequence[Mapping[str, Any]]) -> Path:
        """Write ``rows`` as one batch file (atomically); returns its path."""
        import pyarrow.parquet as pq  # Parquet's modules load with a sweep, not with pik-mj

        table = pa.Table.from_pylist(list(rows), schema=self.schema)
        first = min(r["case"] for r in rows)
        final = self.rows / f"part-{first:08d}-{uuid.uuid4().hex[:8]}.parquet"
        tmp = self.rows / f".tmp-{final.name}"
        pq.write_table(table, tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, final)
        return final

    def table(self) -> pa.Table:
        """Every row written so far, sorted by case."""
        import pyarrow.dataset as pads  # as pyarrow.parquet in write

        parts = self.parts()
        if not parts:
            return self.schema.empty_table()
        data = pads.dataset([str(p) for p in parts], schema=self.schema, format="parquet")
        return data.to_table().sort_by("case")

    def done(self) -> set[int]:
        """Indices of the cases with a row."""
        return set(self.table().column("case").to_pylist())

    def log_run(self, info: Mapping[str, Any]) -> None:
        """Append one run's figures to ``_runs.jsonl``."""
        with open(self.path / RUNS_FILE, "a") as f:
            f.write(json.dumps(dict(info)) + "\n")

    def runs(self) -> list[dict[str, Any]]:
        """The figures of every run logged so far."""
        f = self.path / RUNS_FILE
        if not f.is_file():
            return []
        return [json.loads(line) for line in f.read_text().splitlines() if line.strip()]


def read_rows(path: str | os.PathLike[str]) -> pa.Table:
    """Every row of the sweep directory ``path``, sorted by case."""
    sweep = Dataset.stored_sweep(path)
    if sweep is None:
        raise InvalidInput(f"{str(path)!r} holds no sweep ({SWEEP_FILE} is missing)")
    return Dataset(path, sweep).table()


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".tmp-{path.name}")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def comparable(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """``rows`` without the :data:`UNREPEATABLE` columns, sorted by case."""
    out = [{k: v for k, v in r.items() if k not in UNREPEATABLE} for r in rows]
    return sorted(out, key=lambda r: r["case"])
