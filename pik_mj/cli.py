"""The ``pik-mj`` command: list and run the scenarios, validate poses, take screenshots,
run sweeps.

::

    pik-mj list
    pik-mj run [NAME] [scenario options: --save FILE.rrd, --json FILE, --hold SECONDS,
               --quiet, --model NAME, --headless, ...]
    pik-mj validate FILE.json [--environment ENV] [--duration SECONDS] [--json OUT]
               [--save FILE.rrd]
    pik-mj validate OUT#CASE[,CASE...|all] [--json OUT]
    pik-mj screenshot FILE.rrd --out FILE.png [--timeline NAME] [--time T|last]
               [--view NAME] [--tab NAME] [--size WxH] [--panels]
    pik-mj sweep OUT [--grid NAME=A:B:N ... | --random N --range NAME=LO:HI ...]
               [--robot NAME] [--stack NAME] [--workers N] [--address HOST:PORT]
               [--resume] ...

``list`` shows each scenario's description and what it needs of its robot (two arms,
legs, a floating or a fixed base; ``--model``/``--description`` choose the robot).

``run`` runs the ``main`` of scenario ``NAME`` (default ``fullbody_reach``;
``pik_mj.scenarios.<name>``) with the remaining options, saving its rerun
recording to ``out/NAME-ROBOT.rrd`` (``out/fullbody_reach-unitree_g1.rrd``; the
scenario's default robot keeps ``out/NAME.rrd``) unless a recording option
(``--save``, ``--connect``, ``--serve``, ``--stdout``, ``--headless``) says
otherwise; see ``pik-mj run NAME --help``. A robot the scenario cannot move is
refused before any work, in one line (exit status 2). It prints the scenario's
summary (progress on stderr), with ``--json`` a JSON summary whose ``robot`` entry is
the final pose and what rebuilds its scene.

``validate`` reads a JSON summary written by ``run --json`` (its ``robot``
entry) or a JSON ``{"model": NAME, "q": [...]}`` (optional ``environment``,
``at``, ``keyframe``, ``allowed_contacts``, ``grasps``, ``external``), checks
the pose's joint limits and static equilibrium and holds it in physics
(:func:`pik_mj.sim.validate_pose`); a joint outside its range fails the verdict,
named with its excess. ``OUT#CASE`` replays rows of the sweep in ``OUT`` from
the pose they carry (:func:`pik_mj.sweep.replay.replay`: static check, motion
and hold, no solve) and prints the stored and the replayed verdicts; it passes
when every replayed row is validated.

``sweep`` solves, checks and holds many hand targets on Ray into a Parquet
dataset (:mod:`pik_mj.sweep.cli`; ``pik-mj sweep --help``); it exits 0 when
every case ran, whatever its verdict, and 1 when a case raised.

Exit status: 0 when every check holds (for ``run``: the scenario's checks and the
hold; for ``validate``: the verdict), 1 when one fails or the scenario raised
(its traceback shown), 2 for bad usage, reported in one line without a traceback
(unknown command, scenario or option, a bad number, an unknown model or a file
that is not MJCF, an output file that cannot be written — checked before any
work starts —, an unreadable pose file or a pose of another model, a scenario
still waiting for a module), 130 when interrupted (Ctrl-C; a recording in
progress is closed and readable).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import inspect
import json
import math
import signal
import sys
import threading
import traceback
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import Any

import pik_mj.scenarios
from pik_mj import inputs
from pik_mj.exceptions import (
    InvalidInput,
    OptionError,
    OutputError,
    ScenarioWaiting,
    SimulationUnstable,
    UnknownName,
)
from pik_mj.outputs import write_atomic
from pik_mj.record import Recorder, screenshot
from pik_mj.record.reader import verify
from pik_mj.robot import Robot, RobotSource
from pik_mj.scenario import balance_summary, jsonable, positive
from pik_mj.scenario.exit_status import EXIT_FAILED, EXIT_PASSED, EXIT_USAGE, exit_code, guarded
from pik_mj.scenario.robot_option import RobotOption, model_label
from pik_mj.sim import validate_pose
from pik_mj.sweep import cli as sweep_cli
from pik_mj.sweep.replay import parse_target, replay

_RECORDING_OPTIONS = ("--save", "--connect", "--serve", "--stdout", "--headless")


def load_scenario(name: str) -> ModuleType:
    """The module of scenario ``name``.

    Raises:
        UnknownName: Not a scenario of :data:`pik_mj.scenarios.SCENARIOS`.
        ScenarioWaiting: The scenario needs a pik_mj module that does not exist yet.
    """
    names = pik_mj.scenarios.SCENARIOS
    if name not in names:
        raise UnknownName("scenario", name, names)
    try:
        return importlib.import_module(f"pik_mj.scenarios.{name}")
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.startswith("pik_mj") and exc.name != f"pik_mj.scenarios.{name}":
            raise ScenarioWaiting(name, exc.name) from exc
        raise


def describe(name: str) -> tuple[str, list[str]]:
    """``(first line of the scenario's docstring, flags)`` for ``pik-mj list``."""
    flags = ["default"] if name == pik_mj.scenarios.DEFAULT else []
    try:
        module = load_scenario(name)
    except ScenarioWaiting as exc:
        return "", [*flags, f"waiting for {exc.missing}"]
    robot = scenario_robot(module)
    if robot is not None:
        flags.append(f"--model: {robot.needs()}")
    elif "model" in inspect.signature(module.run).parameters:
        flags.append("--model")
    doc = (module.__doc__ or "").strip().splitlines()
    return (doc[0] if doc else ""), flags


def scenario_robot(module: ModuleType) -> RobotOption | None:
    """What the scenario declares it needs of its robot (its ``ROBOT``), or None for a
    scenario that declares nothing."""
    robot = vars(module).get("ROBOT")
    return robot if isinstance(robot, RobotOption) else None


def _list() -> int:
    names = pik_mj.scenarios.SCENARIOS
    width = max(len(n) for n in names)
    for name in names:
        text, flags = describe(name)
        tail = f"  [{'; '.join(flags)}]" if flags else ""
        print(f"{name:<{width}}  {text}{tail}")
    return EXIT_PASSED


def _run(name: str | None, argv: list[str]) -> int:
    name = pik_mj.scenarios.DEFAULT if name is None else name
    module = load_scenario(name)  # usage errors: exit 2
    if not any(a == o or a.startswith(o + "=") for a in argv for o in _RECORDING_OPTIONS):
        argv = [*argv, "--save", str(default_recording(name, argv))]
    if not {"-h", "--help"} & set(argv):
        print(f"running {name}: {describe(name)[0]}", file=sys.stderr)
    with _sigints() as received, _program(f"pik-mj run {name}"):
        try:
            status = int(module.main(argv))
        except SystemExit as exc:  # the scenario's argparse: --help (0) or bad options (2)
            return exit_code(exc)
        except OptionError as exc:  # an option the user gave cannot be used: exit 2
            print(f"pik-mj: error: {exc}", file=sys.stderr)
            return EXIT_USAGE
        except OutputError as exc:  # the recording or the JSON is incomplete: exit 1
            print(f"pik-mj: error: {exc}", file=sys.stderr)
            return EXIT_FAILED
        except (KeyboardInterrupt, BrokenPipeError):
            _recording_note(argv, "up to the interrupt")
            raise
        except Exception as exc:
            if received:  # Ctrl-C, turned into another error by a native library
                _recording_note(argv, "up to the interrupt")
                raise KeyboardInterrupt from exc
            # the scenario raised: its traceback, exit 1
            traceback.print_exc(file=sys.stderr)
            print(f"pik-mj: scenario {name} raised {type(exc).__name__}: {exc}", file=sys.stderr)
            _recording_note(argv, "up to the error")
            return EXIT_FAILED
    saved = _saved_path(argv)
    if saved is not None and Path(saved).is_file():
        try:
            check_recording(saved)
        except OutputError as exc:
            print(f"pik-mj: error: {exc}", file=sys.stderr)
            return EXIT_FAILED
    return status


def default_recording(name: str, argv: Sequence[str]) -> Path:
    """Where ``pik-mj run NAME`` saves its recording when no recording option is
    given: ``out/NAME.rrd`` for the scenario's default robot, ``out/NAME-ROBOT.rrd``
    for the robot ``--model``/``--description`` name
    (:func:`~pik_mj.scenario.robot_option.model_label`: a name, or the stem of an MJCF
    path), so that runs on other robots do not overwrite each other."""
    model, description = _option_value(argv, "--model"), _option_value(argv, "--description")
    robot = scenario_robot(load_scenario(name))
    default = None if robot is None else robot.default
    if (model is None and description is None) or (description is None and model == default):
        return Path("out") / f"{name}.rrd"
    return Path("out") / f"{name}-{model_label(model, description)}.rrd"


@contextlib.contextmanager
def _program(prog: str) -> Iterator[None]:
    """``sys.argv[0]`` set to ``prog`` inside the block: a scenario's argparse
    names itself after it (``usage: pik-mj run NAME``)."""
    saved = sys.argv[:1]
    sys.argv[:1] = [prog]
    try:
        yield
    finally:
        sys.argv[:1] = saved


def check_recording(path: str | Path) -> None:
    """A recording the command wrote, verified once closed: whole, and its
    manifest read by rerun (:func:`pik_mj.record.reader.verify`).

    Raises:
        OutputError: It is not (the reason given).
    """
    try:
        verify(path)
    except InvalidInput as exc:
        raise OutputError(f"{exc}; it is incomplete") from None


@contextlib.contextmanager
def _sigints() -> Iterator[list[int]]:
    """Python's own SIGINT handler (it raises ``KeyboardInterrupt``) that also
    notes each signal in the list it yields, restored on leaving. A
    ``KeyboardInterrupt`` raised inside a native extension can come out as
    another exception (a Cython buffer check reports a ``ValueError``); the
    note tells that it was Ctrl-C. Outside the main thread: no handler, an
    empty list."""
    received: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def handler(signum: int, frame: Any) -> None:
        received.append(signum)
        signal.default_int_handler(signum, frame)

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield received
    finally:
        signal.signal(signal.SIGINT, previous)


def _option_value(argv: Sequence[str], option: str) -> str | None:
    """The value of the last ``option VALUE`` or ``option=VALUE`` in ``argv``, or None."""
    value = None
    for i, arg in enumerate(argv):
        if arg == option and i + 1 < len(argv):
            value = argv[i + 1]
        elif arg.startswith(option + "="):
            value = arg.removeprefix(option + "=")
    return value


def _saved_path(argv: list[str]) -> str | None:
    """The ``--save`` file of a scenario's options, or None."""
    return _option_value(argv, "--save")


def _recording_note(argv: list[str], when: str) -> None:
    """Say where the recording of an unfinished run is, if it was started."""
    save = _saved_path(argv)
    if save and Path(save).is_file():
        print(f"recording ({when}): {save}")


def read_pose_file(path: str | Path) -> dict[str, Any]:
    """The pose of a JSON file: the ``robot`` entry of a ``pik-mj run --json``
    summary, or the file itself when it has ``model`` and ``q``.

    Returns:
        ``{"source": RobotSource dict, "q", "allowed_contacts", "grasps",
        "external"}`` (``grasps``: ``(frame, body, p_FO, R_FO)`` tuples; missing
        optional entries are None or empty).

    Raises:
        InvalidInput: Missing or unreadable file, or no pose in it.
    """
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InvalidInput(f"pose file {str(p)!r} does not exist") from None
    except IsADirectoryError:
        raise InvalidInput(f"pose file {str(p)!r} is a directory; give a JSON file") from None
    except UnicodeDecodeError:
        raise InvalidInput(
            f"pose file {str(p)!r} is not text (a binary file?); give a JSON file"
        ) from None
    except OSError as exc:
        raise InvalidInput(f"pose file {str(p)!r} cannot be read: {exc.strerror}") from None
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
    where = _non_finite({k: v for k, v in src.items() if k != "q"})  # q: by joint, below
    if where is not None:
        raise InvalidInput(
            f"pose file {str(p)!r}: {where} is not a finite number; every number of a pose "
            "must be finite"
        )
    q = src["q"]
    if not isinstance(q, list) or not all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in q
    ):
        raise InvalidInput(f'pose file {str(p)!r}: "q" must be a list of numbers, got {q!r}')
    grasps = src.get("grasps") or []
    keys = ("frame", "body", "p_FO", "R_FO")
    if not isinstance(grasps, list) or not all(
        isinstance(g, dict) and all(k in g for k in keys) for g in grasps
    ):
        raise InvalidInput(
            f'pose file {str(p)!r}: "grasps" must be a list of {{"frame", "body", "p_FO", "R_FO"}}'
        )
    external = src.get("external") or []
    if not isinstance(external, list) or not all(
        isinstance(w, list) and len(w) == 3 and isinstance(w[0], str) for w in external
    ):
        raise InvalidInput(
            f'pose file {str(p)!r}: "external" must be a list of [frame, force, moment]'
        )
    return {
        "source": RobotSource.from_dict(src),
        "q": [float(x) for x in q],
        "allowed_contacts": src.get("allowed_contacts"),
        "grasps": [tuple(g[k] for k in keys) for g in grasps],
        "external": [tuple(w) for w in external],
    }


