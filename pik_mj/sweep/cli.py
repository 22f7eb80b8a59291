"""``pik-mj sweep``: a balanced-reachability sweep on Ray into a Parquet dataset.

::

    pik-mj sweep OUT [--grid NAME=A:B:N|V1,V2,... ...] [--random N [--range NAME=LO:HI ...]]
                     [--robot NAME ...] [--stack balanced|unbalanced ...] [--seed S]
                     [--hold SECONDS] [--hand LIMB] [--workers N] [--num-cpus N]
                     [--address ADDR] [--connect-timeout SECONDS] [--resume [--repair]]
                     [--batch-size N] [--png FILE] [--rrd FILE]
                     [--across x|y|z] [--no-views] [--quiet]

Without ``--grid`` or ``--random`` it runs 100 random right-hand targets in the
box ``x ∈ [0.2, 0.7]``, ``y ∈ [-0.5, 0.2]``, ``z ∈ [0.2, 1.3]`` m (world frame:
the sample humanoid stands at the origin) × the stacks ``balanced`` and
``unbalanced``. ``--resume`` finishes the sweep stored in OUT (give no sweep
options, or the same ones). Views go to ``OUT/map.png`` and ``OUT/map.rrd``
unless ``--png``/``--rrd`` say otherwise or ``--no-views``. Also run as
``python -m pik_mj.sweep``.

Every option is checked before any work starts (:mod:`pik_mj.inputs`; a bad one
is a usage error, exit 2, and nothing is written): numbers in range, grid and
range specifications, parameter names, each robot built with its hand and feet,
the sweep directory (new, or holding the same sweep with ``--resume``, written
by no other process, its part files readable unless ``--repair``), the picture
and recording files writable, the workers within ``--num-cpus``, a Ray cluster
answering at ``--address`` within ``--connect-timeout``.

Exit status: 0 when every case ran (whatever its verdict), 1 when a case
raised or an output could not be written (a full disk: the file named, the rows
written before kept), 2 for bad usage (also: another process writing OUT, its
pid and host named; no cluster at ``--address``).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.scenario.arguments import argument_type, as_integer, count, positive
from pik_mj.scenario.exit_status import EXIT_FAILED, EXIT_PASSED, guarded
from pik_mj.sweep import cluster
from pik_mj.sweep.case import PARAMETERS, REQUIRED, STACKS, standing_robot
from pik_mj.sweep.cluster import DEFAULT_CONNECT_TIMEOUT
from pik_mj.sweep.dataset import Dataset
from pik_mj.sweep.driver import run_sweep
from pik_mj.sweep.spec import Grid, Sweep, Uniform
from pik_mj.sweep.views import write_views

DEFAULT_BOX = {"x": (0.2, 0.7), "y": (-0.5, 0.2), "z": (0.2, 1.3)}  # [m]
DEFAULT_RANDOM = 100


@argument_type
def _seed(text: str) -> int:
    """An argparse type: an integer >= 0."""
    return inputs.integer(as_integer(text), "a seed", low=0)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The ``pik-mj sweep`` options."""
    p.add_argument("out", help="sweep directory (Parquet dataset)")
    space = p.add_mutually_exclusive_group()
    space.add_argument(
        "--grid",
        nargs="+",
        metavar="NAME=SPEC",
        help="grid axes: NAME=A:B:N (N values from A to B), NAME=V1,V2,... or NAME=V; "
        "names: " + ", ".join(PARAMETERS),
    )
    space.add_argument(
        "--random", type=count, metavar="N", help=f"N random points (default {DEFAULT_RANDOM})"
    )
    p.add_argument(
        "--range",
        nargs="+",
        metavar="NAME=LO:HI",
        help="ranges of --random (default "
        + " ".join(f"{k}={lo:g}:{hi:g}" for k, (lo, hi) in DEFAULT_BOX.items())
        + ")",
    )
    p.add_argument("--robot", action="append", help="robot model (repeat for more)")
    p.add_argument("--stack", action="append", choices=list(STACKS), help="stack (repeatable)")
    p.add_argument("--seed", type=_seed, help="sweep seed (default 0)")
    p.add_argument("--hold", type=positive, help="physics hold of each case [s] (default 3)")
    p.add_argument("--hand", help="limb sent to the targets (default rarm)")
    p.add_argument("--workers", type=count, help="worker processes (default: the cluster's CPUs)")
    p.add_argument("--num-cpus", type=count, help="CPUs of the local Ray instance")
    p.add_argument("--address", help="Ray cluster to join (default: a local instance)")
    p.add_argument(
        "--connect-timeout",
        type=positive,
        default=DEFAULT_CONNECT_TIMEOUT,
        metavar="SECONDS",
        help="longest wait for the cluster at --address to answer "
        f"(default {DEFAULT_CONNECT_TIMEOUT:g})",
    )
    p.add_argument("--resume", action="store_true", help="finish the sweep stored in OUT")
    p.add_argument(
        "--repair",
        action="store_true",
        help="with --resume: move part files that cannot be read to OUT/corrupt/ and run "
        "their cases again",
    )
    p.add_argument("--batch-size", type=count, default=8, help="cases per batch file (at most)")
    p.add_argument("--png", help="map picture (default OUT/map.png)")
    p.add_argument("--rrd", help="rerun recording of the map (default OUT/map.rrd)")
    p.add_argument("--across", choices=REQUIRED, default="y", help="axis of the slices")
    p.add_argument("--no-views", action="store_true", help="write no PNG and no recording")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def _numbers(item: str, what: str) -> tuple[str, list[float], bool]:
    """``NAME=SPEC`` -> (name, the numbers of SPEC, whether ``:`` separates them)."""
    name, sep, spec = item.partition("=")
    if not sep or not name:
        raise InvalidInput(f"{what} {item!r}: expected NAME=VALUES")
    values = []
    for text in spec.replace(":", ",").split(","):
        try:
            value: float | str = float(text)
        except ValueError:
            value = text
        values.append(inputs.real(value, f"{what} {item!r}: each value"))
    return name, values, ":" in spec


