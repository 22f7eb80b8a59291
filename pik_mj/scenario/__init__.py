"""What the scenario scripts share: the acts they play, their result and its summary, and
the command line of their ``main``.

A scenario (``scenarios/<name>.py``, installed as ``pik_mj.scenarios.<name>``)
reads top to bottom: build the robot and hand it to a :class:`Stage` with its
scene, make the tasks, solve (:meth:`Stage.solve`: the scene's static check of
every iteration, the recorder's logger, a progress line, the path of iterates),
play the iterates in physics (:meth:`Stage.play`), hold the final pose in physics
(:meth:`Stage.hold_final_pose`), then put the figures and checks into the stage's
:class:`ScenarioResult`. A failed check makes the scenario fail; it does not
raise. Its ``main(argv)`` parses :func:`parser`'s options (rerun's
``--save/--connect/--serve/--stdout/--headless``, ``--json``, ``--hold``,
``--speed``, ``--quiet``, ``--model``; :func:`run_options` maps them to ``run``'s
keywords), records into :func:`open_recorder`'s
stream and ends with :func:`report`.

The user's options are checked here, once for every scenario, before any work
starts: the output files can be written, ``--model`` is a model that loads and
has what the scenario moves (:class:`RobotOption`), numbers are in range (the
argparse types :func:`count`, :func:`positive`, :func:`finite`,
:func:`duration`, :func:`fraction`). A bad option is a usage error
(``SystemExit(2)`` from argparse, or :class:`OptionError`), which ``pik-mj run``
reports without a traceback.

Modules: :mod:`.stage` (the acts), :mod:`.result` (:class:`ScenarioResult`, the
balance summary, JSON), :mod:`.figures` (measures the scenarios report),
:mod:`.command_line` (:func:`parser`), :mod:`.robot_option`, :mod:`.arguments`
(argparse types), :mod:`.output` (recording and report), :mod:`.exit_status`
(the commands' exit statuses).
"""

from pik_mj.exceptions import OptionError
from pik_mj.scenario.arguments import count, duration, finite, fraction, positive
from pik_mj.scenario.command_line import (
    DEFAULT_HOLD,
    DEFAULT_SPEED,
    ScenarioParser,
    parser,
    run_options,
)
from pik_mj.scenario.figures import com_margin, end_pose, largest_move, largest_turn
from pik_mj.scenario.output import open_recorder, report
from pik_mj.scenario.result import ScenarioResult, balance_summary, jsonable
from pik_mj.scenario.robot_option import RobotOption, RobotRefused
from pik_mj.scenario.scenes import robot_in
from pik_mj.scenario.stage import SolveWatch, Stage
from pik_mj.scenario.stature import Hand, Stature

__all__ = [
    "DEFAULT_HOLD",
    "DEFAULT_SPEED",
    "Hand",
    "OptionError",
    "RobotOption",
    "RobotRefused",
    "ScenarioParser",
    "ScenarioResult",
    "SolveWatch",
    "Stage",
    "Stature",
    "balance_summary",
    "com_margin",
    "count",
    "duration",
    "end_pose",
    "finite",
    "fraction",
    "jsonable",
    "largest_move",
    "largest_turn",
    "open_recorder",
    "parser",
    "positive",
    "report",
    "robot_in",
    "run_options",
]
