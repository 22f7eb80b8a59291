"""The acts every scenario plays on its robot: solve with the scene's static checks, the
recorder's logger and a progress line; play the iterates in physics; hold the final pose.

A scenario script builds its robot and hands it to a :class:`Stage` with the robot's
scene and the recorder; each act then adds to the stage's :class:`ScenarioResult`::

    stage = Stage("reach", robot, recorder, scene=Scene.from_robot(robot), quiet=quiet)
    path = Waypoints(robot)
    stage.solve(fullbody_inverse_kinematics, "reach", targets, path=path, limbs=["larm"])
    if speed:
        stage.play("reach", path, speed=speed)
    stage.hold_final_pose(hold)
    return stage.result
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TextIO

from pik_mj.progress import Progress
from pik_mj.record import Recorder
from pik_mj.record.loggers import MotionLogger, SolveLogger
from pik_mj.robot import Robot
from pik_mj.scenario.result import ScenarioResult
from pik_mj.sim import HoldCriteria, MotionReport, Scene, StaticChecks, Waypoints
from pik_mj.solve import SolveResult


@dataclass
class SolveWatch:
    """The callbacks that follow one solve of a scenario, in the order they run each
    iteration: the scene's static check, the recorder's logger (it logs that check's
    report), the progress line, and the path collecting the iterates.

    Attributes:
        result: The scenario's result, which :meth:`keep` adds the solve to.
        label: The solve's label.
        checks: The scene's per-iteration static checker, or None without a scene.
        log: The recorder's solve logger.
        progress: The progress line.
        path: The path of iterates (in its segment for this solve), or None.
    """

    result: ScenarioResult
    label: str
    checks: StaticChecks | None
    log: SolveLogger
    progress: Progress
    path: Waypoints | None

    @property
    def callbacks(self) -> list[Any]:
        """The ``callback`` list of the solve."""
        return [c for c in (self.checks, self.log, self.progress, self.path) if c is not None]

    def keep(self, solve: SolveResult) -> SolveResult:
        """Hand the solve's result to the logger, the progress and the path (each
        ``finish``) and add it to the scenario's result; returns it."""
        finish = [c for c in (self.log, self.progress, self.path) if c is not None]
        return self.result.add_solve(self.label, solve, self.checks, finish=finish)


class Stage:
    """A scenario's robot in its scene, with the recorder and the result its acts fill.

    Building it logs the robot's geometry.

    Args:
        name: The scenario's name (its result's).
        robot: The robot the IK moves.
        recorder: Where the acts are recorded.
        scene: The robot's scene (floor, servos, contacts), or None for a robot with
            nothing to check or simulate (a fixed-base arm).
        quiet: No progress lines (else on stderr).

    Attributes:
        result: The scenario's result; each act adds to it.
        robot: The robot.
        recorder: The recorder.
        scene: The robot's scene, or None.
        progress: Stream of the progress lines, or None.
    """

    def __init__(
        self,
        name: str,
        robot: Robot,
        recorder: Recorder,
        *,
        scene: Scene | None = None,
        quiet: bool = True,
    ) -> None:
        self.result = ScenarioResult(name)
        self.robot = robot
        self.recorder = recorder
        self.scene = scene
        self.progress: TextIO | None = None if quiet else sys.stderr
        recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)

    def watch(
        self,
        label: str,
        path: Waypoints | None = None,
        *,
        segment: str | None = None,
        total: int | None = None,
        start: bool = True,
    ) -> SolveWatch:
        """The callbacks of solve ``label`` (:class:`SolveWatch`), made now: its
        iterates go to ``path`` in segment ``segment`` (default ``label``).

        Args:
            label: The solve's label.
            path: The path collecting the iterates, or None.
            segment: The path's segment of these iterates (default: ``label``).
            total: Most iterations of the solve, for the progress bar (None: a counter).
            start: Log the robot's start pose at the solve's first tick.
        """
        checks = self.scene.static_checker() if self.scene is not None else None
        log = self.recorder.solve_logger(label, checks=checks, start=self.robot if start else None)
        progress = Progress(label, total=total, stream=self.progress)
        if path is not None:
            path.segment(label if segment is None else segment)
        return SolveWatch(self.result, label, checks, log, progress, path)

    def solve(
        self,
        ik: Callable[..., SolveResult],
        label: str,
        *targets: Any,
        path: Waypoints | None = None,
        segment: str | None = None,
        total: int | None = None,
        start: bool = True,
        **options: Any,
    ) -> SolveResult:
        """``ik(robot, *targets, callback=..., **options)`` watched by :meth:`watch`
        (same arguments), its result kept as ``label``; returns it.

        Args:
            ik: :func:`pik_mj.inverse_kinematics` or :func:`pik_mj.fullbody_inverse_kinematics`.
        """
        watch = self.watch(label, path, segment=segment, total=total, start=start)
        return watch.keep(ik(self.robot, *targets, callback=watch.callbacks, **options))

    def play(
        self,
        label: str,
        path: Waypoints,
        *,
        speed: float,
        scene: Scene | None = None,
        log: MotionLogger | None = None,
        callback: Sequence[Callable[..., Any]] = (),
        **options: Any,
    ) -> MotionReport:
        """Play ``path`` in physics (:meth:`pik_mj.sim.Scene.play`) at ``speed`` (a
        fraction of the joint velocity limits) and keep the motion as ``label``
        (a check on its verdict); returns it.

        Args:
            label: The motion's label.
            path: The iterates to play.
            speed: Fraction of the joint velocity limits.
            scene: Where to play (default: the stage's scene).
            log: The recorder's motion logger (default: a new one), called first.
            callback: More callbacks of the samples, after the logger.
            **options: More options of :meth:`~pik_mj.sim.Scene.play` (``start``,
                ``external``, ...).
        """
        log = self.recorder.motion_logger() if log is None else log
        where = self.scene if scene is None else scene
        motion = where.play(path, speed=speed, callback=[log, *callback], **options)
        return self.result.add_motion(label, motion, finish=[log])

    def hold_final_pose(
        self,
        duration: float,
        *,
        scene: Scene | None = None,
        external: Sequence[tuple[str, Any, Any]] = (),
    ) -> None:
        """Check the robot's configuration statically and hold it ``duration`` [s] in
        physics (0: no hold), the contacts it touches at the start intended; keep both
        in the result (:meth:`ScenarioResult.add_balance`).

        Args:
            duration: Physics hold [s]; 0: the static check only.
            scene: Where (default: the stage's scene).
            external: Wrenches ``(frame, force [N], moment [N·m])`` on the robot.
        """
        where = self.scene if scene is None else scene
        q = self.robot.configuration.q.copy()
        static = where.static_check(q, external=external)
        criteria = HoldCriteria(allowed=[*where.allowed_contacts, *static.touching_geoms])
        held = None
        if duration:
            log = self.recorder.hold_logger()
            held = where.hold(q, duration, criteria=criteria, external=external, callback=log)
        self.result.add_balance(where, static, held, criteria, external=external)
