"""The ``pik-mj`` command: list and run the seed's scenarios.

::

    pik-mj list
    pik-mj run [NAME] [--out FILE.rrd] [--json FILE.json] [--model NAME] [--no-record]

``run`` without a name runs ``fullbody_reach``. It prints a summary (an iteration
counter on stderr while solving), writes a rerun recording (default
``out/NAME.rrd``) and, with ``--json``, a JSON summary. Exit status: 0 when every
check of the scenario holds, 1 when one fails, 2 for bad usage (unknown scenario,
a scenario still waiting for a module, a model the scenario does not take).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .exceptions import PikError
from .scenarios import DEFAULT_SCENARIO, REGISTRY, ScenarioResult, run_scenario, scenario

EXIT_PASSED, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pik-mj", description="Prioritized IK on MuJoCo: run the seed's scenarios."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the scenarios")
    run = sub.add_parser("run", help=f"run a scenario (default: {DEFAULT_SCENARIO})")
    run.add_argument("name", nargs="?", default=DEFAULT_SCENARIO, help="scenario name")
    run.add_argument("--out", help="rerun recording to write (default: out/NAME.rrd)")
    run.add_argument("--no-record", action="store_true", help="write no recording")
    run.add_argument("--json", help="JSON summary to write")
    run.add_argument("--model", help="robot model (scenarios that take one)")
    run.add_argument("--quiet", action="store_true", help="no progress on stderr")
    return parser


def _list() -> int:
    width = max(len(n) for n in REGISTRY)
    for name, entry in REGISTRY.items():
        missing = entry.missing()
        flags = []
        if name == DEFAULT_SCENARIO:
            flags.append("default")
        if entry.accepts_model:
            flags.append("--model")
        if missing:
            flags.append(f"waiting for {', '.join(missing)}")
        tail = f"  [{'; '.join(flags)}]" if flags else ""
        print(f"{name:<{width}}  {entry.description}{tail}")
    return EXIT_PASSED


def balance_check(result: ScenarioResult) -> dict[str, Any] | None:
    """HOOK(balance): simulation validation of the scenario's final pose.

    This is where ``pik_mj.sim`` (Scene + hold) will validate ``result.robot``'s final
    configuration in physics and return its JSON-ready report (drift, slip, minimum
    margin, verdict); the CLI stores it under ``balance`` in the JSON summary. Until
    then there is no balance report.
    """
    return None


def _run(args: argparse.Namespace) -> int:
    entry = scenario(args.name)  # UnknownName lists the scenarios
    out: Path | None = None
    if not args.no_record:
        out = Path(args.out) if args.out else Path("out") / f"{entry.name}.rrd"
        out.parent.mkdir(parents=True, exist_ok=True)
    print(f"running {entry.name}: {entry.description}", file=sys.stderr)
    result = run_scenario(entry.name, out, progress=not args.quiet, model=args.model)
    result.balance = balance_check(result)
    print(result.summary())
    if args.json:
        path = Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(result.to_dict(), indent=2))
        print(f"JSON summary: {path}")
    return EXIT_PASSED if result.passed else EXIT_FAILED


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``pik-mj``; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        if args.command == "list":
            return _list()
        return _run(args)
    except PikError as exc:
        print(f"pik-mj: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    raise SystemExit(main())
