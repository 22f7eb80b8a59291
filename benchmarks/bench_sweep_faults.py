"""Soak of a sweep under faults: killed and resumed three times at random points,
two resumers started together each time; every case must end with exactly one row.

A sweep of ``--n`` random right-hand targets × the stacks ``balanced`` and
``unbalanced`` (default 100 × 2 = 200 cases, ``--hold`` seconds of physics each) is
started with ``python -m pik_mj.sweep OUT`` and killed (``SIGKILL`` to its process
group: the driver and its local Ray instance) once a random number of batch files
is written. Then, three times, two ``--resume`` commands start at the same moment:
the one that takes the sweep directory's lock runs, the other must be refused (exit
2, naming the holder's pid and host); the runner is killed at a random point the
first two times and finishes the third. At the end the part files are read raw
(no de-duplication): every case must appear in exactly one row, and no hidden
``.tmp-`` file may be left.

Printed per round: the runner's pid, the refused resumer's exit status and how long
it took to be refused, the rows on disk after the round, rows written twice (must
be 0); then the total wall time.

Run: ``python benchmarks/bench_sweep_faults.py [--n 100] [--hold 0.3] [--workers 2]
[--seed 0] [--out DIR]``
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import pyarrow.parquet as pq

KILLS = 3  # the first run and the first two resumes are killed


def sweep_command(out: Path, *args: str) -> list[str]:
    return [sys.executable, "-m", "pik_mj.sweep", str(out), "--quiet", "--no-views", *args]


def start(command: list[str], ray_tmp: str) -> subprocess.Popen:
    env = dict(os.environ, RAY_TMPDIR=ray_tmp, RAY_USAGE_STATS_ENABLED="0")
    return subprocess.Popen(
        command,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own group: the driver and its Ray instance
    )


def parts(out: Path) -> list[Path]:
    return sorted((out / "rows").glob("part-*.parquet"))


def raw_cases(out: Path) -> Counter:
    """Rows per case over every part file, read raw (no de-duplication)."""
    count: Counter = Counter()
    for part in parts(out):
        count.update(pq.read_table(part, columns=["case"]).column("case").to_pylist())
    return count


def kill_when(process: subprocess.Popen, out: Path, target: int, timeout: float) -> bool:
    """SIGKILL ``process``'s group once ``out`` holds ``target`` part files; False
    if it ended first."""
    deadline = time.monotonic() + timeout
    while process.poll() is None and time.monotonic() < deadline:
        if len(parts(out)) >= target:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
            return True
        time.sleep(0.05)
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
        return True
    return False


def resume_pair(out: Path, options: list[str], ray_tmp: str) -> tuple:
    """Two resumers started together: (runner, refused, refusal time [s], its stderr)."""
    t0 = time.monotonic()
    pair = [start(sweep_command(out, "--resume", *options), ray_tmp) for _ in range(2)]
    while all(p.poll() is None for p in pair):
        time.sleep(0.05)
    refused = next(p for p in pair if p.poll() is not None)
    runner = next(p for p in pair if p is not refused)
    waited = time.monotonic() - t0
    return runner, refused, waited, refused.stderr.read()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="random targets (x 2 stacks)")
    parser.add_argument("--hold", type=float, default=0.3, help="physics hold per case [s]")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0, help="where the kills fall")
    parser.add_argument("--out", help="sweep directory (default: a temporary one)")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    out = Path(args.out or tempfile.mkdtemp(prefix="soak")) / "sweep"
    ray_tmp = tempfile.mkdtemp(prefix="pks")
    total = 2 * args.n
    options = ["--workers", str(args.workers), "--batch-size", "2"]
    print(f"soak: {total} cases into {out}, {args.workers} workers, host {socket.gethostname()}")
    t0 = time.monotonic()
    first = start(
        sweep_command(out, "--random", str(args.n), "--hold", str(args.hold), *options), ray_tmp
    )
    rounds = []
    target = rng.randint(2, total // 6)
    kill_when(first, out, target, timeout=3600)
    rounds.append({"round": "first run", "killed": True, "rows": sum(raw_cases(out).values())})
    for k in range(KILLS):
        runner, refused, waited, message = resume_pair(out, options, ray_tmp)
        holder_named = f"pid {runner.pid} on host" in message
        done = len(parts(out))
        last = k == KILLS - 1
        if last:
            runner.wait()
            killed = False
        else:
            remaining = total - sum(raw_cases(out).values())
            killed = kill_when(runner, out, done + rng.randint(1, max(1, remaining // 4)), 3600)
        count = raw_cases(out)
        rounds.append(
            {
                "round": f"resume {k + 1}",
                "runner": runner.pid,
                "runner_exit": runner.returncode,
                "refused_exit": refused.returncode,
                "refused_after_s": waited,
                "holder_named": holder_named,
                "killed": killed,
                "rows": sum(count.values()),
                "twice": sum(1 for c in count.values() if c > 1),
            }
        )
    wall = time.monotonic() - t0
    count = raw_cases(out)
    print(
        f"{'round':<10} {'runner':>7} {'exit':>5} {'refused':>8} {'after [s]':>9} "
        f"{'holder named':>12} {'killed':>6} {'rows':>6} {'twice':>6}"
    )
    for r in rounds:
        print(
            f"{r['round']:<10} {r.get('runner', '-')!s:>7} {r.get('runner_exit', '-')!s:>5} "
            f"{r.get('refused_exit', '-')!s:>8} {r.get('refused_after_s', 0.0):>9.1f} "
            f"{r.get('holder_named', '-')!s:>12} {r['killed']!s:>6} {r['rows']:>6} "
            f"{r.get('twice', 0):>6}"
        )
    missing = sorted(set(range(total)) - set(count))
    twice = sorted(c for c, n in count.items() if n > 1)
    hidden = list((out / "rows").glob(".tmp-*"))
    print(
        f"end: {len(count)}/{total} cases, rows {sum(count.values())}, missing {len(missing)}, "
        f"written twice {len(twice)}, hidden files {len(hidden)}; wall {wall:.0f} s"
    )
    ok = (
        not missing
        and not twice
        and not hidden
        and all(r.get("refused_exit", 2) == 2 and r.get("holder_named", True) for r in rounds)
        and rounds[-1]["runner_exit"] in (0, 1)
    )
    print("every case exactly once" if ok else "FAILED")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
