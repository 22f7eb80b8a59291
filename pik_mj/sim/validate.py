"""Static check and physics hold of one pose of a robot rebuilt from its source:
what ``pik-mj validate`` runs on the ``robot`` entry of a run's JSON."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot, RobotSource

from .hold import HoldCriteria, HoldReport
from .scene import External, GraspLike, Scene
from .static import StaticReport

__all__ = ["balance_report", "validate_pose"]


def balance_report(
    static: StaticReport, hold: HoldReport | None, robot: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """``{"robot", "static", "hold", "passed"}``: a pose's static check and hold,
    passed when the pose is in static equilibrium and (if it ran) the hold passed."""
    return {
        "robot": None if robot is None else dict(robot),
        "static": static.to_dict(),
        "hold": None if hold is None else hold.to_dict(),
        "passed": bool(static.feasible and (hold is None or hold.passed)),
    }


def validate_pose(
    source: RobotSource | Mapping[str, Any] | str,
    q: ArrayLike | str | None = None,
    duration: float = 3.0,
    *,
    mu: float | None = None,
    allowed: Sequence[str] | None = None,
    grasps: Sequence[GraspLike] = (),
    external: Sequence[External] = (),
    callback: Any = None,
) -> dict[str, Any]:
    """Static check and physics hold of one pose (for ``pik-mj validate``).

    Args:
        source: The robot's :class:`~pik_mj.robot.RobotSource` (or its
            ``to_dict()``, or a model name / MJCF path).
        q: Robot configuration (the robot's ``nq``; or only its own joints,
            :attr:`~pik_mj.robot.Robot.own_nq`, the environment then at its start),
            the name of one of its keyframes, or None for its start pose.
        duration: Hold duration [s].
        mu: Friction coefficient of the equilibrium LP (None: MuJoCo's).
        allowed: Robot geoms allowed to touch the environment (default: its soles).
        grasps: Objects held by robot frames (see :meth:`Scene.from_robot`).
        external: Wrenches ``(frame, force, moment)`` on the robot in the static
            check and the hold.
        callback: Hold callbacks (e.g. a recorder's ``hold_logger()``).

    Returns:
        :func:`balance_report` with the source under ``"robot"``.

    Raises:
        UnknownName: No such keyframe (or model, site, frame).
        InvalidInput: ``q`` of the wrong shape.
    """
    if isinstance(source, str):
        source = RobotSource(source)
    robot = Robot.from_source(source)
    if isinstance(q, str):
        keys = [robot.model.key(k).name for k in range(robot.model.nkey)]
        if q not in keys:
            raise UnknownName("keyframe", q, keys)
        q = robot.model.key(q).qpos
    if q is not None:
        q = np.asarray(q, dtype=float)
        if q.shape not in ((robot.model.nq,), (robot.own_nq,)):
            raise InvalidInput(
                f"q must be the robot's configuration of shape ({robot.model.nq},) or its "
                f"own joints' ({robot.own_nq},), got shape {q.shape}"
            )
        full = robot.configuration.q.copy()
        full[: len(q)] = q
        robot.configuration.update(full)
    q_robot = robot.configuration.q.copy()
    scene = Scene.from_robot(robot, allowed_contacts=allowed, grasps=grasps)
    static = scene.static_check(q_robot, mu=mu, external=external)
    hold = scene.hold(
        q_robot,
        duration,
        criteria=HoldCriteria(allowed=allowed),
        external=external,
        callback=callback,
    )
    return balance_report(static, hold, robot.source.to_dict() if robot.source else None)
