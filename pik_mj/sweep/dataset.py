"""A sweep's results on disk: a Parquet dataset written one batch file at a time.

Layout of a sweep directory::

    sweep.json                            the sweep definition (Sweep.to_dict)
    runs.jsonl                            one line per run: workers, cases, wall time
    rows/part-<first case>-<id>.parquet   one file per finished batch of cases
    .lock                                 held by the one process writing (pid, host)
    corrupt/                              part files set aside by a repair

One process writes a sweep directory at a time: :meth:`Dataset.open` takes
``.lock`` (:class:`pik_mj.outputs.WriterLock`; released when the writer closes
it or its process ends, also when killed) and a second writer is refused with
the holder's pid and host. Rows are keyed by ``case``: reading keeps one row per
case (a row of a case that ran, over one that raised; else the first part's), so
a case that somehow has two rows is never counted twice. A part file that cannot
be read (a truncated or foreign file) is named, and a repair moves it to
``corrupt/`` so that its cases run again. A failed start (an unknown robot, a
full disk) removes what it created.

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
import shutil
import uuid
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from pik_mj.exceptions import InvalidInput, OutputError
from pik_mj.outputs import WriterLock, write_atomic
from pik_mj.sweep.spec import Case, Sweep

SWEEP_FILE = "sweep.json"
RUNS_FILE = "runs.jsonl"
ROWS_DIR = "rows"
PART_GLOB = "part-*.parquet"
LOCK_FILE = ".lock"
CORRUPT_DIR = "corrupt"

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

    Attributes:
        lock: The writer's lock when opened by :meth:`open` (None: read only).
        created: What :meth:`open` made (removed by :meth:`discard`).
    """

    def __init__(self, path: str | os.PathLike[str], sweep: Sweep):
        self.path = Path(path)
        self.rows = self.path / ROWS_DIR
        self.sweep = sweep
        self.schema = schema(sweep.parameters)
        self.lock: WriterLock | None = None
        self.created: list[Path] = []

    @classmethod
    def check(
        cls,
        path: str | os.PathLike[str],
        sweep: Sweep | None = None,
        *,
        resume: bool = False,
        repair: bool = False,
    ) -> Sweep:
        """The sweep :meth:`open` would open in ``path``, checked without writing.

        Raises:
            InvalidInput: ``path`` holds a sweep and ``resume`` is False; it holds
                another sweep than ``sweep``; ``resume`` without a sweep there and
                none given; ``path`` is a file, a non-empty directory holding no
                sweep, or below a file; a part file cannot be read (unless
                ``repair``: it will be set aside).
            WriterBusy: Another process is writing the sweep (its pid and host named).
        """
        p = Path(path)
        if (p / LOCK_FILE).is_file():  # try the lock, and let go at once
            WriterLock(p / LOCK_FILE, "sweep directory", path=p, records_holder=True).release()
        checked = cls._check(p, sweep, resume)
        if not repair and cls.stored_sweep(p) is not None:
            cls(p, checked).corrupt_parts(raise_them=True)
        return checked

    @classmethod
    def _check(cls, p: Path, sweep: Sweep | None, resume: bool) -> Sweep:
        """:meth:`check` of the sweep and the directory (no lock, no part read)."""
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
        if p.exists() and (not p.is_dir() or any(f.name != LOCK_FILE for f in p.iterdir())):
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
        cls,
        path: str | os.PathLike[str],
        sweep: Sweep | None = None,
        *,
        resume: bool = False,
        repair: bool = False,
    ) -> Dataset:
        """Create the directory for ``sweep``, or (``resume``) reopen it, locked for
        this writer until :meth:`close`. With ``repair``, part files that cannot be
        read are moved to ``corrupt/`` (their cases have no row: they run again).

        Raises:
            InvalidInput: As :meth:`check`; the directory cannot be made.
            WriterBusy: Another process is writing the sweep.
            OutputError: The sweep file cannot be written (a full disk).
            Nothing this call made is left behind when it raises.
        """
        p = Path(path)
        checked = cls.check(p, sweep, resume=resume, repair=True)
        made = _missing_dirs(p)
        try:
            for d in made:
                d.mkdir()
        except OSError as exc:
            _remove(made)
            raise InvalidInput(f"{str(p)!r} cannot be made: {exc.strerror or exc}") from None
        new_lock = not (p / LOCK_FILE).exists()
        try:
            lock = WriterLock(p / LOCK_FILE, "sweep directory", path=p, records_holder=True)
        except BaseException:
            _remove(made)
            raise
        data = cls(p, checked)
        data.lock = lock
        data.created = [*made, *([p / LOCK_FILE] if new_lock else [])]
        try:
            data.sweep = cls._check(p, sweep, resume)  # again, holding the lock
            if cls.stored_sweep(p) is None:
                data.created += [data.rows, p / SWEEP_FILE]
                data.rows.mkdir(exist_ok=True)
                write_atomic(p / SWEEP_FILE, json.dumps(data.sweep.to_dict(), indent=2), "sweep")
            else:
                for tmp in data.rows.glob(".tmp-*"):  # a batch cut short by a kill
                    tmp.unlink()
                data.set_aside(data.corrupt_parts(raise_them=not repair))
        except BaseException:
            data.discard()
            raise
        return data

    def close(self) -> None:
        """Release the writer's lock (idempotent)."""
        if self.lock is not None:
            self.lock.release()

    def discard(self) -> None:
        """Undo a start that wrote no row: remove what :meth:`open` made (the
        sweep file, the empty ``rows/``, the lock, new directories), then release
        the lock. A sweep holding rows is kept (it can be resumed)."""
        if not self.parts():
            _remove(self.created)
        self.close()

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
        """Write ``rows`` as one batch file (atomically); returns its path.

        Raises:
            OutputError: The file cannot be written (a full disk): nothing of it
                is left, the rows written before are kept.
        """
        import pyarrow.parquet as pq  # Parquet's modules load with a sweep, not with pik-mj

        table = pa.Table.from_pylist(list(rows), schema=self.schema)
        cases = sorted(r["case"] for r in rows)
        final = self.rows / f"part-{cases[0]:08d}-{uuid.uuid4().hex[:8]}.parquet"
        buffer = pa.BufferOutputStream()
        pq.write_table(table, buffer)
        try:
            return write_atomic(final, buffer.getvalue().to_pybytes(), f"the rows of cases {cases}")
        except OutputError as exc:
            raise OutputError(
                f"sweep {str(self.path)!r}: {exc} (the rows written before are kept: free "
                "space, then --resume)"
            ) from None

    def _read_parts(self) -> tuple[list[pa.Table], list[tuple[Path, str]]]:
        """The tables of the readable part files, and the others with the reason."""
        import pyarrow.parquet as pq  # as in write

        tables, bad = [], []
        for part in self.parts():
            try:
                tables.append(pq.read_table(part, schema=self.schema))
            except (pa.ArrowException, OSError) as exc:
                bad.append((part, f"{type(exc).__name__}: {str(exc).splitlines()[0]}"))
        return tables, bad

    def corrupt_parts(self, *, raise_them: bool = False) -> list[Path]:
        """The part files that cannot be read (truncated, not Parquet, another schema).

        Raises:
            InvalidInput: With ``raise_them``, when there is one: each named with
                its reason, and the repair that sets them aside.
        """
        _, bad = self._read_parts()
        if bad and raise_them:
            listed = "; ".join(f"{p.name}: {why}" for p, why in bad)
            raise InvalidInput(
                f"sweep {str(self.path)!r} has {len(bad)} part file(s) that cannot be read "
                f"({listed}). Resume with --repair (run_sweep(..., repair=True)) to move them "
                f"to {CORRUPT_DIR}/ and run their cases again"
            )
        return [p for p, _ in bad]

    def set_aside(self, parts: Sequence[Path]) -> None:
        """Move ``parts`` to ``corrupt/`` (kept for a look; no longer read)."""
        if parts:
            (self.path / CORRUPT_DIR).mkdir(exist_ok=True)
        for part in parts:
            shutil.move(part, self.path / CORRUPT_DIR / part.name)

    def table(self) -> pa.Table:
        """Every row written so far, one per case (module docstring), sorted by case.

        Raises:
            InvalidInput: A part file cannot be read (named, with the repair).
        """
        tables, bad = self._read_parts()
        if bad:
            self.corrupt_parts(raise_them=True)
        if not tables:
            return self.schema.empty_table()
        return one_row_per_case(pa.concat_tables(tables)).sort_by("case")

    def done(self) -> set[int]:
        """Indices of the cases with a row."""
        return set(self.table().column("case").to_pylist())

    def log_run(self, info: Mapping[str, Any]) -> None:
        """Append one run's figures to ``runs.jsonl``.

        Raises:
            OutputError: It cannot be written (a full disk); the rows are kept.
        """
        try:
            with open(self.path / RUNS_FILE, "a") as f:
                f.write(json.dumps(dict(info)) + "\n")
        except OSError as exc:
            raise OutputError(
                f"sweep {str(self.path)!r}: the run's figures could not be added to "
                f"{RUNS_FILE}: {exc.strerror or exc}; the rows are kept"
            ) from None

    def runs(self) -> list[dict[str, Any]]:
        """The figures of every run logged so far."""
        f = self.path / RUNS_FILE
        if not f.is_file():
            return []
        return [json.loads(line) for line in f.read_text().splitlines() if line.strip()]