def _non_finite(value: Any, path: str = "") -> str | None:
    """Where in the JSON ``value`` a number is NaN or infinite (``"at"[0]``), or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return f"{path or 'the value'} = {value}"
    if isinstance(value, dict):
        items: Any = ((f"{path}[{k!r}]" if path else repr(k), v) for k, v in value.items())
    elif isinstance(value, list):
        items = ((f"{path}[{i}]", v) for i, v in enumerate(value))
    else:
        return None
    for where, item in items:
        found = _non_finite(item, where)
        if found is not None:
            return found
    return None


def _validate_parser() -> argparse.ArgumentParser:
    val = argparse.ArgumentParser(
        prog="pik-mj validate", description="static check and physics hold of a pose"
    )
    val.add_argument(
        "file", help="JSON summary of `pik-mj run --json`, {model, q}, or a sweep's OUT#CASE"
    )
    val.add_argument(
        "--environment",
        help="environment model (default: the file's; 'none' for a floor only)",
    )
    val.add_argument("--duration", default="3.0", help="hold duration [s] (default 3)")
    val.add_argument("--json", help="JSON report to write")
    val.add_argument("--save", help="rerun recording of the hold (.rrd)")
    return val


def _in_environment(
    source: RobotSource, q: list[float], environment: str, grasps: list[tuple]
) -> tuple[RobotSource, list[float]]:
    """The pose's robot moved into ``environment`` (``"none"``: the floor only),
    and its ``q`` without the old environment's joints.

    Raises:
        InvalidInput: The pose holds a body (``grasps``) that the new
            environment does not have.
    """
    env = None if environment.lower() == "none" else environment
    original = Robot.from_source(source)
    at = source.at
    if isinstance(at, str) and env is None:  # no site to stand at: its coordinates
        at = original.placement
    moved = replace(source, environment=env, at=at)
    held = [body for _, body, _, _ in grasps]
    if held:
        model = Robot.from_source(moved).model
        names = {model.body(i).name for i in range(model.nbody)}
        lost = [body for body in held if body not in names]
        if lost:
            there = "the floor alone" if env is None else f"environment {env!r}"
            raise InvalidInput(
                f"--environment {environment}: the pose holds {', '.join(map(repr, lost))} "
                f"of environment {source.environment!r}, which {there} does not have; "
                "give an environment with it, or leave --environment out"
            )
    return moved, q[: original.own_nq]


def _validate_rows(target: str, json_out: str | None) -> int:
    """``pik-mj validate OUT#CASE``: the sweep rows replayed (module docstring)."""
    path, cases = parse_target(target)
    if json_out:
        inputs.output_path(json_out, "--json")
    rows = replay(path, cases)
    for r in rows:
        a, b = r["stored"], r["replayed"]
        print(
            f"{path}#{r['case']} ({r['robot']}): stored {a['verdict']}, replayed {b['verdict']}; "
            f"hold drift {b['drift'] * 1e3:.2f} mm (stored {a['drift'] * 1e3:.2f} mm)"
        )
    passed = all(r["replayed"]["verdict"] == "validated" for r in rows)
    print("PASSED" if passed else "FAILED")
    if json_out:
        out = Path(json_out)
        out.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(out, json.dumps(jsonable(rows), indent=2), "JSON report")
        print(f"JSON report: {out}")
    return EXIT_PASSED if passed else EXIT_FAILED


