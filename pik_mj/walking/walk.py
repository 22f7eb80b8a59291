"""A walk from start to finish: the pattern of a footstep list on a robot (its
soles, its gait), played in the robot's scene, with the figures and checks of
the walking scenarios (irteus manual: ``:calc-walk-pattern-from-footstep-list``,
then the pattern played in physics)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pik_mj.callbacks import Callback
from pik_mj.robot import Robot
from pik_mj.robot.ground import Sole, robot_soles
from pik_mj.sim import Scene
from pik_mj.walking.gait import Footstep
from pik_mj.walking.playback import WALK_CONTACT, play_walk_pattern
from pik_mj.walking.report import PlaybackReport, evaluate_walk
from pik_mj.walking.robot_gait import RobotGait
from pik_mj.walking.wholebody import WalkPattern, calc_walk_pattern

__all__ = ["Walk", "walk"]


@dataclass(frozen=True)
class Walk:
    """A walk's pattern, its playback and what they show.

    Attributes:
        gait: The gait walked.
        pattern: The whole-body pattern.
        report: Its playback in physics.
        figures: :func:`~pik_mj.walking.report.evaluate_walk`'s figures, with the
            gait's values under ``"gait"``.
        checks: ``[(label, ok, detail), ...]``.
    """

    gait: RobotGait
    pattern: WalkPattern
    report: PlaybackReport
    figures: dict[str, Any]
    checks: list[tuple[str, bool, str]]

    @property
    def passed(self) -> bool:
        """Every check held."""
        return all(ok for _, ok, _ in self.checks)


def walk(
    robot: Robot,
    footsteps: Sequence[Footstep],
    gait: RobotGait,
    *,
    soles: Mapping[str, Sole] | None = None,
    scene: Scene | None = None,
    callback: Callback | Sequence[Callback] | None = None,
    **playback: Any,
) -> Walk:
    """Walk ``footsteps`` with ``gait``: the pattern
    (:func:`~pik_mj.walking.wholebody.calc_walk_pattern` at the gait's CoM height),
    played in ``scene`` (default: the robot's with :data:`WALK_CONTACT`;
    :func:`~pik_mj.walking.playback.play_walk_pattern` with ``callback`` and the
    ``playback`` options), checked (:func:`~pik_mj.walking.report.evaluate_walk`).

    The robot is left in the pattern's last configuration.
    """
    soles = robot_soles(robot) if soles is None else soles
    pattern = calc_walk_pattern(
        robot, footsteps, gait.parameters(), com_height=gait.com_height, soles=soles
    )
    scene = Scene.from_robot(robot, contact=WALK_CONTACT) if scene is None else scene
    report = play_walk_pattern(pattern, scene, callback=callback, **playback)
    figures, checks = evaluate_walk(pattern, report)
    figures["gait"] = gait.to_dict()
    return Walk(gait, pattern, report, figures, checks)
