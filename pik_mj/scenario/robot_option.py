"""The robot options of a scenario's command line: ``--model`` (and ``--description``)
must name a robot that loads and has what the scenario moves; what a robot truly lacks
is said in one line before any work (:class:`RobotRefused`)."""

from __future__ import annotations

import difflib
import os
from collections.abc import Callable
from dataclasses import dataclass

from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.loading import available_models, menagerie_models

LIMB_WORDS = {
    "rarm": "a right arm",
    "larm": "a left arm",
    "rleg": "a right leg",
    "lleg": "a left leg",
    "head": "a head",
    "torso": "a torso",
    "arm": "an arm",
}
"""How ``pik-mj list`` names a limb a scenario needs."""


class RobotRefused(InvalidInput):
    """A robot the scenario cannot move: one line naming the option, the robot and what
    it lacks (raised before any work)."""


@dataclass(frozen=True)
class RobotOption:
    """What ``--model`` (and ``--description``) must give a scenario: a robot that
    loads and has ``limbs`` (and a floating base with ``floating_base``, a fixed one
    with ``fixed_base``).

    Attributes:
        default: The model run when neither option names one.
        limbs: Limbs the scenario moves.
        floating_base: The scenario needs a floating base (a humanoid standing on
            its feet).
        fixed_base: The scenario needs a fixed base (an arm bolted to the world).
        uses: What the scenario uses where the robot has it (shown by ``pik-mj
            list``), e.g. ``"a head camera"``; empty: nothing more.
        requires: What else the robot must have, asked of the built robot: a
            function that returns why the robot cannot play the scenario (a clause
            about the robot, e.g. ``"its right arm has 4 joints; ... asks 5"``), or
            None when it can.
    """

    default: str
    limbs: tuple[str, ...]
    floating_base: bool = False
    fixed_base: bool = False
    uses: str = ""
    requires: Callable[[Robot], str | None] | None = None

    def needs(self) -> str:
        """What the scenario needs of its robot, in words (``pik-mj list``): e.g.
        ``"two arms, two legs, a floating base"``."""
        limbs = list(self.limbs)
        words = []
        for pair, word in ((("rarm", "larm"), "two arms"), (("rleg", "lleg"), "two legs")):
            if all(x in limbs for x in pair):
                words.append(word)
                limbs = [x for x in limbs if x not in pair]
        words = [LIMB_WORDS.get(x, f"a limb {x!r}") for x in limbs] + words
        if self.floating_base:
            words.append("a floating base")
        if self.fixed_base:
            words.append("a fixed base")
        text = ", ".join(words) or "any robot"
        return text + (f"; uses {self.uses} where it has one" if self.uses else "")

    @property
    def category(self) -> str | None:
        """The kind of robot the scenario needs, in MuJoCo Menagerie's words:
        ``"arm"`` (a fixed base), ``"humanoid"`` (a floating base), None (any)."""
        if self.fixed_base:
            return "arm"
        return "humanoid" if self.floating_base else None

    def named_models(self) -> list[str]:
        """The shipped and dm_control model names of the scenario's kind (worlds
        without a robot, such as ``room``, left out)."""
        worlds = available_models("scene")
        return [x for x in available_models(self.category) if x not in worlds]

    def model_names(self) -> list[str]:
        """The model names of the scenario's kind: :meth:`named_models`, then MuJoCo
        Menagerie's."""
        return [*self.named_models(), *menagerie_models(self.category)]

    def valid_models(self) -> str:
        """The models ``--model`` may name for this scenario, in one sentence: the named
        models of its kind, MuJoCo Menagerie's robots of that kind, or an MJCF path."""
        named = self.named_models()
        menagerie = menagerie_models(self.category)
        kind = f"{self.category}s" if self.category else "robots"
        return (
            f"Models for this scenario ({self.needs()}): {named}, the MuJoCo Menagerie "
            f"{kind} {menagerie}, or an MJCF path"
        )

    def check(self, model: str | None, description: str | None) -> tuple[str | None, Robot]:
        """The model to run (the default when neither option names one) and the
        robot built from it and its description.

        Raises:
            InvalidInput: The robot does not load, one line starting with the option
                to blame.
            RobotRefused: The robot lacks what the scenario needs, in one line.
        """
        if model is None and description is None:
            model = self.default
        option = "--model" if model is not None else "--description"
        named = f"model {model!r}" if model is not None else f"the model of {description!r}"
        try:
            robot = Robot.from_model(model, description=description)
        except UnknownName as exc:
            if exc.kind != "model":
                raise InvalidInput(f"argument {option}: {exc}") from None
            near = difflib.get_close_matches(exc.name, self.model_names(), n=3)
            guess = f" (did you mean {' or '.join(map(repr, near))}?)" if near else ""
            raise InvalidInput(
                f"argument {option}: model {exc.name!r} does not exist{guess}. "
                f"{self.valid_models()}"
            ) from None
        except PikError as exc:
            raise InvalidInput(f"argument {option}: {exc}") from None
        if self.fixed_base and robot.has_floating_base:
            raise RobotRefused(
                f"argument {option}: {named} has a floating base (a free joint at its root "
                f"{robot.root_body!r}); this scenario moves an arm with a fixed base"
            )
        missing = [x for x in self.limbs if x not in robot.limbs]
        if missing:
            hint = "" if description else "; name them in a robot description: --description PATH"
            raise RobotRefused(
                f"argument {option}: {named} has no limb {', '.join(missing)}, which this "
                f"scenario moves (its limbs: {', '.join(robot.limbs) or 'none'}){hint}"
            )
        if self.floating_base and not robot.has_floating_base:
            raise RobotRefused(
                f"argument {option}: {named} has no floating base (a free joint at its "
                f"root {robot.root_body!r}), which this scenario needs"
            )
        why = None if self.requires is None else self.requires(robot)
        if why:
            raise RobotRefused(f"argument {option}: {named} cannot play this scenario: {why}")
        return model, robot


def model_label(model: str | os.PathLike[str] | None, description: str | None = None) -> str:
    """A short name of the robot ``--model``/``--description`` give, for file names:
    a model name as it is (``unitree_g1``; an entry point ``unitree_g1:g1_with_hands``
    becomes ``unitree_g1-g1_with_hands``), an MJCF path or a description file by its
    stem (``/x/robot.xml``: ``robot``)."""
    given = model if model is not None else description
    if given is None:
        return "robot"
    text = os.fspath(given)
    if text.endswith((".xml", ".toml", ".json")) or "/" in text or os.sep in text:
        text = os.path.splitext(os.path.basename(text))[0]
    return text.replace(":", "-")