def _validate(argv: list[str]) -> int:
    args = _validate_parser().parse_args(argv)
    if "#" in args.file and Path(args.file.rpartition("#")[0]).is_dir():
        return _validate_rows(args.file, args.json)
    try:
        duration = positive(args.duration)
    except argparse.ArgumentTypeError as exc:
        raise InvalidInput(f"--duration [s]: {exc}") from None
    # Where the results go, checked before any work.
    outputs = {
        option: inputs.output_path(value, option)
        for option, value in (("--json", args.json), ("--save", args.save))
        if value
    }
    if len(outputs) == 2 and len({p.resolve() for p in outputs.values()}) == 1:
        raise InvalidInput(f"--json and --save name the same file {args.json!r}; give two files")
    pose = read_pose_file(args.file)
    source, q = pose["source"], pose["q"]
    if args.environment is not None:  # another world: the robot keeps its pose
        source, q = _in_environment(source, q, args.environment, pose["grasps"])
    recorder = None
    if args.save:
        Path(args.save).parent.mkdir(parents=True, exist_ok=True)
        recorder = Recorder.to_file(args.save, application_id="pik_mj_validate")
    try:
        if recorder is not None:
            robot = Robot.from_source(source)
            recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
        report = validate_pose(
            source,
            q,
            duration,
            allowed=pose["allowed_contacts"],
            grasps=pose["grasps"],
            external=pose["external"],
            callback=None if recorder is None else recorder.hold_logger(),
        )
    except SimulationUnstable as exc:
        print(f"validate {args.file}: FAILED, the simulation went unstable: {exc}")
        return EXIT_FAILED
    finally:
        if recorder is not None:
            recorder.close()
    held = "".join(f", {body} held in {frame}" for frame, body, _, _ in pose["grasps"])
    print(f"validate {args.file}: model {source.model}, environment {source.environment}{held}")
    print(balance_summary(report))
    print("a hold alone: no motion was played")
    print("PASSED" if report["passed"] else "FAILED")
    if args.json:
        out = Path(args.json)
        out.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(out, json.dumps(jsonable(report), indent=2), "JSON report")
        print(f"JSON report: {out}")
    if args.save:
        check_recording(args.save)
        print(f"recording: {args.save}")
    return EXIT_PASSED if report["passed"] else EXIT_FAILED


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pik-mj", description="Prioritized IK on MuJoCo: run the scenarios."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the scenarios")
    run = sub.add_parser(
        "run",
        help="run a scenario (default: fullbody_reach); other options go to its main",
        add_help=False,
    )
    run.add_argument("name", nargs="?", help="scenario name")
    sub.add_parser("validate", help="static check and physics hold of a pose", add_help=False)
    sub.add_parser("screenshot", help="PNG of a recording (rerun's viewer)", add_help=False)
    sub.add_parser(
        "sweep", help="solve, check and hold many hand targets on Ray (reach map)", add_help=False
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``pik-mj``; returns the exit status (see the module docstring).

    Usage errors (argparse's, and :class:`~pik_mj.exceptions.PikError` raised by
    the command itself, not by a scenario) print one line on stderr and return 2;
    Ctrl-C returns 130 once the run has unwound (recordings closed):
    :func:`pik_mj.scenario.exit_status.guarded`.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    return guarded(lambda: _command(argv))


def _command(argv: list[str]) -> int:
    """The command ``argv[0]`` with its options ``argv[1:]``."""
    # `run` and `validate` hand their options on: only the command is parsed here.
    command = _parser().parse_args(argv[:1]).command
    rest = argv[1:]
    if command == "list":
        if rest:
            _parser().error(f"unrecognized arguments: {' '.join(rest)}")
        return _list()
    if command == "validate":
        return _validate(rest)
    if command == "screenshot":
        shot = argparse.ArgumentParser(prog="pik-mj screenshot")
        screenshot.add_arguments(shot)
        return screenshot.run(shot.parse_args(rest))
    if command == "sweep":
        return sweep_cli.main(rest)
    name = rest[0] if rest and not rest[0].startswith("-") else None
    return _run(name, rest[1:] if name is not None else rest)


if __name__ == "__main__":
    raise SystemExit(main())
