"""Run a sweep on Ray: one actor per worker, batches of cases, one Parquet file per batch.

With no address, :func:`run_sweep` starts a local Ray instance on this machine's
cores (``ray.init(address="local")``: never someone else's running instance) and
shuts it down when the sweep ends, also on an error or Ctrl-C; with ``address``
it joins that cluster (whose nodes must have pik_mj installed), giving up with
an error naming the address when it does not answer within ``connect_timeout``
(:mod:`pik_mj.sweep.cluster`). If the calling
process already has Ray initialised, the sweep uses it and leaves it running.

Each actor (one CPU) builds a :class:`pik_mj.sweep.case.Worker` per robot of
the sweep once, before its first case (a robot that cannot be built, e.g. an
unknown model or limb, stops the sweep with that error), and reuses it for
every case. The driver hands an idle actor the next batch of cases
(``batch_size``, smaller as the queue runs dry so that the workers finish
together), and writes each finished batch as one file
(:meth:`pik_mj.sweep.dataset.Dataset.write`): a killed sweep loses the batches
in flight only, and ``resume=True`` runs the cases without a row.

A case that raises becomes a row with ``verdict = "error"``, the exception in
``error`` and ``traceback``; a worker process that dies gives its batch such rows
and is replaced by a new actor.
"""

from __future__ import annotations

import importlib.util
import math
import os
import socket
import sys
import time
import traceback
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.sweep import cluster
from pik_mj.sweep.case import Worker
from pik_mj.sweep.dataset import Dataset, make_row
from pik_mj.sweep.spec import Case, Sweep
from pik_mj.sweep.views import summary_table


class SweepActor:
    """What runs in one Ray worker process: cases, batch by batch.

    Args:
        worker_class: Builds a worker per robot: ``worker_class(robot, hand=..., hold=...)``,
            with ``run(case) -> dict`` of the result columns.
        hand: Limb sent to the target.
        hold: Physics hold duration [s].
    """

    def __init__(self, worker_class: type, hand: str, hold: float):
        self.worker_class = worker_class
        self.options = {"hand": hand, "hold": hold}
        self.workers: dict[str, Any] = {}  # robot -> its worker
        self.name = f"{socket.gethostname()}:{os.getpid()}"

    def setup(self, robots: list[str]) -> str:
        """Build the worker of each robot (once per process); this process's name."""
        for robot in robots:
            if robot not in self.workers:
                try:
                    self.workers[robot] = self.worker_class(robot, **self.options)
                except PikError as exc:  # as an InvalidInput: UnknownName does not unpickle
                    raise InvalidInput(f"robot {robot!r}: {exc}") from None
        return self.name

    def run(self, cases: list[Case]) -> list[dict[str, Any]]:
        """One row per case; a case that raises gets its error, the others go on."""
        rows = []
        for case in cases:
            cpu = time.process_time()
            try:
                result = self.workers[case.robot].run(case)
            except Exception as exc:
                rows.append(make_row(case, None, self.name, _describe(exc), traceback.format_exc()))
            else:
                rows.append(make_row(case, result, self.name, cpu_time=time.process_time() - cpu))
        return rows


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


@dataclass
class SweepReport:
    """What :func:`run_sweep` did.

    Attributes:
        path: The sweep directory.
        sweep: The sweep.
        table: Every row of the dataset, sorted by case.
        ran: Cases run by this call.
        resumed: Cases that already had a row.
        workers: Worker processes used.
        wall_time: Wall time of this call's cases [s] (Ray start-up excluded).
        startup_time: Ray start-up and actor creation [s].
    """

    path: Path
    sweep: Sweep
    table: pa.Table
    ran: int
    resumed: int
    workers: int
    wall_time: float
    startup_time: float

    @property
    def errors(self) -> int:
        """Rows of cases that raised."""
        return len(self.table) - self.table.column("error").null_count

    def summary(self) -> str:
        """What ran, and :func:`pik_mj.sweep.views.summary_table` of every row."""
        head = f"sweep {self.path}: {len(self.table)}/{len(self.sweep)} cases; "
        if self.ran:
            head += (
                f"this run {self.ran} cases on {self.workers} workers in "
                f"{self.wall_time:.1f} s ({self.ran / self.wall_time:.2f} cases/s; "
                f"Ray start-up {self.startup_time:.1f} s)"
            )
        else:
            head += "nothing left to run"
        if self.resumed:
            head += f", {self.resumed} resumed from earlier runs"
        return head + "\n" + summary_table(self.table)


