"""A sweep on a real two-node Ray cluster started on this machine, against a local run.

``ray start --head --num-cpus 1`` and ``ray start --address HEAD --num-cpus 1``
(a second raylet on the same machine, its own CPU count and worker ports) make a
cluster of two nodes; the sweep (default: 20 random right-hand targets of the
sample humanoid x the two stacks, 1 s holds) runs on a local Ray instance of
two CPUs, then on the cluster with two workers (:func:`pik_mj.sweep.run_sweep`
in a process connected to the head). Printed, before the cluster stops: each
run's wall time and cases per second, the cases of each worker process (each
actor takes 1 CPU, each node has 1: one actor per node; Ray's state API needs
the dashboard, off here), and whether the rows are equal but for the times and
worker names. The cluster's processes (found by its temporary directory in their
command line) are stopped by process id at the end, also on an error.

Run: ``python benchmarks/bench_ray_cluster.py [--n 20] [--hold 1]``
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import ray

from pik_mj.sweep import Sweep, Uniform, run_sweep
from pik_mj.sweep.cli import DEFAULT_BOX
from pik_mj.sweep.dataset import comparable

RAY = str(Path(sys.executable).with_name("ray"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _processes(tag: str) -> list[int]:
    """Processes whose command line holds ``tag`` (the cluster's temp directory)."""
    out = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit() and int(proc.name) != os.getpid():
            try:
                if tag.encode() in (proc / "cmdline").read_bytes():
                    out.append(int(proc.name))
            except OSError:
                continue
    return out


def _stop(tag: str) -> None:
    """SIGTERM, then SIGKILL, the cluster's processes, by id."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for pid in _processes(tag):
            try:
                os.kill(pid, sig)
            except OSError:
                pass
        time.sleep(3)


def start_cluster(tmp: str) -> str:
    """Head and second node, one CPU each; the head's address."""
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0", RAY_AUTH_MODE="disabled")
    port = _free_port()
    address = f"127.0.0.1:{port}"
    head = [RAY, "start", "--head", "--num-cpus", "1", "--port", str(port), "--temp-dir", tmp]
    head += ["--include-dashboard", "false", "--disable-usage-stats"]
    subprocess.run(head, env=env, check=True, capture_output=True)
    lo = _free_port() // 2 + 20000  # a worker port range of its own for the second raylet
    node = [RAY, "start", "--address", address, "--num-cpus", "1"]
    node += ["--min-worker-port", str(lo), "--max-worker-port", str(lo + 999)]
    subprocess.run(node, env=env, check=True, capture_output=True)
    return address


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20, help="random targets (x 2 stacks)")
    parser.add_argument("--hold", type=float, default=1.0, help="hold duration [s]")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    sweep = Sweep(Uniform(DEFAULT_BOX, args.n), hold=args.hold, seed=args.seed)
    base = Path(tempfile.mkdtemp(prefix="bench_ray_cluster_"))
    tmp = tempfile.mkdtemp(prefix="pikray")
    os.environ.update(RAY_USAGE_STATS_ENABLED="0", RAY_AUTH_MODE="disabled")
    quiet = {"log_to_driver": False, "logging_level": logging.ERROR}
    # the local run first: this process then joins the cluster once, and reports
    # before the cluster is stopped (a driver outliving its GCS is aborted by Ray)
    local = run_sweep(sweep, base / "local", workers=2, num_cpus=2, progress=False)
    try:
        t0 = time.perf_counter()
        address = start_cluster(tmp)
        ray.init(address=address, **quiet)
        nodes = [n["NodeID"] for n in ray.nodes() if n["Alive"]]
        up = time.perf_counter() - t0
        cluster = run_sweep(sweep, base / "cluster", workers=2, progress=False)
        rows = cluster.table.to_pylist()
        per_worker = Counter(r["worker"] for r in rows)
        same = comparable(rows) == comparable(local.table.to_pylist())
        print(
            f"sweep: {len(sweep)} cases ({args.n} random right-hand targets x {sweep.stacks}), "
            f"hold {args.hold:g} s, sample_humanoid; Ray {ray.__version__}"
        )
        print(f"cluster: {len(nodes)} nodes of 1 CPU on this machine, up in {up:.1f} s ({address})")
        print(f"{'run':>8} {'workers':>7} {'wall [s]':>9} {'cases/s':>8}")
        for name, report in (("cluster", cluster), ("local", local)):
            print(
                f"{name:>8} {report.workers:>7} {report.wall_time:>9.1f} "
                f"{report.ran / report.wall_time:>8.2f}"
            )
        # each actor takes 1 CPU (run_sweep) and each node has 1: one actor per node
        for worker, count in per_worker.items():
            print(f"cases on worker {worker} (one actor of 1 CPU per 1-CPU node): {count}")
        print(f"rows equal to the local run's (times and workers aside): {same}")
        print(f"load average (1 min): {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
        sys.stdout.flush()
        ray.shutdown()
    finally:
        _stop(tmp)
    return {"per_worker": dict(per_worker), "same_rows": same, "nodes": len(nodes)}


if __name__ == "__main__":
    main()