def one_row_per_case(table: pa.Table) -> pa.Table:
    """``table`` with one row per ``case``: of several, a row of a case that ran
    over one that raised, else the first (in the order of ``table``)."""
    cases = table.column("case").to_numpy()
    if len(np.unique(cases)) == len(cases):
        return table
    raised = np.asarray(table.column("verdict").to_pylist()) == "error"
    order = np.lexsort((np.arange(len(cases)), raised, cases))
    first = np.ones(len(order), dtype=bool)
    first[1:] = cases[order][1:] != cases[order][:-1]
    return table.take(pa.array(order[first]))


def _missing_dirs(p: Path) -> list[Path]:
    """The directories to make for ``p`` (itself included), outermost first."""
    made = []
    while not p.exists():
        made.append(p)
        p = p.parent
    return made[::-1]


def _remove(paths: Sequence[Path]) -> None:
    """Remove ``paths`` (files, and directories left empty), innermost last made first."""
    for f in reversed(paths):
        if f.is_file():
            f.unlink()
        elif f.is_dir() and not any(f.iterdir()):
            f.rmdir()


def read_rows(path: str | os.PathLike[str]) -> pa.Table:
    """Every row of the sweep directory ``path``, sorted by case."""
    sweep = Dataset.stored_sweep(path)
    if sweep is None:
        raise InvalidInput(f"{str(path)!r} holds no sweep ({SWEEP_FILE} is missing)")
    return Dataset(path, sweep).table()


def comparable(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """``rows`` without the :data:`UNREPEATABLE` columns, sorted by case."""
    out = [{k: v for k, v in r.items() if k not in UNREPEATABLE} for r in rows]
    return sorted(out, key=lambda r: r["case"])