def run_sweep(
    sweep: Sweep | None,
    out: str | os.PathLike[str],
    *,
    workers: int | None = None,
    address: str | None = None,
    num_cpus: int | None = None,
    resume: bool = False,
    repair: bool = False,
    batch_size: int = 8,
    worker_class: type = Worker,
    progress: bool | Callable[[str], None] = True,
    connect_timeout: float = cluster.DEFAULT_CONNECT_TIMEOUT,
) -> SweepReport:
    """Run ``sweep`` into the Parquet dataset directory ``out`` on Ray.

    One process writes ``out`` at a time (:class:`pik_mj.sweep.dataset.Dataset`'s
    lock, held until the call returns); a start that fails before any row is
    written leaves nothing of what it created.

    Args:
        sweep: The sweep; None with ``resume`` runs the one stored in ``out``.
        out: Sweep directory (new, or one to resume).
        workers: Worker processes (Ray actors of one CPU each); default: every
            CPU of the Ray cluster.
        address: Ray cluster to join (e.g. ``"ray://head:10001"`` or
            ``"head:6379"``, :mod:`pik_mj.sweep.cluster`); None starts a local
            instance.
        num_cpus: CPUs of the local instance (default: Ray's count of this
            machine's cores).
        resume: Run only the cases of ``out`` without a row.
        repair: With ``resume``, move part files that cannot be read to
            ``out/corrupt/`` and run their cases again (without it they are an error).
        batch_size: Cases per batch (per task and per file) at most.
        worker_class: The per-robot worker (see :class:`SweepActor`).
        progress: Print progress lines on stderr (or pass them to this callable).
        connect_timeout: Longest wait [s] for the cluster at ``address`` to answer.

    Returns:
        A :class:`SweepReport`.

    Raises:
        InvalidInput: Bad arguments, ``out`` holding another sweep or unreadable
            part files, more workers than the cluster has CPUs, a cluster that
            does not answer at ``address`` within ``connect_timeout``.
        WriterBusy: Another process is writing ``out`` (its pid and host named).
        OutputError: A batch file cannot be written (a full disk); the rows
            written before are kept.
    """
    batch_size, workers, num_cpus = _check_arguments(
        sweep, batch_size, workers, num_cpus, address, connect_timeout
    )
    data = Dataset.open(out, sweep, resume=resume, repair=repair)
    try:
        return _run(
            data, workers, address, num_cpus, batch_size, worker_class, progress, connect_timeout
        )
    except BaseException:
        data.discard()  # a start that wrote no row leaves nothing behind
        raise
    finally:
        data.close()


def _check_arguments(
    sweep: Sweep | None,
    batch_size: int,
    workers: int | None,
    num_cpus: int | None,
    address: str | None,
    connect_timeout: float,
) -> tuple[int, int | None, int | None]:
    """:func:`run_sweep`'s arguments, checked before anything is written (a Ray
    address probed); ``(batch_size, workers, num_cpus)`` as ints."""
    if sweep is not None and not isinstance(sweep, Sweep):
        raise InvalidInput(f"sweep must be a pik_mj.sweep.Sweep or None, got {sweep!r}")
    batch_size = inputs.integer(batch_size, "batch_size", low=1)
    if workers is not None:
        workers = inputs.integer(workers, "workers", low=1)
    if num_cpus is not None:
        if address is not None:
            raise InvalidInput("num_cpus applies to a local Ray instance, not with an address")
        num_cpus = inputs.integer(num_cpus, "num_cpus", low=1)
        if workers is not None and workers > num_cpus:
            raise InvalidInput(f"workers={workers} but num_cpus={num_cpus}: each worker takes one")
    if address is not None:
        if not isinstance(address, str) or not address:
            raise InvalidInput(
                f"address must be a Ray address such as 'head:6379', got {address!r}"
            )
    inputs.real(connect_timeout, "connect_timeout", unit="s", low=0.0, low_open=True)
    if address is not None:
        cluster.probe(address, connect_timeout)
    if importlib.util.find_spec("ray") is None:
        raise PikError("sweeps run on Ray, which is not installed: pip install 'pik_mj[sweep]'")
    return batch_size, workers, num_cpus


