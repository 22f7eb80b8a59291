"""The command line of a scenario's ``main``: :func:`parser` gives rerun's options,
``--json``, ``--quiet``, ``--hold``, ``--speed`` and ``--model``/``--description``;
the :class:`ScenarioParser` it returns checks the output files and the robot before any
work starts."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import rerun as rr

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.record.sinks import LOOPBACK, check_bind
from pik_mj.scenario.arguments import duration, fraction
from pik_mj.scenario.robot_option import RobotOption, RobotRefused
from pik_mj.sim.motion import DEFAULT_SPEED

DEFAULT_HOLD = 3.0
"""Physics hold of the final pose [s] of a scenario run."""


class ScenarioParser(argparse.ArgumentParser):
    """The argument parser of a scenario's ``main`` (:func:`parser`): after parsing,
    it checks that the output files (``--save``, ``--json``) can be written and
    that ``--model``/``--description`` give a robot the scenario can move, before
    any work starts (a usage error otherwise; a robot the scenario cannot move is
    refused in one line, ``<prog>: error: <why>``, exit status 2). The robot it built
    for that check
    is kept on the namespace as ``robot`` (None for a scenario without
    ``--model``), so that the scenario need not build it again."""

    robot_option: RobotOption | None = None

    def parse_args(self, args: Sequence[str] | None = None, namespace: Any = None) -> Any:  # type: ignore[override]
        ns = super().parse_args(args, namespace)
        try:
            check_destinations(ns)
        except InvalidInput as exc:
            self.error(str(exc))
        outputs = [
            (option, getattr(ns, dest))
            for option, dest in (("--save", "save"), ("--json", "json"))
            if getattr(ns, dest, None) is not None
        ]
        for option, value in outputs:
            try:
                inputs.output_path(value, f"argument {option}:")
            except InvalidInput as exc:
                self.error(str(exc))
        if len(outputs) == 2 and Path(outputs[0][1]).resolve() == Path(outputs[1][1]).resolve():
            self.error(f"--save and --json name the same file {outputs[0][1]!r}; give two files")
        ns.robot = None
        if self.robot_option is not None:
            try:
                ns.model, ns.robot = self.robot_option.check(
                    ns.model, getattr(ns, "description", None)
                )
            except RobotRefused as exc:
                self.exit(2, f"{self.prog}: error: {exc}\n")
            except InvalidInput as exc:
                self.error(str(exc))
        return ns


def check_destinations(ns: argparse.Namespace) -> None:
    """rerun's options (:func:`rerun.script_add_args`) that can go together: one live
    destination (``--stdout``, ``--serve`` or ``--connect``), ``--save`` beside
    ``--serve`` or ``--connect`` (both written) but not ``--stdout`` (the recording is
    on standard output: ``| tee FILE.rrd`` keeps a copy), ``--bind`` with ``--serve``.

    Raises:
        InvalidInput: Options that contradict each other, or a ``--bind`` that is
            not an IP address.
    """
    live = [o for o in ("stdout", "serve", "connect") if getattr(ns, o, False)]
    if len(live) > 1:
        raise InvalidInput(
            f"--{live[0]} and --{live[1]} both say where the recording goes live; give one"
        )
    if getattr(ns, "stdout", False) and getattr(ns, "save", None) is not None:
        raise InvalidInput(
            "--stdout writes the recording to standard output; --save cannot go with it "
            "(keep a copy with `... --stdout | tee FILE.rrd | rerun -`)"
        )
    if getattr(ns, "bind", None) is not None:
        if not getattr(ns, "serve", False):
            raise InvalidInput("--bind says where --serve listens; give it with --serve")
        ns.bind = check_bind(ns.bind)


def parser(
    doc: str | None,
    *,
    hold: bool = True,
    model: str | None = None,
    limbs: Sequence[str] = (),
    floating_base: bool = False,
    description: bool = False,
    robot: RobotOption | None = None,
) -> ScenarioParser:
    """The options of a scenario's ``main``: rerun's (``--save FILE.rrd``,
    ``--connect``, ``--serve``, ``--stdout``, ``--headless``:
    :func:`rerun.script_add_args`; what each does: :mod:`pik_mj.scenario.output`),
    ``--bind ADDRESS`` (where ``--serve`` listens), ``--json FILE``, ``--quiet`` (no progress) and,
    with ``hold``, ``--hold SECONDS`` (physics hold of the final pose, default 3;
    0: none) and ``--speed FRACTION`` (the iterates played in physics at this
    fraction of the joint velocity limits, default 0.2; 0: not played).

    Args:
        doc: The scenario's docstring (its first line describes it).
        hold: Add ``--hold``.
        model: Add ``--model NAME`` with this default: a model name or MJCF path,
            checked when parsed (it loads and builds a robot that has ``limbs``,
            and a floating base with ``floating_base``).
        limbs: Limbs the scenario moves (checked on ``--model``).
        floating_base: The scenario needs a floating base (checked on ``--model``).
        description: With ``model`` (or ``robot``), add ``--description FILE`` (a
            robot description, :mod:`pik_mj.robot.description`), checked with
            ``--model``; ``--model``'s default then applies when neither is given.
        robot: What ``--model`` must give, declared by the scenario (its ``ROBOT``):
            instead of ``model``, ``limbs`` and ``floating_base``.
    """
    p = ScenarioParser(description=(doc or "").strip().splitlines()[0])
    rr.script_add_args(p)
    p.add_argument(
        "--bind",
        metavar="ADDRESS",
        help=f"with --serve: the address its servers listen on (default {LOOPBACK}: this "
        "machine only; 0.0.0.0: every interface)",
    )
    p.add_argument("--json", help="JSON summary to write")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    if hold:
        p.add_argument(
            "--hold",
            type=duration,
            default=DEFAULT_HOLD,
            help=f"physics hold of the final pose [s] (default {DEFAULT_HOLD:g}; 0: none)",
        )
        p.add_argument(
            "--speed",
            type=fraction,
            default=DEFAULT_SPEED,
            help="the iterates played in physics at this fraction of the joint velocity "
            f"limits (default {DEFAULT_SPEED:g}; 0: not played)",
        )
    if robot is None and model is not None:
        robot = RobotOption(model, tuple(limbs), floating_base)
    if robot is not None:
        model = robot.default
        p.robot_option = robot
        p.add_argument(
            "--model",
            help=f"robot ({robot.needs()}): a model name ({model}, a MuJoCo Menagerie "
            "robot such as unitree_g1) or an MJCF path (default: "
            + ("the description's model, else " if description else "")
            + f"{model})",
        )
        if description:
            p.add_argument(
                "--description",
                help="robot description file (.toml/.json): limbs, keyframe, soles the "
                "kinematic tree does not tell",
            )
    return p


def run_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword arguments of a scenario's ``run`` from its parsed :func:`parser`
    options: ``model``, ``description`` and the ``robot`` built when they were checked
    (with ``--model``), ``hold`` and ``speed`` (with ``--hold``), ``quiet``. A
    scenario's own options (``--steps``) are added by the scenario."""
    names = ("model", "description", "hold", "speed", "quiet")
    options = {n: getattr(args, n) for n in names if n in args}
    if "model" in options:
        options["robot"] = args.robot
    return options