def _grid(items: Sequence[str]) -> Grid:
    axes = {}
    for item in items:
        name, vals, ranged = _numbers(item, "--grid")
        if ranged:
            if len(vals) != 3 or vals[2] != int(vals[2]) or vals[2] < 1:
                raise InvalidInput(f"--grid {item!r}: A:B:N needs a whole count N >= 1")
            vals = np.linspace(vals[0], vals[1], int(vals[2])).round(12).tolist()
        if name in axes:
            raise InvalidInput(f"--grid names {name!r} twice")
        axes[name] = vals
    return Grid(axes)


def _uniform(n: int, items: Sequence[str] | None) -> Uniform:
    if items is None:
        return Uniform(DEFAULT_BOX, n)
    bounds = {}
    for item in items:
        name, vals, _ = _numbers(item, "--range")
        if len(vals) not in (1, 2):
            raise InvalidInput(f"--range {item!r}: expected NAME=LO:HI or NAME=VALUE")
        if name in bounds:
            raise InvalidInput(f"--range names {name!r} twice")
        bounds[name] = (vals[0], vals[-1])
    return Uniform(bounds, n)


def sweep_from_args(args: argparse.Namespace) -> Sweep | None:
    """The sweep the options describe; None when they give none (``--resume``)."""
    options = ("grid", "random", "range", "robot", "stack", "seed", "hold", "hand")
    if args.resume and all(getattr(args, k) is None for k in options):
        return None
    if args.range is not None and args.random is None:
        raise InvalidInput("--range goes with --random")
    if args.grid:
        space: Grid | Uniform = _grid(args.grid)
    else:
        space = _uniform(DEFAULT_RANDOM if args.random is None else args.random, args.range)
    given = {
        "robots": tuple(args.robot) if args.robot else None,
        "stacks": tuple(args.stack) if args.stack else None,
        "seed": args.seed,
        "hold": args.hold,
        "hand": args.hand,
    }
    return Sweep(space, **{k: v for k, v in given.items() if v is not None})


def check(args: argparse.Namespace) -> Sweep:
    """Everything the options name, before any work: the sweep (given or stored),
    the sweep directory, each robot, the view files, the worker count.

    Raises:
        InvalidInput, UnknownName: What is wrong, and what is valid.
    """
    given = sweep_from_args(args)
    if args.repair and not args.resume:
        raise InvalidInput("--repair goes with --resume (it mends a stored sweep)")
    sweep = Dataset.check(args.out, given, resume=args.resume, repair=args.repair)
    if not args.no_views:
        for option, value in (("--png", args.png), ("--rrd", args.rrd)):
            if value is not None:
                inputs.output_path(value, f"argument {option}:")
    if args.address is not None and args.num_cpus is not None:
        raise InvalidInput("--num-cpus sizes a local Ray instance; leave it out with --address")
    if args.workers is not None and args.num_cpus is not None and args.workers > args.num_cpus:
        raise InvalidInput(
            f"--workers {args.workers} but --num-cpus {args.num_cpus}: each worker takes a CPU"
        )
    if args.address is not None:
        cluster.probe(args.address, args.connect_timeout)
    for robot in sweep.robots:  # the slowest check last
        standing_robot(robot, sweep.hand)
    return sweep


def run(args: argparse.Namespace) -> int:
    """Body of ``pik-mj sweep`` (options checked first); returns the exit status."""
    sweep = check(args)
    report = run_sweep(
        sweep,
        args.out,
        workers=args.workers,
        address=args.address,
        num_cpus=args.num_cpus,
        resume=args.resume,
        repair=args.repair,
        batch_size=args.batch_size,
        progress=not args.quiet,
        connect_timeout=args.connect_timeout,
    )
    print(report.summary())
    if not args.no_views and len(report.table):
        out = Path(args.out)
        for f in write_views(
            report.table,
            report.sweep,
            png=args.png or out / "map.png",
            rrd=args.rrd or out / "map.rrd",
            across=args.across,
        ):
            print(f"wrote {f}")
    return EXIT_FAILED if report.errors else EXIT_PASSED


def main(argv: Sequence[str] | None = None) -> int:
    """``pik-mj sweep`` with ``argv`` (usage errors raise; :func:`command` and
    ``pik-mj`` turn them into one line and exit 2)."""
    parser = argparse.ArgumentParser(
        prog="pik-mj sweep",
        description="Solve, check statically and hold in physics every case (hand targets x "
        "robots x stacks) on Ray; one row per case in the Parquet dataset OUT/rows; "
        "a map in OUT/map.png and OUT/map.rrd.",
    )
    add_arguments(parser)
    return run(parser.parse_args(argv))


def command(argv: Sequence[str] | None = None) -> int:
    """``python -m pik_mj.sweep``: :func:`main` with a usage error reported in one line
    (exit 2) and Ctrl-C as exit 130 (:func:`pik_mj.scenario.exit_status.guarded`)."""
    return guarded(lambda: main(argv))