def _run(
    data: Dataset,
    workers: int | None,
    address: str | None,
    num_cpus: int | None,
    batch_size: int,
    worker_class: type,
    progress: bool | Callable[[str], None],
    connect_timeout: float,
) -> SweepReport:
    """The body of :func:`run_sweep` once ``data`` is open (and locked)."""
    sweep = data.sweep
    done = data.done()
    todo = deque(c for c in sweep.cases() if c.index not in done)
    say = _printer(progress)
    report = SweepReport(data.path, sweep, pa.table({}), 0, len(done), 0, 0.0, 0.0)
    if todo:
        import ray

        t0 = time.perf_counter()
        started = cluster.start(address, num_cpus, connect_timeout)
        actors = []
        try:
            cpus = int(ray.cluster_resources().get("CPU", 0))
            n = min(workers or cpus, len(todo))
            if n > cpus:
                raise InvalidInput(
                    f"workers={workers} but the Ray cluster has {cpus} CPUs (each worker takes one)"
                )
            remote = ray.remote(num_cpus=1)(SweepActor)
            setups = []

            def new_actor() -> Any:
                actors.append(remote.remote(worker_class, sweep.hand, sweep.hold))
                setups.append(actors[-1].setup.remote(list(sweep.robots)))
                return actors[-1]

            for _ in range(n):
                new_actor()
            try:
                ray.get(setups)
            except ray.exceptions.RayTaskError as exc:  # a robot that cannot be built
                if isinstance(exc.cause, PikError):
                    raise exc.cause from None
                raise
            report.workers = n
            report.startup_time = time.perf_counter() - t0
            report.ran, report.wall_time = _dispatch(
                ray, actors, new_actor, todo, data, batch_size, say
            )
        finally:
            for a in actors:
                ray.kill(a)
            if started:
                ray.shutdown()
        data.log_run(
            {
                "cases": report.ran,
                "workers": report.workers,
                "wall_time": report.wall_time,
                "startup_time": report.startup_time,
                "address": address or "local",
                "ray": ray.__version__,
                "host": socket.gethostname(),
                "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            }
        )
    report.table = data.table()
    return report


def _dispatch(
    ray: Any,
    actors: list[Any],
    new_actor: Callable[[], Any],
    todo: deque[Case],
    data: Dataset,
    batch_size: int,
    say: Callable[[str], None],
) -> tuple[int, float]:
    """Keep every actor busy with one batch until ``todo`` is empty; write each
    finished batch; replace an actor whose process died (``new_actor()``).
    Returns (cases run, wall time [s])."""
    t0 = last = time.perf_counter()
    total, ran, validated, errors = len(todo), 0, 0, 0
    workers = len(actors)
    idle = list(actors)
    in_flight: dict[Any, tuple[Any, list[Case]]] = {}
    while todo or in_flight:
        while idle and todo:
            # smaller batches as the queue runs dry, so the workers finish together
            k = min(batch_size, max(1, math.ceil(len(todo) / (2 * workers))))
            batch = [todo.popleft() for _ in range(min(k, len(todo)))]
            actor = idle.pop()
            in_flight[actor.run.remote(batch)] = (actor, batch)
        [ref], _ = ray.wait(list(in_flight), num_returns=1)
        actor, batch = in_flight.pop(ref)
        try:
            rows = ray.get(ref)
        except ray.exceptions.RayActorError as exc:
            why = _describe(exc).splitlines()[0]
            message = f"worker process died running cases {[c.index for c in batch]}: {why}"
            rows = [make_row(c, None, "", message) for c in batch]
            ray.kill(actor)
            actors.remove(actor)
            actor = new_actor()
        data.write(rows)
        idle.append(actor)
        ran += len(rows)
        validated += sum(r["verdict"] == "validated" for r in rows)
        errors += sum(r["verdict"] == "error" for r in rows)
        now = time.perf_counter()
        if now - last >= 2.0 or ran == total:
            last = now
            say(
                f"sweep: {ran}/{total} cases, {now - t0:.1f} s, {ran / (now - t0):.2f} cases/s, "
                f"{validated} validated, {errors} errors"
            )
    return ran, time.perf_counter() - t0


def _printer(progress: bool | Callable[[str], None]) -> Callable[[str], None]:
    if callable(progress):
        return progress
    if progress:
        return lambda line: print(line, file=sys.stderr, flush=True)
    return lambda line: None
