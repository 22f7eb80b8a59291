"""The ``pik-mj`` command: list and run the seed's scenarios, validate poses.

::

    pik-mj list
    pik-mj run [NAME] [--out FILE.rrd] [--json FILE.json] [--model NAME] [--no-record]
               [--hold SECONDS] [--quiet]
    pik-mj validate FILE.json [--environment ENV] [--duration SECONDS] [--json OUT]
               [--out FILE.rrd]
    pik-mj screenshot FILE.rrd --out FILE.png [--timeline NAME] [--time T|last]
               [--view NAME] [--tab NAME] [--size WxH] [--panels]

``run`` without a name runs ``fullbody_reach``: it solves, validates in
simulation and writes a recording. For a robot with a floating base every IK
iteration is checked statically in a MuJoCo scene, and the final pose is held in
physics for ``--hold`` seconds (default 3; 0 = no hold) into the same recording
(``sim_time`` timeline); the JSON summary gets the report under ``balance`` and
the final configuration under ``robot``. ``run`` prints a summary (an iteration
counter on stderr while solving), writes a rerun recording (default
``out/NAME.rrd``; its path is printed last) and, with ``--json``, a JSON summary.

``validate`` reads a JSON summary written by ``run --json`` (its ``robot``
entry) or a JSON ``{"model": NAME, "q": [...]}`` (optional ``environment``,
``robot_pos``, ``allowed_contacts``), checks the pose's static equilibrium and
holds it in physics (:func:`pik_mj.sim.validate_pose`).

Exit status: 0 when every check holds (for ``run``: the scenario's checks and the
hold; for ``validate``: the verdict), 1 when one fails or the scenario raised,
2 for bad usage (unknown scenario, a scenario still waiting for a module, a model
the scenario does not take, an unreadable pose file).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .exceptions import InvalidInput, PikError, SimulationUnstable
from .scenarios import (
    DEFAULT_HOLD,
    DEFAULT_SCENARIO,
    REGISTRY,
    balance_summary,
    check_runnable,
    jsonable,
    run_scenario,
)

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
    run.add_argument(
        "--hold",
        type=float,
        default=DEFAULT_HOLD,
        help=f"physics hold of the final pose [s] (default {DEFAULT_HOLD:g}; 0: none)",
    )
    run.add_argument("--quiet", action="store_true", help="no progress on stderr")
    val = sub.add_parser("validate", help="static check and physics hold of a pose")
    val.add_argument("file", help="JSON summary of `pik-mj run --json`, or {model, q}")
    val.add_argument(
        "--environment",
        help="environment model (default: the file's; 'none' for a floor only)",
    )
    val.add_argument("--duration", type=float, default=DEFAULT_HOLD, help="hold duration [s]")
    val.add_argument("--json", help="JSON report to write")
    val.add_argument("--out", help="rerun recording of the hold (.rrd)")
    from .record import screenshot

    screenshot.add_arguments(sub.add_parser("screenshot", help="PNG of a recording (rerun)"))
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


def _write_json(path: str, data: Any) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(jsonable(data), indent=2))
    return p


def _run(args: argparse.Namespace) -> int:
    if not (math.isfinite(args.hold) and args.hold >= 0):
        raise InvalidInput(f"--hold must be a duration >= 0 [s], got {args.hold}")
    entry = check_runnable(args.name, args.model)  # usage errors: exit 2
    out: Path | None = None
    if not args.no_record:
        out = Path(args.out) if args.out else Path("out") / f"{entry.name}.rrd"
        out.parent.mkdir(parents=True, exist_ok=True)
    print(f"running {entry.name}: {entry.description}", file=sys.stderr)
    try:
        result = run_scenario(
            entry.name,
            out,
            progress=not args.quiet,
            model=args.model,
            hold=args.hold if args.hold > 0 else None,
        )
    except Exception as exc:
        traceback.print_exc(file=sys.stderr)
        print(f"pik-mj: scenario {entry.name} raised {type(exc).__name__}: {exc}", file=sys.stderr)
        if out is not None and out.is_file():
            print(f"recording (up to the error): {out}")
        return EXIT_FAILED
    print(result.summary(recording=False))
    if args.json:
        print(f"JSON summary: {_write_json(args.json, result.to_dict())}")
    if result.recording:
        print(f"recording: {result.recording}  (view with: rerun {result.recording})")
    return EXIT_PASSED if result.passed else EXIT_FAILED


def read_pose_file(path: str | Path) -> dict[str, Any]:
    """The pose of a JSON file: the ``robot`` entry of a ``pik-mj run --json``
    summary, or the file itself when it has ``model`` and ``q``.

    Returns:
        ``{"model", "q", "environment", "robot_pos", "allowed_contacts", "grasps"}``
        (missing optional entries are None; ``grasps`` is a list of
        ``(frame, body, p_FO, R_FO)``, empty when nothing is held).

    Raises:
        InvalidInput: Missing or unreadable file, or no pose in it.
    """
    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except FileNotFoundError:
        raise InvalidInput(f"pose file {str(p)!r} does not exist") from None
    except json.JSONDecodeError as exc:
        raise InvalidInput(f"pose file {str(p)!r} is not JSON: {exc}") from None
    src = data
    if isinstance(data, dict) and "q" not in data:
        src = data.get("robot")
    if not isinstance(src, dict) or "model" not in src or "q" not in src:
        raise InvalidInput(
            f"pose file {str(p)!r} holds no pose: expected a `pik-mj run --json` summary "
            'of a floating-base scenario (its "robot" entry) or {"model": ..., "q": [...]}'
        )
    q = src["q"]
    if not isinstance(q, list) or not all(isinstance(x, (int, float)) for x in q):
        raise InvalidInput(f'pose file {str(p)!r}: "q" must be a list of numbers')
    grasps = src.get("grasps") or []
    keys = ("frame", "body", "p_FO", "R_FO")
    if not isinstance(grasps, list) or not all(
        isinstance(g, dict) and all(k in g for k in keys) for g in grasps
    ):
        raise InvalidInput(
            f'pose file {str(p)!r}: "grasps" must be a list of {{"frame", "body", "p_FO", "R_FO"}}'
        )
    return {
        "model": src["model"],
        "q": [float(x) for x in q],
        "environment": src.get("environment"),
        "robot_pos": src.get("robot_pos"),
        "allowed_contacts": src.get("allowed_contacts"),
        "grasps": [tuple(g[k] for k in keys) for g in grasps],
    }


def _validate(args: argparse.Namespace) -> int:
    from .sim import validate_pose

    if not (math.isfinite(args.duration) and args.duration > 0):
        raise InvalidInput(f"--duration must be > 0 [s], got {args.duration}")
    pose = read_pose_file(args.file)
    env = pose["environment"] if args.environment is None else args.environment
    if isinstance(env, str) and env.lower() == "none":
        env = None
    recorder = None
    if args.out:
        from .record import Recorder

        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        recorder = Recorder.to_file(args.out, application_id="pik_mj validate")
    try:
        report = validate_pose(
            pose["model"],
            pose["q"],
            env,
            args.duration,
            robot_pos=pose["robot_pos"] if pose["robot_pos"] is not None else (0.0, 0.0, 0.0),
            allowed=pose["allowed_contacts"],
            grasps=pose["grasps"],
            recorder=recorder,
        )
    except SimulationUnstable as exc:
        print(f"validate {args.file}: FAILED, the simulation went unstable: {exc}")
        return EXIT_FAILED
    finally:
        if recorder is not None:
            recorder.close()
    held = "".join(f", {body} held in {frame}" for frame, body, _, _ in pose["grasps"])
    print(f"validate {args.file}: model {pose['model']}, environment {env}{held}")
    print(balance_summary(report))
    print("PASSED" if report["passed"] else "FAILED")
    if args.json:
        print(f"JSON report: {_write_json(args.json, report)}")
    if args.out:
        print(f"recording: {args.out}")
    return EXIT_PASSED if report["passed"] else EXIT_FAILED


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``pik-mj``; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        if args.command == "list":
            return _list()
        if args.command == "validate":
            return _validate(args)
        if args.command == "screenshot":
            from .record import screenshot

            return screenshot.run(args)
        return _run(args)
    except PikError as exc:
        print(f"pik-mj: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    raise SystemExit(main())
