"""The robot options of a scenario's command line: ``--model`` (and ``--description``)
must name a robot that loads and has what the scenario moves."""

from __future__ import annotations

from dataclasses import dataclass

from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.robot import Robot


@dataclass(frozen=True)
class RobotOption:
    """What ``--model`` (and ``--description``) must give a scenario: a robot that
    loads and has ``limbs`` (and a floating base with ``floating_base``).

    Attributes:
        default: The model run when neither option names one.
        limbs: Limbs the scenario moves.
        floating_base: The scenario needs a floating base.
    """

    default: str
    limbs: tuple[str, ...]
    floating_base: bool

    def check(self, model: str | None, description: str | None) -> tuple[str | None, Robot]:
        """The model to run (the default when neither option names one) and the
        robot built from it and its description.

        Raises:
            InvalidInput: Why not, one line starting with the option to blame.
        """
        if model is None and description is None:
            model = self.default
        option = "--model" if model is not None else "--description"
        named = f"model {model!r}" if model is not None else f"the model of {description!r}"
        try:
            robot = Robot.from_model(model, description=description)
        except PikError as exc:
            raise InvalidInput(f"argument {option}: {exc}") from None
        missing = [x for x in self.limbs if x not in robot.limbs]
        if missing:
            hint = "" if description else "; name them in a robot description: --description PATH"
            raise InvalidInput(
                f"argument {option}: {named} has no limb {', '.join(missing)}, which this "
                f"scenario moves (its limbs: {', '.join(robot.limbs) or 'none'}){hint}"
            )
        if self.floating_base and not robot.has_floating_base:
            raise InvalidInput(
                f"argument {option}: {named} has no floating base (a free joint at its "
                f"root {robot.root_body!r}), which this scenario needs"
            )
        return model, robot
